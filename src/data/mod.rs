//! Users' own data: where an experiment's time series come from when they are read rather
//! than simulated ([`DataSource`]), and the checks shared by every reader (a uniformly sampled
//! time column, [`uniform_rate`]).
//!
//! The on-disk dataset format written by `occam simulate` lives in [`crate::data::dataset`].

pub mod checkpoint;
mod csv_write;
pub mod dataset;
mod error;
mod fnv;
pub mod gaps;
pub mod infile;
pub mod memory;
pub mod npz;
pub mod npz_write;
pub mod rundir;
pub mod source;
mod time_column;

pub use fnv::Fnv1a;
pub use memory::{memory_budget, memory_budget_bytes};
pub use source::DataSource;
pub use time_column::{TIME_TOLERANCE, time_grid, uniform_rate};
