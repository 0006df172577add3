//! The exact frequency-domain likelihood of any [`Model`] over all in-band bins.

use super::spectra::ExperimentSpectra;
use super::statistic::{
    LogPeriodogramOptions, LogPgExperiment, Statistic, student_t_const, student_t_shape,
    wishart_const, wishart_shape,
};
use crate::data::dataset::ExperimentData;
use crate::density::LogDensity;
use crate::model::{BlockKernel, MAX_CHANNELS, MAX_RESIDUALS, Model, residual_into, with_buffer};
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
///
/// That is the default statistic, [`Statistic::Whittle`]; [`Likelihood::with_statistic`]
/// makes [`Likelihood::ln_likelihood_full`] (hence every sampler and evidence estimator) use
/// the Student-t, the Wishart or the log-periodogram likelihood instead (`crate::likelihood::statistic`).
/// The Gaussian pieces (residual power, Fisher matrix, MAP search, relative binning) stay
/// available through [`Likelihood::ln_likelihood_whittle`]: one type, so `fit`, `select` and
/// `sweep` need no second code path, and the statistic travels with the likelihood.
#[derive(Debug, Clone)]
pub struct Likelihood {
    model: Arc<dyn Model>,
    spectra: Vec<ExperimentSpectra>,
    /// The model as it applies to each experiment ([`Model::specialise`]): `model` itself
    /// unless its coefficients depend on the experiment's stretch or covariates.
    per_exp: Vec<Arc<dyn Model>>,
    /// The model's prepared kernel per experiment, if it has one.
    kernels: Vec<Option<Arc<dyn BlockKernel>>>,
    /// The model's kernel for all experiments at once, if it has one (used instead).
    joint: Option<Arc<dyn BlockKernel>>,
    prior: Prior,
    ln_norm: f64,
    stat: StatState,
    /// Evaluations refused at unstable parameter values ([`super::stability`]).
    unstable: super::stability::UnstableCount,
}

