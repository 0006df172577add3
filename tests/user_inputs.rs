//! The model and the data as inputs: a user-defined model against the built-in one it copies,
//! the user's own data files through `occam fit`, and the errors on bad models and data.

mod common;
use common::{occam, write_csv};
use occam::config::Study;
use occam::jobs::prepare::{likelihood_of, prepare};
use occam::likelihood::fisher_exact;
use std::fmt::Write as _;
use std::path::Path;

/// The 7-parameter closed loop written as a user-defined model reproduces the built-in model's
/// ln L to 1e−10 relative and its Fisher matrix to 1e−8 on the Table I study.
#[test]
fn user_defined_closed_loop_reproduces_the_builtin_model() {
    let s = Study::load(Path::new("examples/user-model-closed-loop.toml")).unwrap();
    let prep = prepare(&s).unwrap();
    let user = &prep.likelihood;
    assert_eq!(user.model().name(), "cl_user");
    let ltp = s.models.index("ltp").unwrap();
    let builtin = likelihood_of(&s, ltp, &prep.dataset).unwrap();
    let truth = s.truth.to_array();
    let mut points = vec![truth.to_vec()];
    for (k, scale) in [1e-3, 1e-2, 3e-2].iter().enumerate() {
        let mut p = truth.to_vec();
        for (i, x) in p.iter_mut().enumerate() {
            let sign = if (i + k) % 2 == 0 { 1.0 } else { -1.0 };
            *x += sign * scale * x.abs().max(0.05);
        }
        points.push(p);
    }
    let mut worst_l: f64 = 0.0;
    for p in &points {
        // where the loop is unstable (the widest points make ω² positive) the built-in model
        // refuses the value (ln L = −∞); a user model declares no stability condition, so
        // there the residual powers behind ln L are compared
        let (a, b) = if builtin.model().is_stable(p) {
            (user.ln_likelihood_full(p), builtin.ln_likelihood_full(p))
        } else {
            assert_eq!(builtin.ln_likelihood_full(p), f64::NEG_INFINITY);
            (user.residual_power(p), builtin.residual_power(p))
        };
        assert!(((a - b) / b).abs() < 1e-10, "ln L {a} vs {b} at {p:?}");
        worst_l = worst_l.max(((a - b) / b).abs());
    }
    let free: Vec<usize> = (0..7).collect();
    let fu = fisher_exact(user, &truth, &free);
    let fb = fisher_exact(&builtin, &truth, &free);
    let mut worst_f: f64 = 0.0;
    for i in 0..7 {
        for j in 0..7 {
            let scale = (fb[(i, i)] * fb[(j, j)]).sqrt();
            let e = (fu[(i, j)] - fb[(i, j)]).abs() / scale;
            assert!(
                e < 1e-8,
                "F[{i}][{j}]: {} vs {} ({e:.1e})",
                fu[(i, j)],
                fb[(i, j)]
            );
            worst_f = worst_f.max(e);
        }
    }
    eprintln!(
        "user vs built-in: ln L {worst_l:.1e} relative, Fisher {worst_f:.1e} (F00 {:e} vs {:e}, F26 {:e} vs {:e})",
        fu[(0, 0)],
        fb[(0, 0)],
        fu[(2, 6)],
        fb[(2, 6)]
    );
}

const FIT: &str = r#"
[analysis]
band = [1e-3, 0.4]
[fit]
free = ["a_df", "a_sus", "d21", "dt1"]
fixed = { w1sq = -1.3e-6, w2sq = -1.9e-6, dt2 = 0.2 }
chains = 2
iterations = 3000
burn_in = 1000
"#;

use common::TWO_EXPERIMENTS as DESIGNS;

/// `occam simulate` of [`FIT`] on [`DESIGNS`] into `d/sim`, read back.
fn simulated(d: &Path) -> occam::data::dataset::Dataset {
    let sim = format!("seed = 8\noutput = \"sim\"\n{FIT}{DESIGNS}");
    std::fs::write(d.join("sim.toml"), &sim).unwrap();
    let (ok, _, err) = occam(&["simulate", "sim.toml"], d);
    assert!(ok, "{err}");
    occam::data::dataset::Dataset::read(&d.join("sim")).unwrap()
}

