//! Likelihoods for a residual whose noise PSD is uncertain or unknown (ltp-model.md §7.3):
//! the Student-t marginal of the Whittle likelihood over an estimated PSD (one scale per bin),
//! the exact (complex inverse-Wishart) marginal over the whole residual CSD, and the
//! log-periodogram likelihood of the Welch-averaged residual.
//!
//! # Student-t (Röver, Meyer & Christensen, PRD 84, 122004 (2011); LTPDA
//! `@mfh/loglikelihood_core_student.m`)
//! The Whittle likelihood treats the Welch estimate `Ŝ` of the residual PSD as exact. An
//! estimate with `ν` equivalent χ² degrees of freedom has `Ŝ = S χ²_ν/ν`, so with the Jeffreys
//! prior `1/S` the posterior of the true level given `Ŝ` is scaled-inverse-χ²(ν, Ŝ).
//! Marginalising each bin's circular complex Gaussian (real dimension `d = 2R`, `R` residual
//! channels, covariance `C = σ² Ĉ` with one scale `σ²` per bin) over it gives a multivariate
//! Student-t:
//!
//! ```text
//! ln L_k = c_k − ((ν + d)/2) ln(1 + 2 q_k/ν),     q_k = r_kᴴ Ĉ_k⁻¹ r_k,
//! c_k    = ln Γ((ν + d)/2) − ln Γ(ν/2) − R ln(ν/2) − R ln π − ln det Ĉ_k.
//! ```
//!
//! `c_k` makes `L` a proper density of the residual DFT (real and imaginary parts), and as
//! `ν → ∞`, `ln Γ((ν+d)/2) − ln Γ(ν/2) − R ln(ν/2) → 0` and `((ν+d)/2) ln(1 + 2q/ν) → q`: the
//! Whittle likelihood with its normalisation `−R ln π − ln det Ĉ_k`.
//! For two residual channels one common scale per bin is marginalised (the scalar prior of
//! Röver et al.), not a full inverse-Wishart on the 2×2 CSD.
//!
//! `ν` comes from the Welch settings of the noise-only stretch: `ν = 2 M_eff` with `M_eff` the
//! effective number of averages of Percival & Walden (1993) eq. (292b) (after Welch 1967),
//! which accounts for the window and the overlap of the `M` segments
//! ([`crate::signal::WelchConfig::n_eff`]). Neighbouring fit bins share one Welch estimate
//! (its bins are wider than the fit bins): the per-bin marginalisation treats them as
//! independent, as Röver et al. do.
//!
//! # Wishart (the exact marginal over the residual CSD; Sala & Vitale 2025 and the standard
//! complex-Wishart results of Goodman, Ann. Math. Stat. 34, 152 (1963))
//! The Student-t above marginalises one scale per bin. For one residual channel that is the
//! whole unknown; for `R ≥ 2` the `R × R` CSD has `R²` real unknowns (levels, coherence and
//! phase), and the complex-Wishart treatment marginalises all of them.
//!
//! A Welch CSD estimate from `M` independent complex averages of a circular Gaussian series
//! with CSD `S` is complex Wishart: `M Ŝ ~ CW_R(M, S)`, density
//! `∝ det(MŜ)^{M−R} det(S)^{−M} exp(−tr S⁻¹ MŜ) / Γ̃_R(M)`, with the complex multivariate gamma
//! function `Γ̃_R(a) = π^{R(R−1)/2} Π_{j=1}^{R} Γ(a − j + 1)`. With the Jeffreys prior
//! `p(S) ∝ det(S)^{−R}` the posterior is complex inverse-Wishart,
//! `p(S | Ŝ) = det(MŜ)^{M} det(S)^{−(M+R)} exp(−tr S⁻¹ MŜ) / Γ̃_R(M)`, proper for `M > R − 1`.
//! A bin's residual DFT is `r ~ CN(0, κS)` with `κ = (fs/2) Σw²` (the fit window), density
//! `π^{−R} det(κS)^{−1} exp(−rᴴ(κS)⁻¹r)`. The integral
//! `∫ det(S)^{−(a+R)} exp(−tr S⁻¹ Ψ) dS = Γ̃_R(a) det(Ψ)^{−a}` with `a = M + 1`,
//! `Ψ = MŜ + rrᴴ/κ` and `det(MŜ + rrᴴ/κ) = det(MŜ) (1 + q/M)` (`Ĉ = κŜ`, `q = rᴴĈ⁻¹r`) gives
//! the predictive, a complex multivariate t:
//!
//! ```text
//! ln L_k = c_k − (M + 1) ln(1 + q_k/M),      q_k = r_kᴴ Ĉ_k⁻¹ r_k,
//! c_k    = ln Γ(M + 1) − ln Γ(M + 1 − R) − R ln M − R ln π − ln det Ĉ_k,
//! ```
//!
//! since `Γ̃_R(M + 1)/Γ̃_R(M) = Γ(M + 1)/Γ(M + 1 − R)`. As `M → ∞` the constant tends to
//! `−R ln π − ln det Ĉ_k` and `(M + 1) ln(1 + q/M) → q`: the Whittle likelihood. For `R = 1`
//! it is the Student-t above with `ν = 2M` term by term. For `R = 2` the Student-t's exponent
//! is `M + R` (one scale), the Wishart's `M + 1`: at the truth the pivot `q/M` is
//! beta-prime`(R, M + 1 − R)` distributed under repeated sampling of the noise and the fit
//! data (`MĈ = L W Lᴴ` with `W ~ CW_R(M, I)` and `zᴴW⁻¹z ~ |z|²/Γ(M − R + 1)`), exactly the
//! distribution of `q/M` under the predictive above, whereas the Student-t's common-scale
//! predictive makes it beta-prime`(R, M)`, too light-tailed by one complex degree of freedom
//! per extra channel. Any `R` works through the whitener of the bin (`q` and `ln det Ĉ` are
//! what the Whittle likelihood already has).
//!
//! `M` is the effective number of complex averages `M_eff = ν/2` of the Welch settings (as for
//! the Student-t); overlapping tapered segments are not exactly Wishart, and `M_eff` is the
//! moment-matched count (P&W eq. 292b). With `[analysis] welch_resolution = "per_band"` it is
//! per bin. The statistic needs `M_eff > R − 1` at every bin.
//!
//! # Log-periodogram (Vitale et al., PRD 90, 042003 (2014); LTPDA `@mfh/loglikelihood_core_log.m`)
//! The residual time series of the whole fit stretch, `r(t; θ) = IDFT(M(f; θ) d̃(f))` over every
//! DFT bin (not only the band; the DC bin is set to zero since every Welch segment's mean is
//! removed, and the Nyquist bin keeps its real part), is Welch-averaged (`M` segments, window,
//! the window's recommended overlap, segment mean removed) and every `k1`-th Welch bin in the
//! band is kept:
//!
//! ```text
//! ln L(θ) = −M_eff Σ_j ln Ŝ_r(f_j; θ)        (one residual channel)
//! ln L(θ) = −M_eff Σ_j ln det Ŝ_r(f_j; θ)    (two: the 2×2 Welch CSD)
//! ```
//!
//! For `M` independent periodograms of a bin with unknown level `S` and the Jeffreys prior
//! `1/S`, `∫ Π_m S⁻¹ e^{−P_m/S} dS/S ∝ (Σ_m P_m)^{−M}`: the noise level of every retained bin
//! is marginalised. With overlapping tapered segments the periodograms are correlated, and the
//! exponent is the effective number of averages `M_eff` (P&W eq. 292b), which is `M` for
//! rectangular non-overlapping segments (using `M` there would make the posterior too narrow
//! by `√(M/M_eff)`). The additive constant (`ln Γ(M)` and the Jacobians) is the same for every
//! model on the same data and settings, so it is left out: Bayes factors between models on
//! the same data are correct, absolute evidences are not densities of the data.
//!
//! The default decimation `k1` is the smallest lag at which two periodogram bins of a white
//! series are less than 1 % correlated (`|Σ w² e^{−2πi k1 n/L}|² / (Σ w²)² < 0.01`): 1 for the
//! rectangular window, 3 for Hann, 4 for BH92 (its main lobe is ±4 bins wide).

