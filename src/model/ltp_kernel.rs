//! The prepared exact-likelihood kernel of the plain LTP closed loop ([`super::LtpModel`] with
//! no thruster response): everything that does not depend on θ, data included, is folded into
//! per-bin real arrays once, so that per θ and bin only a few dozen flops remain, in
//! structure-of-arrays loops the compiler vectorises (AVX2 + FMA when the CPU has them,
//! chosen at run time).
//!
//! # Algebra
//!
//! Write `σ = −ω²`, `u = E C_df`, `v = E C_sus` (E the OMS phasor), `α = A_df`, `β = A_sus`,
//! `δ = δ21`, `e1 = m1/m_sc`, `e2 = m2/m_sc`, `a00 = w1(1 + e1) + w2 e2`, `a10 = w2 − w1`,
//! `ρ = δ e2 + 1`, `μ = 1 + e1 + e2`, `κ = δ w2 − a10`, `λ = a00 − e2 a10`. Cramer's rule for
//! `P = D + E M A K S` expands (the β² terms cancel) into
//!
//! ```text
//! det P = u (αβ v + α(σ + w2)) + β(ρσ + w1 μ) v + σ² + (a00 + w2) σ + w1 w2 μ,
//! ```
//!
//! and with `A = E C_df I1`, `B = E C_sus I12`, `t_j = e^{−iωΔt_j}`, the numerators
//! `N = det P · H_io I` are
//!
//! ```text
//! N_o1  = t1 α (βv + σ + w2) A          + t2 β e2 σ B,
//! N_o12 = t1 α (κ + δσ) A               + t2 β (αu + λ + ρσ) B.
//! ```
//!
//! The residual `R = Y − N/det P`, so `Rᴴ C⁻¹ R = zᴴ C⁻¹ z / |det P|²` with `z = Y det P − N`.
//! `C⁻¹ = [[a, b], [b*, c]]` is factorised once per bin, `zᴴ C⁻¹ z = |√a (z0 + γ z1)|² +
//! |√c' z1|²` with `γ = b/a`, `c' = c − |b|²/a`, and `√a`, `√a γ`, `√c'` are folded into the
//! data: `Ỹ0 = √a (Y0 + γ Y1)`, `Ỹ1 = √c' Y1`, `P2 = √a X`, `P3 = √a γ X`, `s = √c'/√a`
//! (`X = A` or `B`). Every `|t_j| = 1`, so with one active injection channel `j` the phasor
//! multiplies `det P` only: `|Z_r| = |Ỹ_r det P t_j* − Ñ_r|`. Per bin that leaves
//! `(|Z0|² + |Z1|²)/|det P|²`: one real division, no complex one.
//!
//! Inactive injection channels (identically zero in band) are dropped. Experiments on the same
//! grid with the same controllers share `det P` (see [`LtpKernel::new`]).
//!
//! # Delay phasors
//!
//! On the uniform grid `ω_k = ω_0 + k dω`, with `k = q·BLOCK + l`,
//! `e^{iω_k τ} = e^{iω_{qBLOCK} τ} · e^{i l dω τ}`: one `sin_cos` per block and a table of
//! `BLOCK` fine phasors built by doubling from 8 exact `sin_cos` (at most 8 roundings), so the
//! phasor of every bin carries ~10 roundings, nothing accumulates along the band.

use super::bin::BinBlock;
use super::traits::BlockKernel;
use crate::ltp::Masses;
use num_complex::Complex64;
use std::f64::consts::PI;
use std::sync::Arc;

/// Constants per bin of [`super::LtpModel`]: `C_df, C_sus, E, E·C_df, E·C_sus`.
const N_CONSTS: usize = 5;
/// Bins per phasor block (a power of two: the fine table is built by doubling).
const BLOCK: usize = 256;
const LOG2_BLOCK: u32 = BLOCK.trailing_zeros();
/// Independent accumulators of the inner loops (vector lanes × unrolling).
const LANES: usize = 8;
/// Most phasor tables per evaluation (one per experiment with one active injection channel,
/// two with both); [`LtpKernel::new`] refuses more.
const MAX_TABLES: usize = 4;

/// θ-independent arrays shared by the experiments of one grid.
#[derive(Debug, Clone)]
struct Grid {
    n: usize,
    /// `2π f_0`, `2π df`.
    w0: f64,
    dw: f64,
    sig: Vec<f64>,
    ure: Vec<f64>,
    uim: Vec<f64>,
    vre: Vec<f64>,
    vim: Vec<f64>,
}

/// Per-bin arrays of one active injection channel: `P2 = √a X`, `P3 = √a γ X`.
#[derive(Debug, Clone)]
struct Chan {
    p2re: Vec<f64>,
    p2im: Vec<f64>,
    p3re: Vec<f64>,
    p3im: Vec<f64>,
}

/// Which injection channels carry anything in band.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Active {
    None,
    One(usize),
    Both,
}

/// One experiment's folded data.
#[derive(Debug, Clone)]
struct Exp {
    active: Active,
    y0re: Vec<f64>,
    y0im: Vec<f64>,
    y1re: Vec<f64>,
    y1im: Vec<f64>,
    s: Vec<f64>,
    /// Arrays of the active channels, in channel order.
    chans: Vec<Chan>,
    /// `Σ |Ỹ0|² + |Ỹ1|²`: the whole value when no channel is active.
    y_power: f64,
}

/// The prepared kernel (see the module docs).
#[derive(Debug, Clone)]
pub(crate) struct LtpKernel {
    e1: f64,
    e2: f64,
    grid: Grid,
    exps: Vec<Exp>,
}