/// simulate → CSV files with renamed columns → `occam fit` from the CSVs gives exactly the
/// table of fitting the simulated dataset.
#[test]
fn fit_from_csv_files_equals_fit_from_the_simulated_dataset() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let sim = format!("seed = 8\noutput = \"sim\"\n{FIT}{DESIGNS}");
    std::fs::write(d.join("sim.toml"), &sim).unwrap();
    let (ok, _, err) = occam(&["simulate", "sim.toml"], d);
    assert!(ok, "{err}");
    let from_ds = format!(
        "seed = 8\noutput = \"fit_ds\"\n[analysis]\ndataset = \"sim\"\n{}{DESIGNS}",
        FIT.replace("[analysis]\n", "")
    );
    std::fs::write(d.join("ds.toml"), &from_ds).unwrap();
    let (ok, _, err) = occam(&["fit", "ds.toml", "-q"], d);
    assert!(ok, "{err}");
    // the user's files: their own column names, data and noise in separate files
    let ds = occam::data::dataset::Dataset::read(&d.join("sim")).unwrap();
    std::fs::create_dir(d.join("data")).unwrap();
    let mut exps = String::new();
    for e in &ds.experiments {
        write_csv(
            &d.join(format!("data/{}.csv", e.name)),
            &["time_s", "x1_out", "x12_out", "x1_guid", "x12_guid"],
            &[&e.o[0], &e.o[1], &e.i[0], &e.i[1]],
            e.fs,
        );
        write_csv(
            &d.join(format!("data/{}_quiet.csv", e.name)),
            &["time_s", "x1_out", "x12_out"],
            &[&e.noise[0], &e.noise[1]],
            e.fs,
        );
        write!(
            exps,
            "[[experiment]]\nname = \"{n}\"\ndata = \"data/{n}.csv\"\nnoise_data = \"data/{n}_quiet.csv\"\n\
             columns = {{ t = \"time_s\", o1 = \"x1_out\", o12 = \"x12_out\", i1 = \"x1_guid\", i12 = \"x12_guid\" }}\n",
            n = e.name
        )
        .unwrap();
    }
    let from_csv = format!("seed = 8\noutput = \"fit_csv\"\n[truth]\ndt1 = 0.2\n{FIT}{exps}");
    std::fs::write(d.join("csv.toml"), &from_csv).unwrap();
    let (ok, _, err) = occam(&["fit", "csv.toml", "-q"], d);
    assert!(ok, "{err}");
    let table = |p: &str| std::fs::read_to_string(d.join(p).join("fit/table.txt")).unwrap();
    // the CSV carries no truth, so compare every column but `truth`
    let strip = |t: String| -> Vec<String> {
        t.lines()
            .skip(2)
            .map(|l| {
                let w: Vec<&str> = l.split_whitespace().collect();
                let mut w = w.clone();
                w.remove(2); // `truth` (after `parameter` and `unit`)
                w.join(" ")
            })
            .collect()
    };
    let a = table("fit_ds");
    let b = table("fit_csv");
    assert_eq!(strip(a.clone()), strip(b.clone()), "\n{a}\n{b}");
    assert!(b.contains("dt1"));
}

fn study_error(text: &str, files: &[(&str, &str)]) -> String {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("s.toml"), text).unwrap();
    for (n, c) in files {
        std::fs::write(dir.path().join(n), c).unwrap();
    }
    let (ok, _, err) = occam(&["fit", "s.toml", "-q"], dir.path());
    assert!(!ok, "expected an error");
    err
}

const USER_MODEL: &str = r#"
[[model]]
kind = "user"
name = "g"
parameters = ["a"]
data = ["o1", "i1"]
residual = ["o1"]
[model.coefficients.o1]
o1 = "1"
i1 = "-a"
"#;

