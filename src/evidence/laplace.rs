//! Laplace approximations of the evidence (`ltp-model.md` §9.3).
//!
//! # Formula
//! ```text
//! ln Z ≈ ln L(θ̂) + ln π(θ̂) + (D/2) ln 2π + ½ ln|Σ|,     Σ = H⁻¹,  H = −∇∇[ln L + ln π](θ̂)
//! ```
//! K14 eq. (L) writes `|H|^{+1/2}`; the correct factor is `|H|^{−1/2} = |Σ|^{1/2}`. The prior
//! density at θ̂ is part of the formula (LTPDA omits it, which makes its Bayes factors depend on
//! parameter units).
//!
//! * **Laplace–Fisher** ([`laplace_fisher`]): `H = F + C_π` with `F` the Fisher matrix of `ln L`
//!   supplied by the caller and `C_π = −∇∇ ln π` the prior curvature (1/σ² for Gaussian priors, 0
//!   for uniform, −1/θ² for log-uniform). Exact for linear-Gaussian models with Gaussian priors.
//! * **Laplace–Hessian** ([`laplace_hessian`]): `H` from central differences of the log
//!   posterior ([`numerical_hessian`]), for targets without a Fisher matrix.
//! * **Laplace–Metropolis** ([`laplace_metropolis`]): θ̂ = the sample with the highest posterior,
//!   `Σ` = a robust covariance (MVE or MCD) of the samples.
//!
//! # Boxes
//! The expansion treats the prior as smooth: uniform and log-uniform densities are extended beyond
//! their bounds by their analytic formula. With [`LaplaceOptions::box_correction`] the estimate is
//! multiplied by the mass of `N(θ̂, Σ)` inside the bounds of the bounded parameters (Gaussian-prior
//! parameters have no box), computed with [`mvn_rectangle`]:
//! `ln Z ≈ raw + ln P_{N(θ̂,Σ)}(box)`. Pass the **unconstrained** maximum as θ̂ then (it may lie
//! outside the box). This repairs a MAP on a boundary and prior-dominated parameters; for the
//! linear-Gaussian family it is exact. Without the correction a θ̂ on or outside a bound is an
//! error, and [`LaplaceEstimate::min_margin_sigma`] reports how close θ̂ is to a bound.

use super::error::EvidenceError;
use super::method::Method;
use super::mvn::{MvnOptions, mvn_rectangle};
use super::robust::{RobustMethod, robust_covariance};
use crate::density::LogDensity;
use crate::linalg::SpdOptions;
use crate::prior::{Prior, PriorKind};
use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// Options of the Laplace estimators.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LaplaceOptions {
    /// Multiply by the Gaussian's mass inside the prior box (see the module docs).
    pub box_correction: bool,
    /// Quasi-Monte-Carlo settings of the box mass.
    pub mvn: MvnOptions,
}

impl Default for LaplaceOptions {
    fn default() -> Self {
        Self {
            box_correction: true,
            mvn: MvnOptions::default(),
        }
    }
}

/// A Laplace-type evidence estimate with its ingredients.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LaplaceEstimate {
    /// Estimator.
    pub method: Method,
    /// `ln Z`: `ln_z_raw + ln_box_mass` when the box term was computed, else `ln_z_raw`.
    pub ln_z: f64,
    /// The plain formula `ln L(θ̂) + ln π(θ̂) + (D/2) ln 2π + ½ ln|Σ|`.
    pub ln_z_raw: f64,
    /// `ln P_{N(θ̂,Σ)}(box)`, when computed.
    pub ln_box_mass: Option<f64>,
    /// QMC error of the box term; `None` when there is no box term (the estimate is then
    /// deterministic and its error is an approximation bias).
    pub std_err: Option<f64>,
    /// `ln L(θ̂)`.
    pub ln_likelihood_hat: f64,
    /// `ln π(θ̂)` (uniform and log-uniform densities extended beyond their bounds).
    pub ln_prior_hat: f64,
    /// `ln |Σ|`.
    pub ln_det_cov: f64,
    /// The expansion point.
    pub theta_hat: Vec<f64>,
    /// `Σ` (not serialised; `ln_det_cov` carries its size).
    #[serde(skip)]
    pub cov: DMatrix<f64>,
    /// Smallest distance from θ̂ to a prior bound, in units of the posterior standard deviation
    /// `√Σ_ii` (negative outside; `+∞` when no parameter is bounded). Below ~3 the plain formula
    /// is biased: use the box-corrected value.
    pub min_margin_sigma: f64,
}

