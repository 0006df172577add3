//! The built-in LTP closed-loop model: `r = o − H_io(θ) i` (ltp-model.md §3.2), with the
//! fast per-bin kernel of wave 1 and optional extra factors on the drag-free actuation path.
//!
//! Data channels `(o1, o12, i1, i12)`, residual channels `(o1, o12)`, coefficients
//! `M = [I | −H_io(f; θ)]`. Parameters: the seven of K14 (`w1sq, w2sq, dt1, dt2, a_df, a_sus,
//! d21`) and, with a thruster response, one more:
//!
//! * `thruster = "delay"`: `A_df → A_df e^{−i2πf τ_df}` (parameter `tau_df`, s);
//! * `thruster = "pole"`: `A_df → A_df / (1 + i f/f_df)` (parameter `f_df`, Hz; unity DC
//!   gain, the e^{−i2πft} convention of ltp-model.md §7.1).
//!
//! These are the two thruster-response models of the Bayes-factor-against-SNR study (K14 §IV.A,
//! ltp-model.md §10 item 8).
//!
//! # Continuous or discrete loop response (`response`)
//!
//! * `response = "continuous"` (the default): `H_io` of the continuous loop
//!   ([`h_io_matrix`](crate::ltp::h_io_matrix)), the model of K14 and of data simulated in the
//!   frequency domain.
//! * `response = "discrete"`: the exact `H_io` of the loop discretised at the data's sample
//!   rate (the bin's `fs`): plant by zero-order hold, controllers by Tustin, OMS delay in whole
//!   samples ([`h_io_discrete`](crate::ltp::h_io_discrete)); the loop that
//!   [`DiscreteLoop::simulate`](crate::ltp::timedomain::DiscreteLoop::simulate) runs, i.e. the
//!   model for data from `[simulation] method = "time"` and for a real digital loop. An OMS
//!   delay that is not a whole number of samples is applied as a fractional delay.
//!
//! The two differ mainly by the hold: to first order the discrete loop is the continuous one
//! with an extra in-loop delay `T/2 = 1/(2fs)`. At fs = 10 Hz (K14 Table I) `|H_disc/H_cont − 1|`
//! is ≲ 4e−4 below 3 mHz, 3e−3 on `H_io22` at 10 mHz, 4e−2 at 0.1 Hz and 0.3 at 1 Hz
//! (table in [`timedomain`](crate::ltp::timedomain)); it shrinks like `1/fs`. Per-bin SNRs of
//! the K14 injections are large enough that fitting discretely sampled data with the continuous
//! model biases Δt2, A_sus and Δt1 by many σ (137σ, 46σ, −9.6σ at 10 Hz): use `discrete` for
//! time-domain data, `continuous` only for data generated from the continuous response. Both
//! have a fast kernel; [`Model::check`] tests the stability of the continuous loop (the discrete loop's
//! stability depends on `fs`, which `check` does not know).

use super::bin::{Bin, BinBlock};
use super::traits::{BlockKernel, Model, coefficients_batch_generic, residual_power_generic};
use crate::hermitian;
use crate::lti::delay;
use crate::ltp::hurwitz::{Actuation, LoopPolynomial};
use crate::ltp::{
    BinConsts, Controllers, DiscreteBinConsts, DiscreteControllers, DiscreteLoopKernel, LoopKernel,
    LtpParams, Masses, N_DISCRETE_CONSTS, N_PARAMS, PARAM_NAMES, check_stable,
};
use crate::prior::PriorKind;
use num_complex::{Complex, Complex64};
use num_dual::{Dual64, DualNum};
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// How often the guidance-delay phasors are recomputed exactly in the fast kernel.
pub const PHASOR_RESEED: usize = 256;

/// An extra factor on the drag-free (thruster) actuation path.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum ThrusterResponse {
    /// None: `A_df` alone (the 7-parameter model of K14).
    #[default]
    None,
    /// A pure delay `e^{−i2πf τ_df}`.
    Delay,
    /// A single real pole `1/(1 + i f/f_df)`.
    Pole,
}

