//! The study's types: [`StudyFile`] as parsed from TOML (serde's defaults filled in), its
//! option tables, and the validated [`Study`]. Validation is in `load.rs`.

use super::design;
use super::error::ConfigError;
use super::limits::{check_delay, finite_pos};
use super::models::{ModelSet, ModelSpec};
use super::sweep::SweepOptions;
use crate::experiment::options::{Actuator, Method, NoiseSynthesis, TruthThruster};
use crate::experiment::{ExperimentDesign, SineSegment, SnrDefinition};
use crate::ltp::{Controllers, LtpParams, Masses, NoiseModel};
use crate::prior::PriorKind;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// `[simulation]` options.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SimulationOptions {
    /// A thruster response of the simulated system (default none): the truth of the
    /// thruster-response models (`[[model]] kind = "ltp"`, `thruster = "delay" | "pole"`).
    pub thruster: Option<TruthThruster>,
    pub method: Method,
    pub noise: NoiseSynthesis,
    /// If set, every injection amplitude is scaled by one common factor so that the optimal
    /// SNR ρ_opt = √⟨h|h⟩ of the whole study (all experiments, `snr_band`) equals this — read
    /// on the scale `snr_definition` names.
    pub target_snr: Option<f64>,
    /// The scale `target_snr` is written in: `"optimal"` (ρ_opt, the default), `"ltpda_stnr"`
    /// (√2·ρ_opt) or `"db"` (20·log10 ρ_opt).
    #[serde(skip_serializing_if = "SnrDefinition::is_default")]
    pub snr_definition: SnrDefinition,
    /// Band (Hz) over which ρ_opt is computed: exactly two numbers `[lo, hi]` with
    /// `0 < lo < hi ≤` the Nyquist frequency of every simulated experiment. The default
    /// `[1e-4, 1.0]` is clipped to each experiment's Nyquist frequency instead.
    #[serde(deserialize_with = "two_numbers")]
    pub snr_band: [f64; 2],
    /// `method = "time"` only: run the discretised loop at `oversample × fs` and keep every
    /// `oversample`-th output sample. 1 is the real 10 Hz loop; its zero-order hold lags by half a
    /// sample, which puts it 3.3e−3 from the continuous model at 10 mHz; 10 brings that to
    /// 3.3e−4.
    pub oversample: usize,
    /// `[simulation.actuators]`: the true capacitive actuators of the two test masses (default:
    /// flat, both with the gain `[truth].a_sus`, which is the system of K14).
    #[serde(skip_serializing_if = "ActuatorOptions::is_default")]
    pub actuators: ActuatorOptions,
    /// Generate the data with this `[[model]]` (by name) and its own noise instead of the
    /// built-in LTP loop: its read-outs (the residual channels it reads) are simulated from
    /// the injections on its other channels (`[experiment.inject]`, `x1` → `i1`, …).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub model: Option<String>,
    /// `[simulation.truth]`: the true value of every parameter of `model`, by name.
    #[serde(skip_serializing_if = "std::collections::BTreeMap::is_empty")]
    pub truth: std::collections::BTreeMap<String, f64>,
    /// `[simulation.gaps]`: random gaps in every stretch of every simulated experiment.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gaps: Option<crate::experiment::RandomGaps>,
    /// `[simulation.glitches]`: random force glitches in every simulated experiment (not
    /// written into any channel; recorded in the dataset's metadata).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub glitches: Option<crate::experiment::RandomGlitches>,
}

/// One test mass's actuator as written in `[simulation.actuators]`:
/// `tm1 = { gain = 1.08, pole = 1.963, delay = 0.0 }`, `tm2 = { pole = 1.963 }`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields, default)]
pub struct ActuatorEntry {
    /// DC gain (TM1 only; absent: `[truth].a_sus`, symmetric actuators). TM2's gain is the
    /// closed loop's `[truth].a_sus` and cannot be set here.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gain: Option<f64>,
    /// Frequency (Hz) of a single real pole `1/(1 + i f/f_o)` with unity DC gain; absent: none.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pole: Option<f64>,
    /// Delay τ (s) between the commanded and the applied force, `e^{−i2πfτ}`; default 0.
    pub delay: f64,
}

/// `[simulation.actuators]`: the true actuators of TM1 and TM2.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields, default)]
pub struct ActuatorOptions {
    pub tm1: ActuatorEntry,
    pub tm2: ActuatorEntry,
}

impl ActuatorOptions {
    /// Whether nothing is set (today's system: flat actuators with gain `a_sus`).
    pub fn is_default(&self) -> bool {
        *self == Self::default()
    }

    /// Whether either actuator has a pole or a delay (dynamics beyond a gain).
    pub fn has_dynamics(&self) -> bool {
        [self.tm1, self.tm2]
            .iter()
            .any(|a| a.pole.is_some() || a.delay != 0.0)
    }

    /// The actuators `[TM1, TM2]` of a system whose suspension gain is `a_sus`.
    pub fn resolve(&self, a_sus: f64) -> [Actuator; 2] {
        [
            Actuator {
                gain: self.tm1.gain.unwrap_or(a_sus),
                pole: self.tm1.pole,
                delay: self.tm1.delay,
            },
            Actuator {
                gain: a_sus,
                pole: self.tm2.pole,
                delay: self.tm2.delay,
            },
        ]
    }

