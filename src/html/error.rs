//! [`ReportError`]: why a report cannot be written.

use crate::data::rundir::{MANIFEST, RunDirError};
use std::path::{Path, PathBuf};

/// Why a report cannot be written.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    #[error(
        "{} is not an occam run directory (no manifest.json); {hint}",
        dir.display()
    )]
    NotARun {
        /// The directory given.
        dir: PathBuf,
        /// What to give instead: the runs inside it (a study's output directory holds one per
        /// command), else the general rule.
        hint: String,
    },
    #[error("{file}: {msg}")]
    File { file: PathBuf, msg: String },
    #[error(transparent)]
    RunDir(#[from] RunDirError),
}

/// The run directories directly inside `dir` (a study's output directory holds its
/// simulation and one run per command: `fit/`, `select/`), sorted.
pub fn runs_inside(dir: &Path) -> Vec<PathBuf> {
    let mut runs: Vec<PathBuf> = std::fs::read_dir(dir)
        .into_iter()
        .flatten()
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.join(MANIFEST).is_file())
        .collect();
    runs.sort();
    runs
}

impl ReportError {
    /// `dir` is not a run; the hint names the run directories directly inside it, if any.
    pub fn not_a_run(dir: &Path) -> ReportError {
        let runs: Vec<String> = runs_inside(dir)
            .iter()
            .map(|p| format!("`{}`", p.display()))
            .collect();
        let hint = if runs.is_empty() {
            "give the directory a fit/select/sweep wrote".to_string()
        } else {
            format!("it holds the runs {}: give one of them", runs.join(", "))
        };
        ReportError::NotARun {
            dir: dir.to_path_buf(),
            hint,
        }
    }
}
