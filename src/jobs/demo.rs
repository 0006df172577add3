//! `occam demo`: the paper's guidance-delay investigation (K14 §III.B, 7- against 5-parameter
//! model, data with Δt1 = Δt2 = 0) in its competitive and its non-competitive regime, from the
//! built-in copies of `examples/guidance-delays*.toml`; each runs as `occam select`
//! ([`super::select::Select`]) into its own directory.

use crate::config::Study;
use std::path::Path;

/// The demo's studies: (directory name, study text).
pub const STUDIES: [(&str, &str); 2] = [
    (
        "competitive",
        include_str!("../../examples/guidance-delays.toml"),
    ),
    (
        "high-snr",
        include_str!("../../examples/guidance-delays-high-snr.toml"),
    ),
];

/// The demo's studies, loaded: (directory name, study).
pub fn studies() -> anyhow::Result<Vec<(&'static str, Study)>> {
    STUDIES
        .iter()
        .map(|(name, text)| {
            let label = format!("built-in study `{name}` (examples/guidance-delays*.toml)");
            Ok((*name, Study::from_toml(text, &label, Path::new("."))?))
        })
        .collect()
}
