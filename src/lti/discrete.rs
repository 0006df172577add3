//! Discrete-time LTI pieces: the Tustin (bilinear) map of a [`Rational`] to a transfer function
//! in `z⁻¹`, its frequency response on the unit circle, an IIR filter that runs it sample by
//! sample, and the zero-order-hold discretisation of a continuous state-space pair.
//!
//! Conventions: a discrete transfer function is `H(z) = Σ b_k z⁻ᵏ / Σ a_k z⁻ᵏ` with `a[0] = 1`
//! (the scipy `lfilter` convention, ascending powers of `z⁻¹` — unlike [`Rational`], whose
//! coefficients are in descending powers of `s`). The frequency `f` maps to `z = e^{i2πf/fs}`.

use super::rational::{LtiError, Rational, StateSpace};
use nalgebra::DMatrix;
use num_complex::Complex64;
use std::f64::consts::PI;

/// A discrete-time transfer function `Σ b_k z⁻ᵏ / Σ a_k z⁻ᵏ`, normalised so that `a[0] = 1`
/// (the fields are private so that the normalisation always holds).
#[derive(Debug, Clone, PartialEq)]
pub struct DiscreteTf {
    b: Vec<f64>,
    a: Vec<f64>,
}

impl DiscreteTf {
    /// Validates (non-empty, finite, `a[0] ≠ 0`) and divides both polynomials by `a[0]`.
    pub fn new(b: Vec<f64>, a: Vec<f64>) -> Result<Self, LtiError> {
        if b.is_empty() || a.is_empty() {
            return Err(LtiError::Invalid(
                "discrete transfer function: `b` and `a` need at least one coefficient each".into(),
            ));
        }
        if b.iter().chain(&a).any(|c| !c.is_finite()) {
            return Err(LtiError::Invalid(
                "discrete transfer function: coefficients must be finite numbers".into(),
            ));
        }
        let a0 = a[0];
        if a0 == 0.0 {
            return Err(LtiError::Invalid(
                "discrete transfer function: `a[0]` must be non-zero (it multiplies the current \
                 output; a zero makes the filter non-causal)"
                    .into(),
            ));
        }
        Ok(Self {
            b: b.iter().map(|c| c / a0).collect(),
            a: a.iter().map(|c| c / a0).collect(),
        })
    }

    /// Tustin (bilinear) discretisation of `h` at sample rate `fs`:
    /// `s ← c (1 − z⁻¹)/(1 + z⁻¹)` with `c = 2 fs`, or with prewarping at `f_p`,
    /// `c = ω_p / tan(ω_p/(2 fs))` (`ω_p = 2π f_p`) so that the discrete response equals the
    /// continuous one exactly at `f_p`.
    ///
    /// The map sends the frequency `f` of the discrete filter to the continuous frequency
    /// `(c/2π)·tan(πf/fs)`, so without prewarping the response error is `O((2πf/fs)²)`.
    /// Fails for an improper `h`, a non-positive `fs`, a prewarp frequency outside
    /// `(0, fs/2)`, or a pole of `h` at `s = c` (it would map to `z = ∞`).
    ///
    /// ```
    /// use occam::lti::{Rational, discrete::DiscreteTf};
    /// // 1/(s + a) at fs = 10 Hz: b = [1, 1]/(c + a), a = [1, (a − c)/(c + a)] with c = 2 fs
    /// let (a, c) = (3.0, 20.0);
    /// let h = Rational::new(vec![1.0], vec![1.0, a]).unwrap();
    /// let d = DiscreteTf::tustin(&h, 10.0, None).unwrap();
    /// let want_b = 1.0 / (c + a);
    /// assert!((d.b()[0] - want_b).abs() < 1e-15 && (d.b()[1] - want_b).abs() < 1e-15);
    /// assert!((d.a()[1] - (a - c) / (c + a)).abs() < 1e-15);
    /// // close to the continuous response well below the sample rate
    /// let f = 0.01;
    /// assert!((d.eval_freq(f, 10.0) / h.eval_freq(f) - 1.0).norm() < 1e-4);
    /// ```
    pub fn tustin(h: &Rational, fs: f64, prewarp: Option<f64>) -> Result<Self, LtiError> {
        if !(fs.is_finite() && fs > 0.0) {
            return Err(LtiError::Invalid(format!(
                "Tustin: sample rate fs = {fs} Hz must be a positive finite number"
            )));
        }
        let c = match prewarp {
            None => 2.0 * fs,
            Some(fp) => {
                if !(fp.is_finite() && fp > 0.0 && fp < 0.5 * fs) {
                    return Err(LtiError::Invalid(format!(
                        "Tustin: prewarp frequency {fp} Hz must lie in (0, fs/2) = (0, {}) Hz",
                        0.5 * fs
                    )));
                }
                let wp = 2.0 * PI * fp;
                wp / (wp / (2.0 * fs)).tan()
            }
        };
        let (num, den) = (h.num(), h.den());
        if num.len() > den.len() {
            return Err(LtiError::Invalid(
                "Tustin: improper transfer function (numerator degree above denominator degree) \
                 has no causal discretisation"
                    .into(),
            ));
        }
        let n = den.len() - 1;
        // basis[k] = c^k (1 − w)^k (1 + w)^{n−k} in ascending powers of w = z⁻¹: multiplying
        // N(s) and D(s) by (1 + w)^n clears the fractions of the substitution.
        let basis: Vec<Vec<f64>> = (0..=n)
            .map(|k| {
                let mut p = vec![c.powi(k as i32)];
                for _ in 0..k {
                    p = poly_mul_asc(&p, &[1.0, -1.0]);
                }
                for _ in k..n {
                    p = poly_mul_asc(&p, &[1.0, 1.0]);
                }
                p
            })
            .collect();
        let map = |desc: &[f64]| -> Vec<f64> {
            let deg = desc.len() - 1;
            let mut out = vec![0.0; n + 1];
            for (i, &coef) in desc.iter().enumerate() {
                for (o, &q) in out.iter_mut().zip(&basis[deg - i]) {
                    *o += coef * q;
                }
            }
            out
        };
        let (b, a) = (map(num), map(den));
        if a[0] == 0.0 {
            return Err(LtiError::Invalid(format!(
                "Tustin: the continuous pole at s = {c} maps to z = ∞; choose another sample rate \
                 or prewarp frequency"
            )));
        }
        Self::new(b, a)
    }

