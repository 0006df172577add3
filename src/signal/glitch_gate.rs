//! Glitch detection on a whitened series: the numerics of `[analysis] glitches = "gate"`,
//! independent of any model.
//!
//! A series `x` of `N` samples whose noise has the one-sided PSD `S(f)` is whitened in the
//! frequency domain over a band, `Y_k = X_k / √(N fs S(f_k)/2)` for the regular bins in the
//! band and zero elsewhere, and scaled so that noise alone gives a unit-variance series
//! (`signal` module conventions: `E|X_k|² = (N fs/2) S(f_k)`). The series is end-matched first
//! (the line through its first and last samples removed) so that the DFT's wrap-around does not
//! put a step, and a false detection, at its ends.
//!
//! [`detect`] flags every sample whose whitened value exceeds the threshold (in σ), grows each
//! flagged sample into a region while the smoothed envelope (the RMS over a short moving window)
//! stays above the release level, pads the region on each side and merges overlapping regions.

use super::error::SignalError;
use super::fft::RealFft;
use num_complex::Complex64;

/// How [`detect`] turns a whitened series into gated regions.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GateSettings {
    /// A sample whose |whitened value| exceeds this (σ) starts a region.
    pub threshold: f64,
    /// A region grows while the smoothed envelope exceeds this (σ).
    pub release: f64,
    /// Length of the envelope's moving RMS window (samples, ≥ 1).
    pub smooth: usize,
    /// Samples added on each side of a region.
    pub pad: usize,
}

/// The whitened series of `x` (sampled at `fs` Hz) against the one-sided noise PSD `psd` over
/// `band` (Hz): unit variance for noise of that PSD (module docs). Bins where `psd` is not
/// positive and finite are left out. An error when no regular bin lies in the band.
pub fn whiten(
    x: &[f64],
    fs: f64,
    psd: &dyn Fn(f64) -> f64,
    band: [f64; 2],
) -> Result<Vec<f64>, SignalError> {
    let n = x.len();
    let mut fft = RealFft::new(n)?;
    // end-matching: the circular DFT would otherwise see a step between the last and first
    // samples (red noise wanders far), which whitening turns into a spike at both ends
    let (a, b) = (x[0], x[n - 1]);
    let slope = if n > 1 { (b - a) / (n - 1) as f64 } else { 0.0 };
    let y: Vec<f64> = x
        .iter()
        .enumerate()
        .map(|(k, v)| v - a - slope * k as f64)
        .collect();
    let mut spec = vec![Complex64::new(0.0, 0.0); fft.spectrum_len()];
    fft.forward(&y, &mut spec)?;
    let mut kept = 0usize;
    for (k, s) in spec.iter_mut().enumerate() {
        let f = k as f64 * fs / n as f64;
        // regular bins only: DC and Nyquist are real and carry half the weight
        let regular = k > 0 && 2 * k < n;
        let p = psd(f);
        if regular && f >= band[0] && f <= band[1] && p.is_finite() && p > 0.0 {
            *s /= (n as f64 * fs * p / 2.0).sqrt();
            kept += 1;
        } else {
            *s = Complex64::new(0.0, 0.0);
        }
    }
    if kept == 0 {
        return Err(SignalError::InvalidParameter {
            name: "band",
            value: band[0],
            requirement: "whitening needs at least one regular DFT bin with a positive PSD in the band",
        });
    }
    let mut out = vec![0.0; n];
    fft.inverse(&spec, &mut out)?;
    // each kept bin and its mirror add 1/N² · N to the variance of IDFT(Y)·N … (module docs):
    // Var[(N/√(2K)) IDFT(Y)_j] = 1
    let scale = n as f64 / (2.0 * kept as f64).sqrt();
    for v in &mut out {
        *v *= scale;
    }
    Ok(out)
}

