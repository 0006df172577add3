//! The linear-Gaussian known-answer family (`ltp-model.md` §11).
//!
//! `y = Xθ + ε`, `ε ~ N(0, σ² Iₙ)`, design `X` (n×D) of full column rank, independent priors
//! per parameter (Gaussian or uniform). Nested models are column subsets: the model on the columns
//! `S` has the other parameters fixed at 0 (exactly a [`SubModel`](crate::nested::SubModel) of this
//! density with base vector 0).
//!
//! # Likelihood
//! `ln L(θ) = −(n/2) ln 2πσ² − |y − Xθ|²/(2σ²)`, evaluated as
//! `−(n/2) ln 2πσ² − [RSS_min + (θ − θ_LS)ᵀ XᵀX (θ − θ_LS)]/(2σ²)`: an O(D²) exact identity that
//! allocates nothing and avoids the cancellation of `yᵀy − 2θᵀXᵀy + θᵀXᵀXθ` at high SNR.
//!
//! # Evidence of the model on columns S
//! With `G = X_SᵀX_S`, the subset least-squares fit `θ̂` and its residual `RSS_S`, Gaussian prior
//! precisions `Λ` (zero for uniform parameters) and means `μ`:
//!
//! ```text
//! A = G/σ² + Λ,   m = A⁻¹ (Gθ̂/σ² + Λμ),   Q = (m − θ̂)ᵀ G (m − θ̂)/σ² + (m − μ)ᵀ Λ (m − μ)
//! ln Z = −(n/2) ln 2πσ² − RSS_S/(2σ²) − Q/2 − ½ Σ_gauss ln 2πs_i² − Σ_unif ln w_i
//!        + (D/2) ln 2π − ½ ln|A| + ln P_{N(m, A⁻¹)}(box of the uniform parameters)
//! ```
//!
//! For an all-Gaussian prior this is §11's Woodbury / determinant-lemma form (the box term is
//! absent); for an all-uniform prior it is §11's box formula (`m = θ̂`, `A⁻¹ = σ² G⁻¹`). The box
//! probability comes from [`mvn_rectangle`] and carries its quasi-Monte-Carlo error.

use super::error::EvidenceError;
use super::method::Method;
use super::mvn::{MvnOptions, mvn_rectangle};
use crate::density::LogDensity;
use crate::linalg::{Spd, SpdOptions};
use crate::prior::{Prior, PriorKind};
use nalgebra::{DMatrix, DVector};
use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, StandardNormal};
use rand_xoshiro::Xoshiro256PlusPlus;
use serde::Serialize;
use std::f64::consts::PI;

/// A linear-Gaussian regression problem with a normalised product prior.
#[derive(Debug, Clone)]
pub struct LinearGaussian {
    design: DMatrix<f64>,
    data: DVector<f64>,
    sigma: f64,
    prior: Prior,
    /// XᵀX, row-major, for the allocation-free likelihood.
    gram: Vec<f64>,
    theta_ls: Vec<f64>,
    rss_min: f64,
    ln_norm: f64,
}

/// A closed-form evidence with the error of its box-mass term.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ExactEvidence {
    /// Always [`Method::Exact`].
    pub method: Method,
    /// `ln Z`.
    pub ln_z: f64,
    /// QMC error of the box-mass term (0 when no parameter has a uniform prior).
    pub std_err: f64,
}

/// The Gaussian part `N(m, A⁻¹)` of a sub-model's posterior (before any box truncation).
#[derive(Debug, Clone, PartialEq)]
pub struct GaussianPosterior {
    /// Mean `m` (the maximum of `L·π` with uniform priors extended flat beyond their boxes).
    pub mean: DVector<f64>,
    /// Covariance `A⁻¹`.
    pub cov: DMatrix<f64>,
    /// Precision `A`.
    pub precision: DMatrix<f64>,
}

