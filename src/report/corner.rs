//! Corner plot: 1-D marginal histograms on the diagonal, 2-D histograms below it.

use super::ReportError;
use super::axis::Axis;
use super::plots::{
    DrawResult, Figure, MeshText, bad_input, chart, check_truth, colour, mesh, render, text,
};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

/// Writes `<dir>/<stem>.png` and `.svg`: for `n` parameters an `n × n` lower-triangular grid
/// with the marginal histogram of each parameter on the diagonal and the 2-D histogram of
/// every pair below it (darker = more samples), true values in red when `truth` is given.
///
/// `samples[s][p]` is parameter `p` of pooled sample `s`. Axes are shared down columns and
/// along rows and titled as in [`trace_plot`](super::trace_plot) (power of ten and, for tiny
/// spreads, a round offset). Non-finite values are left out of the histograms that use them.
/// Designed for up to about 10 parameters; beyond that the cells get small.
///
/// Errors ([`ReportError::InvalidInput`]): no names, no samples, a sample whose length is not
/// `names.len()`, or `truth` of the wrong length.
///
/// ```
/// use occam::report::corner_plot;
///
/// let dir = tempfile::tempdir().unwrap();
/// let names = vec!["a".to_string(), "b".to_string()];
/// let samples: Vec<Vec<f64>> = (0..500)
///     .map(|i| { let u = (i as f64 * 0.37).sin(); vec![u, 0.5 * u + (i as f64 * 1.1).cos()] })
///     .collect();
/// corner_plot(dir.path(), "corner", &names, &samples, Some(&[0.0, 0.0])).unwrap();
/// assert!(dir.path().join("corner.svg").exists());
/// ```
pub fn corner_plot(
    dir: &Path,
    stem: &str,
    names: &[String],
    samples: &[Vec<f64>],
    truth: Option<&[f64]>,
) -> Result<(), ReportError> {
    let fig = CornerFigure::new(dir, stem, names, samples, truth)?;
    render(dir, stem, &fig)
}

const TITLE_H: u32 = 34;
/// Room for tick labels and the rotated title of the left column.
const LEFT: u32 = 90;
/// Room for tick labels and the title of the bottom row.
const BOTTOM: u32 = 62;
const RIGHT: u32 = 20;
const TRUTH: RGBColor = RGBColor(214, 39, 40);

struct CornerFigure {
    title: String,
    names: Vec<String>,
    axes: Vec<Axis>,
    truth: Option<Vec<f64>>,
    /// Per parameter: counts in `bins1` equal bins over its axis range.
    marginals: Vec<Vec<f64>>,
    /// `pairs[i][j]` for `j < i`: row-major `bins2 × bins2` counts, x = parameter j.
    pairs: Vec<Vec<Vec<f64>>>,
    bins2: usize,
    cell: u32,
}

/// Index of the bin of width `(hi − lo)/n` holding `v`, if inside.
fn bin(v: f64, axis: &Axis, n: usize) -> Option<usize> {
    let u = (v - axis.lo) / (axis.hi - axis.lo);
    (0.0..1.0)
        .contains(&u)
        .then(|| ((u * n as f64) as usize).min(n - 1))
}

