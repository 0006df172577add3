//! One linear algebra: factorisations, inverses, log-determinants and eigen decompositions of
//! symmetric (positive-definite) matrices, on nalgebra, with one error type.
//!
//! | item | what |
//! |---|---|
//! | [`Spd`], [`SpdOptions`] | Cholesky factor of a symmetric positive-definite matrix: inverse, solve, `ln det`, the factor `L` |
//! | [`Scaling::Jacobi`] | factors `S A S`, `S = diag(1/√a_ii)`: Fisher matrices in SI units span 10¹⁸ on their diagonal (ω² against delays) |
//! | [`unconstrained_directions`], [`weakest_direction`] | eigenvectors of the correlation form with (near-)zero eigenvalue: what a singular Fisher matrix leaves free |
//! | [`symmetric_eigen`], [`symmetrised`], [`jacobi_scaled`], [`unit_diagonal`] | the eigen decomposition and the scalings it is taken in |
//! | [`cholesky_in_place`], [`forward_solve_norm2`], [`ln_det_lower`] | allocation-free kernels on row-major slices, for hot loops (the sampler's adaptation, FAST-MCD's C-steps, RJMCMC's jump density) |
//! | [`LinalgError`] | what is wrong with a matrix; a matrix that is not positive definite names its least-constrained direction |
//!
//! The allocation-free [`cholesky_in_place`] and the general [`Spd`] compute every entry of `L`
//! by the same operations in the same order, so they agree bit for bit (tested); the kernel
//! exists only where a loop refactors a matrix many times.
//!
//! This module is on the bottom layer: it imports nothing from the crate.

mod directions;
mod error;
mod kernels;
mod spd;
mod symmetric;

pub use directions::{
    NULL_EIGENVALUE_TOL, NullDirection, NullKind, format_direction, unconstrained_directions,
    weakest_direction,
};
pub use error::{LinalgError, Weakest};
pub use kernels::{cholesky_in_place, forward_solve_norm2, ln_det_lower};
pub use spd::{SYMMETRY_TOL, Scaling, Spd, SpdOptions, Symmetry, spd_inverse};
pub use symmetric::{jacobi_scaled, symmetric_eigen, symmetrised, unit_diagonal};

#[cfg(test)]
mod tests;
