//! Force glitches: the simulator puts them in from their own random stream (the noise is the
//! same without them) and records them; `glitches = "gate"` finds them on the whitened
//! residual and gates them; `occam simulate` + `occam fit` on gated data recover Table I's
//! truth; bad settings are errors naming the key.

mod common;

use common::occam;
use occam::config::Study;
use occam::data::dataset::Dataset;
use occam::jobs::prepare::{gate_glitches, load_data};
use std::path::Path;

/// Two short, clearly detectable glitches per experiment (peak 1e−13 to 2e−13 m s⁻², tens of σ
/// of the whitened residual), gated.
const GLITCHES: &str = r#"
[simulation.glitches]
count = 2
amplitude = [1e-13, 2e-13]
decay = [30.0, 60.0]
on = "both"

[analysis]
glitches = "gate"
"#;

/// `examples/tn3045.toml` with `extra` appended, written to `dir`.
fn tn3045(extra: &str, dir: &Path) -> std::path::PathBuf {
    let text =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/examples/tn3045.toml"))
            .unwrap()
            .replace("output = \"runs/tn3045\"", "output = \"runs\"");
    let p = dir.join("study.toml");
    std::fs::write(&p, format!("{text}{extra}")).unwrap();
    p
}

/// [`tn3045`] with both experiments sampled at 1 Hz (their band clipped to 0.5 Hz), as
/// `examples/glitches-short.toml`: a tenth of the samples for a case that needs no more.
fn tn3045_at_1_hz(extra: &str, dir: &Path) -> std::path::PathBuf {
    let p = tn3045(extra, dir);
    let mut text = std::fs::read_to_string(&p).unwrap();
    for design in ["\"tn3045_x1\"", "\"tn3045_x12\""] {
        assert!(text.contains(design));
        text = text.replacen(design, &format!("{design}\nfs = 1.0"), 1);
    }
    std::fs::write(&p, text).unwrap();
    p
}

/// Every injected glitch starts inside a gated region; the noise-only stretch (no glitches
/// there) is bit-identical to the glitch-free simulation's, and the fit stretch differs only
/// by the glitches' response.
#[test]
fn the_gate_finds_every_injected_glitch() {
    let dir = tempfile::tempdir().unwrap();
    let s = Study::load(&tn3045(GLITCHES, dir.path())).unwrap();
    let (mut data, _) = load_data(&s).unwrap();
    let mut clean = s.clone();
    clean.simulation.glitches = None;
    let (clean_data, _) = load_data(&clean).unwrap();
    assert!(clean_data.extra.get("glitches").is_none());
    for (e, c) in data.experiments.iter().zip(&clean_data.experiments) {
        assert_eq!(e.noise, c.noise);
        assert_eq!(e.i, c.i);
        assert_ne!(e.o, c.o);
    }
    let gates = gate_glitches(&s, s.fit_model.model, &mut data).unwrap();
    let record = data.extra["glitches"].as_object().unwrap();
    for g in &gates {
        let injected = record[&g.experiment]["fit"].as_array().unwrap();
        assert_eq!(injected.len(), 2);
        for gl in injected {
            let t0 = gl["t0"].as_f64().unwrap();
            assert!(
                g.regions.iter().any(|r| r[0] <= t0 && t0 < r[1]),
                "{}: glitch at {t0} s not in {:?}",
                g.experiment,
                g.regions
            );
        }
        eprintln!("{}", g.describe());
        // the gate is about the glitches, not the whole stretch: a region is the glitch's
        // loud response (~2000 s for these), its pad and the loop's tail (1200 s)
        assert!(
            g.regions.iter().all(|r| r[1] - r[0] < 4000.0),
            "{}",
            g.describe()
        );
        assert!(g.seconds < 0.4 * 19_120.0, "{}", g.describe());
    }
}