impl CornerFigure {
    fn new(
        dir: &Path,
        stem: &str,
        names: &[String],
        samples: &[Vec<f64>],
        truth: Option<&[f64]>,
    ) -> Result<Self, ReportError> {
        let np = names.len();
        if np == 0 {
            return Err(bad_input(
                dir,
                stem,
                "names",
                "is empty; give one name per parameter",
            ));
        }
        if samples.is_empty() {
            return Err(bad_input(dir, stem, "samples", "is empty; nothing to plot"));
        }
        if let Some(s) = samples.iter().position(|v| v.len() != np) {
            return Err(bad_input(
                dir,
                stem,
                format!("samples[{s}]"),
                format!(
                    "has {} values but names has {np}; give one value per parameter",
                    samples[s].len()
                ),
            ));
        }
        check_truth(dir, stem, truth, np)?;
        let n = samples.len() as f64;
        // About √N bins resolve a smooth marginal; the 2-D grid is coarser because its counts
        // are shared among bins² cells.
        let bins1 = (n.sqrt().round() as usize).clamp(10, 50);
        let bins2 = ((n.sqrt() / 3.0).round() as usize).clamp(10, if np > 5 { 24 } else { 32 });
        let cell = (1400 / np as u32).clamp(130, 260);
        let axes: Vec<Axis> = (0..np)
            .map(|p| {
                let t = truth.map(|t| t[p]).filter(|t| t.is_finite());
                let mut a = Axis::linear_for(samples.iter().map(|s| s[p]).chain(t), 4);
                // Half a tick label (~22 px) must fit between a tick and the cell edge.
                a.drop_edge_ticks(22.0 / cell as f64);
                a
            })
            .collect();
        let marginals = (0..np)
            .map(|p| {
                let mut h = vec![0.0; bins1];
                for s in samples {
                    if let Some(b) = bin(s[p], &axes[p], bins1) {
                        h[b] += 1.0;
                    }
                }
                h
            })
            .collect();
        let pairs = (0..np)
            .map(|i| {
                (0..i)
                    .map(|j| {
                        let mut h = vec![0.0; bins2 * bins2];
                        for s in samples {
                            if let (Some(bx), Some(by)) =
                                (bin(s[j], &axes[j], bins2), bin(s[i], &axes[i], bins2))
                            {
                                h[by * bins2 + bx] += 1.0;
                            }
                        }
                        h
                    })
                    .collect()
            })
            .collect();
        let mut title = format!("{} samples", samples.len());
        if truth.is_some() {
            title.push_str("; red: true value");
        }
        Ok(CornerFigure {
            title,
            names: names.to_vec(),
            axes,
            truth: truth.map(<[f64]>::to_vec),
            marginals,
            pairs,
            bins2,
            cell,
        })
    }

    fn truth(&self, p: usize) -> Option<f64> {
        self.truth.as_ref().map(|t| t[p]).filter(|t| t.is_finite())
    }