/// The θ-independent state of the chosen statistic.
#[derive(Debug, Clone)]
enum StatState {
    Whittle,
    /// Degrees of freedom per experiment, per bin where they differ between bins
    /// (`welch_resolution = "per_band"`), and `Σ_k c_k`.
    StudentT {
        nu: Vec<f64>,
        bins: Vec<Option<Vec<f64>>>,
        ln_norm: f64,
    },
    /// Effective complex averages `M = ν/2` per experiment, per bin where they differ, and
    /// `Σ_k c_k`.
    Wishart {
        m: Vec<f64>,
        bins: Vec<Option<Vec<f64>>>,
        ln_norm: f64,
    },
    LogPeriodogram(Vec<LogPgExperiment>),
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
    #[error("statistic `{0}`: {1}")]
    Statistic(&'static str, String),
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
            if nr <= 2 {
                for &(a, b, c) in &e.cinv {
                    // det C = 1/det C⁻¹
                    let det_inv = if nr == 2 { a * c - b.norm_sqr() } else { a };
                    ln_norm -= nr as f64 * std::f64::consts::PI.ln() - det_inv.ln();
                }
            } else {
                for &ld in &e.ln_det {
                    ln_norm -= nr as f64 * std::f64::consts::PI.ln() + ld;
                }
            }
        }
        let per_exp = spectra
            .iter()
            .map(|e| {
                let m = model.specialise(&e.covariates).map_err(|m| {
                    LikelihoodError::Model(
                        model.name().into(),
                        format!("experiment `{}`: {m}", e.name),
                    )
                })?;
                Ok(m.unwrap_or_else(|| model.clone()))
            })
            .collect::<Result<Vec<_>, LikelihoodError>>()?;
        let specialised = per_exp.iter().any(|m| !Arc::ptr_eq(m, &model));
        let blocks: Vec<_> = spectra.iter().map(|e| e.block()).collect();
        // a joint kernel shares one θ's work between experiments: only for one model
        let joint = if specialised {
            None
        } else {
            model.prepare_joint_kernel(&blocks)
        };
        let kernels = match joint {
            Some(_) => vec![None; spectra.len()],
            None => blocks
                .iter()
                .zip(&per_exp)
                .map(|(b, m)| m.prepare_kernel(b))
                .collect(),
        };
        Ok(Self {
            model,
            spectra,
            per_exp,
            kernels,
            joint,
            prior,
            ln_norm,
            stat: StatState::Whittle,
            unstable: Default::default(),
        })
    }

    /// The same likelihood with statistic `statistic`. `data` are the experiments the spectra
    /// were prepared from, in the same order (read by the log-periodogram only, which needs
    /// the whole residual time series); `lp` are the log-periodogram's Welch settings.
    ///
    /// The Student-t and the Wishart need the Welch noise estimate (its degrees of freedom,
    /// per bin with per-band resolution); with `noise = "model"` the PSD is exact and the
    /// statistic is an error. The Wishart also needs `M_eff > R − 1` at every bin.
    pub fn with_statistic(
        mut self,
        statistic: Statistic,
        lp: &LogPeriodogramOptions,
        data: &[ExperimentData],
    ) -> Result<Self, LikelihoodError> {
        let name = statistic.name();
        let nr = self.model.residual_channels().len();
        self.stat = match statistic {
            Statistic::Whittle => StatState::Whittle,
            Statistic::StudentT | Statistic::Wishart => {
                let wishart = statistic == Statistic::Wishart;
                // ν = 2 M_eff per experiment (and per bin), from the Welch settings
                let mut per_exp = Vec::with_capacity(self.spectra.len());
                let mut bins = Vec::with_capacity(self.spectra.len());
                let mut c = self.ln_norm;
                for e in &self.spectra {
                    let v = e.noise_dof.ok_or_else(|| {
                        LikelihoodError::Statistic(
                            name,
                            format!(
                                "experiment `{}` uses the exact noise model (analysis.noise = \"model\"), which has no estimation uncertainty to marginalise; use analysis.noise = \"welch\" or statistic = \"whittle\"",
                                e.name
                            ),
                        )
                    })?;
                    // the statistic's own parameter: ν for the Student-t, M = ν/2 for the
                    // Wishart
                    let conv = |nu: f64| if wishart { 0.5 * nu } else { nu };
                    let cst = |x: f64| {
                        if wishart {
                            wishart_const(nr, x)
                        } else {
                            student_t_const(nr, x)
                        }
                    };
                    let per_bin = e
                        .noise_dof_per_bin
                        .as_ref()
                        .map(|b| b.iter().map(|&x| conv(x)).collect::<Vec<f64>>());
                    let lowest = per_bin
                        .as_ref()
                        .map_or(conv(v), |b| b.iter().cloned().fold(f64::INFINITY, f64::min));
                    if wishart && lowest <= nr as f64 - 1.0 {
                        return Err(LikelihoodError::Statistic(
                            name,
                            format!(
                                "experiment `{}`: the Welch noise estimate has {lowest:.3} effective averages at its coarsest bin, and the complex inverse-Wishart posterior of a {nr}×{nr} CSD is proper only with more than {}: lengthen the noise-only stretch, use welch_resolution = \"fixed\" (per band, the lowest bins have one segment) or statistic = \"student_t\"",
                                e.name,
                                nr - 1
                            ),
                        ));
                    }
                    match &per_bin {
                        None => c += e.len() as f64 * cst(conv(v)),
                        Some(b) => c += b.iter().map(|&x| cst(x)).sum::<f64>(),
                    }
                    per_exp.push(conv(v));
                    bins.push(per_bin);
                }
                if wishart {
                    StatState::Wishart {
                        m: per_exp,
                        bins,
                        ln_norm: c,
                    }
                } else {
                    StatState::StudentT {
                        nu: per_exp,
                        bins,
                        ln_norm: c,
                    }
                }
            }
            Statistic::LogPeriodogram => {
                if data.len() != self.spectra.len() {
                    return Err(LikelihoodError::Statistic(
                        name,
                        format!(
                            "{} experiments of data for {} prepared spectra",
                            data.len(),
                            self.spectra.len()
                        ),
                    ));
                }
                let exps = data
                    .iter()
                    .zip(&self.spectra)
                    .zip(&self.per_exp)
                    .map(|((d, sp), m)| LogPgExperiment::new(d, sp, m.as_ref(), lp))
                    .collect::<Result<Vec<_>, _>>()
                    .map_err(|m| LikelihoodError::Statistic(name, m))?;
                StatState::LogPeriodogram(exps)
            }
        };
        Ok(self)
    }

    /// The statistic [`Likelihood::ln_likelihood_full`] evaluates.
    pub fn statistic(&self) -> Statistic {
        match self.stat {
            StatState::Whittle => Statistic::Whittle,
            StatState::StudentT { .. } => Statistic::StudentT,
            StatState::Wishart { .. } => Statistic::Wishart,
            StatState::LogPeriodogram(_) => Statistic::LogPeriodogram,
        }
    }

    /// The Student-t degrees of freedom per experiment (empty for other statistics; with
    /// per-band Welch resolution the lowest of the experiment's bins, see
    /// [`ExperimentSpectra::noise_dof_per_bin`]).
    pub fn student_t_dof(&self) -> &[f64] {
        match &self.stat {
            StatState::StudentT { nu, .. } => nu,
            _ => &[],
        }
    }

    /// The Wishart statistic's effective complex averages `M = ν/2` per experiment (empty for
    /// other statistics; with per-band Welch resolution the lowest of the experiment's bins).
    pub fn wishart_averages(&self) -> &[f64] {
        match &self.stat {
            StatState::Wishart { m, .. } => m,
            _ => &[],
        }
    }

    /// Per experiment: the frequencies of the log-periodogram's retained Welch bins and its
    /// effective number of averages `M_eff` (empty for other statistics).
    pub fn log_periodogram_bins(&self) -> Vec<(Vec<f64>, f64)> {
        match &self.stat {
            StatState::LogPeriodogram(x) => x.iter().map(|e| (e.freqs(), e.m_eff)).collect(),
            _ => Vec::new(),
        }
    }

    /// The model.
    pub fn model(&self) -> &Arc<dyn Model> {
        &self.model
    }

    /// The model as it applies to experiment `e` (index into [`Likelihood::spectra`]): the
    /// model itself unless it depends on the experiment's stretch or covariates
    /// ([`Model::specialise`]). Everything evaluated per experiment goes through it.
    pub fn model_of(&self, e: usize) -> &Arc<dyn Model> {
        &self.per_exp[e]
    }

    /// [`Likelihood::model_of`] for a spectrum of this likelihood (the model itself for any
    /// other).
    pub fn model_for(&self, e: &ExperimentSpectra) -> &Arc<dyn Model> {
        self.spectra
            .iter()
            .position(|x| std::ptr::eq(x, e))
            .map_or(&self.model, |i| &self.per_exp[i])
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
            .zip(&self.per_exp)
            .map(|((e, k), m)| match k {
                Some(k) => k.residual_power(th),
                None => m.residual_power(th, &e.block()),
            })
            .sum()
    }

    /// As [`Likelihood::residual_power`] through [`Model::residual_power`] only (no prepared
    /// kernel): the reference prepared kernels are tested against.
    pub fn residual_power_unprepared(&self, th: &[f64]) -> f64 {
        self.spectra
            .iter()
            .zip(&self.per_exp)
            .map(|(e, m)| m.residual_power(th, &e.block()))
            .sum()
    }

    /// `ln L` of the statistic ([`Likelihood::statistic`]) at a full parameter vector.
    pub fn ln_likelihood_full(&self, th: &[f64]) -> f64 {
        if th.len() != self.model.param_names().len() {
            return f64::NAN;
        }
        if !self.unstable.admit(self.model.as_ref(), th) {
            return f64::NEG_INFINITY;
        }
        match &self.stat {
            StatState::Whittle => -self.residual_power(th) + self.ln_norm,
            StatState::StudentT { nu, bins, ln_norm } => {
                let nr = self.model.residual_channels().len();
                self.marginal_shape_sum(th, nu, bins, |q, v| student_t_shape(q, nr, v)) + ln_norm
            }
            StatState::Wishart { m, bins, ln_norm } => {
                self.marginal_shape_sum(th, m, bins, wishart_shape) + ln_norm
            }
            StatState::LogPeriodogram(x) => x
                .iter()
                .zip(&self.per_exp)
                .map(|(e, m)| e.eval(m.as_ref(), th, None))
                .sum(),
        }
    }

    /// `ln L` of the statistic term by term: per experiment (in the order of
    /// [`Likelihood::spectra`]), one value per in-band bin (at [`ExperimentSpectra::freqs`]),
    /// each bin's share of [`Likelihood::ln_likelihood_full`] with its share of the
    /// normalisation, so that the terms sum to `ln L` (to rounding). Pointwise terms are what
    /// leave-one-out cross-validation (ArviZ's `loo`) needs: the bins are the independent
    /// observations of the Whittle, Student-t and Wishart likelihoods.
    ///
    /// Every term is `−∞` where the model's system is unstable (as `ln L` is). The
    /// log-periodogram has no per-DFT-bin terms (it sums over Welch bins of the residual):
    /// an error says so, as does a `th` of the wrong length.
    pub fn ln_likelihood_per_bin(&self, th: &[f64]) -> Result<Vec<Vec<f64>>, LikelihoodError> {
        let np = self.model.param_names().len();
        if th.len() != np {
            return Err(LikelihoodError::Model(
                self.model.name().into(),
                format!("{} parameter values for {np} parameters", th.len()),
            ));
        }
        if let StatState::LogPeriodogram(_) = self.stat {
            return Err(LikelihoodError::Statistic(
                Statistic::LogPeriodogram.name(),
                "ln L is a sum over Welch bins of the residual, not over DFT bins: there are no per-bin terms; use statistic = \"whittle\" for pointwise ln L".into(),
            ));
        }
        if !self.unstable.admit(self.model.as_ref(), th) {
            return Ok(self
                .spectra
                .iter()
                .map(|e| vec![f64::NEG_INFINITY; e.len()])
                .collect());
        }
        let nr = self.model.residual_channels().len();
        let ln_pi = nr as f64 * std::f64::consts::PI.ln();
        let mut out = Vec::with_capacity(self.spectra.len());
        for (i, e) in self.spectra.iter().enumerate() {
            let mut terms = Vec::with_capacity(e.len());
            self.visit_residuals(e, th, |k, r, _| {
                // the bin's share of `ln_norm`, as `Likelihood::new` sums it
                let norm = if nr <= 2 {
                    let (a, b, c) = e.cinv[k];
                    let det_inv = if nr == 2 { a * c - b.norm_sqr() } else { a };
                    -(ln_pi - det_inv.ln())
                } else {
                    -(ln_pi + e.ln_det[k])
                };
                let q = e.quad(k, r);
                // the statistic's parameter (ν or M) of this bin
                let at = |per_exp: &[f64], bins: &[Option<Vec<f64>>]| {
                    bins[i].as_ref().map_or(per_exp[i], |b| b[k])
                };
                terms.push(match &self.stat {
                    StatState::StudentT { nu, bins, .. } => {
                        let v = at(nu, bins);
                        norm + student_t_const(nr, v) - student_t_shape(q, nr, v)
                    }
                    StatState::Wishart { m, bins, .. } => {
                        let v = at(m, bins);
                        norm + wishart_const(nr, v) - wishart_shape(q, v)
                    }
                    // the log-periodogram returned above
                    _ => norm - q,
                });
            });
            out.push(terms);
        }
        Ok(out)
    }

    /// Evaluations refused so far because the model's system was unstable there
    /// ([`super::stability`]).
    pub fn unstable_evaluations(&self) -> u64 {
        self.unstable.get()
    }

    /// The Whittle (Gaussian, known-PSD) `ln L`, whatever the statistic: what the Fisher
    /// matrix, the MAP search and relative binning approximate.
    pub fn ln_likelihood_whittle(&self, th: &[f64]) -> f64 {
        if th.len() != self.model.param_names().len() {
            return f64::NAN;
        }
        if !self.unstable.admit(self.model.as_ref(), th) {
            return f64::NEG_INFINITY;
        }
        -self.residual_power(th) + self.ln_norm
    }

    /// `−Σ_e Σ_k shape(q_k, p_{e,k})` bin by bin through the coefficients, with the
    /// statistic's parameter `p` (ν or M) per experiment, or per bin where `bins` has it: the
    /// Student-t's `((ν + d)/2) ln(1 + 2 q_k/ν)` or the Wishart's `(M + 1) ln(1 + q_k/M)`.
    fn marginal_shape_sum(
        &self,
        th: &[f64],
        per_exp: &[f64],
        bins: &[Option<Vec<f64>>],
        shape: impl Fn(f64, f64) -> f64,
    ) -> f64 {
        let nc = self.model.data_channels().len();
        let nr = self.model.residual_channels().len();
        let ncst = self.model.n_consts();
        let mut r = [Complex64::new(0.0, 0.0); MAX_RESIDUALS];
        let r = &mut r[..nr];
        with_buffer(nr * nc, |coef| {
            let mut s = 0.0;
            for (((e, &v), b), m) in self
                .spectra
                .iter()
                .zip(per_exp)
                .zip(bins)
                .zip(&self.per_exp)
            {
                for k in 0..e.len() {
                    m.coefficients(th, &e.bin(k, ncst), coef);
                    residual_into(coef, e.data_at(k), r);
                    let p = b.as_ref().map_or(v, |b| b[k]);
                    s -= shape(e.quad(k, r), p);
                }
            }
            s
        })
    }

    /// The residual `r_k(θ)` and the signal `s_k(θ)` (the part of the residual from the known
    /// input channels) of every bin of experiment `e`, through `visit(k, r, s)` (`R` values
    /// each).
    pub fn visit_residuals(
        &self,
        e: &ExperimentSpectra,
        th: &[f64],
        mut visit: impl FnMut(usize, &[Complex64], &[Complex64]),
    ) {
        let m = self.model_for(e);
        let nc = m.data_channels().len();
        let nr = m.residual_channels().len();
        let ncst = m.n_consts();
        let zero = Complex64::new(0.0, 0.0);
        let mut din = [zero; MAX_CHANNELS];
        let (mut r, mut sig) = ([zero; MAX_RESIDUALS], [zero; MAX_RESIDUALS]);
        with_buffer(nr * nc, |coef| {
            for k in 0..e.len() {
                m.coefficients(th, &e.bin(k, ncst), coef);
                let d = e.data_at(k);
                for c in 0..nc {
                    din[c] = if e.is_input[c] { d[c] } else { zero };
                }
                residual_into(coef, d, &mut r[..nr]);
                residual_into(coef, &din[..nc], &mut sig[..nr]);
                visit(k, &r[..nr], &sig[..nr]);
            }
        })
    }

    /// Optimal SNR `ρ_opt = √⟨s|s⟩ = √(2 Σ s_kᴴ C_k⁻¹ s_k)` of the signal at θ: the model's
    /// response to the known inputs (for the closed loop, `H_io I`).
    ///
    /// NaN for a model that reads no noiseless input channel (the acceleration domain reads
    /// telemetry, which carries noise): it has no signal in this sense.
    pub fn snr(&self, th: &[f64]) -> f64 {
        if !self.spectra.iter().any(|e| e.is_input.iter().any(|&x| x)) {
            return f64::NAN;
        }
        let mut s = 0.0;
        for e in &self.spectra {
            self.visit_residuals(e, th, |k, _, sig| {
                s += 2.0 * e.quad(k, sig);
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
