//! `occam init KIND`: each starting study is written, loads, and runs the command its comments
//! name first (the own-data one on CSV files made from a simulation).

mod common;
use common::{occam, write_csv};

#[test]
fn every_kind_is_written_and_loads_and_an_existing_file_is_kept() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (ok, out, _) = occam(&["init"], d);
    assert!(ok);
    for k in ["closed-loop", "user-model", "own-data", "sweep"] {
        assert!(out.contains(k), "{out}");
        let (ok, out, err) = occam(&["init", k], d);
        assert!(ok, "{err}");
        assert!(out.contains(&format!("wrote {k}.toml")), "{out}");
        let text = std::fs::read_to_string(d.join(format!("{k}.toml"))).unwrap();
        assert!(text.starts_with("# A starting"), "{text}");
    }
    // a second init does not overwrite the user's edits
    std::fs::write(d.join("sweep.toml"), "# mine").unwrap();
    let (ok, _, err) = occam(&["init", "sweep"], d);
    assert!(!ok && err.contains("the file exists"), "{err}");
    assert_eq!(
        std::fs::read_to_string(d.join("sweep.toml")).unwrap(),
        "# mine"
    );
    let (ok, _, err) = occam(&["init", "swep"], d);
    assert!(!ok && err.contains("did you mean `sweep`?"), "{err}");
    // the simulated ones load as they are: `simulate` runs (user-model, closed-loop)
    for k in ["closed-loop", "user-model"] {
        let (ok, _, err) = occam(&["simulate", &format!("{k}.toml"), "-q"], d);
        assert!(ok, "{k}: {err}");
    }
}

#[test]
fn the_own_data_study_fits_csv_files() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // data to stand in for the user's: the closed-loop study's simulation
    let (ok, _, err) = occam(&["init", "closed-loop"], d);
    assert!(ok, "{err}");
    let (ok, _, err) = occam(&["simulate", "closed-loop.toml", "-o", "sim", "-q"], d);
    assert!(ok, "{err}");
    let ds = occam::data::dataset::Dataset::read(&d.join("sim")).unwrap();
    for e in &ds.experiments {
        write_csv(
            &d.join(format!("{}.csv", e.name)),
            &["t", "o1", "o12", "i1", "i12"],
            &[&e.o[0], &e.o[1], &e.i[0], &e.i[1]],
            e.fs,
        );
        write_csv(
            &d.join(format!("{}_noise.csv", e.name)),
            &["t", "o1", "o12"],
            &[&e.noise[0], &e.noise[1]],
            e.fs,
        );
    }
    let (ok, _, err) = occam(&["init", "own-data"], d);
    assert!(ok, "{err}");
    let (ok, out, err) = occam(&["fit", "own-data.toml", "-q"], d);
    assert!(ok, "{err}");
    for p in ["w1sq", "dt1", "d21"] {
        assert!(out.contains(p), "{out}");
    }
    assert!(d.join("runs/own-data/fit/summary.json").is_file());
}