    pub(super) fn validate(&self, method: Method, file: &str) -> Result<(), ConfigError> {
        let bad = |field: &str, msg: String| ConfigError::Invalid {
            file: file.into(),
            field: format!("simulation.actuators.{field}"),
            msg,
        };
        if let Some(g) = self.tm2.gain {
            return Err(bad(
                "tm2.gain",
                format!(
                    "TM2's actuator gain is the closed loop's suspension gain [truth].a_sus: set a_sus there and remove `gain = {g}` here (only tm1 takes a gain, for A1 ≠ A2)"
                ),
            ));
        }
        for (tm, a) in [("tm1", &self.tm1), ("tm2", &self.tm2)] {
            if let Some(g) = a.gain
                && !finite_pos(g)
            {
                return Err(bad(
                    &format!("{tm}.gain"),
                    format!("must be a finite gain > 0 (got {g})"),
                ));
            }
            if let Some(p) = a.pole
                && !finite_pos(p)
            {
                return Err(bad(
                    &format!("{tm}.pole"),
                    format!(
                        "must be a finite pole frequency > 0 Hz (got {p}); leave it out for no pole"
                    ),
                ));
            }
            check_delay(a.delay).map_err(|m| bad(&format!("{tm}.delay"), m))?;
            if method == Method::Time {
                let field = if a.pole.is_some() {
                    Some("pole")
                } else if a.delay != 0.0 {
                    Some("delay")
                } else {
                    None
                };
                if let Some(f) = field {
                    return Err(bad(
                        &format!("{tm}.{f}"),
                        "an actuator pole or delay is supported with method = \"frequency\" only (the discretised loop of method = \"time\" has flat actuators)".into(),
                    ));
                }
            }
        }
        Ok(())
    }
}

impl Default for SimulationOptions {
    fn default() -> Self {
        Self {
            thruster: None,
            oversample: 1,
            method: Method::Frequency,
            noise: NoiseSynthesis::Circular,
            target_snr: None,
            snr_definition: SnrDefinition::Optimal,
            snr_band: [1e-4, 1.0],
            actuators: ActuatorOptions::default(),
            model: None,
            truth: Default::default(),
            gaps: None,
            glitches: None,
        }
    }
}

/// An injection as written in the study file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum InjectionEntry {
    /// No injection. A struct variant, not a unit one: serde lets a unit variant of a tagged
    /// enum ignore every other key, so `{ kind = "none", amplitude = 1e-6 }` was accepted.
    None {},
    SineTrain {
        segments: Vec<SineSegment>,
        #[serde(default)]
        gap: f64,
    },
    Sine {
        freq: f64,
        amplitude: f64,
        duration: f64,
    },
    /// A one-column (or named-column) CSV file of samples at the experiment's `fs`: metres on
    /// `x1`, `x12`; m s⁻² on the force channels `f1`, `f2`, `fsc`.
    File {
        path: PathBuf,
        #[serde(default)]
        column: Option<String>,
    },
}

/// One `[[experiment]]` table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExperimentEntry {
    pub name: String,
    /// A built-in design to start from (`tn3045_x1`, `tn3045_x12`).
    #[serde(default)]
    pub design: Option<String>,
    #[serde(default)]
    pub fs: Option<f64>,
    #[serde(default)]
    pub pre_pad: Option<f64>,
    #[serde(default)]
    pub post_pad: Option<f64>,
    #[serde(default)]
    pub noise_duration: Option<f64>,
    #[serde(default)]
    pub x1: Option<InjectionEntry>,
    #[serde(default)]
    pub x12: Option<InjectionEntry>,
    /// Commanded force per unit mass injected on TM1 (m s⁻²; `method = "frequency"` only).
    #[serde(default)]
    pub f1: Option<InjectionEntry>,
    /// Commanded force per unit mass injected on TM2 (m s⁻²; `method = "frequency"` only).
    #[serde(default)]
    pub f2: Option<InjectionEntry>,
    /// Commanded force per unit mass injected on the spacecraft (m s⁻²; `method = "frequency"`
    /// only).
    #[serde(default)]
    pub fsc: Option<InjectionEntry>,
    /// `[experiment.inject]`: injections on named input channels of the `[simulation] model`
    /// (`u_x = { kind = "sine", … }`), in the channel's unit.
    #[serde(default, skip_serializing_if = "std::collections::BTreeMap::is_empty")]
    pub inject: std::collections::BTreeMap<String, InjectionEntry>,
    /// Multiplies every amplitude of this experiment.
    #[serde(default)]
    pub amplitude_scale: Option<f64>,
    /// Read the experiment's data from this `.csv` or `.npz` file (relative to the study
    /// file) instead of simulating it; see [`crate::data::DataSource`].
    #[serde(default)]
    pub data: Option<PathBuf>,
    /// Channel → column header / array name of `data` (default: the channel's own name).
    #[serde(default)]
    pub columns: std::collections::BTreeMap<String, String>,
    /// A noise-only stretch for the Welch noise estimate (same column map).
    #[serde(default)]
    pub noise_data: Option<PathBuf>,
    /// Missing data of the fit stretch, `[[t0, t1], …]` in seconds from its first sample
    /// (beside any NaN, empty cells or missing time stamps of a data file).
    #[serde(
        default,
        deserialize_with = "crate::experiment::pair::pairs",
        skip_serializing_if = "Vec::is_empty"
    )]
    pub gaps: Vec<[f64; 2]>,
    /// Missing data of the noise-only stretch, likewise.
    #[serde(
        default,
        deserialize_with = "crate::experiment::pair::pairs",
        skip_serializing_if = "Vec::is_empty"
    )]
    pub noise_gaps: Vec<[f64; 2]>,
    /// Glitches to gate, `[[t0, t1], …]` in seconds from the fit stretch's first sample
    /// (gated whatever `[analysis] glitches` says).
    #[serde(
        default,
        deserialize_with = "crate::experiment::pair::pairs",
        skip_serializing_if = "Vec::is_empty"
    )]
    pub glitches: Vec<[f64; 2]>,
    /// The `[[stretch]]` the experiment was taken in ([`crate::config::stretches`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stretch: Option<String>,
}

