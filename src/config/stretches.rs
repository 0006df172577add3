//! `[[stretch]]`: experiments grouped in stretches of data taken at different times, each with
//! its covariates (its `time`, telemetry values such as a temperature) and, for a simulation,
//! the true parameter values that differ in it.
//!
//! ```toml
//! [[stretch]]
//! name = "s1"
//! time = 0.0                            # s (any fixed origin): the covariate `time`
//! covariates = { temperature = 21.3 }   # any other covariates, by name
//! truth = { w1sq = -1.30e-6 }           # [truth] values that differ in this stretch
//!
//! [[experiment]]
//! name = "inv1_s1"
//! stretch = "s1"
//! ```
//!
//! When no `[[experiment]]` names a stretch, every simulated experiment is repeated in every
//! stretch, named `<experiment>_<stretch>`: the same injections taken again at each time.
//! Experiments read from files name their stretch. A model then chooses which parameters are
//! shared, free per stretch or drifting (`kind = "drift"`, [`crate::model::drift`]).

use super::error::ConfigError;
use crate::ltp::{LtpParams, PARAM_NAMES};
use crate::model::Covariates;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Most stretches in a study.
pub const MAX_STRETCHES: usize = 1000;

/// One `[[stretch]]` table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StretchEntry {
    pub name: String,
    /// When the stretch was taken (s, from any fixed origin): the covariate `time`.
    pub time: f64,
    /// Other covariates of the stretch by name (a mean temperature, …).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub covariates: BTreeMap<String, f64>,
    /// `[truth]` values that differ in this stretch (simulated data only).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub truth: BTreeMap<String, f64>,
}

/// The validated stretches and which experiment is in which.
#[derive(Debug, Clone, PartialEq, Default, Serialize)]
pub struct Stretches {
    pub entries: Vec<StretchEntry>,
    /// The stretch of each experiment, by experiment name (experiments in no stretch absent).
    pub of_experiment: Vec<(String, String)>,
}

impl Stretches {
    /// Whether the study has no stretches.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// The covariates of every stretch, in order (`time` first).
    pub fn covariates(&self) -> Vec<Covariates> {
        self.entries.iter().map(covariates_of_entry).collect()
    }

    /// The stretch and covariates of experiment `name` (empty when it is in no stretch).
    pub fn covariates_of(&self, name: &str) -> Covariates {
        self.stretch_of(name)
            .map(covariates_of_entry)
            .unwrap_or_default()
    }

    /// The stretch experiment `name` is in.
    pub fn stretch_of(&self, name: &str) -> Option<&StretchEntry> {
        let (_, s) = self.of_experiment.iter().find(|(e, _)| e == name)?;
        self.entries.iter().find(|x| &x.name == s)
    }

    /// The truth of the built-in loop in stretch `s`: `base` with the stretch's values.
    pub fn truth_in(s: &StretchEntry, base: &LtpParams) -> LtpParams {
        let mut a = base.to_array();
        for (k, v) in &s.truth {
            if let Some(i) = PARAM_NAMES.iter().position(|n| n == k) {
                a[i] = *v;
            }
        }
        LtpParams::from_array(&a)
    }
}

fn covariates_of_entry(s: &StretchEntry) -> Covariates {
    let mut values = vec![("time".to_string(), s.time)];
    values.extend(s.covariates.iter().map(|(k, v)| (k.clone(), *v)));
    Covariates {
        stretch: Some(s.name.clone()),
        values,
        experiment: None,
    }
}

/// What the stretches need of an `[[experiment]]` table.
pub trait InStretch: Clone {
    /// The experiment's name.
    fn name(&self) -> &str;
    /// The stretch it names, if any.
    fn stretch(&self) -> Option<&str>;
    /// Whether it reads its data from a file (it cannot be repeated per stretch).
    fn reads_file(&self) -> bool;
    /// The same experiment repeated in stretch `stretch`, as `<name>_<stretch>`.
    fn repeated_in(&self, stretch: &str) -> Self;
}

