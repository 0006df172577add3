//! Diagnostics end to end: a fit whose data cannot constrain some parameters names them (and
//! only them), and a fit whose MAP sits on a prior bound says which bound and which `[prior]`
//! entry to change.

mod common;
use common::occam;
use occam::config::Study;
use std::path::Path;

/// One experiment that forces TM2 only (`f2`; `g1` is then zero), fitted with the
/// acceleration-domain model with separate actuators: TM1's gain and pole do not enter ln L.
const TM2_ONLY: &str = r#"
seed = 11
output = "out"
[simulation.actuators]
tm1 = { pole = 1.963, delay = 0.05 }
tm2 = { pole = 1.963, delay = 0.05 }
[[experiment]]
name = "tm2-only"
fs = 10.0
pre_pad = 300.0
post_pad = 900.0
noise_duration = 15000.0
x12 = { kind = "sine", freq = 2e-3, amplitude = 1e-7, duration = 1000.0 }
f2 = { kind = "sine_train", gap = 10.0, segments = [{ freq = 0.07, amplitude = 3e-10, duration = 200.0 }, { freq = 1.3, amplitude = 3e-9, duration = 200.0 }, { freq = 2.1, amplitude = 8e-9, duration = 200.0 }] }
[analysis]
band = [1e-3, 3.0]
[[model]]
kind = "accel"
name = "asym"
[prior]
a1 = { kind = "uniform", lo = 0.8, hi = 1.3 }
a2 = { kind = "uniform", lo = 0.8, hi = 1.3 }
f_o1 = { kind = "uniform", lo = 0.5, hi = 10.0 }
f_o2 = { kind = "uniform", lo = 0.5, hi = 10.0 }
[fit]
model = "asym"
chains = 2
iterations = 2000
burn_in = 500
"#;

#[test]
fn a_fit_of_tm1_actuators_without_tm1_forces_names_a1_and_f_o1() {
    let study = Study::from_toml(TM2_ONLY, "tm2.toml", Path::new(".")).unwrap();
    let prep = occam::jobs::prepare::prepare(&study).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let err = match occam::jobs::fit::run(&study, &prep, dir.path(), None, None, false) {
        Ok(_) => panic!("the fit must fail"),
        Err(e) => e.to_string(),
    };
    assert!(
        err.contains("the data do not constrain `a1`, `f_o1`: ln L does not depend on `a1`, `f_o1` (zero Fisher columns)"),
        "{err}"
    );
    // the hint is the study's own terms, and the TM2 parameters stay free
    assert!(
        err.contains(
            r#"[fit] free = ["w1sq", "w2sq", "a2", "f_o2"] and fixed = { a1 = 1.05, f_o1 = 5.25 }"#
        ),
        "{err}"
    );
    // following the hint gives a fit
    let fixed = TM2_ONLY.replace(
        "model = \"asym\"\nchains",
        "model = \"asym\"\nfree = [\"w1sq\", \"w2sq\", \"a2\", \"f_o2\"]\nfixed = { a1 = 1.05, f_o1 = 5.25 }\nchains",
    );
    let study = Study::from_toml(&fixed, "tm2.toml", Path::new(".")).unwrap();
    let prep = occam::jobs::prepare::prepare(&study).unwrap();
    let out = occam::jobs::fit::run(&study, &prep, dir.path(), None, None, false).unwrap();
    assert_eq!(out.summary.rows.len(), 4);
    assert!(out.summary.rows.iter().all(|r| r.cramer_rao.is_finite()));
}

