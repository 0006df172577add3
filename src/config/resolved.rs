//! `study.resolved.toml`: the study a run used, written back as TOML with serde's defaults
//! filled in, so that a run directory says exactly what was computed even when the study file
//! has since changed or the defaults of a later occam differ.

use super::error::ConfigError;
use super::study::Study;

/// The file a run directory keeps its resolved study in.
pub const RESOLVED_FILE: &str = "study.resolved.toml";

/// Writes [`resolved_toml`] of `study` into `dir` as [`RESOLVED_FILE`], atomically, with a
/// header line naming `run_dir`, the directory the run is published to (`dir` is where it is
/// staged; `-o` on the command line may put it anywhere, away from the study's `output`).
pub fn write_resolved(
    study: &Study,
    dir: &std::path::Path,
    run_dir: &std::path::Path,
) -> anyhow::Result<()> {
    use anyhow::Context;
    let text = with_run_dir(&resolved_toml(study)?, run_dir);
    let p = dir.join(RESOLVED_FILE);
    crate::atomic::write_bytes(&p, text.as_bytes())
        .with_context(|| format!("cannot write {}", p.display()))
}

/// The study as TOML, every key that has a default written out, loadable with
/// [`Study::from_toml`] (relative paths against the original study's directory, named in the
/// header comment) to the same study. Keys whose default depends on the model (`[fit] free`,
/// `start`) stay absent when the file left them out: absent is their default.
///
/// Fails for a study whose seed does not fit a TOML integer (a sweep task's derived seed),
/// naming `seed`.
pub fn resolved_toml(study: &Study) -> Result<String, ConfigError> {
    let mut file = study.file.clone();
    // the commands may override these after loading (`-o`, a sweep task's seed)
    file.seed = study.seed;
    file.output = study.output.clone();
    if i64::try_from(file.seed).is_err() {
        return Err(ConfigError::Invalid {
            file: study.source.clone(),
            field: "seed".into(),
            msg: format!(
                "{} does not fit a TOML integer (at most {}); the resolved study cannot be written",
                file.seed,
                i64::MAX
            ),
        });
    }
    let body = super::toml_floats::scientific_floats(&resolved_body(study, &file)?);
    let base = study.base_dir.display().to_string();
    let base = if base.is_empty() { ".".into() } else { base };
    Ok(format!(
        "# The study of this run with every default filled in (occam {}).\n\
         # From: {}\n\
         # Relative paths are relative to: {}\n\n{body}",
        env!("CARGO_PKG_VERSION"),
        one_line(&study.source),
        one_line(&base),
    ))
}

/// The error of a study that cannot be written back.
fn cannot(study: &Study, e: String) -> ConfigError {
    ConfigError::Parse {
        file: study.source.clone(),
        msg: format!("cannot write the resolved study: {e}"),
    }
}

/// `file` (the study file of `study`, the run's seed and output in) as the TOML the resolved
/// study writes, before its floats are put in scientific form.
fn resolved_body(study: &Study, file: &super::study::StudyFile) -> Result<String, ConfigError> {
    let err = |e: String| cannot(study, e);
    // no `until` would read back as the default rule (the glitch model's in `[fit]`, always
    // in `[select]`): say `false`
    let fit_off = file.analysis.glitches == crate::likelihood::GlitchTreatment::Model
        && file.fit.until.is_none();
    let select_off = file.select.until.is_none();
    let text = if fit_off || select_off {
        let mut t = toml::Table::try_from(file).map_err(|e| err(e.to_string()))?;
        for (table, off) in [("fit", fit_off), ("select", select_off)] {
            if off && let Some(toml::Value::Table(tb)) = t.get_mut(table) {
                tb.insert("until".into(), toml::Value::Boolean(false));
            }
        }
        toml::to_string(&t)
    } else {
        toml::to_string(file)
    }
    .map_err(|e| err(e.to_string()))?;
    if uses_ltp_physics(study) {
        return Ok(text);
    }
    // the built-in loop's physics takes no part in this study's runs: its defaults would only
    // make a reader of a state-space study look for a loop that is not there (issue 52). Values
    // the file set stay, so that the study loads back equal either way.
    let unused: Vec<&str> = [
        ("truth", file.truth == Default::default()),
        ("noise", file.noise == Default::default()),
        ("masses", file.masses == Default::default()),
        ("oms_delay", file.oms_delay == 0.0),
    ]
    .into_iter()
    .filter_map(|(k, default)| default.then_some(k))
    .collect();
    let mut want: toml::Table = text
        .parse()
        .map_err(|e: toml::de::Error| err(e.to_string()))?;
    for k in &unused {
        want.remove(*k);
    }
    // cut from the text, so that the rest keeps its order; checked against the table (a
    // layout the cut does not know falls back to the table's own, sorted, order)
    let cut = without_top_level(&text, &unused);
    match cut.parse::<toml::Table>() {
        Ok(t) if t == want => Ok(cut),
        _ => toml::to_string(&want).map_err(|e| err(e.to_string())),
    }
}

