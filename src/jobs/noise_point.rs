//! Where a model's θ-dependent residual noise was evaluated ([`crate::jobs::own_noise`]).

use serde::{Deserialize, Serialize};

/// How the noise point of one (sub-)model was found.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct NoisePoint {
    /// The parameters that move the residual CSD.
    pub params: Vec<String>,
    /// The point the residual CSD is evaluated at (the model's full parameter vector).
    pub theta: Vec<f64>,
    /// Iterations (likelihoods built at a new point).
    pub iterations: usize,
    /// Whether the last iteration moved the MAP by less than [`NOISE_SHIFT_TOL`](crate::jobs::own_noise::NOISE_SHIFT_TOL) σ.
    pub converged: bool,
    /// How far the first point (the study's reference point) was from the first MAP, in σ of
    /// each noise parameter, by name.
    pub first_distance_sigma: Vec<(String, f64)>,
}

/// How [`NoisePoint::note`] begins.
const NOTE_START: &str = "the residual noise moves with ";
/// What it says, in parentheses, of an iteration that converged.
const CONVERGED: &str = "converged";

impl NoisePoint {
    /// [`NoisePoint::note`] for a fit, which corrects no evidence.
    pub fn fit_note(&self) -> String {
        let n = self.note();
        match n.find(", and the evidences") {
            Some(i) => n[..i].to_string(),
            None => n,
        }
    }

    /// Whether `note` is a [`NoisePoint::note`] (or [`NoisePoint::fit_note`]) of a point whose
    /// iteration converged: a fact about the method, listed with the run's notes. One that did
    /// not converge is a warning.
    pub fn is_converged_note(note: &str) -> bool {
        note.starts_with(NOTE_START) && note.contains(&format!("({CONVERGED};"))
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
            "{NOTE_START}{} (noise = \"model\" through the model's own dynamics): it is evaluated at this model's own MAP, iterated {} time{} ({}; the study's reference point was {} from it), and the evidences are corrected to the exact θ-dependent likelihood by importance weights",
            self.params
                .iter()
                .map(|p| format!("`{p}`"))
                .collect::<Vec<_>>()
                .join(", "),
            self.iterations,
            if self.iterations == 1 { "" } else { "s" },
            if self.converged {
                CONVERGED
            } else {
                "NOT converged"
            },
            far.join(", ")
        )
    }
}
