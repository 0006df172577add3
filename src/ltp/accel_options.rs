//! The options of the acceleration-domain model (K14 §III.C, ltp-model.md §7): which actuator
//! dynamics it has and how it differentiates the read-outs. They live beside the physics that
//! reads them ([`super::a12`]); the model (`crate::model::accel`) re-exports them.

use super::fpsder::FPSDER_M;
use serde::{Deserialize, Serialize};

/// How the model differentiates the read-outs twice.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Derivative {
    /// The exact `−(2πf)²` (the default: the residual at the truth is zero).
    #[default]
    Exact,
    /// LTPDA's five-point stencil (its response `fpsder_response`), to reproduce LTPDA's a12
    /// with its error.
    Fpsder,
}

/// Options of the acceleration-domain model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct AccelOptions {
    /// Actuators with a single real pole (parameters `f_o1`, `f_o2`).
    pub pole: bool,
    /// Actuators with a delay (parameters `tau_c1`, `tau_c2`).
    pub delay: bool,
    /// The second derivative's response.
    pub derivative: Derivative,
    /// The stencil coefficient of `derivative = "fpsder"` (LTPDA's default 2/7).
    pub fpsder_m: f64,
    /// The known cross-talk δ21 of `o12` (x12 = o12 − δ21 o1).
    pub d21: f64,
    /// The read-out delay τ_ifo (s), `o(t) = x(t − τ_ifo)`.
    pub tau_ifo: f64,
}

impl Default for AccelOptions {
    fn default() -> Self {
        Self {
            pole: true,
            delay: false,
            derivative: Derivative::Exact,
            fpsder_m: FPSDER_M,
            d21: 0.0,
            tau_ifo: 0.0,
        }
    }
}

impl AccelOptions {
    /// Errors for non-finite or unphysical options, naming the key.
    pub fn validate(&self) -> Result<(), String> {
        if !self.fpsder_m.is_finite() {
            return Err(format!("fpsder_m must be finite (got {})", self.fpsder_m));
        }
        if !self.d21.is_finite() {
            return Err(format!("d21 must be finite (got {})", self.d21));
        }
        if !(self.tau_ifo.is_finite() && self.tau_ifo >= 0.0) {
            return Err(format!(
                "tau_ifo is a delay: it must be finite and ≥ 0 s (got {})",
                self.tau_ifo
            ));
        }
        Ok(())
    }
}
