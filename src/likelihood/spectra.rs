//! Per-experiment spectra in the fit band: DFTs of the outputs and injections, the inverse
//! noise matrix per bin, and the θ-independent closed-loop factors.

use crate::dataset::ExperimentData;
use crate::hermitian::{self, Mat2};
use crate::ltp::{BinConsts, Controllers};
use crate::signal::{RealFft, SignalError, WelchConfig, Window, welch_csd2};
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
    /// The exact CSD of the noise model (for known-answer tests).
    Model,
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
    /// the bias is ~7 % and every Table I parameter is within 3σ (see the README).
    pub welch_averages: usize,
    /// Welch window (with its recommended overlap).
    pub welch_window: Window,
    /// Fixed OMS delay τ_o of the fit model (s).
    pub oms_delay: f64,
}

impl Default for SpectraOptions {
    fn default() -> Self {
        Self {
            band: [1e-4, 1.0],
            window: Window::Rectangular,
            noise: NoiseSource::Welch,
            welch_averages: 16,
            welch_window: Window::Bh92,
            oms_delay: 0.0,
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

/// One experiment reduced to what the likelihood needs, per in-band bin `k`:
/// data `Y_k`, injections `I_k`, packed `C_k⁻¹` and the closed-loop constants.
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
    /// DFT of `(o1, o12)` per bin.
    pub y: Vec<[Complex64; 2]>,
    /// DFT of the commanded `(i1, i12)` per bin.
    pub inj: Vec<[Complex64; 2]>,
    /// `C_k⁻¹` packed as `(a, b, c)`, `C_k = (fs/2) Σw² S_k`.
    pub cinv: Vec<(f64, Complex64, f64)>,
    /// The noise CSD `S_k` used (one-sided).
    pub csd: Vec<Mat2>,
    /// θ-independent loop factors per bin.
    pub consts: Vec<BinConsts>,
    /// Which injection channels carry anything.
    pub active: [bool; 2],
}

impl ExperimentSpectra {
    /// Prepares one experiment. `model_csd` supplies the noise CSD when
    /// `opts.noise == NoiseSource::Model`.
    pub fn new(
        e: &ExperimentData,
        opts: &SpectraOptions,
        ctrl: &Controllers,
        model_csd: Option<&dyn Fn(f64) -> Mat2>,
    ) -> Result<Self, SpectraError> {
        let inv = |msg: String| SpectraError::Invalid {
            exp: e.name.clone(),
            msg,
        };
        let sig = |source| SpectraError::Signal {
            exp: e.name.clone(),
            source,
        };
        let n = e.o[0].len();
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
        let w = opts.window.values(n);
        let sum_w2: f64 = w.iter().map(|x| x * x).sum();
        let mut fft = RealFft::new(n).map_err(sig)?;
        let m = fft.spectrum_len();
        let mut spec = [(); 4].map(|_| vec![Complex64::new(0.0, 0.0); m]);
        let mut buf = vec![0.0; n];
        for (c, series) in [&e.o[0], &e.o[1], &e.i[0], &e.i[1]].into_iter().enumerate() {
            for (b, (x, wi)) in buf.iter_mut().zip(series.iter().zip(&w)) {
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
        let csd: Vec<Mat2> = match opts.noise {
            NoiseSource::Model => {
                let f = model_csd.ok_or_else(|| {
                    inv("noise = \"model\" needs the noise model of the study".into())
                })?;
                freqs.iter().map(|&x| f(x)).collect()
            }
            NoiseSource::Welch => welch_noise(e, opts, &freqs).map_err(&inv)?,
        };
        let scale = fs / 2.0 * sum_w2;
        let mut cinv = Vec::with_capacity(ks.len());
        for (s, f) in csd.iter().zip(&freqs) {
            let c = [
                [s[0][0] * scale, s[0][1] * scale],
                [s[1][0] * scale, s[1][1] * scale],
            ];
            cinv.push(hermitian::inverse(&c).ok_or_else(|| {
                inv(format!(
                    "the noise CSD is singular (or not positive definite) at {f:.6e} Hz: S11 = {:.3e}, S22 = {:.3e}, |S12| = {:.3e}; a channel without noise cannot be fitted: check the noise-only stretch or the noise levels",
                    s[0][0].re, s[1][1].re, s[0][1].norm()
                ))
            })?);
        }
        let y = ks.iter().map(|&k| [spec[0][k], spec[1][k]]).collect();
        let inj: Vec<[Complex64; 2]> = ks.iter().map(|&k| [spec[2][k], spec[3][k]]).collect();
        let active = [0, 1].map(|c| inj.iter().any(|v| v[c] != Complex64::new(0.0, 0.0)));
        let consts = freqs
            .iter()
            .map(|&f| BinConsts::new(f, ctrl, opts.oms_delay))
            .collect();
        Ok(Self {
            name: e.name.clone(),
            fs,
            n,
            df,
            freqs,
            y,
            inj,
            cinv,
            csd,
            consts,
            active,
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
}

/// Welch CSD of the noise-only stretch, interpolated onto `freqs`. Below the first Welch
/// frequency (and above the last regular one) the nearest estimate is used.
fn welch_noise(
    e: &ExperimentData,
    opts: &SpectraOptions,
    freqs: &[f64],
) -> Result<Vec<Mat2>, String> {
    let len = e.noise[0].len();
    let navs = opts.welch_averages.max(1) as f64;
    let ov = opts.welch_window.recommended_overlap();
    // M segments of length L overlapping by ov·L span L (1 + (M − 1)(1 − ov)) samples
    let seg = (len as f64 / (1.0 + (navs - 1.0) * (1.0 - ov))).floor() as usize;
    if seg < 16 {
        return Err(format!(
            "the noise-only stretch ({len} samples) is too short for {} Welch averages",
            opts.welch_averages
        ));
    }
    let cfg = WelchConfig::new(e.fs, opts.welch_window, seg);
    let s = welch_csd2(&e.noise[0], &e.noise[1], &cfg).map_err(|x| x.to_string())?;
    let first = e.fs / seg as f64;
    let last_k = if seg.is_multiple_of(2) {
        seg / 2 - 1
    } else {
        seg / 2
    };
    let last = last_k as f64 * e.fs / seg as f64;
    let targets: Vec<f64> = freqs.iter().map(|f| f.clamp(first, last)).collect();
    let c = s.interpolate(&targets).map_err(|x| x.to_string())?;
    Ok((0..freqs.len()).map(|k| c.matrix(k)).collect())
}
