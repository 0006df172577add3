//! What a refused `--resume` says changed. A checkpoint carries one hash of everything its
//! numbers depend on ([`crate::jobs::prepare::identity`]); a hash cannot say *what* differs.
//! So a run also records, beside its checkpoint, one hash per key of the study file as written
//! (`analysis.band`, `experiment[0].x1.segments[1].freq`, …) and per experiment's data
//! ([`FILE`]); a resume whose identity differs compares them and names the first key that
//! changed, instead of two opaque hashes.
//!
//! ```
//! # let study = |band: &str| occam::config::Study::from_toml(&format!(
//! #     "seed = 1\noutput = \"o\"\n[analysis]\nband = {band}\n[[experiment]]\nname = \"a\"\ndesign = \"tn3045_x1\"\n"),
//! #     "s.toml", std::path::Path::new(".")).unwrap();
//! use occam::jobs::run_identity::RunIdentity;
//! let data = occam::data::dataset::Dataset {
//!     experiments: vec![],
//!     seed: None,
//!     truth: None,
//!     extra: serde_json::Value::Null,
//! };
//! let dir = tempfile::tempdir().unwrap();
//! RunIdentity::of(&study("[1e-3, 0.5]"), &data).record(dir.path()).unwrap();
//! let now = RunIdentity::of(&study("[2e-3, 0.5]"), &data);
//! assert_eq!(now.changed_since(dir.path()).unwrap(), "`analysis.band` changed");
//! ```

use crate::config::Study;
use crate::data::Fnv1a;
use crate::data::dataset::Dataset;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The file beside a run's checkpoint that holds its [`RunIdentity`].
pub const FILE: &str = "checkpoint.identity.json";

/// A run's identity and the hashes of its parts.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunIdentity {
    /// [`crate::jobs::prepare::identity`] of the study and data.
    pub identity: String,
    /// `(part, hash)`: each key of the study file as written, then each experiment's data.
    parts: Vec<(String, String)>,
}

impl RunIdentity {
    /// The identity of a run of `study` on `data`.
    pub fn of(study: &Study, data: &Dataset) -> Self {
        let mut parts = Vec::new();
        let file = serde_json::to_value(&study.file).expect("a study file serialises");
        leaves(&file, String::new(), &mut parts);
        parts.retain(|(k, _)| k != "output");
        for e in &data.experiments {
            let mut h = Fnv1a::default();
            crate::jobs::prepare::hash_samples(&mut h, e);
            parts.push((
                format!("the data of experiment `{}`", e.name),
                format!("{:016x}", h.finish()),
            ));
        }
        RunIdentity {
            identity: crate::jobs::prepare::identity(study, data),
            parts,
        }
    }

    /// Writes it to `dir`/[`FILE`] (atomically).
    pub fn record(&self, dir: &Path) -> std::io::Result<()> {
        let text = serde_json::to_vec_pretty(self).expect("an identity serialises");
        crate::atomic::write_bytes(&dir.join(FILE), &text)
    }

    /// What differs from the run recorded in `dir`: `None` when the identities agree or the
    /// run recorded none (an earlier occam); otherwise the first part that differs, named as
    /// the user wrote it, or that the resolved study differs though no key does.
    pub fn changed_since(&self, dir: &Path) -> Option<String> {
        let bytes = crate::data::infile::read(&dir.join(FILE)).ok()?;
        let old: RunIdentity = serde_json::from_slice(&bytes).ok()?;
        if old.identity == self.identity {
            return None;
        }
        let was = |k: &str| old.parts.iter().find(|(o, _)| o == k).map(|(_, h)| h);
        if let Some((k, _)) = self.parts.iter().find(|(k, h)| was(k) != Some(h)) {
            let verb = if was(k).is_none() {
                "was added"
            } else {
                "changed"
            };
            return Some(if k.starts_with("the data") {
                format!("{k} changed")
            } else {
                format!("`{k}` {verb}")
            });
        }
        if let Some((k, _)) = old
            .parts
            .iter()
            .find(|(k, _)| !self.parts.iter().any(|(n, _)| n == k))
        {
            return Some(if k.starts_with("the data") {
                format!("{k} is gone")
            } else {
                format!("`{k}` was removed")
            });
        }
        Some(
            "no key of the study file differs, but what they resolve to does (a file the study reads, or another occam version)"
                .into(),
        )
    }
}

