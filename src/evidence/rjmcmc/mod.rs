//! Reversible-jump MCMC between nested models: Metropolised Carlin–Chib with independence
//! proposals (`ltp-model.md` §9.2, "correct version").
//!
//! # Chain
//! The state is `(k, θ_k)`. Each iteration
//! 1. updates `θ_k` by a Gaussian random walk with covariance `s²Σ_k` (`s = 2.38/√D_k` by
//!    default), accepted with `min{1, L π(θ*) / L π(θ_k)}`;
//! 2. proposes a model `k' ~ j(·|k)` and `θ' ~ q_k'`, independent of the current state, where
//!    `q_k' = (1 − w)·g_k' + w·π_k'` is a **defensive mixture** of `g_k' = N(center_k', c²Σ_k')`
//!    (or a multivariate Student-t with ν degrees of freedom) and the model's own normalised
//!    prior (weight `w` = [`RjOptions::defensive`]), and accepts with
//!    ```text
//!    α = min{1, [L_k'(θ') π_k'(θ') q_k(θ_k) P(k') j(k|k')] / [L_k(θ_k) π_k(θ_k) q_k'(θ') P(k) j(k'|k)]}
//!    ```
//!    (with `L`, not LTPDA's `L²`, and the prior ratio the right way up). The prior component
//!    makes `q > 0` wherever `π > 0`, so the importance weights `w = Lπ/q ≤ L/w` are bounded:
//!    when the Gaussian part misses the posterior (low SNR: posterior filling the prior box,
//!    MAP on a corner) the prior draws still land in it.
//!
//! **Proposals outside the prior box** are not redrawn: they are rejected (α = 0, as `π_k' = 0`
//! there). This is exact: it is Metropolis–Hastings with the *untruncated* proposal density, for
//! which the ratio above — evaluated with the untruncated `q` — satisfies detailed balance on the
//! support; the truncation normaliser never enters the chain. Redrawing until inside would
//! instead require the normaliser `P_k(box)` in the ratio, whose quadrature error would bias B.
//!
//! # Chains
//! [`RjOptions::n_chains`] independent chains run on the rayon pool; chain `j` draws from
//! `Xoshiro256PlusPlus::seed_from_u64(seed)` advanced by `j` `jump()`s (2¹²⁸ steps each, so the
//! streams never overlap; chain 0 is the single-chain stream), never from anything about the
//! worker thread. They synchronise every 1 % of the run (the progress callback is called from the
//! calling thread there) and once after the pilot (below). Visits, counts and the estimators'
//! sums are pooled; the result is bit-identical for any number of threads.
//!
//! # Estimators (for every pair k, l; `ln B_kl = ln Z_k − ln Z_l`)
//! * **Visits**: `ln B_kl = ln(N_k/N_l) − ln(P(k)/P(l))`. Undefined (None) when a model is never
//!   visited.
//! * **Rao-Blackwellised** (Bartolucci, Scaccia & Mira 2006, their acceptance-probability
//!   estimator): integrating detailed balance over both models gives
//!   `P(k|y) j(l|k) E_k[α_{k→l}] = P(l|y) j(k|l) E_l[α_{l→k}]`, hence
//!   ```text
//!   B_kl = [P(l) j(k|l) / (P(k) j(l|k))] · ᾱ_{l→k} / ᾱ_{k→l},
//!   ```
//!   with `ᾱ_{k→l}` the mean acceptance probability over the iterations spent in k that proposed l
//!   (the realised accept/reject is replaced by its conditional expectation). Note the visit
//!   counts cancel: the sums `Σ_{t∈l} α_{l→k}` must be divided by the number of such proposals.
//!   **When a model was never visited** (no proposals out of it) its mean acceptance is replaced
//!   by its bound `ᾱ = 1`: the estimate stays finite and is a lower bound on the unvisited
//!   model's evidence ratio, exact when jumps out of that model would always be accepted —
//!   which is the case the chain is in when it never enters it (for independence proposals
//!   with `B ≪ 1`, `ᾱ_{l→k} = E[min(1, r)] = E[r] = B_kl·P(k)j(l|k)/(P(l)j(k|l))`). In this
//!   one-sided case the visited direction's α are evaluated with the current state's density
//!   taken as the Gaussian/t part `g_k` alone: with the defensive mixture, a fraction `w` of the
//!   unvisited model's jumps back would be prior draws that are mostly rejected, so the bound
//!   `ᾱ = 1` would be off by up to `−ln(1 − w)`; for `g` it holds as before (with `w = 0` the
//!   two coincide).
//! * **Bridge** (Meng & Wong 1996; BSM's "optimal" estimator): for independence proposals every
//!   jump `k → l` is a draw from `f₁(θ, θ') = L_kπ_k(θ) q̃_l(θ')/Z_k` on the product space, and
//!   every jump `l → k` a draw from `f₂ = q̃_k(θ) L_lπ_l(θ')/Z_l`, with `q̃ = q·1_box/P(box)` the
//!   (mixture) proposal truncated to the prior box (draws outside are the rejected ones and are
//!   dropped). With `ρ = f₂/f₁ = [w_l(θ')/w_k(θ)]·P_l/P_k`, `w = Lπ/q`, the bridge identity
//!   with `h = 1/(s₁r₀f₁ + s₂f₂)` gives, for *any* constants `r₀, s₁, s₂`,
//!   ```text
//!   Z_l/Z_k = r̂(r₀) = [ (1/n₁) Σ_{k→l} ρ_i/(s₁r₀ + s₂ρ_i) ] / [ (1/n₂) Σ_{l→k} 1/(s₁r₀ + s₂ρ_j) ],
//!   ```
//!   and `r₀ = r̂(r₀)`, `s_i = n_i/(n₁+n₂)` is the optimal member. The optimum needs every draw
//!   again at each step of the fixed-point iteration, which a run of 10⁸ iterations cannot keep.
//!   So the chains keep the raw `ln ρ` only during a **pilot** (the first 2¹⁷ post-burn-in
//!   iterations of each chain, pooled), solve the fixed point there, fix `s_i` at the pilot's
//!   fractions and stream `r̂(r₀)` on a grid `r₀ = r_pilot·e^δ`, δ ∈ {0, ±½, ±1, ±2, ±4, ±8};
//!   the grid point whose `r̂(r₀)` is closest to `r₀` is reported (efficiency of the bridge is
//!   flat near the optimum). For runs no longer than the pilot this is exactly the optimal
//!   bridge. With no proposals `l → k` (l never entered) it reduces to the importance-sampling
//!   identity `Z_l/Z_k = E_{f₁}[ρ]`, which stays finite: the chain sitting in k still tells how
//!   much posterior mass l would have. In that one-sided form the sitting model's factor is
//!   `g̃_k(θ)/L_kπ_k(θ)` (any normalised density works there) rather than the mixture's
//!   `q̃_k/L_kπ_k`: the mixture's prior part would turn it into the harmonic-mean estimator
//!   (`E_post[1/L]`, infinite variance); the Gaussian part keeps the variance finite for
//!   `c < √2`. The normalisers are the mixtures' box masses
//!   `P_k = (1 − w)·P_g(box) + w` ([`mvn_rectangle`] for Gaussian `g`, 2¹⁶ Monte-Carlo draws
//!   for Student-t), and their errors are included.
//!
//! # Errors
//! All three estimators are smooth functions of means of per-iteration series; their standard
//! errors come from the delta method applied to the linearised series `u_t`, whose sums the
//! chains stream per batch and per regeneration unit (nothing per iteration is stored). Two
//! estimates of `Var(ū)` are formed and the larger is used:
//! * **batch means** over `a = ⌊N/b⌋` batches of `b = ⌊√N⌋` iterations per chain (N =
//!   post-burn-in iterations of a chain; Flegal & Jones 2010), batches of all chains pooled:
//!   `Var(ū) ≈ b/(A−1)·Σ_j (ū_j − ū)² / N_tot`. Consistent when `b` is much longer than the
//!   chain's memory — which fails exactly when jumps are rare and the chain sits in one model for
//!   whole batches;
//! * **regenerative**: the run cut at every entry into the start model; `Var(ū) ≈
//!   A/(A−1)·Σ_c (U_c − ū n_c)²/N_tot²` over those cycles (sums `U_c` over `n_c` iterations).
//!   Entries are approximate regenerations (the entry state is a fresh proposal draw), so this
//!   sees correlations of any length within a sojourn.
//!
//! **Visit ratio.** Its information is the number of sojourns, not of iterations: for a
//! chain that leaves k and l with per-iteration probabilities `a_k, a_l`, `Var(ln N_k/N_l) =
//! (1/m_k + 1/m_l)(1 − (a_k+a_l)/2)` (m: sojourns; for two models `2(2 − a − β)/n_switch`, the
//! two-state Markov chain's asymptotic variance). Leave probabilities that vary with θ make the
//! sojourn lengths mixtures of geometrics, with a larger coefficient of variation, so this is a
//! floor: the visit error is `max(batch means, regenerative, floor)`, and grows as `2/√n` with
//! `n` accepted jumps however many iterations were run.
//!
//! **Rao-Blackwell and bridge** average over *proposals*, not accepted jumps: every iteration
//! contributes a fresh `θ' ~ q` and the current `θ`. Their precision is limited by (i) how
//! evenly the acceptance probabilities / bridge terms are spread (a mean of `α ∈ [0, 1]` has
//! relative variance ≤ `1/Σα`, reached when α is 0 or 1; when the unvisited model's proposals
//! are informative, e.g. α ≈ B for all of them, it is far smaller) and (ii) how many
//! independent `θ` of each model the chain has seen, which within a sojourn is the random walk's
//! mixing and across sojourns the number of sojourns. Both are what the two variance estimates
//! measure; neither is a count of accepted jumps, so no jump-count floor is imposed on them — a
//! floor would wrongly inflate the informative-proposal case, where they legitimately stay
//! precise with no accepted jump at all.
//!
//! **Warning.** Each pair reports its effective independent jumps (accepted jumps between the
//! two after burn-in) and warns below [`MIN_EFFECTIVE_JUMPS`] = 30: with n jumps the
//! regenerative estimate has about n/2 cycles, so the error bar itself is uncertain by
//! `1/√(2·(n/2 − 1)) ≈ 20 %` at n = 30 and more below.
//!
//! # Memory
//! Per chain: the batch sums (`⌊√N⌋` batches × `K + K²(4 + 11)` numbers), at most 1024
//! regeneration units of the same size, the pilot's raw bridge inputs (≤ 2¹⁷ records, freed after
//! the pilot) and the trace (`N / trace_every` points). Nothing else grows with N.
//!
//! The Student-t box masses draw from `seed_from_u64(seed)` advanced by one `long_jump()`
//! (2¹⁹² steps: beyond every chain's stream).

