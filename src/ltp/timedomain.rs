//! Time-domain simulation of the discretised LTP closed loop (ltp-model.md §4 "Discretisation")
//! and the exact frequency response of that same discrete loop.
//!
//! The loop runs at the sample rate `fs` (10 Hz by default, [`DEFAULT_FS`]). Per sample `n`:
//!
//! ```text
//! o[n]   = S x[n − d] + n_o[n]                 (OMS delay: d = τ_o·fs whole samples)
//! e[n]   = o[n] − i[n]                         (i: injections, already guidance-delayed)
//! u[n]   = −K(z) e[n]                          (C_df, C_sus by Tustin; direct feed-through)
//! X[n+1] = Φ X[n] + Γ (M A u[n] + g[n])        (plant D x = M A u + g by zero-order hold)
//! ```
//!
//! with `X = (x1, x12, ẋ1, ẋ12)`, the full `D` of ltp-model.md §2.1 (m/m_sc terms kept) and
//! `u`, `g` held constant over each sample. [`DiscreteLoop::at`] gives the exact response of
//! these difference equations at `z = e^{i2πf/fs}`; it is the oracle the simulator is tested
//! against, and the model to fit to data produced by [`DiscreteLoop::simulate`].
//!
//! # Discrete versus continuous
//!
//! The discretised loop is not the continuous one of [`ClosedLoop::at`]: the zero-order hold
//! delays the actuation by half a sample on average, so to first order the discrete loop equals
//! the continuous loop with an extra in-loop delay `T/2` (a 0.05 s OMS delay at 10 Hz); Tustin
//! only adds `O((2πf/fs)²)`. Measured with [`discretisation_discrepancy`] (θ = K14 Table I,
//! §4 controllers, fs = 10 Hz, τ_o = 0), rows `(o1, o12)`, columns `(i1, i12)`:
//!
//! ```text
//! DISCREPANCY_TABLE
//! ```

use crate::lti::LtiError;
use crate::lti::discrete::{DiscreteTf, IirFilter, zoh};
use crate::ltp::{BinConsts, ClosedLoop, Controllers, LtpParams, Masses};
use nalgebra::{DMatrix, Matrix2, Matrix4, Matrix4x2, Vector2, Vector4};
use num_complex::Complex64;
use std::f64::consts::PI;

/// The LPF DFACS / data sample rate (Hz), ltp-model.md §1.
pub const DEFAULT_FS: f64 = 10.0;

/// Errors of the discretised loop and its simulator.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum SimError {
    #[error("sample rate fs = {0} Hz must be a positive finite number (the LPF data rate is 10 Hz)")]
    SampleRate(f64),
    #[error(
        "OMS delay τ_o = {tau} s is {samples} samples at fs = {fs} Hz: the time-domain loop needs \
         a non-negative whole number of samples (e.g. 0.3 s at 10 Hz)"
    )]
    OmsDelay { tau: f64, fs: f64, samples: f64 },
    #[error("parameter `{0}` is not a finite number")]
    NonFiniteParam(&'static str),
    #[error("mass `{name}` = {value} kg must be a positive finite number")]
    Mass { name: &'static str, value: f64 },
    #[error("discretisation: {0}")]
    Lti(#[from] LtiError),
    #[error(
        "the discretised closed loop is unstable at fs = {fs} Hz: pole at z = {re:.9} {im:+.9}i \
         (|z| = {modulus:.12}; every pole needs |z| < 1); check the parameters and controllers"
    )]
    Unstable {
        fs: f64,
        re: f64,
        im: f64,
        modulus: f64,
    },
    #[error(
        "input `{name}` has {got} samples but `i1` has {want}: every series must have the same \
         length"
    )]
    Length {
        name: &'static str,
        got: usize,
        want: usize,
    },
    #[error("input `{name}` is not a finite number at sample {index}")]
    NonFiniteInput { name: &'static str, index: usize },
    #[error("frequency f = {f} Hz must lie in (0, fs/2] = (0, {nyquist}] Hz")]
    Frequency { f: f64, nyquist: f64 },
    #[error(
        "the response is singular at f = {0} Hz (an open-loop plant or loop pole on the unit \
         circle); evaluate at a nearby frequency"
    )]
    Singular(f64),
}