/// `occam simulate` records the glitches in `dataset.json` and in no channel; `occam fit` with
/// `glitches = "gate"` on the dataset reports what it gated and recovers every Table I
/// parameter within 5 Cramér–Rao σ.
#[test]
fn simulate_then_fit_gated() {
    let dir = tempfile::tempdir().unwrap();
    let p = tn3045(
        &format!("{GLITCHES}\n[fit]\niterations = 3000\nburn_in = 1000\n"),
        dir.path(),
    );
    let sim = dir.path().join("sim.toml");
    std::fs::write(
        &sim,
        std::fs::read_to_string(&p)
            .unwrap()
            .replace("output = \"runs\"", "output = \"data\""),
    )
    .unwrap();
    let (ok, _, err) = occam(&["simulate", "sim.toml"], dir.path());
    assert!(ok, "{err}");
    let ds = Dataset::read(&dir.path().join("data")).unwrap();
    assert!(ds.experiments.iter().all(|e| e.gaps.is_empty()));
    let g = &ds.extra["glitches"]["inv1"]["fit"];
    assert_eq!(g.as_array().unwrap().len(), 2, "{g}");
    let text = std::fs::read_to_string(&p).unwrap();
    std::fs::write(
        &p,
        text.replace("[analysis]\n", "[analysis]\ndataset = \"data\"\n"),
    )
    .unwrap();
    let (ok, out, err) = occam(&["fit", "study.toml"], dir.path());
    assert!(ok, "{err}");
    assert!(
        format!("{out}{err}").contains("glitch gating removed"),
        "{out}{err}"
    );
    let summary: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join("runs/fit/summary.json")).unwrap(),
    )
    .unwrap();
    let gates = summary["glitch_gates"].as_array().unwrap();
    assert_eq!(gates.len(), 2);
    assert!(gates.iter().all(|g| g["detected"].as_u64().unwrap() >= 1));
    // what the default tail leaves of a glitch's response (the loop at the detection point:
    // 23 % at 1200 s) and the tail that leaves 10 %, and the line that says so
    for g in gates {
        let (left, settle) = (
            g["outlasting"].as_f64().unwrap(),
            g["settling"].as_f64().unwrap(),
        );
        assert!((0.15..0.35).contains(&left), "{g}");
        assert!((2400.0..4800.0).contains(&settle), "{g}");
    }
    assert!(
        summary["warnings"]
            .as_array()
            .unwrap()
            .iter()
            .any(|w| w.as_str().unwrap().contains("outlasts its gate")),
        "{}",
        summary["warnings"]
    );
    assert!(format!("{out}{err}").contains("outlasts its gate"));
    for r in summary["rows"].as_array().unwrap() {
        let (map, cr, truth) = (
            r["map"].as_f64().unwrap(),
            r["cramer_rao"].as_f64().unwrap(),
            r["truth"].as_f64().unwrap(),
        );
        let z = (map - truth) / cr;
        eprintln!("{}: {z:.2}σ", r["name"]);
        assert!(z.abs() < 5.0, "{r}");
    }
}

/// Bad glitch settings are errors naming the key and the fix.
#[test]
fn bad_glitch_settings_name_the_key() {
    let dir = tempfile::tempdir().unwrap();
    let cases = [
        (
            GLITCHES.replace("count = 2", "count = 100000"),
            "simulation.glitches",
            "count",
        ),
        (
            GLITCHES.replace("decay = [30.0, 60.0]", "decay = [60.0, 30.0]"),
            "simulation.glitches",
            "decay",
        ),
        (
            GLITCHES.replace(
                "glitches = \"gate\"",
                "glitches = \"gate\"\nglitch_threshold = 1.0",
            ),
            "analysis.glitch_threshold",
            "≥ 3",
        ),
        (
            GLITCHES.replace(
                "glitches = \"gate\"",
                "glitches = \"gate\"\nglitch_tail = -1.0",
            ),
            "analysis.glitch_tail",
            "≥ 0 s",
        ),
        (
            GLITCHES.replace("glitches = \"gate\"", "glitch_tail = 600.0"),
            "analysis.glitches",
            "glitches = \"gate\"",
        ),
        (
            GLITCHES.replace("glitches = \"gate\"", "glitch_pad = 30.0"),
            "analysis.glitches",
            "glitches = \"gate\"",
        ),
        (
            GLITCHES.replace(
                "glitches = \"gate\"",
                "glitches = \"gate\"\nglitch_count = \"rj\"",
            ),
            "analysis.glitch_count",
            "glitches = \"model\"",
        ),
        (
            GLITCHES.replace(
                "glitches = \"gate\"",
                "glitches = \"model\"\nglitch_count_iterations = 1000",
            ),
            "analysis.glitch_count_iterations",
            "glitch_count = \"rj\"",
        ),
        (
            GLITCHES.replace(
                "glitches = \"gate\"",
                "glitches = \"model\"\nglitch_count = \"rj\"\nglitch_count_iterations = 100",
            ),
            "analysis.glitch_count_iterations",
            "400..=10000000",
        ),
        (
            GLITCHES.replace("glitches = \"gate\"", "glitch_decay = [30.0, 300.0]"),
            "analysis.glitches",
            "glitches = \"model\"",
        ),
        (
            GLITCHES.replace(
                "glitches = \"gate\"",
                "glitches = \"model\"\nglitch_decay = [1.0, 300.0]",
            ),
            "analysis.glitch_decay",
            "rise time",
        ),
        (
            GLITCHES.replace(
                "glitches = \"gate\"",
                "glitches = \"model\"\nglitch_amplitude = 1.0",
            ),
            "analysis.glitch_amplitude",
            "m s⁻²",
        ),
        (
            GLITCHES.replace(
                "glitches = \"gate\"",
                "glitches = \"model\"\nwindow = \"hann\"",
            ),
            "analysis.glitches",
            "rectangular",
        ),
    ];
    for (extra, field, what) in cases {
        let p = tn3045(&extra, dir.path());
        let e = Study::load(&p).unwrap_err().to_string();
        assert!(e.contains(field) && e.contains(what), "{e}");
    }
    // a listed glitch must be [t0, t1] with 0 ≤ t0 < t1
    let text = std::fs::read_to_string(tn3045("", dir.path()))
        .unwrap()
        .replace(
            "design = \"tn3045_x1\"",
            "design = \"tn3045_x1\"\nglitches = [[500.0, 100.0]]",
        );
    let e = Study::from_toml(&text, "s.toml", dir.path())
        .unwrap_err()
        .to_string();
    assert!(e.contains("glitches[0]") && e.contains("t0 < t1"), "{e}");
    // listed glitches are gated without detection
    let text = text.replace("[[500.0, 100.0]]", "[[500.0, 900.0]]");
    let s = Study::from_toml(&text, "s.toml", dir.path()).unwrap();
    let (mut data, _) = load_data(&s).unwrap();
    let gates = gate_glitches(&s, s.fit_model.model, &mut data).unwrap();
    assert_eq!(gates[0].listed, 1);
    assert_eq!(gates[0].detected, 0);
    assert_eq!(gates[0].regions, vec![[500.0, 900.0]]);
    assert_eq!(data.experiments[0].gaps, vec![[5000, 9000]]);
    assert!(data.experiments[1].gaps.is_empty());
}

