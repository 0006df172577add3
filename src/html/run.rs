//! Reading a run directory as its command left it: the manifest, the summary, the tables,
//! the figures and the resolved study. Old runs (no manifest, no resolved study) are read
//! from what they have.

use super::error::ReportError;
use crate::data::rundir::{MANIFEST, Manifest};
use serde_json::Value;
use std::path::{Path, PathBuf};

/// Files larger than this are listed but not read into the page (a figure of that size would
/// make the page unusable; a summary of that size is not one occam wrote).
pub const MAX_INLINE_BYTES: u64 = 32 << 20;

/// The file `fit`, `select` and `sweep` write with the resolved study.
pub const RESOLVED_STUDY: &str = crate::config::RESOLVED_FILE;

/// Which command wrote the run.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum RunKind {
    Fit,
    Select,
    Sweep,
    /// Any other command (`simulate`, `design`, …): the page shows its files generically.
    Other(String),
}

impl RunKind {
    /// The command's name.
    pub fn name(&self) -> &str {
        match self {
            RunKind::Fit => "fit",
            RunKind::Select => "select",
            RunKind::Sweep => "sweep",
            RunKind::Other(s) => s,
        }
    }
}

/// A file that could not be shown, and why.
#[derive(Debug, Clone, PartialEq)]
pub struct Skipped {
    pub name: String,
    pub why: String,
}

/// Everything the page shows, read from the run directory.
#[derive(Debug, Clone)]
pub struct Run {
    pub dir: PathBuf,
    pub kind: RunKind,
    pub manifest: Option<Manifest>,
    /// `summary.json` (fit, select) or `sweep.json` (sweep), with its file name.
    pub summary: Option<(String, Value)>,
    /// Table files (`table.md`, else `table.txt`): name and text.
    pub tables: Vec<(String, String)>,
    /// Figures: file name and the `<svg>` element, sanitised.
    pub figures: Vec<(String, String)>,
    /// Other JSON outputs shown as text (the outputs of simulate and design).
    pub json_files: Vec<(String, String)>,
    /// `study.resolved.toml`, when the run wrote it.
    pub study: Option<String>,
    /// The run's files with their sizes (from the manifest, else the directory).
    pub files: Vec<(String, u64)>,
    /// Files listed but not shown.
    pub skipped: Vec<Skipped>,
}

fn file_err(file: &Path, msg: impl Into<String>) -> ReportError {
    ReportError::File {
        file: file.to_path_buf(),
        msg: msg.into(),
    }
}

/// Reads a UTF-8 file within [`MAX_INLINE_BYTES`]: `Ok(None)` when it is too large.
fn read_text(path: &Path) -> Result<Option<String>, ReportError> {
    let len = std::fs::metadata(path)
        .map_err(|e| file_err(path, format!("cannot read it: {e}")))?
        .len();
    if len > MAX_INLINE_BYTES {
        return Ok(None);
    }
    let bytes = crate::data::infile::read(path)
        .map_err(|e| file_err(path, format!("cannot read it: {e}")))?;
    Ok(Some(String::from_utf8_lossy(&bytes).into_owned()))
}

/// Reads and parses a JSON file the run must have.
fn read_json(path: &Path) -> Result<Value, ReportError> {
    let text = read_text(path)?.ok_or_else(|| {
        file_err(
            path,
            format!("larger than {MAX_INLINE_BYTES} bytes: not a file occam wrote"),
        )
    })?;
    serde_json::from_str(&text).map_err(|e| {
        file_err(
            path,
            format!("not valid JSON ({e}); rerun the command that wrote the directory"),
        )
    })
}

/// The keys a summary of each kind always has (`fit` and `select`: `summary.json`; `sweep`:
/// `sweep.json`): a page is built only on a summary of the run's own kind.
const SHAPES: [(&str, [&str; 2]); 3] = [
    ("fit", ["rows", "acceptance"]),
    ("select", ["pairs", "models"]),
    ("sweep", ["axes", "points"]),
];

/// Whether `v` has the keys of a `kind` summary ([`SHAPES`]).
fn has_shape(kind: &str, v: &Value) -> bool {
    SHAPES
        .iter()
        .find(|(k, _)| *k == kind)
        .is_none_or(|(_, keys)| keys.iter().all(|k| v.get(k).is_some()))
}