/// θ-only coefficients of one evaluation.
#[derive(Debug, Clone, Copy)]
struct Coefs {
    alpha: f64,
    beta: f64,
    w2: f64,
    delta: f64,
    e2: f64,
    /// `det P = u·(ab v + alpha (σ + w2)) + (beta ρσ + beta w1 μ) v + σ² + c1 σ + c0`.
    ab: f64,
    brho: f64,
    bw1mu: f64,
    c1: f64,
    c0: f64,
    kappa: f64,
    lambda: f64,
    rho: f64,
}

impl Coefs {
    fn new(th: &[f64; 7], e1: f64, e2: f64) -> Self {
        let [w1, w2, _, _, alpha, beta, delta] = *th;
        let a00 = w1 * (1.0 + e1) + w2 * e2;
        let a10 = w2 - w1;
        let rho = delta * e2 + 1.0;
        let mu = 1.0 + e1 + e2;
        Self {
            alpha,
            beta,
            w2,
            delta,
            e2,
            ab: alpha * beta,
            brho: beta * rho,
            bw1mu: beta * w1 * mu,
            c1: a00 + w2,
            c0: w1 * w2 * mu,
            kappa: delta * w2 - a10,
            lambda: a00 - e2 * a10,
            rho,
        }
    }
}

impl LtpKernel {
    /// A kernel over experiments that share one grid (`f0`, `df`, `n`) and the model's
    /// constants (controllers, OMS delay), so that `det P` is computed once for all of them.
    /// `None` if the blocks do not share them, are empty, or are not shaped for the LTP model
    /// (4 data channels, 5 constants per bin), or if some `C⁻¹` is not positive definite.
    pub(crate) fn new(masses: &Masses, blocks: &[BinBlock]) -> Option<Self> {
        let b0 = blocks.first()?;
        let n = b0.n;
        if n == 0 {
            return None;
        }
        for b in blocks {
            if b.n != n
                || b.f0 != b0.f0
                || b.df != b0.df
                || b.data.len() != 4 * n
                || b.cinv.len() != n
                || b.consts.len() != N_CONSTS * n
                || b.consts != b0.consts
            {
                return None;
            }
        }
        let mut grid = Grid {
            n,
            w0: 2.0 * PI * b0.f0,
            dw: 2.0 * PI * b0.df,
            sig: Vec::with_capacity(n),
            ure: Vec::with_capacity(n),
            uim: Vec::with_capacity(n),
            vre: Vec::with_capacity(n),
            vim: Vec::with_capacity(n),
        };
        for k in 0..n {
            let f = b0.f0 + k as f64 * b0.df;
            let w = 2.0 * PI * f;
            let c = &b0.consts[N_CONSTS * k..N_CONSTS * (k + 1)];
            grid.sig.push(-w * w);
            grid.ure.push(c[3].re);
            grid.uim.push(c[3].im);
            grid.vre.push(c[4].re);
            grid.vim.push(c[4].im);
        }
        let exps = blocks
            .iter()
            .map(|b| Exp::new(b))
            .collect::<Option<Vec<_>>>()?;
        let tables: usize = exps
            .iter()
            .map(|e| match e.active {
                Active::None => 0,
                Active::One(_) => 1,
                Active::Both => 2,
            })
            .sum();
        if tables > MAX_TABLES {
            return None;
        }
        Some(Self {
            e1: masses.m1 / masses.msc,
            e2: masses.m2 / masses.msc,
            grid,
            exps,
        })
    }

    /// As an `Arc<dyn BlockKernel>`.
    pub(crate) fn arc(self) -> Arc<dyn BlockKernel> {
        Arc::new(self)
    }

    fn eval(&self, th: &[f64; 7]) -> f64 {
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx2")
                && std::arch::is_x86_feature_detected!("fma")
            {
                // SAFETY: the CPU has the features the function is compiled for.
                return unsafe { self.eval_avx2(th) };
            }
        }
        self.eval_generic(th)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn eval_avx2(&self, th: &[f64; 7]) -> f64 {
        self.eval_generic(th)
    }

    #[inline(always)]
    fn eval_generic(&self, th: &[f64; 7]) -> f64 {
        let g = &self.grid;
        let k = Coefs::new(th, self.e1, self.e2);
        let mut det_re = [0.0; BLOCK];
        let mut det_im = [0.0; BLOCK];
        let mut inv = [0.0; BLOCK];
        // fine phasor tables: one per experiment with one active channel, two with both
        let mut tables: [Fine; MAX_TABLES] = std::array::from_fn(|_| Fine::empty());
        let mut total = 0.0;
        let mut slot = 0;
        for e in &self.exps {
            let taus: &[f64] = match e.active {
                Active::None => &[],
                Active::One(j) => &[th[2 + j]],
                // t1* and t2 t1* = e^{iω(Δt1 − Δt2)}
                Active::Both => &[th[2], th[2] - th[3]],
            };
            for &tau in taus {
                tables[slot].fill(g.dw, tau);
                slot += 1;
            }
            if e.active == Active::None {
                total += e.y_power;
            }
        }
        let mut q0 = 0;
        while q0 < g.n {
            let len = BLOCK.min(g.n - q0);
            det_block(g, &k, q0, len, &mut det_re, &mut det_im, &mut inv);
            let wq = g.w0 + q0 as f64 * g.dw;
            let mut slot = 0;
            for e in &self.exps {
                let blk = Blk {
                    q0,
                    len,
                    det_re: &det_re[..len],
                    det_im: &det_im[..len],
                    inv: &inv[..len],
                };
                total += match e.active {
                    Active::None => 0.0,
                    Active::One(0) => exp_block::<0>(g, e, &k, &blk, &tables[slot], wq),
                    Active::One(_) => exp_block::<1>(g, e, &k, &blk, &tables[slot], wq),
                    Active::Both => {
                        exp_block_both(g, e, &k, &blk, &tables[slot], &tables[slot + 1], wq)
                    }
                };
                slot += match e.active {
                    Active::None => 0,
                    Active::One(_) => 1,
                    Active::Both => 2,
                };
            }
            q0 += len;
        }
        total
    }
}