impl ThrusterResponse {
    /// The extra parameter's name, if any.
    pub fn param(&self) -> Option<&'static str> {
        match self {
            ThrusterResponse::None => None,
            ThrusterResponse::Delay => Some("tau_df"),
            ThrusterResponse::Pole => Some("f_df"),
        }
    }

    /// `R(f)` at parameter value `x`, generic over dual numbers.
    #[inline]
    pub fn factor<T: DualNum<Primitive = f64> + Copy>(&self, x: T, f: f64) -> Complex<T> {
        match self {
            ThrusterResponse::None => Complex::new(T::one(), T::zero()),
            ThrusterResponse::Delay => {
                let (s, c) = (x * (2.0 * PI * f)).sin_cos();
                Complex::new(c, -s)
            }
            ThrusterResponse::Pole => {
                // 1/(1 + i f/f0) = (1 − i u)/(1 + u²), u = f/f0
                let u = x.recip() * f;
                let d = (u * u + 1.0).recip();
                Complex::new(d, -u * d)
            }
        }
    }
}

/// Which loop response the model uses (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum LoopResponse {
    /// The continuous loop (K14).
    #[default]
    Continuous,
    /// The loop discretised at the data's sample rate: ZOH plant, Tustin controllers.
    Discrete,
}

/// Options of the built-in closed-loop model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LtpModelOptions {
    /// Masses of the three bodies.
    pub masses: Masses,
    /// Fixed OMS delay τ_o (s).
    pub oms_delay: f64,
    /// Extra factor on the drag-free actuation.
    pub thruster: ThrusterResponse,
    /// Continuous or discrete-time loop response.
    pub response: LoopResponse,
}

impl Default for LtpModelOptions {
    fn default() -> Self {
        Self {
            masses: Masses::default(),
            oms_delay: 0.0,
            thruster: ThrusterResponse::None,
            response: LoopResponse::Continuous,
        }
    }
}

/// The LTP closed loop as a [`Model`].
#[derive(Debug, Clone)]
pub struct LtpModel {
    name: String,
    opts: LtpModelOptions,
    ctrl: Controllers,
    names: Vec<String>,
    data: Vec<String>,
    res: Vec<String>,
    /// The loop's characteristic polynomial (controllers, OMS delay), for the stability test.
    poly: LoopPolynomial,
}

/// Constants per bin: `C_df, C_sus, E, E·C_df, E·C_sus` (continuous) or
/// [`DiscreteBinConsts::to_array`] (discrete).
const N_CONSTS: usize = 5;
const _: () = assert!(N_DISCRETE_CONSTS <= N_CONSTS);

impl LtpModel {
    /// The closed loop with the §4 controllers.
    pub fn new(name: &str, opts: LtpModelOptions) -> Self {
        let mut names: Vec<String> = PARAM_NAMES.iter().map(|s| s.to_string()).collect();
        if let Some(p) = opts.thruster.param() {
            names.push(p.to_string());
        }
        let s = |v: &[&str]| v.iter().map(|x| x.to_string()).collect::<Vec<_>>();
        let ctrl = Controllers::default();
        let poly = LoopPolynomial::new(&ctrl, &opts.masses, opts.oms_delay, Default::default());
        Self {
            name: name.to_string(),
            opts,
            ctrl,
            poly,
            names,
            data: s(&["o1", "o12", "i1", "i12"]),
            res: s(&["o1", "o12"]),
        }
    }

    /// The options.
    pub fn options(&self) -> &LtpModelOptions {
        &self.opts
    }

    /// The thruster response at θ as a loop actuation (none without a thruster parameter).
    fn thruster_actuation(&self, theta: &[f64]) -> Actuation {
        let x = theta.get(N_PARAMS).copied().unwrap_or(f64::NAN);
        match self.opts.thruster {
            ThrusterResponse::None => Actuation::default(),
            ThrusterResponse::Delay => Actuation {
                pole: None,
                delay: x,
            },
            ThrusterResponse::Pole => Actuation {
                pole: Some(x),
                delay: 0.0,
            },
        }
    }

