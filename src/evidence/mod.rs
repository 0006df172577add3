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
//! | Bridge sampling | [`bridge_sampling::bridge_sampling`] | posterior draws of the model's chains |
//!
//! Corrections relative to K14 and LTPDA (see `ltp-model.md` §9.2–9.4): the Laplace formulas use
//! `|H|^{−1/2}`, include `ln π(θ̂)`, and can add the Gaussian's mass inside the prior box; the
//! RJMCMC acceptance ratio is the full Carlin–Chib ratio with `L` (not `L²`) and the prior ratio
//! the right way up; MVE keeps repeated chain samples and never rotates the data.

pub mod bridge_sampling;
#[cfg(test)]
pub(crate) mod coverage_check;
mod error;
pub mod laplace;
pub mod linear_gaussian;
mod ln_b;
mod method;
pub mod mvn;
mod normal;
pub mod pareto;
pub mod rjmcmc;
pub mod robust;
pub mod schwarz;
pub mod tempering;

pub use error::EvidenceError;
pub use laplace::{
    LaplaceEstimate, LaplaceOptions, laplace_fisher, laplace_hessian, laplace_metropolis,
    numerical_hessian,
};
pub use linear_gaussian::{LinearGaussian, RandomPrior, RandomProblem, RandomSpec};
pub use ln_b::LnB;
pub use method::Method;
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
