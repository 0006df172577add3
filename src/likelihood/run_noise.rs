//! The exact noise covariance of a gapped run's DFT bins.
//!
//! A valid run between gaps is tapered and transformed on its own grid (`k/T_run`). The
//! likelihood gives its bin `k` the variance `(fs/2) Σw² S(f_k)`, which holds where `S` is
//! flat across the window's kernel. Below the read-out's corner the LTP's `S` rises as `f⁻⁴`,
//! and the kernel's sidelobes carry the power of frequencies far below `f_k` into the bin: on
//! Table I's study with 10 % of the samples in gaps the `o12` variance of a run's lowest kept
//! bins is 1.06–1.5 times the nominal on runs of 2 000–9 000 s and 2–20 times on runs shorter
//! than 1 500 s (`cargo run --release --example gaps_leakage`). The whitened score then
//! scatters more than the Fisher matrix and the sandwich say (issue 46: sandwich pull sds up to
//! 1.22 with the exact noise model over 100 realisations).
//!
//! The exact covariance follows from the noise's autocovariance on the stretch the run was cut
//! from. Noise of one-sided CSD `S_ab` on the stretch's DFT grid (`N` samples; what occam's
//! simulator draws) has `γ_ab(τ) = E[x_a(t+τ) x_b(t)] = (fs/2N) Σ_j S_ab(f_j) e^{2πijτ/N}`
//! (DC excluded), and the run's tapered DFT `X_k = Σ_t w_t x(t) e^{−2πikt/N_r}` has
//! `E[X_a,k X_b,k*] = Σ_τ A(τ) γ_ab(τ) e^{−2πikτ/N_r}`, `A(τ) = Σ_t w_{t+τ} w_t`: one transform
//! of the run's length per channel pair once `γ` is known. Where `S` is flat this equals the
//! nominal `(fs/2) Σw² S(f_k)` to rounding (unit test).
//!
//! What it does not give: the correlation between a run's bins, which the kernel's leakage
//! raises too (the sandwich keeps the window's `R_{k−l}` for it), and, for the Welch estimate,
//! the noise below the estimate's first frequency, which [`super::spectra`] holds flat at its
//! lowest value (the `o12` read-out rises as `f⁻⁴` there, so the leakage is underestimated).

use crate::signal::RealFft;
use nalgebra::DMatrix;
use num_complex::Complex64;

/// The autocovariance `γ_ab(τ)` of the noisy data channels over a stretch, from their CSD on
/// its DFT grid.
#[derive(Debug, Clone)]
pub(super) struct StretchNoise {
    /// Channels `nn` of the CSD (its matrices are `nn × nn`, row-major).
    nn: usize,
    /// `γ_ab(τ)` for `a ≤ b`, `τ = 0 … N−1` (circular: `γ(−τ) = γ(N − τ)`), in the order
    /// `(0,0), (0,1), …, (1,1), …`.
    gamma: Vec<Vec<f64>>,
}

/// The index of pair `(a, b)`, `a ≤ b`, among `nn` channels.
fn pair(nn: usize, a: usize, b: usize) -> usize {
    a * nn - a * (a + 1) / 2 + b
}

impl StretchNoise {
    /// From the one-sided CSD `csd[j − 1]` (`nn × nn` row-major) at `f_j = j fs/N`,
    /// `j = 1 … N/2`, of a stretch of `n` samples.
    pub(super) fn new(
        n: usize,
        nn: usize,
        csd: &[Vec<Complex64>],
        fs: f64,
    ) -> Result<Self, String> {
        if csd.len() != n / 2 {
            return Err(format!(
                "stretch noise: {} frequencies for {n} samples (need {})",
                csd.len(),
                n / 2
            ));
        }
        let mut fft = RealFft::new(n).map_err(|e| e.to_string())?;
        let mut spec = vec![Complex64::new(0.0, 0.0); fft.spectrum_len()];
        let mut gamma = Vec::with_capacity(nn * (nn + 1) / 2);
        for a in 0..nn {
            for b in a..nn {
                for (s, m) in spec[1..].iter_mut().zip(csd) {
                    *s = m[a * nn + b] * (fs / 2.0);
                }
                let mut g = vec![0.0; n];
                fft.inverse(&spec, &mut g).map_err(|e| e.to_string())?;
                gamma.push(g);
            }
        }
        Ok(Self { nn, gamma })
    }

