//! Trace plots: every parameter and the ln posterior against iteration, one colour per chain,
//! the burn-in marked.

use super::axis::{Axis, decimate, segments};
use super::error::ReportError;
use super::plots::{
    DrawResult, Figure, MeshText, bad_input, chart, check_truth, mesh, render, text, y_label_area,
};
use super::style;
use plotters::coord::Shift;
use plotters::element::DashedPathElement;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::path::Path;

/// Everything a trace plot shows. Build it with a struct literal and `..Default::default()`.
#[derive(Debug, Clone, Copy, Default)]
pub struct TracePlot<'a> {
    /// Parameter names, one per value of a sample.
    pub names: &'a [String],
    /// SI unit per parameter (empty string: dimensionless); an empty slice for none at all.
    pub units: &'a [String],
    /// `chains[c][s][p]`: parameter `p` of draw `s` of chain `c`; chains may differ in length.
    pub chains: &'a [Vec<Vec<f64>>],
    /// `ln_posterior[c][s]` of every draw, drawn in a panel of its own above the parameters;
    /// an empty slice for no such panel.
    pub ln_posterior: &'a [Vec<f64>],
    /// True values, when known (NaN: unknown for that parameter).
    pub truth: Option<&'a [f64]>,
    /// `Some((burn_in, thin))` when the draws are those a sampler kept after `burn_in`
    /// iterations, one every `thin`: draw `k` (from 0) is then plotted at its iteration
    /// `burn_in + (k + 1)·thin`, and the burn-in `[0, burn_in]`, whose draws were not stored,
    /// is shaded. `None` plots against the draw index.
    pub iterations: Option<(usize, usize)>,
}

/// Writes `<dir>/<stem>.png` and `.svg` against the sample index, without ln posterior or
/// burn-in; see [`draw_trace`].
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
    draw_trace(
        dir,
        stem,
        &TracePlot {
            names,
            chains,
            truth,
            ..Default::default()
        },
    )
}

/// Writes `<dir>/<stem>.png` and `.svg`: one panel per parameter, stacked and sharing the
/// iteration axis, under a panel of the ln posterior when given; one colour per chain (the
/// legend above names them, never vermillion or black), the true value as a vermillion line, and with
/// [`TracePlot::iterations`] the burn-in shaded and its end marked by a dashed line.
///
/// Each panel has its own vertical scale; its caption is the axis title with the unit, which
/// factors out a power of ten and, when the spread is tiny next to the value, subtracts a round
/// offset: `w1sq + 1.3×10⁻⁶ [10⁻¹⁰ s⁻²]`. NaN values leave a gap; a parameter without any
/// finite value says so in its panel. Long chains are thinned for drawing to four points per
/// pixel column (first, lowest, highest, last), which keeps every excursion visible.
///
/// Errors ([`ReportError::InvalidInput`]): no names, no samples, a sample whose length is not
/// `names.len()`, `truth` or a non-empty `units` of the wrong length, `ln_posterior` not one
/// value per draw, or `thin = 0`.
///
/// ```
/// use occam::report::{TracePlot, draw_trace};
///
/// let dir = tempfile::tempdir().unwrap();
/// let names = vec!["w1sq".to_string()];
/// let units = vec!["s⁻²".to_string()];
/// let chains: Vec<Vec<Vec<f64>>> = (0..2)
///     .map(|c| (0..300).map(|i| vec![-1.3e-6 + 1e-10 * ((i + 7 * c) as f64 * 0.7).sin()]).collect())
///     .collect();
/// let lp: Vec<Vec<f64>> = chains.iter().map(|c| c.iter().map(|s| -1e20 * (s[0] + 1.3e-6).powi(2)).collect()).collect();
/// draw_trace(dir.path(), "trace", &TracePlot {
///     names: &names, units: &units, chains: &chains, ln_posterior: &lp,
///     truth: Some(&[-1.3e-6]), iterations: Some((1000, 2)),
/// }).unwrap();
/// assert!(dir.path().join("trace.svg").exists());
/// ```
pub fn draw_trace(dir: &Path, stem: &str, plot: &TracePlot<'_>) -> Result<(), ReportError> {
    let fig = TraceFigure::new(dir, stem, plot)?;
    render(dir, stem, &fig)
}