    /// Numerator coefficients of `z⁰, z⁻¹, z⁻², …`.
    pub fn b(&self) -> &[f64] {
        &self.b
    }

    /// Denominator coefficients of `z⁰, z⁻¹, z⁻², …`, with `a[0] = 1`.
    pub fn a(&self) -> &[f64] {
        &self.a
    }

    /// `H(z)` at a complex `z ≠ 0`, by Horner's rule in `z⁻¹`.
    pub fn eval_z(&self, z: Complex64) -> Complex64 {
        let w = z.inv();
        horner_asc(&self.b, w) / horner_asc(&self.a, w)
    }

    /// The frequency response at `f` (Hz) for sample rate `fs`: `H(e^{i2πf/fs})`.
    pub fn eval_freq(&self, f: f64, fs: f64) -> Complex64 {
        self.eval_z(Complex64::from_polar(1.0, 2.0 * PI * f / fs))
    }

    /// A state-space realisation of the difference equation,
    /// `ξ[n+1] = A ξ[n] + B x[n]`, `y[n] = C ξ[n] + D x[n]` (discrete time, although the
    /// [`StateSpace`] type is shared with continuous realisations). Its state is exactly the
    /// state of an [`IirFilter`] running the same function (transposed direct form II), so the
    /// two can be mixed.
    pub fn to_state_space(&self) -> StateSpace {
        let (b, a) = padded(self);
        let n = a.len() - 1;
        let d = b[0];
        let mut am = DMatrix::zeros(n, n);
        let mut bm = nalgebra::DVector::zeros(n);
        let mut cm = nalgebra::RowDVector::zeros(n);
        // y = b0 x + s0;  s_k ← s_{k+1} + b_{k+1} x − a_{k+1} y
        for k in 0..n {
            am[(k, 0)] = -a[k + 1];
            if k + 1 < n {
                am[(k, k + 1)] = 1.0;
            }
            bm[k] = b[k + 1] - a[k + 1] * d;
        }
        if n > 0 {
            cm[0] = 1.0;
        }
        StateSpace {
            a: am,
            b: bm,
            c: cm,
            d,
        }
    }
}

/// Runs a [`DiscreteTf`] sample by sample in transposed direct form II, keeping its state
/// between calls; `step` allocates nothing.
///
/// ```
/// use occam::lti::discrete::{DiscreteTf, IirFilter};
/// // y[n] = x[n] + 0.5 y[n−1]: the impulse response is 0.5ⁿ
/// let tf = DiscreteTf::new(vec![1.0], vec![1.0, -0.5]).unwrap();
/// let mut filt = IirFilter::new(&tf);
/// let h: Vec<f64> = (0..4).map(|n| filt.step(if n == 0 { 1.0 } else { 0.0 })).collect();
/// assert_eq!(h, [1.0, 0.5, 0.25, 0.125]);
/// filt.reset();
/// assert_eq!(filt.step(2.0), 2.0);
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct IirFilter {
    b: Vec<f64>,
    a: Vec<f64>,
    state: Vec<f64>,
}

