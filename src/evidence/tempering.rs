//! Parallel tempering with thermodynamic integration (TI) and stepping-stone (SS) evidence.
//!
//! An evidence reference that needs no Gaussian assumption: it only samples the power posteriors
//! `p_β(θ) ∝ L(θ)^β π(θ)` on a ladder `0 = β_0 < β_1 < … < β_{N−1} = 1` and integrates along it.
//!
//! # Chain
//! * **Rung 0** (`β = 0`) is the normalised prior, sampled *exactly* by an independent draw every
//!   sweep (an independence sampler whose proposal is its target, so every draw is accepted).
//! * **Rungs `β > 0`** take one Gaussian random-walk step per sweep with covariance
//!   `s_i² Σ_i`, `Σ_i = (β_i C⁻¹ + (1 − β_i) P⁻¹)⁻¹`, where `C` is the caller's covariance (an
//!   in-model chain's or the inverse Fisher matrix; the posterior at β = 1) and `P` the diagonal
//!   of the prior variances (`w²/12` for a box of width `w`, `σ²` for a Gaussian). This is the
//!   covariance of the tempered posterior when both are Gaussian: it is `C` at β = 1 and the prior
//!   at β → 0, so hot rungs never propose steps wider than the prior allows. `s_i` starts at
//!   `2.38/√D` and is adapted during the burn-in toward
//!   [`target_acceptance`](TemperingOptions::target_acceptance) (Robbins–Monro on `ln s_i`,
//!   capped so that no coordinate's step exceeds its prior width). Proposals outside the prior are
//!   rejections; a non-finite `ln L` is a rejection and is counted.
//! * **Swaps**: after every sweep, deterministic even–odd swaps (Syed et al. 2019): even sweeps
//!   propose the pairs (0,1), (2,3), …, odd sweeps (1,2), (3,4), …, each accepted with
//!   `min{1, exp[(β_i − β_{i−1})(ln L_{i−1} − ln L_i)]}`.
//! * **Ladder**: the initial ladder is geometric from `β_1` to 1, with `β_1 = 1/sd_π(ln L)`
//!   (from 256 prior draws; capped at `1/(N−1)`), the largest step out of the prior whose
//!   importance weights `L^{β_1}` have a log-spread of about one. During the burn-in it is adapted
//!   to equalise the swap rates of all adjacent pairs (Vousden, Farr & Mandel 2016: every
//!   `adapt_interval` sweeps, `ln(T_{j+1} − T_j) += κ_k (A_j − A_{j+1})` in temperature
//!   `T = 1/β` counted from the cold end, `A_j` the window's swap rate of the pair (j, j+1),
//!   `κ_k = κ₀ t₀/(k + t₀)` decaying), and frozen afterwards: only post-burn-in sweeps, all on
//!   the final ladder, enter the estimators.
//!
//! Every rung owns its random stream ([`chain_rng`]`(seed, i + 1)`; the swaps use stream 0, the
//! pilot draws stream `N + 1`), so running the rungs on any number of threads gives the same
//! numbers.
//!
//! # Thermodynamic integration
//! `ln Z = ∫₀¹ E_β[ln L] dβ`. With `f(β) = E_β[ln L]` the integrand's derivative is known at every
//! rung without extra cost, `f′(β) = Var_β(ln L)`, so the ladder is integrated with the cubic
//! Hermite rule ("corrected trapezoid", exact for cubics):
//! ```text
//! ln Z_TI = Σ_i h_i [f_i + f_{i+1}]/2 + h_i²/12 [f′_i − f′_{i+1}],   h_i = β_{i+1} − β_i.
//! ```
//! The plain trapezoid is reported too ([`ThermodynamicEstimate::ln_z_trapezoid`]); on the
//! Gaussian curve `f = c − (D/2)/(β + a)` with ladder ratios 1.4–2.5 the Hermite rule's error
//! is 6–50 times smaller.
//!
//! **Discretisation error**: Richardson's estimate for a fourth-order rule,
//! `|I_H(ladder) − I_H(every other rung)|/15` (the coarse ladder keeps β = 0 and β = 1). On the
//! Gaussian curve above it is within a factor 1.5 of the true error and errs on the large
//! side (the unit tests check both on that closed-form curve); for ladders so coarse that the
//! rule is far from its asymptotic regime it overstates the error several-fold, which is the
//! safe direction.
//!
//! **Monte-Carlo error**: all rungs advance in lockstep, so the estimator is (to first order) the
//! mean of the per-sweep series `u_t = Σ_i w_i ℓ_i(t) + Σ_i c_i [(ℓ_i(t) − f_i)² − f′_i]` (`w` the
//! trapezoid weights, `c_i = (h_i² − h_{i−1}²)/12`). Its variance comes from batch means of
//! `u_t` with batches of `⌊√n⌋` sweeps (as in [`rjmcmc`](super::rjmcmc)). Because the series
//! sums the rungs *before* batching, the correlation between rungs that swaps induce is included;
//! no independence between rungs is assumed. The remaining approximation is the linearisation
//! (delta method) of the variance term.
//!
//! # Stepping stone (Xie et al. 2011)
//! `ln Z_SS = Σ_{i=0}^{N−2} ln (1/n) Σ_t exp[(β_{i+1} − β_i) ℓ_i(t)]` (log-sum-exp), each ratio
//! from the samples of the lower rung. Error: delta method `δ ln r_i = mean_t(e^{x_t − ln r_i} − 1)`
//! summed over rungs per sweep, then batch means as above. SS has no discretisation error, but
//! its ratios are biased low (Jensen) when a step's weights are dominated by a few samples; the
//! equalised swap rates keep adjacent rungs overlapping, which is the same condition.

use super::{EvidenceError, mvn::log_add_exp};
use crate::density::LogDensity;
use crate::linalg::{Spd, SpdOptions, symmetrised};
use crate::prior::PriorKind;
use crate::sampler::chain_rng;
use nalgebra::DMatrix;
use rand::RngExt;
use rand_distr::{Distribution, StandardNormal};
use rand_xoshiro::Xoshiro256PlusPlus;
use rayon::prelude::*;
use serde::Serialize;

/// Prior draws used to choose the initial `β_1`.
const N_PILOT: usize = 256;
/// Initial step size `κ₀` of the ladder adaptation (in `ln ΔT` per unit swap-rate difference).
const LADDER_KAPPA: f64 = 0.5;

/// States kept per rung in [`TemperingResult::rung_samples`].
pub const SNAPSHOTS: usize = 8;

/// Options of [`run_tempering`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TemperingOptions {
    /// Number of rungs including `β = 0` and `β = 1` (≥ 3: the discretisation error needs a
    /// coarser ladder to compare with).
    pub n_temps: usize,
    /// Sweeps in total, burn-in included. One sweep = one step on every rung + one swap round.
    pub n_iter: usize,
    /// Sweeps discarded; the ladder and proposal scales adapt during them.
    pub burn_in: usize,
    /// Seed of all random streams.
    pub seed: u64,
    /// Initial ladder (ascending, `0` first and `1` last, `n_temps` entries); `None`: geometric
    /// from the pilot `β_1` (see the module docs).
    pub betas: Option<Vec<f64>>,
    /// Equalise the swap rates during the burn-in (Vousden, Farr & Mandel 2016).
    pub adapt_ladder: bool,
    /// Sweeps per adaptation window (ladder and proposal scales).
    pub adapt_interval: usize,
    /// In-rung random-walk acceptance the proposal scales adapt toward.
    pub target_acceptance: f64,
    /// Batch size (sweeps) of the error estimates; `None`: `⌊√n⌋`, n = post-burn-in sweeps.
    pub batch_size: Option<usize>,
    /// Step the rungs in parallel (rayon). The numbers do not depend on it or on the thread
    /// count; turn it off when the likelihood is so cheap that the per-sweep fork–join costs
    /// more than it saves, or when an outer loop is already parallel.
    pub parallel: bool,
}

