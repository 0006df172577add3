//! Running chains until they have converged, in place of a fixed length: after the burn-in,
//! every `every` iterations, the kept draws so far are checked, and the run ends once every
//! parameter has a total ESS of at least `min_ess` and a rank-normalised split-R̂ of at most
//! `max_rhat` ([`super::diagnostics`]), or at its `n_iter` iterations, whichever comes first.
//!
//! The rule is emcee's (check the autocorrelation time every so many steps, stop when the run
//! is long against it) with the diagnostics the run reports anyway, so a run that stops early
//! passes its own checks by construction. Asking at fixed multiples of `every` keeps the end
//! a function of the chains' states only: the same seed stops at the same iteration whatever
//! the threads, the block length or where the run was resumed. Stopping on a diagnostic is an
//! optional stopping rule; `tests.rs` measures what it does to the error bars
//! (`stopping_at_convergence_keeps_the_mean_s_error_bar`).

use super::chain::ChainState;
use super::diagnostics::{ess, split_rhat};
use super::error::SamplerError;

/// The convergence rule of a run that stops early ([`super::MetropolisHastings::until`]).
///
/// ```
/// use occam::sampler::Until;
/// let u = Until::new(400.0, 1.01, 100).unwrap();
/// assert_eq!((u.min_ess(), u.max_rhat(), u.every()), (400.0, 1.01, 100));
/// assert!(Until::new(400.0, 0.99, 100).is_err()); // R̂ is never below 1
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Until {
    min_ess: f64,
    max_rhat: f64,
    every: usize,
    at_least: usize,
}

impl Until {
    /// ESS at least `min_ess` (finite, ≥ 1) and R̂ at most `max_rhat` (finite, > 1) for
    /// every parameter, asked every `every` iterations (≥ 1).
    pub fn new(min_ess: f64, max_rhat: f64, every: usize) -> Result<Self, SamplerError> {
        let bad =
            |field: &'static str, problem: String| Err(SamplerError::Setting { field, problem });
        if !(min_ess.is_finite() && min_ess >= 1.0) {
            return bad(
                "until.ess",
                format!("must be a finite number ≥ 1 (got {min_ess}); 400 is usual"),
            );
        }
        if !(max_rhat.is_finite() && max_rhat > 1.0) {
            return bad(
                "until.rhat",
                format!(
                    "must be a finite number > 1 (got {max_rhat}): R̂ is 1 for chains that agree; 1.01 is usual"
                ),
            );
        }
        if every == 0 {
            return bad(
                "until.every",
                "must be ≥ 1 iteration (how often the chains are checked)".into(),
            );
        }
        Ok(Self {
            min_ess,
            max_rhat,
            every,
            at_least: 0,
        })
    }

    /// The same rule, asked first after `n` iterations and then every [`every`](Self::every):
    /// a run that has converged by `n` ends exactly there, with the draws a fixed run of `n`
    /// iterations gives, and one that has not goes on. `select`'s in-model chains use it, so
    /// that its configured length stays what a converged run does.
    ///
    /// ```
    /// use occam::sampler::Until;
    /// let u = Until::new(400.0, 1.01, 100).unwrap().at_least(12_000);
    /// assert_eq!(u.first_check(), 12_000);
    /// assert_eq!(Until::new(400.0, 1.01, 100).unwrap().first_check(), 100);
    /// ```
    pub fn at_least(mut self, n: usize) -> Self {
        self.at_least = n;
        self
    }

    /// The first iteration the rule is asked at: the `n` of [`at_least`](Self::at_least), or
    /// [`every`](Self::every) without one.
    pub fn first_check(&self) -> usize {
        if self.at_least == 0 {
            self.every
        } else {
            self.at_least
        }
    }

    /// The smallest total ESS per parameter.
    pub fn min_ess(&self) -> f64 {
        self.min_ess
    }

    /// The largest R̂ per parameter.
    pub fn max_rhat(&self) -> f64 {
        self.max_rhat
    }

