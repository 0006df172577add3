//! Closed-loop transfer matrices of the 1-D LTP (ltp-model.md §3.2), and the closed-loop poles.
//!
//! The per-bin response is generic over the scalar type so that the same code gives values
//! (`f64`) and exact parameter derivatives (`num_dual` dual numbers) for the Fisher matrix.

use super::controllers::Controllers;
use super::params::{LtpParams, Masses, N_PARAMS, PARAM_NAMES};
use nalgebra::DMatrix;
use num_complex::{Complex, Complex64};
use num_dual::DualNum;
use std::f64::consts::PI;

/// Errors of the closed-loop model.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum LoopError {
    #[error(
        "the closed loop is unstable for these parameters: pole at {re:.4e} {im:+.4e}i rad/s \
         (every pole needs a negative real part); check the parameter `{hint}` and the controllers"
    )]
    Unstable { re: f64, im: f64, hint: String },
    #[error("parameter `{0}` is not a finite number")]
    NonFinite(&'static str),
    #[error("controller: {0}")]
    Controller(#[from] crate::lti::LtiError),
}

/// θ-independent quantities at one frequency: computed once per bin, reused for every θ.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BinConsts {
    /// Frequency (Hz).
    pub f: f64,
    /// Angular frequency `2πf` (rad/s).
    pub omega: f64,
    /// Drag-free controller response `C_df(i2πf)`.
    pub cdf: Complex64,
    /// Suspension controller response `C_sus(i2πf)`.
    pub csus: Complex64,
    /// Optional fixed OMS delay `E = e^{−i2πf τ_o}`.
    pub e_oms: Complex64,
    /// `E·C_df`, `E·C_sus` (precomputed for the fast kernel).
    pub e_cdf: Complex64,
    pub e_csus: Complex64,
}

impl BinConsts {
    /// Precomputes the controller and OMS-delay responses at `f`.
    pub fn new(f: f64, ctrl: &Controllers, tau_oms: f64) -> Self {
        let cdf = ctrl.df.eval_freq(f);
        let csus = ctrl.sus.eval_freq(f);
        let e_oms = crate::lti::delay(tau_oms, f);
        Self {
            f,
            omega: 2.0 * PI * f,
            cdf,
            csus,
            e_oms,
            e_cdf: e_oms * cdf,
            e_csus: e_oms * csus,
        }
    }
}

/// The θ-dependent scalars of the loop, computed once per θ, for the allocation-free `f64`
/// hot path of the likelihood. Gives the same values as [`response`] (a test checks it) with
/// fewer operations: one complex reciprocal per bin and the delay phasors supplied by the
/// caller (who can generate them by recurrence on a uniform grid).
#[derive(Debug, Clone, Copy)]
pub struct LoopKernel {
    a00: f64,
    a01: f64,
    a10: f64,
    w2: f64,
    adf: f64,
    asus: f64,
    d21: f64,
    e2: f64,
    d21e2: f64,
}

impl LoopKernel {
    /// Precomputes the parameter combinations of `D` and `M A K S`.
    #[inline]
    pub fn new(th: &[f64; N_PARAMS], m: &Masses) -> Self {
        let e1 = m.m1 / m.msc;
        let e2 = m.m2 / m.msc;
        Self {
            a00: th[0] * (1.0 + e1) + th[1] * e2,
            a01: th[1] * e2,
            a10: th[1] - th[0],
            w2: th[1],
            adf: th[4],
            asus: th[5],
            d21: th[6],
            e2,
            d21e2: th[6] * e2,
        }
    }

