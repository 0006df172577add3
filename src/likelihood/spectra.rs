//! Per-experiment spectra in the fit band: DFTs of the outputs and injections, the inverse
//! noise matrix per bin, and the θ-independent closed-loop factors.

use super::noise_matrix::{DataNoise, factorise, model_noise, residual_csd};
use super::run_noise::{NoiseLeak, StretchNoise};
use crate::data::dataset::ExperimentData;
use crate::hermitian::{self, Mat2};
use crate::model::{Bin, BinBlock, Model};
use crate::signal::{
    MultiresConfig, RealFft, SignalError, WelchConfig, Window, multires_csd2, welch_csd2_runs,
};
use num_complex::Complex64;
use serde::{Deserialize, Serialize};

/// Where the noise CSD of the likelihood comes from.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum NoiseSource {
    /// Welch estimate from the experiment's noise-only stretch, interpolated onto the fit bins
    /// (the paper's procedure).
    #[default]
    Welch,
    /// The exact CSD of the noise: the model's own ([`Model::data_noise_csd`]) when it knows
    /// it, else the study's noise model of `o1, o12` (for known-answer tests).
    Model,
}

/// How the Welch estimate of the noise-only stretch chooses its segment length.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum WelchResolution {
    /// One segment length for the whole band (`welch_averages` segments span the stretch).
    #[default]
    Fixed,
    /// Longer segments (fewer averages) where the fixed length does not resolve the band's
    /// bottom: each fit frequency takes the shortest of `L_0, 2L_0, 4L_0, …, N` with at least
    /// twice the window's main-lobe half-width of bins above DC ([`crate::signal::multires`]).
    /// The equivalent degrees of freedom are then per bin
    /// ([`ExperimentSpectra::noise_dof_per_bin`]).
    PerBand,
}

impl WelchResolution {
    /// Whether this is the default, [`WelchResolution::Fixed`] (serialisation skips it).
    pub fn is_fixed(&self) -> bool {
        *self == WelchResolution::Fixed
    }
}

/// Options of the spectral preprocessing.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SpectraOptions {
    /// Fit band `[lo, hi]` (Hz).
    pub band: [f64; 2],
    /// Window applied to data and injections alike before the DFT.
    pub window: Window,
    pub noise: NoiseSource,
    /// Number of Welch averages over the noise-only stretch. LTPDA uses 5, but the
    /// likelihood weights are `1/Ŝ`, and for an estimate with ν effective averages
    /// `E[1/Ŝ] = ν/(ν − 1) · 1/S`: with 5 the inverse noise is overestimated by ~25 %, the
    /// posterior is too narrow and, on the Table I study, Δt2 lands 5σ from the truth. With 16
    /// the bias is ~7 % and every Table I parameter is within 3σ (see docs/src/results.md).
    pub welch_averages: usize,
    /// Welch window (with its recommended overlap).
    pub welch_window: Window,
    /// Data with gaps: length (s) of the cosine taper at each end of a valid run that borders
    /// a gap ([`ExperimentSpectra::of_experiment`]); a run's taper is at most a quarter of it.
    pub gap_taper: f64,
    /// Segment length of the Welch estimate: one for the band, or per band (serialised only
    /// when not the default).
    #[serde(skip_serializing_if = "WelchResolution::is_fixed")]
    pub welch_resolution: WelchResolution,
}

/// Default of [`SpectraOptions::gap_taper`] (s).
pub const DEFAULT_GAP_TAPER: f64 = 600.0;

impl Default for SpectraOptions {
    fn default() -> Self {
        Self {
            band: [1e-4, 1.0],
            window: Window::Rectangular,
            noise: NoiseSource::Welch,
            welch_averages: 16,
            welch_window: Window::Bh92,
            gap_taper: DEFAULT_GAP_TAPER,
            welch_resolution: WelchResolution::Fixed,
        }
    }
}

/// Errors while preparing spectra.
#[derive(Debug, thiserror::Error)]
pub enum SpectraError {
    #[error("experiment `{exp}`: {msg}")]
    Invalid { exp: String, msg: String },
    #[error("experiment `{exp}`: {source}")]
    Signal {
        exp: String,
        #[source]
        source: SignalError,
    },
}

