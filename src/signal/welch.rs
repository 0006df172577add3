//! One-sided Welch estimates of PSDs and cross-spectral densities, and their interpolation.
//!
//! Each segment `m` of length `L` (start `m·D`, step `D = L − round(overlap·L)`) is optionally
//! mean-detrended, multiplied by the window `w` and transformed (`Y_m[k]`, module DFT
//! convention). The estimate is
//!
//! ```text
//! S_xy[k] = c_k / (fs Σw²) · (1/M) Σ_m X_m[k]* Y_m[k],   c_k = 2 for 0 < k < L/2, 1 at DC and Nyquist
//! ```
//!
//! (SciPy/MATLAB scaling: DC and Nyquist are not doubled, so for a smooth one-sided `S(f)`
//! those two bins estimate `S/2`; the likelihood drops them and the interpolators here never
//! use them). Samples after the last full segment are ignored.

use num_complex::Complex64;
use serde::{Deserialize, Serialize};

use super::error::{SignalError, check_finite, check_fs};
use super::fft::RealFft;
use super::window::Window;

/// Per-segment detrending before windowing.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Detrend {
    /// Use the segment as it is.
    None,
    /// Subtract the segment mean (LTPDA detrend order 0): keeps a DC offset from leaking
    /// through the window into the lowest bins.
    #[default]
    Mean,
}

/// Settings of a Welch estimate.
///
/// # Example
/// ```
/// use occam::signal::{Detrend, WelchConfig, Window};
///
/// let cfg = WelchConfig::new(10.0, Window::Bh92, 4096);
/// assert_eq!(cfg.overlap, 0.661); // the window's recommended overlap
/// assert_eq!(cfg.detrend, Detrend::Mean);
/// assert_eq!(cfg.step().unwrap(), 4096 - 2707);
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct WelchConfig {
    /// Sampling frequency in Hz.
    pub fs: f64,
    /// Taper applied to every segment.
    pub window: Window,
    /// Segment length `L` in samples; sets the resolution `fs/L`.
    pub segment_len: usize,
    /// Fraction of a segment shared with the next one, in `[0, 1)`.
    pub overlap: f64,
    /// Per-segment detrending.
    pub detrend: Detrend,
}

impl WelchConfig {
    /// A configuration with the window's recommended overlap and mean detrending.
    pub fn new(fs: f64, window: Window, segment_len: usize) -> Self {
        Self {
            fs,
            window,
            segment_len,
            overlap: window.recommended_overlap(),
            detrend: Detrend::Mean,
        }
    }

    /// Same configuration with another overlap fraction.
    pub fn with_overlap(mut self, overlap: f64) -> Self {
        self.overlap = overlap;
        self
    }

    /// Same configuration with another detrending.
    pub fn with_detrend(mut self, detrend: Detrend) -> Self {
        self.detrend = detrend;
        self
    }

    /// Segment step `D = L − round(overlap·L)` in samples, after validating `fs`,
    /// `segment_len` and `overlap`.
    pub fn step(&self) -> Result<usize, SignalError> {
        check_fs(self.fs)?;
        if self.segment_len < 2 {
            return Err(SignalError::TooShort {
                what: "segment_len",
                min: 2,
                got: self.segment_len,
            });
        }
        if !(self.overlap.is_finite() && (0.0..1.0).contains(&self.overlap)) {
            return Err(SignalError::InvalidParameter {
                name: "overlap",
                value: self.overlap,
                requirement: "the overlap is a fraction in [0, 1)",
            });
        }
        let shared = (self.overlap * self.segment_len as f64).round() as usize;
        if shared >= self.segment_len {
            return Err(SignalError::InvalidParameter {
                name: "overlap",
                value: self.overlap,
                requirement: "rounds to a full segment at this segment_len (step 0); lower it",
            });
        }
        Ok(self.segment_len - shared)
    }

    /// Number of full segments `M` in a series of `len` samples.
    pub fn n_segments(&self, len: usize) -> Result<usize, SignalError> {
        let step = self.step()?;
        if self.segment_len > len {
            return Err(SignalError::SegmentTooLong {
                segment_len: self.segment_len,
                len,
            });
        }
        Ok((len - self.segment_len) / step + 1)
    }

    /// Effective number of independent averages for `M = n_avg` segments, Percival & Walden
    /// (1993) eq. (292b) (after Welch 1967): with `ρ(j) = Σ_n w[n] w[n+j] / Σ_n w[n]²`,
    ///
    /// ```text
    /// M_eff = M / (1 + 2 Σ_{m=1}^{M−1} (1 − m/M) ρ(m D)²)
    /// ```
    ///
    /// so a regular bin of a smooth Gaussian spectrum has relative standard error
    /// `1/√M_eff` (equivalent χ² degrees of freedom `2 M_eff`). Hann at 50 % gives
    /// `ρ(L/2) = 1/6`, i.e. `M_eff → M/1.056`.
    pub fn n_eff(&self, n_avg: usize) -> Result<f64, SignalError> {
        let step = self.step()?;
        let w = self.window.values(self.segment_len);
        let s2: f64 = w.iter().map(|v| v * v).sum();
        let m = n_avg as f64;
        let mut denom = 1.0;
        for lag in 1..n_avg {
            let shift = lag * step;
            if shift >= self.segment_len {
                break;
            }
            let rho: f64 = w[..self.segment_len - shift]
                .iter()
                .zip(&w[shift..])
                .map(|(a, b)| a * b)
                .sum::<f64>()
                / s2;
            denom += 2.0 * (1.0 - lag as f64 / m) * rho * rho;
        }
        Ok(m / denom)
    }

    /// Frequencies `k fs / L`, `k = 0 … L/2`, of the estimate.
    pub fn freqs(&self) -> Result<Vec<f64>, SignalError> {
        super::fft::rfft_freqs(self.segment_len, self.fs)
    }
}

/// A one-sided PSD estimate.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Spectrum {
    /// Frequencies `k fs/L`, `k = 0 … L/2` (Hz).
    pub freqs: Vec<f64>,
    /// One-sided PSD (units²/Hz); DC and Nyquist bins not doubled.
    pub psd: Vec<f64>,
    /// Sampling frequency of the data (Hz).
    pub fs: f64,
    /// Segment length `L` (the last bin is the Nyquist bin when `L` is even).
    pub segment_len: usize,
    /// Number of segments averaged, `M`.
    pub n_avg: usize,
    /// Effective number of independent averages (see [`WelchConfig::n_eff`]).
    pub n_eff: f64,
}

