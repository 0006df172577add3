//! The malformed-study corpus: every case is a study file that must be refused at load with a
//! message naming the file and the field (issue 10, deliverable 6). Each case is written to a
//! file and read with `Study::load`, as the commands read it.

mod common;

use occam::config::Study;

/// The top of a valid study; cases add top-level keys (`top`), tables (`tables`) and keys of
/// the single experiment (`exp`).
fn study(top: &str, tables: &str, exp: &str) -> String {
    format!(
        "seed = 1\noutput = \"out\"\n{top}\n{tables}\n[[experiment]]\nname = \"a\"\ndesign = \"tn3045_x1\"\n{exp}\n"
    )
}

/// Two competing sub-models of the closed loop for `[select]` cases, `fixed` given to the
/// second.
fn select(fixed: &str, extra: &str) -> String {
    format!(
        "[select]\n{extra}\n[[select.model]]\nname = \"X\"\n[[select.model]]\nname = \"Y\"\nfree = [\"w1sq\", \"w2sq\", \"a_sus\", \"d21\"]\nfixed = {{ {fixed} }}\n"
    )
}

const SELECT_OK: &str = "dt1 = 0.2, dt2 = 0.2, a_df = 0.82";

/// (case name, study text, the field the message must name).
fn corpus() -> Vec<(&'static str, String, &'static str)> {
    let s = |top: &str, tables: &str, exp: &str| study(top, tables, exp);
    let long = "n".repeat(70_000);
    vec![
        // syntax, wrong types and unknown keys
        (
            "seed of the wrong type",
            s("", "", "").replace("seed = 1", "seed = \"x\""),
            "seed",
        ),
        (
            "output missing",
            s("", "", "").replace("output = \"out\"\n", ""),
            "output",
        ),
        ("unknown top-level key", s("bogus = 3", "", ""), "bogus"),
        (
            "unknown key in [fit]",
            s("", "[fit]\nchians = 4", ""),
            "chians",
        ),
        (
            "unknown key in an experiment",
            s("", "", "pre_padd = 3.0"),
            "pre_padd",
        ),
        (
            "truth value a string",
            s("", "[truth]\na_df = \"high\"", ""),
            "a_df",
        ),
        (
            "experiment name a number",
            s("", "", "").replace("name = \"a\"", "name = 5"),
            "name",
        ),
        (
            "unterminated string",
            s("", "", "").replace("output = \"out\"", "output = \"out"),
            "output",
        ),
        (
            "float for a count",
            s("", "[fit]\niterations = 1e15", ""),
            "iterations",
        ),
        ("negative count", s("", "[fit]\nchains = -1", ""), "chains"),
        (
            "no experiment",
            "seed = 1\noutput = \"o\"\n".into(),
            "experiment",
        ),
        (
            "empty experiment list",
            "seed = 1\noutput = \"o\"\nexperiment = []\n".into(),
            "experiment",
        ),
        (
            "unknown design",
            s("", "", "").replace("tn3045_x1", "tn9999"),
            "experiment[0].design",
        ),
        (
            "unknown window",
            s("", "[analysis]\nwindow = \"hamm\"", ""),
            "window",
        ),
        // issue 51: a prior that is not a table, one too narrow to sample, an empty output,
        // too few draws kept for the convergence checks (found before the chains run)
        (
            "prior a number",
            s("", "[prior]\nd21 = 3", ""),
            "prior `d21` = 3",
        ),
        (
            "prior width whose square underflows",
            s(
                "",
                "[prior]\nd21 = { kind = \"uniform\", lo = 0.0, hi = 1e-310 }",
                "",
            ),
            "prior.d21",
        ),
        (
            "output empty",
            s("", "", "").replace("output = \"out\"", "output = \"\""),
            "output",
        ),
        (
            "one kept draw per chain",
            s("", "[fit]\niterations = 300\nburn_in = 299", ""),
            "fit.burn_in",
        ),
        (
            "two kept draws per select chain",
            s("", &select(SELECT_OK, "iterations = 100\nburn_in = 98"), ""),
            "select.burn_in",
        ),
        // bands: length, order, Nyquist
        ("empty band", s("", "[analysis]\nband = []", ""), "band"),
        (
            "one-number band",
            s("", "[analysis]\nband = [1e-3]", ""),
            "band",
        ),
        (
            "three-number band",
            s("", "[analysis]\nband = [1e-3, 0.1, 0.3]", ""),
            "band",
        ),
        (
            "three-number snr band",
            s("", "[simulation]\nsnr_band = [1e-3, 0.1, 0.3]", ""),
            "snr_band",
        ),
        (
            "band above Nyquist",
            s("", "[analysis]\nband = [1e-3, 6.0]", ""),
            "analysis.band",
        ),
        (
            "snr band above Nyquist",
            s("", "[simulation]\nsnr_band = [1e-3, 5.5]", ""),
            "simulation.snr_band",
        ),
        (
            "band upside down",
            s("", "[analysis]\nband = [0.1, 1e-3]", ""),
            "analysis.band",
        ),
        (
            "band with NaN",
            s("", "[analysis]\nband = [nan, 0.1]", ""),
            "analysis.band",
        ),
        (
            "band at zero",
            s("", "[analysis]\nband = [0.0, 0.1]", ""),
            "analysis.band",
        ),
        // NaN and inf
        (
            "NaN stiffness",
            s("", "[truth]\nw1sq = nan", ""),
            "truth.w1sq",
        ),
        (
            "infinite noise",
            s("", "[noise]\nreadout_o1 = inf", ""),
            "noise.readout_o1",
        ),
        (
            "infinite sample rate",
            s("", "", "fs = inf"),
            "experiment[0].fs",
        ),
        (
            "NaN pad",
            s("", "", "pre_pad = nan"),
            "experiment[0].pre_pad",
        ),
        (
            "infinite amplitude scale",
            s("", "", "amplitude_scale = inf"),
            "experiment[0].amplitude_scale",
        ),
        (
            "NaN target SNR",
            s("", "[simulation]\ntarget_snr = nan", ""),
            "simulation.target_snr",
        ),
        (
            "NaN start",
            s("", "[fit.start]\na_df = nan", ""),
            "fit.start.a_df",
        ),
        // negative delays and other negatives
        (
            "negative guidance delay",
            s("", "[truth]\ndt1 = -0.1", ""),
            "truth.dt1",
        ),
        (
            "negative OMS delay",
            s("oms_delay = -1.0", "", ""),
            "oms_delay",
        ),
        (
            "negative pad",
            s("", "", "post_pad = -1.0"),
            "experiment[0].post_pad",
        ),
        (
            "negative noise",
            s("", "[noise]\ntm_accel = -1e-15", ""),
            "noise.tm_accel",
        ),
        (
            "negative mass",
            s("", "[masses]\nmsc = -1.0", ""),
            "masses.msc",
        ),
        (
            "negative actuator delay",
            s("", "[simulation.actuators]\ntm1 = { delay = -0.1 }", ""),
            "simulation.actuators.tm1.delay",
        ),
        (
            "negative fixed delay",
            s(
                "",
                "[fit]\nfree = [\"w1sq\", \"w2sq\", \"dt2\", \"a_df\", \"a_sus\", \"d21\"]\nfixed = { dt1 = -0.2 }",
                "",
            ),
            "fit.fixed.dt1",
        ),
        (
            "delay prior below zero",
            s(
                "",
                "[prior]\ntau_df = { kind = \"uniform\", lo = -1.0, hi = 1.0 }\n[[model]]\nkind = \"ltp\"\nname = \"p\"\nthruster = \"delay\"",
                "",
            ),
            "prior.tau_df",
        ),
        (
            "Gaussian prior of a delay",
            s(
                "",
                "[prior]\ndt1 = { kind = \"gaussian\", mu = 0.2, sigma = 0.1 }",
                "",
            ),
            "prior.dt1",
        ),
        (
            "negative start delay",
            s("", "[fit.start]\ndt2 = -1.0", ""),
            "fit.start.dt2",
        ),
        (
            "negative thruster delay",
            s(
                "",
                "[simulation.thruster]\nresponse = \"delay\"\nvalue = -1.0",
                "",
            ),
            "simulation.thruster.value",
        ),
        (
            "negative accel read-out delay",
            s(
                "",
                "[[model]]\nkind = \"accel\"\nname = \"acc\"\ntau_ifo = -0.5",
                "",
            ),
            "model[0]",
        ),
        // huge values: sizes, counts, scalings
        (
            "huge noise stretch",
            s("", "", "noise_duration = 1e12"),
            "experiment[0].noise_duration",
        ),
        (
            "huge pad",
            s("", "", "pre_pad = 1e308"),
            "experiment[0].pre_pad",
        ),
        (
            "huge sample rate",
            s("", "", "fs = 1e300"),
            "experiment[0].fs",
        ),
        (
            "huge gap",
            s(
                "",
                "",
                "x12 = { kind = \"sine_train\", gap = 1e300, segments = [{ freq = 0.01, amplitude = 1e-6, duration = 100.0 }, { freq = 0.02, amplitude = 1e-6, duration = 100.0 }] }",
            ),
            "experiment[0].x12",
        ),
        (
            "huge duration",
            s(
                "",
                "",
                "x12 = { kind = \"sine\", freq = 0.01, amplitude = 1e-6, duration = 1e15 }",
            ),
            "experiment[0].x12",
        ),
        (
            "a key beside kind = none (silently ignored before)",
            s("", "", "x12 = { kind = \"none\", amplitude = 1e-6 }"),
            "amplitude",
        ),
        (
            "huge oversampling",
            s("", "[simulation]\nmethod = \"time\"\noversample = 1000", ""),
            "simulation.oversample",
        ),
        (
            "oversampling above its cap",
            s(
                "",
                "[simulation]\nmethod = \"time\"\noversample = 100000",
                "",
            ),
            "simulation.oversample",
        ),
        (
            "huge iterations",
            s("", "[fit]\niterations = 1000000000000000", ""),
            "fit.iterations",
        ),
        (
            "huge chain count",
            s("", "[fit]\nchains = 1000000000000", ""),
            "fit.chains",
        ),
        (
            "chains times iterations over budget",
            s("", "[fit]\nchains = 4000\niterations = 900000000", ""),
            "fit.iterations",
        ),
        (
            "huge RJ iterations",
            s(
                "",
                &select(SELECT_OK, "rj_iterations = 1000000000000000"),
                "",
            ),
            "select.rj_iterations",
        ),
        (
            "huge PT iterations",
            s(
                "",
                &select(SELECT_OK, "pt_iterations = 1000000000000000"),
                "",
            ),
            "select.pt_iterations",
        ),
        (
            "huge select chains",
            s("", &select(SELECT_OK, "chains = 100000"), ""),
            "select.chains",
        ),
        (
            "implausible OMS delay",
            s("oms_delay = 1e300", "", ""),
            "oms_delay",
        ),
        (
            "implausible guidance delay",
            s("", "[truth]\ndt2 = 1e6", ""),
            "truth.dt2",
        ),
        (
            "implausible amplitude scale",
            s("", "", "amplitude_scale = 1e300"),
            "experiment[0].amplitude_scale",
        ),
        (
            "implausible noise level",
            s("", "[noise]\nreadout_o1 = 1e150", ""),
            "noise.readout_o1",
        ),
        (
            "underflowing noise level",
            s("", "[noise]\ntm_accel = 1e-200", ""),
            "noise.tm_accel",
        ),
        (
            "implausible noise corner",
            s("", "[noise]\ntm_corner = 1e9", ""),
            "noise.tm_corner",
        ),
        (
            "implausible target SNR",
            s("", "[simulation]\ntarget_snr = 1e300", ""),
            "simulation.target_snr",
        ),
        (
            "implausible amplitude",
            s(
                "",
                "",
                "x12 = { kind = \"sine\", freq = 0.01, amplitude = 1e3, duration = 100.0 }",
            ),
            "experiment[0].x12.amplitude",
        ),
        (
            "implausible accel read-out delay",
            s(
                "",
                "[[model]]\nkind = \"accel\"\nname = \"acc\"\ntau_ifo = 1e300",
                "",
            ),
            "model[0].tau_ifo",
        ),
        (
            "huge sweep",
            s(
                "",
                &format!(
                    "{}[sweep]\nrealisations = 1000000000\n[[sweep.axis]]\nkey = \"simulation.target_snr\"\nvalues = [5.0]",
                    select(SELECT_OK, "")
                ),
                "",
            ),
            "sweep.realisations",
        ),
        (
            "huge sweep axis",
            s(
                "",
                &format!(
                    "{}[sweep]\n[[sweep.axis]]\nkey = \"simulation.target_snr\"\nfrom = 1.0\nto = 10.0\npoints = 1000000000000",
                    select(SELECT_OK, "")
                ),
                "",
            ),
            "sweep.axis[0].points",
        ),
        // names
        (
            "70 000-character experiment name",
            s("", "", "").replace("name = \"a\"", &format!("name = \"{long}\"")),
            "experiment[0].name",
        ),
        (
            "experiment name with a slash",
            s("", "", "").replace("name = \"a\"", "name = \"../a\""),
            "experiment[0].name",
        ),
        (
            "experiment name with a space",
            s("", "", "").replace("name = \"a\"", "name = \"a b\""),
            "experiment[0].name",
        ),
        (
            "empty experiment name",
            s("", "", "").replace("name = \"a\"", "name = \"\""),
            "experiment[0].name",
        ),
        (
            "long model name",
            s(
                "",
                &format!("[[model]]\nkind = \"ltp\"\nname = \"{}\"", "m".repeat(100)),
                "",
            ),
            "model[0].name",
        ),
        (
            "select model name with a quote and accent",
            s(
                "",
                &select(SELECT_OK, "").replace("name = \"Y\"", "name = \"Y\\\"é\""),
                "",
            ),
            "select.model[1].name",
        ),
        (
            "duplicate experiment names",
            format!(
                "{}[[experiment]]\nname = \"a\"\ndesign = \"tn3045_x12\"\n",
                s("", "", "")
            ),
            "experiment[1].name",
        ),
        // unstable or implausible fixed values, priors
        ("unstable truth", s("", "[truth]\na_df = -0.5", ""), "truth"),
        (
            "unstable fixed value in [fit]",
            s(
                "",
                "[prior]\na_df = { kind = \"uniform\", lo = -1.0, hi = 2.0 }\n[fit]\nfree = [\"w1sq\", \"w2sq\", \"dt1\", \"dt2\", \"a_sus\", \"d21\"]\nfixed = { a_df = -0.5 }",
                "",
            ),
            "fit.fixed.a_df",
        ),
        (
            "a prior probability 1e310 times below another's",
            s(
                "",
                &format!("{}prior_probability = 1e-310\n", select(SELECT_OK, "")),
                "",
            ),
            "select.model[1].prior_probability",
        ),
        (
            "unstable fixed value in a select model",
            s(
                "",
                &format!(
                    "[prior]\na_df = {{ kind = \"uniform\", lo = -1.0, hi = 2.0 }}\n{}",
                    select("dt1 = 0.2, dt2 = 0.2, a_df = -0.5", "")
                ),
                "",
            ),
            "select.model[1].fixed.a_df",
        ),
        (
            "fixed value outside its prior",
            s(
                "",
                "[fit]\nfree = [\"w2sq\", \"dt1\", \"dt2\", \"a_df\", \"a_sus\", \"d21\"]\nfixed = { w1sq = 1e-3 }",
                "",
            ),
            "fit.fixed.w1sq",
        ),
        (
            "prior box upside down",
            s(
                "",
                "[prior]\ndt1 = { kind = \"uniform\", lo = 1.0, hi = 0.0 }",
                "",
            ),
            "prior.dt1",
        ),
        (
            "prior of no parameter",
            s(
                "",
                "[prior]\nxyz = { kind = \"uniform\", lo = 0.0, hi = 1.0 }",
                "",
            ),
            "prior.xyz",
        ),
        ("empty free list", s("", "[fit]\nfree = []", ""), "fit.free"),
        (
            "unknown fit model",
            s("", "[fit]\nmodel = \"nope\"", ""),
            "fit.model",
        ),
        // counts and messages
        (
            "map_starts beyond its limit",
            s("", "[fit]\nmap_starts = 100000", ""),
            "fit.map_starts",
        ),
        (
            "checkpoint_every zero",
            s("", "[fit]\ncheckpoint_every = 0", ""),
            "fit.checkpoint_every",
        ),
        ("thin zero", s("", "[fit]\nthin = 0", ""), "fit.thin"),
        (
            "burn-in longer than the run",
            s("", "[fit]\niterations = 100\nburn_in = 100", ""),
            "fit.burn_in",
        ),
        (
            "no Welch averages",
            s("", "[analysis]\nwelch_averages = 0", ""),
            "analysis.welch_averages",
        ),
        (
            "frequency above Nyquist",
            s(
                "",
                "",
                "x12 = { kind = \"sine\", freq = 6.0, amplitude = 1e-6, duration = 100.0 }",
            ),
            "experiment[0].x12.freq",
        ),
        (
            "empty sine train",
            study("", "", "").replace(
                "design = \"tn3045_x1\"",
                "x1 = { kind = \"sine_train\", segments = [] }",
            ),
            "experiment[0].x1",
        ),
        (
            "empty sweep axis",
            s(
                "",
                &format!(
                    "{}[sweep]\n[[sweep.axis]]\nkey = \"simulation.target_snr\"\nvalues = []",
                    select(SELECT_OK, "")
                ),
                "",
            ),
            "sweep.axis[0].values",
        ),
    ]
}

