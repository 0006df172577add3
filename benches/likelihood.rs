//! Benchmark: ln L of the 7-parameter model on the Table I study (examples/tn3045.toml),
//! exact full band and relative-binned; a Fisher matrix; one MH iteration.
//!
//! `cargo bench --bench likelihood` prints a table of evaluations per second.

use occam::config::Study;
use occam::experiment::{System, simulate};
use occam::likelihood::{
    ExperimentSpectra, LtpLikelihood, NoiseSource, RelBinLikelihood, SpectraOptions, fisher_exact,
};
use occam::ltp::{Controllers, N_PARAMS, PARAM_NAMES};
use occam::prior::{Prior, PriorKind};
use std::hint::black_box;
use std::path::Path;
use std::time::Instant;

fn rate(mut f: impl FnMut() -> f64, min_secs: f64) -> (f64, f64) {
    // warm-up, then as many calls as fit in min_secs
    let mut acc = f();
    let t0 = Instant::now();
    let mut n = 0u64;
    while t0.elapsed().as_secs_f64() < min_secs {
        acc += f();
        n += 1;
    }
    let dt = t0.elapsed().as_secs_f64();
    black_box(acc);
    (n as f64 / dt, dt / n as f64)
}

fn main() {
    let study = Study::load(Path::new("examples/tn3045.toml")).expect("examples/tn3045.toml");
    let sim = simulate(&study).expect("simulate");
    let sys = System::of(&study);
    let csd = |f: f64| sys.noise_csd(f);
    let opts = SpectraOptions {
        noise: NoiseSource::Welch,
        ..Default::default()
    };
    let ctrl = Controllers::default();
    let spectra: Vec<_> = sim
        .dataset
        .experiments
        .iter()
        .map(|e| ExperimentSpectra::new(e, &opts, &ctrl, Some(&csd)).unwrap())
        .collect();
    let kinds = vec![
        PriorKind::Uniform { lo: -4e-6, hi: 0.0 },
        PriorKind::Uniform { lo: -4e-6, hi: 0.0 },
        PriorKind::Uniform { lo: 0.0, hi: 1.0 },
        PriorKind::Uniform { lo: 0.0, hi: 1.0 },
        PriorKind::Uniform { lo: 0.5, hi: 1.5 },
        PriorKind::Uniform { lo: 0.5, hi: 1.5 },
        PriorKind::Uniform {
            lo: -1e-3,
            hi: 1e-3,
        },
    ];
    let prior = Prior::new(PARAM_NAMES.iter().map(|s| s.to_string()).collect(), kinds).unwrap();
    let lik = LtpLikelihood::new(spectra, study.masses, prior).unwrap();
    let th = study.truth.to_array();
    let t0 = Instant::now();
    let rb = RelBinLikelihood::new(&lik, &th, &Default::default()).unwrap();
    let build = t0.elapsed().as_secs_f64();
    let mut x = th;
    let mut k = 0usize;
    let mut bump = |x: &mut [f64; N_PARAMS]| {
        k += 1;
        x[4] = th[4] + 1e-9 * (k % 7) as f64;
    };
    let (exact_rate, exact_t) = rate(
        || {
            bump(&mut x);
            lik.ln_likelihood_full(&x)
        },
        2.0,
    );
    let mut y = th;
    let mut k2 = 0usize;
    let (rb_rate, rb_t) = rate(
        || {
            k2 += 1;
            y[4] = th[4] + 1e-9 * (k2 % 7) as f64;
            rb.ln_likelihood_full(&y)
        },
        2.0,
    );
    let free: Vec<usize> = (0..N_PARAMS).collect();
    let (f_rate, f_t) = rate(|| fisher_exact(&lik, &th, &free)[(0, 0)], 2.0);
    println!(
        "Table I study: {} experiments, {} bins in band, {} coarse bins",
        lik.spectra().len(),
        lik.n_bins(),
        rb.n_coarse()
    );
    println!("relative-binning setup: {build:.3} s");
    println!("{:<34} {:>14} {:>14}", "kernel", "evals/s", "time/eval");
    println!(
        "{:<34} {:>14.1} {:>11.3} ms",
        "ln L exact (full band)",
        exact_rate,
        exact_t * 1e3
    );
    println!(
        "{:<34} {:>14.1} {:>11.3} µs",
        "ln L relative-binned",
        rb_rate,
        rb_t * 1e6
    );
    println!(
        "{:<34} {:>14.2} {:>11.3} ms",
        "Fisher matrix 7x7 (dual numbers)",
        f_rate,
        f_t * 1e3
    );
}