impl super::stretches::InStretch for ExperimentEntry {
    fn name(&self) -> &str {
        &self.name
    }

    fn stretch(&self) -> Option<&str> {
        self.stretch.as_deref()
    }

    fn reads_file(&self) -> bool {
        self.data.is_some()
    }

    fn repeated_in(&self, stretch: &str) -> Self {
        Self {
            name: format!("{}_{stretch}", self.name),
            stretch: Some(stretch.into()),
            ..self.clone()
        }
    }
}

/// Which likelihood the samplers use.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum LikelihoodKind {
    /// Relative binning around the MAP (fast; `|Δ ln L| < 0.01` in the 5σ region).
    #[default]
    Relbin,
    /// Every in-band bin.
    Exact,
}

/// `[analysis]`: how data become a likelihood (shared by `fit` and `select`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct AnalysisOptions {
    /// A dataset directory written by `occam simulate` (relative to the working directory).
    /// Without it the study is simulated on the fly.
    pub dataset: Option<PathBuf>,
    /// Fit band (Hz): exactly two numbers `[lo, hi]` with `0 < lo < hi ≤` the Nyquist
    /// frequency of every experiment whose sample rate the study gives. The default
    /// `[1e-4, 1.0]` is clipped to the data's frequencies instead.
    #[serde(deserialize_with = "two_numbers")]
    pub band: [f64; 2],
    /// Window applied to data and injections before the DFT.
    pub window: crate::signal::Window,
    /// Noise CSD: `welch` (from the noise-only stretch) or `model`.
    pub noise: crate::likelihood::NoiseSource,
    pub welch_averages: usize,
    pub welch_window: crate::signal::Window,
    /// `fixed` (default: one Welch segment length for the band) or `per_band` (longer segments
    /// where the fixed ones do not resolve the band's bottom; see
    /// [`crate::likelihood::WelchResolution`]). Written to resolved studies only when not the
    /// default, so that existing resolved files and their goldens are unchanged.
    #[serde(skip_serializing_if = "crate::likelihood::WelchResolution::is_fixed")]
    pub welch_resolution: crate::likelihood::WelchResolution,
    pub likelihood: LikelihoodKind,
    /// Relative-binning accuracy: region radius (σ) and per-bin template error.
    pub relbin_sigma: f64,
    pub relbin_tolerance: f64,
    /// The statistic `ln L` is: `whittle` (default; the residual PSD from the noise-only
    /// stretch, held fixed), `student_t` (that estimate's uncertainty marginalised, one scale
    /// per bin), `wishart` (the whole residual CSD marginalised: exact for few averages) or
    /// `log_periodogram` (the residual's own Welch periodogram, noise level unknown). See
    /// [`crate::likelihood::statistic`]. With a statistic other than `whittle` relative
    /// binning (a Gaussian approximation) is not used.
    pub statistic: crate::likelihood::Statistic,
    /// `[analysis.log_periodogram]`: Welch settings of the log-periodogram statistic.
    pub log_periodogram: crate::likelihood::LogPeriodogramOptions,
    /// Data with gaps: the cosine taper (s) at each end of a valid run that borders a gap
    /// (default [`crate::likelihood::DEFAULT_GAP_TAPER`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gap_taper: Option<f64>,
    /// `none` (default), `gate` or `model`: find glitches on the whitened residual at the
    /// reference point and gate them ([`crate::likelihood::glitch_gate`]) or fit them as part
    /// of the model ([`crate::model::glitch`]). Listed `[[experiment]] glitches` are gated
    /// either way.
    #[serde(skip_serializing_if = "crate::likelihood::GlitchTreatment::is_none")]
    pub glitches: crate::likelihood::GlitchTreatment,
    /// Detection threshold (σ of the whitened residual; default
    /// [`crate::likelihood::DEFAULT_GLITCH_THRESHOLD`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub glitch_threshold: Option<f64>,
    /// Seconds gated on each side of a detected glitch (default
    /// [`crate::likelihood::DEFAULT_GLITCH_PAD`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub glitch_pad: Option<f64>,
    /// Seconds gated after a detected glitch's region, beyond `glitch_pad`: the loop's response
    /// to the force outlasts it (default [`crate::likelihood::DEFAULT_GLITCH_TAIL`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub glitch_tail: Option<f64>,
    /// `glitches = "model"`: the prior range `[lo, hi]` of a glitch's decay time (s,
    /// log-uniform; default [`crate::likelihood::DEFAULT_GLITCH_DECAY`]).
    #[serde(
        default,
        deserialize_with = "crate::experiment::pair::opt_pair",
        skip_serializing_if = "Option::is_none"
    )]
    pub glitch_decay: Option<[f64; 2]>,
    /// `glitches = "model"`: a glitch's peak force per unit mass on each test mass is uniform
    /// in `[−A, A]` (m s⁻²; default [`crate::likelihood::DEFAULT_GLITCH_AMPLITUDE`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub glitch_amplitude: Option<f64>,
    /// `glitches = "model"`: a glitch's rise time (s, fixed; default
    /// [`crate::likelihood::DEFAULT_GLITCH_RISE`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub glitch_rise: Option<f64>,
    /// `glitches = "model"`: how many of the candidates are glitches. `all` (default): every
    /// candidate whose start gains enough ([`crate::jobs::glitch_model::KEEP_FRACTION`]);
    /// `rj`: `occam fit` also runs the reversible jump over which of them are on
    /// ([`crate::jobs::glitch_count`]).
    #[serde(skip_serializing_if = "GlitchCountMethod::is_all")]
    pub glitch_count: GlitchCountMethod,
    /// `glitch_count = "rj"`: iterations of the reversible jump (default
    /// [`DEFAULT_GLITCH_COUNT_ITERATIONS`]; the first quarter is burn-in).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub glitch_count_iterations: Option<usize>,
}