/// A one-sided cross-spectral density estimate `S_xy ∝ E[X* Y]` of two series.
#[derive(Clone, Debug, PartialEq)]
pub struct CrossSpectrum {
    /// Frequencies (Hz).
    pub freqs: Vec<f64>,
    /// `S_xy[k]` (units_x·units_y/Hz), conjugate of `x`'s DFT times `y`'s DFT.
    pub csd: Vec<Complex64>,
    /// Sampling frequency of the data (Hz).
    pub fs: f64,
    /// Segment length `L` (the last bin is the Nyquist bin when `L` is even).
    pub segment_len: usize,
    /// Number of segments averaged, `M`.
    pub n_avg: usize,
    /// Effective number of independent averages.
    pub n_eff: f64,
}

/// The one-sided 2×2 Hermitian CSD matrix of two channels, `S = scale · E[Y Yᴴ]`, per
/// frequency: `S11`, `S22` real, `S12 = scale · E[Y1 Y2*]`, `S21 = S12*`.
#[derive(Clone, Debug, PartialEq)]
pub struct Spectrum2 {
    /// Frequencies (Hz).
    pub freqs: Vec<f64>,
    /// PSD of channel 1.
    pub s11: Vec<f64>,
    /// Cross term `E[Y1 Y2*]` (the (1,2) matrix element).
    pub s12: Vec<Complex64>,
    /// PSD of channel 2.
    pub s22: Vec<f64>,
    /// Sampling frequency of the data (Hz).
    pub fs: f64,
    /// Segment length `L` (the last bin is the Nyquist bin when `L` is even).
    pub segment_len: usize,
    /// Number of segments averaged, `M`.
    pub n_avg: usize,
    /// Effective number of independent averages.
    pub n_eff: f64,
}

/// Welch one-sided PSD of `x`.
///
/// # Example
/// ```
/// use occam::signal::{WelchConfig, Window, welch_psd};
///
/// // A unit-amplitude sine at 1 Hz sampled at 16 Hz has power 1/2.
/// let fs = 16.0;
/// let x: Vec<f64> = (0..1024).map(|n| (2.0 * std::f64::consts::PI * n as f64 / fs).sin()).collect();
/// let cfg = WelchConfig::new(fs, Window::Hann, 256);
/// let s = welch_psd(&x, &cfg).unwrap();
/// assert_eq!(s.n_avg, 7); // 50 % overlap
/// let df = fs / 256.0;
/// let power: f64 = s.psd.iter().sum::<f64>() * df; // Parseval: ∫ S df = variance
/// assert!((power - 0.5).abs() < 1e-12);
/// let k = 16; // 1 Hz = 16 bins: peak height × ENBW is the power too
/// assert!((s.psd[k] * Window::Hann.enbw(256, fs) - 0.5).abs() < 1e-12);
/// ```
pub fn welch_psd(x: &[f64], cfg: &WelchConfig) -> Result<Spectrum, SignalError> {
    let est = welch_core(cfg, &[("x", x)], &[[0, x.len()]])?;
    Ok(Spectrum {
        psd: est.cov.iter().map(|m| m[0][0].re).collect(),
        freqs: est.freqs,
        fs: cfg.fs,
        segment_len: cfg.segment_len,
        n_avg: est.n_avg,
        n_eff: est.n_eff,
    })
}

/// Welch one-sided cross-spectral density `S_xy = c/(fs Σw²) ⟨X* Y⟩` (conjugate of `x`'s DFT
/// times `y`'s, as SciPy `csd` and MATLAB `cpsd`). A `y` that lags `x` by `τ` has phase
/// `−2πfτ`. Note `S_xy = S_yx*`, and the matrix element of [`Spectrum2`] is
/// `S12 = S_{y2 y1}`.
///
/// # Example
/// ```
/// use occam::signal::{Detrend, WelchConfig, Window, welch_csd};
///
/// // y is x delayed by one sample (circularly, so one rectangular segment is exact).
/// let x: Vec<f64> = (0..64).map(|n| ((n * 37 % 11) as f64 - 5.0)).collect();
/// let y: Vec<f64> = (0..64).map(|n| x[(n + 63) % 64]).collect();
/// let cfg = WelchConfig::new(1.0, Window::Rectangular, 64).with_detrend(Detrend::None);
/// let s = welch_csd(&x, &y, &cfg).unwrap();
/// let k = 5;
/// let expected_phase = -2.0 * std::f64::consts::PI * s.freqs[k] * 1.0;
/// assert!((s.csd[k].arg() - expected_phase).abs() < 1e-9);
/// ```
pub fn welch_csd(x: &[f64], y: &[f64], cfg: &WelchConfig) -> Result<CrossSpectrum, SignalError> {
    let est = welch_core(cfg, &[("x", x), ("y", y)], &[[0, x.len()]])?;
    Ok(CrossSpectrum {
        // cov[0][1] = ⟨X Y*⟩, so ⟨X* Y⟩ is cov[1][0].
        csd: est.cov.iter().map(|m| m[1][0]).collect(),
        freqs: est.freqs,
        fs: cfg.fs,
        segment_len: cfg.segment_len,
        n_avg: est.n_avg,
        n_eff: est.n_eff,
    })
}

/// Welch estimate of the 2×2 CSD matrix of two channels (see [`Spectrum2`] for the
/// convention), from one set of FFTs.
///
/// # Example
/// ```
/// use occam::signal::{WelchConfig, Window, welch_csd, welch_csd2};
///
/// let y1: Vec<f64> = (0..512).map(|n| ((n * 7919 % 101) as f64).sin()).collect();
/// let y2: Vec<f64> = (0..512).map(|n| ((n * 104729 % 97) as f64).cos()).collect();
/// let cfg = WelchConfig::new(2.0, Window::Hann, 128);
/// let m = welch_csd2(&y1, &y2, &cfg).unwrap();
/// let c = welch_csd(&y2, &y1, &cfg).unwrap(); // S12 = S_{y2 y1}
/// assert!((m.s12[10] - c.csd[10]).norm() < 1e-12 * m.s11[10].max(m.s22[10]));
/// assert!(m.s12[10].norm_sqr() <= m.s11[10] * m.s22[10]); // Cauchy–Schwarz
/// ```
pub fn welch_csd2(y1: &[f64], y2: &[f64], cfg: &WelchConfig) -> Result<Spectrum2, SignalError> {
    welch_csd2_runs(y1, y2, cfg, &[[0, y1.len()]])
}

