//! Hermitian matrix helpers for the residual-noise matrices of the likelihood: the packed 2×2
//! inverse of the one- and two-channel models (kept as it is so their numbers never change),
//! and, for any size `R`, the inverse Cholesky factor `W` with `C⁻¹ = WᴴW`, so a quadratic form
//! is `rᴴC⁻¹r = |W r|²` (about `R²/2` complex multiplications, no division).

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

/// Number of stored entries of a packed `R×R` lower-triangular factor: `R(R+1)/2`, row by
/// row (row `i` holds columns `0..=i` from offset `i(i+1)/2`).
#[inline(always)]
pub const fn tri_len(r: usize) -> usize {
    r * (r + 1) / 2
}

/// Why an `R×R` matrix has no Cholesky factor: the pivot of row `row` (the variance of channel
/// `row` not explained by channels `0..row`) is `pivot`, against the diagonal `diag`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NotPositiveDefinite {
    pub row: usize,
    pub pivot: f64,
    pub diag: f64,
}

/// The inverse Cholesky factor of a Hermitian positive-definite `R×R` matrix `c` (row-major,
/// only the lower triangle is read): writes `W = L⁻¹` (`C = L Lᴴ`, `L` lower triangular with a
/// positive real diagonal) packed into `w` (length [`tri_len`]`(R)`) and returns `ln det C`.
///
/// A pivot must exceed `rel_tol` times its diagonal entry (and be finite): with `rel_tol =
/// 1e−14` that is the relative test of [`inverse`] (for `R = 2` the pivot of row 1 is
/// `det/S11`), which refuses a matrix whose smallest direction is lost in rounding.
///
/// # Formula
/// `L_jj = √(C_jj − Σ_{k<j} |L_jk|²)`, `L_ij = (C_ij − Σ_{k<j} L_ik L_jk*)/L_jj` (i > j);
/// `W_ii = 1/L_ii`, `W_ij = −(Σ_{k=j}^{i−1} L_ik W_kj)/L_ii` (i > j); `ln det C = 2 Σ ln L_jj`.
pub fn whitener(
    c: &[Complex64],
    nr: usize,
    rel_tol: f64,
    w: &mut [Complex64],
) -> Result<f64, NotPositiveDefinite> {
    assert!(c.len() == nr * nr && w.len() == tri_len(nr));
    let mut l = vec![Complex64::new(0.0, 0.0); nr * nr];
    let mut ln_det = 0.0;
    for j in 0..nr {
        let diag = c[j * nr + j].re;
        let pivot = diag - (0..j).map(|k| l[j * nr + k].norm_sqr()).sum::<f64>();
        if !(pivot > rel_tol * diag && pivot > 0.0 && pivot.is_finite()) {
            return Err(NotPositiveDefinite {
                row: j,
                pivot,
                diag,
            });
        }
        let ljj = pivot.sqrt();
        l[j * nr + j] = Complex64::new(ljj, 0.0);
        ln_det += 2.0 * ljj.ln();
        for i in j + 1..nr {
            let mut s = c[i * nr + j];
            for k in 0..j {
                s -= l[i * nr + k] * l[j * nr + k].conj();
            }
            l[i * nr + j] = s / ljj;
        }
    }
    for i in 0..nr {
        let row = tri_len(i);
        let lii = l[i * nr + i].re;
        for j in 0..i {
            let mut s = Complex64::new(0.0, 0.0);
            for k in j..i {
                s += l[i * nr + k] * w[tri_len(k) + j];
            }
            w[row + j] = -s / lii;
        }
        w[row + i] = Complex64::new(1.0 / lii, 0.0);
    }
    Ok(ln_det)
}

/// `out = W x` for a packed lower-triangular `W` of size `x.len()`.
#[inline(always)]
pub fn whiten(w: &[Complex64], x: &[Complex64], out: &mut [Complex64]) {
    for (i, o) in out.iter_mut().enumerate().take(x.len()) {
        let row = &w[tri_len(i)..tri_len(i + 1)];
        let mut s = Complex64::new(0.0, 0.0);
        for (a, b) in row.iter().zip(x) {
            s += a * b;
        }
        *o = s;
    }
}

/// `rᴴ C⁻¹ r = |W r|²` for the factor of [`whitener`] (`R = r.len()`).
#[inline(always)]
pub fn quad_whitened(w: &[Complex64], r: &[Complex64]) -> f64 {
    let mut q = 0.0;
    for i in 0..r.len() {
        let row = &w[tri_len(i)..tri_len(i + 1)];
        let mut s = Complex64::new(0.0, 0.0);
        for (a, b) in row.iter().zip(r) {
            s += a * b;
        }
        q += s.norm_sqr();
    }
    q
}