#[test]
fn every_malformed_study_is_refused_naming_file_and_field() {
    let dir = tempfile::tempdir().unwrap();
    let cases = corpus();
    let mut failures = Vec::new();
    for (i, (name, text, field)) in cases.iter().enumerate() {
        let path = dir.path().join(format!("case-{i:03}.toml"));
        std::fs::write(&path, text).unwrap();
        match Study::load(&path) {
            Ok(_) => failures.push(format!("{name}: loaded")),
            Err(e) => {
                let msg = e.to_string();
                let file = path.display().to_string();
                if !(msg.contains(&file) && msg.contains(field)) {
                    failures.push(format!("{name}: wanted `{field}` in: {msg}"));
                }
                if let Err(why) = common::readable(&msg) {
                    failures.push(format!("{name}: {why}: {msg}"));
                }
            }
        }
    }
    println!("malformed-study corpus: {} cases", cases.len());
    assert!(cases.len() >= 45, "{}", cases.len());
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
}

/// The messages say what is wrong in the study file's terms.
#[test]
fn messages_say_what_to_change() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("s.toml");
    let msg = |text: String| {
        std::fs::write(&path, text).unwrap();
        Study::load(&path).unwrap_err().to_string()
    };
    let e = msg(study("", "[analysis]\nband = [1e-3, 0.1, 0.3]", ""));
    assert!(e.contains("exactly two numbers"), "{e}");
    let e = msg(study("", "", "noise_duration = 1e12"));
    assert!(
        e.contains("memory budget") && e.contains("OCCAM_MEMORY_BUDGET"),
        "{e}"
    );
    let e = msg(study(
        "",
        "[fit]\nfree = [\"w2sq\", \"dt1\", \"dt2\", \"a_df\", \"a_sus\", \"d21\"]\nfixed = { w1sq = 1e-3 }",
        "",
    ));
    assert!(
        e.contains("outside the prior of `w1sq`") && !e.contains("start point"),
        "{e}"
    );
    let e = msg(study(
        "",
        "[prior]\na_df = { kind = \"uniform\", lo = -1.0, hi = 2.0 }\n[fit]\nfree = [\"w1sq\", \"w2sq\", \"dt1\", \"dt2\", \"a_sus\", \"d21\"]\nfixed = { a_df = -0.5 }",
        "",
    ));
    assert!(e.contains("unstable"), "{e}");
    let e = msg(study("", "[analysis]\nband = [1e-3, 6.0]", ""));
    assert!(e.contains("Nyquist") && e.contains("(0, 5]"), "{e}");
    let e = msg(study("", "[noise]\nreadout_o1 = 1e150", ""));
    assert!(e.contains("plausible") && !e.contains("zero"), "{e}");
    let e = msg(study("", "", "").replace(
        "name = \"a\"",
        &format!("name = \"{}\"", "n".repeat(70_000)),
    ));
    assert!(
        e.len() < 500,
        "the message repeats the whole name: {} bytes",
        e.len()
    );
}

/// A sweep's point studies go through the same checks: a point that implies a huge noise
/// stretch is refused while the sweep is planned, before anything runs, naming the point and
/// the field.
#[test]
fn a_sweep_point_over_the_budget_is_refused_when_planned() {
    let text = format!(
        "{}[sweep]\n[[sweep.axis]]\nkey = \"experiment.a.noise_duration\"\nvalues = [20000.0, 1e12]\n",
        study("", &select(SELECT_OK, ""), "")
    );
    let args = occam::jobs::sweep::SweepArgs {
        axes: None,
        realisations: None,
        truth: None,
        output: None,
        select: Vec::new(),
    };
    let e = occam::jobs::sweep::Sweep::from_text(&text, "sw.toml", std::path::Path::new("."), args)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("sw.toml")
            && e.contains("sweep point")
            && e.contains("experiment[0].noise_duration")
            && e.contains("memory budget"),
        "{e}"
    );
}
