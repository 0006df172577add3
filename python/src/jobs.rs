//! `occam.simulate`, `occam.fit`, `occam.select`, `occam.sweep`, `occam.design` and
//! `occam.report`: the command line's jobs ([`occam::jobs`]: run-directory lock, staging,
//! manifest). They return the run directory and the lines the command line prints; the Python
//! package reads the outputs from the directory.
//!
//! A job runs on a worker thread with the GIL released while the calling thread polls Python's
//! signals and hands the job's [`Work`] counters to a Python callback (the package draws the
//! progress bar). On Ctrl-C the callback's thread asks the job to stop ([`Work::request_stop`]):
//! it stops at its next safe point with its checkpoint kept, and the call raises
//! `KeyboardInterrupt`.

use crate::occam_error;
use occam::config::Study;
use occam::jobs::Work;
use pyo3::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// How often the calling thread checks for Ctrl-C and reports progress.
const POLL: Duration = Duration::from_millis(100);

/// The lines a job logs, collected for the result's `log`.
#[derive(Default)]
struct Lines(Mutex<Vec<String>>);

impl Lines {
    fn push(&self, l: &str) {
        self.0
            .lock()
            .expect("no panic holds the lock")
            .push(l.to_string());
    }

    fn extend<I: IntoIterator<Item = String>>(&self, ls: I) {
        self.0.lock().expect("no panic holds the lock").extend(ls);
    }

    fn take(self) -> Vec<String> {
        self.0.into_inner().expect("no panic holds the lock")
    }
}

/// `dir/{a, b, …}`: the files a run published, as the command line lists them.
fn listing(dir: &Path, names: &[String]) -> String {
    format!("{}/{{{}}}", dir.display(), names.join(", "))
}

/// Runs `job` on a worker thread without the GIL. Every [`POLL`] the calling thread runs
/// Python's signal handlers and calls `progress(done, total)` (when given); a
/// `KeyboardInterrupt` (or any exception of the callback) asks the job to stop and is raised
/// once the job has returned.
fn run_watched<T: Send>(
    py: Python<'_>,
    progress: Option<&Bound<'_, PyAny>>,
    job: impl FnOnce(&Work) -> anyhow::Result<T> + Send,
) -> PyResult<T> {
    let work = Work::default();
    let mut raised: Option<PyErr> = None;
    // owned: the watching loop runs without the GIL and takes it back to call
    let callback: Option<Py<PyAny>> = progress.map(|cb| cb.clone().unbind());
    let out = py.detach(|| {
        std::thread::scope(|s| {
            let worker = s.spawn(|| job(&work));
            let mut last = (u64::MAX, u64::MAX);
            while !worker.is_finished() {
                std::thread::sleep(POLL);
                if raised.is_some() {
                    continue;
                }
                let now = work.get();
                let checked = Python::attach(|py| {
                    py.check_signals()?;
                    if let Some(cb) = &callback
                        && now != last
                    {
                        cb.bind(py).call1(now)?;
                    }
                    Ok::<(), PyErr>(())
                });
                last = now;
                if let Err(e) = checked {
                    work.request_stop();
                    raised = Some(e);
                }
            }
            worker.join()
        })
    });
    let out = match out {
        Ok(r) => r,
        Err(_) => {
            return Err(pyo3::exceptions::PyRuntimeError::new_err(
                "occam: the job's thread panicked (a bug of occam: please report it)",
            ));
        }
    };
    match (out, raised) {
        // Ctrl-C (or the callback's exception) wins even over a job that finished meanwhile
        // (one without a safe point to stop at, such as the design search): its files are
        // published, and the user asked to stop
        (_, Some(e)) => Err(e),
        (Ok(v), None) => {
            if let Some(cb) = progress {
                let (_, total) = work.get();
                cb.call1((total, total))?;
            }
            Ok(v)
        }
        (Err(e), None) => Err(occam_error(e)),
    }
}

