//! `occam fit` as a [`Job`]: prepare the data, run the sampler with checkpoints, write the
//! Table I layout, chains and plots.

use super::output::{LEGACY_OUTPUTS, write_outputs};
use super::run::{CHECKPOINT_FILE, run};
use super::summary::FitOutcome;
use crate::config::Study;
use crate::jobs::job::{Context, Job};
use anyhow::Context as _;
use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};

/// The fit job of a study's `[fit]` model.
pub struct Fit<'a> {
    /// The study.
    pub study: &'a Study,
}

/// What the fit job computed.
pub struct Fitted {
    /// The fit (summary, chains, MAP, Fisher matrix).
    pub outcome: FitOutcome,
    /// Where the data came from (a path, or "simulated from `<study>`").
    pub origin: String,
}

impl Job for Fit<'_> {
    type Outcome = Fitted;
    const COMMAND: &'static str = "fit";
    const LEGACY_OUTPUTS: &'static [&'static str] = LEGACY_OUTPUTS;

    /// Fits with checkpoints in `ctx.out` (continuing from one with `ctx.resume`, an error when
    /// there is none); the work counters count MCMC iterations over all chains.
    fn run(&mut self, ctx: &Context) -> anyhow::Result<Fitted> {
        let (study, out) = (self.study, ctx.out);
        if ctx.resume {
            let ckpt = out.join(CHECKPOINT_FILE);
            if !ckpt.exists() && out.join("checkpoint.json").exists() {
                anyhow::bail!(
                    "--resume: {} holds checkpoint.json, the checkpoint of an earlier occam (JSON), which this one cannot continue; run without --resume",
                    out.display()
                );
            }
            if !ckpt.exists() {
                anyhow::bail!(
                    "--resume: there is nothing to resume in {}: it has no {CHECKPOINT_FILE}; run without --resume",
                    out.display()
                );
            }
            let (done, total) = crate::sampler::checkpoint_progress(&ckpt)?;
            (ctx.log)(&format!(
                "resuming from {}: iterations done per chain {done:?} of {total}",
                ckpt.display()
            ));
        }
        let prep = crate::jobs::prepare::prepare(study)
            .with_context(|| format!("preparing the data of {}", study.source))?;
        (ctx.log)(&crate::jobs::prepare::data_line(&prep));
        for line in crate::jobs::prepare::noise_averages_lines(study, &prep.likelihood) {
            (ctx.log)(&line);
        }
        crate::jobs::run_identity::check_or_record(
            study,
            &prep.dataset,
            out,
            ctx.resume,
            CHECKPOINT_FILE,
        )?;
        let chains = study.fit.chains;
        let counts: Vec<AtomicU64> = (0..chains).map(|_| AtomicU64::new(0)).collect();
        if let Some(w) = ctx.work {
            w.start((study.fit.iterations * chains) as u64);
        }
        let work = ctx.work;
        let observer = |p: &crate::sampler::Progress| {
            if let Some(w) = work {
                counts[p.chain].store(p.iteration as u64, Ordering::Relaxed);
                let done: u64 = counts.iter().map(|c| c.load(Ordering::Relaxed)).sum();
                w.done.store(done, Ordering::Relaxed);
            }
        };
        let stop = |_: usize| crate::jobs::progress::stop_requested(work);
        let outcome = run(study, &prep, out, Some(&observer), Some(&stop), ctx.resume);
        // the chains stopped at a block's end with their checkpoint saved
        if outcome.is_err() && crate::jobs::progress::stop_requested(work) {
            return Err(crate::jobs::progress::Interrupted.into());
        }
        let outcome = outcome?;
        Ok(Fitted {
            outcome,
            origin: prep.origin,
        })
    }

    fn write(&self, fitted: &Fitted, staging: &Path, run_dir: &Path) -> anyhow::Result<()> {
        write_outputs(&fitted.outcome, staging)?;
        crate::config::write_resolved(self.study, staging, run_dir)?;
        Ok(())
    }
}
