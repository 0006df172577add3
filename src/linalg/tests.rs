//! Known answers for [`super::Spd`] and the slow oracles of the allocation-free kernels.

use nalgebra::{DMatrix, DVector};
use rand::{RngExt, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

use super::*;

fn names(v: &[&str]) -> Vec<String> {
    v.iter().map(|s| s.to_string()).collect()
}

/// A random symmetric positive-definite `n × n` matrix `D (B Bᵀ + I) D` with `D` log-uniform
/// over `10^±spread` (a Fisher matrix in mixed SI units for `spread` = 9), exactly symmetric.
fn random_spd(rng: &mut Xoshiro256PlusPlus, n: usize, spread: f64) -> DMatrix<f64> {
    let b = DMatrix::from_fn(n, n, |_, _| rng.random::<f64>() * 2.0 - 1.0);
    let d: Vec<f64> = (0..n)
        .map(|_| 10f64.powf(spread * (2.0 * rng.random::<f64>() - 1.0)))
        .collect();
    let g = &b * b.transpose() + DMatrix::identity(n, n);
    let a = DMatrix::from_fn(n, n, |i, j| g[(i, j)] * d[i] * d[j]);
    symmetrised(&a)
}

fn row_major(a: &DMatrix<f64>) -> Vec<f64> {
    let n = a.nrows();
    (0..n * n).map(|k| a[(k / n, k % n)]).collect()
}

#[test]
fn a_two_by_two_has_its_known_factor_inverse_solve_and_determinant() {
    // [[4, 2], [2, 5]] = L Lᵀ with L = [[2, 0], [1, 2]]; det 16; inverse [[5, −2], [−2, 4]]/16
    let a = DMatrix::from_row_slice(2, 2, &[4.0, 2.0, 2.0, 5.0]);
    let spd = Spd::new(&a).unwrap();
    assert_eq!(spd.dim(), 2);
    assert_eq!(spd.l_row_major(), [2.0, 0.0, 1.0, 2.0]);
    assert_eq!(
        spd.l(),
        DMatrix::from_row_slice(2, 2, &[2.0, 0.0, 1.0, 2.0])
    );
    assert!((spd.ln_det() - 16f64.ln()).abs() < 1e-15);
    let want = DMatrix::from_row_slice(2, 2, &[5.0, -2.0, -2.0, 4.0]) / 16.0;
    assert!((spd.inverse() - want).amax() < 1e-16);
    // A x = (1, 2)ᵀ: x = (5 − 4, −2 + 8)/16
    let x = spd.solve(&DVector::from_vec(vec![1.0, 2.0]));
    assert!((x[0] - 1.0 / 16.0).abs() < 1e-16 && (x[1] - 6.0 / 16.0).abs() < 1e-16);
    // the kernel on the same matrix, and its ln det
    let mut l = row_major(&a);
    cholesky_in_place(&mut l, 2, 0.0).unwrap();
    assert_eq!(l, [2.0, 0.0, 1.0, 2.0]);
    assert!((ln_det_lower(&l, 2) - 16f64.ln()).abs() < 1e-15);
}

#[test]
fn jacobi_scaling_inverts_a_matrix_spanning_36_decades() {
    // a Fisher matrix with ω²-like and delay-like scales (10³⁶ apart on the diagonal):
    // F = S C S, so F⁻¹ = S⁻¹ C⁻¹ S⁻¹ with C the correlation matrix
    let s = [1e18, 1.0, 1e-2];
    let c = DMatrix::from_row_slice(3, 3, &[1.0, 0.3, -0.2, 0.3, 1.0, 0.5, -0.2, 0.5, 1.0]);
    let f = DMatrix::from_fn(3, 3, |i, j| c[(i, j)] * s[i] * s[j]);
    let cinv = c.clone().try_inverse().unwrap();
    let opts = SpdOptions::lower().jacobi();
    let spd = opts.factor(&f).unwrap();
    let inv = spd.inverse();
    for i in 0..3 {
        for j in 0..3 {
            let want = cinv[(i, j)] / (s[i] * s[j]);
            assert!(
                (inv[(i, j)] - want).abs() <= 1e-12 * want.abs(),
                "{i},{j}: {} vs {want}",
                inv[(i, j)]
            );
        }
    }
    assert_eq!(spd_inverse(&f, &opts).unwrap(), inv);
    // singular, or a zero diagonal entry: refused
    let sing = DMatrix::from_row_slice(2, 2, &[1.0, 1.0, 1.0, 1.0]);
    assert!(spd_inverse(&sing, &opts).is_err());
    let zero = DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 0.0, 0.0]);
    assert!(spd_inverse(&zero, &opts).is_err());
    // ln det F = ln det C + 2 Σ ln s_i; L Lᵀ = F; F x = b
    let ln_det_c = c.clone().cholesky().unwrap().determinant().ln();
    let want = ln_det_c + 2.0 * s.iter().map(|x| x.ln()).sum::<f64>();
    assert!((spd.ln_det() - want).abs() < 1e-12 * want.abs());
    let l = spd.l();
    let back = &l * l.transpose();
    for i in 0..3 {
        for j in 0..3 {
            assert!((back[(i, j)] - f[(i, j)]).abs() <= 1e-14 * s[i] * s[j]);
        }
    }
    let b = DVector::from_vec(vec![1e18, 0.0, 1e-2]);
    let x = spd.solve(&b);
    for i in 0..3 {
        let want = (cinv[(i, 0)] + cinv[(i, 2)]) / s[i];
        assert!((x[i] - want).abs() <= 1e-12 * want.abs(), "{i}");
    }
}