/// Bad models: each error names the file, the model and the entry.
#[test]
fn bad_models_are_reported_with_file_model_and_entry() {
    let base = format!("seed = 1\noutput = \"o\"\n[fit]\nmodel = \"g\"\n{DESIGNS}");
    // an unknown parameter in a coefficient
    let e = study_error(
        &format!(
            "{base}[prior]\na = {{ kind = \"uniform\", lo = 0.0, hi = 2.0 }}\n{}",
            USER_MODEL.replace("\"-a\"", "\"-b\"")
        ),
        &[],
    );
    assert!(
        e.contains("s.toml") && e.contains("`g`") && e.contains("coefficients.o1.i1"),
        "{e}"
    );
    // a parameter without a prior
    let e = study_error(&format!("{base}{USER_MODEL}"), &[]);
    assert!(e.contains("s.toml") && e.contains("prior.a"), "{e}");
    // a parameter with no effect on the residual
    let e = study_error(
        &format!(
            "{base}[prior]\na = {{ kind = \"uniform\", lo = 0.0, hi = 2.0 }}\n{}",
            USER_MODEL.replace("\"-a\"", "\"-0*a\"")
        ),
        &[],
    );
    assert!(e.contains("s.toml") && e.contains("`a`"), "{e}");
    // a channel no experiment has (not g1: simulated experiments carry the telemetry
    // g1, g2, gsc)
    let e = study_error(
        &format!(
            "{base}[prior]\na = {{ kind = \"uniform\", lo = 0.0, hi = 2.0 }}\n{}",
            USER_MODEL
                .replace("[\"o1\", \"i1\"]", "[\"o1\", \"h1\"]")
                .replace("i1 = \"-a\"", "h1 = \"-a\"")
        ),
        &[],
    );
    assert!(e.contains("h1"), "{e}");
    // an unknown model kind
    let e = study_error(
        &format!("{base}[[model]]\nkind = \"magic\"\nname = \"g\"\n"),
        &[],
    );
    assert!(e.contains("model[0].kind") && e.contains("\"user\""), "{e}");
    // a block with an impossible value
    let e = study_error(
        &format!(
            "{base}[prior]\na = {{ kind = \"uniform\", lo = 0.0, hi = 2.0 }}\n{}[model.blocks]\np = {{ kind = \"pole\", f = -1.0 }}\n",
            USER_MODEL.replace("\"-a\"", "\"-a*p\"")
        ),
        &[],
    );
    assert!(e.contains("blocks.p") && e.contains("`g`"), "{e}");
    // numerical faults: each named by model, entry and cause (they surfaced as "the residual
    // noise CSD is singular" or "parameters have no effect")
    let prior = "[prior]\na = { kind = \"uniform\", lo = 0.0, hi = 2.0 }\n";
    let faults = [
        (
            USER_MODEL.replace("\"-a\"", "\"-a/0\""),
            &[
                "coefficients.o1.i1",
                "NaN",
                "a division by an expression that is zero here",
            ][..],
        ),
        (
            format!(
                "{}[model.define]\nz = \"a/(s - s)\"\n",
                USER_MODEL.replace("\"-a\"", "\"-a + z\"")
            ),
            &[
                "define.z",
                "NaN",
                "a division by an expression that is zero here",
            ],
        ),
        (
            format!(
                "{}[model.define]\nz = \"(a*1e10)^40\"\n",
                USER_MODEL.replace("\"-a\"", "\"-a + z\"")
            ),
            &["define.z", "an overflow (a power beyond 1.8e308)"],
        ),
        (
            format!(
                "{}[model.blocks]\nt = {{ kind = \"delay\", tau = \"a - 2\" }}\n",
                USER_MODEL.replace("\"-a\"", "\"-a*t\"")
            ),
            &[
                "blocks.t.tau",
                "a delay must be ≥ 0 s",
                "prior centre (a = 1)",
            ],
        ),
    ];
    for (model, want) in faults {
        let e = study_error(&format!("{base}{prior}{model}"), &[]);
        assert!(e.contains("s.toml") && e.contains("`g`"), "{e}");
        for w in want {
            assert!(e.contains(w), "lacks {w}: {e}");
        }
    }
}

