//! The fit pipeline: MAP, Fisher matrix, Cramér–Rao bounds and the Metropolis–Hastings chains,
//! checkpointed and resumable.

use super::summary::{
    FitError, FitOutcome, FitSummary, IndependenceCounts, ParamRow, non_finite_warnings,
};
use crate::config::{LikelihoodKind, Study};
use crate::density::LogDensity;
use crate::jobs::prepare::{
    MAP_MAX_ITER, Prepared, default_start, gap_notes, map_search, model_warnings, relbin_of,
    truth_of,
};
use crate::likelihood::{Likelihood, MultiStartMap, ScoringResult, cramer_rao, fisher_exact};
use crate::linalg::SpdOptions;
use crate::model::map_tolerance;
use crate::nested::SubModel;
use crate::sampler::{
    Adapt, Chains, DEFAULT_DOF, Independence, MetropolisHastings, MhSettings, Progress, RunOutcome,
    Start, StudentProposal, chain_starts,
};
use nalgebra::DMatrix;
use std::path::Path;
use std::time::Instant;

/// The fit's checkpoint inside its run directory ([`crate::data::checkpoint`], kind `mh`).
pub const CHECKPOINT_FILE: &str = "checkpoint.cbor";

/// Runs the fit of `study`'s `[fit]` model on prepared data; writes a checkpoint into `out`
/// while it runs (and resumes from it if `resume`). `stop`, asked between blocks of the
/// chains with the iterations done, ends the run early (checkpoint saved) with an error.
pub fn run(
    study: &Study,
    prep: &Prepared,
    out: &Path,
    observer: Option<&(dyn Fn(&Progress) + Sync)>,
    stop: Option<&dyn Fn(usize) -> bool>,
    resume: bool,
) -> Result<FitOutcome, FitError> {
    // modelled glitches: the model carries them (`Prepared::study`)
    let study = prep.study(study);
    let exact = &prep.likelihood;
    let model = &study.fit_model;
    let free = &model.free;
    let names = exact.model().param_names().to_vec();
    let t0 = Instant::now();
    let start = default_start(study, model);
    let free_names: Vec<String> = free.iter().map(|&i| names[i].clone()).collect();
    let value_of = |n: &str| names.iter().position(|p| p == n).map(|i| start[i]);
    let search = map_search(exact, free, &start, study.fit.map_starts).map_err(|e| match e {
        crate::likelihood::MapError::Singular {
            unconstrained,
            detail,
        } => FitError::Other(prep.lead_with_data_loss(format!(
            "MAP search: the Fisher matrix is singular: {detail}. {}",
            fix_hint(&free_names, &unconstrained, &value_of)
        ))),
        e => FitError::Map(e),
    })?;
    let mut map = search.best().result.clone();
    let mut warnings = model_warnings(study, model.model, &prep.dataset);
    let (mut notes, gap_warnings) = gap_notes(study, &prep.dataset);
    warnings.extend(gap_warnings);
    warnings.extend(prep.glitch_notes());
    // a noise point whose iteration converged is how the likelihood was built, not a problem
    if let Some(p) = &prep.noise_point {
        if p.converged {
            notes.push(p.fit_note());
        } else {
            warnings.push(p.fit_note());
        }
    }
    if !map.converged {
        warnings.push(format!(
            "the MAP search stopped after {} iterations without converging; the chains may start far from the mode",
            map.iterations
        ));
    }
    let (at_limit, at_bound): (Vec<_>, Vec<_>) = map
        .bound_report(
            &names,
            exact.prior().kinds(),
            free,
            &exact.model().physical_limits(),
        )
        .into_iter()
        .partition(|(_, physical)| *physical);
    let texts = |v: Vec<(String, bool)>| v.into_iter().map(|(t, _)| t).collect::<Vec<_>>();
    if !at_bound.is_empty() {
        warnings.push(format!(
            "the MAP is on a bound of the prior box: {}. The posterior is cut by the prior there, and the Cramér–Rao σ and the pulls assume an interior maximum",
            texts(at_bound).join("; ")
        ));
    }
    // the data agree with a physical limit: a fact, not a misplaced box
    if !at_limit.is_empty() {
        notes.push(format!(
            "the MAP is at a physical limit: {}. The data are consistent with the limit and the posterior is cut there: the Cramér–Rao σ and the pull of such a parameter assume an interior maximum, so quote its chains' quantiles (an upper or lower limit)",
            texts(at_limit).join("; ")
        ));
    }
    let mut fisher = fisher_exact(exact, &map.theta, free);
    let value_of = |n: &str| names.iter().position(|p| p == n).map(|i| map.theta[i]);
    let mut cr = cramer_rao(&fisher).ok_or_else(|| {
        FitError::Other(prep.lead_with_data_loss(singular_message(
            &fisher,
            &free_names,
            "MAP",
            &value_of,
        )))
    })?;
    // singular to rounding, or the wide range above it where every number looks ordinary
    if let Some(w) = near_singular_warning(&fisher, &free_names)
        .or_else(|| crate::likelihood::degeneracy_warning(&fisher, &free_names, "MAP"))
    {
        warnings.push(w);
    }
    let seconds_map = t0.elapsed().as_secs_f64();
    let d = free.len();
    // capped at the prior's widths, as select's walks are: with the MAP on a bound or a
    // parameter the data barely constrain, the Fisher Gaussian overhangs the box and an
    // uncapped walk proposed outside it almost always (0.1–0.3 % acceptance)
    let walk = crate::sampler::cap_to_prior(
        &SpdOptions::lower()
            .factor(&fisher)
            .expect("checked above")
            .inverse(),
        &exact.prior().subset(free),
    );
    let cov = &walk * (study.fit.proposal_scale * 2.38f64.powi(2) / d as f64);
    let f = &study.fit;
    let settings = MhSettings {
        n_iter: f.iterations,
        burn_in: f.burn_in,
        thin: f.thin,
        n_chains: f.chains,
        seed: f.seed.unwrap_or(study.seed.wrapping_add(1)),
        anneal: None,
        adapt: f.adapt.then(|| Adapt {
            start: f.burn_in / 5,
            ..Default::default()
        }),
        checkpoint_every: f.checkpoint_every,
        progress_every: 200,
    };
    let t1 = Instant::now();
    let statistic = exact.statistic();
    let (kind, why) = crate::jobs::prepare::sampled_kind(study, exact);
    warnings.extend(why);
    // the checkpoint belongs to this study, these data and this likelihood kind (a resumed
    // fit must not continue relative-binned chains as exact ones, or the other way round)
    let identity = format!(
        "{}-{kind:?}",
        crate::jobs::prepare::identity(study, &prep.dataset)
    );
    let ckpt = Checkpoint {
        out,
        resume,
        identity: &identity,
    };
    let independence = independence_share(f, exact.model().as_ref());
    let centre: Vec<f64> = model.free.iter().map(|&i| map.theta[i]).collect();
    let widths: Vec<f64> = (0..walk.nrows()).map(|k| walk[(k, k)].sqrt()).collect();
    let log = log_axes(&names, &model.free, &centre, &widths);
    let around = (&map.theta[..], &walk, &cov, independence, &log[..]);
    let until = f
        .until
        .map(|u| crate::sampler::Until::new(u.ess, u.rhat, u.every))
        .transpose()?;
    let (length, hooks) = ((settings, until), (observer, stop));
    let ((chains, converged_at), n_coarse) = match kind {
        LikelihoodKind::Exact => (sample(exact, model, around, length, &ckpt, hooks)?, None),
        LikelihoodKind::Relbin => {
            let rb = relbin_of(study, exact, &map.theta)?;
            let n = rb.n_coarse();
            (sample(&rb, model, around, length, &ckpt, hooks)?, Some(n))
        }
    };
    let seconds_mcmc = t1.elapsed().as_secs_f64();
    let mut search = search;
    if let Some(w) = chains_above_map(
        exact,
        free,
        &chains,
        &mut search,
        (&mut map, &mut fisher, &mut cr),
    ) {
        warnings.push(w);
    }
    if let Some(d) = search.describe(&names) {
        // a maximum far below the highest is a fact, not a problem
        if search.is_fact() {
            notes.push(d)
        } else {
            warnings.push(d)
        }
    }
    let diag = chains.diagnostics()?;
    warnings.extend(diag.warnings().iter().map(|w| w.to_string()));
    let truth = truth_of(study, model.model, &prep.dataset);
    let glitch_count = count_glitches(study, prep, free, &map.theta, &fisher, truth.as_deref());
    let glitch_count = match glitch_count {
        Ok(g) => {
            if let Some(g) = &g {
                warnings.extend(g.warnings());
            }
            g
        }
        Err(e) => {
            warnings.push(format!("glitch count: not run: {e}"));
            None
        }
    };
    let (sandwich, why) = sandwich_of(exact, &map.theta, free, &fisher).unzip();
    if let Some(w) = sandwich
        .as_ref()
        .zip(why.as_deref())
        .and_then(|(s, why)| sandwich_warning(s, &cr, &diag.sd, &names, free, why))
    {
        match w {
            Shortfall::Warning(w) => warnings.push(w),
            Shortfall::Note(n) => notes.push(n),
        }
    }
    let reference = prep.noise_point.as_ref().map_or_else(
        || crate::jobs::prepare::reference_point(study, model.model),
        |p| p.theta.clone(),
    );
    let injection_bias = match crate::jobs::injection_bias::predict(
        study,
        model.model,
        &prep.dataset,
        exact,
        &reference,
        &map.theta,
        free,
        &cr,
    ) {
        Ok(b) => b,
        Err(e) => {
            warnings.push(format!(
                "the bias of the injection missing inside gaps: not predicted: {e}"
            ));
            None
        }
    };
    let units = exact.model().param_units();
    let rows: Vec<ParamRow> = free
        .iter()
        .enumerate()
        .map(|(k, &i)| {
            let tr = truth.as_ref().and_then(|t| t[i]);
            ParamRow {
                name: names[i].clone(),
                unit: units.get(i).cloned().unwrap_or_default(),
                truth: tr,
                map: map.theta[i],
                mean: diag.mean[k],
                sd: diag.sd[k],
                cramer_rao: cr[k],
                sandwich: sandwich.as_ref().map(|s| s[k]),
                rhat: diag.rhat[k],
                ess: diag.ess[k],
                pull: tr.map(|t| (diag.mean[k] - t) / diag.sd[k]),
            }
        })
        .collect();
    let total_iter = (converged_at.unwrap_or(f.iterations) * f.chains) as f64;
    let mut invalid_reasons = Vec::new();
    if !map.converged {
        invalid_reasons.push(format!(
            "the MAP search did not converge in {} iterations; the chains started from where it stopped — give a [fit] start nearer the mode or raise [fit] map_starts",
            map.iterations
        ));
    }
    if let Some(b) = &injection_bias {
        match b.worst() {
            Some((_, w)) if w > crate::jobs::injection_bias::BIAS_LIMIT => {
                invalid_reasons.push(b.line())
            }
            Some(_) => warnings.push(b.line()),
            None => {}
        }
    }
    let names_free: Vec<String> = rows.iter().map(|r| r.name.clone()).collect();
    let rhat: Vec<f64> = rows.iter().map(|r| r.rhat).collect();
    let ess: Vec<f64> = rows.iter().map(|r| r.ess).collect();
    invalid_reasons.extend(
        crate::jobs::validity::ChainChecks {
            scope: "chains",
            names: &names_free,
            rhat: &rhat,
            ess: Some(&ess),
            acceptance: &diag.acceptance,
            remedy: "run longer ([fit] iterations, burn_in), start nearer the mode ([fit] start), or fix fewer parameters free that the data do not measure",
        }
        .failures(),
    );
    let mut summary = FitSummary {
        valid: invalid_reasons.is_empty(),
        invalid_reasons,
        origin: prep.origin.clone(),
        model: exact.model().name().to_string(),
        statistic,
        likelihood: kind,
        noise_averages: crate::jobs::prepare::noise_averages_for_summary(study, exact),
        glitch_gates: prep.glitch_gates.clone(),
        glitch_count,
        missing_injection_bias: injection_bias,
        n_bins: exact.n_bins(),
        n_coarse_bins: n_coarse,
        rho_opt_at_map: exact.snr(&map.theta),
        // of the statistic, at the (Whittle) MAP the chains start from
        map_ln_posterior: exact.ln_posterior(&map.theta),
        map_iterations: map.iterations,
        rows,
        acceptance: diag.acceptance.clone(),
        independence: (independence > 0.0).then(|| {
            let counts = chains.chains().iter().map(|c| c.counts.independent);
            IndependenceCounts {
                share: independence,
                proposed: counts.clone().map(|c| c.proposed).sum(),
                accepted: counts.map(|c| c.accepted).sum(),
            }
        }),
        non_finite: diag.non_finite.clone(),
        warnings,
        notes,
        chains: f.chains,
        converged_at,
        kept_per_chain: chains.n_kept(),
        burn_in: f.burn_in,
        thin: f.thin,
        seconds_map,
        seconds_mcmc,
        iterations_per_second: total_iter / seconds_mcmc,
        fisher: (0..d)
            .map(|i| (0..d).map(|j| fisher[(i, j)]).collect())
            .collect(),
    };
    let extra = non_finite_warnings(&summary);
    summary.warnings.extend(extra);
    let information = crate::likelihood::information::Information::of(
        exact,
        &map.theta,
        free,
        &names,
        &crate::jobs::prepare::injection_lines(study, exact),
    );
    let (bode, w, n) = crate::jobs::bode::bode_data(
        study,
        &prep.dataset.experiments,
        &[crate::jobs::bode::Fitted {
            name: exact.model().name(),
            likelihood: exact,
            map: &map.theta,
        }],
    );
    summary.warnings.extend(w);
    summary.notes.extend(n);
    let (raw, w) = crate::jobs::raw_data::raw_data(study, exact, &prep.dataset.experiments);
    summary.warnings.extend(w);
    Ok(FitOutcome {
        summary,
        chains,
        map_full: map.theta,
        fisher,
        information,
        bode,
        raw,
    })
}

