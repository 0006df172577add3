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
//! | `independence` | [`StudentProposal`], the independence kernel mixed into the walk ([`Independence`]) |
//! | `anneal` | LTPDA's heat schedule β(n) and search-jump scales (ltp-model.md §9.1) |
//! | `adapt` | Haario-style covariance adaptation, burn-in only |
//! | `chain` | one chain's state and the allocation-free hot loop; per-chain RNG streams |
//! | `driver` | the one loop of every sampler: blocks, progress, checkpoints, stopping |
//! | `mh` | Metropolis–Hastings chains on the driver: rayon over chains, observer, checkpoint |
//! | `chains` | the output: [`Chains`] |
//! | `diagnostics` | ESS, integrated autocorrelation time, split-R̂, [`Warning`]s |
//! | `checkpoint` | atomic JSON checkpoints and their match against the run |
//! | `optimize` | bounded Nelder–Mead with restarts, [`find_map`] |
//! | `starts` | dispersed chain starts inside the prior around a MAP, [`chain_starts`] |
//! | `until` | running until converged (ESS and R̂ per parameter) in place of a fixed length, [`Until`] |
//! | `birth_death` | reversible-jump birth and death of optional components (glitches), [`birth_death()`] |
//!
//! # Conventions
//! * Natural logs throughout; the acceptance test uses `ln π + ln L`, never χ².
//! * Iterations are numbered `n = 1, 2, …, n_iter` per chain. Iterations `n ≤ burn_in` are
//!   discarded; afterwards every `thin`-th state is kept.
//! * Chain `c` draws from its own stream, [`chain_rng`]`(seed, c)`, so the numbers do not depend
//!   on how many threads run the chains.

mod adapt;
mod anneal;
mod birth_death;
mod bits;
mod chain;
mod chains;
mod checkpoint;
pub use checkpoint::{KIND as CHECKPOINT_KIND, progress as checkpoint_progress};
mod diagnostics;
mod driver;
mod error;
mod independence;
mod mh;
mod optimize;
mod proposal;
mod settings;
mod starts;
mod until;

#[cfg(test)]
pub(crate) mod test_targets;
#[cfg(test)]
mod tests;

pub use birth_death::{
    BATCHES, BirthDeathOptions, BirthDeathResult, Component, FEW_SWITCHES, Moves, birth_death,
};
pub use chain::{Progress, chain_rng};
pub use chains::{BestPoint, Chain, ChainCounts, Chains, MaxPosterior, PhaseCounts};
pub use diagnostics::{Diagnostics, Thresholds, Warning, ess, split_rhat};
pub use driver::{Driver, Ended, Sampler};
pub use error::SamplerError;
pub use independence::{DEFAULT_DOF, Independence, StudentProposal};
pub use mh::{MetropolisHastings, RunOutcome};
pub use optimize::{MapEstimate, Minimum, NelderMeadSettings, find_map, nelder_mead};
pub use proposal::{GaussianProposal, Proposal, cap_to_prior};
pub use settings::{Adapt, Anneal, MhSettings, Start};
pub use starts::chain_starts;
pub use until::Until;
