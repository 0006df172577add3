//! The directions a symmetric (Fisher) matrix does not constrain, from the eigen decomposition
//! of its correlation form.

use nalgebra::DMatrix;

use super::symmetric::{jacobi_scaled, symmetric_eigen};

/// Relative eigenvalue (of the Fisher matrix in correlation form, divided by its largest)
/// below which a direction counts as unconstrained. Rounding alone leaves eigenvalues of a
/// few `ε·d` ≈ 1e-15 in an exactly singular matrix; a physical degeneracy strong enough to
/// matter (a correlation of 1 − 10⁻¹⁰ between two parameters) is far above that, and no
/// study of the project comes near it (the Table I study's smallest is ≈ 1e-4).
pub const NULL_EIGENVALUE_TOL: f64 = 1e-10;

/// Weights below this (of a unit eigenvector) are left out of a direction's description:
/// such a parameter moves by less than a tenth of the others along it.
const MIN_WEIGHT: f64 = 0.1;

/// Why a direction is unconstrained (see [`unconstrained_directions`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NullKind {
    /// The parameter's diagonal entry is not positive (a Gram matrix's is then zero with its
    /// whole row): `ln L` does not depend on it at all (e.g. an actuator of a test mass that
    /// no experiment forces).
    ZeroColumn,
    /// The parameter's row has a non-finite entry: its derivative cannot be evaluated there.
    NonFinite,
    /// A combination of parameters whose curvature is (almost) zero relative to the best
    /// constrained one: the data move them together.
    Degenerate,
}

/// A direction of parameter space the Fisher matrix does not constrain.
#[derive(Debug, Clone, PartialEq)]
pub struct NullDirection {
    /// Why it is unconstrained.
    pub kind: NullKind,
    /// Eigenvalue of the correlation form `F_ij / √(F_ii F_jj)` divided by its largest
    /// eigenvalue, clamped at 0 (0 for [`NullKind::ZeroColumn`], NaN for
    /// [`NullKind::NonFinite`]).
    pub relative_eigenvalue: f64,
    /// The unit eigenvector in the scaled coordinates `√F_ii θ_i` (each parameter in units of
    /// its own Fisher scale, so weights are comparable across units), as (row of the matrix,
    /// weight): every weight of magnitude ≥ 0.1, largest magnitude first, signed so that the
    /// first weight is positive.
    pub weights: Vec<(usize, f64)>,
}

/// The directions along which the Fisher matrix `f` (symmetric) is singular or nearly so:
/// parameters with a non-positive diagonal entry (or a non-finite row) first, then the
/// eigenvectors of the correlation form of the rest whose eigenvalue is below `rel_tol` times
/// the largest (use [`NULL_EIGENVALUE_TOL`]).
///
/// The correlation form is used because a Fisher matrix in SI units spans many decades on its
/// diagonal (ω² against delays: 10¹⁸), which would make the eigenvalues of `f` itself measure
/// the units, not the information. Its eigenvalues do not depend on the parameters' units.
/// Within a null space of dimension > 1 the eigenvectors are any orthonormal basis of it:
/// the parameters named are right, the individual weights are one choice among many.
///
/// ```
/// use nalgebra::DMatrix;
/// use occam::linalg::{NULL_EIGENVALUE_TOL, NullKind, unconstrained_directions};
/// // b is a in other units (∂/∂b = 10⁻³ ∂/∂a): rank one
/// let f = DMatrix::from_row_slice(2, 2, &[1.0, 1e-3, 1e-3, 1e-6]);
/// let d = &unconstrained_directions(&f, NULL_EIGENVALUE_TOL)[0];
/// assert_eq!(d.kind, NullKind::Degenerate);
/// assert_eq!(d.weights.len(), 2);
/// ```
pub fn unconstrained_directions(f: &DMatrix<f64>, rel_tol: f64) -> Vec<NullDirection> {
    let n = f.nrows();
    let mut out = Vec::new();
    let mut rest = Vec::with_capacity(n);
    for i in 0..n {
        if (0..n).any(|j| !f[(i, j)].is_finite() || !f[(j, i)].is_finite()) {
            out.push(NullDirection {
                kind: NullKind::NonFinite,
                relative_eigenvalue: f64::NAN,
                weights: vec![(i, 1.0)],
            });
        } else if f[(i, i)] <= 0.0 {
            // a Gram matrix's diagonal is ≥ 0 and is 0 only with its whole row
            out.push(NullDirection {
                kind: NullKind::ZeroColumn,
                relative_eigenvalue: 0.0,
                weights: vec![(i, 1.0)],
            });
        } else {
            rest.push(i);
        }
    }
    if rest.is_empty() {
        return out;
    }
    let m = rest.len();
    let s: Vec<f64> = rest.iter().map(|&i| 1.0 / f[(i, i)].sqrt()).collect();
    let c = jacobi_scaled(&f.select_rows(&rest).select_columns(&rest), &s);
    let eig = symmetric_eigen(c);
    let largest = eig.eigenvalues.iter().copied().fold(f64::MIN, f64::max);
    let mut found: Vec<NullDirection> = (0..m)
        .filter_map(|k| {
            let rel = eig.eigenvalues[k] / largest;
            (rel < rel_tol).then(|| {
                let v = eig.eigenvectors.column(k);
                let mut w: Vec<(usize, f64)> = (0..m)
                    .filter(|&a| v[a].abs() >= MIN_WEIGHT)
                    .map(|a| (rest[a], v[a]))
                    .collect();
                w.sort_by(|p, q| q.1.abs().total_cmp(&p.1.abs()).then(p.0.cmp(&q.0)));
                if w.first().is_some_and(|p| p.1 < 0.0) {
                    w.iter_mut().for_each(|p| p.1 = -p.1);
                }
                NullDirection {
                    kind: NullKind::Degenerate,
                    relative_eigenvalue: rel.max(0.0),
                    weights: w,
                }
            })
        })
        .collect();
    found.sort_by(|p, q| p.relative_eigenvalue.total_cmp(&q.relative_eigenvalue));
    out.extend(found);
    out
}