/// `ln π(θ)` with uniform and log-uniform densities continued beyond their bounds by their
/// formula ([`Prior::ln_pdf_extended`]): the smooth function a Laplace expansion (and an
/// optimiser looking for the unconstrained maximum) works with.
pub fn ln_prior_extended(prior: &Prior, theta: &[f64]) -> Result<f64, EvidenceError> {
    use crate::prior::ExtendedError as E;
    prior.ln_pdf_extended(theta).map_err(|e| match e {
        E::Dimension { got } => EvidenceError::dimension("θ", prior.dim(), got),
        E::NonFinite { name, x } => {
            EvidenceError::non_finite(format!("θ̂ of `{name}`"), x, "pass a finite expansion point")
        }
        E::LogUniformAtNonPositive { name, x } => EvidenceError::UnsupportedPrior {
            param: name,
            why: format!(
                "log-uniform density undefined at θ = {x} ≤ 0; expand at a positive point"
            ),
        },
    })
}

/// `−∇∇ ln π` (diagonal) at θ for the extended prior.
fn prior_curvature(prior: &Prior, theta: &[f64]) -> Vec<f64> {
    prior
        .kinds()
        .iter()
        .zip(theta)
        .map(|(k, &x)| match *k {
            PriorKind::Uniform { .. } => 0.0,
            PriorKind::Gaussian { sigma, .. } => 1.0 / (sigma * sigma),
            PriorKind::LogUniform { .. } => -1.0 / (x * x),
        })
        .collect()
}

/// Laplace–Fisher: `Σ = (F + C_π)⁻¹` with `fisher` the Fisher matrix of `ln L` at `theta_hat`.
///
/// `theta_hat` must be the maximum of `ln L + ln π` (the MAP; with the box correction, the
/// unconstrained maximum).
///
/// ```
/// use nalgebra::DMatrix;
/// use occam::evidence::laplace::{laplace_fisher, LaplaceOptions};
/// use occam::evidence::linear_gaussian::LinearGaussian;
/// use occam::evidence::mvn::MvnOptions;
/// use occam::prior::{Prior, PriorKind};
/// // y = a·x + noise, Gaussian prior: the Laplace approximation is exact.
/// let x = DMatrix::from_row_slice(4, 1, &[1.0, 2.0, 3.0, 4.0]);
/// let prior = Prior::new(vec!["a".into()], vec![PriorKind::Gaussian { mu: 0.0, sigma: 2.0 }]).unwrap();
/// let lg = LinearGaussian::new(x, vec![1.1, 1.9, 3.2, 3.9], 0.3, prior).unwrap();
/// let post = lg.gaussian_posterior(&[0]).unwrap();
/// let est = laplace_fisher(&lg, post.mean.as_slice(), &lg.fisher(&[0]).unwrap(),
///                          &LaplaceOptions::default()).unwrap();
/// let exact = lg.exact_ln_evidence(&[0], &MvnOptions::default()).unwrap().ln_z;
/// assert!((est.ln_z - exact).abs() < 1e-10);
/// ```
pub fn laplace_fisher<T: LogDensity + ?Sized>(
    target: &T,
    theta_hat: &[f64],
    fisher: &DMatrix<f64>,
    opts: &LaplaceOptions,
) -> Result<LaplaceEstimate, EvidenceError> {
    let d = target.dim();
    if theta_hat.len() != d {
        return Err(EvidenceError::dimension("θ̂", d, theta_hat.len()));
    }
    if fisher.nrows() != d || fisher.ncols() != d {
        return Err(EvidenceError::dimension(
            "Fisher matrix rows/columns",
            d,
            fisher.nrows().max(fisher.ncols()),
        ));
    }
    ln_prior_extended(target.prior(), theta_hat)?;
    let mut h = fisher.clone();
    for (i, c) in prior_curvature(target.prior(), theta_hat)
        .into_iter()
        .enumerate()
    {
        h[(i, i)] += c;
    }
    let chol = SpdOptions::default()
        .names(target.prior().names())
        .factor(&h)
        .map_err(EvidenceError::matrix(
            "Fisher matrix + prior curvature",
            "the data do not constrain every parameter; fix or remove the unconstrained ones",
        ))?;
    let cov = chol.inverse();
    assemble(
        target,
        theta_hat,
        cov,
        -chol.ln_det(),
        Method::LaplaceFisher,
        Some(opts),
    )
}