impl IirFilter {
    /// A filter for `tf` with zero initial state.
    pub fn new(tf: &DiscreteTf) -> Self {
        let (b, a) = padded(tf);
        let n = a.len() - 1;
        Self {
            b,
            a,
            state: vec![0.0; n],
        }
    }

    /// Feeds one input sample and returns the output sample of the same instant
    /// (`b[0]` is the direct feed-through).
    #[inline]
    pub fn step(&mut self, x: f64) -> f64 {
        let y = self.b[0] * x + self.state.first().copied().unwrap_or(0.0);
        let n = self.state.len();
        for k in 0..n {
            let next = if k + 1 < n { self.state[k + 1] } else { 0.0 };
            self.state[k] = next + self.b[k + 1] * x - self.a[k + 1] * y;
        }
        y
    }

    /// Clears the state (back to rest).
    pub fn reset(&mut self) {
        self.state.iter_mut().for_each(|s| *s = 0.0);
    }

    /// The internal state, in the order of [`DiscreteTf::to_state_space`].
    pub fn state(&self) -> &[f64] {
        &self.state
    }
}

/// Zero-order-hold discretisation of `ẋ = A x + B u` with period `t` (input held constant over
/// each sample): `x[n+1] = Φ x[n] + Γ u[n]` with `Φ = e^{AT}`, `Γ = ∫₀ᵀ e^{Aτ} dτ B`.
///
/// Both come from one matrix exponential, `exp([[A, B], [0, 0]]·T) = [[Φ, Γ], [0, I]]`.
/// Returns `(Φ, Γ)`.
///
/// ```
/// use occam::lti::discrete::zoh;
/// use nalgebra::DMatrix;
/// // double integrator: Φ = [[1, T], [0, 1]], Γ = [T²/2, T]
/// let a = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, 0.0, 0.0]);
/// let b = DMatrix::from_row_slice(2, 1, &[0.0, 1.0]);
/// let (phi, gam) = zoh(&a, &b, 0.1).unwrap();
/// assert!((phi[(0, 1)] - 0.1).abs() < 1e-15 && (gam[(0, 0)] - 0.005).abs() < 1e-15);
/// ```
pub fn zoh(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    t: f64,
) -> Result<(DMatrix<f64>, DMatrix<f64>), LtiError> {
    let n = a.nrows();
    if a.ncols() != n || b.nrows() != n {
        return Err(LtiError::Invalid(format!(
            "zoh: A must be square and B must have as many rows as A (A is {}×{}, B is {}×{})",
            a.nrows(),
            a.ncols(),
            b.nrows(),
            b.ncols()
        )));
    }
    if !(t.is_finite() && t > 0.0) {
        return Err(LtiError::Invalid(format!(
            "zoh: sample period T = {t} s must be a positive finite number"
        )));
    }
    if a.iter().chain(b.iter()).any(|x| !x.is_finite()) {
        return Err(LtiError::Invalid(
            "zoh: A and B must have finite entries".into(),
        ));
    }
    let m = b.ncols();
    let mut aug = DMatrix::<f64>::zeros(n + m, n + m);
    aug.view_mut((0, 0), (n, n)).copy_from(&(a * t));
    aug.view_mut((0, n), (n, m)).copy_from(&(b * t));
    let e = aug.exp();
    Ok((
        e.view((0, 0), (n, n)).into_owned(),
        e.view((0, n), (n, m)).into_owned(),
    ))
}

/// `b` and `a` zero-padded to a common length (at least 1).
fn padded(tf: &DiscreteTf) -> (Vec<f64>, Vec<f64>) {
    let len = tf.b.len().max(tf.a.len());
    let mut b = tf.b.clone();
    let mut a = tf.a.clone();
    b.resize(len, 0.0);
    a.resize(len, 0.0);
    (b, a)
}

/// Product of two polynomials in ascending powers.
fn poly_mul_asc(p: &[f64], q: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; p.len() + q.len() - 1];
    for (i, &x) in p.iter().enumerate() {
        for (j, &y) in q.iter().enumerate() {
            out[i + j] += x * y;
        }
    }
    out
}

