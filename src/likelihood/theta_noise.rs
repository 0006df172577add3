//! The Whittle likelihood of a model whose residual noise depends on θ (ltp-model.md §8.4).
//!
//! A model that knows its own noise ([`Model::data_noise_csd`](crate::model::Model::data_noise_csd), `noise = "model"`) and passes
//! it through its own dynamics — a state-space model's noise inputs through `(sI − A)⁻¹ G` —
//! has a residual CSD `C_k(θ)` that moves with the parameters. The exact likelihood is then
//!
//! ```text
//! ln L(θ) = − Σ_k [ r_k(θ)ᴴ C_k(θ)⁻¹ r_k(θ) + ln det C_k(θ) + R ln π ]
//! ```
//!
//! [`Likelihood`] holds `C` fixed at the point its spectra were prepared at (fast, relative-
//! binnable, an exact Fisher matrix). This module is the exact θ-dependent evaluation beside it:
//! [`ln_likelihood_theta_noise`] (the slow oracle, a per-bin factorisation of `C_k(θ)`),
//! [`noise_parameters`] (which parameters move `C`), and [`NoiseCorrection`], the importance
//! weight that turns an evidence of the fixed-noise likelihood into one of the exact
//! likelihood, `ln Z_exact = ln Z_fixed + ln E_fixed-posterior[L_exact/L_fixed]`, with its
//! Monte-Carlo error. The weight is close to 1 where `C` was evaluated at the posterior (each
//! model's own MAP): the correction is then small and its error smaller.

use super::exact::Likelihood;
use super::noise_matrix::{factorise, residual_csd};
use crate::density::LogDensity;
use crate::hermitian;
use crate::model::{MAX_RESIDUALS, residual_into};
use crate::prior::Prior;
use num_complex::Complex64;
use serde::{Deserialize, Serialize};

const ZERO: Complex64 = Complex64::new(0.0, 0.0);

/// Whether the model of `lik` knows its own noise (then `C` may depend on θ): the first bin of
/// the first experiment answers.
pub fn knows_own_noise(lik: &Likelihood, th: &[f64]) -> bool {
    let Some(e) = lik.spectra().first() else {
        return false;
    };
    let m = lik.model_of(0);
    let nc = m.data_channels().len();
    let mut s = vec![ZERO; nc * nc];
    m.data_noise_csd(th, &e.bin(0, m.n_consts()), &mut s)
}

/// `Σ_k ln det C_k(θ)` over every experiment, `None` where a bin's `C` cannot be factorised
/// or the model does not know its noise.
fn ln_det_sum(lik: &Likelihood, th: &[f64]) -> Option<f64> {
    let mut sum = 0.0;
    let mut ok = true;
    visit(lik, th, |_, ld| {
        match ld {
            Some((_, ld)) => sum += ld,
            None => ok = false,
        };
    });
    ok.then_some(sum)
}

/// The parameters among `free` whose change moves the residual CSD (their relative step of
/// 10⁻⁴ of the prior's width changes `Σ_k ln det C_k` by more than 10⁻⁹ per bin); empty when
/// the model does not know its own noise.
pub fn noise_parameters(lik: &Likelihood, th: &[f64], free: &[usize]) -> Vec<usize> {
    if !knows_own_noise(lik, th) {
        return Vec::new();
    }
    let Some(base) = ln_det_sum(lik, th) else {
        return Vec::new();
    };
    let bins = lik.n_bins().max(1) as f64;
    let kinds = lik.prior().kinds();
    free.iter()
        .copied()
        .filter(|&a| {
            let h = 1e-4 * kinds[a].sd().max(th[a].abs() * 1e-6).max(f64::MIN_POSITIVE);
            let mut p = th.to_vec();
            p[a] += h;
            ln_det_sum(lik, &p).is_some_and(|v| (v - base).abs() > 1e-9 * bins)
        })
        .collect()
}