#[test]
fn jacobi_inverse_is_the_scaled_formula_to_the_bit() {
    // the arithmetic the select job's proposal covariance was recorded with
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(11);
    for n in 1..8 {
        let f = random_spd(&mut rng, n, 9.0);
        let s: Vec<f64> = (0..n).map(|i| 1.0 / f[(i, i)].sqrt()).collect();
        let g = DMatrix::from_fn(n, n, |i, j| f[(i, j)] * s[i] * s[j]);
        let inv = g.cholesky().unwrap().inverse();
        let want = DMatrix::from_fn(n, n, |i, j| inv[(i, j)] * s[i] * s[j]);
        let got = spd_inverse(&f, &SpdOptions::lower().jacobi()).unwrap();
        assert_eq!(got, want, "n = {n}");
    }
}

#[test]
fn the_in_place_kernel_is_nalgebras_factor_to_the_bit() {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(7);
    for n in 1..=12 {
        for spread in [0.0, 3.0, 9.0] {
            let a = random_spd(&mut rng, n, spread);
            let slow = SpdOptions::lower().factor(&a).unwrap();
            let mut fast = row_major(&a);
            cholesky_in_place(&mut fast, n, 0.0).unwrap();
            assert_eq!(fast, slow.l_row_major(), "n = {n}, spread {spread}");
            assert_eq!(ln_det_lower(&fast, n), slow.ln_det(), "n = {n}");
            // and both are nalgebra's own
            let direct = a.clone().cholesky().unwrap();
            assert_eq!(slow.l(), direct.l());
            assert_eq!(slow.inverse(), direct.inverse());
        }
    }
}

/// The row-oriented factorisation FAST-MCD used before this module, with `ln det` summed as it
/// went: the oracle that its C-steps keep their numbers on [`cholesky_in_place`] and
/// [`ln_det_lower`].
fn row_oriented(a: &[f64], p: usize) -> Option<(Vec<f64>, f64)> {
    let mut l = vec![0.0; p * p];
    let mut ln_det = 0.0;
    for i in 0..p {
        for j in 0..=i {
            let mut s = a[i * p + j];
            for k in 0..j {
                s -= l[i * p + k] * l[j * p + k];
            }
            if i == j {
                if s.is_nan() || s <= 1e-12 * a[i * p + i] || !s.is_finite() {
                    return None;
                }
                let d = s.sqrt();
                l[i * p + i] = d;
                ln_det += 2.0 * d.ln();
            } else {
                l[i * p + j] = s / l[j * p + j];
            }
        }
    }
    Some((l, ln_det))
}

