//! Reading a study: [`Study::load`] parses the TOML and [`StudyFile::resolve`] validates every
//! field (errors name the file, the field and the fix) and resolves built-in designs, injection
//! files and data files.

use super::budget;
use super::error::ConfigError;
use super::limits::{
    DELAY_PARAMS, MAX_ASD, MAX_CORNER, MAX_DELAY, MAX_NAME_LEN, MAX_TARGET_SNR, MIN_ASD,
    check_delay, finite_pos,
};
use super::models::{self, ModelDef, ModelEntry, ModelSet, ModelSpec};
use super::study::{
    AnalysisOptions, ExperimentEntry, FitOptions, InjectionEntry, MAX_GLITCH_COUNT_ITERATIONS,
    MIN_GLITCH_COUNT_ITERATIONS, SelectModel, SelectOptions, SimulationOptions, Study, StudyFile,
};
use crate::experiment::options::{MAX_AMPLITUDE, Method};
use crate::experiment::{ExperimentDesign, SineSegment, SnrDefinition, Waveform};
use crate::ltp::{Controllers, LtpParams, Masses, NoiseModel, check_stable};
use std::path::Path;

impl Study {
    /// Reads and validates a study file.
    pub fn load(path: &Path) -> Result<Study, ConfigError> {
        let (file, text, base) = read_study(path)?;
        Self::from_toml(&text, &file, base)
    }

    /// [`Study::load`] with `[select]` keys set as the command line gives them
    /// (`--target-error`, `--cross-checks`): validated as if the file said them, so the run's
    /// identity and its resolved study record them.
    pub fn load_with_select(
        path: &Path,
        keys: &[(&str, toml::Value)],
    ) -> Result<Study, ConfigError> {
        if keys.is_empty() {
            return Self::load(path);
        }
        let (file, text, base) = read_study(path)?;
        let edited = with_select_keys(&text, &file, keys)?;
        Self::from_toml(&edited, &file, base)
    }

    /// Parses and validates TOML text; `file` names it in messages and `base` resolves
    /// relative injection-file paths.
    pub fn from_toml(text: &str, file: &str, base: &Path) -> Result<Study, ConfigError> {
        let mut raw: StudyFile = toml::from_str(text).map_err(|e| {
            let missing = super::missing::missing_keys(text, &e);
            let msg = if missing.len() > 1 {
                let each: Vec<String> = missing
                    .iter()
                    .map(|(k, line)| match line {
                        0 => format!("`{k}` (top level)"),
                        l => format!("`{k}` (the table at line {l})"),
                    })
                    .collect();
                format!(
                    "{} required keys are missing: {}; add each (docs/src/reference/study-file.md lists every key)",
                    missing.len(),
                    each.join(", ")
                )
            } else {
                super::suggest::did_you_mean(e.to_string().trim_end())
            };
            ConfigError::Parse {
                file: file.into(),
                msg,
            }
        })?;
        if raw.analysis.glitches == crate::likelihood::GlitchTreatment::Model {
            // parsed once more as a table: the run lengths and MAP starts `[fit]` did not give
            // are the glitch model's (the plain ones would take hours at its ln L's cost);
            // before the checks, which hold `burn_in` below `iterations`
            let fit = toml::from_str::<toml::Table>(text)
                .ok()
                .and_then(|t| t.get("fit").and_then(|f| f.as_table()).cloned())
                .unwrap_or_default();
            let (iterations, burn_in) = super::study::GLITCH_ITERATIONS;
            if !fit.contains_key("iterations") {
                raw.fit.iterations = iterations;
            }
            if !fit.contains_key("burn_in") {
                raw.fit.burn_in = burn_in.min(raw.fit.iterations.saturating_sub(1));
            }
            if !fit.contains_key("map_starts") {
                raw.fit.map_starts = super::study::GLITCH_MAP_STARTS;
            }
            if !fit.contains_key("until") {
                raw.fit.until = Some(super::study::GLITCH_UNTIL);
            }
        }
        raw.resolve(file, base)
    }
}

/// The simulated loop with what the state matrix of [`check_stable`] lacks — the OMS delay,
/// `[simulation] thruster` and TM2's actuator (`[simulation.actuators] tm2`) — by
/// Routh–Hurwitz on its characteristic polynomial ([`crate::ltp::hurwitz`]).
fn simulated_loop_stable(
    truth: &LtpParams,
    masses: &Masses,
    oms_delay: f64,
    sim: &super::study::SimulationOptions,
) -> Result<(), String> {
    use crate::ltp::hurwitz::{Actuation, LoopPolynomial, rightmost_root};
    use crate::model::ThrusterResponse;
    let thruster = match sim.thruster {
        Some(t) if t.response == ThrusterResponse::Pole => Actuation {
            pole: Some(t.value),
            delay: 0.0,
        },
        Some(t) if t.response == ThrusterResponse::Delay => Actuation {
            pole: None,
            delay: t.value,
        },
        _ => Actuation::default(),
    };
    let tm2 = sim.actuators.tm2;
    let sus = Actuation {
        pole: tm2.pole,
        delay: tm2.delay,
    };
    let lp = LoopPolynomial::new(
        &Controllers::default(),
        masses,
        oms_delay,
        [Actuation::default(), sus],
    );
    let th = truth.to_array();
    if lp.is_stable(&th, &thruster) {
        return Ok(());
    }
    let pole = rightmost_root(&lp.char_poly(&th, &thruster)).map_or(String::new(), |z| {
        format!(" (a pole at {:.4e} {:+.4e}i rad/s)", z.re, z.im)
    });
    Err(format!(
        "the simulated closed loop is unstable{pole} with its OMS delay ({oms_delay} s), [simulation] thruster ({:?}) and TM2 actuator ({:?}); change those or the loop parameters",
        sim.thruster.map(|t| (t.response, t.value)),
        (tm2.pole, tm2.delay)
    ))
}

/// Study-file text with `[select]` keys set (the command line's `--target-error`,
/// `--cross-checks`), for every command that runs a model selection. Text that does not parse
/// is returned as it is, so the loader reports the file's own parse error.
pub fn with_select_keys(
    text: &str,
    file: &str,
    keys: &[(&str, toml::Value)],
) -> Result<String, ConfigError> {
    if keys.is_empty() {
        return Ok(text.to_string());
    }
    let Ok(mut doc) = text.parse::<toml::Table>() else {
        return Ok(text.to_string());
    };
    let select = doc
        .entry("select")
        .or_insert_with(|| toml::Value::Table(toml::Table::new()));
    let Some(select) = select.as_table_mut() else {
        return Err(invalid(file, "select".into(), "must be a table".into()));
    };
    for (k, v) in keys {
        select.insert((*k).to_string(), v.clone());
    }
    Ok(toml::to_string(&doc).expect("a TOML table serialises"))
}

/// A study file's name for messages, its text, and the directory its relative paths start from.
fn read_study(path: &Path) -> Result<(String, String, &Path), ConfigError> {
    let file = path.display().to_string();
    let text = crate::data::infile::read_to_string(path).map_err(|error| ConfigError::Io {
        file: file.clone(),
        error,
    })?;
    Ok((file, text, path.parent().unwrap_or(Path::new("."))))
}

/// The invalid `field` of `file`, and why.
fn invalid(file: &str, field: String, msg: String) -> ConfigError {
    ConfigError::Invalid {
        file: file.into(),
        field,
        msg,
    }
}

/// The `[[experiment]]` tables, resolved.
struct Experiments {
    /// The designs of the simulated experiments, built-ins resolved and overrides applied.
    designs: Vec<ExperimentDesign>,
    /// The experiments read from files, by name.
    data_sources: Vec<(String, crate::data::DataSource)>,
    /// The commanded injections of read experiments that give them, by name.
    commanded: Vec<(String, ExperimentDesign)>,
    /// Every experiment name in file order.
    names: Vec<String>,
}

impl StudyFile {
    /// Validates every field and resolves designs.
    pub fn resolve(mut self, file: &str, base: &Path) -> Result<Study, ConfigError> {
        let as_parsed = self.clone();
        let truth_names: Vec<String> = match &self.simulation.model {
            // a generator's truth is [simulation.truth]: per-stretch values of it are not read
            Some(_) => Vec::new(),
            None => crate::ltp::PARAM_NAMES
                .iter()
                .map(|n| n.to_string())
                .collect(),
        };
        let (experiment, stretches) =
            super::stretches::resolve(&self.stretch, &self.experiment, &truth_names, file)?;
        self.experiment = experiment;
        let bad = |field: String, msg: String| invalid(file, field, msg);
        if self.output.as_os_str().is_empty() {
            // it wrote into the working directory and printed `wrote /{…}`
            return Err(bad(
                "output".into(),
                "is empty: name the directory the run writes to, e.g. output = \"runs/study\" \
                 (a command's -o overrides it)"
                    .into(),
            ));
        }
        let budget = budget::budget_from_env()
            .map_err(|m| bad(format!("{} (environment)", budget::BUDGET_ENV), m))?;
        check_truth(&self.truth, file)?;
        check_noise(&self.noise, file)?;
        check_masses(&self.masses, file)?;
        check_delay(self.oms_delay).map_err(|m| bad("oms_delay".into(), m))?;
        check_stable(&self.truth, &Controllers::default(), &self.masses)
            .map_err(|e| bad("truth".into(), e.to_string()))?;
        check_simulation(&self.simulation, file)?;
        simulated_loop_stable(&self.truth, &self.masses, self.oms_delay, &self.simulation)
            .map_err(|e| bad("truth".into(), e))?;
        let experiments = self.resolve_experiments(file, base, budget)?;
        validate_analysis(&self.analysis, file)?;
        self.check_bands(&experiments.designs, file)?;
        let models = self.resolve_models(&stretches, file)?;
        check_columns(&self.experiment, &models, file)?;
        super::generator::check(
            &self.simulation,
            &models,
            &experiments.designs,
            &experiments.names,
            file,
        )?;
        let fit_model = self.resolve_fit(&models, file)?;
        let select_models = self.resolve_select(&models, file)?;
        if let Some(sw) = &self.sweep {
            let names: Vec<&str> = select_models.iter().map(|m| m.name.as_str()).collect();
            sw.validate(&names, file)?;
        }
        let study = Study {
            sweep: self.sweep,
            select: self.select,
            select_models,
            design: self.design,
            analysis: self.analysis,
            models,
            fit: self.fit,
            fit_model,
            seed: self.seed,
            output: self.output,
            truth: self.truth,
            noise: self.noise,
            masses: self.masses,
            oms_delay: self.oms_delay,
            simulation: self.simulation,
            experiments: experiments.designs,
            data_sources: experiments.data_sources,
            commanded: experiments.commanded,
            experiment_names: experiments.names,
            glitch_lists: self
                .experiment
                .iter()
                .filter(|e| !e.glitches.is_empty())
                .map(|e| (e.name.clone(), e.glitches.clone()))
                .collect(),
            stretches,
            base_dir: base.to_path_buf(),
            source: file.into(),
            file: as_parsed,
        };
        budget::check_study(&study, budget)?;
        Ok(study)
    }

