//! Corner plot: 1-D marginals with their 16/50/84 % quantiles on the diagonal, 1σ and 2σ
//! credible contours of every pair below it, truth and MAP marked.

use super::axis::Axis;
use super::contour::{SIGMA_MASS, contour_segments, hdr_levels, quantiles_16_50_84, smooth};
use super::error::ReportError;
use super::plots::{
    DrawResult, Figure, MeshText, bad_input, chart, check_truth, mesh, render, text,
};
use super::style;
use crate::numfmt::format::fmt_sig;
use plotters::coord::Shift;
use plotters::element::DashedPathElement;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::path::Path;

/// Everything a corner plot shows. Build it with a struct literal and `..Default::default()`.
#[derive(Debug, Clone, Copy, Default)]
pub struct CornerPlot<'a> {
    /// Parameter names, one per column of `samples`.
    pub names: &'a [String],
    /// SI unit per parameter for the axis titles (empty string: dimensionless); an empty
    /// slice for none at all.
    pub units: &'a [String],
    /// `samples[s][p]`: parameter `p` of pooled sample `s`.
    pub samples: &'a [Vec<f64>],
    /// True values, when known (NaN: unknown for that parameter).
    pub truth: Option<&'a [f64]>,
    /// The maximum a posteriori point, when known.
    pub map: Option<&'a [f64]>,
}

/// Writes `<dir>/<stem>.png` and `.svg` from names, samples and an optional truth (no units,
/// no MAP); see [`draw_corner`].
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
    draw_corner(
        dir,
        stem,
        &CornerPlot {
            names,
            samples,
            truth,
            ..Default::default()
        },
    )
}

/// Writes `<dir>/<stem>.png` and `.svg`: for `n` parameters an `n × n` lower-triangular grid.
///
/// * Diagonal: the marginal histogram of each parameter with dashed lines at its 16, 50 and
///   84 % quantiles and the title `name = median` / `+(q84 − median) −(median − q16)`.
/// * Below: each pair's 1σ and 2σ credible regions, the highest-density regions holding
///   39.3 % and 86.5 % of the samples (the mass inside 1σ and 2σ of a 2-D Gaussian), found on
///   a 2-D histogram smoothed by a Gaussian of one bin, filled in two tints and outlined;
///   samples outside the 2σ region are drawn as dots.
/// * Truth (when given): vermillion solid lines and a star; MAP: black dashed lines and a
///   diamond; a legend above says which is which.
///
/// Axes are shared down columns and along rows and titled with the unit and any power of ten
/// or offset (`w1sq [10⁻⁶ s⁻²]`). Samples with a non-finite value are left out of the panels
/// that use it, and the header says how many there were. A parameter that never moves gets a
/// one-bin marginal and no contours. Designed for a page width (7 in) up to 5 parameters; the
/// canvas grows beyond that so the cells stay legible.
///
/// Errors ([`ReportError::InvalidInput`]): no names, no samples, a sample whose length is not
/// `names.len()`, `truth`, `map` or a non-empty `units` of the wrong length.
pub fn draw_corner(dir: &Path, stem: &str, plot: &CornerPlot<'_>) -> Result<(), ReportError> {
    let fig = CornerFigure::new(dir, stem, plot)?;
    render(dir, stem, &fig)
}

/// Room for tick labels and the rotated title of the left column.
const LEFT: u32 = 2 * style::TICK_PX + 3 * style::TICK_PX;
/// Room for tick labels and the two-line title of the bottom row.
const BOTTOM: u32 = style::TICK_PX + 2 * (style::LABEL_PX + 4) + 24;
const RIGHT: u32 = 24;
/// The two-line quantile title above each marginal.
const DIAG_TITLE: u32 = 2 * (style::TICK_PX + 5) + 4;
/// One header row (figure title, legend).
const HEAD_ROW: u32 = style::LEGEND_PX + 12;
/// At most this many dots for the samples outside the 2σ region, per panel.
const MAX_DOTS: usize = 3000;

struct Pair {
    /// Smoothed density, row-major `bins2 × bins2`, x = parameter j.
    density: Vec<f64>,
    /// Density levels of the 1σ and 2σ regions (`None`: nothing to contour).
    levels: Option<[f64; 2]>,
    /// Samples outside the 2σ region (data coordinates).
    dots: Vec<(f64, f64)>,
}