/// The least-constrained direction of `f` (smallest relative eigenvalue of the correlation
/// form, or a non-positive diagonal entry / non-finite row): what to name when `f` failed a
/// Cholesky factorisation although no eigenvalue is below [`NULL_EIGENVALUE_TOL`].
pub fn weakest_direction(f: &DMatrix<f64>) -> Option<NullDirection> {
    unconstrained_directions(f, f64::INFINITY)
        .into_iter()
        .next()
}

/// `0.71·a1 − 0.70·f_o1`: a direction's weights with the rows' names (`#i` for a row without
/// one).
pub fn format_direction(d: &NullDirection, names: &[String]) -> String {
    let mut s = String::new();
    for (k, &(i, w)) in d.weights.iter().enumerate() {
        let name = row_name(names, i);
        if k == 0 {
            if w < 0.0 {
                s.push('−');
            }
        } else {
            s.push_str(if w < 0.0 { " − " } else { " + " });
        }
        s.push_str(&format!("{:.2}·{name}", w.abs()));
    }
    s
}

/// The name of row `i`: the caller's, or `#i`.
pub(super) fn row_name(names: &[String], i: usize) -> String {
    names.get(i).cloned().unwrap_or_else(|| format!("#{i}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(v: &[&str]) -> Vec<String> {
        v.iter().map(|s| s.to_string()).collect()
    }

    /// `F = D G D`: `G` in other units `D` (spanning 10¹² here, as ω² against delays).
    fn scaled(g: &DMatrix<f64>, d: &[f64]) -> DMatrix<f64> {
        DMatrix::from_fn(g.nrows(), g.ncols(), |i, j| g[(i, j)] * d[i] * d[j])
    }

    #[test]
    fn a_constructed_null_space_is_found_whatever_the_units() {
        // G = I − v vᵀ with v = (1, 1, 0)/√2 has null vector v; its correlation form
        // [[1, −1, 0], [−1, 1, 0], [0, 0, 1]] has the same null vector (its diagonal is equal
        // on the two), whatever the units D of F = D G D.
        let v = [1.0 / 2f64.sqrt(), 1.0 / 2f64.sqrt(), 0.0];
        let g = DMatrix::from_fn(3, 3, |i, j| (if i == j { 1.0 } else { 0.0 }) - v[i] * v[j]);
        // units: ω² (1e-6), a gain (1), a delay (1e3 in F)
        let f = scaled(&g, &[1e9, 1.0, 1e-3]);
        let dirs = unconstrained_directions(&f, NULL_EIGENVALUE_TOL);
        assert_eq!(dirs.len(), 1, "{dirs:?}");
        let d = &dirs[0];
        assert_eq!(d.kind, NullKind::Degenerate);
        assert!(d.relative_eigenvalue < 1e-15, "{}", d.relative_eigenvalue);
        assert_eq!(d.weights.len(), 2, "{d:?}");
        assert_eq!((d.weights[0].0, d.weights[1].0), (0, 1));
        let w = 1.0 / 2f64.sqrt();
        assert!((d.weights[0].1 - w).abs() < 1e-12 && (d.weights[1].1 - w).abs() < 1e-12);
        let n = names(&["w1sq", "a1", "tau_c1"]);
        assert_eq!(format_direction(d, &n), "0.71·w1sq + 0.71·a1");
        assert_eq!(format_direction(d, &[]), "0.71·#0 + 0.71·#1");
        // a well-conditioned matrix has none; its weakest direction is still named on demand
        let ok = DMatrix::from_row_slice(2, 2, &[2.0, 0.5, 0.5, 1.0]);
        assert!(unconstrained_directions(&ok, NULL_EIGENVALUE_TOL).is_empty());
        let weak = weakest_direction(&ok).unwrap();
        // correlation form [[1, c], [c, 1]], c = 0.5/√2: eigenvalues 1 ± c, null-most (1, −1)
        let c = 0.5 / 2f64.sqrt();
        assert!((weak.relative_eigenvalue - (1.0 - c) / (1.0 + c)).abs() < 1e-12);
        assert_eq!(
            format_direction(&weak, &names(&["x", "y"])),
            "0.71·x − 0.71·y"
        );
    }

    #[test]
    fn a_parameter_with_a_zero_column_is_named_alone() {
        // a1 (row 1) has no information; w1sq and w2sq are fine and correlated at 0.9
        let f = DMatrix::from_row_slice(
            3,
            3,
            &[
                4e12,
                0.0,
                0.9 * 2e6 * 3e6,
                0.0,
                0.0,
                0.0,
                0.9 * 2e6 * 3e6,
                0.0,
                9e12,
            ],
        );
        let dirs = unconstrained_directions(&f, NULL_EIGENVALUE_TOL);
        assert_eq!(
            dirs,
            vec![NullDirection {
                kind: NullKind::ZeroColumn,
                relative_eigenvalue: 0.0,
                weights: vec![(1, 1.0)],
            }]
        );
        // every column zero
        let z = DMatrix::<f64>::zeros(2, 2);
        assert_eq!(unconstrained_directions(&z, NULL_EIGENVALUE_TOL).len(), 2);
        // a non-finite row
        let mut nf = DMatrix::<f64>::identity(2, 2);
        nf[(0, 1)] = f64::NAN;
        nf[(1, 0)] = f64::NAN;
        let d = unconstrained_directions(&nf, NULL_EIGENVALUE_TOL);
        assert_eq!(d.len(), 2);
        assert!(d.iter().all(|d| d.kind == NullKind::NonFinite));
    }

    #[test]
    fn two_perfectly_correlated_parameters_make_one_null_direction() {
        // ∂r/∂b = 10⁻³ ∂r/∂a in every bin (the same effect in other units): the (a, b) block
        // has rank one; c is independent
        let ga = [2.0, 1.0, -3.0];
        let gb = ga.map(|x| x * 1e-3);
        let gc = [0.5, -1.0, 0.25];
        let cols = [ga, gb, gc];
        let f = DMatrix::from_fn(3, 3, |i, j| (0..3).map(|k| cols[i][k] * cols[j][k]).sum());
        let dirs = unconstrained_directions(&f, NULL_EIGENVALUE_TOL);
        assert_eq!(dirs.len(), 1, "{dirs:?}");
        let d = &dirs[0];
        assert_eq!(d.kind, NullKind::Degenerate);
        // in scaled coordinates a and b are the same column: null vector (1, −1, 0)/√2
        let w = 1.0 / 2f64.sqrt();
        assert_eq!(d.weights.len(), 2);
        assert!((d.weights[0].1 - w).abs() < 1e-9 && (d.weights[1].1 + w).abs() < 1e-9);
        let mut idx: Vec<usize> = d.weights.iter().map(|p| p.0).collect();
        idx.sort();
        assert_eq!(idx, [0, 1]);
    }

    #[test]
    fn a_two_dimensional_null_space_gives_two_directions() {
        // rank 1 over 3 parameters (all columns proportional) and a fourth independent one
        let g = [
            [1.0, 2.0, 0.0],
            [2.0, 4.0, 0.0],
            [-1.0, -2.0, 0.0],
            [0.0, 0.0, 1.0],
        ];
        let f = DMatrix::from_fn(4, 4, |i, j| (0..3).map(|k| g[i][k] * g[j][k]).sum());
        let dirs = unconstrained_directions(&f, NULL_EIGENVALUE_TOL);
        assert_eq!(dirs.len(), 2, "{dirs:?}");
        let mut rows: Vec<usize> = dirs
            .iter()
            .flat_map(|d| d.weights.iter().map(|w| w.0))
            .collect();
        rows.sort();
        rows.dedup();
        assert_eq!(rows, [0, 1, 2]);
    }
}
