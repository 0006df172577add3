//! Sweep plots: the median of a quantity (usually ln B) with its 16–84 % band against a study
//! key, over the Kass–Raftery evidence zones (the paper's Figs. 5 and 6), and a coloured map
//! for sweeps over two keys.
//!
//! Both figures are drawn for reading at column width: large type, thick lines, and series
//! told apart by colour (Okabe–Ito), marker shape and dash pattern, so they survive
//! grey-scale printing and colour-vision deficiencies.

use super::axis::Axis;
use super::error::ReportError;
use super::plots::{DrawResult, Figure, MeshText, Ticked, bad_input, chart, mesh, render};
use super::style::{self, ZONES, colour, dash, marker as marker_shape};
use crate::numfmt::format::fmt_sig;
use plotters::coord::Shift;
use plotters::element::DashedPathElement;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::path::Path;

/// One estimator's results along a sweep: at each grid point `x[j]`, the median over noise
/// realisations and the 16 % and 84 % quantiles.
///
/// NaN (or an infinite value) means "no number here", e.g. an estimator that failed in every
/// realisation at that point: the line and band break there rather than bridging the gap.
/// A point with a median but no band (NaN `lo`/`hi`) keeps its marker.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct BandSeries {
    /// Legend entry (the estimator's name).
    pub name: String,
    /// Grid coordinate of each point (any order; drawn sorted).
    pub x: Vec<f64>,
    /// Median over realisations, one per point.
    pub median: Vec<f64>,
    /// Lower edge of the band (16 % quantile), one per point.
    pub lo: Vec<f64>,
    /// Upper edge of the band (84 % quantile), one per point.
    pub hi: Vec<f64>,
}

/// A band plot. Build it with a struct literal and `..Default::default()`.
#[derive(Debug, Clone, Copy, Default)]
pub struct BandPlot<'a> {
    /// Title above the plot; empty for none.
    pub title: &'a str,
    /// Horizontal axis title (the study key, with its unit).
    pub x_label: &'a str,
    /// Vertical axis title.
    pub y_label: &'a str,
    /// One entry per estimator.
    pub series: &'a [BandSeries],
    /// Logarithmic horizontal axis (points at x ≤ 0 are then skipped).
    pub log_x: bool,
    /// The vertical axis is ln B: shade the Kass–Raftery zones and draw the line ln B = 0.
    pub zones: bool,
    /// The pair `(X, Y)` whose ln B = ln (Z_X / Z_Y) the vertical axis shows: a line under the
    /// title says which sign favours which model.
    pub sign: Option<(&'a str, &'a str)>,
}

/// The sign convention of ln B of the pair `(x, y)`, as the plots print it.
pub fn sign_note(x: &str, y: &str) -> String {
    format!("ln B > 0 favours X = {x}, ln B < 0 favours Y = {y}")
}

/// Writes `<dir>/<stem>.png` and `.svg`: per series the median as a line with markers and the
/// 16–84 % band as a translucent fill of the same colour.
///
/// With `zones`, grey shades mark the Kass & Raftery (1995) grades of |ln B| (their
/// thresholds 2 ln B = 2, 6, 10): below 1 "bare mention" (not worth more than one), 1–3
/// "positive", 3–5 "strong", above 5 "very strong", symmetric about the line ln B = 0, so a
/// reader sees at a glance where each estimator's verdict changes grade. The zones lie under
/// the data; a zone label is printed only where the zone is tall enough to hold it. The
/// vertical range covers every finite median and band edge, and also ln B = 0 unless that
/// would squeeze the data into under a third of the height.
///
/// Series are told apart by colour (Okabe–Ito), marker shape and dash pattern. The legend sits
/// above the plot, so it never hides data; a series with nothing to draw is listed as
/// "(no values)" rather than silently left out.
///
/// Errors ([`ReportError::InvalidInput`], naming the field): no series; `median`, `lo` or `hi`
/// not one per `x`; a non-finite `x`; `lo > hi`; a median outside its band; nothing drawable
/// at all (every value NaN, or every `x ≤ 0` on a log axis). File and rendering failures are
/// reported too.
///
/// ```
/// use occam::report::{BandPlot, BandSeries, band_plot};
///
/// let dir = tempfile::tempdir().unwrap();
/// let snr = vec![5.0, 10.0, 20.0, 40.0];
/// let rj = BandSeries {
///     name: "RJMCMC".into(),
///     x: snr.clone(),
///     median: vec![-0.4, 1.8, 7.5, 31.0],
///     lo: vec![-1.3, 0.6, 5.9, 28.2],
///     hi: vec![0.7, 3.1, 9.4, 34.5],
/// };
/// // The Laplace approximation failed in every realisation at SNR 10.
/// let laplace = BandSeries {
///     name: "Laplace".into(),
///     x: snr,
///     median: vec![-0.1, f64::NAN, 8.1, 32.2],
///     lo: vec![-0.9, f64::NAN, 6.0, 29.0],
///     hi: vec![0.8, f64::NAN, 9.9, 35.1],
/// };
/// let series = [rj, laplace];
/// band_plot(dir.path(), "lnb_vs_snr", &BandPlot {
///     title: "ln B(X/Y) against SNR",
///     x_label: "SNR",
///     y_label: "ln B(X/Y)",
///     series: &series,
///     log_x: true,
///     zones: true,
///     sign: Some(("ltp", "ltp_pole")),
/// }).unwrap();
/// assert!(dir.path().join("lnb_vs_snr.png").exists());
/// assert!(dir.path().join("lnb_vs_snr.svg").exists());
/// ```
pub fn band_plot(dir: &Path, stem: &str, plot: &BandPlot<'_>) -> Result<(), ReportError> {
    let fig = BandFigure::new(dir, stem, plot)?;
    render(dir, stem, &fig)
}

/// A map of a quantity over a 2-D sweep grid. Build it with a struct literal and
/// `..Default::default()`.
#[derive(Debug, Clone, Copy, Default)]
pub struct HeatMap<'a> {
    /// Title above the map; empty for none.
    pub title: &'a str,
    /// Horizontal axis title.
    pub x_label: &'a str,
    /// Vertical axis title.
    pub y_label: &'a str,
    /// Grid coordinates along the horizontal axis (any order, distinct, finite).
    pub x: &'a [f64],
    /// Grid coordinates along the vertical axis (any order, distinct, finite).
    pub y: &'a [f64],
    /// Values, `z[iy][ix]` at `(x[ix], y[iy])`; NaN (or infinite) for "no value".
    pub z: &'a [Vec<f64>],
    /// Title of the colour bar.
    pub z_label: &'a str,
    /// Logarithmic horizontal axis (columns at x ≤ 0 are then skipped).
    pub log_x: bool,
    /// Logarithmic vertical axis (rows at y ≤ 0 are then skipped).
    pub log_y: bool,
    /// Colour by sign about zero (for ln B): see [`heat_map`].
    pub diverging: bool,
}

/// Writes `<dir>/<stem>.png` and `.svg`: one cell per grid point, coloured by `z`, with a
/// colour bar.
///
/// Cells meet halfway between neighbouring grid points (geometric midpoints on a log axis), so
/// an uneven grid is drawn as it was sampled; the outer cells are as wide as their inner half.
/// Cells without a value are grey with a cross and listed as "no value" under the colour bar.
///
/// Sequential maps (`diverging = false`) use viridis from the smallest to the largest value.
/// Diverging maps use ColorBrewer's red–blue (both colour-blind safe): white at 0, blue for
/// positive values (ln B_XY > 0 favours X), red for negative ones, equal |z| equally deep on
/// both sides. Because ln B across a sweep often runs from about −3 to several hundred, the
/// colour follows sign(z)·ln(1 + |z|): nearly linear for |z| ≲ 1, logarithmic beyond, so the
/// weakly decided region stays visible next to the decisive one. The colour bar is labelled
/// in z itself.
///
/// Errors ([`ReportError::InvalidInput`], naming the field): empty `x` or `y`; a non-finite or
/// repeated grid coordinate; `z` not `y.len()` rows of `x.len()` values; no positive
/// coordinate on a log axis; no finite value in the cells drawn.
///
/// ```
/// use occam::report::{HeatMap, heat_map};
///
/// let dir = tempfile::tempdir().unwrap();
/// let snr = [5.0, 10.0, 20.0, 40.0];
/// let f = [1e-3, 3e-3, 1e-2];
/// let z: Vec<Vec<f64>> = f.iter().map(|fi| snr.iter().map(|s| 0.02 * s * s - 200.0 * fi).collect()).collect();
/// heat_map(dir.path(), "lnb_map", &HeatMap {
///     x_label: "SNR", y_label: "injection frequency [Hz]", z_label: "ln B_XY",
///     x: &snr, y: &f, z: &z, log_x: true, log_y: true, diverging: true,
///     ..Default::default()
/// }).unwrap();
/// assert!(dir.path().join("lnb_map.png").exists());
/// ```
pub fn heat_map(dir: &Path, stem: &str, map: &HeatMap<'_>) -> Result<(), ReportError> {
    let fig = MapFigure::new(dir, stem, map)?;
    render(dir, stem, &fig)
}

