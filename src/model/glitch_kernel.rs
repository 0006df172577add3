//! The prepared kernel of [`super::GlitchModel`] on one experiment: its exact `Σ_k r_kᴴ C_k⁻¹
//! r_k` without re-evaluating the loop when only glitch parameters change, and without a
//! `sin_cos` or `exp` per bin and glitch.
//!
//! # Algebra
//! With the parent's residual `ρ_k(θ_p)`, its force response `H_k(θ_p)` and the glitches' force
//! `G_k = d_δ,k Σ_g a_g S_g,k` (`d_δ` the impulse channel's DFT, `S_g` the template of
//! [`super::glitch::shape_dft`]), the residual is `r_k = ρ_k − H_k G_k`, so
//!
//! ```text
//! Σ_k r_kᴴ C_k⁻¹ r_k = P(θ_p) + Σ_k [v_k |G_k|² − 2 Re(G_k* u_k)],
//! P = Σ_k ρ_kᴴ C_k⁻¹ ρ_k,   u_k = H_kᴴ C_k⁻¹ ρ_k,   v_k = H_kᴴ C_k⁻¹ H_k.
//! ```
//!
//! `P`, `u`, `v` depend on the loop's parameters only: they are computed in one pass over the
//! bins and kept (per thread) until those change, which a move of a glitch's parameters alone
//! (a reversible jump's birth or death, a glitch's block update) does not. A template depends
//! on its glitch's `t0` and `τ` only and is kept likewise; an amplitude enters linearly.
//!
//! # Templates without transcendental functions per bin
//! On the DFT grid `f_k = f_0 + k δf`, the template's phasor `e^{−iω_k n0/fs}` is a geometric
//! sequence in `k`: one `sin_cos` every [`BLOCK`] bins and a complex product between them (at
//! most `BLOCK` roundings, nothing accumulates along the band). `e^{−iω_k/fs}` and the rise
//! term's denominator `1/(1 − e^{−1/(fs τ_r)} e^{−iω_k/fs})` do not depend on θ and are tabled;
//! per bin and glitch one complex division remains. Tested against the generic path
//! ([`super::residual_power_generic`]) to rounding.

use super::bin::{Bin, BinBlock, MAX_CHANNELS, residual};
use super::traits::{BlockKernel, Model};
use crate::hermitian::quad;
use num_complex::Complex64;
use num_dual::DualNum;
use std::cell::RefCell;
use std::f64::consts::PI;
use std::sync::Arc;

/// The peak of `e^{−u/τ} − e^{−u/τ_r}`, at `u* = ln(τ/τ_r) τ τ_r / (τ − τ_r)`.
pub(super) fn peak<T: DualNum<Primitive = f64> + Copy>(tau: T, rise: f64) -> T {
    let u = (tau / rise).ln() * tau * rise / (tau - rise);
    (-u / tau).exp() - (-u / rise).exp()
}

/// Bins between exact phasors of a template.
const BLOCK: usize = 256;

/// The prepared kernel (module docs). Owns copies of everything θ-independent.
#[derive(Debug)]
pub(super) struct GlitchKernel {
    /// Unique per kernel: the key of its per-thread cache.
    id: u64,
    parent: Arc<dyn Model>,
    /// Number of the parent's parameters.
    np: usize,
    /// `θ` index of each active glitch's `t0` (then `τ`, `a`).
    glitches: Vec<usize>,
    rise: f64,
    /// Record length `N/fs` (s).
    duration: f64,
    f0: f64,
    df: f64,
    fs: f64,
    n: usize,
    /// The parent's data, `n × C_p`.
    data: Vec<Complex64>,
    /// The impulse channel's DFT per bin.
    impulse: Vec<Complex64>,
    cinv: Vec<(f64, Complex64, f64)>,
    consts: Vec<Complex64>,
    n_consts: usize,
    /// `e^{−iω_k/fs}` per bin.
    step: Vec<Complex64>,
    /// `1/(1 − e^{−1/(fs τ_r)} e^{−iω_k/fs})` per bin.
    rise_den: Vec<Complex64>,
}

/// `P`, `u`, `v` at the parent's parameters `theta_p`.
#[derive(Default)]
struct LoopState {
    theta_p: Vec<f64>,
    power: f64,
    u: Vec<Complex64>,
    v: Vec<f64>,
}

/// What one thread keeps of one kernel between evaluations: two loop states (a Metropolis
/// step evaluates a proposal and, if it is rejected, returns to the current point; the next
/// block's move must not recompute the loop), the most recent first.
struct Cache {
    id: u64,
    loops: [LoopState; 2],
    /// `(t0, τ)` and the template of each active glitch.
    templates: Vec<([f64; 2], Vec<Complex64>)>,
}

