//! `occam select`: Bayes factors between nested models with every estimator side by side
//! (reversible jump, Laplace–Fisher raw and box-corrected, Laplace–Metropolis with MVE and
//! MCD, Schwarz), the paper's Table II layout, the evolution of B (Fig. 2) and the model-visit
//! histogram (Fig. 4).
//!
//! No estimator's failure ends a run: each per-model stage ([`model`]) and each row of a pair
//! ([`pair`]) that cannot apply carries a note saying why, and every other estimator still
//! reports.

mod checkpoint;
mod console;
mod job;
mod model;
mod output;
mod pair;
mod plan;
mod stage;

pub use checkpoint::{FILE as CHECKPOINT_FILE, SelectCheckpoint, identity};
pub use stage::FILE as STAGE_FILE;
use stage::StageFile;

pub use console::console;
pub use job::Select;
pub use output::{
    Fig2, LEGACY_OUTPUTS, chains_file, fig2, fig2_warnings, rj_chain_arrays, table, write_outputs,
};
pub use pair::{EstimateKind, JumpStats, PairEstimate, PairResult};

use crate::config::Study;
use crate::density::LogDensity;
use crate::evidence::{LaplaceEstimate, ReversibleJump, RjModel, RjOptions, RjOutcome, RjResult};
use crate::jobs::prepare::{Prepared, model_warnings, truth_of};
use crate::nested::SubModel;
use model::{ModelRun, Sampled};
use plan::{Parents, SelectPlan};
use serde::Serialize;
use std::time::Instant;

/// Errors of a model-selection run.
#[derive(Debug, thiserror::Error)]
pub enum SelectError {
    #[error("{0}")]
    Config(String),
    #[error("model `{model}`: {msg}")]
    Model { model: String, msg: String },
    #[error(transparent)]
    Report(#[from] crate::report::ReportError),
    #[error("{0}")]
    Io(String),
}

/// A per-model `ln Z` estimate, or why the estimator does not apply.
#[derive(Debug, Clone, Serialize, serde::Deserialize)]
pub struct Evidence {
    pub ln_z: Option<f64>,
    /// Monte-Carlo standard error (statistical estimators only).
    pub std_err: Option<f64>,
    /// Quadrature error of a systematic estimator's box mass (not a statistical error).
    pub integration_err: Option<f64>,
    /// What a systematic estimator assumes.
    pub assumes: Option<String>,
    /// Why there is no number (the estimator's own error), or a caveat.
    pub note: Option<String>,
}

impl Evidence {
    /// A Monte-Carlo estimate with its standard error.
    fn statistical(r: Result<(f64, f64, Option<f64>), String>) -> Self {
        match r {
            Ok((ln_z, se, integration_err)) => Self {
                ln_z: Some(ln_z),
                std_err: Some(se),
                integration_err,
                assumes: None,
                note: None,
            },
            Err(m) => Self::not_applicable(m),
        }
    }

    fn not_applicable(note: String) -> Self {
        Self {
            ln_z: None,
            std_err: None,
            integration_err: None,
            assumes: None,
            note: Some(note),
        }
    }