/// One experiment reduced to what the likelihood needs, per in-band bin `k`: the DFTs of the
/// model's data channels, the inverse residual-noise matrix `C_k⁻¹` (packed for one or two
/// residual channels; the inverse Cholesky factor and `ln det C_k` for any number) and the
/// model's θ-independent constants.
///
/// # Residual noise
/// The residual `r = Σ_c M_c d_c` carries the noise of the measured channels through the
/// model's coefficients. Its CSD is `S_r = M(θ_ref) S_d M(θ_ref)ᴴ`, with `S_d` the CSD of the
/// data channels (Welch of the noise-only stretch, or the simulator's noise model) and
/// `θ_ref` a reference point, held fixed during sampling as in K14 ("noise independent of the
/// parameters"). Channels with no noise-only series (commanded injections) are noiseless. For
/// the LTP closed loop `M_o = I`, so `S_r = S_o` exactly and `θ_ref` plays no role; where the
/// noise moves with θ the jobs put `θ_ref` at each model's own MAP, iterated
/// (`crate::jobs::own_noise`), and [`crate::likelihood::theta_noise`] holds the exact
/// θ-dependent likelihood beside this one.
#[derive(Debug, Clone)]
pub struct ExperimentSpectra {
    pub name: String,
    pub fs: f64,
    /// Series length `N`.
    pub n: usize,
    /// DFT bin spacing `fs/N` (Hz); the in-band bins are contiguous on this grid.
    pub df: f64,
    /// Frequencies of the in-band bins (Hz).
    pub freqs: Vec<f64>,
    /// Data channels (the model's, in its order).
    pub channels: Vec<String>,
    /// DFTs of the data channels, `len × C`, bin-major.
    pub data: Vec<Complex64>,
    /// Number of residual channels `R` of the model.
    pub nr: usize,
    /// `C_k⁻¹` packed as `(a, b, c)`, `C_k = (fs/2) Σw² S_r,k`, for `R ≤ 2`; empty for more.
    pub cinv: Vec<(f64, Complex64, f64)>,
    /// The inverse Cholesky factor `W_k` of `C_k` (`C_k⁻¹ = W_kᴴW_k`), packed lower triangle,
    /// `R(R+1)/2` per bin, for every `R` ([`crate::hermitian::whitener`]).
    pub whiten: Vec<Complex64>,
    /// `ln det C_k` per bin.
    pub ln_det: Vec<f64>,
    /// `C_k = noise_scale · S_r,k`: `(fs/2) Σw²` of the window the data were tapered with
    /// (what a residual CSD evaluated at another θ is scaled by,
    /// [`crate::likelihood::theta_noise`]).
    pub noise_scale: f64,
    /// The residual-noise CSD `S_r,k` used (one-sided), `R × R` row-major per bin
    /// ([`ExperimentSpectra::csd_at`]).
    pub csd: Vec<Complex64>,
    /// The model's θ-independent constants, `len × n_consts`, bin-major.
    pub consts: Vec<Complex64>,
    /// Which data channels carry anything in band.
    pub active: Vec<bool>,
    /// Which data channels are known inputs (no noise, not the modelled glitches' impulse):
    /// the "signal" of ρ_opt.
    pub is_input: Vec<bool>,
    /// Equivalent χ² degrees of freedom `ν = 2 M_eff` of the Welch noise estimate (Percival &
    /// Walden eq. 292b for the segments, window and overlap used); `None` for the noise model.
    pub noise_dof: Option<f64>,
    /// The equivalent degrees of freedom of the Welch noise estimate per in-band bin, where
    /// they differ between bins (`welch_resolution = "per_band"`: each bin's segment length
    /// has its own number of averages; `noise_dof` is then the lowest); `None` otherwise.
    pub noise_dof_per_bin: Option<Vec<f64>>,
    /// The experiment's stretch and covariates, which a model whose parameters change between
    /// stretches reads ([`crate::model::Model::specialise`]); empty unless the caller sets
    /// them (the study's `[[stretch]]` of the experiment).
    pub covariates: crate::model::Covariates,
    /// How the window correlates neighbouring bins: `R_m = Σ_t w_t² e^{−2πimt/N} / Σ_t w_t²`
    /// for lags `m = 1, 2, …` (`R_0 = 1`, `R_−m = R_m*`) as far as `|R_m| ≥ 1e−4` (at most
    /// [`MAX_WINDOW_LAGS`]); empty for the rectangular window, whose bins are uncorrelated.
    /// Noise whose PSD is smooth over a few bins has `E[r_k r_lᴴ] ≈ R_{k−l} C_k^{½} C_l^{½}`:
    /// what [`crate::likelihood::score_covariance`] needs for the error bars of tapered runs.
    pub window_lags: Vec<Complex64>,
    /// A gapped run's exact noise covariance against the nominal one, per bin
    /// ([`NoiseLeak`]); `None` for a gap-free stretch.
    pub noise_leak: Option<NoiseLeak>,
}

