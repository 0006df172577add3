//! `occam report RUN_DIR`: a run directory as one self-contained HTML page — the tables, the
//! figures inline as SVG, the diagnostics, every warning and the resolved study — that opens
//! in any browser without a network and needs no script.
//!
//! The page is written atomically while holding the run directory's lock (so it never mixes
//! two runs' files), and added to the run's `manifest.json`, so that the command's next run
//! removes the stale report with its other old outputs.

mod error;
mod escape;
mod fit;
mod fmt;
mod page;
mod parts;
mod run;
mod select;
mod sweep;
mod table;
mod warnings;

pub use error::{ReportError, runs_inside};
pub use escape::{esc, inline_svg};
pub use run::{MAX_INLINE_BYTES, RESOLVED_STUDY, Run, RunKind};

use crate::data::rundir::{MANIFEST, RunDir};
use std::path::{Path, PathBuf};

/// The report's default file name inside the run directory.
pub const REPORT: &str = "report.html";

/// Writes the report of the run in `run_dir` to `out` (default `run_dir/report.html`) and
/// returns its path. A report inside the run directory is added to its manifest.
pub fn write_report(run_dir: &Path, out: Option<&Path>) -> Result<PathBuf, ReportError> {
    if !run_dir.is_dir() {
        return Err(ReportError::not_a_run(run_dir));
    }
    // refuse a non-run before taking the lock: the lock file would be created in a directory
    // that is none of occam's
    if !run_dir.join(MANIFEST).is_file()
        && !run_dir.join("summary.json").is_file()
        && !run_dir.join("sweep.json").is_file()
    {
        return Err(ReportError::not_a_run(run_dir));
    }
    let path = out.map_or_else(|| run_dir.join(REPORT), Path::to_path_buf);
    let lock = RunDir::lock(run_dir)?;
    let run = Run::read(run_dir)?;
    // the name the report has inside the run directory, if it goes there
    let inside = inside_name(run_dir, &path);
    if let Some(name) = &inside {
        let own = run.files.iter().any(|(n, _)| n == name) && name != REPORT;
        if own || name == MANIFEST || name == RESOLVED_STUDY {
            return Err(ReportError::File {
                file: path,
                msg: "is one of the run's own files; write the report elsewhere (-o FILE)".into(),
            });
        }
    }
    let html = page::render(&run);
    crate::atomic::write_bytes(&path, html.as_bytes()).map_err(|e| ReportError::File {
        file: path.clone(),
        msg: format!("cannot write the report: {e}"),
    })?;
    if let Some(name) = inside {
        lock.record(&name)?;
    }
    Ok(path)
}

/// The file name of `path` when it lies directly in `dir` (compared after resolving links and
/// `..`), else `None`.
fn inside_name(dir: &Path, path: &Path) -> Option<String> {
    let name = path.file_name()?.to_string_lossy().into_owned();
    let parent = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let (a, b) = (dir.canonicalize().ok()?, parent.canonicalize().ok()?);
    (a == b).then_some(name)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_report_path_is_inside_the_run_only_when_its_directory_is_the_run() {
        let t = tempfile::tempdir().unwrap();
        let d = t.path().join("run");
        std::fs::create_dir_all(d.join("sub")).unwrap();
        assert_eq!(
            inside_name(&d, &d.join("r.html")).as_deref(),
            Some("r.html")
        );
        assert_eq!(
            inside_name(&d, &d.join("sub/../x.html")).as_deref(),
            Some("x.html")
        );
        assert_eq!(inside_name(&d, &d.join("sub/x.html")), None);
        assert_eq!(inside_name(&d, &t.path().join("x.html")), None);
        assert_eq!(inside_name(&d, &t.path().join("missing/x.html")), None);
    }
}
