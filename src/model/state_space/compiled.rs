//! [`StateSpaceModel`]: a compiled state-space model, evaluated through the [`Model`] trait.

use super::def::TimeDomain;
use super::solve::{System, transfer};
use crate::model::bin::{Bin, BinBlock, MAX_CHANNELS, MAX_RESIDUALS};
use crate::model::traits::Model;
use crate::model::user::real::RealExpr;
use num_complex::{Complex, Complex64};
use num_dual::{Dual64, DualNum};
use std::f64::consts::PI;

/// Most states a model may have.
pub const MAX_STATES: usize = 32;

/// A compiled state-space model: `ẋ = A x + B u` (or `x[k+1] = …`), `y = C x + D u`, residual
/// `r = y − H u` with `H = C (sI − A)⁻¹ B + D` and the declared delays.
///
/// ```
/// use occam::model::state_space::{StateSpaceDef, StateSpaceModel};
/// use occam::model::{Model, coefficients_at};
/// // a damped oscillator driven by force u, read out in position y
/// let def: StateSpaceDef = toml::from_str(r#"
///     name = "osc"
///     parameters = ["k", "gamma"]
///     inputs = ["u"]
///     outputs = ["y"]
///     a = [[0, 1], ["-k", "-gamma"]]
///     b = [[0], [1]]
///     c = [[1, 0]]
/// "#).unwrap();
/// let m = StateSpaceModel::new(&def).unwrap();
/// assert_eq!(m.data_channels(), ["y", "u"]);
/// let (k, gamma, f) = (2.0, 0.3, 0.1);
/// let coef = coefficients_at(&m, &[k, gamma], f, 10.0);
/// let s = num_complex::Complex64::new(0.0, 2.0 * std::f64::consts::PI * f);
/// let h = 1.0 / (s * s + gamma * s + k);
/// assert!((coef[0].re - 1.0).abs() < 1e-15);
/// assert!((coef[1] + h).norm() < 1e-14 * h.norm());
/// assert!(m.check(&[k, gamma]).is_ok());
/// assert!(m.check(&[-k, gamma]).unwrap_err().contains("unstable"));
/// ```
#[derive(Debug, Clone)]
pub struct StateSpaceModel {
    pub(super) name: String,
    pub(super) params: Vec<String>,
    /// Unit of each parameter, in θ order (empty: dimensionless or unknown).
    pub(super) units: Vec<String>,
    /// The physical limits of each parameter (`physical_limits`, and 0 below a delay), in θ
    /// order.
    pub(super) limits: Vec<[Option<f64>; 2]>,
    /// Outputs, then inputs.
    pub(super) data: Vec<String>,
    /// Unit of each channel of `data` (empty: unknown).
    pub(super) channel_units: Vec<String>,
    pub(super) outputs: Vec<String>,
    pub(super) states: Vec<String>,
    pub(super) time: TimeDomain,
    /// Dense, row-major: `a` is n×n, `b` n×m, `c` p×n, `d` p×m (empty: zero), `g` n×q, `h`
    /// p×q (empty: zero), `noise` q.
    pub(super) a: Vec<RealExpr>,
    pub(super) b: Vec<RealExpr>,
    pub(super) c: Vec<RealExpr>,
    pub(super) d: Vec<RealExpr>,
    pub(super) g: Vec<RealExpr>,
    pub(super) h: Vec<RealExpr>,
    pub(super) noise: Vec<RealExpr>,
    /// Delay of each input, then of each output (`None`: no delay).
    pub(super) delays: Vec<Option<RealExpr>>,
}

/// Buffers of the elimination: `lu` (n²) and `x` (n × inputs).
pub(super) struct Work<'a, T> {
    /// The matrix being factored.
    pub lu: &'a mut [Complex<T>],
    /// The right-hand sides, then the solution.
    pub x: &'a mut [Complex<T>],
}

fn eval_into<T: DualNum<Primitive = f64> + Copy>(src: &[RealExpr], th: &[T], dst: &mut [T]) {
    for (d, e) in dst.iter_mut().zip(src) {
        *d = e.eval(th);
    }
}

impl StateSpaceModel {
    fn n(&self) -> usize {
        self.states.len()
    }

    fn m(&self) -> usize {
        self.data.len() - self.outputs.len()
    }

    fn p(&self) -> usize {
        self.outputs.len()
    }

    /// The state names (declared, or `x0, x1, …`).
    pub fn state_names(&self) -> &[String] {
        &self.states
    }

    /// The point of the transfer function at `f`: `s = i2πf` or `z = e^{i2πf/fs}`.
    fn point(&self, f: f64, fs: f64) -> Complex64 {
        match self.time {
            TimeDomain::Continuous => Complex64::new(0.0, 2.0 * PI * f),
            TimeDomain::Discrete => Complex64::from_polar(1.0, 2.0 * PI * f / fs),
        }
    }