/// Most lags kept in [`ExperimentSpectra::window_lags`].
pub const MAX_WINDOW_LAGS: usize = 32;

/// [`ExperimentSpectra::window_lags`] of the window `w` (its DFT's convention).
pub fn window_lags(w: &[f64]) -> Result<Vec<Complex64>, crate::signal::SignalError> {
    let n = w.len();
    let w2: Vec<f64> = w.iter().map(|x| x * x).collect();
    let total: f64 = w2.iter().sum();
    if n < 4 || total <= 0.0 {
        return Ok(Vec::new());
    }
    let mut fft = RealFft::new(n)?;
    let mut spec = vec![Complex64::new(0.0, 0.0); fft.spectrum_len()];
    fft.forward(&w2, &mut spec)?;
    let lags = MAX_WINDOW_LAGS.min(spec.len() - 1);
    let mut out: Vec<Complex64> = spec[1..=lags].iter().map(|r| r / total).collect();
    let keep = out
        .iter()
        .rposition(|r| r.norm() >= 1e-4)
        .map_or(0, |i| i + 1);
    out.truncate(keep);
    Ok(out)
}

impl ExperimentSpectra {
    /// Prepares one experiment for `model`, with the residual noise evaluated at `theta_ref`.
    /// With `opts.noise == NoiseSource::Model` the data-channel CSD is the model's own
    /// ([`Model::data_noise_csd`]) if it knows it, else `model_csd`'s CSD of the measured
    /// outputs `(o1, o12)`.
    pub fn new(
        e: &ExperimentData,
        opts: &SpectraOptions,
        model: &dyn Model,
        theta_ref: &[f64],
        model_csd: Option<&dyn Fn(f64) -> Mat2>,
    ) -> Result<Self, SpectraError> {
        if !e.gaps.is_empty() {
            return Err(SpectraError::Invalid {
                exp: e.name.clone(),
                msg: "the fit stretch has gaps: prepare it with ExperimentSpectra::of_experiment, one spectrum per valid run".into(),
            });
        }
        Self::tapered(e, opts, model, theta_ref, model_csd, [0, 0], None)
    }

