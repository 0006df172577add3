//! Is the closed loop stable at θ? The characteristic polynomial of the loop, with the
//! controllers, the OMS delay, a thruster response and a TM2 actuator's dynamics, and its
//! Routh–Hurwitz test: a few hundred flops and no allocation, cheap enough to be asked at
//! every likelihood evaluation (an eigenvalue decomposition of the loop's state matrix costs
//! more than the likelihood itself).
//!
//! # Formula
//! The loop `s² x + W x + B(s) u = 0`, `u = K(s) E(s) S x` (ltp-model.md §3, the state matrix of
//! [`closed_loop_poles`](super::closed_loop_poles)) is stable when every root of
//! `det(s² I + W + B K E S)` has a negative real part. With `S` unit lower triangular,
//! `det(X) = det(X S⁻¹)`, and each channel's loop factor `F_ch = C_ch E R_ch = n_ch / d_ch`
//! (controller, OMS delay, actuation response `R`: the thruster's on `df`, TM2's actuator's on
//! `sus`) scales one column of `B K E`; clearing the denominators column by column gives the
//! polynomial
//!
//! `P(s) = det [ G_{:,df} d_df + B⁰_{:,df} n_df | G_{:,sus} d_sus + B⁰_{:,sus} n_sus ]`,
//! `G = (s² I + W) S⁻¹`, `B⁰ = [[A_df, e2 A_sus], [0, A_sus]]`,
//!
//! of degree 9 for the plain loop (its 9 states). Delays enter as Padé approximants of order
//! [`PADE_ORDER`] (phase error below 10⁻⁴ rad up to `ωτ = 1`, where the loop's margins lie for
//! delays up to a second).

use super::controllers::Controllers;
use super::params::{Masses, N_PARAMS};
use crate::lti::Rational;

/// Order of the Padé approximants of delays.
pub const PADE_ORDER: usize = 3;
/// Most coefficients a loop polynomial holds (degree 9, plus 3 per delay and 1 per pole).
const CAP: usize = 32;

/// A real polynomial, ascending powers of `s`, at most 32 coefficients, on the stack.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Poly {
    c: [f64; CAP],
    n: usize,
}

impl Poly {
    /// The polynomial with coefficients `c` (ascending powers).
    pub fn new(c: &[f64]) -> Self {
        assert!(c.len() <= CAP, "a loop polynomial of degree {}", c.len());
        let mut p = Poly {
            c: [0.0; CAP],
            n: c.len(),
        };
        p.c[..c.len()].copy_from_slice(c);
        p
    }

    /// The constant `a`.
    pub fn constant(a: f64) -> Self {
        Self::new(&[a])
    }

    /// The coefficients, ascending.
    pub fn coefficients(&self) -> &[f64] {
        &self.c[..self.n]
    }

    /// `self · other`.
    pub fn mul(&self, other: &Poly) -> Poly {
        if self.n == 0 || other.n == 0 {
            return Poly::new(&[]);
        }
        let n = self.n + other.n - 1;
        assert!(n <= CAP, "a loop polynomial of degree {n}");
        let mut c = [0.0; CAP];
        for i in 0..self.n {
            for j in 0..other.n {
                c[i + j] += self.c[i] * other.c[j];
            }
        }
        Poly { c, n }
    }

    /// `self + other`.
    pub fn add(&self, other: &Poly) -> Poly {
        let n = self.n.max(other.n);
        let mut c = [0.0; CAP];
        for (i, x) in c.iter_mut().enumerate().take(n) {
            *x = self.c[i] + other.c[i];
        }
        Poly { c, n }
    }

    /// `a · self`.
    pub fn scale(&self, a: f64) -> Poly {
        let mut p = *self;
        p.c[..p.n].iter_mut().for_each(|x| *x *= a);
        p
    }

