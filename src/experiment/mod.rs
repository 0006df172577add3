//! System-identification experiments (ltp-model.md §6): injection waveforms, experiment
//! designs with padding and a noise-only stretch, and their simulation.

mod design;
mod waveform;

pub use design::{ExperimentDesign, ladder_freqs};
pub use waveform::{SineSegment, Waveform};