    /// `H_io(f) (t ⊙ I)` at one bin, where `t = (e^{−iωΔt1}, e^{−iωΔt2})` are the guidance-delay
    /// phasors at this bin.
    #[inline(always)]
    pub fn eval(&self, c: &BinConsts, t: [Complex64; 2], inj: [Complex64; 2]) -> [Complex64; 2] {
        let s2 = -c.omega * c.omega;
        let ek1 = c.e_cdf * self.adf;
        let ek2 = c.e_csus * self.asus;
        let p00 = ek1 + ek2 * self.d21e2 + (s2 + self.a00);
        let p01 = ek2 * self.e2 + self.a01;
        let p10 = ek2 * self.d21 + self.a10;
        let p11 = ek2 + (s2 + self.w2);
        let inv = (p00 * p11 - p01 * p10).inv();
        let v1 = t[0] * inj[0];
        let v2 = t[1] * inj[1];
        let k1v1 = c.cdf * v1 * self.adf;
        let k2v2 = c.csus * v2 * self.asus;
        let w0 = k1v1 + k2v2 * self.e2;
        let x0 = (p11 * w0 - p01 * k2v2) * inv;
        let x1 = (p00 * k2v2 - p10 * w0) * inv;
        [c.e_oms * x0, c.e_oms * (x0 * self.d21 + x1)]
    }
}

#[inline(always)]
pub(crate) fn lift<T: DualNum<Primitive = f64> + Copy>(z: Complex64) -> Complex<T> {
    Complex::new(T::from(z.re), T::from(z.im))
}

/// `P = D + E M A K S` and the actuator terms `k1 = A_df r_df C_df`, `k2 = A_sus r_sus C_sus`,
/// for any plant matrix `D` (continuous `s² I + W`, or the inverse of the held plant of the
/// discrete loop) and controller responses `(C_df, C_sus)`. `r_sus` is the frequency response
/// of the TM2 actuator beyond its gain (`None`: flat, the K14 loop; kept apart from `Some(1)`
/// so that the plain loop's arithmetic, and hence its numbers, stay exactly as they were).
#[inline(always)]
#[allow(clippy::type_complexity)]
pub(crate) fn close_loop<T: DualNum<Primitive = f64> + Copy>(
    th: &[T; N_PARAMS],
    d: [[Complex<T>; 2]; 2],
    e: Complex<T>,
    ctrl: (Complex64, Complex64),
    m: &Masses,
    r_df: Complex<T>,
    r_sus: Option<Complex<T>>,
) -> ([[Complex<T>; 2]; 2], Complex<T>, Complex<T>) {
    let (adf, asus, d21) = (th[4], th[5], th[6]);
    let e2 = m.m2 / m.msc;
    let k1 = lift::<T>(ctrl.0) * r_df * adf;
    let k2 = match r_sus {
        None => lift::<T>(ctrl.1) * asus,
        Some(r) => lift::<T>(ctrl.1) * r * asus,
    };
    let p00 = d[0][0] + e * (k1 + k2 * (d21 * e2));
    let p01 = d[0][1] + e * k2 * T::from(e2);
    let p10 = d[1][0] + e * k2 * d21;
    let p11 = d[1][1] + e * k2;
    ([[p00, p01], [p10, p11]], k1, k2)
}

/// `H_io = E S P⁻¹ M A K T` from the closed-loop matrix `P` and actuator terms of
/// [`close_loop`], with the guidance delays `T = diag(e^{−iωΔt1}, e^{−iωΔt2})`.
#[inline(always)]
pub(crate) fn h_io_of_loop<T: DualNum<Primitive = f64> + Copy>(
    th: &[T; N_PARAMS],
    (p, k1, k2): ([[Complex<T>; 2]; 2], Complex<T>, Complex<T>),
    e: Complex<T>,
    omega: f64,
    m: &Masses,
) -> [[Complex<T>; 2]; 2] {
    let [[p00, p01], [p10, p11]] = p;
    let d21 = th[6];
    let e2 = T::from(m.m2 / m.msc);
    let inv = (p00 * p11 - p01 * p10).inv();
    let (s1, c1) = (th[2] * omega).sin_cos();
    let (s2, c2) = (th[3] * omega).sin_cos();
    let a = k1 * Complex::new(c1, -s1) * inv;
    let b = k2 * Complex::new(c2, -s2) * inv;
    // X = P⁻¹ M A K T, M A K T = [[k1 t1, e2 k2 t2], [0, k2 t2]]
    let x00 = p11 * a;
    let x10 = -p10 * a;
    let x01 = (p11 * e2 - p01) * b;
    let x11 = (p00 - p10 * e2) * b;
    [
        [e * x00, e * x01],
        [e * (x00 * d21 + x10), e * (x01 * d21 + x11)],
    ]
}

