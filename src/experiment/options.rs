//! The simulation settings the simulator reads (a study file writes them in `[simulation]`;
//! [`crate::config`] re-exports them under their old names).

use serde::{Deserialize, Serialize};

/// How the data are generated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Method {
    /// From the continuous-time `H_io` on the DFT grid (exact for the fit model).
    #[default]
    Frequency,
    /// Time-domain simulation of the discretised loop (ZOH plant, Tustin controllers).
    Time,
}

/// How the coloured noise is synthesised.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum NoiseSynthesis {
    /// Circular: the DFT of the series has exactly the model CSD.
    #[default]
    Circular,
    /// Synthesised on a 4× longer grid and cropped: not circular, like real data.
    Realistic,
    /// No noise at all (noiseless templates, for tests and SNR studies).
    None,
}

/// A resolved true actuator of one test mass: the force applied per unit mass is
/// `Act(f)·g` for the commanded `g` (m s⁻²), with `Act(f) = gain · 1/(1 + i f/f_o) · e^{−i2πfτ}`
/// (e^{−2πift} Fourier convention, unity-DC-gain pole when `pole` is set).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Actuator {
    pub gain: f64,
    /// Pole frequency `f_o` (Hz), if any.
    pub pole: Option<f64>,
    /// Delay τ (s).
    pub delay: f64,
}

impl Actuator {
    /// `Act(f)`, the applied force per unit commanded force at `f` (Hz).
    ///
    /// ```
    /// use occam::config::Actuator;
    /// let a = Actuator { gain: 1.08, pole: Some(2.0), delay: 0.0 };
    /// let r = a.response(2.0); // at the pole: gain/(1 + i)
    /// assert!((r.re - 0.54).abs() < 1e-15 && (r.im + 0.54).abs() < 1e-15);
    /// ```
    pub fn response(&self, f: f64) -> num_complex::Complex64 {
        match self.shape(f) {
            Some(r) => r * self.gain,
            None => num_complex::Complex64::new(self.gain, 0.0),
        }
    }

    /// `Act(f)/gain`: the pole and delay factors, or `None` for a flat actuator (no pole, no
    /// delay), so that callers can keep the arithmetic of the flat loop exactly.
    pub fn shape(&self, f: f64) -> Option<num_complex::Complex64> {
        if self.pole.is_none() && self.delay == 0.0 {
            return None;
        }
        Some(crate::model::accel::actuator(
            1.0,
            self.pole,
            (self.delay != 0.0).then_some(self.delay),
            f,
        ))
    }
}

/// The true thruster response of a simulation: `response = "delay"` with `value` = τ_df (s),
/// or `"pole"` with `value` = f_df (Hz).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TruthThruster {
    pub response: crate::model::ThrusterResponse,
    pub value: f64,
}

/// Largest injection amplitude (m on `x1`, `x12`; m s⁻² on `f1`, `f2`, `fsc`), after
/// `amplitude_scale`: 1e-2, above the 4 mm gap around a test mass and ~10⁷ × LPF's force
/// injections. Beyond it ρ² and ln L overflow (`amplitude_scale = 1e300` gave ρ = NaN).
pub const MAX_AMPLITUDE: f64 = 1e-2;
