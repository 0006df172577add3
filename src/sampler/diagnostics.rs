//! Convergence diagnostics: effective sample size, integrated autocorrelation time and
//! rank-normalised split-R̂, after Vehtari, Gelman, Simpson, Carpenter & Bürkner (2021),
//! "Rank-normalization, folding, and localization: an improved R̂", Bayesian Analysis 16.
//!
//! * **ESS** (of the mean): every chain is split in half (a drifting chain then looks like two
//!   disagreeing ones); the multi-chain autocorrelation
//!   `ρ_t = 1 − (W − mean_j γ_j(t)) / var⁺` (γ_j the chain autocovariances, computed by FFT)
//!   is summed with Geyer's initial monotone positive-pair sequence:
//!   `τ = −1 + 2 Σ_{t<T} ρ_t + ρ_T`, `ESS = M N / τ`. This is also the integrated
//!   autocorrelation time reported per parameter, `τ = (total draws) / ESS`, in units of
//!   kept (thinned) samples.
//! * **R̂**: split chains, ranks of the pooled draws mapped to normal scores
//!   `Φ⁻¹((r − 3/8)/(S + 1/4))`, classic `√(var⁺/W)`; the reported value is the larger of the
//!   bulk R̂ and the tail R̂ (the same on `|θ − median|`).

use std::fmt;
use std::sync::Arc;

use realfft::num_complex::Complex;
use realfft::{ComplexToReal, RealFftPlanner, RealToComplex};
use statrs::function::erf::erfc_inv;

use super::chains::Chains;
use super::error::SamplerError;

/// Limits beyond which [`Diagnostics::warnings`] complains.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Thresholds {
    /// Largest acceptable R̂ (Vehtari et al. 2021 recommend 1.01).
    pub max_rhat: f64,
    /// Smallest acceptable total ESS per parameter (their recommendation: 100, i.e. 25 per
    /// chain for 4 chains).
    pub min_ess: f64,
    /// Acceptance rate range of the sampling phase, `[min, max]`.
    pub acceptance: (f64, f64),
}

impl Default for Thresholds {
    fn default() -> Self {
        Self {
            max_rhat: 1.01,
            min_ess: 100.0,
            acceptance: (0.05, 0.8),
        }
    }
}

/// A problem found by [`Diagnostics::warnings`]; `Display` explains it and what to do.
#[derive(Debug, Clone, PartialEq)]
pub enum Warning {
    /// R̂ above the threshold.
    RHat {
        /// Parameter.
        param: String,
        /// Its R̂.
        rhat: f64,
        /// Threshold.
        max: f64,
    },
    /// ESS below the threshold.
    LowEss {
        /// Parameter.
        param: String,
        /// Its ESS.
        ess: f64,
        /// Threshold.
        min: f64,
    },
    /// Sampling-phase acceptance rate outside the range.
    Acceptance {
        /// Chain index.
        chain: usize,
        /// Its acceptance rate.
        rate: f64,
        /// Range.
        range: (f64, f64),
    },
    /// Some proposals had a non-finite `ln L`.
    NonFinite {
        /// Chain index.
        chain: usize,
        /// Number of such proposals (burn-in and sampling).
        count: u64,
    },
    /// A parameter never moved in any kept sample.
    Stuck {
        /// Parameter.
        param: String,
        /// Whether some chain accepted proposals in the sampling phase (then the steps were
        /// below the resolution of the value in `f64`).
        accepted: bool,
    },
    /// R̂ is not finite (∞: every half-chain stayed at one value while the chains disagree,
    /// so the within-chain variance is zero; NaN: the draws overflow), so the convergence of
    /// the parameter is unknown. `summary.json` writes such an R̂ as `null`.
    RHatNotFinite {
        /// Parameter.
        param: String,
        /// Its R̂ (∞ or NaN).
        rhat: f64,
        /// Whether no chain accepted any proposal in the sampling phase.
        none_accepted: bool,
    },
}