/// The examples load, and on `examples/gaps-and-glitches.toml` the gate works beside the random
/// gaps: every injected glitch that does not start in a gap is gated, and the gaps are kept.
#[test]
fn the_glitch_examples_gate_beside_gaps() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    Study::load(&root.join("examples/glitches.toml")).unwrap();
    let s = Study::load(&root.join("examples/gaps-and-glitches.toml")).unwrap();
    let (mut data, _) = load_data(&s).unwrap();
    let before: Vec<_> = data.experiments.iter().map(|e| e.gaps.clone()).collect();
    let gates = gate_glitches(&s, s.fit_model.model, &mut data).unwrap();
    let record = data.extra["glitches"].as_object().unwrap();
    for ((g, e), old) in gates.iter().zip(&data.experiments).zip(&before) {
        for gl in record[&g.experiment]["fit"].as_array().unwrap() {
            let k = (gl["t0"].as_f64().unwrap() * e.fs) as usize;
            assert!(
                e.gaps.iter().any(|s| s[0] <= k && k < s[1]),
                "{}: glitch at {gl} not gated",
                g.experiment
            );
        }
        // the old gaps are still gaps
        for o in old {
            assert!(e.gaps.iter().any(|s| s[0] <= o[0] && o[1] <= s[1]));
        }
        eprintln!("{}", g.describe());
    }
}

/// Gating that leaves little of an experiment can leave the posterior nearly degenerate, and
/// the fit says so: on `examples/glitches.toml` the gates take 82 % of `inv1`, and `w1sq`,
/// `w2sq` come out correlated at ρ = 0.99995 with σ ~600× Table I's — which every other
/// number of the run (R-hat, ESS, σ against Cramér–Rao) showed as ordinary, without a word.
#[test]
fn gating_most_of_an_experiment_says_the_posterior_is_nearly_degenerate() {
    let dir = tempfile::tempdir().unwrap();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join("examples/glitches.toml")).unwrap();
    std::fs::write(
        dir.path().join("study.toml"),
        format!("{text}\n[fit]\niterations = 600\nburn_in = 200\n"),
    )
    .unwrap();
    let (ok, out, err) = occam(&["fit", "study.toml"], dir.path());
    assert!(ok, "{err}");
    let said = format!("{out}{err}");
    let summary: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join("runs/glitches/fit/summary.json")).unwrap(),
    )
    .unwrap();
    let warnings = summary["warnings"].as_array().unwrap();
    let w = warnings
        .iter()
        .filter_map(|w| w.as_str())
        .find(|w| w.contains("nearly degenerate"))
        .unwrap_or_else(|| panic!("no degeneracy warning: {warnings:?}"));
    assert!(
        said.contains("the posterior is nearly degenerate"),
        "{said}"
    );
    assert!(
        w.contains("`w1sq` and `w2sq` correlated at ρ = +0.999"),
        "{w}"
    );
    // σ(w1sq) against the σ it would have with w2sq known: ~1/√(1 − ρ²) ≈ 100
    let inflation: f64 = w
        .split("σ(`w1sq`) ")
        .nth(1)
        .and_then(|r| r.split('×').next())
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("{w}"));
    assert!((30.0..1000.0).contains(&inflation), "{inflation}: {w}");
}

