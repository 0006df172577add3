//! From a study to likelihoods: get the data (load a dataset or simulate the study), reduce
//! each experiment to in-band spectra of a model's data channels with a residual-noise
//! estimate, and build `ln L` of that model with its normalised prior. Shared by `occam fit`,
//! `occam select` and `occam sweep`.

use crate::config::{ModelSpec, Study};
use crate::data::dataset::Dataset;
use crate::experiment::simulate;
use crate::likelihood::{
    ExperimentSpectra, Likelihood, RelBinLikelihood, RelBinOptions, SpectraOptions,
};

pub use super::analysis_error::AnalysisError;
pub use super::map_search::{MAP_MAX_ITER, map_search};

/// Data and the likelihood of a job's first model, ready for samplers.
#[derive(Debug, Clone)]
pub struct Prepared {
    pub dataset: Dataset,
    /// Where the data came from (a path, or "simulated from `<study>`").
    pub origin: String,
    /// The exact likelihood of model [`model`](Self::model).
    pub likelihood: Likelihood,
    /// The index (in the study's models) of the model `likelihood` is of: the `[fit]` model's
    /// for `fit`, the first compared model's for `select`.
    pub model: usize,
    /// What glitch gating did, per experiment (empty when the study gates nothing: no
    /// `[analysis] glitches = "gate"` and no listed `[[experiment]] glitches`).
    pub glitch_gates: Vec<crate::likelihood::GlitchGate>,
    /// With `[analysis] glitches = "model"`: the study whose models carry the glitches found
    /// on the data, with their starts in `[fit] start` ([`crate::jobs::glitch_model`]); the
    /// job runs on it. `None` otherwise.
    pub study: Option<Box<Study>>,
    /// The modelled glitches (empty unless `glitches = "model"`).
    pub glitch_candidates: Vec<crate::jobs::glitch_model::GlitchCandidate>,
    /// The candidates found but not modelled: the data did not support them.
    pub glitch_dropped: Vec<crate::jobs::glitch_model::GlitchCandidate>,
    /// Where the residual noise of `likelihood` was evaluated when it depends on the `[fit]`
    /// model's parameters ([`crate::jobs::own_noise`]; set by [`prepare`] only).
    pub noise_point: Option<crate::jobs::noise_point::NoisePoint>,
}

impl Prepared {
    /// The study the job runs on: [`Prepared::study`] when glitches are modelled, else `study`.
    pub fn study<'a>(&'a self, study: &'a Study) -> &'a Study {
        self.study.as_deref().unwrap_or(study)
    }

    /// `msg` (an error of the fit) led by the gates that took most of an experiment's data,
    /// when there are any: the likely cause, which the run's warnings would say only had it
    /// succeeded.
    pub fn lead_with_data_loss(&self, msg: String) -> String {
        let lost: Vec<String> = self
            .glitch_gates
            .iter()
            .filter(|g| g.gated_most())
            .map(|g| g.describe())
            .collect();
        if lost.is_empty() {
            msg
        } else {
            format!("{}. Then: {msg}", lost.join(". "))
        }
    }

    /// The notes of what was done to the data's glitches (gated or modelled).
    pub fn glitch_notes(&self) -> Vec<String> {
        let mut out = glitch_notes(&self.glitch_gates);
        if self.study.is_some() {
            let names: Vec<String> = self
                .dataset
                .experiments
                .iter()
                .map(|e| e.name.clone())
                .collect();
            out.extend(crate::jobs::glitch_model::glitch_model_notes(
                &self.glitch_candidates,
                &self.glitch_dropped,
                &names,
            ));
        }
        out
    }
}

/// The data of a study and where they came from: the `[analysis] dataset` directory, or every
/// `[[experiment]]` simulated or read from its `data` file, in the order of the study file.
/// A data file must hold the channels of every model of the study; a job that uses only some
/// of them reads only theirs with [`load_data_for`].
pub fn load_data(study: &Study) -> Result<(Dataset, String), AnalysisError> {
    let all: Vec<usize> = (0..study.models.models.len()).collect();
    load_data_for(study, &all)
}

/// The channels models `models` read, each with the models that read it (`model `a`, model
/// `b``), in first-use order.
fn channels_of(study: &Study, models: &[usize]) -> Vec<(String, String)> {
    let mut channels: Vec<(String, Vec<String>)> = Vec::new();
    for &mi in models {
        let name = format!("`{}`", study.models.defs[mi].name());
        for c in study.models.models[mi].data_channels() {
            match channels.iter_mut().find(|(k, _)| k == c) {
                Some((_, by)) if !by.contains(&name) => by.push(name.clone()),
                Some(_) => {}
                None => channels.push((c.clone(), vec![name.clone()])),
            }
        }
    }
    channels
        .into_iter()
        .map(|(c, by)| {
            let what = if by.len() == 1 { "model" } else { "models" };
            (c, format!("{what} {}", by.join(", ")))
        })
        .collect()
}

/// [`load_data`] for a job that uses only the models `models` (indices into the study's
/// models): a data file needs only the channels those models read.
pub fn load_data_for(study: &Study, models: &[usize]) -> Result<(Dataset, String), AnalysisError> {
    if let Some(p) = &study.analysis.dataset {
        // the key and the study file first: the path may be a typo the user must find
        let d = Dataset::read(p).map_err(|e| {
            AnalysisError::Likelihood(format!(
                "{}: `analysis.dataset` = {}: {e}",
                study.source,
                p.display()
            ))
        })?;
        d.check_names(&study.experiment_names).map_err(|e| {
            AnalysisError::Likelihood(format!(
                "{}: `analysis.dataset` = {}: {e}",
                study.source,
                p.display()
            ))
        })?;
        return Ok((d, p.display().to_string()));
    }
    let mut sim = if study.experiments.is_empty() {
        None
    } else {
        Some(simulate(&study.simulation_plan())?.dataset)
    };
    if study.data_sources.is_empty() {
        let d = sim.expect("a study has at least one experiment");
        return Ok((
            d,
            format!("simulated from {} (seed {})", study.source, study.seed),
        ));
    }
    let channels = channels_of(study, models);
    let mut experiments = Vec::new();
    let mut files = Vec::new();
    for name in &study.experiment_names {
        if let Some((_, src)) = study.data_sources.iter().find(|(n, _)| n == name) {
            let mut e = src.load_read_by(name, &study.base_dir, &channels)?;
            if let Some((_, d)) = study.commanded.iter().find(|(n, _)| n == name) {
                crate::experiment::fill_commanded(&mut e, d).map_err(|m| {
                    AnalysisError::Likelihood(format!(
                        "experiment `{name}` ({}): {m}",
                        src.data.display()
                    ))
                })?;
            }
            experiments.push(e);
            files.push(src.data.display().to_string());
        } else {
            let s = sim.as_mut().expect("simulated experiments exist");
            let k = s
                .experiments
                .iter()
                .position(|e| &e.name == name)
                .expect("every design was simulated");
            experiments.push(s.experiments.swap_remove(k));
        }
    }
    let simulated = sim.is_some();
    let origin = if simulated {
        format!(
            "read from {} and simulated from {} (seed {})",
            files.join(", "),
            study.source,
            study.seed
        )
    } else {
        format!("read from {}", files.join(", "))
    };
    let extra = sim
        .map(|s| s.extra)
        .unwrap_or_else(|| serde_json::json!({ "source": study.source }));
    Ok((
        Dataset {
            experiments,
            seed: None,
            truth: None,
            extra,
        },
        origin,
    ))
}

