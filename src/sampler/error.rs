//! [`SamplerError`]: everything that can go wrong in the sampler.

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
