//! The stability guard of every likelihood: where the model's system is unstable
//! ([`Model::is_stable`]) `ln L = −∞`, and the evaluation is counted. The frequency-domain
//! likelihood of an unstable loop is a number that describes no data: it has narrow spurious
//! peaks there (issue 23: a thruster pole below ≈ 0.05 Hz, which a MAP search found at
//! ρ_opt = 5), so samplers and searches must not see it.

use crate::model::Model;
use std::sync::atomic::{AtomicU64, Ordering};

/// Evaluations refused because the system was unstable. Shared by the threads that evaluate
/// one likelihood; a clone starts from the count so far.
#[derive(Debug, Default)]
pub struct UnstableCount(AtomicU64);

impl Clone for UnstableCount {
    fn clone(&self) -> Self {
        UnstableCount(AtomicU64::new(self.get()))
    }
}

impl UnstableCount {
    /// The evaluations refused so far.
    pub fn get(&self) -> u64 {
        self.0.load(Ordering::Relaxed)
    }

    /// Whether `model` may be evaluated at `theta`; counts the refusal when not.
    #[inline]
    pub(crate) fn admit(&self, model: &dyn Model, theta: &[f64]) -> bool {
        if model.is_stable(theta) {
            return true;
        }
        self.0.fetch_add(1, Ordering::Relaxed);
        false
    }
}
