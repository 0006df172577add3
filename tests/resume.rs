//! Run directories and resumption: `select` checkpoints every stage and a resumed run gives
//! the numbers of an uninterrupted one, bit for bit; `--resume` with nothing to resume is an
//! error; a second run on a busy directory and an unusable directory are refused before any
//! work; a killed run leaves no temporaries and a manifest only when it finished.

mod common;
use common::occam;
use occam::jobs::select::{Checkpointing, STAGE_FILE, SelectCheckpoint, run_checkpointed};
use std::path::Path;
use std::time::Duration;

use common::{numbers, small, summary_numbers};

#[test]
fn select_resumed_after_a_crash_in_the_reversible_jump_stage_equals_an_uninterrupted_run() {
    let study = occam::config::Study::from_toml(&small(), "small.toml", Path::new(".")).unwrap();
    let prep = occam::jobs::prepare::prepare(&study).unwrap();
    let id = occam::jobs::select::identity(&study, &prep.dataset);
    let dir = tempfile::tempdir().unwrap();
    let ck = dir.path().join("checkpoint.cbor");

    let whole = occam::jobs::select::run(&study, &prep, None).unwrap();

    // a crash part-way through the reversible-jump run: both model stages are saved
    let crash = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        let mut cb = |p: &occam::evidence::RjProgress<'_>| {
            if p.iteration > 1000 {
                panic!("killed");
            }
        };
        let c = Checkpointing {
            path: &ck,
            state: SelectCheckpoint::new(id.clone()).save_stage_every(Duration::ZERO),
        };
        run_checkpointed(&study, &prep, Some(&mut cb), Some(c)).map(|_| ())
    }));
    assert!(crash.is_err(), "the callback must have stopped the run");
    // the jump chains' state as of the last block before the crash
    let stage = dir.path().join(STAGE_FILE);
    let (kind, _) = occam::data::checkpoint::head(&stage).unwrap();
    assert_eq!(kind, occam::evidence::rjmcmc::KIND);
    let saved = SelectCheckpoint::read(&ck, &id).unwrap();
    let names = vec!["X".to_string(), "Y".to_string()];
    assert_eq!(
        saved.describe(&names),
        "models done: X, Y; to run: none; reversible jump to run"
    );
    let c = Checkpointing {
        path: &ck,
        state: saved,
    };
    let mut first = None;
    let mut seen = |p: &occam::evidence::RjProgress<'_>| {
        first.get_or_insert(p.iteration);
    };
    let resumed = run_checkpointed(&study, &prep, Some(&mut seen), Some(c)).unwrap();
    // it continued the jump chains where they stopped, not from their start
    let first = first.unwrap();
    assert!(first > 1000, "first progress at iteration {first}");
    assert!(!stage.exists(), "a finished stage leaves no stage file");
    let a = numbers(serde_json::to_value(&whole).unwrap());
    let b = numbers(serde_json::to_value(&resumed).unwrap());
    assert!(a == b, "a resumed select must equal an uninterrupted one");

    // resuming a finished run recomputes nothing and still gives the same numbers
    let done = SelectCheckpoint::read(&ck, &id).unwrap();
    assert!(done.describe(&names).ends_with("reversible jump done"));
    let c = Checkpointing {
        path: &ck,
        state: done,
    };
    let again = run_checkpointed(&study, &prep, None, Some(c)).unwrap();
    assert!(numbers(serde_json::to_value(&again).unwrap()) == a);

    // the sample files too, byte for byte, whether the jump run was redone or read back
    let files = |s: &occam::jobs::select::SelectSummary, name: &str| {
        let out = dir.path().join(name);
        occam::jobs::select::write_outputs(s, &out).unwrap();
        ["chains_X.npz", "chains_Y.npz", "rj_chain.npz"]
            .map(|f| std::fs::read(out.join(f)).unwrap_or_else(|e| panic!("{f}: {e}")))
    };
    let w = files(&whole, "whole");
    assert!(
        w == files(&resumed, "resumed"),
        "resumed sample files differ"
    );
    assert!(w == files(&again, "again"), "sample files read back differ");

    // a checkpoint of another version is refused with the way out
    let mut v: ciborium::Value = ciborium::from_reader(std::fs::File::open(&ck).unwrap()).unwrap();
    for (k, val) in v.as_map_mut().unwrap() {
        if k.as_text() == Some("version") {
            *val = ciborium::Value::Integer(1.into());
        }
    }
    let old = dir.path().join("old.cbor");
    ciborium::into_writer(&v, std::fs::File::create(&old).unwrap()).unwrap();
    let e = SelectCheckpoint::read(&old, &id).unwrap_err().to_string();
    assert!(
        e.contains("checkpoint version 1 of `select`") && e.contains("run without --resume"),
        "{e}"
    );

    // a checkpoint of other data is refused
    let mut other = prep.dataset.clone();
    other.experiments[0].o[0][3] += 1e-12;
    let e = SelectCheckpoint::read(&ck, &occam::jobs::select::identity(&study, &other))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("belongs to a different run") && e.contains("without --resume"),
        "{e}"
    );
}