impl BlockKernel for LtpKernel {
    fn residual_power(&self, theta: &[f64]) -> f64 {
        match theta.try_into() {
            Ok(th) => self.eval(th),
            Err(_) => f64::NAN,
        }
    }
}

impl Exp {
    fn new(b: &BinBlock) -> Option<Self> {
        let n = b.n;
        let on = |j: usize| (0..n).any(|k| b.data[4 * k + 2 + j] != Complex64::new(0.0, 0.0));
        let active = match (on(0), on(1)) {
            (false, false) => Active::None,
            (true, false) => Active::One(0),
            (false, true) => Active::One(1),
            (true, true) => Active::Both,
        };
        let act: Vec<usize> = (0..2).filter(|&j| on(j)).collect();
        let mut e = Exp {
            active,
            y0re: Vec::with_capacity(n),
            y0im: Vec::with_capacity(n),
            y1re: Vec::with_capacity(n),
            y1im: Vec::with_capacity(n),
            s: Vec::with_capacity(n),
            chans: act
                .iter()
                .map(|_| Chan {
                    p2re: Vec::with_capacity(n),
                    p2im: Vec::with_capacity(n),
                    p3re: Vec::with_capacity(n),
                    p3im: Vec::with_capacity(n),
                })
                .collect(),
            y_power: 0.0,
        };
        for k in 0..n {
            let (a, bb, c) = b.cinv[k];
            let cp = c - bb.norm_sqr() / a;
            if !(a > 0.0 && cp > 0.0 && a.is_finite() && cp.is_finite()) {
                return None;
            }
            let sa = a.sqrt();
            let sc = cp.sqrt();
            let gam = bb / a;
            let d = &b.data[4 * k..4 * k + 4];
            let cst = &b.consts[N_CONSTS * k..N_CONSTS * (k + 1)];
            let y0 = (d[0] + gam * d[1]) * sa;
            let y1 = d[1] * sc;
            e.y_power += y0.norm_sqr() + y1.norm_sqr();
            e.y0re.push(y0.re);
            e.y0im.push(y0.im);
            e.y1re.push(y1.re);
            e.y1im.push(y1.im);
            e.s.push(sc / sa);
            for (ch, &j) in e.chans.iter_mut().zip(&act) {
                // A = E C_df I1, B = E C_sus I12
                let x = cst[3 + j] * d[2 + j];
                let p2 = x * sa;
                let p3 = x * gam * sa;
                ch.p2re.push(p2.re);
                ch.p2im.push(p2.im);
                ch.p3re.push(p3.re);
                ch.p3im.push(p3.im);
            }
        }
        Some(e)
    }
}

/// Fine phasor table `e^{i l dω τ}`, `l < BLOCK`, built by doubling.
struct Fine {
    re: [f64; BLOCK],
    im: [f64; BLOCK],
    tau: f64,
}

impl Fine {
    fn empty() -> Self {
        Fine {
            re: [0.0; BLOCK],
            im: [0.0; BLOCK],
            tau: 0.0,
        }
    }

    fn fill(&mut self, dw: f64, tau: f64) {
        let t = self;
        t.tau = tau;
        t.re[0] = 1.0;
        t.im[0] = 0.0;
        for m in 0..LOG2_BLOCK {
            let h = 1usize << m;
            let (s, c) = (h as f64 * dw * tau).sin_cos();
            for l in 0..h {
                let (r, i) = (t.re[l], t.im[l]);
                t.re[l + h] = r * c - i * s;
                t.im[l + h] = r * s + i * c;
            }
        }
    }

    /// `e^{i ω τ}`.
    fn coarse(&self, w: f64) -> (f64, f64) {
        let (s, c) = (w * self.tau).sin_cos();
        (c, s)
    }
}

/// `det P` and `1/|det P|²` over bins `q0..q0 + len` of the grid.
#[inline(always)]
fn det_block(
    g: &Grid,
    k: &Coefs,
    q0: usize,
    len: usize,
    det_re: &mut [f64; BLOCK],
    det_im: &mut [f64; BLOCK],
    inv: &mut [f64; BLOCK],
) {
    let r = q0..q0 + len;
    let (sig, ure, uim, vre, vim) = (
        &g.sig[r.clone()],
        &g.ure[r.clone()],
        &g.uim[r.clone()],
        &g.vre[r.clone()],
        &g.vim[r],
    );
    let (dr, di, iv) = (&mut det_re[..len], &mut det_im[..len], &mut inv[..len]);
    for i in 0..len {
        let s = sig[i];
        // q = ab v + alpha (σ + w2)
        let qr = k.ab * vre[i] + k.alpha * (s + k.w2);
        let qi = k.ab * vim[i];
        let rr = k.brho * s + k.bw1mu;
        let poly = (s + k.c1) * s + k.c0;
        let re = ure[i] * qr - uim[i] * qi + rr * vre[i] + poly;
        let im = ure[i] * qi + uim[i] * qr + rr * vim[i];
        dr[i] = re;
        di[i] = im;
        iv[i] = 1.0 / (re * re + im * im);
    }
}

