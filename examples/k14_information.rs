//! Where Table I's information comes from, and the Cramér–Rao bounds against K14's.
//!
//!     cargo run --release --example k14_information -- [STUDY.toml] [welch] [delays] [needs] [calibrate]
//!
//! For the study (default `examples/tn3045.toml`: K14's two experiments and Table I's truth)
//! it computes the Fisher matrix of all seven parameters at the truth — with the exact noise
//! CSD of the study's noise model (a Cramér–Rao bound of the design and the noise model, the
//! same for every realisation), or with `welch`, the Welch estimate of the simulated
//! noise-only stretch as `occam fit` does — and prints σ against K14 Table I's and the LTPDA
//! training's expected bounds (ltp-model.md §6.2), then the information split by experiment,
//! by injection segment and by frequency decade ([`occam::likelihood::information`]).
//!
//! `delays` tries Δt1 elsewhere in the loop (a read-out delay of o1, a thruster actuation
//! delay) instead of on the x1 injection; `needs` says what the x1 sequence would need for
//! K14's σ(Δt1) = 5e−5 s (every amplitude scaled, or one more segment at 0.1–1 Hz).
//!
//! `calibrate` fits the inputs K14 did not publish (ltp-model.md §10) that a study file sets —
//! the `[noise]` levels and readout corner, `amplitude_scale` of the x1 experiment (within its
//! digitisation's ±5 %) and of the x12 one (its ladder is inferred) — to the published bounds:
//! the sensitivity `∂ ln σ_p / ∂ ln k` of every bound to each input, then a damped
//! Gauss–Newton fit of `ln(σ_p / σ_K14)` and `ln(σ_p / σ_training)` over the inputs'
//! logarithms, each within a stated range, with a weak pull of each towards today's value.
//! `examples/tn3045-k14.toml` holds its result.

use nalgebra::{DMatrix, DVector};
use occam::config::Study;
use occam::density::LogDensity;
use occam::experiment::{SineSegment, Waveform};
use occam::jobs::prepare::{injection_lines, prepare};
use occam::likelihood::NoiseSource;
use occam::likelihood::information::Information;
use std::path::Path;

/// K14 Table I's σ and the LTPDA training's expected CRB (ltp-model.md §6.2), by parameter.
const K14: [(&str, f64, Option<f64>); 7] = [
    ("w1sq", 2e-10, Some(1.7e-10)),
    ("w2sq", 2e-10, Some(1.6e-10)),
    ("dt1", 5e-5, None),
    ("dt2", 2e-4, None),
    ("a_df", 2.5e-4, Some(2e-4)),
    ("a_sus", 3e-6, Some(3.0e-6)),
    ("d21", 1e-7, Some(1.1e-7)),
];

/// One input K14 did not publish: its name, how far it may go (a factor on today's value)
/// and how it is set.
struct Knob {
    name: &'static str,
    range: (f64, f64),
    set: fn(&mut Study, f64),
}

/// Scales every amplitude injected on x1 (`on_x1`) or on x12, in every experiment.
fn scale_experiments(s: &mut Study, on_x1: bool, x: f64) {
    for e in &mut s.experiments {
        let w = if on_x1 { &mut e.x1 } else { &mut e.x12 };
        *w = w.scaled(x);
    }
}

/// The inputs the fit may change, each a field a study file sets: the five noise levels and
/// the readout corner of `[noise]`, and `amplitude_scale` of each experiment — x1's within
/// the ±5 % of its digitisation (ltp-model.md §6.1), x12's ladder (inferred, not public) by
/// up to 5× either way.
const KNOBS: [Knob; 7] = [
    Knob {
        name: "readout_o1",
        range: (0.01, 100.0),
        set: |s, x| s.noise.readout_o1 *= x,
    },
    Knob {
        name: "readout_o12",
        range: (0.01, 100.0),
        set: |s, x| s.noise.readout_o12 *= x,
    },
    Knob {
        name: "readout_corner",
        range: (0.1, 3.0),
        set: |s, x| s.noise.readout_corner *= x,
    },
    Knob {
        name: "thruster_force",
        range: (0.01, 100.0),
        set: |s, x| s.noise.thruster_force *= x,
    },
    Knob {
        name: "tm_accel",
        range: (0.01, 100.0),
        set: |s, x| s.noise.tm_accel *= x,
    },
    Knob {
        name: "x1 amplitude_scale",
        range: (0.95, 1.05),
        set: |s, x| scale_experiments(s, true, x),
    },
    Knob {
        name: "x12 amplitude_scale",
        range: (0.2, 5.0),
        set: |s, x| scale_experiments(s, false, x),
    },
];