    /// `[[experiment]]`: at least one, unique names; read ones become data sources, simulated
    /// ones designs (checked against the data budget in file order).
    fn resolve_experiments(
        &self,
        file: &str,
        base: &Path,
        budget: f64,
    ) -> Result<Experiments, ConfigError> {
        let sim = &self.simulation;
        if self.experiment.is_empty() {
            return Err(invalid(
                file,
                "experiment".into(),
                "at least one [[experiment]] table is needed".into(),
            ));
        }
        let mut experiments = Vec::new();
        let mut data_sources: Vec<(String, crate::data::DataSource)> = Vec::new();
        let mut commanded = Vec::new();
        let mut experiment_names: Vec<String> = Vec::new();
        let mut data_bytes = 0.0;
        for (k, e) in self.experiment.iter().enumerate() {
            let at = |f: &str| format!("experiment[{k}].{f}");
            check_experiment_name(e, &experiment_names, &at, file)?;
            experiment_names.push(e.name.clone());
            if let Some(path) = &e.data {
                data_sources.push((e.name.clone(), data_source(e, path, &at, file)?));
                if let Some(d) = commanded_design(e, sim.method, base, &at, file)? {
                    commanded.push((e.name.clone(), d));
                }
                continue;
            }
            let d = simulated_design(e, sim.method, base, &at, file)?;
            // sized before anything is rendered (validate_waveforms renders file injections'
            // checks only; sine lengths are analytic)
            data_bytes += budget::check_experiment(&d, k, sim, data_bytes, budget, file)?;
            validate_waveforms(&d, file, &at(""), e.amplitude_scale.is_none())?;
            experiments.push(scale_amplitudes(d, e.amplitude_scale, &at, file)?);
        }
        Ok(Experiments {
            designs: experiments,
            data_sources,
            commanded,
            names: experiment_names,
        })
    }

    /// Written bands inside (0, Nyquist] of every experiment whose rate is known now (a
    /// written band is an error there, not a silent clip; the defaults are clipped as before).
    fn check_bands(&self, experiments: &[ExperimentDesign], file: &str) -> Result<(), ConfigError> {
        let sim = &self.simulation;
        let defaults = (AnalysisOptions::default(), SimulationOptions::default());
        let rates: Vec<(usize, f64)> = self
            .experiment
            .iter()
            .enumerate()
            .filter_map(|(k, e)| {
                experiments
                    .iter()
                    .find(|d| d.name == e.name)
                    .map(|d| d.fs)
                    .or(e.fs)
                    .map(|fs| (k, fs))
            })
            .collect();
        let simulated: Vec<(usize, f64)> = rates
            .iter()
            .copied()
            .filter(|(k, _)| self.experiment[*k].data.is_none())
            .collect();
        for (field, band, given, list) in [
            (
                "analysis.band",
                self.analysis.band,
                self.analysis.band != defaults.0.band,
                &rates,
            ),
            (
                "simulation.snr_band",
                sim.snr_band,
                sim.snr_band != defaults.1.snr_band,
                &simulated,
            ),
        ] {
            if !given {
                continue;
            }
            if let Some((k, fs)) = list.iter().copied().find(|&(_, fs)| !(band[1] <= fs / 2.0)) {
                return Err(invalid(
                    file,
                    field.into(),
                    format!(
                        "[{}, {}] Hz reaches outside (0, {}] Hz, the frequencies up to the Nyquist frequency of experiment `{}` (fs = {fs} Hz): lower its upper edge",
                        band[0],
                        band[1],
                        fs / 2.0,
                        short(&self.experiment[k].name)
                    ),
                ));
            }
        }
        Ok(())
    }

    /// `[[model]]` and `[prior]`: every model resolved with its prior, user-defined models
    /// checked on a log grid over the fit band, where they must act.
    fn resolve_models(
        &self,
        stretches: &super::stretches::Stretches,
        file: &str,
    ) -> Result<ModelSet, ConfigError> {
        let ltp_defaults = crate::model::LtpModelOptions {
            masses: self.masses,
            oms_delay: self.oms_delay,
            ..Default::default()
        };
        let [blo, bhi] = self.analysis.band;
        let check_fs = self.experiment.iter().find_map(|e| e.fs).unwrap_or(10.0);
        let bhi = if bhi.min(0.49 * check_fs) > blo {
            bhi.min(0.49 * check_fs)
        } else {
            10.0 * blo
        };
        let check_freqs: Vec<f64> = (0..40)
            .map(|i| blo * (bhi / blo).powf(i as f64 / 39.0))
            .collect();
        let accel_defaults = crate::model::AccelOptions {
            d21: self.truth.d21,
            tau_ifo: self.oms_delay,
            ..Default::default()
        };
        ModelSet::resolve(
            &self.model,
            &self.prior,
            &ltp_defaults,
            &accel_defaults,
            (&check_freqs, check_fs),
            &stretches.covariates(),
            file,
        )
    }

    /// `[fit]`: its model, its options, and a stable loop with its fixed values.
    fn resolve_fit(&self, models: &ModelSet, file: &str) -> Result<ModelSpec, ConfigError> {
        let fit_model = ModelEntry {
            model: self.fit.model.clone(),
            free: self.fit.free.clone(),
            fixed: self.fit.fixed.clone(),
        }
        .resolve(models, file, "fit.")?;
        validate_fit(&self.fit, models, file)?;
        check_fixed_loop(
            &self.fit.fixed,
            &fit_model,
            models,
            &self.truth,
            &self.masses,
        )
        .map_err(|(n, m)| invalid(file, format!("fit.fixed.{n}"), m))?;
        check_state_space_start(&self.fit.fixed, &fit_model, models, self.fit.start.as_ref())
            .map_err(|(n, m)| invalid(file, n.replace("fixed.", "fit.fixed."), m))?;
        Ok(fit_model)
    }

    /// `[select]`: its options and models, and a stable loop with each model's fixed values.
    fn resolve_select(
        &self,
        models: &ModelSet,
        file: &str,
    ) -> Result<Vec<SelectModel>, ConfigError> {
        let select_models = validate_select(&self.select, models, file)?;
        for (k, (m, sm)) in self.select.model.iter().zip(&select_models).enumerate() {
            check_fixed_loop(&m.fixed, &sm.spec, models, &self.truth, &self.masses)
                .map_err(|(n, e)| invalid(file, format!("select.model[{k}].fixed.{n}"), e))?;
            check_state_space_start(&m.fixed, &sm.spec, models, self.fit.start.as_ref()).map_err(
                |(n, e)| {
                    invalid(
                        file,
                        n.replace("fixed.", &format!("select.model[{k}].fixed.")),
                        e,
                    )
                },
            )?;
        }
        Ok(select_models)
    }
}

/// `[truth]`: finite values, plausible delays.
fn check_truth(truth: &LtpParams, file: &str) -> Result<(), ConfigError> {
    if let Some(n) = truth.non_finite() {
        return Err(invalid(
            file,
            format!("truth.{n}"),
            "must be a finite number".into(),
        ));
    }
    for (n, v) in [("dt1", truth.dt1), ("dt2", truth.dt2)] {
        check_delay(v).map_err(|m| invalid(file, format!("truth.{n}"), m))?;
    }
    Ok(())
}

/// `[noise]`: finite levels ≥ 0, plausible source ASDs and corner frequencies.
fn check_noise(nz: &NoiseModel, file: &str) -> Result<(), ConfigError> {
    let bad = |field: String, msg: String| invalid(file, field, msg);
    if let Some((n, v)) = nz.invalid_field() {
        return Err(bad(
            format!("noise.{n}"),
            format!("must be a finite number ≥ 0 (got {v})"),
        ));
    }
    for (n, v) in [
        ("readout_o1", nz.readout_o1),
        ("readout_o12", nz.readout_o12),
        ("thruster_force", nz.thruster_force),
        ("tm_accel", nz.tm_accel),
    ] {
        if v > MAX_ASD || (v != 0.0 && v < MIN_ASD) {
            return Err(bad(
                format!("noise.{n}"),
                format!(
                    "{v} is not a plausible noise level: a source ASD is 0 (off) or in [{MIN_ASD:e}, {MAX_ASD}] (LPF's are 1e-15 to 1e-7); larger levels overflow the CSD"
                ),
            ));
        }
    }
    for (n, v) in [
        ("readout_corner", nz.readout_corner),
        ("tm_corner", nz.tm_corner),
    ] {
        if v > MAX_CORNER {
            return Err(bad(
                format!("noise.{n}"),
                format!("must be a corner frequency ≤ {MAX_CORNER} Hz, or 0 for none (got {v})"),
            ));
        }
    }
    Ok(())
}

