//! Gaussian noise with an exactly prescribed one-sided (cross-)spectral density
//! (ltp-model.md §5, "Synthesis recipe").
//!
//! On a grid of `G` samples (`G = N` for [`SynthMode::Circular`]) the one-sided spectrum is
//! drawn bin by bin and inverse transformed:
//!
//! * regular bins `0 < k < G/2`: `Y_k = √(G fs/2) · L(f_k) w_k`, with `L Lᴴ = S(f_k)` the
//!   Cholesky factor and `w_k ~ CN(0, I)` (independent real and imaginary parts of variance
//!   1/2), so `E[Y_k Y_kᴴ] = (G fs/2) S(f_k)`;
//! * DC: `Y_0 = 0` (the noise has zero mean);
//! * Nyquist (even `G`): a real series has a real `Y_{G/2} = Σ_n y[n](−1)ⁿ`. For a stationary
//!   real process with one-sided `S` (two-sided `S/2`), `E[Y_k Y_kᴴ] = G fs · S(f_k)/2` holds
//!   for *every* bin, the Nyquist bin included, so `Y_{G/2} = √(G fs/2) · L_R w` with
//!   `L_R L_Rᴴ = Re S(fs/2)` and `w ~ N(0, I)` real. (`Re S` is what a real process can have
//!   there: its CSD satisfies `S(−f) = S(f)*` and `−fs/2 ≡ fs/2`.) With this choice the series
//!   variance is exactly `(1/G²) Σ_k E|Y_k|²`, Parseval over all bins, and a white `S = 2σ²/fs`
//!   gives `E[y²] = σ² (1 − 1/G)` (the missing `1/G` is the zeroed DC bin).
//!
//! The output is then circular: its rectangular-window DFT has exactly the CSD the likelihood
//! assumes (§8.2). [`SynthMode::Realistic`] draws on a longer grid and keeps the middle `N`
//! samples, which is no longer periodic and leaks like real data.

use num_complex::Complex64;
use rand::Rng;
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};

use super::fft::RealFft;
use super::{SignalError, check_fs};

/// How the synthesis grid relates to the output series.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SynthMode {
    /// Draw on the output's own grid: periodic noise whose DFT has exactly the prescribed CSD.
    /// The default, and what every known-answer test uses.
    #[default]
    Circular,
    /// Draw on an `oversample × N` grid (`oversample ≥ 2`) and keep the middle `N` samples:
    /// not periodic, so a rectangular-window DFT leaks as it would on real data.
    Realistic {
        /// Grid length over output length.
        oversample: usize,
    },
}

/// Relative tolerance for the Hermitian checks (imaginary diagonal, `S21 − S12*`), in units of
/// the trace: generous against rounding in a caller's `H S Hᴴ`, tiny against real mistakes.
const HERMITIAN_RTOL: f64 = 1e-10;
/// Tolerance on `det S ≥ 0`, in units of trace²: a rank-one `v vᴴ` computes to a determinant of
/// a few ε·trace², so 1e-12 accepts it while rejecting any coherence above 1 + 1e-12.
const PSD_RTOL: f64 = 1e-12;

/// Two-channel Gaussian noise of `n` samples at `fs` Hz whose one-sided 2×2 CSD is `csd(f)`
/// (`S12 = E[Y1 Y2*]`-convention, see the module docs of [`crate::signal`]).
///
/// `csd` is evaluated on the synthesis grid `k fs/G`, `0 < k ≤ G/2`, and must be finite,
/// Hermitian and positive semi-definite there (rank-deficient and zero matrices are fine: a
/// zero channel comes out exactly zero); the first offending frequency is reported. The same
/// RNG state gives the same series.
///
/// # Example
/// ```
/// use num_complex::Complex64;
/// use occam::signal::{SynthMode, WelchConfig, Window, synth_two_channel, welch_csd2};
/// use rand::SeedableRng;
/// use rand_xoshiro::Xoshiro256PlusPlus;
///
/// // Channel 2 = channel 1 delayed by 0.25 s plus independent noise of equal level.
/// let (fs, s0, tau) = (10.0, 2e-20, 0.25);
/// let csd = |f: f64| {
///     let d = Complex64::from_polar(1.0, 2.0 * std::f64::consts::PI * f * tau); // E[Y1 Y2*]
///     let s12 = d * s0;
///     [[Complex64::new(s0, 0.0), s12], [s12.conj(), Complex64::new(2.0 * s0, 0.0)]]
/// };
/// let mut rng = Xoshiro256PlusPlus::seed_from_u64(7);
/// let [y1, y2] = synth_two_channel(1 << 16, fs, csd, &mut rng, SynthMode::Circular).unwrap();
/// let est = welch_csd2(&y1, &y2, &WelchConfig::new(fs, Window::Hann, 256)).unwrap();
/// let k = 40; // 1.5625 Hz
/// let rel = (est.s12[k] - csd(est.freqs[k])[0][1]).norm() / s0;
/// assert!(rel < 0.25); // about 5 standard errors of one bin with ~480 averages
/// ```
pub fn synth_two_channel<R: Rng + ?Sized>(
    n: usize,
    fs: f64,
    csd: impl Fn(f64) -> [[Complex64; 2]; 2],
    rng: &mut R,
    mode: SynthMode,
) -> Result<[Vec<f64>; 2], SignalError> {
    synthesize::<2, R>(n, fs, mode, rng, |f, nyquist, rng| {
        let s = csd(f);
        let (l11, l21, l22) = cholesky2(f, s, nyquist)?;
        let (w1, w2) = if nyquist {
            (real_normal(rng), real_normal(rng))
        } else {
            (complex_normal(rng), complex_normal(rng))
        };
        Ok([w1 * l11, l21 * w1 + w2 * l22])
    })
}

