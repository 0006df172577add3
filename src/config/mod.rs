//! The study file (TOML): experiments, injections, true parameters, noise levels, seed and
//! output directory, validated once with errors that name the file, the field and the fix.
//!
//! ```toml
//! seed = 42
//! output = "runs/tn3045"
//! [truth]                      # LTP parameters (default: the paper's Table I)
//! dt1 = 0.2
//! [noise]                      # source ASDs (default: ltp-model.md §5)
//! readout_o1 = 9e-12
//! [simulation]
//! method = "frequency"         # or "time" (discretised loop)
//! noise = "circular"           # or "realistic"
//! target_snr = 1000.0          # optional: scale all injections to this ρ_opt
//! snr_definition = "optimal"    # or "ltpda_stnr" (√2·ρ_opt), "db" (20·log10 ρ_opt)
//! [simulation.actuators]       # true actuators (default: flat, both with gain a_sus)
//! tm1 = { gain = 1.1, pole = 1.963, delay = 0.0 }   # gain default [truth].a_sus
//! tm2 = { pole = 1.963 }       # no gain key: TM2's gain is [truth].a_sus
//! [[experiment]]
//! name = "inv1"
//! design = "tn3045_x1"         # a built-in design; any field below overrides it
//! f1 = { kind = "sine", freq = 0.01, amplitude = 1e-9, duration = 1000.0 }  # force, m s⁻²
//! ```
//!
//! Force injections `f1`, `f2`, `fsc` (commanded force per unit mass on TM1, TM2 and the
//! spacecraft) take the waveform kinds of `x1`/`x12`, are scaled with them by `target_snr` and
//! `amplitude_scale`, and need `method = "frequency"`, as do actuator poles and delays.

pub use crate::experiment::options::{
    Actuator, MAX_AMPLITUDE, Method, NoiseSynthesis, TruthThruster,
};

pub mod budget;
pub mod design;
mod error;
mod generator;
mod limits;
mod load;
mod missing;
mod models;
#[cfg(test)]
mod reference;
mod resolved;
pub mod stretches;
mod study;
mod suggest;
mod sweep;
mod toml_floats;
pub use error::ConfigError;
pub use limits::{DELAY_PARAMS, MAX_ASD, MAX_CORNER, MAX_DELAY, MAX_TARGET_SNR, MIN_ASD};
pub use load::with_select_keys;
pub use models::{
    BUILTIN_LTP, DriftModelEntry, LtpModelEntry, ModelDef, ModelEntry, ModelSet, ModelSpec,
    fmt_point,
};
pub use resolved::{RESOLVED_FILE, resolved_toml, with_run_dir, write_resolved};
pub use study::{
    ActuatorEntry, ActuatorOptions, AnalysisOptions, CrossChecks, DEFAULT_GLITCH_COUNT_ITERATIONS,
    DEFAULT_GLITCH_INDEPENDENCE, ExperimentEntry, FitOptions, GLITCH_ITERATIONS, GLITCH_MAP_STARTS,
    GLITCH_UNTIL, GlitchCountMethod, InjectionEntry, JumpProposal, LikelihoodKind, SelectModel,
    SelectModelEntry, SelectOptions, SimulationOptions, Study, StudyFile, UntilOptions,
};
pub use suggest::closest;
pub use sweep::{MAX_POINTS, MAX_REALISATIONS, Spacing, SweepAxis, SweepOptions};