// ---------------------------------------------------------------------------------------------
// Shared style

/// Type sizes (px) from the common style: a [`style::COLUMN_PX`] figure scaled to a 3.4 in
/// column prints every text at 8 pt or more.
const DESC_PX: u32 = style::LABEL_PX;
const TICK_PX: u32 = style::TICK_PX;
const LEGEND_PX: u32 = style::LEGEND_PX;
const NOTE_PX: u32 = style::NOTE_PX;
/// Median line width (px).
const LINE_W: u32 = style::THIN_PX;

fn font(size: u32) -> TextStyle<'static> {
    super::plots::text(size)
}

/// Width estimate of `s` in DejaVu Sans at `size` px (digits and lower case average about
/// 0.6 em; 0.62 leaves a little room), for laying out before a backend exists.
fn text_width(s: &str, size: u32) -> u32 {
    (s.chars().count() as f64 * 0.62 * size as f64).ceil() as u32
}

/// Room for a vertical axis: its longest tick label plus the rotated title.
fn y_area(labels: impl IntoIterator<Item = String>) -> u32 {
    let widest = labels
        .into_iter()
        .map(|l| text_width(&l, TICK_PX))
        .max()
        .unwrap_or(10);
    widest + 16 + DESC_PX + 12
}

/// Splits a sequence at the `None`s into runs of consecutive values.
fn runs<T>(items: impl IntoIterator<Item = Option<T>>) -> Vec<Vec<T>> {
    let mut out: Vec<Vec<T>> = vec![Vec::new()];
    for item in items {
        match item {
            Some(v) => out.last_mut().expect("never empty").push(v),
            None if !out.last().expect("never empty").is_empty() => out.push(Vec::new()),
            None => {}
        }
    }
    out.retain(|r| !r.is_empty());
    out
}

fn finite(v: f64) -> Option<f64> {
    v.is_finite().then_some(v)
}

// ---------------------------------------------------------------------------------------------
// Band plot

const BAND_W: u32 = style::COLUMN_PX;
const BAND_H: u32 = 540;
const LEGEND_ROW: u32 = LEGEND_PX + 10;
/// Legend swatch: band patch with the line pattern and marker across it.
const SWATCH_W: u32 = 36;
/// Space between legend entries.
const ENTRY_GAP: u32 = 18;

struct PreparedBand {
    name: String,
    /// Median polylines, split at missing values (plotted coordinates).
    lines: Vec<Vec<(f64, f64)>>,
    /// Every finite median.
    markers: Vec<(f64, f64)>,
    /// Runs of consecutive `(x, lo, hi)` with a finite band; one-point runs become bars.
    bands: Vec<Vec<(f64, f64, f64)>>,
}

/// A shaded zone clipped to the axis: `[lo, hi]` in ln B and its label.
#[derive(Debug, Clone, PartialEq)]
struct Zone {
    lo: f64,
    hi: f64,
    label: &'static str,
    shade: RGBColor,
}

struct BandFigure {
    title: String,
    x_title: String,
    y_title: String,
    x: Axis,
    y: Axis,
    series: Vec<PreparedBand>,
    /// Visible zones (empty without `zones`).
    zones: Vec<Zone>,
    /// Draw the ln B = 0 line.
    zero_line: bool,
    /// Series indices per legend row.
    legend_rows: Vec<Vec<usize>>,
    /// The sign convention line ([`sign_note`]), when the plot has a pair.
    sign: Option<String>,
}

/// The zones of [`ZONES`] that intersect `[lo, hi]`, clipped to it.
fn visible_zones(lo: f64, hi: f64) -> Vec<Zone> {
    let mut out = Vec::new();
    let mut inner = 0.0;
    for &(outer, label, shade) in &ZONES {
        let parts: &[(f64, f64)] = if inner == 0.0 {
            &[(-outer, outer)]
        } else {
            &[(inner, outer), (-outer, -inner)]
        };
        for &(a, b) in parts {
            let (a, b) = (a.max(lo), b.min(hi));
            if a < b {
                out.push(Zone {
                    lo: a,
                    hi: b,
                    label,
                    shade,
                });
            }
        }
        inner = outer;
    }
    out
}

impl BandFigure {
    fn new(dir: &Path, stem: &str, plot: &BandPlot<'_>) -> Result<Self, ReportError> {
        let series = plot.series;
        if series.is_empty() {
            return Err(bad_input(
                dir,
                stem,
                "series",
                "is empty; give at least one BandSeries",
            ));
        }
        for (i, s) in series.iter().enumerate() {
            let n = s.x.len();
            for (field, v) in [("median", &s.median), ("lo", &s.lo), ("hi", &s.hi)] {
                if v.len() != n {
                    return Err(bad_input(
                        dir,
                        stem,
                        format!("series[{i}].{field}"),
                        format!(
                            "has {} values but x has {n}; give one per grid point (NaN where \
                             there is none)",
                            v.len()
                        ),
                    ));
                }
            }
            for j in 0..n {
                let (x, m, l, h) = (s.x[j], s.median[j], s.lo[j], s.hi[j]);
                if !x.is_finite() {
                    return Err(bad_input(
                        dir,
                        stem,
                        format!("series[{i}].x[{j}]"),
                        format!("is {x}; grid coordinates must be finite"),
                    ));
                }
                if l.is_finite() && h.is_finite() && l > h {
                    return Err(bad_input(
                        dir,
                        stem,
                        format!("series[{i}].lo[{j}]"),
                        format!("is {l}, above hi = {h}; the band needs lo ≤ hi"),
                    ));
                }
                if m.is_finite() && ((l.is_finite() && m < l) || (h.is_finite() && m > h)) {
                    return Err(bad_input(
                        dir,
                        stem,
                        format!("series[{i}].median[{j}]"),
                        format!(
                            "is {m}, outside its band [{l}, {h}]; check that median, lo and \
                             hi are not swapped"
                        ),
                    ));
                }
            }
        }

        let on_axis = |x: f64| !plot.log_x || x > 0.0;
        let xs: Vec<f64> = series
            .iter()
            .flat_map(|s| s.x.iter().copied())
            .filter(|&x| on_axis(x))
            .collect();
        let ys: Vec<f64> = series
            .iter()
            .flat_map(|s| {
                (0..s.x.len())
                    .filter(|&j| on_axis(s.x[j]))
                    .flat_map(|j| [s.median[j], s.lo[j], s.hi[j]])
            })
            .filter(|v| v.is_finite())
            .collect();
        if ys.is_empty() {
            let why = if plot.log_x {
                "has no drawable point: every median, lo and hi is NaN or infinite, or sits at \
                 x ≤ 0 on the log axis; check the sweep results"
            } else {
                "has no drawable point: every median, lo and hi is NaN or infinite; check the \
                 sweep results"
            };
            return Err(bad_input(dir, stem, "series", why));
        }
        let x = if plot.log_x {
            Axis::log10_for(xs, 7)
        } else {
            Axis::linear_for(xs, 7)
        };
        let (dmin, dmax) = super::axis::finite_range(ys.iter().copied()).expect("ys non-empty");
        let (zmin, zmax) = (dmin.min(0.0), dmax.max(0.0));
        // ln B = 0 is where the verdict flips, so keep it in view, unless the data sit far
        // from it with little spread (ln B ≈ 10⁴ ± 10), when it would flatten them.
        let with_zero = plot.zones && (dmax == dmin || dmax - dmin >= (zmax - zmin) / 3.0);
        let y = if with_zero {
            Axis::linear(zmin, zmax, 7)
        } else {
            Axis::linear(dmin, dmax, 7)
        };

        let prepared: Vec<PreparedBand> = series
            .iter()
            .map(|s| {
                let mut order: Vec<usize> = (0..s.x.len()).collect();
                order.sort_by(|&a, &b| s.x[a].total_cmp(&s.x[b]));
                let lines = runs(
                    order
                        .iter()
                        .map(|&j| Some((x.to_plot(s.x[j])?, finite(s.median[j])?))),
                );
                let bands = runs(
                    order
                        .iter()
                        .map(|&j| Some((x.to_plot(s.x[j])?, finite(s.lo[j])?, finite(s.hi[j])?))),
                );
                let empty = lines.is_empty() && bands.is_empty();
                PreparedBand {
                    name: if empty {
                        format!("{} (no values)", s.name)
                    } else {
                        s.name.clone()
                    },
                    markers: lines.iter().flatten().copied().collect(),
                    lines,
                    bands,
                }
            })
            .collect();

        let zones = if plot.zones {
            visible_zones(y.lo, y.hi)
        } else {
            Vec::new()
        };
        let legend_rows = legend_rows(&prepared, BAND_W - 16);
        Ok(BandFigure {
            title: plot.title.to_string(),
            x_title: plot.x_label.to_string(),
            y_title: plot.y_label.to_string(),
            zero_line: plot.zones && y.lo < 0.0 && y.hi > 0.0,
            x,
            y,
            series: prepared,
            zones,
            legend_rows,
            sign: plot.sign.map(|(x, y)| sign_note(x, y)),
        })
    }
}