impl Default for TemperingOptions {
    /// 32 rungs, 40 000 sweeps of which 8 000 burn-in: 1.2·10⁶ likelihood calls (4 s at
    /// 3·10⁵ calls/s). On a D = 6 problem whose prior box is ~10³ posterior widths per
    /// parameter (ln Z ≈ −185) this gives TI and SS errors of about 0.09 nat; the Monte-Carlo
    /// part dominates and falls as 1/√n_iter.
    fn default() -> Self {
        Self {
            n_temps: 32,
            n_iter: 40_000,
            burn_in: 8_000,
            seed: 1,
            betas: None,
            adapt_ladder: true,
            adapt_interval: 100,
            target_acceptance: 0.25,
            batch_size: None,
            parallel: true,
        }
    }
}

/// Thermodynamic-integration estimate of `ln Z`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ThermodynamicEstimate {
    /// `ln Z` by the cubic Hermite rule (trapezoid plus the `f′ = Var_β ln L` end corrections).
    pub ln_z: f64,
    /// One-sigma Monte-Carlo error of `ln_z` (batch means over sweeps, all rungs together).
    pub std_err: f64,
    /// Estimated quadrature error of `ln_z`: `|I_H − I_H(every other rung)|/15`. Not a
    /// random error; add it to `std_err` (in quadrature or linearly) for a total.
    pub discretisation_err: f64,
    /// `ln Z` by the plain trapezoid on the same ladder, for comparison.
    pub ln_z_trapezoid: f64,
}

impl ThermodynamicEstimate {
    /// `√(std_err² + discretisation_err²)`.
    pub fn total_err(&self) -> f64 {
        self.std_err.hypot(self.discretisation_err)
    }
}

/// Stepping-stone estimate of `ln Z`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SteppingStoneEstimate {
    /// `ln Z`.
    pub ln_z: f64,
    /// One-sigma Monte-Carlo error (delta method and batch means over sweeps).
    pub std_err: f64,
}

/// Output of [`run_tempering`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TemperingResult {
    /// The final (frozen) ladder, ascending: `β_0 = 0` (prior) … `β_{N−1} = 1` (posterior).
    pub betas: Vec<f64>,
    /// Post-burn-in swap acceptance of each adjacent pair `(i, i+1)`.
    pub swap_acceptance: Vec<f64>,
    /// Post-burn-in random-walk acceptance per rung (rung 0 draws the prior exactly: 1).
    pub in_rung_acceptance: Vec<f64>,
    /// Final random-walk scale `s_i` per rung (0 for rung 0).
    pub proposal_scale: Vec<f64>,
    /// `E_β[ln L]` per rung (post-burn-in mean).
    pub mean_ln_l: Vec<f64>,
    /// Batch-means standard error of each `mean_ln_l`.
    pub mean_ln_l_std_err: Vec<f64>,
    /// `Var_β(ln L)` per rung, the slope `d E_β[ln L]/dβ`.
    pub var_ln_l: Vec<f64>,
    /// Thermodynamic integration, or why it does not apply.
    pub thermodynamic: Result<ThermodynamicEstimate, String>,
    /// Stepping stone, or why it does not apply.
    pub stepping_stone: Result<SteppingStoneEstimate, String>,
    /// Sweeps run.
    pub n_iter: usize,
    /// Burn-in sweeps.
    pub burn_in: usize,
    /// Batch size (sweeps) of the errors.
    pub batch_size: usize,
    /// `[rung][k]`: every rung's state at [`SNAPSHOTS`] evenly spaced post-burn-in sweeps, for
    /// checking an approximate likelihood where each rung goes (the hot rungs roam the whole
    /// prior, far beyond where an approximation was validated for the posterior).
    pub rung_samples: Vec<Vec<Vec<f64>>>,
    /// Likelihood evaluations, pilot included.
    pub ln_l_evals: u64,
    /// Proposals and prior draws whose `ln L` was NaN or `+∞` (rejected; at β = 0 the draw
    /// counts as `L = 0`).
    pub non_finite: u64,
}

/// One rung's chain.
struct Rung {
    beta: f64,
    theta: Vec<f64>,
    ln_l: f64,
    ln_prior: f64,
    rng: Xoshiro256PlusPlus,
    /// Row-major lower Cholesky factor of `Σ_i`.
    chol: Vec<f64>,
    /// `ln s_i`.
    ln_scale: f64,
    /// Largest allowed `ln s_i`.
    ln_scale_max: f64,
    prop: Vec<f64>,
    z: Vec<f64>,
    tried: u64,
    accepted: u64,
    non_finite: u64,
    evals: u64,
}

impl Rung {
    fn step(&mut self, target: &dyn LogDensity) {
        let prior = target.prior();
        if self.beta == 0.0 {
            self.theta = prior.sample(&mut self.rng);
            self.ln_prior = prior.ln_pdf(&self.theta);
            let l = target.ln_likelihood(&self.theta);
            self.evals += 1;
            self.ln_l = if l.is_nan() || l == f64::INFINITY {
                self.non_finite += 1;
                f64::NEG_INFINITY
            } else {
                l
            };
            self.tried += 1;
            self.accepted += 1;
            return;
        }
        let d = self.theta.len();
        let s = self.ln_scale.exp();
        for zi in self.z.iter_mut() {
            *zi = StandardNormal.sample(&mut self.rng);
        }
        for i in 0..d {
            let row = &self.chol[i * d..i * d + i + 1];
            self.prop[i] = self.theta[i]
                + s * row
                    .iter()
                    .zip(&self.z[..=i])
                    .map(|(a, b)| a * b)
                    .sum::<f64>();
        }
        let u: f64 = self.rng.random();
        self.tried += 1;
        let lp = prior.ln_pdf(&self.prop);
        if lp == f64::NEG_INFINITY {
            return;
        }
        let l = target.ln_likelihood(&self.prop);
        self.evals += 1;
        if l.is_nan() || l == f64::INFINITY {
            self.non_finite += 1;
            return;
        }
        let ln_a = self.beta * (l - self.ln_l) + (lp - self.ln_prior);
        if u.ln() < ln_a {
            std::mem::swap(&mut self.theta, &mut self.prop);
            self.ln_l = l;
            self.ln_prior = lp;
            self.accepted += 1;
        }
    }
}

/// Per-rung proposal geometry: `C⁻¹`, the prior precisions and widths.
struct Geometry {
    dim: usize,
    cov_inv: DMatrix<f64>,
    prior_prec: Vec<f64>,
    /// Per-coordinate prior width (∞ for a Gaussian prior): the cap on a step.
    width: Vec<f64>,
}

impl Geometry {
    /// Row-major Cholesky factor of `Σ_β = (β C⁻¹ + (1 − β) P⁻¹)⁻¹` and the largest `ln s`.
    fn rung(&self, beta: f64) -> Result<(Vec<f64>, f64), EvidenceError> {
        let d = self.dim;
        let mut m = &self.cov_inv * beta;
        for i in 0..d {
            m[(i, i)] += (1.0 - beta) * self.prior_prec[i];
        }
        let fix = "pass a symmetric positive definite covariance of sensible scale";
        let prec = Spd::new(&m).map_err(EvidenceError::matrix(
            "tempered precision β C⁻¹ + (1 − β) P⁻¹",
            fix,
        ))?;
        let sigma = symmetrised(&prec.inverse());
        let chol = Spd::new(&sigma)
            .map_err(EvidenceError::matrix("tempered covariance", fix))?
            .l_row_major();
        let mut cap = f64::INFINITY;
        for i in 0..d {
            cap = cap.min(self.width[i] / sigma[(i, i)].sqrt());
        }
        Ok((chol, cap.ln()))
    }
}