/// Laplace with the Hessian of `ln L + ln π` computed by [`numerical_hessian`] at `theta_hat`.
///
/// Initial step scales come from the prior (Gaussian σ, or the box width); the steps are then
/// adapted to the posterior width. The likelihood must be defined a few posterior widths around
/// `theta_hat` (also outside the box when θ̂ is near a bound).
pub fn laplace_hessian<T: LogDensity + ?Sized>(
    target: &T,
    theta_hat: &[f64],
    opts: &LaplaceOptions,
) -> Result<LaplaceEstimate, EvidenceError> {
    let d = target.dim();
    if theta_hat.len() != d {
        return Err(EvidenceError::dimension("θ̂", d, theta_hat.len()));
    }
    ln_prior_extended(target.prior(), theta_hat)?;
    let prior = target.prior();
    let scale: Vec<f64> = prior
        .kinds()
        .iter()
        .map(|k| match *k {
            PriorKind::Gaussian { sigma, .. } => sigma,
            PriorKind::Uniform { lo, hi } | PriorKind::LogUniform { lo, hi } => hi - lo,
        })
        .collect();
    let f = |t: &[f64]| match ln_prior_extended(prior, t) {
        Ok(lp) => lp + target.ln_likelihood(t),
        Err(_) => f64::NAN,
    };
    let hess = numerical_hessian(f, theta_hat, &scale, prior.names())?;
    let h = -hess;
    let chol = SpdOptions::default()
        .names(prior.names())
        .factor(&h)
        .map_err(EvidenceError::matrix(
            "−Hessian of the log posterior",
            "θ̂ must be a maximum of ln L + ln π with every parameter constrained",
        ))?;
    let cov = chol.inverse();
    assemble(
        target,
        theta_hat,
        cov,
        -chol.ln_det(),
        Method::LaplaceHessian,
        Some(opts),
    )
}

/// Laplace–Metropolis: `theta_hat` is the sample with the highest posterior (inside the prior
/// support) and `Σ` the robust covariance of `samples` (n × D, one sample per row; repeated
/// samples from rejections are kept). No box term: the samples already live inside the box.
pub fn laplace_metropolis<T: LogDensity + ?Sized>(
    target: &T,
    theta_hat: &[f64],
    samples: &DMatrix<f64>,
    method: &RobustMethod,
) -> Result<LaplaceEstimate, EvidenceError> {
    let d = target.dim();
    if theta_hat.len() != d {
        return Err(EvidenceError::dimension("θ̂", d, theta_hat.len()));
    }
    if samples.ncols() != d {
        return Err(EvidenceError::dimension(
            "sample columns",
            d,
            samples.ncols(),
        ));
    }
    let tag = match method {
        RobustMethod::Mve(_) => Method::LaplaceMetropolisMve,
        RobustMethod::Mcd(_) => Method::LaplaceMetropolisMcd,
    };
    if d == 0 {
        // No free parameter: Z = L exactly, there is nothing to estimate from the samples.
        return assemble(target, theta_hat, DMatrix::zeros(0, 0), 0.0, tag, None);
    }
    let rc = robust_covariance(samples, method)?;
    let chol = SpdOptions::default()
        .names(target.prior().names())
        .factor(&rc.cov)
        .map_err(EvidenceError::matrix(
            "robust covariance",
            "the samples must vary in every parameter",
        ))?;
    let ln_det_cov = chol.ln_det();
    assemble(target, theta_hat, rc.cov, ln_det_cov, tag, None)
}