/// Default `[analysis] glitch_count_iterations`.
pub const DEFAULT_GLITCH_COUNT_ITERATIONS: usize = 4000;
/// Fewest `glitch_count_iterations`: a quarter burn-in, 20 batches of 15 kept.
pub const MIN_GLITCH_COUNT_ITERATIONS: usize = 400;
/// Most `glitch_count_iterations` (each costs ~10 ms on `examples/glitches.toml`: a day).
pub const MAX_GLITCH_COUNT_ITERATIONS: usize = 10_000_000;

/// `[analysis] glitch_count`: how the number of modelled glitches is chosen.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum GlitchCountMethod {
    /// Every candidate whose start gains at least a glitch at the detection threshold.
    #[default]
    All,
    /// Those, and the reversible jump's posterior over which of them are glitches.
    Rj,
}

impl GlitchCountMethod {
    /// Whether this is the default (serialisation skips it).
    pub fn is_all(&self) -> bool {
        *self == GlitchCountMethod::All
    }
}

impl Default for AnalysisOptions {
    fn default() -> Self {
        let s = crate::likelihood::SpectraOptions::default();
        let r = crate::likelihood::RelBinOptions::default();
        Self {
            dataset: None,
            band: s.band,
            window: s.window,
            noise: s.noise,
            welch_averages: s.welch_averages,
            welch_window: s.welch_window,
            welch_resolution: s.welch_resolution,
            likelihood: LikelihoodKind::Relbin,
            relbin_sigma: r.n_sigma,
            relbin_tolerance: r.tolerance,
            statistic: Default::default(),
            log_periodogram: Default::default(),
            gap_taper: None,
            glitches: Default::default(),
            glitch_threshold: None,
            glitch_pad: None,
            glitch_tail: None,
            glitch_decay: None,
            glitch_amplitude: None,
            glitch_rise: None,
            glitch_count: GlitchCountMethod::All,
            glitch_count_iterations: None,
        }
    }
}

/// `[fit]`: MCMC parameter estimation of one model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FitOptions {
    /// The model to fit (default: the built-in closed loop `ltp`).
    pub model: Option<String>,
    /// Free parameter names (default: all of the model's).
    pub free: Option<Vec<String>>,
    /// Values of the parameters that are not free.
    pub fixed: std::collections::BTreeMap<String, f64>,
    pub chains: usize,
    pub iterations: usize,
    pub burn_in: usize,
    pub thin: usize,
    /// Seed of the chains (default: the study seed + 1).
    pub seed: Option<u64>,
    /// Adapt the proposal covariance during the burn-in.
    pub adapt: bool,
    /// Iterations between checkpoints.
    pub checkpoint_every: usize,
    /// Multiplies the proposal covariance `(2.38²/D) F⁻¹`.
    pub proposal_scale: f64,
    /// Start of the MAP search (default: the centre of each prior box, or the mean of a
    /// Gaussian prior).
    pub start: Option<std::collections::BTreeMap<String, f64>>,
    /// Quasi-random starts of the MAP search besides `start` (every model's, `select`'s too;
    /// [`crate::likelihood::multi_start_map`]); 0 searches from `start` alone.
    pub map_starts: usize,
    /// Share of the MCMC iterations that propose from the Laplace approximation at the MAP
    /// (a Gaussian with the inverse Fisher matrix, capped at the prior's widths) instead of
    /// the random walk ([`crate::sampler::Independence`]); `None`: the model's default,
    /// [`DEFAULT_GLITCH_INDEPENDENCE`] with modelled glitches, 0 otherwise.
    pub independence: Option<f64>,
    /// End the chains once every free parameter has converged (`[fit] until = { ess = 400,
    /// rhat = 1.01 }`, or `true` for those defaults), with `iterations` the most they run;
    /// `None` (`until = false`, or no key) runs `iterations`. Set with modelled glitches when
    /// the file gives none ([`GLITCH_UNTIL`]).
    #[serde(
        deserialize_with = "until_or_off",
        skip_serializing_if = "Option::is_none"
    )]
    pub until: Option<UntilOptions>,
}

