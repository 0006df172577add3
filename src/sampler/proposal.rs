//! Proposals: the [`Proposal`] capability and the Gaussian random walk.

use nalgebra::DMatrix;
use rand::Rng;
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};

use super::error::SamplerError;
use crate::linalg::{LinalgError, SpdOptions};

/// `cov` with every marginal standard deviation capped at the prior's
/// ([`crate::prior::PriorKind::sd`]; correlations kept): where the Fisher Gaussian is wider
/// than the prior — a MAP on a bound, a parameter the data barely constrain — the prior is the
/// better description of the posterior, and a random walk or a start draw from the wider
/// Gaussian almost never lands inside the box. Rows and columns follow `prior`'s parameters.
///
/// ```
/// use nalgebra::DMatrix;
/// use occam::prior::{Prior, PriorKind};
/// let prior = Prior::new(
///     vec!["a".into(), "b".into()],
///     vec![PriorKind::Gaussian { mu: 0.0, sigma: 1.0 }, PriorKind::Gaussian { mu: 0.0, sigma: 10.0 }],
/// ).unwrap();
/// let c = occam::sampler::cap_to_prior(&DMatrix::from_row_slice(2, 2, &[4.0, 1.0, 1.0, 1.0]), &prior);
/// assert_eq!(c, DMatrix::from_row_slice(2, 2, &[1.0, 0.5, 0.5, 1.0]));
/// ```
pub fn cap_to_prior(cov: &DMatrix<f64>, prior: &crate::prior::Prior) -> DMatrix<f64> {
    let n = cov.nrows();
    let f: Vec<f64> = (0..n)
        .map(|i| {
            let sd = cov[(i, i)].sqrt();
            let cap = prior.kinds()[i].sd();
            if sd > cap { cap / sd } else { 1.0 }
        })
        .collect();
    DMatrix::from_fn(n, n, |i, j| cov[(i, j)] * f[i] * f[j])
}

/// A Metropolis–Hastings proposal `q(θ' | θ)`.
///
/// Like emcee's moves, a proposal writes the candidate and returns its log Hastings ratio
/// `ln q(θ | θ') − ln q(θ' | θ)` (0 for symmetric proposals), so the driver's acceptance test
/// is the same for every proposal.
pub trait Proposal {
    /// Dimension of θ.
    fn dim(&self) -> usize;

    /// Writes a candidate drawn around `current` into `out` and returns the log Hastings
    /// ratio. `scale` multiplies the proposal's standard deviations (the annealed search uses
    /// it for its jumps); it must not depend on `current`, or the returned ratio would be
    /// wrong. Must not allocate.
    fn propose<R: Rng + ?Sized>(
        &mut self,
        current: &[f64],
        scale: f64,
        rng: &mut R,
        out: &mut [f64],
    ) -> f64;
}

/// Multivariate Gaussian random walk `θ' = θ + scale · L z`, `z ~ N(0, I)`, `L Lᵀ = Σ`.
///
/// Σ is validated and Cholesky-factored once, in [`GaussianProposal::new`] (by
/// [`crate::linalg::Spd`]).
///
/// ```
/// use nalgebra::DMatrix;
/// use occam::sampler::{GaussianProposal, Proposal, chain_rng};
/// let mut q = GaussianProposal::new(&DMatrix::from_row_slice(2, 2, &[4.0, 1.0, 1.0, 1.0])).unwrap();
/// let mut out = [0.0; 2];
/// let ln_hastings = q.propose(&[1.0, 2.0], 1.0, &mut chain_rng(7, 0), &mut out);
/// assert_eq!(ln_hastings, 0.0);
/// assert!((q.covariance()[(0, 1)] - 1.0).abs() < 1e-15);
/// ```
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct GaussianProposal {
    dim: usize,
    /// Lower-triangular factor, row-major `dim × dim`.
    #[serde(with = "super::bits::vec")]
    chol: Vec<f64>,
    #[serde(skip)]
    z: Vec<f64>,
}

impl GaussianProposal {
    /// Validates Σ (square, non-empty, positive variances, finite, symmetric to 1e−8 relative
    /// to `√Σ_ii √Σ_jj`, positive definite) and factors `(Σ + Σᵀ)/2` with [`crate::linalg::Spd`].
    /// The symmetric tolerance admits the round-off of a numerically inverted Fisher matrix.
    pub fn new(cov: &DMatrix<f64>) -> Result<Self, SamplerError> {
        Self::with_names(cov, &[])
    }

    /// As [`GaussianProposal::new`]; when Σ is not positive definite the error names the
    /// least-constrained direction by the parameters' `names` (Σ's rows, in order).
    pub fn with_names(cov: &DMatrix<f64>, names: &[String]) -> Result<Self, SamplerError> {
        let d = cov.nrows();
        let bad = |problem: String| Err(SamplerError::Covariance { problem });
        if d == 0 || cov.ncols() != d {
            return bad(format!(
                "must be square and non-empty (got {}×{})",
                cov.nrows(),
                cov.ncols()
            ));
        }
        for i in 0..d {
            if cov[(i, i)] <= 0.0 {
                return bad(format!(
                    "diagonal entry ({i}, {i}) = {} must be > 0 (it is a variance)",
                    cov[(i, i)]
                ));
            }
        }
        let spd = match SpdOptions::default().names(names).factor(cov) {
            Ok(spd) => spd,
            Err(e @ LinalgError::NotPositiveDefinite { .. }) => {
                return bad(format!(
                    "{e}; check the Fisher matrix for unconstrained or duplicated parameters"
                ));
            }
            Err(e) => return bad(e.to_string()),
        };
        Ok(Self {
            dim: d,
            chol: spd.l_row_major(),
            z: vec![0.0; d],
        })
    }