/// Runs parallel tempering on `target` and returns the TI and SS evidence estimates.
///
/// `start` (inside the prior, finite `ln L`) is where every rung with `β > 0` starts; `cov` is a
/// posterior covariance estimate at β = 1 (inverse Fisher matrix or an in-model chain's sample
/// covariance) that shapes the random walks.
///
/// ```
/// use nalgebra::DMatrix;
/// use occam::evidence::linear_gaussian::LinearGaussian;
/// use occam::evidence::mvn::MvnOptions;
/// use occam::evidence::tempering::{TemperingOptions, run_tempering};
/// use occam::prior::{Prior, PriorKind};
/// let x = DMatrix::from_row_slice(4, 1, &[1.0, 2.0, 3.0, 4.0]);
/// let prior = Prior::new(vec!["a".into()], vec![PriorKind::Uniform { lo: -5.0, hi: 5.0 }]).unwrap();
/// let lg = LinearGaussian::new(x, vec![1.1, 1.9, 3.2, 3.9], 0.5, prior).unwrap();
/// let post = lg.gaussian_posterior(&[0]).unwrap();
/// let opts = TemperingOptions { n_temps: 10, n_iter: 6_000, burn_in: 1_000, parallel: false,
///     ..TemperingOptions::default() };
/// let res = run_tempering(&lg, post.mean.as_slice(), &post.cov, &opts).unwrap();
/// let exact = lg.exact_ln_evidence(&[0], &MvnOptions::default()).unwrap().ln_z;
/// let ss = res.stepping_stone.unwrap();
/// assert!((ss.ln_z - exact).abs() < 5.0 * ss.std_err);
/// ```
pub fn run_tempering(
    target: &dyn LogDensity,
    start: &[f64],
    cov: &DMatrix<f64>,
    opts: &TemperingOptions,
) -> Result<TemperingResult, EvidenceError> {
    run_tempering_observed(target, start, cov, opts, &|| {})
}

/// [`run_tempering`], calling `on_sweep` after every sweep of the ladder (a progress bar's
/// hook; it cannot change the numbers).
pub fn run_tempering_observed(
    target: &dyn LogDensity,
    start: &[f64],
    cov: &DMatrix<f64>,
    opts: &TemperingOptions,
    on_sweep: &(dyn Fn() + Sync),
) -> Result<TemperingResult, EvidenceError> {
    validate(opts)?;
    let (ln_prior0, ln_l0) = check_start(target, start, cov)?;
    let geom = Geometry::new(target, cov)?;
    let n_t = opts.n_temps;
    let pilot = match &opts.betas {
        Some(b) => Pilot {
            betas: b.clone(),
            evals: 0,
            non_finite: 0,
        },
        None => pilot_ladder(target, opts),
    };
    let mut betas = pilot.betas;
    let mut rungs = start_rungs(&betas, &geom, start, (ln_l0, ln_prior0), opts)?;
    // Rung 0 starts from a prior draw.
    rungs[0].step(target);
    let sweeps = sweep(&mut rungs, &mut betas, &geom, target, opts, on_sweep)?;

    let n_post = opts.n_iter - opts.burn_in;
    let series = &sweeps.series;
    let batch = opts
        .batch_size
        .unwrap_or((n_post as f64).sqrt() as usize)
        .max(1);
    let (mean, var, mean_se) = rung_moments(series, n_t, n_post, batch);
    let thermodynamic = thermodynamic(&betas, &mean, &var, series, batch);
    let stepping_stone = stepping_stone(&betas, series, batch);
    let evals = pilot.evals + rungs.iter().map(|r| r.evals).sum::<u64>();
    Ok(TemperingResult {
        swap_acceptance: sweeps
            .swaps_acc
            .iter()
            .zip(&sweeps.swaps_tried)
            .map(|(&a, &n)| a as f64 / n.max(1) as f64)
            .collect(),
        in_rung_acceptance: rungs
            .iter()
            .map(|r| r.accepted as f64 / r.tried.max(1) as f64)
            .collect(),
        proposal_scale: rungs
            .iter()
            .map(|r| if r.beta == 0.0 { 0.0 } else { r.ln_scale.exp() })
            .collect(),
        betas,
        mean_ln_l: mean,
        mean_ln_l_std_err: mean_se,
        var_ln_l: var,
        thermodynamic,
        stepping_stone,
        n_iter: opts.n_iter,
        burn_in: opts.burn_in,
        batch_size: batch,
        rung_samples: sweeps.rung_samples,
        ln_l_evals: evals,
        non_finite: pilot.non_finite + rungs.iter().map(|r| r.non_finite).sum::<u64>(),
    })
}

/// `(ln π(start), ln L(start))`, checking the target has parameters, `start` and `cov` its
/// dimension, and `start` lies inside the prior where the likelihood is finite.
fn check_start(
    target: &dyn LogDensity,
    start: &[f64],
    cov: &DMatrix<f64>,
) -> Result<(f64, f64), EvidenceError> {
    let d = target.dim();
    if d == 0 {
        return Err(EvidenceError::option(
            "tempering target dimension",
            0,
            "the target has no parameters: its evidence is its likelihood, nothing to integrate",
        ));
    }
    if start.len() != d {
        return Err(EvidenceError::dimension("tempering start", d, start.len()));
    }
    if cov.nrows() != d || cov.ncols() != d {
        return Err(EvidenceError::dimension(
            "tempering covariance rows and columns",
            d * d,
            cov.nrows() * cov.ncols(),
        ));
    }
    let ln_prior0 = target.prior().ln_pdf(start);
    if ln_prior0 == f64::NEG_INFINITY {
        return Err(EvidenceError::non_finite(
            "ln π(start)",
            ln_prior0,
            "start inside the prior support",
        ));
    }
    let ln_l0 = target.ln_likelihood(start);
    if !ln_l0.is_finite() {
        return Err(EvidenceError::non_finite(
            "ln L(start)",
            ln_l0,
            "start where the likelihood is positive and finite (e.g. at the MAP)",
        ));
    }
    Ok((ln_prior0, ln_l0))
}

impl Geometry {
    /// `C⁻¹` from the posterior covariance `cov`, and the prior's precisions and widths.
    fn new(target: &dyn LogDensity, cov: &DMatrix<f64>) -> Result<Geometry, EvidenceError> {
        let cov_chol = SpdOptions::default()
            .names(target.prior().names())
            .factor(cov)
            .map_err(EvidenceError::matrix(
                "tempering proposal covariance",
                "pass the inverse Fisher matrix or an in-model chain's sample covariance",
            ))?;
        let cov_inv = symmetrised(&cov_chol.inverse());
        let (prior_prec, width): (Vec<f64>, Vec<f64>) = target
            .prior()
            .kinds()
            .iter()
            .map(|k| match *k {
                PriorKind::Uniform { lo, hi } | PriorKind::LogUniform { lo, hi } => {
                    (12.0 / (hi - lo).powi(2), hi - lo)
                }
                PriorKind::Gaussian { sigma, .. } => (1.0 / (sigma * sigma), f64::INFINITY),
            })
            .unzip();
        Ok(Geometry {
            dim: target.dim(),
            cov_inv,
            prior_prec,
            width,
        })
    }
}

