//! Force glitches: the simulator puts them in from their own random stream (the noise is the
//! same without them) and records them; `glitches = "gate"` finds them on the whitened
//! residual and gates them; `occam simulate` + `occam fit` on gated data recover Table I's
//! truth; bad settings are errors naming the key.

mod common;

use common::occam;
use occam::config::Study;
use occam::data::dataset::Dataset;
use occam::jobs::prepare::{gate_glitches, load_data};
use std::path::Path;

/// Two short, clearly detectable glitches per experiment (peak 1e−13 to 2e−13 m s⁻², tens of σ
/// of the whitened residual), gated.
const GLITCHES: &str = r#"
[simulation.glitches]
count = 2
amplitude = [1e-13, 2e-13]
decay = [30.0, 60.0]
on = "both"

[analysis]
glitches = "gate"
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

/// Every injected glitch starts inside a gated region; the noise-only stretch (no glitches
/// there) is bit-identical to the glitch-free simulation's, and the fit stretch differs only
/// by the glitches' response.
#[test]
fn the_gate_finds_every_injected_glitch() {
    let dir = tempfile::tempdir().unwrap();
    let s = Study::load(&tn3045(GLITCHES, dir.path())).unwrap();
    let (mut data, _) = load_data(&s).unwrap();
    let mut clean = s.clone();
    clean.simulation.glitches = None;
    let (clean_data, _) = load_data(&clean).unwrap();
    assert!(clean_data.extra.get("glitches").is_none());
    for (e, c) in data.experiments.iter().zip(&clean_data.experiments) {
        assert_eq!(e.noise, c.noise);
        assert_eq!(e.i, c.i);
        assert_ne!(e.o, c.o);
    }
    let gates = gate_glitches(&s, s.fit_model.model, &mut data).unwrap();
    let record = data.extra["glitches"].as_object().unwrap();
    for g in &gates {
        let injected = record[&g.experiment]["fit"].as_array().unwrap();
        assert_eq!(injected.len(), 2);
        for gl in injected {
            let t0 = gl["t0"].as_f64().unwrap();
            assert!(
                g.regions.iter().any(|r| r[0] <= t0 && t0 < r[1]),
                "{}: glitch at {t0} s not in {:?}",
                g.experiment,
                g.regions
            );
        }
        eprintln!("{}", g.describe());
        // the gate is about the glitches, not the whole stretch
        assert!(g.seconds < 0.3 * 19_120.0, "{}", g.describe());
    }
}

/// `occam simulate` records the glitches in `dataset.json` and in no channel; `occam fit` with
/// `glitches = "gate"` on the dataset reports what it gated and recovers every Table I
/// parameter within 5 Cramér–Rao σ.
#[test]
fn simulate_then_fit_gated() {
    let dir = tempfile::tempdir().unwrap();
    let p = tn3045(
        &format!("{GLITCHES}\n[fit]\niterations = 3000\nburn_in = 1000\n"),
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
    assert!(ds.experiments.iter().all(|e| e.gaps.is_empty()));
    let g = &ds.extra["glitches"]["inv1"]["fit"];
    assert_eq!(g.as_array().unwrap().len(), 2, "{g}");
    let text = std::fs::read_to_string(&p).unwrap();
    std::fs::write(
        &p,
        text.replace("[analysis]\n", "[analysis]\ndataset = \"data\"\n"),
    )
    .unwrap();
    let (ok, out, err) = occam(&["fit", "study.toml"], dir.path());
    assert!(ok, "{err}");
    assert!(
        format!("{out}{err}").contains("glitch gating removed"),
        "{out}{err}"
    );
    let summary: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join("runs/fit/summary.json")).unwrap(),
    )
    .unwrap();
    let gates = summary["glitch_gates"].as_array().unwrap();
    assert_eq!(gates.len(), 2);
    assert!(gates.iter().all(|g| g["detected"].as_u64().unwrap() >= 1));
    for r in summary["rows"].as_array().unwrap() {
        let (map, cr, truth) = (
            r["map"].as_f64().unwrap(),
            r["cramer_rao"].as_f64().unwrap(),
            r["truth"].as_f64().unwrap(),
        );
        let z = (map - truth) / cr;
        eprintln!("{}: {z:.2}σ", r["name"]);
        assert!(z.abs() < 5.0, "{r}");
    }
}