/// Width of a legend entry: swatch, gap, name, gap to the next entry. Names are mostly lower
/// case, about 0.5 em per character in DejaVu Sans (measured: "Thermodynamic integration" is
/// 272 px at 23 px), so 0.52 em packs the rows without overflowing them; the drawing itself
/// measures each name.
fn legend_entry_width(name: &str) -> u32 {
    let text = (name.chars().count() as f64 * 0.52 * LEGEND_PX as f64).ceil() as u32;
    SWATCH_W + 8 + text + ENTRY_GAP
}

/// Greedy line breaking of the legend entries into rows at most `width` pixels wide.
fn legend_rows(series: &[PreparedBand], width: u32) -> Vec<Vec<usize>> {
    let mut rows: Vec<Vec<usize>> = vec![Vec::new()];
    let mut used = 0;
    for (i, s) in series.iter().enumerate() {
        let w = legend_entry_width(&s.name);
        let row = rows.last_mut().expect("never empty");
        if !row.is_empty() && used + w > width {
            rows.push(vec![i]);
            used = w;
        } else {
            row.push(i);
            used += w;
        }
    }
    rows
}

/// Draws the swatch of series `i` centred vertically at `(x0, yc)` (pixels of `area`).
fn swatch<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    i: usize,
    (x0, yc): (i32, i32),
) -> DrawResult<DB> {
    let c = colour(i);
    let w = SWATCH_W as i32;
    area.draw(&Rectangle::new(
        [(x0, yc - 8), (x0 + w, yc + 8)],
        c.mix(0.22).filled(),
    ))?;
    let line = [(x0, yc), (x0 + w, yc)];
    match dash(i) {
        None => area.draw(&PathElement::new(line, c.stroke_width(LINE_W)))?,
        Some((d, g)) => area.draw(&DashedPathElement::new(line, d, g, c.stroke_width(LINE_W)))?,
    }
    area.draw(&(EmptyElement::at((x0 + w / 2, yc)) + Polygon::new(marker_shape(i), c.filled())))
}

impl Figure for BandFigure {
    fn size(&self) -> (u32, u32) {
        let extra_rows = self.legend_rows.len() as u32 - 1 + u32::from(self.sign.is_some());
        (BAND_W, BAND_H + LEGEND_ROW * extra_rows)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        let area = if self.title.is_empty() {
            root.margin(8, 0, 0, 0)
        } else {
            let (title, style) = super::plots::fitted_title(root, &self.title);
            root.titled(&title, style)?
        };
        let area = match &self.sign {
            Some(note) => {
                let (line, rest) = area.split_vertically(LEGEND_ROW);
                let (w, _) = line.dim_in_pixel();
                let st = font(NOTE_PX).pos(Pos::new(HPos::Center, VPos::Center));
                line.draw_text(note, &st, (w as i32 / 2, LEGEND_ROW as i32 / 2))?;
                rest
            }
            None => area,
        };

        // Legend rows above the plot, each centred.
        let legend_h = LEGEND_ROW * self.legend_rows.len() as u32 + 6;
        let (legend, rest) = area.split_vertically(legend_h);
        for (r, row) in self.legend_rows.iter().enumerate() {
            let widths: Vec<i32> = row
                .iter()
                .map(|&i| {
                    let (tw, _) = legend
                        .estimate_text_size(&self.series[i].name, &font(LEGEND_PX))
                        .unwrap_or((text_width(&self.series[i].name, LEGEND_PX), 0));
                    (SWATCH_W + 8 + tw + ENTRY_GAP) as i32
                })
                .collect();
            let total: i32 = widths.iter().sum::<i32>() - ENTRY_GAP as i32;
            let (lw, _) = legend.dim_in_pixel();
            let mut x0 = ((lw as i32 - total) / 2).max(4);
            let yc = (LEGEND_ROW * r as u32 + LEGEND_ROW / 2 + 2) as i32;
            for (&i, w) in row.iter().zip(&widths) {
                swatch(&legend, i, (x0, yc))?;
                let style = font(LEGEND_PX).pos(Pos::new(HPos::Left, VPos::Center));
                legend.draw_text(&self.series[i].name, &style, (x0 + SWATCH_W as i32 + 8, yc))?;
                x0 += w;
            }
        }

        let plot_area = rest.margin(4, 8, 10, 24);
        let axes = (&self.x, &self.y);
        let y_labels = y_area(self.y.ticks.iter().map(|&t| self.y.label(t)));
        let mut ch = chart(&plot_area, axes, (TICK_PX + DESC_PX + 24, y_labels), None)?;

        // Zones go first so the grid and data lie on top.
        ch.draw_series(
            self.zones
                .iter()
                .map(|z| Rectangle::new([(self.x.lo, z.lo), (self.x.hi, z.hi)], z.shade.filled())),
        )?;
        let labels = MeshText {
            x_title: Some(self.x.desc(&self.x_title)),
            y_title: Some(self.y.desc(&self.y_title)),
            x_labels: true,
            y_labels: true,
        };
        mesh(&mut ch, axes, &labels, TICK_PX)?;
        if self.zero_line {
            ch.draw_series([PathElement::new(
                [(self.x.lo, 0.0), (self.x.hi, 0.0)],
                style::REFERENCE.stroke_width(style::HAIR_PX),
            )])?;
        }
        self.draw_zone_labels(&ch, root)?;

        // All bands before any line, so no band veils another series' median.
        for (i, s) in self.series.iter().enumerate() {
            let c = colour(i);
            for run in &s.bands {
                if run.len() == 1 {
                    let (x, lo, hi) = run[0];
                    ch.draw_series([ErrorBar::new_vertical(
                        x,
                        lo,
                        lo,
                        hi,
                        c.mix(0.6).stroke_width(2),
                        14,
                    )])?;
                    continue;
                }
                let outline: Vec<(f64, f64)> = run
                    .iter()
                    .map(|p| (p.0, p.2))
                    .chain(run.iter().rev().map(|p| (p.0, p.1)))
                    .collect();
                ch.draw_series([Polygon::new(outline, c.mix(0.2).filled())])?;
                for edge in [
                    run.iter().map(|p| (p.0, p.1)).collect::<Vec<_>>(),
                    run.iter().map(|p| (p.0, p.2)).collect(),
                ] {
                    ch.draw_series([PathElement::new(edge, c.mix(0.45).stroke_width(1))])?;
                }
            }
        }
        for (i, s) in self.series.iter().enumerate() {
            let c = colour(i);
            for seg in &s.lines {
                match dash(i) {
                    None => {
                        ch.draw_series(LineSeries::new(
                            seg.iter().copied(),
                            c.stroke_width(LINE_W),
                        ))?;
                    }
                    Some((d, g)) => {
                        ch.draw_series(DashedLineSeries::new(
                            seg.iter().copied(),
                            d,
                            g,
                            c.stroke_width(LINE_W),
                        ))?;
                    }
                }
            }
            let shape = marker_shape(i);
            ch.draw_series(
                s.markers
                    .iter()
                    .map(|&p| EmptyElement::at(p) + Polygon::new(shape.clone(), c.filled())),
            )?;
        }
        Ok(())
    }
}

