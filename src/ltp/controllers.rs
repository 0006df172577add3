//! The representative drag-free and suspension controllers of ltp-model.md §4.
//!
//! The flight controllers are not public; these lead + integrator (+ roll-off) designs
//! reproduce the published loop bandwidths. They are fixed (not fitted), so their frequency
//! response is computed once per frequency bin.

use crate::lti::{LtiError, Rational};
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// The two loop controllers, `K = diag(C_df, C_sus)` in s⁻² (commanded acceleration per metre).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Controllers {
    /// Drag-free controller (reads o1, commands the thrusters).
    pub df: Rational,
    /// Electrostatic suspension controller (reads o12, commands the TM2 force).
    pub sus: Rational,
}

impl Default for Controllers {
    /// The coefficients tabulated in ltp-model.md §4.
    fn default() -> Self {
        Self {
            df: Rational::new(
                vec![0.62598132, 0.13766048, 0.00617819],
                vec![0.03166287, 0.47746483, 1.0, 0.0],
            )
            .expect("tabulated controller is valid"),
            sus: Rational::new(
                vec![6.25200305e-3, 1.37488728e-5, 6.17047969e-9],
                vec![39.78873577, 1.0, 0.0],
            )
            .expect("tabulated controller is valid"),
        }
    }
}

/// Lead + integrator (+ optional first-order roll-off) normalised to unity loop gain at `fc`
/// against a `1/s²` plant.
///
/// # Formula
/// `C(s) = K (1 + s/ωz)/(1 + s/ωp) · (1 + ωi/s) · 1/(1 + s/ωr)` with `ωc = 2π fc`,
/// `ωz = ωc/4`, `ωp = 4ωc`, `ωi = ωc/10`, `ωr = 2π fr`, and `K` such that `|C(iωc)| = ωc²`.
pub fn design_lead_integrator(fc: f64, roll_off: Option<f64>) -> Result<Rational, LtiError> {
    if !(fc.is_finite() && fc > 0.0) || roll_off.is_some_and(|r| !(r.is_finite() && r > 0.0)) {
        return Err(LtiError::Invalid(format!(
            "controller design needs positive finite frequencies (fc = {fc}, roll-off = {roll_off:?})"
        )));
    }
    let wc = 2.0 * PI * fc;
    let (wz, wp, wi) = (wc / 4.0, 4.0 * wc, wc / 10.0);
    // (1 + s/wz)(s + wi) / ((1 + s/wp) s)
    let lead = Rational::new(vec![1.0 / wz, 1.0], vec![1.0 / wp, 1.0])?;
    let integ = Rational::new(vec![1.0, wi], vec![1.0, 0.0])?;
    let mut c = lead.series(&integ);
    if let Some(fr) = roll_off {
        c = c.series(&Rational::new(vec![1.0], vec![1.0 / (2.0 * PI * fr), 1.0])?);
    }
    let k = wc * wc / c.eval_freq(fc).norm();
    let num: Vec<f64> = c.num().iter().map(|x| x * k).collect();
    Rational::new(num, c.den().to_vec())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn design_reproduces_tabulated_controllers() {
        let tab = Controllers::default();
        for (designed, tab) in [
            (design_lead_integrator(0.1, Some(2.0)).unwrap(), &tab.df),
            (design_lead_integrator(1e-3, None).unwrap(), &tab.sus),
        ] {
            for f in [1e-5, 1e-3, 0.05, 1.0] {
                let (a, b) = (designed.eval_freq(f), tab.eval_freq(f));
                // the smallest tabulated coefficient (0.00617819) has 6 significant figures,
                // which dominates at low f: relative agreement is limited to ~1e−6
                assert!((a - b).norm() < 2e-6 * b.norm(), "f = {f}: {a} vs {b}");
            }
        }
    }
}