const WIDTH: u32 = style::PAGE_PX;
/// Header rows: title and chain legend.
const HEAD_ROW: u32 = style::LEGEND_PX + 14;
const PANEL_H: u32 = 190;
const X_AREA: u32 = 2 * style::TICK_PX + 22;
/// At most this many chains get a legend entry each.
const LEGEND_CHAINS: usize = 12;

struct Panel {
    desc: String,
    y: Axis,
    /// Per chain, the drawable segments in (iteration, value).
    lines: Vec<Vec<Vec<(f64, f64)>>>,
    truth: Option<f64>,
    empty: bool,
}

struct TraceFigure {
    title: String,
    x: Axis,
    x_title: String,
    panels: Vec<Panel>,
    y_area: u32,
    n_chains: usize,
    /// End of the (unstored) burn-in, when known.
    burn_in: Option<f64>,
}

/// One panel from the values `value(c, s)` of every chain's draws.
fn panel(
    desc: impl Fn(&Axis) -> String,
    lens: &[usize],
    value: impl Fn(usize, usize) -> f64,
    x_of: impl Fn(usize) -> f64,
    x: &Axis,
    truth: Option<f64>,
) -> Panel {
    let buckets = WIDTH as usize - 160;
    let values = lens
        .iter()
        .enumerate()
        .flat_map(|(c, &n)| (0..n).map(move |s| (c, s)))
        .map(|(c, s)| value(c, s));
    let y = Axis::linear_for(values.chain(truth), 4);
    let lines = lens
        .iter()
        .enumerate()
        .map(|(c, &n)| {
            let pts = (0..n).map(|s| {
                let v = value(c, s);
                v.is_finite().then_some((x_of(s), v))
            });
            segments(pts)
                .into_iter()
                .map(|seg| decimate(&seg, (x.lo, x.hi), buckets))
                .collect()
        })
        .collect::<Vec<Vec<_>>>();
    let empty = lines.iter().all(Vec::is_empty);
    Panel {
        desc: desc(&y),
        y,
        lines,
        truth,
        empty,
    }
}

impl TraceFigure {
    fn new(dir: &Path, stem: &str, plot: &TracePlot<'_>) -> Result<Self, ReportError> {
        let (names, chains) = (plot.names, plot.chains);
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
        check_truth(dir, stem, plot.truth, np)?;
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
        let lp = plot.ln_posterior;
        if !lp.is_empty() {
            if lp.len() != chains.len() {
                return Err(bad_input(
                    dir,
                    stem,
                    "ln_posterior",
                    format!(
                        "has {} chains but chains has {}; give one vector per chain",
                        lp.len(),
                        chains.len()
                    ),
                ));
            }
            if let Some(c) = (0..lp.len()).find(|&c| lp[c].len() != chains[c].len()) {
                return Err(bad_input(
                    dir,
                    stem,
                    format!("ln_posterior[{c}]"),
                    format!(
                        "has {} values but chain {c} has {} draws; give one per draw",
                        lp[c].len(),
                        chains[c].len()
                    ),
                ));
            }
        }
        if let Some((_, 0)) = plot.iterations {
            return Err(bad_input(
                dir,
                stem,
                "iterations",
                "has thin = 0; the sampler keeps one draw every thin ≥ 1 iterations",
            ));
        }
        let x_of = |k: usize| match plot.iterations {
            Some((b, t)) => (b + (k + 1) * t) as f64,
            None => k as f64,
        };
        let (mut x, x_title) = match plot.iterations {
            Some(_) => (Axis::linear(0.0, x_of(longest - 1), 8), "iteration"),
            None => (Axis::linear(0.0, (longest - 1) as f64, 8), "sample index"),
        };
        // Iterations start at 0: no padding to the left of the first one.
        if plot.iterations.is_some() {
            x.lo = 0.0;
            x.ticks.retain(|t| *t >= 0.0);
        }
        let lens: Vec<usize> = chains.iter().map(Vec::len).collect();
        let unit = |p: usize| plot.units.get(p).map_or("", String::as_str);
        let mut panels = Vec::new();
        if !lp.is_empty() {
            panels.push(panel(
                |y| y.desc_unit("ln posterior", ""),
                &lens,
                |c, s| lp[c][s],
                x_of,
                &x,
                None,
            ));
        }
        for p in 0..np {
            let t = plot.truth.map(|t| t[p]).filter(|t| t.is_finite());
            panels.push(panel(
                |y| y.desc_unit(&names[p], unit(p)),
                &lens,
                |c, s| chains[c][s][p],
                x_of,
                &x,
                t,
            ));
        }
        let y_area = panels
            .iter()
            .map(|p| y_label_area(&p.y, false))
            .max()
            .unwrap_or(60);
        let samples = if chains.iter().all(|c| c.len() == longest) {
            format!("{longest} draws each")
        } else {
            format!("up to {longest} draws")
        };
        let n = chains.len();
        let mut title = format!("{n} chain{}, {samples}", if n == 1 { "" } else { "s" });
        if let Some((b, t)) = plot.iterations {
            title.push_str(&format!("; burn-in {b} (shaded, not stored), thin {t}"));
        }
        Ok(TraceFigure {
            title,
            x,
            x_title: x_title.to_string(),
            panels,
            y_area,
            n_chains: n,
            burn_in: plot.iterations.map(|(b, _)| b as f64),
        })
    }