/// [`welch_csd2`] of series with gaps: only segments that lie wholly inside one of the valid
/// runs `runs` (half-open sample ranges, in order, not overlapping) are averaged, each run
/// segmented from its own start as a series of its own; runs shorter than a segment give
/// none. The effective number of averages is the sum of the runs' (their segments are
/// independent across a gap). One run `[0, len]` is exactly [`welch_csd2`].
///
/// ```
/// use occam::signal::{WelchConfig, Window, welch_csd2, welch_csd2_runs};
///
/// let y: Vec<f64> = (0..1024).map(|n| ((n * 7919 % 101) as f64).sin()).collect();
/// let cfg = WelchConfig::new(1.0, Window::Hann, 128);
/// let whole = welch_csd2(&y, &y, &cfg).unwrap();
/// let gapped = welch_csd2_runs(&y, &y, &cfg, &[[0, 400], [600, 1024]]).unwrap();
/// assert!(gapped.n_avg < whole.n_avg);
/// ```
pub fn welch_csd2_runs(
    y1: &[f64],
    y2: &[f64],
    cfg: &WelchConfig,
    runs: &[[usize; 2]],
) -> Result<Spectrum2, SignalError> {
    let est = welch_core(cfg, &[("y1", y1), ("y2", y2)], runs)?;
    Ok(Spectrum2 {
        s11: est.cov.iter().map(|m| m[0][0].re).collect(),
        s12: est.cov.iter().map(|m| m[0][1]).collect(),
        s22: est.cov.iter().map(|m| m[1][1].re).collect(),
        freqs: est.freqs,
        fs: cfg.fs,
        segment_len: cfg.segment_len,
        n_avg: est.n_avg,
        n_eff: est.n_eff,
    })
}

/// Scaled `⟨Y_i Y_j*⟩` for up to two channels (unused entries zero).
struct Estimate {
    freqs: Vec<f64>,
    cov: Vec<[[Complex64; 2]; 2]>,
    n_avg: usize,
    n_eff: f64,
}

