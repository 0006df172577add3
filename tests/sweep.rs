//! `occam sweep` end to end: a 2-D grid with realisations (identical bytes on 1 and 2 threads,
//! a rerun reuses finished tasks), bad keys caught before any computing, and the paper's two
//! design studies (Fig. 5 and Fig. 6) on reduced grids.

use occam::jobs::exec::Threads;
use occam::jobs::sweep::grid::{Axis, parse_axis};
use occam::jobs::sweep::{Sweep, SweepArgs};
use std::path::Path;

/// Gain-only against gain + thruster pole on one short sinusoid: each task takes a fraction of
/// a second.
const SMALL: &str = r#"
seed = 5
output = "unused"
[simulation]
target_snr = 30.0
thruster = { response = "pole", value = 0.3 }
[[model]]
kind = "ltp"
name = "pole"
thruster = "pole"
[prior]
f_df = { kind = "uniform", lo = 0.05, hi = 3.0 }
[select]
rj_iterations = 8000
rj_burn_in = 1000
iterations = 3000
burn_in = 1000
pt_temperatures = 0
[[select.model]]
name = "X"
free = ["a_df"]
fixed = { w1sq = -1.3e-6, w2sq = -1.9e-6, dt1 = 0.2, dt2 = 0.2, a_sus = 1.08, d21 = 4e-4 }
[[select.model]]
name = "Y"
model = "pole"
free = ["a_df", "f_df"]
fixed = { w1sq = -1.3e-6, w2sq = -1.9e-6, dt1 = 0.2, dt2 = 0.2, a_sus = 1.08, d21 = 4e-4 }
[sweep]
realisations = 2
truth = "Y"
[[sweep.axis]]
key = "simulation.target_snr"
values = [20.0, 3000.0]
[[sweep.axis]]
key = "simulation.thruster.value"
values = [0.1, 0.3]
[[experiment]]
name = "inv1"
pre_pad = 1000.0
post_pad = 3000.0
noise_duration = 5000.0
x1 = { kind = "sine", freq = 0.01, amplitude = 1e-6, duration = 2000.0 }
"#;

fn small(out: &Path) -> Sweep {
    let args = SweepArgs {
        output: Some(out.to_path_buf()),
        ..Default::default()
    };
    Sweep::from_text(SMALL, "small.toml", Path::new("."), args).unwrap()
}

fn run(s: &Sweep, threads: usize) -> occam::jobs::sweep::SweepResult {
    let r = s
        .run(&Threads::new(threads).unwrap(), false)
        .unwrap()
        .unwrap();
    let run = occam::data::rundir::RunDir::open(&s.out).unwrap();
    occam::jobs::sweep::publish(s, &r, &run).unwrap();
    r
}

fn bytes(dir: &Path, f: &str) -> Vec<u8> {
    std::fs::read(dir.join(f)).unwrap()
}

