//! One competing model's share of `occam select`: its MAP, Fisher matrix, sampled likelihood,
//! in-model chains, jump proposal and every per-model evidence estimate.
//!
//! Each step that can fail leaves a note and lets the others run: a MAP search that does not
//! converge, a singular Fisher matrix, a diverging unconstrained search, chains with too few
//! distinct samples. Only a model with no point inside its prior where `ln L` is finite stops
//! the run (nothing can be computed for it).

use super::outcome::{Evidence, ModelOutcome, TemperingDiagnostics};
use super::plan::{ModelPlan, StageSettings};
use super::stage::StageFile;
use crate::config::{CrossChecks, JumpProposal, LikelihoodKind, ModelSpec};
use crate::density::LogDensity;
use crate::evidence::bridge_sampling::{PosteriorDraws, bridge_sampling};
use crate::evidence::tempering::{ParallelTempering, TemperingOutcome};
use crate::evidence::{
    LaplaceEstimate, LaplaceOptions, McdOptions, MveOptions, RobustMethod, TemperingOptions,
    laplace_fisher, laplace_metropolis, schwarz_ln_z,
};
use crate::jobs::prepare::MAP_MAX_ITER;
use crate::likelihood::{
    Likelihood, MultiStartMap, RelBinLikelihood, Statistic, fisher_exact, fisher_scoring_unbounded,
    refine_statistic_max,
};
use crate::linalg::{self, SpdOptions};
use crate::model::map_tolerance;
use crate::nested::SubModel;
use crate::prior::Prior;
use crate::sampler::{Chains, MetropolisHastings, MhSettings, RunOutcome, Start, chain_starts};
use nalgebra::DMatrix;

/// The likelihood the samplers of one model run on.
pub(super) enum Sampled {
    /// Relative-binned around the model's MAP.
    RelBin(Box<RelBinLikelihood>),
    /// The model's exact likelihood ([`super::plan::ModelPlan::exact`]).
    Exact,
}

/// What the reversible-jump stage needs from one model.
pub(super) struct ModelRun {
    pub outcome: ModelOutcome,
    pub spec: ModelSpec,
    pub sampled: Sampled,
    /// Full parameter vector the sub-model embeds into (MAP, or the best sample).
    pub base: Vec<f64>,
    /// Location and covariance of the jump proposal (free parameters).
    pub jump_center: Vec<f64>,
    pub jump_cov: DMatrix<f64>,
    /// Where the tempering stage ([`temper`]) starts (free parameters) and the model's seed.
    pub tempering_start: Vec<f64>,
    pub seed: u64,
    /// The in-model Metropolis–Hastings chains (free parameters), for `chains_<model>.npz`;
    /// `None` when they did not run.
    pub chains: Option<Chains>,
}

fn free_vec(th: &[f64], free: &[usize]) -> Vec<f64> {
    free.iter().map(|&i| th[i]).collect()
}

/// The prior's own covariance (diagonal): the proposal of last resort.
fn prior_cov(prior: &Prior) -> DMatrix<f64> {
    DMatrix::from_diagonal(&nalgebra::DVector::from_iterator(
        prior.dim(),
        prior.kinds().iter().map(|k| k.sd().powi(2)),
    ))
}

/// The in-model chains' samples as a matrix (rows = samples).
fn sample_matrix(chains: &Chains) -> DMatrix<f64> {
    let d = chains.dim();
    let n = chains.n_kept() * chains.chains().len();
    let mut m = DMatrix::<f64>::zeros(n, d);
    let mut r = 0;
    for c in chains.chains() {
        for s in c.samples.chunks(d) {
            for j in 0..d {
                m[(r, j)] = s[j];
            }
            r += 1;
        }
    }
    m
}

/// The random-walk covariance of a model's samplers: the inverse Fisher matrix capped at the
/// prior's marginal widths, or the prior's covariance when the Fisher matrix is singular.
pub(super) fn walk_cov(fisher_cov: Option<&DMatrix<f64>>, prior: &Prior) -> DMatrix<f64> {
    fisher_cov
        .map(|c| crate::sampler::cap_to_prior(c, prior))
        .unwrap_or_else(|| prior_cov(prior))
}

/// The likelihood a model's samplers run on around `base` (its MAP), and why it is not the
/// relative-binned one when it is not. Deterministic, so a run resumed from a checkpoint
/// rebuilds the very likelihood the checkpointed stage sampled.
pub(super) fn sampled_around(
    m: &ModelPlan<'_>,
    base: &[f64],
    walk_cov: &DMatrix<f64>,
) -> (Sampled, Vec<String>) {
    let (exact, spec) = (m.exact, &m.spec);
    let mut notes: Vec<String> = m.sampled_why.iter().cloned().collect();
    let sampled = match m.sampled_kind {
        LikelihoodKind::Relbin => {
            match RelBinLikelihood::with_covariance(exact, base, &m.relbin, &spec.free, walk_cov) {
                Ok(rb) => Sampled::RelBin(Box::new(rb)),
                Err(e) => {
                    notes.push(format!(
                        "relative binning not used ({e}); the samplers run on the exact likelihood"
                    ));
                    Sampled::Exact
                }
            }
        }
        LikelihoodKind::Exact => Sampled::Exact,
    };
    (sampled, notes)
}