/// Weight of the pull of each input's `ln k` towards today's value (0): it settles the
/// directions the bounds cannot tell apart (the TM noise against the x12 amplitudes) by the
/// smallest change, and costs what a 10 % miss of one bound costs for a factor e ≈ 2.7.
const STAY: f64 = 0.1;

/// The information of `study`'s `[fit]` parameters at its truth.
fn information(study: &Study) -> Result<Information, Box<dyn std::error::Error>> {
    let prep = prepare(study)?;
    let lik = &prep.likelihood;
    let names = lik.param_names().to_vec();
    let lines = injection_lines(study, lik);
    let th = study.truth.to_array();
    Information::of(lik, &th, &study.fit_model.free, &names, &lines)
        .ok_or_else(|| "the Fisher matrix at the truth is singular".into())
}

fn sigma_of(info: &Information, name: &str) -> f64 {
    let i = info
        .params
        .iter()
        .position(|p| p == name)
        .expect("all seven are free");
    info.sigma[i]
}

/// The fit's residuals: `ln(σ_p / σ_K14)` and, where the training gives one, `ln(σ_p /
/// σ_training)` for every parameter but Δt1 (see [`calibrate`]), then `STAY · ln k` per input.
fn residuals(info: &Information, x: &[f64]) -> Vec<f64> {
    let mut r = Vec::new();
    for (n, k, t) in K14.iter().filter(|(n, _, _)| *n != "dt1") {
        let s = sigma_of(info, n);
        r.push((s / k).ln());
        if let Some(t) = t {
            r.push((s / t).ln());
        }
    }
    r.extend(x.iter().map(|v| STAY * v));
    r
}

/// `ln σ` of the seven parameters, in the order of [`K14`].
fn ln_sigmas(info: &Information) -> Vec<f64> {
    K14.iter().map(|(n, _, _)| sigma_of(info, n).ln()).collect()
}

/// The central-difference Jacobian of `f` at `x` (step `h` in every coordinate).
fn central_jacobian(
    f: impl Fn(&[f64]) -> Result<Vec<f64>, Box<dyn std::error::Error>>,
    x: &[f64],
    h: f64,
) -> Result<DMatrix<f64>, Box<dyn std::error::Error>> {
    let mut cols = Vec::with_capacity(x.len());
    for k in 0..x.len() {
        let (mut up, mut dn) = (x.to_vec(), x.to_vec());
        up[k] += h;
        dn[k] -= h;
        let (a, b) = (f(&up)?, f(&dn)?);
        cols.push(DVector::from_iterator(
            a.len(),
            a.iter().zip(&b).map(|(a, b)| (a - b) / (2.0 * h)),
        ));
    }
    Ok(DMatrix::from_columns(&cols))
}

fn with_knobs(base: &Study, x: &[f64]) -> Study {
    let mut s = base.clone();
    for (k, v) in KNOBS.iter().zip(x) {
        (k.set)(&mut s, v.exp());
    }
    s
}

