//! `occam select`: Bayes factors between nested models with every estimator side by side
//! (reversible jump, Laplace–Fisher raw and box-corrected, Laplace–Metropolis with MVE and
//! MCD, Schwarz), the paper's Table II layout, the evolution of B (Fig. 2) and the model-visit
//! histogram (Fig. 4).
//!
//! No estimator's failure ends a run: each per-model stage (`model.rs`) and each row of a pair
//! (`pair.rs`) that cannot apply carries a note saying why, and every other estimator still
//! reports.

mod checkpoint;
mod console;
mod error;
mod estimates;
mod header;
mod job;
mod model;
mod outcome;
mod output;
mod pair;
mod plan;
mod run;
mod stage;
mod summary;
mod target;

pub use crate::jobs::prepare::identity;
pub use checkpoint::{FILE as CHECKPOINT_FILE, SelectCheckpoint};
pub use stage::{FILE as STAGE_FILE, every_from_env as stage_every_from_env};

pub use console::console;
pub use error::SelectError;
pub use estimates::ParamEstimate;
pub use header::{estimates_table, header};
pub use job::Select;
pub use outcome::{Evidence, ModelOutcome, TemperingDiagnostics};
pub use output::{
    Fig2, LEGACY_OUTPUTS, chains_file, document, fig2, fig2_warnings, rj_chain_arrays, table,
    table_notes, write_outputs,
};
pub use pair::{EstimateKind, JumpStats, PairEstimate, PairResult};
pub use run::{Checkpointing, run, run_checkpointed, run_observed, work_units};
pub use summary::SelectSummary;
pub use target::{TargetOutcome, TargetRound};
