//! Coverage of the Fisher (Cramér–Rao) error bars of `examples/cross-talk.toml` over noise
//! realisations. For each seed the study's data are simulated afresh from its generator
//! (`[simulation] model`, `[simulation.truth]`), the MAP of the `[fit]` model is found by
//! Fisher scoring from the prior centre (as `occam fit` does) and the Fisher matrix is
//! evaluated there. Per parameter it reports the 1σ coverage — the fraction of realisations
//! with |MAP − truth| < σ_Fisher — against 0.683 ± 3 binomial standard deviations
//! (`!` outside), the mean pull (MAP − truth)/σ (bias; its standard error is 1/√N for
//! calibrated errors) and the pulls' standard deviation.
//!
//!   cargo run --release --example cross_talk_coverage -- examples/cross-talk.toml 100
//!
//! Realisations whose MAP search does not converge, or ends on a prior bound, are counted and
//! reported, not dropped silently (they are left out of the table).

use occam::config::Study;
use occam::jobs::prepare::{default_start, prepare};
use occam::likelihood::{cramer_rao, fisher_exact, fisher_scoring};
use rayon::prelude::*;
use std::path::Path;
use std::time::Instant;

/// Nominal 1σ coverage of a calibrated Gaussian error bar.
const COVER: f64 = 0.683;

enum Outcome {
    /// (MAP − truth, σ_Fisher) per free parameter.
    Ok(Vec<(f64, f64)>),
    Failed(String),
}

fn realisation(base: &Study, seed: u64, truth: &[f64]) -> Outcome {
    let mut study = base.clone();
    study.seed = seed;
    let prep = match prepare(&study) {
        Ok(p) => p,
        Err(e) => return Outcome::Failed(format!("seed {seed}: prepare: {e}")),
    };
    let lik = &prep.likelihood;
    let spec = &study.fit_model;
    let start = default_start(&study, spec);
    let map = match fisher_scoring(lik, &start, &spec.free, 1e-3, 200) {
        Ok(m) => m,
        Err(e) => return Outcome::Failed(format!("seed {seed}: MAP: {e}")),
    };
    if !map.converged {
        return Outcome::Failed(format!("seed {seed}: MAP search did not converge"));
    }
    if map.at_bound.iter().any(|b| *b) {
        return Outcome::Failed(format!("seed {seed}: MAP on a prior bound"));
    }
    let f = fisher_exact(lik, &map.theta, &spec.free);
    let Some(sd) = cramer_rao(&f) else {
        return Outcome::Failed(format!("seed {seed}: singular Fisher matrix"));
    };
    Outcome::Ok(
        spec.free
            .iter()
            .zip(&sd)
            .map(|(&i, &s)| (map.theta[i] - truth[i], s))
            .collect(),
    )
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let path = args
        .get(1)
        .map_or("examples/cross-talk.toml", String::as_str);
    let n: u64 = args.get(2).map_or(100, |s| s.parse().expect("N"));
    let study = Study::load(Path::new(path)).expect("study");
    let spec = &study.fit_model;
    let names = study.models.models[spec.model].param_names().to_vec();
    let truth: Vec<f64> = names
        .iter()
        .map(|p| {
            *study
                .simulation
                .truth
                .get(p)
                .unwrap_or_else(|| panic!("[simulation.truth] has no `{p}`"))
        })
        .collect();
    let t0 = Instant::now();
    let outcomes: Vec<Outcome> = (0..n)
        .into_par_iter()
        .map(|k| realisation(&study, study.seed.wrapping_add(1000 + k), &truth))
        .collect();
    let seconds = t0.elapsed().as_secs_f64();
    let mut good: Vec<&Vec<(f64, f64)>> = Vec::new();
    for o in &outcomes {
        match o {
            Outcome::Ok(v) => good.push(v),
            Outcome::Failed(why) => println!("excluded: {why}"),
        }
    }
    let m = good.len() as f64;
    let band = 3.0 * (COVER * (1.0 - COVER) / m).sqrt();
    println!(
        "{} realisations of {path}, {} usable, {seconds:.1} s; 1σ coverage expected {COVER} ± {band:.3} (3 binomial sd)",
        n,
        good.len()
    );
    println!(
        "{:>8} {:>10} {:>10} {:>9} {:>14} {:>9}",
        "param", "truth", "mean σ", "coverage", "bias ± se", "pull sd"
    );
    let mut outside = 0;
    for (j, &i) in spec.free.iter().enumerate() {
        let pulls: Vec<f64> = good.iter().map(|v| v[j].0 / v[j].1).collect();
        let cov = pulls.iter().filter(|z| z.abs() < 1.0).count() as f64 / m;
        let bias = pulls.iter().sum::<f64>() / m;
        let sd = (pulls.iter().map(|z| (z - bias).powi(2)).sum::<f64>() / (m - 1.0)).sqrt();
        let mean_sigma = good.iter().map(|v| v[j].1).sum::<f64>() / m;
        let flag = if (cov - COVER).abs() > band {
            outside += 1;
            "!"
        } else {
            ""
        };
        println!(
            "{:>8} {:>10.3e} {:>10.3e} {:>8.3}{flag:1} {:>7.3} ± {:<5.3} {:>8.3}",
            names[i],
            truth[i],
            mean_sigma,
            cov,
            bias,
            1.0 / m.sqrt(),
            sd
        );
    }
    println!(
        "{outside} of {} parameters outside {COVER} ± {band:.3}",
        spec.free.len()
    );
}
