//! Symmetric positive-definite matrices: the Cholesky factor and what it gives (inverse,
//! solve, `ln det`), with optional Jacobi scaling.

use nalgebra::{Cholesky, DMatrix, DVector, Dyn};

use super::directions::weakest_direction;
use super::error::{LinalgError, Weakest};
use super::symmetric::{jacobi_scaled, symmetrised};

/// Default relative asymmetry tolerated by [`Symmetry::Within`]: far above the round-off of
/// a numerically inverted or accumulated matrix (`AᵀA`-type products, `Σ = F⁻¹`), far below
/// any real asymmetry.
pub const SYMMETRY_TOL: f64 = 1e-8;

/// How the matrix is scaled before it is factored.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scaling {
    /// Factor `A` as given.
    None,
    /// Factor the unit-diagonal `G = S A S`, `S = diag(s)`, `s_i = 1/√a_ii` (entries
    /// `a_ij · s_i · s_j`, see [`jacobi_scaled`]), and undo `S` in every result. A Fisher matrix
    /// in SI units spans 10¹⁸ and more on its diagonal (ω² against delays); scaled, the
    /// factorisation sees its correlations, not its units. Every `a_ii` must be > 0.
    Jacobi,
}

/// Which entries are read, and what is checked about symmetry.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Symmetry {
    /// Read the lower triangle (and diagonal) only, as nalgebra does: for matrices symmetric by
    /// construction. The upper triangle is neither read nor checked.
    Lower,
    /// Require `|a_ij − a_ji| ≤ tol · √(a_ii a_jj)` (a tolerance in the matrix's own scale,
    /// whatever the units of its rows) and factor `(A + Aᵀ)/2` ([`symmetrised`]).
    Within(f64),
}

/// How [`Spd`] factors a matrix (see [`Spd::new`] for the defaults).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpdOptions<'a> {
    /// Scaling before the factorisation.
    pub scaling: Scaling,
    /// Which entries are read and checked.
    pub symmetry: Symmetry,
    /// Names of the rows (parameters), for the error's unconstrained direction; may be empty.
    pub names: &'a [String],
}

impl Default for SpdOptions<'_> {
    fn default() -> Self {
        Self {
            scaling: Scaling::None,
            symmetry: Symmetry::Within(SYMMETRY_TOL),
            names: &[],
        }
    }
}

impl<'a> SpdOptions<'a> {
    /// Reads the lower triangle only ([`Symmetry::Lower`]).
    pub fn lower() -> Self {
        Self {
            symmetry: Symmetry::Lower,
            ..Self::default()
        }
    }

    /// With [`Scaling::Jacobi`].
    pub fn jacobi(self) -> Self {
        Self {
            scaling: Scaling::Jacobi,
            ..self
        }
    }

    /// With the rows' names, for the error.
    pub fn names(self, names: &'a [String]) -> Self {
        Self { names, ..self }
    }

    /// Factors `a` (see [`Spd`]).
    pub fn factor(&self, a: &DMatrix<f64>) -> Result<Spd, LinalgError> {
        Spd::factor(a, self)
    }
}