/// The initial ladder and what choosing it cost.
struct Pilot {
    betas: Vec<f64>,
    /// Likelihood evaluations of the pilot draws.
    evals: u64,
    /// Pilot draws whose `ln L` was NaN or `+∞`.
    non_finite: u64,
}

/// The geometric ladder from the pilot `β_1 = 1/sd_π(ln L)` (from [`N_PILOT`] prior draws on
/// stream `N + 1`; capped at `1/(N−1)`) to 1.
fn pilot_ladder(target: &dyn LogDensity, opts: &TemperingOptions) -> Pilot {
    let prior = target.prior();
    let n_t = opts.n_temps;
    let mut evals = 0u64;
    let mut pilot_non_finite = 0u64;
    let mut rng = chain_rng(opts.seed, n_t + 1);
    let mut ls = Vec::with_capacity(N_PILOT);
    for _ in 0..N_PILOT {
        let l = target.ln_likelihood(&prior.sample(&mut rng));
        evals += 1;
        if l.is_finite() {
            ls.push(l);
        } else if !(l == f64::NEG_INFINITY) {
            pilot_non_finite += 1;
        }
    }
    let cap = 1.0 / (n_t - 1) as f64;
    let beta1 = if ls.len() >= 2 {
        let m = ls.iter().sum::<f64>() / ls.len() as f64;
        let sd = (ls.iter().map(|l| (l - m).powi(2)).sum::<f64>() / (ls.len() - 1) as f64).sqrt();
        if sd > 0.0 { (1.0 / sd).min(cap) } else { cap }
    } else {
        cap
    };
    let beta1 = beta1.max(1e-300);
    let mut b = vec![0.0];
    for i in 0..n_t - 1 {
        let f = i as f64 / (n_t - 2) as f64;
        b.push((beta1.ln() * (1.0 - f)).exp());
    }
    b[n_t - 1] = 1.0;
    Pilot {
        betas: b,
        evals,
        non_finite: pilot_non_finite,
    }
}

/// One rung per β, all at `start` (`(ln L, ln π)` there), rung `i` on stream `i + 1`.
fn start_rungs(
    betas: &[f64],
    geom: &Geometry,
    start: &[f64],
    (ln_l0, ln_prior0): (f64, f64),
    opts: &TemperingOptions,
) -> Result<Vec<Rung>, EvidenceError> {
    let d = start.len();
    let init_ln_scale = (2.38 / (d as f64).sqrt()).ln();
    let mut rungs = Vec::with_capacity(betas.len());
    for (i, &beta) in betas.iter().enumerate() {
        let (chol, cap) = geom.rung(beta)?;
        rungs.push(Rung {
            beta,
            theta: start.to_vec(),
            ln_l: ln_l0,
            ln_prior: ln_prior0,
            rng: chain_rng(opts.seed, i + 1),
            chol,
            ln_scale: init_ln_scale.min(cap),
            ln_scale_max: cap,
            prop: vec![0.0; d],
            z: vec![0.0; d],
            tried: 0,
            accepted: 0,
            non_finite: 0,
            evals: 0,
        });
    }
    Ok(rungs)
}

/// What the sweeps after the burn-in leave.
struct Sweeps {
    /// `ln L` of every rung, sweep-major (`[t * n_t + i]`).
    series: Vec<f64>,
    swaps_tried: Vec<u64>,
    swaps_acc: Vec<u64>,
    rung_samples: Vec<Vec<Vec<f64>>>,
}

/// Runs the `opts.n_iter` sweeps: every rung steps, then one even–odd swap round; the burn-in
/// adapts scales and ladder every `adapt_interval` sweeps; the post-burn-in sweeps are recorded.
fn sweep(
    rungs: &mut [Rung],
    betas: &mut [f64],
    geom: &Geometry,
    target: &dyn LogDensity,
    opts: &TemperingOptions,
    on_sweep: &(dyn Fn() + Sync),
) -> Result<Sweeps, EvidenceError> {
    let n_t = opts.n_temps;
    let mut swap_rng = chain_rng(opts.seed, 0);
    let n_post = opts.n_iter - opts.burn_in;
    let mut series: Vec<f64> = Vec::with_capacity(n_post * n_t);
    let mut swaps_tried = vec![0u64; n_t - 1];
    let mut swaps_acc = vec![0u64; n_t - 1];
    let mut win_tried = vec![0u64; n_t - 1];
    let mut win_acc = vec![0u64; n_t - 1];
    let mut win_rung: Vec<(u64, u64)> = vec![(0, 0); n_t];
    let mut rung_samples: Vec<Vec<Vec<f64>>> = vec![Vec::with_capacity(SNAPSHOTS); n_t];
    let n_updates = opts.burn_in / opts.adapt_interval;
    let t0 = (n_updates as f64 / 4.0).max(1.0);
    let mut update = 0usize;

    for t in 0..opts.n_iter {
        if opts.parallel {
            rungs.par_iter_mut().for_each(|r| r.step(target));
        } else {
            rungs.iter_mut().for_each(|r| r.step(target));
        }
        let (tried, acc) = if t >= opts.burn_in {
            (&mut swaps_tried, &mut swaps_acc)
        } else {
            (&mut win_tried, &mut win_acc)
        };
        swap_round(rungs, t, &mut swap_rng, tried, acc);
        if t < opts.burn_in {
            if (t + 1) % opts.adapt_interval == 0 {
                adapt(
                    rungs,
                    betas,
                    geom,
                    opts,
                    update,
                    t0,
                    (&mut win_tried, &mut win_acc, &mut win_rung),
                )?;
                update += 1;
            }
            if t + 1 == opts.burn_in {
                for r in rungs.iter_mut() {
                    r.tried = 0;
                    r.accepted = 0;
                }
            }
        } else {
            series.extend(rungs.iter().map(|r| r.ln_l));
            if (t - opts.burn_in + 1).is_multiple_of((n_post / SNAPSHOTS).max(1)) {
                for (keep, r) in rung_samples.iter_mut().zip(rungs.iter()) {
                    if keep.len() < SNAPSHOTS {
                        keep.push(r.theta.clone());
                    }
                }
            }
        }
        on_sweep();
    }
    Ok(Sweeps {
        series,
        swaps_tried,
        swaps_acc,
        rung_samples,
    })
}

/// The deterministic even–odd swap round of sweep `t`, counting each pair's proposals and
/// acceptances into `tried` and `acc`.
fn swap_round(
    rungs: &mut [Rung],
    t: usize,
    swap_rng: &mut Xoshiro256PlusPlus,
    tried: &mut [u64],
    acc: &mut [u64],
) {
    let n_t = rungs.len();
    let mut i = 1 + t % 2;
    while i < n_t {
        let (lo, hi) = rungs.split_at_mut(i);
        let (a, b) = (&mut lo[i - 1], &mut hi[0]);
        let ln_a = (b.beta - a.beta) * (a.ln_l - b.ln_l);
        let u: f64 = swap_rng.random();
        let ok = u.ln() < ln_a;
        if ok {
            std::mem::swap(&mut a.theta, &mut b.theta);
            std::mem::swap(&mut a.ln_l, &mut b.ln_l);
            std::mem::swap(&mut a.ln_prior, &mut b.ln_prior);
        }
        tried[i - 1] += 1;
        acc[i - 1] += ok as u64;
        i += 2;
    }
}