    /// Whether this is the plain continuous loop (no thruster response), the one the prepared
    /// kernels of `ltp_kernel` implement; every other variant takes the generic paths.
    fn is_plain_continuous(&self) -> bool {
        self.opts.thruster == ThrusterResponse::None
            && self.opts.response == LoopResponse::Continuous
    }

    /// The default prior of every parameter: uniform boxes `w1sq, w2sq ∈ [−5e−6, 5e−6] s⁻²`,
    /// `dt1, dt2 ∈ [0, 1] s`, `a_df, a_sus ∈ [0.5, 1.5]`, `d21 ∈ [−1e−3, 1e−3]`, `tau_df ∈
    /// [0, 1] s`, `f_df ∈ [0.01, 10] Hz`.
    pub fn default_priors(&self) -> Vec<(String, PriorKind)> {
        let u = |lo, hi| PriorKind::Uniform { lo, hi };
        self.names
            .iter()
            .map(|n| {
                let k = match n.as_str() {
                    "w1sq" | "w2sq" => u(-5e-6, 5e-6),
                    "dt1" | "dt2" | "tau_df" => u(0.0, 1.0),
                    "a_df" | "a_sus" => u(0.5, 1.5),
                    "d21" => u(-1e-3, 1e-3),
                    _ => u(0.01, 10.0),
                };
                (n.clone(), k)
            })
            .collect()
    }

    fn bin_consts_struct(&self, bin: &Bin) -> BinConsts {
        let c = bin.consts;
        BinConsts {
            f: bin.f,
            omega: 2.0 * PI * bin.f,
            cdf: c[0],
            csus: c[1],
            e_oms: c[2],
            e_cdf: c[3],
            e_csus: c[4],
        }
    }

    /// `H_io(f; θ)` (rows `o1, o12`, columns `i1, i12`), generic over dual numbers.
    fn h_io<T: DualNum<Primitive = f64> + Copy>(
        &self,
        th: &[T],
        c: &BinConsts,
    ) -> [[Complex<T>; 2]; 2] {
        let r_df = match self.opts.thruster.param() {
            Some(_) => self.opts.thruster.factor(th[N_PARAMS], c.f),
            None => Complex::new(T::one(), T::zero()),
        };
        let t7: &[T; N_PARAMS] = th[..N_PARAMS].try_into().expect("length checked");
        crate::ltp::h_io_matrix(t7, c, &self.opts.masses, r_df)
    }

    /// `H_io(z; θ)` of the discretised loop at the bin's `fs`.
    fn h_io_discrete<T: DualNum<Primitive = f64> + Copy>(
        &self,
        th: &[T],
        bin: &Bin,
    ) -> [[Complex<T>; 2]; 2] {
        let c = DiscreteBinConsts::from_array(bin.f, bin.fs, bin.consts);
        let r_df = match self.opts.thruster.param() {
            Some(_) => self.opts.thruster.factor(th[N_PARAMS], c.f),
            None => Complex::new(T::one(), T::zero()),
        };
        let t7: &[T; N_PARAMS] = th[..N_PARAMS].try_into().expect("length checked");
        crate::ltp::h_io_discrete(t7, &c, &self.opts.masses, r_df)
    }