/// `text` (TOML as `toml::to_string` writes a struct) without the top-level `keys`: their
/// `key = …` lines before the first table, and their `[key]` and `[key.…]` tables.
fn without_top_level(text: &str, keys: &[&str]) -> String {
    let mut out = String::with_capacity(text.len());
    let (mut in_tables, mut skipping) = (false, false);
    for line in text.lines() {
        let t = line.trim_start();
        if t.starts_with('[') {
            in_tables = true;
            let name = t.trim_start_matches('[').split([']', '.']).next();
            skipping = name.is_some_and(|n| keys.contains(&n.trim()));
        } else if !in_tables {
            let key = t.split('=').next().map(str::trim);
            if key.is_some_and(|k| keys.contains(&k)) {
                continue;
            }
        }
        if !skipping {
            out.push_str(line);
            out.push('\n');
        }
    }
    out
}

/// Whether the built-in LTP loop's physics (`[truth]`, `[noise]`, `[masses]`, `oms_delay`)
/// takes part in a run of `study`: the loop simulates an experiment (no `[simulation] model`
/// and an experiment not read from a file), or a model the runs use (`[fit]`'s, the
/// `[[select.model]]`s', `[simulation] model`) is, or is made from, a `kind = "ltp"` or
/// `"accel"` model.
fn uses_ltp_physics(study: &Study) -> bool {
    let simulated_by_the_loop = study.simulation.model.is_none()
        && study
            .experiment_names
            .iter()
            .any(|n| !study.data_sources.iter().any(|(d, _)| d == n));
    let set = &study.models;
    let mut used: Vec<usize> = vec![study.fit_model.model];
    used.extend(study.select_models.iter().map(|m| m.spec.model));
    used.extend(study.simulation.model.as_deref().and_then(|n| set.index(n)));
    simulated_by_the_loop || used.into_iter().any(|i| built_on_the_loop(set, i, 0))
}

/// Whether model `i` of `set` is an `ltp` or `accel` model or wraps one (`tied`, `drift`).
fn built_on_the_loop(set: &super::models::ModelSet, i: usize, depth: usize) -> bool {
    use super::models::ModelDef;
    // the study validated the chain of wrapped models; the depth only bounds a malformed one
    let of = |name: &str| {
        depth < 32
            && set
                .index(name)
                .is_some_and(|j| built_on_the_loop(set, j, depth + 1))
    };
    match set.defs.get(i) {
        Some(ModelDef::Ltp { .. } | ModelDef::Accel { .. }) => true,
        Some(ModelDef::Tied(t)) => of(&t.of),
        Some(ModelDef::Drift(d)) => of(&d.of),
        _ => false,
    }
}

/// `resolved` with a comment line after its header naming the run directory `run_dir`
/// (absolute when it can be made so, as the reader may be anywhere).
pub fn with_run_dir(resolved: &str, run_dir: &std::path::Path) -> String {
    let shown = std::path::absolute(run_dir).unwrap_or_else(|_| run_dir.to_path_buf());
    let line = format!(
        "# This run was written to: {} (`output` below is the study's: without -o, `fit` writes to <output>/fit, `select` to <output>/select)\n",
        one_line(&shown.display().to_string())
    );
    // after the three header comment lines, before the blank line that ends the header
    match resolved.find("\n\n") {
        Some(k) => format!("{}\n{line}{}", &resolved[..k], &resolved[k + 1..]),
        None => format!("{line}{resolved}"),
    }
}

