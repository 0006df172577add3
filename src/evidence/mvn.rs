//! Probability of a rectangle under a multivariate normal distribution.
//!
//! # Method
//! Genz (1992), "Numerical computation of multivariate normal probabilities", J. Comput. Graph.
//! Stat. 1, 141–149: with `Σ = L Lᵀ` (Cholesky) the rectangle probability becomes, by separation
//! of variables,
//!
//! ```text
//! P = ∫_{[0,1]^{D−1}} Π_{i=1}^{D} (e_i − d_i) dw,
//! d_i = Φ((a_i − Σ_{j<i} L_ij y_j)/L_ii),  e_i = Φ((b_i − Σ_{j<i} L_ij y_j)/L_ii),
//! y_j = Φ⁻¹(d_j + w_j (e_j − d_j)),
//! ```
//!
//! an integral over a (D−1)-cube of a smooth bounded integrand. It is evaluated by randomised
//! quasi-Monte Carlo: a Richtmyer (Kronecker) lattice `x_j = frac(j·√p_i + Δ_i)` (p_i the i-th
//! prime) with `M` independent uniform shifts `Δ` and the baker's transform `|2x − 1|`. The `M`
//! shift averages are independent unbiased estimates, so their spread gives an honest standard
//! error; a pilot chooses the point count and a fresh set of shifts gives the reported value, so
//! the stopping rule cannot bias the error low. Variables are first reordered by the Gibson–Glasbey–Elston rule (tightest conditional
//! interval first; Genz & Bretz 2009 §4.1.3), which changes only the variance.
//!
//! D = 1 is computed exactly with `erfc`. Everything is done in logs, including the conditional
//! draws, so that tiny masses (a Gaussian hundreds of σ outside a box) stay finite and keep
//! their relative precision.

use super::error::EvidenceError;
use super::normal;
use crate::linalg::Spd;
use nalgebra::DMatrix;
use rand::{RngExt, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;
use serde::{Deserialize, Serialize};

/// Settings of the randomised quasi-Monte Carlo integration.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MvnOptions {
    /// Seed of the random shifts (same seed, same number).
    pub seed: u64,
    /// Number `M` of independent random shifts (≥ 4; the error uses their spread).
    pub n_shifts: usize,
    /// Lattice points per shift in the first round; doubled each round until converged.
    pub initial_points: usize,
    /// Upper bound on integrand evaluations (all shifts together).
    pub max_evals: usize,
    /// Stop when the standard error is below `rel_tol · P` (default 1e−3: an error of 0.001
    /// in ln P, negligible next to any evidence estimate) …
    pub rel_tol: f64,
    /// … or below `abs_tol` (0: off).
    pub abs_tol: f64,
}

impl Default for MvnOptions {
    fn default() -> Self {
        Self {
            seed: 0x6e6f_726d_616c,
            n_shifts: 16,
            initial_points: 256,
            max_evals: 1_000_000,
            rel_tol: 1e-3,
            abs_tol: 0.0,
        }
    }
}

/// A rectangle probability with its Monte-Carlo error.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct MvnProbability {
    /// `P` (may underflow to 0 where `ln_p` is still finite).
    pub p: f64,
    /// `ln P`.
    pub ln_p: f64,
    /// One-sigma standard error of `P` (0 for the exact paths).
    pub std_err: f64,
    /// One-sigma standard error of `ln P` (`std_err / P`).
    pub ln_p_std_err: f64,
    /// Integrand evaluations used.
    pub n_evals: usize,
    /// Whether the pilot met the tolerance within `max_evals`. The reported error comes from an
    /// independent final pass at the chosen point count, so it scatters around the tolerance.
    pub converged: bool,
}

impl MvnProbability {
    fn exact(ln_p: f64) -> Self {
        Self {
            p: ln_p.exp(),
            ln_p,
            std_err: 0.0,
            ln_p_std_err: 0.0,
            n_evals: 0,
            converged: true,
        }
    }
}

