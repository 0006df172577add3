//! Reports: plots (PNG and SVG) and text tables from plain numbers.
//!
//! This module knows nothing about samplers or models: callers hand it names, sample arrays
//! and `(x, y)` series. Every figure takes its palette, line widths, markers and type sizes
//! from one style (Okabe–Ito colours, text ≥ 8 pt at print width; see `style.rs`). Every plot is written twice, `<stem>.png` and `<stem>.svg`, each
//! atomically (rendered to a hidden temporary file in the same directory, then renamed), so
//! an interrupted run never leaves a half-drawn figure behind.
//!
//! Axis labels cope with parameters of very different scales (a stiffness of
//! `-1.3×10⁻⁶ s⁻²` next to a gain of `0.8`): every axis gets its own power-of-ten factor, and
//! when the spread is tiny compared with the value a round offset is subtracted, the axis
//! being described as `(name + 1.300×10⁻⁶) / 10⁻¹⁰` (see [`trace_plot`]).
//!
//! ```
//! use occam::report::{Table, fmt_pm, kass_raftery};
//!
//! let mut t = Table::new(["Method", "ln B_XY", "evidence"]);
//! t.push_row(["RJMCMC", "-1.17", kass_raftery(-1.17)]).unwrap();
//! assert!(t.to_markdown().starts_with("| Method |"));
//! assert_eq!(fmt_pm(-1.29998e-6, 2.1e-10), "(-1.29998 ± 0.00021)e-6");
//! ```

mod axis;
mod bands;
mod bars;
pub mod bode;
mod contour;
mod corner;
mod error;
mod lines;
mod plots;
pub mod raw;
pub mod residual_psd;
mod running;
mod style;
mod table;
#[cfg(test)]
mod tests;
mod trace;
mod warnings;

pub use crate::numfmt::{
    fmt_bayes_factor, fmt_fixed, fmt_pm, fmt_roundtrip, fmt_short, fmt_short_sig, fmt_sig,
    kass_raftery, kass_raftery_named,
};
pub use bands::{BandPlot, BandSeries, HeatMap, band_plot, heat_map, sign_note};
pub use bars::model_histogram;
pub use corner::{CornerPlot, corner_plot, draw_corner};
pub use error::ReportError;
pub use lines::{LinePlot, bayes_factor_evolution, line_plot};
pub use running::{RunningSeries, running_bayes_factor};
pub use table::Table;
pub use trace::{TracePlot, draw_trace, trace_plot};
pub use warnings::{group_run_warnings, group_warnings};
