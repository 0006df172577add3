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
///     title: "ln B(X/Y) against SNR",
///     x_label: "SNR",
///     y_label: "ln B(X/Y)",
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
/// bayes_factor_evolution(dir.path(), "bxy", &[("SNR 5".to_string(), run)], true, "B(X/Y)").unwrap();
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

/// Where a drawn line figure put its legend and its curves, in pixels of the whole canvas
/// (recorded by the last draw, so that a test can check that nothing hides a curve).
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct Geometry {
    /// The legend box `[(left, top), (right, bottom)]`; `None` without a legend.
    pub legend: Option<[(i32, i32); 2]>,
    /// The plotting area inside the axes, likewise.
    pub plot: [(i32, i32); 2],
    /// Every vertex of every drawn curve.
    pub curves: Vec<(i32, i32)>,
}

/// Height of one legend row.
const LEGEND_ROW: u32 = style::LEGEND_PX + 10;
/// Legend swatch width (line and marker).
const SWATCH_W: i32 = 30;
/// Space between legend entries in a row.
const ENTRY_GAP: u32 = 18;

/// Width of a legend entry (DejaVu Sans averages about 0.62 em per character).
fn entry_width(name: &str) -> u32 {
    SWATCH_W as u32
        + 8
        + (name.chars().count() as f64 * 0.62 * style::LEGEND_PX as f64).ceil() as u32
        + ENTRY_GAP
}

/// Greedy line breaking of the legend entries into rows at most `width` pixels wide.
fn legend_rows(names: &[&str], width: u32) -> Vec<Vec<usize>> {
    let mut rows: Vec<Vec<usize>> = Vec::new();
    let mut used = 0;
    for (i, n) in names.iter().enumerate() {
        let w = entry_width(n);
        match rows.last_mut() {
            Some(row) if used + w <= width => {
                row.push(i);
                used += w;
            }
            _ => {
                rows.push(vec![i]);
                used = w;
            }
        }
    }
    rows
}

pub(crate) struct LineFigure {
    title: String,
    x_title: String,
    y_title: String,
    x: Axis,
    y: Axis,
    series: Vec<Prepared>,
    /// Series indices per legend row, below the plot (empty: no legend). The legend lies
    /// outside the axes so that it can never cover a curve.
    legend_rows: Vec<Vec<usize>>,
    /// Horizontal reference line `(plotted y, label)`.
    reference: Option<(f64, &'static str)>,
    /// What the last draw put where.
    pub(crate) geometry: std::cell::RefCell<Geometry>,
}

impl LineFigure {
    pub(crate) fn new(
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
        let legend = series.len() > 1 || !series[0].0.is_empty();
        let names: Vec<&str> = series.iter().map(|(n, _)| n.as_str()).collect();
        Ok(LineFigure {
            title: plot.title.to_string(),
            x_title: plot.x_label.to_string(),
            y_title: plot.y_label.to_string(),
            legend_rows: if legend {
                legend_rows(&names, WIDTH - 40)
            } else {
                Vec::new()
            },
            geometry: Default::default(),
            reference: reference.and_then(|(r, label)| Some((y.to_plot(r)?, label))),
            x,
            y,
            series: prepared,
        })
    }
}

impl LineFigure {
    /// The figure without its legend (a panel whose legend another panel shows).
    pub(crate) fn without_legend(mut self) -> Self {
        self.legend_rows.clear();
        self
    }

    /// Height of the legend strip below the plot (0 without a legend).
    fn legend_h(&self) -> u32 {
        if self.legend_rows.is_empty() {
            0
        } else {
            LEGEND_ROW * self.legend_rows.len() as u32 + 8
        }
    }

    /// Draws the legend rows into `area` (the strip below the plot), each row centred; returns
    /// the box the entries occupy, in canvas pixels.
    fn draw_legend<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
    ) -> Result<[(i32, i32); 2], DrawingAreaErrorKind<DB::ErrorType>> {
        let (w, _) = area.dim_in_pixel();
        let (bx, by) = area.get_base_pixel();
        let (mut left, mut right) = (i32::MAX, i32::MIN);
        for (r, row) in self.legend_rows.iter().enumerate() {
            let total: i32 = row
                .iter()
                .map(|&i| entry_width(&self.series[i].name) as i32)
                .sum::<i32>()
                - ENTRY_GAP as i32;
            let mut x0 = ((w as i32 - total) / 2).max(4);
            let yc = (LEGEND_ROW * r as u32 + LEGEND_ROW / 2 + 4) as i32;
            left = left.min(x0);
            for &i in row {
                let s = &self.series[i];
                let c = colour(i);
                let (d, g) = dash(i).unwrap_or((1000, 1));
                area.draw(&DashedPathElement::new(
                    vec![(x0, yc), (x0 + SWATCH_W, yc)],
                    d,
                    g,
                    c.stroke_width(s.stroke),
                ))?;
                if s.markers {
                    let shape: Vec<(i32, i32)> = marker(i)
                        .into_iter()
                        .map(|(a, b)| (a + x0 + SWATCH_W / 2, b + yc))
                        .collect();
                    area.draw(&Polygon::new(shape, c.filled()))?;
                }
                let st = text(style::LEGEND_PX).pos(Pos::new(HPos::Left, VPos::Center));
                area.draw_text(&s.name, &st, (x0 + SWATCH_W + 8, yc))?;
                x0 += entry_width(&s.name) as i32;
            }
            right = right.max(x0 - ENTRY_GAP as i32);
        }
        Ok([(bx + left, by), (bx + right, by + self.legend_h() as i32)])
    }
}

impl Figure for LineFigure {
    fn size(&self) -> (u32, u32) {
        (WIDTH, HEIGHT + self.legend_h())
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        let area = if self.title.is_empty() {
            root.margin(15, 10, 10, 25)
        } else {
            let (title, style) = super::plots::fitted_title(root, &self.title);
            root.titled(&title, style)?.margin(5, 10, 10, 25)
        };
        let (_, h) = area.dim_in_pixel();
        let (area, legend_area) = area.split_vertically(h.saturating_sub(self.legend_h()));
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
        let mut curves = Vec::new();
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
                curves.extend(seg.iter().map(|p| ch.backend_coord(p)));
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
            // A point cut off by NaNs on both sides has no line, so it always gets a marker.
            let pts = s
                .segments
                .iter()
                .filter(|g| s.markers || g.len() == 1)
                .flatten()
                .copied();
            let shape = marker(i);
            ch.draw_series(
                pts.map(|p| EmptyElement::at(p) + Polygon::new(shape.clone(), c.filled())),
            )?;
        }
        let (xr, yr) = ch.plotting_area().get_pixel_range();
        let legend = if self.legend_rows.is_empty() {
            None
        } else {
            Some(self.draw_legend(&legend_area)?)
        };
        *self.geometry.borrow_mut() = Geometry {
            legend,
            plot: [(xr.start, yr.start), (xr.end, yr.end)],
            curves,
        };
        Ok(())
    }
}

/// Line figures stacked top to bottom on one canvas (Bode gain over phase, one time series
/// per channel), each keeping its own axes and legend.
pub(crate) struct Stack(pub Vec<LineFigure>);

impl Figure for Stack {
    fn size(&self) -> (u32, u32) {
        let h = self.0.iter().map(|f| f.size().1).sum();
        (WIDTH, h)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        let mut rest = root.clone();
        for f in &self.0 {
            let (top, below) = rest.split_vertically(f.size().1);
            f.draw(&top)?;
            rest = below;
        }
        Ok(())
    }
}
