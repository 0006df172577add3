//! `occam.simulate`, `occam.fit`, `occam.select`: the command line's jobs
//! ([`occam::jobs`]: run-directory lock, staging, manifest), run with the GIL released.
//! They return the run directory and the lines the command line would print while running;
//! the Python package reads the outputs from the directory.

use crate::occam_error;
use occam::config::Study;
use pyo3::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// Which job.
#[derive(Clone, Copy)]
enum Job {
    Simulate,
    Fit,
    Select,
}

/// Loads the study and runs `job` into `output` (default as on the command line: the study's
/// `output`, `<output>/fit`, `<output>/select`): the run directory and the logged lines.
fn run(
    job: Job,
    path: &Path,
    output: Option<PathBuf>,
    resume: bool,
) -> anyhow::Result<(PathBuf, Vec<String>)> {
    let study = Study::load(path)?;
    let out = output.unwrap_or_else(|| match job {
        Job::Simulate => study.output.clone(),
        Job::Fit => study.output.join("fit"),
        Job::Select => study.output.join("select"),
    });
    let lines = Mutex::new(Vec::new());
    let log = |l: &str| {
        lines
            .lock()
            .expect("no panic holds the lock")
            .push(l.to_string())
    };
    let ctx = occam::jobs::Context {
        out: &out,
        resume,
        log: &log,
        work: None,
    };
    match job {
        Job::Simulate => {
            occam::jobs::execute(&mut occam::jobs::simulate::Simulate { study: &study }, &ctx)?;
        }
        Job::Fit => {
            occam::jobs::execute(&mut occam::jobs::fit::Fit { study: &study }, &ctx)?;
        }
        Job::Select => {
            let mut job = occam::jobs::select::Select {
                study: &study,
                on_rj: None,
            };
            occam::jobs::execute(&mut job, &ctx)?;
        }
    }
    Ok((out, lines.into_inner().expect("no panic holds the lock")))
}

fn run_py(
    py: Python<'_>,
    job: Job,
    path: PathBuf,
    output: Option<PathBuf>,
    resume: bool,
) -> PyResult<(PathBuf, Vec<String>)> {
    py.detach(|| run(job, &path, output, resume))
        .map_err(occam_error)
}

/// `occam simulate STUDY [-o OUTPUT]`: (run directory, log lines).
#[pyfunction]
#[pyo3(signature = (path, output=None))]
pub fn simulate(
    py: Python<'_>,
    path: PathBuf,
    output: Option<PathBuf>,
) -> PyResult<(PathBuf, Vec<String>)> {
    run_py(py, Job::Simulate, path, output, false)
}

/// `occam fit STUDY [-o OUTPUT] [--resume]`: (run directory, log lines).
#[pyfunction]
#[pyo3(signature = (path, output=None, resume=false))]
pub fn fit(
    py: Python<'_>,
    path: PathBuf,
    output: Option<PathBuf>,
    resume: bool,
) -> PyResult<(PathBuf, Vec<String>)> {
    run_py(py, Job::Fit, path, output, resume)
}

/// `occam select STUDY [-o OUTPUT] [--resume]`: (run directory, log lines).
#[pyfunction]
#[pyo3(signature = (path, output=None, resume=false))]
pub fn select(
    py: Python<'_>,
    path: PathBuf,
    output: Option<PathBuf>,
    resume: bool,
) -> PyResult<(PathBuf, Vec<String>)> {
    run_py(py, Job::Select, path, output, resume)
}
