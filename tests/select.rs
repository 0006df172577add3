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

/// `[select] until` on the shipped guidance-delay study (nominal amplitudes, its seed): model
/// X's in-model chains have not converged at their 12 000 iterations (R-hat of `d21` 1.0103,
/// the reason the rule exists), Y's have. With the rule (the default) X's run on to where they
/// converge and Y's are exactly the fixed run's; a rule the most cannot meet says so in one
/// line per model naming every parameter short of it.
#[test]
fn in_model_chains_run_on_until_converged_and_keep_the_converged_ones() {
    let base = || {
        let mut s = Study::load(Path::new("examples/guidance-delays.toml")).unwrap();
        s.select.rj_iterations = 8_000;
        s.select.cross_checks = occam::config::CrossChecks::Off;
        s
    };
    let prep = prepare(&base()).unwrap();
    let go = |s: &Study| run(s, &prep, None).unwrap();
    let fixed = {
        let mut s = base();
        s.select.until = None;
        go(&s)
    };
    let ruled = go(&base());
    let (x0, y0) = (&fixed.models[0], &fixed.models[1]);
    let (x1, y1) = (&ruled.models[0], &ruled.models[1]);
    let in_model_rhat = |m: &occam::jobs::select::ModelOutcome| {
        m.notes
            .iter()
            .any(|n| n.starts_with("in-model chains: R-hat"))
    };
    assert!(
        x0.mcmc_max_rhat.unwrap() > 1.01 && in_model_rhat(x0),
        "{x0:#?}"
    );
    assert_eq!(x0.mcmc_iterations, Some(12_000));
    let n = x1.mcmc_iterations.unwrap();
    assert!(n > 12_000 && n <= 48_000 && (n - 12_000) % 100 == 0, "{n}");
    assert!(
        x1.mcmc_max_rhat.unwrap() <= 1.01 && !in_model_rhat(x1),
        "{x1:#?}"
    );
    // Y converged by 12 000: the same chains, so the same bridge-sampling evidence, bit for bit
    assert_eq!(y1.mcmc_iterations, Some(12_000));
    assert_eq!(
        y1.bridge_sampling.ln_z.map(f64::to_bits),
        y0.bridge_sampling.ln_z.map(f64::to_bits)
    );
    assert!(y1.bridge_sampling.ln_z.is_some());

    // an ESS no run of 12 100 reaches: both run their most and say which parameters fell short
    let mut s = base();
    s.select.until = Some(occam::config::UntilOptions {
        ess: 1e6,
        ..Default::default()
    });
    s.select.max_iterations = Some(12_100);
    let short = go(&s);
    for m in &short.models {
        assert_eq!(m.mcmc_iterations, Some(12_100));
        let line: Vec<&String> = m
            .notes
            .iter()
            .filter(|n| n.contains("effective sample size below 1000000"))
            .collect();
        assert_eq!(line.len(), 1, "{:#?}", m.notes);
        for p in &m.free {
            assert!(line[0].contains(&format!("`{p}` (")), "{p}: {}", line[0]);
        }
        assert!(
            short
                .warnings
                .iter()
                .any(|w| w.contains("raise [select] max_iterations"))
        );
    }
}