/// The MAP search of a model and the Fisher matrix where it ended.
struct MapStage {
    /// The MAP, when the search converged.
    theta: Option<Vec<f64>>,
    /// Why the search failed.
    err: Option<String>,
    /// Free parameters whose MAP value is on a bound of the prior box.
    at_bound: Vec<String>,
    /// The MAP, or the start point without one: where the sub-models embed.
    base: Vec<f64>,
    /// Every maximum the search found, when it found one.
    search: Option<MultiStartMap>,
}

/// The bounded multi-start MAP search from the plan's start; notes a failure and a MAP on
/// the prior box.
fn map_search(m: &ModelPlan<'_>, notes: &mut Vec<String>) -> MapStage {
    let search = crate::jobs::prepare::map_search(m.exact, &m.spec.free, &m.start, m.map_starts)
        .map_err(|e| format!("MAP search: {e}"));
    let mut stage = MapStage {
        theta: None,
        err: None,
        at_bound: Vec::new(),
        base: m.start.clone(),
        search: None,
    };
    match search {
        Ok(s) => {
            stage.search = Some(s);
            stage.settle(m, notes);
        }
        Err(e) => {
            notes.push(e.clone());
            stage.err = Some(e);
        }
    }
    stage
}

/// How a model's note on a MAP at a physical limit of its parameters begins.
const LIMIT_NOTE: &str = "the MAP is at a physical limit: ";

/// Whether a model's note states a fact, not a problem: a MAP at a physical limit, a
/// θ-dependent noise evaluated at the model's own MAP by an iteration that converged, or a
/// MAP search whose other maxima hold no posterior mass. The
/// run lists these under its notes; every other model note is a warning.
pub fn is_fact(note: &str) -> bool {
    note.starts_with(LIMIT_NOTE)
        || crate::jobs::noise_point::NoisePoint::is_converged_note(note)
        || (note.starts_with("MAP search from") && note.contains(crate::likelihood::NO_MASS))
}

impl MapStage {
    /// Takes the highest maximum of the search as the MAP; notes a MAP on the prior box.
    fn settle(&mut self, m: &ModelPlan<'_>, notes: &mut Vec<String>) {
        const BOUND_NOTE: &str = "the MAP is on a bound of the prior box: ";
        notes.retain(|n| !n.starts_with(BOUND_NOTE) && !n.starts_with(LIMIT_NOTE));
        let Some(s) = &self.search else { return };
        let r = &s.best().result;
        let (names, free) = (&m.param_names, &m.spec.free);
        self.at_bound = r.bound_names(names, free);
        let (at_limit, at_bound): (Vec<_>, Vec<_>) = r
            .bound_report(
                names,
                m.exact.prior().kinds(),
                free,
                &m.exact.model().physical_limits(),
            )
            .into_iter()
            .partition(|(_, physical)| *physical);
        let texts = |v: Vec<(String, bool)>| v.into_iter().map(|(t, _)| t).collect::<Vec<_>>();
        if !at_bound.is_empty() {
            notes.push(format!(
                "{BOUND_NOTE}{}; the posterior is cut by the prior there",
                texts(at_bound).join("; ")
            ));
        }
        // the data agree with a physical limit: a fact, not a misplaced box (as in `fit`)
        if !at_limit.is_empty() {
            notes.push(format!(
                "{LIMIT_NOTE}{}; the posterior is cut there",
                texts(at_limit).join("; ")
            ));
        }
        self.theta = Some(r.theta.clone());
        self.base = r.theta.clone();
    }

    /// Which maximum the Laplace–Fisher rows expand around, when the search found several.
    fn which_maximum(&self) -> String {
        match &self.search {
            Some(s) if s.maxima.len() > 1 => format!(
                "; at the highest of the {} maxima the MAP search found, from {}",
                s.maxima.len(),
                s.best().from
            ),
            _ => String::new(),
        }
    }
}

/// When the chains' best sample lies above the highest maximum the MAP search found, searches
/// from there ([`MultiStartMap::search_from_chains`]); a higher maximum becomes the MAP (noted)
/// and `true` is returned.
fn chains_above_map(
    m: &ModelPlan<'_>,
    map: &mut MapStage,
    chains: Option<&Chains>,
    notes: &mut Vec<String>,
) -> bool {
    let (Some(c), Some(s), Some(th0)) = (chains, map.search.as_mut(), map.theta.as_ref()) else {
        return false;
    };
    let mut th = th0.clone();
    for (&i, v) in m.spec.free.iter().zip(c.max_posterior().theta) {
        th[i] = *v;
    }
    let before = s.best().result.ln_posterior;
    let tol = map_tolerance(m.exact.model().as_ref());
    if s.search_from_chains(m.exact, &th, tol, MAP_MAX_ITER) != Some(true) {
        return false;
    }
    notes.push(format!(
        "the chains climbed above the maximum the MAP search found: a search from their best sample found one {} nats higher, where the Laplace–Fisher rows and Schwarz now expand; the chains' proposal and relative binning were set up around the lower one — start the search near it ([fit] start) or raise [fit] map_starts",
        crate::report::fmt_fixed(s.best().result.ln_posterior - before, 2)
    ));
    map.settle(m, notes);
    true
}

