//! Does `select` tell a drifting parameter from a constant one? Over noise realisations of a
//! study with stretches (`examples/drifting-stiffness.toml`), each simulated twice from the same
//! noise streams — with the stretches' drifting truth, and with every stretch at `[truth]` (no
//! drift) — this finds the MAP of the study's two `[[select.model]]`s (the drifting model, and
//! the same with its slope fixed at zero) by Fisher scoring and reports:
//!
//! - `ln B` (first model over second) by Laplace–Fisher, `ln L̂ + ln π̂ + (d/2) ln 2π −
//!   ½ ln det F` per model: mean, spread, and the fraction above 1 (positive evidence);
//! - the slope's pull `(MAP − truth)/σ_Fisher`: bias, sd and 1σ coverage against 0.683 ± 3
//!   binomial sd.
//!
//! `occam select` on seed 2014 of the same study gives the RJMCMC bridge 5.546 ± 0.025 beside
//! Laplace–Fisher 5.556 (every estimator agrees there), which is why the fast estimator is
//! used for the many realisations.
//!
//!   cargo run --release --example drift_validation -- examples/drifting-stiffness.toml 100
//!
//! Realisations whose MAP search fails, does not converge or ends on a prior bound are counted
//! and reported, not dropped silently.

use nalgebra::DMatrix;
use occam::config::Study;
use occam::density::LogDensity;
use occam::jobs::prepare::{default_start, prepare_select, reference_point};
use occam::likelihood::{Likelihood, cramer_rao, fisher_exact, fisher_scoring};
use rayon::prelude::*;
use std::path::Path;
use std::time::Instant;

/// Nominal 1σ coverage of a calibrated Gaussian error bar.
const COVER: f64 = 0.683;

/// `ln det F` through the diagonal scaling (the parameters span 30 orders of magnitude).
fn ln_det(f: &DMatrix<f64>) -> Option<f64> {
    let d: Vec<f64> = (0..f.nrows()).map(|i| 1.0 / f[(i, i)].sqrt()).collect();
    let s = DMatrix::from_fn(f.nrows(), f.ncols(), |i, j| f[(i, j)] * d[i] * d[j]);
    let c = s.cholesky()?;
    let ld: f64 = c.l().diagonal().iter().map(|x| 2.0 * x.ln()).sum();
    Some(ld - 2.0 * d.iter().map(|x| x.ln()).sum::<f64>())
}

/// Laplace–Fisher `ln Z` of the sub-model with free parameters `free` at its MAP, and the MAP.
fn laplace(
    study: &Study,
    lik: &Likelihood,
    k: usize,
    seed: u64,
) -> Result<(f64, Vec<f64>, DMatrix<f64>), String> {
    let spec = &study.select_models[k].spec;
    let start = default_start(study, spec);
    let map = fisher_scoring(lik, &start, &spec.free, 1e-3, 200)
        .map_err(|e| format!("seed {seed}: MAP: {e}"))?;
    if !map.converged {
        return Err(format!("seed {seed}: MAP search did not converge"));
    }
    if map.at_bound.iter().any(|b| *b) {
        return Err(format!("seed {seed}: MAP on a prior bound"));
    }
    let f = fisher_exact(lik, &map.theta, &spec.free);
    let ld = ln_det(&f).ok_or_else(|| format!("seed {seed}: singular Fisher matrix"))?;
    let kinds = lik.prior().kinds();
    let ln_prior: f64 = spec
        .free
        .iter()
        .map(|&i| {
            let (lo, hi) = kinds[i].bounds();
            -(hi - lo).ln()
        })
        .sum();
    let d = spec.free.len() as f64;
    let ln_z = lik.ln_likelihood_whittle(&map.theta)
        + ln_prior
        + 0.5 * d * (2.0 * std::f64::consts::PI).ln()
        - 0.5 * ld;
    Ok((ln_z, map.theta, f))
}

