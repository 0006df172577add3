//! Signal processing: real FFTs, spectral windows, Welch spectra and coloured-noise synthesis.
//!
//! # Conventions (stated once, used by every submodule)
//!
//! * **Units.** SI throughout. A series `y[n]` sampled at `fs` (Hz) in units `u` has PSDs in
//!   `u²/Hz`.
//! * **DFT.** `Y[k] = Σ_{n=0}^{N−1} y[n] e^{−2πikn/N}`, unnormalised; the inverse carries the
//!   `1/N`: `y[n] = (1/N) Σ_k Y[k] e^{+2πikn/N}`. Only the non-negative half `k = 0 … ⌊N/2⌋`
//!   of a real series is stored (`N/2 + 1` bins).
//! * **Frequencies.** `f_k = k fs / N`, so the resolution is `Δf = fs / N`.
//! * **Bins.** For even `N` bin `N/2` is the Nyquist bin. The *regular* bins are
//!   `0 < k < N/2`; the DC bin and the Nyquist bin are real for a real series.
//! * **Spectra are one-sided.** A stationary real process with one-sided PSD `S(f)` has, for
//!   every regular bin of a length-`N` (rectangular-window) DFT, `E|Y_k|² ≈ (N fs/2) S(f_k)`,
//!   exactly so for the circular noise of [`synth`] (ltp-model.md §8.2).
//! * **Cross spectra.** The 2×2 matrix of two channels is `S = (scale) E[Y Yᴴ]`, so
//!   `S12 = (scale) E[Y1 Y2*]` and `S21 = S12*`. This is the convention of the likelihood
//!   (ltp-model.md §8.2: quadratic form `S22|R1|² + S11|R2|² − 2 Re(S12 R1* R2)`). The
//!   two-series function [`welch::welch_csd`]`(x, y)` follows SciPy/MATLAB instead,
//!   `S_xy ∝ E[X* Y]`, hence the matrix element is `S12 = S_{y2 y1} = (S_{y1 y2})*`.
//!
//! # Submodules
//!
//! * [`fft`]: a planned real FFT with the conventions above, and a slow DFT oracle.
//! * [`window`]: rectangular, Hann and Blackman–Harris 92 dB windows.
//! * [`welch`]: one-sided Welch PSD/CSD estimates and their interpolation.
//! * [`synth`]: Gaussian noise with an exactly prescribed one- or two-channel spectrum.

pub mod fft;
pub mod synth;
pub mod welch;
pub mod window;

pub use fft::{RealFft, dft_naive, rfft_freqs};
pub use synth::{SynthMode, synth_one_channel, synth_two_channel};
pub use welch::{
    CrossSpectrum, Csd2, Detrend, Spectrum, Spectrum2, WelchConfig, interp_linear_complex,
    interp_loglog, welch_csd, welch_csd2, welch_psd,
};
pub use window::Window;

/// Errors of the signal-processing module. Each names the offending input and how to fix it.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SignalError {
    /// A transform length of zero was requested.
    #[error("{what}: length must be at least {min}, got {got}")]
    TooShort {
        /// Which length (e.g. "FFT length", "segment_len").
        what: &'static str,
        /// Smallest accepted value.
        min: usize,
        /// The value given.
        got: usize,
    },
    /// A buffer handed to a planned transform has the wrong length.
    #[error("{what}: buffer has length {got}, expected {expected} for this plan")]
    BufferLength {
        /// Which buffer (e.g. "forward input").
        what: &'static str,
        /// Length required by the plan.
        expected: usize,
        /// Length given.
        got: usize,
    },
    /// Two series that must have the same length do not.
    #[error("series lengths differ: {first} has {len_first} samples, {second} has {len_second}")]
    LengthMismatch {
        /// Name of the first series.
        first: &'static str,
        /// Its length.
        len_first: usize,
        /// Name of the second series.
        second: &'static str,
        /// Its length.
        len_second: usize,
    },
    /// A sample or spectrum value is NaN or infinite.
    #[error("{what}[{index}] is not finite ({value}); remove NaN/inf samples before analysis")]
    NonFinite {
        /// Which array.
        what: &'static str,
        /// Index of the first bad value.
        index: usize,
        /// The value.
        value: f64,
    },
    /// A scalar parameter is outside its valid range.
    #[error("{name} = {value} is invalid: {requirement}")]
    InvalidParameter {
        /// Parameter name (e.g. "fs", "overlap").
        name: &'static str,
        /// The value given.
        value: f64,
        /// What it must satisfy.
        requirement: &'static str,
    },
    /// The Welch segment is longer than the data.
    #[error(
        "segment_len = {segment_len} exceeds the series length {len}; use a shorter segment or more data"
    )]
    SegmentTooLong {
        /// Requested segment length.
        segment_len: usize,
        /// Series length.
        len: usize,
    },
    /// A window name could not be parsed.
    #[error("unknown window {name:?}; expected one of \"rectangular\", \"hann\", \"bh92\"")]
    UnknownWindow {
        /// The name given.
        name: String,
    },
    /// A prescribed cross-spectral matrix is not a valid one-sided CSD at some frequency.
    #[error("CSD at f = {freq} Hz is invalid: {reason}")]
    InvalidCsd {
        /// Frequency (Hz) of the offending bin.
        freq: f64,
        /// What is wrong (non-finite, not Hermitian, not positive semi-definite).
        reason: String,
    },
    /// An interpolation grid is not strictly increasing.
    #[error(
        "interpolation grid: frequencies must be strictly increasing, but f[{index}] = {value}"
    )]
    UnsortedGrid {
        /// Index of the first out-of-order frequency.
        index: usize,
        /// Its value.
        value: f64,
    },
    /// An interpolation target lies outside the tabulated range (no extrapolation is done).
    #[error(
        "cannot interpolate at f = {freq} Hz: outside the usable range [{min}, {max}] Hz \
         (longer Welch segments lower the bottom end)"
    )]
    OutOfRange {
        /// The requested frequency.
        freq: f64,
        /// Lowest usable frequency.
        min: f64,
        /// Highest usable frequency.
        max: f64,
    },
    /// A PSD value that must be non-negative is negative.
    #[error("{what} at f = {freq} Hz is negative ({value}); a PSD must be >= 0")]
    NegativePsd {
        /// Which spectrum.
        what: &'static str,
        /// Frequency of the bad value.
        freq: f64,
        /// The value.
        value: f64,
    },
}

/// Checks that every value is finite; names the array and the first bad index otherwise.
pub(crate) fn check_finite(what: &'static str, x: &[f64]) -> Result<(), SignalError> {
    match x.iter().position(|v| !v.is_finite()) {
        Some(index) => Err(SignalError::NonFinite {
            what,
            index,
            value: x[index],
        }),
        None => Ok(()),
    }
}

/// Checks that a sampling frequency is finite and positive.
pub(crate) fn check_fs(fs: f64) -> Result<(), SignalError> {
    if fs.is_finite() && fs > 0.0 {
        Ok(())
    } else {
        Err(SignalError::InvalidParameter {
            name: "fs",
            value: fs,
            requirement: "the sampling frequency must be finite and > 0 Hz",
        })
    }
}