    /// The number of channels of its CSD.
    pub(super) fn channels(&self) -> usize {
        self.nn
    }

    /// `E[X_k X_kᴴ] / ((fs/2) Σ w²)` for each run bin `k` of `ks`, `nn × nn` row-major: the
    /// CSD the run's bin `k` has, in the units of `S`, for a run tapered by `w` (its length
    /// `N_r ≤ N`).
    pub(super) fn windowed(
        &self,
        w: &[f64],
        ks: &[usize],
        fs: f64,
    ) -> Result<Vec<Vec<Complex64>>, String> {
        let nr = w.len();
        let n = self.gamma[0].len();
        if nr > n || nr < 2 {
            return Err(format!("run of {nr} samples in a stretch of {n}"));
        }
        let sum_w2: f64 = w.iter().map(|x| x * x).sum();
        let scale = fs / 2.0 * sum_w2;
        let a = autocorrelation(w)?;
        let mut fft = RealFft::new(nr).map_err(|e| e.to_string())?;
        let mut d = vec![0.0; nr];
        let mut e = vec![Complex64::new(0.0, 0.0); fft.spectrum_len()];
        let nn = self.nn;
        let mut out = vec![vec![Complex64::new(0.0, 0.0); nn * nn]; ks.len()];
        for p in 0..nn {
            for q in p..nn {
                let g = &self.gamma[pair(nn, p, q)];
                // lags τ and τ − N_r fold onto τ: the transform of length N_r is exact
                d[0] = a[0] * g[0];
                for t in 1..nr {
                    d[t] = a[t] * g[t] + a[nr - t] * g[n - (nr - t)];
                }
                fft.forward(&d, &mut e).map_err(|x| x.to_string())?;
                for (o, &k) in out.iter_mut().zip(ks) {
                    let mut v = e[k] / scale;
                    if p == q {
                        // real up to the transform's rounding
                        v.im = 0.0;
                    }
                    o[p * nn + q] = v;
                    o[q * nn + p] = v.conj();
                }
            }
        }
        Ok(out)
    }
}

/// How a gapped run's exact noise covariance relates to the nominal one, per bin: `T_k` with
/// `S_exact,k = T_k S_nom,k T_kᴴ` (`T = L_exact L_nom⁻¹` from their Cholesky factors) over the
/// noisy data channels `channels`. The θ-dependent likelihood
/// ([`crate::likelihood::theta_noise`]) applies it to the noise it evaluates at θ, so that at
/// the point the spectra were made at it is the likelihood's own, and away from it the
/// leakage keeps its proportion to the noise.
#[derive(Debug, Clone)]
pub struct NoiseLeak {
    /// The data channels the transforms act on (the noisy ones).
    pub channels: Vec<usize>,
    /// `T_k`, `n × n` row-major per bin (`n = channels.len()`).
    pub transforms: Vec<Complex64>,
}

impl NoiseLeak {
    /// From the nominal and the exact CSD of each bin (`n × n` row-major); an error where
    /// either is not positive definite.
    pub(super) fn new(
        channels: Vec<usize>,
        nominal: &[Vec<Complex64>],
        exact: &[Vec<Complex64>],
    ) -> Result<Self, String> {
        let n = channels.len();
        let mut transforms = Vec::with_capacity(nominal.len() * n * n);
        for (k, (a, b)) in nominal.iter().zip(exact).enumerate() {
            let chol = |m: &[Complex64]| {
                DMatrix::from_row_slice(n, n, m)
                    .cholesky()
                    .map(|c| c.l())
                    .ok_or_else(|| format!("bin {k}: a noise CSD that is not positive definite"))
            };
            let ln_inv = chol(a)?
                .try_inverse()
                .ok_or_else(|| format!("bin {k}: a singular noise CSD"))?;
            let t = chol(b)? * ln_inv;
            for i in 0..n {
                for j in 0..n {
                    transforms.push(t[(i, j)]);
                }
            }
        }
        Ok(Self {
            channels,
            transforms,
        })
    }

