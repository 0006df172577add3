//! Line plots: a generic one (ln B against SNR or injection frequency, PSDs) and the Bayes
//! factor against iteration (the paper's Fig. 2).

use super::axis::{Axis, decimate, segments};
use super::error::ReportError;
use super::plots::{
    DrawResult, Figure, MeshText, bad_input, chart, mesh, render, text, y_label_area,
};
use super::style::{self, colour, dash, marker};
use plotters::coord::Shift;
use plotters::element::DashedPathElement;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::path::Path;

/// A generic line plot. Build it with a struct literal and `..Default::default()`.
///
/// Points with a NaN or infinite coordinate (or ≤ 0 on a log axis) are skipped and break the
/// line there. Series with at most 60 points also get a marker at every point. Long series
/// are thinned to at most four points per pixel column (first, lowest, highest, last), which
/// draws the same picture.
///
/// ```
/// use occam::report::{LinePlot, line_plot};
///
/// let dir = tempfile::tempdir().unwrap();
/// let lnb = vec![("RJMCMC".to_string(), vec![(5.0, -1.2), (10.0, 0.4), (20.0, 6.1)])];
/// let err = vec![vec![0.3, 0.3, 0.5]];
/// line_plot(dir.path(), "lnb_vs_snr", &LinePlot {
///     title: "ln B_XY against SNR",
///     x_label: "SNR",
///     y_label: "ln B_XY",
///     series: &lnb,
///     y_err: Some(&err),
///     log_x: true,
///     ..Default::default()
/// }).unwrap();
/// assert!(dir.path().join("lnb_vs_snr.svg").exists());
/// ```
#[derive(Debug, Clone, Copy, Default)]
pub struct LinePlot<'a> {
    /// Title above the plot; empty for none.
    pub title: &'a str,
    /// Horizontal axis title.
    pub x_label: &'a str,
    /// Vertical axis title.
    pub y_label: &'a str,
    /// `(legend name, points)` per series; the legend is shown when there are several
    /// series or the single one has a non-empty name.
    pub series: &'a [(String, Vec<(f64, f64)>)],
    /// Optional one-sigma vertical error bars: one vector per series, one value per point
    /// (NaN for "no bar").
    pub y_err: Option<&'a [Vec<f64>]>,
    /// Logarithmic horizontal axis.
    pub log_x: bool,
    /// Logarithmic vertical axis.
    pub log_y: bool,
}

/// Writes `<dir>/<stem>.png` and `.svg` with the line plot `plot`.
///
/// Errors: no series, no drawable point at all, or `y_err` not matching the series shapes
/// or holding a negative value ([`ReportError::InvalidInput`]); file or rendering failures.
pub fn line_plot(dir: &Path, stem: &str, plot: &LinePlot<'_>) -> Result<(), ReportError> {
    let fig = LineFigure::new(dir, stem, plot, None)?;
    render(dir, stem, &fig)
}

/// Writes `<dir>/<stem>.png` and `.svg` with the Bayes factor against iteration, one line per
/// run or regime, like the paper's Fig. 2.
///
/// `series` holds `(name, [(iteration, value)])`; `value` is ln B or B as `y_label` says.
/// With `log_y` the values are B on a logarithmic axis (values ≤ 0 skipped) and a dashed line
/// marks B = 1, where neither model is preferred.
///
/// ```
/// use occam::report::bayes_factor_evolution;
///
/// let dir = tempfile::tempdir().unwrap();
/// let run: Vec<(f64, f64)> = (1..=50).map(|i| (100.0 * i as f64, 0.3 + 1.0 / i as f64)).collect();
/// bayes_factor_evolution(dir.path(), "bxy", &[("SNR 5".to_string(), run)], true, "B_XY").unwrap();
/// assert!(dir.path().join("bxy.png").exists());
/// ```
pub fn bayes_factor_evolution(
    dir: &Path,
    stem: &str,
    series: &[(String, Vec<(f64, f64)>)],
    log_y: bool,
    y_label: &str,
) -> Result<(), ReportError> {
    let plot = LinePlot {
        x_label: "iteration",
        y_label,
        series,
        log_y,
        ..Default::default()
    };
    let reference = log_y.then_some((1.0, "B = 1"));
    let fig = LineFigure::new(dir, stem, &plot, reference)?;
    render(dir, stem, &fig)
}

const WIDTH: u32 = style::COLUMN_PX;
const HEIGHT: u32 = 500;
/// Series up to this many points get point markers.
const MARKER_LIMIT: usize = 60;
/// Series up to this many points are drawn [`style::LINE_PX`] wide, longer ones a hairline.
const THICK_LIMIT: usize = 300;

struct Prepared {
    name: String,
    segments: Vec<Vec<(f64, f64)>>,
    /// `(x, low, centre, high)` in plotted coordinates.
    bars: Vec<(f64, f64, f64, f64)>,
    markers: bool,
    stroke: u32,
}