/// The Fisher matrix at the MAP (or start point) and its inverse; a singular one is noted
/// with the directions the data do not constrain.
fn fisher_at(
    m: &ModelPlan<'_>,
    map: &MapStage,
    notes: &mut Vec<String>,
) -> (DMatrix<f64>, Option<DMatrix<f64>>) {
    let f_map = fisher_exact(m.exact, &map.base, &m.spec.free);
    let fisher_cov = linalg::spd_inverse(&f_map, &SpdOptions::lower().jacobi()).ok();
    if fisher_cov.is_none() {
        let (detail, named) = crate::likelihood::describe_unconstrained(&f_map, &m.free_names);
        notes.push(format!(
            "the Fisher matrix at the {} is singular: {detail}; fix {} (`fixed` of this [[select.model]]) or add an experiment that excites {}",
            if map.theta.is_some() {
                "MAP"
            } else {
                "start point"
            },
            named.join(", "),
            if named.len() == 1 { "it" } else { "them" }
        ));
    }
    (f_map, fisher_cov)
}

/// The in-model Metropolis–Hastings chains on the sampled sub-model `sub_s`, from starts
/// inside the prior around `centre`, and the iterations each ran: `[select] iterations`, then
/// on while they fail `[select] until`; `None` (noted) when they fail.
fn in_model_chains(
    m: &ModelPlan<'_>,
    sub_s: &SubModel<&dyn LogDensity>,
    centre: &[f64],
    walk_cov: &DMatrix<f64>,
    notes: &mut Vec<String>,
    (stage, stop): (Option<&StageFile>, &dyn Fn(usize) -> bool),
) -> Result<Option<(Chains, usize)>, String> {
    let st = &m.stages;
    let starts = chain_starts(sub_s, centre, walk_cov, st.chains, m.seed)?;
    let rule = st
        .until
        .map(|u| crate::sampler::Until::new(u.ess, u.rhat, u.every))
        .transpose()
        .map_err(|e| e.to_string())?
        .map(|u| u.at_least(st.iterations));
    let most = if rule.is_some() {
        st.most_iterations.max(st.iterations)
    } else {
        st.iterations
    };
    let settings = MhSettings {
        n_iter: most,
        burn_in: st.burn_in,
        thin: 1,
        n_chains: st.chains,
        seed: m.seed,
        anneal: None,
        adapt: Some(crate::sampler::Adapt {
            start: st.burn_in / 5,
            ..Default::default()
        }),
        // blocks between which the stage can be saved; the numbers do not depend on them
        checkpoint_every: (st.iterations / 50).max(1),
        progress_every: st.iterations,
    };
    let prop = walk_cov * (2.38f64.powi(2) / m.spec.free.len().max(1) as f64);
    let chains = MetropolisHastings::new(sub_s, &prop, settings)
        .map(|mh| match rule {
            Some(r) => mh.until(r),
            None => mh,
        })
        .and_then(|mh| match stage {
            Some(f) => {
                let id = f.identity(&m.name, "chains");
                let mh = mh
                    .checkpoint(&f.path)
                    .checkpoint_identity(id.clone())
                    .save_every(f.every)
                    .stop_when(stop);
                if f.holds(crate::sampler::CHECKPOINT_KIND, &id) {
                    mh.resume(&f.path)
                } else {
                    mh.run(&Start::PerChain(starts))
                }
            }
            None => mh.run(&Start::PerChain(starts)),
        })
        .map_err(|e| e.to_string())
        .and_then(|o| match o {
            RunOutcome::Finished(c) => Ok((c, most)),
            RunOutcome::Converged { chains, iterations } => Ok((chains, iterations)),
            RunOutcome::Stopped { .. } => Err("the in-model chains stopped early".to_string()),
        });
    Ok(match chains {
        Ok(c) => Some(c),
        Err(e) => {
            notes.push(format!("in-model chains: {e}"));
            None
        }
    })
}

/// The one line for in-model chains that ended (at `[select] max_iterations`, `n` per chain)
/// with some parameter's ESS below `[select] until`'s `min`: R-hat has its own lines.
fn short_of_ess(names: &[String], ess: &[f64], min: f64, n: usize) -> Option<String> {
    let short: Vec<String> = names
        .iter()
        .zip(ess)
        .filter(|(_, e)| !(**e >= min))
        .map(|(p, e)| format!("`{p}` ({e:.0})"))
        .collect();
    (!short.is_empty()).then(|| {
        format!(
            "in-model chains: effective sample size below {min:.0} ([select] until) after {n} iterations per chain, the most [select] max_iterations allows: {}; bridge sampling, Laplace–Metropolis and the jump proposal rest on fewer independent draws than asked — raise [select] max_iterations",
            short.join(", ")
        )
    })
}

/// The jump proposal (centre, covariance, source): the chains' mean and covariance, or the
/// Fisher Gaussian at the MAP, or the prior covariance; a fallback from the chains is noted.
fn jump_proposal(
    m: &ModelPlan<'_>,
    chains: Option<&Chains>,
    fisher_cov: Option<&DMatrix<f64>>,
    centre: &[f64],
    prior: &Prior,
    notes: &mut Vec<String>,
) -> (Vec<f64>, DMatrix<f64>, &'static str) {
    let d = m.spec.free.len();
    let chain_moments = chains.and_then(|c| {
        let cov = DMatrix::from_row_slice(d, d, &c.covariance());
        linalg::spd_inverse(&cov, &SpdOptions::lower().jacobi())
            .ok()
            .map(|_| (c.mean(), cov))
    });
    let (jump_center, jump_cov, jump_source) = match (m.stages.jump_proposal, chain_moments) {
        (JumpProposal::Chain, Some((mu, cov))) => (mu, cov, "in-model chains"),
        (JumpProposal::Chain, None) | (JumpProposal::Fisher, _) => match fisher_cov {
            Some(c) => (centre.to_vec(), c.clone(), "Fisher matrix at the MAP"),
            None => (centre.to_vec(), prior_cov(prior), "prior covariance"),
        },
    };
    if m.stages.jump_proposal == JumpProposal::Chain && jump_source != "in-model chains" {
        notes.push(format!(
            "the jump proposal uses the {jump_source}: the in-model chains gave no covariance"
        ));
    }
    (jump_center, jump_cov, jump_source)
}