    /// [`ExperimentSpectra::new`] of a gap-free stretch whose first `taper[0]` and last
    /// `taper[1]` samples are tapered by a raised cosine on top of `opts.window` (the ends
    /// that border a gap).
    pub(super) fn tapered(
        e: &ExperimentData,
        opts: &SpectraOptions,
        model: &dyn Model,
        theta_ref: &[f64],
        model_csd: Option<&dyn Fn(f64) -> Mat2>,
        taper: [usize; 2],
        stretch: Option<&StretchNoise>,
    ) -> Result<Self, SpectraError> {
        let inv = |msg: String| SpectraError::Invalid {
            exp: e.name.clone(),
            msg,
        };
        let sig = |source| SpectraError::Signal {
            exp: e.name.clone(),
            source,
        };
        let channels: Vec<String> = model.data_channels().to_vec();
        let mut series = Vec::with_capacity(channels.len());
        for c in &channels {
            series.push(e.channel(c).ok_or_else(|| {
                inv(format!(
                    "model `{}` reads data channel `{c}`, which this experiment does not have; it has {}",
                    model.name(),
                    e.channel_names()
                        .iter()
                        .map(|n| format!("`{n}`"))
                        .collect::<Vec<_>>()
                        .join(", ")
                ))
            })?);
        }
        let n = series[0].len();
        if let Some((c, s)) = channels.iter().zip(&series).find(|(_, s)| s.len() != n) {
            return Err(inv(format!(
                "channel `{c}` has {} samples, `{}` has {n}",
                s.len(),
                channels[0]
            )));
        }
        let fs = e.fs;
        let [lo, hi] = opts.band;
        let df = fs / n as f64;
        if !(lo.is_finite() && hi.is_finite() && lo > 0.0 && hi > lo) {
            return Err(inv(format!("fit band [{lo}, {hi}] Hz: need 0 < lo < hi")));
        }
        if lo >= fs / 2.0 || hi < df {
            return Err(inv(format!(
                "fit band [{lo}, {hi}] Hz lies outside the data's frequencies [{df}, {}] Hz (N = {n}, fs = {fs} Hz)",
                fs / 2.0
            )));
        }
        let mut w = opts.window.values(n);
        edge_taper(&mut w, taper);
        let sum_w2: f64 = w.iter().map(|x| x * x).sum();
        let mut fft = RealFft::new(n).map_err(sig)?;
        let m = fft.spectrum_len();
        let nc = channels.len();
        let mut spec = vec![vec![Complex64::new(0.0, 0.0); m]; nc];
        let mut buf = vec![0.0; n];
        for (c, x) in series.iter().enumerate() {
            for (b, (x, wi)) in buf.iter_mut().zip(x.iter().zip(&w)) {
                *b = x * wi;
            }
            fft.forward(&buf, &mut spec[c]).map_err(sig)?;
        }
        // regular bins only: DC and Nyquist are real and carry no phase information
        let ks: Vec<usize> = (1..m)
            .filter(|&k| 2 * k != n)
            .filter(|&k| {
                let f = k as f64 * df;
                f >= lo && f <= hi
            })
            .collect();
        if ks.is_empty() {
            return Err(inv(format!(
                "no DFT bin (spacing {df:.3e} Hz) falls in the fit band [{lo}, {hi}] Hz"
            )));
        }
        let freqs: Vec<f64> = ks.iter().map(|&k| k as f64 * df).collect();
        let ncst = model.n_consts();
        let consts = consts_at(model, &freqs, fs);
        // the CSD of the measured channels, S_d, over the noisy channels
        let DataNoiseOf {
            noise: (noisy, mut sd),
            dof: noise_dof,
            dof_per_bin: noise_dof_per_bin,
        } = data_noise(e, opts, model, theta_ref, model_csd, &freqs, &consts).map_err(&inv)?;
        let mut noise_leak = None;
        if let Some(sn) = stretch {
            // a gapped run: its bins' exact covariance under the stretch's noise
            if sn.channels() != noisy.len() {
                return Err(inv(format!(
                    "the stretch's noise has {} channels, the run's {}",
                    sn.channels(),
                    noisy.len()
                )));
            }
            let exact = sn.windowed(&w, &ks, fs).map_err(&inv)?;
            noise_leak = Some(NoiseLeak::new(noisy.clone(), &sd, &exact).map_err(&inv)?);
            sd = exact;
        }
        let nr = model.residual_channels().len();
        let mut coef = vec![Complex64::new(0.0, 0.0); nr * nc];
        let mut csd = vec![Complex64::new(0.0, 0.0); freqs.len() * nr * nr];
        let scale = fs / 2.0 * sum_w2;
        let mut cinv = Vec::with_capacity(if nr <= 2 { ks.len() } else { 0 });
        let mut whiten = Vec::with_capacity(ks.len() * hermitian::tri_len(nr));
        let mut ln_det = Vec::with_capacity(ks.len());
        for (k, &f) in freqs.iter().enumerate() {
            let cst = &consts[k * ncst..(k + 1) * ncst];
            model.coefficients(theta_ref, &Bin { f, fs, consts: cst }, &mut coef);
            let s = &mut csd[k * nr * nr..(k + 1) * nr * nr];
            residual_csd(&coef, nr, nc, &noisy, &sd[k], s);
            let (packed, w, ld) =
                factorise(s, nr, scale, f, model.residual_channels()).map_err(&inv)?;
            cinv.extend(packed);
            whiten.extend_from_slice(&w);
            ln_det.push(ld);
        }
        let mut data = Vec::with_capacity(ks.len() * nc);
        for &k in &ks {
            for sp in &spec {
                data.push(sp[k]);
            }
        }
        let zero = Complex64::new(0.0, 0.0);
        let active = (0..nc)
            .map(|c| (0..ks.len()).any(|k| data[k * nc + c] != zero))
            .collect();
        // the modelled glitches' impulse is noiseless but no injection: their response is not
        // the signal whose ρ_opt the run reports
        let is_input = (0..nc)
            .map(|c| {
                !noisy.contains(&c) && model.data_channels()[c] != crate::model::GLITCH_CHANNEL
            })
            .collect();
        Ok(Self {
            name: e.name.clone(),
            fs,
            n,
            df,
            freqs,
            channels,
            data,
            nr,
            cinv,
            whiten,
            ln_det,
            noise_scale: scale,
            csd,
            consts,
            active,
            is_input,
            noise_dof,
            noise_dof_per_bin,
            covariates: Default::default(),
            window_lags: window_lags(&w).map_err(sig)?,
            noise_leak,
        })
    }

