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
//! Every rung owns its random stream (`chain_rng(seed, i + 1)`; the swaps use stream 0, the
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
//! **Where `L = 0`** on part of the prior (a model outside its region of validity returns
//! `ln L = −∞`), `E_β[ln L]` diverges as β → 0 although `Z` is finite. With `S` the support of
//! `L` and `p = π(S)`, every rung with β > 0 samples `π L^β ∝ π_S L^β` (it never accepts a
//! point outside `S`), so `ln Z = ln p + ∫₀¹ E_{π_S L^β}[ln L] dβ`: `p` is estimated by the
//! fraction of the prior rung's draws with `L > 0` and `E_{π_S}[ln L]` by their mean
//! ([`ThermodynamicEstimate::ln_support`]; both enter the Monte-Carlo error below). Stepping
//! stone needs nothing extra: its first ratio counts those draws as `L^Δβ = 0`.
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
//! `u_t` with batches of `⌊√n⌋` sweeps (as in [`rjmcmc`](super::rjmcmc)), or from its
//! split-chain effective sample size where that gives more (batches shorter than a few
//! autocorrelation times are biased low: many free parameters, few sweeps). Because the series
//! sums the rungs *before* batching, the correlation between rungs that swaps induce is included;
//! no independence between rungs is assumed. The remaining approximation is the linearisation
//! (delta method) of the variance term.
//!
//! # Stepping stone (Xie et al. 2011)
//! `ln Z_SS = Σ_{i=0}^{N−2} ln (1/n) Σ_t exp[(β_{i+1} − β_i) ℓ_i(t)]` (log-sum-exp), each ratio
//! from the samples of the lower rung. Error: delta method `δ ln r_i = mean_t(e^{x_t − ln r_i} − 1)`
//! summed over rungs per sweep, then as above. SS has no discretisation error, but
//! its ratios are biased low (Jensen) when a step's weights are dominated by a few samples; the
//! equalised swap rates keep adjacent rungs overlapping, which is the same condition.

//!
//! # Checks of a run against itself
//! The batch-means errors assume every rung sampled its power posterior from the first
//! post-burn-in sweep on. Two checks see when that failed ([`TemperingResult::checks`]): the
//! first and second halves of the post-burn-in sweeps give TI and SS of their own, and where
//! they differ by more than 3 of their combined errors the whole run's error becomes at least
//! `|Δ|/2` (the spread the halves show); and `E_β[ln L]`, whose derivative is `Var_β(ln L) ≥ 0`,
//! must not fall from one rung to the next by more than 4 combined errors — a rung where it does
//! is named.
//!
//! # Running
//! [`run_tempering`] runs a ladder to its end; [`ParallelTempering`] does the same on the
//! sampler [`Driver`](crate::sampler::Driver) with progress, a checkpoint (kind
//! [`KIND`], the common format of [`crate::data::checkpoint`]) and a stop hook, and
//! [`ParallelTempering::resume`] continues a saved run to the numbers of an uninterrupted one.

mod checks;
mod integrate;
mod ladder;
mod options;
mod run;
#[cfg(test)]
mod tests;

pub use checks::TemperingChecks;
pub use integrate::{SteppingStoneEstimate, ThermodynamicEstimate};
pub use options::{SNAPSHOTS, TemperingOptions};
pub use run::{
    KIND, ParallelTempering, TemperingOutcome, TemperingResult, run_tempering,
    run_tempering_observed,
};