impl BandFigure {
    /// Prints each zone's grade inside the plot at the left or right edge, whichever has less
    /// data near the label, if the zone is tall enough for the text.
    fn draw_zone_labels<DB: DrawingBackend>(
        &self,
        ch: &ChartContext<'_, DB, super::plots::Coords>,
        root: &DrawingArea<DB, Shift>,
    ) -> DrawResult<DB> {
        if self.zones.is_empty() {
            return Ok(());
        }
        // Data in pixels: medians, band edges, and points every few pixels along the lines.
        let mut data: Vec<(i32, i32)> = Vec::new();
        for s in &self.series {
            for seg in &s.lines {
                let px: Vec<(i32, i32)> = seg.iter().map(|p| ch.backend_coord(p)).collect();
                data.extend(&px);
                for w in px.windows(2) {
                    let (a, b) = (w[0], w[1]);
                    let n = ((b.0 - a.0).abs().max((b.1 - a.1).abs()) / 4).max(1);
                    data.extend(
                        (1..n).map(|k| (a.0 + (b.0 - a.0) * k / n, a.1 + (b.1 - a.1) * k / n)),
                    );
                }
            }
            for p in s.bands.iter().flatten() {
                data.push(ch.backend_coord(&(p.0, p.1)));
                data.push(ch.backend_coord(&(p.0, p.2)));
            }
        }
        let (left, right) = (
            ch.backend_coord(&(self.x.lo, 0.0)).0,
            ch.backend_coord(&(self.x.hi, 0.0)).0,
        );
        let style = font(NOTE_PX).color(&style::MUTED);
        for z in &self.zones {
            // The zone around zero is labelled in its taller half, clear of the zero line.
            let (lo, hi) = if z.lo < 0.0 && z.hi > 0.0 {
                if z.hi >= -z.lo {
                    (0.0, z.hi)
                } else {
                    (z.lo, 0.0)
                }
            } else {
                (z.lo, z.hi)
            };
            let top = ch.backend_coord(&(self.x.lo, hi)).1;
            let bottom = ch.backend_coord(&(self.x.lo, lo)).1;
            if bottom - top < NOTE_PX as i32 + 4 {
                continue;
            }
            let yc = (top + bottom) / 2;
            let (w, _) = root
                .estimate_text_size(z.label, &style)
                .unwrap_or((text_width(z.label, NOTE_PX), NOTE_PX));
            let w = w as i32;
            let h = NOTE_PX as i32;
            let near = |x0: i32| {
                data.iter()
                    .filter(|p| {
                        (x0 - 6..=x0 + w + 6).contains(&p.0)
                            && (yc - h / 2 - 6..=yc + h / 2 + 6).contains(&p.1)
                    })
                    .count()
            };
            let (at_right, at_left) = (right - 6 - w, left + 6);
            let x0 = if near(at_left) < near(at_right) {
                at_left
            } else {
                at_right
            };
            root.draw_text(
                z.label,
                &style.pos(Pos::new(HPos::Left, VPos::Center)),
                (x0, yc),
            )?;
        }
        Ok(())
    }
}

// ---------------------------------------------------------------------------------------------
// Heat map

const MAP_W: u32 = style::COLUMN_PX;
const MAP_H: u32 = 600;
/// Width of the colour-bar column (strip, ticks, labels, title).
const BAR_COL: u32 = 150;
/// Width of the colour strip itself.
const STRIP_PX: u32 = 26;
use style::{NAN_FILL, NAN_HATCH, RDBU, VIRIDIS};

/// Piecewise-linear interpolation of `anchors` (evenly spaced) at `u` ∈ [0, 1] (clamped).
fn interpolate(anchors: &[(u8, u8, u8)], u: f64) -> RGBColor {
    let u = if u.is_nan() { 0.5 } else { u.clamp(0.0, 1.0) };
    let t = u * (anchors.len() - 1) as f64;
    let k = (t.floor() as usize).min(anchors.len() - 2);
    let f = t - k as f64;
    let mix = |a: u8, b: u8| (a as f64 + f * (b as f64 - a as f64)).round() as u8;
    let (a, b) = (anchors[k], anchors[k + 1]);
    RGBColor(mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}

/// sign(z)·ln(1 + |z|): linear near zero, logarithmic in the tails.
fn symlog(z: f64) -> f64 {
    z.signum() * z.abs().ln_1p()
}

/// How values become colours.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Scale {
    /// Viridis from `lo` to `hi`.
    Sequential { lo: f64, hi: f64 },
    /// RdBu over symlog(z) / symlog(max), `max` = largest |z|.
    Diverging { max: f64 },
}

impl Scale {
    /// Position on the colour bar, in the bar's own coordinate (z for sequential maps,
    /// symlog(z)/symlog(max) ∈ [−1, 1] for diverging ones).
    fn bar_coord(&self, z: f64) -> f64 {
        match *self {
            Scale::Sequential { .. } => z,
            Scale::Diverging { max } if max > 0.0 => symlog(z) / symlog(max),
            Scale::Diverging { .. } => 0.0,
        }
    }

    fn colour(&self, z: f64) -> RGBColor {
        match *self {
            Scale::Sequential { lo, hi } => {
                let u = if hi > lo { (z - lo) / (hi - lo) } else { 0.5 };
                interpolate(&VIRIDIS, u)
            }
            Scale::Diverging { .. } => interpolate(&RDBU, 0.5 + 0.5 * self.bar_coord(z)),
        }
    }

    /// The colour at bar coordinate `t`.
    fn colour_at(&self, t: f64) -> RGBColor {
        match *self {
            Scale::Sequential { .. } => self.colour(t),
            Scale::Diverging { .. } => interpolate(&RDBU, 0.5 + 0.5 * t),
        }
    }
}

/// Cell edges (plotted coordinates) around sorted, distinct centres: halfway between
/// neighbours, the outer cells mirrored. A single centre gets a cell of width `lone`.
fn cell_edges(centres: &[f64], lone: f64) -> Vec<f64> {
    let n = centres.len();
    if n == 1 {
        return vec![centres[0] - lone / 2.0, centres[0] + lone / 2.0];
    }
    let mut e = Vec::with_capacity(n + 1);
    e.push(centres[0] - (centres[1] - centres[0]) / 2.0);
    e.extend(centres.windows(2).map(|w| (w[0] + w[1]) / 2.0));
    e.push(centres[n - 1] + (centres[n - 1] - centres[n - 2]) / 2.0);
    e
}

/// One grid axis of a map: kept indices in plotted order, their cell edges, and the axis.
struct GridAxis {
    order: Vec<usize>,
    edges: Vec<f64>,
    axis: Axis,
}

/// Checks a grid coordinate vector and lays out its cells. `name` is `"x"` or `"y"`.
fn grid_axis(
    dir: &Path,
    stem: &str,
    name: &str,
    v: &[f64],
    log: bool,
) -> Result<GridAxis, ReportError> {
    if v.is_empty() {
        return Err(bad_input(
            dir,
            stem,
            name,
            "is empty; give at least one grid coordinate",
        ));
    }
    if let Some(j) = v.iter().position(|c| !c.is_finite()) {
        return Err(bad_input(
            dir,
            stem,
            format!("{name}[{j}]"),
            format!("is {}; grid coordinates must be finite", v[j]),
        ));
    }
    let mut order: Vec<usize> = (0..v.len()).filter(|&j| !log || v[j] > 0.0).collect();
    if order.is_empty() {
        return Err(bad_input(
            dir,
            stem,
            name,
            "has no positive value; a log axis needs coordinates > 0 (or use a linear axis)",
        ));
    }
    order.sort_by(|&a, &b| v[a].total_cmp(&v[b]));
    if let Some(w) = order.windows(2).find(|w| v[w[0]] == v[w[1]]) {
        let (a, b) = (w[0].min(w[1]), w[0].max(w[1]));
        return Err(bad_input(
            dir,
            stem,
            format!("{name}[{b}]"),
            format!(
                "repeats {name}[{a}] = {}; grid coordinates must be distinct",
                v[a]
            ),
        ));
    }
    let plotted: Vec<f64> = order
        .iter()
        .map(|&j| if log { v[j].log10() } else { v[j] })
        .collect();
    let lone = if log {
        0.2
    } else if plotted[0] != 0.0 {
        0.1 * plotted[0].abs()
    } else {
        1.0
    };
    let edges = cell_edges(&plotted, lone);
    let (lo, hi) = (edges[0], edges[edges.len() - 1]);
    let mut axis = if log {
        Axis::log10(lo, hi, 6)
    } else {
        Axis::linear(lo, hi, 6)
    };
    // Cells fill the frame: no padding.
    axis.lo = lo;
    axis.hi = hi;
    axis.ticks.retain(|t| (lo..=hi).contains(t));
    Ok(GridAxis { order, edges, axis })
}

/// A cell in plotted coordinates and its value (NaN for none).
struct Cell {
    x: (f64, f64),
    y: (f64, f64),
    z: f64,
}

struct MapFigure {
    title: String,
    x_title: String,
    y_title: String,
    x: Axis,
    y: Axis,
    cells: Vec<Cell>,
    scale: Scale,
    /// Colour-bar axis (coordinate of [`Scale::bar_coord`]) and its tick labels.
    bar: Axis,
    bar_labels: Vec<(f64, String)>,
    /// Colour-bar title (z label with any power of ten factored out).
    bar_desc: String,
    any_missing: bool,
}

