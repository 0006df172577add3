//! End-to-end tests of `occam simulate`: outputs, determinism and errors on bad input.

use occam::data::dataset::Dataset;
mod common;
use common::occam;

const SMALL: &str = r#"
seed = 5
output = "out"
[[experiment]]
name = "inv1"
fs = 2.0
pre_pad = 100.0
post_pad = 1000.0
noise_duration = 500.0
x1 = { kind = "sine_train", gap = 10.0, segments = [
  { freq = 0.005, amplitude = 1e-6, duration = 400.0 },
  { freq = 0.05, amplitude = 1e-7, duration = 100.0 } ] }
"#;

#[test]
fn writes_a_readable_deterministic_dataset() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("s.toml"), SMALL).unwrap();
    let (ok, stdout, stderr) = occam(&["simulate", "s.toml"], dir.path());
    assert!(ok, "{stderr}");
    assert!(stdout.contains("rho_opt"), "{stdout}");
    let d = Dataset::read(&dir.path().join("out")).unwrap();
    let e = &d.experiments[0];
    assert_eq!(e.fs, 2.0);
    assert_eq!(e.noise[0].len(), 1000);
    assert_eq!(e.o[0].len(), e.i[0].len());
    assert_eq!(d.seed, Some(5));
    assert!(d.truth.is_some());
    let first = std::fs::read(dir.path().join("out/dataset.npz")).unwrap();
    let (ok, _, _) = occam(&["simulate", "s.toml", "-o", "again"], dir.path());
    assert!(ok);
    let second = std::fs::read(dir.path().join("again/dataset.npz")).unwrap();
    assert_eq!(first, second, "same seed, same bytes");
    // no temporary files left behind
    for entry in std::fs::read_dir(dir.path().join("out")).unwrap() {
        let name = entry.unwrap().file_name().into_string().unwrap();
        assert!(!name.starts_with('.'), "left over: {name}");
    }
}

/// Each bad study fails with a message naming the file and the field, and writes nothing.
#[test]
fn bad_input_gets_a_clear_error_and_no_output() {
    let cases: [(&str, String, &[&str]); 8] = [
        ("unknown key", format!("{SMALL}colour = 3\n"), &["colour"]),
        (
            "wrong type",
            SMALL.replace("seed = 5", "seed = \"five\""),
            &["seed"],
        ),
        (
            "missing field",
            SMALL.replace("output = \"out\"\n", ""),
            &["output"],
        ),
        (
            "negative duration",
            SMALL.replace("pre_pad = 100.0", "pre_pad = -1.0"),
            &["experiment[0].pre_pad"],
        ),
        (
            "above Nyquist",
            SMALL.replace("freq = 0.05", "freq = 1.5"),
            &["experiment[0].x1.segments[1].freq", "Nyquist"],
        ),
        (
            "non-finite",
            SMALL.replace("amplitude = 1e-7", "amplitude = nan"),
            &["experiment[0].x1.segments[1].amplitude"],
        ),
        (
            "unstable loop",
            format!("{SMALL}[truth]\na_sus = -1.0\n"),
            &["truth", "unstable"],
        ),
        (
            "CSV with NaN",
            SMALL.replace(
                "x1 = { kind = \"sine_train\"",
                "x12 = { kind = \"file\", path = \"inj.csv\" }\nx1 = { kind = \"sine_train\"",
            ),
            &["experiment[0].x12.path", "inj.csv", "line 3", "not finite"],
        ),
    ];
    for (what, text, needles) in cases {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("inj.csv"), "i\n1e-9\nnan\n").unwrap();
        std::fs::write(dir.path().join("s.toml"), &text).unwrap();
        let (ok, _, stderr) = occam(&["simulate", "s.toml"], dir.path());
        assert!(!ok, "{what}: should fail");
        assert!(
            stderr.contains("s.toml"),
            "{what}: no file name in: {stderr}"
        );
        for n in needles {
            assert!(stderr.contains(n), "{what}: `{n}` missing from: {stderr}");
        }
        assert!(!stderr.contains("panicked"), "{what}: {stderr}");
        assert!(!dir.path().join("out").exists(), "{what}: wrote output");
    }
    let dir = tempfile::tempdir().unwrap();
    let (ok, _, stderr) = occam(&["simulate", "missing.toml"], dir.path());
    assert!(!ok && stderr.contains("missing.toml"), "{stderr}");
}

/// A target SNR on LTPDA's scale gives the data of the same ρ_opt on occam's, and the printout
/// says both.
#[test]
fn a_target_snr_on_the_ltpda_scale_is_the_same_data_as_its_rho_opt() {
    let dir = tempfile::tempdir().unwrap();
    let with = |extra: &str, out: &str| {
        std::fs::write(
            dir.path().join(format!("{out}.toml")),
            format!("{SMALL}[simulation]\n{extra}\n"),
        )
        .unwrap();
        let (ok, stdout, stderr) =
            occam(&["simulate", &format!("{out}.toml"), "-o", out], dir.path());
        assert!(ok, "{stderr}");
        stdout
    };
    let plain = with("target_snr = 20.0", "a");
    let stnr = with(
        &format!(
            "target_snr = {}\nsnr_definition = \"ltpda_stnr\"",
            20.0 * 2f64.sqrt()
        ),
        "b",
    );
    assert!(plain.contains("study rho_opt = 2.0000e1 over"), "{plain}");
    assert!(
        stnr.contains("study rho_opt = 2.0000e1 (= 28.2843 as snr_definition = \"ltpda_stnr\")"),
        "{stnr}"
    );
    // the amplitude factors can differ in the last bit (√2·20/√2); the data to rounding
    let (da, db) = (
        Dataset::read(&dir.path().join("a")).unwrap(),
        Dataset::read(&dir.path().join("b")).unwrap(),
    );
    for (x, y) in da.experiments[0].o[0].iter().zip(&db.experiments[0].o[0]) {
        assert!((x - y).abs() <= 1e-12 * x.abs().max(1e-18), "{x} {y}");
    }
}

/// `fit` simulates the same data `simulate` writes (issue 52, item 8: the starters call
/// `simulate` optional): a fit on the fly and a fit reading the simulated directory through
/// `[analysis] dataset` give the same summary, number for number.
#[test]
fn fit_on_the_fly_sees_the_data_simulate_writes() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let text = common::small();
    std::fs::write(d.join("s.toml"), &text).unwrap();
    let (ok, _, err) = occam(&["simulate", "s.toml", "-q", "-o", "sim"], d);
    assert!(ok, "{err}");
    let (ok, _, err) = occam(&["fit", "s.toml", "-q", "-o", "fly"], d);
    assert!(ok, "{err}");
    let read = text.replace("[analysis]\n", "[analysis]\ndataset = \"sim\"\n");
    assert_ne!(read, text);
    std::fs::write(d.join("r.toml"), &read).unwrap();
    let (ok, _, err) = occam(&["fit", "r.toml", "-q", "-o", "read"], d);
    assert!(ok, "{err}");
    let rows = |run: &str| {
        let s: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(d.join(run).join("summary.json")).unwrap(),
        )
        .unwrap();
        (s["rows"].clone(), s["map"].clone())
    };
    let (fly, read) = (rows("fly"), rows("read"));
    assert!(fly.0.as_array().is_some_and(|r| !r.is_empty()));
    assert_eq!(fly, read);
}
