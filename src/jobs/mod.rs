//! Jobs that own a run directory and spread independent tasks over workers: today the sweep
//! (`occam sweep`); the executors are shared with the jobs that follow.

pub mod exec;
#[cfg(feature = "mpi")]
pub mod mpi;
pub mod sweep;