use super::spectra::ExperimentSpectra;
use crate::data::dataset::ExperimentData;
use crate::model::{Bin, Model, residual, with_buffer};
use crate::signal::{WelchConfig, Window};
use num_complex::Complex64;
use realfft::{ComplexToReal, RealFftPlanner, RealToComplex};
use serde::{Deserialize, Serialize};
use std::cell::RefCell;
use std::sync::Arc;

/// Which statistic `ln L` is (`[analysis] statistic`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Statistic {
    /// Gaussian per bin with the residual PSD estimated once from the noise-only stretch and
    /// held fixed ("known PSD", ltp-model.md §8).
    #[default]
    Whittle,
    /// The Whittle likelihood marginalised over the uncertainty of that estimate (module docs).
    StudentT,
    /// The Whittle likelihood marginalised over the whole residual CSD given its Welch
    /// estimate (complex inverse-Wishart posterior, complex multivariate t predictive; module
    /// docs): exact for any number of averages `M_eff > R − 1`.
    Wishart,
    /// The log-periodogram likelihood of the Welch-averaged residual (module docs).
    LogPeriodogram,
}

impl Statistic {
    /// The study-file name.
    pub fn name(self) -> &'static str {
        match self {
            Statistic::Whittle => "whittle",
            Statistic::StudentT => "student_t",
            Statistic::Wishart => "wishart",
            Statistic::LogPeriodogram => "log_periodogram",
        }
    }
}