impl LinearGaussian {
    /// Builds the problem. `design` is n×D with full column rank, `data` has n entries, `sigma`
    /// is the known noise standard deviation, `prior` has D Gaussian or uniform components.
    pub fn new(
        design: DMatrix<f64>,
        data: Vec<f64>,
        sigma: f64,
        prior: Prior,
    ) -> Result<Self, EvidenceError> {
        let (n, d) = design.shape();
        if n == 0 || d == 0 {
            return Err(EvidenceError::option(
                "linear_gaussian design",
                format!("{n}×{d}"),
                "the design needs at least one row and one column",
            ));
        }
        if data.len() != n {
            return Err(EvidenceError::dimension(
                "linear_gaussian data",
                n,
                data.len(),
            ));
        }
        if prior.dim() != d {
            return Err(EvidenceError::dimension(
                "linear_gaussian prior",
                d,
                prior.dim(),
            ));
        }
        if !(sigma.is_finite() && sigma > 0.0) {
            return Err(EvidenceError::option(
                "linear_gaussian sigma",
                sigma,
                "the noise standard deviation must be finite and > 0",
            ));
        }
        if let Some(v) = design.iter().chain(data.iter()).find(|v| !v.is_finite()) {
            return Err(EvidenceError::non_finite(
                "linear_gaussian design or data entry",
                *v,
                "pass finite numbers",
            ));
        }
        for (name, k) in prior.names().iter().zip(prior.kinds()) {
            if let PriorKind::LogUniform { .. } = k {
                return Err(EvidenceError::UnsupportedPrior {
                    param: name.clone(),
                    why: "the linear-Gaussian family has closed forms for Gaussian and uniform priors only; use one of those".into(),
                });
            }
        }
        let y = DVector::from_vec(data);
        let g = design.transpose() * &design;
        let chol = SpdOptions::default()
            .names(prior.names())
            .factor(&g)
            .map_err(EvidenceError::matrix(
                "XᵀX of the linear-Gaussian design",
                "the design columns must be linearly independent (full column rank)",
            ))?;
        let theta_ls = chol.solve(&(design.transpose() * &y));
        let rss_min = (&y - &design * &theta_ls).norm_squared();
        let gram = (0..d * d).map(|k| g[(k / d, k % d)]).collect();
        Ok(Self {
            ln_norm: -0.5 * n as f64 * (2.0 * PI * sigma * sigma).ln(),
            design,
            data: y,
            sigma,
            prior,
            gram,
            theta_ls: theta_ls.iter().cloned().collect(),
            rss_min,
        })
    }

    /// The design matrix X (n×D).
    pub fn design(&self) -> &DMatrix<f64> {
        &self.design
    }

    /// The data y.
    pub fn data(&self) -> &DVector<f64> {
        &self.data
    }

    /// The noise standard deviation σ.
    pub fn sigma(&self) -> f64 {
        self.sigma
    }

    /// Number of data values n.
    pub fn n_data(&self) -> usize {
        self.data.len()
    }

    fn check_cols(&self, cols: &[usize]) -> Result<(), EvidenceError> {
        let d = self.design.ncols();
        let mut seen = vec![false; d];
        for &c in cols {
            if c >= d {
                return Err(EvidenceError::option(
                    "linear_gaussian column",
                    c,
                    &format!("column indices must be < {d}"),
                ));
            }
            if seen[c] {
                return Err(EvidenceError::option(
                    "linear_gaussian column",
                    c,
                    "list each column once",
                ));
            }
            seen[c] = true;
        }
        Ok(())
    }

    /// Fisher information `X_SᵀX_S/σ²` of the likelihood of the model on `cols`.
    pub fn fisher(&self, cols: &[usize]) -> Result<DMatrix<f64>, EvidenceError> {
        self.check_cols(cols)?;
        let xs = self.design.select_columns(cols);
        Ok(xs.transpose() * &xs / (self.sigma * self.sigma))
    }

