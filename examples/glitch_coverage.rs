//! The bias glitches cause and the bias gating and modelling remove: Fisher-error coverage over
//! noise realisations of a study with `[simulation.glitches]`, fitted four ways from the same
//! noise streams — glitches with no treatment (`[analysis] glitches = "none"`), glitches gated
//! (`"gate"`), glitches modelled (`"model"`: fitted jointly with the physics, the physics'
//! errors marginalised over them), and no glitches at all. For each seed the MAP of the `[fit]` model is found by
//! Fisher scoring from the prior centre (as `occam fit` does) and the Fisher matrix is
//! evaluated there. Per parameter and case it reports the 1σ coverage against 0.683 ± 3
//! binomial standard deviations (`!` outside), the mean pull (bias, standard error 1/√N) and
//! the pulls' standard deviation. It also reports what the gate did: the injected glitches it
//! found (a glitch is found when its start lies in a gated region), the seconds gated, and the
//! seconds it gates on the glitch-free data (the false alarms).
//!
//!   cargo run --release --example glitch_coverage -- examples/glitches.toml 100
//!   cargo run --release --example glitch_coverage -- examples/glitches.toml 100 modelled runs/cov
//!
//! A third argument names the cases to run (`none,gated,modelled,free`, the default all); the
//! others print `–`.
//!
//! Realisations whose MAP search fails, does not converge or ends on a prior bound are counted
//! and reported, not dropped silently.
//!
//! A fourth argument names a directory that keeps each realisation's outcome as it ends
//! (`<case>-<key>-<seed>.json`), so a run of hours can be stopped and run again: a kept outcome
//! is read instead of fitted. The key is a hash of the study file and of this executable, so
//! outcomes of another study or another build are never mixed in; the output says how many
//! were read.

use occam::config::GlitchCountMethod;
use occam::config::Study;
use occam::jobs::glitch_count::glitch_count;
use occam::jobs::prepare::{default_start, prepare, reference_point};
use occam::likelihood::{GlitchTreatment, cramer_rao, fisher_exact, fisher_scoring};
use occam::model::map_tolerance;
use rayon::prelude::*;
use std::path::Path;
use std::time::Instant;

/// Nominal 1σ coverage of a calibrated Gaussian error bar.
const COVER: f64 = 0.683;

/// One fit: (MAP − truth, σ_Fisher) per free parameter of the study's `[fit]` model, and the
/// record (glitches injected, found, seconds gated, glitches modelled, candidates left out,
/// glitch parameters on a prior bound, the reversible jump's mean number of glitches), or why
/// the realisation is left out.
type Outcome = Result<(Vec<(f64, f64)>, [f64; 7]), String>;