/// The size of `name` in `dir` against what the manifest recorded: why the file cannot be
/// trusted, or `None` when it is the run's (or the manifest does not list it).
fn changed_since_run(dir: &Path, manifest: &Manifest, name: &str) -> Option<String> {
    let want = manifest.files.iter().find(|f| f.name == name)?.bytes;
    let got = std::fs::metadata(dir.join(name)).ok()?.len();
    (got != want).then(|| {
        format!("changed since the run wrote it: {got} bytes, manifest.json records {want}")
    })
}

/// The command of a run without a manifest, from the shape of its summary.
fn kind_from_files(dir: &Path) -> Result<Option<(RunKind, String, Value)>, ReportError> {
    let summary = dir.join("summary.json");
    if summary.is_file() {
        let v = read_json(&summary)?;
        let kind = if has_shape("fit", &v) {
            RunKind::Fit
        } else if has_shape("select", &v) {
            RunKind::Select
        } else {
            return Err(file_err(
                &summary,
                "neither a fit nor a select summary (no `rows`, no `pairs`); give the directory a fit/select/sweep wrote",
            ));
        };
        return Ok(Some((kind, "summary.json".into(), v)));
    }
    let sweep = dir.join("sweep.json");
    if sweep.is_file() {
        let v = read_json(&sweep)?;
        return Ok(Some((RunKind::Sweep, "sweep.json".into(), v)));
    }
    Ok(None)
}

/// Whether `name` is a plain file name (a manifest entry must not point elsewhere).
fn plain(name: &str) -> bool {
    let p = Path::new(name);
    p.components().count() == 1 && p.file_name().is_some_and(|n| n == name)
}

impl Run {
    /// Reads the run in `dir`; the error says why it is not a run directory.
    pub fn read(dir: &Path) -> Result<Run, ReportError> {
        if !dir.is_dir() {
            return Err(ReportError::not_a_run(dir));
        }
        let mpath = dir.join(MANIFEST);
        let manifest: Option<Manifest> = if mpath.is_file() {
            let text = read_text(&mpath)?.unwrap_or_default();
            Some(serde_json::from_str(&text).map_err(|e| {
                file_err(
                    &mpath,
                    format!(
                        "not a valid occam manifest ({e}); rerun the command that wrote the directory"
                    ),
                )
            })?)
        } else {
            None
        };
        let (kind, summary) = match &manifest {
            Some(m) => {
                let kind = match m.command.as_str() {
                    "fit" => RunKind::Fit,
                    "select" => RunKind::Select,
                    "sweep" => RunKind::Sweep,
                    c => RunKind::Other(c.to_string()),
                };
                let name = match kind {
                    RunKind::Sweep => Some("sweep.json"),
                    RunKind::Fit | RunKind::Select => Some("summary.json"),
                    RunKind::Other(_) => None,
                };
                let summary = match name {
                    Some(n) => {
                        let p = dir.join(n);
                        if !p.is_file() {
                            return Err(file_err(
                                &p,
                                format!(
                                    "missing, though manifest.json lists a {} run; rerun the command",
                                    kind.name()
                                ),
                            ));
                        }
                        if let Some(why) = changed_since_run(dir, m, n) {
                            return Err(file_err(
                                &p,
                                format!(
                                    "{why}: it was replaced or damaged after the run; rerun the command"
                                ),
                            ));
                        }
                        let v = read_json(&p)?;
                        if !has_shape(kind.name(), &v) {
                            return Err(file_err(
                                &p,
                                format!(
                                    "not a {} summary (no `{}`), though manifest.json lists a {} run; rerun the command",
                                    kind.name(),
                                    SHAPES
                                        .iter()
                                        .find(|(k, _)| *k == kind.name())
                                        .map_or(String::new(), |(_, keys)| keys.join("`, no `")),
                                    kind.name()
                                ),
                            ));
                        }
                        Some((n.to_string(), v))
                    }
                    None => None,
                };
                (kind, summary)
            }
            None => match kind_from_files(dir)? {
                Some((k, n, v)) => (k, Some((n, v))),
                None => return Err(ReportError::not_a_run(dir)),
            },
        };
        // the run's files: the manifest's, else what the directory holds
        let files: Vec<(String, u64)> = match &manifest {
            Some(m) => m
                .files
                .iter()
                .filter(|f| plain(&f.name))
                .map(|f| (f.name.clone(), f.bytes))
                .collect(),
            None => {
                let mut v: Vec<(String, u64)> = std::fs::read_dir(dir)
                    .map_err(|e| file_err(dir, format!("cannot list it: {e}")))?
                    .flatten()
                    .filter_map(|e| {
                        let name = e.file_name().to_string_lossy().into_owned();
                        let meta = e.metadata().ok()?;
                        (meta.is_file() && !name.starts_with('.')).then_some((name, meta.len()))
                    })
                    .collect();
                v.sort();
                v
            }
        };
        let mut run = Run {
            dir: dir.to_path_buf(),
            kind,
            manifest,
            summary,
            tables: Vec::new(),
            figures: Vec::new(),
            json_files: Vec::new(),
            study: None,
            files,
            skipped: Vec::new(),
        };
        run.read_outputs()?;
        Ok(run)
    }

