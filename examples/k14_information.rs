//! Where Table I's information comes from, and the Cramér–Rao bounds against K14's.
//!
//!     cargo run --release --example k14_information -- [STUDY.toml] [welch] [calibrate]
//!
//! For the study (default `examples/tn3045.toml`: K14's two experiments and Table I's truth)
//! it computes the Fisher matrix of all seven parameters at the truth — with the exact noise
//! CSD of the study's noise model (a Cramér–Rao bound of the design and the noise model, the
//! same for every realisation), or with `welch`, the Welch estimate of the simulated
//! noise-only stretch as `occam fit` does — and prints σ against K14 Table I's and the LTPDA
//! training's expected bounds (ltp-model.md §6.2), then the information split by experiment,
//! by injection segment and by frequency decade ([`occam::likelihood::information`]).
//!
//! With `calibrate` it then asks which of the inputs K14 did not publish (ltp-model.md §10)
//! could bring the bounds to K14's: the sensitivity `∂ ln σ_p / ∂ ln k` of every bound to
//! each input `k` (noise levels, the readout corner, the inferred frequencies of x1's last
//! three segments, the x12 ladder's amplitude), and a damped Gauss–Newton fit of
//! `ln(σ_p / σ_K14)` over them, each input held within a stated range.

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

/// One input K14 did not publish: its name, what it scales and how far it may go (a factor
/// on today's value).
struct Knob {
    name: &'static str,
    range: (f64, f64),
    set: fn(&mut Study, f64),
}

fn scale_segments(w: &mut Waveform, from: usize, f: impl Fn(&mut SineSegment)) {
    if let Waveform::SineTrain { segments, .. } = w {
        segments.iter_mut().skip(from).for_each(f);
    }
}

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
        name: "x1 segments 5-7 frequency",
        range: (0.5, 20.0),
        set: |s, x| {
            for e in &mut s.experiments {
                scale_segments(&mut e.x1, 4, |g| g.freq *= x);
            }
        },
    },
    Knob {
        name: "x12 amplitudes",
        range: (0.1, 10.0),
        set: |s, x| {
            for e in &mut s.experiments {
                scale_segments(&mut e.x12, 0, |g| g.amplitude *= x);
            }
        },
    },
];

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

/// `ln(σ_p / σ_K14)` per parameter of Table I.
fn misfit(info: &Information) -> Vec<f64> {
    K14.iter()
        .map(|(n, k, _)| {
            let i = info
                .params
                .iter()
                .position(|p| p == n)
                .expect("all seven are free");
            (info.sigma[i] / k).ln()
        })
        .collect()
}

fn with_knobs(base: &Study, x: &[f64]) -> Study {
    let mut s = base.clone();
    for (k, v) in KNOBS.iter().zip(x) {
        (k.set)(&mut s, v.exp());
    }
    s
}

/// The sensitivity matrix and a damped Gauss–Newton fit of `ln σ` to K14's over the knobs'
/// logarithms, within their ranges.
fn calibrate(base: &Study) -> Result<(), Box<dyn std::error::Error>> {
    let nk = KNOBS.len();
    let h = 0.05;
    let mut x = vec![0.0; nk];
    let jacobian = |x: &[f64]| -> Result<DMatrix<f64>, Box<dyn std::error::Error>> {
        let mut j = DMatrix::zeros(K14.len(), nk);
        for k in 0..nk {
            let (mut up, mut dn) = (x.to_vec(), x.to_vec());
            up[k] += h;
            dn[k] -= h;
            let (a, b) = (
                misfit(&information(&with_knobs(base, &up))?),
                misfit(&information(&with_knobs(base, &dn))?),
            );
            for p in 0..K14.len() {
                j[(p, k)] = (a[p] - b[p]) / (2.0 * h);
            }
        }
        Ok(j)
    };
    let j0 = jacobian(&x)?;
    println!(
        "
Sensitivity ∂ ln σ / ∂ ln k at today's inputs:
"
    );
    println!(
        "| parameter | {} |\n|{}",
        KNOBS.map(|k| k.name).join(" | "),
        " --- |".repeat(nk + 1)
    );
    for (p, (n, _, _)) in K14.iter().enumerate() {
        let row: Vec<String> = (0..nk).map(|k| format!("{:+.2}", j0[(p, k)])).collect();
        println!("| {n} | {} |", row.join(" | "));
    }
    // an input no bound depends on (less than 1 % per e-fold) cannot be calibrated: it stays
    // at today's value
    let enters: Vec<bool> = (0..nk)
        .map(|k| (0..K14.len()).any(|p| j0[(p, k)].abs() > 1e-2))
        .collect();
    let mut r = DVector::from_vec(misfit(&information(&with_knobs(base, &x))?));
    let mut lambda = 1e-2;
    for it in 0..40 {
        let j = jacobian(&x)?;
        let jt = j.transpose();
        let mut a = &jt * &j;
        for k in 0..nk {
            a[(k, k)] *= 1.0 + lambda;
            a[(k, k)] += 1e-9;
        }
        let Some(step) = a.lu().solve(&(-(&jt * &r))) else {
            break;
        };
        let cand: Vec<f64> = (0..nk)
            .map(|k| match enters[k] {
                true => (x[k] + step[k]).clamp(KNOBS[k].range.0.ln(), KNOBS[k].range.1.ln()),
                false => 0.0,
            })
            .collect();
        let rc = DVector::from_vec(misfit(&information(&with_knobs(base, &cand))?));
        if rc.norm() < r.norm() {
            let gain = r.norm() - rc.norm();
            x = cand;
            r = rc;
            lambda = (lambda / 3.0).max(1e-6);
            println!(
                "iteration {it}: rms ln(σ/σ_K14) {:.4}",
                r.norm() / (K14.len() as f64).sqrt()
            );
            if gain < 1e-5 {
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
        "
Calibrated inputs (factor on today's value):

| input | factor | range |
| --- | --- | --- |"
    );
    for ((k, v), e) in KNOBS.iter().zip(&x).zip(&enters) {
        let f = if *e {
            format!("{:.3}", v.exp())
        } else {
            "1 (no bound depends on it)".into()
        };
        println!("| {} | {f} | {}–{} |", k.name, k.range.0, k.range.1);
    }
    let info = information(&with_knobs(base, &x))?;
    println!(
        "
With them:
"
    );
    table(&info);
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
    if args.iter().any(|a| a == "calibrate") {
        calibrate(&study)?;
    }
    Ok(())
}
