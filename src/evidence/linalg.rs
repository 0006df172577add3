//! Small dense linear-algebra helpers with typed errors.

use super::EvidenceError;
use nalgebra::{Cholesky, DMatrix, Dyn, SymmetricEigen};

/// Relative asymmetry tolerated before a matrix is called non-symmetric; below it the matrix
/// is symmetrised (round-off from `AᵀA`-type products is far smaller).
const SYM_TOL: f64 = 1e-8;

/// Cholesky factor of a symmetric positive-definite matrix, with an error naming `what` and the
/// smallest eigenvalue when it fails.
pub(crate) fn spd_cholesky(
    m: &DMatrix<f64>,
    what: &str,
    fix: &str,
) -> Result<Cholesky<f64, Dyn>, EvidenceError> {
    let n = m.nrows();
    if m.ncols() != n {
        return Err(EvidenceError::NotPositiveDefinite {
            what: what.to_string(),
            detail: format!("it is {}×{}, not square", n, m.ncols()),
            fix: fix.to_string(),
        });
    }
    let mut scale = 0.0f64;
    for &v in m.iter() {
        if !v.is_finite() {
            return Err(EvidenceError::non_finite(
                format!("an entry of {what}"),
                v,
                fix,
            ));
        }
        scale = scale.max(v.abs());
    }
    for i in 0..n {
        for j in 0..i {
            if (m[(i, j)] - m[(j, i)]).abs() > SYM_TOL * scale {
                return Err(EvidenceError::NotPositiveDefinite {
                    what: what.to_string(),
                    detail: format!(
                        "entries ({i},{j}) = {} and ({j},{i}) = {} differ",
                        m[(i, j)],
                        m[(j, i)]
                    ),
                    fix: fix.to_string(),
                });
            }
        }
    }
    let sym = (m + m.transpose()) * 0.5;
    match Cholesky::new(sym.clone()) {
        Some(c)
            if c.l_dirty()
                .diagonal()
                .iter()
                .all(|d| *d > 0.0 && d.is_finite()) =>
        {
            Ok(c)
        }
        _ => {
            let eig = SymmetricEigen::new(sym);
            let min = eig
                .eigenvalues
                .iter()
                .cloned()
                .fold(f64::INFINITY, f64::min);
            let max = eig
                .eigenvalues
                .iter()
                .cloned()
                .fold(f64::NEG_INFINITY, f64::max);
            Err(EvidenceError::NotPositiveDefinite {
                what: what.to_string(),
                detail: format!("eigenvalues range from {min:e} to {max:e}"),
                fix: fix.to_string(),
            })
        }
    }
}

/// `ln |A|` from the Cholesky factor of `A`.
pub(crate) fn ln_det(c: &Cholesky<f64, Dyn>) -> f64 {
    2.0 * c.l_dirty().diagonal().iter().map(|d| d.ln()).sum::<f64>()
}

/// The lower Cholesky factor as a dense row-major `Vec` (for allocation-free inner loops).
pub(crate) fn lower_row_major(c: &Cholesky<f64, Dyn>) -> Vec<f64> {
    let l = c.l();
    let n = l.nrows();
    let mut out = vec![0.0; n * n];
    for i in 0..n {
        for j in 0..=i {
            out[i * n + j] = l[(i, j)];
        }
    }
    out
}

/// Solves `L z = x` in place for a row-major lower-triangular `L` (n×n) and returns `|z|²`.
pub(crate) fn forward_solve_norm2(l: &[f64], n: usize, x: &mut [f64]) -> f64 {
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cholesky_errors_are_typed() {
        let bad = DMatrix::from_row_slice(2, 2, &[1.0, 2.0, 2.0, 1.0]);
        assert!(matches!(
            spd_cholesky(&bad, "F", "fix"),
            Err(EvidenceError::NotPositiveDefinite { .. })
        ));
        let asym = DMatrix::from_row_slice(2, 2, &[1.0, 0.5, 0.0, 1.0]);
        assert!(spd_cholesky(&asym, "F", "fix").is_err());
        let nan = DMatrix::from_row_slice(1, 1, &[f64::NAN]);
        assert!(matches!(
            spd_cholesky(&nan, "F", "fix"),
            Err(EvidenceError::NonFinite { .. })
        ));
        let good = DMatrix::from_row_slice(2, 2, &[4.0, 1.0, 1.0, 3.0]);
        let c = spd_cholesky(&good, "F", "fix").unwrap();
        assert!((ln_det(&c) - 11.0f64.ln()).abs() < 1e-14);
        let l = lower_row_major(&c);
        let mut x = [1.0, 2.0];
        let q = forward_solve_norm2(&l, 2, &mut x);
        // xᵀ A⁻¹ x with A⁻¹ = [[3, −1], [−1, 4]]/11.
        assert!((q - (3.0 - 4.0 + 16.0) / 11.0).abs() < 1e-14);
    }
}