    /// Tables, figures, other JSON outputs and the resolved study.
    fn read_outputs(&mut self) -> Result<(), ReportError> {
        let names: Vec<String> = self.files.iter().map(|(n, _)| n.clone()).collect();
        let has = |n: &str| names.iter().any(|x| x == n);
        let table = if has("table.md") {
            Some("table.md")
        } else if has("table.txt") {
            Some("table.txt")
        } else {
            None
        };
        for name in &names {
            let p = self.dir.join(name);
            let is_table = Some(name.as_str()) == table;
            let is_svg = name.ends_with(".svg");
            let is_json = name.ends_with(".json")
                && self.summary.as_ref().is_none_or(|(s, _)| s != name)
                && name != MANIFEST;
            if !(is_table || is_svg || is_json) {
                continue;
            }
            if !p.is_file() {
                self.skipped.push(Skipped {
                    name: name.clone(),
                    why: "listed in manifest.json but missing from the directory".into(),
                });
                continue;
            }
            if let Some(why) = self
                .manifest
                .as_ref()
                .and_then(|m| changed_since_run(&self.dir, m, name))
            {
                self.skipped.push(Skipped {
                    name: name.clone(),
                    why,
                });
                continue;
            }
            let Some(text) = read_text(&p)? else {
                self.skipped.push(Skipped {
                    name: name.clone(),
                    why: format!("larger than {MAX_INLINE_BYTES} bytes: not inlined"),
                });
                continue;
            };
            if is_table {
                self.tables.push((name.clone(), text));
            } else if is_svg {
                match super::escape::inline_svg(&text) {
                    Some(svg) => self.figures.push((name.clone(), svg)),
                    None => self.skipped.push(Skipped {
                        name: name.clone(),
                        why: "holds no <svg> element".into(),
                    }),
                }
            } else {
                self.json_files.push((name.clone(), text));
            }
        }
        let sp = self.dir.join(RESOLVED_STUDY);
        let changed = self
            .manifest
            .as_ref()
            .and_then(|m| changed_since_run(&self.dir, m, RESOLVED_STUDY));
        if let Some(why) = changed {
            self.skipped.push(Skipped {
                name: RESOLVED_STUDY.into(),
                why,
            });
        } else if sp.is_file() {
            self.study = read_text(&sp)?;
            if self.study.is_none() {
                self.skipped.push(Skipped {
                    name: RESOLVED_STUDY.into(),
                    why: format!("larger than {MAX_INLINE_BYTES} bytes: not inlined"),
                });
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn old_runs_are_recognised_by_their_summary() {
        let t = tempfile::tempdir().unwrap();
        let d = t.path();
        std::fs::write(d.join("summary.json"), r#"{"rows": [], "acceptance": []}"#).unwrap();
        std::fs::write(d.join("corner.svg"), "<svg></svg>").unwrap();
        std::fs::write(d.join("notes.svg"), "not a figure").unwrap();
        let r = Run::read(d).unwrap();
        assert_eq!(r.kind, RunKind::Fit);
        assert!(r.manifest.is_none() && r.study.is_none());
        assert_eq!(
            r.figures,
            [("corner.svg".to_string(), "<svg></svg>".to_string())]
        );
        assert_eq!(r.skipped[0].name, "notes.svg");
        std::fs::write(d.join("summary.json"), r#"{"pairs": [], "models": []}"#).unwrap();
        assert_eq!(Run::read(d).unwrap().kind, RunKind::Select);
        std::fs::write(d.join("summary.json"), r#"{"other": 1}"#).unwrap();
        let e = Run::read(d).unwrap_err().to_string();
        assert!(e.contains("summary.json") && e.contains("neither"), "{e}");
        std::fs::write(d.join("summary.json"), "{").unwrap();
        let e = Run::read(d).unwrap_err().to_string();
        assert!(e.contains("not valid JSON"), "{e}");
        std::fs::remove_file(d.join("summary.json")).unwrap();
        std::fs::write(d.join("sweep.json"), r#"{"points": []}"#).unwrap();
        assert_eq!(Run::read(d).unwrap().kind, RunKind::Sweep);
    }

    #[test]
    fn a_directory_without_manifest_or_summary_is_not_a_run() {
        let t = tempfile::tempdir().unwrap();
        let e = Run::read(t.path()).unwrap_err().to_string();
        assert!(
            e.contains("is not an occam run directory (no manifest.json)"),
            "{e}"
        );
        let e = Run::read(&t.path().join("nowhere"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("not an occam run directory"), "{e}");
    }

    #[test]
    fn manifest_entries_that_are_missing_or_leave_the_directory_are_not_read() {
        let t = tempfile::tempdir().unwrap();
        let d = t.path();
        std::fs::write(
            d.join(MANIFEST),
            r#"{"format":"occam-run","command":"design","version":"0","files":[
                {"name":"gone.svg","bytes":3},{"name":"../x.svg","bytes":1},
                {"name":"design.json","bytes":2}]}"#,
        )
        .unwrap();
        std::fs::write(d.join("design.json"), "{}").unwrap();
        let r = Run::read(d).unwrap();
        assert_eq!(r.kind, RunKind::Other("design".into()));
        assert_eq!(r.files.len(), 2);
        assert_eq!(r.skipped[0].name, "gone.svg");
        assert_eq!(r.json_files[0].0, "design.json");
        // a fit manifest without its summary
        std::fs::write(
            d.join(MANIFEST),
            r#"{"format":"occam-run","command":"fit","version":"0","files":[]}"#,
        )
        .unwrap();
        let e = Run::read(d).unwrap_err().to_string();
        assert!(e.contains("summary.json") && e.contains("missing"), "{e}");
        std::fs::write(d.join(MANIFEST), "garbage").unwrap();
        let e = Run::read(d).unwrap_err().to_string();
        assert!(e.contains("not a valid occam manifest"), "{e}");
    }

    #[test]
    fn files_changed_after_the_run_are_not_trusted() {
        let t = tempfile::tempdir().unwrap();
        let d = t.path();
        let fit = r#"{"rows": [], "acceptance": []}"#;
        let manifest = |summary: usize| {
            format!(
                r#"{{"format":"occam-run","command":"fit","version":"0","files":[
                {{"name":"summary.json","bytes":{summary}}},{{"name":"corner.svg","bytes":11}},
                {{"name":"study.resolved.toml","bytes":9}}]}}"#
            )
        };
        std::fs::write(d.join(MANIFEST), manifest(fit.len())).unwrap();
        std::fs::write(d.join("summary.json"), fit).unwrap();
        std::fs::write(d.join("corner.svg"), "<svg></svg>").unwrap();
        std::fs::write(d.join(RESOLVED_STUDY), "seed = 1\n").unwrap();
        let r = Run::read(d).unwrap();
        assert!(r.skipped.is_empty() && r.figures.len() == 1 && r.study.is_some());
        // the summary replaced by other JSON: refused, not shown as a run without warnings
        std::fs::write(
            d.join("summary.json"),
            r#"{"pairs": [], "models": [], "x": 1}"#,
        )
        .unwrap();
        let e = Run::read(d).unwrap_err().to_string();
        assert!(
            e.contains("summary.json") && e.contains("35 bytes, manifest.json records 30"),
            "{e}"
        );
        // of the recorded size, but not a fit's summary
        let other = r#"{"pairs": [], "models": [1]}"#;
        std::fs::write(d.join(MANIFEST), manifest(other.len())).unwrap();
        std::fs::write(d.join("summary.json"), other).unwrap();
        let e = Run::read(d).unwrap_err().to_string();
        assert!(e.contains("not a fit summary (no `rows`"), "{e}");
        // a figure or the resolved study edited: listed as skipped, with the sizes
        std::fs::write(d.join(MANIFEST), manifest(fit.len())).unwrap();
        std::fs::write(d.join("summary.json"), fit).unwrap();
        std::fs::write(d.join("corner.svg"), "<svg>x</svg>").unwrap();
        std::fs::write(d.join(RESOLVED_STUDY), "seed = 12\n").unwrap();
        let r = Run::read(d).unwrap();
        assert!(r.figures.is_empty() && r.study.is_none());
        let why: Vec<&str> = r.skipped.iter().map(|s| s.why.as_str()).collect();
        assert_eq!(
            why,
            [
                "changed since the run wrote it: 12 bytes, manifest.json records 11",
                "changed since the run wrote it: 10 bytes, manifest.json records 9"
            ]
        );
    }
}
