//! Plain functions of symmetric matrices: the symmetrised, Jacobi-scaled and unit-diagonal
//! forms, and the eigen decomposition.

use nalgebra::{DMatrix, Dyn, SymmetricEigen};

/// `(A + Aᵀ)/2`.
pub fn symmetrised(a: &DMatrix<f64>) -> DMatrix<f64> {
    (a + a.transpose()) * 0.5
}

/// `S A S` with `S = diag(s)`: entries `a_ij · s_i · s_j` (in this order of operations). With
/// `s_i = 1/√a_ii` it is the unit-diagonal correlation form that [`Scaling::Jacobi`](crate::linalg::Scaling::Jacobi) factors.
pub fn jacobi_scaled(a: &DMatrix<f64>, s: &[f64]) -> DMatrix<f64> {
    DMatrix::from_fn(a.nrows(), a.ncols(), |i, j| a[(i, j)] * s[i] * s[j])
}

/// The unit-diagonal form by division, `a_ij / (d_i d_j)` with `d_i = √max(a_ii, 0)`, and the
/// rows and columns with `d_i = 0` set to zero; returns it and `d`. The same matrix as
/// [`jacobi_scaled`] with `s = 1/d` up to rounding: the relative-binning region is built on
/// this form, and keeps it so that its numbers do not move.
pub fn unit_diagonal(a: &DMatrix<f64>) -> (DMatrix<f64>, Vec<f64>) {
    let n = a.nrows();
    let d: Vec<f64> = (0..n).map(|i| a[(i, i)].max(0.0).sqrt()).collect();
    let g = DMatrix::from_fn(n, n, |i, j| {
        if d[i] > 0.0 && d[j] > 0.0 {
            a[(i, j)] / (d[i] * d[j])
        } else {
            0.0
        }
    });
    (g, d)
}

/// The eigen decomposition of the symmetric matrix `a` (nalgebra's; eigenvalues in no
/// particular order, unit eigenvectors in the columns).
pub fn symmetric_eigen(a: DMatrix<f64>) -> SymmetricEigen<f64, Dyn> {
    SymmetricEigen::new(a)
}
