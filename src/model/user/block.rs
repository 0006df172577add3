//! Transfer-function blocks of user-defined models, evaluated at `s = i2πf`.

use super::real::RealExpr;
use num_complex::Complex;
use num_dual::DualNum;
use std::f64::consts::PI;

/// Largest `|n|` of an `s_power` block.
pub const MAX_S_POWER: i32 = 16;

/// Most real fields of one block (the coefficients of a `rational` block, numerator and
/// denominator together).
pub const MAX_FIELDS: usize = 64;

/// A compiled block.
#[derive(Debug, Clone)]
pub enum Block {
    /// A real gain.
    Gain(RealExpr),
    /// `e^{−sτ}`.
    Delay(RealExpr),
    /// `1/(1 + s/(2π f))`.
    Pole(RealExpr),
    /// `1 + s/(2π f)`.
    Zero(RealExpr),
    /// `ω0²/(s² + s ω0/q + ω0²)`, `ω0 = 2π f`.
    ComplexPole { f: RealExpr, q: RealExpr },
    /// `s^n`.
    SPower(i32),
    /// `N(s)/D(s)`, coefficients in descending powers.
    Rational {
        num: Vec<RealExpr>,
        den: Vec<RealExpr>,
    },
}

/// A root of the polynomial with coefficients `c` (descending powers) whose real part is
/// positive (beyond rounding), if any: the roots are the eigenvalues of its companion matrix.
/// Roots at zero (integrators, trailing zero coefficients) are stable enough: the loop around
/// them decides.
fn unstable_root(c: &[f64]) -> Option<num_complex::Complex64> {
    let first = c.iter().position(|x| *x != 0.0)?;
    let last = c.iter().rposition(|x| *x != 0.0)?;
    let c = &c[first..=last];
    let n = c.len() - 1;
    if n == 0 {
        return None;
    }
    let mut m = nalgebra::DMatrix::<f64>::zeros(n, n);
    for j in 0..n {
        m[(0, j)] = -c[j + 1] / c[0];
    }
    for i in 1..n {
        m[(i, i - 1)] = 1.0;
    }
    // coefficients spanning more than the solver can square: no verdict rather than nonsense
    if m.iter().any(|x| !(x.abs() <= 1e150)) {
        return None;
    }
    m.complex_eigenvalues()
        .iter()
        .find(|z| z.re > 1e-9 * z.norm())
        .map(|z| num_complex::Complex64::new(z.re, z.im))
}

impl Block {
    /// The real fields with their names (for messages), in declaration order.
    pub fn fields(&self) -> Vec<(String, &RealExpr)> {
        match self {
            Block::Gain(v) => vec![("value".into(), v)],
            Block::Delay(v) => vec![("tau".into(), v)],
            Block::Pole(v) | Block::Zero(v) => vec![("f".into(), v)],
            Block::ComplexPole { f, q } => vec![("f".into(), f), ("q".into(), q)],
            Block::SPower(_) => vec![],
            Block::Rational { num, den } => num
                .iter()
                .enumerate()
                .map(|(i, v)| (format!("num[{i}]"), v))
                .chain(
                    den.iter()
                        .enumerate()
                        .map(|(i, v)| (format!("den[{i}]"), v)),
                )
                .collect(),
        }
    }

    /// Whether no field depends on θ (then the block is a per-bin constant).
    pub fn is_const(&self) -> bool {
        self.fields().iter().all(|(_, v)| v.constant().is_some())
    }

    /// Indices of the parameters the block reads.
    pub fn params(&self) -> Vec<usize> {
        self.fields().iter().flat_map(|(_, v)| v.params()).collect()
    }

