//! The acceleration domain end to end (K14 §III.C, ltp-model.md §7): the a12 oracle on noiseless
//! simulated data, recovery and coverage of the acceleration-domain fit, and its agreement with
//! the closed-loop analysis of the same experiments.

use occam::config::Study;
use occam::experiment::simulate;
use occam::jobs::prepare::{likelihood_of, load_data, truth_of};
use occam::likelihood::{cramer_rao, fisher_exact, fisher_scoring};
use occam::ltp::a12::{a12_kinematic, filter, fpsder_error};
use occam::model::accel::{AccelOptions, Derivative};
use occam::signal::RealFft;
use std::path::Path;

/// A short experiment: guidance sines on x1 and x12 and force trains on both test masses up to
/// 2.3 Hz; actuators with poles, delays and A1 ≠ A2, a read-out delay and cross-talk.
fn study(noise: &str, seed: u64, extra: &str) -> Study {
    let text = format!(
        r#"seed = {seed}
output = "unused"
oms_delay = 0.2
[simulation]
noise = "{noise}"
[simulation.actuators]
tm1 = {{ gain = 1.05, pole = 1.963, delay = 0.03 }}
tm2 = {{ pole = 2.5, delay = 0.01 }}
[[experiment]]
name = "forces"
fs = 10.0
pre_pad = 300.0
post_pad = 900.0
noise_duration = 20000.0
x1 = {{ kind = "sine", freq = 4e-3, amplitude = 1e-6, duration = 750.0 }}
x12 = {{ kind = "sine", freq = 2e-3, amplitude = 1e-7, duration = 1000.0 }}
f1 = {{ kind = "sine_train", gap = 10.0, segments = [{{ freq = 0.05, amplitude = 3e-10, duration = 200.0 }}, {{ freq = 0.9, amplitude = 3e-9, duration = 200.0 }}, {{ freq = 2.3, amplitude = 8e-9, duration = 200.0 }}] }}
f2 = {{ kind = "sine_train", gap = 10.0, segments = [{{ freq = 0.07, amplitude = 3e-10, duration = 200.0 }}, {{ freq = 1.3, amplitude = 3e-9, duration = 200.0 }}, {{ freq = 2.1, amplitude = 8e-9, duration = 200.0 }}] }}
[analysis]
band = [1e-3, 3.0]
[[model]]
kind = "accel"
name = "full"
delay = true
[fit]
model = "full"
{extra}
"#
    );
    Study::from_toml(&text, "accel.toml", Path::new(".")).unwrap()
}

/// `Act(f)·g` applied in the frequency domain (circular, like the simulator).
fn applied(g: &[f64], fs: f64, act: impl Fn(f64) -> num_complex::Complex64) -> Vec<f64> {
    let mut fft = RealFft::new(g.len()).unwrap();
    filter(g, fs, &mut fft, act).unwrap()
}

