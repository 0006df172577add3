//! The exact frequency-domain likelihood of any [`Model`] over all in-band bins.

use super::spectra::ExperimentSpectra;
use crate::density::LogDensity;
use crate::hermitian;
use crate::model::{BlockKernel, MAX_CHANNELS, MAX_RESIDUALS, Model, residual};
use crate::prior::Prior;
use num_complex::Complex64;
use std::sync::Arc;

/// `ln L(θ)` of a model, summed over experiments.
///
/// # Formula
/// `ln L(θ) = −Σ_e Σ_{k ∈ band} r_kᴴ C_k⁻¹ r_k − Σ_e Σ_k ln(π^R det C_k)`, with the residual
/// `r_k = Σ_c M_c(f_k; θ) d_c,k` and `C_k = (fs/2) Σw² S_r,k` (ltp-model.md §8.2; for the LTP
/// closed loop `r_k = Y_k − H_io(f_k; θ) I_k`). The constant makes `L` the density of the
/// in-band residual DFTs (a circular complex Gaussian per bin), so evidences are proper
/// densities; it cancels in every Bayes factor.
#[derive(Debug, Clone)]
pub struct Likelihood {
    model: Arc<dyn Model>,
    spectra: Vec<ExperimentSpectra>,
    /// The model's prepared kernel per experiment, if it has one.
    kernels: Vec<Option<Arc<dyn BlockKernel>>>,
    /// The model's kernel for all experiments at once, if it has one (used instead).
    joint: Option<Arc<dyn BlockKernel>>,
    prior: Prior,
    ln_norm: f64,
}

/// Errors building a likelihood.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum LikelihoodError {
    #[error("the prior has parameters {prior:?}; model `{model}` has {params:?}")]
    PriorNames {
        model: String,
        prior: Vec<String>,
        params: Vec<String>,
    },
    #[error("no experiments to fit")]
    NoData,
    #[error("model `{0}`: {1}")]
    Model(String, String),
    #[error(
        "experiment `{exp}` was prepared for data channels {got:?}; model `{model}` reads {want:?}"
    )]
    Channels {
        exp: String,
        model: String,
        got: Vec<String>,
        want: Vec<String>,
    },
}

impl Likelihood {
    /// A likelihood of `model` over `spectra` (prepared for this model) with a normalised prior
    /// over the model's parameters, in its order.
    pub fn new(
        model: Arc<dyn Model>,
        spectra: Vec<ExperimentSpectra>,
        prior: Prior,
    ) -> Result<Self, LikelihoodError> {
        crate::model::validate_shape(model.as_ref())
            .map_err(|e| LikelihoodError::Model(model.name().into(), e))?;
        if prior.names() != model.param_names() {
            return Err(LikelihoodError::PriorNames {
                model: model.name().into(),
                prior: prior.names().to_vec(),
                params: model.param_names().to_vec(),
            });
        }
        if spectra.is_empty() {
            return Err(LikelihoodError::NoData);
        }
        let nr = model.residual_channels().len();
        let mut ln_norm = 0.0;
        for e in &spectra {
            if e.channels != model.data_channels() {
                return Err(LikelihoodError::Channels {
                    exp: e.name.clone(),
                    model: model.name().into(),
                    got: e.channels.clone(),
                    want: model.data_channels().to_vec(),
                });
            }
            for &(a, b, c) in &e.cinv {
                // det C = 1/det C⁻¹
                let det_inv = if nr == 2 { a * c - b.norm_sqr() } else { a };
                ln_norm -= nr as f64 * std::f64::consts::PI.ln() - det_inv.ln();
            }
        }
        let blocks: Vec<_> = spectra.iter().map(|e| e.block()).collect();
        let joint = model.prepare_joint_kernel(&blocks);
        let kernels = match joint {
            Some(_) => vec![None; spectra.len()],
            None => blocks.iter().map(|b| model.prepare_kernel(b)).collect(),
        };
        Ok(Self {
            model,
            spectra,
            kernels,
            joint,
            prior,
            ln_norm,
        })
    }

