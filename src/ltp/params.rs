//! The seven LTP parameters and the masses.

use serde::{Deserialize, Serialize};

/// Number of parameters of the full closed-loop model.
pub const N_PARAMS: usize = 7;

/// Parameter names in the canonical order used by every array `θ` of the LTP model:
/// `ω1²`, `ω2²` (s⁻²), `Δt1`, `Δt2` (s), `A_df`, `A_sus` (dimensionless), `δ21` (dimensionless).
pub const PARAM_NAMES: [&str; N_PARAMS] = ["w1sq", "w2sq", "dt1", "dt2", "a_df", "a_sus", "d21"];

/// The seven physical parameters of the closed loop (ltp-model.md §3.2).
///
/// Stiffnesses follow the physical convention `ω² < 0` (negative stiffness). The defaults are
/// the paper's Table I truth.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LtpParams {
    /// ω1², stiffness of TM1 to the spacecraft (s⁻²).
    pub w1sq: f64,
    /// ω2², stiffness of TM2 to the spacecraft (s⁻²).
    pub w2sq: f64,
    /// Δt1, guidance delay on the x1 injection (s).
    pub dt1: f64,
    /// Δt2, guidance delay on the x12 injection (s).
    pub dt2: f64,
    /// A_df, thruster (drag-free) actuation gain.
    pub a_df: f64,
    /// A_sus, capacitive (suspension) actuation gain on TM2.
    pub a_sus: f64,
    /// δ21, interferometer cross-talk from x1 into o12.
    pub d21: f64,
}

impl Default for LtpParams {
    fn default() -> Self {
        Self {
            w1sq: -1.3e-6,
            w2sq: -1.9e-6,
            dt1: 0.2,
            dt2: 0.2,
            a_df: 0.82,
            a_sus: 1.08,
            d21: 4e-4,
        }
    }
}

impl LtpParams {
    /// The parameters as an array in [`PARAM_NAMES`] order.
    pub fn to_array(&self) -> [f64; N_PARAMS] {
        [
            self.w1sq, self.w2sq, self.dt1, self.dt2, self.a_df, self.a_sus, self.d21,
        ]
    }

    /// Inverse of [`LtpParams::to_array`].
    pub fn from_array(a: &[f64; N_PARAMS]) -> Self {
        Self {
            w1sq: a[0],
            w2sq: a[1],
            dt1: a[2],
            dt2: a[3],
            a_df: a[4],
            a_sus: a[5],
            d21: a[6],
        }
    }

    /// The first non-finite parameter, if any, by name.
    pub fn non_finite(&self) -> Option<&'static str> {
        self.to_array()
            .iter()
            .zip(PARAM_NAMES)
            .find(|(v, _)| !v.is_finite())
            .map(|(_, n)| n)
    }
}

/// Masses of the three bodies (kg), ltp-model.md §1.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Masses {
    /// TM1 mass.
    pub m1: f64,
    /// TM2 mass.
    pub m2: f64,
    /// Spacecraft mass.
    pub msc: f64,
}

impl Default for Masses {
    fn default() -> Self {
        Self {
            m1: 1.96,
            m2: 1.96,
            msc: 422.7,
        }
    }
}