    /// The Gaussian part of the posterior of the model on `cols` (uniform priors extended flat),
    /// and the subset least-squares residual.
    fn quadratic_part(
        &self,
        cols: &[usize],
    ) -> Result<(GaussianPosterior, DVector<f64>, f64), EvidenceError> {
        self.check_cols(cols)?;
        let k = cols.len();
        let s2 = self.sigma * self.sigma;
        let xs = self.design.select_columns(cols);
        let g = xs.transpose() * &xs;
        let names: Vec<String> = cols
            .iter()
            .map(|&c| self.prior.names()[c].clone())
            .collect();
        let opts = SpdOptions::default().names(&names);
        let (theta_hat, rss) = if k == 0 {
            (DVector::zeros(0), self.data.norm_squared())
        } else {
            let cg = opts.factor(&g).map_err(EvidenceError::matrix(
                "X_SᵀX_S",
                "use linearly independent columns",
            ))?;
            let t = cg.solve(&(xs.transpose() * &self.data));
            let r = (&self.data - &xs * &t).norm_squared();
            (t, r)
        };
        let mut a = &g / s2;
        let mut rhs = &g * &theta_hat / s2;
        for (j, &c) in cols.iter().enumerate() {
            if let PriorKind::Gaussian { mu, sigma } = self.prior.kinds()[c] {
                a[(j, j)] += 1.0 / (sigma * sigma);
                rhs[j] += mu / (sigma * sigma);
            }
        }
        let (mean, cov) = if k == 0 {
            (DVector::zeros(0), DMatrix::zeros(0, 0))
        } else {
            let ca = opts.factor(&a).map_err(EvidenceError::matrix(
                "posterior precision A",
                "use linearly independent columns",
            ))?;
            (ca.solve(&rhs), ca.inverse())
        };
        Ok((
            GaussianPosterior {
                mean,
                cov,
                precision: a,
            },
            theta_hat,
            rss,
        ))
    }

    /// Maximum-likelihood point of the model on `cols` (least squares, ignoring the prior) and
    /// `ln L` there, e.g. for the Schwarz criterion.
    pub fn max_likelihood(&self, cols: &[usize]) -> Result<(Vec<f64>, f64), EvidenceError> {
        let (_, theta_hat, rss) = self.quadratic_part(cols)?;
        let ln_l = self.ln_norm - rss / (2.0 * self.sigma * self.sigma);
        Ok((theta_hat.iter().cloned().collect(), ln_l))
    }

    /// `N(m, A⁻¹)`: the posterior of the model on `cols` before truncation to uniform boxes.
    /// `m` is the maximum of `L·π` (the MAP when it lies inside the boxes).
    pub fn gaussian_posterior(&self, cols: &[usize]) -> Result<GaussianPosterior, EvidenceError> {
        Ok(self.quadratic_part(cols)?.0)
    }

    /// Closed-form `ln Z` of the model on `cols` (the other parameters fixed at 0).
    ///
    /// ```
    /// use nalgebra::DMatrix;
    /// use occam::evidence::linear_gaussian::LinearGaussian;
    /// use occam::evidence::mvn::MvnOptions;
    /// use occam::prior::{Prior, PriorKind};
    /// let x = DMatrix::from_row_slice(3, 1, &[1.0, 2.0, 3.0]);
    /// let prior = Prior::new(vec!["a".into()], vec![PriorKind::Gaussian { mu: 0.0, sigma: 1.0 }]).unwrap();
    /// let lg = LinearGaussian::new(x, vec![0.9, 2.1, 2.9], 0.5, prior).unwrap();
    /// let z = lg.exact_ln_evidence(&[0], &MvnOptions::default()).unwrap();
    /// // Oracle: y ~ N(0, σ²I + x xᵀ), evaluated directly.
    /// assert!((z.ln_z - lg.direct_ln_evidence_gaussian(&[0]).unwrap()).abs() < 1e-12);
    /// ```
    pub fn exact_ln_evidence(
        &self,
        cols: &[usize],
        mvn: &MvnOptions,
    ) -> Result<ExactEvidence, EvidenceError> {
        let (post, theta_hat, rss) = self.quadratic_part(cols)?;
        let s2 = self.sigma * self.sigma;
        let n = self.n_data() as f64;
        let k = cols.len();
        let mut ln_z = -0.5 * n * (2.0 * PI * s2).ln() - 0.5 * rss / s2;
        if k == 0 {
            return Ok(ExactEvidence {
                method: Method::Exact,
                ln_z,
                std_err: 0.0,
            });
        }
        let xs = self.design.select_columns(cols);
        let g = xs.transpose() * &xs;
        let dm = &post.mean - &theta_hat;
        let mut q = dm.dot(&(&g * &dm)) / s2;
        let mut bounded = Vec::new();
        for (j, &c) in cols.iter().enumerate() {
            match self.prior.kinds()[c] {
                PriorKind::Gaussian { mu, sigma } => {
                    q += ((post.mean[j] - mu) / sigma).powi(2);
                    ln_z -= 0.5 * (2.0 * PI * sigma * sigma).ln();
                }
                PriorKind::Uniform { lo, hi } => {
                    ln_z -= (hi - lo).ln();
                    bounded.push((j, lo, hi));
                }
                PriorKind::LogUniform { .. } => unreachable!("rejected in new()"),
            }
        }
        let ca = Spd::new(&post.precision).map_err(EvidenceError::matrix(
            "posterior precision A",
            "unreachable",
        ))?;
        ln_z += -0.5 * q + 0.5 * k as f64 * (2.0 * PI).ln() - 0.5 * ca.ln_det();
        let mut std_err = 0.0;
        if !bounded.is_empty() {
            let idx: Vec<usize> = bounded.iter().map(|b| b.0).collect();
            let lo: Vec<f64> = bounded.iter().map(|b| b.1).collect();
            let hi: Vec<f64> = bounded.iter().map(|b| b.2).collect();
            let mean: Vec<f64> = idx.iter().map(|&j| post.mean[j]).collect();
            let cov = post.cov.select_rows(&idx).select_columns(&idx);
            let p = mvn_rectangle(&lo, &hi, &mean, &cov, mvn)?;
            if p.ln_p == f64::NEG_INFINITY {
                return Err(EvidenceError::BoxMassUnderflow { ln_p: p.ln_p });
            }
            ln_z += p.ln_p;
            std_err = p.ln_p_std_err;
        }
        Ok(ExactEvidence {
            method: Method::Exact,
            ln_z,
            std_err,
        })
    }

