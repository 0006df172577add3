//! The paper's guidance-delay study at ρ_opt = 60, a regime no example holds, through
//! `occam::jobs::select` with shortened runs. The examples' regimes (ρ_opt 5 and 450, the
//! nominal amplitudes) are held to their references in `tests/headline/mod.rs`, on the golden
//! records that a fresh run reproduces bit for bit.

use occam::config::Study;
use occam::jobs::prepare::prepare;
use occam::jobs::select::{PairResult, run};
use std::path::Path;

/// Every row, for the test log (and the note's figures).
fn show(p: &PairResult) {
    for e in &p.estimates {
        eprintln!(
            "{:<28} {:>12?} ± {:<10?} agrees {:?}",
            e.method, e.ln_b, e.std_err, e.agrees
        );
    }
}

/// Asserts that row `m` (with its stated error) is within `k` combined σ of `reference`
/// (value, σ), and returns its distance in those σ.
fn within(p: &PairResult, m: &str, reference: (f64, f64), k: f64) -> f64 {
    let e = p.estimates.iter().find(|e| e.method == m).unwrap();
    let (v, s) = (
        e.ln_b.unwrap_or_else(|| panic!("{m} gave no number")),
        e.std_err.unwrap_or_else(|| panic!("{m} states no error")),
    );
    let z = (v - reference.0).abs() / s.hypot(reference.1);
    assert!(
        z < k,
        "{m}: {v} ± {s} is {z:.1} σ from {} ± {}",
        reference.0,
        reference.1
    );
    z
}

/// nautilus on the exact likelihood of the same data (`bench/peer/results/rho60.nautilus.json`):
/// the independent reference of the ρ_opt = 60 regime.
const NAUTILUS_RHO60: (f64, f64) = (0.09571981523185968, 0.012739854459202234);

/// The statistical rows of the table.
const STATISTICAL: [&str; 5] = [
    "RJMCMC visits",
    "RJMCMC Rao-Blackwell",
    "RJMCMC bridge",
    "Thermodynamic integration",
    "Stepping-stone",
];

fn study(file: &str) -> Study {
    let mut s = Study::load(Path::new(file)).unwrap();
    s.select.rj_iterations = 40_000;
    s.select.iterations = 6_000;
    s.select.burn_in = 2_000;
    s
}

/// ρ_opt = 60: the delays are barely measured, the MAP of X sits on the Δt1 = 1 s bound and
/// the Fisher σ of the delays is wider than their box. The RJ estimators (with jump proposals
/// from the in-model chains), thermodynamic integration and stepping-stone agree within their
/// errors, and every row has a number or a reason.
#[test]
fn rho_60_rj_and_tempering_estimators_agree() {
    let mut s = study("examples/guidance-delays.toml");
    s.simulation.target_snr = Some(60.0);
    let prep = prepare(&s).unwrap();
    let out = run(&s, &prep, None).unwrap();
    let p = &out.pairs[0];
    show(p);
    assert!(p.all_agree, "{:#?}", p.estimates);
    for e in &p.estimates {
        assert!(e.ln_b.is_some() || e.note.is_some(), "{}", e.method);
    }
    // every statistical row against nautilus on the same data, within 2.5 combined σ
    // (measured: 0.2–1.0 σ)
    for m in STATISTICAL {
        within(p, m, NAUTILUS_RHO60, 2.5);
    }
}
