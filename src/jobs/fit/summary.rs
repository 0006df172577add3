//! What a fit reports, and its errors.

use crate::config::LikelihoodKind;
use crate::report::fmt_short;
use crate::sampler::Chains;
use nalgebra::DMatrix;
use serde::Serialize;

/// Errors of a fit.
#[derive(Debug, thiserror::Error)]
pub enum FitError {
    #[error(transparent)]
    Map(#[from] crate::likelihood::MapError),
    #[error(transparent)]
    Sampler(#[from] crate::sampler::SamplerError),
    #[error(transparent)]
    Analysis(#[from] crate::jobs::prepare::AnalysisError),
    #[error(transparent)]
    Nested(#[from] crate::nested::NestedError),
    #[error(transparent)]
    Report(#[from] crate::report::ReportError),
    #[error("{0}")]
    Other(String),
}

/// One row of the Table I layout.
#[derive(Debug, Clone, Serialize)]
pub struct ParamRow {
    pub name: String,
    /// SI unit of the parameter (`"s⁻²"`, `"s"`, `"Hz"`); empty when dimensionless or unknown.
    pub unit: String,
    pub truth: Option<f64>,
    pub map: f64,
    pub mean: f64,
    pub sd: f64,
    pub cramer_rao: f64,
    /// Where the window correlates neighbouring bins (the tapers of the runs between gaps,
    /// or a non-rectangular `window`): the sandwich error `√(F⁻¹JF⁻¹)_ii` at the MAP
    /// ([`crate::likelihood::score_covariance`], with the Welch estimate's degrees of freedom),
    /// which covers where the Fisher error and the chains' sd (the Whittle posterior's, which
    /// treats the bins as independent) are short. Absent otherwise.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sandwich: Option<f64>,
    pub rhat: f64,
    pub ess: f64,
    /// (mean − truth)/sd when the truth is known.
    pub pull: Option<f64>,
}

/// Everything `occam fit` reports.
#[derive(Debug, Clone, Serialize)]
pub struct FitSummary {
    /// Whether the run passed its own checks ([`crate::jobs::validity`]); `false`: its
    /// numbers are not to be used, for the reasons in `invalid_reasons`.
    pub valid: bool,
    /// Why the run is not valid, each with what to change (empty when it is).
    pub invalid_reasons: Vec<String>,
    pub origin: String,
    /// The fitted model.
    pub model: String,
    /// The statistic of every `ln L` reported and sampled (`[analysis] statistic`).
    pub statistic: crate::likelihood::Statistic,
    /// The likelihood the chains ran on (relative binning is replaced by the exact `ln L`
    /// when the statistic is not `whittle`).
    pub likelihood: LikelihoodKind,
    /// Effective Welch averages of the noise reference per decade of the band, per experiment
    /// ([`crate::jobs::prepare::noise_averages_for_summary`]; absent when neither the statistic
    /// nor per-band resolution makes them matter).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub noise_averages: Option<Vec<crate::jobs::prepare::NoiseAverages>>,
    /// What glitch gating did, per experiment (absent when the study gates nothing).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub glitch_gates: Vec<crate::likelihood::GlitchGate>,
    /// `[analysis] glitch_count = "rj"`: the posterior of the number of modelled glitches
    /// (absent otherwise).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub glitch_count: Option<crate::jobs::glitch_count::GlitchCount>,
    /// When an injection is missing inside gaps of the data (and no design fills it in): the
    /// bias it causes, predicted at the MAP ([`crate::jobs::injection_bias`]). Above
    /// [`BIAS_LIMIT`](crate::jobs::injection_bias::BIAS_LIMIT) σ the run is not valid.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub missing_injection_bias: Option<crate::jobs::injection_bias::InjectionBias>,
    pub n_bins: usize,
    pub n_coarse_bins: Option<usize>,
    pub rho_opt_at_map: f64,
    pub map_ln_posterior: f64,
    pub map_iterations: usize,
    pub rows: Vec<ParamRow>,
    pub acceptance: Vec<f64>,
    /// The draws from the Laplace approximation mixed into the random walk
    /// (`[fit] independence`), when there were any.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub independence: Option<IndependenceCounts>,
    pub non_finite: Vec<u64>,
    pub warnings: Vec<String>,
    /// Facts about the data and how they were analysed that are not problems (the gaps and
    /// how many runs between them are analysed); absent when there are none.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub notes: Vec<String>,
    pub chains: usize,
    /// Iterations per chain at which the chains met `[fit] until` and stopped, before
    /// `[fit] iterations`; absent when they ran all of them.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub converged_at: Option<usize>,
    pub kept_per_chain: usize,
    /// Iterations per chain before the first kept draw (`[fit] burn_in`); they are not stored.
    pub burn_in: usize,
    /// One draw kept every `thin` iterations after the burn-in: kept draw `k` (from 0) is
    /// iteration `burn_in + (k + 1)·thin`.
    pub thin: usize,
    pub seconds_map: f64,
    pub seconds_mcmc: f64,
    pub iterations_per_second: f64,
    /// Fisher matrix at the MAP over the free parameters.
    pub fisher: Vec<Vec<f64>>,
}

/// How the independence kernel of a fit did after the burn-in, over all chains.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct IndependenceCounts {
    /// The share of iterations that drew from it (`[fit] independence`).
    pub share: f64,
    /// Its proposals after the burn-in.
    pub proposed: u64,
    /// Of those, accepted.
    pub accepted: u64,
}

/// The outcome of a fit (`run`).
pub struct FitOutcome {
    pub summary: FitSummary,
    pub chains: Chains,
    /// Free-parameter MAP and Fisher matrix (for reuse by evidence estimators).
    pub map_full: Vec<f64>,
    pub fisher: DMatrix<f64>,
    /// Where the information on each free parameter comes from, at the MAP
    /// (`information.md`, `.json` and the plot); `None` when the Fisher matrix is singular.
    pub information: Option<crate::likelihood::information::Information>,
    /// The measured and fitted transfer functions per experiment with injections
    /// (`bode.npz`, `bode_<experiment>.png/.svg`).
    pub bode: Vec<crate::report::bode::BodeExperiment>,
    /// Each experiment's time series and spectra (`timeseries_<experiment>`,
    /// `spectra_<experiment>`).
    pub raw: Vec<crate::report::raw::RawData>,
}

/// Warnings for the numbers of `s` that are not finite, which `summary.json` writes as `null`
/// (JSON has no ∞ or NaN): each names the field and says why it can be so. R-hat is
/// explained by the chains' diagnostics, and `rho_opt_at_map` is NaN by definition for a
/// model that reads no noiseless input channel; neither is repeated here.
pub fn non_finite_warnings(s: &FitSummary) -> Vec<String> {
    let mut w = Vec::new();
    let bad = |v: f64| !v.is_finite();
    if bad(s.map_ln_posterior) {
        w.push(format!(
            "map_ln_posterior is {} (written as null in summary.json): ln L + ln π is not finite at the MAP; the likelihood overflows there (amplitudes or noise levels far out of scale?)",
            fmt_short(s.map_ln_posterior)
        ));
    }
    for r in &s.rows {
        let fields = [
            ("mean", r.mean, "the chains' draws overflow"),
            ("sd", r.sd, "the chains' draws overflow"),
            (
                "cramer_rao",
                r.cramer_rao,
                "the inverse Fisher matrix has a non-finite or negative diagonal",
            ),
            (
                "pull",
                r.pull.unwrap_or(0.0),
                "the chains' sd is 0 (the parameter did not move)",
            ),
        ];
        for (field, v, why) in fields {
            if bad(v) {
                w.push(format!(
                    "`{}`: {field} is {} (written as null in summary.json): {why}",
                    r.name,
                    fmt_short(v)
                ));
            }
        }
    }
    if s.fisher.iter().flatten().any(|v| bad(*v)) {
        w.push(
            "the Fisher matrix has non-finite entries (written as null in summary.json): ln L's derivatives overflow at the MAP".into(),
        );
    }
    w
}
