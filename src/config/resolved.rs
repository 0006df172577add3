//! `study.resolved.toml`: the study a run used, written back as TOML with serde's defaults
//! filled in, so that a run directory says exactly what was computed even when the study file
//! has since changed or the defaults of a later occam differ.

use super::error::ConfigError;
use super::study::Study;

/// The file a run directory keeps its resolved study in.
pub const RESOLVED_FILE: &str = "study.resolved.toml";

/// Writes [`resolved_toml`] of `study` into `dir` as [`RESOLVED_FILE`], atomically.
pub fn write_resolved(study: &Study, dir: &std::path::Path) -> anyhow::Result<()> {
    use anyhow::Context;
    let text = resolved_toml(study)?;
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
    let body = toml::to_string(&file).map_err(|e| ConfigError::Parse {
        file: study.source.clone(),
        msg: format!("cannot write the resolved study: {e}"),
    })?;
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

    #[test]
    fn a_source_name_with_a_line_break_cannot_escape_the_comment() {
        let s = Study::from_toml(MINIMAL, "evil\nseed = 9", Path::new(".")).unwrap();
        let r = resolved_toml(&s).unwrap();
        assert_eq!(load(&r).seed, 3);
    }
}