/// A modelled glitch explains the data it is in, wherever it starts: on noiseless data with one
/// glitch in each experiment, the residual power of the glitch model at the true loop and
/// glitch parameters is a small fraction of the glitch's own (the model without it), for
/// starts from the record's beginning to its last 2 %. What remains is the glitch's part along
/// `x1` that the model leaves out (a glitch on test mass 1). The model used to multiply the
/// loop's response by the glitch's DFT (a circular convolution): at these seeds it left
/// residual powers up to 1.4e5 of 1.4e5 (a glitch starting at 98 % of its record) and 40 at
/// 70 % — the response the loop makes after the record's end, wrapped round to its start.
/// A wrong force response, template or sign would leave the whole.
#[test]
fn a_modelled_glitch_explains_noiseless_data_wherever_it_starts() {
    use occam::config::NoiseSynthesis;
    use occam::experiment::{GlitchTarget, RandomGlitches};
    use occam::likelihood::{ExperimentSpectra, Likelihood, NoiseSource, SpectraOptions};
    use occam::model::{GLITCH_CHANNEL, GlitchModel, Model};
    use occam::prior::{Prior, PriorKind};
    use std::sync::Arc;
    let dir = tempfile::tempdir().unwrap();
    let mut s = Study::load(&tn3045("", dir.path())).unwrap();
    s.simulation.noise = NoiseSynthesis::None;
    let mut latest: f64 = 0.0;
    for (on, want) in [(GlitchTarget::Tm1, 1e-3), (GlitchTarget::Tm2, 1e-3)] {
        s.simulation.glitches = Some(RandomGlitches {
            count: 1,
            noise_count: 0,
            amplitude: [1e-13, 1e-13],
            decay: [100.0, 100.0],
            rise: 2.0,
            on,
        });
        // seeds whose glitches start early, late and at the very end of their stretches
        for seed in [2015u64, 2016, 2018, 2024, 2025, 2044] {
            s.seed = seed;
            let mut data = load_data(&s).unwrap().0;
            for e in &data.experiments {
                let t0 = data.extra["glitches"][&e.name]["fit"][0]["t0"]
                    .as_f64()
                    .unwrap();
                latest = latest.max(t0 / (e.n_samples() as f64 / e.fs));
            }
            let parent = s.models.models[s.fit_model.model].clone();
            let names: Vec<String> = data.experiments.iter().map(|e| e.name.clone()).collect();
            let durations: Vec<(String, f64)> = data
                .experiments
                .iter()
                .map(|e| (e.name.clone(), e.n_samples() as f64 / e.fs))
                .collect();
            let m = Arc::new(GlitchModel::new("g", parent, names.clone(), durations, 2.0).unwrap());
            let mut theta = s.truth.to_array().to_vec();
            for e in &mut data.experiments {
                let g = &data.extra["glitches"][&e.name]["fit"][0];
                let (t0, a) = (g["t0"].as_f64().unwrap(), g["amplitude"].as_f64().unwrap());
                // Δg = g2 − g1
                let dg = if g["tm"].as_u64().unwrap() == 1 {
                    -a
                } else {
                    a
                };
                theta.extend([t0, 100.0, dg]);
                let mut impulse = vec![0.0; e.n_samples()];
                impulse[0] = 1.0;
                e.set_channel(GLITCH_CHANNEL, impulse);
            }
            let opts = SpectraOptions {
                noise: NoiseSource::Model,
                band: [1e-4, 1.0],
                ..Default::default()
            };
            let sys = s.system();
            let csd = |f: f64| sys.noise_csd(f);
            let spectra: Vec<ExperimentSpectra> = data
                .experiments
                .iter()
                .map(|e| {
                    let cov = s.covariates_of(&e.name);
                    let here = m.specialise(&cov).unwrap().unwrap();
                    let mut sp =
                        ExperimentSpectra::new(e, &opts, here.as_ref(), &theta, Some(&csd))
                            .unwrap();
                    sp.covariates = cov;
                    sp
                })
                .collect();
            let kinds = vec![PriorKind::Uniform { lo: -1e9, hi: 1e9 }; theta.len()];
            let prior = Prior::new(m.param_names().to_vec(), kinds).unwrap();
            let lik = Likelihood::new(m.clone(), spectra, prior).unwrap();
            let with = lik.residual_power(&theta);
            let mut without = theta.clone();
            for j in 0..names.len() {
                without[7 + 3 * j + 2] = 0.0;
            }
            let none = lik.residual_power(&without);
            // ρ_opt is the injections' response: the glitches are not part of it
            assert_eq!(lik.snr(&theta), lik.snr(&without));
            eprintln!(
                "{on:?}: residual power {with:.3e} with the glitches modelled, {none:.3e} without"
            );
            assert!(none > 1e3, "the glitches are loud: {none}");
            // in ln L units: far below one, wherever the glitch starts
            assert!(with < want, "{with} vs {none}");
            // the same force on the other test mass (Δg of the other sign) does not explain it
            let mut swapped = theta.clone();
            for j in 0..names.len() {
                swapped[7 + 3 * j + 2] *= -1.0;
            }
            let wrong = lik.residual_power(&swapped);
            assert!(wrong > 3.0 * none, "{wrong} vs {none}");
            // the prepared kernel (the samplers' path) gives the same
            let generic = lik.residual_power_unprepared(&theta);
            assert!((generic - with).abs() < 1e-6 * none, "{generic} vs {with}");
        }
    }
    assert!(latest > 0.97, "a glitch near a record's end: {latest}");
}