/// `[fit] independence`, or the model's default: [`crate::config::DEFAULT_GLITCH_INDEPENDENCE`]
/// with modelled glitches, none otherwise.
pub(super) fn independence_share(
    f: &crate::config::FitOptions,
    model: &dyn crate::model::Model,
) -> f64 {
    f.independence
        .unwrap_or(if crate::model::glitch::carries_glitches(model) {
            crate::config::DEFAULT_GLITCH_INDEPENDENCE
        } else {
            0.0
        })
}

/// Least distance of a glitch's decay or amplitude from 0, in its widths at the MAP, for
/// [`log_axes`] to draw it in logarithm.
pub const LOG_AXIS_WIDTHS: f64 = 5.0;

/// Which of the parameters `free` (indices into `names`, with `centre` and widths `sd` per
/// free parameter) the fit's independence proposal draws in logarithm
/// ([`crate::sampler::StudentProposal::log_axes`]): each glitch's decay `g<j>_tau` and
/// amplitude `g<j>_a` that lies at least [`LOG_AXIS_WIDTHS`] widths from 0. Why: a glitch
/// decaying faster than the loop responds is seen through the product `a τ`, so its posterior
/// is a ridge `ln |a| + ln τ ≈ const`. Measured on `examples/glitches.toml` (seed 2014): a
/// glitch of −5.3e−14 m s⁻² decaying in 37 s had chains spread 1.2–1.5 times its Cramér–Rao σ,
/// one chain wandering to 18 s and −7.8e−14 and staying there (R-hat 1.16, ESS 11). Why not
/// nearer 0: the log-normal of the same width at the centre is then skewed where the posterior
/// need not be, and a decay the data hardly constrain (its width capped at the prior's) would
/// be drawn over decades of `e`. Returns positions in `free`.
pub fn log_axes(names: &[String], free: &[usize], centre: &[f64], sd: &[f64]) -> Vec<usize> {
    free.iter()
        .enumerate()
        .filter(|&(k, &i)| {
            let name = names[i].as_str();
            crate::model::glitch::is_glitch_param(name)
                && (name.ends_with("_tau") || name.ends_with("_a"))
                && centre[k] != 0.0
                && centre[k].abs() >= LOG_AXIS_WIDTHS * sd[k]
        })
        .map(|(k, _)| k)
        .collect()
}