/// The Laplace–Fisher estimates of a model and what they found on the way.
struct LaplaceFisher {
    /// `ln L` at the statistic's own maximum, when it was refined (non-Whittle statistics).
    stat_max_ln_l: Option<f64>,
    /// Raw: at the MAP (or the statistic's maximum), the prior box ignored.
    raw: Result<LaplaceEstimate, String>,
    /// Box-corrected: at the unconstrained maximum.
    boxed: Result<LaplaceEstimate, String>,
    /// The unconstrained maximum of `ln L`, when found.
    unbounded_max: Option<Vec<f64>>,
    /// Smallest distance of the raw expansion point from a prior bound, in Fisher σ.
    min_margin_sigma: f64,
}

/// Laplace–Fisher raw at the MAP (at the statistic's own maximum with its observed
/// information for a statistic other than Whittle's) and box-corrected at the unconstrained
/// maximum; a statistic whose `ln L` is not finite at the Whittle MAP is noted.
fn laplace_fisher_stage(
    m: &ModelPlan<'_>,
    map: &MapStage,
    (f_map, fisher_cov): (&DMatrix<f64>, Option<&DMatrix<f64>>),
    sub_exact: &SubModel<&Likelihood>,
    notes: &mut Vec<String>,
) -> LaplaceFisher {
    let (exact, free, d) = (m.exact, &m.spec.free, m.spec.free.len());
    let statistic = exact.statistic();
    let whittle = statistic == Statistic::Whittle;
    // the statistic's own maximum and observed information (the Whittle MAP and Fisher
    // matrix otherwise)
    let stat_max = match (&map.theta, fisher_cov, whittle) {
        (Some(th), Some(c), false) => {
            let sigma: Vec<f64> = (0..d).map(|i| c[(i, i)].sqrt()).collect();
            refine_statistic_max(exact, th, free, &sigma, 30)
        }
        _ => None,
    };
    if !whittle && map.theta.is_some() && stat_max.is_none() {
        notes.push(format!(
            "ln L of statistic \"{}\" is not finite at the Whittle MAP",
            statistic.name()
        ));
    }
    let (lf_theta, lf_info) = match &stat_max {
        Some((th, _, info)) => (Some(th.clone()), info.clone()),
        None if whittle => (map.theta.clone(), f_map.clone()),
        None => (None, f_map.clone()),
    };
    // Laplace–Fisher: raw at the MAP, box-corrected at the unconstrained maximum
    let lf_raw = match (&lf_theta, fisher_cov) {
        (Some(th), Some(_)) => laplace_fisher(
            sub_exact,
            &free_vec(th, free),
            &lf_info,
            &LaplaceOptions {
                box_correction: false,
                ..Default::default()
            },
        )
        .map_err(|e| e.to_string()),
        (None, _) => Err(format!(
            "needs the MAP ({})",
            map.err.clone().unwrap_or_default()
        )),
        (_, None) => Err("needs a non-singular Fisher matrix at the MAP".into()),
    };
    let min_margin_sigma = lf_raw.as_ref().map_or(0.0, |e| e.min_margin_sigma);
    let unb = if whittle {
        fisher_scoring_unbounded(exact, &map.base, free, map_tolerance(exact.model().as_ref()), 200).map_err(|e| {
            format!("the unconstrained maximum of ln L was not found ({e}); the box-corrected expansion needs it")
        })
    } else {
        Err(format!(
            "not computed for statistic \"{}\": the box-corrected expansion uses the Whittle likelihood's unconstrained maximum and Fisher matrix, which are not those of this ln L",
            statistic.name()
        ))
    };
    let lf_box = unb.as_ref().map_err(|e| e.clone()).and_then(|u| {
        let f = fisher_exact(exact, &u.theta, free);
        laplace_fisher(
            sub_exact,
            &free_vec(&u.theta, free),
            &f,
            &LaplaceOptions::default(),
        )
        .map_err(|e| e.to_string())
    });
    LaplaceFisher {
        stat_max_ln_l: stat_max.map(|s| s.1),
        raw: lf_raw,
        boxed: lf_box,
        unbounded_max: unb.map(|u| u.theta).ok(),
        min_margin_sigma,
    }
}

/// Laplace–Metropolis with the MVE and MCD covariances of the chains at their best sample
/// (`ln L` exact there), and that sample.
type LaplaceMetropolis = (
    Result<LaplaceEstimate, String>,
    Result<LaplaceEstimate, String>,
    Option<Vec<f64>>,
);

fn laplace_metropolis_stage(
    chains: Option<&Chains>,
    sub_exact: &SubModel<&Likelihood>,
) -> LaplaceMetropolis {
    match chains {
        Some(c) => {
            let samples = sample_matrix(c);
            let best = c.max_posterior().theta.to_vec();
            let lm = |method: RobustMethod| {
                laplace_metropolis(sub_exact, &best, &samples, &method).map_err(|e| e.to_string())
            };
            (
                lm(RobustMethod::Mve(MveOptions::default())),
                lm(RobustMethod::Mcd(McdOptions::default())),
                Some(best),
            )
        }
        None => {
            let why = Err::<LaplaceEstimate, String>(
                "needs the in-model chains, which did not run".into(),
            );
            (why.clone(), why, None)
        }
    }
}

