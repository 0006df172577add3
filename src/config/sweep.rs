//! The `[sweep]` table: a 1-D or 2-D grid over any numeric study key, with noise realisations
//! per point (`occam sweep`).
//!
//! ```toml
//! [sweep]
//! realisations = 8                  # noise realisations per grid point
//! truth = "X"                       # the [[select.model]] that generated the data (optional)
//! [[sweep.axis]]
//! key = "simulation.target_snr"     # a dotted path into this file
//! values = [5.0, 10.0, 20.0, 40.0]
//! [[sweep.axis]]
//! key = "experiment.inv1.x1.freq"   # [[experiment]] tables are addressed by name
//! from = 1e-4
//! to = 1.0
//! points = 20
//! spacing = "log"                   # or "linear"
//! ```

use super::error::ConfigError;
use serde::{Deserialize, Serialize};

/// How `from`, `to` and `points` fill an axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Spacing {
    /// Evenly spaced in the logarithm (needs `from`, `to` > 0).
    #[default]
    Log,
    Linear,
}

/// One `[[sweep.axis]]` table: a study key and its values, listed or as a range.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SweepAxis {
    /// A dotted path into the study file, e.g. `simulation.target_snr`,
    /// `experiment.inv1.x1.freq` or `experiment.inv1.x1.segments.0.amplitude`.
    pub key: String,
    #[serde(default)]
    pub values: Option<Vec<f64>>,
    #[serde(default)]
    pub from: Option<f64>,
    #[serde(default)]
    pub to: Option<f64>,
    #[serde(default)]
    pub points: Option<usize>,
    #[serde(default)]
    pub spacing: Spacing,
}

/// Most grid points one sweep may hold (a 100 × 100 grid): beyond that the task list and the
/// result arrays, not the science, are the limit.
pub const MAX_POINTS: usize = 10_000;
/// Most noise realisations per point.
pub const MAX_REALISATIONS: usize = 10_000;

impl SweepAxis {
    /// The axis's values in order, validated; `field` names it in messages.
    pub fn grid(&self, file: &str, field: &str) -> Result<Vec<f64>, ConfigError> {
        let bad = |f: &str, msg: String| ConfigError::Invalid {
            file: file.into(),
            field: format!("{field}.{f}"),
            msg,
        };
        if self.key.trim().is_empty() {
            return Err(bad(
                "key",
                "name a study key, e.g. \"simulation.target_snr\"".into(),
            ));
        }
        let ranged = self.from.is_some() || self.to.is_some() || self.points.is_some();
        let v = match (&self.values, ranged) {
            (Some(_), true) => {
                return Err(bad(
                    "values",
                    "give either `values` or `from`/`to`/`points`, not both".into(),
                ));
            }
            (Some(v), false) => v.clone(),
            (None, true) => {
                let (Some(a), Some(b), Some(n)) = (self.from, self.to, self.points) else {
                    return Err(bad(
                        "points",
                        "a range needs all of `from`, `to` and `points`".into(),
                    ));
                };
                if !(1..=MAX_POINTS).contains(&n) {
                    return Err(bad(
                        "points",
                        format!("must be in 1..={MAX_POINTS} (got {n})"),
                    ));
                }
                if !(a.is_finite() && b.is_finite()) {
                    return Err(bad(
                        "from",
                        format!("`from` and `to` must be finite (got {a}, {b})"),
                    ));
                }
                if self.spacing == Spacing::Log && !(a > 0.0 && b > 0.0) {
                    return Err(bad(
                        "spacing",
                        format!(
                            "a log axis needs from, to > 0 (got {a}, {b}); use spacing = \"linear\""
                        ),
                    ));
                }
                let t = |i: usize| {
                    if n == 1 {
                        0.0
                    } else {
                        i as f64 / (n - 1) as f64
                    }
                };
                // the ends exactly as written (exp(ln a) is not always a)
                (0..n)
                    .map(|i| match self.spacing {
                        _ if i == 0 => a,
                        _ if i + 1 == n => b,
                        Spacing::Log => (a.ln() + t(i) * (b.ln() - a.ln())).exp(),
                        Spacing::Linear => a + t(i) * (b - a),
                    })
                    // 10 significant digits: 100, not 100.00000000000004
                    .map(|x: f64| format!("{x:.9e}").parse::<f64>().unwrap_or(x))
                    .collect()
            }
            (None, false) => {
                return Err(bad(
                    "values",
                    "give the axis's `values = [...]`, or `from`, `to` and `points`".into(),
                ));
            }
        };
        if v.is_empty() || v.len() > MAX_POINTS {
            return Err(bad(
                "values",
                format!("needs 1..={MAX_POINTS} values (got {})", v.len()),
            ));
        }
        if let Some(x) = v.iter().find(|x| !x.is_finite()) {
            return Err(bad(
                "values",
                format!("every value must be finite (got {x})"),
            ));
        }
        for (i, a) in v.iter().enumerate() {
            if v[..i].contains(a) {
                return Err(bad("values", format!("{a} is listed twice")));
            }
        }
        Ok(v)
    }
}

/// `[sweep]` options.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SweepOptions {
    /// Noise realisations per grid point (default 1).
    #[serde(default = "one")]
    pub realisations: usize,
    /// The `[[select.model]]` that generated the data: the sweep then reports how often each
    /// estimator picks it.
    #[serde(default)]
    pub truth: Option<String>,
    /// One or two axes; the grid is their product.
    #[serde(default)]
    pub axis: Vec<SweepAxis>,
}

fn one() -> usize {
    1
}

impl Default for SweepOptions {
    fn default() -> Self {
        Self {
            realisations: 1,
            truth: None,
            axis: Vec::new(),
        }
    }
}