/// Tick values for a diverging colour bar whose |z| reaches `max`.
fn diverging_ticks(max: f64) -> (Vec<f64>, Option<Axis>) {
    if max <= 10.0 {
        let a = Axis::linear(-max, max, 7);
        let ticks = a.ticks.iter().copied().filter(|t| t.abs() <= max).collect();
        return (ticks, Some(a));
    }
    // 1, 3, 10, 30, … while that gives at most five per side, else whole decades, thinned.
    let top = max.log10().floor() as i32;
    let mut side: Vec<f64> = (0..=top)
        .flat_map(|k| [1.0, 3.0].map(|m| m * 10f64.powi(k)))
        .filter(|v| *v <= max)
        .collect();
    if side.len() > 5 {
        let stride = ((top + 1) as usize).div_ceil(5);
        side = (0..=top)
            .filter(|k| (*k as usize).is_multiple_of(stride))
            .map(|k| 10f64.powi(k))
            .collect();
    }
    let mut ticks: Vec<f64> = side.iter().rev().map(|v| -v).collect();
    ticks.push(0.0);
    ticks.extend(&side);
    (ticks, None)
}

impl MapFigure {
    fn new(dir: &Path, stem: &str, map: &HeatMap<'_>) -> Result<Self, ReportError> {
        let gx = grid_axis(dir, stem, "x", map.x, map.log_x)?;
        let gy = grid_axis(dir, stem, "y", map.y, map.log_y)?;
        if map.z.len() != map.y.len() {
            return Err(bad_input(
                dir,
                stem,
                "z",
                format!(
                    "has {} rows but y has {} values; give z[iy][ix], one row per y",
                    map.z.len(),
                    map.y.len()
                ),
            ));
        }
        if let Some(iy) = map.z.iter().position(|r| r.len() != map.x.len()) {
            return Err(bad_input(
                dir,
                stem,
                format!("z[{iy}]"),
                format!(
                    "has {} values but x has {}; give one per x",
                    map.z[iy].len(),
                    map.x.len()
                ),
            ));
        }
        let mut cells = Vec::with_capacity(gx.order.len() * gy.order.len());
        for (ky, &iy) in gy.order.iter().enumerate() {
            for (kx, &ix) in gx.order.iter().enumerate() {
                let z = map.z[iy][ix];
                cells.push(Cell {
                    x: (gx.edges[kx], gx.edges[kx + 1]),
                    y: (gy.edges[ky], gy.edges[ky + 1]),
                    z: if z.is_finite() { z } else { f64::NAN },
                });
            }
        }
        let Some((zmin, zmax)) = super::axis::finite_range(cells.iter().map(|c| c.z)) else {
            return Err(bad_input(
                dir,
                stem,
                "z",
                "has no finite value in the cells drawn (NaN/infinite everywhere, or only at \
                 coordinates ≤ 0 on a log axis); check the sweep results",
            ));
        };
        let any_missing = cells.iter().any(|c| c.z.is_nan());

        let (scale, bar, bar_labels, bar_desc) = if map.diverging {
            let max = zmax.abs().max(zmin.abs());
            let scale = Scale::Diverging { max };
            let (ticks, linear) = diverging_ticks(max);
            let mut bar = Axis::linear(-1.0, 1.0, 2);
            bar.lo = -1.0;
            bar.hi = 1.0;
            let labels: Vec<(f64, String)> = ticks
                .iter()
                .map(|&v| {
                    let label = match &linear {
                        Some(a) => a.label(v),
                        None => fmt_sig(v, 1),
                    };
                    (scale.bar_coord(v), label)
                })
                .collect();
            bar.ticks = labels.iter().map(|l| l.0).collect();
            let desc = match &linear {
                Some(a) => a.desc(map.z_label),
                None => map.z_label.to_string(),
            };
            (scale, bar, labels, desc)
        } else {
            let mut bar = Axis::linear(zmin, zmax, 7);
            if zmax > zmin {
                bar.lo = zmin;
                bar.hi = zmax;
                bar.ticks.retain(|t| (zmin..=zmax).contains(t));
            }
            let labels = bar.ticks.iter().map(|&t| (t, bar.label(t))).collect();
            let desc = bar.desc(map.z_label);
            let scale = if zmax > zmin {
                Scale::Sequential { lo: zmin, hi: zmax }
            } else {
                Scale::Sequential {
                    lo: bar.lo,
                    hi: bar.hi,
                }
            };
            (scale, bar, labels, desc)
        };
        Ok(MapFigure {
            title: map.title.to_string(),
            x_title: map.x_label.to_string(),
            y_title: map.y_label.to_string(),
            x: gx.axis,
            y: gy.axis,
            cells,
            scale,
            bar,
            bar_labels,
            bar_desc,
            any_missing,
        })
    }
}

/// Grey fill with a cross, for a cell (pixel corners) without a value.
fn missing_cell<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    (a, b): ((i32, i32), (i32, i32)),
) -> DrawResult<DB> {
    let (x0, x1) = (a.0.min(b.0), a.0.max(b.0));
    let (y0, y1) = (a.1.min(b.1), a.1.max(b.1));
    root.draw(&Rectangle::new([(x0, y0), (x1, y1)], NAN_FILL.filled()))?;
    let (w, h) = (x1 - x0, y1 - y0);
    if w >= 6 && h >= 6 {
        let inset = (w.min(h) / 5).max(2);
        let style = NAN_HATCH.stroke_width(1);
        root.draw(&PathElement::new(
            [(x0 + inset, y0 + inset), (x1 - inset, y1 - inset)],
            style,
        ))?;
        root.draw(&PathElement::new(
            [(x0 + inset, y1 - inset), (x1 - inset, y0 + inset)],
            style,
        ))?;
    }
    Ok(())
}

