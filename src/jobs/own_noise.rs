//! A model whose residual noise depends on θ (`noise = "model"` with noise through the model's
//! own dynamics, ltp-model.md §8.4): the fixed-noise likelihood of each (sub-)model with its
//! noise evaluated at that model's own MAP, iterated until the MAP stops moving.
//!
//! The fast paths (relative binning, the exact Fisher matrix, the kernels) need a residual
//! CSD that does not move with θ. Evaluated at a point nobody chose — the truth, `[fit] start`
//! or the prior centre, shared by every sub-model of one model — it moved a two-mass study's
//! `ln B` by 13 nats. Evaluated where each model's own posterior is, the fixed-noise and the
//! exact likelihood agree to second order there; what is left is corrected by importance
//! weights over the model's posterior samples
//! ([`crate::likelihood::theta_noise::NoiseCorrection`]).

use super::analysis_error::AnalysisError;
use super::map_search::{MAP_MAX_ITER, map_search};
use crate::config::{ModelSpec, Study};
use crate::likelihood::theta_noise::noise_parameters;
use crate::likelihood::{Likelihood, NoiseSource, cramer_rao, fisher_exact, fisher_scoring};

/// Iterations of the noise point at most.
pub const MAX_NOISE_ITERATIONS: usize = 8;

/// The noise point has stopped moving when no free parameter's MAP moves by more than this
/// many of its Cramér–Rao σ between two iterations.
pub const NOISE_SHIFT_TOL: f64 = 0.01;

pub use super::noise_point::NoisePoint;

/// With `noise = "model"` and a model whose residual CSD moves with a free parameter of
/// `spec`: the exact (fixed-noise) likelihood with the noise at `spec`'s own MAP, iterated
/// (module docs), starting from `start` (a full parameter vector); `None` when the noise does
/// not depend on the free parameters (then the study's reference point is exact).
/// `reference` is the study's reference point of the model, `build` its exact likelihood with
/// the noise evaluated at a given point (`jobs::prepare::likelihood_at` on the job's data).
pub fn own_noise_likelihood(
    study: &Study,
    spec: &ModelSpec,
    start: &[f64],
    reference: Vec<f64>,
    build: &dyn Fn(&[f64]) -> Result<Likelihood, AnalysisError>,
) -> Result<Option<(Likelihood, NoisePoint)>, AnalysisError> {
    if study.analysis.noise != NoiseSource::Model {
        return Ok(None);
    }
    // the sub-model's fixed values, the study's reference point elsewhere
    let mut point = reference;
    for (i, v) in point.iter_mut().enumerate() {
        if !spec.free.contains(&i) {
            *v = spec.base[i];
        }
    }
    let mut lik = build(&point)?;
    let moving = noise_parameters(&lik, &point, &spec.free);
    if moving.is_empty() {
        return Ok(None);
    }
    let names = lik.model().param_names().to_vec();
    let mut from = start.to_vec();
    let mut first_distance_sigma = Vec::new();
    let mut converged = false;
    let mut iterations = 0;
    while iterations < MAX_NOISE_ITERATIONS {
        // the first search from every start of the study's multi-start MAP (a local maximum
        // would put the noise where the posterior is not); later ones from the last MAP
        let found = if iterations == 0 {
            map_search(&lik, &spec.free, &from, study.fit.map_starts)
                .map(|m| m.best().result.clone())
        } else {
            let tol = crate::model::map_tolerance(lik.model().as_ref());
            fisher_scoring(&lik, &from, &spec.free, tol, MAP_MAX_ITER)
        };
        let Ok(map) = found else {
            break;
        };
        let Some(sd) = cramer_rao(&fisher_exact(&lik, &map.theta, &spec.free)) else {
            break;
        };
        let dist: Vec<f64> = spec
            .free
            .iter()
            .zip(&sd)
            .map(|(&a, s)| (map.theta[a] - point[a]).abs() / s)
            .collect();
        if iterations == 0 {
            first_distance_sigma = spec
                .free
                .iter()
                .zip(&dist)
                .filter(|(a, _)| moving.contains(a))
                .map(|(&a, d)| (names[a].clone(), *d))
                .collect();
        }
        if dist.iter().all(|d| *d < NOISE_SHIFT_TOL) {
            converged = true;
            break;
        }
        point = map.theta.clone();
        from = map.theta;
        lik = build(&point)?;
        iterations += 1;
    }
    Ok(Some((
        lik,
        NoisePoint {
            params: moving.iter().map(|&a| names[a].clone()).collect(),
            theta: point,
            iterations,
            converged,
            first_distance_sigma,
        },
    )))
}
