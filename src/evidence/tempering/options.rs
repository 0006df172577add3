//! The options of a tempering run and their validation.

use crate::evidence::error::EvidenceError;
use serde::{Deserialize, Serialize};

/// Prior draws used to choose the initial `β_1`.
pub(crate) const N_PILOT: usize = 256;
/// Initial step size `κ₀` of the ladder adaptation (in `ln ΔT` per unit swap-rate difference).
pub(crate) const LADDER_KAPPA: f64 = 0.5;

/// States kept per rung in [`TemperingResult::rung_samples`](super::TemperingResult::rung_samples).
pub const SNAPSHOTS: usize = 8;

/// Options of [`run_tempering`](super::run_tempering).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
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

/// Checks the options before anything runs.
pub(crate) fn validate(opts: &TemperingOptions) -> Result<(), EvidenceError> {
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