fn realisation(base: &Study, seed: u64, truth: &[f64]) -> Outcome {
    let mut study = base.clone();
    study.seed = seed;
    let prep = prepare(&study).map_err(|e| format!("seed {seed}: prepare: {e}"))?;
    let n_base = study.fit_model.free.len();
    // with modelled glitches the model carries them: its spec and starts
    let study = prep.study(&study).clone();
    // the injected glitches' start times, per experiment, and whether a gate covers them
    let (mut injected, mut found) = (0.0, 0.0);
    if let Some(g) = prep
        .dataset
        .extra
        .get("glitches")
        .and_then(|v| v.as_object())
    {
        for (name, rec) in g {
            let gate = prep.glitch_gates.iter().find(|x| &x.experiment == name);
            for gl in rec["fit"].as_array().into_iter().flatten() {
                let t0 = gl["t0"].as_f64().unwrap_or(f64::NAN);
                injected += 1.0;
                let modelled = prep
                    .glitch_candidates
                    .iter()
                    .any(|c| &c.experiment == name && c.region[0] <= t0 && t0 < c.region[1]);
                if modelled
                    || gate.is_some_and(|x| x.regions.iter().any(|r| r[0] <= t0 && t0 < r[1]))
                {
                    found += 1.0;
                }
            }
        }
    }
    let gated: f64 = prep.glitch_gates.iter().map(|g| g.seconds).sum();
    let lik = &prep.likelihood;
    let spec = &study.fit_model;
    let start = default_start(&study, spec);
    let map = fisher_scoring(
        lik,
        &start,
        &spec.free,
        map_tolerance(lik.model().as_ref()),
        200,
    )
    .map_err(|e| format!("seed {seed}: MAP: {e}"))?;
    if !map.converged {
        return Err(format!("seed {seed}: MAP search did not converge"));
    }
    if map.at_bound[..n_base].iter().any(|b| *b) {
        return Err(format!("seed {seed}: MAP on a prior bound"));
    }
    let glitch_bounds = map.at_bound[n_base..].iter().filter(|b| **b).count() as f64;
    let f = fisher_exact(lik, &map.theta, &spec.free);
    let sd = cramer_rao(&f).ok_or_else(|| format!("seed {seed}: singular Fisher matrix"))?;
    let mut rows: Vec<(f64, f64)> = spec.free[..n_base]
        .iter()
        .zip(&sd)
        .map(|(&i, &s)| (map.theta[i] - truth[i], s))
        .collect();
    if study.analysis.glitch_count.is_all() && !prep.glitch_candidates.is_empty() {
        let pulls: Vec<f64> = rows.iter().map(|(d, s)| d / s).collect();
        eprintln!(
            "seed {seed}: MAP pulls {pulls:.2?}; {} glitches modelled, {} injected",
            prep.glitch_candidates.len(),
            injected
        );
    }
    // the number of glitches by the reversible jump: its marginal mean and sd
    let mut mean_count = f64::NAN;
    if !study.analysis.glitch_count.is_all() && !prep.glitch_candidates.is_empty() {
        let g = glitch_count(
            &study,
            lik,
            &prep.glitch_candidates,
            &spec.free,
            &map.theta,
            &f,
            None,
        )
        .map_err(|e| format!("seed {seed}: glitch count: {e}"))?;
        mean_count = g
            .count
            .iter()
            .enumerate()
            .map(|(k, p)| k as f64 * p.0)
            .sum();
        // the same seed's MAP pulls beside the marginal ones, for a side-by-side comparison
        let pulls = |v: &[(f64, f64)]| v.iter().map(|(d, s)| d / s).collect::<Vec<_>>();
        let marginal: Vec<(f64, f64)> = spec.free[..n_base]
            .iter()
            .zip(&g.parameters)
            .map(|(&i, p)| (p.mean - truth[i], p.sd))
            .collect();
        eprintln!(
            "seed {seed}: MAP pulls {:.2?}; marginal pulls {:.2?}; mean count {mean_count:.2} of {} candidates",
            pulls(&rows),
            pulls(&marginal),
            g.candidates.len()
        );
        for ((row, &i), p) in rows.iter_mut().zip(&spec.free[..n_base]).zip(&g.parameters) {
            *row = (p.mean - truth[i], p.sd);
        }
    }
    Ok((
        rows,
        [
            injected,
            found,
            gated,
            prep.glitch_candidates.len() as f64,
            prep.glitch_dropped.len() as f64,
            glitch_bounds,
            mean_count,
        ],
    ))
}

/// Where realisations' outcomes are kept between runs, and the key of this study and build.
struct Cache {
    dir: std::path::PathBuf,
    key: String,
    read: std::sync::atomic::AtomicUsize,
}

impl Cache {
    fn new(dir: &str, study_path: &str) -> Cache {
        use sha2::{Digest, Sha256};
        let mut h = Sha256::new();
        h.update(std::fs::read(study_path).expect("study file"));
        let exe = std::env::current_exe().expect("this executable's path");
        h.update(std::fs::read(&exe).expect("this executable"));
        let key: String = h.finalize()[..8]
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect();
        std::fs::create_dir_all(dir).expect("cache directory");
        Cache {
            dir: dir.into(),
            key,
            read: 0.into(),
        }
    }

    /// The kept outcome of `case` at `seed`, or `fit`'s, kept (written whole, then renamed).
    fn outcome(&self, case: &str, seed: u64, fit: impl FnOnce() -> Outcome) -> Outcome {
        use serde_json::{Value, json};
        let path = self.dir.join(format!("{case}-{}-{seed}.json", self.key));
        let num = |v: &Value| v.as_f64().unwrap_or(f64::NAN);
        if let Ok(text) = std::fs::read_to_string(&path) {
            let v: Value = serde_json::from_str(&text).expect("a kept outcome");
            self.read.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            if let Some(why) = v["err"].as_str() {
                return Err(why.to_string());
            }
            let rows = v["rows"].as_array().expect("rows");
            let rec = v["record"].as_array().expect("record");
            let mut record = [f64::NAN; 7];
            for (r, x) in record.iter_mut().zip(rec) {
                *r = num(x);
            }
            return Ok((
                rows.iter().map(|r| (num(&r[0]), num(&r[1]))).collect(),
                record,
            ));
        }
        let out = fit();
        let v = match &out {
            Ok((rows, record)) => json!({"rows": rows, "record": record}),
            Err(why) => json!({ "err": why }),
        };
        let tmp = path.with_extension("part");
        std::fs::write(&tmp, v.to_string()).expect("write a kept outcome");
        std::fs::rename(&tmp, &path).expect("keep an outcome");
        out
    }
}