thread_local! {
    static CACHES: RefCell<Vec<Cache>> = const { RefCell::new(Vec::new()) };
}

/// Caches kept per thread; beyond it the least recently made is dropped (a likelihood has one
/// kernel per experiment with glitches).
const MAX_CACHES: usize = 16;

fn next_id() -> u64 {
    static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
}

impl GlitchKernel {
    /// The kernel of `parent` with the glitches at `glitches` (indices of their `t0`) on a
    /// record of `duration` s, over `b` (whose last data channel is the impulse). `None` for
    /// more than two residual channels (the packed inverse covers up to two).
    pub(super) fn new(
        parent: Arc<dyn Model>,
        np: usize,
        glitches: Vec<usize>,
        rise: f64,
        duration: f64,
        b: &BinBlock,
    ) -> Option<Self> {
        let nr = parent.residual_channels().len();
        if nr > 2 || b.cinv.len() != b.n || b.n == 0 {
            return None;
        }
        let nc = b.data.len() / b.n;
        let cp = parent.data_channels().len();
        if nc != cp + 1 {
            return None;
        }
        let mut data = Vec::with_capacity(b.n * cp);
        let mut impulse = Vec::with_capacity(b.n);
        for k in 0..b.n {
            data.extend_from_slice(&b.data[k * nc..k * nc + cp]);
            impulse.push(b.data[k * nc + cp]);
        }
        let decay_r = (-1.0 / (b.fs * rise)).exp();
        let (step, rise_den): (Vec<_>, Vec<_>) = (0..b.n)
            .map(|k| {
                let w = 2.0 * PI * (b.f0 + k as f64 * b.df) / b.fs;
                let (s, c) = w.sin_cos();
                let e = Complex64::new(c, -s);
                (e, (Complex64::new(1.0, 0.0) - e * decay_r).inv())
            })
            .unzip();
        Some(Self {
            id: next_id(),
            n_consts: parent.n_consts(),
            parent,
            np,
            glitches,
            rise,
            duration,
            f0: b.f0,
            df: b.df,
            fs: b.fs,
            n: b.n,
            data,
            impulse,
            cinv: b.cinv.to_vec(),
            consts: b.consts.to_vec(),
            step,
            rise_den,
        })
    }

    /// `P`, `u`, `v` at the parent's parameters `p` (module docs).
    fn loop_pass(&self, p: &[f64], c: &mut LoopState) {
        let cp = self.parent.data_channels().len();
        let nr = self.parent.residual_channels().len();
        let zero = Complex64::new(0.0, 0.0);
        let mut coef = [zero; MAX_CHANNELS * 2];
        let coef = &mut coef[..nr * cp];
        let mut h = [zero; 2];
        c.u.resize(self.n, zero);
        c.v.resize(self.n, 0.0);
        let mut power = 0.0;
        for k in 0..self.n {
            let bin = Bin {
                f: self.f0 + k as f64 * self.df,
                fs: self.fs,
                consts: &self.consts[k * self.n_consts..(k + 1) * self.n_consts],
            };
            self.parent.coefficients(p, &bin, coef);
            h[1] = zero;
            self.parent.force_response(p, &bin, &mut h[..nr]);
            let rho = residual(coef, nr, &self.data[k * cp..(k + 1) * cp]);
            let (a, b, cc) = self.cinv[k];
            let w = [rho[0] * a + b * rho[1], b.conj() * rho[0] + rho[1] * cc];
            power += (rho[0].conj() * w[0] + rho[1].conj() * w[1]).re;
            c.u[k] = h[0].conj() * w[0] + h[1].conj() * w[1];
            c.v[k] = quad(&self.cinv[k], h);
        }
        c.power = power;
        c.theta_p.clear();
        c.theta_p.extend_from_slice(p);
    }