#[test]
fn the_kernel_with_a_floor_is_the_old_row_oriented_factorisation_to_the_bit() {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(3);
    for n in 1..=10 {
        for spread in [0.0, 4.0] {
            let a = row_major(&random_spd(&mut rng, n, spread));
            let (want, want_ln_det) = row_oriented(&a, n).unwrap();
            let mut l = a.clone();
            cholesky_in_place(&mut l, n, 1e-12).unwrap();
            assert_eq!(l, want, "n = {n}");
            assert_eq!(ln_det_lower(&l, n), want_ln_det, "n = {n}");
        }
    }
    // singular to working precision: x and x + 1e-14 y; refused with the floor, both ways
    let (x, y) = ([1.0, 2.0, 3.0], [0.3, -0.1, 0.2]);
    let v: Vec<[f64; 3]> = vec![
        x,
        [
            x[0] + 1e-14 * y[0],
            x[1] + 1e-14 * y[1],
            x[2] + 1e-14 * y[2],
        ],
    ];
    let a: Vec<f64> = (0..4)
        .map(|k| (0..3).map(|m| v[k / 2][m] * v[k % 2][m]).sum())
        .collect();
    assert!(row_oriented(&a, 2).is_none());
    let mut l = a.clone();
    assert_eq!(
        cholesky_in_place(&mut l, 2, 1e-12),
        Err(LinalgError::NotPositiveDefinite {
            pivot: Some(1),
            weakest: None,
        })
    );
}

#[test]
fn the_kernel_refuses_non_positive_and_non_finite_pivots() {
    for bad in [
        [1.0, 0.0, 2.0, 1.0],      // indefinite: pivot 1 = 1 − 4
        [0.0, 0.0, 0.0, 1.0],      // zero pivot 0
        [f64::NAN, 0.0, 0.0, 1.0], // NaN
        [1.0, 0.0, f64::INFINITY, 1.0],
    ] {
        let mut a = bad;
        let e = cholesky_in_place(&mut a, 2, 0.0).unwrap_err();
        assert!(e.to_string().contains("Cholesky pivot"), "{e}");
        // the general path refuses it too
        let m = DMatrix::from_row_slice(2, 2, &bad);
        assert!(SpdOptions::lower().factor(&m).is_err(), "{bad:?}");
    }
}

#[test]
fn forward_solve_matches_nalgebras_triangular_solve() {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(5);
    for n in 1..=8 {
        let a = random_spd(&mut rng, n, 2.0);
        let spd = Spd::new(&a).unwrap();
        let x: Vec<f64> = (0..n).map(|_| rng.random::<f64>() - 0.5).collect();
        let z = spd
            .l()
            .solve_lower_triangular(&DVector::from_vec(x.clone()))
            .unwrap();
        let mut fast = x.clone();
        let q = forward_solve_norm2(&spd.l_row_major(), n, &mut fast);
        for i in 0..n {
            assert!((fast[i] - z[i]).abs() <= 1e-12 * z.amax(), "n = {n}");
        }
        // |z|² = xᵀ A⁻¹ x
        let want =
            (DVector::from_vec(x.clone()).transpose() * spd.solve(&DVector::from_vec(x)))[(0, 0)];
        assert!((q - want).abs() <= 1e-10 * want, "{q} vs {want}");
    }
    // xᵀ A⁻¹ x with A = [[4, 1], [1, 3]], A⁻¹ = [[3, −1], [−1, 4]]/11, x = (1, 2)
    let l = Spd::new(&DMatrix::from_row_slice(2, 2, &[4.0, 1.0, 1.0, 3.0]))
        .unwrap()
        .l_row_major();
    let q = forward_solve_norm2(&l, 2, &mut [1.0, 2.0]);
    assert!((q - (3.0 - 4.0 + 16.0) / 11.0).abs() < 1e-14);
}