/// `glitches = "model"` on glitch-free data: whatever the detector's false alarms, every
/// modelled candidate gained at least a threshold glitch's `ln L` at its start and every
/// left-out one less; the model carries exactly the kept ones (three parameters each, freed in
/// `[fit]`, starts in `[fit] start`), and with none it is the plain model.
#[test]
fn modelled_glitches_on_glitch_free_data_keep_only_supported_candidates() {
    let dir = tempfile::tempdir().unwrap();
    let s = Study::load(&tn3045("\n[analysis]\nglitches = \"model\"\n", dir.path())).unwrap();
    let prep = occam::jobs::prepare::prepare(&s).unwrap();
    let st = prep.study(&s);
    let kept = prep.glitch_candidates.len();
    let min = 0.5 * 5.0 * 5.0;
    assert!(prep.glitch_candidates.iter().all(|c| c.gain >= min));
    assert!(prep.glitch_dropped.iter().all(|c| c.gain < min));
    let names = st.models.models[st.fit_model.model].param_names();
    assert_eq!(names.len(), 7 + 3 * kept);
    assert_eq!(st.fit_model.free.len(), 7 + 3 * kept);
    let starts = st.fit.start.clone().unwrap_or_default();
    for n in &names[7..] {
        assert!(starts.contains_key(n), "no start for {n}");
    }
    let notes = prep.glitch_notes().join("\n");
    eprintln!("{notes}");
    assert!(notes.contains("glitch modelling"), "{notes}");
    if kept == 0 {
        assert_eq!(prep.likelihood.model().param_names().len(), 7);
    }
}

/// The pulls of the loop's seven parameters at the MAP of `prep`'s `[fit]` model (searched from
/// its start), in Cramér–Rao σ of the whole model, against `s`'s truth.
fn loop_pulls(prep: &occam::jobs::prepare::Prepared, s: &Study) -> Vec<f64> {
    use occam::jobs::prepare::{default_start, reference_point};
    use occam::likelihood::{cramer_rao, fisher_exact, fisher_scoring};
    use occam::model::map_tolerance;
    let st = prep.study(s);
    let lik = &prep.likelihood;
    let spec = &st.fit_model;
    let map = fisher_scoring(
        lik,
        &default_start(st, spec),
        &spec.free,
        map_tolerance(lik.model().as_ref()),
        200,
    )
    .unwrap();
    assert!(map.converged);
    let sd = cramer_rao(&fisher_exact(lik, &map.theta, &spec.free)).unwrap();
    let truth = reference_point(s, s.fit_model.model);
    let pulls: Vec<f64> = (0..7)
        .map(|k| (map.theta[spec.free[k]] - truth[spec.free[k]]) / sd[k])
        .collect();
    eprintln!("loop pulls {pulls:.2?}");
    pulls
}

/// Two glitches whose responses overlap make one detected region, and each gets its own
/// modelled glitch. Seed 2030 puts two of 1e−13 m s⁻² (decay 100 s, test mass 2) 293 s apart in
/// `inv1`; the detector merges them. With one candidate per region the loop's MAP was pulled
/// by the glitch left in the residual (on `examples/glitches.toml`, where regions held up to
/// three: pull spreads of 7–22, realisation 3016 at 7.7σ, 8.3σ and −6.0σ on `w1sq`, `w2sq`,
/// `a_sus`). Every injected glitch must now have a candidate starting within 10 s of it with its
/// `Δg` within 20 %, and the loop's MAP must lie within 3.5 Cramér–Rao σ of the truth. Without
/// the rounds one candidate (7e−14 m s⁻², 319 s decay) took both glitches here and the match
/// fails; the loop's pulls stayed small at this seed (at most 1.2: two glitches of one sign on
/// one test mass look much like one longer one), so the pull bound is a sanity check only.
/// Sampled at 1 Hz: the same two glitches, merged into one region, and without the rounds
/// (skipped by hand, 6 Dec 2026) the match fails there too; 8 s against 90 s at 10 Hz.
#[test]
fn a_region_holding_two_glitches_fits_both() {
    use occam::jobs::prepare::prepare;
    let dir = tempfile::tempdir().unwrap();
    let extra = r#"
[simulation.glitches]
count = 2
amplitude = [1e-13, 1e-13]
decay = [100.0, 100.0]
on = "both"

[analysis]
glitches = "model"
"#;
    let mut s = Study::load(&tn3045_at_1_hz(extra, dir.path())).unwrap();
    s.seed = 2030;
    let prep = prepare(&s).unwrap();
    let st = prep.study(&s);
    // the study gives no run lengths: the glitch model's
    assert_eq!(
        (st.fit.iterations, st.fit.burn_in),
        occam::config::GLITCH_ITERATIONS
    );
    let starts = st.fit.start.clone().unwrap_or_default();
    let injected = prep.dataset.extra["glitches"].as_object().unwrap();
    let inv1: Vec<f64> = injected["inv1"]["fit"]
        .as_array()
        .unwrap()
        .iter()
        .map(|g| g["t0"].as_f64().unwrap())
        .collect();
    // the case: one region holds both of inv1's glitches
    assert!(
        prep.glitch_candidates.iter().any(|c| c.experiment == "inv1"
            && inv1.iter().all(|t| c.region[0] <= *t && *t < c.region[1])),
        "inv1's glitches at {inv1:?} are not in one region: {:?}",
        prep.glitch_candidates
    );
    for (name, rec) in injected {
        for g in rec["fit"].as_array().unwrap() {
            let t0 = g["t0"].as_f64().unwrap();
            let a = g["amplitude"].as_f64().unwrap();
            // Δg = g2 − g1
            let dg = if g["tm"].as_u64().unwrap() == 1 {
                -a
            } else {
                a
            };
            let matched = prep.glitch_candidates.iter().any(|c| {
                &c.experiment == name
                    && (starts[&format!("{}_t0", c.name)] - t0).abs() < 10.0
                    && (starts[&format!("{}_a", c.name)] - dg).abs() < 0.2 * dg.abs()
            });
            assert!(
                matched,
                "{name}: no modelled glitch near the one at {t0:.1} s (Δg {dg:.3e}); starts {starts:?}"
            );
        }
    }
    let pulls = loop_pulls(&prep, &s);
    assert!(pulls.iter().all(|p| p.abs() < 3.5), "{pulls:.2?}");
}

