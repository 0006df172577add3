//! `occam init KIND`: a commented starting study a new user edits rather than writes from
//! nothing — the closed loop, a model of their own, their own data, a sweep. Each template
//! loads as it is (tested), so the first command the file names works.

use anyhow::{Context, bail};
use std::path::{Path, PathBuf};

/// The kinds of starting study, with the template of each.
pub const KINDS: &[(&str, &str, &str)] = &[
    (
        "closed-loop",
        "the built-in LTP closed loop on simulated TN3045 experiments: fit and select",
        include_str!("../../assets/init/closed-loop.toml"),
    ),
    (
        "user-model",
        "a model of your own (a state-space system in the study file), simulated with its own noise",
        include_str!("../../assets/init/user-model.toml"),
    ),
    (
        "own-data",
        "the closed loop fitted to your own CSV/npz measurements",
        include_str!("../../assets/init/own-data.toml"),
    ),
    (
        "sweep",
        "the Bayes factor against an injection frequency (K14 Fig. 6)",
        include_str!("../../assets/init/sweep.toml"),
    ),
];

/// The template of `kind`, or an error listing the kinds.
pub fn template(kind: &str) -> anyhow::Result<&'static str> {
    match KINDS.iter().find(|(k, _, _)| *k == kind) {
        Some((_, _, t)) => Ok(t),
        None => {
            let list: Vec<String> = KINDS
                .iter()
                .map(|(k, what, _)| format!("`{k}` ({what})"))
                .collect();
            let hint = crate::config::closest(kind, KINDS.iter().map(|(k, _, _)| *k))
                .map_or(String::new(), |k| format!("; did you mean `{k}`?"));
            bail!(
                "`occam init {kind}`: no such kind of study; the kinds are {}{hint}",
                list.join(", ")
            )
        }
    }
}

/// Writes the template of `kind` to `path` (default `<kind>.toml` in the working directory),
/// refusing to replace an existing file unless `force`; returns the path written.
pub fn write(kind: &str, path: Option<&Path>, force: bool) -> anyhow::Result<PathBuf> {
    let text = template(kind)?;
    let path = path.map_or_else(|| PathBuf::from(format!("{kind}.toml")), Path::to_path_buf);
    if path.exists() && !force {
        bail!(
            "{}: the file exists; give another path (`occam init {kind} -o FILE`) or --force to replace it",
            path.display()
        );
    }
    crate::atomic::write_bytes(&path, text.as_bytes())
        .with_context(|| format!("{}: cannot write the study", path.display()))?;
    Ok(path)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_template_is_a_valid_study_and_an_unknown_kind_lists_the_kinds() {
        for (kind, _, text) in KINDS {
            if *kind == "own-data" {
                continue; // reads files: tests/init.rs gives it data
            }
            let dir = std::env::temp_dir();
            crate::config::Study::from_toml(text, &format!("{kind}.toml"), &dir)
                .unwrap_or_else(|e| panic!("{kind}: {e}"));
        }
        let e = template("closed-lop").unwrap_err().to_string();
        assert!(e.contains("did you mean `closed-loop`?"), "{e}");
        assert!(e.contains("`sweep`") && e.contains("`own-data`"), "{e}");
    }

    #[test]
    fn an_existing_file_is_not_replaced_without_force() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("s.toml");
        std::fs::write(&p, "mine").unwrap();
        let e = write("sweep", Some(&p), false).unwrap_err().to_string();
        assert!(
            e.contains("the file exists") && e.contains("--force"),
            "{e}"
        );
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "mine");
        write("sweep", Some(&p), true).unwrap();
        assert!(
            std::fs::read_to_string(&p)
                .unwrap()
                .contains("[[sweep.axis]]")
        );
    }
}