#[test]
fn a_2d_sweep_is_the_same_on_any_number_of_threads_and_resumes_where_it_stopped() {
    let d = tempfile::tempdir().unwrap();
    let (a, b) = (d.path().join("one"), d.path().join("two"));
    let s1 = small(&a);
    assert_eq!((s1.grid.len(), s1.task_count()), (4, 8));
    let r1 = run(&s1, 1);
    assert_eq!((r1.computed, r1.reused), (8, 0));
    let r2 = run(&small(&b), 2);
    for f in ["sweep.json", "sweep.npz", "table.txt"] {
        assert!(
            bytes(&a, f) == bytes(&b, f),
            "{f} differs between 1 and 2 threads"
        );
    }
    // the strong-signal points pick the true model; the grid and stats are where they belong
    for p in &r2.points {
        assert_eq!(p.realisations, 2);
        assert_eq!(p.failed, 0, "{:?}", p.first_error);
        if p.values[0] == 3000.0 {
            assert_eq!(p.correct, Some(1.0), "point {:?}", p.values);
        }
    }
    let npz = a.join("sweep.npz");
    let mut z = ndarray_npy::NpzReader::new(std::fs::File::open(&npz).unwrap()).unwrap();
    let shape: ndarray::ArrayD<i64> = z.by_name("grid_shape").unwrap();
    assert_eq!(shape.as_slice().unwrap(), &[2, 2]);
    let ln_b: ndarray::ArrayD<f64> = z.by_name("ln_b").unwrap();
    assert_eq!(&ln_b.shape()[..3], &[4, 2, 1]);
    let median: ndarray::ArrayD<f64> = z.by_name("median").unwrap();
    assert_eq!(
        median[[3, 0, 0]],
        r1.points[3].pairs[0].estimators[0].median.unwrap()
    );
    // a killed run: three tasks lost, a temporary file left behind
    let tasks = a.join("tasks");
    let mut files: Vec<_> = std::fs::read_dir(&tasks)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    files.sort();
    assert_eq!(files.len(), 8);
    for f in &files[..3] {
        std::fs::remove_file(f).unwrap();
    }
    std::fs::write(tasks.join(".0123.cbor.tmp-999"), b"half").unwrap();
    let json_before = bytes(&a, "sweep.json");
    let r3 = run(&small(&a), 2);
    assert_eq!((r3.computed, r3.reused), (3, 5));
    assert!(
        bytes(&a, "sweep.json") == json_before,
        "a resumed sweep must give the same numbers"
    );
    assert!(
        !tasks.join(".0123.cbor.tmp-999").exists(),
        "stale temporaries are removed"
    );
    // a third run computes nothing
    let r4 = run(&small(&a), 1);
    assert_eq!((r4.computed, r4.reused), (0, 8));
    assert!(a.join("ln_b_map.png").exists() && a.join("ln_b_map.svg").exists());
    // the same directory as a 1-D sweep: its figure replaces the map
    let args = SweepArgs {
        axes: Some(vec![parse_axis("simulation.target_snr=20,3000").unwrap()]),
        output: Some(a.clone()),
        ..Default::default()
    };
    let s1d = Sweep::from_text(SMALL, "small.toml", Path::new("."), args).unwrap();
    let r5 = run(&s1d, 2);
    assert_eq!(r5.points.len(), 2);
    assert!(a.join("ln_b_vs_snr.png").exists());
    assert!(
        !a.join("ln_b_map.png").exists(),
        "a stale figure must not stay"
    );
}

/// A sweep killed inside a task (the task's select saves its stage in progress after every
/// block) continues that task from its own checkpoint and stage file on the rerun, ends with
/// the numbers of an uninterrupted sweep, and leaves only the task's record behind.
#[test]
fn a_sweep_killed_inside_a_task_continues_the_task() {
    let d = tempfile::tempdir().unwrap();
    let one_task = SMALL
        .replace("realisations = 2", "realisations = 1")
        .replace("values = [20.0, 3000.0]", "values = [3000.0]")
        .replace("values = [0.1, 0.3]", "values = [0.3]")
        .replace(
            "pt_temperatures = 0",
            "pt_temperatures = 6\npt_iterations = 40000\npt_burn_in = 300",
        );
    std::fs::write(d.path().join("s.toml"), &one_task).unwrap();
    let sweep = |out: &str| {
        let mut c = std::process::Command::new(env!("CARGO_BIN_EXE_occam"));
        c.args(["sweep", "s.toml", "-q", "-o", out])
            .env("OCCAM_CHECKPOINT_SECONDS", "0")
            .current_dir(d.path())
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::piped());
        c
    };
    let whole = sweep("whole").output().unwrap();
    assert!(
        whole.status.success(),
        "{}",
        String::from_utf8_lossy(&whole.stderr)
    );

    let mut child = sweep("cut").spawn().unwrap();
    let tasks = d.path().join("cut/tasks");
    // inside a later stage: a finished stage saved and the next one in progress
    let in_task = || {
        let has = |end: &str| {
            std::fs::read_dir(&tasks).is_ok_and(|rd| {
                rd.flatten()
                    .any(|e| e.file_name().to_string_lossy().ends_with(end))
            })
        };
        has(".select.cbor") && has(".stage.cbor")
    };
    let t0 = std::time::Instant::now();
    while !in_task() && t0.elapsed().as_secs() < 120 {
        if child.try_wait().unwrap().is_some() {
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(1));
    }
    let _ = child.kill();
    child.wait().unwrap();
    assert!(in_task(), "the sweep must have been killed inside its task");
    let names = |dir: &Path| {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .flatten()
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    };

    let rerun = sweep("cut").output().unwrap();
    assert!(
        rerun.status.success(),
        "{}",
        String::from_utf8_lossy(&rerun.stderr)
    );
    for f in ["sweep.json", "sweep.npz", "table.txt"] {
        assert!(
            bytes(&d.path().join("whole"), f) == bytes(&d.path().join("cut"), f),
            "{f} differs from the uninterrupted sweep"
        );
    }
    let left = names(&tasks);
    assert_eq!(left.len(), 1, "{left:?}");
    assert!(
        left[0].ends_with(".cbor") && !left[0].contains(".select."),
        "{left:?}"
    );
}