/// The Cholesky factorisation `A = L Lᵀ` of a symmetric positive-definite matrix (nalgebra's),
/// or under [`Scaling::Jacobi`] that of `S A S`, with `S` undone in every result.
///
/// ```
/// use nalgebra::{DMatrix, DVector};
/// use occam::linalg::{LinalgError, Spd, SpdOptions};
/// // a Fisher matrix with the scales of ω² (10⁹) and of a delay (10⁻³), correlation 0.5
/// let s = [1e9, 1e-3];
/// let f = DMatrix::from_fn(2, 2, |i, j| if i == j { 1.0 } else { 0.5 } * s[i] * s[j]);
/// let spd = SpdOptions::default().jacobi().factor(&f).unwrap();
/// let cov = spd.inverse(); // C⁻¹ = [[4, −2], [−2, 4]]/3 in the scaled units
/// assert!((cov[(0, 1)] * s[0] * s[1] + 2.0 / 3.0).abs() < 1e-15);
/// assert!((spd.ln_det() - (0.75f64 * 1e12).ln()).abs() < 1e-12);
/// let x = spd.solve(&DVector::from_vec(vec![1e9, 0.0]));
/// assert!((x[0] - 4.0 / 3.0 * 1e-9).abs() < 1e-22);
///
/// // b = 2a: the error names the direction the matrix does not constrain
/// let names = ["a".to_string(), "b".to_string()];
/// let g = DMatrix::from_row_slice(2, 2, &[1.0, 2.0, 2.0, 4.0]);
/// let err = SpdOptions::default().names(&names).factor(&g).unwrap_err();
/// assert!(matches!(err, LinalgError::NotPositiveDefinite { .. }));
/// assert_eq!(err.unconstrained(), ["a", "b"]);
/// assert!(err.to_string().contains("0.71·a − 0.71·b"), "{err}");
/// ```
#[derive(Debug, Clone)]
pub struct Spd {
    chol: Cholesky<f64, Dyn>,
    /// `s_i = 1/√a_ii` under [`Scaling::Jacobi`]: `chol` factors `S A S`.
    scale: Option<Vec<f64>>,
}

impl Spd {
    /// Factors `a` with the default options: no scaling, symmetric to [`SYMMETRY_TOL`]
    /// (factors `(A + Aᵀ)/2`), every entry finite.
    pub fn new(a: &DMatrix<f64>) -> Result<Self, LinalgError> {
        Self::factor(a, &SpdOptions::default())
    }

    /// Factors `a` as `opts` say. Errors: not square; an entry read is not finite; not
    /// symmetric ([`Symmetry::Within`]); not positive definite (naming the least-constrained
    /// direction, in `opts.names`).
    pub fn factor(a: &DMatrix<f64>, opts: &SpdOptions) -> Result<Self, LinalgError> {
        let n = a.nrows();
        if a.ncols() != n {
            return Err(LinalgError::NotSquare {
                rows: n,
                cols: a.ncols(),
            });
        }
        let read = |i: usize, j: usize| j <= i || matches!(opts.symmetry, Symmetry::Within(_));
        for j in 0..n {
            for i in 0..n {
                let value = a[(i, j)];
                if read(i, j) && !value.is_finite() {
                    return Err(LinalgError::NonFinite {
                        row: i,
                        col: j,
                        value,
                    });
                }
            }
        }
        let sym;
        let m = match opts.symmetry {
            Symmetry::Lower => a,
            Symmetry::Within(tol) => {
                check_symmetric(a, tol)?;
                sym = symmetrised(a);
                &sym
            }
        };
        let fail = || LinalgError::NotPositiveDefinite {
            pivot: None,
            weakest: weakest_direction(&mirror_lower(m)).map(|direction| {
                Box::new(Weakest {
                    direction,
                    names: opts.names.to_vec(),
                })
            }),
        };
        let (chol, scale) = match opts.scaling {
            Scaling::None => (Cholesky::new(m.clone()), None),
            Scaling::Jacobi => {
                if (0..n).any(|i| !(m[(i, i)] > 0.0)) {
                    return Err(fail());
                }
                let s: Vec<f64> = (0..n).map(|i| 1.0 / m[(i, i)].sqrt()).collect();
                (Cholesky::new(jacobi_scaled(m, &s)), Some(s))
            }
        };
        match chol {
            Some(chol)
                if chol
                    .l_dirty()
                    .diagonal()
                    .iter()
                    .all(|d| *d > 0.0 && d.is_finite()) =>
            {
                Ok(Self { chol, scale })
            }
            _ => Err(fail()),
        }
    }

    /// The dimension `n` of the `n × n` matrix.
    pub fn dim(&self) -> usize {
        self.chol.l_dirty().nrows()
    }