/// The LTP closed loop discretised at `fs`: plant by zero-order hold, controllers by Tustin,
/// an OMS delay of a whole number of samples. Build once per parameter set; [`Self::at`] and
/// [`Self::simulate`] reuse it.
#[derive(Debug, Clone, PartialEq)]
pub struct DiscreteLoop {
    fs: f64,
    delay: usize,
    dt: [f64; 2],
    d21: f64,
    phi: Matrix4<f64>,
    /// `Φ − I`, kept separately so that `zI − Φ = (z − 1)I − (Φ − I)` loses no digits at low f.
    phi_m_i: Matrix4<f64>,
    gam: Matrix4x2<f64>,
    /// `M A = [[A_df, (m2/m_sc) A_sus], [0, A_sus]]`.
    ma: Matrix2<f64>,
    kdf: DiscreteTf,
    ksus: DiscreteTf,
    poles: Vec<Complex64>,
}

/// Dense closed-loop difference equations `ζ[n+1] = A ζ[n] + B_i i[n] + B_g g[n]`,
/// `o[n] = O ζ[n] + n_o[n]`, with `ζ = (X, ξ_df, ξ_sus, delay line)`.
struct StateSpaceLoop {
    a: DMatrix<f64>,
    b_i: DMatrix<f64>,
    b_g: DMatrix<f64>,
    o: DMatrix<f64>,
}

impl DiscreteLoop {
    /// Discretises the loop for parameters `p` (ω², A, δ21; the guidance delays `Δt` only enter
    /// [`Self::at`]), controllers `ctrl`, masses `m`, sample rate `fs` (Hz) and OMS delay
    /// `tau_oms` (s, which must be a whole number of samples). Fails on non-finite input, on a
    /// fractional OMS delay, or if the discrete closed loop is unstable.
    pub fn new(
        p: &LtpParams,
        ctrl: &Controllers,
        m: &Masses,
        fs: f64,
        tau_oms: f64,
    ) -> Result<Self, SimError> {
        if !(fs.is_finite() && fs > 0.0) {
            return Err(SimError::SampleRate(fs));
        }
        if let Some(name) = p.non_finite() {
            return Err(SimError::NonFiniteParam(name));
        }
        for (name, value) in [("m1", m.m1), ("m2", m.m2), ("msc", m.msc)] {
            if !(value.is_finite() && value > 0.0) {
                return Err(SimError::Mass { name, value });
            }
        }
        let samples = tau_oms * fs;
        let whole = samples.round();
        // 1e−9 tolerates the rounding of e.g. 0.3·10 = 3.0000000000000004
        if !(tau_oms.is_finite() && tau_oms >= 0.0)
            || (samples - whole).abs() > 1e-9 * whole.max(1.0)
        {
            return Err(SimError::OmsDelay {
                tau: tau_oms,
                fs,
                samples,
            });
        }
        let e1 = m.m1 / m.msc;
        let e2 = m.m2 / m.msc;
        // D(s) = s² I + W
        let w = [
            [p.w1sq * (1.0 + e1) + e2 * p.w2sq, e2 * p.w2sq],
            [p.w2sq - p.w1sq, p.w2sq],
        ];
        let mut ap = DMatrix::<f64>::zeros(4, 4);
        let mut bp = DMatrix::<f64>::zeros(4, 2);
        for i in 0..2 {
            ap[(i, 2 + i)] = 1.0;
            bp[(2 + i, i)] = 1.0;
            for j in 0..2 {
                ap[(2 + i, j)] = -w[i][j];
            }
        }
        let (phi, gam) = zoh(&ap, &bp, 1.0 / fs)?;
        let phi = Matrix4::from_fn(|i, j| phi[(i, j)]);
        let gam = Matrix4x2::from_fn(|i, j| gam[(i, j)]);
        let mut lp = Self {
            fs,
            delay: whole as usize,
            dt: [p.dt1, p.dt2],
            d21: p.d21,
            phi,
            phi_m_i: phi - Matrix4::identity(),
            gam,
            ma: Matrix2::new(p.a_df, e2 * p.a_sus, 0.0, p.a_sus),
            kdf: DiscreteTf::tustin(&ctrl.df, fs, None)?,
            ksus: DiscreteTf::tustin(&ctrl.sus, fs, None)?,
            poles: Vec::new(),
        };
        lp.poles = lp
            .state_space()
            .a
            .complex_eigenvalues()
            .iter()
            .map(|z| Complex64::new(z.re, z.im))
            .collect();
        if let Some(z) = lp.poles.iter().find(|z| z.norm() >= 1.0) {
            return Err(SimError::Unstable {
                fs,
                re: z.re,
                im: z.im,
                modulus: z.norm(),
            });
        }
        Ok(lp)
    }

