//! `examples/cross-talk.toml`: the four-DOF loop with actuation and sensing cross-talk. Its
//! size (≥ 6 read-outs, ≥ 15 parameters), a shortened `select` that must prefer the model with
//! both cross-talks, and a shortened `fit` whose MCMC σ must match the Cramér–Rao σ.
//!
//! The data are the example's own (same seed), so only the samplers' lengths differ from the
//! documented run (docs/src/guide/many-channels.md), where every estimator put the nearest
//! rival, `actuation`, at ln B = −54.5 (bridge ± 0.19; TI, stepping-stone, Laplace within
//! 2.3 nats of it) and `sensing`, `none` at −135 and −198.

mod common;
use common::occam;
use occam::config::Study;
use std::path::{Path, PathBuf};

fn example() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/cross-talk.toml")
}

/// The example with `[fit]` / `[select]` keys replaced (`key = value` lines, whole lines).
fn shortened(dir: &Path, swaps: &[(&str, &str)]) -> PathBuf {
    let mut text = std::fs::read_to_string(example()).unwrap();
    for (from, to) in swaps {
        let n = text.lines().filter(|l| l == from).count();
        assert_eq!(n, 1, "`{from}` is not a line of the example");
        text = text.replacen(&format!("\n{from}\n"), &format!("\n{to}\n"), 1);
    }
    let p = dir.join("cross-talk.toml");
    std::fs::write(&p, text).unwrap();
    p
}

fn summary(dir: &Path, job: &str) -> serde_json::Value {
    let p = dir.join("runs/cross-talk").join(job).join("summary.json");
    serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
}

#[test]
fn the_example_has_six_read_outs_and_fifteen_parameters() {
    let s = Study::load(&example()).unwrap();
    let m = &s.models.models[s.models.index("both").unwrap()];
    assert!(
        m.residual_channels().len() >= 6,
        "{:?}",
        m.residual_channels()
    );
    assert!(m.param_names().len() >= 15, "{:?}", m.param_names());
    assert_eq!(s.select_models.len(), 4);
    // every parameter of the generator has a true value
    for p in m.param_names() {
        assert!(s.simulation.truth.contains_key(p), "{p}");
    }
}

/// Shortened select (reversible jump 6 000 iterations, in-model chains 2 000 and no further,
/// no tempering):
/// the reference of every pair with `both` must prefer `both` by more than 30 nats. The
/// documented run puts the closest rival 54.5 nats below, with a bridge standard error of 0.19
/// and every estimator within 2.3 nats, so 30 nats leaves ten times the estimators' spread; a model that lost a cross-talk channel, or a `both` that could
/// not fit the sensing terms, fails it.
#[test]
fn select_prefers_both_cross_talks() {
    let dir = tempfile::tempdir().unwrap();
    shortened(
        dir.path(),
        &[
            ("rj_iterations = 15000", "rj_iterations = 6000"),
            ("rj_burn_in = 2000", "rj_burn_in = 1000"),
            ("iterations = 24000", "iterations = 2000"),
            // the short chains are the point: `[select] until` would run them to 8 000
            ("burn_in = 4000", "burn_in = 500\nuntil = false"),
            ("pt_temperatures = 32", "pt_temperatures = 0"),
        ],
    );
    let (ok, _, err) = occam(&["select", "cross-talk.toml"], dir.path());
    assert!(ok, "{err}");
    let s = summary(dir.path(), "select");
    let pairs = s["pairs"].as_array().unwrap();
    let mut rivals = Vec::new();
    for p in pairs {
        let (x, y) = (p["x"].as_str().unwrap(), p["y"].as_str().unwrap());
        if y != "both" {
            continue;
        }
        let reference = p["reference"].as_str().unwrap();
        let row = p["estimates"]
            .as_array()
            .unwrap()
            .iter()
            .find(|e| e["method"] == reference)
            .unwrap();
        let ln_b = row["ln_b"].as_f64().unwrap();
        eprintln!("{x}/both: {reference} ln B = {ln_b:.2}");
        assert_eq!(p["preferred"], "both", "{p}");
        assert!(ln_b < -30.0, "{x}/both: ln B = {ln_b}");
        rivals.push(x.to_string());
    }
    rivals.sort();
    assert_eq!(rivals, ["actuation", "none", "sensing"]);
    let probs = s["posterior_model_probabilities"].as_array().unwrap();
    let both = s["models"]
        .as_array()
        .unwrap()
        .iter()
        .position(|m| m["name"] == "both")
        .unwrap();
    assert!(probs[both].as_f64().unwrap() > 0.999, "{probs:?}");
}

/// The example's fit of `both` (4 chains until converged — 16 300 iterations, 2 000 burn-in;
/// about 20 s; at a fixed 10 000 six R-hat were above 1.01, found by issue 52's walk):
/// every parameter's posterior sd is within 4 standard errors of its Cramér–Rao σ. The
/// standard error of a sample sd from `ESS` effective draws of a Gaussian is σ/√(2 ESS); the
/// documented run has every σ/CR within 0.975–1.042 at ESS ≥ 388, i.e. no visible
/// non-Gaussianity, so the Monte-Carlo error is the whole tolerance. (Chains of 4 000
/// iterations with 1 000 burn-in were tried and are too short: ESS 46 for `ay`.)
#[test]
fn fit_sd_matches_the_cramer_rao_bound() {
    let dir = tempfile::tempdir().unwrap();
    shortened(dir.path(), &[]);
    let (ok, _, err) = occam(&["fit", "cross-talk.toml"], dir.path());
    assert!(ok, "{err}");
    let s = summary(dir.path(), "fit");
    let rows = s["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 15);
    for r in rows {
        let (sd, cr, ess) = (
            r["sd"].as_f64().unwrap(),
            r["cramer_rao"].as_f64().unwrap(),
            r["ess"].as_f64().unwrap(),
        );
        let tol = 4.0 / (2.0 * ess).sqrt();
        eprintln!(
            "{}: σ/CR = {:.3} (ESS {ess:.0}, tolerance {tol:.3})",
            r["name"],
            sd / cr
        );
        assert!(ess >= 100.0, "{r}");
        assert!((sd / cr - 1.0).abs() < tol, "{r}");
    }
}