    /// Evaluates the matrices at θ on the stack and hands them, with the workspace, to `k`:
    /// the buffers follow the number of states, so small systems pay for small buffers.
    #[inline]
    pub(super) fn with_system<T, R>(
        &self,
        th: &[T],
        k: impl FnOnce(&System<T>, &[T], Work<T>) -> R,
    ) -> R
    where
        T: DualNum<Primitive = f64> + Copy,
    {
        const C: usize = MAX_CHANNELS;
        match self.n() {
            0..=4 => self.with_n::<T, R, 16, { 4 * C }>(th, k),
            5..=8 => self.with_n::<T, R, 64, { 8 * C }>(th, k),
            9..=16 => self.with_n::<T, R, 256, { 16 * C }>(th, k),
            _ => self.with_n::<T, R, { MAX_STATES * MAX_STATES }, { MAX_STATES * C }>(th, k),
        }
    }

    #[inline]
    fn with_n<T, R, const NN: usize, const NX: usize>(
        &self,
        th: &[T],
        k: impl FnOnce(&System<T>, &[T], Work<T>) -> R,
    ) -> R
    where
        T: DualNum<Primitive = f64> + Copy,
    {
        let z = T::zero();
        let (n, m, p) = (self.n(), self.m(), self.p());
        let mut a = [z; NN];
        let mut b = [z; NX];
        let mut c = [z; NX];
        let mut d = [z; MAX_CHANNELS * MAX_RESIDUALS];
        let mut tau = [z; MAX_CHANNELS + MAX_RESIDUALS];
        eval_into(&self.a, th, &mut a);
        eval_into(&self.b, th, &mut b);
        eval_into(&self.c, th, &mut c);
        eval_into(&self.d, th, &mut d);
        for (t, e) in tau.iter_mut().zip(&self.delays) {
            if let Some(e) = e {
                *t = e.eval(th);
            }
        }
        let sys = System {
            n,
            m,
            p,
            a: &a[..n * n],
            b: &b[..n * m],
            c: &c[..p * n],
            d: &d[..self.d.len()],
        };
        let zc = Complex::new(z, z);
        let mut lu = [zc; NN];
        let mut x = [zc; NX];
        let w = Work {
            lu: &mut lu,
            x: &mut x,
        };
        k(&sys, &tau[..m + p], w)
    }

    /// `M = [I | −H]` at `f` for the evaluated system into `out`.
    #[inline]
    pub(super) fn fill<T: DualNum<Primitive = f64> + Copy>(
        &self,
        sys: &System<T>,
        tau: &[T],
        w: &mut Work<T>,
        (f, fs): (f64, f64),
        out: &mut [Complex<T>],
    ) {
        let zero = Complex::new(T::zero(), T::zero());
        let (m, p) = (sys.m, sys.p);
        let mut h = [zero; MAX_CHANNELS * MAX_RESIDUALS];
        let ok = transfer(sys, self.point(f, fs), w.lu, w.x, &mut h);
        let nc = p + m;
        out.fill(zero);
        let omega = 2.0 * PI * f;
        for o in 0..p {
            out[o * nc + o] = Complex::new(T::one(), T::zero());
            for j in 0..m {
                let v = if !ok {
                    Complex::new(T::from(f64::NAN), T::from(f64::NAN))
                } else if self.delays[j].is_some() || self.delays[m + o].is_some() {
                    let (sn, cs) = ((tau[j] + tau[m + o]) * omega).sin_cos();
                    h[o * m + j] * Complex::new(cs, -sn)
                } else {
                    h[o * m + j]
                };
                out[o * nc + p + j] = -v;
            }
        }
    }
}

impl Model for StateSpaceModel {
    fn name(&self) -> &str {
        &self.name
    }

    fn param_names(&self) -> &[String] {
        &self.params
    }

    fn param_units(&self) -> Vec<String> {
        self.units.clone()
    }

    fn physical_limits(&self) -> Vec<[Option<f64>; 2]> {
        self.limits.clone()
    }

    fn data_channels(&self) -> &[String] {
        &self.data
    }

    fn channel_units(&self) -> Vec<String> {
        self.channel_units.clone()
    }

    fn residual_channels(&self) -> &[String] {
        &self.outputs
    }

    fn coefficients(&self, theta: &[f64], bin: &Bin, out: &mut [Complex64]) {
        self.with_system(theta, |sys, tau, mut w| {
            self.fill(sys, tau, &mut w, (bin.f, bin.fs), out)
        });
    }

    fn coefficients_dual(&self, theta: &[Dual64], bin: &Bin, out: &mut [Complex<Dual64>]) {
        self.with_system(theta, |sys, tau, mut w| {
            self.fill(sys, tau, &mut w, (bin.f, bin.fs), out)
        });
    }