    /// `(n, d)` of a rational function whose coefficients are in descending powers.
    fn of_rational(r: &Rational) -> (Poly, Poly) {
        let asc = |v: &[f64]| Poly::new(&v.iter().rev().copied().collect::<Vec<_>>());
        (asc(r.num()), asc(r.den()))
    }
}

/// The Padé approximant `e^{−sτ} ≈ n(s)/d(s)` of order [`PADE_ORDER`]: `d(s) = Σ c_k (sτ)^k`,
/// `n(s) = d(−s)`, `c_k = (2N−k)! N! / ((2N)! k! (N−k)!)`; `(1, 1)` for `τ = 0`.
pub fn pade_delay(tau: f64) -> (Poly, Poly) {
    if tau == 0.0 {
        return (Poly::constant(1.0), Poly::constant(1.0));
    }
    let n = PADE_ORDER;
    let fact = |k: usize| (1..=k).map(|i| i as f64).product::<f64>();
    let mut d = [0.0; PADE_ORDER + 1];
    let mut num = [0.0; PADE_ORDER + 1];
    for k in 0..=n {
        let ck = fact(2 * n - k) * fact(n) / (fact(2 * n) * fact(k) * fact(n - k));
        d[k] = ck * tau.powi(k as i32);
        num[k] = if k % 2 == 0 { d[k] } else { -d[k] };
    }
    (Poly::new(&num), Poly::new(&d))
}

/// The response of an actuation path beyond its gain: a real pole (Hz), a delay (s).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Actuation {
    /// A real pole `1/(1 + s/(2π f))`.
    pub pole: Option<f64>,
    /// A delay `e^{−sτ}`.
    pub delay: f64,
}

impl Actuation {
    /// `(n, d)` of the response.
    fn polys(&self) -> (Poly, Poly) {
        let (mut n, mut d) = pade_delay(self.delay);
        if let Some(f) = self.pole {
            // ω/(s + ω)
            let w = 2.0 * std::f64::consts::PI * f;
            n = n.scale(w);
            d = d.mul(&Poly::new(&[w, 1.0]));
        }
        (n, d)
    }
}

/// The fixed parts of the loop's characteristic polynomial, prepared once; then
/// [`LoopPolynomial::char_poly`] and [`LoopPolynomial::is_stable`] per θ.
#[derive(Debug, Clone, PartialEq)]
pub struct LoopPolynomial {
    /// `(n, d)` of `C_ch E R_ch` without a θ-dependent thruster response, per channel `[df, sus]`.
    fixed: [(Poly, Poly); 2],
    e1: f64,
    e2: f64,
}

impl LoopPolynomial {
    /// The loop with controllers `ctrl`, masses `m`, OMS delay `oms_delay` (s) and fixed
    /// actuation responses `[df, sus]` beyond the gains.
    pub fn new(ctrl: &Controllers, m: &Masses, oms_delay: f64, fixed: [Actuation; 2]) -> Self {
        let (en, ed) = pade_delay(oms_delay);
        let part = |c: &Rational, a: &Actuation| {
            let (cn, cd) = Poly::of_rational(c);
            let (an, ad) = a.polys();
            (cn.mul(&en).mul(&an), cd.mul(&ed).mul(&ad))
        };
        LoopPolynomial {
            fixed: [part(&ctrl.df, &fixed[0]), part(&ctrl.sus, &fixed[1])],
            e1: m.m1 / m.msc,
            e2: m.m2 / m.msc,
        }
    }