/// When the chains' best sample lies above the MAP search's maximum, searches from there
/// ([`MultiStartMap::search_from_chains`]); a higher maximum replaces `map` with its Fisher
/// matrix and Cramér–Rao σ, and the warning says so.
fn chains_above_map(
    exact: &Likelihood,
    free: &[usize],
    chains: &Chains,
    search: &mut MultiStartMap,
    (map, fisher, cr): (&mut ScoringResult, &mut DMatrix<f64>, &mut Vec<f64>),
) -> Option<String> {
    let mut th = map.theta.clone();
    for (&i, v) in free.iter().zip(chains.max_posterior().theta) {
        th[i] = *v;
    }
    let tol = map_tolerance(exact.model().as_ref());
    if search.search_from_chains(exact, &th, tol, MAP_MAX_ITER) != Some(true) {
        return None;
    }
    let best = search.best().result.clone();
    let f = fisher_exact(exact, &best.theta, free);
    let below = best.ln_posterior - map.ln_posterior;
    let Some(new_cr) = cramer_rao(&f) else {
        return Some(format!(
            "the chains climbed above the maximum the MAP search found: a search from their best sample found one {} nats higher, but the Fisher matrix there is singular; the MAP column and the Cramér–Rao σ are of the lower one",
            crate::report::fmt_fixed(below, 2)
        ));
    };
    let start: Vec<String> = free
        .iter()
        .map(|&i| {
            format!(
                "{} = {}",
                exact.model().param_names()[i],
                crate::report::fmt_roundtrip(best.theta[i])
            )
        })
        .collect();
    *map = best;
    *fisher = f;
    *cr = new_cr;
    Some(format!(
        "the chains climbed above the maximum the MAP search found: a search from their best sample found one {} nats higher, which the MAP column, the Cramér–Rao σ and ρ_opt report; the chains' proposal and relative binning were set up around the lower one — to sample around the higher one, rerun with [fit] start = {{ {} }}",
        crate::report::fmt_fixed(below, 2),
        start.join(", ")
    ))
}