    /// `Σ r_kᴴ C_k⁻¹ r_k` with a per-bin loop kernel `h(bin, t, inj) = H_io (t ⊙ inj)`:
    /// guidance-delay phasors `t` by recurrence on the uniform grid, re-seeded exactly every
    /// [`PHASOR_RESEED`] bins so rounding cannot accumulate beyond ~1e−14; no allocation.
    #[inline(always)]
    fn residual_power_with(
        th: &[f64; N_PARAMS],
        b: &BinBlock,
        h: impl Fn(&Bin, [Complex64; 2], [Complex64; 2]) -> [Complex64; 2],
    ) -> f64 {
        let step = [delay(th[2], b.df), delay(th[3], b.df)];
        let mut t = [Complex64::new(1.0, 0.0); 2];
        let mut s = 0.0;
        for k in 0..b.n {
            let bin = b.bin(k, N_CONSTS);
            if k % PHASOR_RESEED == 0 {
                t = [delay(th[2], bin.f), delay(th[3], bin.f)];
            }
            let d = &b.data[4 * k..4 * k + 4];
            let hk = h(&bin, t, [d[2], d[3]]);
            let r = [d[0] - hk[0], d[1] - hk[1]];
            s += hermitian::quad(&b.cinv[k], r);
            t[0] *= step[0];
            t[1] *= step[1];
        }
        s
    }

    /// `H_to(f; θ)` (rows `o1, o12`, columns TM1, TM2) of the continuous loop: the residual
    /// `o − H_io i` carries a force on a test mass through it unchanged.
    fn force<T: DualNum<Primitive = f64> + Copy>(
        &self,
        th: &[T],
        bin: &Bin,
        out: &mut [Complex<T>],
    ) -> bool {
        if self.opts.response != LoopResponse::Continuous {
            return false;
        }
        let c = self.bin_consts_struct(bin);
        let r_df = match self.opts.thruster.param() {
            Some(_) => self.opts.thruster.factor(th[N_PARAMS], c.f),
            None => Complex::new(T::one(), T::zero()),
        };
        let t7: &[T; N_PARAMS] = th[..N_PARAMS].try_into().expect("length checked");
        out[..2].copy_from_slice(&crate::ltp::h_dg_column(t7, &c, &self.opts.masses, r_df));
        true
    }

    fn fill<T: DualNum<Primitive = f64> + Copy>(
        &self,
        th: &[T],
        bin: &Bin,
        out: &mut [Complex<T>],
    ) {
        let h = match self.opts.response {
            LoopResponse::Continuous => self.h_io(th, &self.bin_consts_struct(bin)),
            LoopResponse::Discrete => self.h_io_discrete(th, bin),
        };
        let one = Complex::new(T::one(), T::zero());
        let zero = Complex::new(T::zero(), T::zero());
        // row-major [I | −H_io]
        out[0] = one;
        out[1] = zero;
        out[2] = -h[0][0];
        out[3] = -h[0][1];
        out[4] = zero;
        out[5] = one;
        out[6] = -h[1][0];
        out[7] = -h[1][1];
    }
}

/// The SI unit of an LTP data channel: the read-outs and guidance injections are
/// displacements, the commanded forces per unit mass accelerations (ltp-model.md §3);
/// `""` for a name the loop does not know.
pub fn ltp_channel_unit(channel: &str) -> &'static str {
    match channel {
        "o1" | "o12" | "i1" | "i12" => "m",
        "g1" | "g2" | "gsc" => "m s⁻²",
        _ => "",
    }
}

impl Model for LtpModel {
    fn name(&self) -> &str {
        &self.name
    }

    fn param_names(&self) -> &[String] {
        &self.names
    }

    /// ω² in s⁻², delays in s, the thruster pole in Hz; gains and the cross-talk `d21` are
    /// dimensionless (ltp-model.md §3.2).
    fn physical_limits(&self) -> Vec<[Option<f64>; 2]> {
        // the guidance delays: causality
        self.names
            .iter()
            .map(|n| match n.as_str() {
                "dt1" | "dt2" => [Some(0.0), None],
                _ => [None, None],
            })
            .collect()
    }