impl Figure for MapFigure {
    fn size(&self) -> (u32, u32) {
        (MAP_W, MAP_H)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        let area = if self.title.is_empty() {
            root.margin(14, 0, 0, 0)
        } else {
            let (title, style) = super::plots::fitted_title(root, &self.title);
            root.titled(&title, style)?.margin(6, 0, 0, 0)
        };
        let (main, side) = area.split_horizontally(MAP_W - BAR_COL);
        let x_area = TICK_PX + DESC_PX + 24;
        let bottom = 10;
        let main = main.margin(0, bottom, 10, 16);
        let axes = (&self.x, &self.y);
        let y_labels = y_area(self.y.ticks.iter().map(|&t| self.y.label(t)));
        let mut ch = chart(&main, axes, (x_area, y_labels), None)?;

        for c in &self.cells {
            let corners = [(c.x.0, c.y.0), (c.x.1, c.y.1)];
            if c.z.is_nan() {
                let px = (ch.backend_coord(&corners[0]), ch.backend_coord(&corners[1]));
                missing_cell(root, px)?;
            } else {
                ch.draw_series([Rectangle::new(corners, self.scale.colour(c.z).filled())])?;
            }
        }
        // Axes, ticks and titles on top of the cells; no grid across the map.
        let mut m = ch.configure_mesh();
        let fx = |v: &f64| self.x.label(*v);
        let fy = |v: &f64| self.y.label(*v);
        m.disable_mesh()
            .x_label_formatter(&fx)
            .y_label_formatter(&fy)
            .label_style(font(TICK_PX))
            .axis_desc_style(font(DESC_PX))
            .axis_style(style::AXIS)
            .x_desc(self.x.desc(&self.x_title))
            .y_desc(self.y.desc(&self.y_title));
        m.draw()?;

        // Colour bar: a strip in bar coordinates, labels on its right.
        // The strip is STRIP_PX wide, its labels and title to the right of it.
        let labels_w = y_area(self.bar_labels.iter().map(|l| l.1.clone()));
        let right = BAR_COL.saturating_sub(4 + STRIP_PX + labels_w).max(6);
        let side = side.margin(0, bottom, 4, right);
        let mut b = ChartBuilder::on(&side);
        b.x_label_area_size(x_area)
            .y_label_area_size(0)
            .right_y_label_area_size(labels_w);
        let mut strip_axis = Axis::linear(0.0, 1.0, 1);
        strip_axis.lo = 0.0;
        strip_axis.hi = 1.0;
        strip_axis.ticks.clear();
        let mut bc = b.build_cartesian_2d(Ticked::new(&strip_axis), Ticked::new(&self.bar))?;
        let steps = 240;
        let span = self.bar.hi - self.bar.lo;
        bc.draw_series((0..steps).map(|k| {
            let t0 = self.bar.lo + span * k as f64 / steps as f64;
            let t1 = self.bar.lo + span * (k + 1) as f64 / steps as f64;
            let colour = self.scale.colour_at((t0 + t1) / 2.0);
            Rectangle::new([(0.0, t0), (1.0, t1)], colour.filled())
        }))?;
        let label_of = |t: &f64| {
            self.bar_labels
                .iter()
                .find(|l| (l.0 - t).abs() <= 1e-9 * (1.0 + t.abs()))
                .map(|l| l.1.clone())
                .unwrap_or_default()
        };
        let blank = |_: &f64| String::new();
        bc.configure_mesh()
            .disable_mesh()
            .x_label_formatter(&blank)
            .y_label_formatter(&label_of)
            .label_style(font(TICK_PX))
            .axis_desc_style(font(DESC_PX))
            .axis_style(style::AXIS)
            .y_desc(&self.bar_desc)
            .draw()?;

        if self.any_missing {
            let (px, py) = bc.backend_coord(&(0.0, self.bar.lo));
            let key = ((px, py + 16), (px + 22, py + 38));
            missing_cell(root, key)?;
            let style = font(NOTE_PX).pos(Pos::new(HPos::Left, VPos::Center));
            root.draw_text("no value", &style, (px + 28, py + 27))?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::report::tests::{assert_invalid, check_outputs};

    /// Renders `fig` into an RGB buffer exactly as the PNG is drawn (after registering the
    /// font through a real render of some figure).
    fn pixels<F: Figure>(fig: &F) -> (Vec<u8>, (u32, u32)) {
        let (w, h) = fig.size();
        let mut buf = vec![0u8; (w * h * 3) as usize];
        {
            let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
            root.fill(&WHITE).unwrap();
            fig.draw(&root).unwrap();
            root.present().unwrap();
        }
        (buf, (w, h))
    }

    fn count(buf: &[u8], c: RGBColor) -> usize {
        buf.chunks_exact(3)
            .filter(|p| (p[0], p[1], p[2]) == (c.0, c.1, c.2))
            .count()
    }

    fn distinct(buf: &[u8]) -> usize {
        let mut seen: Vec<[u8; 3]> = buf.chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect();
        seen.sort_unstable();
        seen.dedup();
        seen.len()
    }

    /// `n` SNR points from 2 to 200, geometric, with a ln B that grows like SNR²/2 and a band
    /// whose width grows with it.
    fn snr_series(name: &str, n: usize, scale: f64) -> BandSeries {
        let x: Vec<f64> = (0..n)
            .map(|k| 2.0 * 100f64.powf(k as f64 / (n - 1) as f64))
            .collect();
        let median: Vec<f64> = x
            .iter()
            .map(|s| scale * (0.5 * s * s / 100.0 - 1.0))
            .collect();
        let width: Vec<f64> = median.iter().map(|m| 0.8 + 0.1 * m.abs()).collect();
        BandSeries {
            name: name.into(),
            lo: median.iter().zip(&width).map(|(m, w)| m - w).collect(),
            hi: median.iter().zip(&width).map(|(m, w)| m + w).collect(),
            median,
            x,
        }
    }

    fn plot(series: &[BandSeries]) -> BandPlot<'_> {
        BandPlot {
            title: "ln B against SNR",
            x_label: "SNR",
            y_label: "ln B_XY",
            series,
            log_x: true,
            zones: true,
            sign: None,
        }
    }

    #[test]
    fn zones_are_the_kass_raftery_grades_clipped_to_the_axis() {
        let z = visible_zones(-4.0, 12.0);
        let spans: Vec<(f64, f64, &str)> = z.iter().map(|z| (z.lo, z.hi, z.label)).collect();
        assert_eq!(
            spans,
            [
                (-1.0, 1.0, "bare mention"),
                (1.0, 3.0, "positive"),
                (-3.0, -1.0, "positive"),
                (3.0, 5.0, "strong"),
                (-4.0, -3.0, "strong"),
                (5.0, 12.0, "very strong"),
            ]
        );
        // Far from zero only the outermost grade shows.
        let far = visible_zones(9000.0, 10000.0);
        assert_eq!(far.len(), 1);
        assert_eq!(far[0].label, "very strong");
        // The shades lighten as the grade strengthens.
        assert!(ZONES.windows(2).all(|w| w[1].2.0 > w[0].2.0));
    }

    #[test]
    fn band_plot_realistic_sweep_renders_every_layer() {
        let dir = tempfile::tempdir().unwrap();
        let series = [
            snr_series("RJMCMC", 10, 1.0),
            snr_series("thermodynamic integration", 10, 0.95),
            snr_series("Laplace", 10, 1.1),
        ];
        band_plot(dir.path(), "snr", &plot(&series)).unwrap();
        let (w, h) = check_outputs(
            dir.path(),
            "snr",
            &[
                "ln B against SNR",
                "RJMCMC",
                "thermodynamic integration",
                "Laplace",
                "very strong",
                "SNR",
                "ln B_XY",
                // Translucent band fills.
                "opacity=\"0.2",
            ],
        );
        let fig = BandFigure::new(dir.path(), "snr", &plot(&series)).unwrap();
        let rows = fig.legend_rows.len() as u32;
        assert_eq!((w, h), (BAND_W, BAND_H + LEGEND_ROW * (rows - 1)));
        let (buf, _) = pixels(&fig);
        assert!(distinct(&buf) > 50, "only {} colours", distinct(&buf));
        for i in 0..3 {
            let n = count(&buf, colour(i));
            assert!(n > 300, "series {i} colour on {n} pixels only");
        }
        // Zone shades and the white background around the frame.
        // (The "very strong" zone is white, like the background.)
        for &(_, label, shade) in &ZONES[..3] {
            assert!(count(&buf, shade) > 500, "zone {label} not visible");
        }
        assert!(count(&buf, WHITE) > 10_000);
        // One line segment per series (no gaps), all points marked and banded.
        for s in &fig.series {
            assert_eq!(s.lines.len(), 1);
            assert_eq!(s.markers.len(), 10);
            assert_eq!(s.bands.len(), 1);
            assert_eq!(s.bands[0].len(), 10);
        }
        assert!(fig.y.lo < 0.0 && fig.zero_line);
    }

    #[test]
    fn nan_points_break_lines_and_bands() {
        let dir = tempfile::tempdir().unwrap();
        let mut a = snr_series("a", 8, 1.0);
        a.median[3] = f64::NAN; // no median: the line breaks, the band goes on
        a.lo[5] = f64::NAN; // no band at 5: the band breaks, the line goes on
        a.hi[5] = f64::NAN;
        a.median[7] = f64::NAN;
        a.lo[7] = f64::NAN;
        a.hi[7] = f64::NAN;
        let series = [a];
        let fig = BandFigure::new(dir.path(), "n", &plot(&series)).unwrap();
        let s = &fig.series[0];
        let lens = |v: &Vec<Vec<(f64, f64)>>| v.iter().map(Vec::len).collect::<Vec<_>>();
        assert_eq!(lens(&s.lines), [3, 3]); // 0-2, 4-6
        assert_eq!(s.markers.len(), 6);
        let band_lens: Vec<usize> = s.bands.iter().map(Vec::len).collect();
        assert_eq!(band_lens, [5, 1]); // 0-4, then 6 alone (drawn as a bar)
        band_plot(dir.path(), "n", &plot(&series)).unwrap();
        check_outputs(dir.path(), "n", &[]);
    }

    #[test]
    fn unsorted_grid_is_drawn_in_order() {
        let dir = tempfile::tempdir().unwrap();
        let series = [BandSeries {
            name: "a".into(),
            x: vec![3.0, 1.0, 2.0],
            median: vec![30.0, 10.0, 20.0],
            lo: vec![29.0, 9.0, 19.0],
            hi: vec![31.0, 11.0, 21.0],
        }];
        let p = BandPlot {
            series: &series,
            ..Default::default()
        };
        let fig = BandFigure::new(dir.path(), "u", &p).unwrap();
        assert_eq!(
            fig.series[0].lines,
            [vec![(1.0, 10.0), (2.0, 20.0), (3.0, 30.0)]]
        );
        // Without zones, zero need not be in range.
        assert!(fig.y.lo > 5.0 && fig.zones.is_empty() && !fig.zero_line);
    }

    #[test]
    fn one_point_and_all_nan_series_among_valid_ones() {
        let dir = tempfile::tempdir().unwrap();
        let one = BandSeries {
            name: "single".into(),
            x: vec![10.0],
            median: vec![2.0],
            lo: vec![1.0],
            hi: vec![3.5],
        };
        let nan = BandSeries {
            name: "failed".into(),
            x: vec![5.0, 10.0],
            median: vec![f64::NAN; 2],
            lo: vec![f64::NAN; 2],
            hi: vec![f64::NAN; 2],
        };
        let series = [snr_series("ok", 6, 1.0), one, nan];
        band_plot(dir.path(), "mix", &plot(&series)).unwrap();
        check_outputs(dir.path(), "mix", &["single", "failed (no values)", "ok"]);
        let fig = BandFigure::new(dir.path(), "mix", &plot(&series)).unwrap();
        assert_eq!(fig.series[1].markers, [(1.0, 2.0)]);
        assert_eq!(fig.series[1].bands, [vec![(1.0, 1.0, 3.5)]]);
        assert!(fig.series[2].lines.is_empty() && fig.series[2].bands.is_empty());
        // The lone point is visible in its own colour.
        let (buf, _) = pixels(&fig);
        assert!(count(&buf, colour(1)) > 40);

        // A lone series of one point renders too.
        let dir = tempfile::tempdir().unwrap();
        band_plot(dir.path(), "one", &plot(&series[1..2])).unwrap();
        check_outputs(dir.path(), "one", &["single"]);
    }

    #[test]
    fn huge_ln_b_renders_with_thin_zones() {
        let dir = tempfile::tempdir().unwrap();
        let series = [
            snr_series("big", 10, 50.0),
            BandSeries {
                name: "negative".into(),
                x: vec![2.0, 200.0],
                median: vec![-3.0, -1.0e4],
                lo: vec![-4.0, -1.2e4],
                hi: vec![-2.0, -0.9e4],
            },
        ];
        band_plot(dir.path(), "huge", &plot(&series)).unwrap();
        check_outputs(dir.path(), "huge", &["very strong", "big", "negative"]);
        let fig = BandFigure::new(dir.path(), "huge", &plot(&series)).unwrap();
        assert!(fig.y.lo <= -1.2e4 && fig.y.hi >= 50.0 * (0.5 * 200.0 * 200.0 / 100.0 - 1.0));
        // The narrow grades exist but are far too thin for labels.
        let svg = std::fs::read_to_string(dir.path().join("huge.svg")).unwrap();
        assert!(!svg.contains("positive") && !svg.contains("bare mention"));
        assert!(fig.zones.iter().any(|z| z.label == "positive"));

        // Large and nearly constant: zero is left out so the spread stays visible.
        let dir = tempfile::tempdir().unwrap();
        let flat = [BandSeries {
            name: "flat".into(),
            x: vec![1.0, 2.0, 3.0],
            median: vec![1.0e4, 1.001e4, 1.002e4],
            lo: vec![0.999e4, 1.0e4, 1.001e4],
            hi: vec![1.001e4, 1.002e4, 1.003e4],
        }];
        let p = BandPlot {
            log_x: false,
            ..plot(&flat)
        };
        band_plot(dir.path(), "flat", &p).unwrap();
        let fig = BandFigure::new(dir.path(), "flat", &p).unwrap();
        assert!(fig.y.lo > 9000.0 && !fig.zero_line);
        assert_eq!(fig.zones.len(), 1);
    }

    #[test]
    fn log_axis_skips_non_positive_x() {
        let dir = tempfile::tempdir().unwrap();
        let series = [BandSeries {
            name: "a".into(),
            x: vec![0.0, 1.0, 10.0],
            median: vec![5.0, 1.0, 2.0],
            lo: vec![4.0, 0.0, 1.0],
            hi: vec![6.0, 2.0, 3.0],
        }];
        let fig = BandFigure::new(dir.path(), "l", &plot(&series)).unwrap();
        assert_eq!(fig.series[0].lines, [vec![(0.0, 1.0), (1.0, 2.0)]]);
        // The value at x = 0 does not stretch the vertical axis.
        assert!(fig.y.hi < 4.0, "{}", fig.y.hi);
        let bad = [BandSeries {
            name: "a".into(),
            x: vec![0.0, -1.0],
            median: vec![5.0, 1.0],
            lo: vec![4.0, 0.0],
            hi: vec![6.0, 2.0],
        }];
        assert_invalid(
            band_plot(dir.path(), "l", &plot(&bad)),
            "series",
            dir.path(),
        );
    }

    #[test]
    fn band_plot_rejects_bad_input_naming_the_field() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let good = snr_series("g", 4, 1.0);
        assert_invalid(band_plot(d, "b", &plot(&[])), "series", d);
        let cases: Vec<(BandSeries, &str)> = vec![
            (
                BandSeries {
                    lo: vec![0.0; 3],
                    ..good.clone()
                },
                "series[1].lo",
            ),
            (
                BandSeries {
                    median: vec![0.0; 5],
                    ..good.clone()
                },
                "series[1].median",
            ),
            (
                {
                    let mut s = good.clone();
                    s.x[2] = f64::NAN;
                    s
                },
                "series[1].x[2]",
            ),
            (
                {
                    let mut s = good.clone();
                    std::mem::swap(&mut s.lo, &mut s.hi);
                    s
                },
                "series[1].lo[0]",
            ),
            (
                {
                    let mut s = good.clone();
                    s.median[3] = s.hi[3] + 1.0;
                    s
                },
                "series[1].median[3]",
            ),
            (
                BandSeries {
                    median: vec![f64::NAN; 4],
                    lo: vec![f64::INFINITY; 4],
                    hi: vec![f64::NAN; 4],
                    ..good.clone()
                },
                "",
            ),
        ];
        for (bad, field) in cases {
            let series = [good.clone(), bad.clone()];
            if field.is_empty() {
                // A series with nothing to draw is fine next to a good one, fatal alone.
                band_plot(d, "b", &plot(&series)).unwrap();
                std::fs::remove_file(d.join("b.png")).unwrap();
                std::fs::remove_file(d.join("b.svg")).unwrap();
                assert_invalid(band_plot(d, "b", &plot(&[bad])), "series", d);
            } else {
                assert_invalid(band_plot(d, "b", &plot(&series)), field, d);
            }
        }
    }