/// Bad glitch settings are errors naming the key and the fix.
#[test]
fn bad_glitch_settings_name_the_key() {
    let dir = tempfile::tempdir().unwrap();
    let cases = [
        (
            GLITCHES.replace("count = 2", "count = 100000"),
            "simulation.glitches",
            "count",
        ),
        (
            GLITCHES.replace("decay = [30.0, 60.0]", "decay = [60.0, 30.0]"),
            "simulation.glitches",
            "decay",
        ),
        (
            GLITCHES.replace(
                "glitches = \"gate\"",
                "glitches = \"gate\"\nglitch_threshold = 1.0",
            ),
            "analysis.glitch_threshold",
            "≥ 3",
        ),
        (
            GLITCHES.replace("glitches = \"gate\"", "glitch_pad = 30.0"),
            "analysis.glitches",
            "glitches = \"gate\"",
        ),
    ];
    for (extra, field, what) in cases {
        let p = tn3045(&extra, dir.path());
        let e = Study::load(&p).unwrap_err().to_string();
        assert!(e.contains(field) && e.contains(what), "{e}");
    }
    // a listed glitch must be [t0, t1] with 0 ≤ t0 < t1
    let text = std::fs::read_to_string(tn3045("", dir.path()))
        .unwrap()
        .replace(
            "design = \"tn3045_x1\"",
            "design = \"tn3045_x1\"\nglitches = [[500.0, 100.0]]",
        );
    let e = Study::from_toml(&text, "s.toml", dir.path())
        .unwrap_err()
        .to_string();
    assert!(e.contains("glitches[0]") && e.contains("t0 < t1"), "{e}");
    // listed glitches are gated without detection
    let text = text.replace("[[500.0, 100.0]]", "[[500.0, 900.0]]");
    let s = Study::from_toml(&text, "s.toml", dir.path()).unwrap();
    let (mut data, _) = load_data(&s).unwrap();
    let gates = gate_glitches(&s, s.fit_model.model, &mut data).unwrap();
    assert_eq!(gates[0].listed, 1);
    assert_eq!(gates[0].detected, 0);
    assert_eq!(gates[0].regions, vec![[500.0, 900.0]]);
    assert_eq!(data.experiments[0].gaps, vec![[5000, 9000]]);
    assert!(data.experiments[1].gaps.is_empty());
}

/// The examples load, and on `examples/gaps-and-glitches.toml` the gate works beside the random
/// gaps: every injected glitch that does not start in a gap is gated, and the gaps are kept.
#[test]
fn the_glitch_examples_gate_beside_gaps() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    Study::load(&root.join("examples/glitches.toml")).unwrap();
    let s = Study::load(&root.join("examples/gaps-and-glitches.toml")).unwrap();
    let (mut data, _) = load_data(&s).unwrap();
    let before: Vec<_> = data.experiments.iter().map(|e| e.gaps.clone()).collect();
    let gates = gate_glitches(&s, s.fit_model.model, &mut data).unwrap();
    let record = data.extra["glitches"].as_object().unwrap();
    for ((g, e), old) in gates.iter().zip(&data.experiments).zip(&before) {
        for gl in record[&g.experiment]["fit"].as_array().unwrap() {
            let k = (gl["t0"].as_f64().unwrap() * e.fs) as usize;
            assert!(
                e.gaps.iter().any(|s| s[0] <= k && k < s[1]),
                "{}: glitch at {gl} not gated",
                g.experiment
            );
        }
        // the old gaps are still gaps
        for o in old {
            assert!(e.gaps.iter().any(|s| s[0] <= o[0] && o[1] <= s[1]));
        }
        eprintln!("{}", g.describe());
    }
}