/// `[fit] until` and `[select] until` from a table of the rule's settings, or `true` (the
/// defaults) or `false` (none); a table's own errors (an unknown key) pass through.
fn until_or_off<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Option<UntilOptions>, D::Error> {
    struct V;
    impl<'de> serde::de::Visitor<'de> for V {
        type Value = Option<UntilOptions>;
        fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
            f.write_str("a table { ess, rhat, every }, or true or false")
        }
        fn visit_bool<E: serde::de::Error>(self, on: bool) -> Result<Self::Value, E> {
            Ok(on.then(UntilOptions::default))
        }
        fn visit_map<A: serde::de::MapAccess<'de>>(self, m: A) -> Result<Self::Value, A::Error> {
            UntilOptions::deserialize(serde::de::value::MapAccessDeserializer::new(m)).map(Some)
        }
    }
    d.deserialize_any(V)
}

/// `[fit] until` and `[select] until`: the convergence rule that ends a fit's chains early
/// and extends select's in-model chains ([`crate::sampler::Until`]), each field optional.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct UntilOptions {
    /// Every free parameter's total ESS (all chains) at least this.
    pub ess: f64,
    /// Every free parameter's rank-normalised split-R̂ at most this.
    pub rhat: f64,
    /// Iterations per chain between checks, after the burn-in.
    pub every: usize,
}

impl Default for UntilOptions {
    fn default() -> Self {
        Self {
            ess: 400.0,
            rhat: 1.01,
            every: 100,
        }
    }
}

/// `[fit] until` of a study with `glitches = "model"` when its file gives none: at ~0.2 s per
/// `ln L` the chains' fixed 3 000 iterations ([`GLITCH_ITERATIONS`], now the most they run)
/// took ~1 000 s on `examples/glitches.toml`, with the loop's ESS five to nine times 400.
pub const GLITCH_UNTIL: UntilOptions = UntilOptions {
    ess: 400.0,
    rhat: 1.01,
    every: 100,
};

/// `[fit] iterations` and `burn_in` of a study with `glitches = "model"` when its file gives
/// none (each replaced on its own, at load, so the resolved study says it). With
/// [`DEFAULT_GLITCH_INDEPENDENCE`] of the iterations drawn from the Laplace approximation,
/// 1 500 iterations (300 burn-in) per chain on `examples/glitches.toml` (34 parameters) gave
/// the loop's parameters ESS 312–748 and R-hat up to 1.018; about twice the draws bring them
/// to ~600 and ~1.01 (docs/src/guide/glitches.md). The plain 20 000 per chain would take over
/// an hour at ~0.2 s per `ln L`. With [`GLITCH_UNTIL`] these are the most the chains run.
pub const GLITCH_ITERATIONS: (usize, usize) = (3_000, 500);

/// `[fit] map_starts` of a study with `glitches = "model"` when its file gives none: the
/// rounds of the glitches' starts already end in a joint MAP search (`jobs::glitch_model`),
/// and quasi-random loop starts with the glitches held there found nothing better. On
/// `examples/glitches.toml` (seed 2014) the default four cost 180 s: three ended on a singular
/// Fisher matrix (two glitches of one region drawn onto each other), one 2 785 nats below the
/// given start's maximum, and their failures filled the run's warnings.
pub const GLITCH_MAP_STARTS: usize = 0;

/// Default of [`FitOptions::independence`] for a model carrying modelled glitches: in their
/// ~40 dimensions the random walk's steps are ~0.4 σ and an `ln L` costs ~0.2 s, while the
/// posterior is close to its Laplace approximation (docs/src/guide/glitches.md); the walk
/// keeps a fifth of the iterations for what the Gaussian's tails miss.
pub const DEFAULT_GLITCH_INDEPENDENCE: f64 = 0.8;

/// Default of [`FitOptions::map_starts`].
pub const DEFAULT_MAP_STARTS: usize = 4;

impl Default for FitOptions {
    fn default() -> Self {
        Self {
            model: None,
            free: None,
            fixed: Default::default(),
            chains: 4,
            iterations: 20_000,
            burn_in: 5_000,
            thin: 1,
            seed: None,
            adapt: true,
            checkpoint_every: 5_000,
            proposal_scale: 1.0,
            start: None,
            map_starts: DEFAULT_MAP_STARTS,
            independence: None,
            until: None,
        }
    }
}

/// One competing model of `[[select.model]]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SelectModelEntry {
    pub name: String,
    /// The model this is a sub-model of (default: the built-in closed loop `ltp`).
    #[serde(default)]
    pub model: Option<String>,
    /// Free parameter names (default: all of the model's).
    #[serde(default)]
    pub free: Option<Vec<String>>,
    /// Values of the parameters that are not free.
    #[serde(default)]
    pub fixed: std::collections::BTreeMap<String, f64>,
    /// Prior model probability (default: equal).
    #[serde(default)]
    pub prior_probability: Option<f64>,
}

