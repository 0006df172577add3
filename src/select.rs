//! `occam select`: Bayes factors between nested LTP models with every estimator side by side
//! (reversible jump, Laplace–Fisher raw and box-corrected, Laplace–Metropolis with MVE and
//! MCD, Schwarz), the paper's Table II layout, the evolution of B (Fig. 2) and the model-visit
//! histogram (Fig. 4).

use crate::analysis::{
    Prepared, default_start, likelihood_of, model_warnings, relbin_of, truth_of,
};
use crate::config::{LikelihoodKind, ModelSpec, Study};
use crate::density::LogDensity;
use crate::evidence::{
    LaplaceEstimate, LaplaceOptions, LnB, McdOptions, MveOptions, ProposalShape, RjModel,
    RjOptions, RjResult, RobustMethod, laplace_fisher, laplace_metropolis, run_rjmcmc,
};
use crate::likelihood::{
    Likelihood, RelBinLikelihood, fisher_exact, fisher_scoring, fisher_scoring_unbounded,
};
use crate::nested::SubModel;
use crate::report::{Table, kass_raftery};
use crate::sampler::{MetropolisHastings, MhSettings, RunOutcome, Start};
use nalgebra::DMatrix;
use serde::Serialize;
use std::borrow::Cow;
use std::path::Path;
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

/// A `ln Z` estimate, or why the estimator does not apply.
#[derive(Debug, Clone, Serialize)]
pub struct Evidence {
    pub ln_z: Option<f64>,
    pub std_err: Option<f64>,
    /// Why there is no number (the estimator's own error), or a caveat.
    pub note: Option<String>,
}

impl Evidence {
    fn from(r: Result<LaplaceEstimate, String>) -> Self {
        match r {
            Ok(e) => Self {
                ln_z: Some(e.ln_z),
                std_err: e.std_err,
                note: None,
            },
            Err(m) => Self {
                ln_z: None,
                std_err: None,
                note: Some(m),
            },
        }
    }
}

/// Per-model results.
#[derive(Debug, Clone, Serialize)]
pub struct ModelOutcome {
    pub name: String,
    /// The model this is a sub-model of.
    pub model: String,
    /// That model's parameters (the order of `map` and `unbounded_max`).
    pub params: Vec<String>,
    pub free: Vec<String>,
    pub prior_probability: f64,
    /// MAP (full parameter vector of the model), inside the prior box.
    pub map: Vec<f64>,
    pub ln_l_map: f64,
    /// Unconstrained maximum of `ln L` (the box-corrected Laplace expansion point).
    pub unbounded_max: Vec<f64>,
    /// Smallest distance of the MAP from a prior bound, in Fisher σ.
    pub min_margin_sigma: f64,
    pub laplace_fisher_raw: Evidence,
    pub laplace_fisher_box: Evidence,
    pub laplace_metropolis_mve: Evidence,
    pub laplace_metropolis_mcd: Evidence,
    pub schwarz_ln_z: f64,
    /// In-model MCMC (for Laplace–Metropolis): acceptance per chain and worst R-hat.
    pub mcmc_acceptance: Vec<f64>,
    pub mcmc_max_rhat: f64,
}

/// One estimator's `ln B_XY` for a pair.
#[derive(Debug, Clone, Serialize)]
pub struct PairEstimate {
    pub method: String,
    pub ln_b: Option<f64>,
    pub std_err: Option<f64>,
    /// Agreement with the reference estimate (see [`PairResult::reference`]).
    pub agrees: Option<bool>,
    pub note: Option<String>,
}

/// `ln B_XY` of one pair by every estimator.
#[derive(Debug, Clone, Serialize)]
pub struct PairResult {
    pub x: String,
    pub y: String,
    pub estimates: Vec<PairEstimate>,
    /// The estimator the others are compared with: the RJ bridge when it has a number, else
    /// the box-corrected Laplace–Fisher.
    pub reference: String,
    pub preferred: String,
    pub kass_raftery: String,
    /// Whether every estimate with a number agrees with the reference: within 2 combined
    /// standard errors when both have one, else within 1 nat (the "not worth more than a bare
    /// mention" band of Kass & Raftery, 2|ln B| < 2).
    pub all_agree: bool,
}

