//! The independence proposal: candidates drawn from a fixed multivariate Student-t around the
//! MAP, whatever the chain's state.
//!
//! A random walk in `D` dimensions moves about `2.4/√D` posterior widths per accepted step, so
//! its autocorrelation time grows like `D`: in the ~35 dimensions of a fit with modelled
//! glitches, each `ln L` costing ~0.2 s of a core, it needs hours for a few hundred
//! independent draws. Where the posterior is close to its Laplace approximation (the MAP and
//! the inverse Fisher matrix), a draw from that approximation is nearly a draw from the
//! posterior, and Metropolis–Hastings with the ratio `q(θ)/q(θ')` corrects what remains: the
//! chain is exact for any proposal, and efficient where the proposal covers the posterior (a
//! Student-t's tails cover one wider than the Fisher matrix says; the fit's default is the
//! Gaussian, [`DEFAULT_DOF`]). Mixed with the random walk
//! ([`super::MetropolisHastings::independence`]), each iteration picks one of the two kernels
//! at random, independently of the state; each kernel keeps the posterior invariant, so the
//! mixture does.

use nalgebra::DMatrix;
use rand::Rng;
use rand_distr::{ChiSquared, Distribution};
use serde::{Deserialize, Serialize};

use super::error::SamplerError;
use super::proposal::{Proposal, correlated_normal};
use crate::linalg::SpdOptions;

/// Degrees of freedom of the fit's proposal: infinite, a Gaussian. Measured on
/// `examples/glitches.toml` with modelled glitches (34 parameters; 300 draws from the Laplace
/// approximation at the MAP, each weighed by its exact posterior; `examples/laplace_weights`):
/// the Gaussian's draws, run through an independence sampler, were accepted 51 % of the time
/// (Kish's effective share of the weights 41 %); a Student-t with ν = 8 36 % (24 %), ν = 4
/// 28 % (20 %), and the Gaussian 1.2 times wider 27 % (13 %). The posterior is that close to
/// its Laplace approximation, and a heavier tail only spends draws where it is not; the random
/// walk mixed in explores what the Gaussian's tails miss.
pub const DEFAULT_DOF: f64 = f64::INFINITY;

/// A multivariate Student-t `t_ν(μ, Σ)`, drawn independently of the chain's state:
/// `θ' = μ + scale · L z / √(w/ν)`, `z ~ N(0, I)`, `w ~ χ²_ν`, `L Lᵀ = Σ`. The log Hastings
/// ratio is `ln q(θ) − ln q(θ')` with `ln q(x) = −(ν + D)/2 · ln(1 + r²/ν)`,
/// `r² = |L⁻¹(x − μ)|²/scale²` (the normalisation cancels). With `ν = ∞` it is the Gaussian
/// `N(μ, Σ)`: `w/ν = 1`, `ln q = −r²/2`.
///
/// ```
/// use nalgebra::DMatrix;
/// use occam::sampler::{Proposal, StudentProposal, chain_rng};
/// let mut q = StudentProposal::new(vec![1.0, 2.0], &DMatrix::identity(2, 2), 8.0).unwrap();
/// let mut out = [0.0; 2];
/// let ln_h = q.propose(&[1.0, 2.0], 1.0, &mut chain_rng(7, 0), &mut out);
/// // from the centre, the ratio is ln q(μ) − ln q(θ') ≥ 0
/// assert!(ln_h >= 0.0);
/// assert!((ln_h - (q.ln_density(&[1.0, 2.0]) - q.ln_density(&out))).abs() < 1e-12);
/// ```
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct StudentProposal {
    #[serde(with = "super::bits::vec")]
    centre: Vec<f64>,
    /// Lower-triangular factor of Σ, row-major `D × D`.
    #[serde(with = "super::bits::vec")]
    chol: Vec<f64>,
    #[serde(with = "super::bits::scalar")]
    dof: f64,
    /// Per axis, `0` where the draws are `t_ν` in `x` itself, or the sign `s = ±1` of an
    /// axis drawn in `u = ln(s x)` ([`StudentProposal::log_axes`]); empty when none is.
    #[serde(default, with = "super::bits::vec")]
    log: Vec<f64>,
    #[serde(skip)]
    z: Vec<f64>,
}

/// Equal in centre, factor and degrees of freedom, bit for bit (the scratch buffer aside).
impl PartialEq for StudentProposal {
    fn eq(&self, other: &Self) -> bool {
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        bits(&self.centre) == bits(&other.centre)
            && bits(&self.chol) == bits(&other.chol)
            && self.dof.to_bits() == other.dof.to_bits()
            && bits(&self.log) == bits(&other.log)
    }
}