mod chain;
mod estimate;
mod run;
#[cfg(test)]
mod tests;

use super::mvn::{MvnOptions, mvn_rectangle};
use super::{EvidenceError, LnB, Method};
use crate::density::LogDensity;
use crate::linalg::{SpdOptions, forward_solve_norm2};
use chain::{Chain, Layout, Shared};
use estimate::{GRID_OFFSETS, Pool, Sojourns};
use nalgebra::DMatrix;
use rand::SeedableRng;
use rand_distr::{ChiSquared, Distribution, StandardNormal};
use rand_xoshiro::Xoshiro256PlusPlus;
pub use run::{KIND, ReversibleJump, RjOutcome, run_rjmcmc};
use serde::Serialize;
use statrs::function::gamma::ln_gamma;
use std::f64::consts::PI;

/// Below this many accepted jumps between two models a pair carries a warning (see the module
/// docs: the error bar's own uncertainty then exceeds about 20 %).
pub const MIN_EFFECTIVE_JUMPS: u64 = 30;

/// Post-burn-in iterations per chain whose raw bridge inputs fix the bridge grid.
const PILOT_ITERS: usize = 1 << 17;

/// One model of the jump chain.
pub struct RjModel<'a> {
    /// Label for tables.
    pub name: String,
    /// The model's posterior target (its own dimension and normalised prior).
    pub target: &'a dyn LogDensity,
    /// Centre of the jump proposal and start point if this is the start model. The posterior
    /// mean of the model's own chain is the robust choice: in the low-SNR regime (posterior
    /// filling its prior box, MAP on a corner) a Fisher-based proposal around the MAP almost
    /// never lands where the posterior is.
    pub center: Vec<f64>,
    /// `Σ_k`: posterior covariance estimate (the model chain's sample covariance, or the inverse
    /// Fisher matrix). The jump proposal uses `c²Σ_k`, the random walk `s²Σ_k`.
    pub cov: DMatrix<f64>,
}