#[test]
fn a_bad_key_or_value_is_an_error_before_anything_runs() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("bad");
    for (axis, needle) in [
        ("experiment.nope.x1.freq=0.1,0.2", "no entry named `nope`"),
        ("simulation.target_snr=10,-1", "target_snr"),
        ("experiment.inv1.name=1", "holds a string"),
        ("simulation.thruster.valu=1,2", "valu"),
    ] {
        let args = SweepArgs {
            axes: Some(vec![parse_axis(axis).unwrap()]),
            output: Some(out.clone()),
            ..Default::default()
        };
        let e = format!(
            "{:#}",
            Sweep::from_text(SMALL, "small.toml", Path::new("."), args).unwrap_err()
        );
        assert!(
            e.contains(needle) && e.contains("small.toml"),
            "{axis}: {e}"
        );
    }
    assert!(
        !out.exists(),
        "nothing may be written for a sweep that cannot run"
    );
    // an unknown truth, from the command line
    let args = SweepArgs {
        truth: Some("Z".into()),
        ..Default::default()
    };
    let e = Sweep::from_text(SMALL, "small.toml", Path::new("."), args)
        .unwrap_err()
        .to_string();
    assert!(e.contains("sweep.truth") && e.contains("`Z`"), "{e}");
}

fn example(file: &str, axis: Axis, realisations: usize, out: &Path) -> Sweep {
    let args = SweepArgs {
        axes: Some(vec![axis]),
        realisations: Some(realisations),
        output: Some(out.to_path_buf()),
        ..Default::default()
    };
    Sweep::load(Path::new(file), args).unwrap()
}

#[test]
fn fig5_the_pole_wins_decisively_only_at_high_snr() {
    let d = tempfile::tempdir().unwrap();
    let axis = parse_axis("simulation.target_snr=10,5000").unwrap();
    let s = example("examples/design-snr.toml", axis, 2, d.path());
    let r = run(&s, 2);
    let (low, high) = (&r.points[0], &r.points[1]);
    let med = |p: &occam::jobs::sweep::stats::PointStats| p.pairs[0].estimators[0].median.unwrap();
    assert!(med(low).abs() < 1.0, "SNR 10: ln B_XY = {}", med(low));
    assert!(med(high) < -5.0, "SNR 5000: ln B_XY = {}", med(high));
    assert_eq!(high.correct, Some(1.0));
    assert_eq!(high.pairs[0].agree, 1.0, "{:?}", high.pairs[0]);
}

#[test]
fn fig6_the_cross_talk_free_model_is_favoured_near_50_mhz_not_at_the_low_end() {
    let d = tempfile::tempdir().unwrap();
    let axis = parse_axis("experiment.scan.x1.freq=1e-4,0.05").unwrap();
    // one realisation's ln B_XY scatters by ±0.7 (½χ²₁ of the noise along d21) around the
    // Occam factor: medians of five
    let s = example("examples/design-frequency.toml", axis, 5, d.path());
    let r = run(&s, 2);
    let med = |k: usize| r.points[k].pairs[0].estimators[0].median.unwrap();
    assert!(med(0).abs() < 0.5, "x1 at 0.1 mHz: ln B_XY = {}", med(0));
    assert!(med(1) > 0.5, "x1 at 50 mHz: ln B_XY = {}", med(1));
    assert!(
        r.points[1].correct.unwrap() >= 0.6,
        "{:?}",
        r.points[1].picks
    );
}
