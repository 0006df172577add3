//! Bar chart of how often each model was visited (the paper's Fig. 4).

use super::axis::Axis;
use super::error::ReportError;
use super::plots::{DrawResult, Figure, bad_input, chart, render, text, y_label_area};
use super::style;
use crate::numfmt::format::fmt_sig;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::FontTransform;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::path::Path;

/// Writes `<dir>/<stem>.png` and `.svg`: one bar per model, its height the fraction of all
/// visits (`counts[k] / Σ counts`, so raw iteration counts and probabilities plot alike),
/// the fraction printed above each bar when there are at most 25 models. Long labels are
/// turned vertical.
///
/// Errors ([`ReportError::InvalidInput`]): no models, `labels` and `counts` of different
/// lengths, a negative or non-finite count, or all counts zero.
///
/// ```
/// use occam::report::model_histogram;
///
/// let dir = tempfile::tempdir().unwrap();
/// let labels: Vec<String> = (3..=7).map(|k| format!("{k}-D")).collect();
/// model_histogram(dir.path(), "models", &labels, &[120.0, 900.0, 7400.0, 1400.0, 180.0]).unwrap();
/// assert!(dir.path().join("models.png").exists());
/// ```
pub fn model_histogram(
    dir: &Path,
    stem: &str,
    labels: &[String],
    counts: &[f64],
) -> Result<(), ReportError> {
    let fig = BarFigure::new(dir, stem, labels, counts)?;
    render(dir, stem, &fig)
}

const HEIGHT: u32 = 480;
const LABEL_LIMIT: usize = 25;
/// DejaVu Sans at the tick size: about 0.6 em per character.
const CHAR_PX: u32 = style::TICK_PX * 6 / 10;

struct BarFigure {
    labels: Vec<String>,
    fractions: Vec<f64>,
    total: f64,
    y: Axis,
    width: u32,
    vertical_labels: bool,
}

impl BarFigure {
    fn new(dir: &Path, stem: &str, labels: &[String], counts: &[f64]) -> Result<Self, ReportError> {
        if counts.is_empty() {
            return Err(bad_input(
                dir,
                stem,
                "counts",
                "is empty; give one count per model",
            ));
        }
        if labels.len() != counts.len() {
            return Err(bad_input(
                dir,
                stem,
                "labels",
                format!(
                    "has {} entries but counts has {}; give one label per model",
                    labels.len(),
                    counts.len()
                ),
            ));
        }
        if let Some(k) = counts.iter().position(|c| !(c.is_finite() && *c >= 0.0)) {
            return Err(bad_input(
                dir,
                stem,
                format!("counts[{k}]"),
                format!("is {}; counts must be finite and ≥ 0", counts[k]),
            ));
        }
        let total: f64 = counts.iter().sum();
        if total <= 0.0 {
            return Err(bad_input(
                dir,
                stem,
                "counts",
                "are all zero; nothing to plot",
            ));
        }
        let fractions: Vec<f64> = counts.iter().map(|c| c / total).collect();
        let peak = fractions.iter().copied().fold(0.0, f64::max);
        // Head room for the value printed above the tallest bar.
        let mut y = Axis::linear(0.0, peak * 1.12, 6);
        y.lo = 0.0;
        y.ticks.retain(|t| *t >= 0.0);
        let n = counts.len() as u32;
        let width = (n * 70 + 160).clamp(style::COLUMN_PX, 2400);
        let slot = (width - 160) / n;
        let longest = labels.iter().map(|l| l.chars().count()).max().unwrap_or(0) as u32;
        Ok(BarFigure {
            labels: labels.to_vec(),
            fractions,
            total,
            y,
            width,
            vertical_labels: longest * CHAR_PX + 6 > slot,
        })
    }
}

impl Figure for BarFigure {
    fn size(&self) -> (u32, u32) {
        let longest = self
            .labels
            .iter()
            .map(|l| l.chars().count())
            .max()
            .unwrap_or(0) as u32;
        let extra = if self.vertical_labels {
            longest * CHAR_PX
        } else {
            0
        };
        (self.width, HEIGHT + extra)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        let total = if self.total.fract() == 0.0 && self.total < 1e15 {
            format!("{:.0}", self.total)
        } else {
            fmt_sig(self.total, 6)
        };
        let title = format!("Model visits ({total} in total)");
        let (title, style) = super::plots::fitted_title(root, &title);
        let area = root.titled(&title, style)?.margin(5, 10, 10, 20);
        let n = self.fractions.len();
        let mut x = Axis::linear(0.0, 1.0, 1);
        x.lo = -0.5;
        x.hi = n as f64 - 0.5;
        x.ticks = (0..n).map(|k| k as f64).collect();
        let longest = self
            .labels
            .iter()
            .map(|l| l.chars().count())
            .max()
            .unwrap_or(0) as u32;
        let x_area = if self.vertical_labels {
            longest * CHAR_PX + style::LABEL_PX + 30
        } else {
            style::TICK_PX + style::LABEL_PX + 20
        };
        let mut ch = chart(
            &area,
            (&x, &self.y),
            (x_area, y_label_area(&self.y, true)),
            None,
        )?;
        // plotters misplaces rotated tick labels, so vertical ones are drawn by hand below.
        let label_of = |v: &f64| {
            let k = v.round();
            if self.vertical_labels || (v - k).abs() > 1e-9 || k < 0.0 {
                String::new()
            } else {
                self.labels.get(k as usize).cloned().unwrap_or_default()
            }
        };
        let y_label = |v: &f64| self.y.label(*v);
        ch.configure_mesh()
            .disable_x_mesh()
            .x_label_formatter(&label_of)
            .y_label_formatter(&y_label)
            .label_style(text(style::TICK_PX))
            .axis_desc_style(text(style::LABEL_PX))
            .bold_line_style(style::GRID)
            .axis_style(style::AXIS)
            .x_desc("model")
            .y_desc(self.y.desc("fraction of visits"))
            .draw()?;
        let fill = style::colour(0).filled();
        ch.draw_series(self.fractions.iter().enumerate().map(|(k, &f)| {
            let k = k as f64;
            Rectangle::new([(k - 0.38, 0.0), (k + 0.38, f)], fill)
        }))?;
        if self.vertical_labels {
            let st = text(style::TICK_PX)
                .transform(FontTransform::Rotate90)
                .pos(Pos::new(HPos::Left, VPos::Center));
            for (k, label) in self.labels.iter().enumerate() {
                let (px, py) = ch.backend_coord(&(k as f64, self.y.lo));
                root.draw_text(label, &st, (px, py + 10))?;
            }
        }
        if n <= LABEL_LIMIT {
            let st = text(style::NOTE_PX).pos(Pos::new(HPos::Center, VPos::Bottom));
            ch.draw_series(
                self.fractions
                    .iter()
                    .enumerate()
                    .map(|(k, &f)| Text::new(trim_zeros(fmt_sig(f, 3)), (k as f64, f), st.clone())),
            )?;
        }
        Ok(())
    }
}

/// `0.0900` → `0.09`: the trailing zeros of a 3-significant-digit fraction are noise on a bar.
fn trim_zeros(s: String) -> String {
    if s.contains('.') && !s.contains('e') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}