    /// Number of in-band bins.
    pub fn len(&self) -> usize {
        self.freqs.len()
    }

    /// Whether no bin is in band (never true for a constructed value).
    pub fn is_empty(&self) -> bool {
        self.freqs.is_empty()
    }

    /// The whole experiment as a [`BinBlock`].
    pub fn block(&self) -> BinBlock<'_> {
        BinBlock {
            f0: self.freqs[0],
            df: self.df,
            fs: self.fs,
            n: self.len(),
            data: &self.data,
            cinv: &self.cinv,
            whiten: &self.whiten,
            consts: &self.consts,
        }
    }

    /// The residual-noise CSD `S_r` of bin `k`, `R × R` row-major.
    pub fn csd_at(&self, k: usize) -> &[Complex64] {
        let n = self.nr * self.nr;
        &self.csd[k * n..(k + 1) * n]
    }

    /// The inverse Cholesky factor `W_k` of bin `k` (`C_k⁻¹ = W_kᴴW_k`, packed lower triangle).
    pub fn whitener(&self, k: usize) -> &[Complex64] {
        let n = hermitian::tri_len(self.nr);
        &self.whiten[k * n..(k + 1) * n]
    }

    /// `rᴴ C_k⁻¹ r` (`r.len() = R`): the packed inverse for `R ≤ 2` (the arithmetic of every
    /// result so far), the Cholesky factor for more.
    #[inline]
    pub fn quad(&self, k: usize, r: &[Complex64]) -> f64 {
        match r.len() {
            1 => hermitian::quad(&self.cinv[k], [r[0], Complex64::new(0.0, 0.0)]),
            2 => hermitian::quad(&self.cinv[k], [r[0], r[1]]),
            _ => hermitian::quad_whitened(self.whitener(k), r),
        }
    }

    /// `Re(xᴴ C_k⁻¹ y)`, as [`ExperimentSpectra::quad`].
    #[inline]
    pub fn inner(&self, k: usize, x: &[Complex64], y: &[Complex64]) -> f64 {
        let z = Complex64::new(0.0, 0.0);
        match x.len() {
            1 => hermitian::inner(&self.cinv[k], [x[0], z], [y[0], z]),
            2 => hermitian::inner(&self.cinv[k], [x[0], x[1]], [y[0], y[1]]),
            _ => hermitian::inner_whitened(self.whitener(k), x, y),
        }
    }

    /// The data of bin `k` (one value per channel).
    pub fn data_at(&self, k: usize) -> &[Complex64] {
        let nc = self.channels.len();
        &self.data[k * nc..(k + 1) * nc]
    }

    /// The model's constants of bin `k`.
    pub fn bin(&self, k: usize, n_consts: usize) -> Bin<'_> {
        Bin {
            f: self.freqs[k],
            fs: self.fs,
            consts: &self.consts[k * n_consts..(k + 1) * n_consts],
        }
    }
}

/// Multiplies the first `taper[0]` and the last `taper[1]` values of `w` by a raised cosine
/// rising from (and falling to) zero; `[0, 0]` leaves `w` as it is.
pub(super) fn edge_taper(w: &mut [f64], taper: [usize; 2]) {
    let n = w.len();
    let ramp = |k: usize, len: usize| {
        0.5 * (1.0 - (std::f64::consts::PI * (k as f64 + 0.5) / len as f64).cos())
    };
    let [a, b] = [taper[0].min(n), taper[1].min(n)];
    for k in 0..a {
        w[k] *= ramp(k, a);
    }
    for k in 0..b {
        w[n - 1 - k] *= ramp(k, b);
    }
}