/// `[analysis.log_periodogram]`: the Welch settings of the residual periodogram.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LogPeriodogramOptions {
    /// Number of Welch segments `M` over the fit stretch (default 8: with BH92 at 66.1 %
    /// overlap `M_eff ≈ 7.3`, so each retained bin has `≈ 15` degrees of freedom, and the
    /// segments stay long enough to resolve the band; fewer averages make ln Ŝ noisier, more
    /// make the bins coarser).
    pub averages: usize,
    /// Welch window, with its recommended overlap (default BH92, as LTPDA: −92 dB sidelobes
    /// keep a large residual at one frequency from leaking into the others).
    pub window: Window,
    /// Keep every `decimate`-th Welch bin (default: the window's correlation length, module
    /// docs).
    pub decimate: Option<usize>,
    /// Pre-whiten the residual by the reference residual PSD of the noise-only stretch before
    /// averaging, and re-colour the averages by it (default true). A θ-independent filter, so
    /// `ln L` changes by a constant only where the window's leakage is negligible; but a
    /// residual whose PSD spans many decades (the acceleration domain: read-out noise × ω⁴
    /// rises by 10¹¹ from 1 mHz to 3 Hz) otherwise leaks through even BH92's −92 dB sidelobes
    /// and swamps the low-frequency bins, where the stiffnesses are measured.
    pub whiten: bool,
}

impl Default for LogPeriodogramOptions {
    fn default() -> Self {
        Self {
            averages: 8,
            window: Window::Bh92,
            decimate: None,
            whiten: true,
        }
    }
}

/// The smallest bin lag at which two periodogram bins of white noise through `window` (length
/// `len`) are less than 1 % correlated.
pub fn default_decimation(window: Window, len: usize) -> usize {
    let w = window.values(len);
    let s2: f64 = w.iter().map(|v| v * v).sum();
    (1..len / 2)
        .find(|&m| {
            let c: Complex64 = w
                .iter()
                .enumerate()
                .map(|(n, v)| {
                    Complex64::from_polar(
                        v * v,
                        -2.0 * std::f64::consts::PI * (m * n) as f64 / len as f64,
                    )
                })
                .sum();
            c.norm_sqr() / (s2 * s2) < 0.01
        })
        .unwrap_or(1)
}

/// The multivariate Student-t `ln` density of one bin (module docs) of a residual with
/// `q = rᴴ Ĉ⁻¹ r`, `R` residual channels, `ν` degrees of freedom and `ln det Ĉ`.
pub fn student_t_ln_density(q: f64, nr: usize, nu: f64, ln_det_c: f64) -> f64 {
    student_t_const(nr, nu)
        - nr as f64 * std::f64::consts::PI.ln()
        - ln_det_c
        - student_t_shape(q, nr, nu)
}

