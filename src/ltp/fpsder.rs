//! The five-point second derivative of LTPDA (`utils.math.fpsder`; Ferraioli, Hueller & Vitale,
//! CQG 26, 094013 (2009)) with which the acceleration domain turns read-outs into accelerations
//! (ltp-model.md §7.2), and its exact frequency response.
//!
//! ```text
//! ẍ[k] ≈ (1/T²)·(m y[k−2] + (1−4m) y[k−1] + (6m−2) y[k] + (1−4m) y[k+1] + m y[k+2])
//! D(f) = (1/T²)·(2m cos 2ωT + 2(1−4m) cos ωT + 6m − 2),  ω = 2πf
//! ```
//!
//! `m = 2/7` (the default, a parabolic fit over five points), `−1/12` (Taylor) or `1/4` (a
//! notch at Nyquist). `D(f) → −ω²` as `f → 0` but falls below it as f grows, which is why the
//! acceleration-domain model applies
//! `D(f)` (not `−ω²`) to the `d²/dt²` term of data differentiated this way.
//!
//! For small `x = ωT`, `D/(−ω²) = 1 − (1 + 12m) x²/12 + O(x⁴)`. At fs = 10 Hz with m = 2/7
//! that is 0.99854 at 0.1 Hz, 0.862 at 1 Hz and 0.530 at 2 Hz (ltp-model.md §7.2 quotes 0.99985
//! at 0.1 Hz: a slip of digits; the series and the tests give 0.99854).

use std::f64::consts::PI;

/// LTPDA's default stencil coefficient `m` (parabolic fit).
pub const FPSDER_M: f64 = 2.0 / 7.0;

/// The second derivative of `y` sampled at `fs` by the five-point stencil with coefficient `m`.
/// The series is extended at both ends by point reflection (LTPDA: `2 y[0] − y[4:−1:1]` before
/// the start, likewise after the end), so the output has the input's length. Series shorter
/// than five samples give `None`.
///
/// ```
/// use occam::ltp::fpsder::{FPSDER_M, fpsder};
/// // the stencil is exact for quadratics: y = t² gives ẍ = 2 away from the reflected ends
/// let fs = 10.0;
/// let y: Vec<f64> = (0..50).map(|k| (k as f64 / fs).powi(2)).collect();
/// let d = fpsder(&y, fs, FPSDER_M).unwrap();
/// assert!(d[2..48].iter().all(|v| (v - 2.0).abs() < 1e-9));
/// ```
pub fn fpsder(y: &[f64], fs: f64, m: f64) -> Option<Vec<f64>> {
    let n = y.len();
    if n < 5 {
        return None;
    }
    // y extended by two samples each side: y[−j] = 2y[0] − y[j], y[n−1+j] = 2y[n−1] − y[n−1−j]
    let at = |k: isize| -> f64 {
        if k < 0 {
            2.0 * y[0] - y[(-k) as usize]
        } else if k as usize >= n {
            let j = k as usize - (n - 1);
            2.0 * y[n - 1] - y[n - 1 - j]
        } else {
            y[k as usize]
        }
    };
    let c = [m, 1.0 - 4.0 * m, 6.0 * m - 2.0, 1.0 - 4.0 * m, m];
    let fs2 = fs * fs;
    Some(
        (0..n as isize)
            .map(|k| {
                fs2 * (-2..=2)
                    .map(|j| c[(j + 2) as usize] * at(k + j))
                    .sum::<f64>()
            })
            .collect(),
    )
}

/// The frequency response `D(f)` of [`fpsder`] (real: the stencil is symmetric), s⁻².
pub fn fpsder_response(f: f64, fs: f64, m: f64) -> f64 {
    // the cosines' constant terms cancel (2m + 2(1 − 4m) + 6m − 2 = 0); written with
    // 1 − cos x = 2 sin²(x/2) the response keeps full relative precision as f → 0
    let x = 2.0 * PI * f / fs;
    -4.0 * fs * fs * (m * x.sin().powi(2) + (1.0 - 4.0 * m) * (0.5 * x).sin().powi(2))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::signal::RealFft;
    use num_complex::Complex64;

    #[test]
    fn response_matches_the_quoted_ratios() {
        let fs = 10.0;
        let ratio = |f: f64| fpsder_response(f, fs, FPSDER_M) / -(2.0 * PI * f).powi(2);
        // ltp-model.md §7.2 quotes 0.99985 (sic: the series gives 0.99854), 0.862 and 0.53
        let x2 = (2.0 * PI * 0.1 / fs).powi(2);
        assert!((ratio(0.1) - (1.0 - (1.0 + 12.0 * FPSDER_M) * x2 / 12.0)).abs() < 1e-6);
        assert!((ratio(0.1) - 0.99854).abs() < 1e-5, "{}", ratio(0.1));
        assert!((ratio(1.0) - 0.862).abs() < 1e-3, "{}", ratio(1.0));
        assert!((ratio(2.0) - 0.53).abs() < 5e-3, "{}", ratio(2.0));
        // full relative precision at low frequency, where the cosine form would cancel
        let x2 = (2.0 * PI * 1e-4 / fs).powi(2);
        assert!((ratio(1e-4) - (1.0 - (1.0 + 12.0 * FPSDER_M) * x2 / 12.0)).abs() < 1e-14);
        // m = 1/4 puts a zero at Nyquist
        assert!(fpsder_response(fs / 2.0, fs, 0.25).abs() < 1e-9);
    }

    /// On a periodic series the interior of the time-domain stencil is the DFT filter `D(f)`
    /// exactly (the stencil is a circular convolution there).
    #[test]
    fn time_domain_interior_equals_the_frequency_response() {
        let (n, fs) = (512usize, 10.0);
        let y: Vec<f64> = (0..n)
            .map(|k| {
                let t = k as f64 / fs;
                (2.0 * PI * 0.37 * t).sin() + 0.3 * (2.0 * PI * 2.1 * t + 0.4).cos()
            })
            .collect();
        let mut fft = RealFft::new(n).unwrap();
        let mut spec = vec![Complex64::new(0.0, 0.0); fft.spectrum_len()];
        fft.forward(&y, &mut spec).unwrap();
        for (k, v) in spec.iter_mut().enumerate() {
            *v *= fpsder_response(k as f64 * fs / n as f64, fs, FPSDER_M);
        }
        let mut want = vec![0.0; n];
        fft.inverse(&spec, &mut want).unwrap();
        let got = fpsder(&y, fs, FPSDER_M).unwrap();
        let scale = want.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        // ends differ (reflection is not periodic continuation); two samples each side
        let worst = (2..n - 2)
            .map(|k| (got[k] - want[k]).abs())
            .fold(0.0, f64::max);
        assert!(worst < 1e-12 * scale, "{worst:e} of {scale:e}");
    }

    #[test]
    fn ends_use_point_reflection_and_short_series_are_refused() {
        // point reflection is exact for a straight line, so its second derivative is 0 at the
        // ends too
        let y: Vec<f64> = (0..10).map(|k| 3.0 - 0.5 * k as f64).collect();
        let d = fpsder(&y, 1.0, FPSDER_M).unwrap();
        assert!(d.iter().all(|v| v.abs() < 1e-12), "{d:?}");
        assert!(fpsder(&[1.0; 4], 1.0, FPSDER_M).is_none());
    }
}