/// `Σ c_k wᵏ` by Horner's rule.
fn horner_asc(c: &[f64], w: Complex64) -> Complex64 {
    c.iter()
        .rev()
        .fold(Complex64::new(0.0, 0.0), |acc, &x| acc * w + x)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tustin_of_first_order_lag_matches_hand_derivation() {
        // 1/(s + a) with s = c(1 − w)/(1 + w): (1 + w)/((c + a) + (a − c) w)
        for (a, fs, prewarp) in [(3.0, 10.0, None), (0.2, 1.0, Some(0.1)), (50.0, 10.0, None)] {
            let h = Rational::new(vec![1.0], vec![1.0, a]).unwrap();
            let d = DiscreteTf::tustin(&h, fs, prewarp).unwrap();
            let c = match prewarp {
                None => 2.0 * fs,
                Some(fp) => {
                    let wp = 2.0 * PI * fp;
                    wp / (wp / (2.0 * fs)).tan()
                }
            };
            let want_b = [1.0 / (c + a), 1.0 / (c + a)];
            let want_a = [1.0, (a - c) / (c + a)];
            assert_eq!(d.a().len(), 2);
            for k in 0..2 {
                assert!((d.b()[k] - want_b[k]).abs() < 1e-15 * want_b[k].abs().max(1.0));
                assert!((d.a()[k] - want_a[k]).abs() < 1e-15);
            }
        }
    }

    #[test]
    fn tustin_error_is_second_order_in_omega_t() {
        // The bilinear map evaluates H at ω' = (2/T) tan(ωT/2) = ω(1 + (ωT)²/12 + …), so
        // H_d/H_c − 1 → (d ln H/d ln ω)(ωT)²/12 = −iω/(iω + a)·(ωT)²/12 as ωT → 0.
        let a = 2.0;
        let h = Rational::new(vec![5.0], vec![1.0, a]).unwrap();
        let f = 0.5;
        let w = 2.0 * PI * f;
        let lead = Complex64::new(0.0, -w) / Complex64::new(a, w) / 12.0;
        for fs in [50.0, 200.0, 1000.0, 5000.0] {
            let d = DiscreteTf::tustin(&h, fs, None).unwrap();
            let wt = w / fs;
            let err = d.eval_freq(f, fs) / h.eval_freq(f) - 1.0;
            let coef = err / (wt * wt);
            // next order: tan(x/2)·2/x = 1 + x²/12 + x⁴/120 + …, and the second-order Taylor
            // term of H(ω') adds ½|ω² H''/H|·(x²/12)² ≤ x⁴/144 for this H (|ω² H''/H| ≤ 2), so
            // |coef − lead| ≤ (1/120 + 1/144) x² < 0.016 x²; 1e−6 covers rounding divided by x²
            assert!(
                (coef - lead).norm() < 0.025 * wt * wt + 1e-6,
                "fs = {fs}: err/(ωT)² = {coef}, expected → {lead}"
            );
        }
    }

    #[test]
    fn prewarped_tustin_is_exact_at_the_prewarp_frequency() {
        let h = Rational::new(vec![0.6, 0.14, 0.006], vec![0.03, 0.48, 1.0, 0.0]).unwrap();
        let fs = 10.0;
        for fp in [0.01, 0.5, 3.0] {
            let d = DiscreteTf::tustin(&h, fs, Some(fp)).unwrap();
            let (hd, hc) = (d.eval_freq(fp, fs), h.eval_freq(fp));
            assert!((hd / hc - 1.0).norm() < 1e-12, "fp = {fp}: {hd} vs {hc}");
        }
    }

    #[test]
    fn tustin_rejects_bad_input() {
        let h = Rational::new(vec![1.0], vec![1.0, 1.0]).unwrap();
        assert!(DiscreteTf::tustin(&h, 0.0, None).is_err());
        assert!(DiscreteTf::tustin(&h, f64::NAN, None).is_err());
        assert!(DiscreteTf::tustin(&h, 10.0, Some(5.0)).is_err());
        let improper = Rational::new(vec![1.0, 0.0, 0.0], vec![1.0, 1.0]).unwrap();
        assert!(DiscreteTf::tustin(&improper, 10.0, None).is_err());
        // pole at s = 2 fs = 20 maps to z = ∞
        let bad = Rational::new(vec![1.0], vec![1.0, -20.0]).unwrap();
        assert!(DiscreteTf::tustin(&bad, 10.0, None).is_err());
        assert!(DiscreteTf::new(vec![1.0], vec![0.0, 1.0]).is_err());
        assert!(DiscreteTf::new(vec![], vec![1.0]).is_err());
    }

    #[test]
    fn zoh_of_double_integrator_is_the_closed_form() {
        let a = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, 0.0, 0.0]);
        let b = DMatrix::from_row_slice(2, 1, &[0.0, 1.0]);
        for t in [0.1, 1.0, 7.5] {
            let (phi, gam) = zoh(&a, &b, t).unwrap();
            let want_phi = DMatrix::from_row_slice(2, 2, &[1.0, t, 0.0, 1.0]);
            let want_gam = DMatrix::from_row_slice(2, 1, &[0.5 * t * t, t]);
            assert!((phi - want_phi).amax() < 1e-14 * t.max(1.0));
            assert!((gam - want_gam).amax() < 1e-14 * (t * t).max(1.0));
        }
    }

    #[test]
    fn zoh_of_first_order_system_is_the_closed_form() {
        // ẋ = −k x + u: Φ = e^{−kT}, Γ = (1 − e^{−kT})/k
        let (k, t) = (0.7, 0.3);
        let (phi, gam) = zoh(
            &DMatrix::from_element(1, 1, -k),
            &DMatrix::from_element(1, 1, 1.0),
            t,
        )
        .unwrap();
        assert!((phi[(0, 0)] - (-k * t).exp()).abs() < 1e-15);
        assert!((gam[(0, 0)] + (-k * t).exp_m1() / k).abs() < 1e-15);
        assert!(zoh(&DMatrix::zeros(2, 3), &DMatrix::zeros(2, 1), t).is_err());
        assert!(zoh(&DMatrix::zeros(2, 2), &DMatrix::zeros(2, 1), -1.0).is_err());
    }

    /// Power-series (long) division of `b(w)/a(w)`: the first `n` impulse-response samples.
    fn series_division(b: &[f64], a: &[f64], n: usize) -> Vec<f64> {
        let mut rem: Vec<f64> = b.to_vec();
        rem.resize(n + a.len(), 0.0);
        let mut q = Vec::with_capacity(n);
        for k in 0..n {
            let c = rem[k] / a[0];
            q.push(c);
            for (j, &aj) in a.iter().enumerate() {
                rem[k + j] -= c * aj;
            }
        }
        q
    }

    #[test]
    fn iir_impulse_response_is_the_series_division() {
        // a stable 3rd-order filter with a longer numerator than needed and a[0] ≠ 1
        let b = vec![0.4, -0.3, 0.25, 0.1];
        let a = vec![2.0, -2.2, 1.18, -0.216];
        let tf = DiscreteTf::new(b.clone(), a.clone()).unwrap();
        let want = series_division(&b, &a, 200);
        let mut filt = IirFilter::new(&tf);
        for (n, w) in want.iter().enumerate() {
            let y = filt.step(if n == 0 { 1.0 } else { 0.0 });
            assert!((y - w).abs() < 1e-14, "n = {n}: {y} vs {w}");
        }
        // reset restores rest: the impulse response starts again
        filt.reset();
        assert!(filt.state().iter().all(|&s| s == 0.0));
        assert!((filt.step(1.0) - want[0]).abs() < 1e-15);
        assert!((filt.step(0.0) - want[1]).abs() < 1e-15);
    }

    #[test]
    fn state_space_realisation_tracks_the_filter() {
        let tf = DiscreteTf::new(vec![0.5, 0.2, -0.1], vec![1.0, -0.9, 0.2]).unwrap();
        let ss = tf.to_state_space();
        let mut filt = IirFilter::new(&tf);
        let mut xi = nalgebra::DVector::<f64>::zeros(2);
        for n in 0..50 {
            let x = (0.37 * n as f64).sin() + 0.1;
            let y_ss = (&ss.c * &xi)[0] + ss.d * x;
            xi = &ss.a * &xi + &ss.b * x;
            let y = filt.step(x);
            assert!((y - y_ss).abs() < 1e-14);
            for (s, t) in filt.state().iter().zip(xi.iter()) {
                assert!((s - t).abs() < 1e-14);
            }
        }
        // and its transfer function is the same H(z)
        let z = Complex64::from_polar(1.0, 0.8);
        let m = DMatrix::<Complex64>::from_fn(2, 2, |i, j| {
            let id = if i == j { z } else { Complex64::new(0.0, 0.0) };
            id - ss.a[(i, j)]
        });
        let v = m.lu().solve(&ss.b.map(|x| Complex64::new(x, 0.0))).unwrap();
        let h = v[0] * ss.c[0] + v[1] * ss.c[1] + ss.d;
        assert!((h - tf.eval_z(z)).norm() < 1e-14);
    }
}