    /// The sample rate (Hz).
    pub fn fs(&self) -> f64 {
        self.fs
    }

    /// The OMS delay in samples.
    pub fn oms_delay_samples(&self) -> usize {
        self.delay
    }

    /// The discrete closed-loop poles (z-plane; all inside the unit circle). A pole `z`
    /// corresponds to `s = fs·ln z`; the slowest decays by `|z|` per sample.
    pub fn poles(&self) -> &[Complex64] {
        &self.poles
    }

    /// The exact frequency response of the discrete loop at `f` (Hz), `0 < f ≤ fs/2`, in the
    /// layout of [`ClosedLoop`] so it can replace [`ClosedLoop::at`]:
    /// * `h_io` includes the guidance delays `T = diag(e^{−i2πfΔt1}, e^{−i2πfΔt2})` applied
    ///   exactly (the simulator expects injections already delayed; there `Δt` plays no role);
    /// * `h_go` is the response to `g` held constant over each sample;
    /// * `h_no` is the response of the measured outputs to readout noise `n_o`.
    ///
    /// # Formula
    /// With `z = e^{i2πf/fs}`, `P(z) = [I 0](zI − Φ)⁻¹Γ`, `G = z^{−d} S P`,
    /// `L = G M A K(z)` and `R = (I + L)⁻¹`: `h_io = R L T`, `h_go = R G`, `h_no = R`.
    /// Allocation-free.
    pub fn at(&self, f: f64) -> Result<ClosedLoop, SimError> {
        let nyquist = 0.5 * self.fs;
        if !(f.is_finite() && f > 0.0 && f <= nyquist) {
            return Err(SimError::Frequency { f, nyquist });
        }
        let c = |x: f64| Complex64::new(x, 0.0);
        let th = 2.0 * PI * f / self.fs;
        let z = Complex64::from_polar(1.0, th);
        // z − 1 without cancellation
        let zm1 = Complex64::new(-2.0 * (0.5 * th).sin().powi(2), th.sin());
        let zi_phi = Matrix4::from_fn(|i, j| {
            let id = if i == j { zm1 } else { c(0.0) };
            id - self.phi_m_i[(i, j)]
        });
        let x = zi_phi
            .lu()
            .solve(&self.gam.map(c))
            .ok_or(SimError::Singular(f))?;
        let e = Complex64::from_polar(1.0, -(self.delay as f64) * th);
        let s = Matrix2::new(c(1.0), c(0.0), c(self.d21), c(1.0));
        let g = s * Matrix2::new(x[(0, 0)], x[(0, 1)], x[(1, 0)], x[(1, 1)]) * e;
        let k = Matrix2::new(self.kdf.eval_z(z), c(0.0), c(0.0), self.ksus.eval_z(z));
        let l = g * self.ma.map(c) * k;
        let r = (Matrix2::identity() + l)
            .try_inverse()
            .ok_or(SimError::Singular(f))?;
        let t = Matrix2::new(
            crate::lti::delay(self.dt[0], f),
            c(0.0),
            c(0.0),
            crate::lti::delay(self.dt[1], f),
        );
        let arr = |m: Matrix2<Complex64>| [[m[(0, 0)], m[(0, 1)]], [m[(1, 0)], m[(1, 1)]]];
        let rg = r * g;
        if !(rg.iter().chain(r.iter()).all(|v| v.re.is_finite() && v.im.is_finite())) {
            return Err(SimError::Singular(f));
        }
        Ok(ClosedLoop {
            h_io: arr(r * l * t),
            h_go: arr(rg),
            h_no: arr(r),
        })
    }

