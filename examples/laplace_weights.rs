//! How close a study's posterior is to its Laplace approximation: draws from the Gaussian (or a
//! Student-t) with the MAP as centre and the inverse Fisher matrix (capped at the prior's
//! widths, as `occam fit` caps it) as covariance, each weighed by the exact posterior over
//! its density. It prints the spread of the log-weights, Kish's effective share
//! `(Σw)²/(N Σw²)`, and the share an independence sampler fed these draws in order accepts —
//! what `[fit] independence` can expect of its draws.
//!
//!   cargo run --release --example laplace_weights -- STUDY [DRAWS] [DOF,…]
//!
//! DRAWS defaults to 300, DOF to `inf,8,4` (`inf`: the Gaussian); each is tried at the
//! Fisher widths and at 1.2 times them, with every axis drawn as it is (`lin`) and with the
//! glitches' decays and amplitudes drawn in logarithm as `occam fit` draws them (`log`,
//! `occam::jobs::fit::log_axes`). The MAP is searched from the prepared start
//! (`[fit] start`, and with modelled glitches the rounds' MAP) by Fisher scoring.

use occam::config::Study;
use occam::density::LogDensity;
use occam::jobs::prepare::{default_start, prepare};
use occam::likelihood::{fisher_exact, fisher_scoring};
use occam::linalg::SpdOptions;
use occam::model::map_tolerance;
use occam::sampler::{Proposal, StudentProposal, cap_to_prior, chain_rng};
use rand::RngExt;
use rayon::prelude::*;
use std::path::Path;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let Some(path) = args.get(1) else {
        eprintln!("usage: laplace_weights STUDY [DRAWS] [DOF,…]");
        std::process::exit(2);
    };
    let study = Study::load(Path::new(path)).unwrap_or_else(|e| panic!("{path}: {e}"));
    let n: usize = args.get(2).map_or(300, |s| s.parse().expect("DRAWS"));
    let dofs: Vec<f64> = args
        .get(3)
        .map_or("inf,8,4", String::as_str)
        .split(',')
        .map(|s| s.parse().expect("DOF"))
        .collect();
    let t = std::time::Instant::now();
    let prep = prepare(&study).unwrap_or_else(|e| panic!("prepare: {e}"));
    let study = prep.study(&study).clone();
    let lik = &prep.likelihood;
    let free = &study.fit_model.free;
    let start = default_start(&study, &study.fit_model);
    let map = fisher_scoring(lik, &start, free, map_tolerance(lik.model().as_ref()), 200)
        .unwrap_or_else(|e| panic!("MAP: {e}"));
    println!(
        "{} free parameters; prepared and MAP ({} iterations, converged: {}) in {:.0} s",
        free.len(),
        map.iterations,
        map.converged,
        t.elapsed().as_secs_f64()
    );
    let names = lik.model().param_names();
    let at_bound: Vec<&str> = free
        .iter()
        .zip(&map.at_bound)
        .filter(|(_, b)| **b)
        .map(|(&i, _)| names[i].as_str())
        .collect();
    println!("MAP on a prior bound: {at_bound:?}");
    // inverted as `occam fit` inverts it (symmetric to the last bit)
    let fisher = fisher_exact(lik, &map.theta, free);
    let cov = cap_to_prior(
        &SpdOptions::lower()
            .factor(&fisher)
            .expect("a regular Fisher matrix")
            .inverse(),
        &lik.prior().subset(free),
    );
    let centre: Vec<f64> = free.iter().map(|&i| map.theta[i]).collect();
    let ln_post_map = lik.ln_posterior(&map.theta);
    let sd: Vec<f64> = (0..cov.nrows()).map(|k| cov[(k, k)].sqrt()).collect();
    let log = occam::jobs::fit::log_axes(names, free, &centre, &sd);
    println!("{} axes drawn in logarithm with `log`", log.len());
    for &k in &log {
        println!(
            "  {} centre {:.4e} sd {:.3e}",
            names[free[k]], centre[k], sd[k]
        );
    }
    println!("dof  widths  axes  inside the prior  Kish share  accepted  log-weight 5/50/95 %");
    for &dof in &dofs {
        for (widths, axes) in [
            (1.0, &[][..]),
            (1.0, &log[..]),
            (1.2, &[][..]),
            (1.2, &log[..]),
        ] {
            let mut q = StudentProposal::new(centre.clone(), &(&cov * (widths * widths)), dof)
                .and_then(|q| q.log_axes(axes))
                .expect("the capped inverse Fisher matrix");
            let mut rng = chain_rng(11, 0);
            // each draw with ln q(draw) − ln q(MAP), from the proposal's own Hastings ratio
            let draws: Vec<(Vec<f64>, f64)> = (0..n)
                .map(|_| {
                    let mut x = vec![0.0; centre.len()];
                    let h = q.propose(&centre, 1.0, &mut rng, &mut x);
                    (x, -h)
                })
                .collect();
            let lw: Vec<f64> = draws
                .par_iter()
                .map(|(x, ln_q)| {
                    let mut th = map.theta.clone();
                    for (&i, v) in free.iter().zip(x) {
                        th[i] = *v;
                    }
                    lik.ln_posterior(&th) - ln_post_map - ln_q
                })
                .collect();
            let kind = if axes.is_empty() { "lin" } else { "log" };
            report(&format!("{dof:>4} {widths:>6}  {kind}"), &lw);
        }
    }
}

/// One line of the table, headed `head`, for the log-weights `lw` (−∞ outside the prior).
fn report(head: &str, lw: &[f64]) {
    let mut inside: Vec<f64> = lw.iter().copied().filter(|v| v.is_finite()).collect();
    if inside.is_empty() {
        println!("{head}  0 of {}", lw.len());
        return;
    }
    let top = inside.iter().copied().fold(f64::MIN, f64::max);
    let (s1, s2) = inside.iter().fold((0.0, 0.0), |(a, b), v| {
        let w = (v - top).exp();
        (a + w, b + w * w)
    });
    let mut rng = chain_rng(12, 0);
    let mut current = f64::NEG_INFINITY;
    let mut accepted = 0;
    for &v in lw {
        if v.is_finite() && (current == f64::NEG_INFINITY || rng.random::<f64>().ln() < v - current)
        {
            current = v;
            accepted += 1;
        }
    }
    inside.sort_by(f64::total_cmp);
    let q = |p: f64| inside[((inside.len() - 1) as f64 * p).round() as usize];
    println!(
        "{head}  {:>4} of {}  {:>10.2}  {:>8.2}  {:.2} / {:.2} / {:.2}",
        inside.len(),
        lw.len(),
        s1 * s1 / (s2 * lw.len() as f64),
        accepted as f64 / lw.len() as f64,
        q(0.05),
        q(0.5),
        q(0.95)
    );
}