    /// A Laplace-type estimate: its error is the failure of `assumes`, not a ± value.
    fn systematic(r: Result<LaplaceEstimate, String>, assumes: String) -> Self {
        match r {
            Ok(e) => Self {
                ln_z: Some(e.ln_z),
                std_err: None,
                integration_err: e.std_err,
                assumes: Some(assumes),
                note: None,
            },
            Err(m) => Self::not_applicable(m),
        }
    }
}

/// Per-model results.
#[derive(Debug, Clone, Serialize, serde::Deserialize)]
pub struct ModelOutcome {
    pub name: String,
    /// The model this is a sub-model of.
    pub model: String,
    /// That model's parameters (the order of `map` and `unbounded_max`).
    pub params: Vec<String>,
    pub free: Vec<String>,
    pub prior_probability: f64,
    /// MAP (full parameter vector of the model), inside the prior box; the search's start
    /// point when `map_found` is false.
    pub map: Vec<f64>,
    pub map_found: bool,
    /// Free parameters whose MAP value is on a bound of the prior box.
    pub map_at_bound: Vec<String>,
    /// How well relative binning reproduces the exact `ln L` where the samplers go (absent
    /// when the samplers ran on the exact likelihood).
    pub relbin: Option<crate::likelihood::RelBinValidation>,
    pub ln_l_map: f64,
    /// Unconstrained maximum of `ln L` (the box-corrected Laplace expansion point), when found.
    pub unbounded_max: Option<Vec<f64>>,
    /// Smallest distance of the MAP from a prior bound, in Fisher σ.
    pub min_margin_sigma: f64,
    pub laplace_fisher_raw: Evidence,
    pub laplace_fisher_box: Evidence,
    pub laplace_metropolis_mve: Evidence,
    pub laplace_metropolis_mcd: Evidence,
    /// Thermodynamic integration; `std_err` combines the Monte-Carlo error and the
    /// discretisation error (`integration_err`).
    pub thermodynamic: Evidence,
    pub stepping_stone: Evidence,
    /// The tempering run: final ladder, swap rate per adjacent pair, acceptance per rung.
    pub tempering: Option<TemperingDiagnostics>,
    pub schwarz_ln_z: f64,
    /// In-model MCMC: acceptance per chain and worst R-hat (absent when the chains failed).
    pub mcmc_acceptance: Vec<f64>,
    pub mcmc_max_rhat: Option<f64>,
    /// Where the reversible-jump proposal of this model comes from.
    pub jump_proposal: String,
    /// Stages that did not apply, and why.
    pub notes: Vec<String>,
}

/// What a parallel-tempering run of one model looked like.
#[derive(Debug, Clone, Serialize, serde::Deserialize)]
pub struct TemperingDiagnostics {
    pub betas: Vec<f64>,
    /// Swap acceptance of each adjacent pair of rungs.
    pub swap_acceptance: Vec<f64>,
    pub in_rung_acceptance: Vec<f64>,
    pub sweeps: usize,
    pub burn_in: usize,
    pub ln_l_evals: u64,
    /// Bound on the shift of `ln Z` by relative binning along the ladder (the rungs' kept
    /// states, exact against relative-binned `ln L`, trapezoid-weighted), added in quadrature
    /// to the thermodynamic and stepping-stone errors; absent on the exact likelihood.
    pub approximation_err: Option<f64>,
    pub seconds: f64,
}

/// Everything `occam select` reports.
#[derive(Debug, Clone, Serialize)]
pub struct SelectSummary {
    pub origin: String,
    /// ρ_opt of the injections under the simulation's exact noise model (when simulated).
    pub rho_opt_simulated: Option<f64>,
    /// ρ_opt = √⟨h|h⟩ at the truth (or the first model's MAP) under the analysis's noise
    /// estimate (Welch by default), which differs from the model noise at low frequencies;
    /// NaN (null) for a model that reads no noiseless input channel.
    pub rho_opt: f64,
    pub n_bins: usize,
    /// The statistic of every `ln L` and evidence (`[analysis] statistic`).
    pub statistic: crate::likelihood::Statistic,
    pub schwarz_n: f64,
    pub models: Vec<ModelOutcome>,
    pub pairs: Vec<PairResult>,
    /// `P(k|y)` from the reference `ln B` of every pair with the first model and the prior
    /// model probabilities (`None` when a pair has no reference number).
    pub posterior_model_probabilities: Option<Vec<f64>>,
    /// The reversible-jump run (absent when it could not run: see `rj_note`).
    pub rj: Option<RjResult>,
    pub rj_note: Option<String>,
    pub rj_iterations_per_second: f64,
    pub seconds: f64,
    /// Warnings about the models, the data and the estimators.
    pub warnings: Vec<String>,
    /// Each model's residual PSD at its MAP (Fig. 3), written to `residual_psd.npz` and
    /// plotted, not into `summary.json`.
    #[serde(skip)]
    pub residual_psd: Vec<(String, Vec<crate::likelihood::residual_psd::ResidualPsd>)>,
    /// Each model's in-model chains (`None` where they did not run), written to
    /// `chains_<model>.npz`, not into `summary.json`.
    #[serde(skip)]
    pub model_chains: Vec<(String, Option<crate::sampler::Chains>)>,
}

/// Runs every estimator on the study's `[[select.model]]` list. Each competing model is a
/// sub-model of one of the study's models; each of those gets its own exact likelihood on the
/// data (the `[fit]` model's is `prep.likelihood`).
pub fn run(
    study: &Study,
    prep: &Prepared,
    progress: Option<&mut dyn FnMut(&crate::evidence::RjProgress<'_>)>,
) -> Result<SelectSummary, SelectError> {
    run_checkpointed(study, prep, progress, None)
}

/// Where [`run_checkpointed`] saves its finished stages, and what it resumes from. The stage
/// in progress is saved beside it, in [`STAGE_FILE`] (see [`SelectCheckpoint::save_stage_every`]).
pub struct Checkpointing<'a> {
    /// The checkpoint file, rewritten (atomically) after every stage.
    pub path: &'a std::path::Path,
    /// The stages already done (from [`SelectCheckpoint::read`]), or a fresh
    /// [`SelectCheckpoint::new`].
    pub state: SelectCheckpoint,
}

impl Checkpointing<'_> {
    /// The stage file beside the checkpoint.
    fn stage_file(&self) -> StageFile {
        StageFile {
            path: self.path.with_file_name(STAGE_FILE),
            run: self.state.identity().to_string(),
            every: self.state.stage_every(),
        }
    }
}