struct CornerFigure {
    header: String,
    names: Vec<String>,
    units: Vec<String>,
    axes: Vec<Axis>,
    truth: Option<Vec<f64>>,
    map: Option<Vec<f64>>,
    /// Per parameter: counts in `bins1` equal bins over its axis range.
    marginals: Vec<Vec<f64>>,
    /// Per parameter: 16/50/84 % quantiles (`None` when no finite value).
    quantiles: Vec<Option<[f64; 3]>>,
    /// `pairs[i][j]` for `j < i`.
    pairs: Vec<Vec<Pair>>,
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

/// The two title lines of a marginal: `name = median` and `+up −down`, the median to the
/// digit of the smaller error's second significant digit.
pub(crate) fn quantile_title(name: &str, q: Option<[f64; 3]>) -> [String; 2] {
    let Some([lo, mid, hi]) = q else {
        return [name.to_string(), "no finite values".to_string()];
    };
    let (up, down) = (hi - mid, mid - lo);
    let err = up.min(down);
    let digits = if err > 0.0 && mid != 0.0 {
        let d = mid.abs().log10().floor() - err.log10().floor() + 2.0;
        d.clamp(2.0, 10.0) as usize
    } else {
        4
    };
    let e = |v: f64| {
        if v == 0.0 {
            "0".to_string()
        } else {
            fmt_sig(v, 2)
        }
    };
    [
        format!("{name} = {}", fmt_sig(mid, digits)),
        format!("+{} −{}", e(up), e(down)),
    ]
}

impl CornerFigure {
    fn new(dir: &Path, stem: &str, plot: &CornerPlot<'_>) -> Result<Self, ReportError> {
        let (names, samples) = (plot.names, plot.samples);
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
        check_truth(dir, stem, plot.truth, np)?;
        if let Some(m) = plot.map
            && m.len() != np
        {
            return Err(bad_input(
                dir,
                stem,
                "map",
                format!(
                    "has {} values but names has {np}; give one per parameter",
                    m.len()
                ),
            ));
        }
        if !plot.units.is_empty() && plot.units.len() != np {
            return Err(bad_input(
                dir,
                stem,
                "units",
                format!(
                    "has {} entries but names has {np}; give one per parameter (\"\" for none) \
                     or none at all",
                    plot.units.len()
                ),
            ));
        }
        let n = samples.len() as f64;
        // About √N bins resolve a smooth marginal; the 2-D grid is coarser because its counts
        // are shared among bins² cells.
        let bins1 = (n.sqrt().round() as usize).clamp(10, 50);
        let bins2 = ((n.sqrt() / 2.5).round() as usize).clamp(12, 40);
        let cell = ((style::PAGE_PX - LEFT - RIGHT) / np as u32).clamp(260, 420);
        let finite = |v: &Option<&[f64]>, p: usize| v.map(|t| t[p]).filter(|t| t.is_finite());
        let axes: Vec<Axis> = (0..np)
            .map(|p| {
                let marks = [finite(&plot.truth, p), finite(&plot.map, p)];
                let mut a = Axis::linear_for(
                    samples
                        .iter()
                        .map(|s| s[p])
                        .chain(marks.into_iter().flatten()),
                    4,
                );
                // Half a tick label must fit between a tick and the cell edge.
                a.drop_edge_ticks(1.6 * style::TICK_PX as f64 / cell as f64);
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
        let quantiles = (0..np)
            .map(|p| quantiles_16_50_84(samples.iter().map(|s| s[p])))
            .collect();
        let pairs = (0..np)
            .map(|i| {
                (0..i)
                    .map(|j| pair(samples, (&axes[j], j), (&axes[i], i), bins2))
                    .collect()
            })
            .collect();
        let bad = samples
            .iter()
            .filter(|s| s.iter().any(|v| !v.is_finite()))
            .count();
        let n = samples.len();
        let mut header = format!("{n} sample{}", if n == 1 { "" } else { "s" });
        if bad > 0 {
            header.push_str(&format!(" ({bad} with non-finite values left out)"));
        }
        Ok(CornerFigure {
            header,
            names: names.to_vec(),
            units: if plot.units.is_empty() {
                vec![String::new(); np]
            } else {
                plot.units.to_vec()
            },
            axes,
            truth: plot.truth.map(<[f64]>::to_vec),
            map: plot.map.map(<[f64]>::to_vec),
            marginals,
            quantiles,
            pairs,
            bins2,
            cell,
        })
    }

    fn truth(&self, p: usize) -> Option<f64> {
        self.truth.as_ref().map(|t| t[p]).filter(|t| t.is_finite())
    }

    fn map(&self, p: usize) -> Option<f64> {
        self.map.as_ref().map(|t| t[p]).filter(|t| t.is_finite())
    }

    fn desc(&self, p: usize) -> String {
        self.axes[p].desc_unit(&self.names[p], &self.units[p])
    }

    /// The title under a bottom-row panel in two lines, the quantity and its scale and unit
    /// (`w1sq + 1.3×10⁻⁶` over `[10⁻¹⁰ s⁻²]`), so neighbouring columns' titles never collide.
    fn draw_x_title<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
        ch: &ChartContext<'_, DB, super::plots::Coords>,
        (p, y_lo): (usize, f64),
    ) -> DrawResult<DB> {
        let x = &self.axes[p];
        let d = self.desc(p);
        let lines: Vec<&str> = match d.find(" [") {
            Some(k) => vec![&d[..k], &d[k + 1..]],
            None => vec![d.as_str()],
        };
        let (x0, yb) = ch.backend_coord(&(x.lo, y_lo));
        let (x1, _) = ch.backend_coord(&(x.hi, y_lo));
        let (bx, by) = area.get_base_pixel();
        let cx = (x0 + x1) / 2 - bx;
        let top = yb - by + style::TICK_PX as i32 + 14;
        let st = text(style::LABEL_PX).pos(Pos::new(HPos::Center, VPos::Top));
        for (k, line) in lines.iter().enumerate() {
            area.draw_text(
                line,
                &st,
                (cx, top + k as i32 * (style::LABEL_PX as i32 + 4)),
            )?;
        }
        Ok(())
    }

    /// Legend entries: (label, what to draw).
    fn legend(&self) -> Vec<(&'static str, Mark)> {
        let mut l = vec![
            ("1σ (39 %)", Mark::Region(0)),
            ("2σ (86 %)", Mark::Region(1)),
            ("16, 50, 84 %", Mark::Quantile),
        ];
        if (0..self.axes.len()).any(|p| self.truth(p).is_some()) {
            l.push(("truth", Mark::Truth));
        }
        if (0..self.axes.len()).any(|p| self.map(p).is_some()) {
            l.push(("MAP", Mark::Map));
        }
        l
    }

    fn draw_marginal<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
        p: usize,
        last_row: bool,
        first_col: bool,
    ) -> DrawResult<DB> {
        let (title, area) = area.split_vertically(DIAG_TITLE);
        let lines = quantile_title(&self.names[p], self.quantiles[p]);
        let x_off = if first_col { LEFT as i32 } else { 0 };
        let (w, _) = title.dim_in_pixel();
        let centre = x_off + (w as i32 - x_off) / 2;
        for (k, line) in lines.iter().enumerate() {
            let style = text(style::TICK_PX).pos(Pos::new(HPos::Center, VPos::Top));
            title.draw_text(
                line,
                &style,
                (centre, 2 + k as i32 * (style::TICK_PX as i32 + 5)),
            )?;
        }
        let h = &self.marginals[p];
        let peak = h.iter().copied().fold(0.0, f64::max).max(1.0);
        let mut y = Axis::linear(0.0, peak * 1.05, 3);
        y.lo = 0.0;
        y.ticks.clear();
        let x = &self.axes[p];
        let x_area = if last_row { BOTTOM } else { 0 };
        let y_area = if first_col { LEFT } else { 0 };
        let mut ch = chart(&area, (x, &y), (x_area, y_area), None)?;
        let labels = MeshText {
            x_title: None,
            y_title: None,
            x_labels: last_row,
            y_labels: false,
        };
        mesh(&mut ch, (x, &y), &labels, style::TICK_PX)?;
        if last_row {
            self.draw_x_title(&area, &ch, (p, 0.0))?;
        }
        let w = (x.hi - x.lo) / h.len() as f64;
        let c = style::colour(0);
        let fill = style::tint(c, 0.35).filled();
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
        ch.draw_series(LineSeries::new(step, c.stroke_width(style::THIN_PX)))?;
        if let Some(q) = self.quantiles[p] {
            for v in q {
                ch.draw_series([DashedPathElement::new(
                    [(v, 0.0), (v, y.hi)],
                    6,
                    4,
                    style::colour(0).stroke_width(style::THIN_PX),
                )])?;
            }
        }
        if let Some(t) = self.truth(p) {
            ch.draw_series([PathElement::new(
                [(t, 0.0), (t, y.hi)],
                style::TRUTH.stroke_width(style::THIN_PX),
            )])?;
        }
        if let Some(m) = self.map(p) {
            let (d, g) = style::MAP_DASH;
            ch.draw_series([DashedPathElement::new(
                [(m, 0.0), (m, y.hi)],
                d,
                g,
                style::MAP.stroke_width(style::THIN_PX),
            )])?;
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
            x_title: None,
            y_title: first_col.then(|| self.desc(i)),
            x_labels: last_row,
            y_labels: first_col,
        };
        mesh(&mut ch, (x, y), &labels, style::TICK_PX)?;
        if last_row {
            self.draw_x_title(area, &ch, (j, y.lo))?;
        }
        let pair = &self.pairs[i][j];
        let nb = self.bins2;
        let (wx, wy) = ((x.hi - x.lo) / nb as f64, (y.hi - y.lo) / nb as f64);
        let c = style::colour(0);
        let dot = style::tint(c, 0.6);
        // Thinned for drawing: the tails' shape shows with a few thousand dots.
        let step = pair.dots.len().div_ceil(MAX_DOTS).max(1);
        ch.draw_series(
            pair.dots
                .iter()
                .step_by(step)
                .map(|&p| Circle::new(p, 1, dot.filled())),
        )?;
        if let Some(levels) = pair.levels {
            // Fill the regions on the histogram grid, the 2σ tint first.
            for (k, tint) in [(1, 0.3), (0, 0.6)] {
                let fill = style::tint(c, tint).filled();
                let cells = pair
                    .density
                    .iter()
                    .enumerate()
                    .filter(|(_, d)| **d >= levels[k])
                    .map(|(idx, _)| {
                        let (bx, by) = ((idx % nb) as f64, (idx / nb) as f64);
                        let (x0, y0) = (x.lo + bx * wx, y.lo + by * wy);
                        Rectangle::new([(x0, y0), (x0 + wx, y0 + wy)], fill)
                    });
                ch.draw_series(cells)?;
            }
            // Outlines through the cell centres.
            let to_data = |(gx, gy): (f64, f64)| (x.lo + (gx + 0.5) * wx, y.lo + (gy + 0.5) * wy);
            for level in levels {
                let segs = contour_segments(&pair.density, nb, nb, level);
                ch.draw_series(segs.into_iter().map(|[a, b]| {
                    PathElement::new([to_data(a), to_data(b)], c.stroke_width(style::THIN_PX))
                }))?;
            }
        }
        let (tx, ty) = (self.truth(j), self.truth(i));
        for (v, vertical) in [(tx, true), (ty, false)] {
            if let Some(t) = v {
                let line = if vertical {
                    [(t, y.lo), (t, y.hi)]
                } else {
                    [(x.lo, t), (x.hi, t)]
                };
                ch.draw_series([PathElement::new(
                    line,
                    style::TRUTH.stroke_width(style::THIN_PX),
                )])?;
            }
        }
        let (mx, my) = (self.map(j), self.map(i));
        for (v, vertical) in [(mx, true), (my, false)] {
            if let Some(m) = v {
                let line = if vertical {
                    [(m, y.lo), (m, y.hi)]
                } else {
                    [(x.lo, m), (x.hi, m)]
                };
                let (d, g) = style::MAP_DASH;
                ch.draw_series([DashedPathElement::new(
                    line,
                    d,
                    g,
                    style::MAP.stroke_width(style::THIN_PX),
                )])?;
            }
        }
        if let (Some(a), Some(b)) = (tx, ty) {
            ch.draw_series([
                EmptyElement::at((a, b)) + Polygon::new(star(), style::TRUTH.filled())
            ])?;
        }
        if let (Some(a), Some(b)) = (mx, my) {
            ch.draw_series([
                EmptyElement::at((a, b)) + Polygon::new(diamond(), style::MAP.filled())
            ])?;
        }
        Ok(())
    }