impl fmt::Display for Warning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Warning::RHat { param, rhat, max } => write!(
                f,
                "R-hat of `{param}` is {rhat:.4} > {max}: the chains have not converged to the same distribution; run longer, start closer to the mode, or check for multiple modes"
            ),
            Warning::LowEss { param, ess, min } => write!(
                f,
                "effective sample size of `{param}` is {ess:.0} < {min}: estimates are noisy; run longer or improve the proposal covariance"
            ),
            Warning::Acceptance { chain, rate, range } => write!(
                f,
                "chain {chain} accepted {:.1}% of proposals, outside [{:.0}%, {:.0}%]: {}",
                100.0 * rate,
                100.0 * range.0,
                100.0 * range.1,
                if *rate < range.0 {
                    "the proposal is too wide; scale the covariance down (occam fit: lower [fit] proposal_scale)"
                } else {
                    "the proposal is too narrow; scale the covariance up (occam fit: raise [fit] proposal_scale)"
                }
            ),
            Warning::NonFinite { chain, count } => write!(
                f,
                "chain {chain}: {count} proposals had a non-finite ln L and were rejected; check the likelihood's domain or tighten the prior"
            ),
            Warning::Stuck { param, accepted } => write!(
                f,
                "`{param}` has the same value in every kept sample: the chains did not move (R-hat ∞, written as null in summary.json); {}",
                if *accepted {
                    "proposals were accepted but did not change it: the proposal's steps are below the resolution of its value in double precision (posterior σ < 1e-16 of the value), i.e. the data constrain it far beyond what the numbers can represent; check the injection amplitudes and noise levels (ρ_opt) of the study"
                } else {
                    "no proposal was accepted: the proposal is too wide for the posterior (lower [fit] proposal_scale) or ln L is not finite around the start; check the start point"
                }
            ),
            Warning::RHatNotFinite {
                param,
                rhat,
                none_accepted,
            } => {
                if rhat.is_nan() {
                    write!(
                        f,
                        "R-hat of `{param}` is NaN (written as null in summary.json): its draws are too large to compute variances (they overflow); rescale the parameter or narrow its prior"
                    )
                } else {
                    write!(
                        f,
                        "R-hat of `{param}` is ∞ (written as null in summary.json): zero within-chain variance, every chain stayed at one value while the chains disagree: the chains did not move{}",
                        if *none_accepted {
                            "; no proposal was accepted in any chain: the proposal is too wide for the posterior (lower [fit] proposal_scale) or ln L is not finite or rounds to the same value around the start (amplitudes so large that ln L ≈ 1e30 changes by less than its rounding)"
                        } else {
                            "; the chains accepted some proposals, but not in this parameter's direction: the proposal covariance is wrong along it (check the Fisher matrix warnings) or ln L is not finite around the start"
                        }
                    )
                }
            }
        }
    }
}

impl Chains {
    /// Diagnostics with the default [`Thresholds`].
    pub fn diagnostics(&self) -> Result<Diagnostics, SamplerError> {
        Diagnostics::compute(self, Thresholds::default())
    }

    /// Diagnostics with the given thresholds for [`Diagnostics::warnings`].
    pub fn diagnostics_with(&self, thresholds: Thresholds) -> Result<Diagnostics, SamplerError> {
        Diagnostics::compute(self, thresholds)
    }
}

/// Per-parameter and per-chain summaries of a run. Computed by [`Chains::diagnostics`].
#[derive(Debug, Clone, PartialEq)]
pub struct Diagnostics {
    /// Parameter names.
    pub names: Vec<String>,
    /// Pooled posterior mean per parameter.
    pub mean: Vec<f64>,
    /// Pooled posterior standard deviation per parameter.
    pub sd: Vec<f64>,
    /// Monte-Carlo standard error of the mean, `sd / √ESS` (∞ if ESS = 0).
    pub mcse: Vec<f64>,
    /// Effective sample size of the mean, total over chains.
    pub ess: Vec<f64>,
    /// Integrated autocorrelation time in kept samples, `M N / ESS`.
    pub tau: Vec<f64>,
    /// Rank-normalised split-R̂ (max of bulk and tail).
    pub rhat: Vec<f64>,
    /// Sampling-phase acceptance rate per chain.
    pub acceptance: Vec<f64>,
    /// Prior rejections per chain (all phases).
    pub prior_rejected: Vec<u64>,
    /// Non-finite `ln L` proposals per chain (all phases).
    pub non_finite: Vec<u64>,
    /// Thresholds used by [`Diagnostics::warnings`].
    pub thresholds: Thresholds,
}