/// How the next model is proposed.
#[derive(Debug, Clone, PartialEq, Serialize, serde::Deserialize)]
pub enum JumpRule {
    /// Uniformly among the other models (the default; K = 1 means no jumps).
    UniformOthers,
    /// Uniformly among all models including the current one (LTPDA's choice; a self-jump is an
    /// independence move inside the model).
    UniformAll,
    /// `j(l|k) = matrix[k][l]`; rows sum to 1 and `j(l|k) > 0 ⇔ j(k|l) > 0`.
    Matrix(Vec<Vec<f64>>),
}

/// Shape of the independence jump proposal.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, serde::Deserialize)]
pub enum ProposalShape {
    /// Multivariate normal.
    Gaussian,
    /// Multivariate Student-t with `nu` degrees of freedom (heavier tails, for non-Gaussian
    /// posteriors; `ltp-model.md` suggests ν = 4).
    StudentT { nu: f64 },
}

/// Options of [`run_rjmcmc`].
#[derive(Debug, Clone, PartialEq, Serialize, serde::Deserialize)]
pub struct RjOptions {
    /// Total iterations summed over the chains (each: one in-model step and one jump attempt).
    /// Each chain runs `⌊n_iter / n_chains⌋`, its burn-in included.
    pub n_iter: usize,
    /// Iterations each chain discards before counting.
    pub burn_in: usize,
    /// Seed; chain `j` uses the stream `seed_from_u64(seed)` advanced by `j` `jump()`s.
    pub seed: u64,
    /// Independent chains, run on the rayon pool and pooled. The result does not depend on the
    /// number of threads. Two chains use both cores of a small machine and let the between-chain
    /// spread show up in the pooled batch means.
    pub n_chains: usize,
    /// Weight `w ∈ [0, 1)` of the model's own prior in the jump proposal
    /// `q = (1 − w)·N/t(center, c²Σ) + w·π_k`. It keeps `q > 0` wherever `π > 0` and bounds the
    /// importance weights `Lπ/q ≤ L/w`, so a badly placed Gaussian cannot make the bridge's and
    /// Rao-Blackwell's weights unbounded. The default 0.1 costs at most a factor `1/(1 − w) ≈ 1.11`
    /// in useful proposals when the Gaussian is good (Hesterberg's defensive mixtures use
    /// 0.1–0.5) while guaranteeing one proposal in ten samples the whole prior box, which is what
    /// the low-SNR regime (posterior filling the box) needs. `0` gives the pure Gaussian/t
    /// proposal and the same random stream as before this option existed.
    pub defensive: f64,
    /// Prior model probabilities `P(k)` (normalised internally); `None`: uniform.
    pub prior_model_probs: Option<Vec<f64>>,
    /// Model proposal.
    pub jump: JumpRule,
    /// Shape of the parameter proposal.
    pub proposal: ProposalShape,
    /// `c` in `c²Σ_k` (`ltp-model.md`: 1–1.5; below √2 keeps the bridge estimator's variance
    /// finite for Gaussian posteriors).
    pub jump_scale: f64,
    /// Random-walk scale `s`; `None`: `2.38/√D_k`.
    pub rw_scale: Option<f64>,
    /// Record the visit counts every this many post-burn-in iterations (per chain); 0: about
    /// 1000 points. The trace is the only output whose size grows with `n_iter / trace_every`.
    pub trace_every: usize,
    /// Batch size for the errors; `None`: `⌊√N⌋` with N the post-burn-in iterations of one chain.
    pub batch_size: Option<usize>,
    /// Index of the starting model (it starts at its `center`).
    pub start_model: usize,
    /// QMC settings of the Gaussian proposals' box masses.
    pub box_mass: MvnOptions,
    /// Keep every post-burn-in draw (model, parameters, `ln L`) in [`RjResult::draws`]:
    /// `N − chains·burn_in` rows of `P + 2` numbers, `P` the union of the models' parameters.
    pub keep_draws: bool,
}

impl Default for RjOptions {
    fn default() -> Self {
        Self {
            n_iter: 100_000,
            burn_in: 1_000,
            seed: 1,
            n_chains: 2,
            defensive: 0.1,
            prior_model_probs: None,
            jump: JumpRule::UniformOthers,
            proposal: ProposalShape::Gaussian,
            jump_scale: 1.2,
            rw_scale: None,
            trace_every: 0,
            batch_size: None,
            start_model: 0,
            box_mass: MvnOptions::default(),
            keep_draws: false,
        }
    }
}

/// Passed to the progress callback about 100 times per run (from the calling thread).
#[derive(Debug, Clone, Copy)]
pub struct RjProgress<'a> {
    /// Iterations done, summed over the chains.
    pub iteration: usize,
    /// Total iterations, summed over the chains.
    pub n_iter: usize,
    /// Current model of chain 0.
    pub model: usize,
    /// Post-burn-in visits so far, summed over the chains.
    pub visits: &'a [u64],
}

/// Bayes-factor estimates for one pair, `ln B_kl = ln Z_k − ln Z_l`.
#[derive(Debug, Clone, PartialEq, Serialize, serde::Deserialize)]
pub struct RjPair {
    /// First model.
    pub k: usize,
    /// Second model.
    pub l: usize,
    /// Visit ratio (None if either model was never visited).
    pub visits: Option<LnB>,
    /// Mean-acceptance-probability ratio (None without accepted-probability mass both ways).
    pub rao_blackwell: Option<LnB>,
    /// Optimal bridge (None only without any in-box proposal between the two).
    pub bridge: Option<LnB>,
    /// Post-burn-in jump proposals k → l.
    pub proposals_k_to_l: u64,
    /// Post-burn-in jump proposals l → k.
    pub proposals_l_to_k: u64,
    /// Post-burn-in accepted jumps k → l.
    pub accepted_k_to_l: u64,
    /// Post-burn-in accepted jumps l → k.
    pub accepted_l_to_k: u64,
    /// Effective independent jumps: accepted jumps between k and l after burn-in, all chains.
    /// Each is the end of a sojourn, and sojourns are what the visit ratio averages over.
    pub effective_jumps: u64,
    /// Expected accepted jumps `Σα` over both directions: the number Rao-Blackwell and the
    /// bridge effectively average over when proposals are rarely accepted (the relative
    /// variance of a mean of `α ∈ [0, 1]` is at most `1/Σα`).
    pub expected_jumps: f64,
    /// Set when `effective_jumps` < [`MIN_EFFECTIVE_JUMPS`]: the visit ratio then rests on a
    /// handful of sojourns and its error bar is itself uncertain.
    pub warning: Option<String>,
}