/// Per rung: the post-burn-in mean and variance of `ln L` and the mean's batch-means error
/// (NaN where the mean is not finite).
fn rung_moments(
    series: &[f64],
    n_t: usize,
    n_post: usize,
    batch: usize,
) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let col = |i: usize| (0..n_post).map(move |t| series[t * n_t + i]);
    let mut mean = Vec::with_capacity(n_t);
    let mut var = Vec::with_capacity(n_t);
    let mut mean_se = Vec::with_capacity(n_t);
    for i in 0..n_t {
        let m = col(i).sum::<f64>() / n_post as f64;
        let v = if m.is_finite() {
            col(i).map(|l| (l - m).powi(2)).sum::<f64>() / n_post as f64
        } else {
            f64::NAN
        };
        let se = if m.is_finite() {
            batch_means_var(|t| series[t * n_t + i], n_post, batch).sqrt()
        } else {
            f64::NAN
        };
        mean.push(m);
        var.push(v);
        mean_se.push(se);
    }
    (mean, var, mean_se)
}

type Windows<'a> = (&'a mut [u64], &'a mut [u64], &'a mut [(u64, u64)]);

/// One adaptation step at the end of a burn-in window: proposal scales toward the target
/// acceptance, then the ladder toward equal swap rates.
fn adapt(
    rungs: &mut [Rung],
    betas: &mut [f64],
    geom: &Geometry,
    opts: &TemperingOptions,
    k: usize,
    t0: f64,
    (win_tried, win_acc, win_rung): Windows<'_>,
) -> Result<(), EvidenceError> {
    let n_t = rungs.len();
    let gamma = 1.0 / ((k + 1) as f64).sqrt();
    for (r, w) in rungs.iter_mut().zip(win_rung.iter_mut()) {
        let (tried, acc) = (r.tried - w.0, r.accepted - w.1);
        *w = (r.tried, r.accepted);
        if r.beta > 0.0 && tried > 0 {
            let a = acc as f64 / tried as f64;
            r.ln_scale = (r.ln_scale + gamma * (a - opts.target_acceptance)).min(r.ln_scale_max);
        }
    }
    if opts.adapt_ladder && n_t > 2 {
        // Cold-first temperatures T_0 = 1 < … < T_{N−2}; T_{N−1} = ∞ is the prior.
        let rate = |j: usize| {
            // pair between cold j and j + 1 = ascending pair (N−2−j, N−1−j)
            let p = n_t - 2 - j;
            if win_tried[p] > 0 {
                win_acc[p] as f64 / win_tried[p] as f64
            } else {
                0.0
            }
        };
        let kappa = LADDER_KAPPA * t0 / (k as f64 + t0);
        let temps: Vec<f64> = (0..n_t - 1).map(|j| 1.0 / betas[n_t - 1 - j]).collect();
        let mut new_t = vec![1.0; n_t - 1];
        for j in 0..n_t - 2 {
            let dt = (temps[j + 1] - temps[j]) * (kappa * (rate(j) - rate(j + 1))).exp();
            new_t[j + 1] = new_t[j] + dt;
        }
        let mut changed = false;
        for j in 1..n_t - 1 {
            let b = 1.0 / new_t[j];
            let i = n_t - 1 - j;
            if b.is_finite() && b > 0.0 && b != betas[i] {
                betas[i] = b;
                changed = true;
            }
        }
        if changed {
            for (i, r) in rungs.iter_mut().enumerate() {
                if r.beta != betas[i] {
                    r.beta = betas[i];
                    let (chol, cap) = geom.rung(r.beta)?;
                    r.chol = chol;
                    r.ln_scale_max = cap;
                    r.ln_scale = r.ln_scale.min(cap);
                }
            }
        }
    }
    win_tried.fill(0);
    win_acc.fill(0);
    Ok(())
}

fn validate(opts: &TemperingOptions) -> Result<(), EvidenceError> {
    if opts.n_temps < 3 {
        return Err(EvidenceError::option(
            "tempering n_temps",
            opts.n_temps,
            "need at least 3 rungs (β = 0, one intermediate, β = 1) so the discretisation error can be estimated",
        ));
    }
    if opts.n_iter <= opts.burn_in || opts.n_iter - opts.burn_in < 100 {
        return Err(EvidenceError::option(
            "tempering n_iter",
            opts.n_iter,
            "need at least 100 sweeps after burn_in",
        ));
    }
    let n_post = opts.n_iter - opts.burn_in;
    if let Some(b) = opts.batch_size
        && (b == 0 || b > n_post / 2)
    {
        return Err(EvidenceError::option(
            "tempering batch_size",
            b,
            "need 1 ≤ batch_size ≤ (n_iter − burn_in)/2 so there are at least 2 batches",
        ));
    }
    if opts.adapt_interval == 0 {
        return Err(EvidenceError::option(
            "tempering adapt_interval",
            0,
            "need at least 1 sweep per adaptation window (100 is typical)",
        ));
    }
    if !(opts.target_acceptance > 0.0 && opts.target_acceptance < 1.0) {
        return Err(EvidenceError::option(
            "tempering target_acceptance",
            opts.target_acceptance,
            "must lie strictly between 0 and 1 (0.25 is typical)",
        ));
    }
    if let Some(b) = &opts.betas {
        let ok = b.len() == opts.n_temps
            && b[0] == 0.0
            && b[b.len() - 1] == 1.0
            && b.windows(2).all(|w| w[0] < w[1]);
        if !ok {
            return Err(EvidenceError::option(
                "tempering betas",
                format!("{b:?}"),
                "the ladder needs n_temps strictly increasing entries from 0 to 1 inclusive",
            ));
        }
    }
    Ok(())
}

/// `Var(ū)` of the mean of `u(0..n)` by batch means with batch size `b` (the first `n mod b`
/// values are dropped).
fn batch_means_var(u: impl Fn(usize) -> f64, n: usize, b: usize) -> f64 {
    let a = n / b;
    let start = n - a * b;
    let means: Vec<f64> = (0..a)
        .map(|j| (0..b).map(|i| u(start + j * b + i)).sum::<f64>() / b as f64)
        .collect();
    let grand = means.iter().sum::<f64>() / a as f64;
    let s2 = b as f64 * means.iter().map(|m| (m - grand).powi(2)).sum::<f64>() / (a - 1) as f64;
    s2 / n as f64
}

/// Trapezoid and cubic-Hermite integrals of `f` (values `f`, slopes `fp`) over the ladder.
pub(crate) fn hermite_integral(betas: &[f64], f: &[f64], fp: &[f64]) -> (f64, f64) {
    let mut trap = 0.0;
    let mut corr = 0.0;
    for i in 0..betas.len() - 1 {
        let h = betas[i + 1] - betas[i];
        trap += h * (f[i] + f[i + 1]) / 2.0;
        corr += h * h / 12.0 * (fp[i] - fp[i + 1]);
    }
    (trap, trap + corr)
}

/// The Hermite integral and its discretisation-error estimate `|I_H − I_H(coarse)|/15`, the
/// coarse ladder being every other rung counted from β = 1, with β = 0 always kept.
pub(crate) fn hermite_with_error(betas: &[f64], f: &[f64], fp: &[f64]) -> (f64, f64, f64) {
    let (trap, fine) = hermite_integral(betas, f, fp);
    let n = betas.len();
    let mut idx: Vec<usize> = (0..n).rev().step_by(2).collect();
    if *idx.last().unwrap() != 0 {
        idx.push(0);
    }
    idx.reverse();
    let pick = |v: &[f64]| idx.iter().map(|&i| v[i]).collect::<Vec<f64>>();
    let (_, coarse) = hermite_integral(&pick(betas), &pick(f), &pick(fp));
    (fine, (fine - coarse).abs() / 15.0, trap)
}