    /// The model.
    pub fn model(&self) -> &Arc<dyn Model> {
        &self.model
    }

    /// The prepared spectra.
    pub fn spectra(&self) -> &[ExperimentSpectra] {
        &self.spectra
    }

    /// The θ-independent normalisation `−Σ ln(π^R det C_k)`.
    pub fn ln_norm(&self) -> f64 {
        self.ln_norm
    }

    /// Number of in-band bins over all experiments.
    pub fn n_bins(&self) -> usize {
        self.spectra.iter().map(|e| e.len()).sum()
    }

    /// Number of real data values entering the likelihood: 2 (re, im) × residual channels ×
    /// bins.
    pub fn n_real_data(&self) -> usize {
        2 * self.model.residual_channels().len() * self.n_bins()
    }

    /// `Σ r_kᴴ C_k⁻¹ r_k` (the "χ²/2" of the residual; `ln L = −this + ln_norm`), through the
    /// model's prepared kernels ([`Model::prepare_joint_kernel`], else
    /// [`Model::prepare_kernel`]) or [`Model::residual_power`].
    pub fn residual_power(&self, th: &[f64]) -> f64 {
        if let Some(k) = &self.joint {
            return k.residual_power(th);
        }
        self.spectra
            .iter()
            .zip(&self.kernels)
            .map(|(e, k)| match k {
                Some(k) => k.residual_power(th),
                None => self.model.residual_power(th, &e.block()),
            })
            .sum()
    }

    /// As [`Likelihood::residual_power`] through [`Model::residual_power`] only (no prepared
    /// kernel): the reference prepared kernels are tested against.
    pub fn residual_power_unprepared(&self, th: &[f64]) -> f64 {
        self.spectra
            .iter()
            .map(|e| self.model.residual_power(th, &e.block()))
            .sum()
    }

    /// `ln L` at a full parameter vector.
    pub fn ln_likelihood_full(&self, th: &[f64]) -> f64 {
        if th.len() != self.model.param_names().len() {
            return f64::NAN;
        }
        -self.residual_power(th) + self.ln_norm
    }

    /// The residual `r_k(θ)` and the signal `s_k(θ)` (the part of the residual from the known
    /// input channels) of every bin of experiment `e`, through `visit(k, r, s)`.
    pub fn visit_residuals(
        &self,
        e: &ExperimentSpectra,
        th: &[f64],
        mut visit: impl FnMut(usize, [Complex64; 2], [Complex64; 2]),
    ) {
        let m = &self.model;
        let nc = m.data_channels().len();
        let nr = m.residual_channels().len();
        let ncst = m.n_consts();
        let mut coef = [Complex64::new(0.0, 0.0); MAX_CHANNELS * MAX_RESIDUALS];
        let mut din = [Complex64::new(0.0, 0.0); MAX_CHANNELS];
        for k in 0..e.len() {
            m.coefficients(th, &e.bin(k, ncst), &mut coef[..nr * nc]);
            let d = e.data_at(k);
            for c in 0..nc {
                din[c] = if e.is_input[c] {
                    d[c]
                } else {
                    Complex64::new(0.0, 0.0)
                };
            }
            visit(k, residual(&coef, nr, d), residual(&coef, nr, &din[..nc]));
        }
    }

    /// Optimal SNR `ρ_opt = √⟨s|s⟩ = √(2 Σ s_kᴴ C_k⁻¹ s_k)` of the signal at θ: the model's
    /// response to the known inputs (for the closed loop, `H_io I`).
    pub fn snr(&self, th: &[f64]) -> f64 {
        let mut s = 0.0;
        for e in &self.spectra {
            self.visit_residuals(e, th, |k, _, sig| {
                s += 2.0 * hermitian::quad(&e.cinv[k], sig);
            });
        }
        s.sqrt()
    }
}

impl LogDensity for Likelihood {
    fn ln_likelihood(&self, theta: &[f64]) -> f64 {
        self.ln_likelihood_full(theta)
    }

    fn prior(&self) -> &Prior {
        &self.prior
    }
}
