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

/// The study whose simulation stands in for the user's measurements beside the `own-data`
/// starter: the `closed-loop` starter (TN3045's two experiments, `inv1` and `inv2`, at ρ_opt =
/// 450, no guidance delays).
const EXAMPLE_DATA_STUDY: &str = "closed-loop";

/// For `own-data`, example measurements beside the study at `study` so that it runs as
/// written: the closed-loop starter's simulated experiments as the CSV files the study reads
/// (`inv1.csv`, `inv1_noise.csv`, `inv2.csv`, `inv2_noise.csv`;
/// [`crate::data::dataset::Dataset::write_csv`]). Returns the files written and those kept
/// because they exist (the user's own, unless `force`); nothing for the other kinds.
pub fn write_example_data(
    kind: &str,
    study: &Path,
    force: bool,
) -> anyhow::Result<(Vec<PathBuf>, Vec<PathBuf>)> {
    if kind != "own-data" {
        return Ok((Vec::new(), Vec::new()));
    }
    // beside the study; a bare file name's directory is the empty path, so that the files
    // are named as the study names them
    let dir = study.parent().map_or_else(PathBuf::new, Path::to_path_buf);
    let source = template(EXAMPLE_DATA_STUDY)?;
    let s = crate::config::Study::from_toml(source, &format!("{EXAMPLE_DATA_STUDY}.toml"), &dir)
        .context("the example data's study")?;
    let files: Vec<PathBuf> = s
        .experiments
        .iter()
        .flat_map(|e| [format!("{}.csv", e.name), format!("{}_noise.csv", e.name)])
        .map(|f| dir.join(f))
        .collect();
    let existing: Vec<PathBuf> = files.iter().filter(|p| p.exists()).cloned().collect();
    if !existing.is_empty() && !force {
        return Ok((Vec::new(), existing));
    }
    let sim = crate::experiment::simulate_observed(&s.simulation_plan(), None)
        .context("simulating the example data")?;
    // only the channels the starter reads: the loop's simulation also records its internal
    // forces (`g1`, `g2`, …), which would only puzzle a reader of the example files
    let mut data = sim.dataset;
    for e in &mut data.experiments {
        e.extra.clear();
        e.noise_extra.clear();
    }
    let written = data.write_csv(&dir).context("writing the example data")?;
    Ok((written, Vec::new()))
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

    /// Every `occam report DIR` a starter's comments name is the directory the job named on
    /// the line before it writes (`<output>/<job>`): the sweep starter named `runs/sweep`,
    /// the study's simulation directory, where its sweep writes `runs/sweep/sweep` (issue 52).
    #[test]
    fn the_report_each_starter_names_is_where_its_job_writes() {
        for (kind, _, text) in KINDS {
            let output = text
                .lines()
                .find_map(|l| l.strip_prefix("output = "))
                .map(|v| v.trim().trim_matches('"'))
                .unwrap_or_else(|| panic!("{kind}: no output"));
            let commands: Vec<Vec<&str>> = text
                .lines()
                .filter_map(|l| l.strip_prefix('#'))
                .map(|l| l.split('#').next().unwrap().split_whitespace().collect())
                .filter(|w: &Vec<&str>| w.first() == Some(&"occam"))
                .collect();
            let at = commands
                .iter()
                .position(|w| w[1] == "report")
                .unwrap_or_else(|| panic!("{kind}: no `occam report` line"));
            let job = commands[at - 1][1];
            assert_eq!(
                commands[at][2],
                format!("{output}/{job}"),
                "{kind}: `occam report` after `occam {job}`"
            );
        }
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
