//! The target every sampler and evidence estimator works on.
//!
//! A [`LogDensity`] is a natural-log likelihood `ln L(θ)` together with a *normalised* prior
//! `π(θ)`. Analytic test problems and the LTP likelihood implement the same trait, so the
//! known-answer tests run through exactly the code the LTP study runs.
//!
//! Conventions: every log is natural; `ln L` is never χ² (ln L = −χ²/2 where a χ² exists);
//! the prior is a normalised density, so its volume is the Occam factor of every estimator.

use crate::prior::Prior;

/// A posterior density known up to the evidence: `ln p(θ | y) = ln L(θ) + ln π(θ) − ln Z`.
///
/// Implementations must be cheap to call and must not allocate in [`LogDensity::ln_likelihood`]
/// (it is the hot path of every sampler). They are shared between chains running on several
/// threads, hence `Sync`.
pub trait LogDensity: Sync {
    /// Number of parameters (the dimension of θ).
    fn dim(&self) -> usize {
        self.prior().dim()
    }

    /// Natural-log likelihood `ln L(θ)`, including every θ-independent constant the
    /// implementation documents. May return a non-finite value, which samplers treat as a
    /// rejection and count.
    fn ln_likelihood(&self, theta: &[f64]) -> f64;

    /// The normalised prior.
    fn prior(&self) -> &Prior;

    /// Names of the parameters, for tables and files.
    fn param_names(&self) -> Vec<String> {
        self.prior().names().to_vec()
    }

    /// `ln L(θ) + ln π(θ)`: the unnormalised log posterior. `−∞` outside the prior support
    /// (the likelihood is then not evaluated).
    fn ln_posterior(&self, theta: &[f64]) -> f64 {
        let lp = self.prior().ln_pdf(theta);
        if lp == f64::NEG_INFINITY {
            return f64::NEG_INFINITY;
        }
        lp + self.ln_likelihood(theta)
    }
}

impl<T: LogDensity + ?Sized> LogDensity for &T {
    fn dim(&self) -> usize {
        (**self).dim()
    }
    fn ln_likelihood(&self, theta: &[f64]) -> f64 {
        (**self).ln_likelihood(theta)
    }
    fn prior(&self) -> &Prior {
        (**self).prior()
    }
    fn param_names(&self) -> Vec<String> {
        (**self).param_names()
    }
}