/// Loads or simulates the data and builds the exact likelihood of the `[fit]` model; a data
/// file needs only the channels that model reads.
///
/// When the residual noise depends on the `[fit]` model's free parameters (`noise = "model"`
/// through the model's own dynamics), the noise is evaluated at the model's own MAP, iterated
/// ([`crate::jobs::own_noise`]), not at the study's reference point.
pub fn prepare(study: &Study) -> Result<Prepared, AnalysisError> {
    let mut prep = prepare_for(study, &[study.fit_model.model])?;
    if prep.study.is_none() {
        let spec = &study.fit_model;
        let start = default_start(study, spec);
        let mi = spec.model;
        let build = |at: &[f64]| likelihood_at(study, mi, &prep.dataset, at);
        let reference = reference_point(study, mi);
        if let Some((lik, point)) =
            crate::jobs::own_noise::own_noise_likelihood(study, spec, &start, reference, &build)?
        {
            prep.likelihood = lik;
            prep.noise_point = Some(point);
        }
    }
    Ok(prep)
}

/// Loads or simulates the data a job on models `models` (indices into the study's models, at
/// least one) needs — the channels those models read — and builds the exact likelihood of the
/// first of them.
pub fn prepare_for(study: &Study, models: &[usize]) -> Result<Prepared, AnalysisError> {
    let first = *models
        .first()
        .ok_or_else(|| AnalysisError::Likelihood("a job needs at least one model".into()))?;
    let (mut dataset, origin) = load_data_for(study, models)?;
    let glitch_gates = gate_glitches(study, first, &mut dataset)?;
    if study.analysis.glitches != crate::likelihood::GlitchTreatment::Model {
        let likelihood = likelihood_of(study, first, &dataset)?;
        return Ok(Prepared {
            dataset,
            origin,
            likelihood,
            model: first,
            glitch_gates,
            study: None,
            glitch_candidates: Vec::new(),
            glitch_dropped: Vec::new(),
            noise_point: None,
        });
    }
    // the loop fitted without glitches: where they are found and their starts made
    let physics = detection_point(study, first, &dataset)?;
    let build = |s: &Study, d: &Dataset| likelihood_of(s, first, d).map_err(|e| e.to_string());
    let (modelled, likelihood) = crate::jobs::glitch_model::model_glitches(
        study,
        models,
        &mut dataset,
        &spectra_options(study),
        &physics,
        &first_spec(study, first).free,
        &build,
    )
    .map_err(|m| AnalysisError::Likelihood(format!("glitches = \"model\": {m}")))?
    .ok_or_else(|| AnalysisError::Likelihood("glitches = \"model\" made no model".into()))?;
    Ok(Prepared {
        dataset,
        origin,
        likelihood,
        model: first,
        glitch_gates,
        study: Some(Box::new(modelled.study)),
        glitch_candidates: modelled.candidates,
        glitch_dropped: modelled.dropped,
        noise_point: None,
    })
}

/// The spec whose start the glitch search uses for model `mi`: the `[fit]` model's when it is
/// `mi`, else that of the first `[[select.model]]` on it, else every parameter free.
fn first_spec(study: &Study, mi: usize) -> ModelSpec {
    if study.fit_model.model == mi {
        return study.fit_model.clone();
    }
    if let Some(s) = study.select_models.iter().find(|s| s.spec.model == mi) {
        return s.spec.clone();
    }
    let n = study.models.models[mi].param_names().len();
    ModelSpec {
        model: mi,
        free: (0..n).collect(),
        base: study.models.priors[mi]
            .kinds()
            .iter()
            .map(|k| k.centre())
            .collect(),
    }
}

/// The models a `select` of `study` uses: the `[fit]` model when some `[[select.model]]` is a
/// sub-model of it (so that its prepared likelihood is reused), then every other parent model,
/// ascending.
pub fn select_models(study: &Study) -> Vec<usize> {
    let mut parents: Vec<usize> = study.select_models.iter().map(|m| m.spec.model).collect();
    parents.sort_unstable();
    parents.dedup();
    if let Some(k) = parents.iter().position(|&m| m == study.fit_model.model) {
        parents[..=k].rotate_right(1);
    }
    parents
}

/// [`prepare_for`] the models `select` compares ([`select_models`]); the `[fit]` model when
/// the study has no `[[select.model]]` (which `select` then refuses with its own message).
pub fn prepare_select(study: &Study) -> Result<Prepared, AnalysisError> {
    let models = select_models(study);
    if models.is_empty() {
        return prepare(study);
    }
    prepare_for(study, &models)
}

/// The effective number of Welch averages behind one experiment's noise reference, per decade
/// of its fit band (issue 22: few averages make the Whittle likelihood overconfident).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct NoiseAverages {
    pub experiment: String,
    /// Per decade holding fit bins: `[f_lo, f_hi]` (Hz) and the lowest and highest `M_eff`
    /// (`ν/2`, Percival & Walden eq. 292b) of its bins.
    pub decades: Vec<DecadeAverages>,
}

/// [`NoiseAverages`] of one decade.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct DecadeAverages {
    pub band: [f64; 2],
    pub m_eff_min: f64,
    pub m_eff_max: f64,
}

/// The averages per decade of every experiment of `lik` with a Welch noise reference (empty
/// with `noise = "model"`).
pub fn noise_averages(lik: &Likelihood) -> Vec<NoiseAverages> {
    lik.spectra()
        .iter()
        .filter_map(|sp| {
            crate::likelihood::averages_per_decade(sp).map(|d| NoiseAverages {
                experiment: sp.name.clone(),
                decades: d
                    .into_iter()
                    .map(|(lo, hi, a, b)| DecadeAverages {
                        band: [lo, hi],
                        m_eff_min: a,
                        m_eff_max: b,
                    })
                    .collect(),
            })
        })
        .collect()
}

/// [`noise_averages`] for the summary: present when the number of averages shapes the
/// likelihood or varies over the band (statistic `student_t` or `wishart`, or
/// `welch_resolution = "per_band"`), absent otherwise so that existing summaries are unchanged.
pub fn noise_averages_for_summary(study: &Study, lik: &Likelihood) -> Option<Vec<NoiseAverages>> {
    use crate::likelihood::{Statistic, WelchResolution};
    let shown = matches!(lik.statistic(), Statistic::StudentT | Statistic::Wishart)
        || study.analysis.welch_resolution == WelchResolution::PerBand;
    let n = noise_averages(lik);
    (shown && !n.is_empty()).then_some(n)
}

/// One line per experiment: `M_eff` per decade of the band, for the job's log. The runs
/// between the gaps of one experiment (`inv1@171s`, …: one noise reference each) are one line
/// (each decade's range over the runs that reach it), not one per run.
pub fn noise_averages_lines(study: &Study, lik: &Likelihood) -> Vec<String> {
    // (experiment, runs merged, decades)
    let mut merged: Vec<(String, usize, Vec<DecadeAverages>)> = Vec::new();
    for n in noise_averages(lik) {
        let base = run_parent(&n.experiment)
            .unwrap_or(&n.experiment)
            .to_string();
        match merged.last_mut() {
            Some((name, runs, decades)) if *name == base && run_parent(&n.experiment).is_some() => {
                *runs += 1;
                for d in n.decades {
                    match decades.iter_mut().find(|o| o.band == d.band) {
                        Some(o) => {
                            o.m_eff_min = o.m_eff_min.min(d.m_eff_min);
                            o.m_eff_max = o.m_eff_max.max(d.m_eff_max);
                        }
                        None => decades.push(d),
                    }
                }
                decades.sort_by(|a, b| a.band[0].total_cmp(&b.band[0]));
            }
            _ => merged.push((base, 1, n.decades)),
        }
    }
    merged
        .iter()
        .map(|(name, runs, decades)| {
            let d: Vec<String> = decades
                .iter()
                .map(|d| {
                    let m = if d.m_eff_min == d.m_eff_max {
                        format!("{:.1}", d.m_eff_min)
                    } else {
                        format!("{:.1}–{:.1}", d.m_eff_min, d.m_eff_max)
                    };
                    format!("[{:.0e}, {:.0e}) Hz: {m}", d.band[0], d.band[1])
                })
                .collect();
            format!(
                "noise reference of `{name}` (Welch, {} averages, {} resolution{}): effective averages per decade {}",
                study.analysis.welch_averages,
                match study.analysis.welch_resolution {
                    crate::likelihood::WelchResolution::Fixed => "fixed",
                    crate::likelihood::WelchResolution::PerBand => "per_band",
                },
                if *runs > 1 {
                    format!("; its {runs} runs between gaps")
                } else {
                    String::new()
                },
                d.join("; ")
            )
        })
        .collect()
}