    /// `P(s)` at the seven loop parameters `th` (order of [`super::PARAM_NAMES`]) with an extra
    /// thruster response `thruster` on the drag-free path.
    pub fn char_poly(&self, th: &[f64; N_PARAMS], thruster: &Actuation) -> Poly {
        let [w1, w2, _, _, a_df, a_sus, d21] = *th;
        let (e1, e2) = (self.e1, self.e2);
        let w = [[w1 * (1.0 + e1) + e2 * w2, e2 * w2], [w2 - w1, w2]];
        // G = (s² I + W) S⁻¹, S⁻¹ = [[1, 0], [−δ21, 1]]
        let s2 = |c: f64| Poly::new(&[c, 0.0, 1.0]);
        let g = [
            [s2(w[0][0] - d21 * w[0][1]), Poly::constant(w[0][1])],
            [
                Poly::new(&[w[1][0] - d21 * w[1][1], 0.0, -d21]),
                s2(w[1][1]),
            ],
        ];
        let b0 = [[a_df, e2 * a_sus], [0.0, a_sus]];
        let (tn, td) = thruster.polys();
        let (n_df, d_df) = (self.fixed[0].0.mul(&tn), self.fixed[0].1.mul(&td));
        let (n_sus, d_sus) = self.fixed[1];
        let col =
            |i: usize, ch: usize, n: &Poly, d: &Poly| g[i][ch].mul(d).add(&n.scale(b0[i][ch]));
        let y00 = col(0, 0, &n_df, &d_df);
        let y10 = col(1, 0, &n_df, &d_df);
        let y01 = col(0, 1, &n_sus, &d_sus);
        let y11 = col(1, 1, &n_sus, &d_sus);
        y00.mul(&y11).add(&y01.mul(&y10).scale(-1.0))
    }

    /// Whether every root of [`LoopPolynomial::char_poly`] has a negative real part.
    pub fn is_stable(&self, th: &[f64; N_PARAMS], thruster: &Actuation) -> bool {
        hurwitz(&self.char_poly(th, thruster))
    }
}

/// Routh–Hurwitz: whether every root of `p` has a negative real part. A zero in the first
/// column (a root on the imaginary axis, or a symmetric pair) counts as unstable, as does a
/// non-finite coefficient. The polynomial is first rescaled, `s = ω₀ σ` with `ω₀` the
/// geometric mean of the roots' magnitudes, so that its coefficients are of one order.
pub fn hurwitz(p: &Poly) -> bool {
    let c = p.coefficients();
    // drop vanishing leading coefficients (exact zeros only)
    let mut n = c.len();
    while n > 0 && c[n - 1] == 0.0 {
        n -= 1;
    }
    if n == 0 || c[..n].iter().any(|x| !x.is_finite()) {
        return false;
    }
    let deg = n - 1;
    if deg == 0 {
        return true;
    }
    if c[0] == 0.0 {
        return false; // a root at s = 0
    }
    let w0 = (c[0] / c[deg]).abs().powf(1.0 / deg as f64);
    let mut a = [0.0; CAP];
    let mut scale = 1.0;
    for k in 0..n {
        a[k] = c[k] * scale;
        scale *= w0;
    }
    // descending powers, normalised, positive leading coefficient
    let lead = a[deg];
    let mut d = [0.0; CAP];
    for k in 0..n {
        d[k] = a[deg - k] / lead;
    }
    // every coefficient of a Hurwitz polynomial has the leading one's sign
    if d[..n].iter().any(|&x| x <= 0.0) {
        return false;
    }
    // the Routh array, two rows at a time
    let mut r0 = [0.0; CAP];
    let mut r1 = [0.0; CAP];
    let (mut l0, mut l1) = (0, 0);
    for (k, &x) in d[..n].iter().enumerate() {
        if k % 2 == 0 {
            r0[l0] = x;
            l0 += 1;
        } else {
            r1[l1] = x;
            l1 += 1;
        }
    }
    for _ in 0..deg {
        if r1[0] <= 0.0 || !r1[0].is_finite() {
            return false;
        }
        let mut next = [0.0; CAP];
        let len = l0.max(l1);
        for j in 0..len.saturating_sub(1) {
            next[j] = (r1[0] * r0[j + 1] - r0[0] * r1[j + 1]) / r1[0];
        }
        r0 = r1;
        l0 = l1;
        r1 = next;
        l1 = len.saturating_sub(1);
        if l1 == 0 {
            break;
        }
    }
    true
}

