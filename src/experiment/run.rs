//! The simulator's entry points: the built-in LTP loop (`simulate.rs`), or the study's own
//! model when the plan has a generator (`model_sim.rs`).

use super::gaps::apply as apply_gaps;
use super::glitches::{Glitch, draw_experiment, force_series};
use super::model_sim::simulate_model;
use super::simulate::{
    SimError, SimProgress, Simulation, SimulationPlan, System, TELEMETRY_CHANNELS, simulate_builtin,
};
use crate::data::dataset::ExperimentData;

/// Simulates every experiment of the plan: the fit stretch (response + noise) and the
/// noise-only stretch. Experiment `j` draws its fit noise from stream `2j` and its noise-only
/// stretch from stream `2j + 1` of the seed.
pub fn simulate(plan: &SimulationPlan) -> Result<Simulation, SimError> {
    simulate_observed(plan, None)
}

/// [`simulate`], reporting finished experiments to `progress` (for a progress bar).
pub fn simulate_observed(
    plan: &SimulationPlan,
    progress: Option<SimProgress>,
) -> Result<Simulation, SimError> {
    let mut sim = match &plan.generator {
        Some(g) => simulate_model(plan, g, progress),
        None => simulate_builtin(plan, progress),
    }?;
    if let Some(g) = &plan.glitches {
        if plan.generator.is_some() {
            return Err(SimError::Other(
                "study".into(),
                "[simulation.glitches] needs the built-in LTP loop, not a `[simulation] model`"
                    .into(),
            ));
        }
        let mut record = serde_json::Map::new();
        for (j, e) in sim.dataset.experiments.iter_mut().enumerate() {
            let (fit, noise) =
                draw_experiment(g, e.n_samples(), e.n_noise_samples(), e.fs, plan.seed, j);
            add_glitches(e, plan.system_of(j), &fit, &noise)
                .map_err(|m| SimError::Other(e.name.clone(), m))?;
            if !(fit.is_empty() && noise.is_empty()) {
                record.insert(
                    e.name.clone(),
                    serde_json::json!({ "fit": fit, "noise": noise }),
                );
            }
        }
        // absent when nothing was drawn, so that a glitch-free dataset is unchanged
        if !record.is_empty()
            && let Some(o) = sim.dataset.extra.as_object_mut()
        {
            o.insert("glitches".into(), serde_json::Value::Object(record));
        }
    }
    // glitches before gaps: a gap blanks whatever the read-out held
    // gaps come last and from their own stream: the noise is the same with and without them
    for (j, (e, d)) in sim
        .dataset
        .experiments
        .iter_mut()
        .zip(&plan.experiments)
        .enumerate()
    {
        apply_gaps(e, d, plan.gaps.as_ref(), plan.seed, j)
            .map_err(|m| SimError::Other(e.name.clone(), m))?;
    }
    Ok(sim)
}

/// Adds the loop's response to the glitches `fit` (fit stretch) and `noise` (noise-only
/// stretch) to the read-outs and the telemetry of `e` ([`System::glitch_response`]). No
/// channel records the glitches themselves.
fn add_glitches(
    e: &mut ExperimentData,
    sys: &System,
    fit: &[Glitch],
    noise: &[Glitch],
) -> Result<(), String> {
    let fs = e.fs;
    for (glitches, is_fit) in [(fit, true), (noise, false)] {
        if glitches.is_empty() {
            continue;
        }
        let n = if is_fit {
            e.n_samples()
        } else {
            e.n_noise_samples()
        };
        let a = force_series(glitches, n, fs);
        let (o, g) = sys
            .glitch_response([&a[0], &a[1]], fs)
            .map_err(|x| x.to_string())?;
        let (outs, tele) = if is_fit {
            (&mut e.o, &mut e.extra)
        } else {
            (&mut e.noise, &mut e.noise_extra)
        };
        for (dst, src) in outs.iter_mut().zip(&o) {
            for (x, d) in dst.iter_mut().zip(src) {
                *x += d;
            }
        }
        for (name, src) in TELEMETRY_CHANNELS.iter().zip(&g) {
            if let Some(dst) = tele.get_mut(*name) {
                for (x, d) in dst.iter_mut().zip(src) {
                    *x += d;
                }
            }
        }
    }
    Ok(())
}
