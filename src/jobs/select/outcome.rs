//! What each model's stages estimate: its evidences by every method, its MAP and the
//! diagnostics of its tempering ladder.

use crate::evidence::LaplaceEstimate;
use serde::Serialize;

/// A per-model `ln Z` estimate, or why the estimator does not apply.
#[derive(Debug, Clone, Serialize, serde::Deserialize)]
pub struct Evidence {
    pub ln_z: Option<f64>,
    /// Monte-Carlo standard error (statistical estimators only).
    pub std_err: Option<f64>,
    /// Quadrature error of a systematic estimator's box mass (not a statistical error); for
    /// thermodynamic integration, the magnitude of its discretisation error.
    pub integration_err: Option<f64>,
    /// Thermodynamic integration only: Richardson's signed correction, minus the estimated
    /// discretisation error ([`crate::evidence::ThermodynamicEstimate::discretisation_shift`]); a
    /// Bayes factor's error takes the difference of two models' shifts rather than each in
    /// quadrature.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub discretisation_shift: Option<f64>,
    /// What a systematic estimator assumes.
    pub assumes: Option<String>,
    /// Why there is no number (the estimator's own error), or a caveat.
    pub note: Option<String>,
}

impl Evidence {
    /// A Monte-Carlo estimate with its standard error.
    pub(super) fn statistical(r: Result<(f64, f64, Option<f64>), String>) -> Self {
        match r {
            Ok((ln_z, se, integration_err)) => Self {
                ln_z: Some(ln_z),
                std_err: Some(se),
                integration_err,
                discretisation_shift: None,
                assumes: None,
                note: None,
            },
            Err(m) => Self::not_applicable(m),
        }
    }

    /// A stage written by a version that did not compute this estimate (a resumed run).
    fn not_recorded() -> Self {
        Self::not_applicable(
            "not computed: this model's stage was saved by an occam without this estimator; start the run afresh for it".into(),
        )
    }

    pub(super) fn not_applicable(note: String) -> Self {
        Self {
            ln_z: None,
            std_err: None,
            integration_err: None,
            discretisation_shift: None,
            assumes: None,
            note: Some(note),
        }
    }

    /// A Laplace-type estimate: its error is the failure of `assumes`, not a ± value.
    pub(super) fn systematic(r: Result<LaplaceEstimate, String>, assumes: String) -> Self {
        match r {
            Ok(e) => Self {
                ln_z: Some(e.ln_z),
                std_err: None,
                integration_err: e.std_err,
                discretisation_shift: None,
                assumes: Some(assumes),
                note: None,
            },
            Err(m) => Self::not_applicable(m),
        }
    }
}

/// Per-model results.
#[derive(Debug, Clone, Serialize, serde::Deserialize)]
pub struct ModelOutcome {
    pub name: String,
    /// The model this is a sub-model of.
    pub model: String,
    /// That model's parameters (the order of `map` and `unbounded_max`).
    pub params: Vec<String>,
    /// Their SI units, in the same order (empty strings: dimensionless or not stated).
    #[serde(default)]
    pub units: Vec<String>,
    pub free: Vec<String>,
    pub prior_probability: f64,
    /// MAP (full parameter vector of the model), inside the prior box; the search's start
    /// point when `map_found` is false.
    pub map: Vec<f64>,
    pub map_found: bool,
    /// When an injection is missing inside gaps of the data: the bias it causes at this
    /// model's MAP ([`crate::jobs::injection_bias`]); above its limit the run is not valid.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub missing_injection_bias: Option<crate::jobs::injection_bias::InjectionBias>,
    /// Free parameters whose MAP value is on a bound of the prior box.
    pub map_at_bound: Vec<String>,
    /// Per free parameter: MAP, posterior mean ± sd of the in-model chains, Fisher σ.
    #[serde(default)]
    pub estimates: Vec<super::estimates::ParamEstimate>,
    /// How well relative binning reproduces the exact `ln L` where the samplers go (absent
    /// when the samplers ran on the exact likelihood).
    pub relbin: Option<crate::likelihood::RelBinValidation>,
    pub ln_l_map: f64,
    /// Unconstrained maximum of `ln L` (the box-corrected Laplace expansion point), when found.
    pub unbounded_max: Option<Vec<f64>>,
    /// Smallest distance of the MAP from a prior bound, in Fisher σ.
    pub min_margin_sigma: f64,
    pub laplace_fisher_raw: Evidence,
    pub laplace_fisher_box: Evidence,
    pub laplace_metropolis_mve: Evidence,
    pub laplace_metropolis_mcd: Evidence,
    /// Thermodynamic integration; `std_err` combines the Monte-Carlo error and the
    /// discretisation error (`integration_err`, signed in `discretisation_shift`).
    pub thermodynamic: Evidence,
    pub stepping_stone: Evidence,
    /// Bridge sampling between the in-model chains' posterior draws and a Gaussian fitted to
    /// them ([`crate::evidence::bridge_sampling`]).
    #[serde(default = "Evidence::not_recorded")]
    pub bridge_sampling: Evidence,
    /// The tempering run: final ladder, swap rate per adjacent pair, acceptance per rung.
    pub tempering: Option<TemperingDiagnostics>,
    pub schwarz_ln_z: f64,
    /// In-model MCMC: acceptance per chain and worst R-hat (absent when the chains failed).
    pub mcmc_acceptance: Vec<f64>,
    pub mcmc_max_rhat: Option<f64>,
    /// Iterations each in-model chain ran, burn-in included: `[select] iterations`, or more
    /// under `[select] until` (absent when the chains failed, and in runs before it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mcmc_iterations: Option<usize>,
    /// Where the reversible-jump proposal of this model comes from.
    pub jump_proposal: String,
    /// Stages that did not apply, and why.
    /// Likelihood evaluations of this model's stages (MAP search, chains, tempering) refused
    /// because the system was unstable there (`ln L = −∞`, [`crate::likelihood::stability`]).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub unstable_evaluations: u64,
    /// With a residual noise that depends on θ: the shift from the fixed-noise evidence (noise
    /// at this model's own MAP) to the exact θ-dependent one, added to every `ln B` row that
    /// involves the model ([`crate::likelihood::theta_noise::NoiseCorrection`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub noise_correction: Option<crate::likelihood::theta_noise::NoiseCorrection>,
    pub notes: Vec<String>,
}