/// `det P` of one phasor block and its bins.
struct Blk<'a> {
    q0: usize,
    len: usize,
    det_re: &'a [f64],
    det_im: &'a [f64],
    inv: &'a [f64],
}

/// `Σ (|Z0|² + |Z1|²)/|det P|²` over one block of one experiment with one active channel `J`.
#[inline(always)]
fn exp_block<const J: usize>(g: &Grid, e: &Exp, k: &Coefs, b: &Blk, tab: &Fine, wq: f64) -> f64 {
    let len = b.len;
    let r = b.q0..b.q0 + len;
    let (cr, ci) = tab.coarse(wq);
    let (fre, fim) = (&tab.re[..len], &tab.im[..len]);
    let (dre, dim, inv) = (&b.det_re[..len], &b.det_im[..len], &b.inv[..len]);
    let sig = &g.sig[r.clone()];
    // the other controller: v for channel 0, u for channel 1
    let (ore, oim) = if J == 0 {
        (&g.vre[r.clone()], &g.vim[r.clone()])
    } else {
        (&g.ure[r.clone()], &g.uim[r.clone()])
    };
    let (y0r, y0i, y1r, y1i, s) = (
        &e.y0re[r.clone()],
        &e.y0im[r.clone()],
        &e.y1re[r.clone()],
        &e.y1im[r.clone()],
        &e.s[r.clone()],
    );
    let c = &e.chans[0];
    let (p2r, p2i, p3r, p3i) = (
        &c.p2re[r.clone()],
        &c.p2im[r.clone()],
        &c.p3re[r.clone()],
        &c.p3im[r],
    );
    let mut buf = [0.0; BLOCK];
    for (i, o) in buf[..len].iter_mut().enumerate() {
        // p = det · e^{iωτ}
        let tr = cr * fre[i] - ci * fim[i];
        let ti = cr * fim[i] + ci * fre[i];
        let pr = dre[i] * tr - dim[i] * ti;
        let pi = dre[i] * ti + dim[i] * tr;
        let sg = sig[i];
        let (n0r, n0i, n1r, n1i);
        if J == 0 {
            // Ñ0 = α(β v P2 + (σ + w2) P2 + (κ + δσ) P3), Ñ1 = α (κ + δσ) s P2
            let h = k.kappa + k.delta * sg;
            let gg = sg + k.w2;
            let xr = k.beta * ore[i] + gg;
            let xi = k.beta * oim[i];
            n0r = k.alpha * (xr * p2r[i] - xi * p2i[i] + h * p3r[i]);
            n0i = k.alpha * (xr * p2i[i] + xi * p2r[i] + h * p3i[i]);
            let m = k.alpha * h * s[i];
            n1r = m * p2r[i];
            n1i = m * p2i[i];
        } else {
            // Ñ0 = β(e2 σ P2 + (αu + λ + ρσ) P3), Ñ1 = β (αu + λ + ρσ) s P2
            let xr = k.alpha * ore[i] + k.lambda + k.rho * sg;
            let xi = k.alpha * oim[i];
            let es = k.e2 * sg;
            n0r = k.beta * (es * p2r[i] + xr * p3r[i] - xi * p3i[i]);
            n0i = k.beta * (es * p2i[i] + xr * p3i[i] + xi * p3r[i]);
            let bs = k.beta * s[i];
            n1r = bs * (xr * p2r[i] - xi * p2i[i]);
            n1i = bs * (xr * p2i[i] + xi * p2r[i]);
        }
        let z0r = y0r[i] * pr - y0i[i] * pi - n0r;
        let z0i = y0r[i] * pi + y0i[i] * pr - n0i;
        let z1r = y1r[i] * pr - y1i[i] * pi - n1r;
        let z1i = y1r[i] * pi + y1i[i] * pr - n1i;
        *o = (z0r * z0r + z0i * z0i + z1r * z1r + z1i * z1i) * inv[i];
    }
    sum_lanes(&buf[..len])
}