impl Diagnostics {
    pub(crate) fn compute(chains: &Chains, thresholds: Thresholds) -> Result<Self, SamplerError> {
        let d = chains.dim();
        let m = chains.chains().len();
        let n = chains.n_kept();
        let mut out = Diagnostics {
            names: chains.names().to_vec(),
            mean: Vec::with_capacity(d),
            sd: Vec::with_capacity(d),
            mcse: Vec::with_capacity(d),
            ess: Vec::with_capacity(d),
            tau: Vec::with_capacity(d),
            rhat: Vec::with_capacity(d),
            acceptance: chains
                .chains()
                .iter()
                .map(|c| c.counts.sampling.acceptance())
                .collect(),
            prior_rejected: chains
                .chains()
                .iter()
                .map(|c| c.counts.burn_in.prior_rejected + c.counts.sampling.prior_rejected)
                .collect(),
            non_finite: chains
                .chains()
                .iter()
                .map(|c| c.counts.burn_in.non_finite + c.counts.sampling.non_finite)
                .collect(),
            thresholds,
        };
        for k in 0..d {
            let series: Vec<Vec<f64>> = (0..m).map(|c| chains.series(c, k)).collect();
            let refs: Vec<&[f64]> = series.iter().map(Vec::as_slice).collect();
            let ess_k = ess(&refs)?;
            let rhat_k = split_rhat(&refs)?;
            let total = (m * n) as f64;
            let mean = refs.iter().flat_map(|s| s.iter()).sum::<f64>() / total;
            let ss: f64 = refs
                .iter()
                .flat_map(|s| s.iter())
                .map(|x| (x - mean) * (x - mean))
                .sum();
            // a parameter that never moved has sd 0 exactly, whatever the rounding of the
            // mean of its (equal) draws ([`Warning::Stuck`] tests for 0)
            let first = refs[0][0];
            let constant = refs.iter().flat_map(|s| s.iter()).all(|&x| x == first);
            let sd = if constant {
                0.0
            } else {
                (ss / (total - 1.0)).sqrt()
            };
            out.mean.push(mean);
            out.sd.push(sd);
            out.mcse.push(if ess_k > 0.0 {
                sd / ess_k.sqrt()
            } else {
                f64::INFINITY
            });
            out.ess.push(ess_k);
            out.tau.push(if ess_k > 0.0 {
                total / ess_k
            } else {
                f64::INFINITY
            });
            out.rhat.push(rhat_k);
        }
        Ok(out)
    }

    /// Everything outside the [`Thresholds`]: R̂ too large, ESS too small, acceptance
    /// outside its range, non-finite `ln L` proposals, parameters that never moved.
    pub fn warnings(&self) -> Vec<Warning> {
        let t = &self.thresholds;
        let mut w = Vec::new();
        for (k, name) in self.names.iter().enumerate() {
            if self.sd[k] == 0.0 {
                w.push(Warning::Stuck {
                    param: name.clone(),
                    accepted: self.acceptance.iter().any(|&a| a > 0.0),
                });
                continue;
            }
            if !self.rhat[k].is_finite() {
                w.push(Warning::RHatNotFinite {
                    param: name.clone(),
                    rhat: self.rhat[k],
                    none_accepted: self.acceptance.iter().all(|&a| a == 0.0),
                });
                continue;
            }
            if self.rhat[k] > t.max_rhat {
                w.push(Warning::RHat {
                    param: name.clone(),
                    rhat: self.rhat[k],
                    max: t.max_rhat,
                });
            }
            if self.ess[k] < t.min_ess {
                w.push(Warning::LowEss {
                    param: name.clone(),
                    ess: self.ess[k],
                    min: t.min_ess,
                });
            }
        }
        for (c, &rate) in self.acceptance.iter().enumerate() {
            if rate < t.acceptance.0 || rate > t.acceptance.1 {
                w.push(Warning::Acceptance {
                    chain: c,
                    rate,
                    range: t.acceptance,
                });
            }
        }
        for (c, &count) in self.non_finite.iter().enumerate() {
            if count > 0 {
                w.push(Warning::NonFinite { chain: c, count });
            }
        }
        w
    }
}