/// The continuous plant matrix `D(s) = s² I + W` (ltp-model.md §2.1, full `D`).
#[inline(always)]
fn plant<T: DualNum<Primitive = f64> + Copy>(
    th: &[T; N_PARAMS],
    omega: f64,
    m: &Masses,
) -> [[Complex<T>; 2]; 2] {
    let (w1, w2) = (th[0], th[1]);
    let e1 = m.m1 / m.msc;
    let e2 = m.m2 / m.msc;
    let s2 = T::from(-omega * omega);
    let re = |x: T| Complex::new(x, T::from(0.0));
    [
        [re(s2 + w1 * (1.0 + e1) + w2 * e2), re(w2 * e2)],
        [re(w2 - w1), re(s2 + w2)],
    ]
}

/// `P = D + E M A K S` of the continuous loop and its actuator terms.
#[inline(always)]
#[allow(clippy::type_complexity)]
fn loop_matrix<T: DualNum<Primitive = f64> + Copy>(
    th: &[T; N_PARAMS],
    c: &BinConsts,
    m: &Masses,
    r_df: Complex<T>,
    r_sus: Option<Complex<T>>,
) -> ([[Complex<T>; 2]; 2], Complex<T>, Complex<T>) {
    close_loop(
        th,
        plant(th, c.omega, m),
        lift(c.e_oms),
        (c.cdf, c.csus),
        m,
        r_df,
        r_sus,
    )
}

/// The output response `h = H_io(f; θ) · I` to the injection DFT `inj = (I1, I2)` at one bin.
///
/// # Formula
/// `w = M A K T I`, `x = P⁻¹ w` with `P = D + E M A K S`, `h = E S x`.
///
/// ```
/// use occam::ltp::{BinConsts, Controllers, LtpParams, Masses, response};
/// use num_complex::Complex64;
/// let c = BinConsts::new(1e-4, &Controllers::default(), 0.0);
/// let th = LtpParams::default().to_array();
/// let one = Complex64::new(1.0, 0.0);
/// let h = response(&th, &c, &Masses::default(), [one, Complex64::new(0.0, 0.0)]);
/// // far below the loop bandwidth the outputs follow the guidance: H_io,11 ≈ 1
/// assert!((h[0] - one).norm() < 1e-3);
/// ```
#[inline]
pub fn response<T: DualNum<Primitive = f64> + Copy>(
    th: &[T; N_PARAMS],
    c: &BinConsts,
    m: &Masses,
    inj: [Complex64; 2],
) -> [Complex<T>; 2] {
    let one = Complex::new(T::one(), T::zero());
    let ([[p00, p01], [p10, p11]], k1, k2) = loop_matrix(th, c, m, one, None);
    let e2 = m.m2 / m.msc;
    // guidance delays act on the injections only: T = diag(e^{−iωΔt1}, e^{−iωΔt2})
    let (s1, c1) = (th[2] * c.omega).sin_cos();
    let (s2, c2) = (th[3] * c.omega).sin_cos();
    let v1 = Complex::new(c1, -s1) * lift::<T>(inj[0]);
    let v2 = Complex::new(c2, -s2) * lift::<T>(inj[1]);
    let w0 = k1 * v1 + k2 * v2 * T::from(e2);
    let w1 = k2 * v2;
    let det = p00 * p11 - p01 * p10;
    let x0 = (p11 * w0 - p01 * w1) / det;
    let x1 = (p00 * w1 - p10 * w0) / det;
    let e: Complex<T> = lift(c.e_oms);
    [e * x0, e * (x0 * th[6] + x1)]
}