    /// Legend entries: one per chain (up to [`LEGEND_CHAINS`]) and the truth.
    fn legend(&self) -> Vec<(String, Option<usize>)> {
        let mut l: Vec<(String, Option<usize>)> = if self.n_chains > 1 {
            (0..self.n_chains.min(LEGEND_CHAINS))
                .map(|c| (format!("chain {}", c + 1), Some(c)))
                .collect()
        } else {
            Vec::new()
        };
        if self.panels.iter().any(|p| p.truth.is_some()) {
            l.push(("truth".to_string(), None));
        }
        l
    }

    fn legend_rows(&self) -> Vec<Vec<(String, Option<usize>)>> {
        let entry =
            |s: &str| 46 + (s.chars().count() as f64 * 0.62 * style::LEGEND_PX as f64) as u32 + 24;
        let mut rows: Vec<Vec<(String, Option<usize>)>> = Vec::new();
        let mut used = WIDTH;
        for e in self.legend() {
            let w = entry(&e.0);
            if used + w > WIDTH - 40 {
                rows.push(Vec::new());
                used = self.y_area;
            }
            used += w;
            rows.last_mut().expect("pushed above").push(e);
        }
        rows
    }

    fn head_h(&self) -> u32 {
        HEAD_ROW * (1 + self.legend_rows().len() as u32) + 4
    }
}