/// (ln B, slope pull) of one realisation.
fn realisation(base: &Study, seed: u64, slope: usize, truth: f64) -> Result<(f64, f64), String> {
    let mut study = base.clone();
    study.seed = seed;
    let prep = prepare_select(&study).map_err(|e| format!("seed {seed}: prepare: {e}"))?;
    let lik = &prep.likelihood;
    let (z1, th1, f1) = laplace(&study, lik, 0, seed)?;
    let (z2, _, _) = laplace(&study, lik, 1, seed)?;
    let sd = cramer_rao(&f1).ok_or_else(|| format!("seed {seed}: singular Fisher matrix"))?;
    let j = study.select_models[0]
        .spec
        .free
        .iter()
        .position(|&i| i == slope)
        .ok_or("the first model's slope is not free")?;
    Ok((z1 - z2, (th1[slope] - truth) / sd[j]))
}

fn report(label: &str, outcomes: &[Result<(f64, f64), String>]) {
    for o in outcomes {
        if let Err(why) = o {
            println!("{label}: excluded: {why}");
        }
    }
    let good: Vec<(f64, f64)> = outcomes.iter().filter_map(|o| o.clone().ok()).collect();
    let m = good.len() as f64;
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let sd = |v: &[f64]| {
        let a = mean(v);
        (v.iter().map(|x| (x - a).powi(2)).sum::<f64>() / (v.len() as f64 - 1.0)).sqrt()
    };
    let lnb: Vec<f64> = good.iter().map(|g| g.0).collect();
    let pulls: Vec<f64> = good.iter().map(|g| g.1).collect();
    let mut sorted = lnb.clone();
    sorted.sort_by(f64::total_cmp);
    let band = 3.0 * (COVER * (1.0 - COVER) / m).sqrt();
    let cov = pulls.iter().filter(|z| z.abs() < 1.0).count() as f64 / m;
    println!("\n{label}: {} usable realisations", good.len());
    println!(
        "  ln B(drift/constant): mean {:.2} ± {:.2} (se), sd {:.2}, median {:.2}, range [{:.2}, {:.2}]; ln B > 1 in {:.2}, ln B < −1 in {:.2}",
        mean(&lnb),
        sd(&lnb) / m.sqrt(),
        sd(&lnb),
        sorted[sorted.len() / 2],
        sorted[0],
        sorted[sorted.len() - 1],
        lnb.iter().filter(|&&x| x > 1.0).count() as f64 / m,
        lnb.iter().filter(|&&x| x < -1.0).count() as f64 / m,
    );
    println!(
        "  slope pull: bias {:.3} ± {:.3}, sd {:.3}, 1σ coverage {:.3} (expected {COVER} ± {band:.3})",
        mean(&pulls),
        1.0 / m.sqrt(),
        sd(&pulls),
        cov
    );
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let path = args
        .get(1)
        .map_or("examples/drifting-stiffness.toml", String::as_str);
    let n: u64 = args.get(2).map_or(100, |s| s.parse().expect("N"));
    let drifting = Study::load(Path::new(path)).expect("study");
    assert!(
        drifting.select_models.len() == 2,
        "the study compares two models"
    );
    let mi = drifting.select_models[0].spec.model;
    let names = drifting.models.models[mi].param_names().to_vec();
    let slope = names
        .iter()
        .position(|n| n.starts_with('d') && n.contains("_d"))
        .expect("a drift slope parameter");
    let truth = reference_point(&drifting, mi)[slope];
    let mut steady = drifting.clone();
    for s in &mut steady.stretches.entries {
        s.truth.clear();
    }
    let t0 = Instant::now();
    let run = |s: &Study, truth: f64| -> Vec<_> {
        (0..n)
            .into_par_iter()
            .map(|k| realisation(s, s.seed.wrapping_add(1000 + k), slope, truth))
            .collect()
    };
    let with = run(&drifting, truth);
    let without = run(&steady, 0.0);
    println!(
        "{n} realisations of {path} with and without its drift ({} = {truth:.4e} and 0), {:.1} s",
        names[slope],
        t0.elapsed().as_secs_f64()
    );
    report("drifting truth", &with);
    report("constant truth", &without);
}