/// The full `H_io(f; θ)` (rows `o1, o12`, columns `i1, i12`) with an extra factor `r_df` on the
/// drag-free actuation (`A_df → A_df r_df`; pass 1 for the plain loop), generic over dual
/// numbers.
///
/// # Formula
/// `H_io = E S P⁻¹ M A K T` with `P = D + E M A K S`, `M A K T = [[k1 t1, e2 k2 t2], [0, k2 t2]]`.
#[inline]
pub fn h_io_matrix<T: DualNum<Primitive = f64> + Copy>(
    th: &[T; N_PARAMS],
    c: &BinConsts,
    m: &Masses,
    r_df: Complex<T>,
) -> [[Complex<T>; 2]; 2] {
    h_io_of_loop(
        th,
        loop_matrix(th, c, m, r_df, None),
        lift(c.e_oms),
        c.omega,
        m,
    )
}

/// The response of the outputs `(o1, o12)` to a differential force per unit mass between the
/// test masses that no actuator commands (a glitch, `Δg = g2 − g1` along `x12`, nothing along
/// `x1`), with an extra factor `r_df` on the drag-free actuation as in [`h_io_matrix`], generic
/// over dual numbers.
///
/// # Formula
/// `H_Δg = E S P⁻¹ (0, 1)ᵀ`, the `x12` column of [`ClosedLoop::h_go`]. A force `(a1, a2)` on
/// the test masses enters the coordinates `x1, x12` as `W (a1, a2)`, `W = [[1 + e1, e2],
/// [−1, 1]]` (`e_i = m_i/m_sc`), as the simulator puts a glitch in: `Δg = a2 − a1` plus a
/// force `(1 + e1) a1 + e2 a2` along `x1` that drag-free control hides (on Table I's set-up, for a
/// glitch decaying in 30 s to 3000 s, its amplitude's Cramér–Rao bound is 7e−12 to 4e−11
/// m s⁻², `Δg`'s 5e−16 to 7e−15), which is why a modelled glitch is its `Δg` alone.
#[inline]
pub fn h_dg_column<T: DualNum<Primitive = f64> + Copy>(
    th: &[T; N_PARAMS],
    c: &BinConsts,
    m: &Masses,
    r_df: Complex<T>,
) -> [Complex<T>; 2] {
    let ([[p00, p01], [p10, p11]], _, _) = loop_matrix(th, c, m, r_df, None);
    let inv = (p00 * p11 - p01 * p10).inv();
    let e: Complex<T> = lift(c.e_oms);
    let d21 = th[6];
    // E S P⁻¹ (0, 1)ᵀ, S = [[1, 0], [δ21, 1]]
    [-e * p01 * inv, e * (p00 - p01 * d21) * inv]
}

/// [`h_io_matrix`] with a frequency response `r_sus` of the TM2 (suspension) actuator beyond its
/// gain: `A_sus → A_sus r_sus` (a real pole, a delay; see
/// [`Actuator`](crate::config::Actuator)).
///
/// # Formula
/// `H_io = E S P⁻¹ B_u K T`, `P = D + E B_u K S`, `B_u = [[A_df r_df, e2 A_sus r_sus],
/// [0, A_sus r_sus]]`, `e2 = m2/m_sc`.
#[inline]
pub fn h_io_matrix_actuated<T: DualNum<Primitive = f64> + Copy>(
    th: &[T; N_PARAMS],
    c: &BinConsts,
    m: &Masses,
    r_df: Complex<T>,
    r_sus: Complex<T>,
) -> [[Complex<T>; 2]; 2] {
    h_io_of_loop(
        th,
        loop_matrix(th, c, m, r_df, Some(r_sus)),
        lift(c.e_oms),
        c.omega,
        m,
    )
}

/// The three closed-loop transfer matrices at one frequency (rows = outputs `(o1, o12)`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClosedLoop {
    /// Injections `(i1, i12)` → outputs.
    pub h_io: [[Complex64; 2]; 2],
    /// Forces per unit mass `g` → outputs (m per m s⁻²).
    pub h_go: [[Complex64; 2]; 2],
    /// Readout noise `n_o` → outputs.
    pub h_no: [[Complex64; 2]; 2],
}

impl ClosedLoop {
    /// Evaluates `H_io`, `H_go`, `H_no` at the frequency of `c`.
    pub fn at(p: &LtpParams, c: &BinConsts, m: &Masses) -> Self {
        Self::with_thruster(p, c, m, Complex64::new(1.0, 0.0))
    }

