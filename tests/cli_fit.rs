//! `occam fit` end to end on a small study, and its errors on bad input.

mod common;
use common::occam;

/// The study: its settings and [`common::TWO_EXPERIMENTS`].
fn small() -> String {
    format!(
        "{}{}",
        r#"
seed = 8
output = "out"
[analysis]
band = [1e-3, 0.4]
[fit]
free = ["a_df", "a_sus", "d21"]
fixed = { w1sq = -1.3e-6, w2sq = -1.9e-6, dt1 = 0.2, dt2 = 0.2 }
chains = 2
iterations = 3000
burn_in = 1000
"#,
        common::TWO_EXPERIMENTS
    )
}

/// `occam fit` on `study` with `extra` lines after its `burn_in`: the summary and the terminal.
fn fit_with(study: &str, extra: &str) -> (serde_json::Value, String) {
    let dir = tempfile::tempdir().unwrap();
    let study = study.replace("burn_in = 1000\n", &format!("burn_in = 1000\n{extra}"));
    std::fs::write(dir.path().join("s.toml"), study).unwrap();
    let (ok, stdout, stderr) = occam(&["fit", "s.toml"], dir.path());
    assert!(ok, "{stderr}");
    let s = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join("out/fit/summary.json")).unwrap(),
    )
    .unwrap();
    (s, stdout)
}

#[test]
fn fit_writes_table_chains_and_plots() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("s.toml"), small()).unwrap();
    let (ok, stdout, stderr) = occam(&["fit", "s.toml", "-q"], dir.path());
    assert!(ok, "{stderr}");
    assert!(
        stdout.contains("Cramér-Rao") && stdout.contains("a_sus"),
        "{stdout}"
    );
    for f in [
        "summary.json",
        "table.md",
        "chains.npz",
        "trace.png",
        "corner.svg",
    ] {
        assert!(dir.path().join("out/fit").join(f).exists(), "{f}");
    }
    let s: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join("out/fit/summary.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(s["rows"].as_array().unwrap().len(), 3);
    // Units of the built-in model (gains and cross-talk are dimensionless), and where the kept
    // draws start.
    let units: Vec<&str> = s["rows"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r["unit"].as_str().unwrap())
        .collect();
    assert_eq!(units, ["", "", ""]);
    assert_eq!(
        (s["burn_in"].as_u64(), s["thin"].as_u64()),
        (Some(1000), Some(1))
    );
    let svg = std::fs::read_to_string(dir.path().join("out/fit/trace.svg")).unwrap();
    assert!(svg.contains("burn-in 1000") && svg.contains("ln posterior"));
    let svg = std::fs::read_to_string(dir.path().join("out/fit/corner.svg")).unwrap();
    assert!(svg.contains("1σ (39 %)") && svg.contains("MAP"));
}

#[test]
fn fit_errors_name_the_field() {
    let cases: [(&str, String, &[&str]); 6] = [
        (
            "band outside the data",
            small().replace("band = [1e-3, 0.4]", "band = [0.6, 0.9]"),
            &["band", "outside"],
        ),
        (
            "singular noise",
            small().replace("[analysis]", "[simulation]\nnoise = \"none\"\n[analysis]"),
            &["singular"],
        ),
        (
            "start outside the prior",
            small().replace("burn_in = 1000", "burn_in = 1000\nstart = { a_df = 3.0 }"),
            &["outside the prior", "a_df"],
        ),
        (
            "zero-volume prior",
            small().replace(
                "[fit]",
                "[prior]\na_df = { kind = \"uniform\", lo = 1.0, hi = 1.0 }\n[fit]",
            ),
            &["prior.a_df", "lo < hi"],
        ),
        (
            "parameter neither free nor fixed",
            small().replace("dt2 = 0.2 }", "}"),
            &["fit.fixed", "dt2"],
        ),
        (
            "burn-in too long",
            small().replace("burn_in = 1000", "burn_in = 3000"),
            &["fit.burn_in"],
        ),
    ];
    for (what, text, needles) in cases {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("s.toml"), &text).unwrap();
        let (ok, _, stderr) = occam(&["fit", "s.toml", "-q"], dir.path());
        assert!(!ok, "{what}: should fail");
        for n in needles {
            assert!(stderr.contains(n), "{what}: `{n}` missing from: {stderr}");
        }
        assert!(!stderr.contains("panicked"), "{what}: {stderr}");
    }
}