#[test]
fn errors_say_what_is_wrong() {
    let e = Spd::new(&DMatrix::zeros(2, 3)).unwrap_err();
    assert_eq!(e, LinalgError::NotSquare { rows: 2, cols: 3 });
    assert!(e.to_string().contains("not square"));
    let nan = DMatrix::from_row_slice(2, 2, &[1.0, f64::NAN, 0.0, 1.0]);
    assert!(matches!(
        Spd::new(&nan),
        Err(LinalgError::NonFinite { row: 0, col: 1, .. })
    ));
    // the lower-triangle mode neither reads nor checks the upper triangle
    assert_eq!(
        SpdOptions::lower().factor(&nan).unwrap().l(),
        DMatrix::identity(2, 2)
    );
    let asym = DMatrix::from_row_slice(2, 2, &[1.0, 0.5, 0.0, 1.0]);
    let e = Spd::new(&asym).unwrap_err();
    assert!(
        matches!(e, LinalgError::NotSymmetric { row: 1, col: 0, .. }),
        "{e}"
    );
    assert!(e.to_string().contains("not symmetric"), "{e}");
    // within the tolerance, (A + Aᵀ)/2 is factored: the tolerance is in the rows' own scale
    let s = [1e9, 1e-3];
    let mut f = DMatrix::from_fn(2, 2, |i, j| if i == j { 2.0 } else { 0.5 } * s[i] * s[j]);
    f[(0, 1)] *= 1.0 + 1e-10;
    let spd = Spd::new(&f).unwrap();
    assert_eq!(spd.l(), symmetrised(&f).cholesky().unwrap().l());
    f[(0, 1)] *= 1.0 + 1e-6;
    assert!(matches!(
        Spd::new(&f),
        Err(LinalgError::NotSymmetric { .. })
    ));
}

#[test]
fn a_singular_matrix_names_its_unconstrained_direction() {
    // b = 2a, in any units: the correlation form is [[1, 1], [1, 1]], null vector (1, −1)/√2
    let n = names(&["a", "b", "c"]);
    let f = DMatrix::from_row_slice(3, 3, &[1.0, 2e6, 0.0, 2e6, 4e12, 0.0, 0.0, 0.0, 1.0]);
    for opts in [
        SpdOptions::default(),
        SpdOptions::lower(),
        SpdOptions::default().jacobi(),
    ] {
        let e = opts.names(&n).factor(&f).unwrap_err();
        let LinalgError::NotPositiveDefinite {
            weakest: Some(w), ..
        } = &e
        else {
            panic!("{e:?}");
        };
        assert_eq!(w.direction.kind, NullKind::Degenerate);
        assert_eq!(w.names, n);
        assert_eq!(e.unconstrained(), ["a", "b"]);
        assert!(
            e.to_string().starts_with(
                "not positive definite; its least-constrained direction is 0.71·a − 0.71·b (relative eigenvalue of the correlation form"
            ),
            "{e}"
        );
    }
    // without names the rows are numbered
    let e = Spd::new(&f).unwrap_err();
    assert!(e.to_string().contains("0.71·#0 − 0.71·#1"), "{e}");
    // a non-positive diagonal entry is named alone, scaled or not
    let z = DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 0.0, -1.0]);
    for opts in [SpdOptions::default(), SpdOptions::default().jacobi()] {
        let e = opts.names(&n).factor(&z).unwrap_err();
        assert_eq!(e.unconstrained(), ["b"]);
        assert!(
            e.to_string()
                .ends_with("the diagonal entry of `b` is not > 0"),
            "{e}"
        );
    }
    // indefinite with a positive diagonal: the negative eigenvalue's direction
    let ind = DMatrix::from_row_slice(2, 2, &[1.0, 2.0, 2.0, 1.0]);
    let e = Spd::new(&ind).unwrap_err();
    assert!(
        e.to_string()
            .contains("0.71·#0 − 0.71·#1 (relative eigenvalue of the correlation form ≤ 0)"),
        "{e}"
    );
}

#[test]
fn unit_diagonal_zeroes_unconstrained_rows() {
    let a = DMatrix::from_row_slice(3, 3, &[4.0, 1.0, 0.0, 1.0, 9.0, 0.0, 0.0, 0.0, 0.0]);
    let (g, d) = unit_diagonal(&a);
    assert_eq!(d, [2.0, 3.0, 0.0]);
    assert_eq!(
        g,
        DMatrix::from_row_slice(
            3,
            3,
            &[1.0, 1.0 / 6.0, 0.0, 1.0 / 6.0, 1.0, 0.0, 0.0, 0.0, 0.0]
        )
    );
    let eig = symmetric_eigen(g);
    let mut v: Vec<f64> = eig.eigenvalues.iter().copied().collect();
    v.sort_by(f64::total_cmp);
    let want = [0.0, 5.0 / 6.0, 7.0 / 6.0];
    for (x, w) in v.iter().zip(want) {
        assert!((x - w).abs() < 1e-15, "{v:?}");
    }
}