/// `occam simulate STUDY [-o OUTPUT]`: (run directory, log lines).
#[pyfunction]
#[pyo3(signature = (path, output=None, progress=None))]
pub fn simulate(
    py: Python<'_>,
    path: PathBuf,
    output: Option<PathBuf>,
    progress: Option<Bound<'_, PyAny>>,
) -> PyResult<(PathBuf, Vec<String>)> {
    run_watched(py, progress.as_ref(), |work| {
        let study = Study::load(&path)?;
        let out = output.unwrap_or_else(|| study.output.clone());
        let lines = Lines::default();
        let log = |l: &str| lines.push(l);
        let ctx = occam::jobs::Context {
            out: &out,
            resume: false,
            log: &log,
            work: Some(work),
        };
        let done = occam::jobs::execute(
            &mut occam::jobs::simulate::Simulate {
                study: &study,
                csv: false,
            },
            &ctx,
        )?;
        lines.push(&format!("wrote {}", listing(&out, &done.written)));
        Ok((out, lines.take()))
    })
}

/// `occam fit STUDY [-o OUTPUT] [--resume]`: (run directory, log lines).
#[pyfunction]
#[pyo3(signature = (path, output=None, resume=false, progress=None))]
pub fn fit(
    py: Python<'_>,
    path: PathBuf,
    output: Option<PathBuf>,
    resume: bool,
    progress: Option<Bound<'_, PyAny>>,
) -> PyResult<(PathBuf, Vec<String>)> {
    run_watched(py, progress.as_ref(), |work| {
        let t0 = Instant::now();
        let study = Study::load(&path)?;
        let out = output.unwrap_or_else(|| study.output.join("fit"));
        let lines = Lines::default();
        let log = |l: &str| lines.push(l);
        let ctx = occam::jobs::Context {
            out: &out,
            resume,
            log: &log,
            work: Some(work),
        };
        let done = occam::jobs::execute(&mut occam::jobs::fit::Fit { study: &study }, &ctx)?;
        let s = &done.outcome.outcome.summary;
        lines.extend(occam::jobs::fit::console(s, &study));
        lines.extend(note_lines(&s.notes));
        lines.extend(warning_lines(&s.warnings));
        lines.push(&format!("wrote {}", listing(&out, &done.written)));
        lines.push(&format!("took {:.1} s", t0.elapsed().as_secs_f64()));
        Ok((out, lines.take()))
    })
}

/// The notes as the command line prints them to standard output: each as it is.
fn note_lines(notes: &[String]) -> impl Iterator<Item = String> + '_ {
    notes.iter().map(|n| format!("note: {n}"))
}

/// The warnings as the command line prints them to standard error: repeats merged.
fn warning_lines(warnings: &[String]) -> impl Iterator<Item = String> {
    occam::report::group_warnings(warnings)
        .into_iter()
        .map(|w| format!("warning: {w}"))
}

/// `occam select STUDY [-o OUTPUT] [--resume]`: (run directory, log lines: every line the
/// command line prints, its table and verdicts included).
#[pyfunction]
#[pyo3(signature = (path, output=None, resume=false, progress=None))]
pub fn select(
    py: Python<'_>,
    path: PathBuf,
    output: Option<PathBuf>,
    resume: bool,
    progress: Option<Bound<'_, PyAny>>,
) -> PyResult<(PathBuf, Vec<String>)> {
    run_watched(py, progress.as_ref(), |work| {
        let t0 = Instant::now();
        let study = Study::load(&path)?;
        let out = output.unwrap_or_else(|| study.output.join("select"));
        let lines = Lines::default();
        let log = |l: &str| lines.push(l);
        let ctx = occam::jobs::Context {
            out: &out,
            resume,
            log: &log,
            work: Some(work),
        };
        let mut job = occam::jobs::select::Select {
            study: &study,
            on_rj: None,
        };
        let done = occam::jobs::execute(&mut job, &ctx)?;
        let s = &done.outcome;
        // each line as `println!` prints it (a trailing newline is a blank line)
        lines.extend(
            occam::jobs::select::console(s)
                .split('\n')
                .map(str::to_string),
        );
        lines.extend(note_lines(&s.notes));
        lines.extend(warning_lines(&s.warnings));
        lines.push(&format!("wrote {}", listing(&out, &done.written)));
        lines.push(&format!("took {:.1} s", t0.elapsed().as_secs_f64()));
        Ok((out, lines.take()))
    })
}