#[test]
fn resume_with_nothing_to_resume_is_an_error_for_every_command() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("s.toml"), small()).unwrap();
    for cmd in ["fit", "select", "sweep"] {
        let (ok, _, err) = occam(&[cmd, "s.toml", "-q", "--resume"], dir.path());
        assert!(!ok, "{cmd}");
        assert!(
            err.contains("nothing to resume") && err.contains("run without --resume"),
            "{cmd}: {err}"
        );
    }
    // a sweep with no finished task but one in progress (its stage file there) has something
    // to resume: it continues that task, here from a damaged stage file, which it names
    let out = dir.path().join("out/sweep");
    let sweep = occam::jobs::sweep::Sweep::load(
        &dir.path().join("s.toml"),
        occam::jobs::sweep::SweepArgs {
            output: Some(out.clone()),
            ..Default::default()
        },
    )
    .unwrap();
    let (_, stage) = sweep.task_checkpoints(0);
    std::fs::create_dir_all(stage.parent().unwrap()).unwrap();
    std::fs::write(&stage, b"half a stage").unwrap();
    assert_eq!((sweep.finished_tasks(), sweep.started_tasks()), (0, 1));
    let (_, _, err) = occam(&["sweep", "s.toml", "-q", "--resume"], dir.path());
    assert!(!err.contains("nothing to resume"), "{err}");
}

#[test]
fn a_busy_or_unusable_directory_is_refused_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("s.toml"), small()).unwrap();
    let held = occam::data::rundir::RunDir::open(&dir.path().join("out/select")).unwrap();
    let (ok, _, err) = occam(&["select", "s.toml", "-q"], dir.path());
    assert!(!ok);
    assert!(
        err.contains("another occam run is writing into this directory")
            && err.contains(&format!("process {}", std::process::id())),
        "{err}"
    );
    drop(held);
    std::fs::write(dir.path().join("plain"), b"").unwrap();
    for cmd in ["simulate", "fit", "select", "sweep"] {
        let (ok, out, err) = occam(&[cmd, "s.toml", "-o", "plain/out"], dir.path());
        assert!(!ok, "{cmd}");
        assert!(
            err.contains("plain/out") && err.contains("-o/--output"),
            "{cmd}: {err}"
        );
        // found before any work: no data were prepared (their `data:` line is the first
        // thing a job logs), rather than a timing, which a loaded machine would break
        assert!(
            !err.contains("data:") && !out.contains("data:"),
            "{cmd}: {out}{err}"
        );
    }
}

/// `select` killed with SIGKILL as soon as its first stage is saved, then resumed: the
/// directory ends as an uninterrupted run's, with no temporaries left.
#[cfg(unix)]
#[test]
fn select_killed_mid_run_and_resumed_matches_an_uninterrupted_run() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("s.toml"), small()).unwrap();
    let (ok, _, err) = occam(&["select", "s.toml", "-q", "-o", "whole"], d);
    assert!(ok, "{err}");

    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_occam"))
        .args(["select", "s.toml", "-q", "-o", "cut"])
        .current_dir(d)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let ck = d.join("cut").join(occam::jobs::select::CHECKPOINT_FILE);
    let t0 = std::time::Instant::now();
    while !ck.exists() && t0.elapsed().as_secs() < 120 {
        if child.try_wait().unwrap().is_some() {
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    let _ = child.kill();
    child.wait().unwrap();
    assert!(ck.exists(), "the first stage must have been checkpointed");
    let (ok, out, err) = occam(&["select", "s.toml", "-q", "-o", "cut", "--resume"], d);
    assert!(ok, "{err}");
    assert!(out.contains("resuming from"), "{out}");
    assert!(summary_numbers(&d.join("whole")) == summary_numbers(&d.join("cut")));
    for f in [
        "table.txt",
        "residual_psd.npz",
        "chains_X.npz",
        "chains_Y.npz",
        "rj_chain.npz",
    ] {
        assert_eq!(
            std::fs::read(d.join("whole").join(f)).unwrap(),
            std::fs::read(d.join("cut").join(f)).unwrap(),
            "{f}"
        );
    }
    let m =
        occam::data::rundir::Manifest::read(&d.join("cut")).expect("a finished run has a manifest");
    for f in &m.files {
        assert!(d.join("cut").join(&f.name).exists(), "{}", f.name);
    }
    let leftovers: Vec<String> = std::fs::read_dir(d.join("cut"))
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains(".tmp") || n == ".staging")
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
}