    /// The template of a glitch at `(t0, τ)` into `out` (as [`super::glitch::shape_dft`]).
    fn template(&self, t0: f64, tau: f64, out: &mut Vec<Complex64>) {
        let zero = Complex64::new(0.0, 0.0);
        out.clear();
        out.resize(self.n, zero);
        let n0 = (t0 * self.fs).ceil().max(0.0);
        if n0 >= (self.duration * self.fs).round() {
            return;
        }
        let start = n0 / self.fs - t0;
        let end = self.duration - t0;
        let (head, tail) = ((-start / tau).exp(), (-end / tau).exp());
        let (head_r, tail_r) = ((-start / self.rise).exp(), (-end / self.rise).exp());
        let decay = (-1.0 / (self.fs * tau)).exp();
        let c = peak(tau, self.rise);
        let one = Complex64::new(1.0, 0.0);
        // the phasor advances by e^{−i 2π δf n0/fs} per bin
        let (s, co) = (2.0 * PI * self.df * n0 / self.fs).sin_cos();
        let adv = Complex64::new(co, -s);
        for (q, chunk) in out.chunks_mut(BLOCK).enumerate() {
            let k0 = q * BLOCK;
            let (s, co) = (2.0 * PI * (self.f0 + k0 as f64 * self.df) / self.fs * n0).sin_cos();
            let mut ph = Complex64::new(co, -s);
            for (l, o) in chunk.iter_mut().enumerate() {
                let k = k0 + l;
                let e = self.step[k];
                let u = (ph * head - tail) / (one - e * decay);
                let ur = (ph * head_r - tail_r) * self.rise_den[k];
                *o = (u - ur) / c;
                ph *= adv;
            }
        }
    }
}

/// The parent's own kernel on an experiment where no glitch acts (the impulse column dropped),
/// read with the parent's parameters.
#[derive(Debug)]
pub(super) struct ParentKernel {
    pub(super) inner: Arc<dyn BlockKernel>,
    pub(super) np: usize,
}

impl BlockKernel for ParentKernel {
    fn residual_power(&self, th: &[f64]) -> f64 {
        self.inner.residual_power(&th[..self.np])
    }
}

impl BlockKernel for GlitchKernel {
    fn residual_power(&self, th: &[f64]) -> f64 {
        let p = &th[..self.np];
        CACHES.with_borrow_mut(|caches| {
            let at = match caches.iter().position(|c| c.id == self.id) {
                Some(i) => i,
                None => {
                    if caches.len() >= MAX_CACHES {
                        caches.remove(0);
                    }
                    caches.push(Cache {
                        id: self.id,
                        loops: Default::default(),
                        templates: vec![([f64::NAN; 2], Vec::new()); self.glitches.len()],
                    });
                    caches.len() - 1
                }
            };
            let c = &mut caches[at];
            let hit = |l: &LoopState| l.theta_p.as_slice() == p && l.u.len() == self.n;
            if !hit(&c.loops[0]) {
                c.loops.swap(0, 1);
                if !hit(&c.loops[0]) {
                    self.loop_pass(p, &mut c.loops[0]);
                }
            }
            let lp = &c.loops[0];
            let mut templates = std::mem::take(&mut c.templates);
            for (&i, (key, t)) in self.glitches.iter().zip(templates.iter_mut()) {
                let want = [th[i], th[i + 1]];
                // bitwise, so that a NaN key never matches
                if key[0].to_bits() != want[0].to_bits()
                    || key[1].to_bits() != want[1].to_bits()
                    || t.len() != self.n
                {
                    self.template(want[0], want[1], t);
                    *key = want;
                }
            }
            let mut s = lp.power;
            for k in 0..self.n {
                let mut g = Complex64::new(0.0, 0.0);
                for (&i, (_, t)) in self.glitches.iter().zip(&templates) {
                    g += t[k] * th[i + 2];
                }
                g *= self.impulse[k];
                s += lp.v[k] * g.norm_sqr() - 2.0 * (g.conj() * lp.u[k]).re;
            }
            c.templates = templates;
            s
        })
    }
}

#[cfg(test)]
mod tests {
    use super::super::glitch::GlitchModel;
    use super::super::glitch::tests::model;
    use super::super::{Covariates, residual_power_generic};
    use super::*;
    use rand::{RngExt, SeedableRng};

    /// A block of bins `k0..k0+n` of a record of `duration` s at 1 Hz with random data (the
    /// impulse's DFT random too, so that the kernel must use it), random positive-definite
    /// inverse noise matrices and the model's constants.
    struct Owned {
        f0: f64,
        df: f64,
        n: usize,
        data: Vec<Complex64>,
        cinv: Vec<(f64, Complex64, f64)>,
        consts: Vec<Complex64>,
    }

    impl Owned {
        fn new(m: &dyn Model, duration: f64, k0: usize, n: usize, seed: u64) -> Self {
            let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
            let nc = m.data_channels().len();
            let df = 1.0 / duration;
            let mut z = || Complex64::new(rng.random::<f64>() - 0.5, rng.random::<f64>() - 0.5);
            let data: Vec<Complex64> = (0..n * nc).map(|_| z() * 1e-9).collect();
            let mut rng = rand::rngs::StdRng::seed_from_u64(seed + 1);
            let cinv = (0..n)
                .map(|_| {
                    let (a, c): (f64, f64) = (
                        1e20 * (0.5 + rng.random::<f64>()),
                        1e20 * (0.5 + rng.random::<f64>()),
                    );
                    let b = Complex64::new(rng.random::<f64>() - 0.5, rng.random::<f64>() - 0.5)
                        * (0.9 * (a * c).sqrt());
                    (a, b, c)
                })
                .collect();
            let nk = m.n_consts();
            let mut consts = vec![Complex64::new(0.0, 0.0); n * nk];
            for k in 0..n {
                m.bin_consts((k0 + k) as f64 * df, 1.0, &mut consts[k * nk..(k + 1) * nk]);
            }
            Self {
                f0: k0 as f64 * df,
                df,
                n,
                data,
                cinv,
                consts,
            }
        }

