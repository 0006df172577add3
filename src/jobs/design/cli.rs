//! `occam design STUDY [-o DIR] [--validate R]`: search, print, write `design.toml`,
//! `baseline.toml` and `design.json`, and optionally validate by full model selection.

use super::search::{
    DesignError, DesignPlan, ProxyScore, SearchResult, asimov_score, realisation_seed, search,
    study_with,
};
use crate::config::Study;
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// A design with its proxy.
#[derive(Debug, Clone, Serialize)]
pub struct ScoredDesign {
    pub label: String,
    /// Segments per channel (frequency Hz, amplitude m), in the order of `channels`.
    pub segments: Vec<Vec<(f64, f64)>>,
    pub proxy: ProxyScore,
}

/// Full model selection over noise realisations of one design.
#[derive(Debug, Clone, Serialize)]
pub struct Validation {
    pub label: String,
    pub realisations: usize,
    /// Reference `ln B` in favour of the true model against its hardest competitor, per
    /// realisation (`None` where select gave no reference number).
    pub ln_b: Vec<Option<f64>>,
    /// Mean and standard error (sample sd / √n) over the realisations with a number.
    pub mean: Option<f64>,
    pub std_err: Option<f64>,
    /// Fraction of realisations where the true model is preferred (reference `ln B` > 0).
    pub fraction_true_preferred: Option<f64>,
    /// The reference estimator of each realisation.
    pub reference: Vec<String>,
    /// The seeds used (see [`super::realisation_seed`]).
    pub seeds: Vec<u64>,
    pub seconds: f64,
}

/// Everything `occam design` reports (`design.json`).
#[derive(Debug, Clone, Serialize)]
pub struct DesignReport {
    pub study: String,
    pub true_model: String,
    pub channels: Vec<String>,
    pub candidates: Vec<f64>,
    pub baseline: ScoredDesign,
    pub start: ScoredDesign,
    pub chosen: ScoredDesign,
    pub search: SearchResult,
    pub validation: Vec<Validation>,
    pub seconds: f64,
}

/// Runs the reference estimator of `occam select` on `r` noise realisations of a design.
pub fn validate(
    study: &Study,
    plan: &DesignPlan,
    label: &str,
    segs: &[Vec<(f64, f64)>],
    r: usize,
) -> Result<Validation, DesignError> {
    let t0 = Instant::now();
    let mut ln_b = Vec::new();
    let mut reference = Vec::new();
    let mut seeds = Vec::new();
    let t = &study.select_models[plan.true_index].name;
    for k in 0..r {
        let mut s = study_with(study, plan.experiments(segs), false);
        s.seed = realisation_seed(study.seed, k);
        s.select.seed = None;
        seeds.push(s.seed);
        let prep = crate::jobs::prepare::prepare_select(&s)
            .map_err(|e| DesignError::Proxy(format!("{label}, realisation {k}: {e}")))?;
        let sum = crate::jobs::select::run(&s, &prep, None)
            .map_err(|e| DesignError::Proxy(format!("{label}, realisation {k}: {e}")))?;
        let mut worst: Option<f64> = None;
        let mut refs = Vec::new();
        let mut missing = false;
        for p in sum.pairs.iter().filter(|p| &p.x == t || &p.y == t) {
            let v = p
                .estimates
                .iter()
                .find(|e| e.method == p.reference)
                .and_then(|e| e.ln_b)
                .map(|b| if &p.x == t { b } else { -b });
            refs.push(p.reference.clone());
            match v {
                Some(v) => worst = Some(worst.map_or(v, |w| w.min(v))),
                None => missing = true,
            }
        }
        ln_b.push(if missing { None } else { worst });
        reference.push(refs.join(", "));
    }
    let vals: Vec<f64> = ln_b.iter().flatten().copied().collect();
    let n = vals.len() as f64;
    let mean = (!vals.is_empty()).then(|| vals.iter().sum::<f64>() / n);
    let std_err = mean
        .filter(|_| vals.len() > 1)
        .map(|m| (vals.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (n - 1.0)).sqrt() / n.sqrt());
    Ok(Validation {
        label: label.into(),
        realisations: r,
        fraction_true_preferred: (!vals.is_empty())
            .then(|| vals.iter().filter(|&&v| v > 0.0).count() as f64 / n),
        ln_b,
        mean,
        std_err,
        reference,
        seeds,
        seconds: t0.elapsed().as_secs_f64(),
    })
}