impl StudentProposal {
    /// Validates the centre (finite, of Σ's dimension), `dof` (> 0; `f64::INFINITY` for a
    /// Gaussian) and Σ (as [`super::GaussianProposal::new`]: symmetric, positive definite).
    pub fn new(centre: Vec<f64>, cov: &DMatrix<f64>, dof: f64) -> Result<Self, SamplerError> {
        let bad = |problem: String| Err(SamplerError::Covariance { problem });
        let d = centre.len();
        if d == 0 || cov.nrows() != d || cov.ncols() != d {
            return bad(format!(
                "the independence proposal's covariance is {}×{} for a centre of {d} parameters",
                cov.nrows(),
                cov.ncols()
            ));
        }
        if let Some(i) = centre.iter().position(|c| !c.is_finite()) {
            return bad(format!(
                "the independence proposal's centre has entry {i} = {}",
                centre[i]
            ));
        }
        if !(dof > 0.0) {
            return bad(format!(
                "the independence proposal's degrees of freedom must be > 0 (got {dof})"
            ));
        }
        let spd = SpdOptions::default()
            .factor(cov)
            .map_err(|e| SamplerError::Covariance {
                problem: format!("the independence proposal's covariance: {e}"),
            })?;
        Ok(Self {
            chol: spd.l_row_major(),
            z: vec![0.0; d],
            centre,
            dof,
            log: Vec::new(),
        })
    }

    /// The same proposal with the axes `axes` drawn in logarithm: on such an axis `i` the
    /// draws are `x_i = s_i exp(u_i)`, `s_i` the centre's sign, `u` the `t_ν` whose centre
    /// is `ln |μ_i|` and whose scale matrix is `DΣD` (`D_ii = 1/μ_i` on those axes, 1 on the
    /// others: the same widths and correlations at the centre), and `ln q` carries the Jacobian
    /// `−Σ ln |x_i|`; a point of the other sign has `q = 0`. Why: a glitch whose decay is
    /// short against the loop's response is seen through the product of its amplitude and
    /// decay, so its posterior is a ridge `ln |a| + ln τ ≈ const` — straight in logarithms,
    /// curved in `(a, τ)`, where a Gaussian's draws fall off it. Fails on an axis out of
    /// range or whose centre is 0.
    ///
    /// ```
    /// use nalgebra::DMatrix;
    /// use occam::sampler::{Proposal, StudentProposal, chain_rng};
    /// let q = StudentProposal::new(vec![-2.0, 3.0], &DMatrix::identity(2, 2), f64::INFINITY);
    /// let mut q = q.unwrap().log_axes(&[0]).unwrap();
    /// let mut out = [0.0; 2];
    /// q.propose(&[-2.0, 3.0], 1.0, &mut chain_rng(7, 0), &mut out);
    /// assert!(out[0] < 0.0);
    /// // the other sign is never drawn, so it has no density
    /// assert_eq!(q.ln_density(&[2.0, 3.0]), f64::NEG_INFINITY);
    /// ```
    pub fn log_axes(mut self, axes: &[usize]) -> Result<Self, SamplerError> {
        let d = self.centre.len();
        let mut log = vec![0.0; d];
        for &i in axes {
            let c = *self.centre.get(i).ok_or_else(|| SamplerError::Covariance {
                problem: format!("log axis {i} of a proposal of {d} parameters"),
            })?;
            if c == 0.0 {
                return Err(SamplerError::Covariance {
                    problem: format!("log axis {i}: the centre is 0"),
                });
            }
            log[i] = c.signum();
        }
        for i in 0..d {
            if log[i] != 0.0 {
                // du = dx / x: signed, so that a negative axis keeps its correlations
                let scale = 1.0 / self.centre[i];
                self.centre[i] = self.centre[i].abs().ln();
                // row i of L scales by D_ii: D L is a lower factor of D Σ D (its diagonal
                // negative on a negative axis; the density and the draws need only L Lᵀ)
                for v in &mut self.chol[i * d..i * d + i + 1] {
                    *v *= scale;
                }
            }
        }
        self.log = if log.iter().any(|s| *s != 0.0) {
            log
        } else {
            Vec::new()
        };
        Ok(self)
    }

    /// Restores the scratch buffer after deserialisation.
    pub(crate) fn prepare(&mut self) {
        self.z.resize(self.centre.len(), 0.0);
    }

    /// `ln q(x)` up to its normalisation, at unit scale.
    pub fn ln_density(&mut self, x: &[f64]) -> f64 {
        self.ln_density_scaled(x, 1.0)
    }