struct LineFigure {
    title: String,
    x_title: String,
    y_title: String,
    x: Axis,
    y: Axis,
    series: Vec<Prepared>,
    legend: bool,
    /// Horizontal reference line `(plotted y, label)`.
    reference: Option<(f64, &'static str)>,
}

impl LineFigure {
    fn new(
        dir: &Path,
        stem: &str,
        plot: &LinePlot<'_>,
        reference: Option<(f64, &'static str)>,
    ) -> Result<Self, ReportError> {
        let series = plot.series;
        if series.is_empty() {
            return Err(bad_input(
                dir,
                stem,
                "series",
                "is empty; give at least one (name, points) series",
            ));
        }
        if let Some(errs) = plot.y_err {
            if errs.len() != series.len() {
                return Err(bad_input(
                    dir,
                    stem,
                    "y_err",
                    format!(
                        "has {} vectors but there are {} series; give one per series",
                        errs.len(),
                        series.len()
                    ),
                ));
            }
            for (i, (e, (_, pts))) in errs.iter().zip(series).enumerate() {
                if e.len() != pts.len() {
                    return Err(bad_input(
                        dir,
                        stem,
                        format!("y_err[{i}]"),
                        format!(
                            "has {} values but series {i} has {} points; give one sigma per point",
                            e.len(),
                            pts.len()
                        ),
                    ));
                }
                if let Some(j) = e.iter().position(|s| *s < 0.0) {
                    return Err(bad_input(
                        dir,
                        stem,
                        format!("y_err[{i}][{j}]"),
                        format!("is {}; uncertainties must be ≥ 0 (NaN for none)", e[j]),
                    ));
                }
            }
        }

        // Ranges: data points plus finite error-bar ends (the low end only if it is drawable).
        let sigma = |i: usize, j: usize| plot.y_err.map_or(f64::NAN, |e| e[i][j]);
        let ok = |x: f64, y: f64| {
            x.is_finite() && y.is_finite() && (!plot.log_x || x > 0.0) && (!plot.log_y || y > 0.0)
        };
        let mut xs = Vec::new();
        let mut ys = Vec::new();
        for (i, (_, pts)) in series.iter().enumerate() {
            for (j, &(x, y)) in pts.iter().enumerate() {
                if ok(x, y) {
                    xs.push(x);
                    ys.push(y);
                    let s = sigma(i, j);
                    if s.is_finite() {
                        ys.push(y + s);
                        if !plot.log_y || y - s > 0.0 {
                            ys.push(y - s);
                        }
                    }
                }
            }
        }
        if xs.is_empty() {
            let why = if plot.log_x || plot.log_y {
                "has no drawable point (all non-finite, or ≤ 0 on a log axis); check the data"
            } else {
                "has no drawable point (all non-finite); check the data"
            };
            return Err(bad_input(dir, stem, "series", why));
        }
        let x = if plot.log_x {
            Axis::log10_for(xs, 8)
        } else {
            Axis::linear_for(xs, 8)
        };
        // The reference (B = 1) is always in view: it shows which model is ahead.
        ys.extend(reference.map(|r| r.0));
        let y = if plot.log_y {
            Axis::log10_for(ys, 7)
        } else {
            Axis::linear_for(ys, 7)
        };

        let plot_px = WIDTH as usize - 150;
        let prepared = series
            .iter()
            .enumerate()
            .map(|(i, (name, pts))| {
                let mapped = pts
                    .iter()
                    .map(|&(px, py)| Some((x.to_plot(px)?, y.to_plot(py)?)));
                let segments = segments(mapped)
                    .into_iter()
                    .map(|s| decimate(&s, (x.lo, x.hi), plot_px))
                    .collect();
                let bars = pts
                    .iter()
                    .enumerate()
                    .filter_map(|(j, &(px, py))| {
                        let s = sigma(i, j);
                        if !(s.is_finite() && ok(px, py)) {
                            return None;
                        }
                        let low = y.to_plot(py - s).unwrap_or(y.lo);
                        let high = y.to_plot(py + s)?;
                        Some((x.to_plot(px)?, low, y.to_plot(py)?, high))
                    })
                    .collect();
                Prepared {
                    name: name.clone(),
                    segments,
                    bars,
                    markers: pts.len() <= MARKER_LIMIT,
                    // Wide polylines get mitred joins without a limit in plotters' bitmap
                    // backend, so sharp spikes in dense noisy data would shoot past the axes.
                    stroke: if pts.len() <= THICK_LIMIT {
                        style::LINE_PX
                    } else {
                        style::HAIR_PX
                    },
                }
            })
            .collect();
        Ok(LineFigure {
            title: plot.title.to_string(),
            x_title: plot.x_label.to_string(),
            y_title: plot.y_label.to_string(),
            legend: series.len() > 1 || !series[0].0.is_empty(),
            reference: reference.and_then(|(r, label)| Some((y.to_plot(r)?, label))),
            x,
            y,
            series: prepared,
        })
    }

    /// The legend goes in the corner with the fewest points near it.
    fn legend_position(&self) -> SeriesLabelPosition {
        let fx = |v: f64| (v - self.x.lo) / (self.x.hi - self.x.lo);
        let fy = |v: f64| (v - self.y.lo) / (self.y.hi - self.y.lo);
        let mut counts = [0usize; 4]; // UR, UL, LR, LL
        for p in self.series.iter().flat_map(|s| s.segments.iter().flatten()) {
            let (u, v) = (fx(p.0), fy(p.1));
            let (right, left, top, bottom) = (u > 0.55, u < 0.45, v > 0.6, v < 0.4);
            counts[0] += (right && top) as usize;
            counts[1] += (left && top) as usize;
            counts[2] += (right && bottom) as usize;
            counts[3] += (left && bottom) as usize;
        }
        match (0..4).min_by_key(|&i| counts[i]) {
            Some(1) => SeriesLabelPosition::UpperLeft,
            Some(2) => SeriesLabelPosition::LowerRight,
            Some(3) => SeriesLabelPosition::LowerLeft,
            _ => SeriesLabelPosition::UpperRight,
        }
    }
}

impl Figure for LineFigure {
    fn size(&self) -> (u32, u32) {
        (WIDTH, HEIGHT)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        let area = if self.title.is_empty() {
            root.margin(15, 10, 10, 25)
        } else {
            root.titled(&self.title, text(style::TITLE_PX))?
                .margin(5, 10, 10, 25)
        };
        let axes = (&self.x, &self.y);
        let mut ch = chart(
            &area,
            axes,
            (
                style::TICK_PX + style::LABEL_PX + 24,
                y_label_area(&self.y, true),
            ),
            None,
        )?;
        let labels = MeshText {
            x_title: Some(self.x.desc(&self.x_title)),
            y_title: Some(self.y.desc(&self.y_title)),
            x_labels: true,
            y_labels: true,
        };
        mesh(&mut ch, axes, &labels, style::TICK_PX)?;
        if let Some((r, label)) = self.reference {
            let grey = style::REFERENCE;
            ch.draw_series(DashedLineSeries::new(
                [(self.x.lo, r), (self.x.hi, r)],
                8,
                5,
                grey.stroke_width(style::HAIR_PX),
            ))?;
            let st = text(style::NOTE_PX)
                .color(&grey)
                .pos(Pos::new(HPos::Left, VPos::Bottom));
            let at = self.x.lo + 0.01 * (self.x.hi - self.x.lo);
            ch.draw_series([Text::new(label, (at, r), st)])?;
        }
        for (i, s) in self.series.iter().enumerate() {
            let c = colour(i);
            for &(x, lo, mid, hi) in &s.bars {
                ch.draw_series([ErrorBar::new_vertical(
                    x,
                    lo,
                    mid,
                    hi,
                    c.stroke_width(style::HAIR_PX),
                    8,
                )])?;
            }
            for seg in &s.segments {
                match dash(i) {
                    None => {
                        ch.draw_series(LineSeries::new(
                            seg.iter().copied(),
                            c.stroke_width(s.stroke),
                        ))?;
                    }
                    Some((d, g)) => {
                        ch.draw_series(DashedLineSeries::new(
                            seg.iter().copied(),
                            d,
                            g,
                            c.stroke_width(s.stroke),
                        ))?;
                    }
                }
            }
            // A point cut off by NaNs on both sides has no line, so it always gets a marker;
            // the legend entry hangs on this (possibly empty) series.
            let pts = s
                .segments
                .iter()
                .filter(|g| s.markers || g.len() == 1)
                .flatten()
                .copied();
            let shape = marker(i);
            let a = ch.draw_series(
                pts.map(|p| EmptyElement::at(p) + Polygon::new(shape.clone(), c.filled())),
            )?;
            if self.legend {
                let w = s.stroke;
                let with_marker = s.markers;
                // One element type for every series: a solid line is a dash longer than the
                // swatch, and a series without markers gets an invisible one.
                a.label(s.name.clone()).legend(move |(x, y)| {
                    let (d, g) = dash(i).unwrap_or((1000, 1));
                    let alpha = if with_marker { 1.0 } else { 0.0 };
                    let shape: Vec<(i32, i32)> =
                        marker(i).into_iter().map(|(a, b)| (a + 9, b)).collect();
                    EmptyElement::at((x, y))
                        + DashedPathElement::new(vec![(-4, 0), (22, 0)], d, g, c.stroke_width(w))
                        + Polygon::new(shape, c.mix(alpha).filled())
                });
            }
        }
        if self.legend {
            ch.configure_series_labels()
                .position(self.legend_position())
                .label_font(text(style::LEGEND_PX))
                .background_style(style::BACKGROUND.mix(0.85))
                .border_style(style::FRAME)
                .draw()?;
        }
        Ok(())
    }
}
