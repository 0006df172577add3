//! Data with gaps: the per-run likelihood with its edge correction is exact for noiseless data
//! at the truth (and badly wrong without the inputs through the gaps); `occam simulate` +
//! `occam fit` with 10 % random gaps recover Table I's truth at ρ_opt ≈ 2.6e5; a dataset with
//! gaps round-trips through its files.

mod common;

use common::occam;
use occam::config::Study;
use occam::data::dataset::Dataset;
use occam::jobs::prepare::{likelihood_of, load_data, reference_point};
use std::path::Path;

const GAPS: &str = r#"
[simulation.gaps]
fraction = 0.1
shortest = 10.0
longest = 3600.0
"#;

/// `examples/tn3045.toml` with `extra` appended, written to `dir`.
fn tn3045(extra: &str, dir: &Path) -> std::path::PathBuf {
    let text =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/examples/tn3045.toml"))
            .unwrap()
            .replace("output = \"runs/tn3045\"", "output = \"runs\"");
    let p = dir.join("study.toml");
    std::fs::write(&p, format!("{text}{extra}")).unwrap();
    p
}

/// Noiseless data with gaps cutting the injections: at the truth, the corrected per-run
/// residual is zero to rounding; with the injections blanked in the gaps (the response to
/// them unknown) it is not.
#[test]
fn the_edge_correction_makes_the_noiseless_residual_vanish() {
    let dir = tempfile::tempdir().unwrap();
    let p = tn3045(GAPS, dir.path());
    let mut s = Study::load(&p).unwrap();
    s.simulation.noise = occam::experiment::options::NoiseSynthesis::None;
    s.analysis.noise = occam::likelihood::NoiseSource::Model;
    let (mut data, _) = load_data(&s).unwrap();
    let hot = data.experiments.iter().any(|e| {
        e.gaps
            .iter()
            .any(|g| e.i.iter().any(|x| x[g[0]..g[1]].iter().any(|v| *v != 0.0)))
    });
    assert!(
        hot,
        "some gap must cut an injection for this test to have power"
    );
    let truth = reference_point(&s, s.fit_model.model);
    let l = likelihood_of(&s, s.fit_model.model, &data).unwrap();
    let rho2 = l.snr(&truth).powi(2);
    let r = l.residual_power(&truth);
    eprintln!("ρ² = {rho2:.4e}, residual power at the truth {r:.3e}");
    assert!(rho2 > 1e10, "{rho2}");
    assert!(r < 1e-12 * rho2, "{r} vs ρ² {rho2}");
    // the same data with the injections missing inside the gaps
    for e in &mut data.experiments {
        e.known_in_gaps.clear();
        let g = e.gaps.clone();
        e.add_gaps(&g);
    }
    let l = likelihood_of(&s, s.fit_model.model, &data).unwrap();
    let r = l.residual_power(&truth);
    eprintln!("without the injections in the gaps: {r:.3e}");
    assert!(r > 1e-6 * rho2, "{r} vs ρ² {rho2}");
}

/// `occam simulate` writes the gaps (NaN in the read-outs, the injections kept); `occam fit`
/// on the dataset recovers every Table I parameter within 4 Cramér–Rao σ and says how much is
/// missing; the dataset reads back equal.
#[test]
fn simulate_then_fit_with_ten_percent_gaps() {
    let dir = tempfile::tempdir().unwrap();
    let p = tn3045(
        &format!("{GAPS}\n[fit]\niterations = 4000\nburn_in = 1000\n"),
        dir.path(),
    );
    let sim = dir.path().join("sim.toml");
    std::fs::write(
        &sim,
        std::fs::read_to_string(&p)
            .unwrap()
            .replace("output = \"runs\"", "output = \"data\""),
    )
    .unwrap();
    let (ok, _, err) = occam(&["simulate", "sim.toml"], dir.path());
    assert!(ok, "{err}");
    let ds = Dataset::read(&dir.path().join("data")).unwrap();
    for e in &ds.experiments {
        let missing: usize = e.gaps.iter().map(|g| g[1] - g[0]).sum();
        let frac = missing as f64 / e.n_samples() as f64;
        assert!((frac - 0.1).abs() < 1e-3, "{}: {frac}", e.name);
        assert_eq!(e.known_in_gaps, vec!["i1".to_string(), "i12".to_string()]);
        assert!(
            e.gaps
                .iter()
                .all(|g| e.o[0][g[0]..g[1]].iter().all(|v| *v == 0.0))
        );
    }
    let text = std::fs::read_to_string(dir.path().join("study.toml")).unwrap();
    std::fs::write(
        dir.path().join("study.toml"),
        text.replace(
            "[simulation]",
            "[analysis]\ndataset = \"data\"\n\n[simulation]",
        ),
    )
    .unwrap();
    let (ok, out, err) = occam(&["fit", "study.toml"], dir.path());
    assert!(ok, "{err}");
    assert!(
        format!("{out}{err}").contains("10.0 % of the fit stretch missing"),
        "{out}{err}"
    );
    let summary: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join("runs/fit/summary.json")).unwrap(),
    )
    .unwrap();
    for r in summary["rows"].as_array().unwrap() {
        let (map, cr, truth) = (
            r["map"].as_f64().unwrap(),
            r["cramer_rao"].as_f64().unwrap(),
            r["truth"].as_f64().unwrap(),
        );
        let z = (map - truth) / cr;
        eprintln!("{}: {z:.2}σ", r["name"]);
        assert!(z.abs() < 4.0, "{r}");
    }
}
