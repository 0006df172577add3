//! [`LnB`]: a log Bayes factor with its Monte-Carlo error.

use serde::Serialize;

use super::laplace::LaplaceEstimate;
use super::method::Method;

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