    fn param_units(&self) -> Vec<String> {
        self.names
            .iter()
            .map(|n| {
                match n.as_str() {
                    "w1sq" | "w2sq" => "s⁻²",
                    "dt1" | "dt2" | "tau_df" => "s",
                    "f_df" => "Hz",
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
            .map(|c| ltp_channel_unit(c).into())
            .collect()
    }

    fn n_consts(&self) -> usize {
        N_CONSTS
    }

    /// Continuous: the controller and OMS-delay responses at `f`. Discrete: the constants of
    /// the loop discretised at `fs` ([`DiscreteBinConsts`]); an invalid `fs` gives NaNs.
    fn bin_consts(&self, f: f64, fs: f64, out: &mut [Complex64]) {
        match self.opts.response {
            LoopResponse::Continuous => {
                let b = BinConsts::new(f, &self.ctrl, self.opts.oms_delay);
                out.copy_from_slice(&[b.cdf, b.csus, b.e_oms, b.e_cdf, b.e_csus]);
            }
            LoopResponse::Discrete => match DiscreteControllers::tustin(&self.ctrl, fs) {
                Ok(dc) => {
                    let b = DiscreteBinConsts::new(f, &dc, self.opts.oms_delay);
                    out[..N_DISCRETE_CONSTS].copy_from_slice(&b.to_array());
                    out[N_DISCRETE_CONSTS..].fill(Complex64::new(0.0, 0.0));
                }
                Err(_) => out.fill(Complex64::new(f64::NAN, f64::NAN)),
            },
        }
    }

    fn coefficients(&self, theta: &[f64], bin: &Bin, out: &mut [Complex64]) {
        self.fill(theta, bin, out);
    }

    fn coefficients_dual(&self, theta: &[Dual64], bin: &Bin, out: &mut [Complex<Dual64>]) {
        self.fill(theta, bin, out);
    }

    fn force_response(&self, theta: &[f64], bin: &Bin, out: &mut [Complex64]) -> bool {
        self.force(theta, bin, out)
    }

    fn force_response_dual(
        &self,
        theta: &[Dual64],
        bin: &Bin,
        out: &mut [Complex<Dual64>],
    ) -> bool {
        self.force(theta, bin, out)
    }

    fn check(&self, theta: &[f64]) -> Result<(), String> {
        let t7: &[f64; N_PARAMS] = theta
            .get(..N_PARAMS)
            .and_then(|t| t.try_into().ok())
            .ok_or_else(|| "wrong parameter count".to_string())?;
        check_stable(&LtpParams::from_array(t7), &self.ctrl, &self.opts.masses)
            .map_err(|e| e.to_string())?;
        // the loop with its thruster response and OMS delay, which the state matrix lacks
        let thruster = self.thruster_actuation(theta);
        if !self.poly.is_stable(t7, &thruster) {
            let p = self.poly.char_poly(t7, &thruster);
            let worst = crate::ltp::hurwitz::rightmost_root(&p);
            return Err(format!(
                "the closed loop is unstable for these parameters{}: {} (Routh–Hurwitz on its characteristic polynomial); check {}",
                match self.opts.thruster.param() {
                    Some(n) => format!(" with its thruster response (`{n}` = {})", theta[N_PARAMS]),
                    None => " with its OMS delay".into(),
                },
                match worst {
                    Some(z) => format!("a pole at {:.4e} {:+.4e}i rad/s", z.re, z.im),
                    None => "its characteristic polynomial is degenerate".into(),
                },
                self.names.join(", ")
            ));
        }
        Ok(())
    }

    fn is_stable(&self, theta: &[f64]) -> bool {
        let Some(t7) = theta
            .get(..N_PARAMS)
            .and_then(|t| <&[f64; N_PARAMS]>::try_from(t).ok())
        else {
            return false;
        };
        self.poly.is_stable(t7, &self.thruster_actuation(theta))
    }

    /// The wave-1 kernel: θ-dependent loop scalars once per θ, one complex reciprocal per bin,
    /// guidance-delay phasors by recurrence on the uniform grid (re-seeded exactly every
    /// [`PHASOR_RESEED`] bins so rounding cannot accumulate beyond ~1e−14), no allocation.
    /// The discrete loop has the same kind of kernel ([`DiscreteLoopKernel`]). With a thruster
    /// response the generic per-bin path is used.
    fn residual_power(&self, theta: &[f64], b: &BinBlock) -> f64 {
        if self.opts.thruster != ThrusterResponse::None {
            return residual_power_generic(self, theta, b);
        }
        let th: &[f64; N_PARAMS] = match theta.try_into() {
            Ok(t) => t,
            Err(_) => return f64::NAN,
        };
        match self.opts.response {
            LoopResponse::Continuous => {
                let kern = LoopKernel::new(th, &self.opts.masses);
                Self::residual_power_with(th, b, |bin, t, inj| {
                    kern.eval(&self.bin_consts_struct(bin), t, inj)
                })
            }
            LoopResponse::Discrete => {
                let kern = DiscreteLoopKernel::new(th, &self.opts.masses, b.fs);
                Self::residual_power_with(th, b, |bin, t, inj| {
                    kern.eval(
                        &DiscreteBinConsts::from_array(bin.f, bin.fs, bin.consts),
                        t,
                        inj,
                    )
                })
            }
        }
    }

    /// The experiments of one grid in one kernel of `super::ltp_kernel` (shared `det P`).
    fn prepare_joint_kernel(&self, b: &[BinBlock]) -> Option<std::sync::Arc<dyn BlockKernel>> {
        if !self.is_plain_continuous() || b.len() < 2 {
            return None;
        }
        super::ltp_kernel::LtpKernel::new(&self.opts.masses, b).map(|k| k.arc())
    }

    /// Only the requested components, by the batch of `super::ltp_kernel` (plain loop only).
    fn coefficients_batch(
        &self,
        th: &[f64],
        freqs: &[f64],
        fs: f64,
        consts: &[Complex64],
        comps: &[usize],
        out: &mut [Complex64],
    ) {
        if !self.is_plain_continuous()
            || !super::ltp_kernel::coefficients_batch(
                &self.opts.masses,
                th,
                freqs,
                consts,
                comps,
                out,
            )
        {
            coefficients_batch_generic(self, th, freqs, fs, consts, comps, out)
        }
    }

    /// The prepared kernel of `super::ltp_kernel` (plain loop only; `None` with a thruster
    /// response).
    fn prepare_kernel(&self, b: &BinBlock) -> Option<std::sync::Arc<dyn BlockKernel>> {
        if !self.is_plain_continuous() {
            return None;
        }
        super::ltp_kernel::LtpKernel::new(&self.opts.masses, std::slice::from_ref(b))
            .map(|k| k.arc())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{coefficients_at, residual_power_generic};

    #[test]
    fn coefficients_are_identity_and_minus_h_io() {
        let m = LtpModel::new("ltp", LtpModelOptions::default());
        let th = LtpParams::default().to_array();
        for f in [1e-4, 1e-3, 1e-2, 0.1, 1.0] {
            let c = coefficients_at(&m, &th, f, 10.0);
            let bc = BinConsts::new(f, &Controllers::default(), 0.0);
            let one = Complex64::new(1.0, 0.0);
            let zero = Complex64::new(0.0, 0.0);
            for j in 0..2 {
                let mut inj = [zero; 2];
                inj[j] = one;
                let h = crate::ltp::response(&th, &bc, &Masses::default(), inj);
                assert!((c[2 + j] + h[0]).norm() <= 1e-14 * h[0].norm().max(1e-300));
                assert!((c[6 + j] + h[1]).norm() <= 1e-14 * h[1].norm().max(1e-300));
            }
            assert_eq!([c[0], c[1], c[4], c[5]], [one, zero, zero, one]);
        }
    }

    /// `m`'s `residual_power` kernel against the generic path on 1000 synthetic bins.
    fn assert_kernel_equals_generic(m: &LtpModel) {
        let th = LtpParams::default().to_array();
        let n = 1000;
        let (f0, df, fs) = (1e-3, 1e-3, 10.0);
        let mut consts = vec![Complex64::new(0.0, 0.0); n * N_CONSTS];
        for k in 0..n {
            m.bin_consts(
                f0 + k as f64 * df,
                fs,
                &mut consts[k * N_CONSTS..(k + 1) * N_CONSTS],
            );
        }
        let data: Vec<Complex64> = (0..4 * n)
            .map(|i| Complex64::new((i as f64 * 0.37).sin(), (i as f64 * 0.91).cos()))
            .collect();
        let cinv: Vec<_> = (0..n)
            .map(|k| (2.0 + k as f64 * 1e-3, Complex64::new(0.1, -0.2), 3.0))
            .collect();
        let b = BinBlock {
            f0,
            df,
            fs,
            n,
            data: &data,
            cinv: &cinv,
            whiten: &[],
            consts: &consts,
        };
        let fast = m.residual_power(&th, &b);
        let slow = residual_power_generic(m, &th, &b);
        assert!(
            (fast - slow).abs() <= 1e-12 * slow.abs(),
            "{fast} vs {slow}"
        );
    }

    #[test]
    fn fast_kernel_equals_the_generic_path() {
        assert_kernel_equals_generic(&LtpModel::new("ltp", LtpModelOptions::default()));
    }

    #[test]
    fn thruster_factors_have_unit_dc_gain_and_exact_derivatives() {
        for (kind, x) in [
            (ThrusterResponse::Delay, 0.3),
            (ThrusterResponse::Pole, 1.963),
        ] {
            let r0 = kind.factor(x, 0.0);
            assert!((r0 - Complex64::new(1.0, 0.0)).norm() < 1e-15);
            let f = 0.7;
            let d = kind.factor(Dual64::from(x).derivative(), f);
            let h = 1e-6;
            let num = (kind.factor(x + h, f) - kind.factor(x - h, f)) / (2.0 * h);
            assert!((Complex64::new(d.re.eps, d.im.eps) - num).norm() < 1e-8);
        }
        // the pole at f_df has |R| = 1/√2 and phase −45°
        let r = ThrusterResponse::Pole.factor(2.0, 2.0);
        assert!((r.norm() - 0.5f64.sqrt()).abs() < 1e-15);
        assert!((r.arg() + PI / 4.0).abs() < 1e-15);
    }

    fn discrete(thruster: ThrusterResponse) -> LtpModel {
        LtpModel::new(
            "ltp",
            LtpModelOptions {
                oms_delay: 0.3,
                thruster,
                response: LoopResponse::Discrete,
                ..Default::default()
            },
        )
    }

    #[test]
    fn discrete_coefficients_are_the_discrete_loop_at_the_bin_sample_rate() {
        use crate::ltp::timedomain::DiscreteLoop;
        let m = discrete(ThrusterResponse::None);
        let p = LtpParams {
            dt1: 0.13,
            dt2: 0.41,
            ..Default::default()
        };
        let th = p.to_array();
        for fs in [10.0, 100.0] {
            let lp = DiscreteLoop::new(&p, &Controllers::default(), &Masses::default(), fs, 0.3)
                .unwrap();
            // from 1 mHz: below, the oracle's own rounding (ε/(ωT)², see
            // ltp::discrete_response) exceeds 1e−10; fs/2 is the hold's zero
            for f in [1e-3, 1e-2, 0.1, 1.0, 0.45 * fs] {
                let c = coefficients_at(&m, &th, f, fs);
                let h = lp.at(f).unwrap().h_io;
                for i in 0..2 {
                    for j in 0..2 {
                        let got = -c[4 * i + 2 + j];
                        assert!(
                            (got - h[i][j]).norm() <= 1e-10 * h[i][j].norm(),
                            "fs {fs}, f {f}: [{i}][{j}] {got} vs {}",
                            h[i][j]
                        );
                    }
                }
            }
        }
        // and differs from the continuous model
        let cont = LtpModel::new(
            "ltp",
            LtpModelOptions {
                oms_delay: 0.3,
                ..Default::default()
            },
        );
        let (a, b) = (
            coefficients_at(&m, &th, 0.1, 10.0),
            coefficients_at(&cont, &th, 0.1, 10.0),
        );
        assert!((a[2] / b[2] - 1.0).norm() > 1e-2);
    }

    #[test]
    fn discrete_dual_coefficients_have_exact_derivatives() {
        let m = discrete(ThrusterResponse::Delay);
        let mut th = LtpParams::default().to_array().to_vec();
        th.push(0.15);
        let (f, fs) = (0.02, 10.0);
        let mut consts = [Complex64::new(0.0, 0.0); N_CONSTS];
        m.bin_consts(f, fs, &mut consts);
        let bin = Bin {
            f,
            fs,
            consts: &consts,
        };
        for j in 0..th.len() {
            let mut td: Vec<Dual64> = th.iter().map(|&x| Dual64::from(x)).collect();
            td[j] = td[j].derivative();
            let mut cd = [Complex::new(Dual64::from(0.0), Dual64::from(0.0)); 8];
            m.coefficients_dual(&td, &bin, &mut cd);
            let h = 1e-3 * th[j].abs();
            let at = |k: f64| {
                let mut t = th.clone();
                t[j] += k * h;
                let mut c = [Complex64::new(0.0, 0.0); 8];
                m.coefficients(&t, &bin, &mut c);
                c
            };
            let (p1, m1, p2, m2) = (at(1.0), at(-1.0), at(2.0), at(-2.0));
            let mut c0 = [Complex64::new(0.0, 0.0); 8];
            m.coefficients(&th, &bin, &mut c0);
            for k in 0..8 {
                assert_eq!(Complex64::new(cd[k].re.re, cd[k].im.re), c0[k]);
                let exact = Complex64::new(cd[k].re.eps, cd[k].im.eps);
                // O(h⁴) central difference; it resolves no better than the rounding of M
                let num = (8.0 * (p1[k] - m1[k]) - (p2[k] - m2[k])) / (12.0 * h);
                let tol = 1e-6 * exact.norm() + 4.0 * f64::EPSILON * c0[k].norm() / h;
                assert!(
                    (num - exact).norm() <= tol,
                    "θ{j}, coefficient {k}: {num} vs {exact}"
                );
            }
        }
    }

    #[test]
    fn discrete_residual_power_equals_the_generic_path() {
        assert_kernel_equals_generic(&discrete(ThrusterResponse::None));
    }

    #[test]
    fn response_option_parses_in_snake_case_and_defaults_to_continuous() {
        let o: LtpModelOptions = toml::from_str("response = \"discrete\"").unwrap();
        assert_eq!(o.response, LoopResponse::Discrete);
        let o: LtpModelOptions = toml::from_str("oms_delay = 0.3").unwrap();
        assert_eq!(o.response, LoopResponse::Continuous);
        assert!(toml::from_str::<LtpModelOptions>("response = \"zoh\"").is_err());
    }
}

#[cfg(test)]
mod unit_tests {
    use super::*;

    #[test]
    fn parameters_carry_si_units() {
        let m = LtpModel::new("ltp", LtpModelOptions::default());
        assert_eq!(
            m.param_units(),
            ["s⁻²", "s⁻²", "s", "s", "", "", ""],
            "{:?}",
            m.param_names()
        );
        for (t, unit) in [
            (ThrusterResponse::Delay, "s"),
            (ThrusterResponse::Pole, "Hz"),
        ] {
            let m = LtpModel::new(
                "ltp",
                LtpModelOptions {
                    thruster: t,
                    ..Default::default()
                },
            );
            assert_eq!(m.param_units().len(), m.param_names().len());
            assert_eq!(m.param_units()[7], unit);
        }
    }
}