/// The index in `lik`'s spectra of experiment `name`, or of its first run between gaps
/// (`inv1@171s`): the experiment's model either way.
pub fn spectra_index(lik: &Likelihood, name: &str) -> Option<usize> {
    lik.spectra()
        .iter()
        .position(|s| s.name == name || run_parent(&s.name) == Some(name))
}

/// The experiment a run between gaps belongs to: `inv1` for `inv1@171s` (the names
/// [`crate::likelihood::GapSummary`]'s runs get), `None` for any other name.
fn run_parent(name: &str) -> Option<&str> {
    let (base, at) = name.rsplit_once('@')?;
    at.strip_suffix('s')?.parse::<f64>().ok().map(|_| base)
}

/// The log's first line of a fit or select: where the data come from, how many experiments and
/// bins in band (`data: simulated from … (1 experiment, 7634 bins in band)`).
pub fn data_line(prep: &Prepared) -> String {
    let n = prep.dataset.experiments.len();
    format!(
        "data: {} ({n} experiment{}, {} bins in band)",
        prep.origin,
        if n == 1 { "" } else { "s" },
        prep.likelihood.n_bins()
    )
}

/// The spectral options of a study.
pub fn spectra_options(study: &Study) -> SpectraOptions {
    let a = &study.analysis;
    SpectraOptions {
        band: a.band,
        window: a.window,
        noise: a.noise,
        welch_averages: a.welch_averages,
        welch_window: a.welch_window,
        gap_taper: a.gap_taper.unwrap_or(crate::likelihood::DEFAULT_GAP_TAPER),
        welch_resolution: a.welch_resolution,
    }
}

/// The true values a study's simulation uses, by parameter name: the seven loop parameters of
/// `[truth]` and, when known, the actuators of `[simulation.actuators]` as the
/// acceleration-domain model names them (`a1, a2` gains, `f_o1, f_o2` poles where there is
/// one, `tau_c1, tau_c2` delays).
pub fn true_values(
    truth: &crate::ltp::LtpParams,
    actuators: Option<&[crate::config::Actuator; 2]>,
) -> Vec<(String, f64)> {
    let mut v: Vec<(String, f64)> = crate::ltp::PARAM_NAMES
        .iter()
        .zip(truth.to_array())
        .map(|(n, x)| (n.to_string(), x))
        .collect();
    for (i, a) in actuators.into_iter().flatten().enumerate() {
        v.push((format!("a{}", i + 1), a.gain));
        if let Some(p) = a.pole {
            v.push((format!("f_o{}", i + 1), p));
        }
        v.push((format!("tau_c{}", i + 1), a.delay));
    }
    v
}

/// The true actuators recorded in a dataset's metadata (`extra.actuators.tm1`, `.tm2`), if
/// any (datasets written before actuators existed have none).
fn dataset_actuators(dataset: &Dataset) -> Option<[crate::config::Actuator; 2]> {
    let a = dataset.extra.get("actuators")?;
    let one = |k: &str| serde_json::from_value(a.get(k)?.clone()).ok();
    Some([one("tm1")?, one("tm2")?])
}

/// The reference point of model `mi`: the truth where the model has the truth's parameters
/// (the loop's `[truth]` and the simulated actuators, or `[simulation.truth]` when a model
/// generates the data), else `[fit] start`, else the prior
/// centre. The residual noise is evaluated there.
pub fn reference_point(study: &Study, mi: usize) -> Vec<f64> {
    let m = &study.models.models[mi];
    let prior = &study.models.priors[mi];
    let truth = match &study.simulation.model {
        // the data's generator knows its own truth; the loop's [truth] plays no part
        Some(_) => study
            .simulation
            .truth
            .iter()
            .map(|(k, v)| (k.clone(), *v))
            .collect(),
        None => true_values(
            &study.truth,
            Some(&study.simulation.actuators.resolve(study.truth.a_sus)),
        ),
    };
    let truth = [drift_truth(study, mi, &truth), truth].concat();
    m.param_names()
        .iter()
        .enumerate()
        .map(|(i, n)| {
            truth
                .iter()
                .find(|(t, _)| t == n)
                .map(|(_, v)| *v)
                .or_else(|| study.fit.start.as_ref().and_then(|s| s.get(n).copied()))
                .unwrap_or_else(|| prior.kinds()[i].centre())
        })
        .collect()
}

/// The true values of the parameters of model `mi` when it drifts between stretches
/// (`kind = "drift"`), from the truth of the loop in each stretch (`base`, by name, with the
/// stretch's own `truth` values over it): per-stretch values as they are, a linear drift by
/// least squares (exact for a linear drift). Empty for any other model. Parameters whose truth
/// is unknown are left out.
pub fn drift_truth(study: &Study, mi: usize, base: &[(String, f64)]) -> Vec<(String, f64)> {
    let Some(Some(d)) = study.models.drifts.get(mi) else {
        return Vec::new();
    };
    let parent = d.parent_names();
    let per: Vec<Vec<f64>> = study
        .stretches
        .entries
        .iter()
        .map(|s| {
            parent
                .iter()
                .map(|n| {
                    s.truth
                        .get(n)
                        .copied()
                        .or_else(|| base.iter().find(|(b, _)| b == n).map(|(_, v)| *v))
                        .unwrap_or(f64::NAN)
                })
                .collect()
        })
        .collect();
    crate::model::Model::param_names(d.as_ref())
        .iter()
        .cloned()
        .zip(d.values_from_stretches(&per))
        .filter(|(_, v)| v.is_finite())
        .collect()
}

/// The exact likelihood of model `mi` of the study on `dataset`, of the study's statistic
/// (`[analysis] statistic`).
pub fn likelihood_of(
    study: &Study,
    mi: usize,
    dataset: &Dataset,
) -> Result<Likelihood, AnalysisError> {
    likelihood_at(study, mi, dataset, &reference_point(study, mi))
}

/// [`likelihood_of`] with the residual noise (and the gaps' edge correction) evaluated at
/// `reference` instead of [`reference_point`] (a model whose noise depends on θ:
/// [`crate::jobs::own_noise`]).
pub fn likelihood_at(
    study: &Study,
    mi: usize,
    dataset: &Dataset,
    reference: &[f64],
) -> Result<Likelihood, AnalysisError> {
    let opts = spectra_options(study);
    let sys = study.system();
    let csd = |f: f64| sys.noise_csd(f);
    let model = study.models.models[mi].clone();
    let a = &study.analysis;
    if a.statistic == crate::likelihood::Statistic::LogPeriodogram
        && let Some(e) = dataset.experiments.iter().find(|e| e.has_gaps())
    {
        return Err(AnalysisError::Likelihood(format!(
            "experiment `{}` has gaps, which `statistic = \"log_periodogram\"` (a Welch average of the residual's time series) does not handle; use \"whittle\" or \"student_t\"",
            e.name
        )));
    }
    let mut spectra = Vec::new();
    for e in &dataset.experiments {
        // the model as it applies to this experiment's stretch: its edge correction and
        // residual noise are evaluated there
        let cov = study.covariates_of(&e.name);
        let here = model
            .specialise(&cov)
            .map_err(|m| {
                AnalysisError::Likelihood(format!(
                    "model `{}`, experiment `{}`: {m}",
                    model.name(),
                    e.name
                ))
            })?
            .unwrap_or_else(|| model.clone());
        let mut sp =
            ExperimentSpectra::of_experiment(e, &opts, here.as_ref(), reference, Some(&csd))?;
        for s in &mut sp {
            s.covariates = cov.clone();
        }
        spectra.extend(sp);
    }
    Likelihood::new(model, spectra, study.models.priors[mi].clone())
        .and_then(|l| l.with_statistic(a.statistic, &a.log_periodogram, &dataset.experiments))
        .map_err(|e| AnalysisError::Likelihood(e.to_string()))
}