    /// As [`ClosedLoop::at`] with an extra factor `r_df` on the drag-free actuation
    /// (`A_df → A_df r_df`: a thruster response).
    pub fn with_thruster(p: &LtpParams, c: &BinConsts, m: &Masses, r_df: Complex64) -> Self {
        Self::build(p, c, m, r_df, None)
    }

    /// As [`ClosedLoop::with_thruster`] with a frequency response `r_sus` of the TM2 actuator
    /// beyond its gain (`A_sus → A_sus r_sus`). `H_go` stays the response to forces per unit
    /// mass *applied* in coordinate space; `H_io` and `H_no` use `B_u K` in place of `M A K`.
    pub fn with_actuators(
        p: &LtpParams,
        c: &BinConsts,
        m: &Masses,
        r_df: Complex64,
        r_sus: Complex64,
    ) -> Self {
        Self::build(p, c, m, r_df, Some(r_sus))
    }

    fn build(
        p: &LtpParams,
        c: &BinConsts,
        m: &Masses,
        r_df: Complex64,
        r_sus: Option<Complex64>,
    ) -> Self {
        let th = p.to_array();
        let ([[p00, p01], [p10, p11]], k1, k2) = loop_matrix::<f64>(&th, c, m, r_df, r_sus);
        let det = p00 * p11 - p01 * p10;
        let pinv = [[p11 / det, -p01 / det], [-p10 / det, p00 / det]];
        let e = c.e_oms;
        let d21 = p.d21;
        let e2 = m.m2 / m.msc;
        // E S P⁻¹
        let hgo = [
            [e * pinv[0][0], e * pinv[0][1]],
            [
                e * (d21 * pinv[0][0] + pinv[1][0]),
                e * (d21 * pinv[0][1] + pinv[1][1]),
            ],
        ];
        // M A K = [[k1, e2 k2], [0, k2]]
        let mak = [[k1, e2 * k2], [Complex64::new(0.0, 0.0), k2]];
        let mul = |a: &[[Complex64; 2]; 2], b: &[[Complex64; 2]; 2]| {
            let mut o = [[Complex64::new(0.0, 0.0); 2]; 2];
            for i in 0..2 {
                for j in 0..2 {
                    o[i][j] = a[i][0] * b[0][j] + a[i][1] * b[1][j];
                }
            }
            o
        };
        let g = mul(&hgo, &mak);
        let t = [crate::lti::delay(p.dt1, c.f), crate::lti::delay(p.dt2, c.f)];
        let mut h_io = g;
        let mut h_no = g;
        for i in 0..2 {
            for j in 0..2 {
                h_io[i][j] = g[i][j] * t[j];
                let id = if i == j { 1.0 } else { 0.0 };
                h_no[i][j] = id - g[i][j];
            }
        }
        Self {
            h_io,
            h_go: hgo,
            h_no,
        }
    }
}

