//! The acceleration-domain examples beyond their own data (K14 §III.C): A1 ≠ A2 selects the
//! asymmetric model decisively, with the files of a many-model run, and a sweep over the
//! actuator gain. The examples as they are (the pole against the delay, the symmetric
//! actuators) are held to their references in `tests/headline/mod.rs`, on their golden records.

use occam::config::Study;
use occam::jobs::prepare::prepare;
use occam::jobs::select::{PairResult, SelectSummary, run};
use std::path::Path;

fn reference(p: &PairResult) -> f64 {
    p.estimates
        .iter()
        .find(|e| e.method == p.reference)
        .and_then(|e| e.ln_b)
        .expect("a reference ln B")
}

fn select(s: &Study) -> SelectSummary {
    let prep = prepare(s).unwrap();
    run(s, &prep, None).unwrap()
}

fn winner(out: &SelectSummary) -> String {
    let p = out.posterior_model_probabilities.as_ref().unwrap();
    let k = (0..p.len()).max_by(|&a, &b| p[a].total_cmp(&p[b])).unwrap();
    out.models[k].name.clone()
}

#[test]
fn unequal_actuator_gains_pick_the_asymmetric_model() {
    // the symmetric actuators of the example itself: `tests/headline/mod.rs`, on its golden
    // record (the winner, the visits, one Fig. 2 or a warning per pair)
    let s = Study::load(Path::new("examples/accel-asymmetry.toml")).unwrap();
    assert!(s.select_models.len() >= 6);
    // K14's next data challenge: A1 ≠ A2
    let mut a = s.clone();
    a.simulation.actuators.tm1.gain = Some(1.075);
    // the winner, the reference ln B and the files need no tempering (most of a select's
    // time); the golden `select-accel-asymmetry` runs these models with it
    a.select.cross_checks = occam::config::CrossChecks::Off;
    let asym = select(&a);
    let visits = &asym.rj.as_ref().unwrap().visits;
    assert_eq!(winner(&asym), "asym-gain");
    let p = asym
        .pairs
        .iter()
        .find(|p| p.x == "sym" && p.y == "asym-gain")
        .unwrap();
    eprintln!(
        "A1 = 1.075, A2 = 1.08: visits {visits:?}, ln B(sym/asym-gain) = {:.1}",
        reference(p)
    );
    assert!(reference(p) < -(1e6f64).ln(), "{}", reference(p));
    // the files of a many-model run: one Fig. 2 per pair (or a warning saying why not — a note
    // when the models exchange no jumps and the answer does not need them), each model's
    // chains, the jump chain over the union of the parameters
    let dir = tempfile::tempdir().unwrap();
    occam::jobs::select::write_outputs(&asym, dir.path()).unwrap();
    assert!(!dir.path().join("bayes_factor.svg").exists());
    for p in &asym.pairs {
        let drawn = dir
            .path()
            .join(format!("bayes_factor_{}_{}.svg", p.x, p.y))
            .exists();
        let said = |lines: &[String]| {
            lines
                .iter()
                .any(|w| w.starts_with(&format!("{}/{}: no Fig. 2", p.x, p.y)))
        };
        let (warned, noted) = (said(&asym.warnings), said(&asym.notes));
        assert!(!(warned && noted), "{}/{}", p.x, p.y);
        assert_eq!(noted, !drawn && p.jumps.note.is_some(), "{}/{}", p.x, p.y);
        let warned = warned || noted;
        assert!(
            drawn != warned,
            "{}/{}: drawn {drawn}, warned {warned}",
            p.x,
            p.y
        );
    }
    let mut z = occam::data::npz::NpzArchive::open(&dir.path().join("rj_chain.npz")).unwrap();
    let (shape, names) = z.read_array("model_names", u64::MAX).unwrap();
    assert_eq!(shape, [asym.models.len() as u64]);
    let want: Vec<String> = asym.models.iter().map(|m| m.name.clone()).collect();
    assert_eq!(names, occam::data::npz::NpyValues::Str(want));
    let (shape, _) = z.read_array("samples", u64::MAX).unwrap();
    let widest = asym.models.iter().map(|m| m.free.len()).max().unwrap() as u64;
    assert!(shape[2] >= widest, "{shape:?}");
    for m in &asym.models {
        let f = dir.path().join(occam::jobs::select::chains_file(&m.name));
        let mut z = occam::data::npz::NpzArchive::open(&f).unwrap();
        let (shape, names) = z.read_array("param_names", u64::MAX).unwrap();
        assert_eq!(shape, [m.free.len() as u64], "{}", m.name);
        assert_eq!(names, occam::data::npz::NpyValues::Str(m.free.clone()));
    }
}

/// A sweep over the TM1 actuator gain runs on acceleration-domain models (which have no ρ_opt:
/// it is null in the task records) and picks the symmetric model, then the asymmetric one.
#[test]
fn a_sweep_over_the_actuator_gain_runs_in_the_acceleration_domain() {
    use occam::jobs::exec::Threads;
    use occam::jobs::sweep::{Sweep, SweepArgs, write_outputs};
    let text = r#"seed = 9
output = "unused"
[simulation.actuators]
tm1 = { pole = 1.963 }
tm2 = { pole = 1.963 }
[[experiment]]
name = "forces"
fs = 10.0
pre_pad = 100.0
post_pad = 100.0
noise_duration = 3000.0
f1 = { kind = "sine", freq = 0.3, amplitude = 3e-10, duration = 600.0 }
f2 = { kind = "sine", freq = 0.5, amplitude = 3e-10, duration = 600.0 }
[analysis]
band = [1e-2, 2.0]
[[model]]
kind = "accel"
name = "asym"
[[model]]
kind = "tied"
name = "sym"
of = "asym"
tie = { a2 = "a1", f_o2 = "f_o1" }
[select]
rj_iterations = 6000
rj_burn_in = 1000
iterations = 3000
burn_in = 1000
pt_temperatures = 0
[[select.model]]
name = "sym"
model = "sym"
fixed = { w1sq = -1.3e-6, w2sq = -1.9e-6 }
free = ["a1", "f_o1"]
[[select.model]]
name = "asym-gain"
model = "asym"
free = ["a1", "a2", "f_o1"]
fixed = { w1sq = -1.3e-6, w2sq = -1.9e-6, f_o2 = 1.963 }
[sweep]
realisations = 1
[[sweep.axis]]
key = "simulation.actuators.tm1.gain"
values = [1.08, 1.0]
"#;
    let dir = tempfile::tempdir().unwrap();
    let args = SweepArgs {
        output: Some(dir.path().to_path_buf()),
        ..Default::default()
    };
    let s = Sweep::from_text(text, "gain.toml", Path::new("."), args).unwrap();
    let r = s.run(&Threads::new(2).unwrap(), false).unwrap().unwrap();
    write_outputs(&s, &r, &s.out).unwrap();
    let o: Vec<_> = r
        .records
        .iter()
        .map(|t| t.outcome.as_ref().unwrap())
        .collect();
    assert!(o.iter().all(|x| x.rho_opt.is_none()));
    assert_eq!(
        o[0].pick(),
        Some(0),
        "equal gains: {:?}",
        o[0].posterior_model_probabilities
    );
    assert_eq!(
        o[1].pick(),
        Some(1),
        "A1 = 1.0: {:?}",
        o[1].posterior_model_probabilities
    );
}