/// The likelihood the samplers of `exact` run on: the study's `[analysis] likelihood`, except
/// that relative binning (an approximation of the Whittle sum) gives way to the exact `ln L`
/// for any other statistic, with the message saying so.
pub fn sampled_kind(
    study: &Study,
    exact: &Likelihood,
) -> (crate::config::LikelihoodKind, Option<String>) {
    let kind = study.analysis.likelihood;
    let stat = exact.statistic();
    if kind == crate::config::LikelihoodKind::Relbin
        && stat != crate::likelihood::Statistic::Whittle
    {
        let why = format!(
            "relative binning approximates the Whittle likelihood only: with statistic = \"{}\" the samplers run on the exact ln L",
            stat.name()
        );
        return (crate::config::LikelihoodKind::Exact, Some(why));
    }
    if kind == crate::config::LikelihoodKind::Relbin
        && crate::model::glitch::carries_glitches(exact.model().as_ref())
    {
        // each coarse edge's coefficient needs the glitches' causal response over the whole
        // record, which is the exact kernel's cost already: binning would only add its
        // set-up (minutes on examples/glitches.toml) and its error
        let why = "modelled glitches: the samplers run on the exact ln L (its glitch kernel), which costs what a relative-binned one would: the glitches' response is computed over the whole record either way".to_string();
        return (crate::config::LikelihoodKind::Exact, Some(why));
    }
    (kind, None)
}

/// The study's relative-binning settings.
pub fn relbin_options(study: &Study) -> RelBinOptions {
    RelBinOptions {
        n_sigma: study.analysis.relbin_sigma,
        tolerance: study.analysis.relbin_tolerance,
        ..Default::default()
    }
}

/// The relative-binned likelihood around `fiducial` with the study's accuracy settings,
/// validated in the region of the Fisher covariance at `fiducial` over all parameters
/// ([`RelBinLikelihood::validation`] holds the measured error). When the error cannot be
/// brought below the limit the error is [`AnalysisError::RelBin`] with
/// [`crate::likelihood::RelBinError::ToleranceNotMet`]: fall back to the exact likelihood.
pub fn relbin_of(
    study: &Study,
    exact: &Likelihood,
    fiducial: &[f64],
) -> Result<RelBinLikelihood, AnalysisError> {
    Ok(RelBinLikelihood::new(
        exact,
        fiducial,
        &relbin_options(study),
    )?)
}

/// The start of a MAP search for `model`: `[fit] start` values, else the prior centre (box
/// midpoint or Gaussian mean; for a log-uniform box, the geometric mean); fixed values as
/// given.
pub fn default_start(study: &Study, model: &ModelSpec) -> Vec<f64> {
    let mut th = model.base.clone();
    let prior = &study.models.priors[model.model];
    let names = study.models.models[model.model].param_names();
    for &i in &model.free {
        th[i] = prior.kinds()[i].centre();
        if let Some(v) = study.fit.start.as_ref().and_then(|s| s.get(&names[i])) {
            th[i] = *v;
        }
    }
    th
}

/// The injected lines of every experiment of `lik` (in its order), for
/// [`crate::likelihood::information::Information`]: the sine segments of the study's
/// waveforms on `x1` and `x12`, labelled by channel. An experiment of loaded data, or with
/// other waveforms, has none (its bins are then all "elsewhere").
pub fn injection_lines(
    study: &Study,
    lik: &Likelihood,
) -> Vec<Vec<crate::likelihood::information::Line>> {
    lik.spectra()
        .iter()
        .map(|sp| {
            study
                .experiments
                .iter()
                .find(|e| e.name == sp.name)
                .map(|e| {
                    [("x1", &e.x1), ("x12", &e.x12)]
                        .iter()
                        .flat_map(|(c, w)| w.segments().iter().map(|s| (c.to_string(), s.freq)))
                        .collect()
                })
                .unwrap_or_default()
        })
        .collect()
}

/// The true parameter values of model `mi` that the dataset knows, by name (the loop's and,
/// when the dataset records them, the actuators'; or those of the model that generated it).
pub fn truth_of(study: &Study, mi: usize, dataset: &Dataset) -> Option<Vec<Option<f64>>> {
    let vals = match dataset.truth {
        Some(t) => true_values(&t, dataset_actuators(dataset).as_ref()),
        // data generated by a model record its truth by parameter name
        None => dataset
            .extra
            .get("truth_values")?
            .as_object()?
            .iter()
            .filter_map(|(k, v)| Some((k.clone(), v.as_f64()?)))
            .collect(),
    };
    // a drifting model's truth comes from the stretches' (simulated by the built-in loop)
    let vals = match dataset.truth {
        Some(_) => [drift_truth(study, mi, &vals), vals].concat(),
        None => vals,
    };
    Some(
        study.models.models[mi]
            .param_names()
            .iter()
            .map(|n| vals.iter().find(|(p, _)| p == n).map(|(_, v)| *v))
            .collect(),
    )
}

/// Warnings about the noise estimate of model `mi`: a fit band that starts below the lowest
/// frequency the Welch estimate of an experiment's noise-only stretch resolves, where the
/// residual PSD is the nearest (lowest-frequency) estimate extrapolated, for a model whose
/// residual combines more noisy channels than it has residuals (the acceleration domain: a12
/// from o1, o12, g1, g2). Its residual noise is a small difference of large correlated terms,
/// and an extrapolated CSD does not cancel: a 3000 s stretch under a 1 mHz band edge made the
/// stiffnesses' Fisher errors 1.5× too small (`tests/accel.rs`). The closed loop (`M_o = I`)
/// has no such cancellation and is not warned about.
pub fn noise_warnings(study: &Study, mi: usize, dataset: &Dataset) -> Vec<String> {
    let opts = spectra_options(study);
    let m = &study.models.models[mi];
    if opts.noise != crate::likelihood::NoiseSource::Welch {
        return Vec::new();
    }
    dataset
        .experiments
        .iter()
        .filter_map(|e| {
            let noisy: Vec<&[f64]> = m
                .data_channels()
                .iter()
                .filter_map(|c| e.noise_channel(c))
                .collect();
            if noisy.len() <= m.residual_channels().len() {
                return None;
            }
            let len = noisy[0].len();
            let seg = match opts.welch_resolution {
                crate::likelihood::WelchResolution::Fixed => {
                    crate::likelihood::welch_segment_len(len, &opts)
                }
                // the longest segment is the whole stretch
                crate::likelihood::WelchResolution::PerBand => len,
            };
            let first = e.fs / seg.max(1) as f64;
            (opts.band[0] < first).then(|| {
                let ov = opts.welch_window.recommended_overlap();
                let need =
                    (1.0 + (opts.welch_averages as f64 - 1.0) * (1.0 - ov)) / opts.band[0];
                format!(
                    "model `{}`, experiment `{}`: the fit band starts at {:.3e} Hz, below the lowest frequency the noise-only stretch resolves with {} Welch averages ({first:.3e} Hz); this model's residual noise is a difference of correlated channels, and extrapolated there it can be badly wrong: make noise_duration at least {need:.0} s, lower [analysis] welch_averages, or raise the band's lower edge",
                    m.name(),
                    e.name,
                    opts.band[0],
                    opts.welch_averages,
                )
            })
        })
        .collect()
}

