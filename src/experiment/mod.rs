//! System-identification experiments (ltp-model.md §6): injection waveforms, experiment
//! designs with padding and a noise-only stretch, and their simulation.

mod commanded;
mod design;
mod gaps;
mod generator;
mod glitches;
mod model_sim;
pub mod options;
pub mod pair;
mod run;
mod simulate;
mod snr_definition;
mod streams;
mod waveform;

pub use commanded::{AGREEMENT, fill_commanded};
pub use design::{ExperimentDesign, FORCE_CHANNELS, ladder_freqs};
pub use gaps::RandomGaps;
pub use generator::{Channels, Generator};
pub use glitches::{Glitch, GlitchTarget, MAX_GLITCHES, RandomGlitches};
pub use run::{simulate, simulate_observed};
pub use simulate::{
    SimError, SimProgress, Simulation, SimulationPlan, System, TELEMETRY_CHANNELS,
    delayed_injections, optimal_snr, stream,
};
pub use snr_definition::SnrDefinition;
pub use waveform::{SineSegment, Waveform};
