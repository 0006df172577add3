//! System-identification experiments (ltp-model.md §6): injection waveforms, experiment
//! designs with padding and a noise-only stretch, and their simulation.

mod design;
mod model_sim;
pub mod options;
mod simulate;
mod waveform;

pub use design::{ExperimentDesign, FORCE_CHANNELS, ladder_freqs};
pub use model_sim::{Channels, Generator};
pub use simulate::{
    SimError, SimProgress, Simulation, SimulationPlan, System, TELEMETRY_CHANNELS,
    delayed_injections, optimal_snr, simulate, simulate_observed, stream,
};
pub use waveform::{SineSegment, Waveform};