    fn draw_header<DB: DrawingBackend>(&self, area: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        let (w, _) = area.dim_in_pixel();
        let style_left = text(style::TITLE_PX).pos(Pos::new(HPos::Left, VPos::Center));
        area.draw_text(
            &self.header,
            &style_left,
            (LEFT as i32, HEAD_ROW as i32 / 2),
        )?;
        // Legend entries on the next row(s), wrapped to the width.
        let entry_w =
            |s: &str| 46 + (s.chars().count() as f64 * 0.62 * style::LEGEND_PX as f64) as i32 + 24;
        let (mut x0, mut row) = (LEFT as i32, 1);
        for (label, mark) in self.legend() {
            let ew = entry_w(label);
            if x0 + ew > w as i32 && x0 > LEFT as i32 {
                x0 = LEFT as i32;
                row += 1;
            }
            let yc = row * HEAD_ROW as i32 + HEAD_ROW as i32 / 2;
            mark.draw(area, (x0, yc))?;
            let s = text(style::LEGEND_PX).pos(Pos::new(HPos::Left, VPos::Center));
            area.draw_text(label, &s, (x0 + 46, yc))?;
            x0 += ew;
        }
        Ok(())
    }

    /// Header rows: the title and the legend, wrapped to the canvas width.
    fn header_rows(&self) -> u32 {
        let w = self.size_without_header().0 as i32;
        let entry_w =
            |s: &str| 46 + (s.chars().count() as f64 * 0.62 * style::LEGEND_PX as f64) as i32 + 24;
        let (mut x0, mut row) = (LEFT as i32, 1);
        for (label, _) in self.legend() {
            let ew = entry_w(label);
            if x0 + ew > w && x0 > LEFT as i32 {
                x0 = LEFT as i32;
                row += 1;
            }
            x0 += ew;
        }
        row as u32 + 1
    }