/// `[masses]`: finite and positive.
fn check_masses(masses: &Masses, file: &str) -> Result<(), ConfigError> {
    for (n, v) in [("m1", masses.m1), ("m2", masses.m2), ("msc", masses.msc)] {
        if !finite_pos(v) {
            return Err(invalid(
                file,
                format!("masses.{n}"),
                format!("must be a finite mass > 0 kg (got {v})"),
            ));
        }
    }
    Ok(())
}

/// `[simulation]`: the thruster response, the actuators, the SNR target, oversampling and
/// the SNR band.
fn check_simulation(sim: &SimulationOptions, file: &str) -> Result<(), ConfigError> {
    let bad = |field: &str, msg: String| invalid(file, field.into(), msg);
    if let Some(t) = &sim.thruster {
        use crate::model::ThrusterResponse as R;
        let ok = match t.response {
            R::None => true,
            R::Delay => t.value.is_finite() && (0.0..=MAX_DELAY).contains(&t.value),
            R::Pole => finite_pos(t.value),
        };
        if !ok {
            return Err(bad(
                "simulation.thruster.value",
                format!(
                    "must be a delay in [0, {MAX_DELAY}] s (response = \"delay\") or a pole frequency > 0 Hz (response = \"pole\"); got {}",
                    t.value
                ),
            ));
        }
        if t.response != R::None && sim.method == Method::Time {
            return Err(bad(
                "simulation.thruster",
                "a thruster response is simulated in the frequency domain only; use method = \"frequency\"".into(),
            ));
        }
    }
    sim.actuators.validate(sim.method, file)?;
    if let Some(t) = sim.target_snr {
        let d = sim.snr_definition;
        let rho = d.to_optimal(t);
        if !(t.is_finite() && finite_pos(rho) && rho <= MAX_TARGET_SNR) {
            let scale = match d {
                SnrDefinition::Optimal => String::new(),
                _ => format!(
                    " on the `snr_definition` scale, here {} at most",
                    d.from_optimal(MAX_TARGET_SNR)
                ),
            };
            return Err(bad(
                "simulation.target_snr",
                format!("must be an SNR ρ_opt in (0, {MAX_TARGET_SNR:e}]{scale} (got {t})"),
            ));
        }
    }
    if let Some(g) = &sim.gaps {
        g.check().map_err(|m| bad("simulation.gaps", m))?;
    }
    if let Some(g) = &sim.glitches {
        g.check().map_err(|m| bad("simulation.glitches", m))?;
        if sim.model.is_some() {
            return Err(bad(
                "simulation.glitches",
                "glitches are simulated in the built-in LTP loop only (a force on a test mass); with `[simulation] model` remove [simulation.glitches], or put the glitch into the model's injections".into(),
            ));
        }
    }
    if !(1..=1000).contains(&sim.oversample) {
        return Err(bad(
            "simulation.oversample",
            format!("must be an integer in 1..=1000 (got {})", sim.oversample),
        ));
    }
    let [lo, hi] = sim.snr_band;
    if !(finite_pos(lo) && hi.is_finite() && hi > lo) {
        return Err(bad(
            "simulation.snr_band",
            format!("must be [lo, hi] with 0 < lo < hi (got [{lo}, {hi}])"),
        ));
    }
    Ok(())
}

/// An experiment's name: 1 to [`MAX_NAME_LEN`] letters, digits, `_` or `-`, not one
/// of the names `before` it.
fn check_experiment_name(
    e: &ExperimentEntry,
    before: &[String],
    at: &dyn Fn(&str) -> String,
    file: &str,
) -> Result<(), ConfigError> {
    if e.name.is_empty()
        || e.name.chars().count() > MAX_NAME_LEN
        || !e
            .name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
    {
        return Err(invalid(
            file,
            at("name"),
            format!(
                "`{}`: use 1 to {} letters, digits, `_` or `-` (it names arrays in the dataset)",
                short(&e.name),
                MAX_NAME_LEN
            ),
        ));
    }
    if before.contains(&e.name) {
        return Err(invalid(
            file,
            at("name"),
            format!("`{}` is used twice", e.name),
        ));
    }
    Ok(())
}

/// An experiment read from `path`: no simulation fields, a positive rate if given, valid
/// channel names.
fn data_source(
    e: &ExperimentEntry,
    path: &Path,
    at: &dyn Fn(&str) -> String,
    file: &str,
) -> Result<crate::data::DataSource, ConfigError> {
    // read, not simulated: the design may say what was commanded (commanded_design), nothing
    // else of a simulation applies
    for (f, given) in [
        ("inject", !e.inject.is_empty()),
        ("noise_duration", e.noise_duration.is_some()),
        ("amplitude_scale", e.amplitude_scale.is_some()),
    ] {
        if given {
            return Err(invalid(
                file,
                at(f),
                format!(
                    "experiment `{}` reads its data from {}; `{f}` describes a simulation and does not apply: remove it",
                    e.name,
                    path.display()
                ),
            ));
        }
    }
    if let Some(fs) = e.fs
        && !finite_pos(fs)
    {
        return Err(invalid(
            file,
            at("fs"),
            format!("must be > 0 Hz (got {fs})"),
        ));
    }
    for ch in e.columns.keys() {
        if ch != "t" {
            crate::data::dataset::check_channel_name(ch)
                .map_err(|m| invalid(file, at(&format!("columns.{ch}")), m))?;
        }
    }
    check_gap_times(e, at, file)?;
    if !e.noise_gaps.is_empty() && e.noise_data.is_none() {
        return Err(invalid(
            file,
            at("noise_gaps"),
            "the experiment has no noise-only stretch (`noise_data`)".into(),
        ));
    }
    Ok(crate::data::DataSource {
        data: path.to_path_buf(),
        columns: e.columns.clone(),
        fs: e.fs,
        noise_data: e.noise_data.clone(),
        gaps: e.gaps.clone(),
        noise_gaps: e.noise_gaps.clone(),
    })
}

/// The commanded injections of an experiment read from a file, when its table gives them
/// (`design`, `x1`, `x12`, `f1`, `f2`, `fsc`, `pre_pad`, `post_pad`): the same design a
/// simulated experiment would have, at the table's `fs` (else the design's), laid over the
/// file's fit stretch from its first sample. `None` when the table gives none of them.
fn commanded_design(
    e: &ExperimentEntry,
    method: Method,
    base: &Path,
    at: &dyn Fn(&str) -> String,
    file: &str,
) -> Result<Option<ExperimentDesign>, ConfigError> {
    let given = e.design.is_some()
        || [&e.x1, &e.x12, &e.f1, &e.f2, &e.fsc]
            .iter()
            .any(|w| w.is_some())
        || e.pre_pad.is_some()
        || e.post_pad.is_some();
    if !given {
        return Ok(None);
    }
    let design_only = ExperimentEntry {
        data: None,
        columns: Default::default(),
        noise_data: None,
        gaps: Vec::new(),
        noise_gaps: Vec::new(),
        glitches: Vec::new(),
        ..e.clone()
    };
    let d = simulated_design(&design_only, method, base, at, file)?;
    validate_waveforms(&d, file, &at(""), true)?;
    Ok(Some(d))
}

