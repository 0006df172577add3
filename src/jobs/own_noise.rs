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

use super::prepare::{AnalysisError, MAP_MAX_ITER, likelihood_at, map_search, reference_point};
use crate::config::{ModelSpec, Study};
use crate::data::dataset::Dataset;
use crate::likelihood::theta_noise::noise_parameters;
use crate::likelihood::{Likelihood, NoiseSource, cramer_rao, fisher_exact, fisher_scoring};
use serde::{Deserialize, Serialize};

/// Iterations of the noise point at most.
pub const MAX_NOISE_ITERATIONS: usize = 8;

/// The noise point has stopped moving when no free parameter's MAP moves by more than this
/// many of its Cramér–Rao σ between two iterations.
pub const NOISE_SHIFT_TOL: f64 = 0.01;

/// How the noise point of one (sub-)model was found.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct NoisePoint {
    /// The parameters that move the residual CSD.
    pub params: Vec<String>,
    /// The point the residual CSD is evaluated at (the model's full parameter vector).
    pub theta: Vec<f64>,
    /// Iterations (likelihoods built at a new point).
    pub iterations: usize,
    /// Whether the last iteration moved the MAP by less than [`NOISE_SHIFT_TOL`] σ.
    pub converged: bool,
    /// How far the first point (the study's reference point) was from the first MAP, in σ of
    /// each noise parameter, by name.
    pub first_distance_sigma: Vec<(String, f64)>,
}

impl NoisePoint {
    /// [`NoisePoint::note`] for a fit, which corrects no evidence.
    pub fn fit_note(&self) -> String {
        let n = self.note();
        match n.find(", and the evidences") {
            Some(i) => n[..i].to_string(),
            None => n,
        }
    }

    /// The line that says what was done, naming the noise parameters and how far the study's
    /// reference point was from the MAP.
    pub fn note(&self) -> String {
        let far: Vec<String> = self
            .first_distance_sigma
            .iter()
            .map(|(n, s)| format!("`{n}` {s:.1}σ"))
            .collect();
        format!(
            "the residual noise moves with {} (noise = \"model\" through the model's own dynamics): it is evaluated at this model's own MAP, iterated {} time{} ({}; the study's reference point was {} from it), and the evidences are corrected to the exact θ-dependent likelihood by importance weights",
            self.params
                .iter()
                .map(|p| format!("`{p}`"))
                .collect::<Vec<_>>()
                .join(", "),
            self.iterations,
            if self.iterations == 1 { "" } else { "s" },
            if self.converged {
                "converged"
            } else {
                "NOT converged"
            },
            far.join(", ")
        )
    }
}

/// With `noise = "model"` and a model whose residual CSD moves with a free parameter of
/// `spec`: the exact (fixed-noise) likelihood with the noise at `spec`'s own MAP, iterated
/// (module docs), starting from `start` (a full parameter vector); `None` when the noise does
/// not depend on the free parameters (then the study's reference point is exact).
pub fn own_noise_likelihood(
    study: &Study,
    spec: &ModelSpec,
    dataset: &Dataset,
    start: &[f64],
) -> Result<Option<(Likelihood, NoisePoint)>, AnalysisError> {
    if study.analysis.noise != NoiseSource::Model {
        return Ok(None);
    }
    let mi = spec.model;
    // the sub-model's fixed values, the study's reference point elsewhere
    let mut point = reference_point(study, mi);
    for (i, v) in point.iter_mut().enumerate() {
        if !spec.free.contains(&i) {
            *v = spec.base[i];
        }
    }
    let mut lik = likelihood_at(study, mi, dataset, &point)?;
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
        lik = likelihood_at(study, mi, dataset, &point)?;
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
