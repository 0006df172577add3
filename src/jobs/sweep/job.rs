//! `occam sweep` end to end: the request as the command line (or Python) states it, the
//! executor it runs on, the run directory held on the root rank, the resume check, and the
//! published outputs. `main.rs` only parses, prints and draws the progress bar.

use super::grid;
use super::study::{Sweep, SweepArgs, SweepResult};
use crate::data::rundir::RunDir;
use crate::jobs::exec::Executor;
use crate::jobs::progress::Work;
use std::path::PathBuf;

/// What the user asked of a sweep.
#[derive(Debug, Clone, Default)]
pub struct SweepRequest {
    /// The study file with `[[select.model]]` tables.
    pub study: PathBuf,
    /// Axes replacing `[[sweep.axis]]`: `KEY=v1,v2,…`, `KEY=log:FROM:TO:N`, `KEY=lin:FROM:TO:N`.
    pub axes: Vec<String>,
    /// Shorthand for an axis `simulation.target_snr=…`.
    pub snr: Option<Vec<f64>>,
    /// Noise realisations per point (default: `[sweep] realisations`, else 1).
    pub realisations: Option<usize>,
    /// The `[[select.model]]` that generated the data.
    pub truth: Option<String>,
    /// Output directory (default `<output>/sweep`).
    pub output: Option<PathBuf>,
    /// Stop when the run directory holds no finished task of this sweep.
    pub resume: bool,
    /// `[select]` keys set for every point (`--target-error`, `--cross-checks`).
    pub select: Vec<(&'static str, toml::Value)>,
}

/// A sweep ready to run: the plan, the run directory (held on the root only) and what to tell
/// the user before it starts.
pub struct PlannedSweep {
    /// The grid, the models and the point studies.
    pub sweep: Sweep,
    run: Option<RunDir>,
    /// Warnings about the sweep's set-up (the root prints them).
    pub warnings: Vec<String>,
    /// Lines for the user before the run (what is resumed, the size of the job).
    pub lines: Vec<String>,
}

/// What a finished sweep published.
pub struct SweepDone {
    /// Every point's estimates and bands.
    pub result: SweepResult,
    /// The text table of the result.
    pub table: String,
    /// The files published into the run directory.
    pub written: Vec<String>,
}

impl SweepDone {
    /// The tasks' warnings for the terminal, as `warning: …` lines: a line counting their
    /// kinds, then each kind once with how many tasks raised it and the first
    /// ([`crate::report::group_run_warnings`]); none without warnings. Every one is in
    /// `sweep.json` and the report of `out`.
    pub fn warning_lines(&self, out: &std::path::Path) -> Vec<String> {
        let runs: Vec<(String, Vec<String>)> = self
            .result
            .records
            .iter()
            .map(|r| {
                let w = r.outcome.as_ref().map(|o| o.warnings.clone());
                (r.id.label(), w.unwrap_or_default())
            })
            .collect();
        let kinds = crate::report::group_run_warnings(&runs, "tasks");
        if kinds.is_empty() {
            return kinds;
        }
        let mut lines = vec![format!(
            "warning: the tasks raised {} kind(s) of warning, each once below with how many tasks raised it; every one is in sweep.json and the report (occam report {})",
            kinds.len(),
            out.display()
        )];
        lines.extend(kinds.into_iter().map(|k| format!("warning: {k}")));
        lines
    }
}

/// Where a job's tasks run. With the `mpi` feature, under `mpirun -n N` (N > 1) the tasks are
/// spread over the N ranks, each running its share on `threads` threads (0 there means 1: one
/// rank per core is how `mpirun` places ranks); otherwise on `threads` threads of this process
/// (0: one per core). Only the root (`is_root()`) prints summaries and writes aggregate files.
pub fn executor(threads: usize) -> anyhow::Result<Box<dyn Executor>> {
    #[cfg(feature = "mpi")]
    if let Some(mpi) = crate::jobs::mpi::Mpi::init()? {
        return Ok(Box::new(mpi.with_threads(threads.max(1))?));
    }
    Ok(Box::new(crate::jobs::exec::Threads::new(threads)?))
}

/// Loads the sweep of a request and holds its run directory (on the root rank).
pub fn plan(req: &SweepRequest, exec: &dyn Executor) -> anyhow::Result<PlannedSweep> {
    let mut axes = req
        .axes
        .iter()
        .map(|a| grid::parse_axis(a))
        .collect::<anyhow::Result<Vec<_>>>()?;
    if let Some(snr) = &req.snr {
        let list: Vec<String> = snr.iter().map(|v| v.to_string()).collect();
        axes.push(grid::parse_axis(&format!(
            "simulation.target_snr={}",
            list.join(",")
        ))?);
    }
    let args = SweepArgs {
        axes: (!axes.is_empty()).then_some(axes),
        realisations: req.realisations,
        truth: req.truth.clone(),
        output: req.output.clone(),
        select: req.select.clone(),
    };
    let sweep = Sweep::load(&req.study, args)?;
    // one run per directory; under MPI the root holds it for every rank
    let run = if exec.is_root() {
        Some(RunDir::open(&sweep.out)?)
    } else {
        None
    };
    let mut lines = Vec::new();
    if req.resume {
        let (done, started) = (sweep.finished_tasks(), sweep.started_tasks());
        if done == 0 && started == 0 {
            anyhow::bail!(
                "--resume: there is nothing to resume in {}: no finished or started task of this sweep in {}/tasks; run without --resume",
                sweep.out.display(),
                sweep.out.display()
            );
        }
        lines.push(format!(
            "resuming from {}/tasks: {done} of {} tasks finished, {started} started (continued from their checkpoints)",
            sweep.out.display(),
            sweep.task_count()
        ));
    }
    lines.push(format!(
        "sweep of {}: {} point(s) × {} realisation(s) = {} tasks on {} worker(s), into {}",
        req.study.display(),
        sweep.grid.len(),
        sweep.realisations,
        sweep.task_count(),
        exec.workers(),
        sweep.out.display()
    ));
    Ok(PlannedSweep {
        warnings: sweep.warnings.clone(),
        sweep,
        run,
        lines,
    })
}

/// Runs the planned sweep's tasks (reusing every finished one) and, on the root, publishes
/// the outputs; other ranks return `None`. `log` sees one line per task.
pub fn run(
    planned: PlannedSweep,
    exec: &dyn Executor,
    log: Option<&(dyn Fn(&str) + Sync)>,
    work: Option<&Work>,
) -> anyhow::Result<Option<SweepDone>> {
    let PlannedSweep { sweep, run, .. } = planned;
    let Some(result) = sweep.run_observed(exec, log, work)? else {
        return Ok(None);
    };
    let table = super::output::table(&sweep, &result);
    let run = run.expect("the root holds the run directory");
    let written = super::output::publish(&sweep, &result, &run)?;
    Ok(Some(SweepDone {
        result,
        table,
        written,
    }))
}
