//! Allocation-free kernels on dense row-major slices, for loops that refactor or solve many
//! times. Each has a slow oracle in the tests: [`super::Spd`] (nalgebra) for the factor and
//! `ln det`, nalgebra's triangular solve for the solve.

use super::error::LinalgError;

/// In-place lower Cholesky factorisation of the symmetric `n × n` row-major matrix `a` (only
/// its lower triangle is read); the upper triangle is zeroed. Allocation-free.
///
/// Fails at the first pivot `p_j = a_jj − Σ_{k<j} L_jk²` that is not finite and
/// `> floor · a_jj`, with [`LinalgError::NotPositiveDefinite`] naming that pivot (no
/// direction: diagnosing would allocate; factor with [`super::Spd`] for that). `floor = 0`
/// asks for positive definiteness; `floor = 1e-12` also rejects matrices singular to working
/// precision (FAST-MCD's subsets). `a` is left partly factored on failure.
///
/// Every entry is computed by the operations of nalgebra's `Cholesky::new` in the same order
/// (`L_ij = (a_ij − Σ_{k<j} L_ik L_jk) / L_jj`, `k` ascending), so the factor is the same
/// to the bit as [`super::Spd::l_row_major`]'s.
///
/// ```
/// use occam::linalg::cholesky_in_place;
/// let mut a = [4.0, 0.0, 2.0, 5.0]; // [[4, 2], [2, 5]], upper triangle not read
/// cholesky_in_place(&mut a, 2, 0.0).unwrap();
/// assert_eq!(a, [2.0, 0.0, 1.0, 2.0]);
/// ```
pub fn cholesky_in_place(a: &mut [f64], n: usize, floor: f64) -> Result<(), LinalgError> {
    for j in 0..n {
        let a_jj = a[j * n + j];
        let mut s = a_jj;
        for k in 0..j {
            s -= a[j * n + k] * a[j * n + k];
        }
        if !(s > floor * a_jj && s.is_finite()) {
            return Err(LinalgError::NotPositiveDefinite {
                pivot: Some(j),
                weakest: None,
            });
        }
        let l = s.sqrt();
        a[j * n + j] = l;
        for i in j + 1..n {
            let mut t = a[i * n + j];
            for k in 0..j {
                t -= a[i * n + k] * a[j * n + k];
            }
            a[i * n + j] = t / l;
        }
    }
    for i in 0..n {
        for j in i + 1..n {
            a[i * n + j] = 0.0;
        }
    }
    Ok(())
}

/// `ln det A = 2 Σ ln L_ii` from the row-major Cholesky factor `l` of `A` (`n × n`).
pub fn ln_det_lower(l: &[f64], n: usize) -> f64 {
    2.0 * (0..n).map(|i| l[i * n + i].ln()).sum::<f64>()
}

/// Solves `L z = x` in place for a row-major lower-triangular `L` (`n × n`) and returns `|z|²`
/// (with `L Lᵀ = Σ`, the squared Mahalanobis norm `xᵀ Σ⁻¹ x`). Allocation-free.
pub fn forward_solve_norm2(l: &[f64], n: usize, x: &mut [f64]) -> f64 {
    let mut s2 = 0.0;
    for i in 0..n {
        let row = &l[i * n..i * n + i];
        let mut s = x[i];
        for (lij, xj) in row.iter().zip(&x[..i]) {
            s -= lij * xj;
        }
        let z = s / l[i * n + i];
        x[i] = z;
        s2 += z * z;
    }
    s2
}
