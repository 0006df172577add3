//! The evolution of the Bayes factor along a reversible-jump run (the paper's Fig. 2): every
//! jump-chain estimator of one pair of models, `ln B` against the iteration, each with its ±1σ
//! band.
//!
//! The drawing itself is [`super::band_plot`] (lines with markers, translucent bands in the
//! Okabe–Ito colours, Kass–Raftery zones, the legend above the plot, a series without values
//! listed as "(no values)"); this module turns running estimates into its series and names what
//! is missing.

use super::bands::{BandPlot, BandSeries, band_plot};
use super::error::ReportError;
use std::path::Path;

/// One estimator's running `ln B`: `(iteration, Some((ln B, σ)))`, `None` where it had no value
/// yet (σ NaN when it has no error).
#[derive(Debug, Clone, PartialEq)]
pub struct RunningSeries {
    /// Legend entry.
    pub name: String,
    /// The points, in any order.
    pub points: Vec<(f64, Option<(f64, f64)>)>,
}

impl RunningSeries {
    /// Whether any point has a finite `ln B`.
    pub fn has_value(&self) -> bool {
        self.points
            .iter()
            .any(|(_, v)| v.is_some_and(|(b, _)| b.is_finite()))
    }

    fn band(&self) -> BandSeries {
        let mut s = BandSeries {
            name: self.name.clone(),
            x: Vec::with_capacity(self.points.len()),
            median: Vec::with_capacity(self.points.len()),
            lo: Vec::with_capacity(self.points.len()),
            hi: Vec::with_capacity(self.points.len()),
        };
        for &(x, v) in &self.points {
            let (m, e) = match v {
                Some((m, e)) if m.is_finite() => (m, if e.is_finite() { e.abs() } else { 0.0 }),
                _ => (f64::NAN, f64::NAN),
            };
            s.x.push(x);
            s.median.push(m);
            s.lo.push(m - e);
            s.hi.push(m + e);
        }
        s
    }
}

/// Writes `<dir>/<stem>.png` and `.svg`: `ln B` of the pair `(x, y)` (ln B = ln Z_x − ln Z_y)
/// against the iteration, one line and ±1σ band per series, with the Kass–Raftery zones and a
/// line saying which sign favours which model. A series without any value stays in the
/// legend as "(no values)"; its name should say why (e.g. "visit ratio (Y never visited)").
///
/// Returns `Ok(false)` without writing anything when no series has a finite value (there is
/// nothing to draw; the caller reports it). Errors as [`band_plot`]'s.
///
/// ```
/// use occam::report::{RunningSeries, running_bayes_factor};
///
/// let dir = tempfile::tempdir().unwrap();
/// let rb = RunningSeries {
///     name: "Rao-Blackwell".into(),
///     points: (1..=20).map(|i| (1e3 * i as f64, Some((2.0 + 1.0 / i as f64, 0.5 / i as f64)))).collect(),
/// };
/// let visits = RunningSeries { name: "visit ratio (Y never visited)".into(), points: vec![(1e3, None)] };
/// assert!(running_bayes_factor(dir.path(), "bayes_factor", "ln B(X/Y)", ("X", "Y"), &[visits, rb]).unwrap());
/// assert!(dir.path().join("bayes_factor.svg").exists());
/// ```
pub fn running_bayes_factor(
    dir: &Path,
    stem: &str,
    title: &str,
    (x, y): (&str, &str),
    series: &[RunningSeries],
) -> Result<bool, ReportError> {
    if !series.iter().any(RunningSeries::has_value) {
        return Ok(false);
    }
    let bands: Vec<BandSeries> = series.iter().map(RunningSeries::band).collect();
    band_plot(
        dir,
        stem,
        &BandPlot {
            title,
            x_label: "iteration (all chains, burn-in included)",
            y_label: "ln B (±1σ)",
            series: &bands,
            log_x: false,
            zones: true,
            sign: Some((x, y)),
        },
    )?;
    Ok(true)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn series(name: &str, pts: Vec<(f64, Option<(f64, f64)>)>) -> RunningSeries {
        RunningSeries {
            name: name.into(),
            points: pts,
        }
    }

    #[test]
    fn nothing_finite_draws_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let s = [
            series("a", vec![(1.0, None), (2.0, Some((f64::NAN, 1.0)))]),
            series("b", vec![]),
        ];
        assert!(!running_bayes_factor(dir.path(), "bf", "t", ("a", "b"), &s).unwrap());
        assert!(std::fs::read_dir(dir.path()).unwrap().next().is_none());
    }

    #[test]
    fn a_missing_estimator_and_missing_errors_still_draw() {
        let dir = tempfile::tempdir().unwrap();
        let s = [
            series("visit ratio (Y never visited)", vec![(1.0, None)]),
            series(
                "bridge",
                vec![
                    (1.0, Some((1.0, f64::NAN))),
                    (2.0, Some((1.5, 0.2))),
                    (3.0, None),
                ],
            ),
        ];
        assert!(running_bayes_factor(dir.path(), "bf", "t", ("a", "b"), &s).unwrap());
        let svg = std::fs::read_to_string(dir.path().join("bf.svg")).unwrap();
        assert!(
            svg.contains("never visited"),
            "the legend names the absent curve"
        );
        assert!(
            svg.contains("ln B &gt; 0 favours X = a, ln B &lt; 0 favours Y = b")
                || svg.contains("ln B > 0 favours X = a, ln B < 0 favours Y = b"),
            "the sign convention is on the plot"
        );
        // a band of σ NaN is drawn as a point (zero width), not refused
        let b = s[1].band();
        assert_eq!((b.lo[0], b.hi[0]), (1.0, 1.0));
        assert!(b.median[2].is_nan());
    }
}