/// Bad data files: each error names the file, the line and the column.
#[test]
fn bad_data_files_are_reported_with_file_line_and_column() {
    let study = |extra: &str| {
        format!(
            "seed = 1\noutput = \"o\"\n[analysis]\nnoise = \"welch\"\n[fit]\nfree = [\"a_df\"]\nfixed = {{ w1sq = -1.3e-6, w2sq = -1.9e-6, dt1 = 0.2, dt2 = 0.2, a_sus = 1.08, d21 = 4e-4 }}\n\
             [[experiment]]\nname = \"a\"\ndata = \"a.csv\"\nnoise_data = \"n.csv\"\n{extra}"
        )
    };
    let mut good = String::from("t,o1,o12,i1,i12\n");
    for k in 0..200 {
        writeln!(good, "{k},1e-9,2e-9,0,0").unwrap();
    }
    let mut noise = String::from("t,o1,o12\n");
    for k in 0..2000 {
        writeln!(
            noise,
            "{k},{:e},{:e}",
            (k as f64).sin() * 1e-9,
            (k as f64).cos() * 1e-9
        )
        .unwrap();
    }
    // an infinity on line 5 (a NaN would be a missing sample)
    let bad = good.replacen("3,1e-9", "3,inf", 1);
    let e = study_error(&study(""), &[("a.csv", &bad), ("n.csv", &noise)]);
    assert!(
        e.contains("a.csv") && e.contains("line 5") && e.contains("`o1`"),
        "{e}"
    );
    // a ragged row
    let bad = good.replacen("7,1e-9,2e-9,0,0", "7,1e-9,2e-9,0", 1);
    let e = study_error(&study(""), &[("a.csv", &bad), ("n.csv", &noise)]);
    assert!(e.contains("a.csv") && e.contains("line 9"), "{e}");
    // a missing column, with the map that was asked for
    let e = study_error(
        &study("columns = { o12 = \"x12\" }\n"),
        &[("a.csv", &good), ("n.csv", &noise)],
    );
    assert!(e.contains("a.csv") && e.contains("`x12`"), "{e}");
    // a map for a channel no model reads (a typo of `o12`): refused, not ignored
    let e = study_error(
        &study("columns = { o21 = \"o12\" }\n"),
        &[("a.csv", &good), ("n.csv", &noise)],
    );
    assert!(
        e.contains("experiment[0].columns.o21") && e.contains("no model of the study reads"),
        "{e}"
    );
    // non-uniform time
    let bad = good.replacen("\n10,", "\n10.5,", 1);
    let e = study_error(&study(""), &[("a.csv", &bad), ("n.csv", &noise)]);
    assert!(
        e.contains("a.csv") && e.contains("line 12") && e.contains("`t`"),
        "{e}"
    );
    // a file that does not exist
    let e = study_error(&study(""), &[("n.csv", &noise)]);
    assert!(e.contains("a.csv"), "{e}");
    // a simulation field on a data experiment
    let e = study_error(
        &study("amplitude_scale = 2.0\n"),
        &[("a.csv", &good), ("n.csv", &noise)],
    );
    assert!(e.contains("experiment[0].amplitude_scale"), "{e}");
    // a design beside the data says what was commanded, and must fit the file
    let e = study_error(
        &study("design = \"tn3045_x1\"\n"),
        &[("a.csv", &good), ("n.csv", &noise)],
    );
    assert!(
        e.contains("s.toml") && e.contains("a.csv") && e.contains("fs = 10 Hz"),
        "{e}"
    );
    let e = study_error(
        &study(
            "fs = 1.0\nx1 = { kind = \"sine\", freq = 0.01, amplitude = 1e-9, duration = 100.0 }\npre_pad = 50.0\npost_pad = 49.0\n",
        ),
        &[("a.csv", &good), ("n.csv", &noise)],
    );
    assert!(e.contains("`i1` differs") && e.contains("pre_pad"), "{e}");
}