/// `[analysis] glitch_count = "rj"`: the reversible jump over the modelled candidates
/// ([`crate::jobs::glitch_count`]); `None` when not asked for or there is no candidate.
fn count_glitches(
    study: &Study,
    prep: &Prepared,
    free: &[usize],
    map: &[f64],
    fisher: &DMatrix<f64>,
    truth: Option<&[Option<f64>]>,
) -> Result<Option<crate::jobs::glitch_count::GlitchCount>, String> {
    if study.analysis.glitch_count.is_all() || prep.glitch_candidates.is_empty() {
        return Ok(None);
    }
    crate::jobs::glitch_count::glitch_count(
        study,
        &prep.likelihood,
        &prep.glitch_candidates,
        free,
        map,
        fisher,
        truth,
    )
    .map(Some)
}

/// The error of a singular Fisher matrix at `at` ("MAP"): which parameters the data do not
/// constrain (its null directions) and what to change ([`fix_hint`]; `value_of` gives the
/// value to suggest for a parameter).
pub fn singular_message(
    fisher: &DMatrix<f64>,
    free_names: &[String],
    at: &str,
    value_of: &dyn Fn(&str) -> Option<f64>,
) -> String {
    let (detail, named) = crate::likelihood::describe_unconstrained(fisher, free_names);
    format!(
        "the Fisher matrix at the {at} is singular: {detail}. {}",
        fix_hint(free_names, &named, value_of)
    )
}

