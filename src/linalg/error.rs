//! The one error type of linear algebra, [`LinalgError`]: what is wrong with a matrix that had
//! to be symmetric positive definite, naming the direction it constrains least.

use super::directions::{NullDirection, NullKind, format_direction, row_name};

/// What is wrong with a matrix that had to be symmetric positive definite. The messages say
/// what is wrong; callers prefix the matrix's name (`proposal covariance: not symmetric: …`).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LinalgError {
    /// The matrix is not square.
    #[error("not square ({rows}×{cols})")]
    NotSquare { rows: usize, cols: usize },
    /// An entry that is read is NaN or infinite.
    #[error("entry ({row}, {col}) = {value} is not finite")]
    NonFinite { row: usize, col: usize, value: f64 },
    /// `|a_ij − a_ji|` exceeds the tolerance of
    /// [`Symmetry::Within`](crate::linalg::Symmetry::Within).
    #[error(
        "not symmetric: ({row}, {col}) = {lower:e} but ({col}, {row}) = {upper:e}; pass (A + Aᵀ)/2 if the difference is round-off"
    )]
    NotSymmetric {
        row: usize,
        col: usize,
        lower: f64,
        upper: f64,
    },
    /// The Cholesky factorisation failed.
    #[error("not positive definite{}", describe_failure(*.pivot, .weakest.as_deref()))]
    NotPositiveDefinite {
        /// The first pivot (row) that is not positive, when known (the kernel reports it).
        pivot: Option<usize>,
        /// The direction the matrix constrains least; `None` from the allocation-free kernel,
        /// which does not diagnose.
        weakest: Option<Box<Weakest>>,
    },
    /// The factorisation succeeded but the inverse overflowed: singular to working precision.
    #[error(
        "its inverse is not finite (entry ({row}, {col}) = {value}): singular to working precision"
    )]
    InverseNotFinite { row: usize, col: usize, value: f64 },
}

/// The direction a matrix that is not positive definite constrains least, with the names of
/// its rows.
#[derive(Debug, Clone, PartialEq)]
pub struct Weakest {
    /// A non-positive diagonal entry, or the eigenvector of the correlation form with the
    /// smallest eigenvalue ([`weakest_direction`](crate::linalg::weakest_direction)).
    pub direction: NullDirection,
    /// The rows' names as the caller gave them (empty: rows are called `#i`).
    pub names: Vec<String>,
}

impl LinalgError {
    /// The parameters (row names, `#i` without names) that the least-constrained direction of a
    /// [`LinalgError::NotPositiveDefinite`] involves, largest weight first; empty otherwise.
    pub fn unconstrained(&self) -> Vec<String> {
        match self {
            LinalgError::NotPositiveDefinite {
                weakest: Some(w), ..
            } => w
                .direction
                .weights
                .iter()
                .map(|&(i, _)| row_name(&w.names, i))
                .collect(),
            _ => Vec::new(),
        }
    }
}

/// The tail of a [`LinalgError::NotPositiveDefinite`] message.
fn describe_failure(pivot: Option<usize>, weakest: Option<&Weakest>) -> String {
    let mut s = String::new();
    if let Some(k) = pivot {
        s.push_str(&format!(" (Cholesky pivot {k} is not > 0)"));
    }
    let Some(Weakest {
        direction: d,
        names,
    }) = weakest
    else {
        return s;
    };
    let first = d.weights.first().map_or(0, |w| w.0);
    match d.kind {
        NullKind::ZeroColumn => s.push_str(&format!(
            "; the diagonal entry of `{}` is not > 0",
            row_name(names, first)
        )),
        NullKind::NonFinite => s.push_str(&format!(
            "; the row of `{}` is not finite",
            row_name(names, first)
        )),
        NullKind::Degenerate => {
            let rel = if d.relative_eigenvalue > 0.0 {
                format!("{:.1e}", d.relative_eigenvalue)
            } else {
                "≤ 0".to_string()
            };
            s.push_str(&format!(
                "; its least-constrained direction is {} (relative eigenvalue of the correlation form {rel})",
                format_direction(d, names)
            ));
        }
    }
    s
}