/// What the gaps are and how they are analysed, as `(notes, warnings)`. Notes (facts, not
/// problems: gaps are routine in real data): one line per experiment with gaps, how many, how
/// much is missing, how many valid runs are analysed ([`crate::likelihood::GapSummary`]), and
/// the commanded channels known through them from the design. Warnings: one per experiment
/// where an input (a channel of the study's models with no noise-only series) is missing
/// inside a gap while it is active within `gap_taper` of it: the edge correction of
/// [`crate::likelihood::ExperimentSpectra::of_experiment`] cannot include its response.
pub fn gap_notes(study: &Study, dataset: &Dataset) -> (Vec<String>, Vec<String>) {
    let opts = spectra_options(study);
    let (mut out, mut warnings) = (Vec::new(), Vec::new());
    for e in &dataset.experiments {
        let Some(s) = crate::likelihood::GapSummary::of(e, &opts) else {
            continue;
        };
        out.push(s.describe());
        if let Some((_, d)) = study.commanded.iter().find(|(n, _)| *n == e.name) {
            let known: Vec<String> = d
                .channel_waveforms()
                .into_iter()
                .map(|(c, _)| c)
                .filter(|c| e.known_in_gaps.contains(c))
                .map(|c| format!("`{c}`"))
                .collect();
            if !known.is_empty() {
                out.push(format!(
                    "experiment `{}`: the commanded {} known through its gaps from the study's design (which agrees with the file outside them)",
                    e.name,
                    known.join(", ")
                ));
            }
        }
        let hot = missing_injections(study, e, &opts).len();
        if hot > 0 {
            warnings.push(format!(
                "experiment `{}`: in {hot} of its {} gap(s) an injection is missing while it runs beside the gap (non-zero within gap_taper = {} s of it); the loop's response to what it did in the gap is unknown and the edge correction cannot include it, which biases the estimates at high SNR: supply the commanded injection through the gap, or give the experiment's design beside its data (`design`, `x1`, `x12`, `pre_pad`, …) and occam fills it in (docs: \"Real data: gaps\")",
                e.name,
                e.gaps.len(),
                opts.gap_taper
            ));
        }
    }
    (out, warnings)
}

/// The gaps of `e` (indices into `e.gaps`) in which some input channel of the study's models
/// (one with no noise-only series: a commanded injection) is missing while it is active
/// within `gap_taper` of the gap, each with those channels: the loop's response to what the
/// input did inside the gap is unknown ([`gap_notes`], [`crate::jobs::injection_bias`]).
pub fn missing_injections(
    study: &Study,
    e: &crate::data::dataset::ExperimentData,
    opts: &SpectraOptions,
) -> Vec<(usize, Vec<String>)> {
    let mut inputs: Vec<&str> = Vec::new();
    for m in &study.models.models {
        for c in m.data_channels() {
            if !inputs.contains(&c.as_str()) {
                inputs.push(c);
            }
        }
    }
    let reach = (opts.gap_taper * e.fs).round() as usize;
    let n = e.n_samples();
    let active: Vec<(&str, &[f64])> = inputs
        .iter()
        .filter(|c| e.noise_channel(c).is_none() && !e.known_in_gaps.iter().any(|k| k == *c))
        .filter_map(|c| e.channel(c).map(|x| (*c, x)))
        .collect();
    e.gaps
        .iter()
        .enumerate()
        .filter_map(|(j, g)| {
            let (a, b) = (g[0].saturating_sub(reach), (g[1] + reach).min(n));
            let hit: Vec<String> = active
                .iter()
                .filter(|(_, x)| x[a..b].iter().any(|v| *v != 0.0))
                .map(|(c, _)| c.to_string())
                .collect();
            (!hit.is_empty()).then_some((j, hit))
        })
        .collect()
}

/// Gates the glitches of `dataset` (module [`crate::likelihood::glitch_gate`]): the regions
/// listed in `[[experiment]] glitches` and, with `[analysis] glitches = "gate"`, those found on
/// the whitened residual of model `mi` at its MAP on the data with the listed regions gated
/// ([`detection_point`]: at a point that is not the data's, such as the prior centre of a real data
/// set, the residual would hold the injections' response, and the detector would gate it). They
/// become gaps of the fit stretch; the channels without a noise-only series (the commanded
/// inputs) keep their values there, which the gaps' edge correction needs. Returns one summary
/// per experiment, none when the study gates nothing (the dataset is then untouched).
pub fn gate_glitches(
    study: &Study,
    mi: usize,
    dataset: &mut Dataset,
) -> Result<Vec<crate::likelihood::GlitchGate>, AnalysisError> {
    use crate::likelihood::{GlitchGate, GlitchTreatment};
    let a = &study.analysis;
    let gate = a.glitches == GlitchTreatment::Gate;
    if !gate && study.glitch_lists.is_empty() {
        return Ok(Vec::new());
    }
    let fail = |name: &str, msg: String| {
        AnalysisError::Likelihood(format!("experiment `{name}`: glitch gating: {msg}"))
    };
    let add = |e: &mut crate::data::dataset::ExperimentData, regions: &[[usize; 2]]| {
        add_gates(e, regions).map_err(|m| {
            fail(
                &e.name,
                format!(
                    "{m}: the gates leave no valid data; raise glitch_threshold, lower glitch_tail or shorten the listed glitches"
                ),
            )
        })
    };
    // the listed regions first: the MAP the detector runs at is made without them
    let mut before = Vec::new();
    let mut listed = Vec::new();
    for e in &mut dataset.experiments {
        before.push(crate::data::gaps::missing(&e.gaps));
        let times = study
            .glitch_lists
            .iter()
            .find(|(name, _)| *name == e.name)
            .map(|(_, l)| l.as_slice())
            .unwrap_or(&[]);
        let l = crate::data::gaps::from_times(times, e.fs, e.n_samples(), "glitches")
            .map_err(|m| fail(&e.name, m))?;
        add(e, &crate::data::gaps::normalise(l.clone()))?;
        listed.push(l);
    }
    let threshold = detection_threshold(study);
    let at = if gate {
        Some(detection_point(study, mi, dataset)?)
    } else {
        None
    };
    let mut out = Vec::new();
    for ((e, before), listed) in dataset.experiments.iter_mut().zip(before).zip(listed) {
        let detected = match &at {
            Some(at) => detect_at(study, mi, e, at, threshold).map_err(|m| fail(&e.name, m))?,
            None => Vec::new(),
        };
        add(e, &crate::data::gaps::normalise(detected.clone()))?;
        let outlast = match &at {
            Some(at) if !detected.is_empty() => outlasting(study, mi, &e.name, at)?,
            _ => None,
        };
        let mut all = listed.clone();
        all.extend_from_slice(&detected);
        let regions = crate::data::gaps::normalise(all);
        out.push(GlitchGate {
            experiment: e.name.clone(),
            detected: detected.len(),
            listed: listed.len(),
            regions: regions
                .iter()
                .map(|r| [r[0] as f64 / e.fs, r[1] as f64 / e.fs])
                .collect(),
            seconds: (crate::data::gaps::missing(&e.gaps) - before) as f64 / e.fs,
            remaining: (e.n_samples() - crate::data::gaps::missing(&e.gaps)) as f64 / e.fs,
            outlasting: outlast.map(|o| o.0),
            settling: outlast.and_then(|o| o.1),
        });
    }
    Ok(out)
}

/// Gates `regions` (samples) of `e`'s fit stretch; an error when no valid data remain. The
/// channels without a noise-only series (the commanded inputs) are known through a gate, as
/// through a telemetry gap.
fn add_gates(
    e: &mut crate::data::dataset::ExperimentData,
    regions: &[[usize; 2]],
) -> Result<(), String> {
    if regions.is_empty() {
        return Ok(());
    }
    if e.gaps.is_empty() && e.n_noise_samples() > 0 {
        e.known_in_gaps = e
            .channel_names()
            .into_iter()
            .filter(|c| e.noise_channel(c).is_none())
            .collect();
    }
    e.add_gaps(regions);
    crate::data::gaps::check(&e.gaps, e.n_samples())
}