/// What to change in the study when the parameters `named` (of the free ones, `free_names`)
/// are unconstrained: the `[fit]` lines that fix them at the values `value_of` suggests, or
/// an experiment that excites them.
pub fn fix_hint(
    free_names: &[String],
    named: &[String],
    value_of: &dyn Fn(&str) -> Option<f64>,
) -> String {
    let them = if named.len() == 1 { "it" } else { "them" };
    let keep: Vec<String> = free_names
        .iter()
        .filter(|n| !named.contains(n))
        .map(|n| format!("\"{n}\""))
        .collect();
    if keep.is_empty() || named.is_empty() {
        return format!(
            "Add an experiment that excites {them}, or fix some of them in [fit] fixed"
        );
    }
    let fixed = named
        .iter()
        .map(|n| match value_of(n) {
            Some(v) => format!("{n} = {}", crate::report::fmt_roundtrip(v)),
            None => format!("{n} = <value>"),
        })
        .collect::<Vec<_>>()
        .join(", ");
    format!(
        "Fix {them}, e.g. [fit] free = [{}] and fixed = {{ {fixed} }} (values of the search; use known values where you have them), or add an experiment that excites {them}",
        keep.join(", ")
    )
}

/// A warning when the Fisher matrix has directions below
/// [`crate::linalg::NULL_EIGENVALUE_TOL`] although its Cholesky factorisation succeeded:
/// the Cramér–Rao σ and the proposal along them are set by rounding, not by the data.
pub fn near_singular_warning(fisher: &DMatrix<f64>, free_names: &[String]) -> Option<String> {
    let dirs = crate::linalg::unconstrained_directions(fisher, crate::linalg::NULL_EIGENVALUE_TOL);
    if dirs.is_empty() {
        return None;
    }
    let (detail, _) = crate::likelihood::describe_unconstrained(fisher, free_names);
    Some(format!(
        "the Fisher matrix at the MAP is nearly singular: {detail}; their Cramér–Rao σ and the proposal along that direction come from rounding, not from the data: fix one of them ([fit] fixed) or add an experiment that separates them"
    ))
}