/// `ln Γ((ν + d)/2) − ln Γ(ν/2) − R ln(ν/2)`, `d = 2R`: → 0 as ν → ∞.
pub(crate) fn student_t_const(nr: usize, nu: f64) -> f64 {
    use statrs::function::gamma::ln_gamma;
    let r = nr as f64;
    ln_gamma(0.5 * nu + r) - ln_gamma(0.5 * nu) - r * (0.5 * nu).ln()
}

/// `((ν + d)/2) ln(1 + 2q/ν)`.
#[inline(always)]
pub(crate) fn student_t_shape(q: f64, nr: usize, nu: f64) -> f64 {
    (0.5 * nu + nr as f64) * (2.0 * q / nu).ln_1p()
}

/// The complex multivariate t `ln` density of one bin (module docs, "Wishart") of a residual
/// with `q = rᴴ Ĉ⁻¹ r`, `R` residual channels, `M` effective complex averages of the noise
/// estimate (`M > R − 1`) and `ln det Ĉ`.
pub fn wishart_ln_density(q: f64, nr: usize, m: f64, ln_det_c: f64) -> f64 {
    wishart_const(nr, m) - nr as f64 * std::f64::consts::PI.ln() - ln_det_c - wishart_shape(q, m)
}

/// `ln Γ(M + 1) − ln Γ(M + 1 − R) − R ln M`: → 0 as M → ∞ (NaN for `M ≤ R − 1`).
///
/// `Γ(M + 1)/Γ(M + 1 − R) = Π_{j<R} (M − j)` for integer `R`, so this is
/// `Σ_{j<R} ln(1 − j/M)`, with no cancellation at large `M`.
pub(crate) fn wishart_const(nr: usize, m: f64) -> f64 {
    if m <= nr as f64 - 1.0 {
        return f64::NAN;
    }
    (0..nr).map(|j| (-(j as f64) / m).ln_1p()).sum()
}

/// `(M + 1) ln(1 + q/M)`.
#[inline(always)]
pub(crate) fn wishart_shape(q: f64, m: f64) -> f64 {
    (m + 1.0) * (q / m).ln_1p()
}

/// The θ-independent part of the log-periodogram likelihood of one experiment.
#[derive(Clone)]
pub(crate) struct LogPgExperiment {
    n: usize,
    fs: f64,
    nc: usize,
    /// Residual channels averaged (the first one or two of the model's).
    nr: usize,
    /// Residual channels of the model (rows of its coefficients).
    nr_model: usize,
    /// Unwindowed DFTs of the data channels at every bin `0 … n/2`, bin-major.
    data: Vec<Complex64>,
    /// The model's constants at every bin, bin-major (bin 0 unused).
    consts: Vec<Complex64>,
    seg: usize,
    step: usize,
    n_seg: usize,
    pub(crate) m_eff: f64,
    window: Vec<f64>,
    /// `2/(fs Σw² M n²)`: the one-sided Welch scaling, with the `1/n` of the inverse DFT.
    scale: f64,
    /// Retained Welch bins.
    pub(crate) bins: Vec<usize>,
    /// Pre-whitening weight per residual channel and DFT bin `0 … n/2` (`1/√S_ref`), and the
    /// re-colouring PSD per channel at each retained Welch bin; empty without whitening.
    whiten: [Vec<f64>; 2],
    recolour: [Vec<f64>; 2],
    inv: Arc<dyn ComplexToReal<f64>>,
    fwd: Arc<dyn RealToComplex<f64>>,
}

impl std::fmt::Debug for LogPgExperiment {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LogPgExperiment")
            .field("n", &self.n)
            .field("seg", &self.seg)
            .field("n_seg", &self.n_seg)
            .field("m_eff", &self.m_eff)
            .field("bins", &self.bins.len())
            .finish()
    }
}