/// Offset of the bridge-sampling draws' seed from the model's seed (whose streams the
/// in-model chains use).
const BRIDGE_SEED_OFFSET: u64 = 0x6272_6964_6765;

/// Bridge sampling on the sampled likelihood the chains ran on (their `ln L + ln π` are its
/// own), from the chains' kept draws.
fn bridge_sampling_stage(
    chains: Option<&Chains>,
    sub_s: &SubModel<&dyn LogDensity>,
    seed: u64,
) -> Evidence {
    let Some(c) = chains else {
        return Evidence::not_applicable("needs the in-model chains, which did not run".into());
    };
    let draws: Vec<PosteriorDraws<'_>> = c
        .chains()
        .iter()
        .map(|ch| PosteriorDraws {
            samples: &ch.samples,
            ln_posterior: &ch.ln_posterior,
        })
        .collect();
    Evidence::statistical(
        bridge_sampling(sub_s, &draws, seed.wrapping_add(BRIDGE_SEED_OFFSET))
            .map(|b| (b.ln_z, b.std_err, None))
            .map_err(|e| e.to_string()),
    )
}

/// What the raw Laplace–Fisher expansion assumes, for the table.
fn raw_assumes(statistic: Statistic, min_margin_sigma: f64) -> String {
    if statistic == Statistic::Whittle {
        format!(
            "a Gaussian posterior around the MAP, the prior box ignored (MAP {min_margin_sigma:.1} σ inside the nearest bound)"
        )
    } else {
        format!(
            "a Gaussian posterior around the maximum of the {} ln L with its numerical Hessian, the prior box ignored (maximum {min_margin_sigma:.1} σ inside the nearest bound)",
            statistic.name()
        )
    }
}