/// The study file at `path` with its `[[experiment]]` tables replaced by the design's and
/// `output` moved to `<output>/<label>`: a complete study `occam select` runs.
pub fn study_toml(
    path: &Path,
    study: &Study,
    plan: &DesignPlan,
    segs: &[Vec<(f64, f64)>],
    label: &str,
) -> Result<String, DesignError> {
    let text = crate::data::infile::read_to_string(path)
        .map_err(|e| DesignError::Io(format!("{}: {e}", path.display())))?;
    let mut t: toml::Table =
        toml::from_str(&text).map_err(|e| DesignError::Io(format!("{}: {e}", path.display())))?;
    let mut exps = toml::value::Array::new();
    for (ch, s) in plan.options.channels.iter().zip(segs) {
        if s.is_empty() {
            continue;
        }
        let mut segments = toml::value::Array::new();
        for &(f, a) in s {
            let mut seg = toml::Table::new();
            seg.insert("freq".into(), f.into());
            seg.insert("amplitude".into(), a.into());
            seg.insert("duration".into(), plan.options.segment_duration.into());
            segments.push(seg.into());
        }
        let mut inj = toml::Table::new();
        inj.insert("kind".into(), "sine_train".into());
        inj.insert("gap".into(), plan.options.gap.into());
        inj.insert("segments".into(), segments.into());
        let mut e = toml::Table::new();
        e.insert("name".into(), format!("design_{ch}").into());
        e.insert(ch.clone(), inj.into());
        exps.push(e.into());
    }
    t.insert("experiment".into(), exps.into());
    t.insert(
        "output".into(),
        study.output.join(label).display().to_string().into(),
    );
    let body = toml::to_string(&t).map_err(|e| DesignError::Io(e.to_string()))?;
    Ok(format!(
        "# Written by `occam design {}`: the study with the experiments of the {} design.\n#   occam select <this file>\n{body}",
        path.display(),
        if label == "design" { "chosen" } else { label }
    ))
}