    #[test]
    fn legend_wraps_into_rows_and_the_canvas_grows() {
        let dir = tempfile::tempdir().unwrap();
        let series: Vec<BandSeries> = (0..7)
            .map(|i| snr_series(&format!("estimator number {i}"), 5, 1.0 + 0.1 * i as f64))
            .collect();
        let fig = BandFigure::new(dir.path(), "w", &plot(&series)).unwrap();
        assert!(fig.legend_rows.len() >= 2);
        let flat: Vec<usize> = fig.legend_rows.iter().flatten().copied().collect();
        assert_eq!(flat, (0..7).collect::<Vec<_>>());
        for row in &fig.legend_rows {
            let w: u32 = row
                .iter()
                .map(|&i| legend_entry_width(&fig.series[i].name))
                .sum();
            assert!(row.len() == 1 || w <= BAND_W - 16, "row {row:?} is {w} px");
        }
        band_plot(dir.path(), "w", &plot(&series)).unwrap();
        let (_, h) = check_outputs(dir.path(), "w", &["estimator number 6"]);
        assert_eq!(h, BAND_H + LEGEND_ROW * (fig.legend_rows.len() as u32 - 1));
    }

    #[test]
    fn series_differ_beyond_colour() {
        // The first twelve series differ in marker shape or dash pattern, not only colour.
        for a in 0..12 {
            for b in 0..a {
                assert!(
                    marker_shape(a) != marker_shape(b) || dash(a) != dash(b),
                    "series {a} and {b}"
                );
            }
        }
        assert!((0..6).all(|i| (0..i).all(|j| marker_shape(i) != marker_shape(j))));
    }

    // -- heat map ------------------------------------------------------------------------------

    #[test]
    fn cell_edges_sit_at_midpoints_geometric_on_log_axes() {
        assert_eq!(cell_edges(&[0.0, 1.0, 3.0], 1.0), [-0.5, 0.5, 2.0, 4.0]);
        assert_eq!(cell_edges(&[2.0], 1.0), [1.5, 2.5]);
        let dir = tempfile::tempdir().unwrap();
        let g = grid_axis(dir.path(), "m", "x", &[16.0, 1.0, 4.0], true).unwrap();
        assert_eq!(g.order, [1, 2, 0]);
        let back: Vec<f64> = g.edges.iter().map(|e| 10f64.powf(*e)).collect();
        // Edges at √(1·4) = 2 and √(4·16) = 8, outer ones mirrored: 0.5 and 32.
        for (got, want) in back.iter().zip([0.5, 2.0, 8.0, 32.0]) {
            assert!((got - want).abs() < 1e-12 * want, "{back:?}");
        }
        assert_eq!((g.axis.lo, g.axis.hi), (g.edges[0], g.edges[3]));
        assert!(
            g.axis
                .ticks
                .iter()
                .all(|t| (g.axis.lo..=g.axis.hi).contains(t))
        );
        // Non-positive coordinates are skipped on a log axis.
        let g = grid_axis(dir.path(), "m", "y", &[-1.0, 0.0, 10.0, 100.0], true).unwrap();
        assert_eq!(g.order, [2, 3]);
    }