    /// Runs the discrete loop from rest over the injections `i1`, `i12` (m; already delayed by
    /// the guidance delays), optional forces per unit mass `g = [g_x1, g_x12]` (m s⁻², the rows
    /// of `G f` in ltp-model.md §2.1, held over each sample) and optional readout noise
    /// `n_o = [n1, n12]` (m, added to the measured outputs inside the loop). Returns the measured
    /// outputs `[o1, o12]` (m), one sample per input sample.
    ///
    /// All series must have the length of `i1` and finite values. Only the outputs are
    /// allocated; the per-sample work allocates nothing.
    ///
    /// ```
    /// use occam::ltp::timedomain::{DEFAULT_FS, DiscreteLoop};
    /// use occam::ltp::{Controllers, LtpParams, Masses};
    /// let p = LtpParams::default();
    /// let lp = DiscreteLoop::new(&p, &Controllers::default(), &Masses::default(), DEFAULT_FS, 0.0)
    ///     .unwrap();
    /// // a 1 nm step on the x1 guidance: the spacecraft follows, o1 settles on 1 nm
    /// let n = 40_000; // 4000 s
    /// let i1 = vec![1e-9; n];
    /// let [o1, _o12] = lp.simulate(&i1, &vec![0.0; n], None, None).unwrap();
    /// assert!((o1[n - 1] - 1e-9).abs() < 1e-12);
    /// ```
    pub fn simulate(
        &self,
        i1: &[f64],
        i12: &[f64],
        g: Option<[&[f64]; 2]>,
        n_o: Option<[&[f64]; 2]>,
    ) -> Result<[Vec<f64>; 2], SimError> {
        let n = i1.len();
        check_series("i1", i1, n)?;
        check_series("i12", i12, n)?;
        if let Some([a, b]) = g {
            check_series("g_x1", a, n)?;
            check_series("g_x12", b, n)?;
        }
        if let Some([a, b]) = n_o {
            check_series("n1", a, n)?;
            check_series("n12", b, n)?;
        }
        let mut fdf = IirFilter::new(&self.kdf);
        let mut fsus = IirFilter::new(&self.ksus);
        let mut line = vec![[0.0; 2]; self.delay];
        let mut head = 0;
        let mut x = Vector4::<f64>::zeros();
        let mut o1 = Vec::with_capacity(n);
        let mut o12 = Vec::with_capacity(n);
        for k in 0..n {
            let sx = [x[0], self.d21 * x[0] + x[1]];
            let mut o = if self.delay == 0 {
                sx
            } else {
                // the line holds S x[k−d .. k−1]; `head` is the oldest
                let old = line[head];
                line[head] = sx;
                head = (head + 1) % self.delay;
                old
            };
            if let Some([a, b]) = n_o {
                o[0] += a[k];
                o[1] += b[k];
            }
            let u = Vector2::new(-fdf.step(o[0] - i1[k]), -fsus.step(o[1] - i12[k]));
            let mut acc = self.ma * u;
            if let Some([a, b]) = g {
                acc[0] += a[k];
                acc[1] += b[k];
            }
            x = self.phi * x + self.gam * acc;
            o1.push(o[0]);
            o12.push(o[1]);
        }
        Ok([o1, o12])
    }