/// Interrupted (Ctrl-C) inside a model's tempering stage (the stage saved after every block),
/// `select` says what it kept and how to continue and exits with 130; `select --resume`
/// continues that stage from `stage.cbor` instead of starting it again, and ends with the
/// numbers and sample files of an uninterrupted run.
#[test]
fn select_killed_inside_a_stage_resumes_the_stage_where_it_stood() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // a tempering stage long enough (≈ a second) to be killed inside
    let study = small().replace("pt_iterations = 1500", "pt_iterations = 40000");
    std::fs::write(d.join("s.toml"), study).unwrap();
    let (ok, _, err) = occam(&["select", "s.toml", "-q", "-o", "whole"], d);
    assert!(ok, "{err}");

    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_occam"))
        .args(["select", "s.toml", "-q", "-o", "cut"])
        .env("OCCAM_CHECKPOINT_SECONDS", "0")
        .current_dir(d)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let stage = d.join("cut").join(STAGE_FILE);
    let tempering = || {
        occam::data::checkpoint::head(&stage)
            .is_ok_and(|(kind, _)| kind == occam::evidence::tempering::KIND)
    };
    let t0 = std::time::Instant::now();
    while !tempering() && t0.elapsed().as_secs() < 120 {
        if child.try_wait().unwrap().is_some() {
            break;
        }
        std::thread::sleep(Duration::from_millis(1));
    }
    // Ctrl-C: the run says what it kept and how to continue, and exits with 130
    // SAFETY: kill(2) on the pid of the child this test spawned and has not reaped
    assert_eq!(unsafe { libc::kill(child.id() as i32, libc::SIGINT) }, 0);
    let ended = child.wait_with_output().unwrap();
    assert!(
        tempering(),
        "the run must have been interrupted inside a tempering stage"
    );
    assert_eq!(ended.status.code(), Some(130));
    let said = String::from_utf8_lossy(&ended.stderr);
    assert!(
        said.contains("interrupted: cut keeps the checkpoint")
            && said.contains("`occam select s.toml -o cut --resume`"),
        "{said}"
    );

    let (ok, out, err) = occam(&["select", "s.toml", "-q", "-o", "cut", "--resume"], d);
    assert!(ok, "{err}");
    assert!(
        out.contains("and the stage in progress from") && out.contains("/tempering"),
        "{out}"
    );
    assert!(summary_numbers(&d.join("whole")) == summary_numbers(&d.join("cut")));
    for f in ["table.txt", "chains_X.npz", "chains_Y.npz", "rj_chain.npz"] {
        assert_eq!(
            std::fs::read(d.join("whole").join(f)).unwrap(),
            std::fs::read(d.join("cut").join(f)).unwrap(),
            "{f}"
        );
    }
    assert!(!stage.exists(), "a finished run leaves no stage file");

    // a value of the variable that is not a number of seconds is refused, naming it
    let bad = std::process::Command::new(env!("CARGO_BIN_EXE_occam"))
        .args(["select", "s.toml", "-q", "-o", "bad"])
        .env("OCCAM_CHECKPOINT_SECONDS", "soon")
        .current_dir(d)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&bad.stderr);
    assert!(!bad.status.success());
    assert!(err.contains("OCCAM_CHECKPOINT_SECONDS = `soon`"), "{err}");
}

