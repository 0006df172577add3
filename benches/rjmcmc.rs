//! Benchmark: reversible-jump throughput on the guidance-delay study
//! (`examples/guidance-delays.toml`, model X with 7 parameters against Y with 5, relative-binned
//! likelihood), built the way `occam select` builds it: `analysis::prepare`, each model's exact
//! likelihood, its MAP by Fisher scoring, the relative-binned likelihood around the MAP, and the
//! RJ models as sub-models centred on the MAP with the inverse Fisher matrix as covariance.
//!
//! `cargo bench --bench rjmcmc` prints iterations per second with 1 and 2 chains (on the rayon
//! pool: one thread per chain on a 2-core machine), ln L evaluations per second, and the
//! projected wall time of 10⁸ iterations. `RJ_BENCH_ITERS` sets the iterations per measurement
//! (default 200 000).

use occam::config::Study;
use occam::density::LogDensity;
use occam::evidence::{RjModel, RjOptions, run_rjmcmc};
use occam::jobs::prepare::{default_start, likelihood_of, prepare, relbin_of};
use occam::likelihood::{fisher_exact, fisher_scoring};
use occam::nested::SubModel;
use std::path::Path;
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let study = Study::load(&root.join("examples/guidance-delays.toml"))?;
    let prep = prepare(&study)?;
    let n_iter: usize = std::env::var("RJ_BENCH_ITERS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(200_000);

    let mut relbins = Vec::new();
    let mut maps = Vec::new();
    for m in &study.select_models {
        let exact = likelihood_of(&study, m.spec.model, &prep.dataset)?;
        let start = default_start(&study, &m.spec);
        let map = fisher_scoring(&exact, &start, &m.spec.free, 1e-3, 200)?;
        let f = fisher_exact(&exact, &map.theta, &m.spec.free);
        let cov = f.cholesky().ok_or("singular Fisher matrix")?.inverse();
        relbins.push(relbin_of(&study, &exact, &map.theta)?);
        maps.push((map.theta, cov));
    }
    let subs: Vec<SubModel<&dyn LogDensity>> = relbins
        .iter()
        .zip(&maps)
        .zip(&study.select_models)
        .map(|((rb, (theta, _)), m)| {
            SubModel::new(rb as &dyn LogDensity, m.spec.free.clone(), theta.clone())
        })
        .collect::<Result<_, _>>()?;
    let models: Vec<RjModel<'_>> = subs
        .iter()
        .zip(&maps)
        .zip(&study.select_models)
        .map(|((s, (theta, cov)), m)| RjModel {
            name: m.name.clone(),
            target: s as &dyn LogDensity,
            center: m.spec.free.iter().map(|&i| theta[i]).collect(),
            cov: cov.clone(),
        })
        .collect();

    // single ln L rate of the larger model, for reference
    let x = &models[0];
    let t0 = Instant::now();
    let mut acc = 0.0;
    let n_l = 20_000;
    for i in 0..n_l {
        let mut th = x.center.clone();
        th[0] *= 1.0 + 1e-6 * (i % 7) as f64;
        acc += x.target.ln_likelihood(&th);
    }
    let lnl_rate = n_l as f64 / t0.elapsed().as_secs_f64();
    std::hint::black_box(acc);

    println!(
        "RJ throughput, {} (X: 7 params, Y: 5), relative-binned ln L",
        study.source
    );
    println!(
        "ln L of X, one thread: {lnl_rate:.0} evaluations/s ({:.2} µs)",
        1e6 / lnl_rate
    );
    println!(
        "{:>7} {:>10} {:>12} {:>14} {:>14} {:>10}",
        "chains", "iters", "seconds", "iters/s", "ln L evals/s", "1e8 iters"
    );
    for n_chains in [1usize, 2] {
        let opts = RjOptions {
            n_iter,
            burn_in: 2_000,
            n_chains,
            seed: 62,
            ..RjOptions::default()
        };
        let t0 = Instant::now();
        let res = run_rjmcmc(&models, &opts, None)?;
        let dt = t0.elapsed().as_secs_f64();
        let rate = res.n_iter as f64 / dt;
        let evals = res.likelihood_calls as f64;
        println!(
            "{:>7} {:>10} {:>12.2} {:>14.0} {:>14.0} {:>9.0}s",
            n_chains,
            res.n_iter,
            dt,
            rate,
            evals / dt,
            1e8 / rate
        );
        // per chain: wall time per iteration against the ln L time it contains
        let per_iter = dt * n_chains as f64 / res.n_iter as f64;
        let lnl_per_iter = evals / res.n_iter as f64 / lnl_rate;
        println!(
            "        {:.2} µs per iteration per chain, of which ln L {:.2} µs ({:.2} calls); overhead {:.0} %",
            per_iter * 1e6,
            lnl_per_iter * 1e6,
            evals / res.n_iter as f64,
            100.0 * (per_iter / lnl_per_iter - 1.0)
        );
        let p = res.pair(0, 1).ok_or("no pair")?;
        println!(
            "        ln B_XY: visits {:?}, bridge {:?}, effective jumps {}",
            p.visits.map(|v| (v.ln_b, v.std_err)),
            p.bridge.map(|v| (v.ln_b, v.std_err)),
            p.effective_jumps
        );
    }
    Ok(())
}