fn thermodynamic(
    betas: &[f64],
    mean: &[f64],
    var: &[f64],
    series: &[f64],
    batch: usize,
) -> Result<ThermodynamicEstimate, String> {
    if let Some(i) = mean.iter().position(|m| !m.is_finite()) {
        return Err(format!(
            "E[ln L] at β = {} is not finite: the rung drew points where L = 0 (or ln L is not a number), so ∫ E_β[ln L] dβ diverges at that rung; use the stepping-stone estimate, or restrict the prior to where the likelihood is positive",
            betas[i]
        ));
    }
    let n_t = betas.len();
    let n = series.len() / n_t;
    let (ln_z, disc, trap) = hermite_with_error(betas, mean, var);
    let h = |i: usize| {
        if i + 1 < n_t {
            betas[i + 1] - betas[i]
        } else {
            0.0
        }
    };
    let w: Vec<f64> = (0..n_t)
        .map(|i| (h(i) + if i > 0 { h(i - 1) } else { 0.0 }) / 2.0)
        .collect();
    let c: Vec<f64> = (0..n_t)
        .map(|i| (h(i).powi(2) - if i > 0 { h(i - 1).powi(2) } else { 0.0 }) / 12.0)
        .collect();
    let v = batch_means_var(
        |t| {
            let row = &series[t * n_t..(t + 1) * n_t];
            (0..n_t)
                .map(|i| w[i] * (row[i] - mean[i]) + c[i] * ((row[i] - mean[i]).powi(2) - var[i]))
                .sum()
        },
        n,
        batch,
    );
    Ok(ThermodynamicEstimate {
        ln_z,
        std_err: v.sqrt(),
        discretisation_err: disc,
        ln_z_trapezoid: trap,
    })
}