/// `Re(xᴴ C⁻¹ y) = Re((W x)ᴴ (W y))` for the factor of [`whitener`].
#[inline(always)]
pub fn inner_whitened(w: &[Complex64], x: &[Complex64], y: &[Complex64]) -> f64 {
    let mut v = 0.0;
    for i in 0..x.len() {
        let row = &w[tri_len(i)..tri_len(i + 1)];
        let (mut a, mut b) = (Complex64::new(0.0, 0.0), Complex64::new(0.0, 0.0));
        for (wk, (xk, yk)) in row.iter().zip(x.iter().zip(y)) {
            a += wk * xk;
            b += wk * yk;
        }
        v += (a.conj() * b).re;
    }
    v
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

    /// A random Hermitian positive-definite `n×n` matrix `A Aᴴ + n·I/10`, row-major.
    fn random_hpd(n: usize, seed: u64) -> Vec<Complex64> {
        let mut x = seed;
        let mut u = || {
            x = x
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (x >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let a: Vec<Complex64> = (0..n * n).map(|_| Complex64::new(u(), u())).collect();
        let mut c = vec![Complex64::new(0.0, 0.0); n * n];
        for i in 0..n {
            for j in 0..n {
                for k in 0..n {
                    c[i * n + j] += a[i * n + k] * a[j * n + k].conj();
                }
            }
            c[i * n + i] += n as f64 / 10.0;
        }
        c
    }

    #[test]
    fn whitener_inverts_and_its_log_determinant_is_right() {
        for n in [1, 2, 3, 5, 16] {
            let c = random_hpd(n, n as u64);
            let mut w = vec![Complex64::new(0.0, 0.0); tri_len(n)];
            let ln_det = whitener(&c, n, 1e-14, &mut w).unwrap();
            let dense = nalgebra::DMatrix::from_row_slice(n, n, &c);
            let inv = dense.clone().try_inverse().unwrap();
            let det = dense.determinant();
            assert!(det.im.abs() < 1e-10 * det.re.abs());
            assert!(
                (ln_det - det.re.ln()).abs() < 1e-12 * ln_det.abs().max(1.0),
                "{n}"
            );
            let r: Vec<Complex64> = (0..n)
                .map(|i| Complex64::new(i as f64 - 1.3, 0.7 * i as f64 + 0.2))
                .collect();
            let y: Vec<Complex64> = r.iter().map(|v| v * Complex64::new(0.3, -1.1)).collect();
            let rv = nalgebra::DVector::from_column_slice(&r);
            let yv = nalgebra::DVector::from_column_slice(&y);
            let want = (rv.adjoint() * &inv * &rv)[(0, 0)].re;
            let want_xy = (rv.adjoint() * &inv * &yv)[(0, 0)].re;
            let got = quad_whitened(&w, &r);
            assert!(
                (got - want).abs() < 1e-12 * want.abs(),
                "{n}: {got} vs {want}"
            );
            let got_xy = inner_whitened(&w, &r, &y);
            assert!((got_xy - want_xy).abs() < 1e-12 * want.abs(), "{n}");
            let mut wr = vec![Complex64::new(0.0, 0.0); n];
            whiten(&w, &r, &mut wr);
            let q: f64 = wr.iter().map(|v| v.norm_sqr()).sum();
            assert!((q - got).abs() < 1e-14 * got);
        }
    }

    #[test]
    fn whitener_refuses_a_singular_matrix_and_names_the_row() {
        // channel 2 is channel 0 again: its pivot vanishes to rounding
        let mut c = random_hpd(3, 7);
        for j in 0..3 {
            c[2 * 3 + j] = c[j];
            c[j * 3 + 2] = c[j * 3];
        }
        c[8] = c[0];
        let mut w = vec![Complex64::new(0.0, 0.0); tri_len(3)];
        let err = whitener(&c, 3, 1e-14, &mut w).unwrap_err();
        assert_eq!(err.row, 2);
        assert!(err.pivot <= 1e-14 * err.diag);
        let mut nan = random_hpd(3, 8);
        nan[4] = Complex64::new(f64::NAN, 0.0);
        assert!(whitener(&nan, 3, 1e-14, &mut w).is_err());
    }
}