/// As [`exp_block`] with both injection channels active: `Z_r t1* = Ỹ_r det t1* − Ñ_r¹ −
/// (t2 t1*) Ñ_r²`.
#[inline(always)]
fn exp_block_both(g: &Grid, e: &Exp, k: &Coefs, b: &Blk, t1: &Fine, t21: &Fine, wq: f64) -> f64 {
    let tab = [t1, t21];
    let len = b.len;
    let r = b.q0..b.q0 + len;
    let (cr, ci) = tab[0].coarse(wq);
    let (dr, di) = tab[1].coarse(wq);
    let (fre, fim) = (&tab[0].re[..len], &tab[0].im[..len]);
    let (gre, gim) = (&tab[1].re[..len], &tab[1].im[..len]);
    let (dre, dim, inv) = (&b.det_re[..len], &b.det_im[..len], &b.inv[..len]);
    let sig = &g.sig[r.clone()];
    let (ure, uim, vre, vim) = (
        &g.ure[r.clone()],
        &g.uim[r.clone()],
        &g.vre[r.clone()],
        &g.vim[r.clone()],
    );
    let (y0r, y0i, y1r, y1i, s) = (
        &e.y0re[r.clone()],
        &e.y0im[r.clone()],
        &e.y1re[r.clone()],
        &e.y1im[r.clone()],
        &e.s[r.clone()],
    );
    let (a, bb) = (&e.chans[0], &e.chans[1]);
    let (a2r, a2i, a3r, a3i) = (
        &a.p2re[r.clone()],
        &a.p2im[r.clone()],
        &a.p3re[r.clone()],
        &a.p3im[r.clone()],
    );
    let (b2r, b2i, b3r, b3i) = (
        &bb.p2re[r.clone()],
        &bb.p2im[r.clone()],
        &bb.p3re[r.clone()],
        &bb.p3im[r],
    );
    let mut buf = [0.0; BLOCK];
    for (i, o) in buf[..len].iter_mut().enumerate() {
        let tr = cr * fre[i] - ci * fim[i];
        let ti = cr * fim[i] + ci * fre[i];
        let pr = dre[i] * tr - dim[i] * ti;
        let pi = dre[i] * ti + dim[i] * tr;
        // t2 t1* = e^{iω(Δt1 − Δt2)}
        let wr = dr * gre[i] - di * gim[i];
        let wi = dr * gim[i] + di * gre[i];
        let sg = sig[i];
        // channel 1 (x1)
        let h = k.kappa + k.delta * sg;
        let xr = k.beta * vre[i] + sg + k.w2;
        let xi = k.beta * vim[i];
        let a0r = k.alpha * (xr * a2r[i] - xi * a2i[i] + h * a3r[i]);
        let a0i = k.alpha * (xr * a2i[i] + xi * a2r[i] + h * a3i[i]);
        let m = k.alpha * h * s[i];
        let a1r = m * a2r[i];
        let a1i = m * a2i[i];
        // channel 2 (x12)
        let xr = k.alpha * ure[i] + k.lambda + k.rho * sg;
        let xi = k.alpha * uim[i];
        let es = k.e2 * sg;
        let b0r = k.beta * (es * b2r[i] + xr * b3r[i] - xi * b3i[i]);
        let b0i = k.beta * (es * b2i[i] + xr * b3i[i] + xi * b3r[i]);
        let bs = k.beta * s[i];
        let b1r = bs * (xr * b2r[i] - xi * b2i[i]);
        let b1i = bs * (xr * b2i[i] + xi * b2r[i]);
        let z0r = y0r[i] * pr - y0i[i] * pi - a0r - (wr * b0r - wi * b0i);
        let z0i = y0r[i] * pi + y0i[i] * pr - a0i - (wr * b0i + wi * b0r);
        let z1r = y1r[i] * pr - y1i[i] * pi - a1r - (wr * b1r - wi * b1i);
        let z1i = y1r[i] * pi + y1i[i] * pr - a1i - (wr * b1i + wi * b1r);
        *o = (z0r * z0r + z0i * z0i + z1r * z1r + z1i * z1i) * inv[i];
    }
    sum_lanes(&buf[..len])
}

/// `Σ x` with [`LANES`] independent accumulators (so that it vectorises).
#[inline(always)]
fn sum_lanes(x: &[f64]) -> f64 {
    let mut acc = [0.0; LANES];
    let mut it = x.chunks_exact(LANES);
    for c in &mut it {
        for (a, x) in acc.iter_mut().zip(c) {
            *a += x;
        }
    }
    acc.iter().sum::<f64>() + it.remainder().iter().sum::<f64>()
}

/// Edges per chunk of [`coefficients_batch`] (stack buffers).
const CHUNK: usize = 64;
/// Largest `|ω Δt|` the polynomial `sin_cos` takes (the Cody–Waite reduction is exact for
/// quadrant numbers below 2^20); beyond it the caller falls back to the generic path.
const PHASE_LIMIT: f64 = 1e5;

/// The LTP closed loop's [`super::Model::coefficients_batch`]: only the requested components of
/// `[I | −H_io]`, computed in chunks of [`CHUNK`] edges by vectorisable loops (Cramer's rule as
/// in the module docs, one real division per edge, delay phasors from a branch-free polynomial
/// `sin_cos`). Returns `false` (nothing written) when it does not apply (shape, or phases
/// beyond [`PHASE_LIMIT`]); the caller then uses the generic path.
pub(crate) fn coefficients_batch(
    masses: &Masses,
    theta: &[f64],
    freqs: &[f64],
    consts: &[Complex64],
    comps: &[usize],
    out: &mut [Complex64],
) -> bool {
    let Ok(th) = <&[f64; 7]>::try_from(theta) else {
        return false;
    };
    let n = freqs.len();
    if consts.len() != N_CONSTS * n || out.len() != n * comps.len() || comps.iter().any(|&c| c >= 8)
    {
        return false;
    }
    let wmax = freqs.iter().fold(0.0f64, |m, f| m.max(f.abs())) * 2.0 * PI;
    if !(th[2].abs().max(th[3].abs()) * wmax <= PHASE_LIMIT) {
        return false;
    }
    let e1 = masses.m1 / masses.msc;
    let e2 = masses.m2 / masses.msc;
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
        {
            // SAFETY: the CPU has the features the function is compiled for.
            unsafe { batch_avx2(th, e1, e2, freqs, consts, comps, out) };
            return true;
        }
    }
    batch_dispatch::<false>(th, e1, e2, freqs, consts, comps, out);
    true
}