/// The regions (half-open sample ranges, sorted, disjoint, inside `[0, y.len())`) that
/// `settings` gate in the whitened series `y`. Samples inside `ignore` (sorted half-open
/// ranges: data already missing) neither start a region nor hold one open.
pub fn detect(y: &[f64], ignore: &[[usize; 2]], settings: &GateSettings) -> Vec<[usize; 2]> {
    let n = y.len();
    let mut masked = y.to_vec();
    for g in ignore {
        let end = g[1].min(n);
        if g[0] < end {
            masked[g[0]..end].fill(0.0);
        }
    }
    let env = envelope(&masked, settings.smooth.max(1));
    let mut regions: Vec<[usize; 2]> = Vec::new();
    let mut k = 0;
    while k < n {
        if masked[k].abs() <= settings.threshold {
            k += 1;
            continue;
        }
        let mut a = k;
        while a > 0 && env[a - 1] > settings.release {
            a -= 1;
        }
        let mut b = k + 1;
        while b < n && env[b] > settings.release {
            b += 1;
        }
        regions.push([a.saturating_sub(settings.pad), (b + settings.pad).min(n)]);
        k = b;
    }
    merge(regions)
}

/// The moving mean of `y` over a centred window of `w` samples, counting only the samples
/// `valid` marks: the matched filter of a slow glitch, whose whitened form keeps one sign for
/// about its decay time while the noise averages down. A window that holds `m < w` valid
/// samples (at the ends of the series, beside a gap) gives `Σ_valid y / √(m w)`, which has
/// the variance of a full window's mean for white noise (`1/w`): a plain mean over fewer
/// samples would be noisier and trigger falsely there. Zero where no sample is valid.
pub fn moving_mean(y: &[f64], valid: &[bool], w: usize) -> Vec<f64> {
    let n = y.len();
    let w = w.max(1);
    let mut cum = Vec::with_capacity(n + 1);
    let mut cnt = Vec::with_capacity(n + 1);
    cum.push(0.0);
    cnt.push(0usize);
    for (v, ok) in y.iter().zip(valid) {
        cum.push(cum.last().unwrap() + if *ok { *v } else { 0.0 });
        cnt.push(cnt.last().unwrap() + usize::from(*ok));
    }
    let h = w / 2;
    (0..n)
        .map(|k| {
            let (a, b) = (k.saturating_sub(h), (k + w - h).min(n));
            let m = cnt[b] - cnt[a];
            if m == 0 {
                0.0
            } else {
                (cum[b] - cum[a]) / ((m * w) as f64).sqrt()
            }
        })
        .collect()
}

/// The moving RMS of `y` over a centred window of `w` samples (shorter at the ends).
fn envelope(y: &[f64], w: usize) -> Vec<f64> {
    let n = y.len();
    let mut cum = Vec::with_capacity(n + 1);
    cum.push(0.0);
    for v in y {
        cum.push(cum.last().unwrap() + v * v);
    }
    let h = w / 2;
    (0..n)
        .map(|k| {
            let (a, b) = (k.saturating_sub(h), (k + w - h).min(n));
            ((cum[b] - cum[a]) / (b - a) as f64).max(0.0).sqrt()
        })
        .collect()
}

/// The robust standard deviation of `y`, `1.4826 × median |y|` (the MAD of a zero-mean
/// Gaussian), which a few outliers do not move; `None` for an empty or all-zero series.
pub fn robust_sd(y: &[f64]) -> Option<f64> {
    let mut a: Vec<f64> = y.iter().map(|v| v.abs()).collect();
    if a.is_empty() {
        return None;
    }
    let mid = a.len() / 2;
    let (_, med, _) = a.select_nth_unstable_by(mid, |p, q| p.total_cmp(q));
    let sd = 1.482_602_218_505_602 * *med;
    (sd > 0.0 && sd.is_finite()).then_some(sd)
}

