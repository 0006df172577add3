//! Trace plots: every parameter against sample index, one line per chain.

use super::ReportError;
use super::axis::{Axis, decimate, segments};
use super::plots::{
    DrawResult, Figure, MeshText, bad_input, chart, check_truth, colour, mesh, render, text,
    y_label_area,
};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::path::Path;

/// Writes `<dir>/<stem>.png` and `.svg`: one panel per parameter (stacked, sharing the
/// sample-index axis), one coloured line per chain, and the true value as a dashed black line
/// when `truth` is given.
///
/// `chains[c][s][p]` is parameter `p` of sample `s` of chain `c`; chains may differ in length.
/// Each panel has its own vertical scale; its caption is the axis title, which factors out a
/// power of ten and, when the spread is tiny next to the value, subtracts a round offset:
/// `(ω₁² + 1.300×10⁻⁶) / 10⁻¹⁰` means the ticks show `(ω₁² + 1.3×10⁻⁶)×10¹⁰`. NaN values
/// leave a gap. Long chains are thinned for drawing to four points per pixel column (first,
/// lowest, highest, last), which keeps every excursion visible.
///
/// Errors ([`ReportError::InvalidInput`]): no names, no samples, a sample whose length is not
/// `names.len()`, or `truth` of the wrong length.
///
/// ```
/// use occam::report::trace_plot;
///
/// let dir = tempfile::tempdir().unwrap();
/// let names = vec!["ω₁² [s⁻²]".to_string(), "A_df".to_string()];
/// let chain: Vec<Vec<f64>> = (0..200)
///     .map(|i| vec![-1.3e-6 + 1e-10 * (i as f64 * 0.7).sin(), 0.8 + 0.01 * (i as f64).cos()])
///     .collect();
/// trace_plot(dir.path(), "trace", &names, &[chain], Some(&[-1.3e-6, 0.8])).unwrap();
/// assert!(dir.path().join("trace.png").exists());
/// ```
pub fn trace_plot(
    dir: &Path,
    stem: &str,
    names: &[String],
    chains: &[Vec<Vec<f64>>],
    truth: Option<&[f64]>,
) -> Result<(), ReportError> {
    let fig = TraceFigure::new(dir, stem, names, chains, truth)?;
    render(dir, stem, &fig)
}

const WIDTH: u32 = 1000;
const TITLE_H: u32 = 36;
const PANEL_H: u32 = 150;
const X_AREA: u32 = 45;

struct Panel {
    desc: String,
    y: Axis,
    /// Per chain, the drawable segments in (sample index, value).
    lines: Vec<Vec<Vec<(f64, f64)>>>,
    truth: Option<f64>,
    empty: bool,
}

struct TraceFigure {
    title: String,
    x: Axis,
    panels: Vec<Panel>,
    y_area: u32,
}

impl TraceFigure {
    fn new(
        dir: &Path,
        stem: &str,
        names: &[String],
        chains: &[Vec<Vec<f64>>],
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
        let longest = chains.iter().map(Vec::len).max().unwrap_or(0);
        if longest == 0 {
            return Err(bad_input(
                dir,
                stem,
                "chains",
                "holds no samples; nothing to plot",
            ));
        }
        for (c, chain) in chains.iter().enumerate() {
            if let Some(s) = chain.iter().position(|v| v.len() != np) {
                return Err(bad_input(
                    dir,
                    stem,
                    format!("chains[{c}][{s}]"),
                    format!(
                        "has {} values but names has {np}; give one value per parameter",
                        chain[s].len()
                    ),
                ));
            }
        }
        check_truth(dir, stem, truth, np)?;
        let x = Axis::linear(0.0, (longest - 1) as f64, 10);
        let buckets = WIDTH as usize - 120;
        let panels: Vec<Panel> = (0..np)
            .map(|p| {
                let t = truth.map(|t| t[p]).filter(|t| t.is_finite());
                let values = chains.iter().flatten().map(|s| s[p]);
                let y = Axis::linear_for(values.chain(t), 4);
                let lines = chains
                    .iter()
                    .map(|chain| {
                        let pts = chain
                            .iter()
                            .enumerate()
                            .map(|(i, s)| s[p].is_finite().then_some((i as f64, s[p])));
                        segments(pts)
                            .into_iter()
                            .map(|seg| decimate(&seg, (x.lo, x.hi), buckets))
                            .collect()
                    })
                    .collect::<Vec<Vec<_>>>();
                let empty = lines.iter().all(Vec::is_empty);
                Panel {
                    desc: y.desc(&names[p]),
                    y,
                    lines,
                    truth: t,
                    empty,
                }
            })
            .collect();
        let y_area = panels
            .iter()
            .map(|p| y_label_area(&p.y, false))
            .max()
            .unwrap_or(60);
        let samples = if chains.iter().all(|c| c.len() == longest) {
            format!("{longest} samples each")
        } else {
            format!("up to {longest} samples")
        };
        let n = chains.len();
        let mut title = format!("{n} chain{}, {samples}", if n == 1 { "" } else { "s" });
        if truth.is_some() {
            title.push_str("; dashed: true value");
        }
        Ok(TraceFigure {
            title,
            x,
            panels,
            y_area,
        })
    }
}

impl Figure for TraceFigure {
    fn size(&self) -> (u32, u32) {
        let n = self.panels.len() as u32;
        (WIDTH, TITLE_H + n * PANEL_H + X_AREA)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        let area = root.titled(&self.title, text(18))?.margin(0, 5, 10, 25);
        let n = self.panels.len();
        let breaks: Vec<u32> = (1..n as u32).map(|i| i * PANEL_H).collect();
        let rows = area.split_by_breakpoints([] as [u32; 0], breaks);
        for (i, (panel, row)) in self.panels.iter().zip(&rows).enumerate() {
            let last = i + 1 == n;
            let axes = (&self.x, &panel.y);
            let x_area = if last { X_AREA } else { 0 };
            let mut ch = chart(row, axes, (x_area, self.y_area), Some((&panel.desc, 15)))?;
            let labels = MeshText {
                x_title: last.then(|| self.x.desc("sample index")),
                y_title: None,
                x_labels: last,
                y_labels: true,
            };
            mesh(&mut ch, axes, &labels, 13)?;
            for (c, chain) in panel.lines.iter().enumerate() {
                let style = colour(c).mix(0.85).stroke_width(1);
                for seg in chain {
                    ch.draw_series(LineSeries::new(seg.iter().copied(), style))?;
                }
            }
            if let Some(t) = panel.truth {
                ch.draw_series(DashedLineSeries::new(
                    [(self.x.lo, t), (self.x.hi, t)],
                    10,
                    6,
                    BLACK.stroke_width(2),
                ))?;
            }
            if panel.empty {
                let mid = (
                    (self.x.lo + self.x.hi) / 2.0,
                    (panel.y.lo + panel.y.hi) / 2.0,
                );
                let style = text(15).pos(Pos::new(HPos::Center, VPos::Center));
                ch.draw_series([Text::new("no finite values", mid, style)])?;
            }
        }
        Ok(())
    }
}
