//! Evidence (marginal likelihood) estimators and Bayes factors.
//!
//! Every estimator works on any [`LogDensity`](crate::density::LogDensity), so the closed-form
//! linear-Gaussian problems of [`linear_gaussian`] run through exactly the code the LTP study runs.
//! All logs are natural; `ln B_XY = ln Z_X − ln Z_Y`; priors are normalised densities, so their
//! volume (the Occam factor) is part of every estimate.
//!
//! | estimator | function | needs |
//! |---|---|---|
//! | Laplace–Fisher | [`laplace::laplace_fisher`] | θ̂, Fisher matrix of ln L |
//! | Laplace–Hessian | [`laplace::laplace_hessian`] | θ̂ (numerical Hessian of ln posterior) |
//! | Laplace–Metropolis | [`laplace::laplace_metropolis`] | best sample, posterior samples (MVE / MCD covariance) |
//! | Schwarz (SBIC) | [`schwarz::schwarz_ln_b`] | maximum ln L of each model, n |
//! | RJMCMC (visits, Rao-Blackwell, bridge) | [`rjmcmc::run_rjmcmc`] | θ̂ and covariance per model |
//! | Thermodynamic integration, stepping stone | [`tempering::run_tempering`] | a start point and covariance per model |
//!
//! Corrections relative to K14 and LTPDA (see `ltp-model.md` §9.2–9.4): the Laplace formulas use
//! `|H|^{−1/2}`, include `ln π(θ̂)`, and can add the Gaussian's mass inside the prior box; the
//! RJMCMC acceptance ratio is the full Carlin–Chib ratio with `L` (not `L²`) and the prior ratio
//! the right way up; MVE keeps repeated chain samples and never rotates the data.

pub mod laplace;
pub mod linear_gaussian;
pub mod mvn;
mod normal;
pub mod rjmcmc;
pub mod robust;
pub mod schwarz;
pub mod tempering;

use serde::Serialize;

pub use laplace::{
    LaplaceEstimate, LaplaceOptions, laplace_fisher, laplace_hessian, laplace_metropolis,
    numerical_hessian,
};
pub use linear_gaussian::{LinearGaussian, RandomPrior, RandomProblem, RandomSpec};
pub use mvn::{MvnOptions, MvnProbability, mvn_rectangle};
pub use rjmcmc::{
    JumpRule, MAX_RUNNING_POINTS, MIN_EFFECTIVE_JUMPS, ProposalShape, ReversibleJump, RjDraws,
    RjModel, RjOptions, RjOutcome, RjPair, RjProgress, RjResult, RjRunningPair, RjRunningPoint,
    run_rjmcmc, union_columns,
};
pub use robust::{McdOptions, MveOptions, RobustCovariance, RobustMethod, mcd, mve};
pub use schwarz::{schwarz_ln_b, schwarz_ln_z};
pub use tempering::{
    ParallelTempering, SteppingStoneEstimate, TemperingOptions, TemperingOutcome, TemperingResult,
    ThermodynamicEstimate, run_tempering, run_tempering_observed,
};

/// Which estimator produced a number.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Method {
    /// Closed form (known-answer problems).
    Exact,
    /// Laplace with the Fisher matrix (plus prior curvature).
    LaplaceFisher,
    /// Laplace with a numerical Hessian of the log posterior.
    LaplaceHessian,
    /// Laplace–Metropolis, minimum-volume-ellipsoid covariance.
    LaplaceMetropolisMve,
    /// Laplace–Metropolis, minimum-covariance-determinant covariance.
    LaplaceMetropolisMcd,
    /// Schwarz criterion (SBIC).
    Schwarz,
    /// RJMCMC visit ratio.
    RjVisits,
    /// RJMCMC mean-acceptance-probability ratio (Bartolucci, Scaccia & Mira 2006).
    RjRaoBlackwell,
    /// RJMCMC optimal bridge on the independence-proposal pairs (Meng & Wong 1996).
    RjBridge,
}

/// A log Bayes factor `ln B_XY = ln Z_X − ln Z_Y` with its Monte-Carlo standard error.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, serde::Deserialize)]
pub struct LnB {
    /// Estimator.
    pub method: Method,
    /// `ln B_XY`.
    pub ln_b: f64,
    /// One-sigma Monte-Carlo error of `ln_b`; `None` for deterministic approximations, whose
    /// error is a bias the number cannot tell (Laplace without box term, Schwarz).
    pub std_err: Option<f64>,
}

impl LnB {
    /// `ln B_XY` from two estimates of the same method: `ln Z_X − ln Z_Y`, errors added in
    /// quadrature.
    pub fn from_estimates(x: &LaplaceEstimate, y: &LaplaceEstimate) -> LnB {
        let std_err = match (x.std_err, y.std_err) {
            (None, None) => None,
            (a, b) => Some(a.unwrap_or(0.0).hypot(b.unwrap_or(0.0))),
        };
        LnB {
            method: x.method,
            ln_b: x.ln_z - y.ln_z,
            std_err,
        }
    }
}

