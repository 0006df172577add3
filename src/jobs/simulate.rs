//! `occam simulate`: the study's experiments → `dataset.npz` + `dataset.json` (and, asked, the
//! same as CSV files that `[[experiment]] data = "…"` reads back).

use super::job::{Context, Job};
use crate::config::Study;
use crate::experiment::Simulation;
use anyhow::Context as _;
use std::path::Path;

/// The simulate job of a study.
pub struct Simulate<'a> {
    /// The study whose experiments are simulated.
    pub study: &'a Study,
    /// Also write every experiment as CSV ([`crate::data::dataset::Dataset::write_csv`]):
    /// `<experiment>.csv` and `<experiment>_noise.csv`.
    pub csv: bool,
}

impl Job for Simulate<'_> {
    type Outcome = Simulation;
    const COMMAND: &'static str = "simulate";
    const LEGACY_OUTPUTS: &'static [&'static str] = &["dataset.npz", "dataset.json"];

    fn run(&mut self, ctx: &Context) -> anyhow::Result<Simulation> {
        let plan = self.study.simulation_plan();
        let progress = |done: u64, total: u64| {
            if let Some(w) = ctx.work {
                if done == 0 {
                    w.start(total);
                } else {
                    w.done.store(done, std::sync::atomic::Ordering::Relaxed);
                }
            }
        };
        crate::experiment::simulate_observed(&plan, Some(&progress))
            .with_context(|| format!("simulating {}", self.study.source))
    }

    fn write(&self, sim: &Simulation, staging: &Path, _run_dir: &Path) -> anyhow::Result<()> {
        sim.dataset.write(staging)?;
        if self.csv {
            sim.dataset.write_csv(staging)?;
        }
        Ok(())
    }
}
