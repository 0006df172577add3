//! Rational transfer functions `N(s)/D(s)` with real coefficients.

use num_complex::Complex64;
use serde::{Deserialize, Serialize};

/// Errors building a transfer function.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum LtiError {
    #[error("transfer function: {0}")]
    Invalid(String),
}

/// A rational transfer function with real polynomial coefficients in *descending* powers of `s`
/// (the MATLAB/scipy convention): `[1, 2, 3]` is `s² + 2s + 3`.
///
/// ```
/// use occam::lti::Rational;
/// use num_complex::Complex64;
/// // 1/(s + 1) at s = i: 1/(1 + i) = (1 − i)/2
/// let h = Rational::new(vec![1.0], vec![1.0, 1.0]).unwrap();
/// let v = h.eval(Complex64::new(0.0, 1.0));
/// assert!((v - Complex64::new(0.5, -0.5)).norm() < 1e-15);
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Rational {
    num: Vec<f64>,
    den: Vec<f64>,
}

impl Rational {
    /// Validates: non-empty, finite coefficients, a denominator that is not identically zero.
    /// Leading zeros are stripped.
    pub fn new(num: Vec<f64>, den: Vec<f64>) -> Result<Self, LtiError> {
        let strip = |v: Vec<f64>| -> Vec<f64> {
            let first = v.iter().position(|&c| c != 0.0).unwrap_or(v.len());
            v[first..].to_vec()
        };
        if num.iter().chain(&den).any(|c| !c.is_finite()) {
            return Err(LtiError::Invalid(
                "coefficients must be finite numbers".into(),
            ));
        }
        let num = strip(num);
        let den = strip(den);
        if den.is_empty() {
            return Err(LtiError::Invalid(
                "the denominator is identically zero".into(),
            ));
        }
        let num = if num.is_empty() { vec![0.0] } else { num };
        Ok(Self { num, den })
    }

    /// A constant gain.
    pub fn gain(k: f64) -> Self {
        Self {
            num: vec![k],
            den: vec![1.0],
        }
    }

    /// Numerator coefficients (descending powers).
    pub fn num(&self) -> &[f64] {
        &self.num
    }

    /// Denominator coefficients (descending powers).
    pub fn den(&self) -> &[f64] {
        &self.den
    }

    /// Evaluates `N(s)/D(s)` at a complex `s` by Horner's rule.
    pub fn eval(&self, s: Complex64) -> Complex64 {
        horner(&self.num, s) / horner(&self.den, s)
    }

    /// Evaluates at `s = i2πf`.
    pub fn eval_freq(&self, f: f64) -> Complex64 {
        self.eval(Complex64::new(0.0, 2.0 * std::f64::consts::PI * f))
    }

    /// Series connection `self · other`.
    pub fn series(&self, other: &Rational) -> Rational {
        Rational {
            num: polymul(&self.num, &other.num),
            den: polymul(&self.den, &other.den),
        }
    }

    /// Negative feedback `G/(1 + G·H)` with `G = self` in the forward path and `H` in the
    /// feedback path.
    pub fn feedback(&self, h: &Rational) -> Rational {
        // G/(1+GH) = Ng Dh / (Dg Dh + Ng Nh)
        let num = polymul(&self.num, &h.den);
        let den = polyadd(&polymul(&self.den, &h.den), &polymul(&self.num, &h.num));
        Rational { num, den }
    }

    /// Roots of the denominator (the poles), by the eigenvalues of the companion matrix.
    pub fn poles(&self) -> Vec<Complex64> {
        poly_roots(&self.den)
    }
}

/// The frequency response `e^{−i2πfτ}` of a pure delay `τ` (seconds).
pub fn delay(tau: f64, f: f64) -> Complex64 {
    Complex64::from_polar(1.0, -2.0 * std::f64::consts::PI * f * tau)
}

fn horner(c: &[f64], s: Complex64) -> Complex64 {
    let mut acc = Complex64::new(0.0, 0.0);
    for &a in c {
        acc = acc * s + a;
    }
    acc
}

/// Product of two polynomials in descending powers.
pub(crate) fn polymul(a: &[f64], b: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; a.len() + b.len() - 1];
    for (i, &x) in a.iter().enumerate() {
        for (j, &y) in b.iter().enumerate() {
            out[i + j] += x * y;
        }
    }
    out
}

/// Sum of two polynomials in descending powers (aligned on the constant term).
pub(crate) fn polyadd(a: &[f64], b: &[f64]) -> Vec<f64> {
    let n = a.len().max(b.len());
    let mut out = vec![0.0; n];
    for (i, &x) in a.iter().enumerate() {
        out[n - a.len() + i] += x;
    }
    for (i, &y) in b.iter().enumerate() {
        out[n - b.len() + i] += y;
    }
    out
}