/// The oracle of ltp-model.md §7.2: on noiseless data at the true parameters the differential
/// acceleration from the read-outs equals the force difference the actuators applied — exactly
/// with the exact second derivative, and up to the stencil's own known error with LTPDA's
/// five-point stencil.
#[test]
fn a12_from_noiseless_read_outs_is_the_applied_force() {
    let s = study("none", 1, "");
    let sim = simulate(&s.simulation_plan()).unwrap();
    let e = &sim.dataset.experiments[0];
    let sys = s.system();
    let fs = e.fs;
    let g1 = e.channel("g1").unwrap();
    let g2 = e.channel("g2").unwrap();
    let f_applied: Vec<f64> = {
        let a1 = applied(g1, fs, |f| sys.actuator_response(f)[0]);
        let a2 = applied(g2, fs, |f| sys.actuator_response(f)[1]);
        a2.iter().zip(&a1).map(|(x, y)| x - y).collect()
    };
    let peak = f_applied.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let t = s.truth;
    let opts = AccelOptions {
        d21: t.d21,
        tau_ifo: s.oms_delay,
        derivative: Derivative::Exact,
        ..Default::default()
    };
    let exact = a12_kinematic(&e.o[0], &e.o[1], fs, t.w1sq, t.w2sq, &opts).unwrap();
    let worst = exact
        .iter()
        .zip(&f_applied)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    eprintln!(
        "exact derivative: max |a12 − F_applied| = {:.2e} of the peak {peak:.2e}",
        worst / peak
    );
    assert!(worst < 1e-9 * peak, "{:.2e}", worst / peak);

    let fps = AccelOptions {
        derivative: Derivative::Fpsder,
        ..opts
    };
    let a = a12_kinematic(&e.o[0], &e.o[1], fs, t.w1sq, t.w2sq, &fps).unwrap();
    // x12 as the stencil sees it, to predict its error
    let adv = |o: &[f64]| applied(o, fs, |f| occam::lti::delay(-s.oms_delay, f));
    let (x1, o12) = (adv(&e.o[0]), adv(&e.o[1]));
    let x12: Vec<f64> = o12.iter().zip(&x1).map(|(a, b)| a - t.d21 * b).collect();
    let err = fpsder_error(&x12, fs, fps.fpsder_m).unwrap();
    let n = a.len();
    let raw = (0..n)
        .map(|k| (a[k] - f_applied[k]).abs())
        .fold(0.0, f64::max);
    let corrected = (2..n - 2)
        .map(|k| (a[k] - f_applied[k] - err[k]).abs())
        .fold(0.0, f64::max);
    eprintln!(
        "fpsder (m = 2/7): max |a12 − F_applied| = {:.2e} of the peak; after its known response: {:.2e}",
        raw / peak,
        corrected / peak
    );
    assert!(
        raw > 1e-3 * peak,
        "the stencil's error at 2.3 Hz is not small"
    );
    assert!(corrected < 1e-9 * peak, "{:.2e}", corrected / peak);
}

/// The model's residual at the truth is zero on noiseless data.
#[test]
fn model_residual_vanishes_at_the_truth_on_noiseless_data() {
    let s = study("none", 1, "");
    let mut sim = simulate(&s.simulation_plan()).unwrap();
    // the residual noise comes from a noisy twin's noise-only stretch
    let noisy = simulate(&study("circular", 1, "").simulation_plan()).unwrap();
    let (e, n) = (
        &mut sim.dataset.experiments[0],
        &noisy.dataset.experiments[0],
    );
    e.noise = n.noise.clone();
    e.noise_extra = n.noise_extra.clone();
    let lik = likelihood_of(&s, s.fit_model.model, &sim.dataset).unwrap();
    let truth: Vec<f64> = truth_of(&s, s.fit_model.model, &sim.dataset)
        .unwrap()
        .iter()
        .map(|v| v.unwrap())
        .collect();
    let e = &lik.spectra()[0];
    let mut worst: f64 = 0.0;
    let mut scale: f64 = 0.0;
    lik.visit_residuals(e, &truth, |_, r, _| worst = worst.max(r[0].norm()));
    for k in 0..e.len() {
        scale = scale.max(e.data_at(k)[1].norm() * 1e-3);
    }
    let mut off = truth.clone();
    off[4] *= 1.01;
    let mut moved: f64 = 0.0;
    lik.visit_residuals(e, &off, |_, r, _| moved = moved.max(r[0].norm()));
    eprintln!("max |r| at the truth {worst:.2e}, with f_o1 1 % off {moved:.2e}");
    assert!(worst < 1e-9 * moved, "{worst:e} vs {moved:e}");
}