    fn size_without_header(&self) -> (u32, u32) {
        let n = self.axes.len() as u32;
        (LEFT + n * self.cell + RIGHT, n * self.cell + BOTTOM)
    }
}

/// A legend mark.
#[derive(Debug, Clone, Copy)]
enum Mark {
    Region(usize),
    Quantile,
    Truth,
    Map,
}

impl Mark {
    fn draw<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
        (x0, yc): (i32, i32),
    ) -> DrawResult<DB> {
        let c = style::colour(0);
        let line = [(x0, yc), (x0 + 36, yc)];
        match *self {
            Mark::Region(k) => {
                let tint = if k == 0 { 0.6 } else { 0.3 };
                area.draw(&Rectangle::new(
                    [(x0, yc - 9), (x0 + 36, yc + 9)],
                    style::tint(c, tint).filled(),
                ))?;
                area.draw(&Rectangle::new(
                    [(x0, yc - 9), (x0 + 36, yc + 9)],
                    c.stroke_width(style::THIN_PX),
                ))
            }
            Mark::Quantile => area.draw(&DashedPathElement::new(
                line,
                6,
                4,
                c.stroke_width(style::THIN_PX),
            )),
            Mark::Truth => {
                area.draw(&PathElement::new(
                    line,
                    style::TRUTH.stroke_width(style::THIN_PX),
                ))?;
                area.draw(
                    &(EmptyElement::at((x0 + 18, yc))
                        + Polygon::new(star(), style::TRUTH.filled())),
                )
            }
            Mark::Map => {
                let (d, g) = style::MAP_DASH;
                area.draw(&DashedPathElement::new(
                    line,
                    d,
                    g,
                    style::MAP.stroke_width(style::THIN_PX),
                ))?;
                area.draw(
                    &(EmptyElement::at((x0 + 18, yc))
                        + Polygon::new(diamond(), style::MAP.filled())),
                )
            }
        }
    }
}