    #[test]
    fn colour_maps_are_centred_and_symmetric() {
        let s = Scale::Diverging { max: 400.0 };
        assert_eq!(s.colour(0.0), RGBColor(247, 247, 247));
        assert_eq!(s.colour(400.0), RGBColor(5, 48, 97));
        assert_eq!(s.colour(-400.0), RGBColor(103, 0, 31));
        // Equal |z| equally deep: mirrored positions on the bar.
        for z in [0.3, 3.0, 30.0] {
            assert!((s.bar_coord(z) + s.bar_coord(-z)).abs() < 1e-15);
        }
        // ln B = -3 next to a maximum of 400 is still visibly red, not white (a linear scale
        // would give (247, 244, 241)).
        let c = s.colour(-3.0);
        assert!(c.2 + 40 < 247 && c.0 > c.2 + 40, "{c:?}");
        // Sequential: viridis ends.
        let q = Scale::Sequential { lo: 2.0, hi: 5.0 };
        assert_eq!(q.colour(2.0), RGBColor(68, 1, 84));
        assert_eq!(q.colour(5.0), RGBColor(253, 231, 37));
        // Diverging ticks: readable counts at every magnitude, symmetric, including 0.
        for max in [0.004, 0.8, 7.0, 11.0, 400.0, 1e4, 1e9] {
            let (t, _) = diverging_ticks(max);
            assert!((3..=13).contains(&t.len()), "{max}: {t:?}");
            assert!(t.contains(&0.0), "{max}: {t:?}");
            assert!(
                t.iter().all(|v| v.abs() <= max && t.contains(&-v)),
                "{max}: {t:?}"
            );
        }
    }

    fn lnb_map(nx: usize, ny: usize) -> (Vec<f64>, Vec<f64>, Vec<Vec<f64>>) {
        let snr: Vec<f64> = (0..nx)
            .map(|k| 2.0 * 50f64.powf(k as f64 / (nx - 1) as f64))
            .collect();
        let f: Vec<f64> = (0..ny)
            .map(|k| 1e-4 * 100f64.powf(k as f64 / (ny - 1) as f64))
            .collect();
        let z = f
            .iter()
            .map(|fi| {
                snr.iter()
                    .map(|s| 0.3 * s * s * (fi / 1e-2).powf(0.5) - 3.0)
                    .collect()
            })
            .collect();
        (snr, f, z)
    }

    #[test]
    fn heat_map_diverging_with_missing_cells() {
        let dir = tempfile::tempdir().unwrap();
        let (x, y, mut z) = lnb_map(20, 20);
        z[4][7] = f64::NAN;
        z[15][2] = f64::INFINITY;
        let m = HeatMap {
            title: "ln B over SNR and frequency",
            x_label: "SNR",
            y_label: "f [Hz]",
            x: &x,
            y: &y,
            z: &z,
            z_label: "ln B_XY",
            log_x: true,
            log_y: true,
            diverging: true,
        };
        heat_map(dir.path(), "map", &m).unwrap();
        let (w, h) = check_outputs(
            dir.path(),
            "map",
            &[
                "ln B over SNR and frequency",
                "no value",
                "ln B_XY",
                "f [Hz]",
            ],
        );
        assert_eq!((w, h), (MAP_W, MAP_H));
        let fig = MapFigure::new(dir.path(), "map", &m).unwrap();
        assert_eq!(fig.cells.len(), 400);
        assert_eq!(fig.cells.iter().filter(|c| c.z.is_nan()).count(), 2);
        let (buf, _) = pixels(&fig);
        assert!(distinct(&buf) > 100, "{}", distinct(&buf));
        // Both ends of the diverging map, and the grey of the missing cells (2 cells + key).
        assert!(count(&buf, NAN_FILL) > 2 * 200);
        let z_min = z
            .iter()
            .flatten()
            .copied()
            .filter(|v| v.is_finite())
            .fold(f64::MAX, f64::min);
        assert!(count(&buf, fig.scale.colour(z_min)) > 200, "negative cells");
        assert!(
            count(&buf, RGBColor(5, 48, 97)) > 200,
            "strongest positive cells"
        );
    }

    #[test]
    fn heat_map_sequential_linear_uneven_and_single_cell() {
        let dir = tempfile::tempdir().unwrap();
        let x = [0.0, 1.0, 3.0, 7.0];
        let y = [-2.0, 5.0];
        let z = vec![vec![1.0, 2.0, 3.0, 4.0], vec![5.0, 6.0, 7.0, 8.0]];
        let m = HeatMap {
            x: &x,
            y: &y,
            z: &z,
            z_label: "width",
            ..Default::default()
        };
        heat_map(dir.path(), "seq", &m).unwrap();
        check_outputs(dir.path(), "seq", &["width"]);
        let fig = MapFigure::new(dir.path(), "seq", &m).unwrap();
        assert_eq!(fig.cells[1].x, (0.5, 2.0));
        assert_eq!(fig.cells[3].x, (5.0, 9.0));
        assert_eq!(fig.cells[4].y, (1.5, 8.5));
        let (buf, _) = pixels(&fig);
        assert!(count(&buf, RGBColor(68, 1, 84)) > 500);
        assert!(count(&buf, RGBColor(253, 231, 37)) > 500);
        // No missing cells, no key (a few anti-aliased text pixels may share the grey).
        assert!(count(&buf, NAN_FILL) < 50, "{}", count(&buf, NAN_FILL));

        let dir = tempfile::tempdir().unwrap();
        let one = vec![vec![-2.5]];
        for diverging in [false, true] {
            let m = HeatMap {
                x: &[3.0],
                y: &[1e-3],
                z: &one,
                log_y: true,
                diverging,
                ..Default::default()
            };
            heat_map(dir.path(), "one", &m).unwrap();
            check_outputs(dir.path(), "one", &[]);
        }
        // All values zero on a diverging map: everything at the centre colour.
        let zeros = vec![vec![0.0; 2]; 2];
        let m = HeatMap {
            x: &[1.0, 2.0],
            y: &[1.0, 2.0],
            z: &zeros,
            diverging: true,
            ..Default::default()
        };
        heat_map(dir.path(), "one", &m).unwrap();
        check_outputs(dir.path(), "one", &[]);
        let fig = MapFigure::new(dir.path(), "one", &m).unwrap();
        assert_eq!(fig.scale.colour(0.0), RGBColor(247, 247, 247));
    }

    #[test]
    fn heat_map_rejects_bad_shapes_naming_the_field() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let x = [1.0, 2.0, 3.0];
        let y = [1.0, 2.0];
        let z = vec![vec![0.0; 3]; 2];
        let m = HeatMap {
            x: &x,
            y: &y,
            z: &z,
            ..Default::default()
        };
        heat_map(d, "ok", &m).unwrap();
        std::fs::remove_file(d.join("ok.png")).unwrap();
        std::fs::remove_file(d.join("ok.svg")).unwrap();
        let short = vec![vec![0.0; 3]];
        let ragged = vec![vec![0.0; 3], vec![0.0; 2]];
        let nan = vec![vec![f64::NAN; 3]; 2];
        let cases: Vec<(HeatMap, &str)> = vec![
            (HeatMap { x: &[], ..m }, "x"),
            (HeatMap { y: &[], ..m }, "y"),
            (HeatMap { z: &short, ..m }, "z"),
            (HeatMap { z: &ragged, ..m }, "z[1]"),
            (HeatMap { z: &nan, ..m }, "z"),
            (
                HeatMap {
                    x: &[1.0, f64::NAN, 3.0],
                    ..m
                },
                "x[1]",
            ),
            (
                HeatMap {
                    y: &[2.0, 2.0],
                    ..m
                },
                "y[1]",
            ),
            (
                HeatMap {
                    x: &[0.0, -1.0, -2.0],
                    log_x: true,
                    ..m
                },
                "x",
            ),
        ];
        for (bad, field) in cases {
            assert_invalid(heat_map(d, "m", &bad), field, d);
        }
        // Only the cells at x > 0 are drawn on a log axis: NaN there and values at x ≤ 0
        // leave nothing to colour.
        let z = vec![vec![1.0, f64::NAN, f64::NAN]; 2];
        let bad = HeatMap {
            x: &[-1.0, 2.0, 3.0],
            z: &z,
            log_x: true,
            ..m
        };
        assert_invalid(heat_map(d, "m", &bad), "z", d);
    }
}
