//! `[design]`: the schema of `occam design`'s budget and search (checked against the study
//! by the design job, `crate::jobs::design`).

use serde::{Deserialize, Serialize};

/// Candidate frequencies: a list (Hz) or a log-spaced grid.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Candidates {
    List(Vec<f64>),
    LogGrid { from: f64, to: f64, points: usize },
}

impl Candidates {
    /// The frequencies (Hz), ascending for a grid.
    pub fn freqs(&self) -> Vec<f64> {
        match self {
            Candidates::List(v) => v.clone(),
            Candidates::LogGrid { from, to, points } => {
                if *points == 1 {
                    return vec![*from];
                }
                let (a, b) = (from.ln(), to.ln());
                (0..*points)
                    .map(|k| (a + (b - a) * k as f64 / (*points - 1) as f64).exp())
                    .collect()
            }
        }
    }
}

/// What the chosen design is compared with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Baseline {
    /// The TN3045 ladder (ltp-model.md §6.1) under the same budget.
    #[default]
    Tn3045,
}

fn default_channels() -> Vec<String> {
    vec!["x1".into(), "x12".into()]
}

/// Most candidate frequencies of a `{ from, to, points }` grid: each is scored for each
/// segment in each pass, so 10 000 is already hours of search.
pub const MAX_CANDIDATES: usize = 10_000;

/// `[design]`: the budget and the search. Keys:
/// * `true_model`: the `[[select.model]]` name that generated the data (required);
/// * `channels`: guidance channels, one experiment each (default `["x1", "x12"]`);
/// * `candidates`: frequencies in Hz, a list or `{ from, to, points }` log-spaced;
/// * `segments` (default 7), `segment_duration` (s, default 1200), `gap` (s, default 120);
/// * `amplitude`: the largest amplitude of a segment (m, default 1e-6);
/// * `max_accel`: optional cap on the commanded acceleration (m s⁻²): a segment at `f` gets at
///   most `max_accel / (2πf)²`;
/// * `allow_repeat`: whether a channel may use one frequency twice (default false);
/// * `max_passes`: coordinate-exchange passes (default 3);
/// * `realisations`: noise realisations of `--validate` when the flag gives no number (default 16);
/// * `baseline`: `"tn3045"`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DesignOptions {
    pub true_model: String,
    #[serde(default = "default_channels")]
    pub channels: Vec<String>,
    pub candidates: Candidates,
    #[serde(default = "d_segments")]
    pub segments: usize,
    #[serde(default = "d_duration")]
    pub segment_duration: f64,
    #[serde(default = "d_gap")]
    pub gap: f64,
    #[serde(default = "d_amplitude")]
    pub amplitude: f64,
    #[serde(default)]
    pub max_accel: Option<f64>,
    #[serde(default)]
    pub allow_repeat: bool,
    #[serde(default = "d_passes")]
    pub max_passes: usize,
    #[serde(default = "d_realisations")]
    pub realisations: usize,
    #[serde(default)]
    pub baseline: Baseline,
}

fn d_segments() -> usize {
    7
}
fn d_duration() -> f64 {
    1200.0
}
fn d_gap() -> f64 {
    120.0
}
fn d_amplitude() -> f64 {
    1e-6
}
fn d_passes() -> usize {
    3
}
fn d_realisations() -> usize {
    16
}
