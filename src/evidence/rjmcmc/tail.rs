//! How far a one-sided estimate can be trusted: the tail of its reciprocal terms.
//!
//! With a model never entered, the Rao-Blackwell and bridge estimates average, over the visited
//! model `k`'s posterior draws, the terms `g_k(θ)/(L_kπ_k(θ))` (module docs of
//! [`super`]). For a Gaussian posterior and the Gaussian part `g_k` at jump scale `c`
//! their tail has Pareto shape `1 − 1/c²` (0.31 at the default 1.2), and the error the
//! chains estimate holds. A posterior that is skewed, or lighter-tailed than `g_k` in some
//! direction, makes the shape larger; above ½ the terms have no variance, and the estimate's
//! stated error is too small however long the run (measured on `examples/accel-asymmetry.toml`
//! against importance sampling: misses of up to 4.3 stated σ, docs/src/reference/estimators.md).
//!
//! `select` does not apply it to its rows yet: computed from the in-model chains it gave 0.80
//! on the nominal guidance-delay study, whose one-sided bridge agrees with nested sampling
//! there, so the threshold on chain draws needs a calibration first (the estimators
//! reference says what was measured).

use super::options::{RjModel, RjOptions};
use super::prepare::prepare;
use crate::evidence::error::EvidenceError;
use crate::evidence::pareto::pareto_khat;

/// Pareto k̂ of the one-sided estimates' reciprocal terms `g_k(θ)/(L_kπ_k(θ))` for `model`
/// (its jump proposal's Gaussian/t part under `opts`), over posterior draws `samples`
/// (row-major, the model's dimension) with their `ln L + ln π` in `ln_target` (any constant
/// offset cancels). `None` without enough draws.
pub fn reciprocal_khat(
    model: &RjModel<'_>,
    opts: &RjOptions,
    samples: &[f64],
    ln_target: &[f64],
) -> Result<Option<f64>, EvidenceError> {
    let d = model.target.dim();
    if d == 0 || samples.len() != d * ln_target.len() {
        return Ok(None);
    }
    let prepared = prepare(std::slice::from_ref(model), opts)?;
    let p = &prepared[0];
    let mut buf = vec![0.0; d];
    let ln_w: Vec<f64> = samples
        .chunks(d)
        .zip(ln_target)
        .map(|(theta, lt)| p.ln_q(theta, opts.proposal, &mut buf) - lt)
        .collect();
    Ok(pareto_khat(&ln_w))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::density::LogDensity;
    use crate::prior::{Prior, PriorKind};
    use nalgebra::DMatrix;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Exp1, StandardNormal};
    use rand_xoshiro::Xoshiro256PlusPlus;

    /// A one-parameter posterior on a wide box: `ln L = f(θ)`.
    struct OneD {
        prior: Prior,
        f: fn(f64) -> f64,
    }

    impl LogDensity for OneD {
        fn ln_likelihood(&self, theta: &[f64]) -> f64 {
            (self.f)(theta[0])
        }
        fn prior(&self) -> &Prior {
            &self.prior
        }
    }

    fn khat_of(f: fn(f64) -> f64, draws: &[f64], mean: f64, var: f64) -> f64 {
        let t = OneD {
            prior: Prior::new(
                vec!["x".into()],
                vec![PriorKind::Uniform {
                    lo: -50.0,
                    hi: 50.0,
                }],
            )
            .unwrap(),
            f,
        };
        let m = RjModel {
            name: "m".into(),
            target: &t,
            center: vec![mean],
            cov: DMatrix::from_element(1, 1, var),
        };
        let ln_target: Vec<f64> = draws.iter().map(|&x| t.ln_posterior(&[x])).collect();
        reciprocal_khat(&m, &RjOptions::default(), draws, &ln_target)
            .unwrap()
            .unwrap()
    }

    /// The default jump scale 1.2 on a Gaussian posterior: shape `1 − 1/1.44 = 0.31`, a
    /// finite variance. The posterior of `ln E`, `E` exponential (skewed, with a right tail far
    /// lighter than a Gaussian's), under its moment-matched Gaussian: beyond 0.7.
    #[test]
    fn a_gaussian_posterior_passes_and_a_skewed_one_does_not() {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(3);
        let gauss: Vec<f64> = (0..20_000)
            .map(|_| StandardNormal.sample(&mut rng))
            .collect();
        let k = khat_of(|x| -0.5 * x * x, &gauss, 0.0, 1.0);
        assert!((k - (1.0 - 1.0 / 1.44)).abs() < 0.1, "Gaussian: k̂ {k}");
        let skewed: Vec<f64> = (0..20_000)
            .map(|_| Exp1.sample(&mut rng))
            .map(|e: f64| e.ln())
            .collect();
        let euler = 0.577_215_664_901_532_9;
        let pi2_6 = std::f64::consts::PI.powi(2) / 6.0;
        let k = khat_of(|x| x - x.exp(), &skewed, -euler, pi2_6);
        assert!(k > 0.7, "skewed: k̂ {k}");
    }
}