/// Seconds of a force's response [`outlasting`] follows (a day).
const OUTLASTING_HORIZON: f64 = 86_400.0;

/// What the tail leaves of a gated glitch's response on experiment `name`: the residual's
/// response to a force impulse `glitch_tail` s after it over its peak, with model `mi` (as it
/// applies to the experiment) at `at`, and the tail after which it falls below
/// [`crate::likelihood::OUTLASTING_LIMIT`] (`None` beyond [`OUTLASTING_HORIZON`]). `None` when
/// the model does not say how a force enters its residual.
fn outlasting(
    study: &Study,
    mi: usize,
    name: &str,
    at: &[f64],
) -> Result<Option<(f64, Option<f64>)>, AnalysisError> {
    use crate::likelihood::{DEFAULT_GLITCH_TAIL, OUTLASTING_LIMIT};
    let model = &study.models.models[mi];
    let here = model
        .specialise(&study.covariates_of(name))
        .map_err(AnalysisError::Likelihood)?
        .unwrap_or_else(|| model.clone());
    let tail = study.analysis.glitch_tail.unwrap_or(DEFAULT_GLITCH_TAIL);
    // a day's horizon whatever the tail: a tail longer than that leaves the day's value at
    // most, and a horizon set by the tail (any finite number) could exhaust memory
    let Some(env) = crate::model::force_envelope(here.as_ref(), at, OUTLASTING_HORIZON) else {
        return Ok(None);
    };
    let left = env[(tail.min(OUTLASTING_HORIZON).round() as usize).min(env.len() - 1)];
    let settle = env
        .iter()
        .position(|v| *v <= OUTLASTING_LIMIT)
        .map(|t| t as f64);
    Ok(Some((left, settle)))
}

/// The glitches the detector finds in `e` on the whitened residual of model `mi` (as it
/// applies to `e`'s stretch) at `at`, at `threshold` σ with `[analysis]`'s pad, each region
/// extended by `glitch_tail` after its end (the loop's response outlasts the force).
fn detect_at(
    study: &Study,
    mi: usize,
    e: &crate::data::dataset::ExperimentData,
    at: &[f64],
    threshold: f64,
) -> Result<Vec<[usize; 2]>, String> {
    use crate::likelihood::{DEFAULT_GLITCH_PAD, DEFAULT_GLITCH_TAIL, detect_glitches};
    let a = &study.analysis;
    let model = &study.models.models[mi];
    let here = model
        .specialise(&study.covariates_of(&e.name))?
        .unwrap_or_else(|| model.clone());
    let found = detect_glitches(
        e,
        here.as_ref(),
        at,
        &spectra_options(study),
        threshold,
        a.glitch_pad.unwrap_or(DEFAULT_GLITCH_PAD),
    )?;
    let tail = (a.glitch_tail.unwrap_or(DEFAULT_GLITCH_TAIL) * e.fs).round() as usize;
    let n = e.n_samples();
    Ok(crate::data::gaps::normalise(
        found
            .into_iter()
            .map(|r| [r[0], r[1].saturating_add(tail).min(n)])
            .collect(),
    ))
}

/// `[analysis] glitch_threshold` or its default (σ of the whitened residual).
fn detection_threshold(study: &Study) -> f64 {
    study
        .analysis
        .glitch_threshold
        .unwrap_or(crate::likelihood::DEFAULT_GLITCH_THRESHOLD)
}

/// The thresholds of [`detection_point`]'s passes, as multiples of `glitch_threshold`: the
/// loudest glitches first. A first fit on data with every glitch in it is pulled by tens of σ
/// (measured on `examples/glitches.toml`, seed 3018: −61σ in `w2sq`); its residual then holds
/// the injections' mis-fit, and a detection at the full threshold there gated whole stretches
/// (14 of 100 realisations). Gating only what stands far above that mis-fit brings the next fit
/// within a few σ, and each pass lowers the threshold from a better point.
pub const DETECTION_LADDER: [f64; 3] = [8.0, 4.0, 2.0];

/// Where glitches are detected (gated or modelled): the MAP of model `mi` without glitches
/// ([`loop_map`]) on `dataset` gated by detections at decreasing thresholds
/// ([`DETECTION_LADDER`] × `glitch_threshold`), each made at the MAP of the pass before. At a
/// wrong point the residual holds part of the injections' response, which the detector flags;
/// the fit on ungated data is such a point. A pass whose gates would leave an experiment
/// without data ends the ladder at the point before it.
pub fn detection_point(
    study: &Study,
    mi: usize,
    dataset: &Dataset,
) -> Result<Vec<f64>, AnalysisError> {
    let threshold = detection_threshold(study);
    let mut at = loop_map(study, mi, dataset)?;
    let mut gated = dataset.clone();
    for m in DETECTION_LADDER {
        let mut next = gated.clone();
        let mut any = false;
        for e in &mut next.experiments {
            let spans =
                detect_at(study, mi, e, &at, m * threshold).map_err(AnalysisError::Likelihood)?;
            any |= !spans.is_empty();
            if add_gates(e, &crate::data::gaps::normalise(spans)).is_err() {
                return Ok(at);
            }
        }
        if any {
            // a pass that gates away what a parameter needs ends the ladder where it was
            match try_loop_map(study, mi, &next)? {
                Some(m) => at = m,
                None => return Ok(at),
            }
            gated = next;
        }
    }
    Ok(at)
}

/// The MAP of model `mi` (its `[fit]` or first `[[select.model]]` free parameters, from their
/// start) on `dataset` as it is, without modelled glitches; the reference point
/// ([`reference_point`]) when the search fails. Glitches are found there, and the starts of
/// modelled glitches made.
pub fn loop_map(study: &Study, mi: usize, dataset: &Dataset) -> Result<Vec<f64>, AnalysisError> {
    Ok(try_loop_map(study, mi, dataset)?.unwrap_or_else(|| reference_point(study, mi)))
}

/// [`loop_map`], `None` when the search fails (a singular Fisher matrix, a bad start).
fn try_loop_map(
    study: &Study,
    mi: usize,
    dataset: &Dataset,
) -> Result<Option<Vec<f64>>, AnalysisError> {
    let plain = likelihood_of(study, mi, dataset)?;
    let spec = first_spec(study, mi);
    Ok(crate::likelihood::fisher_scoring(
        &plain,
        &default_start(study, &spec),
        &spec.free,
        1e-3,
        100,
    )
    .map(|m| m.theta)
    .ok())
}

/// One line per experiment that glitch gating touched ([`gate_glitches`]), and one saying
/// that nothing was gated when that is so (the gates also appear as gaps in [`gap_notes`]).
pub fn glitch_notes(gates: &[crate::likelihood::GlitchGate]) -> Vec<String> {
    let touched: Vec<String> = gates
        .iter()
        .filter(|g| !g.regions.is_empty())
        .map(|g| g.describe())
        .collect();
    if touched.is_empty() && !gates.is_empty() {
        return vec![format!(
            "glitch gating: nothing gated in any of the {} experiment(s)",
            gates.len()
        )];
    }
    let mut out = touched;
    out.extend(outlasting_line(gates));
    out
}

/// One line when the gates leave more than [`crate::likelihood::OUTLASTING_LIMIT`] of a
/// glitch's response in the data fitted: what it costs and why, and the tail that would not.
fn outlasting_line(gates: &[crate::likelihood::GlitchGate]) -> Option<String> {
    use crate::likelihood::OUTLASTING_LIMIT;
    let worst = gates
        .iter()
        .filter(|g| g.detected > 0)
        .filter_map(|g| g.outlasting.map(|o| (o, g.settling)))
        .max_by(|a, b| a.0.total_cmp(&b.0))?;
    if worst.0 <= OUTLASTING_LIMIT {
        return None;
    }
    let fix = match worst.1 {
        Some(t) => format!(
            "a glitch_tail of {t:.0} s takes it below {:.0} % where the gates leave enough data (or fit the glitches: glitches = \"model\")",
            100.0 * OUTLASTING_LIMIT
        ),
        None => "fit the glitches instead (glitches = \"model\")".into(),
    };
    Some(format!(
        "glitch gating: the loop's response to a glitch outlasts its gate ({:.0} % of a force impulse's peak response is left after the glitch_tail), and what the gates leave in the data pulls the parameters it reaches, so their errors may be short (on Table I's study with five glitches of 2e-14 to 2e-13 m s⁻² per stretch and the default glitch_tail, the pulls of the stiffnesses, dt2, a_sus and d21 scattered 1.3 to 2.7 times their errors over 40 realisations, a_sus the most; docs/src/guide/glitches.md); {fix}",
        100.0 * worst.0
    ))
}

