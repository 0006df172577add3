//! Benchmark: ln L of the 7-parameter model on the Table I study (examples/tn3045.toml),
//! exact full band and relative-binned; a Fisher matrix; one Metropolis–Hastings iteration on
//! the relative-binned density; and, when `bench/peer/.venv` exists, the same exact ln L in
//! vectorised numpy (bench/peer/numpy_lnl.py) for comparison.
//!
//! `cargo bench --bench likelihood` prints one table of evaluations per second (see
//! BENCHMARKS.md). `bash bench/peer/setup.sh` creates the numpy venv.
//! `OCCAM_BENCH=user cargo bench --bench likelihood` runs only the user-defined model's rows.

#[path = "../bench/peer/peer_npz.rs"]
mod peer_npz;

use nalgebra::DMatrix;
use ndarray_npy::NpzWriter;
use occam::config::Study;
use occam::experiment::simulate;
use occam::likelihood::{
    ExperimentSpectra, Likelihood, NoiseSource, RelBinLikelihood, SpectraOptions, fisher_exact,
};
use occam::ltp::{Masses, N_PARAMS};
use occam::model::{LtpModel, Model};
use occam::sampler::{MetropolisHastings, MhSettings, Start};
use std::hint::black_box;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::Arc;
use std::time::Instant;

/// Seconds spent timing each ln L / Fisher kernel.
const MIN_SECS: f64 = 2.0;
/// Iterations of the timed Metropolis–Hastings run (burn-in included).
const MH_ITERS: usize = 30_000;

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

fn fmt_time(s: f64) -> String {
    if s >= 1e-3 {
        format!("{:.3} ms", s * 1e3)
    } else {
        format!("{:.2} µs", s * 1e6)
    }
}

/// What the numpy peer reported.
struct Peer {
    evals_per_s: f64,
    max_rel: f64,
    numpy: String,
}

/// Writes the numpy peer's input file to `path`.
fn write_peer_inputs(
    path: &Path,
    lik: &Likelihood,
    masses: &Masses,
    truth: &[f64; N_PARAMS],
    checks: &[[f64; N_PARAMS]],
) -> Result<(), Box<dyn std::error::Error>> {
    let mut z = NpzWriter::new(std::fs::File::create(path)?);
    peer_npz::write_peer_inputs(&mut z, lik, masses, truth, checks)?;
    z.finish()?;
    Ok(())
}

/// Runs the numpy peer if its venv exists. `Err` carries why there is no figure.
fn run_peer(npz: &Path) -> Result<Peer, String> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let python = root.join("bench/peer/.venv/bin/python");
    if !python.exists() {
        return Err(format!(
            "skipped: {} not found; set it up with `bash bench/peer/setup.sh`",
            python.display()
        ));
    }
    // Elementwise complex ufuncs do not call BLAS, so the OpenBLAS overrides this machine may
    // set cannot matter; drop them for this one command anyway, as a benchmark should.
    let out = Command::new(&python)
        .arg(root.join("bench/peer/numpy_lnl.py"))
        .arg(npz)
        .env_remove("OPENBLAS_CORETYPE")
        .env_remove("OPENBLAS_L2_SIZE")
        .output()
        .map_err(|e| format!("could not run {}: {e}", python.display()))?;
    let stdout = String::from_utf8_lossy(&out.stdout);
    for line in stdout.lines().filter(|l| !l.starts_with("PEER ")) {
        println!("  peer: {line}");
    }
    if !out.status.success() {
        return Err(format!(
            "FAILED ({}): {}{}",
            out.status,
            stdout
                .lines()
                .find(|l| l.starts_with("PEER "))
                .unwrap_or(""),
            String::from_utf8_lossy(&out.stderr)
        ));
    }
    let line = stdout
        .lines()
        .find(|l| l.starts_with("PEER "))
        .ok_or("the peer printed no `PEER ` line")?;
    let field = |key: &str| {
        line.split_whitespace()
            .find_map(|w| w.strip_prefix(key)?.strip_prefix('='))
            .map(str::to_string)
            .ok_or(format!("no `{key}=` in the peer line `{line}`"))
    };
    let num = |key: &str| -> Result<f64, String> {
        field(key)?
            .parse::<f64>()
            .map_err(|e| format!("`{key}` in `{line}`: {e}"))
    };
    Ok(Peer {
        evals_per_s: num("evals_per_s")?,
        max_rel: num("max_rel")?,
        numpy: field("numpy")?,
    })
}