/// One-channel Gaussian noise of `n` samples at `fs` Hz with one-sided PSD `psd(f)`
/// (finite and ≥ 0 on the synthesis grid), by the same recipe as [`synth_two_channel`].
///
/// # Example
/// ```
/// use occam::signal::{SynthMode, synth_one_channel};
/// use rand::SeedableRng;
/// use rand_xoshiro::Xoshiro256PlusPlus;
///
/// // White noise of one-sided level 2σ²/fs has variance σ²(1 − 1/N).
/// let (fs, sigma) = (10.0, 3e-9);
/// let mut rng = Xoshiro256PlusPlus::seed_from_u64(1);
/// let y = synth_one_channel(1 << 14, fs, |_| 2.0 * sigma * sigma / fs, &mut rng, SynthMode::Circular)
///     .unwrap();
/// let var = y.iter().map(|v| v * v).sum::<f64>() / y.len() as f64;
/// assert!((var / (sigma * sigma) - 1.0).abs() < 0.05); // std error √(2/N) ≈ 0.011
/// ```
pub fn synth_one_channel<R: Rng + ?Sized>(
    n: usize,
    fs: f64,
    psd: impl Fn(f64) -> f64,
    rng: &mut R,
    mode: SynthMode,
) -> Result<Vec<f64>, SignalError> {
    let [y] = synthesize::<1, R>(n, fs, mode, rng, |f, nyquist, rng| {
        let s = psd(f);
        if !s.is_finite() || s < 0.0 {
            return Err(SignalError::InvalidCsd {
                freq: f,
                reason: format!("the PSD must be finite and >= 0, got {s}"),
            });
        }
        let w = if nyquist {
            real_normal(rng)
        } else {
            complex_normal(rng)
        };
        Ok([w * s.sqrt()])
    })?;
    Ok(y)
}

/// Shared recipe: validates sizes, fills the one-sided spectra with `bin(f, is_nyquist, rng)`
/// scaled by `√(G fs/2)`, inverse transforms and crops.
fn synthesize<const C: usize, R: Rng + ?Sized>(
    n: usize,
    fs: f64,
    mode: SynthMode,
    rng: &mut R,
    mut bin: impl FnMut(f64, bool, &mut R) -> Result<[Complex64; C], SignalError>,
) -> Result<[Vec<f64>; C], SignalError> {
    check_fs(fs)?;
    if n < 2 {
        return Err(SignalError::TooShort {
            what: "n (samples to synthesise)",
            min: 2,
            got: n,
        });
    }
    let grid = match mode {
        SynthMode::Circular => n,
        SynthMode::Realistic { oversample } => {
            if oversample < 2 {
                return Err(SignalError::InvalidParameter {
                    name: "oversample",
                    value: oversample as f64,
                    requirement: "must be >= 2 (oversample 1 is SynthMode::Circular)",
                });
            }
            n.checked_mul(oversample)
                .ok_or(SignalError::InvalidParameter {
                    name: "oversample",
                    value: oversample as f64,
                    requirement: "oversample × n overflows; lower it",
                })?
        }
    };
    let nb = grid / 2 + 1;
    let amp = (grid as f64 * fs / 2.0).sqrt();
    let zero = Complex64::new(0.0, 0.0);
    let mut spectra: [Vec<Complex64>; C] = std::array::from_fn(|_| vec![zero; nb]);
    for k in 1..nb {
        let nyquist = 2 * k == grid;
        let f = k as f64 * fs / grid as f64;
        let z = bin(f, nyquist, rng)?;
        for (spec, zc) in spectra.iter_mut().zip(z) {
            spec[k] = zc * amp;
        }
    }
    let mut fft = RealFft::new(grid)?;
    let start = (grid - n) / 2;
    let mut full = vec![0.0; grid];
    let mut out: [Vec<f64>; C] = std::array::from_fn(|_| Vec::new());
    for (spec, y) in spectra.iter().zip(out.iter_mut()) {
        fft.inverse(spec, &mut full)?;
        *y = full[start..start + n].to_vec();
    }
    Ok(out)
}