/// A prior box narrower than the data's own resolution (`d21` in a box of 2e−8 against a
/// Fisher σ of ~2e−7): the walk is capped at the prior's width, as `select`'s is, so the chains
/// still move (an uncapped walk proposed outside the box almost always: 0.1–0.3 % acceptance)
/// and the posterior of `d21` fills its box (a uniform's sd is width/√12).
#[test]
fn a_posterior_wider_than_its_prior_box_is_still_sampled() {
    let dir = tempfile::tempdir().unwrap();
    let study = small().replace(
        "[fit]\n",
        "[prior]\nd21 = { kind = \"uniform\", lo = 3.9999e-4, hi = 4.0001e-4 }\n[fit]\n",
    );
    std::fs::write(dir.path().join("s.toml"), study).unwrap();
    let (ok, _, stderr) = occam(&["fit", "s.toml", "-q"], dir.path());
    assert!(ok, "{stderr}");
    let s: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join("out/fit/summary.json")).unwrap(),
    )
    .unwrap();
    for a in s["acceptance"].as_array().unwrap() {
        let a = a.as_f64().unwrap();
        assert!(a > 0.1, "acceptance {a}");
    }
    let d21 = s["rows"]
        .as_array()
        .unwrap()
        .iter()
        .find(|r| r["name"] == "d21")
        .unwrap();
    let sd = d21["sd"].as_f64().unwrap();
    let box_sd = 2e-8 / 12f64.sqrt();
    assert!((sd / box_sd - 1.0).abs() < 0.2, "sd {sd}, box {box_sd}");
}

/// `[fit] independence`: with 80 % of the iterations drawn from the Laplace approximation the
/// chains sample the posterior the random walk does — every parameter's mean within 4
/// combined Monte-Carlo errors, its sd within 4 errors of the sd's (measured: the independence
/// draws accepted as if their ratio were 1 fail it) — with more ESS for the same iterations, and `summary.json` and the terminal say how many were accepted.
#[test]
fn independence_draws_sample_the_walk_s_posterior() {
    let run = |extra: &str| fit_with(&small(), extra);
    let (walk, _) = run("");
    let (mixed, stdout) = run("independence = 0.8\n");
    assert!(walk.get("independence").is_none());
    let q = &mixed["independence"];
    let (proposed, accepted) = (
        q["proposed"].as_u64().unwrap(),
        q["accepted"].as_u64().unwrap(),
    );
    // 0.8 of 2 × 2000 sampling iterations: 3200 ± 25
    assert!((proposed as f64 - 3200.0).abs() < 150.0, "{proposed}");
    assert!(
        accepted as f64 > 0.3 * proposed as f64,
        "{accepted} of {proposed}"
    );
    assert!(
        stdout.contains("80 % of the iterations drew from the Laplace approximation"),
        "{stdout}"
    );
    let rows = |s: &serde_json::Value| s["rows"].as_array().unwrap().clone();
    for (a, b) in rows(&walk).iter().zip(&rows(&mixed)) {
        let f = |r: &serde_json::Value, k: &str| r[k].as_f64().unwrap();
        let (sa, sb) = (f(a, "sd"), f(b, "sd"));
        let (ea, eb) = (f(a, "ess"), f(b, "ess"));
        let se_mean = (sa * sa / ea + sb * sb / eb).sqrt();
        assert!(
            (f(a, "mean") - f(b, "mean")).abs() < 4.0 * se_mean,
            "{}: means {} and {} (se {se_mean})",
            a["name"],
            f(a, "mean"),
            f(b, "mean")
        );
        // the relative error of an sd from n effective draws is 1/√(2n)
        let se_ratio = (1.0 / (2.0 * ea) + 1.0 / (2.0 * eb)).sqrt();
        assert!(
            (sb / sa - 1.0).abs() < 4.0 * se_ratio,
            "{}: sds {sa} and {sb} (se of the ratio {se_ratio})",
            a["name"]
        );
        assert!(eb > 2.0 * ea, "{}: ESS {eb} mixed, {ea} walk", a["name"]);
    }
}

/// `[fit] until`: the chains stop once every parameter has ESS ≥ 400 and R-hat ≤ 1.01, at a
/// multiple of `every` before `iterations`; the summary says where (`converged_at`) and its
/// rows meet the rule, the terminal says so, and a run without it has no `converged_at`.
#[test]
fn until_converged_stops_the_chains_early_and_says_where() {
    let long = small().replace("iterations = 3000", "iterations = 20000");
    let run = |extra: &str| fit_with(&long, extra);
    let (s, stdout) = run("until = { ess = 400, every = 50 }\n");
    let at = s["converged_at"].as_u64().expect("converged_at");
    assert!(at % 50 == 0 && at > 1000 && at < 20000, "{at}");
    assert_eq!(s["kept_per_chain"].as_u64(), Some(at - 1000));
    for r in s["rows"].as_array().unwrap() {
        assert!(r["ess"].as_f64().unwrap() >= 400.0, "{r}");
        assert!(r["rhat"].as_f64().unwrap() <= 1.01, "{r}");
    }
    assert!(
        stdout.contains(&format!("2 chains × {at} iterations (converged")),
        "{stdout}"
    );
    // an ESS no run of 20 000 reaches: it runs them all and says it did not converge
    let (s, stdout) = run("until = { ess = 1e9 }\n");
    assert!(s.get("converged_at").is_none());
    assert!(stdout.contains("not converged by then"), "{stdout}");
}