/// Location and covariance of a model's reversible-jump proposal.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum JumpProposal {
    /// The mean and covariance of the model's in-model chains (default): right also where
    /// the posterior fills its prior box and the Fisher Gaussian overhangs it.
    Chain,
    /// The MAP and the inverse Fisher matrix there (K14's choice).
    Fisher,
}

/// `[select]`: Bayes factors between two or more nested models with every estimator.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SelectOptions {
    pub model: Vec<SelectModelEntry>,
    /// Reversible-jump iterations (each: an in-model step and a jump attempt).
    pub rj_iterations: usize,
    pub rj_burn_in: usize,
    /// `c` of the jump proposals `N(μ_k, c² Σ_k)`.
    pub jump_scale: f64,
    /// Where `μ_k, Σ_k` of the jump proposals come from.
    pub jump_proposal: JumpProposal,
    /// Weight of each model's own prior in its jump proposal (a defensive mixture component
    /// that keeps the proposal positive wherever the prior is), in [0, 1).
    pub defensive: f64,
    /// Independent reversible-jump chains (run in parallel, combined; `rj_iterations` is
    /// their total).
    pub rj_chains: usize,
    /// Degrees of freedom of a Student-t jump proposal; 0 for Gaussian.
    pub student_t: f64,
    /// Metropolis–Hastings per model for Laplace–Metropolis: chains, iterations, burn-in.
    pub chains: usize,
    pub iterations: usize,
    pub burn_in: usize,
    /// Parallel tempering per model (thermodynamic integration and stepping-stone): rungs
    /// including β = 0 and 1 (0 turns it off), sweeps and burn-in sweeps.
    pub pt_temperatures: usize,
    pub pt_iterations: usize,
    pub pt_burn_in: usize,
    /// Seed of the samplers (default: the study seed + 2).
    pub seed: Option<u64>,
    /// `n` of the Schwarz criterion (default: the number of real data values in the
    /// likelihood, 4 × in-band bins).
    pub schwarz_n: Option<f64>,
    /// The standard error of `ln B` to reach on every pair's reference row: the reversible
    /// jump is run again, longer, until its error is at most this (or `rj_max_iterations` is
    /// reached); `None` (the default): the fixed `rj_iterations`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub target_error: Option<f64>,
    /// The budget of a run with `target_error`: the most reversible-jump iterations one
    /// round may have (default: 16 × `rj_iterations`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rj_max_iterations: Option<usize>,
    /// How much of the run the cross-check rows that need their own sampler (thermodynamic
    /// integration and stepping-stone) get.
    #[serde(skip_serializing_if = "CrossChecks::is_full")]
    pub cross_checks: CrossChecks,
    /// The in-model chains run `iterations`, then on, while they fail this rule, until they
    /// meet it or reach `max_iterations` (`[select] until = { ess = 400, rhat = 1.01 }`, the
    /// default, or `false` for exactly `iterations`). Asked first at `iterations`, so chains
    /// that have converged by then are those of a fixed run of that length.
    #[serde(
        deserialize_with = "until_or_off",
        skip_serializing_if = "is_default_select_until"
    )]
    pub until: Option<UntilOptions>,
    /// The most iterations an in-model chain runs under `until` (default: 4 × `iterations`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_iterations: Option<usize>,
}

/// The resolved study leaves out `[select] until` when it is the default rule, and when it is
/// off (`None`), which [`super::resolved`] writes as `false` itself (TOML has no none).
fn is_default_select_until(u: &Option<UntilOptions>) -> bool {
    u.is_none_or(|u| u == UntilOptions::default())
}

/// How much of a select run goes to the tempering cross-checks (`[select] cross_checks`).
/// The rows that come with the reference run or cost next to nothing (the reversible jump's
/// visit ratio and Rao–Blackwell, Laplace, Schwarz) are always there.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CrossChecks {
    /// The tempering ladder as configured (`pt_temperatures`, `pt_iterations`, `pt_burn_in`).
    #[default]
    Full,
    /// The same ladder with a quarter of the sweeps and of the burn-in: errors about twice
    /// as large, for a quarter of the cost.
    Light,
    /// No tempering: thermodynamic integration and stepping-stone say so on their rows.
    Off,
}

impl CrossChecks {
    /// The default, which the resolved study does not write.
    pub fn is_full(&self) -> bool {
        *self == CrossChecks::Full
    }

    /// The name as a study file writes it.
    pub fn name(&self) -> &'static str {
        match self {
            CrossChecks::Full => "full",
            CrossChecks::Light => "light",
            CrossChecks::Off => "off",
        }
    }
}

impl Default for SelectOptions {
    fn default() -> Self {
        Self {
            model: Vec::new(),
            rj_iterations: 100_000,
            rj_burn_in: 2_000,
            jump_scale: 1.2,
            jump_proposal: JumpProposal::Chain,
            defensive: 0.1,
            rj_chains: 2,
            student_t: 0.0,
            chains: 2,
            iterations: 12_000,
            burn_in: 4_000,
            pt_temperatures: 32,
            pt_iterations: 40_000,
            pt_burn_in: 8_000,
            seed: None,
            schwarz_n: None,
            target_error: None,
            rj_max_iterations: None,
            cross_checks: CrossChecks::Full,
            until: Some(UntilOptions::default()),
            max_iterations: None,
        }
    }
}