    /// Oracle for tests: `ln N(y; X_S μ₀, σ²I + X_S Σ₀ X_Sᵀ)` by a dense n×n Cholesky. Only for
    /// all-Gaussian priors on `cols`.
    pub fn direct_ln_evidence_gaussian(&self, cols: &[usize]) -> Result<f64, EvidenceError> {
        self.check_cols(cols)?;
        let n = self.n_data();
        let xs = self.design.select_columns(cols);
        let mut mu0 = DVector::zeros(cols.len());
        let mut s0 = DMatrix::zeros(cols.len(), cols.len());
        for (j, &c) in cols.iter().enumerate() {
            match self.prior.kinds()[c] {
                PriorKind::Gaussian { mu, sigma } => {
                    mu0[j] = mu;
                    s0[(j, j)] = sigma * sigma;
                }
                _ => {
                    return Err(EvidenceError::UnsupportedPrior {
                        param: self.prior.names()[c].clone(),
                        why: "the direct oracle needs a Gaussian prior".into(),
                    });
                }
            }
        }
        let c = DMatrix::identity(n, n) * (self.sigma * self.sigma) + &xs * s0 * xs.transpose();
        let cc = Spd::new(&c).map_err(EvidenceError::matrix("data covariance C", "unreachable"))?;
        let r = &self.data - &xs * mu0;
        let q = r.dot(&cc.solve(&r));
        Ok(-0.5 * (n as f64 * (2.0 * PI).ln() + cc.ln_det() + q))
    }

    /// `n` exact posterior draws (rows) of the model on `cols`: multivariate normal, truncated to
    /// the uniform boxes by rejection. Errors if fewer than 1 in 1000 draws land in the box.
    pub fn sample_posterior<R: Rng + ?Sized>(
        &self,
        cols: &[usize],
        n: usize,
        rng: &mut R,
    ) -> Result<DMatrix<f64>, EvidenceError> {
        let post = self.gaussian_posterior(cols)?;
        let k = cols.len();
        let mut out = DMatrix::zeros(n, k);
        if k == 0 {
            return Ok(out);
        }
        let l = Spd::new(&post.cov)
            .map_err(EvidenceError::matrix("posterior covariance", "unreachable"))?
            .l();
        let sub = self.prior.subset(cols);
        let mut z = DVector::zeros(k);
        let (mut got, mut tries) = (0usize, 0usize);
        while got < n {
            tries += 1;
            if tries > 1000 * n.max(1) + 1000 {
                return Err(EvidenceError::option(
                    "sample_posterior n",
                    n,
                    "fewer than 1 in 1000 posterior draws land inside the prior box; rejection sampling is impractical for this box",
                ));
            }
            for v in z.iter_mut() {
                *v = StandardNormal.sample(rng);
            }
            let x = &post.mean + &l * &z;
            if sub.contains(x.as_slice()) {
                out.set_row(got, &x.transpose());
                got += 1;
            }
        }
        Ok(out)
    }
}