/// Everything `occam select` reports.
#[derive(Debug, Clone, Serialize)]
pub struct SelectSummary {
    pub origin: String,
    /// ρ_opt of the injections under the simulation's exact noise model (when simulated).
    pub rho_opt_simulated: Option<f64>,
    /// ρ_opt = √⟨h|h⟩ at the truth (or the first model's MAP) under the analysis's noise
    /// estimate (Welch by default), which differs from the model noise at low frequencies.
    pub rho_opt: f64,
    pub n_bins: usize,
    pub schwarz_n: f64,
    pub models: Vec<ModelOutcome>,
    pub pairs: Vec<PairResult>,
    pub rj: RjResult,
    pub rj_iterations_per_second: f64,
    pub seconds: f64,
    /// Warnings about the models and the data.
    pub warnings: Vec<String>,
}

struct Prepped {
    spec: ModelSpec,
    /// The sampled likelihood: relative-binned around this model's MAP, or exact.
    sampled: Sampled,
    map: Vec<f64>,
    fisher: DMatrix<f64>,
}

enum Sampled {
    RelBin(RelBinLikelihood),
    Exact(usize),
}

fn free_vec(th: &[f64], free: &[usize]) -> Vec<f64> {
    free.iter().map(|&i| th[i]).collect()
}