/// Shared tail of every Laplace estimator. `opts = None`: no box term (Laplace–Metropolis).
fn assemble<T: LogDensity + ?Sized>(
    target: &T,
    theta_hat: &[f64],
    cov: DMatrix<f64>,
    ln_det_cov: f64,
    method: Method,
    opts: Option<&LaplaceOptions>,
) -> Result<LaplaceEstimate, EvidenceError> {
    let d = theta_hat.len();
    let prior = target.prior();
    let ln_prior_hat = ln_prior_extended(prior, theta_hat)?;
    let ln_likelihood_hat = target.ln_likelihood(theta_hat);
    if !ln_likelihood_hat.is_finite() {
        return Err(EvidenceError::non_finite(
            "ln L(θ̂)",
            ln_likelihood_hat,
            "expand at a point where the likelihood is defined",
        ));
    }
    let ln_z_raw =
        ln_likelihood_hat + ln_prior_hat + 0.5 * d as f64 * (2.0 * PI).ln() + 0.5 * ln_det_cov;
    let mut bounded = Vec::new();
    let mut min_margin_sigma = f64::INFINITY;
    let mut first_outside = None;
    for (i, k) in prior.kinds().iter().enumerate() {
        let (lo, hi) = k.bounds();
        if lo.is_finite() || hi.is_finite() {
            bounded.push(i);
            let x = theta_hat[i];
            let margin = (x - lo).min(hi - x) / cov[(i, i)].sqrt();
            min_margin_sigma = min_margin_sigma.min(margin);
            if (x <= lo || x >= hi) && first_outside.is_none() {
                first_outside = Some((i, x, lo, hi));
            }
        }
    }
    let correct = opts.is_some_and(|o| o.box_correction) && !bounded.is_empty();
    if !correct && let Some((i, value, lo, hi)) = first_outside {
        return Err(EvidenceError::OnBoundary {
            param: prior.names()[i].clone(),
            value,
            lo,
            hi,
        });
    }
    let (ln_box_mass, std_err) = if correct {
        let lo: Vec<f64> = bounded
            .iter()
            .map(|&i| prior.kinds()[i].bounds().0)
            .collect();
        let hi: Vec<f64> = bounded
            .iter()
            .map(|&i| prior.kinds()[i].bounds().1)
            .collect();
        let mean: Vec<f64> = bounded.iter().map(|&i| theta_hat[i]).collect();
        let sub = cov.select_rows(&bounded).select_columns(&bounded);
        let mvn = opts.map(|o| o.mvn).unwrap_or_default();
        let p = mvn_rectangle(&lo, &hi, &mean, &sub, &mvn)?;
        if p.ln_p == f64::NEG_INFINITY {
            return Err(EvidenceError::BoxMassUnderflow { ln_p: p.ln_p });
        }
        (Some(p.ln_p), Some(p.ln_p_std_err))
    } else {
        (None, None)
    };
    Ok(LaplaceEstimate {
        method,
        ln_z: ln_z_raw + ln_box_mass.unwrap_or(0.0),
        ln_z_raw,
        ln_box_mass,
        std_err,
        ln_likelihood_hat,
        ln_prior_hat,
        ln_det_cov,
        theta_hat: theta_hat.to_vec(),
        cov,
        min_margin_sigma,
    })
}