/// `gaps` and `noise_gaps`: each `[t0, t1]` finite with `0 ≤ t0 < t1` (seconds from the
/// stretch's first sample). Whether they fall inside the stretch is known once the data are.
fn check_gap_times(
    e: &ExperimentEntry,
    at: &dyn Fn(&str) -> String,
    file: &str,
) -> Result<(), ConfigError> {
    for (key, list) in [
        ("gaps", &e.gaps),
        ("noise_gaps", &e.noise_gaps),
        ("glitches", &e.glitches),
    ] {
        for (k, &[t0, t1]) in list.iter().enumerate() {
            if !(t0.is_finite() && t1.is_finite() && t0 >= 0.0 && t1 > t0) {
                return Err(invalid(
                    file,
                    at(&format!("{key}[{k}]")),
                    format!(
                        "[{t0}, {t1}]: {} is [t0, t1] in seconds from the stretch's first sample, with 0 ≤ t0 < t1",
                        if key == "glitches" {
                            "a glitch to gate"
                        } else {
                            "a gap"
                        }
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// The design of a simulated experiment: a built-in one or the defaults, with the table's
/// rate, durations and injections (force injections need `method = "frequency"`).
fn simulated_design(
    e: &ExperimentEntry,
    method: Method,
    base: &Path,
    at: &dyn Fn(&str) -> String,
    file: &str,
) -> Result<ExperimentDesign, ConfigError> {
    let bad = |field: String, msg: String| invalid(file, field, msg);
    if !e.columns.is_empty() || e.noise_data.is_some() {
        return Err(bad(
            at(if e.noise_data.is_some() {
                "noise_data"
            } else {
                "columns"
            }),
            "only an experiment that reads its data (`data = \"file.csv\"`) takes `columns` and `noise_data`".into(),
        ));
    }
    let mut d = match &e.design {
        Some(n) => ExperimentDesign::builtin(n).ok_or_else(|| {
            bad(
                at("design"),
                format!(
                    "unknown design `{n}`; built-in designs are {:?}",
                    ExperimentDesign::BUILTINS
                ),
            )
        })?,
        None => ExperimentDesign {
            name: String::new(),
            fs: 10.0,
            pre_pad: 2000.0,
            post_pad: 8000.0,
            noise_duration: 20000.0,
            x1: Waveform::None,
            x12: Waveform::None,
            f1: Waveform::None,
            f2: Waveform::None,
            fsc: Waveform::None,
            inject: Default::default(),
            gaps: Vec::new(),
            noise_gaps: Vec::new(),
        },
    };
    d.name = e.name.clone();
    if let Some(fs) = e.fs {
        if !finite_pos(fs) {
            return Err(bad(at("fs"), format!("must be > 0 Hz (got {fs})")));
        }
        d.fs = fs;
    }
    for (f, src, dst) in [
        ("pre_pad", e.pre_pad, &mut d.pre_pad),
        ("post_pad", e.post_pad, &mut d.post_pad),
        ("noise_duration", e.noise_duration, &mut d.noise_duration),
    ] {
        if let Some(v) = src {
            if !(v.is_finite() && v >= 0.0) {
                return Err(bad(at(f), format!("must be a duration ≥ 0 s (got {v})")));
            }
            *dst = v;
        }
    }
    if d.noise_duration * d.fs < 64.0 {
        return Err(bad(
            at("noise_duration"),
            format!(
                "the noise-only stretch needs at least 64 samples for noise estimation (got {} s at {} Hz)",
                d.noise_duration, d.fs
            ),
        ));
    }
    for (ch, entry, dst) in [
        ("x1", &e.x1, &mut d.x1),
        ("x12", &e.x12, &mut d.x12),
        ("f1", &e.f1, &mut d.f1),
        ("f2", &e.f2, &mut d.f2),
        ("fsc", &e.fsc, &mut d.fsc),
    ] {
        if let Some(entry) = entry {
            *dst = to_waveform(entry, base, file, &at(ch))?;
        }
    }
    for (ch, entry) in &e.inject {
        let field = at(&format!("inject.{ch}"));
        crate::data::dataset::check_channel_name(ch).map_err(|m| bad(field.clone(), m))?;
        let w = to_waveform(entry, base, file, &field)?;
        d.inject.insert(ch.clone(), w);
    }
    check_gap_times(e, at, file)?;
    d.gaps = e.gaps.clone();
    d.noise_gaps = e.noise_gaps.clone();
    if method == Method::Time
        && let Some((ch, _)) = [("f1", &d.f1), ("f2", &d.f2), ("fsc", &d.fsc)]
            .into_iter()
            .find(|(_, w)| !w.is_none())
    {
        return Err(bad(
            at(ch),
            "force injections are supported with method = \"frequency\" only (the discretised loop of method = \"time\" takes guidance injections x1, x12)".into(),
        ));
    }
    Ok(d)
}

/// `d` with `amplitude_scale` applied, if given: finite, and keeping every amplitude within
/// [`MAX_AMPLITUDE`].
fn scale_amplitudes(
    d: ExperimentDesign,
    amplitude_scale: Option<f64>,
    at: &dyn Fn(&str) -> String,
    file: &str,
) -> Result<ExperimentDesign, ConfigError> {
    let Some(s) = amplitude_scale else {
        return Ok(d);
    };
    if !s.is_finite() {
        return Err(invalid(
            file,
            at("amplitude_scale"),
            format!("must be finite (got {s})"),
        ));
    }
    let scaled = d.scaled(s);
    if let Some(a) = max_amplitude(&scaled)
        && !(a <= MAX_AMPLITUDE)
    {
        return Err(invalid(
            file,
            at("amplitude_scale"),
            format!(
                "{s} scales the largest injection amplitude to {a:e}, above the plausible {MAX_AMPLITUDE} (m or m s⁻²); lower it"
            ),
        ));
    }
    Ok(scaled)
}

/// Checks that the fixed values of a sub-model of the closed loop (an `ltp` model or a
/// `tied` one) leave the loop stable with the other parameters at `[truth]`; the error names
/// the fixed parameter that alone destabilises it (or the first one, if only their
/// combination does) and the message.
fn check_fixed_loop(
    fixed: &std::collections::BTreeMap<String, f64>,
    spec: &ModelSpec,
    models: &ModelSet,
    truth: &LtpParams,
    masses: &Masses,
) -> Result<(), (String, String)> {
    if !matches!(
        models.defs[spec.model],
        ModelDef::Ltp { .. } | ModelDef::Tied(_)
    ) {
        return Ok(());
    }
    let names = crate::ltp::PARAM_NAMES;
    let with = |only: Option<&str>| {
        let mut a = truth.to_array();
        for (n, &v) in fixed {
            if only.is_some_and(|o| o != n) {
                continue;
            }
            if let Some(i) = names.iter().position(|p| p == n) {
                a[i] = v;
            }
        }
        LtpParams::from_array(&a)
    };
    let ctrl = Controllers::default();
    if let Err(e) = check_stable(&with(None), &ctrl, masses) {
        let culprit = fixed
            .keys()
            .filter(|n| names.contains(&n.as_str()))
            .find(|n| check_stable(&with(Some(n)), &ctrl, masses).is_err())
            .or_else(|| fixed.keys().find(|n| names.contains(&n.as_str())))
            .cloned()
            .unwrap_or_default();
        return Err((
            culprit,
            format!(
                "these fixed values make the closed loop unstable with the other parameters at [truth]: {e}; a sub-model must describe a working loop"
            ),
        ));
    }
    Ok(())
}

/// Checks that a sub-model of a state-space model is stable where its MAP search starts:
/// the fixed values, the free parameters at `[fit] start` or else at their prior centre. The
/// error's field is `fixed.<first fixed parameter>` (or `fit.start` when nothing is fixed).
fn check_state_space_start(
    fixed: &std::collections::BTreeMap<String, f64>,
    spec: &ModelSpec,
    models: &ModelSet,
    start: Option<&std::collections::BTreeMap<String, f64>>,
) -> Result<(), (String, String)> {
    if !matches!(models.defs[spec.model], ModelDef::StateSpace(_)) {
        return Ok(());
    }
    let m = &models.models[spec.model];
    let names = m.param_names();
    let mut th = spec.base.clone();
    let mut from_start = false;
    for &i in &spec.free {
        th[i] = models.priors[spec.model].kinds()[i].centre();
        if let Some(v) = start.and_then(|s| s.get(&names[i])) {
            th[i] = *v;
            from_start = true;
        }
    }
    if fixed.is_empty() && !from_start {
        // the prior centre alone is checked when the model is built
        return Ok(());
    }
    m.check(&th).map_err(|e| {
        let field = match fixed.keys().next() {
            Some(n) => format!("fixed.{n}"),
            None => "fit.start".into(),
        };
        (
            field,
            format!(
                "{e}; checked at the fixed values with the free parameters at [fit] start or \
                 their prior centre ({}): a sub-model must describe a stable system",
                super::models::fmt_point(names, &th)
            ),
        )
    })
}

fn validate_analysis(a: &AnalysisOptions, file: &str) -> Result<(), ConfigError> {
    let bad = |field: &str, msg: String| ConfigError::Invalid {
        file: file.into(),
        field: format!("analysis.{field}"),
        msg,
    };
    let [lo, hi] = a.band;
    if !(finite_pos(lo) && hi.is_finite() && hi > lo) {
        return Err(bad(
            "band",
            format!("must be [lo, hi] with 0 < lo < hi Hz (got [{lo}, {hi}])"),
        ));
    }
    if a.welch_averages == 0 {
        return Err(bad("welch_averages", "must be ≥ 1".into()));
    }
    if !finite_pos(a.relbin_sigma) {
        return Err(bad(
            "relbin_sigma",
            format!("must be > 0 (got {})", a.relbin_sigma),
        ));
    }
    if !finite_pos(a.relbin_tolerance) {
        return Err(bad(
            "relbin_tolerance",
            format!("must be > 0 (got {})", a.relbin_tolerance),
        ));
    }
    if let Some(t) = a.glitch_threshold
        && !(t.is_finite() && t >= 3.0)
    {
        return Err(bad(
            "glitch_threshold",
            format!(
                "must be ≥ 3 σ of the whitened residual (got {t}; below that pure noise is gated everywhere); the default is {}",
                crate::likelihood::DEFAULT_GLITCH_THRESHOLD
            ),
        ));
    }
    if let Some(p) = a.glitch_pad
        && !(p.is_finite() && p >= 0.0)
    {
        return Err(bad(
            "glitch_pad",
            format!("must be a duration ≥ 0 s (got {p})"),
        ));
    }
    if let Some(p) = a.glitch_tail
        && !(p.is_finite() && p >= 0.0)
    {
        return Err(bad(
            "glitch_tail",
            format!("must be a duration ≥ 0 s (got {p})"),
        ));
    }
    if a.glitches.is_none()
        && (a.glitch_threshold.is_some() || a.glitch_pad.is_some() || a.glitch_tail.is_some())
    {
        return Err(bad(
            "glitches",
            "glitch_threshold, glitch_pad and glitch_tail apply to detection only: set glitches = \"gate\" or remove them".into(),
        ));
    }
    let modelled = a.glitches == crate::likelihood::GlitchTreatment::Model;
    if !modelled
        && (a.glitch_decay.is_some() || a.glitch_amplitude.is_some() || a.glitch_rise.is_some())
    {
        return Err(bad(
            "glitches",
            "glitch_decay, glitch_amplitude and glitch_rise set the modelled glitches' priors: set glitches = \"model\" or remove them".into(),
        ));
    }
    if !modelled && (!a.glitch_count.is_all() || a.glitch_count_iterations.is_some()) {
        return Err(bad(
            "glitch_count",
            "glitch_count and glitch_count_iterations choose how many modelled glitches there are: set glitches = \"model\" or remove them".into(),
        ));
    }
    if let Some(n) = a.glitch_count_iterations {
        if a.glitch_count.is_all() {
            return Err(bad(
                "glitch_count_iterations",
                "sets the reversible jump's length: set glitch_count = \"rj\" or remove it".into(),
            ));
        }
        if !(MIN_GLITCH_COUNT_ITERATIONS..=MAX_GLITCH_COUNT_ITERATIONS).contains(&n) {
            return Err(bad(
                "glitch_count_iterations",
                format!(
                    "must be in {MIN_GLITCH_COUNT_ITERATIONS}..={MAX_GLITCH_COUNT_ITERATIONS} (got {n}): a quarter is burn-in and the rest makes the 20 batches of its errors"
                ),
            ));
        }
    }
    let rise = a
        .glitch_rise
        .unwrap_or(crate::likelihood::DEFAULT_GLITCH_RISE);
    if !(rise.is_finite() && rise > 0.0) {
        return Err(bad(
            "glitch_rise",
            format!("must be a duration > 0 s (got {rise})"),
        ));
    }
    if let Some([lo, hi]) = a.glitch_decay
        && !(lo.is_finite() && hi.is_finite() && lo > rise && hi > lo)
    {
        return Err(bad(
            "glitch_decay",
            format!(
                "[{lo}, {hi}] s: need rise time ({rise} s) < lo < hi (the decay time's log-uniform prior)"
            ),
        ));
    }
    if let Some(amp) = a.glitch_amplitude
        && !(amp.is_finite() && amp > 0.0 && amp <= 1e-6)
    {
        return Err(bad(
            "glitch_amplitude",
            format!(
                "must be in (0, 1e−6] m s⁻², the largest peak force per unit mass a glitch may have (got {amp})"
            ),
        ));
    }
    if modelled && a.window != crate::signal::Window::Rectangular {
        return Err(bad(
            "glitches",
            "glitches = \"model\" needs window = \"rectangular\": the model's glitches act through an impulse at the first sample, which a tapered window removes".into(),
        ));
    }
    if !a.glitches.is_none() && a.statistic == crate::likelihood::Statistic::LogPeriodogram {
        return Err(bad(
            "glitches",
            "statistic = \"log_periodogram\" (a Welch average of the residual's time series) handles neither the gaps that gating makes nor modelled glitches: use \"whittle\" or \"student_t\"".into(),
        ));
    }
    if a.log_periodogram.averages == 0 {
        return Err(bad("log_periodogram.averages", "must be ≥ 1".into()));
    }
    if a.log_periodogram.decimate == Some(0) {
        return Err(bad(
            "log_periodogram.decimate",
            "must be ≥ 1 (1 keeps every Welch bin)".into(),
        ));
    }
    if matches!(
        a.statistic,
        crate::likelihood::Statistic::StudentT | crate::likelihood::Statistic::Wishart
    ) && a.noise == crate::likelihood::NoiseSource::Model
    {
        return Err(bad(
            "statistic",
            format!(
                "\"{}\" marginalises the uncertainty of the Welch noise estimate, and noise = \"model\" has none: use noise = \"welch\" or statistic = \"whittle\"",
                a.statistic.name()
            ),
        ));
    }
    Ok(())
}

/// Fewest draws per chain after the burn-in and thinning: split R-hat halves each chain, and
/// `sampler::diagnostics` refuses fewer than four.
const MIN_KEPT: usize = 4;

fn validate_fit(f: &FitOptions, models: &ModelSet, file: &str) -> Result<(), ConfigError> {
    let bad = |field: &str, msg: String| ConfigError::Invalid {
        file: file.into(),
        field: format!("fit.{field}"),
        msg,
    };
    if f.chains == 0 {
        return Err(bad("chains", "must be ≥ 1".into()));
    }
    if f.iterations == 0 || f.burn_in >= f.iterations {
        return Err(bad(
            "burn_in",
            format!(
                "must be smaller than `iterations` (got burn_in = {}, iterations = {})",
                f.burn_in, f.iterations
            ),
        ));
    }
    if f.chains > budget::MAX_CHAINS {
        return Err(bad(
            "chains",
            format!("must be at most {} (got {})", budget::MAX_CHAINS, f.chains),
        ));
    }
    if f.iterations > budget::MAX_ITERATIONS {
        return Err(bad(
            "iterations",
            format!(
                "must be at most {:e}, beyond which a run does not end (got {})",
                budget::MAX_ITERATIONS as f64,
                f.iterations
            ),
        ));
    }
    if f.thin == 0 || f.thin > f.iterations - f.burn_in {
        return Err(bad(
            "thin",
            format!(
                "must be ≥ 1 and keep at least one draw of the {} after the burn-in (got {})",
                f.iterations - f.burn_in,
                f.thin
            ),
        ));
    }
    // found before the chains run, not after (it ran the whole MCMC, then refused)
    let kept = (f.iterations - f.burn_in) / f.thin;
    if kept < MIN_KEPT {
        return Err(bad(
            "burn_in",
            format!(
                "keeps {kept} draw(s) per chain ((iterations − burn_in)/thin = ({} − {})/{}), but \
                 the convergence checks split each chain and need at least {MIN_KEPT}: lower \
                 burn_in or thin, or raise iterations",
                f.iterations, f.burn_in, f.thin
            ),
        ));
    }
    if f.checkpoint_every == 0 {
        return Err(bad(
            "checkpoint_every",
            "must be ≥ 1 iteration between checkpoints".into(),
        ));
    }
    if let Some(u) = &f.until
        && let Err(crate::sampler::SamplerError::Setting { field, problem }) =
            crate::sampler::Until::new(u.ess, u.rhat, u.every)
    {
        return Err(bad(field, problem));
    }
    if let Some(s) = f.independence
        && !(0.0..=1.0).contains(&s)
    {
        return Err(bad(
            "independence",
            format!("must be a share in [0, 1] of the iterations (got {s})"),
        ));
    }
    if !finite_pos(f.proposal_scale) {
        return Err(bad(
            "proposal_scale",
            format!("must be > 0 (got {})", f.proposal_scale),
        ));
    }
    if f.map_starts > budget::MAX_MAP_STARTS {
        return Err(bad(
            "map_starts",
            format!(
                "must be at most {} quasi-random starts, each a full MAP search (got {})",
                budget::MAX_MAP_STARTS,
                f.map_starts
            ),
        ));
    }
    if let Some(start) = &f.start {
        for (n, v) in start {
            // the start applies to every model that has the parameter (`select` too)
            if !models.models.iter().any(|m| m.param_names().contains(n)) {
                return Err(bad(
                    &format!("start.{n}"),
                    format!(
                        "not a parameter of any model; the parameters are {:?}",
                        models.all_param_names()
                    ),
                ));
            }
            if !v.is_finite() {
                return Err(bad(
                    &format!("start.{n}"),
                    format!("must be finite (got {v})"),
                ));
            }
            let delay_of_builtin = DELAY_PARAMS.contains(&n.as_str())
                && models
                    .defs
                    .iter()
                    .zip(&models.models)
                    .any(|(d, m)| !d.is_user_defined() && m.param_names().contains(n));
            if delay_of_builtin {
                check_delay(*v).map_err(|m| bad(&format!("start.{n}"), m))?;
            }
        }
    }
    Ok(())
}

fn validate_select(
    s: &SelectOptions,
    models: &ModelSet,
    file: &str,
) -> Result<Vec<SelectModel>, ConfigError> {
    let bad = |field: String, msg: String| ConfigError::Invalid {
        file: file.into(),
        field,
        msg,
    };
    if s.rj_iterations == 0 || s.rj_burn_in >= s.rj_iterations {
        return Err(bad(
            "select.rj_burn_in".into(),
            format!(
                "must be smaller than `rj_iterations` (got {} and {})",
                s.rj_burn_in, s.rj_iterations
            ),
        ));
    }
    for (f, v) in [
        ("rj_iterations", s.rj_iterations),
        ("iterations", s.iterations),
        ("pt_iterations", s.pt_iterations),
        ("max_iterations", s.max_iterations.unwrap_or(0)),
    ] {
        if v > budget::MAX_ITERATIONS {
            return Err(bad(
                format!("select.{f}"),
                format!(
                    "must be at most {:e}, beyond which a run does not end (got {v})",
                    budget::MAX_ITERATIONS as f64
                ),
            ));
        }
    }
    if s.chains > budget::MAX_CHAINS {
        return Err(bad(
            "select.chains".into(),
            format!("must be at most {} (got {})", budget::MAX_CHAINS, s.chains),
        ));
    }
    if s.iterations == 0 || s.burn_in.saturating_add(MIN_KEPT) > s.iterations || s.chains == 0 {
        return Err(bad(
            "select.burn_in".into(),
            format!(
                "need chains ≥ 1 and at least {MIN_KEPT} draws per chain after the burn-in, which the convergence checks split (got chains = {}, burn_in = {}, iterations = {})",
                s.chains, s.burn_in, s.iterations
            ),
        ));
    }
    if let Some(u) = &s.until
        && let Err(crate::sampler::SamplerError::Setting { field, problem }) =
            crate::sampler::Until::new(u.ess, u.rhat, u.every)
    {
        return Err(bad(format!("select.{field}"), problem));
    }
    if let Some(m) = s.max_iterations
        && m < s.iterations
    {
        return Err(bad(
            "select.max_iterations".into(),
            format!(
                "must be at least `iterations` ({}), which the in-model chains always run (got {m}); `until = false` runs exactly `iterations`",
                s.iterations
            ),
        ));
    }
    if s.pt_temperatures != 0
        && (s.pt_temperatures < 3 || s.pt_burn_in >= s.pt_iterations || s.pt_temperatures > 200)
    {
        return Err(bad(
            "select.pt_temperatures".into(),
            format!(
                "parallel tempering needs 3 to 200 rungs (0 turns it off) and pt_burn_in < pt_iterations (got {} rungs, pt_burn_in = {}, pt_iterations = {})",
                s.pt_temperatures, s.pt_burn_in, s.pt_iterations
            ),
        ));
    }
    if !(s.defensive >= 0.0 && s.defensive < 1.0) {
        return Err(bad(
            "select.defensive".into(),
            format!(
                "the prior's weight in the jump proposal must be in [0, 1) (got {})",
                s.defensive
            ),
        ));
    }
    if s.pt_temperatures != 0 && s.pt_iterations - s.pt_burn_in < 100 {
        return Err(bad(
            "select.pt_iterations".into(),
            format!(
                "parallel tempering needs at least 100 sweeps after pt_burn_in (got pt_iterations = {}, pt_burn_in = {})",
                s.pt_iterations, s.pt_burn_in
            ),
        ));
    }
    let (light_temps, light_iter, light_burn) = s.tempering_ladder();
    if light_temps != 0 && light_iter - light_burn < 100 {
        return Err(bad(
            "select.cross_checks".into(),
            format!(
                "`{}` leaves {} tempering sweeps after burn-in (pt_iterations = {}, pt_burn_in = {}); at least 100 are needed: lengthen pt_iterations or choose \"full\"",
                s.cross_checks.name(),
                light_iter - light_burn,
                s.pt_iterations,
                s.pt_burn_in
            ),
        ));
    }
    if s.rj_chains == 0
        || s.rj_chains > 4096
        || s.rj_iterations / s.rj_chains.max(1) < s.rj_burn_in + 100
    {
        return Err(bad(
            "select.rj_chains".into(),
            format!(
                "need 1 to 4096 chains, each at least 100 iterations longer than rj_burn_in, i.e. rj_iterations ≥ rj_chains × (rj_burn_in + 100) (got {} chains of {} iterations, rj_burn_in = {})",
                s.rj_chains,
                s.rj_iterations / s.rj_chains.max(1),
                s.rj_burn_in
            ),
        ));
    }
    if !finite_pos(s.jump_scale) {
        return Err(bad(
            "select.jump_scale".into(),
            format!("must be > 0 (got {})", s.jump_scale),
        ));
    }
    if !(s.student_t == 0.0 || (s.student_t.is_finite() && s.student_t > 0.0)) {
        return Err(bad(
            "select.student_t".into(),
            format!(
                "degrees of freedom must be > 0, or 0 for a Gaussian (got {})",
                s.student_t
            ),
        ));
    }
    if let Some(n) = s.schwarz_n
        && !(n.is_finite() && n > 1.0)
    {
        return Err(bad(
            "select.schwarz_n".into(),
            format!("must be > 1 (got {n})"),
        ));
    }
    if let Some(t) = s.target_error
        && !finite_pos(t)
    {
        return Err(bad(
            "select.target_error".into(),
            format!("the standard error of ln B to reach must be > 0 (got {t})"),
        ));
    }
    if s.target_error.is_some() && s.rj_budget() > budget::MAX_ITERATIONS {
        return Err(bad(
            "select.rj_max_iterations".into(),
            format!(
                "the budget of a run with `target_error` must be at most {:e} (got {}, 16 × rj_iterations unless set)",
                budget::MAX_ITERATIONS as f64,
                s.rj_budget()
            ),
        ));
    }
    if let Some(n) = s.rj_max_iterations {
        if s.target_error.is_none() {
            return Err(bad(
                "select.rj_max_iterations".into(),
                "is the budget of a run with `target_error`; set `target_error` too, or remove it"
                    .into(),
            ));
        }
        if n < s.rj_iterations {
            return Err(bad(
                "select.rj_max_iterations".into(),
                format!(
                    "must be at least `rj_iterations` ({}), the first round's length (got {n})",
                    s.rj_iterations
                ),
            ));
        }
    }
    let mut out: Vec<SelectModel> = Vec::new();
    for (k, m) in s.model.iter().enumerate() {
        let at = format!("select.model[{k}].");
        models::check_name(&m.name).map_err(|e| bad(format!("{at}name"), e))?;
        if out.iter().any(|o| o.name == m.name) {
            return Err(bad(
                format!("{at}name"),
                format!("`{}` must be unique", m.name),
            ));
        }
        let spec = ModelEntry {
            model: m.model.clone(),
            free: m.free.clone(),
            fixed: m.fixed.clone(),
        }
        .resolve(models, file, &at)?;
        let p = m.prior_probability.unwrap_or(1.0);
        if !finite_pos(p) {
            return Err(bad(
                format!("{at}prior_probability"),
                format!("must be > 0 (got {p})"),
            ));
        }
        out.push(SelectModel {
            name: m.name.clone(),
            spec,
            prior_probability: p,
        });
    }
    if out.len() == 1 {
        return Err(bad(
            "select.model".into(),
            "model selection needs at least two [[select.model]] tables".into(),
        ));
    }
    normalise_prior_probabilities(&mut out, file)?;
    Ok(out)
}

/// Every `columns` entry of a read experiment maps `t` or a channel some model of the study
/// reads: an entry for no channel (a typo such as `o21`, a stale map) would otherwise be
/// ignored, leaving the user believing the column they named was fitted.
fn check_columns(
    experiments: &[ExperimentEntry],
    models: &super::models::ModelSet,
    file: &str,
) -> Result<(), ConfigError> {
    let mut read: Vec<&str> = Vec::new();
    for m in &models.models {
        for c in m.data_channels() {
            if !read.contains(&c.as_str()) {
                read.push(c);
            }
        }
    }
    for (k, e) in experiments.iter().enumerate() {
        if let Some(c) = e
            .columns
            .keys()
            .find(|c| *c != "t" && !read.contains(&c.as_str()))
        {
            let listed: Vec<String> = read.iter().map(|c| format!("`{c}`")).collect();
            return Err(invalid(
                file,
                format!("experiment[{k}].columns.{c}"),
                format!(
                    "maps channel `{c}`, which no model of the study reads (they read {}); remove the entry or correct the channel's name",
                    listed.join(", ")
                ),
            ));
        }
    }
    Ok(())
}

/// Scales the models' prior probabilities to sum to one. They are divided by the largest
/// first, so that values near `f64::MAX` cannot overflow their sum (two of 1e308 are equal
/// priors); a ratio so extreme that a probability would vanish is refused, naming the model,
/// because that model could never be chosen whatever the data.
fn normalise_prior_probabilities(out: &mut [SelectModel], file: &str) -> Result<(), ConfigError> {
    let max = out.iter().map(|m| m.prior_probability).fold(0.0, f64::max);
    for m in out.iter_mut() {
        m.prior_probability /= max;
    }
    let total: f64 = out.iter().map(|m| m.prior_probability).sum();
    for (i, m) in out.iter_mut().enumerate() {
        m.prior_probability /= total;
        if m.prior_probability < 1e-300 {
            return Err(invalid(
                file,
                format!("select.model[{i}].prior_probability"),
                "is below 1e-300 of the largest model's: that model could never be chosen; drop it or give a prior probability within 1e300 of the others".into(),
            ));
        }
    }
    Ok(())
}

fn to_waveform(
    e: &InjectionEntry,
    base: &Path,
    file: &str,
    field: &str,
) -> Result<Waveform, ConfigError> {
    Ok(match e {
        InjectionEntry::None {} => Waveform::None,
        InjectionEntry::SineTrain { segments, gap } => Waveform::SineTrain {
            segments: segments.clone(),
            gap: *gap,
        },
        InjectionEntry::Sine {
            freq,
            amplitude,
            duration,
        } => Waveform::Sine(SineSegment {
            freq: *freq,
            amplitude: *amplitude,
            duration: *duration,
        }),
        InjectionEntry::File { path, column } => {
            let p = base.join(path);
            let table = crate::data::dataset::read_csv(&p).map_err(|e| ConfigError::Invalid {
                file: file.into(),
                field: format!("{field}.path"),
                msg: e.to_string(),
            })?;
            let col = match column {
                Some(c) => table.column(c).ok_or_else(|| ConfigError::Invalid {
                    file: file.into(),
                    field: format!("{field}.column"),
                    msg: format!(
                        "no column `{c}` in {}; it has {:?}",
                        p.display(),
                        table.names
                    ),
                })?,
                None if table.names.len() == 1 => &table.columns[0],
                None => {
                    return Err(ConfigError::Invalid {
                        file: file.into(),
                        field: format!("{field}.column"),
                        msg: format!(
                            "{} has several columns {:?}: name one with `column = \"...\"`",
                            p.display(),
                            table.names
                        ),
                    });
                }
            };
            // a data file's NaN or empty cell is a gap; a commanded injection has none
            if let Some(k) = col.iter().position(|v| v.is_nan()) {
                return Err(ConfigError::Invalid {
                    file: file.into(),
                    field: format!("{field}.path"),
                    msg: format!(
                        "{}: line {}: the sample is missing or not finite (NaN or an empty cell); an injection file gives every sample",
                        p.display(),
                        table.lines[k]
                    ),
                });
            }
            Waveform::Samples {
                values: col.clone(),
            }
        }
    })
}

/// The largest |amplitude| of a design's injections (sine amplitudes and file samples), `None`
/// without any; NaN if one is NaN.
fn max_amplitude(d: &ExperimentDesign) -> Option<f64> {
    let mut out: Option<f64> = None;
    for w in [&d.x1, &d.x12, &d.f1, &d.f2, &d.fsc] {
        let vals: Vec<f64> = match w {
            Waveform::Samples { values } => values.iter().map(|v| v.abs()).collect(),
            _ => w.segments().iter().map(|s| s.amplitude.abs()).collect(),
        };
        for a in vals {
            out = Some(match out {
                Some(m) if !(a > m) && !a.is_nan() => m,
                _ => a,
            });
            if a.is_nan() {
                return Some(a);
            }
        }
    }
    out
}

/// A user string shortened for a message (a 70 000-character name must not fill the screen).
fn short(s: &str) -> String {
    const KEEP: usize = 40;
    if s.chars().count() <= KEEP {
        s.to_string()
    } else {
        let head: String = s.chars().take(KEEP).collect();
        format!("{head}… ({} characters)", s.chars().count())
    }
}

/// Validates the injections of `d`; `bound` also checks every amplitude against
/// [`MAX_AMPLITUDE`] (the caller checks it after `amplitude_scale` otherwise).
fn validate_waveforms(
    d: &ExperimentDesign,
    file: &str,
    at: &str,
    bound: bool,
) -> Result<(), ConfigError> {
    let nyq = d.fs / 2.0;
    for (ch, w) in d.waveforms() {
        // a named channel's unit is the user's model's: only finiteness is checked there
        let bound = bound && !ch.starts_with("inject.");
        let bad = |f: String, msg: String| ConfigError::Invalid {
            file: file.into(),
            field: format!("{at}{ch}{f}"),
            msg,
        };
        if let Waveform::SineTrain { gap, .. } = w
            && !(gap.is_finite() && *gap >= 0.0)
        {
            return Err(bad(".gap".into(), format!("must be ≥ 0 s (got {gap})")));
        }
        let train = matches!(w, Waveform::SineTrain { .. });
        for (i, s) in w.segments().iter().enumerate() {
            let seg = if train {
                format!(".segments[{i}]")
            } else {
                String::new()
            };
            if !finite_pos(s.freq) || s.freq >= nyq {
                return Err(bad(
                    format!("{seg}.freq"),
                    format!(
                        "must be in (0, {nyq}) Hz, below the Nyquist frequency of fs = {} Hz (got {})",
                        d.fs, s.freq
                    ),
                ));
            }
            if !s.amplitude.is_finite() || (bound && s.amplitude.abs() > MAX_AMPLITUDE) {
                return Err(bad(
                    format!("{seg}.amplitude"),
                    format!(
                        "must be finite with |amplitude| ≤ {MAX_AMPLITUDE} (m on x1, x12; m s⁻² on f1, f2, fsc), got {}",
                        s.amplitude
                    ),
                ));
            }
            if !finite_pos(s.duration) || 2.0 * s.freq * s.duration < 1.0 {
                return Err(bad(
                    format!("{seg}.duration"),
                    format!(
                        "must hold at least half a cycle of {} Hz, i.e. ≥ {} s (got {})",
                        s.freq,
                        0.5 / s.freq,
                        s.duration
                    ),
                ));
            }
        }
        if let Waveform::Samples { values } = w
            && let Some(i) = values.iter().position(|v| !v.is_finite())
        {
            return Err(bad(
                String::new(),
                format!("sample {i} of the injection file is not finite"),
            ));
        }
        if let Waveform::Samples { values } = w
            && bound
            && let Some(i) = values.iter().position(|v| v.abs() > MAX_AMPLITUDE)
        {
            return Err(bad(
                String::new(),
                format!(
                    "sample {i} of the injection file is {}, above the plausible {MAX_AMPLITUDE} (m or m s⁻²)",
                    values[i]
                ),
            ));
        }
    }
    if d.waveforms().iter().all(|(_, w)| w.is_empty(d.fs)) {
        return Err(ConfigError::Invalid {
            file: file.into(),
            field: format!("{at}x1"),
            msg: "the experiment injects nothing: give `x1` or `x12` (or a `design`), a force injection `f1`, `f2` or `fsc`, or (with a [simulation] model) `[experiment.inject]`".into(),
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::JumpProposal;

    use crate::config::GLITCH_ITERATIONS;

    fn load(s: &str) -> Result<Study, ConfigError> {
        Study::from_toml(s, "study.toml", Path::new("."))
    }

    const OK: &str = r#"
seed = 1
output = "out"
[[experiment]]
name = "inv1"
design = "tn3045_x1"
"#;

    /// With `glitches = "model"` the run lengths and MAP starts `[fit]` does not give are
    /// the glitch model's, each on its own; without, the plain defaults. `independence` outside [0, 1] is
    /// refused by name.
    #[test]
    fn modelled_glitches_take_their_run_lengths_where_the_file_gives_none() {
        let lengths = |extra: &str| {
            let f = load(&format!("{OK}{extra}")).unwrap().fit;
            (f.iterations, f.burn_in)
        };
        let model = "[analysis]\nglitches = \"model\"\n";
        assert_eq!(lengths(""), (20_000, 5_000));
        assert_eq!(lengths(model), GLITCH_ITERATIONS);
        let starts = |extra: &str| load(&format!("{OK}{extra}")).unwrap().fit.map_starts;
        assert_eq!(starts(model), 0);
        assert_eq!(starts(&format!("{model}[fit]\nmap_starts = 2\n")), 2);
        assert_eq!(
            lengths(&format!("{model}[fit]\niterations = 9000\n")),
            (9000, GLITCH_ITERATIONS.1)
        );
        // shorter than the plain burn-in: the glitch model's burn-in, not an error about 5 000
        assert_eq!(
            lengths(&format!("{model}[fit]\niterations = 2000\n")),
            (2000, GLITCH_ITERATIONS.1)
        );
        assert_eq!(
            lengths(&format!("{model}[fit]\nburn_in = 100\nchains = 2\n")),
            (GLITCH_ITERATIONS.0, 100)
        );
        let e = load(&format!("{OK}[fit]\nindependence = 1.5\n"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("independence") && e.contains("[0, 1]"), "{e}");
        // the convergence rule: the glitch model's unless given; none otherwise
        let until = |extra: &str| load(&format!("{OK}{extra}")).unwrap().fit.until;
        assert_eq!(until(""), None);
        assert_eq!(until(model), Some(crate::config::GLITCH_UNTIL));
        let given = until(&format!("{model}[fit]\nuntil = {{ ess = 1000 }}\n")).unwrap();
        assert_eq!((given.ess, given.rhat, given.every), (1000.0, 1.01, 100));
        assert_eq!(
            until("[fit]\nuntil = { rhat = 1.05, every = 50 }\n").map(|u| (u.rhat, u.every)),
            Some((1.05, 50))
        );
        for (bad, field) in [
            ("{ ess = 0 }", "fit.until.ess"),
            ("{ rhat = 0.99 }", "fit.until.rhat"),
            ("{ every = 0 }", "fit.until.every"),
        ] {
            let e = load(&format!("{OK}[fit]\nuntil = {bad}\n"))
                .unwrap_err()
                .to_string();
            assert!(e.contains(field), "{bad}: {e}");
        }
        let e = load(&format!("{OK}[fit]\nuntil = {{ ess_min = 400 }}\n"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("ess_min"), "{e}");
        // `true` for the defaults, `false` for fixed lengths with modelled glitches too, and
        // the resolved study reads back to the same
        assert_eq!(
            until("[fit]\nuntil = true\n"),
            Some(crate::config::UntilOptions::default())
        );
        let off = load(&format!("{OK}{model}[fit]\nuntil = false\n")).unwrap();
        assert_eq!(off.fit.until, None);
        for study in [off, load(&format!("{OK}{model}")).unwrap()] {
            let text = crate::config::resolved_toml(&study).unwrap();
            assert_eq!(load(&text).unwrap().fit.until, study.fit.until, "{text}");
        }
        let e = load(&format!("{OK}[fit]\nuntil = 400\n"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("true or false"), "{e}");
    }

    /// `[select] until`: on by default (the in-model chains run past `iterations` until they
    /// converge, at most `max_iterations`, 4 × `iterations` unless given); `false` runs exactly
    /// `iterations`; the resolved study reads back to the same; bad values name their field.
    #[test]
    fn select_s_in_model_chains_run_until_converged_unless_told_not_to() {
        let sel = |extra: &str| load(&format!("{OK}{extra}")).unwrap().select;
        let d = sel("");
        assert_eq!(d.until, Some(crate::config::UntilOptions::default()));
        assert_eq!(d.most_iterations(), 4 * d.iterations);
        let off = sel("[select]\nuntil = false\n");
        assert_eq!((off.until, off.most_iterations()), (None, off.iterations));
        let given =
            sel("[select]\nuntil = { ess = 800 }\niterations = 9000\nmax_iterations = 20000\n");
        assert_eq!(given.until.map(|u| (u.ess, u.rhat)), Some((800.0, 1.01)));
        assert_eq!(given.most_iterations(), 20_000);
        for extra in [
            "",
            "[select]\nuntil = false\n",
            "[select]\nuntil = { rhat = 1.05 }\nmax_iterations = 50000\n",
        ] {
            let study = load(&format!("{OK}{extra}")).unwrap();
            let text = crate::config::resolved_toml(&study).unwrap();
            let back = load(&text).unwrap().select;
            assert_eq!(
                (back.until, back.max_iterations),
                (study.select.until, study.select.max_iterations),
                "{text}"
            );
        }
        for (bad, field) in [
            ("until = { ess = 0 }", "select.until.ess"),
            ("until = { every = 0 }", "select.until.every"),
            ("max_iterations = 11999", "select.max_iterations"),
            ("max_iterations = 1000000000000", "select.max_iterations"),
        ] {
            let e = load(&format!("{OK}[select]\n{bad}\n"));
            let e = e.map(|_| ()).unwrap_err().to_string();
            assert!(e.contains(field), "{bad}: {e}");
        }
    }

    /// Pairs with a third number were read as their first two, silently (issue 51); now every
    /// pair of a study is exactly two numbers or an error naming what was given.
    #[test]
    fn pairs_with_another_count_of_numbers_are_refused() {
        for (extra, line) in [
            (
                "[[experiment]]\nname = \"b\"\ndesign = \"tn3045_x12\"\ngaps = [[1.0, 2.0, 3.0]]\n",
                "gaps",
            ),
            (
                "[[experiment]]\nname = \"b\"\ndesign = \"tn3045_x12\"\nglitches = [[500.0, 560.0, 9.0]]\n",
                "glitches",
            ),
            (
                "[[experiment]]\nname = \"b\"\ndesign = \"tn3045_x12\"\nnoise_gaps = [[5.0]]\n",
                "noise_gaps",
            ),
            (
                "[analysis]\nglitches = \"model\"\nglitch_decay = [10.0, 3000.0, 1.0]\n",
                "glitch_decay",
            ),
            (
                "[simulation.glitches]\ncount = 1\ndecay = [10.0, 100.0]\namplitude = [1e-14, 1e-13, 5.0]\n",
                "amplitude",
            ),
            (
                "[simulation.glitches]\ncount = 1\ndecay = [10.0]\namplitude = [1e-14, 1e-13]\n",
                "decay",
            ),
        ] {
            let e = load(&format!("{OK}{extra}")).unwrap_err().to_string();
            assert!(
                e.contains("exactly two numbers") && e.contains(line),
                "{extra}: {e}"
            );
        }
        let s = load(&format!(
            "{OK}[[experiment]]\nname = \"b\"\ndesign = \"tn3045_x12\"\ngaps = [[1.0, 2.0]]\n"
        ))
        .unwrap();
        assert!(!s.experiments.is_empty());
    }

    #[test]
    fn a_simulated_loop_unstable_through_its_thruster_actuator_or_oms_delay_is_refused() {
        // the state matrix alone (no thruster, actuator or OMS delay) calls each of these stable
        for (extra, stable) in [
            (
                "[simulation]\nthruster = { response = \"pole\", value = 0.3 }\n",
                true,
            ),
            (
                "[simulation]\nthruster = { response = \"pole\", value = 0.03 }\n",
                false,
            ),
            (
                "[simulation]\nthruster = { response = \"delay\", value = 3.0 }\n",
                false,
            ),
            ("[simulation.actuators]\ntm2 = { delay = 0.2 }\n", true),
            ("[simulation.actuators]\ntm2 = { pole = 1e-4 }\n", false),
            ("oms_delay = 3.0\n", false),
        ] {
            let text = if extra.starts_with('[') {
                format!("{OK}{extra}")
            } else {
                format!("{extra}{OK}")
            };
            match load(&text) {
                Ok(_) => assert!(stable, "{extra}: accepted"),
                Err(e) => {
                    let e = e.to_string();
                    assert!(!stable, "{extra}: {e}");
                    assert!(e.contains("truth") && e.contains("unstable"), "{e}");
                }
            }
        }
    }

    #[test]
    fn minimal_study_uses_defaults() {
        let s = load(OK).unwrap();
        assert_eq!(s.truth, LtpParams::default());
        assert_eq!(s.experiments[0].fs, 10.0);
    }

    fn err(s: &str) -> String {
        load(s).unwrap_err().to_string()
    }

    #[test]
    fn prior_probabilities_near_the_largest_float_do_not_overflow() {
        let two = |a: &str, b: &str| {
            format!(
                "{OK}[select]\n[[select.model]]\nname = \"X\"\nprior_probability = {a}\n[[select.model]]\nname = \"Y\"\nfree = [\"w1sq\", \"w2sq\", \"a_sus\", \"d21\"]\nfixed = {{ dt1 = 0.2, dt2 = 0.2, a_df = 0.82 }}\nprior_probability = {b}\n"
            )
        };
        let p = |s: &Study| -> Vec<f64> {
            s.select_models
                .iter()
                .map(|m| m.prior_probability)
                .collect()
        };
        // their plain sum is +inf, which made every probability 0 and the reversible jump fail
        assert_eq!(p(&load(&two("1e308", "1e308")).unwrap()), [0.5, 0.5]);
        assert_eq!(
            p(&load(&two("3e307", "1e308")).unwrap()),
            [0.23076923076923075, 0.7692307692307692]
        );
        let q = p(&load(&two("1e-300", "1e-301")).unwrap());
        assert!((q[0] - 10.0 / 11.0).abs() < 1e-15, "{q:?}");
        let e = err(&two("1.7e308", "1e-10"));
        assert!(e.contains("select.model[1].prior_probability"), "{e}");
    }

    #[test]
    fn errors_name_file_and_field() {
        let e = err(&format!("{OK}\nbogus = 3\n"));
        assert!(e.contains("study.toml") && e.contains("bogus"), "{e}");
        let e = err(&OK.replace("seed = 1", "seed = \"x\""));
        assert!(e.contains("seed"), "{e}");
        let e = err(&OK.replace("seed = 1\n", ""));
        assert!(e.contains("seed"), "{e}");
        let e = err(&format!("{OK}pre_pad = -5.0\n"));
        assert!(
            e.contains("experiment[0].pre_pad") && e.contains("≥ 0"),
            "{e}"
        );
        let e = err(&format!(
            "{OK}x12 = {{ kind = \"sine\", freq = 6.0, amplitude = 1e-6, duration = 100.0 }}\n"
        ));
        assert!(
            e.contains("experiment[0].x12.freq") && e.contains("Nyquist"),
            "{e}"
        );
        let e = err(&format!("{OK}[truth]\na_df = nan\n"));
        assert!(e.contains("truth.a_df"), "{e}");
        let e = err(&format!("{OK}[truth]\na_df = -0.5\n"));
        assert!(e.contains("unstable"), "{e}");
        let e = err(&format!("{OK}[noise]\ntm_accel = -1.0\n"));
        assert!(e.contains("noise.tm_accel"), "{e}");
        let e = err(&OK.replace("tn3045_x1", "nope"));
        assert!(
            e.contains("experiment[0].design") && e.contains("tn3045_x12"),
            "{e}"
        );
        let e = err(&format!("{OK}[simulation]\ntarget_snr = inf\n"));
        assert!(e.contains("simulation.target_snr"), "{e}");
    }

    #[test]
    fn a_target_snr_on_another_scale_reaches_the_simulator_as_rho_opt() {
        let plan = |sim: &str| {
            load(&format!("{OK}[simulation]\n{sim}\n"))
                .unwrap()
                .simulation_plan()
                .target_snr
                .unwrap()
        };
        assert_eq!(plan("target_snr = 28.0"), 28.0);
        let stnr = plan("target_snr = 28.0\nsnr_definition = \"ltpda_stnr\"");
        assert!((stnr - 28.0 / 2f64.sqrt()).abs() < 1e-12, "{stnr}");
        // 0 dB and below are SNRs too: ρ_opt = 1 and 0.1
        assert_eq!(plan("target_snr = 0.0\nsnr_definition = \"db\""), 1.0);
        assert!((plan("target_snr = -20.0\nsnr_definition = \"db\"") - 0.1).abs() < 1e-15);
        // the bound is on ρ_opt, and the message says it on the study's scale
        let e = err(&format!(
            "{OK}[simulation]\ntarget_snr = 200.0\nsnr_definition = \"db\"\n"
        ));
        assert!(
            e.contains("simulation.target_snr") && e.contains("here 120 at most"),
            "{e}"
        );
        let e = err(&format!(
            "{OK}[simulation]\ntarget_snr = 0.0\nsnr_definition = \"ltpda_stnr\"\n"
        ));
        assert!(e.contains("simulation.target_snr"), "{e}");
        let e = err(&format!("{OK}[simulation]\nsnr_definition = \"stnr\"\n"));
        assert!(
            e.contains("snr_definition") && e.contains("ltpda_stnr"),
            "{e}"
        );
    }

    #[test]
    fn jump_proposal_source_is_chosen_by_name() {
        let with = |v: &str| {
            let t = OK.replacen(
                "[[experiment]]",
                &format!("[select]\njump_proposal = {v}\n[[experiment]]"),
                1,
            );
            load(&t)
        };
        assert_eq!(load(OK).unwrap().select.jump_proposal, JumpProposal::Chain);
        assert_eq!(
            with("\"fisher\"").unwrap().select.jump_proposal,
            JumpProposal::Fisher
        );
        let e = with("\"prior\"").unwrap_err().to_string();
        assert!(e.contains("jump_proposal") && e.contains("chain"), "{e}");
    }

    /// `kind = "accel"` and `kind = "tied"` models: parameters, defaults from the study, and the
    /// messages for a bad parent, a bad tie and an unphysical option.
    #[test]
    fn acceleration_domain_and_tied_models() {
        let models = r#"
[[model]]
kind = "accel"
name = "full"
delay = true
[[model]]
kind = "tied"
name = "sym"
of = "full"
tie = { a2 = "a1", f_o2 = "f_o1", tau_c2 = "tau_c1" }
[fit]
model = "sym"
"#;
        let s = load(&format!("oms_delay = 0.3\n{OK}{models}")).unwrap();
        let full = &s.models.models[s.models.index("full").unwrap()];
        assert_eq!(full.param_names().len(), 8);
        match &s.models.defs[s.models.index("full").unwrap()] {
            ModelDef::Accel { options, .. } => {
                assert_eq!(options.tau_ifo, 0.3);
                assert_eq!(options.d21, s.truth.d21);
            }
            d => panic!("{d:?}"),
        }
        let sym = &s.models.models[s.fit_model.model];
        assert_eq!(sym.param_names(), ["w1sq", "w2sq", "a1", "f_o1", "tau_c1"]);
        // the tied model's priors are its parent's defaults, by name
        assert_eq!(
            s.models.priors[s.fit_model.model].names(),
            sym.param_names()
        );

        let bad = |m: &str| err(&format!("{OK}{m}"));
        let e = bad(
            "[[model]]\nkind = \"tied\"\nname = \"t\"\nof = \"nothing\"\ntie = { a2 = \"a1\" }\n",
        );
        assert!(e.contains("model[0]") && e.contains("nothing"), "{e}");
        let e = bad(
            "[[model]]\nkind = \"accel\"\nname = \"a\"\n[[model]]\nkind = \"tied\"\nname = \"t\"\nof = \"a\"\ntie = { a3 = \"a1\" }\n",
        );
        assert!(
            e.contains("model[1]") && e.contains("`a3` is not a parameter"),
            "{e}"
        );
        let e = bad("[[model]]\nkind = \"accel\"\nname = \"a\"\ntau_ifo = -1.0\n");
        assert!(e.contains("model[0]") && e.contains("tau_ifo"), "{e}");
        let e = bad("[[model]]\nkind = \"accel\"\nname = \"a\"\npoles = true\n");
        assert!(e.contains("model[0]") && e.contains("poles"), "{e}");
        let e = bad("[[model]]\nkind = \"acel\"\nname = \"a\"\n");
        assert!(e.contains("\"accel\""), "{e}");
    }
}