/// The Table I loop's small fit (tests/cli_fit.rs) with `a_sus`'s prior narrowed below the
/// truth (the default 1.08): the MAP is on the upper bound.
/// The study: its settings and [`common::TWO_EXPERIMENTS`].
fn bound() -> String {
    format!(
        "{}{}",
        r#"
seed = 8
output = "out"
[analysis]
band = [1e-3, 0.4]
[prior]
a_sus = { kind = "uniform", lo = 0.9, hi = 1.0 }
[fit]
free = ["a_df", "a_sus", "d21"]
fixed = { w1sq = -1.3e-6, w2sq = -1.9e-6, dt1 = 0.2, dt2 = 0.2 }
chains = 2
iterations = 1000
burn_in = 300
"#,
        common::TWO_EXPERIMENTS
    )
}

#[test]
fn a_map_on_a_prior_bound_names_the_bound_and_the_prior_entry() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("s.toml"), bound()).unwrap();
    let (ok, _, stderr) = occam(&["fit", "s.toml", "-q"], dir.path());
    assert!(ok, "{stderr}");
    assert!(
        stderr.contains(r#"`a_sus` = 1 is on the upper bound (hi = 1 of [prior] a_sus = { kind = "uniform", lo = 0.9, hi = 1 }: raise hi if the bound is not physical)"#),
        "{stderr}"
    );
    // only a_sus is on a bound
    assert!(!stderr.contains("`a_df` = "), "{stderr}");
    let s: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join("out/fit/summary.json")).unwrap(),
    )
    .unwrap();
    assert!(
        s["warnings"].as_array().unwrap().iter().any(|w| w
            .as_str()
            .unwrap()
            .contains("upper bound (hi = 1 of [prior] a_sus")),
        "{s}"
    );
}

/// A fit whose chains cannot have converged (four chains of 120 iterations, a proposal 30×
/// too wide) leads with "RESULTS NOT VALID" before its table, writes `"valid": false` with the
/// merged reasons, and the report opens with them; the same study run long enough is valid.
#[test]
fn a_fit_that_failed_its_checks_leads_with_it() {
    let dir = tempfile::tempdir().unwrap();
    let bad = common::small().replace(
        "chains = 2\niterations = 2000\nburn_in = 500\n[select]",
        "chains = 4\niterations = 120\nburn_in = 20\nproposal_scale = 30.0\n[select]",
    );
    assert_ne!(bad, common::small(), "the [fit] lengths were replaced");
    std::fs::write(dir.path().join("bad.toml"), &bad).unwrap();
    let (ok, out, err) = occam(&["fit", "bad.toml"], dir.path());
    assert!(ok, "{err}");
    // after the lines the run prints as it goes (the data, the noise reference), before the
    // table and everything else it prints at the end
    let headline = out.find("RESULTS NOT VALID").expect("the failure is said");
    assert!(headline < out.find("parameter  unit").unwrap(), "{out}");
    assert!(
        out[..headline]
            .lines()
            .all(|l| l.starts_with("data:") || l.starts_with("noise reference")),
        "{out}"
    );
    let s: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join("out/fit/summary.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(s["valid"], false);
    let reasons: Vec<&str> = s["invalid_reasons"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_str().unwrap())
        .collect();
    eprintln!("{reasons:#?}");
    assert!(
        reasons
            .iter()
            .any(|r| r.contains("effective sample size below 50")),
        "{reasons:?}"
    );
    // one line per kind of failure, however many parameters it hit
    assert!(reasons.len() <= 4, "{reasons:?}");
    let (ok, _, err) = occam(&["report", "out/fit"], dir.path());
    assert!(ok, "{err}");
    let page = std::fs::read_to_string(dir.path().join("out/fit/report.html")).unwrap();
    let banner = page.find("Results not valid").expect("the report says so");
    assert!(banner < page.find("id=\"tables\"").unwrap());

    std::fs::write(dir.path().join("good.toml"), common::small()).unwrap();
    let (ok, out, err) = occam(&["fit", "good.toml", "--output", "good"], dir.path());
    assert!(ok, "{err}");
    assert!(!out.contains("RESULTS NOT VALID"), "{out}");
    let s: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join("good/summary.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(s["valid"], true, "{}", s["invalid_reasons"]);
}