fn stepping_stone(
    betas: &[f64],
    series: &[f64],
    batch: usize,
) -> Result<SteppingStoneEstimate, String> {
    let n_t = betas.len();
    let n = series.len() / n_t;
    let mut ln_r = Vec::with_capacity(n_t - 1);
    for i in 0..n_t - 1 {
        let dbeta = betas[i + 1] - betas[i];
        let lse = (0..n)
            .map(|t| dbeta * series[t * n_t + i])
            .fold(f64::NEG_INFINITY, log_add_exp);
        let r = lse - (n as f64).ln();
        if !r.is_finite() {
            return Err(format!(
                "every sample of the rung at β = {} has L = 0 (or ln L is not finite), so the stepping-stone ratio to β = {} is undefined; start the chain in the likelihood's support",
                betas[i],
                betas[i + 1]
            ));
        }
        ln_r.push(r);
    }
    let v = batch_means_var(
        |t| {
            (0..n_t - 1)
                .map(|i| {
                    let x = (betas[i + 1] - betas[i]) * series[t * n_t + i];
                    (x - ln_r[i]).exp() - 1.0
                })
                .sum()
        },
        n,
        batch,
    );
    Ok(SteppingStoneEstimate {
        ln_z: ln_r.iter().sum(),
        std_err: v.sqrt(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::evidence::linear_gaussian::{LinearGaussian, RandomPrior, RandomSpec};
    use crate::evidence::mvn::MvnOptions;
    use crate::prior::Prior;
    use nalgebra::DVector;
    use rand::SeedableRng;

    fn quick(seed: u64) -> TemperingOptions {
        TemperingOptions {
            seed,
            parallel: false,
            ..TemperingOptions::default()
        }
    }

    fn run_lg(lg: &LinearGaussian, opts: &TemperingOptions) -> (TemperingResult, f64, f64) {
        let d = lg.design().ncols();
        let cols: Vec<usize> = (0..d).collect();
        let post = lg.gaussian_posterior(&cols).unwrap();
        // start at the posterior mean clamped into the prior box
        let start: Vec<f64> = post
            .mean
            .iter()
            .zip(lg.prior().bounds())
            .map(|(&m, (lo, hi))| m.clamp(lo, hi))
            .collect();
        let res = run_tempering(lg, &start, &post.cov, opts).unwrap();
        let ex = lg.exact_ln_evidence(&cols, &MvnOptions::default()).unwrap();
        (res, ex.ln_z, ex.std_err)
    }

    /// Asserts TI and SS agree with the exact ln Z within `k` of their stated (total) errors.
    fn check(res: &TemperingResult, exact: f64, exact_se: f64, k: f64) {
        let ti = res.thermodynamic.clone().unwrap();
        let ss = res.stepping_stone.clone().unwrap();
        eprintln!(
            "exact {exact:.4} | TI {:.4} ± {:.4} (disc {:.4}, trapezoid {:.4}) | SS {:.4} ± {:.4} | betas {:?} | swaps {:?} | acc {:?}",
            ti.ln_z,
            ti.std_err,
            ti.discretisation_err,
            ti.ln_z_trapezoid,
            ss.ln_z,
            ss.std_err,
            res.betas,
            res.swap_acceptance,
            res.in_rung_acceptance
        );
        let ti_err = ti.total_err().hypot(exact_se);
        assert!(
            (ti.ln_z - exact).abs() < k * ti_err,
            "TI {} vs exact {exact}: {}σ",
            ti.ln_z,
            (ti.ln_z - exact) / ti_err
        );
        let ss_err = ss.std_err.hypot(exact_se);
        assert!(
            (ss.ln_z - exact).abs() < k * ss_err,
            "SS {} vs exact {exact}: {}σ",
            ss.ln_z,
            (ss.ln_z - exact) / ss_err
        );
        assert!(ti.std_err > 0.0 && ss.std_err > 0.0);
    }

    /// The quadrature on the closed-form Gaussian curve `f = c − (D/2)/(β + a)` (isotropic
    /// Gaussian likelihood, Gaussian prior of relative precision a): the Hermite rule beats the
    /// trapezoid, and the Richardson estimate is within [1, 1.5] times its true error.
    #[test]
    fn hermite_rule_and_its_error_estimate_on_the_gaussian_curve() {
        for (dim, a, n) in [
            (8.0, 1e-6, 20),
            (8.0, 1e-6, 30),
            (8.0, 1e-3, 20),
            (8.0, 1e-3, 30),
            (1.0, 1e-3, 20),
        ] {
            let f = |b: f64| 2.0 - dim / 2.0 / (b + a);
            let fp = |b: f64| dim / 2.0 / (b + a).powi(2);
            let b1: f64 = a / 10.0;
            let mut betas = vec![0.0];
            for i in 0..n - 1 {
                betas.push((b1.ln() * (1.0 - i as f64 / (n - 2) as f64)).exp());
            }
            let fv: Vec<f64> = betas.iter().map(|&b| f(b)).collect();
            let fpv: Vec<f64> = betas.iter().map(|&b| fp(b)).collect();
            let exact = 2.0 - dim / 2.0 * ((1.0 + a).ln() - a.ln());
            let (h, est, trap) = hermite_with_error(&betas, &fv, &fpv);
            let (eh, et) = ((h - exact).abs(), (trap - exact).abs());
            assert!(eh < et / 5.0, "D={dim} a={a} n={n}: {eh} vs {et}");
            assert!(
                est >= eh && est <= 1.5 * eh,
                "D={dim} a={a} n={n}: estimate {est}, true {eh}"
            );
        }
        // Exact for a cubic, and the estimate is then 0 too.
        let betas = [0.0, 0.1, 0.3, 0.7, 1.0];
        let f: Vec<f64> = betas.iter().map(|b| b * b * b - 2.0 * b).collect();
        let fp: Vec<f64> = betas.iter().map(|b| 3.0 * b * b - 2.0).collect();
        let (h, est, _) = hermite_with_error(&betas, &f, &fp);
        assert!((h - (0.25 - 1.0)).abs() < 1e-14 && est < 1e-14);
    }

    struct Flat {
        prior: Prior,
        ln_l: f64,
    }
    impl LogDensity for Flat {
        fn ln_likelihood(&self, _: &[f64]) -> f64 {
            self.ln_l
        }
        fn prior(&self) -> &Prior {
            &self.prior
        }
    }

    /// A flat likelihood: Z = L exactly, every swap is accepted, no error.
    #[test]
    fn flat_likelihood_gives_ln_l_exactly() {
        let t = Flat {
            prior: Prior::new(
                vec!["x".into()],
                vec![PriorKind::Uniform { lo: 0.0, hi: 2.0 }],
            )
            .unwrap(),
            ln_l: -3.7,
        };
        let opts = TemperingOptions {
            n_temps: 5,
            n_iter: 2_000,
            burn_in: 500,
            ..quick(3)
        };
        let res = run_tempering(&t, &[1.0], &DMatrix::from_element(1, 1, 1.0), &opts).unwrap();
        let ti = res.thermodynamic.unwrap();
        let ss = res.stepping_stone.unwrap();
        assert!((ti.ln_z + 3.7).abs() < 1e-12 && ti.std_err < 1e-12);
        assert!(ti.discretisation_err < 1e-12);
        assert!((ss.ln_z + 3.7).abs() < 1e-12 && ss.std_err < 1e-12);
        assert!(res.swap_acceptance.iter().all(|&a| a == 1.0));
        // steps are capped by the box width, and the walk moves
        assert!(
            res.proposal_scale[1..]
                .iter()
                .all(|&s| s * (1.0f64 / 3.0).sqrt() <= 2.0)
        );
        assert!(res.in_rung_acceptance[1..].iter().all(|&a| a > 0.1));
    }

    /// Well constrained: D = 3, SNR 20, uniform priors 40 σ_post wide and more (ln Z dominated
    /// by the Occam factor).
    #[test]
    fn well_constrained_uniform_prior() {
        let lg = LinearGaussian::random(&RandomSpec {
            n_data: 40,
            dim: 3,
            snr: 20.0,
            n_absent: 1,
            sigma: 1.0,
            prior: RandomPrior::Uniform { lo: -5.0, hi: 5.0 },
            seed: 11,
        })
        .unwrap()
        .model;
        let (res, exact, se) = run_lg(&lg, &quick(5));
        check(&res, exact, se, 4.0);
        assert_eq!(res.swap_acceptance.len(), 31);
        assert!(res.swap_acceptance.iter().all(|&a| a > 0.2 && a < 1.0));
        // the adapted ladder equalises the swap rates
        let (lo, hi) = res
            .swap_acceptance
            .iter()
            .fold((1.0f64, 0.0f64), |(a, b), &x| (a.min(x), b.max(x)));
        assert!(hi - lo < 0.2, "{:?}", res.swap_acceptance);
        assert!(
            res.in_rung_acceptance[1..]
                .iter()
                .all(|&a| a > 0.1 && a < 0.5)
        );
        // every rung keeps SNAPSHOTS states inside the prior; the prior rung roams the box
        // while the posterior rung stays near the mode
        assert!(res.rung_samples.iter().all(|r| r.len() == SNAPSHOTS));
        assert!(
            res.rung_samples
                .iter()
                .flatten()
                .all(|t| lg.prior().contains(t))
        );
        let spread = |r: &[Vec<f64>]| {
            let m = r.iter().map(|t| t[0]).sum::<f64>() / r.len() as f64;
            r.iter().map(|t| (t[0] - m).powi(2)).sum::<f64>().sqrt()
        };
        assert!(spread(&res.rung_samples[0]) > 3.0 * spread(&res.rung_samples[31]));
        let ti = res.thermodynamic.unwrap();
        assert!(ti.total_err() < 0.1, "{ti:?}");
    }

    /// D = 2, SNR 10, Gaussian priors N(0, 3²): no box term in the exact answer.
    fn gaussian_prior_problem() -> LinearGaussian {
        LinearGaussian::random(&RandomSpec {
            n_data: 30,
            dim: 2,
            snr: 10.0,
            n_absent: 0,
            sigma: 1.0,
            prior: RandomPrior::Gaussian {
                mu: 0.0,
                sigma: 3.0,
            },
            seed: 2,
        })
        .unwrap()
        .model
    }

    /// Gaussian priors (no box term in the exact answer).
    #[test]
    fn gaussian_prior() {
        let lg = gaussian_prior_problem();
        let (res, exact, se) = run_lg(&lg, &quick(6));
        assert_eq!(se, 0.0);
        check(&res, exact, se, 4.0);
    }

    /// Prior-dominated: the box is half the likelihood width, the truth sits on its corner and
    /// the data push the maximum beyond it, so the MAP is the corner itself.
    #[test]
    fn prior_dominated_map_on_a_corner() {
        let (n, d) = (30, 2);
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(4);
        let x: DMatrix<f64> = DMatrix::from_fn(n, d, |_, _| StandardNormal.sample(&mut rng));
        let h = 0.5 / (n as f64).sqrt();
        let beyond = DVector::from_vec(vec![h + 2.0 / (n as f64).sqrt(); d]);
        let y: Vec<f64> = (&x * beyond).iter().cloned().collect();
        let box_ = PriorKind::Uniform { lo: -h, hi: h };
        let prior = Prior::new(vec!["a".into(), "b".into()], vec![box_, box_]).unwrap();
        let lg = LinearGaussian::new(x.clone(), y.clone(), 1.0, prior).unwrap();
        // KKT at the corner (h, h): the likelihood gradient points out of the box in both
        // coordinates, so the constrained maximum is the corner.
        let corner = DVector::from_vec(vec![h; d]);
        let grad = x.transpose() * (DVector::from_vec(y) - &x * &corner);
        assert!(grad.iter().all(|&g| g > 0.0), "{grad}");
        let (res, exact, se) = run_lg(&lg, &quick(7));
        check(&res, exact, se, 4.0);
        // The posterior is about as wide as the prior: hot and cold rungs look alike.
        assert!(res.swap_acceptance.iter().all(|&a| a > 0.5));
    }

    #[test]
    fn errors_grow_when_n_iter_shrinks() {
        let lg = LinearGaussian::random(&RandomSpec {
            n_data: 30,
            dim: 2,
            snr: 10.0,
            n_absent: 1,
            sigma: 1.0,
            prior: RandomPrior::Uniform { lo: -4.0, hi: 4.0 },
            seed: 3,
        })
        .unwrap()
        .model;
        let short = TemperingOptions {
            n_iter: 3_000,
            burn_in: 1_000,
            ..quick(8)
        };
        let (a, exact, se) = run_lg(&lg, &short);
        let (b, _, _) = run_lg(&lg, &quick(8));
        check(&a, exact, se, 4.0);
        let (ta, tb) = (a.thermodynamic.unwrap(), b.thermodynamic.unwrap());
        let (sa, sb) = (a.stepping_stone.unwrap(), b.stepping_stone.unwrap());
        // 2 000 vs 24 000 kept sweeps: √12 ≈ 3.5 times smaller errors expected.
        assert!(ta.std_err > 2.0 * tb.std_err, "{ta:?} {tb:?}");
        assert!(sa.std_err > 2.0 * sb.std_err, "{sa:?} {sb:?}");
    }

    #[test]
    fn same_numbers_for_any_thread_count() {
        let lg = LinearGaussian::random(&RandomSpec {
            n_data: 30,
            dim: 3,
            snr: 10.0,
            n_absent: 1,
            sigma: 1.0,
            prior: RandomPrior::Uniform { lo: -4.0, hi: 4.0 },
            seed: 5,
        })
        .unwrap()
        .model;
        let opts = TemperingOptions {
            n_temps: 8,
            n_iter: 3_000,
            burn_in: 1_000,
            parallel: true,
            ..quick(9)
        };
        let pool = |n| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .unwrap()
        };
        let one = pool(1).install(|| run_lg(&lg, &opts).0);
        let three = pool(3).install(|| run_lg(&lg, &opts).0);
        let serial = run_lg(
            &lg,
            &TemperingOptions {
                parallel: false,
                ..opts.clone()
            },
        )
        .0;
        assert_eq!(one, three);
        assert_eq!(one, serial);
        let other = run_lg(&lg, &TemperingOptions { seed: 10, ..opts }).0;
        assert_ne!(one.mean_ln_l, other.mean_ln_l);
    }

    #[test]
    fn bad_inputs_are_errors_not_panics() {
        let lg = LinearGaussian::random(&RandomSpec {
            n_data: 20,
            dim: 2,
            snr: 5.0,
            n_absent: 0,
            sigma: 1.0,
            prior: RandomPrior::Uniform { lo: -2.0, hi: 2.0 },
            seed: 1,
        })
        .unwrap()
        .model;
        let cov = DMatrix::identity(2, 2) * 0.01;
        let base = TemperingOptions {
            n_temps: 4,
            n_iter: 1_000,
            burn_in: 200,
            ..quick(1)
        };
        let bad = [
            TemperingOptions {
                n_temps: 2,
                ..base.clone()
            },
            TemperingOptions {
                n_iter: 250,
                ..base.clone()
            },
            TemperingOptions {
                batch_size: Some(0),
                ..base.clone()
            },
            TemperingOptions {
                batch_size: Some(700),
                ..base.clone()
            },
            TemperingOptions {
                adapt_interval: 0,
                ..base.clone()
            },
            TemperingOptions {
                target_acceptance: 1.0,
                ..base.clone()
            },
            TemperingOptions {
                betas: Some(vec![0.0, 0.5, 0.4, 1.0]),
                ..base.clone()
            },
            TemperingOptions {
                betas: Some(vec![0.1, 0.2, 0.5, 1.0]),
                ..base.clone()
            },
        ];
        for o in &bad {
            let e = run_tempering(&lg, &[0.0, 0.0], &cov, o);
            assert!(
                matches!(e, Err(EvidenceError::InvalidOption { .. })),
                "{o:?}"
            );
        }
        assert!(matches!(
            run_tempering(&lg, &[0.0], &cov, &base),
            Err(EvidenceError::Dimension { .. })
        ));
        assert!(matches!(
            run_tempering(&lg, &[3.0, 0.0], &cov, &base),
            Err(EvidenceError::NonFinite { .. })
        ));
        assert!(matches!(
            run_tempering(&lg, &[0.0, 0.0], &(DMatrix::identity(2, 2) * -1.0), &base),
            Err(EvidenceError::Matrix {
                source: crate::linalg::LinalgError::NotPositiveDefinite { .. },
                ..
            })
        ));
        // A user-given ladder is used as given when not adapted.
        let fixed = TemperingOptions {
            betas: Some(vec![0.0, 0.01, 0.2, 1.0]),
            adapt_ladder: false,
            ..base
        };
        let r = run_tempering(&lg, &[0.0, 0.0], &cov, &fixed).unwrap();
        assert_eq!(r.betas, vec![0.0, 0.01, 0.2, 1.0]);
    }

    /// A likelihood that is zero on part of the prior: TI diverges there and says so; SS
    /// still works.
    #[test]
    fn zero_likelihood_region_disables_ti_with_a_reason() {
        struct Half {
            prior: Prior,
        }
        impl LogDensity for Half {
            fn ln_likelihood(&self, t: &[f64]) -> f64 {
                if t[0] < 0.0 { f64::NEG_INFINITY } else { 0.0 }
            }
            fn prior(&self) -> &Prior {
                &self.prior
            }
        }
        let t = Half {
            prior: Prior::new(
                vec!["x".into()],
                vec![PriorKind::Uniform { lo: -1.0, hi: 1.0 }],
            )
            .unwrap(),
        };
        let opts = TemperingOptions {
            n_temps: 4,
            n_iter: 20_000,
            burn_in: 1_000,
            ..quick(2)
        };
        let res = run_tempering(&t, &[0.5], &DMatrix::from_element(1, 1, 0.3), &opts).unwrap();
        let e = res.thermodynamic.unwrap_err();
        assert!(e.contains("diverges"), "{e}");
        // Z = 1/2 exactly.
        let ss = res.stepping_stone.unwrap();
        assert!((ss.ln_z - 0.5f64.ln()).abs() < 4.0 * ss.std_err, "{ss:?}");
    }

    /// Every rung samples its power posterior: with a Gaussian prior the tempered posterior is
    /// Gaussian with precision `βF + Λ`, so `E_β[ln L] = ln L_max − ½[tr(F A_β⁻¹) + (m_β − θ̂)ᵀF(m_β − θ̂)]`
    /// in closed form. Each rung's mean lies within 4.5 of its own standard errors.
    #[test]
    fn rung_means_follow_the_closed_form_power_posterior_curve() {
        let lg = gaussian_prior_problem();
        let cols = [0usize, 1];
        let post = lg.gaussian_posterior(&cols).unwrap();
        let (th, lmax) = lg.max_likelihood(&cols).unwrap();
        let f = lg.fisher(&cols).unwrap();
        let lam = DMatrix::identity(2, 2) / 9.0;
        let thv = DVector::from_vec(th);
        let curve = |b: f64| {
            let ai = (&f * b + &lam).try_inverse().unwrap();
            let dm = &ai * (&f * &thv * b) - &thv;
            lmax - 0.5 * ((&f * &ai).trace() + (dm.transpose() * &f * &dm)[(0, 0)])
        };
        let r = run_tempering(&lg, post.mean.as_slice(), &post.cov, &quick(12)).unwrap();
        for i in 0..r.betas.len() {
            let z = (r.mean_ln_l[i] - curve(r.betas[i])) / r.mean_ln_l_std_err[i];
            assert!(z.abs() < 4.5, "rung {i} (β = {}): z = {z}", r.betas[i]);
        }
        // the curve spans hundreds of nats between the prior and the posterior
        assert!(r.mean_ln_l[r.betas.len() - 1] - r.mean_ln_l[0] > 100.0);
    }

    /// Cost of the defaults on a D = 6 problem with a prior box ~10³ posterior widths wide per
    /// parameter (ln Z ≈ −56, an LTP-like Occam factor): the TI and SS errors and the number of
    /// likelihood calls.
    #[test]
    fn defaults_reach_a_tenth_of_a_nat_at_d6() {
        let lg = LinearGaussian::random(&RandomSpec {
            n_data: 100,
            dim: 6,
            snr: 30.0,
            n_absent: 0,
            sigma: 1.0,
            prior: RandomPrior::Uniform {
                lo: -50.0,
                hi: 50.0,
            },
            seed: 21,
        })
        .unwrap()
        .model;
        let (res, exact, se) = run_lg(&lg, &quick(13));
        eprintln!("evals {}", res.ln_l_evals);
        check(&res, exact, se, 4.0);
        let ti = res.thermodynamic.unwrap();
        let ss = res.stepping_stone.unwrap();
        assert!(ti.total_err() < 0.15 && ss.std_err < 0.15, "{ti:?} {ss:?}");
        assert!(res.ln_l_evals < 1_300_000);
    }
}