/// Checks draws: ≥ 1 chain, equal lengths ≥ 4, all finite. Returns the length.
fn check(chains: &[&[f64]]) -> Result<usize, SamplerError> {
    let bad = |problem: String| Err(SamplerError::Diagnostics { problem });
    let Some(first) = chains.first() else {
        return bad("no chains given".into());
    };
    let n = first.len();
    if let Some((j, c)) = chains.iter().enumerate().find(|(_, c)| c.len() != n) {
        return bad(format!(
            "chain {j} has {} draws but chain 0 has {n}; chains must have equal lengths",
            c.len()
        ));
    }
    if n < 4 {
        return bad(format!(
            "{n} draws per chain; at least 4 are needed to split chains (keep more samples)"
        ));
    }
    if chains.iter().flat_map(|c| c.iter()).any(|x| !x.is_finite()) {
        return bad("a draw is not finite".into());
    }
    Ok(n)
}

/// Each chain cut into its first and last `⌊n/2⌋` draws (the middle one dropped if `n` is
/// odd).
fn split<'a>(chains: &[&'a [f64]]) -> Vec<&'a [f64]> {
    let mut out = Vec::with_capacity(2 * chains.len());
    for c in chains {
        let h = c.len() / 2;
        out.push(&c[..h]);
        out.push(&c[c.len() - h..]);
    }
    out
}

/// Biased autocovariance `γ(t) = (1/n) Σ (x_i − x̄)(x_{i+t} − x̄)` of equal-length series by
/// zero-padded real FFT, one plan for all chains.
struct Autocov {
    n: usize,
    r2c: Arc<dyn RealToComplex<f64>>,
    c2r: Arc<dyn ComplexToReal<f64>>,
    time: Vec<f64>,
    freq: Vec<Complex<f64>>,
}

impl Autocov {
    fn new(n: usize) -> Self {
        let nfft = (2 * n).next_power_of_two();
        let mut planner = RealFftPlanner::<f64>::new();
        let r2c = planner.plan_fft_forward(nfft);
        let c2r = planner.plan_fft_inverse(nfft);
        let time = r2c.make_input_vec();
        let freq = r2c.make_output_vec();
        Self {
            n,
            r2c,
            c2r,
            time,
            freq,
        }
    }

    fn compute(&mut self, x: &[f64], out: &mut [f64]) {
        let n = self.n;
        let nfft = self.time.len();
        let mean = x.iter().sum::<f64>() / n as f64;
        self.time.iter_mut().for_each(|v| *v = 0.0);
        for (t, v) in self.time.iter_mut().zip(x) {
            *t = v - mean;
        }
        self.r2c
            .process(&mut self.time, &mut self.freq)
            .expect("buffers come from the plan");
        for c in &mut self.freq {
            *c = Complex::new(c.norm_sqr(), 0.0);
        }
        self.c2r
            .process(&mut self.freq, &mut self.time)
            .expect("buffers come from the plan and the power spectrum is real");
        let norm = 1.0 / (nfft as f64 * n as f64);
        for (o, t) in out.iter_mut().zip(&self.time) {
            *o = t * norm;
        }
    }
}

/// Multi-chain ESS of unsplit equal-length chains (Geyer initial monotone sequence).
fn ess_raw(chains: &[&[f64]]) -> f64 {
    let m = chains.len();
    let n = chains[0].len();
    let mut ac = Autocov::new(n);
    let mut acov = vec![vec![0.0; n]; m];
    for (c, a) in chains.iter().zip(&mut acov) {
        ac.compute(c, a);
    }
    let nf = n as f64;
    let means: Vec<f64> = chains.iter().map(|c| c.iter().sum::<f64>() / nf).collect();
    let mean_var = acov.iter().map(|a| a[0]).sum::<f64>() / m as f64 * nf / (nf - 1.0);
    let mut var_plus = mean_var * (nf - 1.0) / nf;
    if m > 1 {
        let mu = means.iter().sum::<f64>() / m as f64;
        var_plus += means.iter().map(|x| (x - mu) * (x - mu)).sum::<f64>() / (m - 1) as f64;
    }
    // Inputs are finite (checked), so only an all-equal sample gets here.
    if var_plus <= 0.0 {
        return 0.0;
    }
    let rho =
        |t: usize| 1.0 - (mean_var - acov.iter().map(|a| a[t]).sum::<f64>() / m as f64) / var_plus;
    let mut r = vec![0.0; n];
    r[0] = 1.0;
    let mut even = 1.0;
    let mut odd = rho(1);
    r[1] = odd;
    let mut t = 0usize;
    while t + 5 < n && even + odd > 0.0 {
        t += 2;
        even = rho(t);
        odd = rho(t + 1);
        if even + odd >= 0.0 {
            r[t] = even;
            r[t + 1] = odd;
        }
    }
    let max_t = t;
    if even > 0.0 {
        r[max_t] = even;
    }
    // Geyer: the pair sums must not increase.
    let mut t = 0usize;
    while t + 4 <= max_t {
        t += 2;
        let prev = r[t - 2] + r[t - 1];
        if r[t] + r[t + 1] > prev {
            r[t] = prev / 2.0;
            r[t + 1] = prev / 2.0;
        }
    }
    let total = (m * n) as f64;
    let tau = -1.0 + 2.0 * r[..max_t].iter().sum::<f64>() + r[max_t];
    // The floor caps ESS at S·log₁₀S for antithetic chains, as in Stan and posterior.
    let tau = tau.max(1.0 / total.log10());
    total / tau
}