/// Why an evidence computation could not produce a number.
#[derive(Debug, PartialEq, thiserror::Error)]
pub enum EvidenceError {
    /// A vector or matrix has the wrong size.
    #[error("{what}: expected {expected} entries, got {got}")]
    Dimension {
        what: String,
        expected: usize,
        got: usize,
    },
    /// An input is NaN or infinite where a finite number is needed.
    #[error("{what} is not finite ({value}); {fix}")]
    NonFinite {
        what: String,
        value: f64,
        fix: String,
    },
    /// A matrix that must be symmetric positive definite is not (found outside a
    /// factorisation: a pivot of the reordered MVN integral, a Hessian diagonal).
    #[error("{what} is not symmetric positive definite ({detail}); {fix}")]
    NotPositiveDefinite {
        what: String,
        detail: String,
        fix: String,
    },
    /// A matrix that must be symmetric positive definite failed its factorisation: `source`
    /// says why (naming the least-constrained direction when it is not positive definite).
    #[error("{what}: {source}; {fix}")]
    Matrix {
        what: String,
        source: crate::linalg::LinalgError,
        fix: String,
    },
    /// The expansion point is on or outside the prior support and no box correction was asked.
    #[error(
        "θ̂ of `{param}` = {value} is on or outside its prior bounds [{lo}, {hi}]: the plain Laplace formula does not apply at a bound; the box-corrected form (expanded at the unconstrained maximum, times the Gaussian's mass inside the box) does"
    )]
    OnBoundary {
        param: String,
        value: f64,
        lo: f64,
        hi: f64,
    },
    /// The Gaussian approximation puts no representable mass inside the prior box.
    #[error(
        "the Gaussian approximation N(θ̂, Σ) has no representable mass inside the prior box (ln P = {ln_p}); the Laplace estimate is not applicable here"
    )]
    BoxMassUnderflow { ln_p: f64 },
    /// Too few samples for a robust covariance.
    #[error(
        "{what}: {n} samples for {dim} parameters; at least {min} (5·(p+1)) are needed, run a longer chain"
    )]
    TooFewSamples {
        what: String,
        n: usize,
        dim: usize,
        min: usize,
    },
    /// Too few distinct samples (a chain that barely moves) for a robust covariance.
    #[error(
        "{what}: only {distinct} distinct samples among {n} for {dim} parameters (at least {min}, 10·(p+1), are needed): the chain barely moves; run longer chains or use a better proposal (a smaller scale, or the posterior covariance) so more proposals are accepted"
    )]
    TooFewDistinct {
        what: String,
        n: usize,
        distinct: usize,
        dim: usize,
        min: usize,
    },
    /// The samples do not span all dimensions.
    #[error(
        "{what}: the covariance is singular ({detail}); check for constant or collinear parameters"
    )]
    SingularCovariance { what: String, detail: String },
    /// A prior kind the method cannot handle.
    #[error("prior of `{param}`: {why}")]
    UnsupportedPrior { param: String, why: String },
    /// An option value is out of range.
    #[error("option `{field}` = {value}: {fix}")]
    InvalidOption {
        field: String,
        value: String,
        fix: String,
    },
    /// The prior could not be built.
    #[error(transparent)]
    Prior(#[from] crate::prior::PriorError),
    /// A checkpoint cannot be read or written.
    #[error(transparent)]
    CheckpointFile(#[from] crate::data::checkpoint::CheckpointError),
    /// A readable checkpoint that belongs to another run.
    #[error("checkpoint `{path}`: {problem}")]
    Checkpoint {
        /// The checkpoint file.
        path: String,
        /// What does not match, and what to do.
        problem: String,
    },
}

impl EvidenceError {
    pub(crate) fn option(field: &str, value: impl std::fmt::Display, fix: &str) -> Self {
        EvidenceError::InvalidOption {
            field: field.to_string(),
            value: value.to_string(),
            fix: fix.to_string(),
        }
    }

    pub(crate) fn non_finite(what: impl Into<String>, value: f64, fix: &str) -> Self {
        EvidenceError::NonFinite {
            what: what.into(),
            value,
            fix: fix.to_string(),
        }
    }

    /// The context of a [`crate::linalg::LinalgError`], for `map_err`: the matrix's name and
    /// what to do about it.
    pub(crate) fn matrix<'a>(
        what: impl Into<String>,
        fix: &'a str,
    ) -> impl FnOnce(crate::linalg::LinalgError) -> Self + 'a {
        let what = what.into();
        move |source| EvidenceError::Matrix {
            what,
            source,
            fix: fix.to_string(),
        }
    }

    pub(crate) fn dimension(what: impl Into<String>, expected: usize, got: usize) -> Self {
        EvidenceError::Dimension {
            what: what.into(),
            expected,
            got,
        }
    }
}