/// MAP pulls `(MAP − truth)/σ_Fisher` of the full asymmetric model over seeds: the truth is
/// recovered and the Fisher intervals cover it at their rate (the Whittle likelihood with the
/// residual PSD from the noise-only stretch).
#[test]
fn acceleration_fit_recovers_the_truth_and_covers_it() {
    use rayon::prelude::*;
    // per data set, (MAP − truth)ᵀ F (MAP − truth): χ² with 8 degrees of freedom when the
    // Fisher errors are right, independent across data sets (the 1σ rate of the 8 correlated
    // pulls of one data set is not). The data sets run in parallel (each depends on its seed
    // only); the statistics are gathered in seed order.
    let seeds = 64u64;
    let per_seed: Vec<(f64, Vec<f64>)> = (0..seeds)
        .into_par_iter()
        .map(|seed| {
            let s = study("circular", 100 + seed, "");
            let (data, _) = load_data(&s).unwrap();
            let mi = s.fit_model.model;
            let lik = likelihood_of(&s, mi, &data).unwrap();
            let truth: Vec<f64> = truth_of(&s, mi, &data)
                .unwrap()
                .iter()
                .map(|v| v.unwrap())
                .collect();
            let free: Vec<usize> = (0..truth.len()).collect();
            let map = fisher_scoring(&lik, &truth, &free, 1e-4, 100).unwrap();
            let fisher = fisher_exact(&lik, &map.theta, &free);
            let sd = cramer_rao(&fisher).unwrap();
            let delta = nalgebra::DVector::from_iterator(
                truth.len(),
                map.theta.iter().zip(&truth).map(|(m, t)| m - t),
            );
            let names = lik.model().param_names();
            let pulls: Vec<f64> = (0..truth.len())
                .map(|i| (map.theta[i] - truth[i]) / sd[i])
                .collect();
            for (i, p) in pulls.iter().enumerate() {
                if p.abs() > 3.0 {
                    eprintln!("seed {seed}: pull of {} is {p:+.2}", names[i]);
                }
            }
            if seed == 0 {
                for i in 0..truth.len() {
                    eprintln!(
                        "{:>7} truth {:+.6e} MAP {:+.6e} ± {:.2e}",
                        names[i], truth[i], map.theta[i], sd[i]
                    );
                }
            }
            (delta.dot(&(&fisher * &delta)), pulls)
        })
        .collect();
    let d2: Vec<f64> = per_seed.iter().map(|(d, _)| *d).collect();
    let pulls: Vec<f64> = per_seed.iter().flat_map(|(_, p)| p.clone()).collect();
    let inside = pulls.iter().filter(|p| p.abs() < 1.0).count();
    let total = pulls.len();
    let worst = pulls.iter().fold(0.0f64, |w, p| w.max(p.abs()));
    let rate = inside as f64 / total as f64;
    let k = 8.0;
    let mean_d2 = d2.iter().sum::<f64>() / d2.len() as f64;
    // χ²_8 has mean 8 and variance 16: the mean of 64 has sd 0.5, a 3 sd band [6.5, 9.5];
    // errors 20 % too small (F ×1/0.64) put it at 12.5, 20 % too large (F ×1/1.44) at 5.6
    let band = 3.0 * (2.0 * k / d2.len() as f64).sqrt();
    eprintln!(
        "±1σ coverage over {seeds} seeds × 8 parameters: {rate:.3} (nominal 0.683); largest |pull| {worst:.2}; mean (MAP − truth)ᵀF(MAP − truth) {mean_d2:.2} (χ²_8: 8 ± {band:.2})"
    );
    assert!((mean_d2 - k).abs() < band, "{mean_d2}");
    assert!(
        (mean_d2 / 0.64 - k).abs() > band && (mean_d2 / 1.44 - k).abs() > band,
        "no power: errors 20 % off would give {} or {}",
        mean_d2 / 0.64,
        mean_d2 / 1.44
    );
    assert!((rate - 0.683).abs() < 0.1, "{rate}");
    assert!(worst < 5.0, "{worst}");
}