/// [`run`], saving each finished stage to a checkpoint and skipping the stages the
/// checkpoint already holds; the numbers are those of an uninterrupted run, bit for bit.
pub fn run_checkpointed(
    study: &Study,
    prep: &Prepared,
    progress: Option<&mut dyn FnMut(&crate::evidence::RjProgress<'_>)>,
    ckpt: Option<Checkpointing<'_>>,
) -> Result<SelectSummary, SelectError> {
    run_observed(study, prep, progress, None, ckpt)
}

/// Likelihood evaluations a select run of `study` makes, as [`run_observed`] counts them:
/// per model its Metropolis–Hastings chains and its tempering ladder (every rung each sweep),
/// then the reversible-jump iterations.
pub fn work_units(study: &Study) -> u64 {
    let s = &study.select;
    let per_model = s.chains * s.iterations + s.pt_temperatures * s.pt_iterations;
    (study.select_models.len() * per_model + s.rj_iterations) as u64
}

/// [`run_checkpointed`], counting its work ([`work_units`]) into `work` as it goes, so that a
/// progress bar can follow every stage, not only the reversible jump.
pub fn run_observed(
    study: &Study,
    prep: &Prepared,
    progress: Option<&mut dyn FnMut(&crate::evidence::RjProgress<'_>)>,
    work: Option<&crate::jobs::progress::Work>,
    mut ckpt: Option<Checkpointing<'_>>,
) -> Result<SelectSummary, SelectError> {
    if let Some(w) = work {
        w.start(work_units(study));
    }
    let t0 = Instant::now();
    if study.select_models.len() < 2 {
        return Err(SelectError::Config(format!(
            "{}: `select.model`: model selection needs at least two [[select.model]] tables",
            study.source
        )));
    }
    // one exact likelihood per parent model in use
    let parents = Parents::new(study, prep)?;
    let plan = SelectPlan::new(study, &parents);
    let runs = run_models(&plan, &mut ckpt, work)?;
    let rj = reversible_jump(&plan, &parents, &runs, &mut ckpt, progress, work)?;
    let mut out = summarise(study, prep, &plan, &parents, runs, rj)?;
    out.seconds = t0.elapsed().as_secs_f64();
    Ok(out)
}

/// Counts `n` more likelihood evaluations into `work`.
fn add_work(work: Option<&crate::jobs::progress::Work>, n: usize) {
    if let Some(w) = work {
        w.done
            .fetch_add(n as u64, std::sync::atomic::Ordering::Relaxed);
    }
}

/// Every model's stages in turn — the in-model stage, then its tempering — each restored from
/// the checkpoint where it holds it, and saved to it once done.
fn run_models(
    plan: &SelectPlan<'_>,
    ckpt: &mut Option<Checkpointing<'_>>,
    work: Option<&crate::jobs::progress::Work>,
) -> Result<Vec<ModelRun>, SelectError> {
    let stage = ckpt.as_ref().map(Checkpointing::stage_file);
    let mut runs = Vec::new();
    for (k, m) in plan.models.iter().enumerate() {
        let st = &m.stages;
        let saved = ckpt.as_ref().and_then(|c| c.state.models.get(k).cloned());
        let tempered = saved.as_ref().is_some_and(|s| s.tempered);
        let err = |msg| SelectError::Model {
            model: m.name.clone(),
            msg,
        };
        let mut r = match saved {
            Some(stage) => stage.restore(m),
            None => model::run_model(m, stage.as_ref()),
        }
        .map_err(err)?;
        add_work(work, st.chains * st.iterations);
        if let Some(c) = ckpt.as_mut()
            && c.state.models.len() == k
        {
            c.state.models.push(checkpoint::ModelStage::of(&r, false));
            c.state.write(c.path)?;
            stage.iter().for_each(StageFile::clear);
        }
        if !tempered {
            let mut counted = 0;
            let mut progress = |done: usize| {
                add_work(work, (done - counted) * st.pt_temperatures);
                counted = done;
            };
            model::temper(m, &mut r, &mut progress, stage.as_ref()).map_err(err)?;
            if let Some(c) = ckpt.as_mut() {
                c.state.models[k] = checkpoint::ModelStage::of(&r, true);
                c.state.write(c.path)?;
                stage.iter().for_each(StageFile::clear);
            }
        } else {
            add_work(work, st.pt_temperatures * st.pt_iterations);
        }
        runs.push(r);
    }
    Ok(runs)
}

/// The reversible-jump run and why it did not run, and its iterations per second.
type RjStage = (Option<RjResult>, Option<String>, f64);

/// The reversible jump over all models, each on its own sampled likelihood: restored from
/// the checkpoint where it holds it, else run and saved.
fn reversible_jump(
    plan: &SelectPlan<'_>,
    parents: &Parents<'_>,
    runs: &[ModelRun],
    ckpt: &mut Option<Checkpointing<'_>>,
    progress: Option<&mut dyn FnMut(&crate::evidence::RjProgress<'_>)>,
    work: Option<&crate::jobs::progress::Work>,
) -> Result<RjStage, SelectError> {
    let rj_base = work.map_or(0, |w| w.done.load(std::sync::atomic::Ordering::Relaxed));
    let targets: Vec<&dyn LogDensity> = runs
        .iter()
        .map(|r| match &r.sampled {
            Sampled::RelBin(rb) => rb.as_ref() as &dyn LogDensity,
            Sampled::Exact(mi) => parents.of(*mi) as &dyn LogDensity,
        })
        .collect();
    let subs: Vec<SubModel<&dyn LogDensity>> = runs
        .iter()
        .zip(&targets)
        .map(|(r, t)| SubModel::new(*t, r.spec.free.clone(), r.base.clone()))
        .collect::<Result<_, _>>()
        .map_err(|e| SelectError::Config(e.to_string()))?;
    let rj_models: Vec<RjModel<'_>> = runs
        .iter()
        .zip(&subs)
        .zip(&plan.models)
        .map(|((r, s), m)| RjModel {
            name: m.name.clone(),
            target: s as &dyn LogDensity,
            center: r.jump_center.clone(),
            cov: r.jump_cov.clone(),
        })
        .collect();
    if let Some(s) = ckpt.as_ref().and_then(|c| c.state.rj.clone()) {
        let mut rj = s.rj;
        if let Some(r) = rj.as_mut() {
            r.draws = s.draws;
        }
        return Ok((rj, s.note, s.rate));
    }
    run_rj(&rj_models, &plan.rj, ckpt, progress, work, rj_base)
}

/// Runs the reversible jump on `rj_models` (work counted from `rj_base` on) and saves it to
/// the checkpoint.
fn run_rj(
    rj_models: &[RjModel<'_>],
    opts: &RjOptions,
    ckpt: &mut Option<Checkpointing<'_>>,
    mut progress: Option<&mut dyn FnMut(&crate::evidence::RjProgress<'_>)>,
    work: Option<&crate::jobs::progress::Work>,
    rj_base: u64,
) -> Result<RjStage, SelectError> {
    let t_rj = Instant::now();
    let mut observe = |p: &crate::evidence::RjProgress<'_>| {
        if let Some(w) = work {
            w.done.store(
                rj_base + p.iteration as u64,
                std::sync::atomic::Ordering::Relaxed,
            );
        }
        if let Some(f) = progress.as_mut() {
            f(p);
        }
    };
    let stage = ckpt.as_ref().map(Checkpointing::stage_file);
    let ran = ReversibleJump::new(rj_models, opts).and_then(|rj| {
        let rj = rj.progress(&mut observe);
        match &stage {
            Some(f) => {
                let id = f.identity("all models", "rj");
                let rj = rj.checkpoint(&f.path, id.clone(), f.every);
                if f.holds(crate::evidence::rjmcmc::KIND, &id) {
                    rj.resume(&f.path)
                } else {
                    rj.run()
                }
            }
            None => rj.run(),
        }
    });
    let (mut rj, note) = match ran {
        Ok(RjOutcome::Finished(r)) => (Some(*r), None),
        Ok(RjOutcome::Stopped { iterations }) => (
            None,
            Some(format!(
                "the reversible-jump chain stopped after {iterations} iterations"
            )),
        ),
        Err(e) => (
            None,
            Some(format!("the reversible-jump chain did not run: {e}")),
        ),
    };
    let rate = opts.n_iter as f64 / t_rj.elapsed().as_secs_f64();
    if let Some(c) = ckpt.as_mut() {
        // the draws move into the checkpoint for writing and back out (no copy)
        let draws = rj.as_mut().and_then(|r| r.draws.take());
        c.state.rj = Some(checkpoint::RjStage {
            rj: rj.clone(),
            note: note.clone(),
            rate,
            draws,
        });
        let written = c.state.write(c.path);
        if let (Some(r), Some(stage)) = (rj.as_mut(), c.state.rj.as_mut()) {
            r.draws = stage.draws.take();
        }
        written?;
        stage.iter().for_each(StageFile::clear);
    }
    Ok((rj, note, rate))
}

/// The summary of a finished run: pairs, warnings (models, data, estimators), residual PSDs
/// (Fig. 3) and the optimal SNR; `seconds` is left 0 for the caller.
fn summarise(
    study: &Study,
    prep: &Prepared,
    plan: &SelectPlan<'_>,
    parents: &Parents<'_>,
    runs: Vec<ModelRun>,
    (rj, rj_note, rj_rate): RjStage,
) -> Result<SelectSummary, SelectError> {
    let mut model_chains = Vec::with_capacity(runs.len());
    let mut models: Vec<ModelOutcome> = Vec::with_capacity(runs.len());
    for r in runs {
        model_chains.push((r.outcome.name.clone(), r.chains));
        models.push(r.outcome);
    }
    let mut pairs = Vec::new();
    for x in 0..models.len() {
        for y in x + 1..models.len() {
            pairs.push(pair::pair(&models, rj.as_ref(), rj_note.as_deref(), x, y));
        }
    }
    let mut warnings: Vec<String> = parents
        .indices()
        .flat_map(|mi| model_warnings(study, mi, &prep.dataset))
        .collect();
    for m in &models {
        warnings.extend(m.notes.iter().map(|n| format!("model `{}`: {n}", m.name)));
    }
    warnings.extend(rj_note.clone());
    warnings.extend(rj.as_ref().map(output::fig2_warnings).unwrap_or_default());
    for p in &pairs {
        if let Some(w) = &p.jumps.warning {
            warnings.push(format!("{}/{}: {w}", p.x, p.y));
        }
    }
    // the paper's Fig. 3: each model's residual PSD at its MAP
    let mut residual_psd = Vec::new();
    for (m, pm) in models.iter().zip(&plan.models) {
        match crate::likelihood::residual_psd::residual_psds(
            pm.exact,
            &prep.dataset.experiments,
            &m.map,
        ) {
            Ok(c) => residual_psd.push((m.name.clone(), c)),
            Err(e) => warnings.push(format!("model `{}`: no residual PSD: {e}", m.name)),
        }
    }
    // ρ_opt at the truth where the first model has every true value, else at its MAP
    let first = plan.models[0].exact;
    let truth_snr = truth_of(study, plan.models[0].spec.model, &prep.dataset)
        .and_then(|t| t.into_iter().collect::<Option<Vec<f64>>>())
        .map(|t| first.snr(&t));
    Ok(SelectSummary {
        origin: prep.origin.clone(),
        rho_opt_simulated: prep.dataset.extra.get("snr_total").and_then(|v| v.as_f64()),
        rho_opt: truth_snr.unwrap_or_else(|| first.snr(&models[0].map)),
        n_bins: first.n_bins(),
        statistic: first.statistic(),
        schwarz_n: plan.n_sbic,
        posterior_model_probabilities: pair::posterior_probabilities(&models, &pairs),
        models,
        pairs,
        rj,
        rj_note,
        rj_iterations_per_second: rj_rate,
        seconds: 0.0,
        warnings,
        residual_psd,
        model_chains,
    })
}
