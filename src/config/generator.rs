//! Validation of `[simulation] model` and `[simulation.truth]`: a study whose data are generated
//! by one of its own `[[model]]` tables (`crate::experiment::Generator`).

use super::error::ConfigError;
use super::models::ModelSet;
use super::study::SimulationOptions;
use crate::experiment::options::Method;
use crate::experiment::{ExperimentDesign, Generator};

fn bad(file: &str, field: &str, msg: String) -> ConfigError {
    ConfigError::Invalid {
        file: file.into(),
        field: field.into(),
        msg,
    }
}

/// Checks the generator of a study: a known model that can generate data (read-outs with its
/// own noise), a finite truth for exactly its parameters at which it passes its own check
/// (stability), and injections on its inputs only. Without `[simulation] model`, named
/// injections and `[simulation.truth]` are refused (the built-in loop takes neither).
pub(super) fn check(
    sim: &SimulationOptions,
    models: &ModelSet,
    designs: &[ExperimentDesign],
    names: &[String],
    file: &str,
) -> Result<(), ConfigError> {
    let at = |d: &ExperimentDesign| {
        let k = names.iter().position(|n| *n == d.name).unwrap_or(0);
        format!("experiment[{k}].inject")
    };
    let Some(name) = &sim.model else {
        if !sim.truth.is_empty() {
            return Err(bad(
                file,
                "simulation.truth",
                "gives the parameters of a `[simulation] model`, and none is named: set `model = \"<a [[model]] name>\"` in [simulation], or put the built-in loop's true values in [truth]".into(),
            ));
        }
        if let Some(d) = designs.iter().find(|d| !d.inject.is_empty()) {
            return Err(bad(
                file,
                &at(d),
                "named injections drive the model that generates the data: set `model = \"<a [[model]] name>\"` in [simulation] (the built-in loop takes x1, x12, f1, f2, fsc)".into(),
            ));
        }
        return Ok(());
    };
    let i = models.index(name).ok_or_else(|| {
        bad(
            file,
            "simulation.model",
            format!(
                "no [[model]] is called `{name}`; the study's models are {:?}",
                models.names()
            ),
        )
    })?;
    if sim.method != Method::Frequency {
        return Err(bad(
            file,
            "simulation.method",
            "a [simulation] model is simulated in the frequency domain only: use method = \"frequency\"".into(),
        ));
    }
    if sim.thruster.is_some() || !sim.actuators.is_default() {
        return Err(bad(
            file,
            if sim.thruster.is_some() {
                "simulation.thruster"
            } else {
                "simulation.actuators"
            },
            format!(
                "describes the built-in loop, which does not generate the data when `model = \"{name}\"` is set: write the thruster or actuators into the model instead"
            ),
        ));
    }
    let model = &models.models[i];
    let params = model.param_names();
    if let Some(k) = sim.truth.keys().find(|k| !params.contains(k)) {
        return Err(bad(
            file,
            &format!("simulation.truth.{k}"),
            format!("is not a parameter of model `{name}`; its parameters are {params:?}"),
        ));
    }
    let missing: Vec<&String> = params
        .iter()
        .filter(|p| !sim.truth.contains_key(*p))
        .collect();
    if !missing.is_empty() {
        return Err(bad(
            file,
            "simulation.truth",
            format!(
                "needs the true value of every parameter of model `{name}`; missing {missing:?}"
            ),
        ));
    }
    if let Some((k, v)) = sim.truth.iter().find(|(_, v)| !v.is_finite()) {
        return Err(bad(
            file,
            &format!("simulation.truth.{k}"),
            format!("must be finite (got {v})"),
        ));
    }
    let g = Generator {
        model: model.clone(),
        theta: params.iter().map(|p| sim.truth[p]).collect(),
    };
    let ch = g.channels().map_err(|m| bad(file, "simulation.model", m))?;
    model.check(&g.theta).map_err(|m| {
        bad(
            file,
            "simulation.truth",
            format!("model `{name}` at the truth: {m}"),
        )
    })?;
    let data = model.data_channels();
    let inputs: Vec<&String> = ch.inputs.iter().map(|&c| &data[c]).collect();
    for d in designs {
        if let Some((c, _)) = d
            .channel_waveforms()
            .into_iter()
            .find(|(c, _)| !inputs.contains(&c))
        {
            let what = if d.inject.contains_key(&c) {
                format!("{}.{c}", at(d))
            } else {
                at(d).replace(".inject", "")
            };
            return Err(bad(
                file,
                &what,
                format!(
                    "experiment `{}` injects `{c}`, which is not an input of the simulation model `{name}`; its inputs are {inputs:?}",
                    d.name
                ),
            ));
        }
        let fs = d.fs;
        let mut s = vec![num_complex::Complex64::new(0.0, 0.0); ch.outputs.len().pow(2)];
        if !g.noise_csd(&ch, fs / 4.0, fs, &mut s) {
            return Err(bad(
                file,
                "simulation.model",
                format!(
                    "model `{name}` knows no noise of its own, and the simulator draws the read-out noise from it: give it noise inputs (`g`, `h`, `noise` of a state-space model)"
                ),
            ));
        }
    }
    Ok(())
}