/// The sensitivity matrix and a damped Gauss–Newton (Levenberg–Marquardt) fit of the bounds'
/// logarithms to K14's and the training's over the inputs' logarithms, within their ranges.
///
/// Δt1 is left out of the fit: its bound and A_df's both come from o1 at the x1 segments,
/// where the thruster noise dominates, so every noise input moves them together
/// (sensitivities +1.00 and +1.00) and no amplitude within the digitisation separates them;
/// their ratio σ(Δt1)/σ(A_df) is fixed by the x1 sequence's frequencies (1.9 here, 0.2 in
/// K14). Fitting Δt1 too would trade A_df's match for half of Δt1's miss.
fn calibrate(base: &Study) -> Result<(), Box<dyn std::error::Error>> {
    let nk = KNOBS.len();
    let h = 0.05;
    let mut x = vec![0.0; nk];
    let misfit = |x: &[f64]| -> Result<Vec<f64>, Box<dyn std::error::Error>> {
        Ok(residuals(&information(&with_knobs(base, x))?, x))
    };
    // the sensitivities ∂ ln σ / ∂ ln k of all seven bounds at today's inputs
    println!("\nSensitivity ∂ ln σ / ∂ ln k at today's inputs:\n");
    println!(
        "| parameter | {} |\n|{}",
        KNOBS.map(|k| k.name).join(" | "),
        " --- |".repeat(nk + 1)
    );
    let sens = central_jacobian(
        |x| Ok(ln_sigmas(&information(&with_knobs(base, x))?)),
        &x,
        h,
    )?;
    for (p, (n, _, _)) in K14.iter().enumerate() {
        let row: Vec<String> = (0..nk).map(|k| format!("{:+.2}", sens[(p, k)])).collect();
        println!("| {n} | {} |", row.join(" | "));
    }
    let mut r = DVector::from_vec(misfit(&x)?);
    let mut lambda = 1e-2;
    println!();
    for it in 0..40 {
        let j = central_jacobian(misfit, &x, h)?;
        let jt = j.transpose();
        let mut a = &jt * &j;
        for k in 0..nk {
            a[(k, k)] *= 1.0 + lambda;
        }
        let Some(step) = a.lu().solve(&(-(&jt * &r))) else {
            break;
        };
        let cand: Vec<f64> = (0..nk)
            .map(|k| (x[k] + step[k]).clamp(KNOBS[k].range.0.ln(), KNOBS[k].range.1.ln()))
            .collect();
        let rc = DVector::from_vec(misfit(&cand)?);
        if rc.norm() < r.norm() {
            let gain = r.norm() - rc.norm();
            x = cand;
            r = rc;
            lambda = (lambda / 3.0).max(1e-6);
            println!("iteration {it}: cost ½|r|² {:.5}", 0.5 * r.norm_squared());
            if gain < 1e-6 {
                break;
            }
        } else {
            lambda *= 10.0;
            if lambda > 1e6 {
                break;
            }
        }
    }
    println!(
        "\nCalibrated inputs (factor on today's value; the fit's residuals are ln(σ/σ_K14) and \
         ln(σ/σ_training) of the six parameters but Δt1, and {STAY}·ln(factor) per input):\n\n\
         | input | factor | range |\n| --- | --- | --- |"
    );
    for (k, v) in KNOBS.iter().zip(&x) {
        println!(
            "| {} | {:.4} | {}–{} |",
            k.name,
            v.exp(),
            k.range.0,
            k.range.1
        );
    }
    let s = with_knobs(base, &x);
    let n = &s.noise;
    println!(
        "\nAs study-file inputs:\n\n[noise]\nreadout_o1 = {:.3e}\nreadout_o12 = {:.3e}\n\
         readout_corner = {:.3e}\nthruster_force = {:.3e}\ntm_accel = {:.3e}\n\
         x1 experiments: amplitude_scale = {:.3}; x12 experiments: amplitude_scale = {:.3}",
        n.readout_o1,
        n.readout_o12,
        n.readout_corner,
        n.thruster_force,
        n.tm_accel,
        x[5].exp(),
        x[6].exp()
    );
    println!("\nWith them:\n");
    table(&information(&s)?);
    Ok(())
}