/// A five-pointed star of radius 9 px.
fn star() -> Vec<(i32, i32)> {
    (0..10)
        .map(|k| {
            let r = if k % 2 == 0 { 9.0 } else { 4.0 };
            let a = -std::f64::consts::FRAC_PI_2 + k as f64 * std::f64::consts::PI / 5.0;
            ((r * a.cos()).round() as i32, (r * a.sin()).round() as i32)
        })
        .collect()
}

/// A diamond of half-diagonal 7 px.
fn diamond() -> Vec<(i32, i32)> {
    vec![(0, -7), (7, 0), (0, 7), (-7, 0)]
}

/// The smoothed density of parameters `(x, y)`, its 1σ/2σ levels and the samples outside 2σ.
fn pair(samples: &[Vec<f64>], (ax, j): (&Axis, usize), (ay, i): (&Axis, usize), nb: usize) -> Pair {
    let mut h = vec![0.0; nb * nb];
    let mut inside = Vec::new();
    for s in samples {
        if let (Some(bx), Some(by)) = (bin(s[j], ax, nb), bin(s[i], ay, nb)) {
            h[by * nb + bx] += 1.0;
            inside.push((bx, by, (s[j], s[i])));
        }
    }
    let density = smooth(&h, nb, nb, 1.0);
    // A pair in which either parameter never moves has all its mass in one row or column:
    // a line, not a region, so no contours.
    let occupied_x = (0..nb)
        .filter(|&bx| (0..nb).any(|by| h[by * nb + bx] > 0.0))
        .count();
    let occupied_y = (0..nb)
        .filter(|&by| (0..nb).any(|bx| h[by * nb + bx] > 0.0))
        .count();
    let levels = if occupied_x > 1 && occupied_y > 1 {
        hdr_levels(&density, &SIGMA_MASS).map(|l| [l[0], l[1]])
    } else {
        None
    };
    let outside: Vec<(f64, f64)> = inside
        .iter()
        .filter(|(bx, by, _)| levels.is_none_or(|l| density[by * nb + bx] < l[1]))
        .map(|t| t.2)
        .collect();
    Pair {
        density,
        levels,
        dots: outside,
    }
}

