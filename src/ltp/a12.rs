//! The differential acceleration from the read-outs in the time domain (ltp-model.md §7.2), as
//! LTPDA computes it: the "kinematic" part of K14 eq. (a12),
//!
//! ```text
//! a12_kin(t) = ẍ12 + ω2² x12 + (ω2² − ω1²) x1,   x1 = o1(t + τ_ifo),  x12 = o12(t + τ_ifo) − δ21 x1
//! ```
//!
//! which equals the force difference actually applied to the test masses, `Act2 g2 − Act1 g1`,
//! plus the external differential force noise. The acceleration-domain model
//! ([`crate::model::accel`]) is the same expression in the frequency domain.

use super::accel_options::{AccelOptions, Derivative};
use super::fpsder::{fpsder, fpsder_response};
use crate::signal::{RealFft, SignalError};
use num_complex::Complex64;
use std::f64::consts::PI;

/// `a12_kin` of read-outs `o1`, `o12` sampled at `fs` with stiffnesses `w1sq`, `w2sq` (s⁻²) and the
/// model options' δ21, τ_ifo and derivative. The read-out delay is removed by a circular
/// fractional advance (exact for periodic, band-limited series). `derivative = "fpsder"` runs
/// the stencil in the time domain with LTPDA's point-reflected ends; `"exact"` differentiates
/// spectrally (circular).
pub fn a12_kinematic(
    o1: &[f64],
    o12: &[f64],
    fs: f64,
    w1sq: f64,
    w2sq: f64,
    opts: &AccelOptions,
) -> Result<Vec<f64>, SignalError> {
    let n = o1.len();
    if o12.len() != n {
        return Err(SignalError::LengthMismatch {
            first: "o1",
            len_first: n,
            second: "o12",
            len_second: o12.len(),
        });
    }
    if n < 5 {
        return Err(SignalError::TooShort {
            what: "a12 read-outs (the five-point stencil)",
            min: 5,
            got: n,
        });
    }
    let mut fft = RealFft::new(n)?;
    let (x1, x12) = if opts.tau_ifo != 0.0 {
        let adv = |o: &[f64], fft: &mut RealFft| -> Result<Vec<f64>, SignalError> {
            filter(o, fs, fft, |f| crate::lti::delay(-opts.tau_ifo, f))
        };
        (adv(o1, &mut fft)?, adv(o12, &mut fft)?)
    } else {
        (o1.to_vec(), o12.to_vec())
    };
    let x12: Vec<f64> = x12.iter().zip(&x1).map(|(a, b)| a - opts.d21 * b).collect();
    let d2 = match opts.derivative {
        Derivative::Fpsder => fpsder(&x12, fs, opts.fpsder_m).expect("n ≥ 5 checked"),
        Derivative::Exact => filter(&x12, fs, &mut fft, |f| {
            Complex64::new(-(2.0 * PI * f).powi(2), 0.0)
        })?,
    };
    Ok((0..n)
        .map(|k| d2[k] + w2sq * x12[k] + (w2sq - w1sq) * x1[k])
        .collect())
}

/// `y` through the frequency response `h(f)` (circular).
pub fn filter(
    y: &[f64],
    fs: f64,
    fft: &mut RealFft,
    h: impl Fn(f64) -> Complex64,
) -> Result<Vec<f64>, SignalError> {
    let n = y.len();
    let mut spec = vec![Complex64::new(0.0, 0.0); fft.spectrum_len()];
    fft.forward(y, &mut spec)?;
    for (k, v) in spec.iter_mut().enumerate() {
        let f = k as f64 * fs / n as f64;
        // the Nyquist bin of an even length is real: keep its real part
        *v *= if 2 * k == n {
            Complex64::new(h(f).re, 0.0)
        } else {
            h(f)
        };
    }
    let mut out = vec![0.0; n];
    fft.inverse(&spec, &mut out)?;
    Ok(out)
}

/// The error of the five-point stencil against the exact second derivative on a periodic
/// series, `IFFT((D_fps(f) + ω²) ỹ)`: what [`a12_kinematic`] with `fpsder` adds to the applied
/// forces on noiseless data, away from the two reflected samples at each end.
pub fn fpsder_error(y: &[f64], fs: f64, m: f64) -> Result<Vec<f64>, SignalError> {
    let mut fft = RealFft::new(y.len())?;
    filter(y, fs, &mut fft, |f| {
        Complex64::new(fpsder_response(f, fs, m) + (2.0 * PI * f).powi(2), 0.0)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A free test-mass pair: x12 = sin, x1 = cos, ω² known; a12 by hand.
    #[test]
    fn exact_derivative_gives_the_kinematic_acceleration() {
        let (n, fs, f0) = (1000usize, 10.0, 0.37);
        let w = 2.0 * PI * f0;
        let t = |k: usize| k as f64 / fs;
        let x1: Vec<f64> = (0..n).map(|k| 1e-9 * (w * t(k)).cos()).collect();
        let x12: Vec<f64> = (0..n).map(|k| 2e-9 * (w * t(k)).sin()).collect();
        let (w1, w2, d21) = (-1.3e-6, -1.9e-6, 4e-4);
        // read-outs: o1 = x1, o12 = x12 + δ21 x1 (no read-out delay)
        let o12: Vec<f64> = x12.iter().zip(&x1).map(|(a, b)| a + d21 * b).collect();
        let opts = AccelOptions {
            derivative: Derivative::Exact,
            d21,
            ..Default::default()
        };
        let a = a12_kinematic(&x1, &o12, fs, w1, w2, &opts).unwrap();
        for k in 0..n {
            let want = (-w * w + w2) * x12[k] + (w2 - w1) * x1[k];
            assert!(
                (a[k] - want).abs() < 1e-10 * 2e-9 * w * w,
                "{k}: {} vs {want}",
                a[k]
            );
        }
    }

    /// A read-out delay τ is undone: o(t) = x(t − τ).
    #[test]
    fn read_out_delay_is_removed() {
        let (n, fs, f0, tau) = (1000usize, 10.0, 0.37, 0.25);
        let w = 2.0 * PI * f0;
        let x12 = |t: f64| 2e-9 * (w * t).sin();
        let o12: Vec<f64> = (0..n).map(|k| x12(k as f64 / fs - tau)).collect();
        let zero = vec![0.0; n];
        let opts = AccelOptions {
            derivative: Derivative::Exact,
            tau_ifo: tau,
            ..Default::default()
        };
        let a = a12_kinematic(&zero, &o12, fs, 0.0, 0.0, &opts).unwrap();
        for (k, v) in a.iter().enumerate() {
            let want = -w * w * x12(k as f64 / fs);
            assert!((v - want).abs() < 1e-10 * 2e-9 * w * w, "{k}");
        }
    }

    #[test]
    fn short_or_mismatched_series_are_errors() {
        let o = AccelOptions::default();
        assert!(a12_kinematic(&[0.0; 4], &[0.0; 4], 1.0, 0.0, 0.0, &o).is_err());
        assert!(a12_kinematic(&[0.0; 8], &[0.0; 9], 1.0, 0.0, 0.0, &o).is_err());
    }
}