/// Per-thread buffers of [`LogPgExperiment::ln_likelihood`], grown on first use only.
#[derive(Default)]
struct Scratch {
    spec: [Vec<Complex64>; 2],
    time: [Vec<f64>; 2],
    seg: Vec<f64>,
    seg_spec: [Vec<Complex64>; 2],
    fft: Vec<Complex64>,
    acc: Vec<[Complex64; 3]>,
}

thread_local! {
    static SCRATCH: RefCell<Scratch> = RefCell::new(Scratch::default());
}

fn grow<T: Clone + Default>(v: &mut Vec<T>, n: usize) {
    if v.len() < n {
        v.resize(n, T::default());
    }
}

impl LogPgExperiment {
    /// Prepares experiment `e` (whose in-band spectra are `sp`) for `model`: the statistic,
    /// which is refused for more than two residual channels.
    pub(crate) fn new(
        e: &ExperimentData,
        sp: &ExperimentSpectra,
        model: &dyn Model,
        opts: &LogPeriodogramOptions,
    ) -> Result<Self, String> {
        let nr = model.residual_channels().len();
        if nr > 2 {
            return Err(format!(
                "model `{}` has {nr} residual channels and the log-periodogram likelihood is implemented for one or two: with R channels it is −M_eff Σ ln det of the R×R Welch matrix of the residual, which is singular unless every retained bin has at least R effective averages, and its marginalisation over one noise level per bin has been checked for 2×2 only; use statistic = \"whittle\", \"student_t\" or \"wishart\"",
                model.name()
            ));
        }
        Self::build(e, sp, model, opts, nr)
    }

    /// As [`LogPgExperiment::new`] averaging the first residual channel only (any number of
    /// channels): the residual PSD of the model's first channel.
    pub(crate) fn first_channel(
        e: &ExperimentData,
        sp: &ExperimentSpectra,
        model: &dyn Model,
        opts: &LogPeriodogramOptions,
    ) -> Result<Self, String> {
        Self::build(e, sp, model, opts, 1)
    }