/// [`batch_impl`] for the injection channels the components need.
#[inline(always)]
fn batch_dispatch<const F: bool>(
    th: &[f64; 7],
    e1: f64,
    e2: f64,
    freqs: &[f64],
    consts: &[Complex64],
    comps: &[usize],
    out: &mut [Complex64],
) {
    let c0 = comps.iter().any(|&c| c == 2 || c == 6);
    let c1 = comps.iter().any(|&c| c == 3 || c == 7);
    match (c0, c1) {
        (true, false) => batch_impl::<true, false, F>(th, e1, e2, freqs, consts, comps, out),
        (false, true) => batch_impl::<false, true, F>(th, e1, e2, freqs, consts, comps, out),
        _ => batch_impl::<true, true, F>(th, e1, e2, freqs, consts, comps, out),
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn batch_avx2(
    th: &[f64; 7],
    e1: f64,
    e2: f64,
    freqs: &[f64],
    consts: &[Complex64],
    comps: &[usize],
    out: &mut [Complex64],
) {
    batch_dispatch::<true>(th, e1, e2, freqs, consts, comps, out)
}

/// The batch; `C0`, `C1`: whether the components of injection channel 1 / 2 are needed.
#[inline(always)]
fn batch_impl<const C0: bool, const C1: bool, const F: bool>(
    th: &[f64; 7],
    e1: f64,
    e2: f64,
    freqs: &[f64],
    consts: &[Complex64],
    comps: &[usize],
    out: &mut [Complex64],
) {
    let k = Coefs::new(th, e1, e2);
    let n = freqs.len();
    let nc = comps.len();
    // H_io entries: [h00, h10, h01, h11] × (re, im)
    let mut h = [[0.0; CHUNK]; 8];
    let mut gath = [[0.0; CHUNK]; 5];
    let mut c0 = 0;
    while c0 < n {
        let len = CHUNK.min(n - c0);
        for i in 0..len {
            let c = &consts[N_CONSTS * (c0 + i)..N_CONSTS * (c0 + i + 1)];
            gath[0][i] = freqs[c0 + i];
            gath[1][i] = c[3].re;
            gath[2][i] = c[3].im;
            gath[3][i] = c[4].re;
            gath[4][i] = c[4].im;
        }
        let [f, ure, uim, vre, vim] = &gath;
        let (f, ure, uim, vre, vim) = (
            &f[..len],
            &ure[..len],
            &uim[..len],
            &vre[..len],
            &vim[..len],
        );
        let [h00r, h00i, h10r, h10i, h01r, h01i, h11r, h11i] = &mut h;
        let (h00r, h00i, h10r, h10i) = (
            &mut h00r[..len],
            &mut h00i[..len],
            &mut h10r[..len],
            &mut h10i[..len],
        );
        let (h01r, h01i, h11r, h11i) = (
            &mut h01r[..len],
            &mut h01i[..len],
            &mut h11r[..len],
            &mut h11i[..len],
        );
        for i in 0..len {
            let w = 2.0 * PI * f[i];
            let s = -w * w;
            let qr = k.ab * vre[i] + k.alpha * (s + k.w2);
            let qi = k.ab * vim[i];
            let rr = k.brho * s + k.bw1mu;
            let poly = (s + k.c1) * s + k.c0;
            let dr = ure[i] * qr - uim[i] * qi + rr * vre[i] + poly;
            let di = ure[i] * qi + uim[i] * qr + rr * vim[i];
            let inv = 1.0 / (dr * dr + di * di);
            // 1/det = conj(det)/|det|²
            let (ir, ii) = (dr * inv, -di * inv);
            // channel 1: F0 = α t1 u / det, H00 = F0 (βv + σ + w2), H10 = F0 (κ + δσ)
            if C0 {
                let (s1, c1) = sin_cos_poly_f::<F>(th[2] * w);
                let (ar, ai) = (ure[i] * ir - uim[i] * ii, ure[i] * ii + uim[i] * ir);
                let (fr, fi) = (k.alpha * (ar * c1 + ai * s1), k.alpha * (ai * c1 - ar * s1));
                let (pr, pi) = (k.beta * vre[i] + s + k.w2, k.beta * vim[i]);
                h00r[i] = fr * pr - fi * pi;
                h00i[i] = fr * pi + fi * pr;
                let hh = k.kappa + k.delta * s;
                h10r[i] = fr * hh;
                h10i[i] = fi * hh;
            }
            // channel 2: F1 = β t2 v / det, H01 = F1 e2 σ, H11 = F1 (αu + λ + ρσ)
            if C1 {
                let (s2, c2) = sin_cos_poly_f::<F>(th[3] * w);
                let (br, bi) = (vre[i] * ir - vim[i] * ii, vre[i] * ii + vim[i] * ir);
                let (gr, gi) = (k.beta * (br * c2 + bi * s2), k.beta * (bi * c2 - br * s2));
                let es = k.e2 * s;
                h01r[i] = gr * es;
                h01i[i] = gi * es;
                let (xr, xi) = (k.alpha * ure[i] + k.lambda + k.rho * s, k.alpha * uim[i]);
                h11r[i] = gr * xr - gi * xi;
                h11i[i] = gr * xi + gi * xr;
            }
        }
        for (j, &c) in comps.iter().enumerate() {
            let dst = out[c0 * nc..(c0 + len) * nc].iter_mut().skip(j).step_by(nc);
            let val =
                |re: &[f64; CHUNK], im: &[f64; CHUNK], i: usize| Complex64::new(-re[i], -im[i]);
            match c {
                2 | 6 | 3 | 7 => {
                    let e = match c {
                        2 => 0,
                        6 => 1,
                        3 => 2,
                        _ => 3,
                    };
                    for (i, o) in dst.enumerate() {
                        *o = val(&h[2 * e], &h[2 * e + 1], i);
                    }
                }
                _ => {
                    let one = if c == 0 || c == 5 { 1.0 } else { 0.0 };
                    for o in dst {
                        *o = Complex64::new(one, 0.0);
                    }
                }
            }
        }
        c0 += len;
    }
}

/// `a·b + c`, fused when `F` (only where the CPU has FMA: otherwise `mul_add` is a libm call).
#[inline(always)]
fn fma<const F: bool>(a: f64, b: f64, c: f64) -> f64 {
    if F { a.mul_add(b, c) } else { a * b + c }
}

/// `(sin x, cos x)` for `|x| ≤` [`PHASE_LIMIT`], branch-free (vectorisable), with fused
/// multiply–adds when `F`: Cody–Waite reduction by π/2 and Taylor polynomials on `[−π/4, π/4]`
/// (truncation below 5e−17), within 2.2e−16 of `f64::sin_cos` (tested).
#[inline(always)]
fn sin_cos_poly_f<const F: bool>(x: f64) -> (f64, f64) {
    const MAGIC: f64 = 6755399441055744.0; // 1.5·2^52: adding it rounds to an integer
    const PIO2_1: f64 = 1.570_796_326_734_125_6; // first 33 bits of π/2
    const PIO2_1T: f64 = 6.077_100_506_506_192e-11; // π/2 − PIO2_1
    // 1/(2k+1)! and 1/(2k)!, highest order first
    const S: [f64; 7] = [
        -1.0 / 1_307_674_368_000.0,
        1.0 / 6_227_020_800.0,
        -1.0 / 39_916_800.0,
        1.0 / 362_880.0,
        -1.0 / 5040.0,
        1.0 / 120.0,
        -1.0 / 6.0,
    ];
    const C: [f64; 7] = [
        1.0 / 20_922_789_888_000.0,
        -1.0 / 87_178_291_200.0,
        1.0 / 479_001_600.0,
        -1.0 / 3_628_800.0,
        1.0 / 40_320.0,
        -1.0 / 720.0,
        1.0 / 24.0,
    ];
    let t = x * std::f64::consts::FRAC_2_PI + MAGIC;
    let q = t.to_bits() & 3;
    let nq = t - MAGIC;
    let r = (x - nq * PIO2_1) - nq * PIO2_1T;
    let z = r * r;
    let mut sp = S[0];
    let mut cp = C[0];
    for i in 1..7 {
        sp = fma::<F>(sp, z, S[i]);
        cp = fma::<F>(cp, z, C[i]);
    }
    let sn = fma::<F>(r * z, sp, r);
    let cs = fma::<F>(z * z, cp, 1.0 - 0.5 * z);
    let (a, b) = if q & 1 == 1 { (cs, sn) } else { (sn, cs) };
    let sa = f64::from_bits(a.to_bits() ^ ((q & 2) << 62));
    let sb = f64::from_bits(b.to_bits() ^ (((q + 1) & 2) << 62));
    (sa, sb)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::likelihood::tests::{likelihood_of, small_study};
    use crate::likelihood::{NoiseSource, SpectraOptions};
    use crate::ltp::LtpParams;
    use crate::model::{LtpModel, Model, residual_power_generic};

    /// θ at the truth, with delays up to 1 s, and far from the truth (other sign of the
    /// stiffnesses, gains at the prior edges, large cross-talk).
    fn thetas() -> Vec<[f64; 7]> {
        let t = LtpParams::default().to_array();
        let mut v = vec![t];
        for (dt1, dt2) in [(0.0, 0.0), (1.0, 1.0), (0.37, 0.93), (1.0, 0.0)] {
            let mut x = t;
            x[2] = dt1;
            x[3] = dt2;
            v.push(x);
        }
        v.push([3e-6, -4.9e-6, 0.9, 0.05, 1.45, 0.55, -9e-4]);
        v.push([-5e-6, 5e-6, 0.01, 0.99, 0.5, 1.5, 1e-3]);
        v.push([1e-9, -1e-9, 0.5, 0.5, 1.0, 1.0, 0.0]);
        v
    }

    fn rel(a: f64, b: f64) -> f64 {
        (a - b).abs() / b.abs()
    }

    #[test]
    fn prepared_kernel_equals_the_generic_path_on_real_spectra() {
        let m = LtpModel::new("ltp", Default::default());
        let mut worst: f64 = 0.0;
        for noise in [NoiseSource::Model, NoiseSource::Welch] {
            let opts = SpectraOptions {
                noise,
                band: [1e-3, 0.3],
                ..Default::default()
            };
            let lik = likelihood_of(&small_study(11, 1e-7, "circular"), &opts);
            for e in lik.spectra() {
                let b = e.block();
                let k = m.prepare_kernel(&b).expect("plain loop has a kernel");
                let kern = LtpKernel::new(&Masses::default(), &[b]).unwrap();
                assert!(matches!(kern.exps[0].active, Active::One(_)));
                for th in thetas() {
                    let fast = k.residual_power(&th);
                    let slow = residual_power_generic(&m, &th, &b);
                    worst = worst.max(rel(fast, slow));
                    assert!(rel(fast, slow) <= 1e-11, "{th:?}: {fast} vs {slow}");
                    // the generic (non-AVX) code path gives the same
                    let g = kern.eval_generic(&th);
                    assert!(rel(g, slow) <= 1e-11, "{th:?}: {g} vs {slow}");
                }
                // two experiments on one grid share det P
                let two = LtpKernel::new(&Masses::default(), &[b, b]).unwrap();
                let th = thetas()[3];
                let want = 2.0 * residual_power_generic(&m, &th, &b);
                assert!(rel(two.residual_power(&th), want) <= 1e-11);
            }
            // and the likelihood uses the kernels
            for th in thetas() {
                let (a, b) = (lik.residual_power(&th), lik.residual_power_unprepared(&th));
                assert!(rel(a, b) <= 1e-11, "{a} vs {b}");
            }
        }
        eprintln!("prepared LTP kernel vs generic path, worst relative difference {worst:.2e}");
    }

    /// Synthetic data with both injection channels active, none, a non-zero OMS delay and
    /// correlated noise, on a grid whose length is not a multiple of the block.
    #[test]
    fn both_channels_none_and_oms_delay() {
        let m = LtpModel::new(
            "ltp",
            crate::model::LtpModelOptions {
                oms_delay: 0.3,
                ..Default::default()
            },
        );
        let n = 3 * BLOCK + 37;
        let (f0, df, fs) = (1e-3, 1.7e-3, 10.0);
        let mut consts = vec![Complex64::new(0.0, 0.0); n * N_CONSTS];
        for k in 0..n {
            m.bin_consts(
                f0 + k as f64 * df,
                fs,
                &mut consts[k * N_CONSTS..(k + 1) * N_CONSTS],
            );
        }
        let cinv: Vec<_> = (0..n)
            .map(|k| (2.0 + k as f64 * 1e-3, Complex64::new(0.4, -0.7), 3.0))
            .collect();
        let mut worst: f64 = 0.0;
        for mask in [[true, true], [false, false], [true, false], [false, true]] {
            let data: Vec<Complex64> = (0..4 * n)
                .map(|i| {
                    if i % 4 >= 2 && !mask[i % 4 - 2] {
                        Complex64::new(0.0, 0.0)
                    } else {
                        Complex64::new((i as f64 * 0.37).sin(), (i as f64 * 0.91).cos())
                    }
                })
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
            let k = m.prepare_kernel(&b).unwrap();
            for th in thetas() {
                let fast = k.residual_power(&th);
                let slow = residual_power_generic(&m, &th, &b);
                worst = worst.max(rel(fast, slow));
                assert!(
                    rel(fast, slow) <= 1e-11,
                    "{mask:?} {th:?}: {fast} vs {slow}"
                );
            }
        }
        eprintln!("synthetic blocks: worst relative difference {worst:.2e}");
        // no kernel with a thruster response
        let mt = LtpModel::new(
            "ltp",
            crate::model::LtpModelOptions {
                thruster: crate::model::ThrusterResponse::Delay,
                ..Default::default()
            },
        );
        let data = vec![Complex64::new(1.0, 0.0); 4 * n];
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
        assert!(mt.prepare_kernel(&b).is_none());
    }
}

#[cfg(test)]
mod batch_tests {
    use super::*;
    use crate::model::{LtpModel, Model, coefficients_batch_generic};

    #[test]
    fn batch_equals_coefficients_and_sin_cos_is_accurate() {
        let m = LtpModel::new(
            "ltp",
            crate::model::LtpModelOptions {
                oms_delay: 0.2,
                ..Default::default()
            },
        );
        let freqs: Vec<f64> = (0..150).map(|i| 1e-4 * 1.06f64.powi(i)).collect();
        let mut consts = vec![Complex64::new(0.0, 0.0); freqs.len() * N_CONSTS];
        for (k, &f) in freqs.iter().enumerate() {
            m.bin_consts(f, 10.0, &mut consts[k * N_CONSTS..(k + 1) * N_CONSTS]);
        }
        let comps = [2, 6, 3, 7, 0, 1, 4, 5];
        let mut worst: f64 = 0.0;
        let th0 = crate::ltp::LtpParams::default().to_array();
        for th in [
            th0,
            [3e-6, -4.9e-6, 0.9, 0.05, 1.45, 0.55, -9e-4],
            [-5e-6, 5e-6, 1.0, 0.0, 0.5, 1.5, 1e-3],
        ] {
            let mut a = vec![Complex64::new(0.0, 0.0); freqs.len() * comps.len()];
            let mut b = a.clone();
            assert!(coefficients_batch(
                &Masses::default(),
                &th,
                &freqs,
                &consts,
                &comps,
                &mut a
            ));
            coefficients_batch_generic(&m, &th, &freqs, 10.0, &consts, &comps, &mut b);
            for (x, y) in a.iter().zip(&b) {
                let d = (x - y).norm() / y.norm().max(1e-300);
                worst = worst.max(if y.norm() == 0.0 { x.norm() } else { d });
            }
        }
        eprintln!("LTP coefficient batch vs coefficients: worst relative difference {worst:.2e}");
        assert!(worst <= 1e-13);
        let mut w: f64 = 0.0;
        for i in 0..200_000 {
            let x = -PHASE_LIMIT + 2.0 * PHASE_LIMIT * i as f64 / 200_000.0 + 0.123;
            let (s, c) = sin_cos_poly_f::<false>(x);
            let (s0, c0) = x.sin_cos();
            w = w.max((s - s0).abs()).max((c - c0).abs());
            let (s, c) = sin_cos_poly_f::<true>(x);
            w = w.max((s - s0).abs()).max((c - c0).abs());
        }
        for i in 0..20_000 {
            let x = -40.0 + 80.0 * i as f64 / 20_000.0;
            let (s, c) = sin_cos_poly_f::<false>(x);
            let (s0, c0) = x.sin_cos();
            w = w.max((s - s0).abs()).max((c - c0).abs());
        }
        eprintln!("polynomial sin_cos: worst absolute difference {w:.2e}");
        assert!(w <= 1e-15);
    }
}