/// The model's θ-independent constants at `freqs`, `freqs.len() × n_consts`, bin-major.
pub(super) fn consts_at(model: &dyn Model, freqs: &[f64], fs: f64) -> Vec<Complex64> {
    let ncst = model.n_consts();
    let mut consts = vec![Complex64::new(0.0, 0.0); freqs.len() * ncst];
    for (k, &f) in freqs.iter().enumerate() {
        model.bin_consts(f, fs, &mut consts[k * ncst..(k + 1) * ncst]);
    }
    consts
}

/// The noise CSD of the data channels that carry noise ([`DataNoise`]) at `freqs`, with the
/// Welch estimate's degrees of freedom (overall, and per bin for `per_band`).
pub(super) struct DataNoiseOf {
    pub noise: DataNoise,
    pub dof: Option<f64>,
    pub dof_per_bin: Option<Vec<f64>>,
}

/// [`DataNoiseOf`] experiment `e` for `model` at `freqs` (`consts` the model's constants
/// there): the model's own noise or the study's (`noise = "model"`), or the Welch estimate
/// from the noise-only stretch.
pub(super) fn data_noise(
    e: &ExperimentData,
    opts: &SpectraOptions,
    model: &dyn Model,
    theta_ref: &[f64],
    model_csd: Option<&dyn Fn(f64) -> Mat2>,
    freqs: &[f64],
    consts: &[Complex64],
) -> Result<DataNoiseOf, String> {
    let channels = model.data_channels();
    let nc = channels.len();
    match opts.noise {
        NoiseSource::Model => {
            let noise = match model_noise(model, theta_ref, e.fs, freqs, consts)? {
                Some(x) => x,
                None => study_noise(model, channels, freqs, model_csd)?,
            };
            Ok(DataNoiseOf {
                noise,
                dof: None,
                dof_per_bin: None,
            })
        }
        NoiseSource::Welch => {
            let noisy: Vec<usize> = (0..nc)
                .filter(|&c| e.noise_channel(&channels[c]).is_some())
                .collect();
            if noisy.is_empty() {
                return Err(format!(
                    "Welch noise needs a noise-only stretch of at least one channel model `{}` reads ({})",
                    model.name(),
                    channels.join(", ")
                ));
            }
            let ser: Vec<&[f64]> = noisy
                .iter()
                .map(|&c| e.noise_channel(&channels[c]).expect("filtered"))
                .collect();
            let (sd, dof, dof_per_bin) = match opts.welch_resolution {
                WelchResolution::Fixed => {
                    let (sd, dof) = welch_noise(e, &ser, &e.noise_valid_runs(), opts, freqs)?;
                    (sd, dof, None)
                }
                WelchResolution::PerBand => {
                    if !e.noise_gaps.is_empty() {
                        return Err(
                            "welch_resolution = \"per_band\" does not handle gaps in the noise-only stretch yet; use \"fixed\"".into(),
                        );
                    }
                    let (sd, per_bin) = welch_noise_per_band(e, &ser, opts, freqs)?;
                    let lowest = per_bin.iter().cloned().fold(f64::INFINITY, f64::min);
                    (sd, lowest, Some(per_bin))
                }
            };
            Ok(DataNoiseOf {
                noise: (noisy, sd),
                dof: Some(dof),
                dof_per_bin,
            })
        }
    }
}

/// The study's noise model of the outputs `(o1, o12)` (`model_csd`) as the CSD of the noisy
/// channels of `model`, per frequency.
fn study_noise(
    model: &dyn Model,
    channels: &[String],
    freqs: &[f64],
    model_csd: Option<&dyn Fn(f64) -> Mat2>,
) -> Result<DataNoise, String> {
    let f = model_csd.ok_or_else(|| {
        format!(
            "noise = \"model\" needs the noise model of the study (model `{}` does not know the noise of its data channels)",
            model.name()
        )
    })?;
    let idx: Vec<usize> = ["o1", "o12"]
        .iter()
        .map(|o| channels.iter().position(|c| c == o))
        .collect::<Option<_>>()
        .ok_or_else(|| {
            format!(
                "noise = \"model\" knows the noise of `o1` and `o12` only, and model `{}` does not read both; use noise = \"welch\"",
                model.name()
            )
        })?;
    let sd = freqs
        .iter()
        .map(|&x| {
            let s = f(x);
            vec![s[0][0], s[0][1], s[1][0], s[1][1]]
        })
        .collect();
    Ok((idx, sd))
}