/// Hessian of `f` at `x` by central differences with automatic steps.
///
/// `scale[i]` is a rough width of `f` along coordinate i (any value within a few orders of
/// magnitude of the posterior width works). The steps are adapted until `h_i = τ·σ_i` with
/// `σ_i = (−∂²f/∂x_i²)^{−1/2}` and `τ = (12 ε max(1, |f(x)|))^{1/4}`, the step that balances the
/// `O(τ²)` truncation error against the `O(ε|f|/τ²)` round-off error of a second difference.
/// Off-diagonal entries use the four-point formula. Errors if `f` is not finite near `x` or if
/// `x` is not a maximum along some coordinate (`names` label the coordinates in messages).
pub fn numerical_hessian<F: Fn(&[f64]) -> f64>(
    f: F,
    x: &[f64],
    scale: &[f64],
    names: &[String],
) -> Result<DMatrix<f64>, EvidenceError> {
    let d = x.len();
    if scale.len() != d {
        return Err(EvidenceError::dimension("Hessian scales", d, scale.len()));
    }
    let name = |i: usize| names.get(i).cloned().unwrap_or_else(|| format!("#{i}"));
    let f0 = f(x);
    if !f0.is_finite() {
        return Err(EvidenceError::non_finite(
            "the log posterior at θ̂",
            f0,
            "expand at a point where it is defined",
        ));
    }
    let tau = (12.0 * f64::EPSILON * f0.abs().max(1.0))
        .powf(0.25)
        .clamp(1e-5, 0.1);
    let mut p = x.to_vec();
    let eval = |p: &mut Vec<f64>, steps: &[(usize, f64)]| -> Result<f64, EvidenceError> {
        for &(i, s) in steps {
            p[i] += s;
        }
        let v = f(p);
        p.copy_from_slice(x);
        if v.is_finite() {
            Ok(v)
        } else {
            Err(EvidenceError::non_finite(
                format!(
                    "the log posterior near θ̂ (step along `{}`)",
                    name(steps[0].0)
                ),
                v,
                "the likelihood must be defined a few posterior widths around θ̂",
            ))
        }
    };
    let mut h: Vec<f64> = (0..d)
        .map(|i| {
            if scale[i].is_finite() && scale[i] > 0.0 {
                1e-3 * scale[i]
            } else {
                1e-3 * x[i].abs().max(1.0)
            }
        })
        .collect();
    let mut diag = vec![0.0; d];
    for i in 0..d {
        let mut shrink = 0;
        for _ in 0..12 {
            let fp = eval(&mut p, &[(i, h[i])])?;
            let fm = eval(&mut p, &[(i, -h[i])])?;
            let d2 = (fp - 2.0 * f0 + fm) / (h[i] * h[i]);
            if d2.is_nan() || d2 >= 0.0 {
                shrink += 1;
                if shrink > 6 {
                    return Err(EvidenceError::NotPositiveDefinite {
                        what: "−Hessian of the log posterior".into(),
                        detail: format!("θ̂ is not a maximum along `{}` (∂²f = {d2:e})", name(i)),
                        fix: "pass the maximum of ln L + ln π as θ̂".into(),
                    });
                }
                h[i] /= 10.0;
                continue;
            }
            diag[i] = d2;
            let target = tau / (-d2).sqrt();
            let ratio = target / h[i];
            h[i] = target;
            if (0.5..=2.0).contains(&ratio) {
                break;
            }
        }
    }
    let mut out = DMatrix::zeros(d, d);
    for i in 0..d {
        let fp = eval(&mut p, &[(i, h[i])])?;
        let fm = eval(&mut p, &[(i, -h[i])])?;
        out[(i, i)] = (fp - 2.0 * f0 + fm) / (h[i] * h[i]);
        for j in 0..i {
            let fpp = eval(&mut p, &[(i, h[i]), (j, h[j])])?;
            let fpm = eval(&mut p, &[(i, h[i]), (j, -h[j])])?;
            let fmp = eval(&mut p, &[(i, -h[i]), (j, h[j])])?;
            let fmm = eval(&mut p, &[(i, -h[i]), (j, -h[j])])?;
            let v = (fpp - fpm - fmp + fmm) / (4.0 * h[i] * h[j]);
            out[(i, j)] = v;
            out[(j, i)] = v;
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::evidence::LnB;
    use crate::evidence::linear_gaussian::{LinearGaussian, RandomPrior, RandomSpec};
    use crate::evidence::robust::{McdOptions, MveOptions};
    use crate::nested::SubModel;
    use rand::SeedableRng;
    use rand_xoshiro::Xoshiro256PlusPlus;

    fn lg(prior: RandomPrior, d: usize, snr: f64, seed: u64) -> LinearGaussian {
        LinearGaussian::random(&RandomSpec {
            n_data: 60,
            dim: d,
            snr,
            n_absent: usize::from(d > 1),
            sigma: 1.0,
            prior,
            seed,
        })
        .unwrap()
        .model
    }

    #[test]
    fn fisher_is_exact_with_gaussian_priors_on_nested_models() {
        for d in 1..=6 {
            let m = lg(
                RandomPrior::Gaussian {
                    mu: 0.1,
                    sigma: 2.0,
                },
                d,
                20.0,
                d as u64,
            );
            let mut pair = Vec::new();
            for cols in [(0..d).collect::<Vec<_>>(), (0..d - 1).collect()] {
                let sub = SubModel::new(&m, cols.clone(), vec![0.0; d]).unwrap();
                let post = m.gaussian_posterior(&cols).unwrap();
                let est = laplace_fisher(
                    &sub,
                    post.mean.as_slice(),
                    &m.fisher(&cols).unwrap(),
                    &LaplaceOptions::default(),
                )
                .unwrap();
                let exact = m.exact_ln_evidence(&cols, &MvnOptions::default()).unwrap();
                assert!((est.ln_z - exact.ln_z).abs() < 1e-8, "d={d} {cols:?}");
                assert_eq!(est.ln_box_mass, None);
                assert_eq!(est.min_margin_sigma, f64::INFINITY);
                // Numerical Hessian: exact up to round-off for a quadratic.
                let eh = laplace_hessian(&sub, post.mean.as_slice(), &LaplaceOptions::default())
                    .unwrap();
                assert!((eh.ln_z - exact.ln_z).abs() < 1e-5, "hessian d={d}");
                pair.push((est, exact.ln_z));
            }
            let b = LnB::from_estimates(&pair[0].0, &pair[1].0);
            assert_eq!(b.method, Method::LaplaceFisher);
            assert!((b.ln_b - (pair[0].1 - pair[1].1)).abs() < 1e-8);
            assert_eq!(b.std_err, None);
        }
    }

    #[test]
    fn box_correction_repairs_a_narrow_box_and_boundary_map() {
        // Box half-width 0.15 vs posterior σ ≈ 0.13 and θ_true ≈ 1: the unconstrained maximum
        // lies far outside the box.
        let m = lg(
            RandomPrior::Uniform {
                lo: -0.15,
                hi: 0.15,
            },
            3,
            15.0,
            4,
        );
        let cols = [0usize, 1, 2];
        let post = m.gaussian_posterior(&cols).unwrap();
        let f = m.fisher(&cols).unwrap();
        let plain = LaplaceOptions {
            box_correction: false,
            ..LaplaceOptions::default()
        };
        assert!(matches!(
            laplace_fisher(&m, post.mean.as_slice(), &f, &plain),
            Err(EvidenceError::OnBoundary { .. })
        ));
        let opts = LaplaceOptions {
            mvn: MvnOptions {
                seed: 99,
                ..MvnOptions::default()
            },
            ..LaplaceOptions::default()
        };
        let est = laplace_fisher(&m, post.mean.as_slice(), &f, &opts).unwrap();
        let exact = m.exact_ln_evidence(&cols, &MvnOptions::default()).unwrap();
        let se = est.std_err.unwrap().hypot(exact.std_err);
        assert!(
            est.ln_box_mass.unwrap() < -5.0,
            "the box term must matter here"
        );
        assert!(est.min_margin_sigma < 0.0);
        // Two independent QMC estimates of the same box mass: 5σ of their combined error.
        assert!(
            (est.ln_z - exact.ln_z).abs() < 5.0 * se + 1e-9,
            "{} vs {}",
            est.ln_z,
            exact.ln_z
        );
        assert!((est.ln_z_raw - exact.ln_z).abs() > 5.0);
    }

    #[test]
    fn rejects_singular_fisher_and_saddles() {
        let m = lg(RandomPrior::Uniform { lo: -5.0, hi: 5.0 }, 2, 10.0, 2);
        let post = m.gaussian_posterior(&[0, 1]).unwrap();
        let singular = DMatrix::from_row_slice(2, 2, &[1.0, 1.0, 1.0, 1.0]);
        assert!(matches!(
            laplace_fisher(
                &m,
                post.mean.as_slice(),
                &singular,
                &LaplaceOptions::default()
            ),
            Err(EvidenceError::Matrix {
                source: crate::linalg::LinalgError::NotPositiveDefinite { .. },
                ..
            })
        ));
        let saddle = |t: &[f64]| t[0] * t[0] - t[1] * t[1];
        assert!(matches!(
            numerical_hessian(saddle, &[0.0, 0.0], &[1.0, 1.0], &[]),
            Err(EvidenceError::NotPositiveDefinite { .. })
        ));
        assert!(laplace_fisher(&m, &[0.0], &singular, &LaplaceOptions::default()).is_err());
    }

    #[test]
    fn numerical_hessian_of_a_non_quadratic_function() {
        // f = −cosh(x) − y⁴/4 − (x−y)²: Hessian at 0 is [[−3, 2], [2, −2]] (y⁴ term is flat at 0).
        let f = |t: &[f64]| -t[0].cosh() - 0.25 * t[1].powi(4) - (t[0] - t[1]).powi(2);
        let h = numerical_hessian(f, &[0.0, 0.0], &[1.0, 1.0], &[]).unwrap();
        let expect = [[-3.0, 2.0], [2.0, -2.0]];
        for i in 0..2 {
            for j in 0..2 {
                assert!((h[(i, j)] - expect[i][j]).abs() < 1e-6, "{h}");
            }
        }
    }

    #[test]
    fn metropolis_with_exact_posterior_samples() {
        let d = 3;
        let m = lg(RandomPrior::Uniform { lo: -5.0, hi: 5.0 }, d, 10.0, 8);
        let cols: Vec<usize> = (0..d).collect();
        let exact = m
            .exact_ln_evidence(&cols, &MvnOptions::default())
            .unwrap()
            .ln_z;
        let post = m.gaussian_posterior(&cols).unwrap();
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(3);
        let n = 4000;
        let s = m.sample_posterior(&cols, n, &mut rng).unwrap();
        let best = (0..n)
            .max_by(|&a, &b| {
                let pa = m.ln_posterior(s.row(a).transpose().as_slice());
                let pb = m.ln_posterior(s.row(b).transpose().as_slice());
                pa.total_cmp(&pb)
            })
            .unwrap();
        let theta_best: Vec<f64> = s.row(best).iter().cloned().collect();
        // At the MAP with the true covariance LM is exact (the box is ≥ 30σ wide). Using the
        // best sample lowers the estimate by exactly gap = ln p(MAP) − ln p(best); what remains
        // is ½ ln(|Σ̂|/|Σ|), whose sd is ½√(2D/(n·eff)) ≤ 0.027 for D = 3, n = 4000 and a
        // robust-estimator efficiency eff ≥ 0.5. Tolerance: 5 sd.
        let gap = m.ln_posterior(post.mean.as_slice()) - m.ln_posterior(&theta_best);
        assert!(gap >= 0.0);
        let tol = 5.0 * 0.5 * (2.0 * d as f64 / (n as f64 * 0.5)).sqrt();
        for method in [
            RobustMethod::Mve(MveOptions::default()),
            RobustMethod::Mcd(McdOptions::default()),
        ] {
            let est = laplace_metropolis(&m, &theta_best, &s, &method).unwrap();
            let resid = est.ln_z + gap - exact;
            assert!(resid.abs() < tol, "{method:?}: residual {resid}, tol {tol}");
            assert!(est.std_err.is_none());
        }
        let few = s.rows(0, 10).into_owned();
        assert!(matches!(
            laplace_metropolis(
                &m,
                &theta_best,
                &few,
                &RobustMethod::Mcd(McdOptions::default())
            ),
            Err(EvidenceError::TooFewSamples { .. })
        ));
    }
}
