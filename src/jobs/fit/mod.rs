//! `occam fit`: MAP, Fisher matrix and Metropolis–Hastings parameter estimation of one model,
//! with the paper's Table I layout, chains on disk, plots and a JSON summary.

mod job;
pub use job::{Fit, Fitted};

/// The fit's checkpoint inside its run directory ([`crate::data::checkpoint`], kind `mh`).
pub const CHECKPOINT_FILE: &str = "checkpoint.cbor";

use crate::config::{LikelihoodKind, Study};
use crate::density::LogDensity;
use crate::jobs::prepare::{Prepared, default_start, model_warnings, relbin_of, truth_of};
use crate::likelihood::{cramer_rao, fisher_exact, fisher_scoring};
use crate::linalg::SpdOptions;
use crate::nested::SubModel;
use crate::report::{Table, fmt_fixed, fmt_pm, fmt_short, fmt_sig};
use crate::sampler::{Adapt, Chains, MetropolisHastings, MhSettings, Progress, RunOutcome, Start};
use nalgebra::DMatrix;
use serde::Serialize;
use std::path::Path;
use std::time::Instant;

/// Errors of a fit.
#[derive(Debug, thiserror::Error)]
pub enum FitError {
    #[error(transparent)]
    Map(#[from] crate::likelihood::MapError),
    #[error(transparent)]
    Sampler(#[from] crate::sampler::SamplerError),
    #[error(transparent)]
    Analysis(#[from] crate::jobs::prepare::AnalysisError),
    #[error(transparent)]
    Nested(#[from] crate::nested::NestedError),
    #[error(transparent)]
    Report(#[from] crate::report::ReportError),
    #[error("{0}")]
    Other(String),
}

/// One row of the Table I layout.
#[derive(Debug, Clone, Serialize)]
pub struct ParamRow {
    pub name: String,
    /// SI unit of the parameter (`"s⁻²"`, `"s"`, `"Hz"`); empty when dimensionless or unknown.
    pub unit: String,
    pub truth: Option<f64>,
    pub map: f64,
    pub mean: f64,
    pub sd: f64,
    pub cramer_rao: f64,
    pub rhat: f64,
    pub ess: f64,
    /// (mean − truth)/sd when the truth is known.
    pub pull: Option<f64>,
}

/// Everything `occam fit` reports.
#[derive(Debug, Clone, Serialize)]
pub struct FitSummary {
    pub origin: String,
    /// The fitted model.
    pub model: String,
    /// The statistic of every `ln L` reported and sampled (`[analysis] statistic`).
    pub statistic: crate::likelihood::Statistic,
    /// The likelihood the chains ran on (relative binning is replaced by the exact `ln L`
    /// when the statistic is not `whittle`).
    pub likelihood: LikelihoodKind,
    pub n_bins: usize,
    pub n_coarse_bins: Option<usize>,
    pub rho_opt_at_map: f64,
    pub map_ln_posterior: f64,
    pub map_iterations: usize,
    pub rows: Vec<ParamRow>,
    pub acceptance: Vec<f64>,
    pub non_finite: Vec<u64>,
    pub warnings: Vec<String>,
    pub chains: usize,
    pub kept_per_chain: usize,
    /// Iterations per chain before the first kept draw (`[fit] burn_in`); they are not stored.
    pub burn_in: usize,
    /// One draw kept every `thin` iterations after the burn-in: kept draw `k` (from 0) is
    /// iteration `burn_in + (k + 1)·thin`.
    pub thin: usize,
    pub seconds_map: f64,
    pub seconds_mcmc: f64,
    pub iterations_per_second: f64,
    /// Fisher matrix at the MAP over the free parameters.
    pub fisher: Vec<Vec<f64>>,
}

/// The outcome of [`run`].
pub struct FitOutcome {
    pub summary: FitSummary,
    pub chains: Chains,
    /// Free-parameter MAP and Fisher matrix (for reuse by evidence estimators).
    pub map_full: Vec<f64>,
    pub fisher: DMatrix<f64>,
}

/// Runs the fit of `study`'s `[fit]` model on prepared data; writes a checkpoint into `out`
/// while it runs (and resumes from it if `resume`).
pub fn run(
    study: &Study,
    prep: &Prepared,
    out: &Path,
    observer: Option<&(dyn Fn(&Progress) + Sync)>,
    resume: bool,
) -> Result<FitOutcome, FitError> {
    let exact = &prep.likelihood;
    let model = &study.fit_model;
    let free = &model.free;
    let names = exact.model().param_names().to_vec();
    let t0 = Instant::now();
    let start = default_start(study, model);
    let free_names: Vec<String> = free.iter().map(|&i| names[i].clone()).collect();
    let value_of = |n: &str| names.iter().position(|p| p == n).map(|i| start[i]);
    let map = fisher_scoring(exact, &start, free, 1e-3, 200).map_err(|e| match e {
        crate::likelihood::MapError::Singular {
            unconstrained,
            detail,
        } => FitError::Other(format!(
            "MAP search: the Fisher matrix is singular: {detail}. {}",
            fix_hint(&free_names, &unconstrained, &value_of)
        )),
        e => FitError::Map(e),
    })?;
    let mut warnings = model_warnings(study, model.model, &prep.dataset);
    if !map.converged {
        warnings.push(format!(
            "the MAP search stopped after {} iterations without converging; the chains may start far from the mode",
            map.iterations
        ));
    }
    let at_bound = map.bound_report(&names, exact.prior().kinds(), free);
    if !at_bound.is_empty() {
        warnings.push(format!(
            "the MAP is on a bound of the prior box: {}. The posterior is cut by the prior there, and the Cramér–Rao σ and the pulls assume an interior maximum",
            at_bound.join("; ")
        ));
    }
    let fisher = fisher_exact(exact, &map.theta, free);
    let value_of = |n: &str| names.iter().position(|p| p == n).map(|i| map.theta[i]);
    let cr = cramer_rao(&fisher)
        .ok_or_else(|| FitError::Other(singular_message(&fisher, &free_names, "MAP", &value_of)))?;
    if let Some(w) = near_singular_warning(&fisher, &free_names) {
        warnings.push(w);
    }
    let seconds_map = t0.elapsed().as_secs_f64();
    let d = free.len();
    let cov = SpdOptions::lower()
        .factor(&fisher)
        .expect("checked above")
        .inverse()
        * (study.fit.proposal_scale * 2.38f64.powi(2) / d as f64);
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
        crate::jobs::select::identity(study, &prep.dataset)
    );
    let ckpt = Checkpoint {
        out,
        resume,
        identity: &identity,
    };
    let (chains, n_coarse) = match kind {
        LikelihoodKind::Exact => (
            sample(exact, model, &map.theta, &cov, settings, &ckpt, observer)?,
            None,
        ),
        LikelihoodKind::Relbin => {
            let rb = relbin_of(study, exact, &map.theta)?;
            let n = rb.n_coarse();
            (
                sample(&rb, model, &map.theta, &cov, settings, &ckpt, observer)?,
                Some(n),
            )
        }
    };
    let seconds_mcmc = t1.elapsed().as_secs_f64();
    let diag = chains.diagnostics()?;
    warnings.extend(diag.warnings().iter().map(|w| w.to_string()));
    let truth = truth_of(study, model.model, &prep.dataset);
    let units = exact.model().param_units();
    let rows = free
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
                rhat: diag.rhat[k],
                ess: diag.ess[k],
                pull: tr.map(|t| (diag.mean[k] - t) / diag.sd[k]),
            }
        })
        .collect();
    let total_iter = (f.iterations * f.chains) as f64;
    let mut summary = FitSummary {
        origin: prep.origin.clone(),
        model: exact.model().name().to_string(),
        statistic,
        likelihood: kind,
        n_bins: exact.n_bins(),
        n_coarse_bins: n_coarse,
        rho_opt_at_map: exact.snr(&map.theta),
        // of the statistic, at the (Whittle) MAP the chains start from
        map_ln_posterior: exact.ln_posterior(&map.theta),
        map_iterations: map.iterations,
        rows,
        acceptance: diag.acceptance.clone(),
        non_finite: diag.non_finite.clone(),
        warnings,
        chains: f.chains,
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
    Ok(FitOutcome {
        summary,
        chains,
        map_full: map.theta,
        fisher,
    })
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

fn sample<D: LogDensity>(
    parent: &D,
    model: &crate::config::ModelSpec,
    map: &[f64],
    cov: &DMatrix<f64>,
    settings: MhSettings,
    ck: &Checkpoint,
    observer: Option<&(dyn Fn(&Progress) + Sync)>,
) -> Result<Chains, FitError> {
    let (out, resume) = (ck.out, ck.resume);
    let mut base = model.base.clone();
    for &i in &model.free {
        base[i] = map[i];
    }
    let sub = SubModel::new(parent, model.free.clone(), base)?;
    std::fs::create_dir_all(out).map_err(|e| FitError::Other(format!("{}: {e}", out.display())))?;
    let ckpt = out.join(CHECKPOINT_FILE);
    let mut mh = MetropolisHastings::new(&sub, cov, settings)?
        .checkpoint(&ckpt)
        .checkpoint_identity(ck.identity);
    if let Some(o) = observer {
        mh = mh.observer(o);
    }
    let outcome = if resume && ckpt.exists() {
        mh.resume(&ckpt)?
    } else {
        mh.run(&Start::Around {
            centre: model.free.iter().map(|&i| map[i]).collect(),
            spread: 2.0,
        })?
    };
    match outcome {
        RunOutcome::Finished(c) => Ok(c),
        RunOutcome::Stopped { iterations } => Err(FitError::Other(format!(
            "stopped after {iterations} iterations; run again with --resume"
        ))),
    }
}

/// R-hat for the table: 4 decimals, `∞ (stuck)` when it is infinite (zero within-chain
/// variance: the chains did not move; `sd` 0: not even between chains), `NaN` when it could
/// not be computed.
pub fn fmt_rhat(rhat: f64, sd: f64) -> String {
    if rhat == f64::INFINITY {
        if sd == 0.0 {
            "∞ (stuck, sd 0)".into()
        } else {
            "∞ (stuck)".into()
        }
    } else {
        fmt_fixed(rhat, 4)
    }
}

/// Warnings for the numbers of `s` that are not finite, which `summary.json` writes as `null`
/// (JSON has no ∞ or NaN): each names the field and says why it can be so. R-hat is
/// explained by the chains' diagnostics, and `rho_opt_at_map` is NaN by definition for a
/// model that reads no noiseless input channel; neither is repeated here.
pub fn non_finite_warnings(s: &FitSummary) -> Vec<String> {
    let mut w = Vec::new();
    let bad = |v: f64| !v.is_finite();
    if bad(s.map_ln_posterior) {
        w.push(format!(
            "map_ln_posterior is {} (written as null in summary.json): ln L + ln π is not finite at the MAP; the likelihood overflows there (amplitudes or noise levels far out of scale?)",
            fmt_short(s.map_ln_posterior)
        ));
    }
    for r in &s.rows {
        let fields = [
            ("mean", r.mean, "the chains' draws overflow"),
            ("sd", r.sd, "the chains' draws overflow"),
            (
                "cramer_rao",
                r.cramer_rao,
                "the inverse Fisher matrix has a non-finite or negative diagonal",
            ),
            (
                "pull",
                r.pull.unwrap_or(0.0),
                "the chains' sd is 0 (the parameter did not move)",
            ),
        ];
        for (field, v, why) in fields {
            if bad(v) {
                w.push(format!(
                    "`{}`: {field} is {} (written as null in summary.json): {why}",
                    r.name,
                    fmt_short(v)
                ));
            }
        }
    }
    if s.fisher.iter().flatten().any(|v| bad(*v)) {
        w.push(
            "the Fisher matrix has non-finite entries (written as null in summary.json): ln L's derivatives overflow at the MAP".into(),
        );
    }
    w
}

/// The Table I layout as a text table.
pub fn table(s: &FitSummary) -> Table {
    let mut t = Table::new([
        "parameter",
        "truth",
        "MAP",
        "estimate ± σ",
        "Cramér-Rao σ",
        "σ/CR",
        "R-hat",
        "ESS",
    ]);
    for r in &s.rows {
        t.push_row([
            r.name.clone(),
            r.truth.map_or("–".into(), |v| fmt_sig(v, 4)),
            fmt_sig(r.map, 6),
            fmt_pm(r.mean, r.sd),
            fmt_short(r.cramer_rao),
            fmt_fixed(r.sd / r.cramer_rao, 3),
            fmt_rhat(r.rhat, r.sd),
            fmt_fixed(r.ess, 0),
        ])
        .expect("row width matches the header");
    }
    t
}

/// What a fit directory held before `manifest.json` existed: the files a new run removes when
/// it does not write them itself ([`crate::data::rundir::RunDir::publish`]).
pub const LEGACY_OUTPUTS: &[&str] = &[
    "summary.json",
    "table.txt",
    "table.md",
    "chains.npz",
    "trace.png",
    "trace.svg",
    "corner.png",
    "corner.svg",
    // `occam report` records its page in the manifest; in an older directory only this finds it
    "report.html",
];

/// Writes `summary.json`, `table.txt`, `table.md`, `chains.npz` and the trace and corner plots
/// into `out`; every file atomically.
pub fn write_outputs(o: &FitOutcome, out: &Path) -> Result<(), FitError> {
    let io = |p: &Path, e: std::io::Error| FitError::Other(format!("{}: {e}", p.display()));
    std::fs::create_dir_all(out).map_err(|e| io(out, e))?;
    let json = serde_json::to_string_pretty(&o.summary).expect("summary serialises") + "\n";
    let p = out.join("summary.json");
    crate::atomic::write_bytes(&p, json.as_bytes()).map_err(|e| io(&p, e))?;
    let t = table(&o.summary);
    let p = out.join("table.txt");
    crate::atomic::write_bytes(&p, t.to_text().as_bytes()).map_err(|e| io(&p, e))?;
    let p = out.join("table.md");
    crate::atomic::write_bytes(&p, t.to_markdown().as_bytes()).map_err(|e| io(&p, e))?;
    write_chains_npz(&o.chains, &out.join("chains.npz"))?;
    let names = o.chains.names().to_vec();
    let per_chain: Vec<Vec<Vec<f64>>> = o
        .chains
        .chains()
        .iter()
        .map(|c| c.samples.chunks(names.len()).map(|s| s.to_vec()).collect())
        .collect();
    // NaN marks a parameter whose true value is unknown; the plots leave it unmarked.
    let truth: Option<Vec<f64>> = o.summary.rows.iter().any(|r| r.truth.is_some()).then(|| {
        o.summary
            .rows
            .iter()
            .map(|r| r.truth.unwrap_or(f64::NAN))
            .collect()
    });
    // Units by name: the chains hold the free parameters, the rows say what each one is.
    let units: Vec<String> = names
        .iter()
        .map(|n| {
            o.summary
                .rows
                .iter()
                .find(|r| &r.name == n)
                .map(|r| r.unit.clone())
                .unwrap_or_default()
        })
        .collect();
    let ln_posterior: Vec<Vec<f64>> = o
        .chains
        .chains()
        .iter()
        .map(|c| c.ln_posterior.clone())
        .collect();
    crate::report::draw_trace(
        out,
        "trace",
        &crate::report::TracePlot {
            names: &names,
            units: &units,
            chains: &per_chain,
            ln_posterior: &ln_posterior,
            truth: truth.as_deref(),
            iterations: Some((o.summary.burn_in, o.summary.thin)),
        },
    )?;
    let map: Option<Vec<f64>> = names
        .iter()
        .map(|n| o.summary.rows.iter().find(|r| &r.name == n).map(|r| r.map))
        .collect();
    let pooled: Vec<Vec<f64>> = per_chain.iter().flatten().cloned().collect();
    let step = (pooled.len() / 20_000).max(1);
    let thinned: Vec<Vec<f64>> = pooled.into_iter().step_by(step).collect();
    crate::report::draw_corner(
        out,
        "corner",
        &crate::report::CornerPlot {
            names: &names,
            units: &units,
            samples: &thinned,
            truth: truth.as_deref(),
            map: map.as_deref(),
        },
    )?;
    Ok(())
}

/// Writes a run's chains as `chains.npz` (see [`chains_arrays`]), atomically.
pub fn write_chains_npz(chains: &Chains, path: &Path) -> Result<(), FitError> {
    crate::data::npz_write::write_npz_file(path, &chains_arrays(chains))
        .map_err(|e| FitError::Other(format!("{}: {e}", path.display())))
}

/// The arrays of a `chains.npz`: `samples` (chains × kept × parameters), `ln_posterior` and
/// `ln_likelihood` (chains × kept), `param_names` (parameters; the order of the last axis of
/// `samples`) and `accepted` (chains × kept: a proposal was accepted since the previous kept
/// draw — with `thin` = 1 exactly this draw's proposal, with thinning "the state moved").
pub fn chains_arrays(chains: &Chains) -> Vec<crate::data::npz_write::NpyArray> {
    use crate::data::npz_write::{NpyArray, NpyData};
    let (m, n, d) = (chains.chains().len(), chains.n_kept(), chains.dim());
    let cat = |f: &dyn Fn(&crate::sampler::Chain) -> &[f64]| -> Vec<f64> {
        chains
            .chains()
            .iter()
            .flat_map(|c| f(c).iter().copied())
            .collect()
    };
    vec![
        NpyArray::new("samples", &[m, n, d], NpyData::F64(cat(&|c| &c.samples))),
        NpyArray::new(
            "ln_posterior",
            &[m, n],
            NpyData::F64(cat(&|c| &c.ln_posterior)),
        ),
        NpyArray::new(
            "ln_likelihood",
            &[m, n],
            NpyData::F64(cat(&|c| &c.ln_likelihood)),
        ),
        NpyArray::new("param_names", &[d], NpyData::Str(chains.names().to_vec())),
        NpyArray::new(
            "accepted",
            &[m, n],
            NpyData::Bool(
                chains
                    .chains()
                    .iter()
                    .flat_map(|c| c.accepted.iter().copied())
                    .collect(),
            ),
        ),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn summary(rows: Vec<ParamRow>) -> FitSummary {
        FitSummary {
            origin: "test".into(),
            model: "m".into(),
            statistic: crate::likelihood::Statistic::Whittle,
            likelihood: LikelihoodKind::Exact,
            n_bins: 1,
            n_coarse_bins: None,
            rho_opt_at_map: f64::NAN,
            map_ln_posterior: -1.0,
            map_iterations: 1,
            rows,
            acceptance: vec![0.0],
            non_finite: vec![0],
            warnings: vec![],
            chains: 1,
            kept_per_chain: 10,
            burn_in: 5,
            thin: 1,
            seconds_map: 0.0,
            seconds_mcmc: 0.0,
            iterations_per_second: 0.0,
            fisher: vec![vec![1.0]],
        }
    }

    fn row(name: &str, sd: f64, rhat: f64, ess: f64) -> ParamRow {
        ParamRow {
            name: name.into(),
            unit: String::new(),
            truth: Some(1.0),
            map: 1.0,
            mean: 1.0,
            sd,
            cramer_rao: 0.1,
            rhat,
            ess,
            pull: Some(0.0 / sd),
        }
    }

    #[test]
    fn the_table_spells_out_stuck_chains_and_huge_numbers() {
        let s = summary(vec![
            row("ok", 0.1, 1.0012, 1234.4),
            row("stuck", 0.3, f64::INFINITY, 2.0),
            row("flat", 0.0, f64::INFINITY, 0.0),
            row("huge", 1e300, 1.5, 1e20),
        ]);
        let t = table(&s).to_text();
        let line = |n: &str| t.lines().find(|l| l.starts_with(n)).unwrap().to_string();
        assert!(
            line("ok").contains("1.0012") && line("ok").contains("1234"),
            "{t}"
        );
        assert!(line("stuck").contains("∞ (stuck)"), "{t}");
        assert!(line("flat").contains("∞ (stuck, sd 0)"), "{t}");
        // σ/CR = 1e301 and ESS = 1e20 in short form
        assert!(
            line("huge").contains("1.000e301") && line("huge").contains("1e20"),
            "{t}"
        );
        assert!(!t.contains("inf"), "{t}");
        assert!(t.lines().all(|l| l.chars().count() < 200), "{t}");
        // the flat row's pull is NaN (0/0): a warning names it
        let w = non_finite_warnings(&s);
        assert!(
            w.iter()
                .any(|m| m.starts_with("`flat`: pull is NaN (written as null")),
            "{w:?}"
        );
        assert_eq!(w.len(), 1, "{w:?}");
    }

    #[test]
    fn the_fix_hint_lists_the_lines_to_write() {
        let free: Vec<String> = ["w1sq", "a1", "f_o1"]
            .iter()
            .map(|s| s.to_string())
            .collect();
        let named = vec!["a1".to_string(), "f_o1".to_string()];
        let h = fix_hint(&free, &named, &|n| (n == "a1").then_some(1.05));
        assert_eq!(
            h,
            "Fix them, e.g. [fit] free = [\"w1sq\"] and fixed = { a1 = 1.05, f_o1 = <value> } (values of the search; use known values where you have them), or add an experiment that excites them"
        );
        // every free parameter unconstrained: nothing to keep free
        let h = fix_hint(&named, &named, &|_| None);
        assert!(h.starts_with("Add an experiment that excites them"), "{h}");
        // the whole message from a matrix with a zero column
        let f = DMatrix::from_row_slice(3, 3, &[1.0, 0.0, 0.2, 0.0, 0.0, 0.0, 0.2, 0.0, 1.0]);
        let m = singular_message(&f, &free, "MAP", &|_| Some(0.5));
        assert!(
            m.starts_with("the Fisher matrix at the MAP is singular: the data do not constrain `a1`: ln L does not depend on `a1` (zero Fisher column). Fix it, e.g. [fit] free = [\"w1sq\", \"f_o1\"] and fixed = { a1 = 0.5 }"),
            "{m}"
        );
    }
}
