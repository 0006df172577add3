//! Noise sources of the 1-D LTP and their exact two-channel output CSD (ltp-model.md §5).

use super::closed_loop::ClosedLoop;
use super::params::Masses;
use num_complex::Complex64;
use serde::{Deserialize, Serialize};

/// Independent Gaussian noise sources, as one-sided amplitude spectral densities (SI).
///
/// Defaults are the representative levels of ltp-model.md §5.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct NoiseModel {
    /// Readout noise ASD on o1 at high frequency (m/√Hz).
    pub readout_o1: f64,
    /// Readout noise ASD on o12 at high frequency (m/√Hz).
    pub readout_o12: f64,
    /// Corner of the readout low-frequency rise `[1 + (f_c/f)⁴]^{1/2}` (Hz); 0 disables it.
    pub readout_corner: f64,
    /// Thruster force noise on the spacecraft (N/√Hz).
    pub thruster_force: f64,
    /// Force-per-unit-mass noise on each test mass (m s⁻²/√Hz).
    pub tm_accel: f64,
    /// Corner of the optional TM-noise rise `[1 + (f_c/f)²]^{1/2}` (Hz); 0 disables it.
    pub tm_corner: f64,
}

impl Default for NoiseModel {
    fn default() -> Self {
        Self {
            readout_o1: 9e-12,
            readout_o12: 9e-12,
            readout_corner: 3e-3,
            thruster_force: 1e-7,
            tm_accel: 1e-14,
            tm_corner: 0.0,
        }
    }
}

impl NoiseModel {
    /// The first field that is negative or not finite, if any, with its name.
    pub fn invalid_field(&self) -> Option<(&'static str, f64)> {
        [
            ("readout_o1", self.readout_o1),
            ("readout_o12", self.readout_o12),
            ("readout_corner", self.readout_corner),
            ("thruster_force", self.thruster_force),
            ("tm_accel", self.tm_accel),
            ("tm_corner", self.tm_corner),
        ]
        .into_iter()
        .find(|(_, v)| !v.is_finite() || *v < 0.0)
    }

    /// A copy with every source ASD multiplied by `k` (PSDs by `k²`).
    pub fn scaled(&self, k: f64) -> Self {
        Self {
            readout_o1: self.readout_o1 * k,
            readout_o12: self.readout_o12 * k,
            thruster_force: self.thruster_force * k,
            tm_accel: self.tm_accel * k,
            ..*self
        }
    }

    /// One-sided 2×2 output CSD `S_o(f)` of `(o1, o12)` given the closed loop at `f`.
    ///
    /// # Formula
    /// `S_o = H_go S_g H_goᴴ + H_no S_n H_noᴴ`, with `S_n = diag(S_r1, S_r12)` and
    /// `S_g = [[S_a1 + S_asc, −S_a1], [−S_a1, S_a1 + S_a2]]`, `S_asc = S_F/m_sc²`: the TM1 force
    /// noise appears in both rows of `g = (g1 − g_sc, g2 − g1)`, hence the correlation.
    pub fn output_csd(&self, cl: &ClosedLoop, f: f64, m: &Masses) -> [[Complex64; 2]; 2] {
        let ro = if self.readout_corner > 0.0 {
            1.0 + (self.readout_corner / f).powi(4)
        } else {
            1.0
        };
        let tm = if self.tm_corner > 0.0 {
            1.0 + (self.tm_corner / f).powi(2)
        } else {
            1.0
        };
        let sn = [self.readout_o1.powi(2) * ro, self.readout_o12.powi(2) * ro];
        let sa = self.tm_accel.powi(2) * tm;
        let ssc = (self.thruster_force / m.msc).powi(2);
        let sg = [[sa + ssc, -sa], [-sa, 2.0 * sa]];
        let mut out = [[Complex64::new(0.0, 0.0); 2]; 2];
        for i in 0..2 {
            for j in 0..2 {
                let mut acc = Complex64::new(0.0, 0.0);
                for k in 0..2 {
                    acc += cl.h_no[i][k] * sn[k] * cl.h_no[j][k].conj();
                    for l in 0..2 {
                        acc += cl.h_go[i][k] * sg[k][l] * cl.h_go[j][l].conj();
                    }
                }
                out[i][j] = acc;
            }
        }
        // exact Hermitian symmetry despite rounding
        out[1][0] = out[0][1].conj();
        out[0][0].im = 0.0;
        out[1][1].im = 0.0;
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ltp::{BinConsts, Controllers, LtpParams};

    #[test]
    fn csd_is_hermitian_positive_definite_and_shaped_as_expected() {
        let m = Masses::default();
        let nm = NoiseModel::default();
        let ctrl = Controllers::default();
        for f in [1e-4, 1e-3, 1e-2, 0.1, 1.0] {
            let cl = ClosedLoop::at(&LtpParams::default(), &BinConsts::new(f, &ctrl, 0.0), &m);
            let s = nm.output_csd(&cl, f, &m);
            let det = s[0][0].re * s[1][1].re - s[0][1].norm_sqr();
            assert!(
                s[0][0].re > 0.0 && s[1][1].re > 0.0 && det > 0.0,
                "{f}: {s:?}"
            );
        }
        // ltp-model.md §5: o12 sees the readout almost unfiltered above a few mHz.
        let f = 0.5;
        let cl = ClosedLoop::at(&LtpParams::default(), &BinConsts::new(f, &ctrl, 0.0), &m);
        let s = nm.output_csd(&cl, f, &m);
        let r = s[1][1].re / (9e-12f64).powi(2);
        assert!((r - 1.0).abs() < 0.05, "S_o12/S_readout = {r}");
    }

    #[test]
    fn readout_only_noise_is_h_no_filtered() {
        let m = Masses::default();
        let nm = NoiseModel {
            thruster_force: 0.0,
            tm_accel: 0.0,
            readout_corner: 0.0,
            ..Default::default()
        };
        let f = 1e-3;
        let cl = ClosedLoop::at(
            &LtpParams::default(),
            &BinConsts::new(f, &Controllers::default(), 0.0),
            &m,
        );
        let s = nm.output_csd(&cl, f, &m);
        let want = (cl.h_no[0][0].norm_sqr() + cl.h_no[0][1].norm_sqr()) * 81e-24;
        assert!((s[0][0].re - want).abs() < 1e-12 * want);
    }
}
