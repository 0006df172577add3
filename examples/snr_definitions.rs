//! Which SNR definition maps K14's numbers onto the regimes occam finds (issue 25, item 2).
//!
//!     cargo run --release --example snr_definitions
//!
//! K14 names its regimes by an SNR it does not define: Table II's competitive regime at
//! "SNR ≈ 5", Fig. 5's threshold at "SNR ≈ 21", Fig. 6 at "SNR = 28". occam finds them at
//! ρ_opt = √⟨h|h⟩ ≈ 450 (`examples/guidance-delays.toml`, B_XY ≈ 0.3), ≈ 464 (the pole wins
//! with positive evidence, `examples/design-snr.toml`) and 28 (`examples/design-frequency.toml`,
//! the 50 mHz optimum, x1 there); `guidance-delays-k14.toml` is Table II's study with the noise
//! and amplitudes calibrated to Table I (`examples/tn3045-k14.toml`), at the ρ_opt of today's
//! competitive regime, which its sweep finds unchanged (docs: "What was measured"). For each
//! study at that ρ_opt this prints candidate
//! definitions, each computed from the study's own injections and noise model:
//! - ρ_opt, √2·ρ_opt (LTPDA's `stnr`) and 20·log10 ρ_opt (dB);
//! - per sinusoid: ρ_opt of each sine segment alone (the largest and the root-mean-square);
//! - in the time domain: each segment's peak response over the noise RMS of the same read-out
//!   in the band (the largest over segments and read-outs), as "amplitude over noise" is
//!   often quoted.

use occam::config::Study;
use occam::experiment::options::NoiseSynthesis;
use occam::experiment::{ExperimentDesign, SineSegment, Waveform, optimal_snr};
use std::path::Path;

/// One sine segment of an experiment's design alone, every other injection off.
fn one_segment(d: &ExperimentDesign, on_x1: bool, s: &SineSegment) -> ExperimentDesign {
    let mut e = d.clone();
    e.x1 = Waveform::None;
    e.x12 = Waveform::None;
    let w = Waveform::Sine(*s);
    if on_x1 {
        e.x1 = w;
    } else {
        e.x12 = w;
    }
    e
}

/// The noise RMS of read-outs o1, o12 over `band`, from the noise model's one-sided PSDs.
fn noise_rms(study: &Study, band: [f64; 2]) -> [f64; 2] {
    let sys = study.system();
    let n = 20_000;
    let (l0, l1) = (band[0].ln(), band[1].ln());
    let mut acc = [0.0; 2];
    for i in 0..n {
        // log-spaced midpoint rule: ∫ S df = ∫ S f d(ln f)
        let x = l0 + (i as f64 + 0.5) * (l1 - l0) / n as f64;
        let f = x.exp();
        let s = sys.noise_csd(f);
        let w = f * (l1 - l0) / n as f64;
        acc[0] += s[0][0].re * w;
        acc[1] += s[1][1].re * w;
    }
    [acc[0].sqrt(), acc[1].sqrt()]
}

/// Peak |o1|, |o12| of the noiseless response to `design`.
fn peak_response(
    study: &Study,
    design: ExperimentDesign,
) -> Result<[f64; 2], Box<dyn std::error::Error>> {
    let mut plan = study.simulation_plan();
    plan.noise = NoiseSynthesis::None;
    plan.target_snr = None;
    plan.experiments = vec![design];
    let sim = occam::experiment::simulate(&plan)?;
    let e = &sim.dataset.experiments[0];
    let peak = |c: &str| {
        e.channel(c)
            .map_or(0.0, |x| x.iter().fold(0.0f64, |m, v| m.max(v.abs())))
    };
    Ok([peak("o1"), peak("o12")])
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let cases = [
        (
            "guidance-delays.toml",
            450.0,
            5.0,
            "Table II, competitive regime",
        ),
        (
            "guidance-delays-k14.toml",
            450.0,
            5.0,
            "Table II, competitive; noise calibrated to Table I",
        ),
        ("design-snr.toml", 464.0, 21.0, "Fig. 5, threshold"),
        ("design-frequency.toml", 28.0, 28.0, "Fig. 6"),
    ];
    println!(
        "| study | K14 | ρ_opt | √2·ρ_opt | dB | per sinusoid: largest | per sinusoid: rms | peak ÷ noise RMS: largest |\n| --- | --- | --- | --- | --- | --- | --- | --- |"
    );
    for (file, rho, k14, what) in cases {
        let mut study = Study::load(&root.join("examples").join(file))?;
        study.simulation.target_snr = Some(rho);
        let sys = study.system();
        let band = study.simulation.snr_band;
        // the one factor the simulator scales every amplitude by to reach ρ_opt
        let written: f64 = study
            .experiments
            .iter()
            .map(|d| optimal_snr(&sys, d, band).map(|r| r * r))
            .sum::<Result<f64, _>>()?
            .sqrt();
        let scale = rho / written;
        let rms = noise_rms(&study, band);
        let mut per_sine = Vec::new();
        let mut td: f64 = 0.0;
        for d in &study.experiments {
            for (on_x1, w) in [(true, &d.x1), (false, &d.x12)] {
                for s in w.segments() {
                    let one = one_segment(d, on_x1, s);
                    per_sine.push(optimal_snr(&sys, &one, band)? * scale);
                    let p = peak_response(&study, one)?;
                    for c in 0..2 {
                        td = td.max(p[c] * scale / rms[c]);
                    }
                }
            }
        }
        let largest = per_sine.iter().fold(0.0f64, |m, v| m.max(*v));
        let rms_sine = (per_sine.iter().map(|v| v * v).sum::<f64>() / per_sine.len() as f64).sqrt();
        println!(
            "| {file} ({what}; {} sinusoids) | {k14} | {rho:.0} | {:.0} | {:.1} | {largest:.1} | {rms_sine:.1} | {td:.2} |",
            per_sine.len(),
            2f64.sqrt() * rho,
            20.0 * rho.log10(),
        );
    }
    Ok(())
}