/// The Welch segment length of the noise estimate's rule for a series of `len` samples whose
/// valid runs are `runs` ([`welch_segment_len`] without gaps, the gapped search with them).
pub fn welch_segment_len_for(len: usize, runs: &[[usize; 2]], opts: &SpectraOptions) -> usize {
    if runs.len() == 1 && runs[0] == [0, len] {
        welch_segment_len(len, opts)
    } else {
        gapped_segment_len(runs, opts)
    }
}

/// The Welch segment length for a noise-only series of `len` samples: `welch_averages`
/// segments with the window's recommended overlap span the series.
pub fn welch_segment_len(len: usize, opts: &SpectraOptions) -> usize {
    let navs = opts.welch_averages.max(1) as f64;
    let ov = opts.welch_window.recommended_overlap();
    // M segments of length L overlapping by ov·L span L (1 + (M − 1)(1 − ov)) samples
    (len as f64 / (1.0 + (navs - 1.0) * (1.0 - ov))).floor() as usize
}

/// The Welch segment length for a noise-only stretch with gaps (valid runs `runs`): the longest
/// at which the runs hold the `welch_averages` asked for (segments wholly inside one run, the
/// window's recommended overlap), searched down from the length those averages would have over
/// the valid samples in steps of 5 %. A 2×2 estimate from one segment is singular, so fewer
/// averages are never accepted while a shorter segment would give them.
fn gapped_segment_len(runs: &[[usize; 2]], opts: &SpectraOptions) -> usize {
    let valid: usize = runs.iter().map(|r| r[1] - r[0]).sum();
    let want = opts.welch_averages.max(1);
    let ov = opts.welch_window.recommended_overlap();
    let count = |l: usize| -> usize {
        let step = (l - (ov * l as f64).round() as usize).max(1);
        runs.iter()
            .filter(|r| r[1] - r[0] >= l)
            .map(|r| (r[1] - r[0] - l) / step + 1)
            .sum()
    };
    let mut l = welch_segment_len(valid, opts);
    while l >= 16 && count(l) < want {
        l = (l as f64 * 0.95).floor() as usize;
    }
    l
}

/// As [`welch_noise`] with a segment length per band ([`WelchResolution::PerBand`]): the
/// shortest segments are `welch_segment_len`'s, so bins these resolve get the same estimate;
/// returns the equivalent degrees of freedom `2 M_eff` per fit bin.
fn welch_noise_per_band(
    e: &ExperimentData,
    ser: &[&[f64]],
    opts: &SpectraOptions,
    freqs: &[f64],
) -> Result<(Vec<Vec<Complex64>>, Vec<f64>), String> {
    let len = ser[0].len();
    if let Some(s) = ser.iter().find(|s| s.len() != len) {
        return Err(format!(
            "the noise-only series have different lengths ({} and {len} samples)",
            s.len()
        ));
    }
    let seg = welch_segment_len(len, opts);
    if seg < 16 {
        return Err(format!(
            "the noise-only stretch ({len} samples) is too short for {} Welch averages",
            opts.welch_averages
        ));
    }
    let cfg = MultiresConfig::new(e.fs, opts.welch_window, seg);
    let nn = ser.len();
    let mut out = vec![vec![Complex64::new(0.0, 0.0); nn * nn]; freqs.len()];
    let mut dof = vec![0.0; freqs.len()];
    for a in 0..nn {
        // one channel alone, else every pair (as the fixed estimate)
        for b in (a + 1).min(nn - 1)..nn {
            if nn > 1 && b == a {
                continue;
            }
            let c = multires_csd2(ser[a], ser[b], &cfg, freqs).map_err(|x| x.to_string())?;
            for (k, o) in out.iter_mut().enumerate() {
                let m = c.matrix(k);
                o[a * nn + a] = m[0][0];
                o[b * nn + b] = m[1][1];
                o[a * nn + b] = m[0][1];
                o[b * nn + a] = m[1][0];
                dof[k] = 2.0 * c.n_eff[k];
            }
        }
    }
    Ok((out, dof))
}