/// The first corner of model `mi`'s prior box that the model's check rejects (a delay that
/// goes negative, a pole frequency through zero, an unstable state-space system), as a
/// warning: the samplers explore the whole box and do not call the check per draw. Every
/// corner for up to [`MAX_CORNER_PARAMS`] parameters, else each parameter's two ends with
/// the others at the centre; an unbounded (Gaussian) side is taken at the centre (not
/// checked).
fn box_corner_fault(study: &Study, mi: usize) -> Option<String> {
    let m = &study.models.models[mi];
    let kinds = study.models.priors[mi].kinds();
    let centre: Vec<f64> = kinds.iter().map(crate::prior::PriorKind::centre).collect();
    if m.check(&centre).is_err() {
        return None; // refused at load, or warned about as a start
    }
    let ends = box_ends(kinds, &centre);
    let n = ends.len();
    let points: Box<dyn Iterator<Item = Vec<f64>>> = if n <= MAX_CORNER_PARAMS {
        Box::new(
            (0..1usize << n).map(move |bits| (0..n).map(|i| ends[i][(bits >> i) & 1]).collect()),
        )
    } else {
        let c = centre.clone();
        Box::new((0..2 * n).map(move |j| {
            let mut p = c.clone();
            p[j / 2] = ends[j / 2][j % 2];
            p
        }))
    };
    for p in points {
        if let Err(why) = m.check(&p) {
            return Some(format!(
                "model `{}` fails its check inside the prior box, at {}: {why}; the samplers draw from the whole box and do not check each draw, so narrow the prior to where the model holds",
                study.models.defs[mi].name(),
                crate::config::fmt_point(m.param_names(), &p)
            ));
        }
    }
    None
}

/// Each parameter's two ends of its prior box; an unbounded (Gaussian) side at the centre.
fn box_ends(kinds: &[crate::prior::PriorKind], centre: &[f64]) -> Vec<[f64; 2]> {
    kinds
        .iter()
        .zip(centre)
        .map(|(k, &c)| {
            let (lo, hi) = k.bounds();
            [
                if lo.is_finite() { lo } else { c },
                if hi.is_finite() { hi } else { c },
            ]
        })
        .collect()
}

/// Most parameters whose prior box is checked at every corner (more: each parameter's two ends).
pub const MAX_CORNER_PARAMS: usize = 12;

/// Where model `mi`'s prior box reaches parameter values at which its system is unstable
/// ([`crate::model::Model::is_stable`]), as a warning with the boundary found: each
/// parameter alone (the others at the prior centre) from the centre to each end of its box,
/// the first unstable value by bisection; then every corner (up to [`MAX_CORNER_PARAMS`]
/// parameters), the count of unstable ones and, when no parameter alone reaches instability,
/// the boundary on the line from the centre to the first. The samplers refuse those values
/// (`ln L = −∞`, counted per model); the warning says where they are.
pub fn stability_warning(study: &Study, mi: usize) -> Option<String> {
    let m = &study.models.models[mi];
    let kinds = study.models.priors[mi].kinds();
    let centre: Vec<f64> = kinds.iter().map(crate::prior::PriorKind::centre).collect();
    if !m.is_stable(&centre) {
        return None; // the start's check warns about it
    }
    let names = m.param_names();
    let units = m.param_units();
    // the last stable point on the segment from the centre to `to` (unstable)
    let boundary = |to: &[f64]| {
        let at = |t: f64| -> Vec<f64> {
            centre
                .iter()
                .zip(to)
                .map(|(c, x)| c + t * (x - c))
                .collect()
        };
        let (mut lo, mut hi) = (0.0, 1.0);
        for _ in 0..50 {
            let mid = 0.5 * (lo + hi);
            if m.is_stable(&at(mid)) {
                lo = mid
            } else {
                hi = mid
            }
        }
        at(hi)
    };
    let mut alone = Vec::new();
    for (i, k) in kinds.iter().enumerate() {
        let (lo, hi) = k.bounds();
        for (end, word) in [(lo, "below"), (hi, "above")] {
            if !end.is_finite() {
                continue;
            }
            let mut p = centre.clone();
            p[i] = end;
            if !m.is_stable(&p) {
                let b = boundary(&p)[i];
                let unit = units.get(i).filter(|u| !u.is_empty());
                alone.push(format!(
                    "`{}` {word} {}{}",
                    names[i],
                    crate::numfmt::fmt_sig(b, 4),
                    unit.map_or(String::new(), |u| format!(" {u}"))
                ));
            }
        }
    }
    let n = kinds.len();
    let mut corners = (0usize, 0usize, None::<Vec<f64>>);
    if n <= MAX_CORNER_PARAMS {
        let ends = box_ends(kinds, &centre);
        for bits in 0..1usize << n {
            let p: Vec<f64> = (0..n).map(|i| ends[i][(bits >> i) & 1]).collect();
            corners.1 += 1;
            if !m.is_stable(&p) {
                corners.0 += 1;
                corners.2.get_or_insert(p);
            }
        }
    }
    if alone.is_empty() && corners.0 == 0 {
        return None;
    }
    let mut parts = Vec::new();
    if !alone.is_empty() {
        parts.push(format!(
            "{} (the others at the prior centre)",
            alone.join(", ")
        ));
    }
    if corners.0 > 0 {
        let mut s = format!("{} of the box's {} corners", corners.0, corners.1);
        if alone.is_empty()
            && let Some(p) = &corners.2
        {
            s.push_str(&format!(
                ", from the prior centre towards {} first at {}",
                crate::config::fmt_point(names, p),
                crate::config::fmt_point(names, &boundary(p))
            ));
        }
        parts.push(s);
    }
    Some(format!(
        "model `{}`: its prior box reaches parameter values where the closed loop is unstable: {}; the samplers refuse those values (ln L = −∞, counted in each model's `unstable_evaluations`), so the posterior ends there — narrow the prior if that instability is not physics you mean to test",
        study.models.defs[mi].name(),
        parts.join("; ")
    ))
}