/// Runs every estimator on the study's `[[select.model]]` list. Each competing model is a
/// sub-model of one of the study's models; each of those gets its own exact likelihood on the
/// data (the `[fit]` model's is `prep.likelihood`).
pub fn run(
    study: &Study,
    prep: &Prepared,
    progress: Option<&mut dyn FnMut(&crate::evidence::RjProgress<'_>)>,
) -> Result<SelectSummary, SelectError> {
    let t0 = Instant::now();
    let sel = &study.select;
    if study.select_models.len() < 2 {
        return Err(SelectError::Config(format!(
            "{}: `select.model`: model selection needs at least two [[select.model]] tables",
            study.source
        )));
    }
    // one exact likelihood per parent model in use
    let mut parents: Vec<usize> = study.select_models.iter().map(|m| m.spec.model).collect();
    parents.sort_unstable();
    parents.dedup();
    let mut exacts: Vec<(usize, Cow<Likelihood>)> = Vec::new();
    for &mi in &parents {
        let lik = if mi == study.fit_model.model {
            Cow::Borrowed(&prep.likelihood)
        } else {
            Cow::Owned(
                likelihood_of(study, mi, &prep.dataset).map_err(|e| SelectError::Model {
                    model: study.models.defs[mi].name().to_string(),
                    msg: e.to_string(),
                })?,
            )
        };
        exacts.push((mi, lik));
    }
    let exact_of =
        |mi: usize| -> &Likelihood { &exacts.iter().find(|(i, _)| *i == mi).expect("built").1 };
    let first = exact_of(study.select_models[0].spec.model);
    let seed = sel.seed.unwrap_or(study.seed.wrapping_add(2));
    let n_sbic = sel.schwarz_n.unwrap_or(first.n_real_data() as f64);
    let mut models = Vec::new();
    let mut prepped = Vec::new();
    for (k, m) in study.select_models.iter().enumerate() {
        let err = |msg: String| SelectError::Model {
            model: m.name.clone(),
            msg,
        };
        let (outcome, pp) = one_model(
            study,
            exact_of(m.spec.model),
            m,
            seed.wrapping_add(k as u64),
            n_sbic,
        )
        .map_err(err)?;
        models.push(outcome);
        prepped.push(pp);
    }
    // reversible jump over all models, each on its own sampled likelihood
    let targets: Vec<&dyn LogDensity> = prepped
        .iter()
        .map(|p| match &p.sampled {
            Sampled::RelBin(rb) => rb as &dyn LogDensity,
            Sampled::Exact(mi) => exact_of(*mi) as &dyn LogDensity,
        })
        .collect();
    let subs: Vec<SubModel<&dyn LogDensity>> = prepped
        .iter()
        .zip(&targets)
        .map(|(p, t)| SubModel::new(*t, p.spec.free.clone(), p.map.clone()))
        .collect::<Result<_, _>>()
        .map_err(|e| SelectError::Config(e.to_string()))?;
    let rj_models: Vec<RjModel<'_>> = prepped
        .iter()
        .zip(&subs)
        .zip(&study.select_models)
        .map(|((p, s), m)| RjModel {
            name: m.name.clone(),
            target: s as &dyn LogDensity,
            center: free_vec(&p.map, &p.spec.free),
            cov: p.fisher.clone().cholesky().expect("checked").inverse(),
        })
        .collect();
    let opts = RjOptions {
        n_iter: sel.rj_iterations,
        burn_in: sel.rj_burn_in,
        seed,
        prior_model_probs: Some(
            study
                .select_models
                .iter()
                .map(|m| m.prior_probability)
                .collect(),
        ),
        proposal: if sel.student_t > 0.0 {
            ProposalShape::StudentT { nu: sel.student_t }
        } else {
            ProposalShape::Gaussian
        },
        jump_scale: sel.jump_scale,
        ..Default::default()
    };
    let t_rj = Instant::now();
    let rj = run_rjmcmc(&rj_models, &opts, progress)
        .map_err(|e| SelectError::Config(format!("reversible jump: {e}")))?;
    let rj_rate = sel.rj_iterations as f64 / t_rj.elapsed().as_secs_f64();
    let mut pairs = Vec::new();
    for x in 0..models.len() {
        for y in x + 1..models.len() {
            pairs.push(pair(&models, &rj, x, y));
        }
    }
    // ρ_opt at the truth where the first model has every true value, else at its MAP
    let m0 = study.select_models[0].spec.model;
    let truth_snr = truth_of(study, m0, &prep.dataset)
        .and_then(|t| t.into_iter().collect::<Option<Vec<f64>>>())
        .map(|t| first.snr(&t));
    Ok(SelectSummary {
        origin: prep.origin.clone(),
        rho_opt_simulated: prep.dataset.extra.get("snr_total").and_then(|v| v.as_f64()),
        rho_opt: truth_snr.unwrap_or_else(|| first.snr(&models[0].map)),
        n_bins: first.n_bins(),
        schwarz_n: n_sbic,
        models,
        pairs,
        rj,
        rj_iterations_per_second: rj_rate,
        seconds: t0.elapsed().as_secs_f64(),
        warnings: parents
            .iter()
            .flat_map(|&mi| model_warnings(study, mi, &prep.dataset))
            .collect(),
    })
}

fn one_model(
    study: &Study,
    exact: &Likelihood,
    m: &crate::config::SelectModel,
    seed: u64,
    n_sbic: f64,
) -> Result<(ModelOutcome, Prepped), String> {
    let spec = &m.spec;
    let free = &spec.free;
    let names = exact.model().param_names().to_vec();
    let start = default_start(study, spec);
    let map = fisher_scoring(exact, &start, free, 1e-3, 200).map_err(|e| e.to_string())?;
    let unb =
        fisher_scoring_unbounded(exact, &map.theta, free, 1e-3, 200).map_err(|e| e.to_string())?;
    let f_map = fisher_exact(exact, &map.theta, free);
    let f_unb = fisher_exact(exact, &unb.theta, free);
    let cov = f_map.clone().cholesky().ok_or_else(|| {
        format!(
            "the Fisher matrix at the MAP is singular: the data do not constrain some of {:?}",
            free.iter().map(|&i| names[i].as_str()).collect::<Vec<_>>()
        )
    })?;
    let cov = cov.inverse();
    let sub_exact =
        SubModel::new(exact, free.clone(), map.theta.clone()).map_err(|e| e.to_string())?;
    let raw_opts = LaplaceOptions {
        box_correction: false,
        ..Default::default()
    };
    let lf_raw = laplace_fisher(&sub_exact, &free_vec(&map.theta, free), &f_map, &raw_opts);
    let min_margin_sigma = match &lf_raw {
        Ok(e) => e.min_margin_sigma,
        Err(_) => 0.0,
    };
    let lf_box = laplace_fisher(
        &sub_exact,
        &free_vec(&unb.theta, free),
        &f_unb,
        &LaplaceOptions::default(),
    );
    // in-model chains on the sampled likelihood around this model's MAP
    let sampled = match study.analysis.likelihood {
        LikelihoodKind::Relbin => {
            Sampled::RelBin(relbin_of(study, exact, &map.theta).map_err(|e| e.to_string())?)
        }
        LikelihoodKind::Exact => Sampled::Exact(spec.model),
    };
    let target: &dyn LogDensity = match &sampled {
        Sampled::RelBin(rb) => rb,
        Sampled::Exact(_) => exact,
    };
    let sub_s =
        SubModel::new(target, free.clone(), map.theta.clone()).map_err(|e| e.to_string())?;
    let d = free.len();
    let prop = &cov * (2.38f64.powi(2) / d as f64);
    let sel = &study.select;
    let settings = MhSettings {
        n_iter: sel.iterations,
        burn_in: sel.burn_in,
        thin: 1,
        n_chains: sel.chains,
        seed,
        anneal: None,
        adapt: Some(crate::sampler::Adapt {
            start: sel.burn_in / 5,
            ..Default::default()
        }),
        checkpoint_every: sel.iterations,
        progress_every: sel.iterations,
    };
    let mh = MetropolisHastings::new(&sub_s, &prop, settings).map_err(|e| e.to_string())?;
    let chains = match mh
        .run(&Start::Around {
            centre: free_vec(&map.theta, free),
            spread: 1.0,
        })
        .map_err(|e| e.to_string())?
    {
        RunOutcome::Finished(c) => c,
        RunOutcome::Stopped { .. } => return Err("in-model chains stopped early".into()),
    };
    let diag = chains.diagnostics().map_err(|e| e.to_string())?;
    let best = chains.max_posterior();
    let n = chains.n_kept() * chains.chains().len();
    let mut samples = DMatrix::<f64>::zeros(n, d);
    let mut r = 0;
    for c in chains.chains() {
        for s in c.samples.chunks(d) {
            for j in 0..d {
                samples[(r, j)] = s[j];
            }
            r += 1;
        }
    }
    // Laplace–Metropolis evaluates ln L at the best sample with the exact likelihood
    let lm = |method: RobustMethod| {
        laplace_metropolis(&sub_exact, best.theta, &samples, &method).map_err(|e| e.to_string())
    };
    let lm_mve = lm(RobustMethod::Mve(MveOptions::default()));
    let lm_mcd = lm(RobustMethod::Mcd(McdOptions::default()));
    let ln_l_map = exact.ln_likelihood_full(&map.theta);
    let outcome = ModelOutcome {
        name: m.name.clone(),
        model: exact.model().name().to_string(),
        params: names.clone(),
        free: free.iter().map(|&i| names[i].clone()).collect(),
        prior_probability: m.prior_probability,
        map: map.theta.clone(),
        ln_l_map,
        unbounded_max: unb.theta,
        min_margin_sigma,
        laplace_fisher_raw: Evidence::from(lf_raw.map_err(|e| e.to_string())),
        laplace_fisher_box: Evidence::from(lf_box.map_err(|e| e.to_string())),
        laplace_metropolis_mve: Evidence::from(lm_mve),
        laplace_metropolis_mcd: Evidence::from(lm_mcd),
        schwarz_ln_z: crate::evidence::schwarz_ln_z(ln_l_map, d, n_sbic)
            .map_err(|e| e.to_string())?,
        mcmc_acceptance: diag.acceptance.clone(),
        mcmc_max_rhat: diag.rhat.iter().cloned().fold(0.0, f64::max),
    };
    Ok((
        outcome,
        Prepped {
            spec: spec.clone(),
            sampled,
            map: map.theta,
            fisher: f_map,
        },
    ))
}

fn diff(a: &Evidence, b: &Evidence) -> (Option<f64>, Option<f64>, Option<String>) {
    match (a.ln_z, b.ln_z) {
        (Some(x), Some(y)) => {
            let err = match (a.std_err, b.std_err) {
                (None, None) => None,
                (p, q) => Some(p.unwrap_or(0.0).hypot(q.unwrap_or(0.0))),
            };
            (Some(x - y), err, None)
        }
        _ => (
            None,
            None,
            Some(
                a.note
                    .clone()
                    .or_else(|| b.note.clone())
                    .unwrap_or_default(),
            ),
        ),
    }
}

fn pair(models: &[ModelOutcome], rj: &RjResult, x: usize, y: usize) -> PairResult {
    let (mx, my) = (&models[x], &models[y]);
    let mut est = Vec::new();
    let rjp = rj.pair(x, y);
    let from_lnb = |name: &str, b: Option<LnB>, why: &str| PairEstimate {
        method: name.into(),
        ln_b: b.map(|b| b.ln_b),
        std_err: b.and_then(|b| b.std_err),
        agrees: None,
        note: b.is_none().then(|| why.to_string()),
    };
    est.push(from_lnb(
        "RJMCMC visits",
        rjp.as_ref().and_then(|p| p.visits),
        "a model was never visited: the visit ratio is undefined (see Rao-Blackwell / bridge)",
    ));
    let mut rb = from_lnb(
        "RJMCMC Rao-Blackwell",
        rjp.as_ref().and_then(|p| p.rao_blackwell),
        "no jump proposals in either direction",
    );
    if rb.ln_b.is_some() && rjp.as_ref().is_some_and(|p| p.visits.is_none()) {
        rb.note = Some(
            "one-sided: the unvisited model's mean acceptance set to its bound 1 (exact when jumps out of it are always accepted)"
                .into(),
        );
    }
    est.push(rb);
    est.push(from_lnb(
        "RJMCMC bridge",
        rjp.as_ref().and_then(|p| p.bridge),
        "no in-box proposals between the two models",
    ));
    for (name, a, b) in [
        (
            "Laplace-Fisher raw",
            &mx.laplace_fisher_raw,
            &my.laplace_fisher_raw,
        ),
        (
            "Laplace-Fisher box",
            &mx.laplace_fisher_box,
            &my.laplace_fisher_box,
        ),
        (
            "Laplace-Metropolis MVE",
            &mx.laplace_metropolis_mve,
            &my.laplace_metropolis_mve,
        ),
        (
            "Laplace-Metropolis MCD",
            &mx.laplace_metropolis_mcd,
            &my.laplace_metropolis_mcd,
        ),
    ] {
        let (ln_b, std_err, note) = diff(a, b);
        est.push(PairEstimate {
            method: name.into(),
            ln_b,
            std_err,
            agrees: None,
            note,
        });
    }
    est.push(PairEstimate {
        method: "Schwarz (SBIC)".into(),
        ln_b: Some(mx.schwarz_ln_z - my.schwarz_ln_z),
        std_err: None,
        agrees: None,
        note: None,
    });
    let ref_idx = if est[2].ln_b.is_some() { 2 } else { 4 };
    let reference = est[ref_idx].method.clone();
    let (rv, re) = (est[ref_idx].ln_b, est[ref_idx].std_err);
    let mut all_agree = true;
    for e in est.iter_mut() {
        if let (Some(v), Some(r)) = (e.ln_b, rv) {
            let ok = match (e.std_err, re) {
                (Some(a), Some(b)) => (v - r).abs() <= 2.0 * a.hypot(b),
                _ => (v - r).abs() <= 1.0,
            };
            e.agrees = Some(ok);
            all_agree &= ok;
        }
    }
    let lb = rv.unwrap_or(0.0);
    let preferred = if lb >= 0.0 {
        mx.name.clone()
    } else {
        my.name.clone()
    };
    PairResult {
        x: mx.name.clone(),
        y: my.name.clone(),
        estimates: est,
        reference,
        preferred,
        kass_raftery: kass_raftery(lb).to_string(),
        all_agree,
    }
}

/// The Table II layout: one row per estimator, for each pair.
pub fn table(s: &SelectSummary) -> Table {
    let mut t = Table::new([
        "pair",
        "estimator",
        "B_XY",
        "ln B_XY",
        "± σ",
        "agrees",
        "note",
    ]);
    for p in &s.pairs {
        for e in &p.estimates {
            let b = e.ln_b.map_or("–".into(), |v| format!("{:.4e}", v.exp()));
            let lb = e.ln_b.map_or("–".into(), |v| format!("{v:.3}"));
            let se = e.std_err.map_or("–".into(), |v| format!("{v:.3}"));
            let ag = e
                .agrees
                .map_or("–".into(), |a| if a { "yes" } else { "no" }.to_string());
            let note = e.note.clone().unwrap_or_default();
            let note = if note.chars().count() > 60 {
                format!("{}…", note.chars().take(60).collect::<String>())
            } else {
                note
            };
            t.push_row([
                format!("{}/{}", p.x, p.y),
                e.method.clone(),
                b,
                lb,
                se,
                ag,
                note,
            ])
            .expect("row width matches the header");
        }
    }
    t
}

/// Writes `summary.json`, `table.txt`, `table.md`, the evolution of B (`bayes_factor`) and the
/// model-visit histogram (`model_visits`), each atomically.
pub fn write_outputs(s: &SelectSummary, out: &Path) -> Result<(), SelectError> {
    let io = |p: &Path, e: std::io::Error| SelectError::Io(format!("{}: {e}", p.display()));
    std::fs::create_dir_all(out).map_err(|e| io(out, e))?;
    let json = serde_json::to_string_pretty(s).expect("summary serialises") + "\n";
    let p = out.join("summary.json");
    crate::atomic::write_bytes(&p, json.as_bytes()).map_err(|e| io(&p, e))?;
    let t = table(s);
    let p = out.join("table.txt");
    crate::atomic::write_bytes(&p, t.to_text().as_bytes()).map_err(|e| io(&p, e))?;
    let p = out.join("table.md");
    crate::atomic::write_bytes(&p, t.to_markdown().as_bytes()).map_err(|e| io(&p, e))?;
    let series: Vec<(String, Vec<(f64, f64)>)> = s
        .pairs
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let (x, y) = pair_indices(s.models.len(), i);
            let pts =
                s.rj.ln_b_trace(x, y)
                    .into_iter()
                    .map(|(it, v)| (it as f64, v.map_or(f64::NAN, f64::exp)))
                    .collect();
            (format!("B {}/{}", p.x, p.y), pts)
        })
        .collect();
    if series
        .iter()
        .any(|(_, v)| v.iter().any(|p| p.1.is_finite()))
    {
        crate::report::bayes_factor_evolution(
            out,
            "bayes_factor",
            &series,
            true,
            "B_XY (visit ratio)",
        )?;
    }
    let labels: Vec<String> = s.models.iter().map(|m| m.name.clone()).collect();
    let counts: Vec<f64> = s.rj.visits.iter().map(|&v| v as f64).collect();
    crate::report::model_histogram(out, "model_visits", &labels, &counts)?;
    Ok(())
}

fn pair_indices(k: usize, idx: usize) -> (usize, usize) {
    let mut n = 0;
    for x in 0..k {
        for y in x + 1..k {
            if n == idx {
                return (x, y);
            }
            n += 1;
        }
    }
    (0, 1)
}