fn main() {
    if std::env::var("OCCAM_BENCH").as_deref() == Ok("user") {
        user_model_rate();
        return;
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let study =
        Study::load(&root.join("examples/tn3045.toml")).expect("examples/tn3045.toml loads");
    let sim = simulate(&study.simulation_plan()).expect("simulate");
    let sys = study.system();
    let csd = |f: f64| sys.noise_csd(f);
    let opts = SpectraOptions {
        noise: NoiseSource::Welch,
        ..Default::default()
    };
    let model: Arc<dyn Model> = Arc::new(LtpModel::new(
        "ltp",
        occam::model::LtpModelOptions {
            masses: study.masses,
            ..Default::default()
        },
    ));
    let th = study.truth.to_array();
    let spectra: Vec<_> = sim
        .dataset
        .experiments
        .iter()
        .map(|e| ExperimentSpectra::new(e, &opts, model.as_ref(), &th, Some(&csd)).unwrap())
        .collect();
    // the study's prior (the default uniform boxes of `[prior]`)
    let prior = study.models.priors[0].clone();
    let lik = Likelihood::new(model, spectra, prior).unwrap();
    let t0 = Instant::now();
    let rb = RelBinLikelihood::new(&lik, &th, &Default::default()).unwrap();
    let build = t0.elapsed().as_secs_f64();

    // θ moves by a negligible amount at every call so that no kernel can reuse a result.
    let mut x = th;
    let mut k = 0usize;
    let (exact_rate, exact_t) = rate(
        || {
            k += 1;
            x[4] = th[4] + 1e-9 * (k % 7) as f64;
            lik.ln_likelihood_full(&x)
        },
        MIN_SECS,
    );
    let mut y = th;
    let mut k2 = 0usize;
    let (rb_rate, rb_t) = rate(
        || {
            k2 += 1;
            y[4] = th[4] + 1e-9 * (k2 % 7) as f64;
            rb.ln_likelihood_full(&y)
        },
        MIN_SECS,
    );
    let free: Vec<usize> = (0..N_PARAMS).collect();
    let (f_rate, f_t) = rate(|| fisher_exact(&lik, &th, &free)[(0, 0)], MIN_SECS);

    // One MH chain on the relative-binned 7-parameter density, proposal (2.38²/7)·F⁻¹ at the
    // truth: the sampler's cost per iteration (proposal draw, prior check, ln L, bookkeeping).
    let cov: DMatrix<f64> = fisher_exact(&lik, &th, &free)
        .cholesky()
        .expect("the Fisher matrix at the truth is positive definite")
        .inverse()
        * (2.38f64.powi(2) / N_PARAMS as f64);
    let settings = MhSettings {
        n_iter: MH_ITERS,
        burn_in: MH_ITERS / 10,
        n_chains: 1,
        seed: 3045,
        checkpoint_every: MH_ITERS,
        ..MhSettings::default()
    };
    let mh = MetropolisHastings::new(&rb, &cov, settings).expect("MH settings");
    let t0 = Instant::now();
    let chains = mh
        .run(&Start::Point(th.to_vec()))
        .expect("MH run")
        .into_chains()
        .expect("not stopped");
    let mh_t = t0.elapsed().as_secs_f64() / MH_ITERS as f64;
    let counts = &chains.chains()[0].counts;
    let accepted = counts.burn_in.accepted + counts.sampling.accepted;
    let proposed = counts.burn_in.proposed + counts.sampling.proposed;
    let outside = counts.burn_in.prior_rejected + counts.sampling.prior_rejected;

    // the numpy peer: ln L at the truth and at points 1, 2 and 5 σ (Cramér–Rao) away
    let sigma: Vec<f64> = (0..N_PARAMS)
        .map(|a| (cov[(a, a)] * N_PARAMS as f64 / 2.38f64.powi(2)).sqrt())
        .collect();
    let checks: Vec<[f64; N_PARAMS]> = [0.0, 1.0, 2.0, 5.0]
        .iter()
        .map(|&c| {
            std::array::from_fn(|a| th[a] + c * sigma[a] * if a % 2 == 0 { 1.0 } else { -1.0 })
        })
        .collect();
    let npz = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("numpy_peer_inputs.npz");
    println!(
        "Table I study: {} experiments, {} bins in band, {} coarse bins",
        lik.spectra().len(),
        lik.n_bins(),
        rb.n_coarse()
    );
    println!("relative-binning setup: {build:.3} s");
    println!(
        "MH: {MH_ITERS} iterations, 1 chain, acceptance {:.1} %, {outside} proposals outside \
         the prior (ln L not evaluated)",
        100.0 * accepted as f64 / proposed as f64
    );
    println!("numpy peer (exact ln L), inputs in {}:", npz.display());
    let peer = write_peer_inputs(&npz, &lik, &study.masses, &th, &checks)
        .map_err(|e| format!("could not write {}: {e}", npz.display()))
        .and_then(|()| run_peer(&npz));
    match &peer {
        Ok(p) => println!(
            "  peer: numpy {} agrees with the Rust ln L to {:.1e} relative (tolerance 1e-9)",
            p.numpy, p.max_rel
        ),
        Err(why) => println!("  peer {why}"),
    }

    let rows: [(&str, f64, f64, bool); 4] = [
        ("ln L exact (full band)", exact_rate, exact_t, true),
        ("ln L relative-binned", rb_rate, rb_t, true),
        ("MH iteration (rel.-binned, 7 par)", 1.0 / mh_t, mh_t, true),
        ("Fisher matrix 7x7 (dual numbers)", f_rate, f_t, false),
    ];
    println!();
    println!(
        "{:<36} {:>13} {:>13} {:>14}",
        "kernel", "evals/s", "time/eval", "× numpy exact"
    );
    if let Ok(p) = &peer {
        println!(
            "{:<36} {:>13.1} {:>13} {:>14}",
            format!("numpy ln L exact (numpy {})", p.numpy),
            p.evals_per_s,
            fmt_time(1.0 / p.evals_per_s),
            "1"
        );
    }
    for (name, r, t, comparable) in rows {
        let ratio = match (&peer, comparable) {
            (Ok(p), true) => format!("{:.1}", r / p.evals_per_s),
            _ => "—".into(),
        };
        println!("{name:<36} {r:>13.1} {:>13} {ratio:>14}", fmt_time(t));
    }
    println!(
        "(× numpy exact = evaluations/s divided by the numpy peer's exact full-band ln L; \
         a numpy MH iteration costs at least one such ln L)"
    );
    rj_rate();
    user_model_rate();
    if let Err(why) = &peer
        && why.starts_with("FAILED")
    {
        eprintln!("the numpy peer disagrees with the Rust ln L: see above");
        std::process::exit(1);
    }
}

/// Reversible-jump iterations per second on the guidance-delay study (7- against 5-parameter
/// model, `examples/guidance-delays.toml`, relative-binned likelihoods; each iteration is an
/// in-model step and a jump attempt), and what 10⁸ iterations (K14's figure for
/// non-competitive models) would take at that rate.
fn rj_rate() {
    let mut study = Study::load(Path::new("examples/guidance-delays.toml"))
        .expect("examples/guidance-delays.toml");
    study.select.rj_iterations = 200_000;
    study.select.iterations = 4_000;
    study.select.burn_in = 1_000;
    let prep = occam::jobs::prepare::prepare(&study).expect("prepare");
    let s = occam::jobs::select::run(&study, &prep, None).expect("select");
    let rate = s.rj_iterations_per_second;
    println!();
    println!(
        "RJMCMC, guidance-delay study: {rate:.0} iterations/s ({} iterations, visits {:?}); \
         10^8 iterations would take {:.1} h",
        s.rj.as_ref().unwrap().n_iter,
        s.rj.as_ref().unwrap().visits,
        1e8 / rate / 3600.0
    );
}

/// The 7-parameter closed loop written as a user-defined model
/// (`examples/user-model-closed-loop.toml`) and as a state-space model
/// (`examples/state-space.toml`, on the same data and band) against the built-in model with its
/// fast kernel: ln L evaluations per second, exact and relative-binned.
fn user_model_rate() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let study = Study::load(&root.join("examples/user-model-closed-loop.toml"))
        .expect("examples/user-model-closed-loop.toml");
    let prep = occam::jobs::prepare::prepare(&study).expect("prepare");
    let user = &prep.likelihood;
    let ltp = study.models.index("ltp").expect("the built-in model");
    let builtin =
        occam::jobs::prepare::likelihood_of(&study, ltp, &prep.dataset).expect("likelihood");
    let mut ss_study =
        Study::load(&root.join("examples/state-space.toml")).expect("examples/state-space.toml");
    ss_study.analysis.band = study.analysis.band;
    let ss_index = ss_study.models.index("loop").expect("the state-space loop");
    let ss = occam::jobs::prepare::likelihood_of(&ss_study, ss_index, &prep.dataset)
        .expect("state-space likelihood");
    let th = study.truth.to_array();
    let rb_user = RelBinLikelihood::new(user, &th, &Default::default()).unwrap();
    let rb_builtin = RelBinLikelihood::new(&builtin, &th, &Default::default()).unwrap();
    let rb_ss = RelBinLikelihood::new(&ss, &th, &Default::default()).unwrap();
    let timed = |f: &dyn Fn(&[f64]) -> f64| {
        let mut x = th;
        let mut k = 0usize;
        rate(
            || {
                k += 1;
                x[4] = th[4] + 1e-9 * (k % 7) as f64;
                f(&x)
            },
            MIN_SECS,
        )
        .0
    };
    let rows = [
        (
            "exact",
            timed(&|t| builtin.ln_likelihood_full(t)),
            timed(&|t| user.ln_likelihood_full(t)),
            timed(&|t| ss.ln_likelihood_full(t)),
        ),
        (
            "relative-binned",
            timed(&|t| rb_builtin.ln_likelihood_full(t)),
            timed(&|t| rb_user.ln_likelihood_full(t)),
            timed(&|t| rb_ss.ln_likelihood_full(t)),
        ),
    ];
    println!();
    println!(
        "the closed loop written as a user-defined model (examples/user-model-closed-loop.toml) \
         and as a state-space model (examples/state-space.toml) against the built-in model:"
    );
    println!(
        "{:<16} {:>14} {:>12} {:>7} {:>14} {:>7}",
        "ln L", "built-in /s", "user /s", "ratio", "state-space /s", "ratio"
    );
    for (name, b, u, x) in rows {
        println!(
            "{name:<16} {b:>14.1} {u:>12.1} {:>7.3} {x:>14.1} {:>7.3}",
            u / b,
            x / b
        );
    }
}