    /// Replaces the noisy channels' block of `s` (the data channels' CSD at bin `k`, `nc × nc`
    /// row-major) by `T_k s T_kᴴ`.
    pub fn apply(&self, k: usize, s: &mut [Complex64], nc: usize) {
        let n = self.channels.len();
        let t = &self.transforms[k * n * n..(k + 1) * n * n];
        let block: Vec<Complex64> = (0..n * n)
            .map(|x| s[self.channels[x / n] * nc + self.channels[x % n]])
            .collect();
        for i in 0..n {
            for j in 0..n {
                let mut v = Complex64::new(0.0, 0.0);
                for a in 0..n {
                    for b in 0..n {
                        v += t[i * n + a] * block[a * n + b] * t[j * n + b].conj();
                    }
                }
                s[self.channels[i] * nc + self.channels[j]] = v;
            }
        }
    }
}

/// `A(τ) = Σ_t w_{t+τ} w_t` for `τ = 0 … N_r − 1`.
fn autocorrelation(w: &[f64]) -> Result<Vec<f64>, String> {
    let nr = w.len();
    let mut fft = RealFft::new(2 * nr).map_err(|e| e.to_string())?;
    let mut padded = w.to_vec();
    padded.resize(2 * nr, 0.0);
    let mut s = vec![Complex64::new(0.0, 0.0); fft.spectrum_len()];
    fft.forward(&padded, &mut s).map_err(|e| e.to_string())?;
    for z in &mut s {
        *z = Complex64::new(z.norm_sqr(), 0.0);
    }
    fft.inverse(&s, &mut padded).map_err(|e| e.to_string())?;
    padded.truncate(nr);
    Ok(padded)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::signal::{SynthMode, synth_two_channel};
    use rand::SeedableRng;

    /// A steep 2×2 CSD with a coherent part: `o12`-like `1 + (fc/f)⁴` and a flat channel.
    fn steep(f: f64) -> [[Complex64; 2]; 2] {
        let s1 = 1.0 + (0.02 / f).powi(4);
        let s2 = 2.0;
        let c = Complex64::new(0.3, 0.2) * (s1 * s2).sqrt() * 0.5;
        [
            [Complex64::new(s1, 0.0), c],
            [c.conj(), Complex64::new(s2, 0.0)],
        ]
    }

    fn flat(csd: impl Fn(f64) -> [[Complex64; 2]; 2], n: usize, fs: f64) -> Vec<Vec<Complex64>> {
        (1..=n / 2)
            .map(|j| {
                let m = csd(j as f64 * fs / n as f64);
                vec![m[0][0], m[0][1], m[1][0], m[1][1]]
            })
            .collect()
    }

    fn tukey(nr: usize, t: usize) -> Vec<f64> {
        let mut w = vec![1.0; nr];
        super::super::spectra::edge_taper(&mut w, [t, t]);
        w
    }

    #[test]
    fn white_noise_has_the_nominal_variance_in_every_bin() {
        let (n, fs) = (1000, 2.0);
        // a real coherence: an imaginary one, odd in the two-sided frequency, is not flat
        // across f = 0 and leaks like a steep spectrum (the double-sum test covers it)
        let white = |_f: f64| {
            let c = Complex64::new(0.1, 0.0);
            [
                [Complex64::new(1.5, 0.0), c],
                [c.conj(), Complex64::new(0.7, 0.0)],
            ]
        };
        let sn = StretchNoise::new(n, 2, &flat(white, n, fs), fs).unwrap();
        let w = tukey(300, 40);
        let ks: Vec<usize> = (1..150).collect();
        let got = sn.windowed(&w, &ks, fs).unwrap();
        let m = white(0.0);
        let sum_w2: f64 = w.iter().map(|x| x * x).sum();
        for (g, &k) in got.iter().zip(&ks) {
            // DC is absent from the stretch: a white spectrum misses the power `S fs/2N` at
            // every lag, which the run's bin sees through its window, `|W_k|²`
            let wk: Complex64 = w
                .iter()
                .enumerate()
                .map(|(t, &x)| {
                    x * Complex64::from_polar(
                        1.0,
                        -2.0 * std::f64::consts::PI * (k * t) as f64 / w.len() as f64,
                    )
                })
                .sum();
            let kept = 1.0 - wk.norm_sqr() / (n as f64 * sum_w2);
            for (v, want) in g.iter().zip([m[0][0], m[0][1], m[1][0], m[1][1]]) {
                assert!(
                    (v - want * kept).norm() < 1e-12,
                    "bin {k}: {v} vs {}",
                    want * kept
                );
            }
        }
    }

    #[test]
    fn the_transform_equals_the_double_sum_over_samples() {
        let (n, fs, nr) = (96, 1.0, 40);
        let sn = StretchNoise::new(n, 2, &flat(steep, n, fs), fs).unwrap();
        let w = tukey(nr, 7);
        let ks: Vec<usize> = (1..nr / 2).collect();
        let got = sn.windowed(&w, &ks, fs).unwrap();
        let scale = fs / 2.0 * w.iter().map(|x| x * x).sum::<f64>();
        let gamma = |a: usize, b: usize, tau: i64| -> f64 {
            let t = tau.rem_euclid(n as i64) as usize;
            if a <= b {
                sn.gamma[pair(2, a, b)][t]
            } else {
                // γ_ba(τ) = γ_ab(−τ)
                sn.gamma[pair(2, b, a)][(n - t) % n]
            }
        };
        for (g, &k) in got.iter().zip(&ks) {
            for a in 0..2 {
                for b in 0..2 {
                    let mut s = Complex64::new(0.0, 0.0);
                    for t in 0..nr {
                        for u in 0..nr {
                            let ph = -2.0 * std::f64::consts::PI * (k * t) as f64 / nr as f64
                                + 2.0 * std::f64::consts::PI * (k * u) as f64 / nr as f64;
                            s += w[t]
                                * w[u]
                                * gamma(a, b, t as i64 - u as i64)
                                * Complex64::from_polar(1.0, ph);
                        }
                    }
                    let v = g[a * 2 + b];
                    assert!(
                        (v - s / scale).norm() < 1e-10 * (s / scale).norm().max(1e-3),
                        "k {k} ({a},{b}): {v} vs {}",
                        s / scale
                    );
                }
            }
        }
    }

    /// The leakage transform turns each bin's nominal CSD into its exact one, in place inside
    /// a larger CSD whose other channels it leaves alone, and is the identity where they agree.
    #[test]
    fn the_leak_transform_maps_the_nominal_csd_to_the_exact_one() {
        let (n, fs, nr) = (2048, 1.0, 300);
        let sn = StretchNoise::new(n, 2, &flat(steep, n, fs), fs).unwrap();
        let w = tukey(nr, 75);
        let ks = [1usize, 3, 8, 60];
        let exact = sn.windowed(&w, &ks, fs).unwrap();
        let nominal: Vec<Vec<Complex64>> = ks
            .iter()
            .map(|&k| {
                let m = steep(k as f64 * fs / nr as f64);
                vec![m[0][0], m[0][1], m[1][0], m[1][1]]
            })
            .collect();
        // the noisy channels are data channels 2 and 0 of three (channel 1 noiseless)
        let leak = NoiseLeak::new(vec![2, 0], &nominal, &exact).unwrap();
        let same = NoiseLeak::new(vec![2, 0], &nominal, &nominal).unwrap();
        for (k, (nom, ex)) in nominal.iter().zip(&exact).enumerate() {
            let mut s = vec![Complex64::new(0.0, 0.0); 9];
            for (i, &a) in [2usize, 0].iter().enumerate() {
                for (j, &b) in [2usize, 0].iter().enumerate() {
                    s[a * 3 + b] = nom[i * 2 + j];
                }
            }
            let mut t = s.clone();
            leak.apply(k, &mut t, 3);
            same.apply(k, &mut s, 3);
            for (i, &a) in [2usize, 0].iter().enumerate() {
                for (j, &b) in [2usize, 0].iter().enumerate() {
                    let want = ex[i * 2 + j];
                    assert!(
                        (t[a * 3 + b] - want).norm() < 1e-10 * want.norm().max(1.0),
                        "bin {k} ({a},{b}): {} vs {want}",
                        t[a * 3 + b]
                    );
                    let was = nom[i * 2 + j];
                    assert!((s[a * 3 + b] - was).norm() < 1e-12 * was.norm().max(1.0));
                }
            }
            assert!(t[3..6].iter().all(|z| z.norm() == 0.0), "channel 1 touched");
        }
        // bin 1 leaks: the transform is not the identity there
        assert!((leak.transforms[0].norm() - 1.0).abs() > 0.1);
    }

    /// Monte Carlo: noise drawn on the stretch's grid, a tapered run cut from it; the mean of
    /// `X_k X_kᴴ` over realisations is the windowed CSD within its errors, and far from the
    /// nominal `S(f_k)` in the lowest bins (so a likelihood taking the nominal one is wrong
    /// there, and this test would tell).
    #[test]
    fn drawn_noise_has_the_windowed_covariance() {
        let (n, fs, nr, start) = (4096, 1.0, 600, 1234);
        let sn = StretchNoise::new(n, 2, &flat(steep, n, fs), fs).unwrap();
        let w = tukey(nr, 150);
        let ks = [3usize, 4, 6, 12, 40];
        let want = sn.windowed(&w, &ks, fs).unwrap();
        let scale = fs / 2.0 * w.iter().map(|x| x * x).sum::<f64>();
        let reps = 1500;
        let mut rng = rand::rngs::StdRng::seed_from_u64(46);
        let mut fft = RealFft::new(nr).unwrap();
        let mut acc = vec![[[0.0; 2]; 2]; ks.len()];
        let mut cross = vec![Complex64::new(0.0, 0.0); ks.len()];
        let mut spec = [
            vec![Complex64::new(0.0, 0.0); fft.spectrum_len()],
            vec![Complex64::new(0.0, 0.0); fft.spectrum_len()],
        ];
        for _ in 0..reps {
            let x = synth_two_channel(n, fs, steep, &mut rng, SynthMode::Circular).unwrap();
            for c in 0..2 {
                let buf: Vec<f64> = (0..nr).map(|t| x[c][start + t] * w[t]).collect();
                fft.forward(&buf, &mut spec[c]).unwrap();
            }
            for (i, &k) in ks.iter().enumerate() {
                acc[i][0][0] += spec[0][k].norm_sqr() / scale;
                acc[i][1][1] += spec[1][k].norm_sqr() / scale;
                cross[i] += spec[0][k] * spec[1][k].conj() / scale;
            }
        }
        for (i, &k) in ks.iter().enumerate() {
            let f = k as f64 * fs / nr as f64;
            let nominal = steep(f)[0][0].re;
            for c in 0..2 {
                let mean = acc[i][c][c] / reps as f64;
                let exact = want[i][c * 2 + c].re;
                // |X|² is exponential: relative standard error 1/√reps
                let z = (mean / exact - 1.0) * (reps as f64).sqrt();
                assert!(
                    z.abs() < 4.0,
                    "k {k} ch {c}: mean {mean} exact {exact} (z {z:.2})"
                );
            }
            let c = cross[i] / reps as f64;
            let e = want[i][1];
            let sd = (want[i][0].re * want[i][3].re / reps as f64).sqrt();
            assert!(
                (c - e).norm() < 4.0 * sd,
                "k {k}: cross {c} vs {e} (sd {sd})"
            );
            if k == 3 {
                let ratio = want[i][0].re / nominal;
                assert!(ratio > 1.5, "bin 3 leaks little: {ratio}");
            }
        }
    }
}
