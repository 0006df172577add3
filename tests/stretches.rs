//! Stretches and drifting parameters: the drifting model's likelihood is the sum of the parent's
//! over the stretches at each stretch's parameters (exactly, and through relative binning);
//! noiseless data simulated with a drifting truth have zero residual at the drift model's truth
//! and not at the constant model's; `occam select` prefers a strong drift over a constant
//! stiffness; bad stretch tables are refused with the field and the fix.

mod common;

use common::occam;
use occam::config::Study;
use occam::jobs::prepare::{likelihood_of, load_data, reference_point};
use std::path::Path;

/// Table I's inv1 experiment in three stretches a day apart, ω1² drifting by `step` per
/// stretch, with a drifting model and its constant sub-model.
fn study(step: f64, extra: &str) -> String {
    let w = |k: f64| -1.3e-6 + (k - 1.0) * step;
    format!(
        r#"seed = 7
output = "runs"
[[stretch]]
name = "a"
time = 0.0
truth = {{ w1sq = {} }}
[[stretch]]
name = "b"
time = 86400.0
truth = {{ w1sq = {} }}
[[stretch]]
name = "c"
time = 172800.0
truth = {{ w1sq = {} }}
[[model]]
kind = "drift"
name = "drifting"
of = "ltp"
linear = {{ w1sq = "time" }}
[[model]]
kind = "drift"
name = "per_stretch"
of = "ltp"
per_stretch = ["w1sq"]
[prior]
dw1sq_dtime = {{ kind = "uniform", lo = -1e-13, hi = 1e-13 }}
[fit]
model = "drifting"
[[experiment]]
name = "inv1"
design = "tn3045_x1"
{extra}"#,
        w(0.0),
        w(1.0),
        w(2.0)
    )
}

fn load(text: &str) -> Study {
    Study::from_toml(text, "stretches.toml", Path::new(".")).unwrap()
}

/// The drifting model's ln L is the plain loop's ln L summed over the stretches, each at the
/// stretch's ω1² = w1sq + (t − t̄)·slope; relative binning agrees with it.
#[test]
fn drift_likelihood_is_the_sum_over_stretches_at_their_parameters() {
    let s = load(&study(3e-9, ""));
    assert_eq!(s.experiment_names, ["inv1_a", "inv1_b", "inv1_c"]);
    let (data, _) = load_data(&s).unwrap();
    let mi = s.fit_model.model;
    let drift = likelihood_of(&s, mi, &data).unwrap();
    let li = s.models.index("ltp").unwrap();
    let th = reference_point(&s, mi);
    let names = s.models.models[mi].param_names();
    let slope = names.iter().position(|n| n == "dw1sq_dtime").unwrap();
    // the truth read from the stretches: ω1² at t̄ = 86400 s and 3e−9 per day
    assert!((th[0] + 1.3e-6).abs() < 1e-18, "{}", th[0]);
    assert!((th[slope] - 3e-9 / 86400.0).abs() < 1e-24, "{}", th[slope]);
    // move away from the truth so the residuals are not noise only
    let mut at = th.clone();
    at[slope] *= -0.5;
    at[0] += 2e-9;
    let mut sum = 0.0;
    for (k, e) in data.experiments.iter().enumerate() {
        let one = occam::data::dataset::Dataset {
            experiments: vec![e.clone()],
            ..data.clone()
        };
        let plain = likelihood_of(&s, li, &one).unwrap();
        let mut p = occam::ltp::LtpParams::default().to_array().to_vec();
        p[0] = at[0] + (k as f64 * 86400.0 - 86400.0) * at[slope];
        sum += plain.ln_likelihood_whittle(&p);
    }
    let total = drift.ln_likelihood_whittle(&at);
    assert!(
        (total - sum).abs() < 1e-9 * sum.abs(),
        "drift {total} vs Σ stretches {sum}"
    );
    // one ω1² per stretch: each at the stretch's truth
    let ps = s.models.index("per_stretch").unwrap();
    let per = likelihood_of(&s, ps, &data).unwrap();
    let tp = reference_point(&s, ps);
    assert_eq!(
        &s.models.models[ps].param_names()[..3],
        ["w1sq_a", "w1sq_b", "w1sq_c"]
    );
    for (k, v) in tp[..3].iter().enumerate() {
        assert!(
            (v - (-1.3e-6 + (k as f64 - 1.0) * 3e-9)).abs() < 1e-20,
            "{tp:?}"
        );
    }
    let mut sum = 0.0;
    for (k, e) in data.experiments.iter().enumerate() {
        let one = occam::data::dataset::Dataset {
            experiments: vec![e.clone()],
            ..data.clone()
        };
        let mut p = occam::ltp::LtpParams::default().to_array().to_vec();
        p[0] = tp[k] + 1e-9;
        sum += likelihood_of(&s, li, &one)
            .unwrap()
            .ln_likelihood_whittle(&p);
    }
    let mut at = tp.clone();
    for v in &mut at[..3] {
        *v += 1e-9;
    }
    let total = per.ln_likelihood_whittle(&at);
    assert!((total - sum).abs() < 1e-9 * sum.abs(), "{total} vs {sum}");
    let rb = occam::jobs::prepare::relbin_of(&s, &drift, &th).unwrap();
    let near = {
        let mut v = th.clone();
        v[slope] *= 1.01;
        v
    };
    let d = (rb.ln_likelihood_full(&near) - drift.ln_likelihood_whittle(&near)).abs();
    assert!(d < 0.01, "relative binning off by {d}");
}