/// `s` with line breaks replaced, so that a file name cannot end the comment it is in.
fn one_line(s: &str) -> String {
    s.replace(['\n', '\r'], " ")
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    fn load(text: &str) -> Study {
        Study::from_toml(text, "s.toml", Path::new("/base")).unwrap()
    }

    fn round_trip(text: &str) {
        let study = load(text);
        let resolved = resolved_toml(&study).unwrap();
        let again = load(&resolved);
        assert!(
            again == study,
            "the resolved study loads to another study:\n{resolved}"
        );
        // writing it again changes nothing
        assert_eq!(resolved_toml(&again).unwrap(), resolved);
    }

    const MINIMAL: &str = r#"
seed = 3
output = "out"
[[experiment]]
name = "a"
fs = 1.0
pre_pad = 100.0
post_pad = 100.0
noise_duration = 1000.0
x1 = { kind = "sine", freq = 0.01, amplitude = 1e-6, duration = 300.0 }
"#;

    #[test]
    fn a_minimal_study_gains_its_defaults_and_loads_back_to_the_same_study() {
        round_trip(MINIMAL);
        let r = resolved_toml(&load(MINIMAL)).unwrap();
        // defaults the file did not write are now explicit
        for key in [
            "[analysis]",
            "welch_averages",
            "[select]",
            "rj_iterations",
            "[truth]",
        ] {
            assert!(r.contains(key), "{key} missing:\n{r}");
        }
        assert!(r.contains("# Relative paths are relative to: /base"), "{r}");
    }

    #[test]
    fn every_example_study_round_trips() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples");
        let mut n = 0;
        for e in std::fs::read_dir(&dir).unwrap().flatten() {
            let p = e.path();
            if p.extension().is_some_and(|x| x == "toml") {
                let text = std::fs::read_to_string(&p).unwrap();
                let study = Study::from_toml(&text, "x.toml", &dir).unwrap();
                let resolved = resolved_toml(&study).unwrap();
                let again = Study::from_toml(&resolved, "x.toml", &dir)
                    .unwrap_or_else(|e| panic!("{}: {e}\n{resolved}", p.display()));
                assert!(again == study, "{} does not round-trip", p.display());
                n += 1;
            }
        }
        assert!(n >= 5, "only {n} example studies found");
    }

    #[test]
    fn a_study_without_the_loop_does_not_write_its_default_physics() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples");
        let read = |name: &str| {
            let text = std::fs::read_to_string(dir.join(name)).unwrap();
            let study = Study::from_toml(&text, "x.toml", &dir).unwrap();
            (text, resolved_toml(&study).unwrap())
        };
        let loop_tables = ["[truth]", "[noise]", "[masses]", "oms_delay ="];
        // a state-space model simulates and is fitted: no loop anywhere
        let (text, r) = read("two-mass-damper.toml");
        for key in loop_tables {
            assert!(!r.contains(key), "{key} in the two-mass study:\n{r}");
        }
        // cut from the text, the rest in the order every other resolved study has
        let body = r.split_once("\n\n").unwrap().1;
        assert!(body.starts_with("seed = 46\noutput = "), "{body}");
        // the loop simulates the data of this state-space study: its physics stays
        let (_, r) = read("state-space.toml");
        for key in loop_tables {
            assert!(
                r.contains(key),
                "{key} missing from state-space.toml's:\n{r}"
            );
        }
        // a value the file sets stays, used or not (the study must load back equal)
        let set = text.replacen("[simulation]", "oms_delay = 0.25\n\n[simulation]", 1);
        let study = Study::from_toml(&set, "x.toml", &dir).unwrap();
        let r = resolved_toml(&study).unwrap();
        assert!(
            r.contains("oms_delay = 0.25") && !r.contains("[truth]"),
            "{r}"
        );
        let again = Study::from_toml(&r, "x.toml", &dir).unwrap();
        assert!(again == study);
    }

    #[test]
    fn overridden_seed_and_output_are_those_of_the_run() {
        let mut s = load(MINIMAL);
        s.seed = 77;
        s.output = "elsewhere".into();
        let r = resolved_toml(&s).unwrap();
        let again = load(&r);
        assert_eq!((again.seed, again.output.clone()), (77, "elsewhere".into()));
        s.seed = u64::MAX;
        let e = resolved_toml(&s).unwrap_err().to_string();
        assert!(e.contains("`seed`") && e.contains("s.toml"), "{e}");
    }

    /// Every float of a TOML text, in document order, as bits.
    fn float_bits(text: &str) -> Vec<u64> {
        fn walk(v: &toml::Value, out: &mut Vec<u64>) {
            match v {
                toml::Value::Float(f) => out.push(f.to_bits()),
                toml::Value::Array(a) => a.iter().for_each(|x| walk(x, out)),
                toml::Value::Table(t) => t.values().for_each(|x| walk(x, out)),
                _ => {}
            }
        }
        let mut out = Vec::new();
        walk(
            &toml::Value::Table(text.parse::<toml::Table>().unwrap()),
            &mut out,
        );
        out
    }

    #[test]
    fn small_and_large_floats_are_written_in_scientific_form_and_load_bit_for_bit() {
        let text = MINIMAL.replace("amplitude = 1e-6", "amplitude = 1e-14")
            + "[analysis]\nband = [1.2345678901234568e-5, 0.4]\n[prior]\nw1sq = { kind = \"uniform\", lo = -1.0000000000000002e-6, hi = 5e300 }\n";
        let study = load(&text);
        let r = resolved_toml(&study).unwrap();
        assert!(r.contains("amplitude = 1e-14"), "{r}");
        assert!(r.contains("1.2345678901234568e-5"), "{r}");
        assert!(
            r.contains("-1.0000000000000002e-6") && r.contains("5e300"),
            "{r}"
        );
        assert!(
            !r.contains("0.0000"),
            "a float written in long fixed form:\n{r}"
        );
        // numbers of a readable size stay as they were
        assert!(r.contains("pre_pad = 100.0") && r.contains("0.4]"), "{r}");
        let again = load(&r);
        assert!(again == study, "{r}");
        let body = |t: &str| t.split_once("\n\n").unwrap().1.to_string();
        let plain = resolved_body(&study, &study.file).unwrap();
        assert_eq!(float_bits(&body(&r)), float_bits(&plain));
        assert_eq!(
            float_bits(&body(&resolved_toml(&again).unwrap())),
            float_bits(&plain)
        );
    }

    #[test]
    fn every_example_study_keeps_every_float_bit_for_bit() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples");
        for e in std::fs::read_dir(&dir).unwrap().flatten() {
            let p = e.path();
            if p.extension().is_some_and(|x| x == "toml") {
                let text = std::fs::read_to_string(&p).unwrap();
                let study = Study::from_toml(&text, "x.toml", &dir).unwrap();
                let r = resolved_toml(&study).unwrap();
                let body = r.split_once("\n\n").unwrap().1;
                let plain = resolved_body(&study, &study.file).unwrap();
                assert_eq!(float_bits(body), float_bits(&plain), "{}", p.display());
            }
        }
    }

    #[test]
    fn the_run_directory_is_recorded_and_the_file_still_loads() {
        let s = load(MINIMAL);
        let r = with_run_dir(&resolved_toml(&s).unwrap(), Path::new("/runs/this-one"));
        assert!(
            r.contains("# This run was written to: /runs/this-one ("),
            "{r}"
        );
        assert!(load(&r) == s, "{r}");
        let dir = tempfile::tempdir().unwrap();
        write_resolved(&s, dir.path(), Path::new("/elsewhere/fit")).unwrap();
        let w = std::fs::read_to_string(dir.path().join(RESOLVED_FILE)).unwrap();
        assert!(w.contains("written to: /elsewhere/fit"), "{w}");
    }

    #[test]
    fn a_source_name_with_a_line_break_cannot_escape_the_comment() {
        let s = Study::from_toml(MINIMAL, "evil\nseed = 9", Path::new(".")).unwrap();
        let r = resolved_toml(&s).unwrap();
        assert_eq!(load(&r).seed, 3);
    }
}