/// `P(lower ≤ X ≤ upper)` for `X ~ N(mean, cov)`; bounds may be `±∞`.
///
/// ```
/// use nalgebra::DMatrix;
/// use occam::evidence::mvn::{mvn_rectangle, MvnOptions};
/// // Bivariate orthant probability: P(X1 > 0, X2 > 0) = 1/4 + asin(ρ)/(2π).
/// let rho: f64 = 0.6;
/// let cov = DMatrix::from_row_slice(2, 2, &[1.0, rho, rho, 1.0]);
/// let inf = f64::INFINITY;
/// let r = mvn_rectangle(&[0.0, 0.0], &[inf, inf], &[0.0, 0.0], &cov, &MvnOptions::default()).unwrap();
/// let exact = 0.25 + rho.asin() / (2.0 * std::f64::consts::PI);
/// assert!((r.p - exact).abs() < 5.0 * r.std_err + 1e-12);
/// ```
pub fn mvn_rectangle(
    lower: &[f64],
    upper: &[f64],
    mean: &[f64],
    cov: &DMatrix<f64>,
    opts: &MvnOptions,
) -> Result<MvnProbability, EvidenceError> {
    let d = mean.len();
    if lower.len() != d {
        return Err(EvidenceError::dimension("mvn lower bounds", d, lower.len()));
    }
    if upper.len() != d {
        return Err(EvidenceError::dimension("mvn upper bounds", d, upper.len()));
    }
    if cov.nrows() != d || cov.ncols() != d {
        return Err(EvidenceError::dimension(
            "mvn covariance rows",
            d,
            cov.nrows().max(cov.ncols()),
        ));
    }
    validate_options(opts)?;
    for i in 0..d {
        if !mean[i].is_finite() {
            return Err(EvidenceError::non_finite(
                format!("mvn mean[{i}]"),
                mean[i],
                "pass a finite centre",
            ));
        }
        if lower[i].is_nan() || upper[i].is_nan() || lower[i] > upper[i] {
            return Err(EvidenceError::option(
                &format!("mvn bounds[{i}]"),
                format!("[{}, {}]", lower[i], upper[i]),
                "each bound pair needs lower ≤ upper (±∞ allowed, NaN not)",
            ));
        }
    }
    if d == 0 {
        return Ok(MvnProbability::exact(0.0));
    }
    let chol = Spd::new(cov).map_err(EvidenceError::matrix(
        "mvn covariance",
        "pass a positive-definite covariance",
    ))?;
    if lower.iter().zip(upper).any(|(a, b)| a == b) {
        return Ok(MvnProbability::exact(f64::NEG_INFINITY));
    }
    if d == 1 {
        let s = chol.l()[(0, 0)];
        let ln_p = normal::ln_interval((lower[0] - mean[0]) / s, (upper[0] - mean[0]) / s);
        return Ok(MvnProbability::exact(ln_p));
    }
    let prep = Prepared::new(lower, upper, mean, cov)?;
    Ok(prep.integrate(opts))
}

fn validate_options(o: &MvnOptions) -> Result<(), EvidenceError> {
    if o.n_shifts < 4 {
        return Err(EvidenceError::option(
            "mvn n_shifts",
            o.n_shifts,
            "use at least 4 shifts so the error estimate has 3 degrees of freedom",
        ));
    }
    if o.initial_points == 0 || o.max_evals < 2 * o.n_shifts * o.initial_points {
        return Err(EvidenceError::option(
            "mvn max_evals",
            o.max_evals,
            "need initial_points ≥ 1 and max_evals ≥ 2·n_shifts·initial_points (pilot and final pass)",
        ));
    }
    if !(o.rel_tol >= 0.0 && o.abs_tol >= 0.0) {
        return Err(EvidenceError::option(
            "mvn tolerances",
            format!("rel {} abs {}", o.rel_tol, o.abs_tol),
            "tolerances must be ≥ 0",
        ));
    }
    Ok(())
}

/// The reordered, centred problem with its row-major Cholesky factor.
struct Prepared {
    d: usize,
    l: Vec<f64>,
    a: Vec<f64>,
    b: Vec<f64>,
}