/// A dataset directory that does not exist is an error naming it (it used to load the parent
/// directory's dataset), and a dataset whose experiments are not the study's is refused.
#[test]
fn dataset_paths_and_names_are_checked() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("sim.toml"),
        format!("seed = 8\noutput = \"sim\"\n{DESIGNS}"),
    )
    .unwrap();
    let (ok, _, err) = occam(&["simulate", "sim.toml"], d);
    assert!(ok, "{err}");
    let fit = |ds: &str, designs: &str| {
        std::fs::write(
            d.join("f.toml"),
            format!(
                "seed = 8\noutput = \"f\"\n[analysis]\ndataset = \"{ds}\"\n{}{designs}",
                FIT.replace("[analysis]\n", "")
            ),
        )
        .unwrap();
        occam(&["fit", "f.toml", "-q"], d)
    };
    let (ok, _, err) = fit("sim/typo", DESIGNS);
    assert!(!ok && err.contains("sim/typo"), "{err}");
    let (ok, _, err) = fit("sim", &DESIGNS.replace("name = \"b\"", "name = \"c\""));
    assert!(
        !ok && (err.contains("`c`") || err.contains("\"c\"")),
        "{err}"
    );
}

/// Relative binning of a coefficient that vanishes at the fiducial point (a read-out
/// cross-talk `xo` of o1 into the o12 residual, zero in the data): the ratio form is undefined
/// there, the difference form is used, and ln L̃ stays within 0.01 of the exact ln L over the
/// 4σ Fisher ellipsoid.
#[test]
fn relative_binning_handles_a_coefficient_that_vanishes_at_the_fiducial_point() {
    let text = std::fs::read_to_string("examples/user-model-closed-loop.toml")
        .unwrap()
        .replace(
            "parameters = [\"w1sq\", \"w2sq\", \"dt1\", \"dt2\", \"a_df\", \"a_sus\", \"d21\"]",
            "parameters = [\"w1sq\", \"w2sq\", \"dt1\", \"dt2\", \"a_df\", \"a_sus\", \"d21\", \"xo\"]",
        )
        .replace(
            "[model.coefficients.o12]\no12 = \"1\"",
            "[model.coefficients.o12]\no12 = \"1\"\no1 = \"-xo\"",
        )
        .replace(
            "d21 = { kind = \"uniform\", lo = -1e-3, hi = 1e-3 }",
            "d21 = { kind = \"uniform\", lo = -1e-3, hi = 1e-3 }\nxo = { kind = \"uniform\", lo = -1e-3, hi = 1e-3 }",
        );
    assert!(text.contains("\"-xo\""));
    let s = Study::from_toml(&text, "xo.toml", Path::new(".")).unwrap();
    let prep = prepare(&s).unwrap();
    let lik = &prep.likelihood;
    let mut fid = s.truth.to_array().to_vec();
    fid.push(0.0);
    let free: Vec<usize> = (0..8).collect();
    let f = fisher_exact(lik, &fid, &free);
    let cov = f.clone().cholesky().unwrap().inverse();
    let rb = occam::likelihood::RelBinLikelihood::new(lik, &fid, &Default::default()).unwrap();
    let l = cov.cholesky().unwrap().l();
    let mut worst: f64 = 0.0;
    for k in 0..40 {
        // deterministic directions on the 4σ ellipsoid
        let u: Vec<f64> = (0..8).map(|i| ((k * 8 + i) as f64 * 1.7).sin()).collect();
        let n = u.iter().map(|x| x * x).sum::<f64>().sqrt();
        let p: Vec<f64> = (0..8)
            .map(|i| fid[i] + 4.0 * (0..8).map(|j| l[(i, j)] * u[j] / n).sum::<f64>())
            .collect();
        worst = worst.max((rb.ln_likelihood_full(&p) - lik.ln_likelihood_full(&p)).abs());
    }
    eprintln!("vanishing coefficient: worst |Δ ln L| = {worst:.2e}");
    assert!(worst < 0.01, "worst |Δ ln L| = {worst}");
}

