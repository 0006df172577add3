//! The exact frequency-domain likelihood of the 7-parameter LTP model over all in-band bins.

use super::spectra::ExperimentSpectra;
use crate::density::LogDensity;
use crate::hermitian;
use crate::lti::delay;
use crate::ltp::{LoopKernel, Masses, N_PARAMS, response};
use crate::prior::Prior;
use num_complex::Complex64;

/// How often the delay phasors are recomputed exactly in [`LtpLikelihood::residual_power`].
pub const PHASOR_RESEED: usize = 256;

/// `ln L(θ)` of the full 7-parameter closed-loop model, summed over experiments.
///
/// # Formula
/// `ln L(θ) = −Σ_e Σ_{k ∈ band} R_kᴴ C_k⁻¹ R_k − Σ_e Σ_k ln(π² det C_k)`, with
/// `R_k = Y_k − H_io(f_k; θ) I_k` and `C_k = (fs/2) Σw² S_k` (ltp-model.md §8.2). The constant
/// makes `L` the density of the in-band DFT data (a circular complex Gaussian per bin), so
/// evidences are proper densities; it cancels in every Bayes factor.
#[derive(Debug, Clone)]
pub struct LtpLikelihood {
    spectra: Vec<ExperimentSpectra>,
    masses: Masses,
    prior: Prior,
    ln_norm: f64,
}

/// Errors building a likelihood.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum LikelihoodError {
    #[error(
        "the prior has {0} parameters; the LTP model has 7 (w1sq, w2sq, dt1, dt2, a_df, a_sus, d21)"
    )]
    PriorDim(usize),
    #[error("no experiments to fit")]
    NoData,
    #[error("experiments have different sample rates or are inconsistent: {0}")]
    Inconsistent(String),
}

impl LtpLikelihood {
    /// A likelihood over `spectra` with a normalised 7-parameter prior.
    pub fn new(
        spectra: Vec<ExperimentSpectra>,
        masses: Masses,
        prior: Prior,
    ) -> Result<Self, LikelihoodError> {
        if prior.dim() != N_PARAMS {
            return Err(LikelihoodError::PriorDim(prior.dim()));
        }
        if spectra.is_empty() {
            return Err(LikelihoodError::NoData);
        }
        let mut ln_norm = 0.0;
        for e in &spectra {
            for &(a, b, c) in &e.cinv {
                // det C = 1/det C⁻¹
                let det_inv = a * c - b.norm_sqr();
                ln_norm -= 2.0 * std::f64::consts::PI.ln() - det_inv.ln();
            }
        }
        Ok(Self {
            spectra,
            masses,
            prior,
            ln_norm,
        })
    }

    /// The prepared spectra.
    pub fn spectra(&self) -> &[ExperimentSpectra] {
        &self.spectra
    }

    /// The masses of the fit model.
    pub fn masses(&self) -> &Masses {
        &self.masses
    }

    /// The θ-independent normalisation `−Σ ln(π² det C_k)`.
    pub fn ln_norm(&self) -> f64 {
        self.ln_norm
    }

    /// Number of in-band bins over all experiments.
    pub fn n_bins(&self) -> usize {
        self.spectra.iter().map(|e| e.len()).sum()
    }

    /// Number of real data values entering the likelihood: 2 (re, im) × 2 channels × bins.
    pub fn n_real_data(&self) -> usize {
        4 * self.n_bins()
    }

    /// `Σ R_kᴴ C_k⁻¹ R_k` (the "χ²/2" of the residual; `ln L = −this + ln_norm`).
    ///
    /// The hot path: [`LoopKernel`] per bin, guidance-delay phasors by recurrence on the
    /// uniform DFT grid (re-seeded exactly every [`PHASOR_RESEED`] bins, so rounding cannot
    /// accumulate beyond ~1e−14), no allocation.
    pub fn residual_power(&self, th: &[f64; N_PARAMS]) -> f64 {
        let kern = LoopKernel::new(th, &self.masses);
        let mut s = 0.0;
        for e in &self.spectra {
            let step = [delay(th[2], e.df), delay(th[3], e.df)];
            let mut t = [Complex64::new(1.0, 0.0); 2];
            for k in 0..e.len() {
                if k % PHASOR_RESEED == 0 {
                    let f = e.freqs[k];
                    t = [delay(th[2], f), delay(th[3], f)];
                }
                let h = kern.eval(&e.consts[k], t, e.inj[k]);
                let r = [e.y[k][0] - h[0], e.y[k][1] - h[1]];
                s += hermitian::quad(&e.cinv[k], r);
                t[0] *= step[0];
                t[1] *= step[1];
            }
        }
        s
    }

    /// `ln L` at a full parameter vector.
    pub fn ln_likelihood_full(&self, th: &[f64; N_PARAMS]) -> f64 {
        -self.residual_power(th) + self.ln_norm
    }

    /// Templates `h_k(θ)` of every experiment.
    pub fn templates(&self, th: &[f64; N_PARAMS]) -> Vec<Vec<[Complex64; 2]>> {
        self.spectra
            .iter()
            .map(|e| {
                (0..e.len())
                    .map(|k| response(th, &e.consts[k], &self.masses, e.inj[k]))
                    .collect()
            })
            .collect()
    }

    /// Optimal SNR `ρ_opt = √⟨h|h⟩ = √(2 Σ h_kᴴ C_k⁻¹ h_k)` of the template at θ.
    pub fn snr(&self, th: &[f64; N_PARAMS]) -> f64 {
        let mut s = 0.0;
        for (e, h) in self.spectra.iter().zip(self.templates(th)) {
            for (k, hk) in h.into_iter().enumerate() {
                s += 2.0 * hermitian::quad(&e.cinv[k], hk);
            }
        }
        s.sqrt()
    }
}

impl LogDensity for LtpLikelihood {
    fn ln_likelihood(&self, theta: &[f64]) -> f64 {
        let th: &[f64; N_PARAMS] = match theta.try_into() {
            Ok(t) => t,
            Err(_) => return f64::NAN,
        };
        self.ln_likelihood_full(th)
    }

    fn prior(&self) -> &Prior {
        &self.prior
    }
}