/// Roots of a real polynomial (descending powers) from its companion matrix.
pub(crate) fn poly_roots(c: &[f64]) -> Vec<Complex64> {
    let first = c.iter().position(|&x| x != 0.0).unwrap_or(c.len());
    let c = &c[first..];
    if c.len() < 2 {
        return Vec::new();
    }
    let n = c.len() - 1;
    let mut m = nalgebra::DMatrix::<f64>::zeros(n, n);
    for j in 0..n {
        m[(0, j)] = -c[j + 1] / c[0];
    }
    for i in 1..n {
        m[(i, i - 1)] = 1.0;
    }
    m.complex_eigenvalues()
        .iter()
        .map(|z| Complex64::new(z.re, z.im))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn feedback_of_integrator_is_first_order_lag() {
        // 1/s with unity feedback = 1/(s + 1)
        let g = Rational::new(vec![1.0], vec![1.0, 0.0]).unwrap();
        let cl = g.feedback(&Rational::gain(1.0));
        let s = Complex64::new(0.3, 1.7);
        assert!((cl.eval(s) - 1.0 / (s + 1.0)).norm() < 1e-15);
        let p = cl.poles();
        assert_eq!(p.len(), 1);
        assert!((p[0] + 1.0).norm() < 1e-14);
    }

    #[test]
    fn series_multiplies_responses() {
        let a = Rational::new(vec![2.0, 1.0], vec![1.0, 3.0, 2.0]).unwrap();
        let b = Rational::new(vec![1.0, -1.0], vec![4.0, 1.0]).unwrap();
        let s = Complex64::new(-0.2, 0.9);
        assert!((a.series(&b).eval(s) - a.eval(s) * b.eval(s)).norm() < 1e-14);
    }

    #[test]
    fn rejects_bad_coefficients() {
        assert!(Rational::new(vec![1.0], vec![0.0, 0.0]).is_err());
        assert!(Rational::new(vec![f64::NAN], vec![1.0]).is_err());
    }

    #[test]
    fn roots_of_quadratic() {
        // (s+1)(s+2)
        let mut r: Vec<f64> = poly_roots(&[1.0, 3.0, 2.0]).iter().map(|z| z.re).collect();
        r.sort_by(f64::total_cmp);
        assert!((r[0] + 2.0).abs() < 1e-12 && (r[1] + 1.0).abs() < 1e-12);
    }
}

/// A continuous-time state-space realisation `ẋ = A x + B u`, `y = C x + D u` of a single-input
/// single-output system.
#[derive(Debug, Clone, PartialEq)]
pub struct StateSpace {
    pub a: nalgebra::DMatrix<f64>,
    pub b: nalgebra::DVector<f64>,
    pub c: nalgebra::RowDVector<f64>,
    pub d: f64,
}

impl Rational {
    /// Controllable-canonical realisation. Fails for an improper function (numerator degree
    /// above the denominator's), which has no state-space form.
    pub fn to_state_space(&self) -> Result<StateSpace, LtiError> {
        let n = self.den.len() - 1;
        if self.num.len() > self.den.len() {
            return Err(LtiError::Invalid(
                "improper transfer function (numerator degree above denominator degree)".into(),
            ));
        }
        let a0 = self.den[0];
        let den: Vec<f64> = self.den.iter().map(|c| c / a0).collect();
        let mut num = vec![0.0; n + 1];
        let off = n + 1 - self.num.len();
        for (i, &c) in self.num.iter().enumerate() {
            num[off + i] = c / a0;
        }
        let d = num[0];
        let mut a = nalgebra::DMatrix::zeros(n, n);
        let mut b = nalgebra::DVector::zeros(n);
        let mut c = nalgebra::RowDVector::zeros(n);
        if n > 0 {
            for j in 0..n {
                a[(0, j)] = -den[j + 1];
                // strictly proper part: num − d·den
                c[j] = num[j + 1] - d * den[j + 1];
            }
            for i in 1..n {
                a[(i, i - 1)] = 1.0;
            }
            b[0] = 1.0;
        }
        Ok(StateSpace { a, b, c, d })
    }
}

#[cfg(test)]
mod ss_tests {
    use super::*;

    #[test]
    fn state_space_reproduces_transfer_function() {
        let h = Rational::new(vec![0.6, 0.14, 0.006], vec![0.03, 0.48, 1.0, 0.0]).unwrap();
        let g = Rational::new(vec![6e-3, 1.4e-5, 6e-9], vec![39.8, 1.0, 0.0]).unwrap();
        for tf in [h, g] {
            let ss = tf.to_state_space().unwrap();
            for f in [1e-4, 1e-2, 0.3, 2.0] {
                let s = Complex64::new(0.0, 2.0 * std::f64::consts::PI * f);
                let n = ss.a.nrows();
                let m = nalgebra::DMatrix::<Complex64>::from_fn(n, n, |i, j| {
                    let e = if i == j { s } else { Complex64::new(0.0, 0.0) };
                    e - ss.a[(i, j)]
                });
                let b = ss.b.map(|x| Complex64::new(x, 0.0));
                let x = m.lu().solve(&b).unwrap();
                let y: Complex64 = (0..n).map(|i| x[i] * ss.c[i]).sum::<Complex64>() + ss.d;
                let want = tf.eval(s);
                assert!((y - want).norm() < 1e-9 * want.norm(), "{f}: {y} vs {want}");
            }
        }
    }
}
