//! Dispersed chain starts inside the prior, for chains started around a MAP whose Fisher
//! Gaussian may overhang the prior box (a MAP on a corner at low SNR).

use crate::density::LogDensity;
use crate::linalg::SpdOptions;
use nalgebra::DMatrix;
use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};
use rand_xoshiro::Xoshiro256PlusPlus;

/// Chain starts inside the prior with a finite `ln L`: draws from `N(centre, cov)` truncated to
/// the prior support (by rejection), and prior draws where the Gaussian misses the support
/// (MAP on a corner of a box the Gaussian overhangs). Chain `c` draws from its own stream
/// `seed + 1000 + c`, so the starts do not depend on the number of threads.
pub fn chain_starts<D: LogDensity + ?Sized>(
    target: &D,
    centre: &[f64],
    cov: &DMatrix<f64>,
    n_chains: usize,
    seed: u64,
) -> Result<Vec<Vec<f64>>, String> {
    let d = centre.len();
    let l = SpdOptions::lower().factor(cov).ok().map(|c| c.l());
    let ok = |th: &[f64]| target.ln_posterior(th).is_finite();
    let mut starts = Vec::with_capacity(n_chains);
    for c in 0..n_chains {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed.wrapping_add(1000 + c as u64));
        let mut found = None;
        if let Some(l) = &l {
            for _ in 0..1000 {
                let z: Vec<f64> = (0..d).map(|_| StandardNormal.sample(&mut rng)).collect();
                let th: Vec<f64> = (0..d)
                    .map(|i| centre[i] + (0..=i).map(|j| l[(i, j)] * z[j]).sum::<f64>())
                    .collect();
                if ok(&th) {
                    found = Some(th);
                    break;
                }
            }
        }
        if found.is_none() {
            for _ in 0..1000 {
                let th = target.prior().sample(&mut rng);
                if ok(&th) {
                    found = Some(th);
                    break;
                }
            }
        }
        match found {
            Some(th) => starts.push(th),
            None => {
                return Err(
                    "no start point inside the prior with a finite ln L in 2000 draws (around the MAP and from the prior): the likelihood is not finite over the prior box; narrow the prior"
                        .into(),
                );
            }
        }
    }
    Ok(starts)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::prior::{Prior, PriorKind};
    use crate::sampler::test_targets::CornerTarget;

    #[test]
    fn starts_are_inside_the_box_when_the_map_is_on_a_corner_and_the_gaussian_overhangs() {
        let d = 4;
        let prior = Prior::new(
            (0..d).map(|k| format!("p{k}")).collect(),
            vec![PriorKind::Uniform { lo: 0.0, hi: 1.0 }; d],
        )
        .unwrap();
        // the Fisher σ is 5 box widths: 1 in 10⁴ of the uncapped Gaussian's draws from the
        // corner land inside (each coordinate has P ≈ 0.08 of falling in [0, 1])
        let t = CornerTarget { sd: 5.0, prior };
        let corner = vec![1.0; d];
        let fisher_cov = DMatrix::from_diagonal_element(d, d, 25.0);
        for cov in [
            fisher_cov.clone(),
            crate::sampler::cap_to_prior(&fisher_cov, t.prior()),
        ] {
            let starts = chain_starts(&t, &corner, &cov, 8, 3).unwrap();
            assert_eq!(starts.len(), 8);
            for s in &starts {
                assert!(t.prior().contains(s), "{s:?}");
            }
            // dispersed, not all at the corner
            let spread: f64 = starts.iter().map(|s| (s[0] - starts[0][0]).abs()).sum();
            assert!(spread > 0.1, "{starts:?}");
            // reproducible from the seed
            assert_eq!(starts, chain_starts(&t, &corner, &cov, 8, 3).unwrap());
        }
        // a likelihood that is nowhere finite inside the box is a clear error, not a hang
        struct Nowhere(Prior);
        impl LogDensity for Nowhere {
            fn ln_likelihood(&self, _: &[f64]) -> f64 {
                f64::NAN
            }
            fn prior(&self) -> &Prior {
                &self.0
            }
        }
        let e = chain_starts(&Nowhere(t.prior().clone()), &corner, &fisher_cov, 2, 1).unwrap_err();
        assert!(e.contains("finite ln L"), "{e}");
    }
}