/// Per free parameter: (coverage, bias, pull sd), and the number of usable realisations.
fn stats(outcomes: &[Outcome], n_par: usize) -> (Vec<[f64; 3]>, usize) {
    let good: Vec<&Vec<(f64, f64)>> = outcomes
        .iter()
        .filter_map(|o| o.as_ref().ok().map(|(r, _)| r))
        .collect();
    let m = good.len() as f64;
    let rows = (0..n_par)
        .map(|j| {
            let pulls: Vec<f64> = good.iter().map(|v| v[j].0 / v[j].1).collect();
            let cov = pulls.iter().filter(|z| z.abs() < 1.0).count() as f64 / m;
            let bias = pulls.iter().sum::<f64>() / m;
            let sd = (pulls.iter().map(|z| (z - bias).powi(2)).sum::<f64>() / (m - 1.0)).sqrt();
            [cov, bias, sd]
        })
        .collect();
    (rows, good.len())
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let path = args.get(1).map_or("examples/glitches.toml", String::as_str);
    let n: u64 = args.get(2).map_or(100, |s| s.parse().expect("N"));
    let wanted: Vec<&str> = args
        .get(3)
        .map_or("none,gated,modelled,counted,free", String::as_str)
        .split(',')
        .collect();
    for w in &wanted {
        assert!(
            ["none", "gated", "modelled", "counted", "free"].contains(w),
            "unknown case `{w}`: none, gated, modelled, counted or free"
        );
    }
    let base = Study::load(Path::new(path)).expect("study");
    assert!(
        base.simulation.glitches.is_some(),
        "{path} has no [simulation.glitches]"
    );
    let mut none = base.clone();
    none.analysis.glitches = GlitchTreatment::None;
    none.analysis.glitch_threshold = None;
    none.analysis.glitch_pad = None;
    let mut gated = base.clone();
    gated.analysis.glitches = GlitchTreatment::Gate;
    let mut modelled = base.clone();
    modelled.analysis.glitches = GlitchTreatment::Model;
    let mut counted = modelled.clone();
    counted.analysis.glitch_count = GlitchCountMethod::Rj;
    let mut clean = none.clone();
    clean.simulation.glitches = None;
    // the false alarms: the gate on glitch-free data
    let mut clean_gated = gated.clone();
    clean_gated.simulation.glitches = None;
    let truth = reference_point(&base, base.fit_model.model);
    let cache = args.get(4).map(|d| Cache::new(d, path));
    let t0 = Instant::now();
    let run = |case: &str, s: &Study| -> Vec<Outcome> {
        if !wanted.contains(&case) {
            return Vec::new();
        }
        (0..n)
            .into_par_iter()
            .map(|k| {
                let seed = s.seed.wrapping_add(1000 + k);
                let fit = || realisation(s, seed, &truth);
                match &cache {
                    Some(c) => c.outcome(case, seed, fit),
                    None => fit(),
                }
            })
            .collect()
    };
    let cases = [
        ("no treatment", run("none", &none)),
        ("gated", run("gated", &gated)),
        ("modelled", run("modelled", &modelled)),
        ("counted", run("counted", &counted)),
        ("glitch-free", run("free", &clean)),
    ];
    let false_alarm: Vec<f64> = (0..if wanted.contains(&"gated") { n } else { 0 })
        .into_par_iter()
        .map(|k| {
            let mut s = clean_gated.clone();
            s.seed = s.seed.wrapping_add(1000 + k);
            prepare(&s)
                .map(|p| p.glitch_gates.iter().map(|g| g.seconds).sum())
                .unwrap_or(f64::NAN)
        })
        .collect();
    println!(
        "{n} realisations of {path}: no treatment, gated, modelled, counted, glitch-free; {:.1} s",
        t0.elapsed().as_secs_f64()
    );
    if let Some(c) = &cache {
        println!(
            "{} outcomes read from {} (key {}), the others fitted and kept there",
            c.read.load(std::sync::atomic::Ordering::Relaxed),
            c.dir.display(),
            c.key
        );
    }
    for (label, out) in &cases {
        for o in out {
            if let Err(why) = o {
                println!("{label}: excluded: {why}");
            }
        }
    }
    let names = base.models.models[base.fit_model.model].param_names();
    let free = &base.fit_model.free;
    let st: Vec<(Vec<[f64; 3]>, usize)> = cases.iter().map(|(_, o)| stats(o, free.len())).collect();
    let m = st
        .iter()
        .zip(&cases)
        .filter(|(_, (_, o))| !o.is_empty())
        .map(|(s, _)| s.1)
        .min()
        .unwrap_or(0) as f64;
    let band = 3.0 * (COVER * (1.0 - COVER) / m).sqrt();
    println!(
        "usable realisations: {}; 1σ coverage expected {COVER} ± {band:.3}; bias ± {:.3}",
        st.iter()
            .zip(&cases)
            .map(|(s, (l, _))| format!("{l} {}", s.1))
            .collect::<Vec<_>>()
            .join(", "),
        1.0 / m.sqrt()
    );
    println!(
        "| parameter | bias none / gated / modelled / counted / free | pull sd none / gated / modelled / counted / free | coverage none / gated / modelled / counted / free |"
    );
    println!("|---|---|---|---|");
    for (j, &i) in free.iter().enumerate() {
        // one of bias (q = 1), pull sd (2) or coverage (0, flagged) per case, `–` where not run
        let col = |q: usize| {
            (0..cases.len())
                .map(|c| {
                    if cases[c].1.is_empty() {
                        return "–".to_string();
                    }
                    let v = st[c].0[j][q];
                    let flag = if q == 0 && (v - COVER).abs() > band {
                        "!"
                    } else {
                        ""
                    };
                    format!("{v:.2}{flag}")
                })
                .collect::<Vec<_>>()
                .join(" / ")
        };
        println!("| {} | {} | {} | {} |", names[i], col(1), col(2), col(0));
    }
    let totals = |c: usize| -> (Vec<f64>, usize) {
        let rec: Vec<[f64; 7]> = cases[c]
            .1
            .iter()
            .filter_map(|o| o.as_ref().ok().map(|x| x.1))
            .collect();
        let mut t = vec![0.0; 7];
        for r in &rec {
            for (a, b) in t.iter_mut().zip(r) {
                *a += b;
            }
        }
        (t, rec.len().max(1))
    };
    let (t, k) = totals(1);
    if !cases[1].1.is_empty() {
        println!(
            "gate: {} of {} injected glitches found ({:.1} %); {:.0} s gated per realisation on average",
            t[1],
            t[0],
            100.0 * t[1] / t[0],
            t[2] / k as f64
        );
    }
    let (t, k) = totals(2);
    if !cases[2].1.is_empty() {
        println!(
            "model: {} of {} injected glitches inside a modelled candidate's region ({:.1} %); {:.2} glitches modelled and {:.2} candidates left out per realisation; {:.2} glitch parameters per realisation on a prior bound at the MAP",
            t[1],
            t[0],
            100.0 * t[1] / t[0],
            t[3] / k as f64,
            t[4] / k as f64,
            t[5] / k as f64
        );
    }
    let (t, k) = totals(3);
    if !cases[3].1.is_empty() {
        println!(
            "counted: {} glitches injected, {:.2} candidates modelled and {:.2} glitches by the reversible jump (posterior mean) per realisation",
            t[0] / k as f64,
            t[3] / k as f64,
            t[6] / k as f64
        );
    }
    let fa: Vec<f64> = false_alarm
        .iter()
        .copied()
        .filter(|x| x.is_finite())
        .collect();
    let fa_total: f64 = fa.iter().sum();
    let fa_any = fa.iter().filter(|x| **x > 0.0).count();
    if !fa.is_empty() {
        println!(
            "false alarms on glitch-free data: {fa_total:.0} s gated over {} realisations ({fa_any} with any), {:.2e} of the data",
            fa.len(),
            fa_total / (fa.len() as f64 * data_seconds(&base))
        );
    }
}

/// Seconds of fit-stretch data per realisation of `study`.
fn data_seconds(study: &Study) -> f64 {
    study
        .experiments
        .iter()
        .map(|d| d.n_samples() as f64 / d.fs)
        .sum()
}