    fn draw_marginal<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
        p: usize,
        last_row: bool,
        first_col: bool,
    ) -> DrawResult<DB> {
        let h = &self.marginals[p];
        let peak = h.iter().copied().fold(0.0, f64::max).max(1.0);
        let mut y = Axis::linear(0.0, peak * 1.05, 3);
        y.lo = 0.0;
        y.ticks.clear();
        let x = &self.axes[p];
        let x_area = if last_row { BOTTOM } else { 0 };
        let y_area = if first_col { LEFT } else { 0 };
        let mut ch = chart(area, (x, &y), (x_area, y_area), None)?;
        let labels = MeshText {
            x_title: last_row.then(|| x.desc(&self.names[p])),
            y_title: None,
            x_labels: last_row,
            y_labels: false,
        };
        mesh(&mut ch, (x, &y), &labels, 12)?;
        let w = (x.hi - x.lo) / h.len() as f64;
        let fill = colour(0).mix(0.45).filled();
        let bars = h
            .iter()
            .enumerate()
            .filter(|(_, c)| **c > 0.0)
            .map(|(k, &c)| {
                let x0 = x.lo + k as f64 * w;
                Rectangle::new([(x0, 0.0), (x0 + w, c)], fill)
            });
        ch.draw_series(bars)?;
        // Outline as a step line so neighbouring bars of equal height read as one plateau.
        let step = h.iter().enumerate().flat_map(|(k, &c)| {
            let x0 = x.lo + k as f64 * w;
            [(x0, c), (x0 + w, c)]
        });
        ch.draw_series(LineSeries::new(step, colour(0).stroke_width(1)))?;
        if let Some(t) = self.truth(p) {
            ch.draw_series(LineSeries::new(
                [(t, 0.0), (t, y.hi)],
                TRUTH.stroke_width(2),
            ))?;
        }
        Ok(())
    }

    fn draw_pair<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
        (i, j): (usize, usize),
        last_row: bool,
        first_col: bool,
    ) -> DrawResult<DB> {
        let (x, y) = (&self.axes[j], &self.axes[i]);
        let x_area = if last_row { BOTTOM } else { 0 };
        let y_area = if first_col { LEFT } else { 0 };
        let mut ch = chart(area, (x, y), (x_area, y_area), None)?;
        let labels = MeshText {
            x_title: last_row.then(|| x.desc(&self.names[j])),
            y_title: first_col.then(|| y.desc(&self.names[i])),
            x_labels: last_row,
            y_labels: first_col,
        };
        mesh(&mut ch, (x, y), &labels, 12)?;
        let h = &self.pairs[i][j];
        let nb = self.bins2;
        let peak = h.iter().copied().fold(0.0, f64::max);
        let (wx, wy) = ((x.hi - x.lo) / nb as f64, (y.hi - y.lo) / nb as f64);
        let dark = colour(0);
        let cells = h
            .iter()
            .enumerate()
            .filter(|(_, c)| **c > 0.0)
            .map(|(k, &c)| {
                let (bx, by) = ((k % nb) as f64, (k / nb) as f64);
                // Even one sample must stay visible against white: shade from 15 % to 100 %.
                let a = 0.15 + 0.85 * c / peak;
                let mix = |d: u8| (255.0 - a * (255.0 - d as f64)).round() as u8;
                let shade = RGBColor(mix(dark.0), mix(dark.1), mix(dark.2));
                let (x0, y0) = (x.lo + bx * wx, y.lo + by * wy);
                Rectangle::new([(x0, y0), (x0 + wx, y0 + wy)], shade.filled())
            });
        ch.draw_series(cells)?;
        let (tx, ty) = (self.truth(j), self.truth(i));
        if let Some(t) = tx {
            ch.draw_series(LineSeries::new(
                [(t, y.lo), (t, y.hi)],
                TRUTH.stroke_width(1),
            ))?;
        }
        if let Some(t) = ty {
            ch.draw_series(LineSeries::new(
                [(x.lo, t), (x.hi, t)],
                TRUTH.stroke_width(1),
            ))?;
        }
        if let (Some(a), Some(b)) = (tx, ty) {
            ch.draw_series([Circle::new((a, b), 4, TRUTH.filled())])?;
        }
        Ok(())
    }
}

impl Figure for CornerFigure {
    fn size(&self) -> (u32, u32) {
        let n = self.axes.len() as u32;
        (
            LEFT + n * self.cell + RIGHT,
            TITLE_H + n * self.cell + BOTTOM,
        )
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        let n = self.axes.len();
        let area = root.titled(&self.title, text(16))?.margin(4, 0, 0, RIGHT);
        let xs: Vec<u32> = (1..n as u32).map(|k| LEFT + k * self.cell).collect();
        let ys: Vec<u32> = (1..n as u32).map(|k| k * self.cell).collect();
        let cells = area.split_by_breakpoints(xs, ys);
        for (k, cell) in cells.iter().enumerate() {
            let (i, j) = (k / n, k % n);
            let (last_row, first_col) = (i + 1 == n, j == 0);
            // A few pixels between cells keep neighbouring tick labels apart.
            let inner = cell.margin(3, 3, 3, 3);
            if i == j {
                self.draw_marginal(&inner, i, last_row, first_col)?;
            } else if j < i {
                self.draw_pair(&inner, (i, j), last_row, first_col)?;
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::report::axis::finite_range;

    #[test]
    fn binning_covers_the_axis_and_rejects_outside() {
        let a = Axis::linear(0.0, 1.0, 4);
        assert_eq!(bin(a.lo, &a, 10), Some(0));
        assert_eq!(bin(a.hi - 1e-12, &a, 10), Some(9));
        assert_eq!(bin(a.hi, &a, 10), None);
        assert_eq!(bin(f64::NAN, &a, 10), None);
        assert_eq!(finite_range([f64::NAN, 2.0, -1.0]), Some((-1.0, 2.0)));
    }
}
