//! `occam report RUN_DIR`: one self-contained HTML page of a finished fit, select or sweep
//! run, drawn from the files the run published ([`crate::html`]).

use std::path::{Path, PathBuf};

/// Writes the report of `run_dir` to `output` (default `RUN_DIR/report.html`) and returns the
/// path written.
pub fn run(run_dir: &Path, output: Option<&Path>) -> anyhow::Result<PathBuf> {
    Ok(crate::html::write_report(run_dir, output)?)
}