/// Validates the `[[stretch]]` tables against the experiments and returns the experiments
/// with stretches applied (every simulated experiment repeated per stretch when none names
/// one) and the stretches. `truth_names` are the names a stretch's `truth` may set.
pub fn resolve<E: InStretch>(
    entries: &[StretchEntry],
    experiments: &[E],
    truth_names: &[String],
    file: &str,
) -> Result<(Vec<E>, Stretches), ConfigError> {
    let bad = |field: String, msg: String| ConfigError::Invalid {
        file: file.into(),
        field,
        msg,
    };
    if entries.is_empty() {
        if let Some((k, e)) = experiments
            .iter()
            .enumerate()
            .find(|(_, e)| e.stretch().is_some())
        {
            let s = e.stretch().unwrap_or("");
            return Err(bad(
                format!("experiment[{k}].stretch"),
                format!(
                    "names stretch `{s}`, and the study has no [[stretch]] table: add one with `name = \"{s}\"` and its `time`"
                ),
            ));
        }
        return Ok((experiments.to_vec(), Stretches::default()));
    }
    if entries.len() > MAX_STRETCHES {
        return Err(bad(
            "stretch".into(),
            format!("{} stretches; at most {MAX_STRETCHES}", entries.len()),
        ));
    }
    for (k, s) in entries.iter().enumerate() {
        let at = |f: &str| format!("stretch[{k}].{f}");
        super::models::check_name(&s.name).map_err(|m| bad(at("name"), m))?;
        if entries[..k].iter().any(|x| x.name == s.name) {
            return Err(bad(at("name"), format!("`{}` must be unique", s.name)));
        }
        if !s.time.is_finite() {
            return Err(bad(at("time"), "must be a finite number of seconds".into()));
        }
        for (c, v) in &s.covariates {
            if c == "time" {
                return Err(bad(
                    at("covariates.time"),
                    "`time` is the stretch's own `time` key: give it there".into(),
                ));
            }
            if !v.is_finite() {
                return Err(bad(at(&format!("covariates.{c}")), "must be finite".into()));
            }
        }
        if !s.truth.is_empty() && truth_names.is_empty() {
            return Err(bad(
                at("truth"),
                "a stretch's truth sets the built-in loop's parameters, and this study simulates with a [simulation] model: remove it (the generator's truth is [simulation.truth])".into(),
            ));
        }
        for (n, v) in &s.truth {
            if !truth_names.contains(n) {
                return Err(bad(
                    at(&format!("truth.{n}")),
                    format!(
                        "`{n}` is not a true parameter of the simulation; they are {truth_names:?}"
                    ),
                ));
            }
            if !v.is_finite() {
                return Err(bad(at(&format!("truth.{n}")), "must be finite".into()));
            }
        }
    }
    let named = experiments.iter().any(|e| e.stretch().is_some());
    let mut out = Vec::new();
    let mut of_experiment = Vec::new();
    if named {
        for (k, e) in experiments.iter().enumerate() {
            let s = e.stretch().ok_or_else(|| {
                bad(
                    format!("experiment[{k}].stretch"),
                    format!(
                        "experiment `{}` names no stretch while others do: give it `stretch = …` (one of {:?})",
                        e.name(),
                        entries.iter().map(|s| &s.name).collect::<Vec<_>>()
                    ),
                )
            })?;
            if !entries.iter().any(|x| x.name == s) {
                return Err(bad(
                    format!("experiment[{k}].stretch"),
                    format!(
                        "`{s}` is no [[stretch]]; the stretches are {:?}",
                        entries.iter().map(|s| &s.name).collect::<Vec<_>>()
                    ),
                ));
            }
            of_experiment.push((e.name().to_string(), s.to_string()));
            out.push(e.clone());
        }
    } else {
        if let Some((k, _)) = experiments.iter().enumerate().find(|(_, e)| e.reads_file()) {
            return Err(bad(
                format!("experiment[{k}].stretch"),
                "the experiment reads its data from a file: say which stretch it was taken in with `stretch = …` (only simulated experiments are repeated in every stretch)".into(),
            ));
        }
        for s in entries {
            for e in experiments {
                let e = e.repeated_in(&s.name);
                of_experiment.push((e.name().to_string(), s.name.clone()));
                out.push(e);
            }
        }
    }
    for s in entries {
        if !of_experiment.iter().any(|(_, x)| x == &s.name) {
            return Err(bad(
                "stretch".into(),
                format!(
                    "stretch `{}` holds no experiment: give some [[experiment]] `stretch = \"{}\"` or remove it",
                    s.name, s.name
                ),
            ));
        }
    }
    Ok((
        out,
        Stretches {
            entries: entries.to_vec(),
            of_experiment,
        },
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::ExperimentEntry;

    fn stretch(name: &str, time: f64) -> StretchEntry {
        StretchEntry {
            name: name.into(),
            time,
            covariates: BTreeMap::new(),
            truth: BTreeMap::new(),
        }
    }

    fn experiment(name: &str, stretch: Option<&str>) -> ExperimentEntry {
        let text = format!("name = \"{name}\"\ndesign = \"tn3045_x1\"\n");
        let mut e: ExperimentEntry = toml::from_str(&text).unwrap();
        e.stretch = stretch.map(str::to_string);
        e
    }

    fn names() -> Vec<String> {
        PARAM_NAMES.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn experiments_are_repeated_per_stretch_when_none_names_one() {
        let (exps, st) = resolve(
            &[stretch("a", 0.0), stretch("b", 86400.0)],
            &[experiment("inv1", None), experiment("inv2", None)],
            &names(),
            "t.toml",
        )
        .unwrap();
        let n: Vec<&str> = exps.iter().map(|e| e.name.as_str()).collect();
        assert_eq!(n, ["inv1_a", "inv2_a", "inv1_b", "inv2_b"]);
        let c = st.covariates_of("inv2_b");
        assert_eq!(c.stretch.as_deref(), Some("b"));
        assert_eq!(c.get("time"), Some(86400.0));
        assert!(st.covariates_of("inv1").is_empty());
    }

    #[test]
    fn the_truth_of_a_stretch_overrides_the_study_truth() {
        let mut s = stretch("a", 0.0);
        s.truth.insert("w1sq".into(), -1.4e-6);
        let t = Stretches::truth_in(&s, &LtpParams::default());
        assert_eq!(t.w1sq, -1.4e-6);
        assert_eq!(t.w2sq, LtpParams::default().w2sq);
    }

    #[test]
    fn bad_stretches_name_the_field_and_the_fix() {
        let err = |s: &[StretchEntry], e: &[ExperimentEntry]| {
            resolve(s, e, &names(), "t.toml").unwrap_err().to_string()
        };
        let e = err(&[], &[experiment("x", Some("a"))]);
        assert!(
            e.contains("experiment[0].stretch") && e.contains("no [[stretch]]"),
            "{e}"
        );
        let e = err(
            &[stretch("a", 0.0), stretch("a", 1.0)],
            &[experiment("x", None)],
        );
        assert!(e.contains("stretch[1].name") && e.contains("unique"), "{e}");
        let e = err(&[stretch("a", f64::NAN)], &[experiment("x", None)]);
        assert!(e.contains("stretch[0].time"), "{e}");
        let mut t = stretch("a", 0.0);
        t.truth.insert("w9".into(), 1.0);
        let e = err(&[t], &[experiment("x", None)]);
        assert!(e.contains("stretch[0].truth.w9"), "{e}");
        let e = err(
            &[stretch("a", 0.0), stretch("b", 1.0)],
            &[experiment("x", Some("a")), experiment("y", None)],
        );
        assert!(
            e.contains("experiment[1].stretch") && e.contains("names no stretch"),
            "{e}"
        );
        let e = err(
            &[stretch("a", 0.0), stretch("b", 1.0)],
            &[experiment("x", Some("a"))],
        );
        assert!(e.contains("`b` holds no experiment"), "{e}");
        let e = err(&[stretch("a", 0.0)], &[experiment("x", Some("c"))]);
        assert!(e.contains("`c` is no [[stretch]]"), "{e}");
    }
}