/// Where a fit checkpoints and whether it continues from there.
struct Checkpoint<'a> {
    out: &'a Path,
    resume: bool,
    /// The run's identity in the checkpoint (study, data and likelihood kind).
    identity: &'a str,
}

/// What the chains report to (the progress observer) and ask whether to stop.
type Hooks<'a> = (
    Option<&'a (dyn Fn(&Progress) + Sync)>,
    Option<&'a dyn Fn(usize) -> bool>,
);

fn sample<D: LogDensity>(
    parent: &D,
    model: &crate::config::ModelSpec,
    (map, walk, cov, independence, log): (&[f64], &DMatrix<f64>, &DMatrix<f64>, f64, &[usize]),
    (settings, until): (MhSettings, Option<crate::sampler::Until>),
    ck: &Checkpoint,
    (observer, stop): Hooks,
) -> Result<(Chains, Option<usize>), FitError> {
    let (out, resume) = (ck.out, ck.resume);
    let mut base = model.base.clone();
    for &i in &model.free {
        base[i] = map[i];
    }
    let sub = SubModel::new(parent, model.free.clone(), base)?;
    std::fs::create_dir_all(out).map_err(|e| FitError::Other(format!("{}: {e}", out.display())))?;
    let ckpt = out.join(CHECKPOINT_FILE);
    let (n_chains, seed) = (settings.n_chains, settings.seed);
    let mut mh = MetropolisHastings::new(&sub, cov, settings)?
        .checkpoint(&ckpt)
        .checkpoint_identity(ck.identity);
    let centre: Vec<f64> = model.free.iter().map(|&i| map[i]).collect();
    if independence > 0.0 {
        let laplace = StudentProposal::new(centre.clone(), walk, DEFAULT_DOF)?.log_axes(log)?;
        mh = mh.independence(Independence::new(independence, laplace)?)?;
    }
    if let Some(o) = observer {
        mh = mh.observer(o);
    }
    if let Some(s) = stop {
        mh = mh.stop_when(s);
    }
    if let Some(u) = until {
        mh = mh.until(u);
    }
    let outcome = if resume && ckpt.exists() {
        mh.resume(&ckpt)?
    } else {
        // select's starts: N(MAP, capped F⁻¹) truncated to the prior, prior draws where that
        // Gaussian misses the box (a MAP on a corner)
        let starts = chain_starts(&sub, &centre, walk, n_chains, seed).map_err(FitError::Other)?;
        mh.run(&Start::PerChain(starts))?
    };
    match outcome {
        RunOutcome::Finished(c) => Ok((c, None)),
        RunOutcome::Converged { chains, iterations } => Ok((chains, Some(iterations))),
        RunOutcome::Stopped { iterations } => Err(FitError::Other(format!(
            "stopped after {iterations} iterations; run again with --resume"
        ))),
    }
}

