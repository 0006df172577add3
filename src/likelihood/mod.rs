//! The frequency-domain likelihood (ltp-model.md §8) of any [`crate::model::Model`]:
//! per-experiment spectra, the exact `ln L` over all in-band bins, a relative-binned fast
//! `ln L`, Fisher matrices and the MAP search.
//!
//! `ln L = −Σ_e Σ_k r_kᴴ C_k⁻¹ r_k + const`, `r_k = Σ_c M_c(f_k; θ) d_c,k` (for the closed loop
//! `r_k = Y_k − H_io(f_k; θ) I_k`),
//! `C_k = (fs/2) Σ_n w[n]² S_k` (`= (N fs/2) S_k` for the rectangular window): normalised by the
//! series length `N`, not by the number of in-band bins.

mod degeneracy;
mod exact;
mod fisher;
pub mod glitch_gate;
pub mod information;
mod map;
mod multistart;
mod noise_matrix;
mod relbin;
pub mod residual_psd;
mod run_noise;
mod segments;
mod spectra;
pub mod stability;
pub mod statistic;
pub mod theta_noise;
pub mod transfer;

pub use degeneracy::{CONDITION_LIMIT, CORRELATION_LIMIT, Degeneracy, degeneracy_warning};
pub use exact::{Likelihood, LikelihoodError};
#[cfg(test)]
pub(crate) use fisher::gradient_and_fisher_serial;
pub use fisher::{
    cramer_rao, default_step, describe_unconstrained, fisher_exact, fisher_numeric, fisher_parts,
    gradient_and_fisher, gradient_hessian_numeric, residual_derivatives, sandwich_errors,
    score_covariance, score_covariance_differs,
};
pub use glitch_gate::{
    DEFAULT_GLITCH_AMPLITUDE, DEFAULT_GLITCH_DECAY, DEFAULT_GLITCH_PAD, DEFAULT_GLITCH_RISE,
    DEFAULT_GLITCH_TAIL, DEFAULT_GLITCH_THRESHOLD, GlitchGate, GlitchTreatment, OUTLASTING_LIMIT,
    detect_glitches,
};
pub use map::{
    MapError, RUNAWAY_WIDTHS, ScoringResult, fisher_scoring, fisher_scoring_unbounded,
    refine_statistic_max,
};
pub use multistart::{
    CHAIN_MARGIN, MapStart, Maximum, MultiStartMap, NEGLIGIBLE_LN_MASS, NO_MASS, StartFrom,
    multi_start_map, quasi_random_starts,
};
pub use relbin::{MAX_REFINEMENTS, RelBinError, RelBinLikelihood, RelBinOptions, RelBinValidation};
pub use run_noise::NoiseLeak;
pub use segments::GapSummary;
pub use spectra::{
    DEFAULT_GAP_TAPER, ExperimentSpectra, MAX_WINDOW_LAGS, NoiseSource, SpectraError,
    SpectraOptions, WelchResolution, averages_per_decade, welch_segment_len, welch_segment_len_for,
    window_lags,
};
pub use statistic::{LogPeriodogramOptions, Statistic};

#[cfg(test)]
mod nch_tests;
#[cfg(test)]
mod statistic_tests;
#[cfg(test)]
pub(crate) mod tests;