    /// Checks the field values that are known (`value(field)` is `None` for a field not known
    /// yet, e.g. a θ-dependent one at construction): what is impossible. Returns the offending
    /// field and why.
    pub fn check_values(
        &self,
        value: &dyn Fn(&RealExpr) -> Option<f64>,
    ) -> Result<(), (String, String)> {
        for (name, v) in self.fields() {
            if let Some(x) = value(v)
                && !x.is_finite()
            {
                return Err((name, format!("is {x}, not a finite number")));
            }
        }
        let need = |name: &str, v: &RealExpr, ok: fn(f64) -> bool, what: &str| match value(v) {
            Some(x) if !ok(x) => Err((name.to_string(), format!("is {x}; {what}"))),
            _ => Ok(()),
        };
        match self {
            Block::Gain(_) | Block::SPower(_) => Ok(()),
            Block::Delay(t) => need("tau", t, |x| x >= 0.0, "a delay must be ≥ 0 s"),
            Block::Pole(f) => need("f", f, |x| x > 0.0, "a pole frequency must be > 0 Hz"),
            Block::Zero(f) => need("f", f, |x| x != 0.0, "a zero frequency must be non-zero"),
            Block::ComplexPole { f, q } => {
                need("f", f, |x| x > 0.0, "a pole frequency must be > 0 Hz")?;
                need("q", q, |x| x > 0.0, "a quality factor must be > 0")
            }
            Block::Rational { den, .. } => {
                if den.iter().all(|d| value(d) == Some(0.0)) {
                    return Err((
                        "den".into(),
                        "is identically zero; a denominator needs a non-zero coefficient".into(),
                    ));
                }
                let known: Option<Vec<f64>> = den.iter().map(value).collect();
                match known.as_deref().and_then(unstable_root) {
                    Some(z) => Err((
                        "den".into(),
                        format!(
                            "has the root s = {:.6e} {} {:.6e}i with a positive real part: the \
                             block is unstable on its own (a pole block refuses a negative \
                             frequency likewise), and the frequency-domain likelihood and \
                             simulation hold only for a stable loop; check the signs of `den` \
                             (coefficients of descending powers of s)",
                            z.re,
                            if z.im < 0.0 { "−" } else { "+" },
                            z.im.abs()
                        ),
                    )),
                    None => Ok(()),
                }
            }
        }
    }

    /// Number of real fields, the length of [`Block::field_values`].
    pub fn n_fields(&self) -> usize {
        match self {
            Block::SPower(_) => 0,
            Block::Gain(_) | Block::Delay(_) | Block::Pole(_) | Block::Zero(_) => 1,
            Block::ComplexPole { .. } => 2,
            Block::Rational { num, den } => num.len() + den.len(),
        }
    }

    /// The real fields' values at θ into `out` (length [`Block::n_fields`]), in the order of
    /// [`Block::fields`]: what the response needs of θ, computed once per θ by the compiled
    /// kernel rather than once per bin.
    #[inline]
    pub fn field_values<T: DualNum<Primitive = f64> + Copy>(&self, th: &[T], out: &mut [T]) {
        match self {
            Block::SPower(_) => {}
            Block::Gain(v) | Block::Delay(v) | Block::Pole(v) | Block::Zero(v) => {
                out[0] = v.eval(th)
            }
            Block::ComplexPole { f, q } => {
                out[0] = f.eval(th);
                out[1] = q.eval(th);
            }
            Block::Rational { num, den } => {
                for (o, a) in out.iter_mut().zip(num.iter().chain(den)) {
                    *o = a.eval(th);
                }
            }
        }
    }

    /// The response at frequency `f` (Hz), generic over dual numbers.
    #[inline]
    pub fn eval<T: DualNum<Primitive = f64> + Copy>(&self, th: &[T], f: f64) -> Complex<T> {
        let mut vals = [T::zero(); MAX_FIELDS];
        let n = self.n_fields();
        self.field_values(th, &mut vals[..n]);
        self.response(&vals[..n], f)
    }

    /// The response at frequency `f` (Hz) from the field values `v` ([`Block::field_values`]).
    #[inline]
    pub fn response<T: DualNum<Primitive = f64> + Copy>(&self, v: &[T], f: f64) -> Complex<T> {
        let w = 2.0 * PI * f;
        match self {
            Block::Gain(_) => Complex::new(v[0], T::zero()),
            Block::Delay(_) => {
                let (s, c) = (v[0] * w).sin_cos();
                Complex::new(c, -s)
            }
            Block::Pole(_) => {
                // 1/(1 + i u) = (1 − i u)/(1 + u²), u = f/f0
                let u = v[0].recip() * f;
                let d = (u * u + 1.0).recip();
                Complex::new(d, -u * d)
            }
            Block::Zero(_) => Complex::new(T::one(), v[0].recip() * f),
            Block::ComplexPole { .. } => {
                let w0 = v[0] * (2.0 * PI);
                let w02 = w0 * w0;
                let den = Complex::new(w02 - w * w, w0 * w / v[1]);
                den.inv() * w02
            }
            Block::SPower(n) => {
                let m = w.powi(*n);
                let v = match n.rem_euclid(4) {
                    0 => (m, 0.0),
                    1 => (0.0, m),
                    2 => (-m, 0.0),
                    _ => (0.0, -m),
                };
                Complex::new(T::from(v.0), T::from(v.1))
            }
            Block::Rational { num, .. } => {
                let horner = |c: &[T]| {
                    let mut acc = Complex::new(T::zero(), T::zero());
                    for &a in c {
                        // acc·(iω) + a
                        acc = Complex::new(-acc.im * w + a, acc.re * w);
                    }
                    acc
                };
                let (n, d) = v.split_at(num.len());
                horner(n) / horner(d)
            }
        }
    }
}
