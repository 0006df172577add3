//! Test densities with known answers.

use nalgebra::DMatrix;
use rand_distr::{Distribution, StandardNormal};

use crate::density::LogDensity;
use crate::prior::{Prior, PriorKind};
use crate::sampler::chain_rng;

/// Isotropic Gaussian likelihood of width `sd` centred on the corner `(1, …, 1)` of the
/// prior (the unit box in the tests).
pub(crate) struct CornerTarget {
    pub(crate) sd: f64,
    pub(crate) prior: Prior,
}

impl LogDensity for CornerTarget {
    fn ln_likelihood(&self, th: &[f64]) -> f64 {
        -0.5 * th
            .iter()
            .map(|x| ((x - 1.0) / self.sd).powi(2))
            .sum::<f64>()
    }
    fn prior(&self) -> &Prior {
        &self.prior
    }
}

/// `N(μ, Σ)` likelihood (normalised in θ) under a uniform box `μ ± 20 √Σ_ii`, wide enough that
/// the box holds all but `e^{-200}` of the mass: the posterior is the Gaussian.
pub(crate) struct GaussianTarget {
    pub(crate) mu: Vec<f64>,
    pub(crate) cov: DMatrix<f64>,
    prec: Vec<f64>,
    ln_norm: f64,
    prior: Prior,
}

impl GaussianTarget {
    /// Random rotation `Q` (QR of a Gaussian matrix) and eigenvalues log-spaced from 1 down
    /// to `1/cond`, so the condition number of Σ is `cond`; μ drawn from `N(0, 3²)`.
    pub(crate) fn correlated(dim: usize, cond: f64, seed: u64) -> Self {
        let mut rng = chain_rng(seed, 0);
        let g = DMatrix::from_fn(dim, dim, |_, _| {
            let z: f64 = StandardNormal.sample(&mut rng);
            z
        });
        let q = g.qr().q();
        let lambda: Vec<f64> = (0..dim)
            .map(|k| {
                if dim == 1 {
                    1.0
                } else {
                    cond.powf(-(k as f64) / (dim - 1) as f64)
                }
            })
            .collect();
        let cov = &q * DMatrix::from_diagonal(&lambda.clone().into()) * q.transpose();
        let inv: Vec<f64> = lambda.iter().map(|l| 1.0 / l).collect();
        let p = &q * DMatrix::from_diagonal(&inv.into()) * q.transpose();
        let cov = 0.5 * (&cov + cov.transpose());
        let mu: Vec<f64> = (0..dim)
            .map(|_| {
                let z: f64 = StandardNormal.sample(&mut rng);
                3.0 * z
            })
            .collect();
        let prec = (0..dim * dim)
            .map(|k| 0.5 * (p[(k / dim, k % dim)] + p[(k % dim, k / dim)]))
            .collect();
        let ln_norm = dim as f64 * (2.0 * std::f64::consts::PI).ln()
            + lambda.iter().map(|l| l.ln()).sum::<f64>();
        Self::with_box(mu, cov, prec, ln_norm, 20.0)
    }

    fn with_box(mu: Vec<f64>, cov: DMatrix<f64>, prec: Vec<f64>, ln_norm: f64, width: f64) -> Self {
        let dim = mu.len();
        let names = (0..dim).map(|k| format!("p{k}")).collect();
        let kinds = (0..dim)
            .map(|k| {
                let s = cov[(k, k)].sqrt();
                PriorKind::Uniform {
                    lo: mu[k] - width * s,
                    hi: mu[k] + width * s,
                }
            })
            .collect();
        Self {
            prior: Prior::new(names, kinds).unwrap(),
            mu,
            cov,
            prec,
            ln_norm,
        }
    }

    /// The same Gaussian with its mean moved by `shift` (prior box unchanged).
    pub(crate) fn shifted(&self, shift: f64) -> Self {
        let mut t = Self::with_box(
            self.mu.clone(),
            self.cov.clone(),
            self.prec.clone(),
            self.ln_norm,
            20.0,
        );
        t.mu.iter_mut().for_each(|m| *m += shift);
        t
    }

    /// Squared Mahalanobis distance of θ from μ.
    pub(crate) fn mahalanobis2(&self, theta: &[f64]) -> f64 {
        -2.0 * self.ln_likelihood(theta) - self.ln_norm
    }

    /// `√Σ_kk`.
    pub(crate) fn sd(&self, k: usize) -> f64 {
        self.cov[(k, k)].sqrt()
    }
}

impl LogDensity for GaussianTarget {
    fn ln_likelihood(&self, theta: &[f64]) -> f64 {
        let d = self.mu.len();
        let mut q = 0.0;
        for i in 0..d {
            let di = theta[i] - self.mu[i];
            let row = &self.prec[i * d..(i + 1) * d];
            let s: f64 = row
                .iter()
                .zip(theta.iter().zip(&self.mu))
                .map(|(p, (t, m))| p * (t - m))
                .sum();
            q += di * s;
        }
        -0.5 * (q + self.ln_norm)
    }

    fn prior(&self) -> &Prior {
        &self.prior
    }
}