/// The roots of `p` from its companion matrix: for messages and as the tests' oracle (an
/// eigenvalue decomposition; never on the hot path). Empty for a constant.
pub fn roots(p: &Poly) -> Vec<num_complex::Complex64> {
    let c = p.coefficients();
    let Some(deg) = c.iter().rposition(|&x| x != 0.0) else {
        return Vec::new();
    };
    if deg == 0 || c.iter().any(|x| !x.is_finite()) {
        return Vec::new();
    }
    let mut m = nalgebra::DMatrix::<f64>::zeros(deg, deg);
    for i in 1..deg {
        m[(i, i - 1)] = 1.0;
    }
    for i in 0..deg {
        m[(i, deg - 1)] = -c[i] / c[deg];
    }
    m.complex_eigenvalues()
        .iter()
        .map(|z| num_complex::Complex64::new(z.re, z.im))
        .collect()
}

/// The root of `p` with the largest real part (`None` for a constant or a non-finite `p`).
pub fn rightmost_root(p: &Poly) -> Option<num_complex::Complex64> {
    roots(p).into_iter().max_by(|a, b| a.re.total_cmp(&b.re))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ltp::{LtpParams, closed_loop_poles};
    use num_complex::Complex64;

    fn sorted(mut v: Vec<Complex64>) -> Vec<Complex64> {
        v.sort_by(|a, b| (a.re, a.im).partial_cmp(&(b.re, b.im)).unwrap());
        v
    }

    #[test]
    fn hurwitz_knows_stable_and_unstable_polynomials() {
        // (s + 1)(s + 2)(s + 3) and (s − 1)(s + 2)(s + 3)
        assert!(hurwitz(&Poly::new(&[6.0, 11.0, 6.0, 1.0])));
        assert!(!hurwitz(&Poly::new(&[-6.0, 1.0, 4.0, 1.0])));
        // s² + 1: roots on the axis
        assert!(!hurwitz(&Poly::new(&[1.0, 0.0, 1.0])));
        // (s² + 0.1 s + 4)(s + 1)² stable; (s² − 0.1 s + 4)(s + 1)², all coefficients positive,
        // is not (only the array sees it)
        let q = Poly::new(&[1.0, 2.0, 1.0]);
        assert!(hurwitz(&Poly::new(&[4.0, 0.1, 1.0]).mul(&q)));
        let bad = Poly::new(&[4.0, -0.1, 1.0]).mul(&q);
        assert!(bad.coefficients().iter().all(|&x| x > 0.0));
        assert!(!hurwitz(&bad));
        assert!(!hurwitz(&Poly::new(&[f64::NAN, 1.0])));
        assert!(hurwitz(&Poly::new(&[2.0, 1.0])));
    }

    #[test]
    fn the_plain_loop_polynomial_has_the_state_matrix_poles() {
        let lp = LoopPolynomial::new(
            &Controllers::default(),
            &Masses::default(),
            0.0,
            Default::default(),
        );
        let p = LtpParams::default();
        let poly = lp.char_poly(&p.to_array(), &Actuation::default());
        assert_eq!(
            poly.coefficients().len(),
            10,
            "degree 9: the loop's 9 states"
        );
        // every pole of the state matrix is a root: |P(λ)| against the size of its terms (the
        // roots themselves, from the coefficients, are ill-conditioned: the slow ones cluster
        // within a decade)
        let poles = closed_loop_poles(&p, &Controllers::default(), &Masses::default()).unwrap();
        assert_eq!(poles.len(), 9);
        for z in &poles {
            let (mut v, mut size, mut zk) =
                (Complex64::new(0.0, 0.0), 0.0, Complex64::new(1.0, 0.0));
            for &c in poly.coefficients() {
                v += zk * c;
                size += c.abs() * zk.norm();
                zk *= z;
            }
            assert!(v.norm() < 1e-7 * size, "P({z}) = {v} of terms {size}");
        }
        // and the companion roots are those poles to the digits the clustering leaves
        let a = sorted(roots(&poly));
        let b = sorted(poles);
        for (x, y) in a.iter().zip(&b) {
            assert!((x - y).norm() < 1e-3 * y.norm(), "{x} vs {y}");
        }
        assert!(lp.is_stable(&p.to_array(), &Actuation::default()));
    }

    #[test]
    fn routh_hurwitz_agrees_with_the_state_matrix_over_a_wide_box() {
        // 3000 draws over boxes far wider than any study's, stable and unstable alike
        let lp = LoopPolynomial::new(
            &Controllers::default(),
            &Masses::default(),
            0.0,
            Default::default(),
        );
        use rand::{RngExt, SeedableRng};
        let mut rng = rand::rngs::StdRng::seed_from_u64(5);
        let mut u = |lo: f64, hi: f64| lo + (hi - lo) * rng.random::<f64>();
        let (mut stable, mut unstable, mut close) = (0, 0, 0);
        for _ in 0..3000 {
            let p = LtpParams {
                w1sq: u(-2e-5, 2e-5),
                w2sq: u(-2e-5, 2e-5),
                dt1: 0.2,
                dt2: 0.2,
                a_df: u(-0.5, 4.0),
                a_sus: u(-0.5, 4.0),
                d21: u(-0.5, 0.5),
            };
            let poles = closed_loop_poles(&p, &Controllers::default(), &Masses::default()).unwrap();
            let worst = poles
                .iter()
                .map(|z| z.re / z.norm())
                .fold(f64::MIN, f64::max);
            let truth = worst < 0.0;
            let rh = lp.is_stable(&p.to_array(), &Actuation::default());
            if worst.abs() < 1e-7 {
                close += 1;
                continue;
            }
            assert_eq!(rh, truth, "{p:?}: worst Re/|z| = {worst}");
            if truth { stable += 1 } else { unstable += 1 }
        }
        assert!(
            stable > 300 && unstable > 300,
            "{stable} / {unstable} / {close}"
        );
    }

    #[test]
    fn a_slow_thruster_destabilises_the_drag_free_loop_near_55_mhz() {
        // issue 23: a thruster pole below ≈ 0.055 Hz (A_df = 0.82) makes the loop unstable
        let lp = LoopPolynomial::new(
            &Controllers::default(),
            &Masses::default(),
            0.0,
            Default::default(),
        );
        let th = LtpParams::default().to_array();
        let pole = |f: f64| Actuation {
            pole: Some(f),
            delay: 0.0,
        };
        assert!(lp.is_stable(&th, &pole(1.0)));
        assert!(lp.is_stable(&th, &pole(0.07)));
        assert!(!lp.is_stable(&th, &pole(0.04)));
        // the boundary, by bisection, against the roots of the same polynomial
        let (mut lo, mut hi) = (0.04, 0.07);
        for _ in 0..40 {
            let mid = 0.5 * (lo + hi);
            if lp.is_stable(&th, &pole(mid)) {
                hi = mid
            } else {
                lo = mid
            }
        }
        assert!((0.045..0.065).contains(&hi), "boundary at {hi} Hz");
        for f in [hi * 1.001, hi * 0.999] {
            let worst = roots(&lp.char_poly(&th, &pole(f)))
                .iter()
                .map(|z| z.re)
                .fold(f64::MIN, f64::max);
            assert_eq!(worst < 0.0, f > hi, "f = {f}: max Re = {worst}");
        }
        // a thruster delay: 0.3 s keeps the 43° margin of ltp-model.md §4, 3 s does not
        let delay = |t: f64| Actuation {
            pole: None,
            delay: t,
        };
        assert!(lp.is_stable(&th, &delay(0.3)));
        assert!(!lp.is_stable(&th, &delay(3.0)));
    }
}