/// The sandwich errors at the MAP ([`ParamRow::sandwich`]) and why they differ from the
/// Fisher errors, when they do ([`crate::likelihood::score_covariance_differs`]: a window that
/// correlates the bins, or a Welch noise estimate under the Whittle statistic — Table I's
/// study as shipped, whose Fisher pulls scatter with RMS 1.11 ± 0.02 over 200 realisations,
/// `tests/table1.rs`); `None` otherwise, or when `fisher` is singular.
fn sandwich_of(
    exact: &Likelihood,
    theta: &[f64],
    free: &[usize],
    fisher: &nalgebra::DMatrix<f64>,
) -> Option<(Vec<f64>, String)> {
    let why = crate::likelihood::score_covariance_differs(exact)?;
    let j = crate::likelihood::score_covariance(exact, theta, free);
    crate::likelihood::sandwich_errors(fisher, &j).map(|s| (s, why))
}

/// How far the Fisher errors fall short of the sandwich ones: a note up to
/// [`SHORTFALL_WARNING`] (the default Welch estimate's 16 averages, ν = 29, make every fit's
/// 8 %: routine, and the table's `sandwich σ` column is there), a warning beyond.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum Shortfall {
    Note(String),
    Warning(String),
}

/// The sandwich errors exceeding the Fisher errors or the chains' sd by more than this is a
/// warning; from 5 % to this, a note.
pub(super) const SHORTFALL_WARNING: f64 = 0.10;

/// One line when the sandwich errors exceed the Fisher errors or the chains' sd by more than
/// 5 % somewhere: which parameter, by how much, and what to quote ([`Shortfall`]).
pub(super) fn sandwich_warning(
    sandwich: &[f64],
    cr: &[f64],
    sd: &[f64],
    names: &[String],
    free: &[usize],
    why: &str,
) -> Option<Shortfall> {
    let (k, ratio) = sandwich
        .iter()
        .zip(cr.iter().zip(sd))
        .map(|(s, (c, d))| s / c.max(*d))
        .enumerate()
        .max_by(|a, b| a.1.total_cmp(&b.1))?;
    if ratio.is_infinite() {
        // ν ≤ 4 in some bin (`score_covariance`): the estimate's variance has no finite value
        return Some(Shortfall::Warning(format!(
            "the noise PSD is a Welch estimate of 4 or fewer degrees of freedom in some bins: the estimate's variance is not finite there, so no error bar of `{}` (nor the chains' sd) can be stood behind; raise [analysis] welch_averages or the noise-only stretch",
            names[free[k]]
        )));
    }
    (ratio > 1.05).then(|| {
        let text = format!(
            "the Fisher errors and the chains' sd treat the bins as independent and the noise PSD as exact, but {why}: they are short by up to {:.0} % (`{}`); quote the sandwich errors (the `sandwich σ` column, `sandwich` in summary.json), which account for it",
            100.0 * (ratio - 1.0),
            names[free[k]]
        );
        if ratio > 1.0 + SHORTFALL_WARNING {
            Shortfall::Warning(text)
        } else {
            Shortfall::Note(text)
        }
    })
}