    /// The lower-triangular `L` with `A = L Lᵀ` (under Jacobi scaling `S⁻¹ L_G`).
    pub fn l(&self) -> DMatrix<f64> {
        let mut l = self.chol.l();
        if let Some(s) = &self.scale {
            for (i, si) in s.iter().enumerate() {
                l.row_mut(i).unscale_mut(*si);
            }
        }
        l
    }

    /// [`Spd::l`] as a dense row-major `Vec` (upper triangle zero), for the allocation-free
    /// kernels of hot loops.
    pub fn l_row_major(&self) -> Vec<f64> {
        let l = self.l();
        let n = l.nrows();
        let mut out = vec![0.0; n * n];
        for i in 0..n {
            for j in 0..=i {
                out[i * n + j] = l[(i, j)];
            }
        }
        out
    }

    /// `A⁻¹` (under Jacobi scaling `S G⁻¹ S`, entries `(G⁻¹)_ij · s_i · s_j`).
    pub fn inverse(&self) -> DMatrix<f64> {
        let inv = self.chol.inverse();
        match &self.scale {
            None => inv,
            Some(s) => DMatrix::from_fn(inv.nrows(), inv.ncols(), |i, j| inv[(i, j)] * s[i] * s[j]),
        }
    }

    /// `x` with `A x = b` (under Jacobi scaling `S G⁻¹ S b`).
    pub fn solve(&self, b: &DVector<f64>) -> DVector<f64> {
        match &self.scale {
            None => self.chol.solve(b),
            Some(s) => {
                let sb = DVector::from_fn(b.len(), |i, _| b[i] * s[i]);
                let y = self.chol.solve(&sb);
                DVector::from_fn(y.len(), |i, _| y[i] * s[i])
            }
        }
    }

    /// `ln det A = 2 Σ ln L_ii` (under Jacobi scaling `ln det G − 2 Σ ln s_i`).
    pub fn ln_det(&self) -> f64 {
        let g = 2.0
            * self
                .chol
                .l_dirty()
                .diagonal()
                .iter()
                .map(|d| d.ln())
                .sum::<f64>();
        match &self.scale {
            None => g,
            Some(s) => g - 2.0 * s.iter().map(|x| x.ln()).sum::<f64>(),
        }
    }
}

/// `A⁻¹` with a check that every entry is finite (the factorisation of a matrix singular to
/// working precision can succeed and its inverse still overflow).
pub fn spd_inverse(a: &DMatrix<f64>, opts: &SpdOptions) -> Result<DMatrix<f64>, LinalgError> {
    let inv = opts.factor(a)?.inverse();
    for j in 0..inv.ncols() {
        for i in 0..inv.nrows() {
            let value = inv[(i, j)];
            if !value.is_finite() {
                return Err(LinalgError::InverseNotFinite {
                    row: i,
                    col: j,
                    value,
                });
            }
        }
    }
    Ok(inv)
}

/// The symmetric matrix whose lower triangle is `a`'s.
fn mirror_lower(a: &DMatrix<f64>) -> DMatrix<f64> {
    DMatrix::from_fn(a.nrows(), a.ncols(), |i, j| {
        if j <= i { a[(i, j)] } else { a[(j, i)] }
    })
}

/// `|a_ij − a_ji| ≤ tol · √a_ii · √a_jj` for every pair (a NaN bound, from a negative diagonal
/// entry, passes: the factorisation then fails on that entry and says so).
fn check_symmetric(a: &DMatrix<f64>, tol: f64) -> Result<(), LinalgError> {
    for i in 0..a.nrows() {
        for j in 0..i {
            if (a[(i, j)] - a[(j, i)]).abs() > tol * a[(i, i)].sqrt() * a[(j, j)].sqrt() {
                return Err(LinalgError::NotSymmetric {
                    row: i,
                    col: j,
                    lower: a[(i, j)],
                    upper: a[(j, i)],
                });
            }
        }
    }
    Ok(())
}