impl RjPair {
    fn flipped(&self) -> RjPair {
        let neg = |b: &Option<LnB>| b.map(|b| LnB { ln_b: -b.ln_b, ..b });
        RjPair {
            k: self.l,
            l: self.k,
            visits: neg(&self.visits),
            rao_blackwell: neg(&self.rao_blackwell),
            bridge: neg(&self.bridge),
            proposals_k_to_l: self.proposals_l_to_k,
            proposals_l_to_k: self.proposals_k_to_l,
            accepted_k_to_l: self.accepted_l_to_k,
            accepted_l_to_k: self.accepted_k_to_l,
            effective_jumps: self.effective_jumps,
            expected_jumps: self.expected_jumps,
            warning: self.warning.clone(),
        }
    }
}

/// Visit counts at one point of the run.
#[derive(Debug, Clone, PartialEq, Serialize, serde::Deserialize)]
pub struct RjTracePoint {
    /// Iterations done (including burn-in), summed over the chains.
    pub iteration: usize,
    /// Post-burn-in visits per model so far, summed over the chains.
    pub visits: Vec<u64>,
}

/// The three jump-chain estimates of one pair at one point of the run.
#[derive(Debug, Clone, PartialEq, Serialize, serde::Deserialize)]
pub struct RjRunningPair {
    /// First model.
    pub k: usize,
    /// Second model.
    pub l: usize,
    /// Visit ratio (`None` while either model is unvisited).
    pub visits: Option<LnB>,
    /// Rao-Blackwell (mean acceptance probabilities).
    pub rao_blackwell: Option<LnB>,
    /// Bridge.
    pub bridge: Option<LnB>,
}

/// Every pair's estimates from the first part of the run (the evolution of B, Fig. 2).
#[derive(Debug, Clone, PartialEq, Serialize, serde::Deserialize)]
pub struct RjRunningPoint {
    /// Iterations done (including burn-in), summed over the chains.
    pub iteration: usize,
    /// One entry per pair `k < l`, in the order of [`RjResult::pairs`].
    pub pairs: Vec<RjRunningPair>,
}

/// The kept post-burn-in draws of every jump chain (`keep_draws`), chain-major.
#[derive(Debug, Clone, PartialEq, Serialize, serde::Deserialize)]
pub struct RjDraws {
    /// Model names (what `model_index` indexes).
    pub model_names: Vec<String>,
    /// The union of the models' parameter names, in first-seen order (model by model).
    pub param_names: Vec<String>,
    /// Chains.
    pub n_chains: usize,
    /// Draws per chain.
    pub n_draws: usize,
    /// Every `thin`-th post-burn-in iteration is kept (1: all).
    pub thin: usize,
    /// `[chain][draw]`: the model the chain is in.
    pub model_index: Vec<i64>,
    /// `[chain][draw][param]`: its parameters, NaN where the model has no such parameter.
    pub samples: Vec<f64>,
    /// `[chain][draw]`: `ln L` of the state.
    pub ln_likelihood: Vec<f64>,
}

/// The union of the models' parameter names (first-seen order) and, per model, the column of
/// each of its parameters in it.
pub fn union_columns(names: &[&[String]]) -> (Vec<String>, Vec<Vec<usize>>) {
    let mut all: Vec<String> = Vec::new();
    let cols = names
        .iter()
        .map(|ns| {
            ns.iter()
                .map(|n| match all.iter().position(|a| a == n) {
                    Some(i) => i,
                    None => {
                        all.push(n.clone());
                        all.len() - 1
                    }
                })
                .collect()
        })
        .collect();
    (all, cols)
}

/// Output of [`run_rjmcmc`].
#[derive(Debug, Clone, PartialEq, Serialize, serde::Deserialize)]
pub struct RjResult {
    /// Model names.
    pub model_names: Vec<String>,
    /// Iterations run, summed over the chains.
    pub n_iter: usize,
    /// Independent chains.
    pub n_chains: usize,
    /// Burn-in iterations of each chain.
    pub burn_in: usize,
    /// Defensive prior weight of the jump proposals.
    pub defensive: f64,
    /// Batch size used for the errors.
    pub batch_size: usize,
    /// Normalised prior model probabilities.
    pub prior_model_probs: Vec<f64>,
    /// Post-burn-in iterations spent in each model.
    pub visits: Vec<u64>,
    /// In-model random-walk acceptance rate per model (`None` for a model never visited or of
    /// dimension 0).
    pub in_model_acceptance: Vec<Option<f64>>,
    /// `[k][l]`: jump proposals k → l (whole run, all chains).
    pub jumps_proposed: Vec<Vec<u64>>,
    /// `[k][l]`: accepted jumps k → l (whole run, all chains).
    pub jumps_accepted: Vec<Vec<u64>>,
    /// Post-burn-in sojourns per model (all chains).
    pub sojourns: Vec<u64>,
    /// Regeneration units (entries into the start model, merged pairwise beyond 1024 per chain)
    /// behind the regenerative variance.
    pub regeneration_units: usize,
    /// Proposals with a non-finite likelihood inside the prior (counted as rejections).
    pub non_finite: u64,
    /// `ln L` evaluations, all chains (proposals outside the prior support cost none).
    pub likelihood_calls: u64,
    /// `ln P_k(box)` of each model's jump proposal: `ln[(1 − w)·P_gauss(box) + w]`.
    pub ln_box_mass: Vec<f64>,
    /// Standard errors of `ln_box_mass`.
    pub ln_box_mass_std_err: Vec<f64>,
    /// Estimates for every pair k < l.
    pub pairs: Vec<RjPair>,
    /// Visit counts along the run (for the evolution of B).
    pub trace: Vec<RjTracePoint>,
    /// Every estimator along the run, at most [`MAX_RUNNING_POINTS`] points; the last is the
    /// whole run (equal to `pairs`). Point `b` pools the first `b` batches of every chain (and
    /// the stretch before them), its errors from the batch means alone: the regeneration units
    /// that the final errors also use are not resolved in time.
    #[serde(default)]
    pub running: Vec<RjRunningPoint>,
    /// The post-burn-in draws, when [`RjOptions::keep_draws`] asked for them. Not serialised
    /// (they go to `rj_chain.npz`, not to `summary.json`).
    #[serde(skip)]
    pub draws: Option<RjDraws>,
}

