//! The exact variance of a gapped run's lowest DFT bins against the `S(f_k)` the likelihood
//! gives them: noise drawn on the fit stretch's DFT grid (the simulator's circular noise) has
//! autocovariance `γ(τ) = (fs/2N) Σ_j S(f_j) e^{2πijτ/N}`, and a run of `N_r` samples tapered
//! by `w` has `E|X_k|² = Σ_τ A(τ) γ(τ) e^{−2πikτ/N_r}` with `A(τ) = Σ_t w_t w_{t+τ}`; the
//! likelihood takes `(fs/2) Σ w² S(f_k)`. Prints, per run, the ratio for the run's bins 3 to 12
//! of both read-outs.
//!
//!   cargo run --release --example gaps_leakage -- examples/gaps.toml 5 5000

use num_complex::Complex64;
use occam::config::Study;
use occam::jobs::prepare::prepare;
use occam::signal::RealFft;
use std::path::Path;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let path = args.get(1).map_or("examples/gaps.toml", String::as_str);
    let n_seeds: u64 = args.get(2).map_or(3, |s| s.parse().expect("N"));
    let first: u64 = args.get(3).map_or(5000, |s| s.parse().expect("FIRST"));
    let base = Study::load(Path::new(path)).expect("study");
    let sys = base.system();
    let taper_s = base
        .analysis
        .gap_taper
        .unwrap_or(occam::likelihood::DEFAULT_GAP_TAPER);
    for s in 0..n_seeds {
        let mut study = base.clone();
        study.seed = base.seed.wrapping_add(first + s);
        let prep = prepare(&study).expect("prepare");
        for e in &prep.dataset.experiments {
            let n = e.n_samples();
            let fs = e.fs;
            let mut fft = RealFft::new(n).unwrap();
            let m = fft.spectrum_len();
            let mut gam = [vec![0.0; n], vec![0.0; n]];
            for c in 0..2 {
                let spec: Vec<Complex64> = (0..m)
                    .map(|j| {
                        let f = j as f64 * fs / n as f64;
                        Complex64::new(fs / 2.0 * sys.noise_csd(f)[c][c].re, 0.0)
                    })
                    .collect();
                fft.inverse(&spec, &mut gam[c]).unwrap();
            }
            for run in e.valid_runs() {
                let nr = run[1] - run[0];
                if nr < 64 {
                    continue;
                }
                let t = ((taper_s * fs).round() as usize).min(nr / 4);
                let mut w = vec![1.0; nr];
                let ramp = |k: usize, len: usize| {
                    0.5 * (1.0 - (std::f64::consts::PI * (k as f64 + 0.5) / len as f64).cos())
                };
                for k in 0..t {
                    w[k] *= ramp(k, t);
                    w[nr - 1 - k] *= ramp(k, t);
                }
                let sw2: f64 = w.iter().map(|x| x * x).sum();
                let mut pad = RealFft::new(2 * nr).unwrap();
                let mut wp = w.clone();
                wp.resize(2 * nr, 0.0);
                let mut ws = vec![Complex64::new(0.0, 0.0); pad.spectrum_len()];
                pad.forward(&wp, &mut ws).unwrap();
                let p: Vec<Complex64> = ws
                    .iter()
                    .map(|z| Complex64::new(z.norm_sqr(), 0.0))
                    .collect();
                let mut a = vec![0.0; 2 * nr];
                pad.inverse(&p, &mut a).unwrap();
                let mut line = format!(
                    "seed {} {} run {:>7.0}–{:<7.0} s ({:>6.0} s):",
                    study.seed,
                    e.name,
                    run[0] as f64 / fs,
                    run[1] as f64 / fs,
                    nr as f64 / fs
                );
                for c in 0..2 {
                    line.push_str(if c == 0 { " o1" } else { " | o12" });
                    for k in 3..=12usize {
                        let mut ek = a[0] * gam[c][0];
                        for tau in 1..nr {
                            ek += 2.0
                                * a[tau]
                                * gam[c][tau]
                                * (2.0 * std::f64::consts::PI * (k * tau) as f64 / nr as f64).cos();
                        }
                        let f = k as f64 * fs / nr as f64;
                        let nominal = fs / 2.0 * sw2 * sys.noise_csd(f)[c][c].re;
                        line.push_str(&format!(" {:.2}", ek / nominal));
                    }
                }
                println!("{line}");
            }
        }
    }
}