/// A candidate pruned at a round's MAP is scanned again at a later one. Realisation 3029 of
/// `examples/glitches-short.toml` holds a 3.5e−14 m s⁻² glitch (decay 55 s, test mass 1) at
/// 3 266.9 s of `inv2`, during the injections; its candidate's first scan put the start on its
/// window's end (3 694 s, decay on the 3 000 s bound), and at the first joint MAP its removal
/// cost 12.1 < 12.5: pruned, with its region never scanned again, it left `w1sq`, `w2sq`,
/// `dt2`, `a_sus` at −5.1, −5.4, +3.4, +3.5 σ. Scanned again at the next MAP it is found (5 s
/// off, gaining 138) and every loop pull is within 1.2 σ. Every injected glitch must lie in a
/// modelled candidate's region with a start within 15 s of it, and every loop pull within 2.5.
#[test]
fn a_candidate_pruned_at_a_map_is_scanned_again() {
    use occam::jobs::prepare::prepare;
    let mut s = Study::load(Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/examples/glitches-short.toml"
    )))
    .unwrap();
    s.seed = 3029;
    let prep = prepare(&s).unwrap();
    let st = prep.study(&s);
    let starts = st.fit.start.clone().unwrap_or_default();
    for (name, rec) in prep.dataset.extra["glitches"].as_object().unwrap() {
        for g in rec["fit"].as_array().unwrap() {
            let t0 = g["t0"].as_f64().unwrap();
            let matched = prep.glitch_candidates.iter().any(|c| {
                &c.experiment == name && (starts[&format!("{}_t0", c.name)] - t0).abs() < 15.0
            });
            assert!(
                matched,
                "{name}: no modelled glitch near the one at {t0:.1} s; candidates {:?}, left out {:?}",
                prep.glitch_candidates, prep.glitch_dropped
            );
        }
    }
    let pulls = loop_pulls(&prep, &s);
    assert!(pulls.iter().all(|p| p.abs() < 2.5), "{pulls:.2?}");
}

/// `glitches = "gate"` finds glitches at the loop's MAP on the data, not at the study's
/// reference point: on glitch-free data analysed with a `[truth]` that is not the data's (as a
/// real data set's nominal values are not), the residual at that point holds the injections'
/// response, which the detector flags over much of the stretch; at the MAP it gates (almost)
/// nothing.
#[test]
fn the_gate_detects_at_the_data_s_map_not_at_the_reference_point() {
    use occam::jobs::prepare::{reference_point, spectra_options};
    use occam::likelihood::{DEFAULT_GLITCH_PAD, DEFAULT_GLITCH_THRESHOLD, detect_glitches};
    let dir = tempfile::tempdir().unwrap();
    // no tail: the test counts what the detector flags
    let s = Study::load(&tn3045(
        "\n[analysis]\nglitches = \"gate\"\nglitch_tail = 0\n",
        dir.path(),
    ))
    .unwrap();
    let (data, _) = load_data(&s).unwrap();
    let mut wrong = s.clone();
    wrong.truth.a_df = 0.86;
    wrong.truth.dt1 = 0.25;
    let mi = s.fit_model.model;
    let reference = reference_point(&wrong, mi);
    let at_reference: f64 = data
        .experiments
        .iter()
        .map(|e| {
            let spans = detect_glitches(
                e,
                wrong.models.models[mi].as_ref(),
                &reference,
                &spectra_options(&wrong),
                DEFAULT_GLITCH_THRESHOLD,
                DEFAULT_GLITCH_PAD,
            )
            .unwrap();
            spans
                .iter()
                .map(|r| (r[1] - r[0]) as f64 / e.fs)
                .sum::<f64>()
        })
        .sum();
    let mut gated = data.clone();
    let gates = gate_glitches(&wrong, mi, &mut gated).unwrap();
    let at_map: f64 = gates.iter().map(|g| g.seconds).sum();
    eprintln!("gated {at_reference:.0} s at the reference point, {at_map:.0} s at the MAP");
    // the fit stretches hold 2 × 19 120 s; a false alarm gates a few hundred seconds
    assert!(at_reference > 10.0 * at_map, "{at_reference} vs {at_map}");
    assert!(at_map < 0.03 * 38_240.0, "{at_map}");
}