/// What a parallel-tempering run of one model looked like.
#[derive(Debug, Clone, Serialize, serde::Deserialize)]
pub struct TemperingDiagnostics {
    pub betas: Vec<f64>,
    /// Swap acceptance of each adjacent pair of rungs.
    pub swap_acceptance: Vec<f64>,
    pub in_rung_acceptance: Vec<f64>,
    pub sweeps: usize,
    pub burn_in: usize,
    pub ln_l_evals: u64,
    /// Bound on the shift of `ln Z` by relative binning along the ladder (the rungs' kept
    /// states, exact against relative-binned `ln L`, trapezoid-weighted), added in quadrature
    /// to the thermodynamic and stepping-stone errors; absent on the exact likelihood.
    pub approximation_err: Option<f64>,
    pub seconds: f64,
}

/// Swap acceptance between neighbouring rungs below which the tempering ladder counts as
/// broken (at most one accepted swap in a hundred attempts).
pub const BROKEN_SWAP_RATE: f64 = 0.01;

impl TemperingDiagnostics {
    /// A warning when some neighbouring rungs (almost) never swapped: the ladder is then
    /// disconnected, thermodynamic integration and stepping-stone integrate over rungs that do
    /// not exchange states, and their error bars do not cover what that costs. With 8 rungs
    /// on `examples/cross-talk.toml` (four pairs at rate 0) stepping-stone gave
    /// ln B = −26.2 ± 2.3 where the bridge and Laplace–Fisher agree on −50.1 (with a ±1e−2
    /// prior on `s_xp`); 32 rungs (lowest rate 0.07) bring it to within 2.2 nats.
    pub fn broken_ladder_warning(&self) -> Option<String> {
        let broken: Vec<String> = self
            .swap_acceptance
            .iter()
            .enumerate()
            .filter(|(_, r)| !(**r >= BROKEN_SWAP_RATE))
            .map(|(k, r)| {
                let b = |i: usize| self.betas.get(i).copied().unwrap_or(f64::NAN);
                format!("{k}–{} (β {:.2e}–{:.2e}: {r:.3})", k + 1, b(k), b(k + 1))
            })
            .collect();
        (!broken.is_empty()).then(|| {
            format!(
                "parallel tempering: neighbouring rungs {} swapped at a rate below {BROKEN_SWAP_RATE}: the ladder is broken there, so thermodynamic integration and stepping-stone rest on rungs that do not exchange states and their error bars understate their error; raise [select] pt_temperatures (or pt_burn_in, over which the ladder adapts)",
                broken.join(", ")
            )
        })
    }
}

/// Whether a count is zero (not written then).
fn is_zero(n: &u64) -> bool {
    *n == 0
}

#[cfg(test)]
mod tests {
    use super::*;

    fn diag(swaps: &[f64]) -> TemperingDiagnostics {
        TemperingDiagnostics {
            betas: (0..=swaps.len())
                .map(|i| 10f64.powi(i as i32 - 4))
                .collect(),
            swap_acceptance: swaps.to_vec(),
            in_rung_acceptance: vec![0.3; swaps.len() + 1],
            sweeps: 1000,
            burn_in: 500,
            ln_l_evals: 0,
            approximation_err: None,
            seconds: 0.0,
        }
    }

    #[test]
    fn a_ladder_with_rungs_that_never_swap_is_reported() {
        assert!(diag(&[0.7, 0.3, 0.07]).broken_ladder_warning().is_none());
        let w = diag(&[0.5, 0.0, 0.2, 0.004])
            .broken_ladder_warning()
            .expect("two pairs below the rate");
        assert!(w.contains("1–2 (β 1.00e-3–1.00e-2: 0.000)"), "{w}");
        assert!(w.contains("3–4"), "{w}");
        assert!(!w.contains("0–1") && !w.contains("2–3"), "{w}");
        assert!(w.contains("pt_temperatures"), "{w}");
        // a NaN rate (no attempts recorded) is not taken for a working pair
        assert!(diag(&[f64::NAN]).broken_ladder_warning().is_some());
    }
}