/// `CN(0, 1)`: real and imaginary parts independent `N(0, 1/2)`.
fn complex_normal<R: Rng + ?Sized>(rng: &mut R) -> Complex64 {
    let re: f64 = StandardNormal.sample(rng);
    let im: f64 = StandardNormal.sample(rng);
    Complex64::new(re, im) * std::f64::consts::FRAC_1_SQRT_2
}

/// `N(0, 1)` as a complex number with zero imaginary part (for the Nyquist bin).
fn real_normal<R: Rng + ?Sized>(rng: &mut R) -> Complex64 {
    Complex64::new(StandardNormal.sample(rng), 0.0)
}

/// Validates `s` as a one-sided CSD at `f` and returns its lower Cholesky factor
/// `[[l11, 0], [l21, l22]]` with `l11, l22 ≥ 0`. At the Nyquist bin the factor is that of
/// `Re S` (see the module docs). Rank-deficient matrices get `l22 = 0` (or `l11 = 0`), never
/// a NaN.
fn cholesky2(
    f: f64,
    s: [[Complex64; 2]; 2],
    nyquist: bool,
) -> Result<(f64, Complex64, f64), SignalError> {
    let bad = |reason: String| SignalError::InvalidCsd { freq: f, reason };
    if s.iter().flatten().any(|c| !(c.re.is_finite() && c.im.is_finite())) {
        return Err(bad(format!("non-finite entry in {s:?}")));
    }
    let scale = s[0][0].re.abs() + s[1][1].re.abs();
    let tol = HERMITIAN_RTOL * scale;
    if s[0][0].im.abs() > tol || s[1][1].im.abs() > tol {
        return Err(bad(format!(
            "diagonal must be real, got S11 = {}, S22 = {}",
            s[0][0], s[1][1]
        )));
    }
    if (s[1][0] - s[0][1].conj()).norm() > tol {
        return Err(bad(format!(
            "not Hermitian: S21 = {} but S12* = {}",
            s[1][0],
            s[0][1].conj()
        )));
    }
    let (s11, s22) = (s[0][0].re, s[1][1].re);
    if s11 < -tol || s22 < -tol {
        return Err(bad(format!("negative PSD on the diagonal: S11 = {s11}, S22 = {s22}")));
    }
    let (s11, s22) = (s11.max(0.0), s22.max(0.0));
    let mut s12 = (s[0][1] + s[1][0].conj()) * 0.5;
    if nyquist {
        s12.im = 0.0;
    }
    if s12.norm_sqr() - s11 * s22 > PSD_RTOL * scale * scale {
        return Err(bad(format!(
            "not positive semi-definite: |S12|² = {} > S11·S22 = {}",
            s12.norm_sqr(),
            s11 * s22
        )));
    }
    // Within tolerance a coherence slightly above 1 is rounding: pull it back to exactly 1 so
    // the factor below cannot amplify it (|l21|² = |S12|²/S11 would blow up for tiny S11).
    let cap = (s11 * s22).sqrt();
    if s12.norm() > cap {
        s12 = if cap > 0.0 {
            s12 * (cap / s12.norm())
        } else {
            Complex64::new(0.0, 0.0)
        };
    }
    if s11 > 0.0 {
        let l11 = s11.sqrt();
        let l21 = s12.conj() / l11;
        let l22 = (s22 - l21.norm_sqr()).max(0.0).sqrt();
        Ok((l11, l21, l22))
    } else {
        Ok((0.0, Complex64::new(0.0, 0.0), s22.sqrt()))
    }
}