impl Prepared {
    /// Gibson–Glasbey–Elston reordering interleaved with the Cholesky decomposition.
    fn new(
        lower: &[f64],
        upper: &[f64],
        mean: &[f64],
        cov: &DMatrix<f64>,
    ) -> Result<Self, EvidenceError> {
        let d = mean.len();
        let mut c: Vec<f64> = (0..d * d).map(|k| cov[(k / d, k % d)]).collect();
        let mut a: Vec<f64> = (0..d).map(|i| lower[i] - mean[i]).collect();
        let mut b: Vec<f64> = (0..d).map(|i| upper[i] - mean[i]).collect();
        let mut l = vec![0.0; d * d];
        let mut y = vec![0.0; d];
        for i in 0..d {
            let mut best = (f64::INFINITY, i);
            for j in i..d {
                let s: f64 = (0..i).map(|m| l[j * d + m] * y[m]).sum();
                let v = c[j * d + j] - (0..i).map(|m| l[j * d + m].powi(2)).sum::<f64>();
                if v <= 0.0 {
                    continue;
                }
                let sd = v.sqrt();
                let ln_p = normal::ln_interval((a[j] - s) / sd, (b[j] - s) / sd);
                if ln_p < best.0 {
                    best = (ln_p, j);
                }
            }
            let j = best.1;
            if j != i {
                a.swap(i, j);
                b.swap(i, j);
                for k in 0..d {
                    c.swap(i * d + k, j * d + k);
                }
                for k in 0..d {
                    c.swap(k * d + i, k * d + j);
                }
                for m in 0..i {
                    l.swap(i * d + m, j * d + m);
                }
            }
            let v = c[i * d + i] - (0..i).map(|m| l[i * d + m].powi(2)).sum::<f64>();
            if v.is_nan() || v <= 0.0 {
                return Err(EvidenceError::NotPositiveDefinite {
                    what: "mvn covariance".into(),
                    detail: format!("pivot {v:e} during the reordered factorisation"),
                    fix: "pass a well-conditioned positive-definite covariance".into(),
                });
            }
            let lii = v.sqrt();
            l[i * d + i] = lii;
            for r in i + 1..d {
                let s: f64 = (0..i).map(|m| l[r * d + m] * l[i * d + m]).sum();
                l[r * d + i] = (c[r * d + i] - s) / lii;
            }
            let s: f64 = (0..i).map(|m| l[i * d + m] * y[m]).sum();
            y[i] = normal::truncated_mean((a[i] - s) / lii, (b[i] - s) / lii);
        }
        Ok(Self { d, l, a, b })
    }

    /// `ln Π (e_i − d_i)` at the point `w ∈ [0,1]^{D−1}`; `y` is scratch of length D.
    fn ln_integrand(&self, w: &[f64], y: &mut [f64]) -> f64 {
        let d = self.d;
        let mut ln_f = 0.0;
        for i in 0..d {
            let row = &self.l[i * d..i * d + i];
            let s: f64 = row.iter().zip(&y[..i]).map(|(l, y)| l * y).sum();
            let lii = self.l[i * d + i];
            let (lo, hi) = ((self.a[i] - s) / lii, (self.b[i] - s) / lii);
            if i + 1 < d {
                let (yi, ln_p) = normal::truncated_quantile(lo, hi, w[i]);
                if ln_p == f64::NEG_INFINITY {
                    return f64::NEG_INFINITY;
                }
                y[i] = yi;
                ln_f += ln_p;
            } else {
                ln_f += normal::ln_interval(lo, hi);
            }
        }
        ln_f
    }

    /// Adds the lattice points `from+1..=to` of every shift to the per-shift log sums.
    fn accumulate(
        &self,
        gens: &[f64],
        shifts: &[Vec<f64>],
        from: usize,
        to: usize,
        lse: &mut [f64],
    ) {
        let mut w = vec![0.0; self.d - 1];
        let mut y = vec![0.0; self.d];
        for (acc, shift) in lse.iter_mut().zip(shifts) {
            for j in from + 1..=to {
                for ((wi, &g), &sh) in w.iter_mut().zip(gens).zip(shift) {
                    let x = ((j as f64) * g + sh).fract();
                    *wi = (2.0 * x - 1.0).abs();
                }
                *acc = log_add_exp(*acc, self.ln_integrand(&w, &mut y));
            }
        }
    }

