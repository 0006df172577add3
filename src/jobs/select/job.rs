//! `occam select` as a [`Job`]: prepare the data, run every model's stages and the reversible
//! jump with checkpoints, write Table II, the figures and the samples.

use super::checkpoint::{FILE as CHECKPOINT_FILE, SelectCheckpoint};
use super::output::{LEGACY_OUTPUTS, write_outputs};
use super::run::{Checkpointing, run_observed};
use super::stage::{self, FILE as STAGE_FILE};
use super::summary::SelectSummary;
use crate::config::Study;
use crate::evidence::RjProgress;
use crate::jobs::job::{Context, Job};
use crate::jobs::prepare::identity;
use anyhow::Context as _;
use std::path::Path;

/// The select job of a study's `[[select.model]]` models.
pub struct Select<'a, 'r> {
    /// The study.
    pub study: &'a Study,
    /// Sees the reversible-jump run's visits as it goes.
    pub on_rj: Option<&'r mut dyn FnMut(&RjProgress<'_>)>,
}

impl Job for Select<'_, '_> {
    type Outcome = SelectSummary;
    const COMMAND: &'static str = "select";
    const LEGACY_OUTPUTS: &'static [&'static str] = LEGACY_OUTPUTS;

    /// Saves each finished stage to `checkpoint.cbor` and the stage in progress to
    /// `stage.cbor` (continuing from them with `ctx.resume`, an error when there is no
    /// checkpoint); the work counters count likelihood evaluations of every stage.
    fn run(&mut self, ctx: &Context) -> anyhow::Result<SelectSummary> {
        let (study, out) = (self.study, ctx.out);
        let ckpt_path = out.join(CHECKPOINT_FILE);
        if ctx.resume && !ckpt_path.exists() {
            anyhow::bail!(
                "--resume: there is nothing to resume in {}: it has no {}; run without --resume",
                out.display(),
                CHECKPOINT_FILE
            );
        }
        let prep = crate::jobs::prepare::prepare_select(study)
            .with_context(|| format!("preparing the data of {}", study.source))?;
        let identity = identity(study, &prep.dataset);
        crate::jobs::run_identity::check_or_record(
            study,
            &prep.dataset,
            out,
            ctx.resume,
            CHECKPOINT_FILE,
        )?;
        let state = if ctx.resume {
            let c = SelectCheckpoint::read(&ckpt_path, &identity)?;
            let names: Vec<String> = study.select_models.iter().map(|m| m.name.clone()).collect();
            (ctx.log)(&format!(
                "resuming from {}: {}",
                ckpt_path.display(),
                c.describe(&names)
            ));
            let stage = out.join(STAGE_FILE);
            if let Ok((_, id)) = crate::data::checkpoint::head(&stage)
                && let Some(what) = id.strip_prefix(&format!("{identity}/"))
            {
                (ctx.log)(&format!(
                    "and the stage in progress from {}: {what}",
                    stage.display()
                ));
            }
            c
        } else {
            // a stage file of an earlier run in this directory must not be resumed
            let _ = std::fs::remove_file(out.join(STAGE_FILE));
            SelectCheckpoint::new(identity)
        };
        let state = match stage::every_from_env()? {
            Some(every) => state.save_stage_every(every),
            None => state,
        };
        (ctx.log)(&crate::jobs::prepare::data_line(&prep));
        for line in crate::jobs::prepare::noise_averages_lines(study, &prep.likelihood) {
            (ctx.log)(&line);
        }
        let ckpt = Checkpointing {
            path: &ckpt_path,
            state,
        };
        let on_rj = self.on_rj.take();
        Ok(run_observed(study, &prep, on_rj, ctx.work, Some(ckpt))?)
    }

    fn write(&self, summary: &SelectSummary, staging: &Path, run_dir: &Path) -> anyhow::Result<()> {
        write_outputs(summary, staging)?;
        crate::config::write_resolved(self.study, staging, run_dir)?;
        Ok(())
    }
}
