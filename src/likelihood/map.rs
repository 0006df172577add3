//! Maximum-likelihood / MAP search for any model by Fisher scoring (Gauss–Newton).
//!
//! The template is smooth and the posterior close to Gaussian, so Newton steps with the
//! Fisher matrix as the Hessian converge in a few iterations from anywhere the linearisation
//! holds; a backtracking line search on the exact `ln L + ln π` keeps every step an ascent,
//! and steps are clipped to the prior box. Nelder–Mead ([`crate::sampler::find_map`]) is the
//! derivative-free alternative for other models.

use super::exact::Likelihood;
use super::fisher::gradient_and_fisher;
use crate::density::LogDensity;

/// Result of [`fisher_scoring`].
#[derive(Debug, Clone, PartialEq)]
pub struct ScoringResult {
    /// The maximum found (full parameter vector; fixed parameters unchanged).
    pub theta: Vec<f64>,
    /// `ln L + ln π` there.
    pub ln_posterior: f64,
    pub iterations: usize,
    /// Whether the last Newton step was below `tol` standard deviations in every parameter.
    pub converged: bool,
}

/// Errors of the MAP search.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum MapError {
    #[error("MAP search: the start point is outside the prior (parameter `{0}`)")]
    StartOutsidePrior(String),
    #[error(
        "MAP search: the Fisher matrix is singular at the current point: the data do not constrain some of {0:?}; fix those parameters or add experiments"
    )]
    Singular(Vec<String>),
}

/// Fisher scoring over the parameters `free`, from `start`, until every Newton step is below
/// `tol` (in units of the Cramér–Rao σ) or `max_iter` iterations. Steps are clipped to the
/// prior box, so the result is the MAP, possibly on a bound.
pub fn fisher_scoring(
    lik: &Likelihood,
    start: &[f64],
    free: &[usize],
    tol: f64,
    max_iter: usize,
) -> Result<ScoringResult, MapError> {
    scoring(lik, start, free, tol, max_iter, true)
}

/// As [`fisher_scoring`] but without the prior box: the maximum of `ln L` (plus the prior's
/// Gaussian terms) where the likelihood is defined beyond the box, e.g. at negative delays.
/// This is the expansion point of the box-corrected Laplace estimate (ltp-model.md §9.3).
pub fn fisher_scoring_unbounded(
    lik: &Likelihood,
    start: &[f64],
    free: &[usize],
    tol: f64,
    max_iter: usize,
) -> Result<ScoringResult, MapError> {
    scoring(lik, start, free, tol, max_iter, false)
}

fn scoring(
    lik: &Likelihood,
    start: &[f64],
    free: &[usize],
    tol: f64,
    max_iter: usize,
    bounded: bool,
) -> Result<ScoringResult, MapError> {
    let names = lik.param_names();
    let bounds: Vec<(f64, f64)> = if bounded {
        lik.prior().bounds()
    } else {
        vec![(f64::NEG_INFINITY, f64::INFINITY); start.len()]
    };
    let post = |th: &[f64]| {
        if bounded {
            lik.ln_posterior(th)
        } else {
            lik.ln_likelihood_full(th)
                + crate::evidence::laplace::ln_prior_extended(lik.prior(), th).unwrap_or(f64::NAN)
        }
    };
    let mut th = start.to_vec();
    let mut lp = post(&th);
    if lp == f64::NEG_INFINITY || lp.is_nan() {
        let bad = (0..start.len())
            .find(|&i| !(bounds[i].0..=bounds[i].1).contains(&th[i]))
            .unwrap_or(0);
        return Err(MapError::StartOutsidePrior(names[bad].clone()));
    }
    let mut converged = false;
    let mut it = 0;
    while it < max_iter {
        it += 1;
        let (g, f) = gradient_and_fisher(lik, &th, free);
        let chol = f
            .clone()
            .cholesky()
            .ok_or_else(|| MapError::Singular(free.iter().map(|&i| names[i].clone()).collect()))?;
        let step = chol.solve(&nalgebra::DVector::from_vec(g));
        let cov = chol.inverse();
        let small = (0..free.len()).all(|i| step[i].abs() <= tol * cov[(i, i)].sqrt());
        // backtracking: halve until ln posterior increases (or the step is negligible)
        let mut t = 1.0;
        let mut accepted = false;
        for _ in 0..40 {
            let mut cand = th.clone();
            for (i, &a) in free.iter().enumerate() {
                cand[a] = (th[a] + t * step[i]).clamp(bounds[a].0, bounds[a].1);
            }
            let lc = post(&cand);
            if lc >= lp {
                th = cand;
                lp = lc;
                accepted = true;
                break;
            }
            t *= 0.5;
        }
        if small || !accepted {
            converged = small;
            break;
        }
    }
    Ok(ScoringResult {
        theta: th,
        ln_posterior: lp,
        iterations: it,
        converged,
    })
}