impl SweepOptions {
    /// Checks the table against the study's `[[select.model]]` names; returns the axes' grids.
    pub fn validate(
        &self,
        select_models: &[&str],
        file: &str,
    ) -> Result<Vec<Vec<f64>>, ConfigError> {
        let bad = |field: &str, msg: String| ConfigError::Invalid {
            file: file.into(),
            field: format!("sweep.{field}"),
            msg,
        };
        if !(1..=MAX_REALISATIONS).contains(&self.realisations) {
            return Err(bad(
                "realisations",
                format!(
                    "must be in 1..={MAX_REALISATIONS} (got {})",
                    self.realisations
                ),
            ));
        }
        if let Some(t) = &self.truth
            && !select_models.contains(&t.as_str())
        {
            return Err(bad(
                "truth",
                format!("`{t}` is not a [[select.model]] name; the names are {select_models:?}"),
            ));
        }
        if self.axis.len() > 2 {
            return Err(bad(
                "axis",
                format!("a sweep has one or two axes (got {})", self.axis.len()),
            ));
        }
        if self.axis.len() == 2 && self.axis[0].key == self.axis[1].key {
            return Err(bad(
                "axis",
                format!("`{}` is swept twice", self.axis[0].key),
            ));
        }
        let grids = self
            .axis
            .iter()
            .enumerate()
            .map(|(i, a)| a.grid(file, &format!("sweep.axis[{i}]")))
            .collect::<Result<Vec<_>, _>>()?;
        let n: usize = grids.iter().map(Vec::len).product();
        if n.saturating_mul(self.realisations) > MAX_POINTS * 10 {
            return Err(bad(
                "realisations",
                format!(
                    "{n} points × {} realisations = {} tasks; at most {} per sweep: split the sweep",
                    self.realisations,
                    n.saturating_mul(self.realisations),
                    MAX_POINTS * 10
                ),
            ));
        }
        Ok(grids)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn axis(toml_text: &str) -> SweepAxis {
        toml::from_str(toml_text).unwrap()
    }

    #[test]
    fn log_and_linear_ranges_hit_both_ends() {
        let g = axis("key = \"a\"\nfrom = 1e-4\nto = 1.0\npoints = 5")
            .grid("f", "x")
            .unwrap();
        assert_eq!(g.len(), 5);
        assert!((g[0] - 1e-4).abs() < 1e-18 && (g[4] - 1.0).abs() < 1e-14);
        assert_eq!(g[1], 1e-3, "{g:?}");
        let g = axis("key = \"a\"\nfrom = -1.0\nto = 1.0\npoints = 3\nspacing = \"linear\"")
            .grid("f", "x")
            .unwrap();
        assert_eq!(g, vec![-1.0, 0.0, 1.0]);
        let g = axis("key = \"a\"\nfrom = 3.0\nto = 9.0\npoints = 1")
            .grid("f", "x")
            .unwrap();
        assert_eq!(g, vec![3.0]);
    }

    #[test]
    fn bad_axes_are_named() {
        for (text, field, needle) in [
            ("key = \"a\"", "x.values", "give the axis"),
            (
                "key = \"a\"\nvalues = [1.0]\nfrom = 1.0",
                "x.values",
                "not both",
            ),
            ("key = \"a\"\nfrom = 1.0\nto = 2.0", "x.points", "all of"),
            (
                "key = \"a\"\nfrom = 0.0\nto = 2.0\npoints = 3",
                "x.spacing",
                "linear",
            ),
            (
                "key = \"a\"\nfrom = 1.0\nto = 2.0\npoints = 1000000",
                "x.points",
                "1..=",
            ),
            ("key = \"a\"\nvalues = []", "x.values", "1..="),
            ("key = \"a\"\nvalues = [1.0, 1.0]", "x.values", "twice"),
            ("key = \"\"\nvalues = [1.0]", "x.key", "study key"),
        ] {
            let e = axis(text).grid("f", "x").unwrap_err().to_string();
            assert!(
                e.contains(&format!("`{field}`")) && e.contains(needle),
                "{text}: {e}"
            );
        }
    }

    #[test]
    fn options_check_truth_axes_and_task_count() {
        let o: SweepOptions = toml::from_str(
            "realisations = 2\ntruth = \"Y\"\n[[axis]]\nkey = \"a\"\nvalues = [1.0, 2.0]",
        )
        .unwrap();
        assert_eq!(o.validate(&["X", "Y"], "f").unwrap(), vec![vec![1.0, 2.0]]);
        let e = o.validate(&["X", "Z"], "f").unwrap_err().to_string();
        assert!(e.contains("sweep.truth") && e.contains("\"Z\""), "{e}");
        let mut big = o.clone();
        big.realisations = 0;
        assert!(
            big.validate(&["Y"], "f")
                .unwrap_err()
                .to_string()
                .contains("sweep.realisations")
        );
        big.realisations = 10_000;
        big.axis[0].values = Some((0..200).map(f64::from).collect());
        let e = big.validate(&["Y"], "f").unwrap_err().to_string();
        assert!(e.contains("tasks"), "{e}");
        let mut three = o.clone();
        three.axis = vec![o.axis[0].clone(); 3];
        assert!(
            three
                .validate(&["Y"], "f")
                .unwrap_err()
                .to_string()
                .contains("one or two")
        );
        let mut twice = o.clone();
        twice.axis = vec![o.axis[0].clone(); 2];
        assert!(
            twice
                .validate(&["Y"], "f")
                .unwrap_err()
                .to_string()
                .contains("swept twice")
        );
    }
}