    fn ln_density_scaled(&mut self, x: &[f64], scale: f64) -> f64 {
        let d = self.centre.len();
        // the log axes' coordinates and Jacobian
        let mut jacobian = 0.0;
        let mut at = |i: usize| match self.log.get(i) {
            Some(&s) if s != 0.0 => {
                let v = s * x[i];
                jacobian -= v.ln();
                if v > 0.0 { v.ln() } else { f64::NAN }
            }
            _ => x[i],
        };
        // forward substitution L u = x − μ, into the scratch buffer
        let mut r2 = 0.0;
        for i in 0..d {
            let row = &self.chol[i * d..i * d + i + 1];
            let s: f64 = row[..i].iter().zip(&self.z[..i]).map(|(l, u)| l * u).sum();
            let u = (at(i) - self.centre[i] - s) / row[i];
            self.z[i] = u;
            r2 += u * u;
        }
        if r2.is_nan() {
            // a log axis of the other sign: never drawn
            return f64::NEG_INFINITY;
        }
        let r2 = r2 / (scale * scale);
        let q = if self.dof.is_infinite() {
            -0.5 * r2
        } else {
            -0.5 * (self.dof + d as f64) * (r2 / self.dof).ln_1p()
        };
        q + jacobian
    }
}

impl Proposal for StudentProposal {
    fn dim(&self) -> usize {
        self.centre.len()
    }

    fn propose<R: Rng + ?Sized>(
        &mut self,
        current: &[f64],
        scale: f64,
        rng: &mut R,
        out: &mut [f64],
    ) -> f64 {
        let here = self.ln_density_scaled(current, scale);
        let stretch = if self.dof.is_infinite() {
            scale
        } else {
            let w: f64 = ChiSquared::new(self.dof)
                .expect("dof checked in the constructor")
                .sample(rng);
            scale / (w / self.dof).sqrt()
        };
        let (centre, log) = (&self.centre, &self.log);
        correlated_normal(&self.chol, &mut self.z, rng, |i, s| {
            let u = centre[i] + stretch * s;
            out[i] = match log.get(i) {
                Some(&sign) if sign != 0.0 => sign * u.exp(),
                _ => u,
            };
        });
        here - self.ln_density_scaled(out, scale)
    }
}

/// The independence kernel of a mixture: `proposal`, drawn from in a share `share` of the
/// iterations (the random walk in the others).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Independence {
    #[serde(with = "super::bits::scalar")]
    share: f64,
    proposal: StudentProposal,
}

impl Independence {
    /// Validates `share` (in `(0, 1]`).
    pub fn new(share: f64, proposal: StudentProposal) -> Result<Self, SamplerError> {
        if !(share > 0.0 && share <= 1.0) {
            return Err(SamplerError::Setting {
                field: "independence",
                problem: format!(
                    "the share of independence proposals must be in (0, 1] (got {share})"
                ),
            });
        }
        Ok(Self { share, proposal })
    }

    /// The dimension of its draws.
    pub fn dim(&self) -> usize {
        self.proposal.dim()
    }

    /// The share of iterations drawn from [`Independence::proposal`].
    pub fn share(&self) -> f64 {
        self.share
    }

    /// The Student-t proposal.
    pub fn proposal(&mut self) -> &mut StudentProposal {
        &mut self.proposal
    }