    /// Prepares the Welch averages of the first `nr` (≤ 2) residual channels.
    fn build(
        e: &ExperimentData,
        sp: &ExperimentSpectra,
        model: &dyn Model,
        opts: &LogPeriodogramOptions,
        nr: usize,
    ) -> Result<Self, String> {
        let series: Vec<&[f64]> = model
            .data_channels()
            .iter()
            .map(|c| {
                e.channel(c)
                    .ok_or_else(|| format!("experiment `{}` has no channel `{c}`", e.name))
            })
            .collect::<Result<_, _>>()?;
        let n = series[0].len();
        let fs = e.fs;
        if opts.averages == 0 {
            return Err("analysis.log_periodogram.averages must be ≥ 1".into());
        }
        let ov = opts.window.recommended_overlap();
        let seg = (n as f64 / (1.0 + (opts.averages as f64 - 1.0) * (1.0 - ov))).floor() as usize;
        if seg < 16 {
            return Err(format!(
                "experiment `{}`: the fit stretch ({n} samples) is too short for {} Welch averages (segments of {seg} < 16 samples); lower analysis.log_periodogram.averages",
                e.name, opts.averages
            ));
        }
        let cfg = WelchConfig::new(fs, opts.window, seg);
        let step = cfg.step().map_err(|x| x.to_string())?;
        let n_seg = cfg.n_segments(n).map_err(|x| x.to_string())?;
        let m_eff = cfg.n_eff(n_seg).map_err(|x| x.to_string())?;
        let k1 = match opts.decimate {
            Some(0) => return Err("analysis.log_periodogram.decimate must be ≥ 1".into()),
            Some(k) => k,
            None => default_decimation(opts.window, seg),
        };
        let [lo, hi] = [
            sp.freqs[0] - 0.5 * sp.df,
            sp.freqs[sp.len() - 1] + 0.5 * sp.df,
        ];
        let dfs = fs / seg as f64;
        let bins: Vec<usize> = (1..seg.div_ceil(2))
            .filter(|&j| {
                let f = j as f64 * dfs;
                f >= lo && f <= hi
            })
            .step_by(k1)
            .collect();
        if bins.is_empty() {
            return Err(format!(
                "experiment `{}`: no Welch bin of the residual (spacing {dfs:.3e} Hz, {} averages) falls in the fit band [{:.3e}, {:.3e}] Hz; lower analysis.log_periodogram.averages or widen the band",
                e.name,
                opts.averages,
                sp.freqs[0],
                sp.freqs[sp.len() - 1]
            ));
        }
        let nc = series.len();
        let m = n / 2 + 1;
        let mut planner = RealFftPlanner::<f64>::new();
        let fwd_n = planner.plan_fft_forward(n);
        let mut data = vec![Complex64::new(0.0, 0.0); m * nc];
        let mut buf = vec![0.0; n];
        let mut out = vec![Complex64::new(0.0, 0.0); m];
        for (c, x) in series.iter().enumerate() {
            if x.len() != n {
                return Err(format!(
                    "experiment `{}`: channel lengths differ ({} and {n})",
                    e.name,
                    x.len()
                ));
            }
            buf.copy_from_slice(x);
            fwd_n
                .process(&mut buf, &mut out)
                .map_err(|x| x.to_string())?;
            for k in 0..m {
                data[k * nc + c] = out[k];
            }
        }
        let ncst = model.n_consts();
        let mut consts = vec![Complex64::new(0.0, 0.0); m * ncst];
        for k in 1..m {
            model.bin_consts(
                k as f64 * fs / n as f64,
                fs,
                &mut consts[k * ncst..(k + 1) * ncst],
            );
        }
        let window = opts.window.values(seg);
        let s2: f64 = window.iter().map(|v| v * v).sum();
        let nr_model = model.residual_channels().len();
        // the reference PSD of residual channel r at frequency f: the fit bin on the same DFT
        // grid, the band's edge value outside it
        let s_ref = |r: usize, f: f64| -> f64 {
            let k = ((f - sp.freqs[0]) / sp.df)
                .round()
                .clamp(0.0, (sp.len() - 1) as f64);
            sp.csd_at(k as usize)[r * nr_model + r].re
        };
        let (mut whiten, mut recolour) = ([Vec::new(), Vec::new()], [Vec::new(), Vec::new()]);
        if opts.whiten {
            for r in 0..nr {
                whiten[r] = (0..m)
                    .map(|k| 1.0 / s_ref(r, k as f64 * fs / n as f64).sqrt())
                    .collect();
                recolour[r] = bins.iter().map(|&j| s_ref(r, j as f64 * dfs)).collect();
                if whiten[r]
                    .iter()
                    .chain(&recolour[r])
                    .any(|v| !(v.is_finite() && *v > 0.0))
                {
                    return Err(format!(
                        "experiment `{}`: the reference residual PSD is not positive and finite everywhere, so the residual cannot be pre-whitened; set analysis.log_periodogram.whiten = false",
                        e.name
                    ));
                }
            }
        }
        Ok(Self {
            n,
            fs,
            nc,
            nr,
            nr_model,
            data,
            consts,
            seg,
            step,
            n_seg,
            m_eff,
            window,
            // the inverse transform is unnormalised: r(t) = IDFT/n
            scale: 2.0 / (fs * s2 * n_seg as f64 * (n as f64).powi(2)),
            bins,
            whiten,
            recolour,
            inv: planner.plan_fft_inverse(n),
            fwd: planner.plan_fft_forward(seg),
        })
    }

    /// Frequencies of the retained Welch bins (Hz).
    pub(crate) fn freqs(&self) -> Vec<f64> {
        let dfs = self.fs / self.seg as f64;
        self.bins.iter().map(|&j| j as f64 * dfs).collect()
    }

