//! `[select] target_error` and `cross_checks`: the reversible jump runs in rounds until the
//! reference error reaches the target, and the published run is exactly the fixed-length run
//! of its final length; a budget too small says so; the cross-checks' share changes the
//! tempering rows and nothing else; a run killed in a later round resumes to the same numbers.

mod common;
use common::{numbers, small};
use occam::config::Study;
use occam::jobs::select::{Checkpointing, SelectCheckpoint, SelectSummary, run_checkpointed};
use std::path::Path;
use std::time::Duration;

fn study(extra: &str) -> Study {
    let text = small().replacen("[select]\n", &format!("[select]\n{extra}\n"), 1);
    Study::from_toml(&text, "small.toml", Path::new(".")).unwrap()
}

fn select(s: &Study) -> SelectSummary {
    let prep = occam::jobs::prepare::prepare(s).unwrap();
    occam::jobs::select::run(s, &prep, None).unwrap()
}

fn row<'a>(s: &'a SelectSummary, method: &str) -> &'a occam::jobs::select::PairEstimate {
    s.pairs[0]
        .estimates
        .iter()
        .find(|e| e.method == method)
        .unwrap()
}

/// The summary's numbers without what a target adds (its rounds and the warning it may
/// give), for comparing with a fixed-length run.
fn without_target(s: &SelectSummary) -> serde_json::Value {
    let mut v = numbers(serde_json::to_value(s).unwrap());
    v.as_object_mut().unwrap().remove("target");
    v
}

/// The small study with `rj_iterations = n`.
fn with_rj_iterations(n: usize) -> Study {
    let text = small().replace("rj_iterations = 6000", &format!("rj_iterations = {n}"));
    Study::from_toml(&text, "small.toml", Path::new(".")).unwrap()
}

#[test]
fn a_target_error_lengthens_the_jump_run_and_equals_the_fixed_run_of_its_length() {
    let base = select(&study(""));
    let e0 = row(&base, "RJMCMC bridge").std_err.unwrap();
    assert!(base.target.is_none());
    // a target the first round misses by a factor 2.2 in error (about 5 in length)
    let target = e0 / 2.2;
    let s = select(&study(&format!("target_error = {target}")));
    let t = s.target.as_ref().unwrap();
    assert!(t.met, "{t:?}");
    assert!(t.rounds.len() >= 2, "{t:?}");
    assert_eq!(t.rounds[0].iterations, 6000);
    assert_eq!(t.rounds[0].error, Some(e0), "round 1 is the fixed run");
    let reached = row(&s, "RJMCMC bridge").std_err.unwrap();
    assert_eq!(t.reached, Some(reached));
    assert!(reached <= target, "{reached} > {target}");
    // the lengths grow, and the last is not longer than the last error asked for by much
    for w in t.rounds.windows(2) {
        assert!(
            w[1].iterations as f64 >= 1.5 * w[0].iterations as f64,
            "{t:?}"
        );
    }
    let n = t.rounds.last().unwrap().iterations;
    let before = &t.rounds[t.rounds.len() - 2];
    let asked = before.iterations as f64 * (before.error.unwrap() / target).powi(2);
    assert!(
        (n as f64) < 1.5 * asked.max(1.5 * before.iterations as f64),
        "{t:?}"
    );
    assert!(s.warnings.iter().all(|w| !w.contains("target_error")));
    // the published run is the fixed-length run of the final length, bit for bit
    let fixed = select(&with_rj_iterations(n));
    assert!(
        without_target(&s) == without_target(&fixed),
        "a target run must equal the fixed run of its final length ({n} iterations)"
    );
}

#[test]
fn a_budget_too_small_for_the_target_says_so_and_reports_what_it_reached() {
    let base = select(&study(""));
    let e0 = row(&base, "RJMCMC bridge").std_err.unwrap();
    let s = select(&study(&format!(
        "target_error = {}\nrj_max_iterations = 12000",
        e0 / 10.0
    )));
    let t = s.target.as_ref().unwrap();
    assert!(!t.met);
    assert_eq!(t.rounds.last().unwrap().iterations, 12000, "{t:?}");
    assert!(t.reached.unwrap() > e0 / 10.0);
    let note = t.note.as_deref().unwrap();
    assert!(note.contains("budget (12000"), "{note}");
    assert!(
        s.warnings
            .iter()
            .any(|w| w.contains("target_error not met")),
        "{:?}",
        s.warnings
    );
    let lines = occam::jobs::select::console(&s);
    assert!(lines.contains("not met: the budget"), "{lines}");
}