impl LogDensity for LinearGaussian {
    /// `−(n/2) ln 2πσ² − |y − Xθ|²/(2σ²)`, all constants included.
    fn ln_likelihood(&self, theta: &[f64]) -> f64 {
        let d = self.theta_ls.len();
        assert_eq!(theta.len(), d);
        let mut q = 0.0;
        for i in 0..d {
            let di = theta[i] - self.theta_ls[i];
            let row = &self.gram[i * d..(i + 1) * d];
            let mut s = 0.0;
            for j in 0..d {
                s += row[j] * (theta[j] - self.theta_ls[j]);
            }
            q += di * s;
        }
        self.ln_norm - (self.rss_min + q) / (2.0 * self.sigma * self.sigma)
    }

    fn prior(&self) -> &Prior {
        &self.prior
    }
}

/// The prior every parameter of a [`random`](LinearGaussian::random) problem gets.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub enum RandomPrior {
    /// `N(mu, sigma²)` for every parameter.
    Gaussian { mu: f64, sigma: f64 },
    /// `U[lo, hi]` for every parameter.
    Uniform { lo: f64, hi: f64 },
}

/// Recipe for a random linear-Gaussian problem.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct RandomSpec {
    /// Number of data values n.
    pub n_data: usize,
    /// Number of parameters D.
    pub dim: usize,
    /// Signal-to-noise ratio `|Xθ_true|/σ` (0 allowed: no signal).
    pub snr: f64,
    /// Number of trailing parameters whose true value is 0 (the nested models without them are
    /// then true).
    pub n_absent: usize,
    /// Noise standard deviation σ.
    pub sigma: f64,
    /// Prior of every parameter.
    pub prior: RandomPrior,
    /// Seed (design, true θ and noise are drawn from it, in that order).
    pub seed: u64,
}

/// A random problem and the parameters that generated its data.
#[derive(Debug, Clone)]
pub struct RandomProblem {
    /// The problem.
    pub model: LinearGaussian,
    /// The true θ.
    pub theta_true: Vec<f64>,
}

impl LinearGaussian {
    /// The typical size `σ·snr/√n` of a true parameter of a [`random`](Self::random) problem (its
    /// design entries are N(0, 1), so `|Xθ| ≈ √n |θ|`); the posterior width of one parameter is
    /// about `σ/√n`. Use it to choose prior widths.
    pub fn signal_scale(n_data: usize, snr: f64, sigma: f64) -> f64 {
        sigma * snr / (n_data as f64).sqrt()
    }

