//! The select pipeline: every model's stages in turn (each restored from the checkpoint or run
//! and saved), then the reversible jump over all models, then the summary.

use super::checkpoint::{self, SelectCheckpoint};
use super::error::SelectError;
use super::model::{self, ModelRun, Sampled};
use super::outcome::ModelOutcome;
use super::output;
use super::pair;
use super::plan::{Parents, SelectPlan};
use super::stage::{FILE as STAGE_FILE, StageFile};
use super::summary::SelectSummary;
use super::target::{self, TargetOutcome, TargetRound};
use crate::config::Study;
use crate::density::LogDensity;
use crate::evidence::{ReversibleJump, RjModel, RjOptions, RjOutcome, RjResult};
use crate::jobs::prepare::{Prepared, gap_notes, model_warnings, truth_of};
use crate::jobs::progress::stop_requested;
use crate::nested::SubModel;
use std::time::Instant;

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
            path: match self.state.stage_path() {
                Some(p) => p.to_path_buf(),
                None => self.path.with_file_name(STAGE_FILE),
            },
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
    let (rungs, sweeps, _) = s.tempering_ladder();
    let per_model = s.chains * s.iterations + rungs * sweeps;
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
    // modelled glitches: the models carry them (`Prepared::study`)
    let study = prep.study(study);
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
    let rj = reversible_jump(&plan, &runs, &mut ckpt, progress, work)?;
    let mut out = summarise(study, prep, &plan, &parents, runs, rj)?;
    out.seconds = t0.elapsed().as_secs_f64();
    Ok(out)
}