#[test]
fn the_cross_checks_share_changes_the_tempering_rows_and_nothing_else() {
    let full = select(&study(""));
    let light = select(&study("cross_checks = \"light\""));
    let off = select(&study("cross_checks = \"off\""));
    for s in [&light, &off] {
        for m in ["RJMCMC bridge", "RJMCMC Rao-Blackwell", "RJMCMC visits"] {
            assert_eq!(row(s, m).ln_b, row(&full, m).ln_b, "{m}");
            assert_eq!(row(s, m).std_err, row(&full, m).std_err, "{m}");
        }
        assert_eq!(s.models[0].map, full.models[0].map);
    }
    // light: the ladder with a quarter of the sweeps (1500 → 375, burn-in 300 → 75)
    let diag = light.models[0].tempering.as_ref().unwrap();
    assert_eq!((diag.sweeps, diag.burn_in), (375, 75));
    let full_evals = full.models[0].tempering.as_ref().unwrap().ln_l_evals as f64;
    let share = diag.ln_l_evals as f64 / full_evals;
    assert!((0.25..0.3).contains(&share), "{share}");
    for m in ["Thermodynamic integration", "Stepping-stone"] {
        let (l, f) = (row(&light, m), row(&full, m));
        // another (shorter) run: its own numbers (6 rungs: TI's error is the ladder's here)
        assert!(l.ln_b.is_some() && l.ln_b != f.ln_b, "{m}");
        let o = row(&off, m);
        assert!(o.ln_b.is_none(), "{m}");
        assert!(
            o.note
                .as_deref()
                .unwrap()
                .contains("cross_checks = \"off\"")
        );
    }
    assert!(off.models[0].tempering.is_none());
    let v = serde_json::to_value(&off).unwrap();
    assert_eq!(v["cross_checks"], "off");
    assert!(
        serde_json::to_value(&full)
            .unwrap()
            .get("cross_checks")
            .is_none()
    );
    assert!(occam::jobs::select::console(&light).contains("cross-checks light"));
}

#[test]
fn a_target_run_killed_in_a_later_round_resumes_to_the_same_numbers() {
    let base = select(&study(""));
    let e0 = row(&base, "RJMCMC bridge").std_err.unwrap();
    let s = study(&format!("target_error = {}", e0 / 2.2));
    let prep = occam::jobs::prepare::prepare(&s).unwrap();
    let whole = occam::jobs::select::run(&s, &prep, None).unwrap();
    let id = occam::jobs::select::identity(&s, &prep.dataset);
    let dir = tempfile::tempdir().unwrap();
    let ck = dir.path().join("checkpoint.cbor");
    // killed part-way through round 2 (its progress restarts below round 1's 6000)
    let crash = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        let mut last = 0;
        let mut cb = |p: &occam::evidence::RjProgress<'_>| {
            if p.n_iter > 6000 && p.iteration > 2000 {
                panic!("killed in round 2");
            }
            last = p.iteration;
        };
        let c = Checkpointing {
            path: &ck,
            state: SelectCheckpoint::new(id.clone()).save_stage_every(Duration::ZERO),
        };
        run_checkpointed(&s, &prep, Some(&mut cb), Some(c)).map(|_| ())
    }));
    assert!(crash.is_err(), "the callback must have stopped the run");
    let saved = SelectCheckpoint::read(&ck, &id).unwrap();
    let mut first = None;
    let mut seen = |p: &occam::evidence::RjProgress<'_>| {
        first.get_or_insert((p.iteration, p.n_iter));
    };
    let c = Checkpointing {
        path: &ck,
        state: saved,
    };
    let resumed = run_checkpointed(&s, &prep, Some(&mut seen), Some(c)).unwrap();
    // it went on in round 2, where it stopped: neither round 1 nor round 2 from its start
    let (it, n) = first.unwrap();
    assert!(n > 6000 && it > 2000, "first progress at {it} of {n}");
    assert!(
        numbers(serde_json::to_value(&whole).unwrap())
            == numbers(serde_json::to_value(&resumed).unwrap()),
        "a resumed target run must equal an uninterrupted one"
    );
}

