//! `occam sweep`: model selection over a grid of study keys with noise realisations per
//! point (the paper's Fig. 5 and Fig. 6).
//!
//! A sweep is a list of tasks, one per (grid point, realisation). Task `t` is point
//! `t / R`, realisation `t % R`; its study is the base study file with the swept keys set
//! ([`grid::set_key`]) and the seed [`grid::task_seed`] of (run seed, point values, realisation),
//! so its numbers do not depend on which worker runs it or in what order. Each finished task is
//! written atomically to `tasks/<hash>.cbor` (a checkpoint, [`crate::data::checkpoint`]) in the run directory; a rerun reuses every task
//! whose file matches it exactly ([`record::TaskRecord::load`]), so a killed sweep loses only
//! the tasks in flight. The outputs (`sweep.json`, `sweep.npz`, table, plots) are written when
//! every task is done.

pub mod grid;
mod job;
pub mod output;
mod plots;
pub mod record;
pub mod stats;
mod study;

pub use job::{PlannedSweep, SweepDone, SweepRequest, executor, plan, run as run_request};
pub use output::{LEGACY_OUTPUTS, publish, write_outputs};
pub use study::{DEFAULT_SNRS, Sweep, SweepArgs, SweepResult};