/// `occam sweep STUDY [--axis …] [--realisations R] [--truth M] [-o OUTPUT] [--resume]`:
/// (run directory, log lines).
#[pyfunction]
#[pyo3(signature = (path, output=None, resume=false, axes=None, realisations=None, truth=None, threads=0, progress=None))]
#[allow(clippy::too_many_arguments)]
pub fn sweep(
    py: Python<'_>,
    path: PathBuf,
    output: Option<PathBuf>,
    resume: bool,
    axes: Option<Vec<String>>,
    realisations: Option<usize>,
    truth: Option<String>,
    threads: usize,
    progress: Option<Bound<'_, PyAny>>,
) -> PyResult<(PathBuf, Vec<String>)> {
    use occam::jobs::sweep::{SweepRequest, executor, plan, run_request};
    run_watched(py, progress.as_ref(), |work| {
        let t0 = Instant::now();
        let exec = executor(threads)?;
        let req = SweepRequest {
            study: path,
            axes: axes.unwrap_or_default(),
            snr: None,
            realisations,
            truth,
            output,
            resume,
            select: Vec::new(),
        };
        let planned = plan(&req, exec.as_ref())?;
        let out = planned.sweep.out.clone();
        let lines = Lines::default();
        let (before, size) = planned.lines.split_at(planned.lines.len() - 1);
        lines.extend(before.iter().cloned());
        lines.extend(warning_lines(&planned.warnings));
        lines.extend(size.iter().cloned());
        let log = |l: &str| lines.push(l);
        let done = run_request(planned, exec.as_ref(), Some(&log), Some(work))?
            .ok_or_else(|| anyhow::anyhow!("the sweep ran on no root process"))?;
        lines.extend(done.table.lines().map(str::to_string));
        lines.extend(done.warning_lines(&out));
        lines.push(&format!("wrote {}", listing(&out, &done.written)));
        lines.push(&format!(
            "{} task(s) computed, {} reused; took {:.1} s",
            done.result.computed,
            done.result.reused,
            t0.elapsed().as_secs_f64()
        ));
        Ok((out, lines.take()))
    })
}

/// `occam design STUDY [-o OUTPUT] [--validate R]`: (run directory, log lines). `validate`:
/// `None` no validation, `0` the study's `[design] realisations`, `R` that many.
#[pyfunction]
#[pyo3(signature = (path, output=None, validate=None, progress=None))]
pub fn design(
    py: Python<'_>,
    path: PathBuf,
    output: Option<PathBuf>,
    validate: Option<usize>,
    progress: Option<Bound<'_, PyAny>>,
) -> PyResult<(PathBuf, Vec<String>)> {
    run_watched(py, progress.as_ref(), |_| {
        let study = Study::load(&path)?;
        let out = output.unwrap_or_else(|| study.output.join("design"));
        let v = validate.map(|r| (r > 0).then_some(r));
        let r = occam::jobs::design::run_cli(&path, Some(out.clone()), v)?;
        let lines = occam::jobs::design::table(&r)
            .split('\n')
            .map(str::to_string)
            .collect();
        Ok((out, lines))
    })
}

/// `occam report RUN_DIR [-o OUTPUT]`: the HTML file written.
#[pyfunction]
#[pyo3(signature = (run_dir, output=None))]
pub fn report(py: Python<'_>, run_dir: PathBuf, output: Option<PathBuf>) -> PyResult<PathBuf> {
    run_watched(py, None, |_| {
        occam::jobs::report::run(&run_dir, output.as_deref())
    })
}