    /// A random problem: `X_ij ~ N(0, 1)`, θ_true along a random N(0, I) direction with the last
    /// `n_absent` entries zero, scaled so `|Xθ_true| = snr·σ`, `y = Xθ_true + σ ε`.
    ///
    /// ```
    /// use occam::evidence::linear_gaussian::{LinearGaussian, RandomPrior, RandomSpec};
    /// let spec = RandomSpec { n_data: 50, dim: 3, snr: 10.0, n_absent: 1, sigma: 1.0,
    ///     prior: RandomPrior::Gaussian { mu: 0.0, sigma: 5.0 }, seed: 7 };
    /// let p = LinearGaussian::random(&spec).unwrap();
    /// let signal = p.model.design() * nalgebra::DVector::from_vec(p.theta_true.clone());
    /// assert!((signal.norm() - 10.0).abs() < 1e-12);
    /// assert_eq!(p.theta_true[2], 0.0);
    /// ```
    pub fn random(spec: &RandomSpec) -> Result<RandomProblem, EvidenceError> {
        let &RandomSpec {
            n_data: n,
            dim: d,
            snr,
            n_absent,
            sigma,
            prior,
            seed,
        } = spec;
        if n < d || d == 0 {
            return Err(EvidenceError::option(
                "random dim",
                d,
                &format!("need 1 ≤ dim ≤ n_data (= {n}) for a full-rank design"),
            ));
        }
        if !(snr.is_finite() && snr >= 0.0) {
            return Err(EvidenceError::option(
                "random snr",
                snr,
                "snr must be finite and ≥ 0",
            ));
        }
        if n_absent > d || (n_absent == d && snr > 0.0) {
            return Err(EvidenceError::option(
                "random n_absent",
                n_absent,
                "at least one parameter must be present when snr > 0 (n_absent < dim)",
            ));
        }
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
        let x = DMatrix::from_fn(n, d, |_, _| StandardNormal.sample(&mut rng));
        let mut theta = DVector::from_fn(d, |i, _| {
            let z: f64 = StandardNormal.sample(&mut rng);
            if i < d - n_absent { z } else { 0.0 }
        });
        let signal = (&x * &theta).norm();
        if snr > 0.0 {
            theta *= snr * sigma / signal;
        } else {
            theta.fill(0.0);
        }
        let y: Vec<f64> = (&x * &theta)
            .iter()
            .map(|m| {
                let e: f64 = StandardNormal.sample(&mut rng);
                m + sigma * e
            })
            .collect();
        let kind = match prior {
            RandomPrior::Gaussian { mu, sigma } => PriorKind::Gaussian { mu, sigma },
            RandomPrior::Uniform { lo, hi } => PriorKind::Uniform { lo, hi },
        };
        let names = (0..d).map(|i| format!("theta{i}")).collect();
        let p = Prior::new(names, vec![kind; d])?;
        Ok(RandomProblem {
            model: LinearGaussian::new(x, y, sigma, p)?,
            theta_true: theta.iter().cloned().collect(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::nested::SubModel;

    fn problem(prior: RandomPrior, d: usize, snr: f64, seed: u64) -> RandomProblem {
        LinearGaussian::random(&RandomSpec {
            n_data: 40,
            dim: d,
            snr,
            n_absent: usize::from(d > 1),
            sigma: 0.7,
            prior,
            seed,
        })
        .unwrap()
    }

    #[test]
    fn likelihood_matches_the_direct_residual_sum() {
        let p = problem(RandomPrior::Uniform { lo: -3.0, hi: 3.0 }, 4, 30.0, 1);
        let m = &p.model;
        let theta = [0.3, -0.2, 1.1, 0.05];
        let r = m.data() - m.design() * DVector::from_row_slice(&theta);
        let n = m.n_data() as f64;
        let s2 = m.sigma().powi(2);
        let direct = -0.5 * n * (2.0 * PI * s2).ln() - r.norm_squared() / (2.0 * s2);
        assert!((m.ln_likelihood(&theta) - direct).abs() < 1e-10 * direct.abs());
    }

    #[test]
    fn gaussian_prior_evidence_matches_the_dense_oracle() {
        for d in 1..=5 {
            let p = problem(
                RandomPrior::Gaussian {
                    mu: 0.2,
                    sigma: 0.8,
                },
                d,
                10.0,
                d as u64,
            );
            for cols in [
                (0..d).collect::<Vec<_>>(),
                (0..d - 1).collect(),
                vec![d - 1],
            ] {
                let z = p
                    .model
                    .exact_ln_evidence(&cols, &MvnOptions::default())
                    .unwrap();
                let oracle = p.model.direct_ln_evidence_gaussian(&cols).unwrap();
                assert!(
                    (z.ln_z - oracle).abs() < 1e-9,
                    "d={d} {cols:?}: {} vs {oracle}",
                    z.ln_z
                );
                assert_eq!(z.std_err, 0.0);
            }
        }
    }

    /// Uniform box in 1-D and 2-D against brute-force quadrature of L over the box.
    #[test]
    fn uniform_prior_evidence_matches_quadrature() {
        // Narrow box so the truncation matters: posterior σ ≈ 0.7/√40 ≈ 0.11.
        let p = problem(RandomPrior::Uniform { lo: -0.1, hi: 0.25 }, 2, 3.0, 11);
        let m = &p.model;
        let n = 800;
        let (lo, hi) = (-0.1, 0.25);
        let h = (hi - lo) / n as f64;
        let w = |i: usize| if i == 0 || i == n { 0.5 } else { 1.0 };
        let ref_ln = m.ln_likelihood(&[0.0, 0.0]);
        // 1-D: column 0 only (θ1 = 0).
        let mut s1 = 0.0;
        for i in 0..=n {
            s1 += w(i) * (m.ln_likelihood(&[lo + h * i as f64, 0.0]) - ref_ln).exp();
        }
        let quad1 = ref_ln + (s1 * h / (hi - lo)).ln();
        let z1 = m.exact_ln_evidence(&[0], &MvnOptions::default()).unwrap();
        // Trapezoid error ~ h²·(curvature) ≈ (4e-4)²/(0.11)² ≈ 1e-5 relative.
        assert!((z1.ln_z - quad1).abs() < 1e-4, "{} vs {quad1}", z1.ln_z);
        let mut s2 = 0.0;
        for i in 0..=n {
            for j in 0..=n {
                let t = [lo + h * i as f64, lo + h * j as f64];
                s2 += w(i) * w(j) * (m.ln_likelihood(&t) - ref_ln).exp();
            }
        }
        let quad2 = ref_ln + (s2 * h * h / (hi - lo).powi(2)).ln();
        let z2 = m
            .exact_ln_evidence(&[0, 1], &MvnOptions::default())
            .unwrap();
        assert!(
            (z2.ln_z - quad2).abs() < 1e-4 + 5.0 * z2.std_err,
            "{} vs {quad2}",
            z2.ln_z
        );
    }

    #[test]
    fn nested_models_are_submodels_with_zero_base() {
        let p = problem(
            RandomPrior::Gaussian {
                mu: 0.0,
                sigma: 1.0,
            },
            3,
            10.0,
            3,
        );
        let sub = SubModel::new(&p.model, vec![0, 2], vec![0.0; 3]).unwrap();
        let theta = [0.4, -0.3];
        assert_eq!(
            sub.ln_likelihood(&theta),
            p.model.ln_likelihood(&[0.4, 0.0, -0.3])
        );
        let (ml, ln_l) = p.model.max_likelihood(&[0, 2]).unwrap();
        assert!((sub.ln_likelihood(&ml) - ln_l).abs() < 1e-9);
        let post = p.model.gaussian_posterior(&[0, 2]).unwrap();
        // The posterior mean is the maximum of ln L + ln π of the sub-model: zero gradient.
        let f = |t: &[f64]| sub.ln_posterior(t);
        let h = 1e-5;
        for i in 0..2 {
            let mut a = post.mean.as_slice().to_vec();
            let mut b = a.clone();
            a[i] += h;
            b[i] -= h;
            assert!(((f(&a) - f(&b)) / (2.0 * h)).abs() < 1e-4);
        }
    }

    #[test]
    fn generator_is_deterministic_and_validates() {
        let spec = RandomSpec {
            n_data: 30,
            dim: 3,
            snr: 5.0,
            n_absent: 0,
            sigma: 1.0,
            prior: RandomPrior::Uniform { lo: -1.0, hi: 1.0 },
            seed: 9,
        };
        let a = LinearGaussian::random(&spec).unwrap();
        let b = LinearGaussian::random(&spec).unwrap();
        assert_eq!(a.theta_true, b.theta_true);
        assert_eq!(a.model.data(), b.model.data());
        assert!(
            LinearGaussian::random(&RandomSpec {
                n_absent: 3,
                ..spec
            })
            .is_err()
        );
        assert!(LinearGaussian::random(&RandomSpec { dim: 31, ..spec }).is_err());
        assert!(
            LinearGaussian::random(&RandomSpec {
                snr: f64::NAN,
                ..spec
            })
            .is_err()
        );
        let collinear = DMatrix::from_row_slice(3, 2, &[1.0, 2.0, 2.0, 4.0, 3.0, 6.0]);
        let prior = Prior::new(
            vec!["a".into(), "b".into()],
            vec![PriorKind::Uniform { lo: 0.0, hi: 1.0 }; 2],
        )
        .unwrap();
        assert!(matches!(
            LinearGaussian::new(collinear, vec![1.0; 3], 1.0, prior),
            Err(EvidenceError::Matrix {
                source: crate::linalg::LinalgError::NotPositiveDefinite { .. },
                ..
            })
        ));
    }

    #[test]
    fn posterior_draws_have_the_posterior_moments() {
        let p = problem(
            RandomPrior::Gaussian {
                mu: 0.0,
                sigma: 1.0,
            },
            2,
            10.0,
            5,
        );
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(1);
        let n = 20_000;
        let s = p.model.sample_posterior(&[0, 1], n, &mut rng).unwrap();
        let post = p.model.gaussian_posterior(&[0, 1]).unwrap();
        for j in 0..2 {
            let mean = s.column(j).mean();
            let sd = post.cov[(j, j)].sqrt();
            // 4σ of the Monte-Carlo error of a mean of n iid draws.
            assert!((mean - post.mean[j]).abs() < 4.0 * sd / (n as f64).sqrt());
        }
    }
}