/// Sorts and merges overlapping or touching ranges.
fn merge(mut r: Vec<[usize; 2]>) -> Vec<[usize; 2]> {
    r.sort_unstable();
    let mut out: Vec<[usize; 2]> = Vec::with_capacity(r.len());
    for s in r {
        match out.last_mut() {
            Some(last) if s[0] <= last[1] => last[1] = last[1].max(s[1]),
            _ => out.push(s),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::signal::synth_one_channel;
    use rand::SeedableRng;
    use rand_xoshiro::Xoshiro256PlusPlus;

    const FS: f64 = 10.0;

    fn settings() -> GateSettings {
        GateSettings {
            threshold: 5.0,
            release: 2.0,
            smooth: 100,
            pad: 600,
        }
    }

    /// White noise of one-sided PSD `s0` (variance `s0 fs / 2`).
    fn white(n: usize, s0: f64, seed: u64) -> Vec<f64> {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
        synth_one_channel(n, FS, |_| s0, &mut rng, crate::signal::SynthMode::Circular).unwrap()
    }

    #[test]
    fn white_noise_whitens_to_unit_variance_and_gates_nothing() {
        let s0 = 4e-22;
        let n = 200_000;
        let (mut total, mut var_sum) = (0, 0.0);
        for seed in 0..5 {
            let x = white(n, s0, seed);
            let y = whiten(&x, FS, &|_| s0, [1e-3, 1.0]).unwrap();
            let var = y.iter().map(|v| v * v).sum::<f64>() / n as f64;
            var_sum += var;
            total += detect(&y, &[], &settings()).len();
        }
        // 5 × 2e4 in-band bins: the mean variance is 1 to about 0.005
        assert!(
            (var_sum / 5.0 - 1.0).abs() < 0.02,
            "variance {}",
            var_sum / 5.0
        );
        // 1e6 samples of roughly 2e5 independent ones at 5σ: P ≈ 6e-7 each
        assert_eq!(total, 0);
    }

    #[test]
    fn a_glitch_in_white_noise_is_found_at_its_time() {
        let s0 = 4e-22;
        let n = 100_000;
        let mut x = white(n, s0, 7);
        let sigma = (s0 * FS / 2.0).sqrt();
        // a fast-rise, 50 s decay pulse of peak 10σ (per sample, before band-limiting) at 4000 s
        let t0 = 40_000;
        for (k, v) in x.iter_mut().enumerate().skip(t0) {
            let t = (k - t0) as f64 / FS;
            *v += 10.0 * sigma * ((-t / 50.0).exp() - (-t / 2.0).exp()) / 0.9;
        }
        let y = whiten(&x, FS, &|_| s0, [1e-3, 1.0]).unwrap();
        let r = detect(&y, &[], &settings());
        assert_eq!(r.len(), 1, "{r:?}");
        assert!(r[0][0] < t0 && r[0][1] > t0, "{r:?} misses {t0}");
        // the pad is there, and the region is not much more than the glitch's rise
        assert!(r[0][1] - r[0][0] < 2 * 600 + 2_000, "{r:?}");
        // an ignored stretch over the glitch hides it
        assert!(detect(&y, &[[t0 - 1000, t0 + 2000]], &settings()).is_empty());
    }

    #[test]
    fn robust_normalisation_ignores_a_few_outliers() {
        let x = white(100_000, 1.0, 3);
        let sd = (x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64).sqrt();
        let mut y: Vec<f64> = x.iter().map(|v| 1.3 * v / sd).collect();
        y[10] = 1e6;
        y[20] = -1e6;
        let r = robust_sd(&y).unwrap();
        assert!((r / 1.3 - 1.0).abs() < 0.02, "{r}");
        assert_eq!(robust_sd(&[0.0; 4]), None);
    }

    #[test]
    fn moving_means_average_a_centred_window() {
        let y = [1.0, 2.0, 3.0, 4.0, 5.0];
        let all = [true; 5];
        assert_eq!(moving_mean(&y, &all, 1), y.to_vec());
        // full windows: the mean; two samples at the ends: Σ/√(2·3)
        let m = moving_mean(&y, &all, 3);
        assert_eq!(m[1..4], [2.0, 3.0, 4.0]);
        assert!((m[0] - 3.0 / 6f64.sqrt()).abs() < 1e-15);
        // an invalid sample counts for nothing
        let some = [true, true, false, true, true];
        assert_eq!(moving_mean(&y, &some, 1)[2], 0.0);
        assert!((moving_mean(&y, &some, 3)[2] - 6.0 / 6f64.sqrt()).abs() < 1e-15);
    }

    #[test]
    fn regions_merge_and_clip() {
        assert_eq!(
            merge(vec![[5, 8], [0, 3], [3, 4], [7, 9]]),
            vec![[0, 4], [5, 9]]
        );
        let mut y = vec![0.0; 50];
        y[2] = 9.0;
        let s = GateSettings {
            threshold: 5.0,
            release: 2.0,
            smooth: 1,
            pad: 5,
        };
        assert_eq!(detect(&y, &[], &s), vec![[0, 8]]);
    }
}
