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
//! * [`multires`]: Welch with a segment length per band (longer segments where the band's
//!   bottom needs the resolution).
//! * [`glitch_gate`]: whitening against a noise PSD and gating of the samples that exceed a
//!   threshold (`[analysis] glitches = "gate"`).
//! * [`prediction`]: linear prediction (Burg) of a series through its gaps.
//! * [`synth`]: Gaussian noise with an exactly prescribed one- or two-channel spectrum.

mod error;
pub mod fft;
pub mod glitch_gate;
pub mod multires;
pub mod prediction;
pub mod synth;
pub mod welch;
pub mod window;

pub use error::SignalError;
pub use fft::{RealFft, dft_naive, rfft_freqs};
pub use multires::{MultiresConfig, MultiresCsd2, multires_csd2};
pub use synth::{SynthMode, synth_channels, synth_one_channel, synth_two_channel};
pub use welch::{
    CrossSpectrum, Csd2, Detrend, Spectrum, Spectrum2, WelchConfig, interp_linear_complex,
    interp_loglog, welch_csd, welch_csd2, welch_csd2_runs, welch_psd,
};
pub use window::Window;