/// Realisation `seed` of `examples/glitches.toml` (five glitches per stretch) gated with a
/// `glitch_tail` of `tail` s: the gates, and the MAP's distance from the truth in Cramér–Rao σ
/// per free parameter, each injected glitch's start checked to lie in a gated region.
fn gated_pulls(seed: u64, tail: f64) -> (Vec<occam::likelihood::GlitchGate>, Vec<f64>) {
    use occam::jobs::prepare::{default_start, likelihood_of, reference_point};
    use occam::likelihood::{cramer_rao, fisher_exact, fisher_scoring};
    let mut s = Study::load(Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/examples/glitches.toml"
    )))
    .unwrap();
    s.seed = seed;
    s.analysis.glitch_tail = Some(tail);
    let (mut data, _) = load_data(&s).unwrap();
    let mi = s.fit_model.model;
    let gates = gate_glitches(&s, mi, &mut data).unwrap();
    for g in &gates {
        for gl in data.extra["glitches"][&g.experiment]["fit"]
            .as_array()
            .unwrap()
        {
            let t0 = gl["t0"].as_f64().unwrap();
            assert!(
                g.regions.iter().any(|r| r[0] <= t0 && t0 < r[1]),
                "glitch at {t0} s not gated: {}",
                g.describe()
            );
        }
    }
    let lik = likelihood_of(&s, mi, &data).unwrap();
    let free = &s.fit_model.free;
    let map = fisher_scoring(&lik, &default_start(&s, &s.fit_model), free, 1e-3, 100).unwrap();
    assert!(map.converged);
    let sd = cramer_rao(&fisher_exact(&lik, &map.theta, free)).unwrap();
    let truth = reference_point(&s, mi);
    let pulls: Vec<f64> = free
        .iter()
        .zip(&sd)
        .map(|(&i, sd)| (map.theta[i] - truth[i]) / sd)
        .collect();
    eprintln!("seed {seed}, glitch_tail {tail} s: pulls {pulls:.1?}");
    (gates, pulls)
}

/// Detection starts from the loudest glitches ([`occam::jobs::prepare::DETECTION_LADDER`]):
/// realisation 3018 of `examples/glitches.toml` pulls the fit on ungated data by −61σ in
/// `w2sq`, and a detection at the full threshold there gated all of `inv2` ([15, 19 110) s),
/// leaving `dt2` without data. With the ladder (and no tail, to see the detector alone) the
/// gates cover well under half of each stretch, and the MAP on the gated data is within
/// 10 Cramér–Rao σ of the truth in every parameter.
#[test]
fn detection_starts_from_the_loudest_glitches() {
    let (gates, pulls) = gated_pulls(3018, 0.0);
    for g in &gates {
        eprintln!("{}: {:.0} s gated", g.experiment, g.seconds);
        assert!(g.seconds < 0.5 * 19_120.0, "{}", g.describe());
    }
    assert!(pulls.iter().all(|z| z.abs() < 10.0), "{pulls:?}");
}

/// Gated with the default `glitch_tail` (the loop's slowest time constant), realisation 3014 of
/// `examples/glitches.toml` has every parameter within 3σ (ungated, the glitches pull the
/// stiffnesses by tens of σ). Gated without a tail it had `d21` 8.5σ off until the runs
/// between gates took their bins' exact noise covariance (`likelihood::run_noise`); it is now
/// within 1.28σ there too (measured; not computed here, since nothing is asserted of it).
/// That the tail still narrows the pulls on average is a coverage figure (the glitch guide: 40
/// realisations each way).
#[test]
fn the_gate_with_its_tail_recovers_every_parameter() {
    let (_, tail) = gated_pulls(3014, occam::likelihood::DEFAULT_GLITCH_TAIL);
    assert!(tail.iter().all(|z| z.abs() < 3.0), "{tail:?}");
}