        fn block(&self) -> BinBlock<'_> {
            BinBlock {
                f0: self.f0,
                df: self.df,
                fs: 1.0,
                n: self.n,
                data: &self.data,
                cinv: &self.cinv,
                whiten: &[],
                consts: &self.consts,
            }
        }
    }

    fn on(m: &GlitchModel, e: &str) -> Arc<dyn Model> {
        let cov = Covariates {
            experiment: Some(e.into()),
            ..Default::default()
        };
        m.specialise(&cov).unwrap().unwrap()
    }

    /// The kernel equals the generic path to rounding through a sequence of moves that hit and
    /// miss its caches: the loop's parameters, one glitch's start (on and between sample
    /// times, before the record, after it), its decay, an amplitude alone, and back.
    #[test]
    fn the_kernel_equals_the_generic_path_through_cache_hits_and_misses() {
        let m = model();
        let a = on(&m, "a");
        let owned = Owned::new(a.as_ref(), 3000.0, 2, 1400, 7);
        let b = owned.block();
        let kernel = a.prepare_kernel(&b).expect("a glitch model has a kernel");
        let mut th = crate::ltp::LtpParams::default().to_array().to_vec();
        for j in 0..3 {
            th.extend([300.4 + 500.0 * j as f64, 60.0, -1e-13 * (j + 1) as f64]);
        }
        let base = th.clone();
        let mut moves: Vec<Vec<f64>> = vec![th.clone()];
        let mut step = |i: usize, v: f64| {
            th[i] = v;
            moves.push(th.clone());
        };
        step(7, 301.0); // on a sample time
        step(7, 0.0); // the first sample
        step(7, -20.0); // before the record: starts at the first sample
        step(7, 2999.5); // in the last sample interval
        step(7, 3000.5); // after the record: no glitch
        step(7, 1234.56);
        step(8, 2500.0);
        step(9, 3e-12); // amplitude alone
        step(0, base[0] * 1.01); // the loop
        step(9, 0.0);
        step(13, 2.5);
        moves.push(base.clone());
        // a rejected loop move and back, twice: both loop states are kept
        let loop_moved = moves[9].clone();
        moves.extend([loop_moved.clone(), base.clone(), loop_moved, base.clone()]);
        for (q, th) in moves.iter().enumerate() {
            let want = residual_power_generic(a.as_ref(), th, &b);
            let got = kernel.residual_power(th);
            // the glitches' part of the power is what the kernel computes differently
            let loop_only = {
                let mut z = th.clone();
                for j in 0..3 {
                    z[7 + 3 * j + 2] = 0.0;
                }
                residual_power_generic(a.as_ref(), &z, &b)
            };
            let scale = (want - loop_only).abs().max(1e-6 * want.abs());
            assert!(
                (got - want).abs() < 1e-9 * scale + 1e-12 * want.abs(),
                "move {q}: kernel {got} generic {want} (glitches' part {})",
                want - loop_only
            );
        }
        // experiment b's single glitch (g2), and c where none acts (the parent's kernel)
        for (e, duration) in [("b", 5000.0), ("c", 3000.0)] {
            let s = on(&m, e);
            let owned = Owned::new(s.as_ref(), duration, 1, 900, 11);
            let b = owned.block();
            let k = s.prepare_kernel(&b).expect("a kernel");
            for th in [&base, &moves[9]] {
                let want = residual_power_generic(s.as_ref(), th, &b);
                let got = k.residual_power(th);
                assert!(
                    (got - want).abs() < 1e-10 * want.abs(),
                    "{e}: kernel {got} generic {want}"
                );
            }
        }
    }

    /// Unspecialised (no experiment), the model has no kernel: the generic path makes every
    /// glitch's coefficient zero there.
    #[test]
    fn an_unspecialised_model_has_no_kernel() {
        let m = model();
        let owned = Owned::new(&m, 3000.0, 2, 10, 3);
        assert!(m.prepare_kernel(&owned.block()).is_none());
    }
}
