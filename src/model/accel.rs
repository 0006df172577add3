//! The acceleration-domain model of K14 §III.C (ltp-model.md §7): the differential acceleration
//! `a12` built from the read-outs and the commanded forces, whose residual is the external
//! differential force noise.
//!
//! ```text
//! a12 = [d²/dt² + ω2²] x12 + (ω2² − ω1²) x1 − Act2 g2 + Act1 g1           (K14 eqs. a12, a12+)
//! x1 = o1(t + τ_ifo),  x12 = o12(t + τ_ifo) − δ21 x1
//! Act_i(f) = A_i · 1/(1 + i f/f_oi) · e^{−i2πf τ_Ci}
//! ```
//!
//! Data channels `(o1, o12, g1, g2)` (read-outs and commanded forces per unit mass, the
//! telemetry the simulator writes), one residual channel `a12`. Parameters `w1sq, w2sq, a1, a2`
//! and, per the options, `f_o1, f_o2` (actuator poles, Hz) and `tau_c1, tau_c2` (actuator
//! delays, s): the asymmetric family of K14 eq. (a12+). Its nested members (symmetric
//! actuators, one shared pole, …) are `kind = "tied"` models over it (see
//! [`crate::model::tied`]) or sub-models with fixed values.
//!
//! # Conventions
//! * Read-out delay: the read-out lags the motion, `o(t) = x(t − τ_ifo)`, so `x̃ = e^{+i2πfτ_ifo} õ`
//!   (K14 writes `o(t − τ_ifo)`; only the relative delay of the o-terms and the force terms
//!   matters). The simulator's OMS delay `τ_o` is the same quantity with the same sign, and is
//!   the default of `tau_ifo`.
//! * `d²/dt²` is the exact `−(2πf)²` on the DFT of the read-outs (`derivative = "exact"`, the
//!   default): on noiseless data at the true parameters the residual is then zero to rounding
//!   (`tests/accel.rs`). `derivative = "fpsder"` uses instead the response of the five-point
//!   stencil with which LTPDA differentiates the read-outs in the time domain
//!   ([`crate::ltp::fpsder`]): the model then reproduces LTPDA's a12 exactly, including its
//!   error `(D_fps(f) + ω²)·x12`, which is not noise (10 % of the applied force at 0.9 Hz at
//!   fs = 10 Hz) and biases the actuator parameters unless the band stays below ≈ 0.1 Hz. The
//!   stencil's error is a known function of the data, so LTPDA's a12 corrected by it is the
//!   exact one (ltp-model.md §7.2 says to apply the stencil's response "to the model's d²/dt²
//!   term"; but that term acts on the measured read-outs, not on a prediction, so the response
//!   must be removed from the data, not added to the model).
//! * The pole has unity DC gain, `1/(1 + i f/f_o)`: K14's `f_o/(f − j f_o)` is a typo
//!   (ltp-model.md §7.1).

use super::bin::Bin;
use super::traits::Model;
pub use crate::ltp::accel_options::{AccelOptions, Derivative};
use crate::ltp::fpsder::fpsder_response;
use crate::prior::PriorKind;
use num_complex::{Complex, Complex64};
use num_dual::{Dual64, DualNum};
use std::f64::consts::PI;

/// The acceleration-domain model (see the module docs).
#[derive(Debug, Clone)]
pub struct AccelModel {
    name: String,
    opts: AccelOptions,
    names: Vec<String>,
    data: Vec<String>,
    res: Vec<String>,
    /// Indices of `f_o1`, `tau_c1` in θ (the `…2` parameter follows each).
    pole_at: Option<usize>,
    delay_at: Option<usize>,
}

/// The actuator factor `A · 1/(1 + i f/f_o) · e^{−i2πfτ}` (pole and delay optional), generic
/// over dual numbers.
#[inline]
pub fn actuator<T: DualNum<Primitive = f64> + Copy>(
    gain: T,
    pole: Option<T>,
    delay: Option<T>,
    f: f64,
) -> Complex<T> {
    let mut z = Complex::new(gain, T::zero());
    if let Some(fo) = pole {
        // 1/(1 + i u) = (1 − i u)/(1 + u²), u = f/f_o
        let u = fo.recip() * f;
        let d = (u * u + 1.0).recip();
        z *= Complex::new(d, -u * d);
    }
    if let Some(tau) = delay {
        let (s, c) = (tau * (2.0 * PI * f)).sin_cos();
        z *= Complex::new(c, -s);
    }
    z
}