    /// The dense closed-loop difference equations (used for the poles and as a test oracle).
    fn state_space(&self) -> StateSpaceLoop {
        let sdf = self.kdf.to_state_space();
        let ssus = self.ksus.to_state_space();
        let (n1, n2) = (sdf.a.nrows(), ssus.a.nrows());
        let (odf, osus, oq) = (4, 4 + n1, 4 + n1 + n2);
        let n = oq + 2 * self.delay;
        let s = [[1.0, 0.0], [self.d21, 1.0]];
        // o = O ζ: the plant positions, or the oldest entry of the delay line
        let mut o = DMatrix::<f64>::zeros(2, n);
        for i in 0..2 {
            for j in 0..2 {
                if self.delay == 0 {
                    o[(i, j)] = s[i][j];
                }
            }
            if self.delay > 0 {
                o[(i, oq + 2 * (self.delay - 1) + i)] = 1.0;
            }
        }
        let mut a = DMatrix::<f64>::zeros(n, n);
        let mut b_i = DMatrix::<f64>::zeros(n, 2);
        let mut b_g = DMatrix::<f64>::zeros(n, 2);
        // controller channel k: v_k = C_k ξ_k + D_k (O_k ζ − i_k), ξ_k ← A_k ξ_k + B_k (O_k ζ − i_k)
        // v as a row map of ζ and of i
        let mut v_z = DMatrix::<f64>::zeros(2, n);
        let mut v_i = DMatrix::<f64>::zeros(2, 2);
        for (ch, ss, off) in [(0usize, &sdf, odf), (1, &ssus, osus)] {
            let nk = ss.a.nrows();
            for c in 0..nk {
                v_z[(ch, off + c)] += ss.c[c];
            }
            for j in 0..n {
                v_z[(ch, j)] += ss.d * o[(ch, j)];
            }
            v_i[(ch, ch)] = -ss.d;
            for r in 0..nk {
                for c in 0..nk {
                    a[(off + r, off + c)] = ss.a[(r, c)];
                }
                for j in 0..n {
                    a[(off + r, j)] += ss.b[r] * o[(ch, j)];
                }
                b_i[(off + r, ch)] = -ss.b[r];
            }
        }
        // X ← Φ X + Γ (M A (−v) + g)
        let gam = DMatrix::from_fn(4, 2, |i, j| self.gam[(i, j)]);
        let gma = &gam * DMatrix::from_fn(2, 2, |i, j| self.ma[(i, j)]);
        let xa = -&gma * &v_z;
        let xb = -&gma * &v_i;
        for i in 0..4 {
            for j in 0..4 {
                a[(i, j)] += self.phi[(i, j)];
            }
            for j in 0..n {
                a[(i, j)] += xa[(i, j)];
            }
            for j in 0..2 {
                b_i[(i, j)] = xb[(i, j)];
                b_g[(i, j)] = gam[(i, j)];
            }
        }
        // delay line: q_1 ← S x, q_j ← q_{j−1}
        for q in 0..self.delay {
            for i in 0..2 {
                let row = oq + 2 * q + i;
                if q == 0 {
                    for j in 0..2 {
                        a[(row, j)] = s[i][j];
                    }
                } else {
                    a[(row, row - 2)] = 1.0;
                }
            }
        }
        StateSpaceLoop { a, b_i, b_g, o }
    }
}

fn check_series(name: &'static str, x: &[f64], want: usize) -> Result<(), SimError> {
    if x.len() != want {
        return Err(SimError::Length {
            name,
            got: x.len(),
            want,
        });
    }
    match x.iter().position(|v| !v.is_finite()) {
        Some(index) => Err(SimError::NonFiniteInput { name, index }),
        None => Ok(()),
    }
}

/// Simulates the discretised loop at sample rate `fs` with no OMS delay and no readout noise:
/// see [`DiscreteLoop::simulate`]. Returns `[o1, o12]`.
///
/// ```
/// use occam::ltp::timedomain::{DEFAULT_FS, simulate};
/// use occam::ltp::{Controllers, LtpParams, Masses};
/// let (p, c, m) = (LtpParams::default(), Controllers::default(), Masses::default());
/// let i12 = vec![0.0; 100];
/// let i1: Vec<f64> = (0..100).map(|n| 1e-9 * (0.02 * n as f64).sin()).collect();
/// let [o1, o12] = simulate(&p, &c, &m, DEFAULT_FS, &i1, &i12, None).unwrap();
/// assert_eq!((o1.len(), o12.len()), (100, 100));
/// assert_eq!(o1[0], 0.0); // from rest, and the plant has no feed-through
/// ```
pub fn simulate(
    p: &LtpParams,
    ctrl: &Controllers,
    m: &Masses,
    fs: f64,
    i1: &[f64],
    i12: &[f64],
    g: Option<[&[f64]; 2]>,
) -> Result<[Vec<f64>; 2], SimError> {
    DiscreteLoop::new(p, ctrl, m, fs, 0.0)?.simulate(i1, i12, g, None)
}

