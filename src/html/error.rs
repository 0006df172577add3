//! [`ReportError`]: why a report cannot be written.

use crate::data::rundir::RunDirError;
use std::path::PathBuf;

/// Why a report cannot be written.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    #[error(
        "{0} is not an occam run directory (no manifest.json); give the directory a fit/select/sweep wrote"
    )]
    NotARun(PathBuf),
    #[error("{file}: {msg}")]
    File { file: PathBuf, msg: String },
    #[error(transparent)]
    RunDir(#[from] RunDirError),
}