/// Classic potential scale reduction of equal-length chains; ∞ if the within-chain variance
/// is zero.
fn rhat_raw(chains: &[&[f64]]) -> f64 {
    let m = chains.len() as f64;
    let n = chains[0].len() as f64;
    let means: Vec<f64> = chains.iter().map(|c| c.iter().sum::<f64>() / n).collect();
    let w = chains
        .iter()
        .zip(&means)
        .map(|(c, mu)| c.iter().map(|x| (x - mu) * (x - mu)).sum::<f64>() / (n - 1.0))
        .sum::<f64>()
        / m;
    if w <= 0.0 {
        return f64::INFINITY;
    }
    let mu = means.iter().sum::<f64>() / m;
    let b_over_n = if m > 1.0 {
        means.iter().map(|x| (x - mu) * (x - mu)).sum::<f64>() / (m - 1.0)
    } else {
        0.0
    };
    (((n - 1.0) / n * w + b_over_n) / w).sqrt()
}

/// Normal scores of the pooled ranks (ties get their average rank).
fn rank_normalise(chains: &[&[f64]]) -> Vec<Vec<f64>> {
    let mut pooled: Vec<(f64, usize, usize)> = chains
        .iter()
        .enumerate()
        .flat_map(|(c, s)| s.iter().enumerate().map(move |(i, &x)| (x, c, i)))
        .collect();
    pooled.sort_by(|a, b| a.0.total_cmp(&b.0));
    let s = pooled.len() as f64;
    let mut out: Vec<Vec<f64>> = chains.iter().map(|c| vec![0.0; c.len()]).collect();
    let mut i = 0;
    while i < pooled.len() {
        let mut j = i;
        while j + 1 < pooled.len() && pooled[j + 1].0 == pooled[i].0 {
            j += 1;
        }
        // 1-based ranks i+1 ..= j+1 share their mean.
        let rank = (i + j) as f64 / 2.0 + 1.0;
        let p = (rank - 0.375) / (s + 0.25);
        let z = -std::f64::consts::SQRT_2 * erfc_inv(2.0 * p);
        for &(_, c, k) in &pooled[i..=j] {
            out[c][k] = z;
        }
        i = j + 1;
    }
    out
}

/// Split-chain effective sample size of the mean of `chains` (one slice per chain, equal
/// lengths ≥ 4, finite): total over chains. 0 if every draw is identical.
///
/// ```
/// use occam::sampler::{chain_rng, ess};
/// use rand::RngExt;
/// // Independent draws: ESS ≈ number of draws. The estimate's relative standard error is
/// // ≈ √(2(2M + 1)/N) ≈ 3 % for a window M of a few lags, so 15 % is 5 of them.
/// let mut rng = chain_rng(1, 0);
/// let a: Vec<f64> = (0..4000).map(|_| rng.random::<f64>()).collect();
/// let e = ess(&[&a[..2000], &a[2000..]]).unwrap();
/// assert!((e - 4000.0).abs() < 600.0, "{e}");
/// ```
pub fn ess(chains: &[&[f64]]) -> Result<f64, SamplerError> {
    check(chains)?;
    Ok(ess_raw(&split(chains)))
}