fn fmt_segs(segs: &[Vec<(f64, f64)>], channels: &[String]) -> String {
    channels
        .iter()
        .zip(segs)
        .map(|(c, s)| {
            format!(
                "{c}: {}",
                s.iter()
                    .map(|(f, a)| format!("{:.3} mHz @ {:.3} nm", f * 1e3, a * 1e9))
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        })
        .collect::<Vec<_>>()
        .join("\n    ")
}

/// The printed table: per channel and candidate, the best proxy among the trials that put
/// that frequency in that channel; then baseline, start and chosen designs.
pub fn table(r: &DesignReport) -> String {
    let mut out = String::new();
    out.push_str(&format!(
        "proxy = Asimov Laplace-Fisher ln B({} vs hardest competitor), noiseless data, model noise\n",
        r.true_model
    ));
    out.push_str("candidate scores (best proxy of the designs tried with that frequency):\n");
    out.push_str(&format!("{:>12}", "f (mHz)"));
    for c in &r.channels {
        out.push_str(&format!("{:>14}", c));
    }
    out.push('\n');
    for &f in &r.candidates {
        out.push_str(&format!("{:>12.4}", f * 1e3));
        for c in &r.channels {
            let best = r
                .search
                .trials
                .iter()
                .filter(|t| &t.channel == c && t.freq == f)
                .filter_map(|t| t.ln_b)
                .fold(None, |m: Option<f64>, v| Some(m.map_or(v, |m| m.max(v))));
            out.push_str(&match best {
                Some(b) => format!("{b:>14.3}"),
                None => format!("{:>14}", "–"),
            });
        }
        out.push('\n');
    }
    for d in [&r.baseline, &r.start, &r.chosen] {
        out.push_str(&format!(
            "{:<9} proxy ln B = {:>8.3}  (ρ_opt {:.1}; Laplace {:?})\n    {}\n",
            d.label,
            d.proxy.ln_b,
            d.proxy.rho_opt,
            d.proxy.laplace,
            fmt_segs(&d.segments, &r.channels)
        ));
    }
    out.push_str(&format!(
        "search: {} trials in {} passes\n",
        r.search.trials.len(),
        r.search.passes
    ));
    for v in &r.validation {
        let pm = |x: Option<f64>| x.map_or("–".to_string(), |v| format!("{v:.3}"));
        out.push_str(&format!(
            "validation {}: mean reference ln B = {} ± {} over {} realisations; true model preferred in {} ({:.0} s)\n",
            v.label,
            pm(v.mean),
            pm(v.std_err),
            v.realisations,
            pm(v.fraction_true_preferred),
            v.seconds
        ));
    }
    out
}

/// `occam design`: loads the study, searches, validates `validate_r` realisations each of the
/// chosen design and the baseline (`None`: no validation; `Some(None)`: `[design]
/// realisations`), prints the table and writes `design.toml`,
/// `baseline.toml` and `design.json` to `out` (default `<output>/design`).
pub fn run_cli(
    path: &Path,
    out: Option<PathBuf>,
    validate_r: Option<Option<usize>>,
) -> Result<DesignReport, DesignError> {
    let t0 = Instant::now();
    let study = Study::load(path).map_err(|e| DesignError::Io(e.to_string()))?;
    let opts = study.design.clone().ok_or_else(|| {
        DesignError::Proxy(format!(
            "{}: `design`: the study has no [design] table: add one with true_model and candidates (see docs/src/guide/design.md)",
            study.source
        ))
    })?;
    let plan = opts.validate(&study)?;
    let out = out.unwrap_or_else(|| study.output.join("design"));
    let run =
        crate::data::rundir::RunDir::open(&out).map_err(|e| DesignError::Io(e.to_string()))?;
    let base_segs = plan.baseline();
    let baseline = ScoredDesign {
        label: "baseline".into(),
        proxy: asimov_score(&study, &plan, plan.experiments(&base_segs))?,
        segments: base_segs.clone(),
    };
    let s = search(&study, &plan)?;
    let start = ScoredDesign {
        label: "start".into(),
        segments: s.start.clone(),
        proxy: s.start_score.clone(),
    };
    let chosen = ScoredDesign {
        label: "chosen".into(),
        segments: s.chosen.clone(),
        proxy: s.chosen_score.clone(),
    };
    let r = match validate_r {
        None => 0,
        Some(None) => opts.realisations,
        Some(Some(r)) => r,
    };
    let mut validation = Vec::new();
    if r > 0 {
        validation.push(validate(&study, &plan, "chosen", &chosen.segments, r)?);
        validation.push(validate(&study, &plan, "baseline", &base_segs, r)?);
    }
    let report = DesignReport {
        study: study.source.clone(),
        true_model: opts.true_model.clone(),
        channels: opts.channels.clone(),
        candidates: plan.candidates.clone(),
        baseline,
        start,
        chosen,
        search: s,
        validation,
        seconds: t0.elapsed().as_secs_f64(),
    };
    let stage = run.staging().map_err(|e| DesignError::Io(e.to_string()))?;
    let io = |e: std::io::Error| DesignError::Io(format!("{}: {e}", out.display()));
    crate::atomic::write_bytes(
        &stage.join("design.toml"),
        study_toml(path, &study, &plan, &report.chosen.segments, "design")?.as_bytes(),
    )
    .map_err(io)?;
    crate::atomic::write_bytes(
        &stage.join("baseline.toml"),
        study_toml(path, &study, &plan, &base_segs, "baseline")?.as_bytes(),
    )
    .map_err(io)?;
    let json = serde_json::to_vec_pretty(&report).map_err(|e| DesignError::Io(e.to_string()))?;
    crate::atomic::write_bytes(&stage.join("design.json"), &json).map_err(io)?;
    run.publish("design", &["design.toml", "baseline.toml", "design.json"])
        .map_err(|e| DesignError::Io(e.to_string()))?;
    Ok(report)
}