/// Runs every per-model stage but tempering ([`temper`]) for a competing model on its
/// parent's exact likelihood: MAP and Fisher matrix, the sampled likelihood, the in-model
/// chains, the jump proposal, Laplace–Fisher, Laplace–Metropolis and Schwarz.
/// `stop`, asked between blocks of the chains, ends them early (stage saved).
pub(super) fn run_model(
    m: &ModelPlan<'_>,
    stage: Option<&StageFile>,
    stop: &dyn Fn(usize) -> bool,
) -> Result<ModelRun, String> {
    let (exact, spec) = (m.exact, &m.spec);
    let free = &spec.free;
    let d = free.len();
    let mut notes = Vec::new();

    // MAP (bounded) and the Fisher matrix there
    let mut map = map_search(m, &mut notes);
    let base = map.base.clone();
    let sub_exact = SubModel::new(exact, free.clone(), base.clone()).map_err(|e| e.to_string())?;
    let prior = sub_exact.prior().clone();
    let (f_map, fisher_cov) = fisher_at(m, &map, &mut notes);
    let walk_cov = walk_cov(fisher_cov.as_ref(), &prior);

    // the sampled likelihood
    let (sampled, why) = sampled_around(m, &base, &walk_cov);
    notes.extend(why);
    let target: &dyn LogDensity = match &sampled {
        Sampled::RelBin(rb) => rb.as_ref(),
        Sampled::Exact => exact,
    };
    let sub_s = SubModel::new(target, free.clone(), base.clone()).map_err(|e| e.to_string())?;

    // in-model chains from starts inside the prior
    let centre = free_vec(&base, free);
    let ran = in_model_chains(m, &sub_s, &centre, &walk_cov, &mut notes, (stage, stop))?;
    let mcmc_iterations = ran.as_ref().map(|(_, n)| *n);
    let chains = ran.map(|(c, _)| c);
    let diag = chains.as_ref().and_then(|c| c.diagnostics().ok());
    // only chains that ran their most: those that stopped earlier met the rule
    if let (Some(u), Some(g), Some(n)) = (m.stages.until, diag.as_ref(), mcmc_iterations)
        && n >= m.stages.most_iterations
    {
        notes.extend(short_of_ess(&g.names, &g.ess, u.ess, n));
    }
    // the chains feed Laplace–Metropolis and the jump proposals: a convergence failure is a
    // warning of the run (the report marks the same R-hat threshold)
    for w in diag.iter().flat_map(|g| g.warnings()) {
        use crate::sampler::Warning as W;
        if matches!(
            w,
            W::RHat { .. } | W::RHatNotFinite { .. } | W::Stuck { .. }
        ) {
            notes.push(format!("in-model chains: {w}"));
        }
    }
    let (jump_center, jump_cov, jump_source) = jump_proposal(
        m,
        chains.as_ref(),
        fisher_cov.as_ref(),
        &centre,
        &prior,
        &mut notes,
    );
    // the chains may have climbed into a basin the starts missed
    let (f_map, fisher_cov) = if chains_above_map(m, &mut map, chains.as_ref(), &mut notes) {
        fisher_at(m, &map, &mut notes)
    } else {
        (f_map, fisher_cov)
    };
    if fisher_cov.is_some() {
        let at = if map.theta.is_some() {
            "MAP"
        } else {
            "start point"
        };
        notes.extend(crate::likelihood::degeneracy_warning(
            &f_map,
            &m.free_names,
            at,
        ));
    }
    let lf = laplace_fisher_stage(
        m,
        &map,
        (&f_map, fisher_cov.as_ref()),
        &sub_exact,
        &mut notes,
    );
    let (lm_mve, lm_mcd, best) = laplace_metropolis_stage(chains.as_ref(), &sub_exact);
    let bridge = bridge_sampling_stage(chains.as_ref(), &sub_s, m.seed);
    // parallel tempering (its own stage: [`temper`]) starts from the best sample with the
    // chains' covariance
    let tempering_start = best.clone().unwrap_or_else(|| centre.clone());

    // Schwarz at the MAP, or at the best sample when there is no MAP
    let ln_l_map = match (&map.theta, &best, lf.stat_max_ln_l) {
        // the statistic's maximum, not its value at the Whittle MAP
        (Some(_), _, Some(l)) => l,
        (Some(th), _, None) => exact.ln_likelihood_full(th),
        (None, Some(b), _) => sub_exact.ln_likelihood(b),
        (None, None, _) => exact.ln_likelihood_full(&base),
    };
    let schwarz = schwarz_ln_z(ln_l_map, d, m.n_sbic).map_err(|e| e.to_string())?;

    let noise_correction = m
        .noise_point
        .as_ref()
        .and_then(|p| noise_correction(exact, chains.as_ref(), &base, free, p, &mut notes));

    let which = map.which_maximum();
    if let Some(d) = map.search.as_ref().and_then(|s| s.describe(&m.param_names)) {
        notes.push(d);
    }
    let box_assumes =
        "a Gaussian likelihood around its unconstrained maximum, cut by the prior box".to_string();
    let lm_assumes = "a Gaussian posterior with the chains' robust covariance, centred on the best sample, the prior box ignored".to_string();
    let outcome = ModelOutcome {
        name: m.name.clone(),
        model: exact.model().name().to_string(),
        params: m.param_names.clone(),
        units: exact.model().param_units(),
        free: m.free_names.clone(),
        prior_probability: m.prior_probability,
        map: map.base.clone(),
        map_found: map.theta.is_some(),
        missing_injection_bias: None,
        map_at_bound: map.at_bound,
        estimates: super::estimates::param_estimates(
            &m.param_names,
            &exact.model().param_units(),
            free,
            &map.base,
            diag.as_ref().map(|g| (&g.mean[..], &g.sd[..])),
            fisher_cov.as_ref(),
        ),
        relbin: match &sampled {
            Sampled::RelBin(rb) => Some(rb.validation().clone()),
            Sampled::Exact => None,
        },
        ln_l_map,
        unbounded_max: lf.unbounded_max,
        min_margin_sigma: lf.min_margin_sigma,
        laplace_fisher_raw: Evidence::systematic(
            lf.raw,
            raw_assumes(exact.statistic(), lf.min_margin_sigma) + &which,
        ),
        laplace_fisher_box: Evidence::systematic(lf.boxed, box_assumes + &which),
        laplace_metropolis_mve: Evidence::systematic(lm_mve, lm_assumes.clone()),
        laplace_metropolis_mcd: Evidence::systematic(lm_mcd, lm_assumes),
        thermodynamic: Evidence::not_applicable("parallel tempering has not run yet".into()),
        stepping_stone: Evidence::not_applicable("parallel tempering has not run yet".into()),
        bridge_sampling: bridge,
        tempering: None,
        schwarz_ln_z: schwarz,
        mcmc_acceptance: diag.as_ref().map_or(Vec::new(), |g| g.acceptance.clone()),
        mcmc_max_rhat: diag
            .as_ref()
            .map(|g| g.rhat.iter().cloned().fold(0.0, f64::max)),
        mcmc_iterations,
        jump_proposal: jump_source.to_string(),
        unstable_evaluations: 0,
        noise_correction,
        notes,
    };
    Ok(ModelRun {
        outcome,
        spec: spec.clone(),
        sampled,
        base,
        jump_center,
        jump_cov,
        tempering_start,
        seed: m.seed,
        chains,
    })
}

/// Samples of the in-model chains the noise correction averages over (evenly thinned, in
/// chain order; each costs a factorisation of the residual CSD per bin): first the smaller
/// number, then the larger when the error is above [`NOISE_CORRECTION_ERROR`] nats.
const NOISE_CORRECTION_SAMPLES: [usize; 2] = [500, 2000];

/// The noise correction's error (nats) below which its first, smaller sample suffices.
const NOISE_CORRECTION_ERROR: f64 = 0.02;

