//! Coverage of the Fisher (Cramér–Rao) and sandwich error bars of a study with gaps, beside
//! the same study without them, over noise realisations. For each seed the data are simulated twice from the
//! same noise streams — with the study's `[simulation.gaps]` and listed gaps, and with none —
//! the MAP of the `[fit]` model is found by Fisher scoring from the prior centre (as
//! `occam fit` does) and the Fisher matrix is evaluated there. Per parameter and per case it
//! reports the 1σ coverage (fraction of realisations with |MAP − truth| < σ_Fisher) against
//! 0.683 ± 3 binomial standard deviations (`!` outside), the mean pull (bias, standard error
//! 1/√N), the pulls' standard deviation and the mean σ (the information the gaps cost); the
//! same for the sandwich errors `√(F⁻¹JF⁻¹)` ([`occam::likelihood::score_covariance`]). Per
//! case it also checks the sandwich's two parts: the score at the truth whitened by `J` (mean
//! square 1 if `J` is its covariance; by `F` beside it) and the curvature of `ln L` at the MAP
//! (central differences at 0.3 σ) against `F`'s diagonal.
//!
//!   cargo run --release --example gaps_coverage -- examples/gaps.toml 100 [FIRST]
//!
//! Realisation `k` is seed `seed + FIRST + k` (FIRST defaults to 1000, the guide's sample).
//!
//! Realisations whose MAP search fails, does not converge or ends on a prior bound are
//! counted and reported, not dropped silently.

use occam::config::Study;
use occam::density::LogDensity as _;
use occam::jobs::prepare::{default_start, prepare, reference_point};
use occam::likelihood::{
    cramer_rao, fisher_exact, fisher_scoring, gradient_and_fisher, gradient_hessian_numeric,
    sandwich_errors, score_covariance,
};
use rayon::prelude::*;
use std::path::Path;
use std::time::Instant;

/// Nominal 1σ coverage of a calibrated Gaussian error bar.
const COVER: f64 = 0.683;

/// One realisation.
struct Outcome {
    /// Per free parameter: MAP − truth, σ_Fisher, σ_sandwich.
    params: Vec<(f64, f64, f64)>,
    /// `gᵀJ⁻¹g` and `gᵀF⁻¹g` of the score `g` at the truth.
    score: (f64, f64),
    /// Per free parameter: the curvature of `−ln L` at the MAP over `F_ii`.
    curvature: Vec<f64>,
}

/// [`Outcome`] per free parameter, or why the realisation is left out.
fn realisation(base: &Study, seed: u64, truth: &[f64]) -> Result<Outcome, String> {
    let mut study = base.clone();
    study.seed = seed;
    let prep = prepare(&study).map_err(|e| format!("seed {seed}: prepare: {e}"))?;
    let lik = &prep.likelihood;
    let spec = &study.fit_model;
    let start = default_start(&study, spec);
    let map = fisher_scoring(lik, &start, &spec.free, 1e-3, 200)
        .map_err(|e| format!("seed {seed}: MAP: {e}"))?;
    if !map.converged {
        return Err(format!("seed {seed}: MAP search did not converge"));
    }
    if map.at_bound.iter().any(|b| *b) {
        return Err(format!("seed {seed}: MAP on a prior bound"));
    }
    let f = fisher_exact(lik, &map.theta, &spec.free);
    let sd = cramer_rao(&f).ok_or_else(|| format!("seed {seed}: singular Fisher matrix"))?;
    let j = score_covariance(lik, &map.theta, &spec.free);
    let sw =
        sandwich_errors(&f, &j).ok_or_else(|| format!("seed {seed}: singular Fisher matrix"))?;
    let (g, f0) = gradient_and_fisher(lik, truth, &spec.free);
    let j0 = score_covariance(lik, truth, &spec.free);
    let g = nalgebra::DVector::from_vec(g);
    let whitened = |c: nalgebra::DMatrix<f64>| -> Result<f64, String> {
        let l = c
            .cholesky()
            .ok_or_else(|| format!("seed {seed}: J or F not positive definite"))?;
        Ok(l.l()
            .solve_lower_triangular(&g)
            .expect("triangular")
            .norm_squared())
    };
    let steps: Vec<f64> = sd.iter().map(|s| 0.3 * s).collect();
    let ln_l = |t: &[f64]| lik.ln_likelihood(t);
    let (_, h) = gradient_hessian_numeric(&ln_l, &map.theta, &spec.free, &steps);
    Ok(Outcome {
        params: spec
            .free
            .iter()
            .zip(sd.iter().zip(&sw))
            .map(|(&i, (&s, &w))| (map.theta[i] - truth[i], s, w))
            .collect(),
        score: (whitened(j0)?, whitened(f0)?),
        curvature: (0..spec.free.len())
            .map(|i| -h[(i, i)] / f[(i, i)])
            .collect(),
    })
}