/// Calls `f(quadratic form, Some((k, ln det C_k)))` per bin of every experiment at `th`, with
/// `C_k` evaluated at `th`; `None` for a bin whose `C` is not positive definite (or unknown).
fn visit(lik: &Likelihood, th: &[f64], mut f: impl FnMut(f64, Option<(usize, f64)>)) {
    for (ei, e) in lik.spectra().iter().enumerate() {
        let m = lik.model_of(ei);
        let (nc, nr) = (e.channels.len(), e.nr);
        let all: Vec<usize> = (0..nc).collect();
        let mut coef = vec![ZERO; nr * nc];
        let mut sd = vec![ZERO; nc * nc];
        let mut s = vec![ZERO; nr * nr];
        let mut r = [ZERO; MAX_RESIDUALS];
        for k in 0..e.len() {
            let bin = e.bin(k, m.n_consts());
            if !m.data_noise_csd(th, &bin, &mut sd) {
                f(0.0, None);
                continue;
            }
            // a gapped run: the leakage its bins have at the spectra's point, in proportion
            if let Some(leak) = &e.noise_leak {
                leak.apply(k, &mut sd, nc);
            }
            m.coefficients(th, &bin, &mut coef);
            residual_csd(&coef, nr, nc, &all, &sd, &mut s);
            match factorise(&s, nr, e.noise_scale, bin.f, m.residual_channels()) {
                Ok((_, w, ld)) => {
                    residual_into(&coef, e.data_at(k), &mut r[..nr]);
                    f(hermitian::quad_whitened(&w, &r[..nr]), Some((k, ld)));
                }
                Err(_) => f(0.0, None),
            }
        }
    }
}

/// The exact Whittle `ln L(θ)` with the residual CSD evaluated at `th` itself (module docs);
/// `−∞` where `C_k(θ)` is not positive definite or the system is unstable, `NaN` for a
/// parameter vector of the wrong length. Equals [`Likelihood::ln_likelihood_whittle`] at the
/// point the likelihood's spectra were prepared at.
pub fn ln_likelihood_theta_noise(lik: &Likelihood, th: &[f64]) -> f64 {
    if th.len() != lik.model().param_names().len() {
        return f64::NAN;
    }
    if !lik.model().is_stable(th) || th.iter().any(|v| !v.is_finite()) {
        return f64::NEG_INFINITY;
    }
    let ln_pi = std::f64::consts::PI.ln();
    let mut sum = 0.0;
    let mut ok = true;
    for e in lik.spectra() {
        sum -= e.nr as f64 * ln_pi * e.len() as f64;
    }
    visit(lik, th, |q, ld| match ld {
        Some((_, ld)) => sum -= q + ld,
        None => ok = false,
    });
    if ok && sum.is_finite() {
        sum
    } else {
        f64::NEG_INFINITY
    }
}

/// [`ln_likelihood_theta_noise`] bin by bin, one vector per experiment in the likelihood's
/// order (as [`Likelihood::ln_likelihood_per_bin`]); `−∞` in a bin whose `C_k(θ)` is not
/// positive definite, every bin `−∞` where the system is unstable. Their sum is
/// [`ln_likelihood_theta_noise`] wherever that is finite.
pub fn ln_likelihood_theta_noise_per_bin(lik: &Likelihood, th: &[f64]) -> Vec<Vec<f64>> {
    let ninf = || {
        lik.spectra()
            .iter()
            .map(|e| vec![f64::NEG_INFINITY; e.len()])
            .collect()
    };
    if th.len() != lik.model().param_names().len()
        || !lik.model().is_stable(th)
        || th.iter().any(|v| !v.is_finite())
    {
        return ninf();
    }
    let mut flat = Vec::with_capacity(lik.n_bins());
    visit(lik, th, |q, ld| {
        flat.push(ld.map_or(f64::NEG_INFINITY, |(_, ld)| -q - ld));
    });
    let ln_pi = std::f64::consts::PI.ln();
    let mut rest = flat.as_slice();
    lik.spectra()
        .iter()
        .map(|e| {
            let (mine, tail) = rest.split_at(e.len());
            rest = tail;
            mine.iter().map(|v| v - e.nr as f64 * ln_pi).collect()
        })
        .collect()
}

/// A [`Likelihood`] evaluated with its residual CSD at θ ([`ln_likelihood_theta_noise`]), as a
/// density for any sampler or evidence estimator (slow: a factorisation per bin).
#[derive(Debug, Clone, Copy)]
pub struct ThetaNoiseDensity<'a>(pub &'a Likelihood);

impl LogDensity for ThetaNoiseDensity<'_> {
    fn ln_likelihood(&self, theta: &[f64]) -> f64 {
        ln_likelihood_theta_noise(self.0, theta)
    }

    fn prior(&self) -> &Prior {
        self.0.prior()
    }
}

/// `ln E[L_exact/L_fixed]` over posterior samples of the fixed-noise likelihood: what turns
/// its evidence into the exact θ-dependent one (module docs).
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
pub struct NoiseCorrection {
    /// `ln Z_exact − ln Z_fixed`.
    pub ln_z_shift: f64,
    /// Its one-sigma Monte-Carlo error (batch means over the samples in chain order).
    pub std_err: f64,
    /// Kish's effective sample size of the importance weights.
    pub weight_ess: f64,
    /// Samples the correction averages over.
    pub samples: usize,
    /// The largest `|ln L_exact − ln L_fixed|` over the samples (nats): how far the fixed
    /// noise is from the exact one where the posterior is.
    pub max_abs_log_ratio: f64,
}

