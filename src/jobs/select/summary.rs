//! Everything `occam select` reports.

use super::outcome::ModelOutcome;
use super::pair::PairResult;
use crate::evidence::RjResult;
use serde::Serialize;

/// Everything `occam select` reports.
#[derive(Debug, Clone, Serialize)]
pub struct SelectSummary {
    /// Whether the run passed its own checks ([`crate::jobs::validity`]); `false`: its
    /// numbers are not to be used, for the reasons in `invalid_reasons`.
    pub valid: bool,
    /// Why the run is not valid, each with what to change (empty when it is).
    pub invalid_reasons: Vec<String>,
    pub origin: String,
    /// ρ_opt of the injections under the simulation's exact noise model (when simulated).
    pub rho_opt_simulated: Option<f64>,
    /// ρ_opt = √⟨h|h⟩ at the truth (or the first model's MAP) under the analysis's noise
    /// estimate (Welch by default), which differs from the model noise at low frequencies;
    /// NaN (null) for a model that reads no noiseless input channel.
    pub rho_opt: f64,
    pub n_bins: usize,
    /// The statistic of every `ln L` and evidence (`[analysis] statistic`).
    pub statistic: crate::likelihood::Statistic,
    /// Effective Welch averages of the noise reference per decade of the band, per experiment
    /// ([`crate::jobs::prepare::noise_averages_for_summary`]; absent when neither the statistic
    /// nor per-band resolution makes them matter).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub noise_averages: Option<Vec<crate::jobs::prepare::NoiseAverages>>,
    /// What glitch gating did, per experiment (absent when the study gates nothing).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub glitch_gates: Vec<crate::likelihood::GlitchGate>,
    pub schwarz_n: f64,
    pub models: Vec<ModelOutcome>,
    pub pairs: Vec<PairResult>,
    /// `P(k|y)` from the reference `ln B` of every pair with the first model and the prior
    /// model probabilities (`None` when a pair has no reference number).
    pub posterior_model_probabilities: Option<Vec<f64>>,
    /// The reversible-jump run (absent when it could not run: see `rj_note`).
    pub rj: Option<RjResult>,
    pub rj_note: Option<String>,
    pub rj_iterations_per_second: f64,
    /// How a run with `[select] target_error` went (absent without one).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub target: Option<super::target::TargetOutcome>,
    /// How much of the run the tempering cross-checks got (absent when `full`).
    #[serde(skip_serializing_if = "crate::config::CrossChecks::is_full")]
    pub cross_checks: crate::config::CrossChecks,
    pub seconds: f64,
    /// Warnings about the models, the data and the estimators.
    pub warnings: Vec<String>,
    /// Facts about the data and how they were analysed that are not problems (the gaps and
    /// how many runs between them are analysed); absent when there are none.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub notes: Vec<String>,
    /// Each model's residual PSD at its MAP (Fig. 3), written to `residual_psd.npz` and
    /// plotted, not into `summary.json`.
    #[serde(skip)]
    pub residual_psd: Vec<(String, Vec<crate::likelihood::residual_psd::ResidualPsd>)>,
    /// Each model's in-model chains (`None` where they did not run), written to
    /// `chains_<model>.npz`, not into `summary.json`.
    #[serde(skip)]
    pub model_chains: Vec<(String, Option<crate::sampler::Chains>)>,
    /// The measured transfer functions against every model's at its MAP (`bode.npz`,
    /// `bode_<experiment>.png/.svg`), not into `summary.json`.
    #[serde(skip)]
    pub bode: Vec<crate::report::bode::BodeExperiment>,
    /// Each experiment's time series and spectra, not into `summary.json`.
    #[serde(skip)]
    pub raw: Vec<crate::report::raw::RawData>,
}