/// Most points of [`RjResult::running`].
pub const MAX_RUNNING_POINTS: usize = 200;

impl RjResult {
    /// The estimates for `ln B_kl` (either order).
    pub fn pair(&self, k: usize, l: usize) -> Option<RjPair> {
        self.pairs.iter().find_map(|p| {
            if p.k == k && p.l == l {
                Some(p.clone())
            } else if p.k == l && p.l == k {
                Some(p.flipped())
            } else {
                None
            }
        })
    }

    /// Evolution of the visit-ratio `ln B_kl` along the run: `(iteration, ln B)` with `None`
    /// while either model is unvisited.
    pub fn ln_b_trace(&self, k: usize, l: usize) -> Vec<(usize, Option<f64>)> {
        let lp = self.prior_model_probs[l].ln() - self.prior_model_probs[k].ln();
        self.trace
            .iter()
            .map(|t| {
                let (a, b) = (t.visits[k], t.visits[l]);
                let v = (a > 0 && b > 0).then(|| (a as f64).ln() - (b as f64).ln() + lp);
                (t.iteration, v)
            })
            .collect()
    }

    /// Jump acceptance `k → l` over the whole run: `(accepted, proposed, rate)`, the rate
    /// `None` without proposals.
    pub fn jump_acceptance(&self, k: usize, l: usize) -> (u64, u64, Option<f64>) {
        let (a, p) = (self.jumps_accepted[k][l], self.jumps_proposed[k][l]);
        (a, p, (p > 0).then(|| a as f64 / p as f64))
    }

    /// `[k][l]`: jump acceptance rates (None where nothing was proposed, e.g. the diagonal).
    pub fn jump_acceptance_rates(&self) -> Vec<Vec<Option<f64>>> {
        let k = self.jumps_proposed.len();
        (0..k)
            .map(|a| (0..k).map(|b| self.jump_acceptance(a, b).2).collect())
            .collect()
    }

    /// Visit fractions (estimates of the posterior model probabilities).
    pub fn visit_fractions(&self) -> Vec<f64> {
        let n: u64 = self.visits.iter().sum();
        self.visits.iter().map(|&v| v as f64 / n as f64).collect()
    }
}

/// Per-model constants.
pub(super) struct Prepared<'a> {
    pub target: &'a dyn LogDensity,
    pub dim: usize,
    pub center: Vec<f64>,
    /// Row-major Cholesky factor of `c²Σ`.
    pub lq: Vec<f64>,
    /// Normalising constant of `ln q` (everything but the quadratic form).
    pub ln_q_norm: f64,
    /// Row-major Cholesky factor of `s²Σ`.
    pub lrw: Vec<f64>,
}

impl Prepared<'_> {
    /// `ln g(θ)` of the Gaussian/t part; `buf` is scratch of length ≥ dim.
    pub fn ln_q(&self, theta: &[f64], shape: ProposalShape, buf: &mut [f64]) -> f64 {
        let d = self.dim;
        for ((b, t), c) in buf[..d].iter_mut().zip(theta).zip(&self.center) {
            *b = t - c;
        }
        let m2 = forward_solve_norm2(&self.lq, d, &mut buf[..d]);
        match shape {
            ProposalShape::Gaussian => self.ln_q_norm - 0.5 * m2,
            ProposalShape::StudentT { nu } => {
                self.ln_q_norm - 0.5 * (nu + d as f64) * (m2 / nu).ln_1p()
            }
        }
    }
}

/// The constants every chain reads: jump ratios and cumulative jump rows from the validated
/// prior model probabilities `prior_p` and jump matrix `jump`, box-mass shifts, the proposal's
/// χ² (Student-t), batch size and trace spacing; `columns` is the union of the models'
/// parameters (each model's columns and the union's width).
fn shared<'a>(
    prepared: Vec<Prepared<'a>>,
    prior_p: &[f64],
    jump: &[Vec<f64>],
    boxes: &BoxMasses,
    opts: &RjOptions,
    per_chain: usize,
    columns: (Vec<Vec<usize>>, usize),
) -> Result<Shared<'a>, EvidenceError> {
    let k_models = prior_p.len();
    let (ln_box, ln_box_g) = (&boxes.ln_p, &boxes.ln_p_g);
    let n_post = per_chain - opts.burn_in;
    let batch = opts
        .batch_size
        .unwrap_or((n_post as f64).sqrt() as usize)
        .max(1);
    let trace_every = if opts.trace_every == 0 {
        (n_post / 1000).max(1)
    } else {
        opts.trace_every
    };
    // ln R[k][l] = ln P(l) + ln j(k|l) − ln P(k) − ln j(l|k).
    let ln_ratio: Vec<Vec<f64>> = (0..k_models)
        .map(|k| {
            (0..k_models)
                .map(|l| prior_p[l].ln() + jump[l][k].ln() - prior_p[k].ln() - jump[k][l].ln())
                .collect()
        })
        .collect();
    let cumulative: Vec<Vec<f64>> = jump
        .iter()
        .map(|row| {
            row.iter()
                .scan(0.0, |s, &p| {
                    *s += p;
                    Some(*s)
                })
                .collect()
        })
        .collect();
    let shift: Vec<Vec<f64>> = (0..k_models)
        .map(|k| (0..k_models).map(|l| ln_box[l] - ln_box[k]).collect())
        .collect();
    let shift_g: Vec<Vec<f64>> = (0..k_models)
        .map(|k| (0..k_models).map(|l| ln_box[l] - ln_box_g[k]).collect())
        .collect();
    let chi2 =
        match opts.proposal {
            ProposalShape::StudentT { nu } => Some(ChiSquared::new(nu).map_err(|_| {
                EvidenceError::option("proposal nu", nu, "ν must be finite and > 0")
            })?),
            ProposalShape::Gaussian => None,
        };
    let w = opts.defensive;
    let (columns, n_columns) = columns;
    Ok(Shared {
        prepared,
        shape: opts.proposal,
        chi2,
        defensive: (w, (1.0 - w).ln(), w.ln()),
        ln_ratio,
        cumulative,
        shift,
        shift_g,
        burn_in: opts.burn_in,
        n_iter: per_chain,
        batch,
        trace_every,
        start_model: opts.start_model,
        layout: Layout {
            k: k_models,
            g: GRID_OFFSETS.len(),
        },
        grid: None,
        columns: opts.keep_draws.then_some(columns),
        n_columns,
    })
}