    /// Pilot rounds (points per shift doubled until the tolerance is met) choose the point count;
    /// the reported estimate and error come from fresh shifts at that count. Reusing the pilot
    /// would bias the error low: a run stops exactly when its error estimate happens to be small.
    fn integrate(&self, opts: &MvnOptions) -> MvnProbability {
        let d = self.d;
        let m = opts.n_shifts;
        let gens: Vec<f64> = first_primes(d - 1)
            .into_iter()
            .map(|p| (p as f64).sqrt().fract())
            .collect();
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(opts.seed);
        let mut draw_shifts = || -> Vec<Vec<f64>> {
            (0..m)
                .map(|_| (0..d - 1).map(|_| rng.random::<f64>()).collect())
                .collect()
        };
        let pilot = draw_shifts();
        let mut lse = vec![f64::NEG_INFINITY; m];
        let mut n_done = 0usize;
        let mut n_target = opts.initial_points;
        let converged = loop {
            self.accumulate(&gens, &pilot, n_done, n_target, &mut lse);
            n_done = n_target;
            let est = shift_statistics(&lse, n_done);
            if est.ln_p == f64::NEG_INFINITY {
                return MvnProbability {
                    n_evals: n_done * m,
                    ..est
                };
            }
            let converged = (opts.abs_tol > 0.0 && est.std_err <= opts.abs_tol)
                || est.ln_p_std_err <= opts.rel_tol;
            // The final pass costs n_done·m more evaluations.
            if converged || 3 * n_done * m > opts.max_evals {
                break converged;
            }
            n_target *= 2;
        };
        let fresh = draw_shifts();
        let mut lse = vec![f64::NEG_INFINITY; m];
        self.accumulate(&gens, &fresh, 0, n_done, &mut lse);
        MvnProbability {
            n_evals: 2 * n_done * m,
            converged,
            ..shift_statistics(&lse, n_done)
        }
    }
}

/// Mean and standard error over the shifts, from per-shift log sums of `n` points.
fn shift_statistics(lse: &[f64], n: usize) -> MvnProbability {
    let m = lse.len() as f64;
    let ln_means: Vec<f64> = lse.iter().map(|s| s - (n as f64).ln()).collect();
    let reference = ln_means.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    if reference == f64::NEG_INFINITY {
        return MvnProbability::exact(f64::NEG_INFINITY);
    }
    let v: Vec<f64> = ln_means.iter().map(|l| (l - reference).exp()).collect();
    let mean = v.iter().sum::<f64>() / m;
    let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (m - 1.0);
    let rel = (var / m).sqrt() / mean;
    let ln_p = reference + mean.ln();
    let p = ln_p.exp();
    MvnProbability {
        p,
        ln_p,
        std_err: rel * p,
        ln_p_std_err: rel,
        n_evals: 0,
        converged: false,
    }
}

pub(crate) fn log_add_exp(a: f64, b: f64) -> f64 {
    if a == f64::NEG_INFINITY {
        return b;
    }
    if b == f64::NEG_INFINITY {
        return a;
    }
    let m = a.max(b);
    m + ((a - m).exp() + (b - m).exp()).ln()
}