/// A model on channels of the user's own naming: `x` (a read-out), `u` and `v` (two injected
/// signals), `r = x − a·u − b·v`.
const OWN_CHANNELS: &str = r#"
[[model]]
kind = "user"
name = "g"
parameters = ["a", "b"]
data = ["x", "u", "v"]
residual = ["x"]
[model.coefficients.x]
x = "1"
u = "-a"
v = "-b"
[prior]
a = { kind = "uniform", lo = -10.0, hi = 10.0 }
b = { kind = "uniform", lo = -10.0, hi = 10.0 }
"#;

/// A job reads only the channels of the models it uses: a user model on its own channels
/// `x, u, v` fits and selects from files without the LTP columns `o1, o12, i1, i12`, which the
/// built-in model (unused) would read. A channel a used model reads and the file lacks is an
/// error naming the experiment, the model, the channel and the columns the file has.
#[test]
fn a_job_reads_only_the_channels_of_the_models_it_uses() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let ds = simulated(d);
    let mut exps = String::new();
    for e in &ds.experiments {
        write_csv(
            &d.join(format!("{}.csv", e.name)),
            &["time_s", "x", "u", "v"],
            &[&e.o[0], &e.i[0], &e.i[1]],
            e.fs,
        );
        write_csv(
            &d.join(format!("{}_quiet.csv", e.name)),
            &["time_s", "x"],
            &[&e.noise[0]],
            e.fs,
        );
        write!(
            exps,
            "[[experiment]]\nname = \"{n}\"\ndata = \"{n}.csv\"\nnoise_data = \"{n}_quiet.csv\"\ncolumns = {{ t = \"time_s\" }}\n",
            n = e.name
        )
        .unwrap();
    }
    let study = format!(
        "seed = 3\noutput = \"out\"\n[analysis]\nband = [1e-3, 0.4]\n\
         [fit]\nmodel = \"g\"\nchains = 2\niterations = 2000\nburn_in = 500\n\
         [select]\nrj_iterations = 4000\nrj_burn_in = 500\niterations = 2000\nburn_in = 500\n\
         pt_temperatures = 0\n\
         [[select.model]]\nname = \"ab\"\nmodel = \"g\"\nfree = [\"a\", \"b\"]\n\
         [[select.model]]\nname = \"a\"\nmodel = \"g\"\nfree = [\"a\"]\nfixed = {{ b = 0.0 }}\n\
         {OWN_CHANNELS}{exps}"
    );
    std::fs::write(d.join("own.toml"), &study).unwrap();
    for cmd in ["fit", "select"] {
        let (ok, _, err) = occam(&[cmd, "own.toml", "-q"], d);
        assert!(ok, "{cmd}: {err}");
    }
    assert!(d.join("out/fit/summary.json").exists());
    assert!(d.join("out/select/summary.json").exists());

    // the file of the first experiment without `v`
    let first = &ds.experiments[0];
    write_csv(
        &d.join(format!("{}.csv", first.name)),
        &["time_s", "x", "u"],
        &[&first.o[0], &first.i[0]],
        first.fs,
    );
    let (ok, _, err) = occam(&["fit", "own.toml", "-q"], d);
    assert!(!ok);
    assert!(
        err.contains(&format!("experiment `{}`", first.name))
            && err.contains("model `g` reads channel `v`")
            && err.contains("`time_s`, `x`, `u`"),
        "{err}"
    );
}