/// The shift from this model's fixed-noise evidence to the exact θ-dependent one, over the
/// in-model chains' samples; the note of where the noise was evaluated (and of a correction
/// not to be trusted) goes to `notes`.
fn noise_correction(
    exact: &crate::likelihood::Likelihood,
    chains: Option<&Chains>,
    base: &[f64],
    free: &[usize],
    point: &crate::jobs::own_noise::NoisePoint,
    notes: &mut Vec<String>,
) -> Option<crate::likelihood::theta_noise::NoiseCorrection> {
    use crate::likelihood::theta_noise::NoiseCorrection;
    notes.push(point.note());
    let Some(chains) = chains else {
        notes.push("no in-model chains: the evidences are those of the noise held at the MAP, not corrected to the exact θ-dependent likelihood".into());
        return None;
    };
    let d = chains.dim();
    let all: Vec<&[f64]> = chains
        .chains()
        .iter()
        .flat_map(|c| c.samples.chunks(d))
        .collect();
    let at = |n: usize| {
        let step = all.len().div_ceil(n).max(1);
        let full: Vec<Vec<f64>> = all
            .iter()
            .step_by(step)
            .map(|s| {
                let mut th = base.to_vec();
                for (&a, v) in free.iter().zip(*s) {
                    th[a] = *v;
                }
                th
            })
            .collect();
        NoiseCorrection::estimate(exact, full.iter().map(|v| v.as_slice()))
    };
    let [few, many] = NOISE_CORRECTION_SAMPLES;
    let c = match at(few) {
        Some(c) if c.std_err <= NOISE_CORRECTION_ERROR && !c.unreliable() => Some(c),
        _ => at(many),
    };
    match &c {
        None => notes.push("the exact θ-dependent likelihood is not finite at some posterior sample: the evidences are those of the noise held at the MAP, not corrected".into()),
        Some(c) if c.unreliable() => notes.push(format!(
            "the correction to the exact θ-dependent likelihood ({:+.3} ± {:.3} nats) rests on {:.0} effective of {} samples: not to be trusted; the noise point did not settle where the posterior is",
            c.ln_z_shift, c.std_err, c.weight_ess, c.samples
        )),
        Some(_) => {}
    }
    c
}

/// The parallel-tempering stage of a model (thermodynamic integration and stepping-stone),
/// run after [`run_model`]: a stage of its own so that a checkpoint can hold a model whose
/// tempering, the longest part, has not run yet.
/// `progress` is called with the sweeps done (for progress); with `stage` the ladder is saved
/// as it goes and resumed from there.
pub(super) fn temper(
    m: &ModelPlan<'_>,
    run: &mut ModelRun,
    progress: &mut dyn FnMut(usize),
    (stage, stop): (Option<&StageFile>, &dyn Fn(usize) -> bool),
) -> Result<(), String> {
    let exact = m.exact;
    let free = &run.spec.free;
    let target: &dyn LogDensity = match &run.sampled {
        Sampled::RelBin(rb) => rb.as_ref(),
        Sampled::Exact => exact,
    };
    let sub_s = SubModel::new(target, free.clone(), run.base.clone()).map_err(|e| e.to_string())?;
    let sub_exact =
        SubModel::new(exact, free.clone(), run.base.clone()).map_err(|e| e.to_string())?;
    let (thermodynamic, stepping_stone, tempering) = tempering(
        &m.stages,
        &sub_s,
        matches!(run.sampled, Sampled::RelBin(_)).then_some(&sub_exact as &dyn LogDensity),
        (&run.tempering_start, &run.jump_cov),
        (run.seed, m.name.as_str()),
        progress,
        (stage, stop),
    );
    run.outcome.thermodynamic = thermodynamic;
    run.outcome.stepping_stone = stepping_stone;
    run.outcome.tempering = tempering;
    Ok(())
}

/// `Σ_i w_i max_k |ln L_exact − ln L_approx|` over the states each rung kept, `w_i` the
/// trapezoid weights of the ladder: a bound on how far an approximate likelihood moves the
/// integral `∫ E_β[ln L] dβ`. The hot rungs roam the whole prior, far beyond the region where
/// relative binning was validated for the posterior, but enter with weights of order `β`.
fn ladder_approximation_error(
    betas: &[f64],
    rung_samples: &[Vec<Vec<f64>>],
    approx: &dyn LogDensity,
    exact: &dyn LogDensity,
) -> f64 {
    let n = betas.len();
    (0..n)
        .map(|i| {
            let lo = if i > 0 { betas[i] - betas[i - 1] } else { 0.0 };
            let hi = if i + 1 < n {
                betas[i + 1] - betas[i]
            } else {
                0.0
            };
            let worst = rung_samples[i]
                .iter()
                .map(|t| (exact.ln_likelihood(t) - approx.ln_likelihood(t)).abs())
                .fold(0.0, f64::max);
            0.5 * (lo + hi) * worst
        })
        .sum()
}