impl Figure for CornerFigure {
    fn size(&self) -> (u32, u32) {
        let (w, h) = self.size_without_header();
        (w, h + self.header_rows() * HEAD_ROW + 6)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        let n = self.axes.len();
        let (head, area) = root.split_vertically(self.header_rows() * HEAD_ROW + 6);
        self.draw_header(&head)?;
        let area = area.margin(0, 0, 0, RIGHT);
        let xs: Vec<u32> = (1..n as u32).map(|k| LEFT + k * self.cell).collect();
        let ys: Vec<u32> = (1..n as u32).map(|k| k * self.cell).collect();
        let cells = area.split_by_breakpoints(xs, ys);
        for (k, cell) in cells.iter().enumerate() {
            let (i, j) = (k / n, k % n);
            let (last_row, first_col) = (i + 1 == n, j == 0);
            // A few pixels between cells keep neighbouring tick labels apart.
            let inner = cell.margin(4, 4, 4, 4);
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

    #[test]
    fn quantile_titles_round_to_the_error() {
        assert_eq!(
            quantile_title("w1sq", Some([-1.30019e-6, -1.29998e-6, -1.29977e-6])),
            [
                "w1sq = -1.29998e-6".to_string(),
                "+2.1e-10 −2.1e-10".to_string()
            ]
        );
        assert_eq!(
            quantile_title("a_df", Some([0.80, 0.8123, 0.83])),
            ["a_df = 0.812".to_string(), "+0.018 −0.012".to_string()]
        );
        // A parameter that never moves; one with no finite value.
        assert_eq!(
            quantile_title("d", Some([4e-4; 3])),
            ["d = 4.000e-4".to_string(), "+0 −0".to_string()]
        );
        assert_eq!(quantile_title("x", None)[1], "no finite values");
    }

    /// Samples of a correlated Gaussian: the 1σ region holds about 39 % of them and the 2σ
    /// region about 86 %, so the dots (outside 2σ) are about 14 %.
    #[test]
    fn pair_regions_hold_their_mass() {
        use rand::SeedableRng;
        use rand_distr::{Distribution, StandardNormal};
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(7);
        let samples: Vec<Vec<f64>> = (0..40_000)
            .map(|_| {
                let (a, b): (f64, f64) = (
                    StandardNormal.sample(&mut rng),
                    StandardNormal.sample(&mut rng),
                );
                vec![a, 0.6 * a + 0.8 * b]
            })
            .collect();
        let ax = Axis::linear_for(samples.iter().map(|s| s[0]), 4);
        let ay = Axis::linear_for(samples.iter().map(|s| s[1]), 4);
        let p = pair(&samples, (&ax, 0), (&ay, 1), 40);
        let l = p.levels.unwrap();
        assert!(l[0] > l[1]);
        let frac = p.dots.len() as f64 / samples.len() as f64;
        assert!((frac - (1.0 - SIGMA_MASS[1])).abs() < 0.03, "{frac}");
        // A constant column gives no contours.
        let flat: Vec<Vec<f64>> = samples.iter().map(|s| vec![s[0], 2.0]).collect();
        let af = Axis::linear_for(flat.iter().map(|s| s[1]), 4);
        assert!(pair(&flat, (&ax, 0), (&af, 1), 40).levels.is_none());
    }
}