/// Rank-normalised split-R̂ of `chains` (one slice per chain, equal lengths ≥ 4, finite):
/// the larger of bulk and tail R̂. ∞ if the chains never move.
pub fn split_rhat(chains: &[&[f64]]) -> Result<f64, SamplerError> {
    check(chains)?;
    let halves = split(chains);
    let z = rank_normalise(&halves);
    let bulk = rhat_raw(&z.iter().map(Vec::as_slice).collect::<Vec<_>>());
    let mut pooled: Vec<f64> = halves.iter().flat_map(|c| c.iter().copied()).collect();
    pooled.sort_by(f64::total_cmp);
    let k = pooled.len();
    let median = if k % 2 == 1 {
        pooled[k / 2]
    } else {
        0.5 * (pooled[k / 2 - 1] + pooled[k / 2])
    };
    let folded: Vec<Vec<f64>> = halves
        .iter()
        .map(|c| c.iter().map(|x| (x - median).abs()).collect())
        .collect();
    let folded_refs: Vec<&[f64]> = folded.iter().map(Vec::as_slice).collect();
    let zf = rank_normalise(&folded_refs);
    let tail = rhat_raw(&zf.iter().map(Vec::as_slice).collect::<Vec<_>>());
    Ok(bulk.max(tail))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::chain_rng;
    use rand_distr::{Distribution, StandardNormal};

    fn ar1(seed: u64, n: usize, phi: f64, shift: f64) -> Vec<f64> {
        let mut rng = chain_rng(seed, 0);
        let mut x = 0.0;
        let s = (1.0 - phi * phi).sqrt();
        (0..n)
            .map(|_| {
                let z: f64 = StandardNormal.sample(&mut rng);
                x = phi * x + s * z;
                x + shift
            })
            .collect()
    }

    #[test]
    fn fft_autocovariance_matches_direct_sum() {
        let x = ar1(4, 257, 0.6, 0.3);
        let mut out = vec![0.0; x.len()];
        Autocov::new(x.len()).compute(&x, &mut out);
        let n = x.len();
        let mean = x.iter().sum::<f64>() / n as f64;
        for t in [0, 1, 5, 100, 256] {
            let direct: f64 = (0..n - t)
                .map(|i| (x[i] - mean) * (x[i + t] - mean))
                .sum::<f64>()
                / n as f64;
            assert!(
                (out[t] - direct).abs() < 1e-12,
                "lag {t}: {} vs {direct}",
                out[t]
            );
        }
    }

    #[test]
    fn ess_of_ar1_matches_theory() {
        // AR(1) with φ = 0.9 has τ = (1 + φ)/(1 − φ) = 19. A windowed τ estimate has
        // var(τ̂)/τ² ≈ 2(2M + 1)/N (Sokal 1997); with a window M ≈ 5τ ≈ 95 and N = 200 000
        // draws that is a 4.4 % standard error, so 20 % is 4.5 standard errors.
        let chains: Vec<Vec<f64>> = (0..4).map(|c| ar1(10 + c, 50_000, 0.9, 0.0)).collect();
        let refs: Vec<&[f64]> = chains.iter().map(Vec::as_slice).collect();
        let e = ess(&refs).unwrap();
        let tau = 200_000.0 / e;
        assert!((tau - 19.0).abs() < 0.2 * 19.0, "tau = {tau}");
    }

    #[test]
    fn rhat_flags_disagreeing_chains_only() {
        let same: Vec<Vec<f64>> = (0..4).map(|c| ar1(20 + c, 4000, 0.5, 0.0)).collect();
        let refs: Vec<&[f64]> = same.iter().map(Vec::as_slice).collect();
        let r = split_rhat(&refs).unwrap();
        assert!(r < 1.01, "{r}");
        // One chain shifted by one standard deviation: R̂ well above 1.01.
        let mut shifted = same.clone();
        shifted[3] = ar1(23, 4000, 0.5, 1.0);
        let refs: Vec<&[f64]> = shifted.iter().map(Vec::as_slice).collect();
        let r = split_rhat(&refs).unwrap();
        assert!(r > 1.05, "{r}");
        // Stuck chains.
        let flat = vec![1.0; 100];
        assert_eq!(split_rhat(&[&flat, &flat]).unwrap(), f64::INFINITY);
        assert_eq!(ess(&[&flat, &flat]).unwrap(), 0.0);
    }

    /// Builds chains of two parameters from per-chain series, with `accepted` of 100
    /// sampling-phase proposals accepted in every chain.
    fn chain_set(series: &[(Vec<f64>, Vec<f64>)], accepted: u64) -> Chains {
        use crate::sampler::chains::{BestPoint, Chain, ChainCounts, PhaseCounts};
        let chains = series
            .iter()
            .map(|(a, b)| Chain {
                samples: a.iter().zip(b).flat_map(|(x, y)| [*x, *y]).collect(),
                ln_posterior: vec![-1.0; a.len()],
                ln_likelihood: vec![-1.0; a.len()],
                accepted: vec![true; a.len()],
                counts: ChainCounts {
                    burn_in: PhaseCounts::default(),
                    sampling: PhaseCounts {
                        proposed: 100,
                        accepted,
                        ..Default::default()
                    },
                    ..Default::default()
                },
                best: BestPoint {
                    theta: vec![a[0], b[0]],
                    ln_posterior: -1.0,
                    ln_likelihood: -1.0,
                },
                proposal_covariance: vec![1.0, 0.0, 0.0, 1.0],
            })
            .collect();
        Chains::new(vec!["amp".into(), "x".into()], chains).unwrap()
    }

    #[test]
    fn chains_stuck_at_different_values_give_infinite_rhat_and_say_why() {
        // `amp` (×1e20) never moves, each chain at its own start; `x` mixes
        let moving = |seed| ar1(seed, 400, 0.3, 0.0);
        let stuck = |v: f64| vec![v * 1e20; 400];
        let c = chain_set(&[(stuck(1.0), moving(1)), (stuck(1.5), moving(2))], 0);
        let d = c.diagnostics().unwrap();
        assert_eq!(d.rhat[0], f64::INFINITY);
        assert!(d.sd[0] > 0.0);
        assert!(d.rhat[1].is_finite());
        let w = d.warnings();
        let msg: Vec<String> = w.iter().map(|w| w.to_string()).collect();
        assert!(
            w.contains(&Warning::RHatNotFinite {
                param: "amp".into(),
                rhat: f64::INFINITY,
                none_accepted: true
            }),
            "{msg:?}"
        );
        let m = msg.iter().find(|m| m.contains("`amp`")).unwrap();
        assert!(
            m.contains("is ∞ (written as null in summary.json)")
                && m.contains("zero within-chain variance")
                && m.contains("proposal is too wide")
                && m.contains("proposal_scale"),
            "{m}"
        );
        assert!(
            !msg.iter().any(|m| m.contains("`x`") && m.contains("∞")),
            "{msg:?}"
        );
        // the same with accepted proposals: the other explanation
        let c = chain_set(&[(stuck(1.0), moving(3)), (stuck(2.0), moving(4))], 30);
        let m = c.diagnostics().unwrap().warnings()[0].to_string();
        assert!(m.contains("not in this parameter's direction"), "{m}");
        // every chain at the same value: sd = 0, the Stuck warning only
        let c = chain_set(&[(stuck(1.0), moving(5)), (stuck(1.0), moving(6))], 0);
        let w = c.diagnostics().unwrap().warnings();
        assert!(w.contains(&Warning::Stuck {
            param: "amp".into(),
            accepted: false
        }));
        // accepted proposals that did not move it: below the value's resolution
        let c = chain_set(&[(stuck(1.0), moving(7)), (stuck(1.0), moving(8))], 100);
        let m = c.diagnostics().unwrap().warnings()[0].to_string();
        assert!(
            m.starts_with("`amp` has the same value") && m.contains("resolution"),
            "{m}"
        );
        assert!(!w.iter().any(|w| matches!(w, Warning::RHatNotFinite { .. })));
    }

    #[test]
    fn bad_draws_are_errors() {
        let a = [1.0, 2.0, 3.0, 4.0, 5.0];
        assert!(ess(&[]).is_err());
        assert!(ess(&[&a[..3]]).is_err());
        assert!(ess(&[&a, &a[..4]]).is_err());
        assert!(split_rhat(&[&[1.0, f64::NAN, 2.0, 3.0]]).is_err());
    }
}
