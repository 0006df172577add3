//! The options every long command shares: `--threads` changes no number, `-q` and a pipe
//! draw no progress bar, and each of simulate, fit, select, sweep and demo takes both.

mod common;
use common::{occam, small, summary_numbers};

#[test]
fn every_long_command_takes_quiet_and_threads() {
    let dir = tempfile::tempdir().unwrap();
    for cmd in ["simulate", "fit", "select", "sweep", "demo"] {
        let (ok, help, err) = occam(&[cmd, "--help"], dir.path());
        assert!(ok, "{cmd}: {err}");
        assert!(help.contains("-q, --quiet"), "{cmd}: {help}");
        assert!(help.contains("--threads <THREADS>"), "{cmd}: {help}");
    }
    let (ok, help, _) = occam(&["design", "--help"], dir.path());
    assert!(ok && help.contains("--threads <THREADS>"), "{help}");
}

#[test]
fn the_thread_count_changes_no_number() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("s.toml"), small()).unwrap();
    for cmd in ["fit", "select"] {
        let runs: Vec<std::path::PathBuf> = ["1", "2"]
            .iter()
            .map(|t| {
                let out = format!("{cmd}-{t}");
                let (ok, _, err) = occam(
                    &[cmd, "s.toml", "--threads", t, "-q", "-o", &out],
                    dir.path(),
                );
                assert!(ok, "{cmd} --threads {t}: {err}");
                // a pipe is not a terminal: no bar, no escape codes
                assert!(!err.contains('\u{1b}') && !err.contains('█'), "{err}");
                dir.path().join(out)
            })
            .collect();
        assert_eq!(
            summary_numbers(&runs[0]),
            summary_numbers(&runs[1]),
            "{cmd}: summary.json differs between 1 and 2 threads"
        );
        if cmd == "fit" {
            let read = |d: &std::path::Path| std::fs::read(d.join("chains.npz")).unwrap();
            assert!(read(&runs[0]) == read(&runs[1]), "chains.npz differs");
        }
    }
    let (ok, _, err) = occam(&["simulate", "s.toml", "--threads", "0", "-q"], dir.path());
    assert!(ok, "{err}");
}

/// Errors a new user meets first say it once and point the way: a missing study file's I/O
/// error is not repeated, an unknown key gets the likely intended one, and `occam report` on a
/// study's output directory names the runs inside it.
#[test]
fn first_errors_say_it_once_and_point_the_way() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (ok, _, err) = occam(&["fit", "nope.toml"], d);
    assert!(!ok);
    assert_eq!(err.matches("No such file or directory").count(), 1, "{err}");

    std::fs::write(
        d.join("typo.toml"),
        "seed = 1\noutput = \"o\"\n[analysys]\nband = [1e-3, 0.4]\n",
    )
    .unwrap();
    let (ok, _, err) = occam(&["fit", "typo.toml"], d);
    assert!(!ok);
    assert!(err.contains("did you mean `analysis`?"), "{err}");

    std::fs::create_dir_all(d.join("runs/x/select")).unwrap();
    let (ok, _, err) = occam(&["report", "runs/x"], d);
    assert!(!ok);
    assert!(
        err.contains("give the directory a fit/select/sweep wrote"),
        "{err}"
    );
    std::fs::write(d.join("runs/x/select/manifest.json"), "{}").unwrap();
    let (ok, _, err) = occam(&["report", "runs/x"], d);
    assert!(!ok);
    assert!(
        err.contains("it holds the runs `runs/x/select`: give one of them"),
        "{err}"
    );
}