/// `glitch_count = "rj"` through `occam fit` on Table I's study with two loud glitches per
/// experiment: the reversible jump keeps every candidate that holds an injected glitch (none is
/// switched off after burn-in), `summary.json` carries the number's posterior, each
/// candidate's probability and the loop's parameters marginalised over the number, the
/// terminal says it, and a 19-parameter fit writes its plots (the first 16 parameters; the
/// truth was not cut to them before).
#[test]
#[ignore = "slow since the glitch model is causal: its MAP search runs the dual path (two transforms of the record per seeded direction), > 13 min on two cores; run with --ignored"]
fn the_reversible_jump_keeps_the_injected_glitches() {
    let dir = tempfile::tempdir().unwrap();
    let extra = GLITCHES.replace(
        "glitches = \"gate\"",
        "glitches = \"model\"\nglitch_count = \"rj\"\nglitch_count_iterations = 800\n\n[fit]\niterations = 600\nburn_in = 200\nchains = 2",
    );
    let p = tn3045(&extra, dir.path());
    let (ok, out, err) = occam(&["fit", p.to_str().unwrap()], dir.path());
    assert!(ok, "{out}\n{err}");
    assert!(
        out.contains("glitch count (reversible jump, 800 iterations, 200 burn-in"),
        "{out}"
    );
    assert!(
        out.contains("marginalised over the number of glitches"),
        "{out}"
    );
    let run = dir.path().join("runs/fit");
    assert!(run.join("trace.png").exists() && run.join("corner.png").exists());
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(run.join("summary.json")).unwrap()).unwrap();
    let g = &summary["glitch_count"];
    let cands = g["candidates"].as_array().unwrap();
    assert!(!cands.is_empty());
    let s = Study::load(&p).unwrap();
    let (data, _) = load_data(&s).unwrap();
    let record = data.extra["glitches"].as_object().unwrap();
    let mut holding = 0;
    for c in cands {
        let (e, r0, r1) = (
            c["experiment"].as_str().unwrap(),
            c["region"][0].as_f64().unwrap(),
            c["region"][1].as_f64().unwrap(),
        );
        let holds = record[e]["fit"]
            .as_array()
            .unwrap()
            .iter()
            .any(|gl| (r0..r1).contains(&gl["t0"].as_f64().unwrap()));
        if holds {
            holding += 1;
            assert_eq!(c["probability"].as_f64(), Some(1.0), "{c}");
            assert_eq!(c["deaths"]["accepted"].as_u64(), Some(0), "{c}");
            assert!(c["deaths"]["proposed"].as_u64().unwrap() > 50, "{c}");
            // never switched: no error is claimed
            assert!(c["error"].is_null(), "{c}");
        }
    }
    assert!(holding >= 3, "{cands:?}");
    let count = g["count"].as_array().unwrap();
    assert_eq!(count.len(), cands.len() + 1);
    let total: f64 = count.iter().map(|p| p[0].as_f64().unwrap()).sum();
    assert!((total - 1.0).abs() < 1e-9);
    let params = g["parameters"].as_array().unwrap();
    assert_eq!(params.len(), 7);
    for r in params {
        let pull = r["pull"].as_f64().unwrap();
        assert!(pull.abs() < 5.0, "{r}");
    }
}

/// The edge the reversible jump is for: on glitch-free data detected at 3σ, the false alarms
/// whose starts gain a threshold glitch's `ln L` are modelled; the reversible jump switches
/// every one of them off (the prior volume of a glitch's three parameters outweighs a gain of
/// 5–17 in `ln L`) and finds no glitch with probability > 0.95.
#[test]
#[ignore = "slow since the glitch model is causal: its MAP search runs the dual path (two transforms of the record per seeded direction), > 13 min on two cores; run with --ignored"]
fn the_reversible_jump_switches_off_false_alarms() {
    use occam::jobs::glitch_count::glitch_count;
    use occam::likelihood::{fisher_exact, fisher_scoring};
    let dir = tempfile::tempdir().unwrap();
    let s = Study::load(&tn3045(
        "\n[analysis]\nglitches = \"model\"\nglitch_threshold = 3.0\nglitch_count = \"rj\"\nglitch_count_iterations = 800\n",
        dir.path(),
    ))
    .unwrap();
    let prep = occam::jobs::prepare::prepare(&s).unwrap();
    let st = prep.study(&s).clone();
    let spec = &st.fit_model;
    assert!(
        prep.glitch_candidates.len() >= 4,
        "{:?}",
        prep.glitch_candidates
    );
    let lik = &prep.likelihood;
    let start = occam::jobs::prepare::default_start(&st, spec);
    let map = fisher_scoring(lik, &start, &spec.free, 1e-2, 200).unwrap();
    let f = fisher_exact(lik, &map.theta, &spec.free);
    let g = glitch_count(
        &st,
        lik,
        &prep.glitch_candidates,
        &spec.free,
        &map.theta,
        &f,
        None,
    )
    .unwrap();
    for line in g.describe() {
        eprintln!("{line}");
    }
    assert_eq!(g.most_probable(), 0);
    assert!(g.count[0].0 > 0.95, "{:?}", g.count);
    for c in &g.candidates {
        assert!(c.probability < 0.05, "{c:?}");
    }
}

/// A gate that takes nearly all of an experiment's data leads the fit's error with that, not
/// only with the singular Fisher matrix that follows from it (issue 51: the gate's own line
/// was printed only when a run succeeded). `examples/glitches-short.toml` gated with a tail
/// of 15 000 s leaves 122 s of `inv1`.
#[test]
fn a_gate_that_takes_nearly_all_data_leads_the_error() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/examples/glitches-short.toml"
    ))
    .unwrap()
    .replace(
        "\nglitches = \"model\"",
        "\nglitches = \"gate\"\nglitch_tail = 15000.0",
    );
    std::fs::write(dir.path().join("s.toml"), text).unwrap();
    let (ok, _, err) = occam(&["fit", "s.toml", "-q", "-o", "f"], dir.path());
    assert!(!ok);
    let line = err.lines().find(|l| l.starts_with("error:")).unwrap();
    let gate = line.find("glitch gating removed").expect(line);
    let singular = line.find("Fisher matrix is singular").expect(line);
    assert!(
        gate < singular && line.contains("lower glitch_tail"),
        "{line}"
    );
}