impl Figure for TraceFigure {
    fn size(&self) -> (u32, u32) {
        let n = self.panels.len() as u32;
        (WIDTH, self.head_h() + n * PANEL_H + X_AREA + 10)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        let (head, area) = root.split_vertically(self.head_h());
        let left = self.y_area as i32 + 10;
        let st = text(style::TITLE_PX).pos(Pos::new(HPos::Left, VPos::Center));
        head.draw_text(&self.title, &st, (left, HEAD_ROW as i32 / 2))?;
        for (r, row) in self.legend_rows().iter().enumerate() {
            let yc = (HEAD_ROW * (r as u32 + 1) + HEAD_ROW / 2) as i32;
            let mut x0 = left;
            for (label, chain) in row {
                let line = [(x0, yc), (x0 + 36, yc)];
                match chain {
                    Some(c) => head.draw(&PathElement::new(
                        line,
                        style::chain_colour(*c).stroke_width(style::LINE_PX),
                    ))?,
                    None => head.draw(&PathElement::new(
                        line,
                        style::TRUTH.stroke_width(style::LINE_PX),
                    ))?,
                }
                let s = text(style::LEGEND_PX).pos(Pos::new(HPos::Left, VPos::Center));
                head.draw_text(label, &s, (x0 + 46, yc))?;
                x0 += 46
                    + (label.chars().count() as f64 * 0.62 * style::LEGEND_PX as f64) as i32
                    + 24;
            }
        }
        let area = area.margin(0, 10, 10, 30);
        let n = self.panels.len();
        let breaks: Vec<u32> = (1..n as u32).map(|i| i * PANEL_H).collect();
        let rows = area.split_by_breakpoints([] as [u32; 0], breaks);
        let stroke = if self.n_chains > 2 {
            style::HAIR_PX
        } else {
            style::THIN_PX - 1
        }
        .max(1);
        for (i, (panel, row)) in self.panels.iter().zip(&rows).enumerate() {
            let last = i + 1 == n;
            let axes = (&self.x, &panel.y);
            let x_area = if last { X_AREA } else { 0 };
            let mut ch = chart(
                row,
                axes,
                (x_area, self.y_area),
                Some((&panel.desc, style::TICK_PX)),
            )?;
            if let Some(b) = self.burn_in {
                ch.draw_series([Rectangle::new(
                    [(self.x.lo, panel.y.lo), (b.min(self.x.hi), panel.y.hi)],
                    style::BURN_IN.filled(),
                )])?;
            }
            let labels = MeshText {
                x_title: last.then(|| self.x.desc(&self.x_title)),
                y_title: None,
                x_labels: last,
                y_labels: true,
            };
            mesh(&mut ch, axes, &labels, style::TICK_PX)?;
            if let Some(b) = self.burn_in {
                ch.draw_series([DashedPathElement::new(
                    [(b, panel.y.lo), (b, panel.y.hi)],
                    8,
                    5,
                    style::REFERENCE.stroke_width(style::THIN_PX),
                )])?;
                if i == 0 {
                    // Name the shaded region where it is wide enough for the words.
                    let (x0, _) = ch.backend_coord(&(self.x.lo, panel.y.hi));
                    let (x1, yt) = ch.backend_coord(&(b, panel.y.hi));
                    let label = "burn-in";
                    if (x1 - x0) as f64 > label.len() as f64 * 0.62 * style::NOTE_PX as f64 + 12.0 {
                        let s = text(style::NOTE_PX)
                            .color(&style::MUTED)
                            .pos(Pos::new(HPos::Center, VPos::Top));
                        root.draw_text(label, &s, ((x0 + x1) / 2, yt + 6 + self.head_h() as i32))?;
                    }
                }
            }
            for (c, chain) in panel.lines.iter().enumerate() {
                let colour = style::chain_colour(c).stroke_width(stroke);
                for seg in chain {
                    ch.draw_series(LineSeries::new(seg.iter().copied(), colour))?;
                }
            }
            if let Some(t) = panel.truth {
                ch.draw_series([PathElement::new(
                    [(self.x.lo, t), (self.x.hi, t)],
                    style::TRUTH.stroke_width(style::THIN_PX),
                )])?;
            }
            if panel.empty {
                let mid = (
                    (self.x.lo + self.x.hi) / 2.0,
                    (panel.y.lo + panel.y.hi) / 2.0,
                );
                let style = text(style::NOTE_PX).pos(Pos::new(HPos::Center, VPos::Center));
                ch.draw_series([Text::new("no finite values", mid, style)])?;
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kept_draws_sit_at_their_iteration() {
        let names = vec!["a".to_string()];
        let chains = vec![vec![vec![1.0], vec![2.0], vec![f64::NAN], vec![4.0]]];
        let lp = vec![vec![-1.0, -2.0, f64::NEG_INFINITY, -3.0]];
        let d = std::path::Path::new("/nonexistent");
        let fig = TraceFigure::new(
            d,
            "t",
            &TracePlot {
                names: &names,
                chains: &chains,
                ln_posterior: &lp,
                iterations: Some((100, 10)),
                ..Default::default()
            },
        )
        .unwrap();
        // ln posterior first, then the parameter; draw k at 100 + (k + 1)·10; NaN splits.
        assert_eq!(fig.panels.len(), 2);
        assert_eq!(
            fig.panels[1].lines[0],
            vec![vec![(110.0, 1.0), (120.0, 2.0)], vec![(140.0, 4.0)]]
        );
        assert_eq!(fig.panels[0].lines[0][0][0], (110.0, -1.0));
        assert_eq!(fig.burn_in, Some(100.0));
        assert_eq!(fig.x.lo, 0.0);
        assert!(fig.x.hi >= 140.0);
    }
}