/// The closed loop (o against the guidance injections) and the acceleration domain (o against
/// the commanded forces) measure the same stiffnesses on the same experiments.
#[test]
fn closed_loop_and_acceleration_domain_agree_on_the_stiffnesses() {
    let text = r#"seed = 77
output = "unused"
[simulation]
noise = "circular"
[[experiment]]
name = "guidance"
fs = 10.0
pre_pad = 2000.0
post_pad = 3000.0
noise_duration = 6000.0
x1 = { kind = "sine", freq = 2e-3, amplitude = 1e-6, duration = 3000.0 }
x12 = { kind = "sine", freq = 1e-3, amplitude = 1e-6, duration = 3000.0 }
[analysis]
band = [3e-4, 1.0]
[[model]]
kind = "accel"
name = "gain"
pole = false
[[model]]
kind = "tied"
name = "sym-gain"
of = "gain"
tie = { a2 = "a1" }
[fit]
model = "ltp"
free = ["w1sq", "w2sq", "a_sus"]
fixed = { dt1 = 0.2, dt2 = 0.2, a_df = 0.82, d21 = 4e-4 }
"#;
    let s = Study::from_toml(text, "consistency.toml", Path::new(".")).unwrap();
    let (data, _) = load_data(&s).unwrap();
    let fit = |mi: usize, start: Vec<f64>, free: Vec<usize>| {
        let lik = likelihood_of(&s, mi, &data).unwrap();
        let map = fisher_scoring(&lik, &start, &free, 1e-4, 100).unwrap();
        let sd = cramer_rao(&fisher_exact(&lik, &map.theta, &free)).unwrap();
        let names = lik.model().param_names().to_vec();
        let get = |n: &str| {
            let i = names.iter().position(|p| p == n).unwrap();
            let k = free.iter().position(|&f| f == i).unwrap();
            (map.theta[i], sd[k])
        };
        (get("w1sq"), get("w2sq"))
    };
    let t = s.truth;
    let ltp = s.models.index("ltp").unwrap();
    let cl = fit(ltp, t.to_array().to_vec(), vec![0, 1, 5]);
    let acc = s.models.index("sym-gain").unwrap();
    let ac = fit(acc, vec![t.w1sq, t.w2sq, t.a_sus], vec![0, 1, 2]);
    for (name, (a, sa), (b, sb)) in [("w1sq", cl.0, ac.0), ("w2sq", cl.1, ac.1)] {
        let z = (a - b) / (sa * sa + sb * sb).sqrt();
        eprintln!(
            "{name}: closed loop {a:+.5e} ± {sa:.1e}, acceleration {b:+.5e} ± {sb:.1e}: {z:+.2}σ apart"
        );
        assert!(z.abs() < 3.0, "{name}: {z}");
    }
}

/// A noise-only stretch too short for the band's lower edge is warned about for the
/// acceleration domain (its residual is a difference of correlated channels), not for the
/// closed loop.
#[test]
fn a_short_noise_stretch_is_warned_about() {
    use occam::jobs::prepare::model_warnings;
    let long = study("circular", 5, "");
    let (data, _) = load_data(&long).unwrap();
    assert!(model_warnings(&long, long.fit_model.model, &data).is_empty());
    // the same study with 3000 s of noise: the Welch estimate starts at 2 mHz, the band at 1 mHz
    let mut short = long.clone();
    for e in &mut short.experiments {
        e.noise_duration = 3000.0;
    }
    let (data, _) = load_data(&short).unwrap();
    let w = model_warnings(&short, short.fit_model.model, &data);
    assert!(
        w.iter()
            .any(|m| m.contains("noise_duration at least") && m.contains("`forces`")),
        "{w:?}"
    );
    let ltp = short.models.index("ltp").unwrap();
    let w = model_warnings(&short, ltp, &data);
    assert!(!w.iter().any(|m| m.contains("noise_duration")), "{w:?}");
}

/// The closed loop fitted to experiments with force injections is warned about (it does not
/// model their response); the acceleration domain is not.
#[test]
fn closed_loop_on_force_injections_is_warned_about() {
    use occam::jobs::prepare::model_warnings;
    let s = study("circular", 6, "");
    let (data, _) = load_data(&s).unwrap();
    let ltp = s.models.index("ltp").unwrap();
    let w = model_warnings(&s, ltp, &data);
    assert!(
        w.iter()
            .any(|m| m.contains("force injections (f1, f2)") && m.contains("`forces`")),
        "{w:?}"
    );
    assert!(model_warnings(&s, s.fit_model.model, &data).is_empty());
}