/// The chains' counts, summed.
struct Totals {
    visits: Vec<u64>,
    sojourns: Vec<u64>,
    rw_tried: Vec<u64>,
    rw_accepted: Vec<u64>,
    proposed: Vec<Vec<u64>>,
    accepted: Vec<Vec<u64>>,
    accepted_post: Vec<Vec<u64>>,
    non_finite: u64,
    trace: Vec<RjTracePoint>,
}

impl Totals {
    fn of(chains: &[Chain], k_models: usize) -> Totals {
        let sum_vec = |f: &dyn Fn(&Chain) -> &Vec<u64>| -> Vec<u64> {
            let mut v = vec![0u64; k_models];
            for c in chains {
                for (a, b) in v.iter_mut().zip(f(c)) {
                    *a += b;
                }
            }
            v
        };
        let sum_mat = |f: &dyn Fn(&Chain) -> &Vec<Vec<u64>>| -> Vec<Vec<u64>> {
            let mut m = vec![vec![0u64; k_models]; k_models];
            for c in chains {
                for (row, crow) in m.iter_mut().zip(f(c)) {
                    for (a, b) in row.iter_mut().zip(crow) {
                        *a += b;
                    }
                }
            }
            m
        };
        // traces: every chain has the same points; sum them
        let trace: Vec<RjTracePoint> = (0..chains[0].trace.len())
            .map(|i| {
                let mut p = RjTracePoint {
                    iteration: 0,
                    visits: vec![0; k_models],
                };
                for c in chains {
                    let q = &c.trace[i];
                    p.iteration += q.iteration;
                    for (a, b) in p.visits.iter_mut().zip(&q.visits) {
                        *a += b;
                    }
                }
                p
            })
            .collect();
        Totals {
            visits: sum_vec(&|c| &c.visits),
            sojourns: sum_vec(&|c| &c.sojourns),
            rw_tried: sum_vec(&|c| &c.rw_tried),
            rw_accepted: sum_vec(&|c| &c.rw_accepted),
            proposed: sum_mat(&|c| &c.proposed),
            accepted: sum_mat(&|c| &c.accepted),
            accepted_post: sum_mat(&|c| &c.accepted_post),
            non_finite: chains.iter().map(|c| c.non_finite).sum(),
            trace,
        }
    }
}

/// The three estimates of a pair from a pool of sums: one code path for the final numbers and
/// for every running point.
struct PairEstimator<'a> {
    prior_p: &'a [f64],
    ln_ratio: &'a [Vec<f64>],
    grid: &'a estimate::Grid,
    boxes: &'a BoxMasses,
}

impl PairEstimator<'_> {
    fn estimates(
        &self,
        pool: &Pool<'_>,
        soj: &Sojourns<'_>,
        a: usize,
        b: usize,
    ) -> estimate::PairEstimates {
        let BoxMasses {
            ln_p: ln_box,
            se: ln_box_se,
            se_g: ln_box_g_se,
            ..
        } = self.boxes;
        (
            estimate::visit_estimate(pool, a, b, self.prior_p, soj),
            estimate::acceptance_estimate(pool, a, b, self.ln_ratio[a][b]),
            estimate::bridge_estimate(
                pool,
                self.grid,
                a,
                b,
                [(ln_box[a], ln_box_se[a]), (ln_box[b], ln_box_se[b])],
                [ln_box_g_se[a], ln_box_g_se[b]],
            ),
        )
    }
}