/// Thermodynamic integration and stepping-stone from one parallel-tempering run on the
/// sampled likelihood (its own seed stream, `seed + 7919`). With `exact` (the sampled
/// likelihood is an approximation of it), the approximation's effect along the ladder is
/// measured at the rungs' states and added to both errors. The ladder starts at `start` with
/// random walks shaped by `cov`; `model` names its stage in the stage file.
fn tempering(
    st: &StageSettings,
    target: &dyn LogDensity,
    exact: Option<&dyn LogDensity>,
    (start, cov): (&[f64], &DMatrix<f64>),
    (seed, model): (u64, &str),
    progress: &mut dyn FnMut(usize),
    (stage, stop): (Option<&StageFile>, &dyn Fn(usize) -> bool),
) -> (Evidence, Evidence, Option<TemperingDiagnostics>) {
    if st.pt_temperatures == 0 {
        let why = if st.cross_checks == CrossChecks::Off {
            "cross-checks are off ([select] cross_checks = \"off\"): no tempering ran"
        } else {
            "parallel tempering is off ([select] pt_temperatures = 0)"
        };
        let off = || Evidence::not_applicable(why.into());
        return (off(), off(), None);
    }
    let opts = TemperingOptions {
        n_temps: st.pt_temperatures,
        n_iter: st.pt_iterations,
        burn_in: st.pt_burn_in,
        seed: seed.wrapping_add(7919),
        ..Default::default()
    };
    let t0 = std::time::Instant::now();
    let ran = ParallelTempering::new(target, start, cov, &opts).and_then(|pt| {
        let pt = pt.progress(progress);
        match stage {
            Some(f) => {
                let id = f.identity(model, "tempering");
                let pt = pt.checkpoint(&f.path, id.clone(), f.every).stop_when(stop);
                if f.holds(crate::evidence::tempering::KIND, &id) {
                    pt.resume(&f.path)
                } else {
                    pt.run()
                }
            }
            None => pt.run(),
        }
    });
    match ran {
        Ok(TemperingOutcome::Finished(r)) => {
            let approx_err =
                exact.map(|e| ladder_approximation_error(&r.betas, &r.rung_samples, target, e));
            let a = approx_err.unwrap_or(0.0);
            let ti = r
                .thermodynamic
                .as_ref()
                .map(|t| (t.ln_z, t.total_err().hypot(a), Some(t.discretisation_err)))
                .map_err(|e| e.clone());
            let shift = r
                .thermodynamic
                .as_ref()
                .ok()
                .map(|t| t.discretisation_shift);
            let ss = r
                .stepping_stone
                .as_ref()
                .map(|t| (t.ln_z, t.std_err.hypot(a), None))
                .map_err(|e| e.clone());
            let diag = TemperingDiagnostics {
                betas: r.betas,
                swap_acceptance: r.swap_acceptance,
                in_rung_acceptance: r.in_rung_acceptance,
                sweeps: r.n_iter,
                burn_in: r.burn_in,
                ln_l_evals: r.ln_l_evals,
                approximation_err: approx_err,
                seconds: t0.elapsed().as_secs_f64(),
            };
            // the run's checks against itself (its error already widened where they failed)
            // each estimate carries the messages that concern it
            let caveat = |mut e: Evidence, checks: Vec<String>| {
                if e.ln_z.is_some() && !checks.is_empty() {
                    e.note = Some(checks.join("; "));
                }
                e
            };
            let ti = Evidence {
                discretisation_shift: shift,
                ..Evidence::statistical(ti)
            };
            (
                caveat(ti, r.checks.for_thermodynamic()),
                caveat(Evidence::statistical(ss), r.checks.for_stepping_stone()),
                Some(diag),
            )
        }
        Ok(TemperingOutcome::Stopped { sweeps }) => {
            let why = || {
                Evidence::not_applicable(format!(
                    "parallel tempering stopped after {sweeps} sweeps"
                ))
            };
            (why(), why(), None)
        }
        Err(e) => {
            let why = || Evidence::not_applicable(format!("parallel tempering: {e}"));
            (why(), why(), None)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::prior::PriorKind;
    use crate::sampler::test_targets::CornerTarget;

    #[test]
    fn caps_each_marginal_at_the_prior_and_keeps_correlations() {
        let prior = Prior::new(
            vec!["a".into(), "b".into()],
            vec![
                PriorKind::Uniform { lo: 0.0, hi: 1.0 },
                PriorKind::Uniform { lo: 0.0, hi: 1.0 },
            ],
        )
        .unwrap();
        // a: σ = 10 (10 box widths), b: σ = 0.01; correlation 0.5
        let cov = DMatrix::from_row_slice(2, 2, &[100.0, 0.05, 0.05, 1e-4]);
        let c = crate::sampler::cap_to_prior(&cov, &prior);
        let sd_box = 1.0 / 12f64.sqrt();
        assert!((c[(0, 0)].sqrt() - sd_box).abs() < 1e-15);
        assert!((c[(1, 1)] - 1e-4).abs() < 1e-18);
        let rho = c[(0, 1)] / (c[(0, 0)] * c[(1, 1)]).sqrt();
        assert!((rho - 0.5).abs() < 1e-12);
    }

    #[test]
    fn ladder_error_weights_each_rung_by_its_share_of_beta() {
        let prior = Prior::new(
            vec!["a".into()],
            vec![PriorKind::Uniform { lo: 0.0, hi: 1.0 }],
        )
        .unwrap();
        let exact = CornerTarget {
            sd: 1.0,
            prior: prior.clone(),
        };
        // an approximation off by |θ|·3 nats: the hot rung's far states count with weight β
        struct Off<'a>(&'a CornerTarget);
        impl LogDensity for Off<'_> {
            fn ln_likelihood(&self, th: &[f64]) -> f64 {
                self.0.ln_likelihood(th) + 3.0 * th[0]
            }
            fn prior(&self) -> &Prior {
                self.0.prior()
            }
        }
        let betas = [0.0, 0.25, 1.0];
        let samples = vec![
            vec![vec![1.0], vec![0.5]], // β = 0: worst |Δ| = 3,   weight 0.125
            vec![vec![0.2]],            // β = 0.25: |Δ| = 0.6,   weight 0.5
            vec![vec![0.1], vec![0.0]], // β = 1: worst |Δ| = 0.3, weight 0.375
        ];
        let e = ladder_approximation_error(&betas, &samples, &Off(&exact), &exact);
        assert!(
            (e - (0.125 * 3.0 + 0.5 * 0.6 + 0.375 * 0.3)).abs() < 1e-12,
            "{e}"
        );
        assert_eq!(
            ladder_approximation_error(&betas, &samples, &exact, &exact),
            0.0
        );
    }
}