    pub(crate) fn prepare(&mut self) {
        self.proposal.prepare();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::chain_rng;

    #[test]
    fn rejects_bad_settings() {
        let id = DMatrix::identity(2, 2);
        let err = |r: Result<StudentProposal, SamplerError>| match r {
            Err(SamplerError::Covariance { problem }) => problem,
            other => panic!("expected an error, got {other:?}"),
        };
        assert!(err(StudentProposal::new(vec![0.0], &id, 8.0)).contains("2×2"));
        assert!(err(StudentProposal::new(vec![0.0, f64::NAN], &id, 8.0)).contains("entry 1"));
        assert!(err(StudentProposal::new(vec![0.0; 2], &id, 0.0)).contains("degrees"));
        let singular = DMatrix::from_row_slice(2, 2, &[1.0, 1.0, 1.0, 1.0]);
        assert!(err(StudentProposal::new(vec![0.0; 2], &singular, 8.0)).contains("covariance"));
    }

    /// The density the Hastings ratio uses is the one the draws follow: the squared radius
    /// `r² = |L⁻¹(x − μ)|²` of a `t_ν` in `D` dimensions is `D·F(D, ν)`-distributed (mean
    /// `D ν/(ν − 2)`, variance `2 D ν² (D + ν − 2)/((ν − 2)²(ν − 4))`), of the Gaussian (ν = ∞)
    /// `χ²_D` (mean `D`, variance `2D`); and `ln q` equals the closed form at a known point.
    #[test]
    fn draws_follow_the_density_of_the_ratio() {
        let cov = DMatrix::from_row_slice(3, 3, &[4.0, 1.0, 0.2, 1.0, 2.0, 0.3, 0.2, 0.3, 1.0]);
        let mu = vec![1.0, -2.0, 0.5];
        let inv = cov.clone().try_inverse().unwrap();
        let r2 = |x: &[f64]| {
            let dx = nalgebra::DVector::from_iterator(3, x.iter().zip(&mu).map(|(a, b)| a - b));
            (dx.transpose() * &inv * &dx)[(0, 0)]
        };
        let x = [2.0, -1.0, 0.0];
        for (dof, ln_q, mean, var) in [
            (6.0, -0.5 * 9.0 * (r2(&x) / 6.0).ln_1p(), 4.5, 47.25),
            (f64::INFINITY, -0.5 * r2(&x), 3.0, 6.0),
        ] {
            let mut q = StudentProposal::new(mu.clone(), &cov, dof).unwrap();
            assert!((q.ln_density(&x) - ln_q).abs() < 1e-12);
            let mut rng = chain_rng(5, 0);
            let n = 100_000;
            let mut out = [0.0; 3];
            let mut sum = 0.0;
            for _ in 0..n {
                q.propose(&mu, 1.0, &mut rng, &mut out);
                sum += r2(&out);
            }
            let se = (var / n as f64).sqrt();
            assert!(
                (sum / n as f64 - mean).abs() < 4.0 * se,
                "ν = {dof}: {}",
                sum / n as f64
            );
        }
    }

    /// On log axes the density is the log-normal's — `u = ln(s x)` Gaussian with centre
    /// `ln |μ|` and scale `DΣD`, times the Jacobian `Π 1/|x_i|` — checked against that closed
    /// form at points of either sign, and the draws follow it: their `r²` in `u` is `χ²_D`
    /// (mean 3, variance 6), every draw keeps the centre's sign, and the draws' median on a
    /// log axis is the centre (a Gaussian in `x` has the centre as its mean instead).
    #[test]
    fn log_axes_draw_the_log_normal_of_the_ratio() {
        let cov =
            DMatrix::from_row_slice(3, 3, &[0.09, 0.05, 0.0, 0.05, 0.16, 0.02, 0.0, 0.02, 1.0]);
        let mu = vec![-2.0, 1.5, 0.5];
        let mut q = StudentProposal::new(mu.clone(), &cov, f64::INFINITY)
            .unwrap()
            .log_axes(&[0, 1])
            .unwrap();
        // the scale matrix in u = (ln −x0, ln x1, x2): D Σ D with D = diag(−1/2, 1/1.5, 1),
        // du = dx/x (signed: x0 and x1 correlate positively, so ln −x0 and ln x1 negatively)
        let d = [-0.5, 1.0 / 1.5, 1.0];
        let cu = DMatrix::from_fn(3, 3, |i, j| cov[(i, j)] * d[i] * d[j]);
        let inv = cu.try_inverse().unwrap();
        let mu_u = [2.0f64.ln(), 1.5f64.ln(), 0.5];
        let u_of = |x: &[f64]| [(-x[0]).ln(), x[1].ln(), x[2]];
        let r2 = |u: &[f64; 3]| {
            let du = nalgebra::DVector::from_iterator(3, u.iter().zip(&mu_u).map(|(a, b)| a - b));
            (du.transpose() * &inv * &du)[(0, 0)]
        };
        let closed = |x: &[f64]| -0.5 * r2(&u_of(x)) - (-x[0]).ln() - x[1].ln();
        for x in [[-2.5, 1.0, 0.0], [-1.0, 3.0, 2.0], [-2.0, 1.5, 0.5]] {
            assert!((q.ln_density(&x) - closed(&x)).abs() < 1e-12, "{x:?}");
        }
        assert_eq!(q.ln_density(&[2.0, 1.5, 0.5]), f64::NEG_INFINITY);
        assert_eq!(q.ln_density(&[-2.0, 0.0, 0.5]), f64::NEG_INFINITY);
        let mut rng = chain_rng(9, 0);
        let n = 100_000;
        let mut out = [0.0; 3];
        let (mut sum, mut below) = (0.0, 0usize);
        for _ in 0..n {
            let ln_h = q.propose(&mu, 1.0, &mut rng, &mut out);
            assert!(out[0] < 0.0 && out[1] > 0.0);
            assert!((ln_h - (closed(&mu) - closed(&out))).abs() < 1e-9);
            sum += r2(&u_of(&out));
            below += usize::from(out[1] < 1.5);
        }
        let se = (6.0 / n as f64).sqrt();
        assert!(
            (sum / n as f64 - 3.0).abs() < 4.0 * se,
            "{}",
            sum / n as f64
        );
        let half = below as f64 / n as f64;
        assert!(
            (half - 0.5).abs() < 4.0 * (0.25 / n as f64).sqrt(),
            "{half}"
        );
        assert!(
            StudentProposal::new(vec![0.0, 1.0], &DMatrix::identity(2, 2), 8.0)
                .unwrap()
                .log_axes(&[0])
                .is_err()
        );
    }
}