impl AccelModel {
    /// The model called `name` with options `opts` (validate them first with
    /// [`AccelOptions::validate`]).
    pub fn new(name: &str, opts: AccelOptions) -> Self {
        let mut names: Vec<String> = ["w1sq", "w2sq", "a1", "a2"]
            .iter()
            .map(|s| s.to_string())
            .collect();
        let mut pole_at = None;
        let mut delay_at = None;
        if opts.pole {
            pole_at = Some(names.len());
            names.extend(["f_o1".to_string(), "f_o2".to_string()]);
        }
        if opts.delay {
            delay_at = Some(names.len());
            names.extend(["tau_c1".to_string(), "tau_c2".to_string()]);
        }
        let s = |v: &[&str]| v.iter().map(|x| x.to_string()).collect::<Vec<_>>();
        Self {
            name: name.into(),
            opts,
            names,
            data: s(&["o1", "o12", "g1", "g2"]),
            res: s(&["a12"]),
            pole_at,
            delay_at,
        }
    }

    /// The options.
    pub fn options(&self) -> &AccelOptions {
        &self.opts
    }

    /// Default priors: `w1sq, w2sq ∈ [−5e−6, 5e−6] s⁻²`, `a1, a2 ∈ [0.5, 1.5]`,
    /// `f_o1, f_o2 ∈ [0.1, 20] Hz`, `tau_c1, tau_c2 ∈ [0, 1] s`.
    pub fn default_priors(&self) -> Vec<(String, PriorKind)> {
        let u = |lo, hi| PriorKind::Uniform { lo, hi };
        self.names
            .iter()
            .map(|n| {
                let k = match n.as_str() {
                    "w1sq" | "w2sq" => u(-5e-6, 5e-6),
                    "a1" | "a2" => u(0.5, 1.5),
                    "f_o1" | "f_o2" => u(0.1, 20.0),
                    _ => u(0.0, 1.0),
                };
                (n.clone(), k)
            })
            .collect()
    }

    /// `Act_i(f; θ)` of test mass `i` (1 or 2).
    pub fn actuator_at<T: DualNum<Primitive = f64> + Copy>(
        &self,
        th: &[T],
        i: usize,
        f: f64,
    ) -> Complex<T> {
        let j = i - 1;
        actuator(
            th[2 + j],
            self.pole_at.map(|p| th[p + j]),
            self.delay_at.map(|p| th[p + j]),
            f,
        )
    }

    fn fill<T: DualNum<Primitive = f64> + Copy>(
        &self,
        th: &[T],
        bin: &Bin,
        out: &mut [Complex<T>],
    ) {
        let lift = |z: Complex64| Complex::new(T::from(z.re), T::from(z.im));
        let (phi, phi_d) = (lift(bin.consts[0]), lift(bin.consts[1]));
        let (w1, w2) = (th[0], th[1]);
        let m12 = phi_d + phi * w2;
        out[0] = m12 * T::from(-self.opts.d21) + phi * (w2 - w1);
        out[1] = m12;
        out[2] = self.actuator_at(th, 1, bin.f);
        out[3] = -self.actuator_at(th, 2, bin.f);
    }
}

impl Model for AccelModel {
    fn name(&self) -> &str {
        &self.name
    }

    fn param_names(&self) -> &[String] {
        &self.names
    }

    /// The actuator delays: causality (the check refuses less).
    fn physical_limits(&self) -> Vec<[Option<f64>; 2]> {
        self.names
            .iter()
            .map(|n| match n.as_str() {
                "tau_c1" | "tau_c2" => [Some(0.0), None],
                _ => [None, None],
            })
            .collect()
    }

    /// ω² in s⁻², actuator poles in Hz, actuator delays in s; the gains are dimensionless.
    fn param_units(&self) -> Vec<String> {
        self.names
            .iter()
            .map(|n| {
                match n.as_str() {
                    "w1sq" | "w2sq" => "s⁻²",
                    "f_o1" | "f_o2" => "Hz",
                    "tau_c1" | "tau_c2" => "s",
                    _ => "",
                }
                .to_string()
            })
            .collect()
    }

    fn data_channels(&self) -> &[String] {
        &self.data
    }

    fn residual_channels(&self) -> &[String] {
        &self.res
    }

    fn channel_units(&self) -> Vec<String> {
        self.data
            .iter()
            .map(|c| crate::model::ltp::ltp_channel_unit(c).into())
            .collect()
    }

    fn n_consts(&self) -> usize {
        2
    }

    /// `Φ = e^{+i2πfτ_ifo}` and `Φ·D(f)`, `D` the second derivative's response at `fs`.
    fn bin_consts(&self, f: f64, fs: f64, out: &mut [Complex64]) {
        let d = match self.opts.derivative {
            Derivative::Fpsder => fpsder_response(f, fs, self.opts.fpsder_m),
            Derivative::Exact => -(2.0 * PI * f).powi(2),
        };
        let phi = crate::lti::delay(-self.opts.tau_ifo, f);
        out[0] = phi;
        out[1] = phi * d;
    }

    fn coefficients(&self, theta: &[f64], bin: &Bin, out: &mut [Complex64]) {
        self.fill(theta, bin, out)
    }

    fn coefficients_dual(&self, theta: &[Dual64], bin: &Bin, out: &mut [Complex<Dual64>]) {
        self.fill(theta, bin, out)
    }

