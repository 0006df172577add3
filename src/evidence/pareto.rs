//! The Pareto k̂ of a sample of importance weights: the shape of a generalized Pareto
//! distribution fitted to their largest values (Zhang & Stephens 2009, with the weakly
//! informative prior of Vehtari et al.'s Pareto-smoothed importance sampling).
//!
//! A mean of weights with tail shape `k` has a finite variance only for `k < ½`, and its
//! delta-method or batch-means error is then trustworthy; for `½ ≤ k < 0.7` the mean converges
//! but slowly and its stated error is too small; beyond 0.7 it is not to be used
//! (`examples/evidence_is.rs` reports it beside every importance-sampling estimate, and
//! [`super::rjmcmc::reciprocal_khat`] applies it to the one-sided reversible-jump estimates).

/// Pareto k̂ of the weights `exp(ln_w)` (only their ratios matter: the logs are shifted by their
/// maximum first). The tail is the largest `M = min(n/5, 3√n)` values, as exceedances over the
/// next largest. `None` with fewer than 25 finite values or a tail of equal values.
///
/// ```
/// use occam::evidence::pareto::pareto_khat;
/// // uniform draws: a bounded tail, k̂ well below ½
/// let ln_w: Vec<f64> = (1..=4000).map(|i| (i as f64 / 4001.0).ln()).collect();
/// assert!(pareto_khat(&ln_w).unwrap() < 0.0);
/// ```
pub fn pareto_khat(ln_w: &[f64]) -> Option<f64> {
    let mut l: Vec<f64> = ln_w.iter().copied().filter(|v| v.is_finite()).collect();
    let n = l.len();
    if n < 25 {
        return None;
    }
    l.sort_by(f64::total_cmp);
    let top = l[n - 1];
    let m = ((n / 5) as f64).min(3.0 * (n as f64).sqrt()).floor() as usize;
    let cutoff = (l[n - m - 1] - top).exp();
    let x: Vec<f64> = l[n - m..]
        .iter()
        .map(|v| (v - top).exp() - cutoff)
        .collect();
    (x[m - 1] > 0.0 && x[0] >= 0.0).then(|| gpd_shape(&x))
}

/// Shape of a generalized Pareto fitted to the ascending exceedances `x`: the profile-posterior
/// mean of `b = −k/σ` over Zhang & Stephens' quasi-grid, then `k` shrunk towards ½ with the
/// weight of 10 observations.
fn gpd_shape(x: &[f64]) -> f64 {
    let n = x.len() as f64;
    let grid = 30 + n.sqrt() as usize;
    let quartile = x[((n / 4.0 + 0.5) as usize).max(1) - 1];
    let xmax = x[x.len() - 1];
    let mean_log = |b: f64| x.iter().map(|&v| (-b * v).ln_1p()).sum::<f64>() / n;
    let b: Vec<f64> = (1..=grid)
        .map(|j| (1.0 - (grid as f64 / (j as f64 - 0.5)).sqrt()) / (3.0 * quartile) + 1.0 / xmax)
        .collect();
    let profile: Vec<f64> = b
        .iter()
        .map(|&bj| {
            let k = mean_log(bj);
            n * ((-bj / k).ln() - k - 1.0)
        })
        .collect();
    // weights ∝ exp(profile), each as 1/Σ exp(profile_j − profile_i) (no overflow)
    let w: Vec<f64> = profile
        .iter()
        .map(|&pi| 1.0 / profile.iter().map(|&pj| (pj - pi).exp()).sum::<f64>())
        .map(|v| if v >= 10.0 * f64::EPSILON { v } else { 0.0 })
        .collect();
    let b_post = b.iter().zip(&w).map(|(b, w)| b * w).sum::<f64>() / w.iter().sum::<f64>();
    let k = mean_log(b_post);
    (n * k + 10.0 * 0.5) / (n + 10.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_xoshiro::Xoshiro256PlusPlus;

    /// ln of draws from a generalized Pareto of shape `k` (scale 1), by inversion.
    fn gpd_ln_draws(k: f64, n: usize, seed: u64) -> Vec<f64> {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
        (0..n)
            .map(|_| {
                let u = rng.random::<f64>();
                let x = if k == 0.0 {
                    -(1.0 - u).ln()
                } else {
                    ((1.0 - u).powf(-k) - 1.0) / k
                };
                (1.0 + x).ln()
            })
            .collect()
    }

    /// The mean k̂ of five samples of 20 000 draws within 3 of its standard errors of the shape:
    /// the tail is 424 values, where one k̂ scatters by about `(1 + k)/√424`.
    #[test]
    fn recovers_the_shape_of_generalized_pareto_draws() {
        for k in [0.0, 0.3, 0.5, 0.7, 0.9] {
            let mean = (0..5u64)
                .map(|s| pareto_khat(&gpd_ln_draws(k, 20_000, 10 * s + 1)).unwrap())
                .sum::<f64>()
                / 5.0;
            let se = (1.0 + k) / 424f64.sqrt() / 5f64.sqrt();
            assert!(
                (mean - k).abs() < 3.0 * se,
                "k = {k}: mean k̂ = {mean} (± {se})"
            );
        }
    }

    /// The reciprocal importance weights `g/p` of a Gaussian posterior `p = N(0, 1)` under a
    /// proposal part `g = N(0, c²)`, at posterior draws, have tail shape `1 − 1/c²` (the
    /// one-sided estimator's case, `super::super::rjmcmc`): 0.31 at select's default c = 1.2.
    #[test]
    fn the_reciprocal_gaussian_weights_have_tail_one_minus_one_over_c_squared() {
        use rand_distr::{Distribution, StandardNormal};
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(7);
        for c in [1.2f64, 1.35] {
            let ln_w: Vec<f64> = (0..40_000)
                .map(|_| {
                    let z: f64 = StandardNormal.sample(&mut rng);
                    -0.5 * z * z / (c * c) + 0.5 * z * z
                })
                .collect();
            let got = pareto_khat(&ln_w).unwrap();
            let want = 1.0 - 1.0 / (c * c);
            assert!((got - want).abs() < 0.1, "c = {c}: k̂ {got}, want {want}");
        }
    }

    #[test]
    fn too_few_or_equal_values_give_none() {
        assert_eq!(pareto_khat(&[0.0; 10]), None);
        assert_eq!(pareto_khat(&[1.5; 100]), None);
        let mut v = vec![f64::NEG_INFINITY; 100];
        v[0] = 0.0;
        assert_eq!(pareto_khat(&v), None);
    }
}