/// Noiseless data with a drifting truth: the drifting model's residual vanishes at its truth;
/// the constant model (slope 0) at its best point cannot follow the drift.
#[test]
fn noiseless_drift_is_fitted_exactly_by_the_drifting_model_only() {
    let mut s = load(&study(3e-9, ""));
    s.simulation.noise = occam::experiment::options::NoiseSynthesis::None;
    s.analysis.noise = occam::likelihood::NoiseSource::Model;
    let (data, _) = load_data(&s).unwrap();
    let mi = s.fit_model.model;
    let lik = likelihood_of(&s, mi, &data).unwrap();
    let th = reference_point(&s, mi);
    let rho2 = lik.snr(&th).powi(2);
    let at_truth = lik.residual_power(&th);
    let mut flat = th.clone();
    flat[1] = 0.0;
    let constant = lik.residual_power(&flat);
    // with slope 0 the first and last stretches are off by ∓3e−9 in ω1²: the residual power
    // is ½ F_s δ² per stretch, F_s a third of the whole Fisher information of ω1²
    let f = occam::likelihood::fisher_exact(&lik, &th, &[0])[(0, 0)];
    let want = 0.5 * (f / 3.0) * 2.0 * (3e-9f64).powi(2);
    eprintln!(
        "ρ² {rho2:.3e}: residual at the truth {at_truth:.3e}, slope 0 {constant:.3e} (Fisher: {want:.3e})"
    );
    assert!(at_truth < 1e-12 * rho2, "{at_truth} vs {rho2}");
    assert!((constant / want - 1.0).abs() < 0.02, "{constant} vs {want}");
}

/// `occam select` on a drift of 4e−9 s⁻² per stretch (≈ 17σ of one stretch over the three)
/// prefers the drifting model; with no drift the constant one (the Occam factor of the slope's
/// prior box, about ln(2e−13 s⁻²/s / σ_slope) ≈ 7 nats).
#[test]
fn select_prefers_a_strong_drift_and_the_constant_model_without_one() {
    let dir = tempfile::tempdir().unwrap();
    let sel = r#"
[select]
rj_iterations = 20000
rj_burn_in = 1000
chains = 2
iterations = 3000
burn_in = 1000
pt_temperatures = 0
[[select.model]]
name = "drift"
model = "drifting"
fixed = { dt2 = 0.2 }    # inv1 alone does not measure it
[[select.model]]
name = "constant"
model = "drifting"
fixed = { dw1sq_dtime = 0.0, dt2 = 0.2 }
"#;
    for (step, want) in [(4e-9, "drift"), (0.0, "constant")] {
        let p = dir.path().join(format!("s{step}.toml"));
        std::fs::write(&p, study(step, sel)).unwrap();
        let (ok, stdout, stderr) = occam(&["select", p.to_str().unwrap()], dir.path());
        assert!(ok, "{stderr}");
        let summary: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(dir.path().join("runs/select/summary.json")).unwrap(),
        )
        .unwrap();
        let text = summary.to_string();
        assert!(
            stdout.contains(&format!("preferred model {want}")),
            "drift step {step}: {stdout}\n{text}"
        );
    }
}

#[test]
fn bad_drift_models_are_refused_with_the_fix() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("bad.toml");
    // no prior for the slope
    std::fs::write(
        &p,
        study(0.0, "").replace(
            "dw1sq_dtime = { kind = \"uniform\", lo = -1e-13, hi = 1e-13 }",
            "",
        ),
    )
    .unwrap();
    let (ok, _, err) = occam(&["fit", p.to_str().unwrap()], dir.path());
    assert!(!ok);
    assert!(
        err.contains("prior.dw1sq_dtime") && err.contains("has no prior"),
        "{err}"
    );
    // a covariate no stretch gives
    std::fs::write(
        &p,
        study(0.0, "").replace("w1sq = \"time\"", "w1sq = \"temperature\""),
    )
    .unwrap();
    let (ok, _, err) = occam(&["fit", p.to_str().unwrap()], dir.path());
    assert!(!ok);
    assert!(
        err.contains("model[0]") && err.contains("temperature"),
        "{err}"
    );
}
