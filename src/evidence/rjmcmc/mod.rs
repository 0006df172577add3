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
//! chains stream per batch and per regeneration unit (nothing per iteration is stored). Three
//! estimates of the variance are formed and the largest is used:
//! * **batch means** over `a = ⌊N/b⌋` batches of `b = ⌊√N⌋` iterations per chain (N =
//!   post-burn-in iterations of a chain; Flegal & Jones 2010), batches of all chains pooled:
//!   `Var(ū) ≈ b/(A−1)·Σ_j (ū_j − ū)² / N_tot`. Consistent when `b` is much longer than the
//!   chain's memory — which fails exactly when jumps are rare and the chain sits in one model for
//!   whole batches;
//! * **regenerative**: the run cut at every entry into the start model; `Var(ū) ≈
//!   A/(A−1)·Σ_c (U_c − ū n_c)²/N_tot²` over those cycles (sums `U_c` over `n_c` iterations).
//!   Entries are approximate regenerations (the entry state is a fresh proposal draw), so this
//!   sees correlations of any length within a sojourn;
//! * **jackknife** over the same units: the estimate recomputed from the pooled sums without
//!   unit `c`, `θ̂₍c₎`, for every `c`; `Var ≈ (A−1)/A·Σ_c (θ̂₍c₎ − θ̄)²` (Iglehart 1975 for
//!   regenerative ratio estimators; beyond 1024 units, groups of consecutive units are deleted
//!   instead). The first two linearise the estimate (a log of ratios of sums) about its value;
//!   with a few dozen units that is short, because the estimate is curved over the range the
//!   units move it and the α's and bridge terms of a poorly matched proposal are skewed. Measured on 400 linear-Gaussian problems with ≈ 36 accepted jumps
//!   (≈ 17 units) each, the linearised errors covered 0.57–0.60 at 1σ, the jackknife's 0.70;
//!   with hundreds of units the three agree. Each leave-one-out estimate takes the form its
//!   pool calls for: where the left-out unit held all of a direction's proposals (a model
//!   entered in one sojourn), the Rao-Blackwell and bridge estimates without it are the
//!   one-sided ones, so the spread shows how much rests on that sojourn (a test with one or two
//!   accepted jumps: misses of 4–62 σ became 1.2–1.6 σ). It needs at least 3 units and a finite
//!   estimate without each of them (otherwise only the other two estimates — and for the visit
//!   ratio its floor below — apply).
//!
//! **Unseen rejections.** A model entered in a few sojourns, every jump back out of it
//! accepted: its `m` proposals all have α = 1, and no estimate built from them can see the
//! share of proposals that would be rejected (the defensive mixture's prior draws, a tail of
//! `g`). Measured on linear-Gaussian problems (ln B ≈ +9, defensive weight 0.1, 1 600 seeds),
//! those runs missed by `−ln 0.9 ≈ 0.1` nat with errors of ± 0.01. So the Rao-Blackwell and
//! bridge variances are floored at `Σ 1/(m + 1)²` over the directions with proposals: the
//! shift in the log of a mean of `m` non-negative terms that one more proposal with a zero
//! term would make (`1/m` is also the Jeffreys 84 % bound on a rate seen zero times in `m`
//! trials). Unseen *high* terms are not floored: their share is what the accepted jumps count,
//! and the informative direction (many tiny, equal α) legitimately stays precise. With `m` in
//! the thousands the floor is below 10⁻³ nat. On those 1 600 seeds the RB/bridge 1σ coverage by
//! accepted jumps, 3–10 / 10–30 / 30–100, went from 0.18 / 0.47 / 0.69 to 0.95 / 0.82 / 0.69 (a
//! floor cannot know the unseen rate, so it over-covers where `m` is smallest).
//!
//! **Visit ratio.** Its information is the number of sojourns, not of iterations: for a
//! chain that leaves k and l with per-iteration probabilities `a_k, a_l`, `Var(ln N_k/N_l) =
//! (1/m_k + 1/m_l)(1 − (a_k+a_l)/2)` (m: sojourns; for two models `2(2 − a − β)/n_switch`, the
//! two-state Markov chain's asymptotic variance). Leave probabilities that vary with θ make the
//! sojourn lengths mixtures of geometrics, with a larger coefficient of variation, so this is a
//! floor: the visit error is `max(batch means, regenerative, jackknife, floor)`, and grows as `2/√n` with
//! `n` accepted jumps however many iterations were run.
//!
//! **Rao-Blackwell and bridge** average over *proposals*, not accepted jumps: every iteration
//! contributes a fresh `θ' ~ q` and the current `θ`. Their precision is limited by (i) how
//! evenly the acceptance probabilities / bridge terms are spread (a mean of `α ∈ [0, 1]` has
//! relative variance ≤ `1/Σα`, reached when α is 0 or 1; when the unvisited model's proposals
//! are informative, e.g. α ≈ B for all of them, it is far smaller) and (ii) how many
//! independent `θ` of each model the chain has seen, which within a sojourn is the random walk's
//! mixing and across sojourns the number of sojourns. Both are what the variance estimates
//! measure; neither is a count of accepted jumps, so no jump-count floor is imposed on them — a
//! floor would wrongly inflate the informative-proposal case, where they legitimately stay
//! precise with no accepted jump at all. (The unseen-rejection floor above counts proposals,
//! not jumps, and vanishes in that case.)
//!
//! **Warning.** Each pair reports its effective independent jumps (accepted jumps between the
//! two after burn-in) and warns below [`MIN_EFFECTIVE_JUMPS`] = 30: with n jumps the
//! regenerative estimate has about n/2 cycles, so the error bar itself is uncertain by
//! `1/√(2·(n/2 − 1)) ≈ 20 %` at n = 30 and more below.
//!
//! # Memory
//! Per chain: the batch sums (`⌊√N⌋` batches × `K + K²(4 + 11)` numbers), at most 1024
//! regeneration units of the same size, the pilot's raw bridge inputs (≤ 2¹⁷ records, freed after
//! the pilot) and the trace (`N / trace_every` points). After the run, the jackknife's
//! leave-one-out sums: at most 1024 groups of consecutive units (2 × 1024 sums), whatever the
//! number of chains. Nothing else grows with N.
//!
//! The Student-t box masses draw from `seed_from_u64(seed)` advanced by one `long_jump()`
//! (2¹⁹² steps: beyond every chain's stream).
//!
//! [`mvn_rectangle`]: crate::evidence::mvn_rectangle

mod bridge;
pub(crate) use bridge::fixed_point;
mod chain;
mod estimate;
mod logsum;
mod options;
mod pairs;
mod prepare;
mod result;
mod run;
mod tail;
#[cfg(test)]
mod tests;

pub use options::{JumpRule, MIN_EFFECTIVE_JUMPS, ProposalShape, RjModel, RjOptions};
pub use result::{
    MAX_RUNNING_POINTS, RjDraws, RjPair, RjProgress, RjResult, RjRunningPair, RjRunningPoint,
    RjTracePoint, union_columns,
};
pub use run::{KIND, ReversibleJump, RjOutcome, run_rjmcmc};
pub use tail::reciprocal_khat;