#[test]
fn bad_target_settings_are_refused_naming_the_key() {
    let text = |extra: &str| small().replacen("[select]\n", &format!("[select]\n{extra}\n"), 1);
    for (extra, key) in [
        ("target_error = 0.0", "select.target_error"),
        ("target_error = -1e-3", "select.target_error"),
        ("rj_max_iterations = 100000", "select.rj_max_iterations"),
        (
            "target_error = 0.01\nrj_max_iterations = 100",
            "select.rj_max_iterations",
        ),
        ("cross_checks = \"light\"", "select.cross_checks"),
        ("cross_checks = \"some\"", "cross_checks"),
    ] {
        // `light` leaves (1500 − 300) / 4 = 300 sweeps: too few only with fewer sweeps
        let t = if extra.starts_with("cross_checks = \"light\"") {
            text(extra).replace("pt_iterations = 1500", "pt_iterations = 650")
        } else {
            text(extra)
        };
        let e = Study::from_toml(&t, "small.toml", Path::new("."))
            .unwrap_err()
            .to_string();
        assert!(e.contains(key), "{extra}: {e}");
    }
}

#[test]
fn the_command_line_flags_set_the_select_keys_and_the_run_records_them() {
    let (dir, out) = run_small(
        &["select"],
        &["--target-error", "1e-9", "--cross-checks", "off"],
    );
    assert!(out.contains("target ± 1.0e-9"), "{out}");
    assert!(out.contains("not met: the budget (96000"), "{out}");
    assert!(out.contains("cross-checks off"), "{out}");
    let run = dir.path().join("out/select");
    let s: serde_json::Value =
        serde_json::from_slice(&std::fs::read(run.join("summary.json")).unwrap()).unwrap();
    assert_eq!(s["cross_checks"], "off");
    assert_eq!(s["target"]["budget"], 96000);
    let resolved = std::fs::read_to_string(run.join("study.resolved.toml")).unwrap();
    let resolved: toml::Table = resolved.parse().unwrap();
    assert_eq!(resolved["select"]["target_error"].as_float(), Some(1e-9));
    assert_eq!(resolved["select"]["cross_checks"].as_str(), Some("off"));
    let table = std::fs::read_to_string(run.join("table.md")).unwrap();
    assert!(table.contains("target ± 1.0e-9"), "{table}");
    // a value the study file could not hold is refused naming the flag's key
    refused_target(&dir, &["select"]);
}

/// Runs `occam <command> small.toml --quiet <flags>` in a fresh directory holding
/// [`small`]; the directory and the standard output.
fn run_small(command: &[&str], flags: &[&str]) -> (tempfile::TempDir, String) {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("small.toml"), small()).unwrap();
    let args: Vec<&str> = [command, &["small.toml", "--quiet"], flags].concat();
    let (ok, out, err) = common::occam(&args, dir.path());
    assert!(ok, "{args:?}: {err}");
    (dir, out)
}

/// `--target-error=0`, which the study file could not hold either, is refused naming the key.
fn refused_target(dir: &tempfile::TempDir, command: &[&str]) {
    let args: Vec<&str> = [command, &["small.toml", "--quiet", "--target-error=0"]].concat();
    let (ok, _, err) = common::occam(&args, dir.path());
    assert!(
        !ok && err.contains("select.target_error"),
        "{args:?}: {err}"
    );
}

/// `occam sweep` takes the same flags: every point runs with them (no tempering with
/// `--cross-checks off`), and the sweep's resolved study records them.
#[test]
fn the_sweep_takes_the_select_flags() {
    let flags = ["--target-error", "0.5", "--cross-checks", "off"];
    let (dir, _) = run_small(&["sweep", "--snr", "30"], &flags);
    let run = dir.path().join("out/sweep");
    let resolved: toml::Table = std::fs::read_to_string(run.join("study.resolved.toml"))
        .unwrap()
        .parse()
        .unwrap();
    assert_eq!(resolved["select"]["target_error"].as_float(), Some(0.5));
    assert_eq!(resolved["select"]["cross_checks"].as_str(), Some("off"));
    let s: serde_json::Value =
        serde_json::from_slice(&std::fs::read(run.join("sweep.json")).unwrap()).unwrap();
    let rows = s["points"][0]["pairs"][0]["estimates"].as_array().unwrap();
    let value = |m: &str| rows.iter().find(|e| e["method"] == m).unwrap()["ln_b"].clone();
    assert!(value("Thermodynamic integration").is_null(), "{rows:?}");
    assert!(value("Stepping-stone").is_null(), "{rows:?}");
    assert!(value("RJMCMC bridge").is_number(), "{rows:?}");
    // refused by the key's name, as select refuses it
    refused_target(&dir, &["sweep", "--snr", "30"]);
}
