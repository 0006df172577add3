//! Every job of occam — simulate, fit, select, sweep, design, report, demo — behind one
//! contract, and the machinery they share: run directories, progress, logs, checkpoints and
//! executors (threads, MPI). The command line and the Python package call these and nothing
//! else.
//!
//! The contract ([`Job`]): a job is built from the study (its plan of plain values),
//! [`Job::run`]s with a [`Context`] (the run directory, whether to resume, the log and the
//! work counters), and [`Job::write`]s its outcome into the staging directory; [`execute`]
//! holds the run directory, runs, stages and publishes the files together (see
//! [`crate::data::rundir`]). The sweep spreads tasks over an executor and holds its run
//! directory only on the root rank, so it keeps its own driver ([`sweep`]); the design search
//! writes several studies ([`design`]).

mod analysis_error;
pub mod bode;
pub mod chains_npz;
pub mod demo;
pub mod design;
mod error_text;
pub mod exec;
pub mod fit;
pub mod glitch_count;
pub mod glitch_model;
pub mod init;
pub mod injection_bias;
mod job;
mod map_search;
#[cfg(feature = "mpi")]
pub mod mpi;
#[cfg(any(test, feature = "mpi"))]
mod mpi_wire;
pub mod noise_point;
pub mod own_noise;
pub mod prepare;
pub mod progress;
pub mod raw_data;
pub mod report;
pub mod run_identity;
pub mod sampled;
pub mod select;
pub mod simulate;
pub mod sweep;
pub mod validity;

pub use error_text::error_text;
pub use job::{Context, Done, Job, Log, execute};
pub use progress::Work;