/// The exact `H_io(e^{i2πf/fs})` of the discretised loop (no OMS delay), guidance delays
/// included: see [`DiscreteLoop::at`]. Builds the discretisation on every call; for many
/// frequencies build a [`DiscreteLoop`] once.
pub fn discrete_h_io(
    p: &LtpParams,
    ctrl: &Controllers,
    m: &Masses,
    fs: f64,
    f: f64,
) -> Result<[[Complex64; 2]; 2], SimError> {
    Ok(DiscreteLoop::new(p, ctrl, m, fs, 0.0)?.at(f)?.h_io)
}

/// How far the discrete `H_io` is from the continuous one at one frequency, per entry
/// (rows = outputs `(o1, o12)`, columns = injections `(i1, i12)`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Discrepancy {
    /// Frequency (Hz).
    pub f: f64,
    /// `|H_disc/H_cont − 1|`.
    pub rel: [[f64; 2]; 2],
    /// Amplitude error `|H_disc|/|H_cont| − 1`.
    pub amp: [[f64; 2]; 2],
    /// Phase difference `arg(H_disc/H_cont)` (rad).
    pub phase: [[f64; 2]; 2],
}

/// Compares the discretised loop at `fs` ([`DiscreteLoop::at`]) with the continuous loop
/// ([`ClosedLoop::at`]), both with OMS delay `tau_oms`, at each frequency of `freqs`.
pub fn discretisation_discrepancy(
    p: &LtpParams,
    ctrl: &Controllers,
    m: &Masses,
    fs: f64,
    tau_oms: f64,
    freqs: &[f64],
) -> Result<Vec<Discrepancy>, SimError> {
    let lp = DiscreteLoop::new(p, ctrl, m, fs, tau_oms)?;
    freqs
        .iter()
        .map(|&f| {
            let hd = lp.at(f)?.h_io;
            let hc = ClosedLoop::at(p, &BinConsts::new(f, ctrl, tau_oms), m).h_io;
            let mut out = Discrepancy {
                f,
                rel: [[0.0; 2]; 2],
                amp: [[0.0; 2]; 2],
                phase: [[0.0; 2]; 2],
            };
            for i in 0..2 {
                for j in 0..2 {
                    let q = hd[i][j] / hc[i][j];
                    out.rel[i][j] = (q - 1.0).norm();
                    out.amp[i][j] = q.norm() - 1.0;
                    out.phase[i][j] = q.arg();
                }
            }
            Ok(out)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn setup(dt: f64) -> (LtpParams, Controllers, Masses) {
        let p = LtpParams {
            dt1: dt,
            dt2: dt,
            ..Default::default()
        };
        (p, Controllers::default(), Masses::default())
    }

    /// Cosine of frequency `f` on input channel `col` (0 i1, 1 i12, 2 g_x1, 3 g_x12, 4 n1,
    /// 5 n12) for `n` samples from rest; returns the outputs and the matching column of the
    /// exact response (h_io, h_go or h_no).
    fn drive(lp: &DiscreteLoop, col: usize, f: f64, n: usize) -> ([Vec<f64>; 2], [Complex64; 2]) {
        let w = 2.0 * PI * f / lp.fs();
        let cosine: Vec<f64> = (0..n).map(|k| (w * k as f64).cos()).collect();
        let zero = vec![0.0; n];
        let mut ch: [&[f64]; 6] = [&zero; 6];
        ch[col] = &cosine;
        let g = (col / 2 == 1).then_some([ch[2], ch[3]]);
        let no = (col / 2 == 2).then_some([ch[4], ch[5]]);
        let out = lp.simulate(ch[0], ch[1], g, no).unwrap();
        let cl = lp.at(f).unwrap();
        let h = match col / 2 {
            0 => cl.h_io,
            1 => cl.h_go,
            _ => cl.h_no,
        };
        (out, [h[0][col % 2], h[1][col % 2]])
    }

    /// The start-up transient of the outputs for the drive of [`drive`], from the dense
    /// closed-loop state space: ε[k] = A^k (0 − ζ_ss[0]), transient = O ε[k].
    fn transient(lp: &DiscreteLoop, col: usize, f: f64, n: usize) -> [Vec<f64>; 2] {
        let ss = lp.state_space();
        let dim = ss.a.nrows();
        let b = match col / 2 {
            0 => ss.b_i.column(col % 2).into_owned(),
            1 => ss.b_g.column(col % 2).into_owned(),
            // readout noise enters the error exactly like a negative injection
            _ => -ss.b_i.column(col % 2).into_owned(),
        };
        let z = Complex64::from_polar(1.0, 2.0 * PI * f / lp.fs());
        let m = DMatrix::<Complex64>::from_fn(dim, dim, |i, j| {
            let id = if i == j { z } else { Complex64::new(0.0, 0.0) };
            id - ss.a[(i, j)]
        });
        let zss = m.lu().solve(&b.map(|x| Complex64::new(x, 0.0))).unwrap();
        let mut eps = nalgebra::DVector::from_fn(dim, |i, _| -zss[i].re);
        let mut next = eps.clone();
        let mut out = [Vec::with_capacity(n), Vec::with_capacity(n)];
        for _ in 0..n {
            for (i, o) in out.iter_mut().enumerate() {
                o.push(ss.o.row(i).dot(&eps.transpose()));
            }
            next.gemv(1.0, &ss.a, &eps, 0.0);
            std::mem::swap(&mut eps, &mut next);
        }
        out
    }

    #[test]
    fn explore() {
        let (p, c, m) = setup(0.0);
        let lp = DiscreteLoop::new(&p, &c, &m, 10.0, 0.0).unwrap();
        let n = 250_000;
        for (col, f) in [(0, 1e-3), (1, 1e-3), (0, 0.05), (1, 0.05), (2, 0.01), (3, 0.01), (4, 0.02), (5, 0.02)] {
            let (out, h) = drive(&lp, col, f, n);
            let tr = transient(&lp, col, f, n);
            let w = 2.0 * PI * f / 10.0;
            for i in 0..2 {
                let mut max_dev: f64 = 0.0;
                let mut max_res: f64 = 0.0;
                let mut max_tr: f64 = 0.0;
                let mut max_tr_start: f64 = 0.0;
                for k in 0..n {
                    let ss = (h[i] * Complex64::from_polar(1.0, w * k as f64)).re;
                    let dev = out[i][k] - ss;
                    let res = dev - tr[i][k];
                    max_res = max_res.max(res.abs());
                    if k >= n - 20_000 {
                        max_dev = max_dev.max(dev.abs());
                        max_tr = max_tr.max(tr[i][k].abs());
                    } else {
                        max_tr_start = max_tr_start.max(tr[i][k].abs());
                    }
                }
                let hn = h[i].norm();
                println!("col {col} f {f} out {i}: |H| {hn:.3e} dev/|H| {:.2e} tr/|H| {:.2e} maxtr(all)/|H| {:.2e} res(all)/|H| {:.2e}", max_dev / hn, max_tr / hn, max_tr_start / hn, max_res / hn);
            }
        }
        let f = 1e-3;
        let t = 0.05;
        let h0 = ClosedLoop::at(&p, &BinConsts::new(f, &c, 0.0), &m).h_io;
        let _ = (h0, t);
        for f in [1e-4, 1e-3, 3e-3, 1e-2, 3e-2, 0.1, 0.3, 1.0] {
            let hd = lp.at(f).unwrap().h_io;
            let hc = ClosedLoop::at(&p, &BinConsts::new(f, &c, 0.05), &m).h_io;
            let wt = 2.0 * PI * f / 10.0;
            print!("{f:.1e} (wT)^2={:.2e}:", wt * wt);
            for i in 0..2 { for j in 0..2 { print!(" {:.2e}", (hd[i][j] / hc[i][j] - 1.0).norm()); } }
            println!();
        }
        // step
        let nn = 40_000;
        let [o1, _] = lp.simulate(&vec![1e-9; nn], &vec![0.0; nn], None, None).unwrap();
        for k in [10_000, 20_000, 39_999] { println!("step o1[{k}] = {:.6e}", o1[k]); }
    }
}