    /// The matrices are evaluated once for all frequencies (the generic batch would evaluate
    /// them per frequency).
    fn coefficients_batch(
        &self,
        theta: &[f64],
        freqs: &[f64],
        fs: f64,
        _consts: &[Complex64],
        comps: &[usize],
        out: &mut [Complex64],
    ) {
        let ncoef = self.data.len() * self.outputs.len();
        let nc = comps.len();
        self.with_system(theta, |sys, tau, mut w| {
            let mut coef = [Complex64::new(0.0, 0.0); MAX_CHANNELS * MAX_RESIDUALS];
            for (e, &f) in freqs.iter().enumerate() {
                self.fill(sys, tau, &mut w, (f, fs), &mut coef[..ncoef]);
                for (o, &c) in out[e * nc..(e + 1) * nc].iter_mut().zip(comps) {
                    *o = coef[c];
                }
            }
        });
    }

    /// The matrices are evaluated once per θ, then the transfer matrix is solved bin by bin.
    fn residual_power(&self, theta: &[f64], b: &BinBlock) -> f64 {
        let nc = self.data.len();
        let nr = self.outputs.len();
        self.with_system(theta, |sys, tau, mut w| {
            let mut coef = [Complex64::new(0.0, 0.0); MAX_CHANNELS * MAX_RESIDUALS];
            let mut s = 0.0;
            for k in 0..b.n {
                let f = b.f0 + k as f64 * b.df;
                self.fill(sys, tau, &mut w, (f, b.fs), &mut coef[..nr * nc]);
                s += b.residual_quad(k, &coef[..nr * nc], nr);
            }
            s
        })
    }

    fn data_noise_csd(&self, theta: &[f64], bin: &Bin, out: &mut [Complex64]) -> bool {
        if self.noise.is_empty() {
            return false;
        }
        let ev = |v: &[RealExpr]| -> Vec<f64> { v.iter().map(|e| e.eval(theta)).collect() };
        let (a, g, c, h, psd) = (
            ev(&self.a),
            ev(&self.g),
            ev(&self.c),
            ev(&self.h),
            ev(&self.noise),
        );
        let (m, p) = (self.m(), self.p());
        let omega = 2.0 * PI * bin.f;
        let phase: Vec<Complex64> = self.delays[m..]
            .iter()
            .map(|d| match d {
                Some(d) => Complex64::from_polar(1.0, -omega * d.eval(theta)),
                None => Complex64::new(1.0, 0.0),
            })
            .collect();
        let sys = System {
            n: self.n(),
            m: self.noise.len(),
            p,
            a: &a,
            b: &g,
            c: &c,
            d: &h,
        };
        let z = self.point(bin.f, bin.fs);
        super::noise::output_csd(&sys, &psd, &phase, z, p + m, out)
    }

    /// Every eigenvalue of `A` in the left half-plane (inside the unit circle for a
    /// discrete-time model), the stability part of [`Model::check`]; its other conditions
    /// (delays, noise PSDs) are not stability and do not make `ln L = −∞`.
    fn is_stable(&self, theta: &[f64]) -> bool {
        if theta.len() != self.params.len() || theta.iter().any(|x| !x.is_finite()) {
            return false;
        }
        let a: Vec<f64> = self.a.iter().map(|e| e.eval(theta)).collect();
        super::stability::check_stable(&a, self.n(), self.time).is_ok()
    }

    /// θ has the right length and finite values, delays are ≥ 0, noise PSDs ≥ 0, and the
    /// system is stable (every eigenvalue of `A` in the left half-plane, or inside the unit
    /// circle for a discrete-time model).
    fn check(&self, theta: &[f64]) -> Result<(), String> {
        let m = &self.name;
        if theta.len() != self.params.len() {
            return Err(format!(
                "state-space model `{m}`: θ has {} values for {} parameters",
                theta.len(),
                self.params.len()
            ));
        }
        if let Some((p, x)) = self.params.iter().zip(theta).find(|(_, x)| !x.is_finite()) {
            return Err(format!(
                "state-space model `{m}`: parameter `{p}` is {x}, not finite"
            ));
        }
        let channels = self.data[self.p()..].iter().chain(&self.outputs);
        for (ch, d) in channels.zip(&self.delays) {
            if let Some(d) = d {
                let t = d.eval(theta);
                if !(t >= 0.0) {
                    return Err(format!(
                        "state-space model `{m}`: delay.{ch} is {t} at this θ; a delay is ≥ 0 s"
                    ));
                }
            }
        }
        for (k, e) in self.noise.iter().enumerate() {
            let v = e.eval(theta);
            if !(v >= 0.0 && v.is_finite()) {
                return Err(format!(
                    "state-space model `{m}`: noise[{k}] is {v} at this θ; a PSD is finite and ≥ 0"
                ));
            }
        }
        let n = self.n();
        let a: Vec<f64> = self.a.iter().map(|e| e.eval(theta)).collect();
        super::stability::check_stable(&a, n, self.time)
            .map_err(|e| format!("state-space model `{m}`: {e} at this θ"))
    }
}
