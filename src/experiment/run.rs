//! The simulator's entry points: the built-in LTP loop (`simulate.rs`), or the study's own
//! model when the plan has a generator (`model_sim.rs`).

use super::gaps::apply as apply_gaps;
use super::model_sim::simulate_model;
use super::simulate::{SimError, SimProgress, Simulation, SimulationPlan, simulate_builtin};

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