#[test]
fn a_rerun_removes_the_previous_runs_files_it_does_not_write() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("s.toml"), small()).unwrap();
    // a directory of an older occam: a figure this run does not draw
    std::fs::create_dir_all(d.join("out/select")).unwrap();
    std::fs::write(d.join("out/select/residual_psd_old.png"), b"stale").unwrap();
    std::fs::write(d.join("out/select/chains_Gone.npz"), b"stale").unwrap();
    std::fs::write(d.join("out/select/my-notes.txt"), b"the user's").unwrap();
    let (ok, out, err) = occam(&["select", "s.toml", "-q"], d);
    assert!(ok, "{err}");
    assert!(!d.join("out/select/residual_psd_old.png").exists());
    assert!(!d.join("out/select/chains_Gone.npz").exists());
    assert!(d.join("out/select/rj_chain.npz").exists());
    assert!(d.join("out/select/my-notes.txt").exists());
    // the files it says it wrote are exactly those on disk, listed in the manifest
    let line = out.lines().find(|l| l.starts_with("wrote ")).unwrap();
    let m = occam::data::rundir::Manifest::read(&d.join("out/select")).unwrap();
    for f in &m.files {
        assert!(line.contains(&f.name), "{line} lacks {}", f.name);
        assert!(d.join("out/select").join(&f.name).exists());
    }
    assert!(!line.contains("my-notes.txt"), "{line}");
}

#[test]
fn a_fit_resumed_with_another_likelihood_kind_is_refused() {
    // the chains of a relative-binned fit must not be continued (and published) as exact ones
    let dir = tempfile::tempdir().unwrap();
    let exact = small().replace("[analysis]\n", "[analysis]\nlikelihood = \"exact\"\n");
    std::fs::write(dir.path().join("s.toml"), &exact).unwrap();
    let (ok, _, err) = occam(&["fit", "s.toml", "-q", "-o", "f"], dir.path());
    assert!(ok, "{err}");
    assert!(dir.path().join("f/checkpoint.cbor").exists());
    // the same study resumes (a finished fit has nothing left to do)
    let (ok, _, err) = occam(&["fit", "s.toml", "-q", "-o", "f", "--resume"], dir.path());
    assert!(ok, "{err}");
    // a changed prior is named by its parameter and [prior] entries (it printed both prior
    // vectors in Debug form, 390–640 bytes)
    let wider =
        format!("{exact}\n[prior]\nd21 = {{ kind = \"uniform\", lo = -2e-3, hi = 2e-3 }}\n");
    std::fs::write(dir.path().join("s.toml"), &wider).unwrap();
    let (ok, _, err) = occam(&["fit", "s.toml", "-q", "-o", "f", "--resume"], dir.path());
    assert!(!ok, "a changed prior was resumed");
    assert!(
        (err.contains("d21 = { kind = \"uniform\", lo = -0.002, hi = 0.002 }")
            || err.contains("`prior.d21` changed"))
            && !err.contains("Uniform {")
            && err.len() < 500,
        "{err}"
    );
    let relbin = exact.replace("likelihood = \"exact\"", "likelihood = \"relbin\"");
    std::fs::write(dir.path().join("s.toml"), relbin).unwrap();
    let (ok, _, err) = occam(&["fit", "s.toml", "-q", "-o", "f", "--resume"], dir.path());
    assert!(!ok, "a changed likelihood kind was resumed");
    assert!(
        err.contains("belongs to a different run")
            && err.contains("`analysis.likelihood` changed")
            && err.contains("run without --resume"),
        "{err}"
    );
}

#[test]
fn a_refused_resume_names_what_changed() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("s.toml"), small()).unwrap();
    let (ok, _, err) = occam(&["select", "s.toml", "-q", "-o", "s"], d);
    assert!(ok, "{err}");
    let cases = [
        (
            "[analysis]\n",
            "[analysis]\nwelch_averages = 4\n",
            "`analysis.welch_averages` changed",
        ),
        ("seed = ", "seed = 1", "`seed` changed"),
    ];
    for (from, to, want) in cases {
        std::fs::write(d.join("s.toml"), small().replacen(from, to, 1)).unwrap();
        let (ok, _, err) = occam(&["select", "s.toml", "-q", "-o", "s", "--resume"], d);
        assert!(!ok, "{want}: resumed");
        assert!(
            err.contains("belongs to a different run") && err.contains(want) && err.len() < 400,
            "{want}: {err}"
        );
    }
}