impl SelectOptions {
    /// The tempering ladder the run gets under `cross_checks`: rungs (0: none), sweeps and
    /// burn-in sweeps. `light` keeps the rungs and takes a quarter of the sweeps and of the
    /// burn-in (rounded up).
    pub fn tempering_ladder(&self) -> (usize, usize, usize) {
        match self.cross_checks {
            CrossChecks::Full => (self.pt_temperatures, self.pt_iterations, self.pt_burn_in),
            CrossChecks::Light => (
                self.pt_temperatures,
                self.pt_iterations.div_ceil(4),
                self.pt_burn_in.div_ceil(4),
            ),
            CrossChecks::Off => (0, 0, 0),
        }
    }

    /// The most iterations an in-model chain runs: `iterations` without `until`, else
    /// `max_iterations`, else 4 × `iterations`.
    pub fn most_iterations(&self) -> usize {
        match self.until {
            None => self.iterations,
            Some(_) => self
                .max_iterations
                .unwrap_or_else(|| self.iterations.saturating_mul(4)),
        }
    }

    /// The reversible-jump budget of a run with `target_error`: `rj_max_iterations`, else 16
    /// × `rj_iterations`.
    pub fn rj_budget(&self) -> usize {
        self.rj_max_iterations
            .unwrap_or_else(|| self.rj_iterations.saturating_mul(16))
    }
}

/// A validated competing model.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SelectModel {
    pub name: String,
    pub spec: ModelSpec,
    pub prior_probability: f64,
}

/// The study file as written.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StudyFile {
    pub seed: u64,
    pub output: PathBuf,
    #[serde(default)]
    pub truth: LtpParams,
    #[serde(default)]
    pub noise: NoiseModel,
    #[serde(default)]
    pub masses: Masses,
    /// Fixed OMS processing delay τ_o (s), default 0.
    #[serde(default)]
    pub oms_delay: f64,
    #[serde(default)]
    pub simulation: SimulationOptions,
    #[serde(default)]
    pub analysis: AnalysisOptions,
    /// Normalised priors by parameter name (defaults: the built-in model's boxes, see
    /// [`crate::model::LtpModel::default_priors`]); every parameter of a user-defined model
    /// needs one.
    #[serde(default, deserialize_with = "priors")]
    pub prior: std::collections::BTreeMap<String, PriorKind>,
    /// `[[model]]` tables: built-in closed loops with options and user-defined models.
    #[serde(default)]
    pub model: Vec<toml::Table>,
    #[serde(default)]
    pub fit: FitOptions,
    #[serde(default)]
    pub select: SelectOptions,
    /// `[sweep]`: the grid of `occam sweep` (ignored by the other commands).
    #[serde(default)]
    pub sweep: Option<SweepOptions>,
    /// `[design]`: the injection-design search of `occam design` (`crate::jobs::design`).
    #[serde(default)]
    pub design: Option<design::DesignOptions>,
    pub experiment: Vec<ExperimentEntry>,
    /// `[[stretch]]` tables: experiments grouped by when they were taken.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub stretch: Vec<super::stretches::StretchEntry>,
}

/// A validated study, with built-in designs and injection files resolved.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Study {
    pub seed: u64,
    pub output: PathBuf,
    pub truth: LtpParams,
    pub noise: NoiseModel,
    pub masses: Masses,
    pub oms_delay: f64,
    pub simulation: SimulationOptions,
    pub experiments: Vec<ExperimentDesign>,
    /// Experiments read from files (`[[experiment]] data = …`), by name.
    pub data_sources: Vec<(String, crate::data::DataSource)>,
    /// The commanded injections of experiments read from files that give their design
    /// (`design`, `x1`, `x12`, `f1`, `f2`, `fsc`, `pre_pad`, `post_pad` beside `data`), by
    /// name: filled in where the file's injection channels are missing (telemetry gaps).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub commanded: Vec<(String, ExperimentDesign)>,
    /// Every experiment name in the order of the study file (each repeated per stretch when
    /// the study has stretches and no experiment names one).
    pub experiment_names: Vec<String>,
    /// Listed glitches to gate (`[[experiment]] glitches`, seconds), by experiment name; only
    /// experiments with some.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub glitch_lists: Vec<(String, Vec<[f64; 2]>)>,
    /// The `[[stretch]]` tables and which experiment is in which (empty: no stretches).
    #[serde(skip_serializing_if = "super::stretches::Stretches::is_empty")]
    pub stretches: super::stretches::Stretches,
    /// The directory of the study file (relative data paths start there).
    pub base_dir: PathBuf,
    pub analysis: AnalysisOptions,
    /// Every model with its validated prior.
    pub models: ModelSet,
    pub fit: FitOptions,
    /// The validated `[fit]` model.
    pub fit_model: ModelSpec,
    pub select: SelectOptions,
    /// The validated `[[select.model]]` list (empty if none).
    pub select_models: Vec<SelectModel>,
    /// `[sweep]` as written (validated against the select models).
    pub sweep: Option<SweepOptions>,
    /// `[design]` as written (validated by [`design::DesignOptions::validate`]).
    pub design: Option<design::DesignOptions>,
    /// The file it came from (for messages).
    pub source: String,
    /// The study file as parsed, serde's defaults filled in
    /// ([`resolved_toml`](crate::config::resolved_toml)); not part of the study's identity
    /// (checkpoints hash the serialised study).
    #[serde(skip)]
    pub file: StudyFile,
}

