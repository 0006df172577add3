//! The transfer matrix `C (zI − A)⁻¹ B + D` of evaluated real matrices at one complex point,
//! by Gaussian elimination with partial pivoting on the caller's buffers, generically over dual
//! numbers (the pivots are chosen on the real parts, so the derivatives are those of the same
//! elimination: exact).

use num_complex::Complex;
use num_dual::DualNum;

/// `|z|²` of the real part of a dual complex number: what pivoting compares.
#[inline(always)]
fn mag<T: DualNum<Primitive = f64> + Copy>(z: &Complex<T>) -> f64 {
    let (r, i) = (z.re.re(), z.im.re());
    r * r + i * i
}

/// Solves `M X = R` in place: `m` is `n × n` row-major (destroyed), `r` is `n × k` row-major
/// and becomes `X`. `false` when `M` is singular at working precision (a pivot of zero or not
/// finite).
pub fn solve_in_place<T: DualNum<Primitive = f64> + Copy>(
    m: &mut [Complex<T>],
    n: usize,
    r: &mut [Complex<T>],
    k: usize,
) -> bool {
    for col in 0..n {
        let mut piv = col;
        let mut best = mag(&m[col * n + col]);
        for row in col + 1..n {
            let v = mag(&m[row * n + col]);
            if v > best {
                best = v;
                piv = row;
            }
        }
        if best == 0.0 || !best.is_finite() {
            return false;
        }
        if piv != col {
            for j in 0..n {
                m.swap(col * n + j, piv * n + j);
            }
            for j in 0..k {
                r.swap(col * k + j, piv * k + j);
            }
        }
        let inv = Complex::new(T::one(), T::zero()) / m[col * n + col];
        for row in col + 1..n {
            let f = m[row * n + col] * inv;
            // sparse systems (loops of blocks) have many exact zeros below the pivot; a dual
            // zero may still carry a derivative, so only plain numbers are skipped
            if T::NDERIV == 0 && f.re.re() == 0.0 && f.im.re() == 0.0 {
                continue;
            }
            for j in col + 1..n {
                let t = m[col * n + j];
                m[row * n + j] -= f * t;
            }
            for j in 0..k {
                let t = r[col * k + j];
                r[row * k + j] -= f * t;
            }
        }
    }
    for col in (0..n).rev() {
        let inv = Complex::new(T::one(), T::zero()) / m[col * n + col];
        for j in 0..k {
            let mut acc = r[col * k + j];
            for i in col + 1..n {
                acc -= m[col * n + i] * r[i * k + j];
            }
            r[col * k + j] = acc * inv;
        }
    }
    true
}

/// Real matrices of a state-space system evaluated at θ, row-major, borrowed.
#[derive(Debug, Clone, Copy)]
pub struct System<'a, T> {
    /// States.
    pub n: usize,
    /// Columns of `b` and `d` (inputs).
    pub m: usize,
    /// Outputs.
    pub p: usize,
    /// `n × n`.
    pub a: &'a [T],
    /// `n × m`.
    pub b: &'a [T],
    /// `p × n`.
    pub c: &'a [T],
    /// `p × m`, or empty for zero.
    pub d: &'a [T],
}

/// `H = C (zI − A)⁻¹ B + D` into `h` (`p × m`, row-major), using `lu` (at least `n²`) and `x`
/// (at least `n·m`) as workspace. `false` when `zI − A` is singular (`z` is an eigenvalue).
pub fn transfer<T: DualNum<Primitive = f64> + Copy>(
    sys: &System<T>,
    z: Complex<f64>,
    lu: &mut [Complex<T>],
    x: &mut [Complex<T>],
    h: &mut [Complex<T>],
) -> bool {
    let (n, m, p) = (sys.n, sys.m, sys.p);
    let zero = Complex::new(T::zero(), T::zero());
    for i in 0..n {
        for j in 0..n {
            lu[i * n + j] = Complex::new(-sys.a[i * n + j], T::zero());
        }
        lu[i * n + i] += Complex::new(T::from(z.re), T::from(z.im));
    }
    for (xi, bi) in x[..n * m].iter_mut().zip(&sys.b[..n * m]) {
        *xi = Complex::new(*bi, T::zero());
    }
    if !solve_in_place(&mut lu[..n * n], n, &mut x[..n * m], m) {
        return false;
    }
    for o in 0..p {
        for j in 0..m {
            let mut acc = if sys.d.is_empty() {
                zero
            } else {
                Complex::new(sys.d[o * m + j], T::zero())
            };
            for i in 0..n {
                let c = sys.c[o * n + i];
                acc += x[i * m + j] * c;
            }
            h[o * m + j] = acc;
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;
    use num_complex::Complex64;
    use num_dual::Dual64;

    #[test]
    fn solves_a_system_that_needs_pivoting() {
        // [[0, 1], [2, 3]] x = [1, 8] → x = [2.5, 1]
        let c = |x: f64| Complex64::new(x, 0.0);
        let mut m = [c(0.0), c(1.0), c(2.0), c(3.0)];
        let mut r = [c(1.0), c(8.0)];
        assert!(solve_in_place(&mut m, 2, &mut r, 1));
        assert!((r[0] - c(2.5)).norm() < 1e-15 && (r[1] - c(1.0)).norm() < 1e-15);
        let mut s = [c(1.0), c(2.0), c(2.0), c(4.0)];
        assert!(!solve_in_place(&mut s, 2, &mut r, 1));
    }

    #[test]
    fn first_order_transfer_and_its_derivative() {
        // ẋ = −a x + u, y = x: H = 1/(s + a), dH/da = −1/(s + a)²
        let a0 = 0.7;
        let a = [-Dual64::from(a0).derivative()];
        let one = [Dual64::from(1.0)];
        let sys = System {
            n: 1,
            m: 1,
            p: 1,
            a: &a,
            b: &one,
            c: &one,
            d: &[],
        };
        let s = Complex64::new(0.0, 2.0);
        let zero = Complex::new(Dual64::from(0.0), Dual64::from(0.0));
        let (mut lu, mut x, mut h) = ([zero], [zero], [zero]);
        assert!(transfer(&sys, s, &mut lu, &mut x, &mut h));
        let want = Complex64::new(1.0, 0.0) / (s + a0);
        let dwant = -want * want;
        assert!((Complex64::new(h[0].re.re, h[0].im.re) - want).norm() < 1e-15);
        assert!((Complex64::new(h[0].re.eps, h[0].im.eps) - dwant).norm() < 1e-15);
    }
}