fn welch_core(
    cfg: &WelchConfig,
    series: &[(&'static str, &[f64])],
    runs: &[[usize; 2]],
) -> Result<Estimate, SignalError> {
    assert!((1..=2).contains(&series.len()));
    let (first, x0) = series[0];
    for &(name, x) in &series[1..] {
        if x.len() != x0.len() {
            return Err(SignalError::LengthMismatch {
                first,
                len_first: x0.len(),
                second: name,
                len_second: x.len(),
            });
        }
    }
    for &(name, x) in series {
        check_finite(name, x)?;
    }
    let step = cfg.step()?;
    let l = cfg.segment_len;
    // segment starts, run by run
    let mut starts = Vec::new();
    let mut n_eff = 0.0;
    let mut longest = 0;
    for &[a, b] in runs {
        if a > b || b > x0.len() {
            return Err(SignalError::InvalidParameter {
                name: "runs",
                value: b as f64,
                requirement: "valid runs lie inside the series, each [start, end) with start ≤ end",
            });
        }
        longest = longest.max(b - a);
        if b - a < l {
            continue;
        }
        let m = cfg.n_segments(b - a)?;
        starts.extend((0..m).map(|j| a + j * step));
        n_eff += cfg.n_eff(m)?;
    }
    if starts.is_empty() {
        return Err(SignalError::SegmentTooLong {
            segment_len: l,
            len: longest,
        });
    }
    let n_avg = starts.len();
    let nb = l / 2 + 1;
    let w = cfg.window.values(l);
    let s2: f64 = w.iter().map(|v| v * v).sum();

    let mut fft = RealFft::new(l)?;
    let mut seg = vec![0.0; l];
    let zero = Complex64::new(0.0, 0.0);
    let mut spec = [vec![zero; nb], vec![zero; nb]];
    let mut cov = vec![[[zero; 2]; 2]; nb];
    let nch = series.len();
    for &start in &starts {
        for (c, &(_, x)) in series.iter().enumerate() {
            let chunk = &x[start..start + l];
            let mean = match cfg.detrend {
                Detrend::None => 0.0,
                Detrend::Mean => chunk.iter().sum::<f64>() / l as f64,
            };
            for ((s, &v), &wv) in seg.iter_mut().zip(chunk).zip(&w) {
                *s = (v - mean) * wv;
            }
            fft.forward(&seg, &mut spec[c])?;
        }
        for (k, acc) in cov.iter_mut().enumerate() {
            for i in 0..nch {
                for j in i..nch {
                    acc[i][j] += spec[i][k] * spec[j][k].conj();
                }
            }
        }
    }
    let base = 1.0 / (cfg.fs * s2 * n_avg as f64);
    for (k, acc) in cov.iter_mut().enumerate() {
        let regular = k > 0 && 2 * k < l;
        let scale = if regular { 2.0 * base } else { base };
        acc[0][0] = Complex64::new(acc[0][0].re * scale, 0.0);
        if nch == 2 {
            acc[0][1] *= scale;
            acc[1][0] = acc[0][1].conj();
            acc[1][1] = Complex64::new(acc[1][1].re * scale, 0.0);
        }
    }
    Ok(Estimate {
        freqs: cfg.freqs()?,
        cov,
        n_avg,
        n_eff,
    })
}

impl Spectrum {
    /// The PSD at arbitrary frequencies, linear in log-log between the regular bins
    /// `0 < k < L/2` (see [`interp_loglog`]); targets must lie in `[fs/L, f_last_regular]`.
    pub fn interpolate(&self, targets: &[f64]) -> Result<Vec<f64>, SignalError> {
        let r = regular_range(self.freqs.len(), self.segment_len);
        interp_loglog(&self.freqs[r.clone()], &self.psd[r], targets)
    }
}

impl CrossSpectrum {
    /// The CSD at arbitrary frequencies, linear in the complex value between regular bins
    /// `0 < k < L/2` (see [`interp_linear_complex`]).
    pub fn interpolate(&self, targets: &[f64]) -> Result<Vec<Complex64>, SignalError> {
        let r = regular_range(self.freqs.len(), self.segment_len);
        interp_linear_complex(&self.freqs[r.clone()], &self.csd[r], targets)
    }
}

impl Spectrum2 {
    /// The 2×2 matrix `[[S11, S12], [S12*, S22]]` at bin `k`.
    pub fn matrix(&self, k: usize) -> [[Complex64; 2]; 2] {
        hermitian(self.s11[k], self.s12[k], self.s22[k])
    }

    /// The matrix at arbitrary frequencies `targets`, which must lie within the regular bins
    /// `[fs/L, f_last_regular]`.
    ///
    /// `S11`, `S22` are interpolated linearly in log-log; the cross term through the complex
    /// coherence `γ = S12/√(S11 S22)`, linearly, then `S12 = γ √(S11 S22)` at the target.
    /// Plain linear interpolation of `S12` next to geometric interpolation of the diagonal can
    /// push `|S12|² > S11 S22` between strongly coherent bins (AM ≥ GM), giving a matrix the
    /// likelihood cannot invert; linear interpolation keeps `|γ| ≤ 1`, so this cannot.
    pub fn interpolate(&self, targets: &[f64]) -> Result<Csd2, SignalError> {
        let r = regular_range(self.freqs.len(), self.segment_len);
        let f = &self.freqs[r.clone()];
        let s11 = interp_loglog(f, &self.s11[r.clone()], targets)?;
        let s22 = interp_loglog(f, &self.s22[r.clone()], targets)?;
        let gamma: Vec<Complex64> = r
            .map(|k| {
                let d = (self.s11[k] * self.s22[k]).sqrt();
                if d > 0.0 {
                    self.s12[k] / d
                } else {
                    Complex64::new(0.0, 0.0)
                }
            })
            .collect();
        let g = interp_linear_complex(f, &gamma, targets)?;
        let s12 = g
            .iter()
            .zip(s11.iter().zip(&s22))
            .map(|(g, (a, b))| g * (a * b).sqrt())
            .collect();
        Ok(Csd2 {
            freqs: targets.to_vec(),
            s11,
            s12,
            s22,
        })
    }
}

/// A one-sided 2×2 CSD matrix on an arbitrary frequency grid (same convention as
/// [`Spectrum2`]), e.g. a Welch estimate interpolated onto the likelihood's bins.
#[derive(Clone, Debug, PartialEq)]
pub struct Csd2 {
    /// Frequencies (Hz).
    pub freqs: Vec<f64>,
    /// PSD of channel 1.
    pub s11: Vec<f64>,
    /// Cross term `E[Y1 Y2*]`.
    pub s12: Vec<Complex64>,
    /// PSD of channel 2.
    pub s22: Vec<f64>,
}

impl Csd2 {
    /// The 2×2 matrix `[[S11, S12], [S12*, S22]]` at index `k`.
    pub fn matrix(&self, k: usize) -> [[Complex64; 2]; 2] {
        hermitian(self.s11[k], self.s12[k], self.s22[k])
    }
}

fn hermitian(s11: f64, s12: Complex64, s22: f64) -> [[Complex64; 2]; 2] {
    [
        [Complex64::new(s11, 0.0), s12],
        [s12.conj(), Complex64::new(s22, 0.0)],
    ]
}

/// Regular bins `1 ≤ k ≤ (L−1)/2` of an `L`-point estimate with `nb = L/2 + 1` bins.
fn regular_range(nb: usize, segment_len: usize) -> std::ops::Range<usize> {
    let last = segment_len.saturating_sub(1) / 2;
    1..(last + 1).min(nb)
}

/// Validates an interpolation grid and finds, for `t`, the bracketing index `i` with
/// `f[i] ≤ t ≤ f[i+1]` (or `i = len−1` when `t` equals the last node).
fn bracket(f: &[f64], t: f64) -> Result<usize, SignalError> {
    let (min, max) = (f[0], f[f.len() - 1]);
    if !(t >= min && t <= max) {
        return Err(SignalError::OutOfRange { freq: t, min, max });
    }
    // First node strictly greater than t, minus one.
    Ok(f.partition_point(|&x| x <= t).saturating_sub(1))
}

fn check_grid(f: &[f64], nvalues: usize) -> Result<(), SignalError> {
    if f.len() != nvalues {
        return Err(SignalError::LengthMismatch {
            first: "frequencies",
            len_first: f.len(),
            second: "values",
            len_second: nvalues,
        });
    }
    if f.is_empty() {
        return Err(SignalError::TooShort {
            what: "interpolation grid",
            min: 1,
            got: 0,
        });
    }
    check_finite("frequencies", f)?;
    if let Some(i) = (1..f.len()).find(|&i| f[i] <= f[i - 1]) {
        return Err(SignalError::UnsortedGrid {
            index: i,
            value: f[i],
        });
    }
    Ok(())
}

/// Interpolates a non-negative spectrum `values(freqs)` at `targets`, linearly in
/// `(ln f, ln S)` (exact for power laws, the natural shape of noise spectra).
///
/// `freqs` must be positive and strictly increasing; targets outside `[freqs[0], freqs.last]`
/// are an error (no extrapolation). Where a bracketing value is zero, log-log is undefined and
/// the interval is interpolated linearly instead.
///
/// # Example
/// ```
/// use occam::signal::interp_loglog;
///
/// let f = [1e-3, 1e-2, 1e-1];
/// let s: Vec<f64> = f.iter().map(|f: &f64| 4e-20 * f.powi(-2)).collect();
/// let v = interp_loglog(&f, &s, &[3e-3]).unwrap();
/// assert!((v[0] / (4e-20 * 3e-3f64.powi(-2)) - 1.0).abs() < 1e-12);
/// ```
pub fn interp_loglog(
    freqs: &[f64],
    values: &[f64],
    targets: &[f64],
) -> Result<Vec<f64>, SignalError> {
    check_grid(freqs, values.len())?;
    if freqs[0] <= 0.0 {
        return Err(SignalError::InvalidParameter {
            name: "freqs[0]",
            value: freqs[0],
            requirement: "log-log interpolation needs positive frequencies (drop the DC bin)",
        });
    }
    check_finite("values", values)?;
    if let Some(i) = values.iter().position(|&v| v < 0.0) {
        return Err(SignalError::NegativePsd {
            what: "spectrum",
            freq: freqs[i],
            value: values[i],
        });
    }
    targets
        .iter()
        .map(|&t| {
            let i = bracket(freqs, t)?;
            if i + 1 == freqs.len() || t == freqs[i] {
                return Ok(values[i]);
            }
            let (f0, f1, v0, v1) = (freqs[i], freqs[i + 1], values[i], values[i + 1]);
            if v0 > 0.0 && v1 > 0.0 {
                let u = (t / f0).ln() / (f1 / f0).ln();
                Ok((v0.ln() + u * (v1 / v0).ln()).exp())
            } else {
                let u = (t - f0) / (f1 - f0);
                Ok(v0 + u * (v1 - v0))
            }
        })
        .collect()
}

/// Interpolates complex values linearly in frequency (real and imaginary parts separately).
///
/// `freqs` must be strictly increasing; targets outside the grid are an error.
///
/// # Example
/// ```
/// use num_complex::Complex64;
/// use occam::signal::interp_linear_complex;
///
/// let f = [1.0, 2.0];
/// let v = [Complex64::new(0.0, 1.0), Complex64::new(2.0, -1.0)];
/// let out = interp_linear_complex(&f, &v, &[1.5]).unwrap();
/// assert_eq!(out[0], Complex64::new(1.0, 0.0));
/// ```
pub fn interp_linear_complex(
    freqs: &[f64],
    values: &[Complex64],
    targets: &[f64],
) -> Result<Vec<Complex64>, SignalError> {
    check_grid(freqs, values.len())?;
    for (i, v) in values.iter().enumerate() {
        if !(v.re.is_finite() && v.im.is_finite()) {
            return Err(SignalError::NonFinite {
                what: "values",
                index: i,
                value: if v.re.is_finite() { v.im } else { v.re },
            });
        }
    }
    targets
        .iter()
        .map(|&t| {
            let i = bracket(freqs, t)?;
            if i + 1 == freqs.len() {
                return Ok(values[i]);
            }
            let u = (t - freqs[i]) / (freqs[i + 1] - freqs[i]);
            Ok(values[i] + (values[i + 1] - values[i]) * u)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::signal::fft::dft_naive;
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};
    use rand_xoshiro::Xoshiro256PlusPlus;

    /// With gaps the estimate is the segment-count-weighted mean of the runs' own estimates
    /// (each run a series of its own), and the effective averages add up; a run shorter than
    /// a segment contributes nothing, and one run over the whole series is `welch_csd2`.
    #[test]
    fn valid_runs_average_their_own_segments() {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(11);
        let n = 3000;
        let a: Vec<f64> = (0..n).map(|_| StandardNormal.sample(&mut rng)).collect();
        let b: Vec<f64> = a
            .iter()
            .map(|x| {
                let z: f64 = StandardNormal.sample(&mut rng);
                0.5 * x + z
            })
            .collect();
        let cfg = WelchConfig::new(2.0, Window::Hann, 256);
        let runs = [[0, 1000], [1100, 1200], [1300, 3000]];
        let got = welch_csd2_runs(&a, &b, &cfg, &runs).unwrap();
        let p1 = welch_csd2(&a[0..1000], &b[0..1000], &cfg).unwrap();
        let p2 = welch_csd2(&a[1300..3000], &b[1300..3000], &cfg).unwrap();
        assert_eq!(got.n_avg, p1.n_avg + p2.n_avg);
        assert!((got.n_eff - (p1.n_eff + p2.n_eff)).abs() < 1e-12);
        let (m1, m2) = (p1.n_avg as f64, p2.n_avg as f64);
        for k in 0..got.s11.len() {
            let want11 = (m1 * p1.s11[k] + m2 * p2.s11[k]) / (m1 + m2);
            let want12 = (p1.s12[k] * m1 + p2.s12[k] * m2) / (m1 + m2);
            assert!((got.s11[k] - want11).abs() <= 1e-12 * want11.abs(), "{k}");
            assert!((got.s12[k] - want12).norm() <= 1e-12 * want12.norm().max(1e-300));
        }
        let whole = welch_csd2(&a, &b, &cfg).unwrap();
        let one = welch_csd2_runs(&a, &b, &cfg, &[[0, n]]).unwrap();
        assert_eq!(
            (whole.s11, whole.s12, whole.n_eff),
            (one.s11, one.s12, one.n_eff)
        );
        assert!(welch_csd2_runs(&a, &b, &cfg, &[[0, 100], [200, 300]]).is_err());
    }

    fn white(n: usize, sigma: f64, seed: u64) -> Vec<f64> {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
        (0..n)
            .map(|_| {
                let z: f64 = StandardNormal.sample(&mut rng);
                sigma * z
            })
            .collect()
    }

    /// Variance factor of a band mean of Welch bins for white Gaussian noise.
    ///
    /// With `Y_{m,k}` the windowed DFT of segment `m`, `E[Y_{m,k} Y*_{m',k'}] = σ² Σw² ρ(ℓ, Δ)`,
    /// `ℓ = m'−m`, `Δ = k−k'`, `ρ(ℓ, Δ) = Σ_n w[n] w[n+ℓD] e^{−2πiΔn/L} / Σw²` (|ρ| is even in
    /// both). Isserlis gives `Cov(|Y_a|², |Y_b|²) = |E[Y_a Y_b*]|² + |E[Y_a Y_b]|²`; the second
    /// (pseudo-covariance) term needs `k + k' ≈ 0 or L` and vanishes for bands kept away from
    /// DC and Nyquist. The band mean of K bins over M segments therefore has relative variance
    /// `v/(M K)` with `v = Σ_ℓ (1 − |ℓ|/M) Σ_Δ (1 − |Δ|/K) |ρ(ℓ,Δ)|²`. For the rectangular
    /// window without overlap `v = 1`, the textbook `1/(M K)`; Hann's correlated neighbours
    /// (|ρ(0,±1)|² = 4/9) make it ≈ 1.94/1.06 times larger, so `1/√(M_eff K)` alone would
    /// understate the error. The same `v` holds for cross spectra (every covariance term of
    /// `X1 X2*` is proportional to `|ρ|²`).
    fn band_mean_var_factor(w: &[f64], step: usize, m: usize, k: usize) -> f64 {
        let l = w.len();
        let s2: f64 = w.iter().map(|v| v * v).sum();
        let mut v = 0.0;
        for lag in 0..m {
            let shift = lag * step;
            if shift >= l {
                break;
            }
            let wl = if lag == 0 { 1.0 } else { 2.0 } * (1.0 - lag as f64 / m as f64);
            for d in 0..k {
                let rho: Complex64 = (0..l - shift)
                    .map(|n| {
                        let ph = -2.0 * std::f64::consts::PI * ((d * n) % l) as f64 / l as f64;
                        Complex64::from_polar(w[n] * w[n + shift], ph)
                    })
                    .sum::<Complex64>()
                    / s2;
                let wd = if d == 0 { 1.0 } else { 2.0 } * (1.0 - d as f64 / k as f64);
                v += wl * wd * rho.norm_sqr();
            }
        }
        v
    }

    #[test]
    fn one_rectangular_segment_is_the_naive_periodogram() {
        for &n in &[100usize, 99] {
            let fs = 4.0;
            let x = white(n, 2.0, n as u64);
            let cfg = WelchConfig::new(fs, Window::Rectangular, n).with_detrend(Detrend::None);
            let s = welch_psd(&x, &cfg).unwrap();
            let y = dft_naive(&x);
            assert_eq!(s.psd.len(), y.len());
            assert_eq!(s.n_avg, 1);
            for (k, (p, yk)) in s.psd.iter().zip(&y).enumerate() {
                let doubled = k > 0 && 2 * k < n;
                let c = if doubled { 2.0 } else { 1.0 };
                let want = c * yk.norm_sqr() / (fs * n as f64);
                assert!((p - want).abs() <= 1e-12 * want.max(1.0), "n={n} k={k}");
                assert!((s.freqs[k] - k as f64 * fs / n as f64).abs() < 1e-12);
            }
            // One Hann segment: the same with w·x and Σw².
            let cfg = WelchConfig::new(fs, Window::Hann, n).with_detrend(Detrend::None);
            let s = welch_psd(&x, &cfg).unwrap();
            let w = Window::Hann.values(n);
            let wx: Vec<f64> = x.iter().zip(&w).map(|(a, b)| a * b).collect();
            let s2: f64 = w.iter().map(|v| v * v).sum();
            for (k, yk) in dft_naive(&wx).iter().enumerate() {
                let c = if k > 0 && 2 * k < n { 2.0 } else { 1.0 };
                let want = c * yk.norm_sqr() / (fs * s2);
                assert!(
                    (s.psd[k] - want).abs() <= 1e-12 * want.max(1.0),
                    "hann n={n} k={k}"
                );
            }
        }
    }

    #[test]
    fn mean_detrend_removes_offset_and_segments_average() {
        let n = 64;
        let x: Vec<f64> = white(n, 1.0, 5).iter().map(|v| v + 100.0).collect();
        let cfg = WelchConfig::new(1.0, Window::Rectangular, 32).with_overlap(0.5);
        let s = welch_psd(&x, &cfg).unwrap();
        assert_eq!(s.n_avg, 3);
        assert!(s.psd[0] < 1e-20);
        // Average of the three detrended segments' periodograms, by hand.
        let mut want = [0.0; 17];
        for m in 0..3 {
            let seg = &x[16 * m..16 * m + 32];
            let mu = seg.iter().sum::<f64>() / 32.0;
            let d: Vec<f64> = seg.iter().map(|v| v - mu).collect();
            for (k, y) in dft_naive(&d).iter().enumerate() {
                let c = if k > 0 && k < 16 { 2.0 } else { 1.0 };
                want[k] += c * y.norm_sqr() / 32.0 / 3.0;
            }
        }
        for (k, (got, want)) in s.psd.iter().zip(&want).enumerate().skip(1) {
            assert!((got - want).abs() < 1e-12 * want.max(1.0), "k={k}");
        }
    }

    #[test]
    fn csd_is_conj_x_times_y_and_consistent_with_matrix() {
        // Circular one-sample delay: Y = X e^{−2πik/L}, so X* Y = |X|² e^{−2πik/L}.
        let n = 128;
        let x = white(n, 1.0, 11);
        let y: Vec<f64> = (0..n).map(|i| x[(i + n - 1) % n]).collect();
        let cfg = WelchConfig::new(1.0, Window::Rectangular, n).with_detrend(Detrend::None);
        let c = welch_csd(&x, &y, &cfg).unwrap();
        let p = welch_psd(&x, &cfg).unwrap();
        for k in 1..n / 2 {
            let want =
                Complex64::from_polar(p.psd[k], -2.0 * std::f64::consts::PI * k as f64 / n as f64);
            assert!(
                (c.csd[k] - want).norm() < 1e-12 * p.psd[k].max(1.0),
                "k={k}"
            );
        }
        // Matrix element S12 = S_{y2 y1}, diagonals are the PSDs.
        let cfg = WelchConfig::new(3.0, Window::Bh92, 64);
        let (a, b) = (white(1000, 1.0, 1), white(1000, 2.0, 2));
        let m = welch_csd2(&a, &b, &cfg).unwrap();
        let pa = welch_psd(&a, &cfg).unwrap();
        let pb = welch_psd(&b, &cfg).unwrap();
        let cba = welch_csd(&b, &a, &cfg).unwrap();
        let caa = welch_csd(&a, &a, &cfg).unwrap();
        for k in 0..m.freqs.len() {
            assert_eq!(m.s11[k], pa.psd[k]);
            assert_eq!(m.s22[k], pb.psd[k]);
            assert!((m.s12[k] - cba.csd[k]).norm() <= 1e-14 * (m.s11[k] + m.s22[k]));
            assert!(
                (caa.csd[k].re - pa.psd[k]).abs() <= 1e-14 * pa.psd[k]
                    && caa.csd[k].im.abs() <= 1e-14 * pa.psd[k]
            );
            let mk = m.matrix(k);
            assert_eq!(mk[1][0], m.s12[k].conj());
        }
        assert_eq!(m.n_avg, pa.n_avg);
    }

    #[test]
    fn n_eff_matches_closed_forms() {
        // Hann at exactly 50 %: ρ(L/2) = 1/6 for the periodic window, no other lag overlaps.
        let cfg = WelchConfig::new(1.0, Window::Hann, 256);
        let m = 100usize;
        let want = m as f64 / (1.0 + 2.0 * (1.0 - 1.0 / m as f64) / 36.0);
        assert!((cfg.n_eff(m).unwrap() - want).abs() < 1e-10);
        let rect = WelchConfig::new(1.0, Window::Rectangular, 256);
        assert_eq!(rect.n_eff(7).unwrap(), 7.0);
        // BH92 at 66.1 %: lags 1 and 2 overlap; compare with the independent helper's Δ = 0 sum.
        let cfg = WelchConfig::new(1.0, Window::Bh92, 300);
        let step = cfg.step().unwrap();
        let w = Window::Bh92.values(300);
        let v0 = band_mean_var_factor(&w, step, 50, 1);
        assert!((cfg.n_eff(50).unwrap() - 50.0 / v0).abs() < 1e-9);
    }

    #[test]
    fn white_noise_level_matches_parseval_within_derived_error() {
        // White noise of variance σ² has one-sided PSD 2σ²/fs at every regular bin, for any
        // window (E|Y_k|² = σ² Σw²). Band mean over K bins and M segments: relative standard
        // error √(v/(M K)), v from `band_mean_var_factor`; we allow 4 standard errors
        // (two-sided false-alarm rate 6e-5; seeds are fixed, so the test is deterministic).
        let (fs, sigma, l) = (10.0, 3e-12, 512usize);
        let level = 2.0 * sigma * sigma / fs;
        for (i, window) in Window::ALL.into_iter().enumerate() {
            let cfg = WelchConfig::new(fs, window, l);
            let step = cfg.step().unwrap();
            let m = 200;
            let x = white((m - 1) * step + l, sigma, 40 + i as u64);
            let s = welch_psd(&x, &cfg).unwrap();
            assert_eq!(s.n_avg, m);
            // Skip the bins touched by the mean removal (window mainlobe: 4 cosine terms at
            // most) and the matching ones below Nyquist (pseudo-covariance).
            let band = 4..l / 2 - 4;
            let k = band.len();
            let mean = s.psd[band.clone()].iter().sum::<f64>() / k as f64 / level;
            let v = band_mean_var_factor(&window.values(l), step, m, k);
            let se = (v / (m as f64 * k as f64)).sqrt();
            eprintln!(
                "{window}: band mean/level − 1 = {:.2e} ({:+.2} se), v = {v:.3}",
                mean - 1.0,
                (mean - 1.0) / se
            );
            assert!(
                (mean - 1.0).abs() < 4.0 * se,
                "{window}: mean {mean}, se {se}"
            );
            // Bin scatter: relative variance 1/M_eff per bin. Bins 4 apart are uncorrelated
            // for white noise (ρ(0, Δ) = 0 for |Δ| ≥ 4 with ≤ 4 cosine terms), so the sample
            // variance of K' bins has relative error √(2/(K'−1)).
            let picks: Vec<f64> = s.psd[band]
                .iter()
                .step_by(4)
                .map(|p| p / level - 1.0)
                .collect();
            let kp = picks.len() as f64;
            let mu = picks.iter().sum::<f64>() / kp;
            let var = picks.iter().map(|r| (r - mu).powi(2)).sum::<f64>() / (kp - 1.0);
            let ratio = var * s.n_eff;
            eprintln!(
                "{window}: bin variance × M_eff = {ratio:.3} over {kp} bins, M_eff = {:.1}",
                s.n_eff
            );
            assert!(
                (ratio - 1.0).abs() < 4.0 * (2.0 / (kp - 1.0)).sqrt(),
                "{window}: var·M_eff = {ratio}"
            );
        }
    }

    #[test]
    fn correlated_white_cross_spectrum_has_the_right_level() {
        // y = a x + b n with x, n independent white of variance σ²: S_xy = a·2σ²/fs, real.
        // Single-bin variances (circular Gaussian, Isserlis): Var Re Ŝ = (S11 S22 + Re S12²)/2,
        // Var Im Ŝ = (S11 S22 − Re S12²)/2 per independent average; the band mean divides by
        // M K/v as for the PSD. Tolerance 4 standard errors.
        let (fs, sigma, l, m) = (2.0, 1.5, 256usize, 300usize);
        let (a, b) = (0.7, 1.3);
        let cfg = WelchConfig::new(fs, Window::Hann, l);
        let step = cfg.step().unwrap();
        let len = (m - 1) * step + l;
        let x = white(len, sigma, 3);
        let noise = white(len, sigma, 4);
        let y: Vec<f64> = x.iter().zip(&noise).map(|(x, n)| a * x + b * n).collect();
        let c = welch_csd(&x, &y, &cfg).unwrap();
        let s0 = 2.0 * sigma * sigma / fs;
        let (s11, s22, s12) = (s0, (a * a + b * b) * s0, a * s0);
        let band = 4..l / 2 - 4;
        let k = band.len();
        let mean: Complex64 = c.csd[band].iter().sum::<Complex64>() / k as f64;
        let v = band_mean_var_factor(&Window::Hann.values(l), step, m, k);
        let scale = v / (m as f64 * k as f64);
        let se_re = ((s11 * s22 + s12 * s12) / 2.0 * scale).sqrt();
        let se_im = ((s11 * s22 - s12 * s12) / 2.0 * scale).sqrt();
        eprintln!(
            "cross: re {:+.2} se, im {:+.2} se",
            (mean.re - s12) / se_re,
            mean.im / se_im
        );
        assert!(
            (mean.re - s12).abs() < 4.0 * se_re,
            "re {} vs {s12} ± {se_re}",
            mean.re
        );
        assert!(mean.im.abs() < 4.0 * se_im, "im {} ± {se_im}", mean.im);
    }

    #[test]
    fn invalid_inputs_are_named_errors() {
        let cfg = WelchConfig::new(1.0, Window::Hann, 16);
        let x = vec![0.0; 32];
        assert!(matches!(
            welch_csd(&x, &x[..31], &cfg),
            Err(SignalError::LengthMismatch {
                len_first: 32,
                len_second: 31,
                ..
            })
        ));
        assert!(matches!(
            welch_psd(&x[..10], &cfg),
            Err(SignalError::SegmentTooLong {
                segment_len: 16,
                len: 10
            })
        ));
        for bad in [1.0, -0.1, f64::NAN] {
            assert!(matches!(
                welch_psd(&x, &cfg.clone().with_overlap(bad)),
                Err(SignalError::InvalidParameter {
                    name: "overlap",
                    ..
                })
            ));
        }
        // 0.99 of 16 samples rounds to 16: a zero step is refused, not looped on.
        assert!(matches!(
            welch_psd(&x, &cfg.clone().with_overlap(0.99)),
            Err(SignalError::InvalidParameter {
                name: "overlap",
                ..
            })
        ));
        let mut y = x.clone();
        y[7] = f64::INFINITY;
        assert!(matches!(
            welch_csd2(&x, &y, &cfg),
            Err(SignalError::NonFinite {
                what: "y2",
                index: 7,
                ..
            })
        ));
        let mut c = cfg.clone();
        c.fs = 0.0;
        assert!(matches!(
            welch_psd(&x, &c),
            Err(SignalError::InvalidParameter { name: "fs", .. })
        ));
        let mut c = cfg.clone();
        c.segment_len = 1;
        assert!(matches!(
            welch_psd(&x, &c),
            Err(SignalError::TooShort { .. })
        ));
    }

    #[test]
    fn loglog_interpolation_is_exact_on_power_laws() {
        let f: Vec<f64> = (1..=20).map(|k| k as f64 * 0.01).collect();
        let s: Vec<f64> = f.iter().map(|f| 3e-24 * f.powf(-1.7)).collect();
        let t = [0.01, 0.015, 0.0333, 0.1999, 0.2];
        let v = interp_loglog(&f, &s, &t).unwrap();
        for (ti, vi) in t.iter().zip(&v) {
            assert!((vi / (3e-24 * ti.powf(-1.7)) - 1.0).abs() < 1e-12, "f={ti}");
        }
        // A zero endpoint falls back to linear on that interval only.
        let v = interp_loglog(&[1.0, 2.0, 4.0], &[0.0, 2.0, 8.0], &[1.5, 2.0, 3.0]).unwrap();
        assert!((v[0] - 1.0).abs() < 1e-15);
        assert_eq!(v[1], 2.0);
        assert!((v[2] - 2.0 * 1.5f64.powi(2)).abs() < 1e-12);
        assert!(matches!(
            interp_loglog(&f, &s, &[0.005]),
            Err(SignalError::OutOfRange { .. })
        ));
        assert!(matches!(
            interp_loglog(&f, &s, &[f64::NAN]),
            Err(SignalError::OutOfRange { .. })
        ));
        assert!(matches!(
            interp_loglog(&[1.0, 1.0], &[1.0, 1.0], &[1.0]),
            Err(SignalError::UnsortedGrid { index: 1, .. })
        ));
        assert!(matches!(
            interp_loglog(&[0.0, 1.0], &[1.0, 1.0], &[0.5]),
            Err(SignalError::InvalidParameter {
                name: "freqs[0]",
                ..
            })
        ));
        assert!(matches!(
            interp_loglog(&[1.0, 2.0], &[1.0, -1.0], &[1.5]),
            Err(SignalError::NegativePsd { freq: 2.0, .. })
        ));
        assert!(matches!(
            interp_loglog(&[1.0, 2.0], &[1.0], &[1.5]),
            Err(SignalError::LengthMismatch { .. })
        ));
    }

    #[test]
    fn complex_interpolation_is_exact_on_lines() {
        let f = [0.5, 1.0, 3.0];
        let line = |x: f64| Complex64::new(2.0 * x - 1.0, -0.5 * x + 4.0);
        let vals: Vec<Complex64> = f.iter().map(|&x| line(x)).collect();
        let t = [0.5, 0.75, 2.2, 3.0];
        for (ti, v) in t.iter().zip(interp_linear_complex(&f, &vals, &t).unwrap()) {
            assert!((v - line(*ti)).norm() < 1e-14);
        }
        assert!(matches!(
            interp_linear_complex(&f, &vals, &[3.5]),
            Err(SignalError::OutOfRange { freq: 3.5, .. })
        ));
    }

    #[test]
    fn spectrum_interpolation_skips_dc_and_nyquist() {
        let (fs, l) = (8.0, 64usize);
        let x = white(4096, 1.0, 9);
        let cfg = WelchConfig::new(fs, Window::Hann, l);
        let s = welch_psd(&x, &cfg).unwrap();
        let df = fs / l as f64;
        let v = s.interpolate(&[df, 2.5 * df, fs / 2.0 - df]).unwrap();
        assert_eq!(v[0], s.psd[1]);
        assert_eq!(v[2], s.psd[l / 2 - 1]);
        let geo = (s.psd[2] * s.psd[3]).sqrt();
        // Midpoint in ln f between f_2 and f_3 is not 2.5 df, so compare with the formula.
        let u = (2.5f64 / 2.0).ln() / (1.5f64).ln();
        let want = s.psd[2] * (s.psd[3] / s.psd[2]).powf(u);
        assert!((v[1] - want).abs() < 1e-12 * geo);
        assert!(matches!(
            s.interpolate(&[fs / 2.0]),
            Err(SignalError::OutOfRange { .. })
        ));
        assert!(matches!(
            s.interpolate(&[0.5 * df]),
            Err(SignalError::OutOfRange { .. })
        ));
        let c = welch_csd(&x, &x, &cfg).unwrap();
        assert!(c.interpolate(&[0.0]).is_err());
        assert!((c.interpolate(&[df]).unwrap()[0].re - s.psd[1]).abs() < 1e-12 * s.psd[1]);
    }

    #[test]
    fn matrix_interpolation_keeps_coherence_at_most_one() {
        // Fully coherent channels whose levels change fast between two bins: interpolating
        // S12 linearly next to log-log diagonals would give |S12|² > S11 S22 (AM ≥ GM).
        let zero = Complex64::new(0.0, 0.0);
        let s11: Vec<f64> = vec![0.0, 1.0, 100.0, 1.0];
        let s22: Vec<f64> = vec![0.0, 4.0, 1.0, 4.0];
        let phase = [0.0, 0.3, 2.0, 1.0];
        let s12: Vec<Complex64> = (0..4)
            .map(|k| Complex64::from_polar((s11[k] * s22[k]).sqrt(), phase[k]))
            .collect();
        let spec = Spectrum2 {
            freqs: vec![0.0, 1.0, 2.0, 3.0],
            s11,
            s12,
            s22,
            fs: 7.0,
            segment_len: 7,
            n_avg: 1,
            n_eff: 1.0,
        };
        let t: Vec<f64> = (0..=20).map(|i| 1.0 + 0.1 * i as f64).collect();
        let out = spec.interpolate(&t).unwrap();
        let mut naive_violates = false;
        for (i, &ti) in t.iter().enumerate() {
            let bound = out.s11[i] * out.s22[i];
            assert!(out.s12[i].norm_sqr() <= bound * (1.0 + 1e-12), "f={ti}");
            let naive = interp_linear_complex(&spec.freqs[1..], &spec.s12[1..], &[ti]).unwrap()[0];
            naive_violates |= naive.norm_sqr() > bound * (1.0 + 1e-6);
            let m = out.matrix(i);
            assert_eq!(m[1][0], m[0][1].conj());
        }
        assert!(
            naive_violates,
            "the case must be one where plain linear interpolation fails"
        );
        // Nodes are reproduced exactly.
        assert!((out.s12[10] - spec.s12[2]).norm() < 1e-12 * 10.0);
        assert_ne!(out.s12[5], zero);
    }
}