/// What the x1 sequence would need for K14's σ(Δt1) = 5e−5 s, with the study's noise: (a)
/// one factor on all its amplitudes (today's σ(Δt1) ÷ 5e−5), (b) one more 1200 s
/// segment at a higher frequency, of the amplitude that brings σ(Δt1) to 5e−5, found by
/// bisection on its logarithm — each with what it does to A_df's bound.
fn x1_needs(base: &Study) -> Result<(), Box<dyn std::error::Error>> {
    let target = 5e-5;
    let info = information(base)?;
    let (dt1, adf) = (sigma_of(&info, "dt1"), sigma_of(&info, "a_df"));
    println!(
        "\nWhat x1 would need for σ(Δt1) = {target:.0e} s (today {dt1:.3e} s, A_df {adf:.3e}):\n\n\
         | change to the x1 sequence | σ(Δt1) | σ(A_df) | σ(A_df) ÷ K14 |\n| --- | --- | --- | --- |"
    );
    // the x1 experiment alone measures Δt1 and A_df, so σ ∝ 1/amplitude nearly (not exactly:
    // the stiffnesses they correlate with are measured by x12 too): computed, not assumed
    let k = dt1 / target;
    let mut scaled = base.clone();
    scale_experiments(&mut scaled, true, k);
    let i = information(&scaled)?;
    let a = sigma_of(&i, "a_df");
    println!(
        "| every amplitude ×{k:.1} | {:.2e} | {a:.2e} | {:.2} |",
        sigma_of(&i, "dt1"),
        a / 2.5e-4
    );
    if !base
        .experiments
        .iter()
        .any(|e| matches!(e.x1, Waveform::SineTrain { .. }))
    {
        return Err("`needs` adds a segment to a sine train on x1, and the study has none".into());
    }
    for f in [0.1, 0.2, 0.4, 1.0] {
        let with = |a: f64| -> Result<Information, Box<dyn std::error::Error>> {
            let mut s = base.clone();
            for e in &mut s.experiments {
                if let Waveform::SineTrain { segments, .. } = &mut e.x1 {
                    segments.push(SineSegment {
                        freq: f,
                        amplitude: a,
                        duration: 1200.0,
                    });
                }
            }
            information(&s)
        };
        let (mut lo, mut hi) = (1e-10f64.ln(), 1e-4f64.ln());
        if sigma_of(&with(hi.exp())?, "dt1") > target {
            println!("| one more segment at {f} Hz | > {target:.0e} even at 100 µm | – | – |");
            continue;
        }
        for _ in 0..40 {
            let mid = 0.5 * (lo + hi);
            if sigma_of(&with(mid.exp())?, "dt1") > target {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let i = with(hi.exp())?;
        let a = sigma_of(&i, "a_df");
        println!(
            "| one more segment at {f} Hz, {:.3e} m | {:.2e} | {a:.2e} | {:.2} |",
            hi.exp(),
            sigma_of(&i, "dt1"),
            a / 2.5e-4
        );
    }
    Ok(())
}

/// Δt1 elsewhere in the loop: `examples/user-model-closed-loop.toml` (the built-in loop
/// written out) with Δt1 moved from the x1 injection into the loop — (a) as a read-out delay
/// of o1 (`o1 = e^{−sΔt1} x1`, seen by the drag-free controller and in the output), (b) as a
/// delay of the thruster actuation — each with the noise model CSD. If K14's Δt1 acted in the
/// loop, the loop's response near its bandwidth would measure it too.
fn delay_hypotheses(root: &Path) -> Result<(), Box<dyn std::error::Error>> {
    let path = root.join("examples/user-model-closed-loop.toml");
    let text = std::fs::read_to_string(&path)?;
    let edit = |t: &str, from: &str, to: &str| -> Result<String, Box<dyn std::error::Error>> {
        if !t.contains(from) {
            return Err(format!("{}: no `{from}` to edit", path.display()).into());
        }
        Ok(t.replace(from, to))
    };
    // the loop term of P = D + M A K E S: the drag-free command sees e^{−sΔt1} x1
    let in_loop = edit(&text, "(k1 + k2*(d21*e2))", "(k1*t1 + k2*(d21*e2))")?;
    // (a) the guidance is not delayed, the o1 output is
    let readout = edit(
        &edit(
            &edit(&in_loop, "a = \"k1*t1*inv\"", "a = \"k1*inv\"")?,
            "h11 = \"x00\"",
            "h11 = \"t1*x00\"",
        )?,
        "h12 = \"x01\"",
        "h12 = \"t1*x01\"",
    )?;
    // (b) the applied thrust is delayed (the forcing M A T K i keeps k1 t1), the output not
    let actuation = in_loop;
    println!(
        "\nΔt1 in the loop instead of on the x1 injection (noise model CSD):\n\n\
         | Δt1 acts as | σ(Δt1) | ÷ K14 | σ(A_df) | ÷ K14 |\n| --- | --- | --- | --- | --- |"
    );
    for (what, t) in [
        (
            "a delay of the x1 injection (K14 §III.B; today's model)",
            text.clone(),
        ),
        ("a read-out delay of o1, inside the drag-free loop", readout),
        ("a delay of the thruster actuation", actuation),
    ] {
        let mut study = Study::from_toml(&t, &path.display().to_string(), path.parent().unwrap())?;
        study.analysis.noise = NoiseSource::Model;
        let info = information(&study)?;
        let (d, a) = (sigma_of(&info, "dt1"), sigma_of(&info, "a_df"));
        println!(
            "| {what} | {d:.3e} | {:.2} | {a:.3e} | {:.2} |",
            d / 5e-5,
            a / 2.5e-4
        );
    }
    Ok(())
}

fn table(info: &Information) {
    println!(
        "| parameter | σ | K14 σ | σ ÷ K14 | training CRB | σ ÷ training |\n| --- | --- | --- | --- | --- | --- |"
    );
    for (p, s) in info.params.iter().zip(&info.sigma) {
        let Some((_, k, t)) = K14.iter().find(|(n, _, _)| n == p) else {
            continue;
        };
        let tr = t.map_or("– | –".to_string(), |t| {
            format!("{t:.2e} | {:.2}", s / t)
        });
        println!("| {p} | {s:.3e} | {k:.1e} | {:.2} | {tr} |", s / k);
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let path = args
        .iter()
        .find(|a| a.ends_with(".toml"))
        .map(Into::into)
        .unwrap_or_else(|| root.join("examples/tn3045.toml"));
    let welch = args.iter().any(|a| a == "welch");
    let mut study = Study::load(&path)?;
    if !welch {
        study.analysis.noise = NoiseSource::Model;
    }
    let info = information(&study)?;
    println!(
        "{}: noise {}\n",
        path.display(),
        if welch {
            "Welch estimate of the simulated noise-only stretch"
        } else {
            "model CSD"
        }
    );
    table(&info);
    println!("\n{}", info.markdown());
    if args.iter().any(|a| a == "delays") {
        delay_hypotheses(root)?;
    }
    if args.iter().any(|a| a == "needs") {
        x1_needs(&study)?;
    }
    if args.iter().any(|a| a == "calibrate") {
        calibrate(&study)?;
    }
    Ok(())
}