/// Poles (rad/s) of the continuous closed loop without the OMS delay, from the eigenvalues of
/// the closed-loop state matrix (plant states `x, ẋ` plus controller states). Checks the
/// parameters are finite; does not itself judge stability (see [`check_stable`]).
pub fn closed_loop_poles(
    p: &LtpParams,
    ctrl: &Controllers,
    m: &Masses,
) -> Result<Vec<Complex64>, LoopError> {
    if let Some(n) = p.non_finite() {
        return Err(LoopError::NonFinite(n));
    }
    let kd = ctrl.df.to_state_space()?;
    let ks = ctrl.sus.to_state_space()?;
    let (n1, n2) = (kd.a.nrows(), ks.a.nrows());
    let n = 4 + n1 + n2;
    let e1 = m.m1 / m.msc;
    let e2 = m.m2 / m.msc;
    let w = [
        [p.w1sq * (1.0 + e1) + e2 * p.w2sq, e2 * p.w2sq],
        [p.w2sq - p.w1sq, p.w2sq],
    ];
    // M A = [[A_df, e2 A_sus], [0, A_sus]]; S = [[1, 0], [d21, 1]]
    let ma = [[p.a_df, e2 * p.a_sus], [0.0, p.a_sus]];
    let s = [[1.0, 0.0], [p.d21, 1.0]];
    let dk = [kd.d, ks.d];
    let mut a = DMatrix::<f64>::zeros(n, n);
    for i in 0..2 {
        a[(i, 2 + i)] = 1.0;
        for j in 0..2 {
            // −W − M A D_K S
            let mut v = -w[i][j];
            for k in 0..2 {
                v -= ma[i][k] * dk[k] * s[k][j];
            }
            a[(2 + i, j)] = v;
        }
    }
    let blocks = [(&kd, 4usize, 0usize), (&ks, 4 + n1, 1usize)];
    for (ss, off, ch) in blocks {
        let nk = ss.a.nrows();
        for r in 0..nk {
            for c in 0..nk {
                a[(off + r, off + c)] = ss.a[(r, c)];
            }
            // ξ̇ = A_K ξ + B_K (S x)_ch
            for j in 0..2 {
                a[(off + r, j)] += ss.b[r] * s[ch][j];
            }
        }
        // ẍ_i −= (M A)_{i,ch} C_K ξ
        for i in 0..2 {
            for c in 0..nk {
                a[(2 + i, off + c)] -= ma[i][ch] * ss.c[c];
            }
        }
    }
    Ok(a.complex_eigenvalues()
        .iter()
        .map(|z| Complex64::new(z.re, z.im))
        .collect())
}