/// [`SelectError::Interrupted`] when `work` asks the run to stop: checked after every stage,
/// before the stage is recorded as done. The checkpoint is written first (the stages done so
/// far; the stage file holds the one in progress), so that a resumed run finds it even when
/// no stage had finished.
fn interrupted(
    work: Option<&crate::jobs::progress::Work>,
    ckpt: &Option<Checkpointing<'_>>,
) -> Result<(), SelectError> {
    if !stop_requested(work) {
        return Ok(());
    }
    if let Some(c) = ckpt {
        c.state.write(c.path)?;
    }
    Err(crate::jobs::progress::Interrupted.into())
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
    let stop = |_: usize| stop_requested(work);
    let mut runs = Vec::new();
    for (k, m) in plan.models.iter().enumerate() {
        let st = &m.stages;
        let saved = ckpt.as_ref().and_then(|c| c.state.models.get(k).cloned());
        let tempered = saved.as_ref().is_some_and(|s| s.tempered);
        let err = |msg| SelectError::Model {
            model: m.name.clone(),
            msg,
        };
        // the stages run one after another on the model's likelihoods: what each refused
        let refused = |r: &ModelRun| {
            m.exact.unstable_evaluations()
                + match &r.sampled {
                    Sampled::RelBin(rb) => rb.unstable_evaluations(),
                    Sampled::Exact => 0,
                }
        };
        let refused_before = m.exact.unstable_evaluations();
        let mut r = match saved {
            Some(stage) => stage.restore(m),
            None => model::run_model(m, stage.as_ref(), &stop).map(|mut r| {
                r.outcome.unstable_evaluations = refused(&r) - refused_before;
                r
            }),
        }
        .map_err(err)?;
        // a stage stopped on request is not recorded as done: its stage file holds it
        interrupted(work, ckpt)?;
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
            let before = refused(&r);
            model::temper(m, &mut r, &mut progress, (stage.as_ref(), &stop)).map_err(err)?;
            interrupted(work, ckpt)?;
            r.outcome.unstable_evaluations += refused(&r) - before;
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

/// The reversible-jump run and why it did not run, its iterations per second, and the
/// rounds of a run with a target error.
struct RjStage {
    rj: Option<RjResult>,
    note: Option<String>,
    rate: f64,
    rounds: Option<Vec<TargetRound>>,
}

/// The reversible jump over all models, each on its own sampled likelihood: restored from
/// the checkpoint where it holds it, else run and saved.
fn reversible_jump(
    plan: &SelectPlan<'_>,
    runs: &[ModelRun],
    ckpt: &mut Option<Checkpointing<'_>>,
    progress: Option<&mut dyn FnMut(&crate::evidence::RjProgress<'_>)>,
    work: Option<&crate::jobs::progress::Work>,
) -> Result<RjStage, SelectError> {
    let rj_base = work.map_or(0, |w| w.done.load(std::sync::atomic::Ordering::Relaxed));
    let targets: Vec<&dyn LogDensity> = runs
        .iter()
        .zip(&plan.models)
        .map(|(r, m)| match &r.sampled {
            Sampled::RelBin(rb) => rb.as_ref() as &dyn LogDensity,
            Sampled::Exact => m.exact as &dyn LogDensity,
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
        return Ok(RjStage {
            rj,
            note: s.note,
            rate: s.rate,
            rounds: s.rounds,
        });
    }
    let Some(target) = plan.target else {
        let (rj, note, rate) = run_rj(&rj_models, &plan.rj, "rj", ckpt, progress, work, rj_base);
        interrupted(work, ckpt)?;
        let stage = RjStage {
            rj,
            note,
            rate,
            rounds: None,
        };
        return save_rj(ckpt, stage);
    };
    // rounds of growing length until the error reaches the target (`target.rs`); a resumed
    // run continues after the rounds its checkpoint records
    let mut rounds: Vec<TargetRound> = ckpt
        .as_ref()
        .map(|c| c.state.rj_rounds.clone())
        .unwrap_or_default();
    let mut opts = plan.rj.clone();
    let mut base = rj_base;
    for r in &rounds {
        let next = r.error.and_then(|e| {
            target::next_length(r.iterations, e, target.error, target.budget, opts.n_chains)
        });
        opts.n_iter = next.unwrap_or(r.iterations);
        base += r.iterations as u64;
    }
    let mut progress = progress;
    loop {
        let name = if rounds.is_empty() {
            "rj".to_string()
        } else {
            format!("rj round {} ({} iterations)", rounds.len() + 1, opts.n_iter)
        };
        if let Some(w) = work
            && !rounds.is_empty()
        {
            w.total
                .fetch_add(opts.n_iter as u64, std::sync::atomic::Ordering::Relaxed);
        }
        let (rj, note, rate) = run_rj(
            &rj_models,
            &opts,
            &name,
            ckpt,
            progress
                .as_mut()
                .map(|f| &mut **f as &mut dyn FnMut(&crate::evidence::RjProgress<'_>)),
            work,
            base,
        );
        interrupted(work, ckpt)?;
        let error = rj.as_ref().and_then(target::rj_error);
        rounds.push(TargetRound {
            iterations: opts.n_iter,
            error,
        });
        let next = error
            .and_then(|e| {
                target::next_length(opts.n_iter, e, target.error, target.budget, opts.n_chains)
            })
            .filter(|_| rounds.len() < target::MAX_ROUNDS);
        match next {
            Some(n) => {
                if let Some(c) = ckpt.as_mut() {
                    c.state.rj_rounds = rounds.clone();
                    c.state.write(c.path)?;
                }
                base += opts.n_iter as u64;
                opts.n_iter = n;
            }
            None => {
                let stage = RjStage {
                    rj,
                    note,
                    rate,
                    rounds: Some(rounds),
                };
                return save_rj(ckpt, stage);
            }
        }
    }
}

/// Saves the finished reversible-jump stage to the checkpoint.
fn save_rj(
    ckpt: &mut Option<Checkpointing<'_>>,
    mut stage: RjStage,
) -> Result<RjStage, SelectError> {
    if let Some(c) = ckpt.as_mut() {
        // the draws move into the checkpoint for writing and back out (no copy)
        let draws = stage.rj.as_mut().and_then(|r| r.draws.take());
        c.state.rj = Some(checkpoint::RjStage {
            rj: stage.rj.clone(),
            note: stage.note.clone(),
            rate: stage.rate,
            draws,
            rounds: stage.rounds.clone(),
        });
        let written = c.state.write(c.path);
        if let (Some(r), Some(saved)) = (stage.rj.as_mut(), c.state.rj.as_mut()) {
            r.draws = saved.draws.take();
        }
        written?;
        c.stage_file().clear();
    }
    Ok(stage)
}

/// Runs the reversible jump on `rj_models` (work counted from `rj_base` on), its state in
/// progress saved in the stage file under `name`: the run, why it has no result, and its
/// iterations per second.
fn run_rj(
    rj_models: &[RjModel<'_>],
    opts: &RjOptions,
    name: &str,
    ckpt: &mut Option<Checkpointing<'_>>,
    mut progress: Option<&mut dyn FnMut(&crate::evidence::RjProgress<'_>)>,
    work: Option<&crate::jobs::progress::Work>,
    rj_base: u64,
) -> (Option<RjResult>, Option<String>, f64) {
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
    let stop = |_: usize| stop_requested(work);
    let ran = ReversibleJump::new(rj_models, opts).and_then(|rj| {
        let rj = rj.progress(&mut observe);
        match &stage {
            Some(f) => {
                let id = f.identity("all models", name);
                let rj = rj.checkpoint(&f.path, id.clone(), f.every).stop_when(&stop);
                if f.holds(crate::evidence::rjmcmc::KIND, &id) {
                    rj.resume(&f.path)
                } else {
                    rj.run()
                }
            }
            None => rj.run(),
        }
    });
    let (rj, note) = match ran {
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
    (rj, note, rate)
}

/// The gross failures of the models' own checks ([`crate::jobs::validity`]): in-model chains
/// that did not converge or barely moved, a MAP search that failed, an evidence correction
/// resting on a handful of samples; and pairs whose estimators are grossly apart.
fn invalid_reasons(models: &[ModelOutcome], pairs: &[pair::PairResult]) -> Vec<String> {
    use crate::jobs::validity::{ChainChecks, RHAT_LIMIT};
    let mut out = Vec::new();
    for m in models {
        let scope = format!("model `{}`: in-model chains", m.name);
        if !m.map_found {
            out.push(format!(
                "model `{}`: the MAP search failed; the estimators that expand around it have no number and the chains started from the prior — give [fit] start values nearer the mode or raise [fit] map_starts",
                m.name
            ));
        }
        let remedy = "run longer ([select] max_iterations, or iterations and burn_in) or start nearer the mode ([fit] start)";
        let worst = m.mcmc_max_rhat.unwrap_or(f64::NAN);
        if worst.is_finite() && worst > RHAT_LIMIT {
            out.push(format!(
                "{scope}: R-hat up to {worst:.2}, above {RHAT_LIMIT} — the chains have not converged to one distribution; {remedy}"
            ));
        }
        out.extend(
            ChainChecks {
                scope: &scope,
                names: &[],
                rhat: &[],
                ess: None,
                acceptance: &m.mcmc_acceptance,
                remedy,
            }
            .failures(),
        );
        if let Some(b) = &m.missing_injection_bias
            && b.worst()
                .is_some_and(|(_, w)| w > crate::jobs::injection_bias::BIAS_LIMIT)
        {
            out.push(format!("model `{}`: {}", m.name, b.line()));
        }
        if let Some(c) = m.noise_correction.filter(|c| c.unreliable()) {
            out.push(format!(
                "model `{}`: the correction to the exact θ-dependent likelihood rests on {:.0} effective of {} samples — its evidences are not to be trusted; give the noise point a better start ([fit] start)",
                m.name, c.weight_ess, c.samples
            ));
        }
    }
    out.extend(
        pairs
            .iter()
            .filter_map(pair::PairResult::gross_disagreement),
    );
    out
}

/// Each model's predicted bias from injections missing inside gaps
/// ([`crate::jobs::injection_bias`]), set on its outcome; warnings where it could not be
/// predicted.
fn injection_biases(
    study: &Study,
    prep: &Prepared,
    plan: &SelectPlan<'_>,
    parents: &Parents<'_>,
    models: &mut [ModelOutcome],
) -> Vec<String> {
    let mut warnings = Vec::new();
    if !crate::jobs::injection_bias::applies(study, &prep.dataset) {
        return warnings;
    }
    for (k, (m, pm)) in models.iter_mut().zip(&plan.models).enumerate() {
        if !m.map_found {
            continue;
        }
        let free = &pm.spec.free;
        let exact = parents.for_model(k, pm.spec.model);
        let fisher = crate::likelihood::fisher_exact(exact, &m.map, free);
        let Some(cr) = crate::likelihood::cramer_rao(&fisher) else {
            continue;
        };
        let reference = parents.noise_point(k).map_or_else(
            || crate::jobs::prepare::reference_point(study, pm.spec.model),
            |p| p.theta.clone(),
        );
        match crate::jobs::injection_bias::predict(
            study,
            pm.spec.model,
            &prep.dataset,
            exact,
            &reference,
            &m.map,
            free,
            &cr,
        ) {
            Ok(b) => m.missing_injection_bias = b,
            Err(e) => warnings.push(format!(
                "model `{}`: the bias of the injection missing inside gaps: not predicted: {e}",
                m.name
            )),
        }
    }
    warnings
}

/// The summary of a finished run: pairs, warnings (models, data, estimators), residual PSDs
/// (Fig. 3) and the optimal SNR; `seconds` is left 0 for the caller.
fn summarise(
    study: &Study,
    prep: &Prepared,
    plan: &SelectPlan<'_>,
    parents: &Parents<'_>,
    runs: Vec<ModelRun>,
    rj_stage: RjStage,
) -> Result<SelectSummary, SelectError> {
    let RjStage {
        mut rj,
        note: rj_note,
        rate: rj_rate,
        rounds,
    } = rj_stage;
    let mut model_chains = Vec::with_capacity(runs.len());
    let mut models: Vec<ModelOutcome> = Vec::with_capacity(runs.len());
    for r in runs {
        model_chains.push((r.outcome.name.clone(), r.chains));
        models.push(r.outcome);
    }
    let mut warnings = injection_biases(study, prep, plan, parents, &mut models);
    let mut pairs = Vec::new();
    for x in 0..models.len() {
        for y in x + 1..models.len() {
            pairs.push(pair::pair(&models, rj.as_ref(), rj_note.as_deref(), x, y));
        }
    }
    // the jump chain's few-jumps warning of a pair becomes the pair's, which knows the
    // reference (and may say that the answer needs no jumps): the outputs say one thing
    for rp in rj.iter_mut().flat_map(|r| r.pairs.iter_mut()) {
        let (x, y) = (&models[rp.k].name, &models[rp.l].name);
        if let Some(p) = pairs.iter().find(|p| &p.x == x && &p.y == y) {
            rp.warning.clone_from(&p.jumps.warning);
            rp.note.clone_from(&p.jumps.note);
        }
    }
    warnings.extend(
        parents
            .indices()
            .flat_map(|mi| model_warnings(study, mi, &prep.dataset)),
    );
    let (mut notes, gap_warnings) = gap_notes(study, &prep.dataset);
    warnings.extend(gap_warnings);
    warnings.extend(prep.glitch_notes());
    if !study.analysis.glitch_count.is_all() {
        warnings.push(
            "glitch_count = \"rj\" is run by `occam fit`; `occam select` compares the models with every modelled candidate on".into(),
        );
    }
    for m in &models {
        for n in &m.notes {
            let line = format!("model `{}`: {n}", m.name);
            if super::model::is_fact(n) {
                notes.push(line);
            } else {
                warnings.push(line);
            }
        }
        if let Some(b) = &m.missing_injection_bias
            && b.worst()
                .is_some_and(|(_, w)| w <= crate::jobs::injection_bias::BIAS_LIMIT)
        {
            warnings.push(format!("model `{}`: {}", m.name, b.line()));
        }
        if m.unstable_evaluations > 0 {
            warnings.push(format!(
                "model `{}`: {} likelihood evaluations fell where the closed loop is unstable and were refused (ln L = −∞): the prior box reaches instability (see the warning on the model's prior box)",
                m.name, m.unstable_evaluations
            ));
        }
        if let Some(w) = m.tempering.as_ref().and_then(|t| t.broken_ladder_warning()) {
            warnings.push(format!("model `{}`: {w}", m.name));
        }
    }
    warnings.extend(rj_note.clone());
    if let Some(r) = &rj {
        let (w, n) = output::fig2_warnings(r);
        warnings.extend(w);
        notes.extend(n);
    }
    for p in &pairs {
        if let Some(w) = &p.jumps.warning {
            warnings.push(format!("{}/{}: {w}", p.x, p.y));
        }
        if let Some(n) = &p.jumps.note {
            notes.push(format!("{}/{}: {n}", p.x, p.y));
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
    let fitted: Vec<crate::jobs::bode::Fitted<'_>> = models
        .iter()
        .zip(&plan.models)
        .filter(|(m, _)| m.map_found)
        .map(|(m, pm)| crate::jobs::bode::Fitted {
            name: &m.name,
            likelihood: pm.exact,
            map: &m.map,
        })
        .collect();
    let (bode, w, n) = crate::jobs::bode::bode_data(study, &prep.dataset.experiments, &fitted);
    warnings.extend(w);
    notes.extend(n);
    let (raw, w) =
        crate::jobs::raw_data::raw_data(study, plan.models[0].exact, &prep.dataset.experiments);
    warnings.extend(w);
    // ρ_opt at the truth where the first model has every true value, else at its MAP
    let first = plan.models[0].exact;
    let truth_snr = truth_of(study, plan.models[0].spec.model, &prep.dataset)
        .and_then(|t| t.into_iter().collect::<Option<Vec<f64>>>())
        .map(|t| first.snr(&t));
    let target = plan
        .target
        .zip(rounds)
        .map(|(t, rounds)| TargetOutcome::finish(t.error, t.budget, rounds, &pairs));
    if let Some(n) = target.as_ref().and_then(|t| t.note.as_ref()) {
        warnings.push(format!("[select] target_error not met: {n}"));
    }
    let invalid_reasons = invalid_reasons(&models, &pairs);
    Ok(SelectSummary {
        valid: invalid_reasons.is_empty(),
        invalid_reasons,
        origin: prep.origin.clone(),
        target,
        cross_checks: study.select.cross_checks,
        rho_opt_simulated: prep.dataset.extra.get("snr_total").and_then(|v| v.as_f64()),
        rho_opt: truth_snr.unwrap_or_else(|| first.snr(&models[0].map)),
        n_bins: first.n_bins(),
        statistic: first.statistic(),
        noise_averages: crate::jobs::prepare::noise_averages_for_summary(study, first),
        glitch_gates: prep.glitch_gates.clone(),
        schwarz_n: plan.n_sbic,
        posterior_model_probabilities: pair::posterior_probabilities(&models, &pairs),
        models,
        pairs,
        rj,
        rj_note,
        rj_iterations_per_second: rj_rate,
        seconds: 0.0,
        warnings,
        notes,
        residual_psd,
        model_chains,
        bode,
        raw,
    })
}
