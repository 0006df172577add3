//! The prepared kernel of [`super::GlitchModel`] on one experiment: its exact `Σ_k r_kᴴ C_k⁻¹
//! r_k` without re-evaluating the loop's residual when only glitch parameters change.
//!
//! # Algebra
//! With the parent's residual `ρ_k(θ_p)` and the glitches' causal response `y_k`
//! ([`super::glitch_response`], times the impulse channel's DFT `d_δ,k`), the residual is
//! `r_k = ρ_k − y_k`, so
//!
//! ```text
//! Σ_k r_kᴴ C_k⁻¹ r_k = P(θ_p) + Σ_k [y_kᴴ C_k⁻¹ y_k − 2 Re(y_kᴴ w_k)],
//! P = Σ_k ρ_kᴴ C_k⁻¹ ρ_k,   w_k = C_k⁻¹ ρ_k.
//! ```
//!
//! `P`, `w` and the loop's force response on the padded grid depend on the loop's parameters
//! only: they are computed once and kept (per thread, for the last two loop points: a rejected
//! Metropolis step returns to the current one) until those change, which a move of a glitch's
//! parameters alone (a reversible jump's birth or death, a glitch's block update) does not.
//! `y` is the module's five transforms. Tested against the generic path
//! ([`super::residual_power_generic`]) to rounding.

use super::bin::{Bin, BinBlock, MAX_CHANNELS, residual};
use super::glitch_response::{
    Causal, GridConsts, Quadratic, add_samples, grid_index, record_padding, response_grid,
};
use super::traits::{BlockKernel, Model};
use num_complex::Complex64;
use std::cell::RefCell;
use std::sync::Arc;

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
    /// Samples of the record.
    samples: usize,
    /// The record's DFT bin of the block's first bin.
    first: usize,
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
    /// The parent's constants on the padded grid.
    grid: GridConsts,
}

/// `P`, `w`, the data side `q` of [`Quadratic`] and the force response on the padded grid at
/// the parent's parameters `theta_p`.
#[derive(Default)]
struct LoopState {
    theta_p: Vec<f64>,
    power: f64,
    w: Vec<[Complex64; 2]>,
    q: Vec<Vec<Complex64>>,
    h: Vec<Complex64>,
}

/// What one thread keeps of one kernel between evaluations.
struct Cache {
    id: u64,
    loops: [LoopState; 2],
    causal: Causal,
    quad: Quadratic,
    /// The parameters `y` was computed at (the parent's, then each glitch's three), and the
    /// padded spectra of the cut response.
    y_at: Vec<f64>,
    y: Vec<Vec<Complex64>>,
    /// Scratch: the glitches' samples and their spectrum.
    g: Vec<f64>,
    gs: Vec<Complex64>,
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
    /// more than two residual channels (the packed inverse covers up to two) or bins off the
    /// record's DFT grid.
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
        let samples = (duration * b.fs).round() as usize;
        let first = grid_index(b.f0, b.fs, samples)?;
        let last = grid_index(b.f0 + (b.n - 1) as f64 * b.df, b.fs, samples)?;
        if samples < 2 || last != first + b.n - 1 {
            return None;
        }
        let mut data = Vec::with_capacity(b.n * cp);
        let mut impulse = Vec::with_capacity(b.n);
        for k in 0..b.n {
            data.extend_from_slice(&b.data[k * nc..k * nc + cp]);
            impulse.push(b.data[k * nc + cp]);
        }
        let grid = GridConsts::new(parent.as_ref(), record_padding(samples, b.fs), b.fs);
        Some(Self {
            id: next_id(),
            grid,
            n_consts: parent.n_consts(),
            parent,
            np,
            glitches,
            rise,
            samples,
            first,
            f0: b.f0,
            df: b.df,
            fs: b.fs,
            n: b.n,
            data,
            impulse,
            cinv: b.cinv.to_vec(),
            consts: b.consts.to_vec(),
        })
    }

    /// `P`, `w` and the force response grid at the parent's parameters `p` (module docs).
    fn loop_pass(&self, p: &[f64], quad: &mut Quadratic, c: &mut LoopState) {
        let cp = self.parent.data_channels().len();
        let nr = self.parent.residual_channels().len();
        let zero = Complex64::new(0.0, 0.0);
        let mut coef = [zero; MAX_CHANNELS * 2];
        let coef = &mut coef[..nr * cp];
        c.w.resize(self.n, [zero; 2]);
        let mut power = 0.0;
        for k in 0..self.n {
            let bin = Bin {
                f: self.f0 + k as f64 * self.df,
                fs: self.fs,
                consts: &self.consts[k * self.n_consts..(k + 1) * self.n_consts],
            };
            self.parent.coefficients(p, &bin, coef);
            let rho = residual(coef, nr, &self.data[k * cp..(k + 1) * cp]);
            let (a, b, cc) = self.cinv[k];
            let w = [rho[0] * a + b * rho[1], b.conj() * rho[0] + rho[1] * cc];
            power += (rho[0].conj() * w[0] + rho[1].conj() * w[1]).re;
            c.w[k] = w;
        }
        response_grid(self.parent.as_ref(), p, &self.grid, &mut c.h);
        quad.data_side(&c.w, &mut c.q);
        c.power = power;
        c.theta_p.clear();
        c.theta_p.extend_from_slice(p);
    }

    /// Whether `y_at` holds the parameters `th` of the parent and the glitches.
    fn same_point(&self, y_at: &[f64], th: &[f64]) -> bool {
        let np = self.np;
        y_at.len() == np + 3 * self.glitches.len()
            && y_at[..np]
                .iter()
                .zip(&th[..np])
                .all(|(a, b)| a.to_bits() == b.to_bits())
            && self.glitches.iter().enumerate().all(|(j, &i)| {
                (0..3).all(|q| y_at[np + 3 * j + q].to_bits() == th[i + q].to_bits())
            })
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
                    let nr = self.parent.residual_channels().len();
                    let bins: Vec<usize> = (self.first..self.first + self.n).collect();
                    caches.push(Cache {
                        id: self.id,
                        loops: Default::default(),
                        causal: Causal::new(self.samples, self.fs),
                        quad: Quadratic::new(
                            self.samples,
                            self.fs,
                            nr,
                            &bins,
                            &self.cinv,
                            &self.impulse,
                        ),
                        y_at: Vec::new(),
                        y: Vec::new(),
                        g: vec![0.0; self.samples],
                        gs: Vec::new(),
                    });
                    caches.len() - 1
                }
            };
            let c = &mut caches[at];
            let hit = |l: &LoopState| l.theta_p.as_slice() == p && l.w.len() == self.n;
            if !hit(&c.loops[0]) {
                c.loops.swap(0, 1);
                if !hit(&c.loops[0]) {
                    self.loop_pass(p, &mut c.quad, &mut c.loops[0]);
                }
            }
            if !self.same_point(&c.y_at, th) {
                c.g.fill(0.0);
                for &i in &self.glitches {
                    add_samples(th[i], th[i + 1], th[i + 2], self.rise, self.fs, &mut c.g);
                }
                c.causal.spectrum(&c.g, &mut c.gs);
                c.quad.response(&c.loops[0].h, &c.gs, &mut c.y);
                c.y_at.clear();
                c.y_at.extend_from_slice(p);
                for &i in &self.glitches {
                    c.y_at.extend_from_slice(&th[i..i + 3]);
                }
            }
            let lp = &c.loops[0];
            let (b, a) = c.quad.terms(&c.y, &lp.q);
            lp.power - 2.0 * b + a
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
