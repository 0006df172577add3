//! The jobs behind `occam simulate`, `fit` and `select`, shared by the command line and the
//! Python package: one code path that opens the run directory (lock, staging), computes,
//! publishes the outputs together and returns what it computed. Callers print; these
//! functions only report through [`Log`] and the work counters.

use crate::config::Study;
use crate::rundir::RunDir;
use anyhow::{Context, Result};
use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};

/// Where a job reports lines a user should see while it runs (what is resumed, where the
/// data come from). The command line prints them; Python drops or logs them.
pub type Log<'a> = &'a dyn Fn(&str);

/// How far a job is: `done` of `total` units of work, readable from another thread (a
/// progress bar polls it). A unit is one likelihood evaluation of a sampler (fit, select) or
/// one experiment (simulate).
#[derive(Debug, Default)]
pub struct Work {
    /// Units finished so far.
    pub done: AtomicU64,
    /// Units the job will do in all (0 until the job knows it).
    pub total: AtomicU64,
}

impl Work {
    /// Sets the total and clears what is done.
    pub fn start(&self, total: u64) {
        self.done.store(0, Ordering::Relaxed);
        self.total.store(total, Ordering::Relaxed);
    }

    /// `(done, total)` now.
    pub fn get(&self) -> (u64, u64) {
        (
            self.done.load(Ordering::Relaxed),
            self.total.load(Ordering::Relaxed),
        )
    }
}

/// What [`simulate`] made and wrote.
pub struct Simulated {
    /// The simulation (dataset, designs after SNR scaling, ρ_opt).
    pub sim: crate::experiment::Simulation,
    /// The files published into the run directory.
    pub written: Vec<String>,
}

/// What `simulate` wrote before `manifest.json` existed (see [`RunDir::publish`]).
const LEGACY_SIMULATE: &[&str] = &["dataset.npz", "dataset.json"];

/// Simulates the study's experiments and writes `dataset.npz` + `dataset.json` into `out`.
pub fn simulate(study: &Study, out: &Path, work: Option<&Work>) -> Result<Simulated> {
    let run = RunDir::open(out)?;
    let sim = crate::experiment::simulate_observed(study, work)
        .with_context(|| format!("simulating {}", study.source))?;
    sim.dataset.write(&run.staging()?)?;
    let written = run.publish("simulate", LEGACY_SIMULATE)?;
    Ok(Simulated { sim, written })
}

/// What [`fit`] computed and wrote.
pub struct Fitted {
    /// The fit (summary, chains, MAP, Fisher matrix).
    pub outcome: crate::fit::FitOutcome,
    /// Where the data came from (a path, or "simulated from <study>").
    pub origin: String,
    /// The files published into the run directory.
    pub written: Vec<String>,
}

/// Fits the study's `[fit]` model into `out` (checkpointing while it runs; continuing from the
/// checkpoint with `resume`, an error when there is none). `work` counts MCMC iterations over
/// all chains.
pub fn fit(
    study: &Study,
    out: &Path,
    resume: bool,
    log: Log,
    work: Option<&Work>,
) -> Result<Fitted> {
    let run = RunDir::open(out)?;
    if resume {
        let ckpt = out.join("checkpoint.json");
        if !ckpt.exists() {
            anyhow::bail!(
                "--resume: there is nothing to resume in {}: it has no checkpoint.json; run without --resume",
                out.display()
            );
        }
        let (done, total) = crate::sampler::checkpoint_progress(&ckpt)?;
        log(&format!(
            "resuming from {}: iterations done per chain {done:?} of {total}",
            ckpt.display()
        ));
    }
    let prep = crate::analysis::prepare(study)
        .with_context(|| format!("preparing the data of {}", study.source))?;
    log(&format!(
        "data: {} ({} experiments, {} bins in band)",
        prep.origin,
        prep.dataset.experiments.len(),
        prep.likelihood.n_bins()
    ));
    let chains = study.fit.chains;
    let counts: Vec<AtomicU64> = (0..chains).map(|_| AtomicU64::new(0)).collect();
    if let Some(w) = work {
        w.start((study.fit.iterations * chains) as u64);
    }
    let observer = |p: &crate::sampler::Progress| {
        if let Some(w) = work {
            counts[p.chain].store(p.iteration as u64, Ordering::Relaxed);
            let done: u64 = counts.iter().map(|c| c.load(Ordering::Relaxed)).sum();
            w.done.store(done, Ordering::Relaxed);
        }
    };
    let outcome = crate::fit::run(study, &prep, out, Some(&observer), resume)?;
    // one staging directory: asking for it again starts it afresh
    let staged = run.staging()?;
    crate::fit::write_outputs(&outcome, &staged)?;
    crate::config::write_resolved(study, &staged)?;
    let written = run.publish("fit", crate::fit::LEGACY_OUTPUTS)?;
    Ok(Fitted {
        outcome,
        origin: prep.origin,
        written,
    })
}

/// What [`select`] computed and wrote.
pub struct Selected {
    /// Every estimator's Bayes factors and the diagnostics.
    pub summary: crate::select::SelectSummary,
    /// The files published into the run directory.
    pub written: Vec<String>,
}

/// Runs model selection between the study's `[[select.model]]` models into `out`, saving each
/// finished stage to `checkpoint.cbor` (and continuing from it with `resume`, an error when
/// there is none). `work` counts likelihood evaluations of every stage; `on_rj` sees the
/// reversible-jump run's visits as it goes.
pub fn select(
    study: &Study,
    out: &Path,
    resume: bool,
    log: Log,
    work: Option<&Work>,
    on_rj: Option<&mut dyn FnMut(&crate::evidence::RjProgress<'_>)>,
) -> Result<Selected> {
    let run = RunDir::open(out)?;
    let ckpt_path = out.join(crate::select::CHECKPOINT_FILE);
    if resume && !ckpt_path.exists() {
        anyhow::bail!(
            "--resume: there is nothing to resume in {}: it has no {}; run without --resume",
            out.display(),
            crate::select::CHECKPOINT_FILE
        );
    }
    let prep = crate::analysis::prepare(study)
        .with_context(|| format!("preparing the data of {}", study.source))?;
    let identity = crate::select::identity(study, &prep.dataset);
    let state = if resume {
        let c = crate::select::SelectCheckpoint::read(&ckpt_path, &identity)?;
        let names: Vec<String> = study.select_models.iter().map(|m| m.name.clone()).collect();
        log(&format!(
            "resuming from {}: {}",
            ckpt_path.display(),
            c.describe(&names)
        ));
        c
    } else {
        crate::select::SelectCheckpoint::new(identity)
    };
    log(&format!(
        "data: {} ({} experiments, {} bins in band)",
        prep.origin,
        prep.dataset.experiments.len(),
        prep.likelihood.n_bins()
    ));
    let ckpt = crate::select::Checkpointing {
        path: &ckpt_path,
        state,
    };
    let summary = crate::select::run_observed(study, &prep, on_rj, work, Some(ckpt))?;
    // one staging directory: asking for it again starts it afresh
    let staged = run.staging()?;
    crate::select::write_outputs(&summary, &staged)?;
    crate::config::write_resolved(study, &staged)?;
    let written = run.publish("select", crate::select::LEGACY_OUTPUTS)?;
    Ok(Selected { summary, written })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn work_starts_from_zero_with_its_total() {
        let w = Work::default();
        assert_eq!(w.get(), (0, 0));
        w.done.store(5, Ordering::Relaxed);
        w.start(40);
        assert_eq!(w.get(), (0, 40));
    }
}