    fn check(&self, theta: &[f64]) -> Result<(), String> {
        for (n, &v) in self.names.iter().zip(theta) {
            let bad = match n.as_str() {
                "f_o1" | "f_o2" => !(v > 0.0),
                "tau_c1" | "tau_c2" => !(v >= 0.0),
                _ => !v.is_finite(),
            };
            if bad || !v.is_finite() {
                return Err(format!(
                    "{n} = {v}: poles must be > 0 Hz, delays ≥ 0 s, every value finite"
                ));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::coefficients_at;

    fn model(pole: bool, delay: bool) -> AccelModel {
        AccelModel::new(
            "a",
            AccelOptions {
                pole,
                delay,
                d21: 4e-4,
                tau_ifo: 0.3,
                ..Default::default()
            },
        )
    }

    #[test]
    fn parameters_follow_the_options() {
        assert_eq!(
            model(false, false).param_names(),
            ["w1sq", "w2sq", "a1", "a2"]
        );
        assert_eq!(
            model(true, true).param_units(),
            ["s⁻²", "s⁻²", "", "", "Hz", "Hz", "s", "s"]
        );
        assert_eq!(
            model(true, true).param_names(),
            [
                "w1sq", "w2sq", "a1", "a2", "f_o1", "f_o2", "tau_c1", "tau_c2"
            ]
        );
        assert_eq!(model(false, true).param_names()[4], "tau_c1");
    }

    /// The coefficients against the formula written out by hand at one frequency, with either
    /// second derivative.
    #[test]
    fn coefficients_are_the_written_formula() {
        let th = [-1.3e-6, -1.9e-6, 1.01, 0.98, 1.963, 2.5, 0.01, 0.02];
        let (f, fs) = (0.7, 10.0);
        let i = Complex64::i();
        let w = 2.0 * PI * f;
        for (derivative, d) in [
            (Derivative::Exact, -w * w),
            (
                Derivative::Fpsder,
                fpsder_response(f, fs, crate::ltp::fpsder::FPSDER_M),
            ),
        ] {
            let m = AccelModel::new(
                "a",
                AccelOptions {
                    derivative,
                    ..model(true, true).opts
                },
            );
            let c = coefficients_at(&m, &th, f, fs);
            let phi = (i * w * 0.3).exp();
            let act = |a: f64, fo: f64, tau: f64| a / (1.0 + i * f / fo) * (-i * w * tau).exp();
            let want = [
                phi * (-4e-4 * (d + th[1]) + (th[1] - th[0])),
                phi * (d + th[1]),
                act(1.01, 1.963, 0.01),
                -act(0.98, 2.5, 0.02),
            ];
            for (g, w) in c.iter().zip(want) {
                assert!(
                    (g - w).norm() <= 1e-12 * w.norm(),
                    "{derivative:?}: {g} vs {w}"
                );
            }
        }
    }

    /// Dual derivatives equal central finite differences of the f64 coefficients.
    #[test]
    fn dual_derivatives_match_finite_differences() {
        let m = model(true, true);
        let th = [-1.3e-6, -1.9e-6, 1.01, 0.98, 1.963, 2.5, 0.01, 0.02];
        let (f, fs) = (0.4, 10.0);
        let mut consts = [Complex64::new(0.0, 0.0); 2];
        m.bin_consts(f, fs, &mut consts);
        let bin = Bin {
            f,
            fs,
            consts: &consts,
        };
        for a in 0..th.len() {
            let mut td: Vec<Dual64> = th.iter().map(|&x| Dual64::from(x)).collect();
            td[a] = Dual64::from(th[a]).derivative();
            let mut out = [Complex::new(Dual64::from(0.0), Dual64::from(0.0)); 4];
            m.coefficients_dual(&td, &bin, &mut out);
            // the stiffnesses are tiny beside the other terms: an absolute step avoids cancellation
            let h = (1e-6 * th[a].abs()).max(1e-7);
            let (mut p, mut q) = (th, th);
            p[a] += h;
            q[a] -= h;
            let (cp, cq) = (
                coefficients_at(&m, &p, f, fs),
                coefficients_at(&m, &q, f, fs),
            );
            for c in 0..4 {
                let fd = (cp[c] - cq[c]) / (2.0 * h);
                let an = Complex64::new(out[c].re.eps, out[c].im.eps);
                assert!(
                    (fd - an).norm() <= 1e-6 * an.norm().max(1e-12 * cp[c].norm()),
                    "param {a} coef {c}: {an} vs {fd}"
                );
            }
        }
    }

    #[test]
    fn check_refuses_unphysical_actuators() {
        let m = model(true, true);
        let ok = [-1.3e-6, -1.9e-6, 1.0, 1.0, 2.0, 2.0, 0.0, 0.0];
        assert!(m.check(&ok).is_ok());
        let mut bad = ok;
        bad[5] = 0.0;
        assert!(m.check(&bad).unwrap_err().contains("f_o2"));
        let mut bad = ok;
        bad[6] = -0.1;
        assert!(m.check(&bad).unwrap_err().contains("tau_c1"));
    }
}