/// Every pair `a < b`: its estimates, jump counts and a warning when too few jumps were
/// accepted after burn-in.
fn pairs(
    models: &[RjModel<'_>],
    est: &PairEstimator<'_>,
    pool: &Pool<'_>,
    soj: &Sojourns<'_>,
    layout: Layout,
    accepted_post: &[Vec<u64>],
) -> Vec<RjPair> {
    let k_models = models.len();
    let mut pairs = Vec::new();
    for a in 0..k_models {
        for b in a + 1..k_models {
            let effective_jumps = accepted_post[a][b] + accepted_post[b][a];
            let expected_jumps = pool.total.logs[layout.alpha(a, b)].exp()
                + pool.total.logs[layout.alpha(b, a)].exp();
            let warning = (effective_jumps < MIN_EFFECTIVE_JUMPS).then(|| {
                format!(
                    "only {effective_jumps} accepted jumps between `{}` and `{}` after burn-in (< {MIN_EFFECTIVE_JUMPS}): the visit ratio rests on a few sojourns and its error bar is itself uncertain by more than about 20 % (Rao-Blackwell and the bridge average over every proposal and rest on Σα = {expected_jumps:.3e} expected jumps instead); run longer, center the jump proposals on the models' posterior chains (mean, covariance) or raise `defensive`",
                    models[a].name, models[b].name
                )
            });
            let (visits, rao_blackwell, bridge) = est.estimates(pool, soj, a, b);
            pairs.push(RjPair {
                k: a,
                l: b,
                visits,
                rao_blackwell,
                bridge,
                proposals_k_to_l: pool.total.counts[layout.prop(a, b)] as u64,
                proposals_l_to_k: pool.total.counts[layout.prop(b, a)] as u64,
                accepted_k_to_l: accepted_post[a][b],
                accepted_l_to_k: accepted_post[b][a],
                effective_jumps,
                expected_jumps,
                warning,
            });
        }
    }
    pairs
}

type Validated = (Vec<f64>, Vec<Vec<f64>>);

fn validate(models: &[RjModel<'_>], opts: &RjOptions) -> Result<Validated, EvidenceError> {
    let k = models.len();
    if k == 0 || k > u16::MAX as usize {
        return Err(EvidenceError::option(
            "rjmcmc models",
            k,
            "pass between 1 and 65535 models",
        ));
    }
    if opts.n_chains == 0 || opts.n_chains > 4096 {
        return Err(EvidenceError::option(
            "rjmcmc n_chains",
            opts.n_chains,
            "run between 1 and 4096 chains",
        ));
    }
    if !(opts.defensive.is_finite() && (0.0..1.0).contains(&opts.defensive)) {
        return Err(EvidenceError::option(
            "rjmcmc defensive",
            opts.defensive,
            "the prior weight of the jump proposal must be in [0, 1) (0.1 is a good default; 1 would drop the Gaussian part)",
        ));
    }
    let per_chain = opts.n_iter / opts.n_chains;
    if per_chain <= opts.burn_in || per_chain - opts.burn_in < 100 {
        return Err(EvidenceError::option(
            "rjmcmc n_iter",
            opts.n_iter,
            &format!(
                "need at least 100 iterations after burn_in in each of the {} chains (n_iter ≥ n_chains·(burn_in + 100))",
                opts.n_chains
            ),
        ));
    }
    let n_post = per_chain - opts.burn_in;
    if let Some(b) = opts.batch_size
        && (b == 0 || b > n_post / 2)
    {
        return Err(EvidenceError::option(
            "rjmcmc batch_size",
            b,
            "need 1 ≤ batch_size ≤ (n_iter/n_chains − burn_in)/2 so each chain has at least 2 batches",
        ));
    }
    if !(opts.jump_scale.is_finite() && opts.jump_scale > 0.0) {
        return Err(EvidenceError::option(
            "rjmcmc jump_scale",
            opts.jump_scale,
            "c must be finite and > 0 (typically 1–1.5)",
        ));
    }
    if let Some(s) = opts.rw_scale
        && !(s.is_finite() && s > 0.0)
    {
        return Err(EvidenceError::option(
            "rjmcmc rw_scale",
            s,
            "the random-walk scale must be finite and > 0",
        ));
    }
    if let ProposalShape::StudentT { nu } = opts.proposal
        && !(nu.is_finite() && nu > 0.0)
    {
        return Err(EvidenceError::option(
            "rjmcmc proposal nu",
            nu,
            "ν must be finite and > 0",
        ));
    }
    if opts.start_model >= k {
        return Err(EvidenceError::option(
            "rjmcmc start_model",
            opts.start_model,
            &format!("must be < {k}"),
        ));
    }
    let prior_p = match &opts.prior_model_probs {
        None => vec![1.0 / k as f64; k],
        Some(p) => {
            if p.len() != k {
                return Err(EvidenceError::dimension("prior_model_probs", k, p.len()));
            }
            if p.iter().any(|v| !(v.is_finite() && *v > 0.0)) {
                return Err(EvidenceError::option(
                    "rjmcmc prior_model_probs",
                    format!("{p:?}"),
                    "every prior model probability must be finite and > 0",
                ));
            }
            let s: f64 = p.iter().sum();
            p.iter().map(|v| v / s).collect()
        }
    };
    let jump = match &opts.jump {
        JumpRule::UniformOthers => (0..k)
            .map(|a| {
                (0..k)
                    .map(|b| {
                        if k == 1 {
                            1.0
                        } else if a == b {
                            0.0
                        } else {
                            1.0 / (k - 1) as f64
                        }
                    })
                    .collect()
            })
            .collect(),
        JumpRule::UniformAll => vec![vec![1.0 / k as f64; k]; k],
        JumpRule::Matrix(m) => {
            if m.len() != k || m.iter().any(|r| r.len() != k) {
                return Err(EvidenceError::option(
                    "rjmcmc jump matrix",
                    format!("{} rows", m.len()),
                    &format!("pass a {k}×{k} matrix"),
                ));
            }
            for (a, row) in m.iter().enumerate() {
                let s: f64 = row.iter().sum();
                if row.iter().any(|v| !(v.is_finite() && *v >= 0.0)) || (s - 1.0).abs() > 1e-9 {
                    return Err(EvidenceError::option(
                        "rjmcmc jump matrix",
                        format!("row {a} = {row:?}"),
                        "each row must hold probabilities ≥ 0 summing to 1",
                    ));
                }
                for (b, &v) in row.iter().enumerate() {
                    if (v > 0.0) != (m[b][a] > 0.0) {
                        return Err(EvidenceError::option(
                            "rjmcmc jump matrix",
                            format!("j({b}|{a}) = {v}, j({a}|{b}) = {}", m[b][a]),
                            "a jump must be possible in both directions or in neither (reversibility)",
                        ));
                    }
                }
            }
            m.clone()
        }
    };
    for (i, m) in models.iter().enumerate() {
        let d = m.target.dim();
        if m.center.len() != d {
            return Err(EvidenceError::dimension(
                format!("center of model `{}`", m.name),
                d,
                m.center.len(),
            ));
        }
        if m.cov.nrows() != d || m.cov.ncols() != d {
            return Err(EvidenceError::dimension(
                format!("cov rows of model `{}`", m.name),
                d,
                m.cov.nrows().max(m.cov.ncols()),
            ));
        }
        if let Some(v) = m.center.iter().find(|v| !v.is_finite()) {
            return Err(EvidenceError::non_finite(
                format!("center of model `{}`", m.name),
                *v,
                "pass the MAP",
            ));
        }
        if i == opts.start_model {
            let lp = m.target.ln_posterior(&m.center);
            if !lp.is_finite() {
                return Err(EvidenceError::non_finite(
                    format!("ln posterior at the center of start model `{}`", m.name),
                    lp,
                    "the start model's center must lie inside its prior with a finite likelihood",
                ));
            }
        }
    }
    Ok((prior_p, jump))
}

fn prepare<'a>(
    models: &[RjModel<'a>],
    opts: &RjOptions,
) -> Result<Vec<Prepared<'a>>, EvidenceError> {
    let c2 = opts.jump_scale * opts.jump_scale;
    models
        .iter()
        .map(|m| {
            let d = m.target.dim();
            if d == 0 {
                return Ok(Prepared {
                    target: m.target,
                    dim: 0,
                    center: vec![],
                    lq: vec![],
                    ln_q_norm: 0.0,
                    lrw: vec![],
                });
            }
            let chol = SpdOptions::default()
                .names(m.target.prior().names())
                .factor(&m.cov)
                .map_err(EvidenceError::matrix(
                    format!("proposal covariance of model `{}`", m.name),
                    "pass the inverse Fisher matrix or another positive-definite posterior covariance",
                ))?;
            let l = chol.l_row_major();
            let ln_det_sigma = chol.ln_det();
            let ln_det_q = ln_det_sigma + d as f64 * c2.ln();
            let df = d as f64;
            let ln_q_norm = match opts.proposal {
                ProposalShape::Gaussian => -0.5 * df * (2.0 * PI).ln() - 0.5 * ln_det_q,
                ProposalShape::StudentT { nu } => {
                    ln_gamma(0.5 * (nu + df))
                        - ln_gamma(0.5 * nu)
                        - 0.5 * df * (nu * PI).ln()
                        - 0.5 * ln_det_q
                }
            };
            let s = opts.rw_scale.unwrap_or(2.38 / df.sqrt());
            Ok(Prepared {
                target: m.target,
                dim: d,
                center: m.center.clone(),
                lq: l.iter().map(|v| v * opts.jump_scale).collect(),
                ln_q_norm,
                lrw: l.iter().map(|v| v * s).collect(),
            })
        })
        .collect()
}

/// `ln P_k(box)` of each jump proposal and its standard error.
/// Box masses of the jump proposals: the mixture's and the Gaussian/t part's, with errors.
struct BoxMasses {
    ln_p: Vec<f64>,
    se: Vec<f64>,
    ln_p_g: Vec<f64>,
    se_g: Vec<f64>,
}

fn box_masses(prepared: &[Prepared<'_>], opts: &RjOptions) -> Result<BoxMasses, EvidenceError> {
    let mut out = BoxMasses {
        ln_p: Vec::with_capacity(prepared.len()),
        se: Vec::with_capacity(prepared.len()),
        ln_p_g: Vec::with_capacity(prepared.len()),
        se_g: Vec::with_capacity(prepared.len()),
    };
    let mut push = |ln_pg: f64, se_g: f64| {
        let (lp, s) = defensive_mass(ln_pg, se_g, opts.defensive);
        out.ln_p.push(lp);
        out.se.push(s);
        out.ln_p_g.push(ln_pg);
        out.se_g.push(se_g);
    };
    let mut mc_rng = Xoshiro256PlusPlus::seed_from_u64(opts.seed);
    mc_rng.long_jump();
    for m in prepared {
        let d = m.dim;
        let kinds = m.target.prior().kinds();
        let bounded: Vec<usize> = (0..d)
            .filter(|&i| {
                let (lo, hi) = kinds[i].bounds();
                lo.is_finite() || hi.is_finite()
            })
            .collect();
        if bounded.is_empty() {
            push(0.0, 0.0);
            continue;
        }
        match opts.proposal {
            ProposalShape::Gaussian => {
                let mut cov = DMatrix::zeros(d, d);
                for i in 0..d {
                    for j in 0..=i {
                        cov[(i, j)] = (0..=j).map(|r| m.lq[i * d + r] * m.lq[j * d + r]).sum();
                        cov[(j, i)] = cov[(i, j)];
                    }
                }
                let sub = cov.select_rows(&bounded).select_columns(&bounded);
                let lo: Vec<f64> = bounded.iter().map(|&i| kinds[i].bounds().0).collect();
                let hi: Vec<f64> = bounded.iter().map(|&i| kinds[i].bounds().1).collect();
                let mean: Vec<f64> = bounded.iter().map(|&i| m.center[i]).collect();
                let p = mvn_rectangle(&lo, &hi, &mean, &sub, &opts.box_mass)?;
                push(p.ln_p, p.ln_p_std_err);
            }
            ProposalShape::StudentT { nu } => {
                let n = 1usize << 16;
                let chi2 = ChiSquared::new(nu).map_err(|_| {
                    EvidenceError::option("proposal nu", nu, "ν must be finite and > 0")
                })?;
                let mut x = vec![0.0; d];
                let mut z = vec![0.0; d];
                let mut hits = 0usize;
                for _ in 0..n {
                    for zi in z.iter_mut() {
                        *zi = StandardNormal.sample(&mut mc_rng);
                    }
                    let s = (nu / chi2.sample(&mut mc_rng)).sqrt();
                    for (i, xi) in x.iter_mut().enumerate() {
                        let row = &m.lq[i * d..i * d + i + 1];
                        *xi = m.center[i] + s * row.iter().zip(&z).map(|(a, b)| a * b).sum::<f64>();
                    }
                    if m.target.prior().contains(&x) {
                        hits += 1;
                    }
                }
                let p = hits as f64 / n as f64;
                let s = if hits > 0 {
                    ((1.0 - p) / (p * n as f64)).sqrt()
                } else {
                    f64::INFINITY
                };
                push(p.ln(), s);
            }
        }
    }
    Ok(out)
}

/// `ln[(1 − w)·P_g + w]` and its error from `ln P_g ± se`: the mixture's box mass (the prior
/// part has mass 1 in its own support). With `w = 0` the inputs are returned unchanged.
fn defensive_mass(ln_pg: f64, se: f64, w: f64) -> (f64, f64) {
    if w == 0.0 {
        return (ln_pg, se);
    }
    let a = (1.0 - w).ln() + ln_pg;
    let ln_p = estimate::lae(a, w.ln());
    // d ln P / d ln P_g = (1 − w)P_g / P
    let s = if se.is_finite() {
        (a - ln_p).exp() * se
    } else {
        // no Gaussian mass measured: P ∈ [w, 1]
        0.5 * (-w.ln())
    };
    (ln_p, s)
}