/// Batches the error of [`NoiseCorrection`] is estimated from.
const BATCHES: usize = 20;

impl NoiseCorrection {
    /// The correction from the samples `thetas` (full parameter vectors, in chain order, the
    /// chains one after another) of the posterior of `fixed`; `None` with fewer than
    /// `2 · BATCHES` samples or when a sample's likelihood is not finite under both.
    pub fn estimate<'a>(
        fixed: &Likelihood,
        thetas: impl IntoIterator<Item = &'a [f64]>,
    ) -> Option<NoiseCorrection> {
        let w: Vec<f64> = thetas
            .into_iter()
            .map(|th| ln_likelihood_theta_noise(fixed, th) - fixed.ln_likelihood_whittle(th))
            .collect();
        Self::from_log_ratios(&w)
    }

    /// The correction from the log ratios `ln L_exact − ln L_fixed` of posterior samples of
    /// the fixed-noise likelihood, in chain order.
    pub fn from_log_ratios(w: &[f64]) -> Option<NoiseCorrection> {
        let n = w.len();
        if n < 2 * BATCHES || w.iter().any(|v| !v.is_finite()) {
            return None;
        }
        let top = w.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        let v: Vec<f64> = w.iter().map(|x| (x - top).exp()).collect();
        let mean = v.iter().sum::<f64>() / n as f64;
        let sum2: f64 = v.iter().map(|x| x * x).sum();
        let weight_ess = v.iter().sum::<f64>().powi(2) / sum2;
        // batch means: correlated MCMC samples, contiguous batches
        let len = n / BATCHES;
        let bm: Vec<f64> = (0..BATCHES)
            .map(|b| v[b * len..(b + 1) * len].iter().sum::<f64>() / len as f64)
            .collect();
        let bmean = bm.iter().sum::<f64>() / BATCHES as f64;
        let var = bm.iter().map(|x| (x - bmean).powi(2)).sum::<f64>() / (BATCHES - 1) as f64;
        let se = (var / BATCHES as f64).sqrt() / mean;
        Some(NoiseCorrection {
            ln_z_shift: top + mean.ln(),
            std_err: se,
            weight_ess,
            samples: n,
            max_abs_log_ratio: w.iter().map(|x| x.abs()).fold(0.0, f64::max),
        })
    }

    /// Whether the weights are too uneven for the correction to be trusted (fewer than 5 % of
    /// the samples effective, or fewer than 100).
    pub fn unreliable(&self) -> bool {
        self.weight_ess < 100.0_f64.max(0.05 * self.samples as f64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn equal_likelihoods_need_no_correction() {
        let c = NoiseCorrection::from_log_ratios(&[0.0; 200]).unwrap();
        assert_eq!(c.ln_z_shift, 0.0);
        assert_eq!(c.std_err, 0.0);
        assert!((c.weight_ess - 200.0).abs() < 1e-9);
        assert!(!c.unreliable());
    }

    #[test]
    fn a_constant_ratio_shifts_by_itself() {
        let c = NoiseCorrection::from_log_ratios(&[-3.25; 400]).unwrap();
        assert!((c.ln_z_shift + 3.25).abs() < 1e-12);
    }

    #[test]
    fn gaussian_log_ratios_give_the_lognormal_mean_within_the_error() {
        // w ~ N(μ, s²) independent: E[e^w] = e^{μ + s²/2}; the error must cover it at its rate
        use rand::SeedableRng;
        use rand_distr::{Distribution, Normal};
        let (mu, s) = (0.4, 0.5);
        let truth = mu + s * s / 2.0;
        let mut z2 = 0.0;
        let reps = 200;
        for seed in 0..reps {
            let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(seed);
            let d = Normal::new(mu, s).unwrap();
            let w: Vec<f64> = (0..2000).map(|_| d.sample(&mut rng)).collect();
            let c = NoiseCorrection::from_log_ratios(&w).unwrap();
            z2 += ((c.ln_z_shift - truth) / c.std_err).powi(2);
        }
        let rms = (z2 / reps as f64).sqrt();
        // 200 seeds: the RMS z of a right error bar is 1 ± 0.05; 20 % off is 0.83 or 1.25
        assert!((0.88..1.14).contains(&rms), "RMS z {rms}");
    }

    #[test]
    fn too_few_samples_give_nothing() {
        assert!(NoiseCorrection::from_log_ratios(&[0.0; 10]).is_none());
        assert!(NoiseCorrection::from_log_ratios(&[0.0, f64::NAN].repeat(50)).is_none());
    }
}