    /// `−M_eff Σ_j ln Ŝ_r(f_j; θ)` (or `ln det`), or the Welch estimate itself through `visit`
    /// (`(j, [S11, S12, S22])`).
    pub(crate) fn eval(
        &self,
        model: &dyn Model,
        th: &[f64],
        mut visit: Option<&mut dyn FnMut(usize, [Complex64; 3])>,
    ) -> f64 {
        SCRATCH.with(|s| {
            let s = &mut *s.borrow_mut();
            let (n, m, nc, nr) = (self.n, self.n / 2 + 1, self.nc, self.nr);
            let ncst = model.n_consts();
            let zero = Complex64::new(0.0, 0.0);
            for r in 0..nr {
                grow(&mut s.spec[r], m);
                grow(&mut s.time[r], n);
                grow(&mut s.seg_spec[r], self.seg / 2 + 1);
            }
            grow(&mut s.seg, self.seg);
            grow(
                &mut s.fft,
                self.inv.get_scratch_len().max(self.fwd.get_scratch_len()),
            );
            grow(&mut s.acc, self.bins.len());
            // residual spectrum at every bin
            for r in 0..nr {
                s.spec[r][0] = zero;
            }
            let df = self.fs / n as f64;
            with_buffer(self.nr_model * nc, |coef| {
                for k in 1..m {
                    let bin = Bin {
                        f: k as f64 * df,
                        fs: self.fs,
                        consts: &self.consts[k * ncst..(k + 1) * ncst],
                    };
                    model.coefficients(th, &bin, coef);
                    let rk = residual(coef, nr, &self.data[k * nc..(k + 1) * nc]);
                    for r in 0..nr {
                        s.spec[r][k] = match self.whiten[r].get(k) {
                            Some(w) => rk[r] * *w,
                            None => rk[r],
                        };
                    }
                }
            });
            for r in 0..nr {
                if n.is_multiple_of(2) {
                    s.spec[r][m - 1].im = 0.0;
                }
                if s.spec[r][..m]
                    .iter()
                    .any(|c| !(c.re.is_finite() && c.im.is_finite()))
                {
                    return f64::NAN;
                }
                self.inv
                    .process_with_scratch(&mut s.spec[r][..m], &mut s.time[r][..n], &mut s.fft)
                    .expect("lengths fixed at construction, DC and Nyquist real");
            }
            // Welch over the residual, accumulated at the retained bins only
            for a in s.acc[..self.bins.len()].iter_mut() {
                *a = [zero; 3];
            }
            let l = self.seg;
            for seg_i in 0..self.n_seg {
                let start = seg_i * self.step;
                for r in 0..nr {
                    let chunk = &s.time[r][start..start + l];
                    let mean = chunk.iter().sum::<f64>() / l as f64;
                    for ((o, &v), &w) in s.seg[..l].iter_mut().zip(chunk).zip(&self.window) {
                        *o = (v - mean) * w;
                    }
                    self.fwd
                        .process_with_scratch(
                            &mut s.seg[..l],
                            &mut s.seg_spec[r][..l / 2 + 1],
                            &mut s.fft,
                        )
                        .expect("lengths fixed at construction");
                }
                for (a, &j) in s.acc.iter_mut().zip(&self.bins) {
                    let x = s.seg_spec[0][j];
                    a[0] += x.norm_sqr();
                    if nr == 2 {
                        let y = s.seg_spec[1][j];
                        a[1] += x.conj() * y;
                        a[2] += y.norm_sqr();
                    }
                }
            }
            let mut sum = 0.0;
            for (i, a) in s.acc[..self.bins.len()].iter_mut().enumerate() {
                if !self.recolour[0].is_empty() {
                    let c0 = self.recolour[0][i];
                    a[0] *= c0;
                    if nr == 2 {
                        let c1 = self.recolour[1][i];
                        a[1] *= (c0 * c1).sqrt();
                        a[2] *= c1;
                    }
                }
                let s11 = a[0].re * self.scale;
                let v = if nr == 2 {
                    let s12 = a[1] * self.scale;
                    let s22 = a[2].re * self.scale;
                    if let Some(f) = visit.as_deref_mut() {
                        f(i, [a[0] * self.scale, s12, a[2] * self.scale]);
                    }
                    s11 * s22 - s12.norm_sqr()
                } else {
                    if let Some(f) = visit.as_deref_mut() {
                        f(i, [a[0] * self.scale, zero, zero]);
                    }
                    s11
                };
                sum += v.ln();
            }
            -self.m_eff * sum
        })
    }
}