/// For a job that checkpoints in `dir`: with `resume`, refuses a run whose study or data
/// changed since the checkpoint was written, naming what changed (`checkpoint` names the
/// file); without it, records this run's identity for a later resume to compare with.
pub fn check_or_record(
    study: &Study,
    data: &Dataset,
    dir: &Path,
    resume: bool,
    checkpoint: &str,
) -> anyhow::Result<()> {
    let me = RunIdentity::of(study, data);
    if resume {
        if let Some(what) = me.changed_since(dir) {
            anyhow::bail!(
                "--resume: {} belongs to a different run: {what} since it was written; undo the change, or run without --resume to start afresh",
                dir.join(checkpoint).display()
            );
        }
        return Ok(());
    }
    std::fs::create_dir_all(dir)
        .and_then(|()| me.record(dir))
        .map_err(|e| anyhow::anyhow!("{}: {e}", dir.join(FILE).display()))
}

/// The leaves of `v` as `(path, hash of the leaf's JSON)`: objects by key, arrays by index; an
/// array of scalars (a band, a list of names) is one leaf; nulls (keys left out) are skipped.
fn leaves(v: &serde_json::Value, at: String, out: &mut Vec<(String, String)>) {
    use serde_json::Value;
    let scalar = |v: &Value| !matches!(v, Value::Object(_) | Value::Array(_));
    match v {
        Value::Null => {}
        Value::Object(m) => {
            for (k, x) in m {
                let p = if at.is_empty() {
                    k.clone()
                } else {
                    format!("{at}.{k}")
                };
                leaves(x, p, out);
            }
        }
        Value::Array(a) if !a.iter().all(scalar) => {
            for (i, x) in a.iter().enumerate() {
                leaves(x, format!("{at}[{i}]"), out);
            }
        }
        _ => {
            let mut h = Fnv1a::default();
            h.update(&serde_json::to_vec(v).expect("JSON serialises"));
            out.push((at, format!("{:016x}", h.finish())));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn study(extra: &str, exp: &str) -> Study {
        Study::from_toml(
            &format!(
                "seed = 1\noutput = \"o\"\n{extra}\n[[experiment]]\nname = \"a\"\ndesign = \"tn3045_x1\"\n{exp}\n[[experiment]]\nname = \"b\"\ndesign = \"tn3045_x12\"\n"
            ),
            "s.toml",
            Path::new("."),
        )
        .unwrap()
    }

    fn empty() -> Dataset {
        Dataset {
            experiments: vec![],
            seed: None,
            truth: None,
            extra: serde_json::Value::Null,
        }
    }

    fn changed(old: &Study, new: &Study, data: (&Dataset, &Dataset)) -> Option<String> {
        let dir = tempfile::tempdir().unwrap();
        RunIdentity::of(old, data.0).record(dir.path()).unwrap();
        RunIdentity::of(new, data.1).changed_since(dir.path())
    }

    #[test]
    fn names_the_first_key_that_changed() {
        let d = empty();
        let base = study("", "");
        assert_eq!(changed(&base, &base, (&d, &d)), None);
        let other_output = Study {
            output: "elsewhere".into(),
            ..base.clone()
        };
        assert_eq!(changed(&base, &other_output, (&d, &d)), None);
        let likelihood = study("[analysis]\nlikelihood = \"exact\"", "");
        assert_eq!(
            changed(&base, &likelihood, (&d, &d)).unwrap(),
            "`analysis.likelihood` changed"
        );
        let added = study("", "pre_pad = 100.0");
        assert_eq!(
            changed(&base, &added, (&d, &d)).unwrap(),
            "`experiment[0].pre_pad` was added"
        );
        assert_eq!(
            changed(&added, &base, (&d, &d)).unwrap(),
            "`experiment[0].pre_pad` was removed"
        );
        let fixed = study("[fit]\nfixed = { a_df = 0.8 }", "");
        let fixed2 = study("[fit]\nfixed = { a_df = 0.81 }", "");
        assert_eq!(
            changed(&fixed, &fixed2, (&d, &d)).unwrap(),
            "`fit.fixed.a_df` changed"
        );
        let mut data = empty();
        data.experiments
            .push(crate::data::dataset::ExperimentData::new(
                "a",
                1.0,
                [vec![1.0], vec![2.0]],
                [vec![0.0], vec![0.0]],
                [vec![], vec![]],
            ));
        let mut data2 = data.clone();
        data2.experiments[0].o[0][0] = 1.5;
        assert_eq!(
            changed(&base, &base, (&data, &data2)).unwrap(),
            "the data of experiment `a` changed"
        );
    }

    #[test]
    fn a_run_without_a_record_or_with_a_damaged_one_says_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let now = RunIdentity::of(&study("", ""), &empty());
        assert_eq!(now.changed_since(dir.path()), None);
        std::fs::write(dir.path().join(FILE), "{not json").unwrap();
        assert_eq!(now.changed_since(dir.path()), None);
    }
}
