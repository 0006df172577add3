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

use super::error::{SignalError, check_fs};
use super::fft::RealFft;

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
    synthesize_array::<2, R>(n, fs, mode, rng, |f, nyquist, rng| {
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
    let [y] = synthesize_array::<1, R>(n, fs, mode, rng, |f, nyquist, rng| {
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

/// Gaussian noise in `nr` channels (`nr ≥ 1`) of `n` samples at `fs` Hz whose one-sided
/// `nr × nr` CSD is `csd(f, out)` (row-major into `out`; `S_ij = E[Y_i Y_j*]`), by the recipe
/// of [`synth_two_channel`]. `csd` must be Hermitian positive semi-definite on the synthesis
/// grid: a channel fully explained by the others is fine (it is drawn from them), a negative
/// direction is an error naming the frequency and the channel.
///
/// # Example
/// ```
/// use num_complex::Complex64;
/// use occam::signal::{SynthMode, synth_channels};
/// use rand::SeedableRng;
/// use rand_xoshiro::Xoshiro256PlusPlus;
///
/// // three white channels of levels 1, 2, 3 (one-sided, per Hz), uncorrelated
/// let mut rng = Xoshiro256PlusPlus::seed_from_u64(3);
/// let csd = |_f: f64, s: &mut [Complex64]| {
///     s.fill(Complex64::new(0.0, 0.0));
///     for j in 0..3 {
///         s[4 * j] = Complex64::new(1.0 + j as f64, 0.0);
///     }
/// };
/// let y = synth_channels(1 << 14, 2.0, 3, csd, &mut rng, SynthMode::Circular).unwrap();
/// // variance = S fs/2 for a white one-sided S
/// let var = y[2].iter().map(|v| v * v).sum::<f64>() / y[2].len() as f64;
/// assert!((var / 3.0 - 1.0).abs() < 0.05);
/// ```
pub fn synth_channels<R: Rng + ?Sized>(
    n: usize,
    fs: f64,
    nr: usize,
    mut csd: impl FnMut(f64, &mut [Complex64]),
    rng: &mut R,
    mode: SynthMode,
) -> Result<Vec<Vec<f64>>, SignalError> {
    if nr == 0 {
        return Err(SignalError::InvalidParameter {
            name: "nr",
            value: 0.0,
            requirement: "at least one channel",
        });
    }
    let zero = Complex64::new(0.0, 0.0);
    let (mut s, mut l) = (vec![zero; nr * nr], vec![zero; nr * nr]);
    synthesize(n, fs, mode, rng, nr, |f, nyquist, rng, out| {
        csd(f, &mut s);
        let bad = |reason: String| SignalError::InvalidCsd { freq: f, reason };
        if let Some(v) = s.iter().find(|c| !(c.re.is_finite() && c.im.is_finite())) {
            return Err(bad(format!("non-finite entry {v}")));
        }
        if nyquist {
            // a real series has a real Nyquist bin: only Re S is reachable there
            for v in s.iter_mut() {
                v.im = 0.0;
            }
        }
        let scale: f64 = (0..nr).map(|j| s[j * nr + j].re.abs()).sum();
        for i in 0..nr {
            for j in 0..=i {
                if (s[i * nr + j] - s[j * nr + i].conj()).norm() > HERMITIAN_RTOL * scale {
                    return Err(bad(format!(
                        "not Hermitian: S[{i}][{j}] = {} but S[{j}][{i}]* = {}",
                        s[i * nr + j],
                        s[j * nr + i].conj()
                    )));
                }
            }
        }
        cholesky_psd(&s, nr, PSD_RTOL, &mut l).map_err(|(row, pivot, diag)| {
            bad(format!(
                "not positive semi-definite: channel {row} has a pivot of {pivot:e} (diagonal {diag:e})"
            ))
        })?;
        for i in 0..nr {
            let w = if nyquist {
                real_normal(rng)
            } else {
                complex_normal(rng)
            };
            // column i of L times an independent draw
            for r in i..nr {
                out[r] += l[r * nr + i] * w;
            }
        }
        Ok(())
    })
}

/// A lower-triangular `L` (row-major `R×R`, written into `l`) with `L Lᴴ = C` for a Hermitian
/// positive *semi*-definite `C` (only the lower triangle is read): what a noise synthesiser
/// needs, where a channel fully explained by the others (a pivot within `rel_tol` of zero
/// relative to its own diagonal, so channels of very different scales are judged each on its
/// own) is legitimate and gets a zero column. A pivot below `−rel_tol` times its diagonal, or
/// a non-finite one, means `C` is not positive semi-definite: the error is `(row, pivot,
/// diagonal)`.
///
/// # Formula
/// The Cholesky–Banachiewicz recursion (`crate::hermitian::whitener`'s `L`), with `L_ij = 0` below a zero pivot `j`.
fn cholesky_psd(
    c: &[Complex64],
    nr: usize,
    rel_tol: f64,
    l: &mut [Complex64],
) -> Result<(), (usize, f64, f64)> {
    assert!(c.len() == nr * nr && l.len() == nr * nr);
    l.fill(Complex64::new(0.0, 0.0));
    for j in 0..nr {
        let diag = c[j * nr + j].re;
        let pivot = diag - (0..j).map(|k| l[j * nr + k].norm_sqr()).sum::<f64>();
        if !pivot.is_finite() || pivot < -rel_tol * diag.abs() {
            return Err((j, pivot, diag));
        }
        if pivot <= rel_tol * diag.abs() {
            continue;
        }
        let ljj = pivot.sqrt();
        l[j * nr + j] = Complex64::new(ljj, 0.0);
        for i in j + 1..nr {
            let mut s = c[i * nr + j];
            for k in 0..j {
                s -= l[i * nr + k] * l[j * nr + k].conj();
            }
            l[i * nr + j] = s / ljj;
        }
    }
    Ok(())
}

/// Shared recipe: validates sizes, fills the one-sided spectra of `nc` channels with
/// `bin(f, is_nyquist, rng, out)` (which adds into the zeroed `out`), scales by `√(G fs/2)`,
/// inverse transforms and crops.
fn synthesize<R: Rng + ?Sized>(
    n: usize,
    fs: f64,
    mode: SynthMode,
    rng: &mut R,
    nc: usize,
    mut bin: impl FnMut(f64, bool, &mut R, &mut [Complex64]) -> Result<(), SignalError>,
) -> Result<Vec<Vec<f64>>, SignalError> {
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
    let mut spectra: Vec<Vec<Complex64>> = vec![vec![zero; nb]; nc];
    let mut z = vec![zero; nc];
    for k in 1..nb {
        let nyquist = 2 * k == grid;
        let f = k as f64 * fs / grid as f64;
        z.fill(zero);
        bin(f, nyquist, rng, &mut z)?;
        for (spec, zc) in spectra.iter_mut().zip(&z) {
            spec[k] = zc * amp;
        }
    }
    let mut fft = RealFft::new(grid)?;
    let start = (grid - n) / 2;
    let mut full = vec![0.0; grid];
    let mut out = Vec::with_capacity(nc);
    for spec in &spectra {
        fft.inverse(spec, &mut full)?;
        out.push(full[start..start + n].to_vec());
    }
    Ok(out)
}

/// [`synthesize`] for a fixed number of channels, as an array.
fn synthesize_array<const C: usize, R: Rng + ?Sized>(
    n: usize,
    fs: f64,
    mode: SynthMode,
    rng: &mut R,
    mut bin: impl FnMut(f64, bool, &mut R) -> Result<[Complex64; C], SignalError>,
) -> Result<[Vec<f64>; C], SignalError> {
    let out = synthesize(n, fs, mode, rng, C, |f, nyquist, rng, out| {
        out.copy_from_slice(&bin(f, nyquist, rng)?);
        Ok(())
    })?;
    Ok(out.try_into().expect("C channels"))
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
    if s.iter()
        .flatten()
        .any(|c| !(c.re.is_finite() && c.im.is_finite()))
    {
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
        return Err(bad(format!(
            "negative PSD on the diagonal: S11 = {s11}, S22 = {s22}"
        )));
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
        // A rank-one S leaves a residual of a few ε·S22 from rounding; its square root would be
        // a spurious independent component of relative size √ε ≈ 1e−8, so treat it as zero.
        let resid = s22 - l21.norm_sqr();
        let l22 = if resid > 8.0 * f64::EPSILON * s22 {
            resid.sqrt()
        } else {
            0.0
        };
        Ok((l11, l21, l22))
    } else {
        Ok((0.0, Complex64::new(0.0, 0.0), s22.sqrt()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `L Lᴴ` of a row-major lower-triangular `L`.
    fn product(l: &[Complex64], nr: usize) -> Vec<Complex64> {
        let mut c = vec![Complex64::new(0.0, 0.0); nr * nr];
        for i in 0..nr {
            for j in 0..nr {
                c[i * nr + j] = (0..nr).map(|k| l[i * nr + k] * l[j * nr + k].conj()).sum();
            }
        }
        c
    }

    #[test]
    fn n_channel_synthesis_equals_the_two_channel_recipe() {
        use rand::SeedableRng;
        let c = |a, b| Complex64::new(a, b);
        let csd = |f: f64| {
            let s12 = c(0.3 * f, -0.2) * 1e-20;
            [
                [c(2e-20, 0.0), s12],
                [s12.conj(), c(1e-20 * (1.0 + f), 0.0)],
            ]
        };
        for mode in [SynthMode::Circular, SynthMode::Realistic { oversample: 2 }] {
            let mut r1 = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(11);
            let mut r2 = r1.clone();
            let two = synth_two_channel(1000, 4.0, csd, &mut r1, mode).unwrap();
            let n = synth_channels(
                1000,
                4.0,
                2,
                |f, s| {
                    let m = csd(f);
                    s.copy_from_slice(&[m[0][0], m[0][1], m[1][0], m[1][1]]);
                },
                &mut r2,
                mode,
            )
            .unwrap();
            let scale = two[0].iter().map(|v| v.abs()).fold(0.0, f64::max);
            for ch in 0..2 {
                for (a, b) in two[ch].iter().zip(&n[ch]) {
                    assert!((a - b).abs() <= 1e-12 * scale, "{a} vs {b}");
                }
            }
        }
    }

    #[test]
    fn cholesky_psd_reproduces_full_and_rank_deficient_matrices() {
        let c = |a, b| Complex64::new(a, b);
        // rank 2 in 3 channels: channel 2 = channel 0 − i·channel 1
        let v = [[c(1.0, 0.5), c(0.0, 2.0)], [c(-0.3, 0.0), c(0.7, -0.2)]];
        let mut x = [[c(0.0, 0.0); 2]; 3];
        x[0] = v[0];
        x[1] = v[1];
        x[2] = [
            v[0][0] - c(0.0, 1.0) * v[1][0],
            v[0][1] - c(0.0, 1.0) * v[1][1],
        ];
        let mut cm = vec![c(0.0, 0.0); 9];
        for i in 0..3 {
            for j in 0..3 {
                cm[i * 3 + j] = x[i][0] * x[j][0].conj() + x[i][1] * x[j][1].conj();
            }
        }
        let mut l = vec![c(0.0, 0.0); 9];
        cholesky_psd(&cm, 3, 1e-12, &mut l).unwrap();
        assert_eq!(
            l[2 * 3 + 2],
            c(0.0, 0.0),
            "the explained channel has a zero pivot"
        );
        for (a, b) in product(&l, 3).iter().zip(&cm) {
            assert!((a - b).norm() < 1e-14, "{a} vs {b}");
        }
        // full rank: the same factor as the whitener's inverse
        cm[8] += c(0.5, 0.0);
        cholesky_psd(&cm, 3, 1e-12, &mut l).unwrap();
        for (a, b) in product(&l, 3).iter().zip(&cm) {
            assert!((a - b).norm() < 1e-14);
        }
        // not semi-definite: a negative pivot is refused and named
        cm[8] -= c(1.0, 0.0);
        let e = cholesky_psd(&cm, 3, 1e-12, &mut l).unwrap_err();
        assert_eq!(e.0, 2);
    }

    use crate::signal::fft::RealFft;
    use crate::signal::welch::{WelchConfig, welch_csd2, welch_psd};
    use crate::signal::window::Window;
    use rand::SeedableRng;
    use rand_xoshiro::Xoshiro256PlusPlus;
    use std::f64::consts::PI;

    type M2 = [[Complex64; 2]; 2];
    type BoxedCsd = Box<dyn Fn(f64) -> M2>;

    /// `S = L Lᴴ` with a frequency-dependent lower-triangular `L`: red channel 1, complex
    /// rotating cross term, coherence ≈ 0.5–0.8. Levels are LPF-like (m²/Hz).
    fn coloured(fs: f64) -> impl Fn(f64) -> M2 {
        move |f: f64| {
            let l11 = 3e-12 / (1.0 + (f / (0.05 * fs)).powi(2)).sqrt();
            let l21 = Complex64::from_polar(2e-12, 2.0 * PI * 3.0 * f / fs + 0.5);
            let l22 = 1.5e-12 * (1.0 + f / fs);
            let s11 = l11 * l11;
            let s12 = l21.conj() * l11; // (L Lᴴ)_12 = l11 · l21*
            let s22 = l21.norm_sqr() + l22 * l22;
            [
                [Complex64::new(s11, 0.0), s12],
                [s12.conj(), Complex64::new(s22, 0.0)],
            ]
        }
    }

    fn rng(seed: u64) -> Xoshiro256PlusPlus {
        Xoshiro256PlusPlus::seed_from_u64(seed)
    }

    fn dft(y: &[f64]) -> Vec<Complex64> {
        let mut fft = RealFft::new(y.len()).unwrap();
        let mut out = vec![Complex64::new(0.0, 0.0); fft.spectrum_len()];
        fft.forward(y, &mut out).unwrap();
        out
    }

    #[test]
    fn circular_dft_has_the_prescribed_csd() {
        // In Circular mode the regular bins are independent with E[Y Yᴴ] = c S, c = N fs/2.
        // Each |Y_j|²/(c S_jj) is Exp(1) (mean 1, sd 1), so the average over K bins has
        // standard error 1/√K. For the cross term u = Y1 Y2*/(c √(S11 S22)) has mean the
        // coherence γ, Var Re u = (1 + Re γ²)/2, Var Im u = (1 − Re γ²)/2 (Isserlis). Allow 4
        // standard errors.
        let (n, fs) = (8192usize, 10.0);
        let csd = coloured(fs);
        let [y1, y2] = synth_two_channel(n, fs, &csd, &mut rng(21), SynthMode::Circular).unwrap();
        let (d1, d2) = (dft(&y1), dft(&y2));
        let c = n as f64 * fs / 2.0;
        let bins = 1..n / 2;
        let k = bins.len() as f64;
        let (mut r1, mut r2, mut u, mut var_re, mut var_im) =
            (0.0, 0.0, Complex64::new(0.0, 0.0), 0.0, 0.0);
        for b in bins {
            let s = csd(b as f64 * fs / n as f64);
            let (s11, s22) = (s[0][0].re, s[1][1].re);
            r1 += d1[b].norm_sqr() / (c * s11);
            r2 += d2[b].norm_sqr() / (c * s22);
            let gamma = s[0][1] / (s11 * s22).sqrt();
            u += d1[b] * d2[b].conj() / (c * (s11 * s22).sqrt()) - gamma;
            var_re += (1.0 + (gamma * gamma).re) / 2.0;
            var_im += (1.0 - (gamma * gamma).re) / 2.0;
        }
        let tol = 4.0 / k.sqrt();
        eprintln!(
            "circular DFT: ratios {:.4} {:.4} (se {:.4}), cross {:+.2}/{:+.2} se",
            r1 / k,
            r2 / k,
            1.0 / k.sqrt(),
            u.re / var_re.sqrt(),
            u.im / var_im.sqrt()
        );
        assert!((r1 / k - 1.0).abs() < tol, "channel 1: {}", r1 / k);
        assert!((r2 / k - 1.0).abs() < tol, "channel 2: {}", r2 / k);
        assert!(
            (u.re / k).abs() < 4.0 * var_re.sqrt() / k,
            "cross re {}",
            u.re / k
        );
        assert!(
            (u.im / k).abs() < 4.0 * var_im.sqrt() / k,
            "cross im {}",
            u.im / k
        );
        // DC is exactly zero: the series sums to zero.
        assert!(d1[0].norm() < 1e-9 * d1[1].norm() && d2[0].norm() < 1e-9 * d2[1].norm());
    }

    #[test]
    fn nyquist_bin_is_real_with_the_derived_variance() {
        // E[Y_{N/2} Y_{N/2}ᵀ] = (N fs/2) Re S(fs/2): check the three entries over R independent
        // short series. Y_j²/(c S_jj) is χ²₁ (mean 1, var 2): standard error √(2/R). The
        // normalised product Y1 Y2/(c √(S11 S22)) has mean ρ = Re γ, var 1 + ρ².
        let (n, fs, reps) = (16usize, 1.0, 4000usize);
        let csd = coloured(fs);
        let s = csd(fs / 2.0);
        let (s11, s22) = (s[0][0].re, s[1][1].re);
        let rho = s[0][1].re / (s11 * s22).sqrt();
        let c = n as f64 * fs / 2.0;
        let mut g = rng(5);
        let (mut a, mut b, mut x) = (0.0, 0.0, 0.0);
        for _ in 0..reps {
            let [y1, y2] = synth_two_channel(n, fs, &csd, &mut g, SynthMode::Circular).unwrap();
            let (d1, d2) = (dft(&y1), dft(&y2));
            assert!(d1[n / 2].im.abs() < 1e-12 * d1[n / 2].norm().max(1e-30));
            a += d1[n / 2].re.powi(2) / (c * s11);
            b += d2[n / 2].re.powi(2) / (c * s22);
            x += d1[n / 2].re * d2[n / 2].re / (c * (s11 * s22).sqrt());
        }
        let r = reps as f64;
        let se = (2.0 / r).sqrt();
        eprintln!(
            "nyquist: {:.4} {:.4} (se {se:.4}); cross {:.4} vs {rho:.4}",
            a / r,
            b / r,
            x / r
        );
        assert!((a / r - 1.0).abs() < 4.0 * se, "S11 at Nyquist: {}", a / r);
        assert!((b / r - 1.0).abs() < 4.0 * se, "S22 at Nyquist: {}", b / r);
        assert!(
            (x / r - rho).abs() < 4.0 * ((1.0 + rho * rho) / r).sqrt(),
            "Re S12: {}",
            x / r
        );
    }

    /// Normalised Welch deviations (Ŝ − S)/σ over bins `band` (every third bin, which are
    /// uncorrelated for Hann: |ρ(0, Δ)| = 0 for |Δ| ≥ 3), with the single-bin standard errors
    /// of a Welch estimate with `M_eff` effective averages of a circular Gaussian DFT:
    /// σ(Ŝ11) = S11/√M_eff, σ(Ŝ22) = S22/√M_eff, σ(Re Ŝ12)² = (S11 S22 + Re S12²)/(2 M_eff),
    /// σ(Im Ŝ12)² = (S11 S22 − Re S12²)/(2 M_eff) (Isserlis; Bendat & Piersol §9.2). Returns
    /// the deviations of S11, S22, Re S12, Im S12.
    fn welch_deviations(
        y1: &[f64],
        y2: &[f64],
        fs: f64,
        l: usize,
        csd: &impl Fn(f64) -> M2,
    ) -> [Vec<f64>; 4] {
        let est = welch_csd2(y1, y2, &WelchConfig::new(fs, Window::Hann, l)).unwrap();
        let me = est.n_eff;
        let mut d: [Vec<f64>; 4] = Default::default();
        for k in (3..l / 2 - 3).step_by(3) {
            let s = csd(est.freqs[k]);
            let (s11, s22, s12) = (s[0][0].re, s[1][1].re, s[0][1]);
            let re2 = (s12 * s12).re;
            d[0].push((est.s11[k] - s11) / (s11 / me.sqrt()));
            d[1].push((est.s22[k] - s22) / (s22 / me.sqrt()));
            d[2].push((est.s12[k].re - s12.re) / ((s11 * s22 + re2) / (2.0 * me)).sqrt());
            d[3].push((est.s12[k].im - s12.im) / ((s11 * s22 - re2) / (2.0 * me)).sqrt());
        }
        d
    }

    /// χ²-style check: the K deviations have mean 0 (standard error 1/√K) and mean square 1
    /// (standard error √(2/K) for Gaussian deviations; with M_eff ≈ 480 the χ² shape adds
    /// only 12/(2 M_eff) ≈ 1 % to that variance). 4 standard errors each. Welch's leakage bias
    /// is second order in (bin width / spectral scale), ≈ 1e−3 relative here, far below the
    /// ≈ 5 % single-bin error.
    fn assert_chi2_like(d: &[Vec<f64>; 4], what: &str) {
        for (name, dev) in ["S11", "S22", "Re S12", "Im S12"].iter().zip(d) {
            let k = dev.len() as f64;
            let mean = dev.iter().sum::<f64>() / k;
            let ms = dev.iter().map(|x| x * x).sum::<f64>() / k;
            eprintln!(
                "{what} {name}: mean {mean:+.3} (se {:.3}), mean square {ms:.3} (se {:.3}), K = {k}",
                1.0 / k.sqrt(),
                (2.0 / k).sqrt()
            );
            assert!(
                mean.abs() < 4.0 / k.sqrt(),
                "{what} {name}: mean deviation {mean}"
            );
            assert!(
                (ms - 1.0).abs() < 4.0 * (2.0 / k).sqrt(),
                "{what} {name}: mean square {ms}"
            );
        }
    }

    #[test]
    fn welch_recovers_the_prescribed_two_channel_csd() {
        let (fs, l) = (10.0, 1024usize);
        let n = 1 << 18; // 511 Hann segments at 50 %, M_eff ≈ 484
        let csd = coloured(fs);
        let [y1, y2] = synth_two_channel(n, fs, &csd, &mut rng(2024), SynthMode::Circular).unwrap();
        let d = welch_deviations(&y1, &y2, fs, l, &csd);
        assert_eq!(d[0].len(), 169);
        assert_chi2_like(&d, "circular");
    }

    #[test]
    fn realistic_mode_is_the_middle_of_a_longer_circular_draw() {
        let (n, fs) = (1000usize, 4.0);
        let csd = coloured(fs);
        let real = synth_two_channel(
            n,
            fs,
            &csd,
            &mut rng(8),
            SynthMode::Realistic { oversample: 3 },
        )
        .unwrap();
        let long = synth_two_channel(3 * n, fs, &csd, &mut rng(8), SynthMode::Circular).unwrap();
        for c in 0..2 {
            assert_eq!(real[c].len(), n);
            assert_eq!(real[c][..], long[c][n..2 * n]);
        }
    }

    #[test]
    fn realistic_mode_has_the_prescribed_csd() {
        let (fs, l) = (10.0, 512usize);
        let n = 1 << 16; // 255 segments, M_eff ≈ 242
        let csd = coloured(fs);
        let [y1, y2] = synth_two_channel(
            n,
            fs,
            &csd,
            &mut rng(99),
            SynthMode::Realistic { oversample: 4 },
        )
        .unwrap();
        assert_chi2_like(&welch_deviations(&y1, &y2, fs, l, &csd), "realistic");
    }

    #[test]
    fn one_channel_matches_its_psd_and_white_variance() {
        // White one-sided level 2σ²/fs: E[y²] = σ²(1 − 1/N) exactly (DC bin zeroed); the
        // sample mean square of N samples of a circular series built from N/2 independent
        // bins has relative standard error √(2/N). 4 standard errors.
        let (n, fs, sigma) = (1usize << 15, 10.0, 2e-9);
        let y = synth_one_channel(
            n,
            fs,
            |_| 2.0 * sigma * sigma / fs,
            &mut rng(3),
            SynthMode::Circular,
        )
        .unwrap();
        let ms = y.iter().map(|v| v * v).sum::<f64>() / n as f64;
        let want = sigma * sigma * (1.0 - 1.0 / n as f64);
        eprintln!(
            "white variance ratio − 1 = {:.2e} (se {:.2e})",
            ms / want - 1.0,
            (2.0 / n as f64).sqrt()
        );
        assert!(
            (ms / want - 1.0).abs() < 4.0 * (2.0 / n as f64).sqrt(),
            "{}",
            ms / want
        );
        // Coloured: Welch PSD over a band, mean ratio within 4 standard errors √(1.94/(M_eff K))
        // (1.94 = Hann neighbour-correlation factor, see the welch tests).
        let psd = |f: f64| 1e-20 * (1.0 + (0.3 / f.max(1e-9)).powi(2));
        let y = synth_one_channel(n, fs, psd, &mut rng(4), SynthMode::Circular).unwrap();
        let est = welch_psd(&y, &WelchConfig::new(fs, Window::Hann, 256)).unwrap();
        let band = 8..120;
        let k = band.len() as f64;
        let mean = band.map(|b| est.psd[b] / psd(est.freqs[b])).sum::<f64>() / k;
        eprintln!(
            "one-channel coloured: ratio − 1 = {:.2e} (se {:.2e})",
            mean - 1.0,
            (1.94 / (est.n_eff * k)).sqrt()
        );
        assert!(
            (mean - 1.0).abs() < 4.0 * (1.94 / (est.n_eff * k)).sqrt(),
            "ratio {mean}"
        );
    }

    #[test]
    fn rank_deficient_and_zero_csds_give_no_nan() {
        let (n, fs) = (512usize, 1.0);
        // Fully coherent: y2 = −2 y1 exactly (S = v vᴴ with v = (1, −2)·a(f)).
        let rank1 = |f: f64| {
            let a2 = 1e-18 / (1.0 + f);
            [
                [Complex64::new(a2, 0.0), Complex64::new(-2.0 * a2, 0.0)],
                [
                    Complex64::new(-2.0 * a2, 0.0),
                    Complex64::new(4.0 * a2, 0.0),
                ],
            ]
        };
        let [y1, y2] = synth_two_channel(n, fs, rank1, &mut rng(1), SynthMode::Circular).unwrap();
        let scale = y1.iter().map(|v| v.abs()).fold(0.0, f64::max);
        assert!(scale > 0.0);
        for (a, b) in y1.iter().zip(&y2) {
            assert!((b + 2.0 * a).abs() < 1e-12 * scale);
        }
        // Zero channel 1 and an all-zero CSD.
        let zero1 = |_f: f64| {
            let z = Complex64::new(0.0, 0.0);
            [[z, z], [z, Complex64::new(1.0, 0.0)]]
        };
        let [y1, y2] = synth_two_channel(n, fs, zero1, &mut rng(1), SynthMode::Circular).unwrap();
        assert!(y1.iter().all(|&v| v == 0.0));
        assert!(y2.iter().all(|v| v.is_finite()) && y2.iter().any(|&v| v != 0.0));
        let z = Complex64::new(0.0, 0.0);
        let [a, b] = synth_two_channel(
            n,
            fs,
            |_| [[z, z], [z, z]],
            &mut rng(1),
            SynthMode::Circular,
        )
        .unwrap();
        assert!(a.iter().chain(&b).all(|&v| v == 0.0));
        let y = synth_one_channel(n, fs, |_| 0.0, &mut rng(1), SynthMode::Circular).unwrap();
        assert!(y.iter().all(|&v| v == 0.0));
    }

    #[test]
    fn deterministic_for_a_seed() {
        let csd = coloured(10.0);
        let a = synth_two_channel(300, 10.0, &csd, &mut rng(77), SynthMode::Circular).unwrap();
        let b = synth_two_channel(300, 10.0, &csd, &mut rng(77), SynthMode::Circular).unwrap();
        let c = synth_two_channel(300, 10.0, &csd, &mut rng(78), SynthMode::Circular).unwrap();
        assert_eq!(a, b);
        assert_ne!(a, c);
    }

    #[test]
    fn invalid_csds_report_the_frequency() {
        let (n, fs) = (64usize, 8.0);
        let one = Complex64::new(1.0, 0.0);
        let z = Complex64::new(0.0, 0.0);
        // Invalid only above 2 Hz: the first offending grid frequency is 2.125 Hz.
        let cases: Vec<(BoxedCsd, &str)> = vec![
            (
                Box::new(move |f| {
                    if f > 2.0 {
                        [[one, one * 2.0], [one * 2.0, one]]
                    } else {
                        [[one, z], [z, one]]
                    }
                }),
                "positive",
            ),
            (
                Box::new(move |f| {
                    if f > 2.0 {
                        [
                            [one, Complex64::new(0.1, 0.1)],
                            [Complex64::new(0.1, 0.1), one],
                        ]
                    } else {
                        [[one, z], [z, one]]
                    }
                }),
                "Hermitian",
            ),
            (
                Box::new(move |f| {
                    if f > 2.0 {
                        [[one, z], [z, Complex64::new(f64::NAN, 0.0)]]
                    } else {
                        [[one, z], [z, one]]
                    }
                }),
                "finite",
            ),
            (
                Box::new(move |f| {
                    if f > 2.0 {
                        [[-one, z], [z, one]]
                    } else {
                        [[one, z], [z, one]]
                    }
                }),
                "negative",
            ),
            (
                Box::new(move |f| {
                    if f > 2.0 {
                        [[Complex64::new(1.0, 0.5), z], [z, one]]
                    } else {
                        [[one, z], [z, one]]
                    }
                }),
                "real",
            ),
        ];
        for (csd, word) in cases {
            match synth_two_channel(n, fs, csd, &mut rng(0), SynthMode::Circular) {
                Err(SignalError::InvalidCsd { freq, reason }) => {
                    assert_eq!(freq, 2.125, "{word}");
                    assert!(reason.contains(word), "{word}: {reason}");
                }
                other => panic!("{word}: expected InvalidCsd, got {other:?}"),
            }
        }
        assert!(matches!(
            synth_one_channel(n, fs, |f| if f > 3.0 { -1.0 } else { 1.0 }, &mut rng(0), SynthMode::Circular),
            Err(SignalError::InvalidCsd { freq, .. }) if freq == 3.125
        ));
        // Nyquist imaginary cross term is legal input (dropped), tiny rounding is accepted.
        let ok = move |_f: f64| {
            let c = Complex64::new(0.5, 0.5) * (1.0 + 1e-15);
            [[one, c], [c.conj(), one * 0.5]]
        };
        assert!(synth_two_channel(n, fs, ok, &mut rng(0), SynthMode::Circular).is_ok());
        let sizes = [
            synth_one_channel(1, fs, |_| 1.0, &mut rng(0), SynthMode::Circular),
            synth_one_channel(8, 0.0, |_| 1.0, &mut rng(0), SynthMode::Circular),
            synth_one_channel(
                8,
                fs,
                |_| 1.0,
                &mut rng(0),
                SynthMode::Realistic { oversample: 1 },
            ),
            synth_one_channel(
                usize::MAX / 2,
                fs,
                |_| 1.0,
                &mut rng(0),
                SynthMode::Realistic { oversample: 4 },
            ),
        ];
        assert!(matches!(sizes[0], Err(SignalError::TooShort { .. })));
        assert!(matches!(
            sizes[1],
            Err(SignalError::InvalidParameter { name: "fs", .. })
        ));
        assert!(matches!(
            sizes[2],
            Err(SignalError::InvalidParameter {
                name: "oversample",
                ..
            })
        ));
        assert!(matches!(
            sizes[3],
            Err(SignalError::InvalidParameter {
                name: "oversample",
                ..
            })
        ));
        assert_eq!(
            serde_json::to_string(&SynthMode::Realistic { oversample: 2 }).unwrap(),
            r#"{"realistic":{"oversample":2}}"#
        );
        assert_eq!(
            serde_json::to_string(&SynthMode::default()).unwrap(),
            r#""circular""#
        );
    }
}