fn report(label: &str, study: &Study, outcomes: &[Result<Outcome, String>]) {
    let good: Vec<&Outcome> = outcomes.iter().filter_map(|o| o.as_ref().ok()).collect();
    for o in outcomes {
        if let Err(why) = o {
            println!("{label}: excluded: {why}");
        }
    }
    let m = good.len() as f64;
    let band = 3.0 * (COVER * (1.0 - COVER) / m).sqrt();
    println!(
        "\n{label}: {} usable realisations; 1σ coverage expected {COVER} ± {band:.3}",
        good.len()
    );
    println!(
        "{:>8} {:>10} {:>9} {:>14} {:>9} {:>13} {:>12} {:>12}",
        "param",
        "mean σ",
        "coverage",
        "bias ± se",
        "pull sd",
        "sandwich ÷ σ",
        "sw coverage",
        "sw pull sd"
    );
    let spec = &study.fit_model;
    let names = study.models.models[spec.model].param_names();
    for (j, &i) in spec.free.iter().enumerate() {
        let pulls: Vec<f64> = good.iter().map(|v| v.params[j].0 / v.params[j].1).collect();
        let cov = pulls.iter().filter(|z| z.abs() < 1.0).count() as f64 / m;
        let bias = pulls.iter().sum::<f64>() / m;
        let sd = (pulls.iter().map(|z| (z - bias).powi(2)).sum::<f64>() / (m - 1.0)).sqrt();
        let mean_sigma = good.iter().map(|v| v.params[j].1).sum::<f64>() / m;
        let flag = if (cov - COVER).abs() > band { "!" } else { "" };
        let sw: Vec<f64> = good.iter().map(|v| v.params[j].0 / v.params[j].2).collect();
        let sw_cov = sw.iter().filter(|z| z.abs() < 1.0).count() as f64 / m;
        let sw_bias = sw.iter().sum::<f64>() / m;
        let sw_sd = (sw.iter().map(|z| (z - sw_bias).powi(2)).sum::<f64>() / (m - 1.0)).sqrt();
        let ratio = good
            .iter()
            .map(|v| v.params[j].2 / v.params[j].1)
            .sum::<f64>()
            / m;
        let sw_flag = if (sw_cov - COVER).abs() > band {
            "!"
        } else {
            ""
        };
        println!(
            "{:>8} {:>10.3e} {:>8.3}{flag:1} {:>7.3} ± {:<5.3} {:>8.3} {:>13.3} {:>11.3}{sw_flag:1} {:>11.3}",
            names[i],
            mean_sigma,
            cov,
            bias,
            1.0 / m.sqrt(),
            sd,
            ratio,
            sw_cov,
            sw_sd
        );
    }
    let d = spec.free.len() as f64;
    let by_j = good.iter().map(|v| v.score.0).sum::<f64>() / (m * d);
    let by_f = good.iter().map(|v| v.score.1).sum::<f64>() / (m * d);
    println!(
        "score at the truth whitened by J: mean square {by_j:.3} (standard error {:.3}); by F {by_f:.3}",
        (2.0 / (m * d)).sqrt()
    );
    let c: Vec<f64> = good
        .iter()
        .flat_map(|v| v.curvature.iter().copied())
        .collect();
    let (lo, hi) = c
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
            (a.min(x), b.max(x))
        });
    println!("curvature of −ln L at the MAP ÷ F, diagonal: {lo:.4} to {hi:.4}");
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let path = args.get(1).map_or("examples/gaps.toml", String::as_str);
    let n: u64 = args.get(2).map_or(100, |s| s.parse().expect("N"));
    let first: u64 = args.get(3).map_or(1000, |s| s.parse().expect("FIRST"));
    let gapped = Study::load(Path::new(path)).expect("study");
    let free = gapped.without_gaps();
    let truth = reference_point(&gapped, gapped.fit_model.model);
    let t0 = Instant::now();
    let run = |s: &Study| -> Vec<_> {
        (0..n)
            .into_par_iter()
            .map(|k| realisation(s, s.seed.wrapping_add(first + k), &truth))
            .collect()
    };
    let with = run(&gapped);
    let without = run(&free);
    println!(
        "{n} realisations of {path} (seeds from {first} after the study's) with and without its gaps, {:.1} s",
        t0.elapsed().as_secs_f64()
    );
    report("with gaps", &gapped, &with);
    report("without gaps", &free, &without);
}