/// Warnings about fitting model `mi` to `dataset`: a start point (fixed and start values) the
/// model rejects ([`crate::model::Model::check`]), and a continuous-time closed loop fitted to
/// data from the discretised loop (`[simulation] method = "time"`), which the zero-order
/// hold's half-sample lag biases (tens of σ on the Table I study), and [`noise_warnings`].
pub fn model_warnings(study: &Study, mi: usize, dataset: &Dataset) -> Vec<String> {
    let mut w = Vec::new();
    let specs = std::iter::once(&study.fit_model)
        .chain(study.select_models.iter().map(|m| &m.spec))
        .filter(|s| s.model == mi);
    for spec in specs {
        if let Err(why) = study.models.models[mi].check(&default_start(study, spec)) {
            w.push(format!(
                "the start of the MAP search of model `{}` fails the model's check: {why}",
                study.models.defs[mi].name()
            ));
            break;
        }
    }
    if study.models.defs[mi].is_user_defined()
        && let Some(why) = box_corner_fault(study, mi)
    {
        w.push(why);
    }
    w.extend(stability_warning(study, mi));
    w.extend(noise_warnings(study, mi, dataset));
    // a guidance-injection model on data with force injections: their response is in the
    // outputs but not in `H_io i`, so the residual is not noise
    let m = &study.models.models[mi];
    let reads = |c: &str| m.data_channels().iter().any(|d| d == c);
    if (reads("i1") || reads("i12")) && !crate::experiment::FORCE_CHANNELS.iter().any(|c| reads(c))
    {
        for e in &dataset.experiments {
            let forced: Vec<&str> = crate::experiment::FORCE_CHANNELS
                .iter()
                .copied()
                .filter(|c| e.channel(c).is_some_and(|v| v.iter().any(|x| *x != 0.0)))
                .collect();
            if !forced.is_empty() {
                w.push(format!(
                    "experiment `{}` has force injections ({}) that model `{}` does not model: their response is in the outputs, not in the guidance response H_io·i, and biases the fit; fit such experiments in the acceleration domain (kind = \"accel\") or leave them out",
                    e.name,
                    forced.join(", "),
                    m.name()
                ));
            }
        }
    }
    let time_domain = dataset.extra.get("method").and_then(|v| v.as_str()) == Some("time");
    if let crate::config::ModelDef::Ltp { name, options } = &study.models.defs[mi]
        && time_domain
        && options.response == crate::model::LoopResponse::Continuous
    {
        w.push(format!(
            "model `{name}` is the continuous-time loop, but the data come from the discretised loop (method = \"time\"): expect biased parameters; use a [[model]] with kind = \"ltp\", response = \"discrete\""
        ));
    }
    w
}

/// A hash of what a run's numbers depend on: the resolved study without its output directory
/// and file name, and every sample of the data (the identity of `select`'s and `fit`'s
/// checkpoints).
pub fn identity(study: &Study, data: &Dataset) -> String {
    let mut v = serde_json::to_value(study).expect("a study serialises");
    if let Some(o) = v.as_object_mut() {
        o.remove("output");
        o.remove("source");
        o.remove("base_dir");
    }
    let mut h = crate::data::Fnv1a::default();
    h.update(&serde_json::to_vec(&v).expect("a study serialises"));
    for e in &data.experiments {
        h.update(e.name.as_bytes());
        hash_samples(&mut h, e);
    }
    format!("{:016x}", h.finish())
}

/// Adds an experiment's sample rate and every sample of every channel (outputs, injections,
/// noise-only stretch, named channels) to `h`.
pub fn hash_samples(h: &mut crate::data::Fnv1a, e: &crate::data::dataset::ExperimentData) {
    h.update(&e.fs.to_bits().to_le_bytes());
    let named = e.extra.iter().chain(&e.noise_extra);
    let fixed = e.o.iter().chain(&e.i).chain(&e.noise);
    for s in fixed.chain(named.map(|(_, s)| s)) {
        h.update(&(s.len() as u64).to_le_bytes());
        for x in s {
            h.update(&x.to_bits().to_le_bytes());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn study(tau: &str, lo: f64) -> Study {
        Study::from_toml(
            &format!(
                "seed = 1\noutput = \"o\"\n[fit]\nmodel = \"g\"\n[prior]\na = {{ kind = \"uniform\", lo = {lo}, hi = 2.0 }}\nb = {{ kind = \"gaussian\", mu = 1.0, sigma = 5.0 }}\n[[model]]\nkind = \"user\"\nname = \"g\"\nparameters = [\"a\", \"b\"]\ndata = [\"o1\", \"i1\"]\nresidual = [\"o1\"]\n[model.blocks]\nt = {{ kind = \"delay\", tau = \"{tau}\" }}\n[model.coefficients.o1]\no1 = \"1\"\ni1 = \"-a*b*t\"\n[[experiment]]\nname = \"inv1\"\ndesign = \"tn3045_x1\"\n"
            ),
            "s.toml",
            std::path::Path::new("."),
        )
        .unwrap()
    }

    #[test]
    fn a_prior_box_reaching_an_impossible_block_is_found_at_its_corner() {
        // the delay a − 1 is negative below a = 1: the centre (1.25) is fine, the corner not
        let g = |s: &Study| box_corner_fault(s, s.models.index("g").unwrap());
        let w = g(&study("a - 1", 0.5)).unwrap();
        assert!(
            w.contains("model `g`") && w.contains("a = 0.5") && w.contains("blocks.t.tau"),
            "{w}"
        );
        assert_eq!(g(&study("a - 1", 1.0)), None);
        // a Gaussian side is not checked beyond its centre (b = 1 gives a delay of 0)
        assert_eq!(g(&study("a*b - 1", 1.0)), None);
    }

    /// The gates' line says what a gated glitch's outlasting response costs when more than
    /// the limit of it is left (the worst experiment's share, the tail that would do), and
    /// nothing when it is below the limit, when nothing was detected or when the model does
    /// not say.
    #[test]
    fn the_gate_says_what_the_response_it_leaves_costs() {
        use crate::likelihood::GlitchGate;
        let gate = |detected: usize, outlasting: Option<f64>, settling: Option<f64>| GlitchGate {
            experiment: "inv1".into(),
            detected,
            listed: 0,
            regions: vec![[100.0, 1500.0]],
            seconds: 1400.0,
            remaining: 17_000.0,
            outlasting,
            settling,
        };
        let lines = glitch_notes(&[
            gate(2, Some(0.12), Some(3300.0)),
            gate(1, Some(0.23), Some(3300.0)),
        ]);
        assert_eq!(lines.len(), 3, "{lines:?}");
        assert!(
            lines[2].contains("23 %")
                && lines[2].contains("glitch_tail of 3300 s")
                && lines[2].contains("errors may be short"),
            "{}",
            lines[2]
        );
        let none = |g: GlitchGate| glitch_notes(&[g]).len();
        assert_eq!(none(gate(2, Some(0.08), Some(3300.0))), 1);
        assert_eq!(none(gate(0, Some(0.5), Some(3300.0))), 1);
        assert_eq!(none(gate(2, None, None)), 1);
        let never = glitch_notes(&[gate(2, Some(0.5), None)]);
        assert!(
            never[1].contains("fit the glitches instead"),
            "{}",
            never[1]
        );
    }
}

#[cfg(test)]
mod stability_tests {
    use super::*;

    fn thruster_study(lo: f64) -> Study {
        let text = format!(
            r#"seed = 1
output = "o"
[[model]]
kind = "ltp"
name = "pole"
thruster = "pole"
[prior]
f_df = {{ kind = "uniform", lo = {lo}, hi = 3.0 }}
a_df = {{ kind = "uniform", lo = 0.8, hi = 0.84 }}
[fit]
model = "pole"
[[experiment]]
name = "inv1"
design = "tn3045_x1"
"#
        );
        Study::from_toml(&text, "t.toml", std::path::Path::new(".")).unwrap()
    }

    #[test]
    fn a_prior_box_reaching_instability_is_warned_about_with_the_boundary() {
        let s = thruster_study(0.02);
        let w = stability_warning(&s, s.models.index("pole").unwrap()).unwrap();
        // the boundary at the prior centre (A_df = 0.82): ≈ 0.055 Hz, as issue 23 measured
        let b: f64 = w
            .split("`f_df` below ")
            .nth(1)
            .and_then(|r| r.split(' ').next())
            .and_then(|x| x.parse().ok())
            .unwrap_or_else(|| panic!("{w}"));
        assert!((0.050..0.060).contains(&b), "{w}");
        assert!(w.contains(" Hz (the others at the prior centre)"), "{w}");
        assert!(w.contains("corners"), "{w}");
        // a box that stays stable gets no warning
        let s = thruster_study(0.08);
        assert_eq!(stability_warning(&s, s.models.index("pole").unwrap()), None);
        // nor does the guidance-delay study's
        let s = Study::load(std::path::Path::new("examples/guidance-delays.toml")).unwrap();
        assert_eq!(stability_warning(&s, s.models.index("ltp").unwrap()), None);
    }
}
