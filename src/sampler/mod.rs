//! Markov-chain Monte Carlo and MAP search on any [`LogDensity`](crate::density::LogDensity).
//!
//! The layout follows emcee and argmin: small capability traits ([`Proposal`] returns its log
//! Hastings ratio; the target is a [`LogDensity`](crate::density::LogDensity)) and one driver,
//! [`MetropolisHastings`], that owns the loop, progress reports, checkpoints and stopping.
//!
//! | module | job |
//! |---|---|
//! | `settings` | [`MhSettings`], [`Anneal`], [`Adapt`], [`Start`] and their validation |
//! | `proposal` | [`Proposal`] trait, [`GaussianProposal`] (Cholesky-factored once) |
//! | `anneal` | LTPDA's heat schedule β(n) and search-jump scales (ltp-model.md §9.1) |
//! | `adapt` | Haario-style covariance adaptation, burn-in only |
//! | `chain` | one chain's state and the allocation-free hot loop; per-chain RNG streams |
//! | `driver` | the one loop of every sampler: blocks, progress, checkpoints, stopping |
//! | `mh` | Metropolis–Hastings chains on the driver: rayon over chains, observer, checkpoint |
//! | `chains` | the output: [`Chains`] |
//! | `diagnostics` | ESS, integrated autocorrelation time, split-R̂, [`Warning`]s |
//! | `checkpoint` | atomic JSON checkpoints and their match against the run |
//! | `optimize` | bounded Nelder–Mead with restarts, [`find_map`] |
//!
//! # Conventions
//! * Natural logs throughout; the acceptance test uses `ln π + ln L`, never χ².
//! * Iterations are numbered `n = 1, 2, …, n_iter` per chain. Iterations `n ≤ burn_in` are
//!   discarded; afterwards every `thin`-th state is kept.
//! * Chain `c` draws from its own stream, [`chain_rng`]`(seed, c)`, so the numbers do not depend
//!   on how many threads run the chains.

mod adapt;
mod anneal;
mod bits;
mod chain;
mod chains;
mod checkpoint;
pub use checkpoint::{KIND as CHECKPOINT_KIND, progress as checkpoint_progress};
mod diagnostics;
mod driver;
mod mh;
mod optimize;
mod proposal;
mod settings;

#[cfg(test)]
mod test_targets;
#[cfg(test)]
mod tests;

pub use chain::{Progress, chain_rng};
pub use chains::{BestPoint, Chain, ChainCounts, Chains, MaxPosterior, PhaseCounts};
pub use diagnostics::{Diagnostics, Thresholds, Warning, ess, split_rhat};
pub use driver::{Driver, Ended, Sampler};
pub use mh::{MetropolisHastings, RunOutcome};
pub use optimize::{MapEstimate, Minimum, NelderMeadSettings, find_map, nelder_mead};
pub use proposal::{GaussianProposal, Proposal};
pub use settings::{Adapt, Anneal, MhSettings, Start};

use std::path::PathBuf;

/// Everything that can go wrong in this module. Each message names the offending field or
/// input and what to do about it.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SamplerError {
    /// A run setting is out of range.
    #[error("sampler setting `{field}`: {problem}")]
    Setting {
        /// The setting, e.g. `burn_in` or `anneal.tc2`.
        field: &'static str,
        /// What is wrong and how to fix it.
        problem: String,
    },
    /// The proposal covariance is unusable.
    #[error("proposal covariance: {problem}")]
    Covariance {
        /// What is wrong and how to fix it.
        problem: String,
    },
    /// A chain's start point is unusable.
    #[error("start point of chain {chain}: {problem}")]
    Start {
        /// Chain index.
        chain: usize,
        /// What is wrong and how to fix it.
        problem: String,
    },
    /// A checkpoint could not be written, read or parsed.
    #[error("checkpoint `{}`: {problem}", path.display())]
    Checkpoint {
        /// The checkpoint file.
        path: PathBuf,
        /// What went wrong.
        problem: String,
    },
    /// A checkpoint was written by a different run.
    #[error(
        "checkpoint `{}` does not match this run: {field} is {in_checkpoint} in the checkpoint \
         but {in_run} in this run; resume with the settings and target the checkpoint was \
         written with, or start a new run",
        path.display()
    )]
    CheckpointMismatch {
        /// The checkpoint file.
        path: PathBuf,
        /// What differs, e.g. `seed` or `dimension`.
        field: &'static str,
        /// Value stored in the checkpoint.
        in_checkpoint: String,
        /// Value of this run.
        in_run: String,
    },
    /// Sample storage with inconsistent shapes.
    #[error("chains: {problem}")]
    Chains {
        /// What is inconsistent.
        problem: String,
    },
    /// Diagnostics cannot be computed from the given draws.
    #[error("diagnostics: {problem}")]
    Diagnostics {
        /// What is wrong and how to fix it.
        problem: String,
    },
    /// The optimiser was given unusable input.
    #[error("Nelder–Mead: {problem}")]
    Optimizer {
        /// What is wrong and how to fix it.
        problem: String,
    },
}