fn first_primes(k: usize) -> Vec<u64> {
    let mut out = Vec::with_capacity(k);
    let mut n = 2u64;
    while out.len() < k {
        if out
            .iter()
            .take_while(|&&p| p * p <= n)
            .all(|&p| !n.is_multiple_of(p))
        {
            out.push(n);
        }
        n += 1;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    const INF: f64 = f64::INFINITY;

    #[test]
    fn one_dimension_is_exact() {
        let cov = DMatrix::from_element(1, 1, 4.0);
        let r = mvn_rectangle(&[-1.0], &[3.0], &[1.0], &cov, &MvnOptions::default()).unwrap();
        // (−1 − 1)/2 = −1, (3 − 1)/2 = 1: P = erf(1/√2).
        let exact = statrs::function::erf::erf(1.0 / 2f64.sqrt());
        assert!((r.p - exact).abs() < 1e-15);
        assert_eq!(r.std_err, 0.0);
        // Far tail: ln P of N(0,1) above 30 is −454.3212 (asymptotic series), p underflows
        // only below e^{−745}.
        let one = DMatrix::from_element(1, 1, 1.0);
        let r = mvn_rectangle(&[30.0], &[INF], &[0.0], &one, &MvnOptions::default()).unwrap();
        let x: f64 = 30.0;
        let asym = -0.5 * x * x - x.ln() - 0.5 * (2.0 * PI).ln() + (1.0 - 1.0 / (x * x)).ln();
        assert!((r.ln_p - asym).abs() < 1e-5, "{} vs {asym}", r.ln_p);
    }

    #[test]
    fn diagonal_covariance_is_a_product_of_1d_probabilities() {
        let sd = [0.5, 2.0, 1.0, 3.0, 0.7];
        let mean = [0.1, -1.0, 0.0, 2.0, 0.3];
        let lo = [-0.2, -3.0, -INF, 1.0, -1.0];
        let hi = [0.9, 0.5, 0.4, INF, 1.2];
        let cov = DMatrix::from_fn(5, 5, |i, j| if i == j { sd[i] * sd[i] } else { 0.0 });
        let r = mvn_rectangle(&lo, &hi, &mean, &cov, &MvnOptions::default()).unwrap();
        let exact: f64 = (0..5)
            .map(|i| normal::interval((lo[i] - mean[i]) / sd[i], (hi[i] - mean[i]) / sd[i]))
            .product();
        // With diagonal Σ the separated integrand is constant, so QMC is exact up to round-off.
        assert!((r.p / exact - 1.0).abs() < 1e-12, "{} vs {exact}", r.p);
        assert!(r.converged);
    }

    #[test]
    fn orthant_probabilities_match_closed_forms() {
        // 2-D: 1/4 + asin(ρ)/(2π); 3-D: 1/8 + (asin ρ12 + asin ρ13 + asin ρ23)/(4π).
        for rho in [-0.9, -0.3, 0.5, 0.95] {
            let cov = DMatrix::from_row_slice(2, 2, &[1.0, rho, rho, 1.0]);
            let r = mvn_rectangle(
                &[0.0, 0.0],
                &[INF, INF],
                &[0.0, 0.0],
                &cov,
                &MvnOptions::default(),
            )
            .unwrap();
            let exact = 0.25 + f64::asin(rho) / (2.0 * PI);
            // 5σ of the reported error, plus 1e-12 for the case where the error is ~0.
            assert!(
                (r.p - exact).abs() < 5.0 * r.std_err + 1e-12,
                "ρ={rho}: {} ± {} vs {exact}",
                r.p,
                r.std_err
            );
            // The final pass scatters around the tolerance (16 shifts: ~18 % relative sd).
            assert!(r.ln_p_std_err < 2.0 * MvnOptions::default().rel_tol);
        }
        let (r12, r13, r23) = (0.5, -0.2, 0.3);
        let cov = DMatrix::from_row_slice(3, 3, &[1.0, r12, r13, r12, 1.0, r23, r13, r23, 1.0]);
        let r = mvn_rectangle(
            &[-INF; 3],
            &[0.0; 3],
            &[0.0; 3],
            &cov,
            &MvnOptions::default(),
        )
        .unwrap();
        let exact = 0.125 + (f64::asin(r12) + f64::asin(r13) + f64::asin(r23)) / (4.0 * PI);
        assert!((r.p - exact).abs() < 5.0 * r.std_err + 1e-12);
    }

    /// 2-D finite rectangle against 1-D Simpson quadrature of the conditional probability.
    #[test]
    fn correlated_rectangle_matches_quadrature() {
        let (s1, s2, rho) = (1.5, 0.8, 0.7);
        let cov = DMatrix::from_row_slice(2, 2, &[s1 * s1, rho * s1 * s2, rho * s1 * s2, s2 * s2]);
        let (mean, lo, hi) = ([0.3, -0.2], [-1.0, -0.5], [2.0, 0.1]);
        let r = mvn_rectangle(&lo, &hi, &mean, &cov, &MvnOptions::default()).unwrap();
        let n = 4000;
        let (a, b) = ((lo[0] - mean[0]) / s1, (hi[0] - mean[0]) / s1);
        let c = (1.0 - rho * rho).sqrt();
        let g = |z: f64| {
            let m2 = mean[1] + rho * s2 * z;
            normal::pdf(z) * normal::interval((lo[1] - m2) / (s2 * c), (hi[1] - m2) / (s2 * c))
        };
        let h = (b - a) / n as f64;
        let mut s = g(a) + g(b);
        for i in 1..n {
            s += g(a + h * i as f64) * if i % 2 == 1 { 4.0 } else { 2.0 };
        }
        let quad = s * h / 3.0;
        assert!(
            (r.p - quad).abs() < 5.0 * r.std_err + 1e-10,
            "{} vs {quad}",
            r.p
        );
    }

    /// The reported error must be honest: over 600 seeds the 1σ intervals cover at the nominal
    /// rate, and would not with errors 20 % off.
    #[test]
    fn error_estimate_covers_at_the_nominal_rate() {
        let (r12, r13, r23) = (0.4, 0.6, -0.1);
        let cov = DMatrix::from_row_slice(3, 3, &[1.0, r12, r13, r12, 1.0, r23, r13, r23, 1.0]);
        let exact = 0.125 + (f64::asin(r12) + f64::asin(r13) + f64::asin(r23)) / (4.0 * PI);
        let z: Vec<f64> = (0..600)
            .map(|seed| {
                let opts = MvnOptions {
                    seed,
                    initial_points: 64,
                    max_evals: 2 * 64 * 16,
                    ..MvnOptions::default()
                };
                let r = mvn_rectangle(&[0.0; 3], &[INF; 3], &[0.0; 3], &cov, &opts).unwrap();
                (r.p - exact) / r.std_err
            })
            .collect();
        crate::evidence::coverage_check::assert_nominal_coverage("orthant probability", &z);
    }

    #[test]
    fn far_tail_box_keeps_relative_precision() {
        // Independent coordinates far from the box: product of exact tails, through the QMC path.
        let cov = DMatrix::from_row_slice(3, 3, &[1.0, 0.0, 0.0, 0.0, 4.0, 0.0, 0.0, 0.0, 1.0]);
        let r = mvn_rectangle(
            &[12.0, -INF, 20.0],
            &[INF, -20.0, 21.0],
            &[0.0; 3],
            &cov,
            &MvnOptions::default(),
        )
        .unwrap();
        let exact = normal::interval(12.0, INF).ln()
            + normal::interval(-INF, -10.0).ln()
            + normal::interval(20.0, 21.0).ln();
        assert!((r.ln_p - exact).abs() < 1e-9, "{} vs {exact}", r.ln_p);
        // 100σ out, correlated: no underflow, and the 2-D result matches the 1-D marginal when
        // the second interval is unbounded.
        let cov = DMatrix::from_row_slice(2, 2, &[1.0, 0.6, 0.6, 1.0]);
        let r = mvn_rectangle(
            &[100.0, -INF],
            &[INF, INF],
            &[0.0; 2],
            &cov,
            &MvnOptions::default(),
        )
        .unwrap();
        assert!(
            (r.ln_p - normal::ln_upper(100.0)).abs() < 1e-9,
            "{}",
            r.ln_p
        );
        assert_eq!(r.p, 0.0);
    }

    #[test]
    fn rejects_bad_input() {
        let cov = DMatrix::identity(2, 2);
        let o = MvnOptions::default();
        assert!(mvn_rectangle(&[0.0], &[1.0, 1.0], &[0.0, 0.0], &cov, &o).is_err());
        assert!(mvn_rectangle(&[1.0, 0.0], &[0.0, 1.0], &[0.0, 0.0], &cov, &o).is_err());
        assert!(mvn_rectangle(&[f64::NAN, 0.0], &[1.0, 1.0], &[0.0, 0.0], &cov, &o).is_err());
        let bad = DMatrix::from_row_slice(2, 2, &[1.0, 2.0, 2.0, 1.0]);
        assert!(matches!(
            mvn_rectangle(&[0.0, 0.0], &[1.0, 1.0], &[0.0, 0.0], &bad, &o),
            Err(EvidenceError::Matrix {
                source: crate::linalg::LinalgError::NotPositiveDefinite { .. },
                ..
            })
        ));
        let few = MvnOptions { n_shifts: 2, ..o };
        assert!(mvn_rectangle(&[0.0, 0.0], &[1.0, 1.0], &[0.0, 0.0], &cov, &few).is_err());
    }

    #[test]
    fn same_seed_same_number() {
        let cov = DMatrix::from_row_slice(2, 2, &[1.0, 0.3, 0.3, 2.0]);
        let o = MvnOptions::default();
        let a = mvn_rectangle(&[-1.0, 0.0], &[1.0, 2.0], &[0.0, 0.5], &cov, &o).unwrap();
        let b = mvn_rectangle(&[-1.0, 0.0], &[1.0, 2.0], &[0.0, 0.5], &cov, &o).unwrap();
        assert_eq!(a, b);
    }
}
