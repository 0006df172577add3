//! [`Method`]: which estimator produced a number.

use serde::Serialize;

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