/// Fails with [`LoopError::Unstable`] unless every closed-loop pole has a negative real part.
pub fn check_stable(p: &LtpParams, ctrl: &Controllers, m: &Masses) -> Result<(), LoopError> {
    let poles = closed_loop_poles(p, ctrl, m)?;
    if let Some(z) = poles.iter().find(|z| z.re >= 0.0) {
        let hint = PARAM_NAMES.join(", ");
        return Err(LoopError::Unstable {
            re: z.re,
            im: z.im,
            hint,
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn c(re: f64, im: f64) -> Complex64 {
        Complex64::new(re, im)
    }

    /// A tabulated number and half a unit of its last quoted digit.
    fn quoted(s: &str) -> (f64, f64) {
        let v: f64 = s.parse().unwrap();
        let (mant, exp) = match s.split_once('e') {
            Some((m, e)) => (m, e.parse::<i32>().unwrap()),
            None => (s, 0),
        };
        let decimals = mant.split_once('.').map_or(0, |(_, d)| d.len()) as i32;
        (v, 0.5 * 10f64.powi(exp - decimals))
    }

    #[test]
    fn matches_the_section_3_3_table() {
        // ltp-model.md §3.3: H_io complex (re, im per entry), |H_go| and |H_no|, θ = Table I,
        // τ_o = 0. Each number must agree to within half a unit of its last quoted digit.
        type Row = (
            f64,
            [[(&'static str, &'static str); 2]; 2],
            [[&'static str; 2]; 2],
            [[&'static str; 2]; 2],
        );
        let table: [Row; 5] = [
            (
                1e-4,
                [
                    [("1.0000", "-1.25e-4"), ("1.4e-11", "-2.6e-10")],
                    [("3.73e-2", "2.03e-2"), ("1.143", "7.76e-2")],
                ],
                [["0.124", "5.9e-4"], ["5.3e-3", "7.09e4"]],
                [["2.1e-7", "2.6e-10"], ["4.2e-2", "0.163"]],
            ),
            (
                1e-3,
                [
                    [("1.0000", "-1.21e-3"), ("-2.26e-7", "-9.0e-8")],
                    [("-6.59e-3", "-1.32e-2"), ("0.5325", "-0.9358")],
                ],
                [["1.233", "6.0e-3"], ["1.82e-2", "2.53e4"]],
                [["5.0e-5", "2.4e-7"], ["1.47e-2", "1.045"]],
            ),
            (
                1e-2,
                [
                    [("1.0299", "1.43e-3"), ("4.45e-6", "4.55e-6")],
                    [("2.65e-4", "4.1e-6"), ("-3.90e-2", "-1.41e-2")],
                ],
                [["8.39", "1.6e-3"], ["2.2e-3", "263"]],
                [["3.3e-2", "6.4e-6"], ["2.7e-4", "1.039"]],
            ),
            (
                0.1,
                [
                    [("0.1428", "-0.9742"), ("-1.63e-6", "-1.75e-6")],
                    [("5.70e-5", "-3.88e-4"), ("-4.28e-4", "3.83e-5")],
                ],
                [["3.04", "6.0e-6"], ["1.2e-3", "2.53"]],
                [["1.20", "2.4e-6"], ["3.9e-4", "1.000"]],
            ),
            (
                1.0,
                [
                    [("-5.34e-3", "2.74e-2"), ("-6.3e-9", "1.95e-8")],
                    [("-2.14e-6", "1.10e-5"), ("-1.34e-6", "4.08e-6")],
                ],
                [["2.6e-2", "5e-10"], ["1.0e-5", "2.5e-2"]],
                [["1.03", "2e-8"], ["1.1e-5", "1.000"]],
            ),
        ];
        let ctrl = Controllers::default();
        let m = Masses::default();
        let p = LtpParams::default();
        let mut checked = 0;
        for (f, hio, hgo, hno) in table {
            let cl = ClosedLoop::at(&p, &BinConsts::new(f, &ctrl, 0.0), &m);
            for i in 0..2 {
                for j in 0..2 {
                    let got = cl.h_io[i][j];
                    for (part, g, s) in [("re", got.re, hio[i][j].0), ("im", got.im, hio[i][j].1)] {
                        let (want, tol) = quoted(s);
                        assert!(
                            (g - want).abs() <= tol * (1.0 + 1e-9),
                            "{part} H_io[{i}][{j}] at {f} Hz: got {g:.5e}, table {s}"
                        );
                        checked += 1;
                    }
                    for (name, g, s) in [
                        ("H_go", cl.h_go[i][j].norm(), hgo[i][j]),
                        ("H_no", cl.h_no[i][j].norm(), hno[i][j]),
                    ] {
                        let (want, tol) = quoted(s);
                        assert!(
                            (g - want).abs() <= tol * (1.0 + 1e-9),
                            "|{name}[{i}][{j}]| at {f} Hz: got {g:.5e}, table {s}"
                        );
                        checked += 1;
                    }
                }
            }
        }
        assert_eq!(checked, 80);
    }

    #[test]
    fn fast_kernel_equals_generic_response() {
        let ctrl = Controllers::default();
        let m = Masses::default();
        let p = LtpParams {
            dt1: 0.13,
            dt2: 0.41,
            ..Default::default()
        };
        let th = p.to_array();
        let kern = LoopKernel::new(&th, &m);
        for f in [1e-4, 3e-3, 0.05, 0.7, 4.0] {
            let bc = BinConsts::new(f, &ctrl, 0.3);
            let inj = [c(0.3, -1.1), c(-2.0, 0.4)];
            let t = [crate::lti::delay(p.dt1, f), crate::lti::delay(p.dt2, f)];
            let a = kern.eval(&bc, t, inj);
            let b = response(&th, &bc, &m, inj);
            for i in 0..2 {
                assert!(
                    (a[i] - b[i]).norm() <= 1e-13 * b[i].norm(),
                    "{f}: {a:?} vs {b:?}"
                );
            }
        }
    }

    #[test]
    fn response_equals_matrix_times_injection() {
        let ctrl = Controllers::default();
        let m = Masses::default();
        let p = LtpParams::default();
        for f in [2e-4, 3e-3, 0.05, 0.7] {
            let bc = BinConsts::new(f, &ctrl, 0.3);
            let cl = ClosedLoop::at(&p, &bc, &m);
            let inj = [c(0.3, -1.1), c(-2.0, 0.4)];
            let h = response(&p.to_array(), &bc, &m, inj);
            for i in 0..2 {
                let want = cl.h_io[i][0] * inj[0] + cl.h_io[i][1] * inj[1];
                assert!((h[i] - want).norm() < 1e-12 * want.norm());
            }
        }
    }

    /// The force response of the model layer is the simulator's glitch path for a force along
    /// `x12`: the second column of `H_go`.
    #[test]
    fn differential_force_response_is_the_x12_column_of_h_go() {
        let ctrl = Controllers::default();
        let m = Masses::default();
        let p = LtpParams {
            d21: 3e-3,
            ..Default::default()
        };
        for f in [2e-4, 3e-3, 0.05, 0.7] {
            let bc = BinConsts::new(f, &ctrl, 0.3);
            let cl = ClosedLoop::at(&p, &bc, &m);
            let h = h_dg_column(&p.to_array(), &bc, &m, c(1.0, 0.0));
            for r in 0..2 {
                let want = cl.h_go[r][1];
                assert!((h[r] - want).norm() < 1e-12 * want.norm(), "{f} {r}");
            }
        }
    }

    #[test]
    fn high_gain_limit_is_the_guidance() {
        // Scale both controllers up: H_io → T = diag(e^{−iωΔt1}, e^{−iωΔt2}).
        let base = Controllers::default();
        let m = Masses::default();
        let p = LtpParams::default();
        let f = 1e-2;
        let mut prev = f64::INFINITY;
        for g in [1e4, 1e6, 1e8] {
            let scale = |r: &crate::lti::Rational| {
                crate::lti::Rational::new(r.num().iter().map(|x| x * g).collect(), r.den().to_vec())
                    .unwrap()
            };
            let ctrl = Controllers {
                df: scale(&base.df),
                sus: scale(&base.sus),
            };
            let cl = ClosedLoop::at(&p, &BinConsts::new(f, &ctrl, 0.0), &m);
            let t = [crate::lti::delay(p.dt1, f), crate::lti::delay(p.dt2, f)];
            // the loop forces the measured outputs onto the guidance, δ21 included
            let mut err: f64 = 0.0;
            for i in 0..2 {
                for j in 0..2 {
                    let want = if i == j { t[j] } else { c(0.0, 0.0) };
                    err = err.max((cl.h_io[i][j] - want).norm());
                }
            }
            // first-order approach to the limit: H_io − T = O(D/(A K)) ∝ 1/g
            if prev.is_finite() {
                let ratio = prev / err;
                assert!(
                    (ratio / 100.0 - 1.0).abs() < 0.05,
                    "error ratio {ratio} per ×100 gain"
                );
            }
            prev = err;
        }
        assert!(prev < 1e-6, "H_io − T = {prev} at gain 1e8");
    }

    #[test]
    fn closed_loop_poles_are_stable_and_match_the_design_note() {
        let poles = closed_loop_poles(
            &LtpParams::default(),
            &Controllers::default(),
            &Masses::default(),
        )
        .unwrap();
        assert_eq!(poles.len(), 9);
        assert!(poles.iter().all(|z| z.re < 0.0), "{poles:?}");
        // ltp-model.md §4: real poles at 0.13, 0.31, 1.05, 2.5, 9.4 mHz, 0.28 and 2.0 Hz and a
        // complex pair at 55 mHz (|s|/2π); quoted to 2–3 figures.
        let mut hz: Vec<f64> = poles.iter().map(|z| z.norm() / (2.0 * PI)).collect();
        hz.sort_by(f64::total_cmp);
        let want = [
            0.13e-3, 0.31e-3, 1.05e-3, 2.5e-3, 9.4e-3, 55e-3, 55e-3, 0.28, 2.0,
        ];
        for (g, w) in hz.iter().zip(want) {
            assert!(
                (g - w).abs() < 0.05 * w,
                "pole {g:.4e} Hz vs note {w:.2e} Hz"
            );
        }
        assert!(
            check_stable(
                &LtpParams::default(),
                &Controllers::default(),
                &Masses::default()
            )
            .is_ok()
        );
    }

    #[test]
    fn unstable_parameters_are_reported() {
        let p = LtpParams {
            a_df: -0.5,
            ..Default::default()
        };
        let err = check_stable(&p, &Controllers::default(), &Masses::default()).unwrap_err();
        assert!(matches!(err, LoopError::Unstable { .. }), "{err}");
    }
}