    /// The Cholesky factor `L` (lower-triangular, row-major).
    pub fn cholesky(&self) -> &[f64] {
        &self.chol
    }

    /// `Σ = L Lᵀ`.
    pub fn covariance(&self) -> DMatrix<f64> {
        let l = DMatrix::from_row_slice(self.dim, self.dim, &self.chol);
        &l * l.transpose()
    }

    /// Replaces `L` (used by the adaptation; the caller has checked it).
    pub(crate) fn cholesky_mut(&mut self) -> &mut [f64] {
        &mut self.chol
    }

    /// Restores the scratch buffer after deserialisation.
    pub(crate) fn prepare(&mut self) {
        self.z.resize(self.dim, 0.0);
    }
}

impl Proposal for GaussianProposal {
    fn dim(&self) -> usize {
        self.dim
    }

    fn propose<R: Rng + ?Sized>(
        &mut self,
        current: &[f64],
        scale: f64,
        rng: &mut R,
        out: &mut [f64],
    ) -> f64 {
        correlated_normal(&self.chol, &mut self.z, rng, |i, s| {
            out[i] = current[i] + scale * s
        });
        0.0
    }
}

/// Draws `z ~ N(0, I)` into `z` (its length is the dimension `D`), then hands each
/// `(i, (L z)_i)` to `put`, with `L` the row-major lower-triangular `D × D` factor `chol`.
pub(super) fn correlated_normal<R: Rng + ?Sized>(
    chol: &[f64],
    z: &mut [f64],
    rng: &mut R,
    mut put: impl FnMut(usize, f64),
) {
    let d = z.len();
    for v in z.iter_mut() {
        *v = StandardNormal.sample(rng);
    }
    for i in 0..d {
        let row = &chol[i * d..i * d + i + 1];
        put(i, row.iter().zip(z.iter()).map(|(l, z)| l * z).sum());
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::chain_rng;

    #[test]
    fn cholesky_reproduces_matrix() {
        let m = DMatrix::from_row_slice(3, 3, &[4.0, 2.0, 0.4, 2.0, 5.0, 1.0, 0.4, 1.0, 3.0]);
        let q = GaussianProposal::new(&m).unwrap();
        let back = q.covariance();
        assert!((back - &m).amax() < 1e-14);
        let l = q.cholesky();
        assert_eq!((l[1], l[2], l[5]), (0.0, 0.0, 0.0));
    }

    #[test]
    fn rejects_bad_covariances() {
        let err = |m: DMatrix<f64>| match GaussianProposal::new(&m) {
            Err(SamplerError::Covariance { problem }) => problem,
            other => panic!("expected an error, got {other:?}"),
        };
        assert!(err(DMatrix::zeros(2, 3)).contains("square"));
        assert!(
            err(DMatrix::from_row_slice(2, 2, &[1.0, f64::NAN, 0.0, 1.0])).contains("not finite")
        );
        assert!(
            err(DMatrix::from_row_slice(2, 2, &[1.0, 0.5, 0.0, 1.0])).contains("not symmetric")
        );
        assert!(
            err(DMatrix::from_row_slice(2, 2, &[1.0, 2.0, 2.0, 1.0]))
                .contains("not positive definite")
        );
        assert!(err(DMatrix::from_row_slice(2, 2, &[-1.0, 0.0, 0.0, 1.0])).contains("variance"));
        // with names, the unconstrained direction is named
        let names = ["a".to_string(), "b".to_string()];
        let singular = DMatrix::from_row_slice(2, 2, &[1.0, 1.0, 1.0, 1.0]);
        match GaussianProposal::with_names(&singular, &names) {
            Err(SamplerError::Covariance { problem }) => {
                assert!(problem.contains("0.71·a − 0.71·b"), "{problem}")
            }
            other => panic!("expected an error, got {other:?}"),
        }
    }

    #[test]
    fn draws_have_the_requested_covariance() {
        // 200 000 draws: the sample covariance of a Gaussian has standard error
        // sqrt((Σ_ii Σ_jj + Σ_ij²)/N) ≤ sqrt(2·4·4/2e5) ≈ 0.013 here; 5 standard errors allowed.
        let m = DMatrix::from_row_slice(2, 2, &[4.0, 1.5, 1.5, 1.0]);
        let mut q = GaussianProposal::new(&m).unwrap();
        let mut rng = chain_rng(3, 0);
        let n = 200_000;
        let (mut s00, mut s01, mut s11) = (0.0, 0.0, 0.0);
        let mut out = [0.0; 2];
        for _ in 0..n {
            q.propose(&[0.0, 0.0], 1.0, &mut rng, &mut out);
            s00 += out[0] * out[0];
            s01 += out[0] * out[1];
            s11 += out[1] * out[1];
        }
        let nf = n as f64;
        let se = |i: usize, j: usize| ((m[(i, i)] * m[(j, j)] + m[(i, j)] * m[(i, j)]) / nf).sqrt();
        assert!((s00 / nf - 4.0).abs() < 5.0 * se(0, 0));
        assert!((s01 / nf - 1.5).abs() < 5.0 * se(0, 1));
        assert!((s11 / nf - 1.0).abs() < 5.0 * se(1, 1));
    }
}
