//! 2×2 Hermitian matrix helpers for the two-channel (o1, o12) spectra.

use num_complex::Complex64;

/// A 2×2 complex matrix, row-major.
pub type Mat2 = [[Complex64; 2]; 2];

/// The inverse of a Hermitian positive-definite 2×2 matrix, stored as its three independent
/// real numbers `(a, b, c)` with `S⁻¹ = [[a, b], [b*, c]]`, so quadratic forms cost six
/// multiplications. `None` if the matrix is not positive definite (or not finite).
///
/// # Formula
/// `det = S11 S22 − |S12|²`, `S⁻¹ = [[S22, −S12], [−S12*, S11]]/det`.
pub fn inverse(s: &Mat2) -> Option<(f64, Complex64, f64)> {
    let s11 = s[0][0].re;
    let s22 = s[1][1].re;
    let s12 = s[0][1];
    let det = s11 * s22 - s12.norm_sqr();
    // relative test: det must not be lost in rounding of s11·s22
    if !(s11 > 0.0 && s22 > 0.0 && det > 1e-14 * s11 * s22 && det.is_finite()) {
        return None;
    }
    Some((s22 / det, -s12 / det, s11 / det))
}

/// `rᴴ S⁻¹ r` for `S⁻¹ = [[a, b], [b*, c]]` as returned by [`inverse`].
///
/// # Formula
/// `a|r1|² + c|r2|² + 2 Re(b r1* r2)`
#[inline(always)]
pub fn quad(inv: &(f64, Complex64, f64), r: [Complex64; 2]) -> f64 {
    let (a, b, c) = *inv;
    a * r[0].norm_sqr() + c * r[1].norm_sqr() + 2.0 * (b * r[0].conj() * r[1]).re
}

/// `Re(xᴴ S⁻¹ y)` for the same packed inverse.
#[inline(always)]
pub fn inner(inv: &(f64, Complex64, f64), x: [Complex64; 2], y: [Complex64; 2]) -> f64 {
    let (a, b, c) = *inv;
    let v = x[0].conj() * (y[0] * a + b * y[1]) + x[1].conj() * (b.conj() * y[0] + y[1] * c);
    v.re
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quad_matches_explicit_inverse() {
        let c = |a, b| Complex64::new(a, b);
        let s = [[c(2.0, 0.0), c(0.3, -0.7)], [c(0.3, 0.7), c(1.5, 0.0)]];
        let inv = inverse(&s).unwrap();
        let r = [c(0.4, -1.2), c(2.0, 0.5)];
        // solve S x = r by Cramer and compare rᴴ x
        let det = s[0][0] * s[1][1] - s[0][1] * s[1][0];
        let x0 = (s[1][1] * r[0] - s[0][1] * r[1]) / det;
        let x1 = (s[0][0] * r[1] - s[1][0] * r[0]) / det;
        let want = (r[0].conj() * x0 + r[1].conj() * x1).re;
        assert!((quad(&inv, r) - want).abs() < 1e-14 * want.abs());
        assert!((inner(&inv, r, r) - want).abs() < 1e-14 * want.abs());
        assert!(inverse(&[[c(1.0, 0.0), c(1.0, 0.0)], [c(1.0, 0.0), c(1.0, 0.0)]]).is_none());
    }
}
