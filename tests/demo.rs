//! `occam demo`'s headline numbers (README, "Run the demo") against references it does not
//! share a random stream with: every statistical row within 2.5 combined σ (measured: at most
//! 1.25), and every error no larger than the README quotes, so a bias of 3 of its own σ or an
//! error inflated to hide one fails.

mod common;
use common::occam;
use serde_json::Value;

/// The competitive regime (`examples/guidance-delays.toml`, ρ_opt = 450, the demo's data): the
/// bridge of a reversible jump 16× longer than the demo's on another sampler seed (`[select]
/// seed = 4242`, `rj_iterations = 1600000`, measured 2026-11-28): ln B_XY.
const REF_COMPETITIVE: (f64, f64) = (-1.2056455627159401, 0.001684428125438415);
/// The nominal amplitudes: nautilus on the exact likelihood of the same data
/// (`bench/peer/results/nominal.nautilus.json`, as in `tests/select.rs`).
const REF_NOMINAL: (f64, f64) = (-14.229583978652954, 0.010770460116461862);

/// `(ln B, σ)` of every statistical row with a number, and the pair's verdict.
fn rows(dir: &std::path::Path) -> (Vec<(String, f64, f64)>, String) {
    let text = std::fs::read_to_string(dir.join("summary.json")).unwrap();
    let v: Value = serde_json::from_str(&text).unwrap();
    let p = &v["pairs"][0];
    let rows = p["estimates"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|e| {
            Some((
                e["method"].as_str()?.to_string(),
                e["ln_b"].as_f64()?,
                e["std_err"].as_f64()?,
            ))
        })
        .collect();
    (rows, p["preferred"].as_str().unwrap().to_string())
}

fn assert_within(regime: &str, rows: &[(String, f64, f64)], r: (f64, f64), k: f64) {
    for (m, v, s) in rows {
        let z = (v - r.0) / s.hypot(r.1);
        assert!(
            z.abs() < k,
            "{regime}, {m}: {v} ± {s} is {z:+.1} combined σ from {} ± {}",
            r.0,
            r.1
        );
    }
}

#[test]
fn the_demo_reproduces_its_headline_bayes_factors() {
    let dir = tempfile::tempdir().unwrap();
    let (ok, out, err) = occam(&["demo", "-q", "-o", "demo"], dir.path());
    assert!(ok, "{err}");
    let (competitive, preferred) = rows(&dir.path().join("demo/competitive"));
    let names: Vec<&str> = competitive.iter().map(|r| r.0.as_str()).collect();
    assert_eq!(
        names,
        [
            "RJMCMC visits",
            "RJMCMC Rao-Blackwell",
            "RJMCMC bridge",
            "Thermodynamic integration",
            "Stepping-stone"
        ],
        "{out}"
    );
    assert_eq!(preferred, "Y");
    assert_within("competitive", &competitive, REF_COMPETITIVE, 2.5);
    // B_XY ≈ 0.30 as the README says, and the error bars are the ones it quotes (± 0.01 nat
    // for the reversible jump, ± 0.05 for tempering): neither a 3σ bias nor errors inflated
    // to hide one pass
    for (m, _, s) in &competitive {
        let limit = if m.starts_with("RJMCMC") { 0.012 } else { 0.06 };
        assert!(*s < limit, "competitive, {m}: ± {s}");
    }
    // the nominal amplitudes: the chain never enters X, so no visit ratio; the bridge and the
    // one-sided Rao-Blackwell estimate against nautilus
    let (high, preferred) = rows(&dir.path().join("demo/high-snr"));
    assert_eq!(preferred, "Y");
    assert!(
        !high.iter().any(|r| r.0 == "RJMCMC visits"),
        "the visit ratio needs visits to X: {high:?}"
    );
    for m in ["RJMCMC Rao-Blackwell", "RJMCMC bridge"] {
        let (_, v, s) = high.iter().find(|r| r.0 == m).unwrap();
        assert!(*s < 0.02, "nominal, {m}: {v} ± {s}");
    }
    assert_within("nominal", &high, REF_NOMINAL, 2.5);
}