/// A read-out with a NaN or two (a missing sample each) fits from CSV: a single NaN splits the
/// stretch into runs, a run too short to hold an in-band bin is left out and the warning says
/// so, and data whose only valid run holds no in-band bin are refused naming the experiment,
/// the band and the longest run.
#[test]
fn nan_samples_in_a_csv_read_out_split_the_fit_into_runs() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let ds = simulated(d);
    let fit = |case: &str, blank: &dyn Fn(usize) -> bool| {
        let mut exps = String::new();
        for e in &ds.experiments {
            let mut o1 = e.o[0].clone();
            if e.name == "a" {
                for (k, v) in o1.iter_mut().enumerate() {
                    if blank(k) {
                        *v = f64::NAN;
                    }
                }
            }
            let (data, quiet) = (
                format!("{case}_{}.csv", e.name),
                format!("{case}_{}_q.csv", e.name),
            );
            write_csv(
                &d.join(&data),
                &["t", "o1", "o12", "i1", "i12"],
                &[&o1, &e.o[1], &e.i[0], &e.i[1]],
                e.fs,
            );
            write_csv(
                &d.join(&quiet),
                &["t", "o1", "o12"],
                &[&e.noise[0], &e.noise[1]],
                e.fs,
            );
            write!(
                exps,
                "[[experiment]]\nname = \"{}\"\ndata = \"{data}\"\nnoise_data = \"{quiet}\"\n",
                e.name
            )
            .unwrap();
        }
        let study = format!("seed = 8\noutput = \"{case}\"\n{FIT}{exps}");
        std::fs::write(d.join(format!("{case}.toml")), study).unwrap();
        occam(&["fit", &format!("{case}.toml"), "-q"], d)
    };
    // the gaps' notes are on standard output
    let (ok, out, err) = fit("one", &|k| k == 77);
    assert!(ok, "{err}");
    assert!(
        out.contains("note: experiment `a`: 1 gap(s)") && out.contains("2 valid run(s)"),
        "{out}"
    );
    assert!(out.contains(" (2 experiments, "), "{out}");
    let (ok, out, err) = fit("two", &|k| k == 700 || k == 780);
    assert!(ok, "{err}");
    assert!(out.contains("3 valid run(s)"), "{out}");
    let (ok, out, err) = fit("edge", &|k| k == 2);
    assert!(ok, "{err}");
    assert!(
        out.contains("1 run(s) of 2 samples in all left out (no in-band bin)"),
        "{out}"
    );
    let (ok, _, err) = fit("short", &|k| !(5..7).contains(&k));
    assert!(!ok);
    assert!(
        err.contains("experiment `a`")
            && err.contains("none of its 1 valid runs")
            && err.contains("the longest is 2 s"),
        "{err}"
    );
    assert!(
        !err.contains("panicked") && !err.contains("relative binning"),
        "{err}"
    );
}

/// A data file that is a directory is named once, with its cause once (issue 51: `d.csv: a
/// directory, not a regular file: …: a directory, not a regular file: …`, the I/O error both
/// in the message and as its source). `common::occam` also holds the line to
/// `common::readable`, which fails a cause said twice.
#[test]
fn a_directory_named_as_data_is_refused_with_its_cause_once() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir(d.join("d.csv")).unwrap();
    std::fs::write(
        d.join("s.toml"),
        "seed = 1\noutput = \"o\"\n[[experiment]]\nname = \"a\"\ndata = \"d.csv\"\n",
    )
    .unwrap();
    let (ok, _, err) = occam(&["fit", "s.toml", "-q"], d);
    assert!(!ok);
    assert!(
        err.contains("d.csv: a directory, not a regular file")
            && err.matches("not a regular file").count() == 1,
        "{err}"
    );
}

/// The log counts one experiment as one (issue 52: "1 experiments"). Table I's study with its
/// first experiment alone: the data line comes before the MAP search, whatever that finds.
#[test]
fn one_experiment_is_counted_as_one() {
    let dir = tempfile::tempdir().unwrap();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join("examples/tn3045.toml")).unwrap();
    let cut = text.rfind("[[experiment]]").unwrap();
    std::fs::write(dir.path().join("one.toml"), &text[..cut]).unwrap();
    let (_, out, _) = occam(&["fit", "one.toml", "-q"], dir.path());
    assert!(out.contains(" (1 experiment, "), "{out}");
}