    /// Iterations between checks.
    pub fn every(&self) -> usize {
        self.every
    }

    /// Whether chains whose kept draws of parameter `k` are `series(k)` (one vector per
    /// chain) meet the rule for all `dim` parameters. Fewer than 4 draws per chain, or any
    /// non-finite diagnostic, never do.
    pub fn met(&self, dim: usize, series: impl Fn(usize) -> Vec<Vec<f64>>) -> bool {
        (0..dim).all(|k| {
            let s = series(k);
            let refs: Vec<&[f64]> = s.iter().map(Vec::as_slice).collect();
            if refs.is_empty() || refs[0].len() < 4 {
                return false;
            }
            match (ess(&refs), split_rhat(&refs)) {
                (Ok(e), Ok(r)) => e >= self.min_ess && r <= self.max_rhat,
                _ => false,
            }
        })
    }

    /// [`Until::met`] on the kept draws of running chains.
    pub(crate) fn met_by(&self, states: &[ChainState]) -> bool {
        let Some(first) = states.first() else {
            return false;
        };
        self.met(first.dim(), |k| {
            states.iter().map(|s| s.kept_series(k)).collect()
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::chain_rng;
    use rand_distr::{Distribution, StandardNormal};

    fn ar1(seed: u64, chain: usize, n: usize, phi: f64) -> Vec<f64> {
        let mut rng = chain_rng(seed, chain);
        let s = (1.0 - phi * phi).sqrt();
        let mut x = 0.0;
        (0..n)
            .map(|_| {
                let z: f64 = StandardNormal.sample(&mut rng);
                x = phi * x + s * z;
                x
            })
            .collect()
    }

    #[test]
    fn the_rule_needs_enough_independent_draws_from_chains_that_agree() {
        let u = Until::new(400.0, 1.01, 100).unwrap();
        // four chains of white noise: ESS ≈ 4n, met from n ≈ 100 draws on
        let white = |n: usize| move |_: usize| (0..4).map(|c| ar1(1, c, n, 0.0)).collect();
        assert!(!u.met(2, white(50)));
        assert!(u.met(2, white(2000)));
        // strongly correlated draws (τ ≈ 39): 2000 per chain give ESS ≈ 200
        let slow = |_: usize| (0..4).map(|c| ar1(2, c, 2000, 0.95)).collect();
        assert!(!u.met(1, slow));
        // one chain elsewhere: R̂ far above 1.01, however many draws
        let apart = |_: usize| {
            (0..4)
                .map(|c| {
                    let shift = if c == 3 { 1.0 } else { 0.0 };
                    ar1(3, c, 4000, 0.0).iter().map(|x| x + shift).collect()
                })
                .collect()
        };
        assert!(!u.met(1, apart));
        // a chain that never moves, and too few draws to split
        let stuck = |_: usize| vec![vec![0.5; 1000]; 4];
        assert!(!u.met(1, stuck));
        assert!(!u.met(1, |_: usize| vec![vec![0.1, 0.2, 0.3]; 4]));
        // every parameter must meet it: one slow parameter holds the run
        let mixed = |k: usize| {
            let phi = if k == 1 { 0.95 } else { 0.0 };
            (0..4).map(|c| ar1(4 + k as u64, c, 2000, phi)).collect()
        };
        assert!(!u.met(2, mixed));
    }

    #[test]
    fn bad_settings_name_the_field() {
        for (e, r, n, field) in [
            (0.5, 1.01, 100, "until.ess"),
            (f64::NAN, 1.01, 100, "until.ess"),
            (400.0, 1.0, 100, "until.rhat"),
            (400.0, f64::INFINITY, 100, "until.rhat"),
            (400.0, 1.01, 0, "until.every"),
        ] {
            match Until::new(e, r, n) {
                Err(SamplerError::Setting { field: f, .. }) => assert_eq!(f, field),
                other => panic!("{e} {r} {n}: {other:?}"),
            }
        }
    }
}