impl Study {
    /// The same study with no gaps: no `[simulation.gaps]` and no experiment's listed `gaps`
    /// or `noise_gaps` (what a coverage study compares a gapped one against, on the same
    /// noise streams).
    pub fn without_gaps(&self) -> Study {
        let mut s = self.clone();
        s.simulation.gaps = None;
        for d in &mut s.experiments {
            d.gaps.clear();
            d.noise_gaps.clear();
        }
        s
    }

    /// The true system of the study (`[truth]`, `[masses]`, `[noise]`, the OMS delay and the
    /// `[simulation]` thruster and actuators).
    pub fn system(&self) -> crate::experiment::System {
        self.system_with(self.truth)
    }

    /// [`Study::system`] with the loop's parameters `truth` (a stretch's).
    fn system_with(&self, truth: LtpParams) -> crate::experiment::System {
        crate::experiment::System {
            truth,
            controllers: Controllers::default(),
            masses: self.masses,
            noise: self.noise,
            oms_delay: self.oms_delay,
            thruster: self.simulation.thruster,
            actuators: self.simulation.actuators.resolve(truth.a_sus),
        }
    }

    /// The stretch and covariates of experiment `name` (no stretch and no values when the
    /// study has no stretches), with the experiment's name.
    pub fn covariates_of(&self, name: &str) -> crate::model::Covariates {
        crate::model::Covariates {
            experiment: Some(name.to_string()),
            ..self.stretches.covariates_of(name)
        }
    }

    /// The model that generates the data (`[simulation] model` at `[simulation.truth]`), if
    /// the study names one; validated at load.
    pub fn generator(&self) -> Option<crate::experiment::Generator> {
        let name = self.simulation.model.as_ref()?;
        let i = self.models.index(name)?;
        let model = self.models.models[i].clone();
        let theta = model
            .param_names()
            .iter()
            .map(|n| self.simulation.truth.get(n).copied().unwrap_or(f64::NAN))
            .collect();
        Some(crate::experiment::Generator { model, theta })
    }

    /// What the simulator needs of the study, as plain values.
    pub fn simulation_plan(&self) -> crate::experiment::SimulationPlan {
        let o = &self.simulation;
        crate::experiment::SimulationPlan {
            source: self.source.clone(),
            seed: self.seed,
            system: self.system(),
            experiments: self.experiments.clone(),
            method: o.method,
            noise: o.noise,
            target_snr: o.target_snr.map(|t| o.snr_definition.to_optimal(t)),
            snr_band: o.snr_band,
            oversample: o.oversample,
            generator: self.generator(),
            gaps: o.gaps,
            glitches: o.glitches,
            systems: self
                .experiments
                .iter()
                .map(|d| {
                    let s = self.stretches.stretch_of(&d.name)?;
                    (!s.truth.is_empty()).then(|| {
                        self.system_with(super::stretches::Stretches::truth_in(s, &self.truth))
                    })
                })
                .collect(),
        }
    }
}

/// `[prior]`: each entry read on its own, so that a message names the parameter and says what
/// a prior looks like (serde's own: "expected internally tagged enum PriorKind").
fn priors<'de, D: serde::Deserializer<'de>>(
    d: D,
) -> Result<std::collections::BTreeMap<String, PriorKind>, D::Error> {
    let raw: std::collections::BTreeMap<String, toml::Value> =
        std::collections::BTreeMap::deserialize(d)?;
    let example = "{ kind = \"uniform\", lo = …, hi = … }, { kind = \"gaussian\", mu = …, sigma = … } \
                   or { kind = \"log_uniform\", lo = …, hi = … }";
    raw.into_iter()
        .map(|(name, v)| {
            if !v.is_table() {
                return Err(serde::de::Error::custom(format!(
                    "prior `{name}` = {v}: a prior is a table, {example}"
                )));
            }
            PriorKind::deserialize(v)
                .map(|k| (name.clone(), k))
                .map_err(|e| {
                    serde::de::Error::custom(format!(
                        "prior `{name}`: {}; a prior is {example}",
                        e.message().trim_end()
                    ))
                })
        })
        .collect()
}

/// A band `[lo, hi]` from exactly two numbers: serde's fixed-size arrays take the first two
/// elements of a longer TOML array and drop the rest silently (a three-number band fitted
/// 1 % of the intended bins), so the band is read as a list and its length checked.
fn two_numbers<'de, D: serde::Deserializer<'de>>(d: D) -> Result<[f64; 2], D::Error> {
    let v: Vec<f64> = Vec::deserialize(d)?;
    match v[..] {
        [lo, hi] => Ok([lo, hi]),
        _ => Err(serde::de::Error::custom(format!(
            "a band is exactly two numbers [lo, hi] in Hz (got {} numbers: {v:?})",
            v.len()
        ))),
    }
}