/// The number of effective averages `M_eff = ν/2` behind the noise estimate of `sp`, summarised
/// per decade of its fit band: `(f_lo, f_hi, lowest M_eff, highest M_eff)` per decade that
/// holds bins (`None` for the noise model).
pub fn averages_per_decade(sp: &ExperimentSpectra) -> Option<Vec<(f64, f64, f64, f64)>> {
    let fixed = sp.noise_dof?;
    let mut out: Vec<(f64, f64, f64, f64)> = Vec::new();
    for (k, &f) in sp.freqs.iter().enumerate() {
        let m = 0.5 * sp.noise_dof_per_bin.as_ref().map_or(fixed, |b| b[k]);
        let lo = 10f64.powf(f.log10().floor());
        match out.last_mut() {
            Some(d) if d.0 == lo => {
                d.2 = d.2.min(m);
                d.3 = d.3.max(m);
            }
            _ => out.push((lo, 10.0 * lo, m, m)),
        }
    }
    Some(out)
}

/// Welch CSD matrix of the noise-only series `ser` (all the same length), interpolated onto
/// `freqs`, flattened row-major per frequency. Below the first Welch frequency (and above the
/// last regular one) the nearest estimate is used. Pairs of channels are estimated together,
/// so two channels give exactly the two-channel estimate. Also returns the estimate's
/// equivalent degrees of freedom `2 M_eff`.
fn welch_noise(
    e: &ExperimentData,
    ser: &[&[f64]],
    runs: &[[usize; 2]],
    opts: &SpectraOptions,
    freqs: &[f64],
) -> Result<(Vec<Vec<Complex64>>, f64), String> {
    let len = ser[0].len();
    if let Some(s) = ser.iter().find(|s| s.len() != len) {
        return Err(format!(
            "the noise-only series have different lengths ({} and {len} samples)",
            s.len()
        ));
    }
    // with gaps: the averages asked for over the valid samples, in segments no longer than
    // the longest valid run (fewer averages when the runs are short)
    let seg = match runs {
        [r] if *r == [0, len] => welch_segment_len(len, opts),
        _ => gapped_segment_len(runs, opts),
    };
    if seg < 16 {
        return Err(format!(
            "the noise-only stretch ({len} samples, {} valid) is too short for {} Welch averages",
            runs.iter().map(|r| r[1] - r[0]).sum::<usize>(),
            opts.welch_averages
        ));
    }
    let cfg = WelchConfig::new(e.fs, opts.welch_window, seg);
    let mut dof = 0.0;
    for r in runs.iter().filter(|r| r[1] - r[0] >= seg) {
        dof += cfg
            .n_segments(r[1] - r[0])
            .and_then(|m| cfg.n_eff(m))
            .map_err(|x| x.to_string())?;
    }
    let dof = dof * 2.0;
    let first = e.fs / seg as f64;
    let last_k = if seg.is_multiple_of(2) {
        seg / 2 - 1
    } else {
        seg / 2
    };
    let last = last_k as f64 * e.fs / seg as f64;
    let targets: Vec<f64> = freqs.iter().map(|f| f.clamp(first, last)).collect();
    let nn = ser.len();
    let mut out = vec![vec![Complex64::new(0.0, 0.0); nn * nn]; freqs.len()];
    let pair = |a: usize, b: usize| -> Result<_, String> {
        let s = welch_csd2_runs(ser[a], ser[b], &cfg, runs).map_err(|x| x.to_string())?;
        s.interpolate(&targets).map_err(|x| x.to_string())
    };
    if nn == 1 {
        let c = pair(0, 0)?;
        for (k, o) in out.iter_mut().enumerate() {
            o[0] = c.matrix(k)[0][0];
        }
        return Ok((out, dof));
    }
    for a in 0..nn {
        for b in a + 1..nn {
            let c = pair(a, b)?;
            for (k, o) in out.iter_mut().enumerate() {
                let m = c.matrix(k);
                o[a * nn + a] = m[0][0];
                o[b * nn + b] = m[1][1];
                o[a * nn + b] = m[0][1];
                o[b * nn + a] = m[1][0];
            }
        }
    }
    Ok((out, dof))
}
