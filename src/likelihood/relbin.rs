//! Fast likelihood by relative binning (heterodyning; Cornish 2010, arXiv:1007.4820; Zackay,
//! Dai & Venumadhav 2018, arXiv:1806.08792).
//!
//! Around a fiducial θ0 (the MAP), the ratio `r_ij(f; θ) = H_ij(f; θ)/H_ij(f; θ0)` of every
//! transfer-matrix element is smooth in `f`. Interpolating `δr = r − 1` linearly across coarse
//! bins turns the sums over all fine bins into sums over coarse bins of precomputed summary
//! data. The likelihood is written around the fiducial residual `R0 = Y − h0`, so no term is
//! of order ρ² and nothing cancels catastrophically:
//!
//! ```text
//! ln L̃ = ln_norm − Σ R0ᴴC⁻¹R0 + 2 Re Σ Δhᴴ C⁻¹ R0 − Σ Δhᴴ C⁻¹ Δh,   Δh_i = Σ_j δr̃_ij g_ij,
//! g_ij,k = H_ij(f_k; θ0) I_j,k,   δr̃(x) = u + v x,  x = (f − f_lo)/(f_hi − f_lo)
//! ```
//!
//! With summaries `A_p = Σ x^p g*ᵢ (C⁻¹R0)ᵢ` (p = 0, 1) and `B_p = Σ x^p g*_c C⁻¹_{c c'} g_c'`
//! (p = 0, 1, 2) per coarse bin, `ln L̃` is *exact* for the interpolated template; the only
//! approximation is the linear interpolation of `δr`.

use super::exact::LtpLikelihood;
use super::fisher::fisher_exact;
use super::spectra::ExperimentSpectra;
use crate::density::LogDensity;
use crate::hermitian;
use crate::lti::delay;
use crate::ltp::{BinConsts, LoopKernel, Masses, N_PARAMS, response};
use crate::prior::Prior;
use nalgebra::DMatrix;
use num_complex::Complex64;
use serde::{Deserialize, Serialize};

/// How the coarse bins are chosen.
///
/// Bins are built greedily from the low end: a bin grows while, for every test point θ_p (the
/// fiducial moved by `n_sigma` along each principal axis of the Fisher covariance, clipped to
/// the prior box), the interpolation error of the template inside it stays below `tolerance`:
/// `max_p Σ_{k ∈ bin} e_kᴴ C_k⁻¹ e_k ≤ tolerance`, `e_k = h̃_k(θ_p) − h_k(θ_p)`. The error of
/// `ln L̃` is then bounded by `Σ_bins` of that plus a cross term `2 Re Σ eᴴC⁻¹(Y − h)` of the
/// order of its square root times the residual. Measured on the Table I study (200 random
/// points of the 5σ ellipsoid, `tests/table1.rs`): tolerance 1e−9 → 363 coarse bins, worst
/// `|Δ ln L|` 6.7e−4; 1e−8 (the default) → 267 bins, 3.2e−3; 3e−8 → 228 bins, 4.4e−3.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RelBinOptions {
    /// Radius (in standard deviations of the Fisher covariance) of the region the
    /// approximation must hold in.
    pub n_sigma: f64,
    /// Largest template interpolation error `Σ eᴴC⁻¹e` allowed in one coarse bin.
    pub tolerance: f64,
}

impl Default for RelBinOptions {
    fn default() -> Self {
        Self {
            n_sigma: 6.0,
            tolerance: 1e-8,
        }
    }
}

/// Errors building the relative-binned likelihood.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum RelBinError {
    #[error("relative binning: {0}")]
    Invalid(String),
}

const ZERO: Complex64 = Complex64::new(0.0, 0.0);

/// One experiment's summary data.
#[derive(Debug, Clone)]
struct Summary {
    /// Loop constants at the coarse-bin edges.
    edges: Vec<BinConsts>,
    /// Active components `(output i, input j)`.
    comps: Vec<(usize, usize)>,
    /// Active input channels.
    inputs: Vec<usize>,
    /// `1/H_ij(edge; θ0)` per edge, per component.
    h0inv: Vec<Complex64>,
    /// `[A0, A1]` per (coarse bin, component).
    a: Vec<[Complex64; 2]>,
    /// `[B0, B1, B2]` per (coarse bin, component, component).
    b: Vec<[Complex64; 3]>,
}

/// `ln L` by relative binning around a fiducial point; same value convention as
/// [`LtpLikelihood`].
#[derive(Debug, Clone)]
pub struct RelBinLikelihood {
    exps: Vec<Summary>,
    masses: Masses,
    prior: Prior,
    /// `ln_norm − Σ R0ᴴ C⁻¹ R0` at the fiducial point.
    base: f64,
    fiducial: [f64; N_PARAMS],
    n_coarse: usize,
}

impl RelBinLikelihood {
    /// Summarises `exact`'s data around the fiducial point `fid` (usually the MAP), with
    /// coarse bins chosen so the approximation holds within `opts.n_sigma` of `fid` (see
    /// [`RelBinOptions`]).
    pub fn new(
        exact: &LtpLikelihood,
        fid: &[f64; N_PARAMS],
        opts: &RelBinOptions,
    ) -> Result<Self, RelBinError> {
        if !(opts.n_sigma > 0.0 && opts.n_sigma.is_finite() && opts.tolerance > 0.0) {
            return Err(RelBinError::Invalid(format!(
                "n_sigma and tolerance must be > 0 (got {} and {})",
                opts.n_sigma, opts.tolerance
            )));
        }
        let tests = test_points(exact, fid, opts.n_sigma);
        let masses = *exact.masses();
        let mut base = exact.ln_norm();
        let mut exps = Vec::new();
        let mut n_coarse = 0;
        for e in exact.spectra() {
            let (s, r0) = summarise(e, fid, &masses, &tests, opts.tolerance)?;
            base -= r0;
            n_coarse += s.edges.len() - 1;
            exps.push(s);
        }
        Ok(Self {
            exps,
            masses,
            prior: exact.prior().clone(),
            base,
            fiducial: *fid,
            n_coarse,
        })
    }

    /// The fiducial point.
    pub fn fiducial(&self) -> &[f64; N_PARAMS] {
        &self.fiducial
    }

    /// Number of coarse bins over all experiments.
    pub fn n_coarse(&self) -> usize {
        self.n_coarse
    }

    /// `ln L̃` at a full parameter vector. Allocation-free.
    pub fn ln_likelihood_full(&self, th: &[f64; N_PARAMS]) -> f64 {
        let kern = LoopKernel::new(th, &self.masses);
        let mut lin = 0.0;
        let mut quad = 0.0;
        for s in &self.exps {
            let nc = s.comps.len();
            // δr at the previous edge, per component (at most 4 components)
            let mut prev = [ZERO; 4];
            for (ei, edge) in s.edges.iter().enumerate() {
                let mut cur = [ZERO; 4];
                for &j in &s.inputs {
                    let mut unit = [ZERO; 2];
                    unit[j] = delay(th[2 + j], edge.f);
                    let col = kern.eval(edge, [Complex64::new(1.0, 0.0); 2], unit);
                    for (c, &(i, jj)) in s.comps.iter().enumerate() {
                        if jj == j {
                            cur[c] = col[i] * s.h0inv[ei * nc + c] - 1.0;
                        }
                    }
                }
                if ei > 0 {
                    let b = ei - 1;
                    let u = &prev;
                    let mut v = [ZERO; 4];
                    for c in 0..nc {
                        v[c] = cur[c] - prev[c];
                    }
                    for c in 0..nc {
                        let a = s.a[b * nc + c];
                        lin += (u[c].conj() * a[0] + v[c].conj() * a[1]).re;
                        // B_p is Hermitian in (c, c'): real diagonal, and each off-diagonal
                        // pair contributes twice the real part of one ordering
                        let bb = s.b[(b * nc + c) * nc + c];
                        quad += u[c].norm_sqr() * bb[0].re
                            + 2.0 * (u[c].conj() * v[c]).re * bb[1].re
                            + v[c].norm_sqr() * bb[2].re;
                        for c2 in c + 1..nc {
                            let bb = s.b[(b * nc + c) * nc + c2];
                            quad += 2.0
                                * (u[c].conj() * u[c2] * bb[0]
                                    + (u[c].conj() * v[c2] + v[c].conj() * u[c2]) * bb[1]
                                    + v[c].conj() * v[c2] * bb[2])
                                    .re;
                        }
                    }
                }
                prev = cur;
            }
        }
        self.base + 2.0 * lin - quad
    }
}

/// Test points: the fiducial moved by `n_sigma` along ± each principal axis of the Fisher
/// covariance over all seven parameters, each step shortened if needed to stay in the prior
/// box. Directions the data do not constrain (eigenvalues of F below 1e−12 of the largest)
/// are skipped.
fn test_points(exact: &LtpLikelihood, fid: &[f64; N_PARAMS], n_sigma: f64) -> Vec<[f64; N_PARAMS]> {
    let free: Vec<usize> = (0..N_PARAMS).collect();
    let f = fisher_exact(exact, fid, &free);
    // scale to unit diagonal so the eigen-decomposition is well conditioned
    let d: Vec<f64> = (0..N_PARAMS).map(|i| f[(i, i)].sqrt()).collect();
    let fs = DMatrix::from_fn(N_PARAMS, N_PARAMS, |i, j| {
        if d[i] > 0.0 && d[j] > 0.0 {
            f[(i, j)] / (d[i] * d[j])
        } else {
            0.0
        }
    });
    let eig = fs.symmetric_eigen();
    let lmax = eig.eigenvalues.iter().cloned().fold(0.0, f64::max);
    let bounds = exact.prior().bounds();
    let mut pts = vec![*fid];
    for (m, &lam) in eig.eigenvalues.iter().enumerate() {
        if !(lam > 1e-12 * lmax) {
            continue;
        }
        for sign in [-1.0, 1.0] {
            let mut step = [0.0; N_PARAMS];
            for i in 0..N_PARAMS {
                if d[i] > 0.0 {
                    step[i] = sign * n_sigma * eig.eigenvectors[(i, m)] / (lam.sqrt() * d[i]);
                }
            }
            // shorten to stay inside the prior box
            let mut t: f64 = 1.0;
            for i in 0..N_PARAMS {
                let (lo, hi) = bounds[i];
                let x = fid[i] + step[i];
                if x > hi && step[i] > 0.0 {
                    t = t.min((hi - fid[i]) / step[i]);
                } else if x < lo && step[i] < 0.0 {
                    t = t.min((lo - fid[i]) / step[i]);
                }
            }
            let t = t.max(0.0);
            pts.push(std::array::from_fn(|i| fid[i] + t * step[i]));
        }
    }
    pts
}

/// Summary data of one experiment; returns it and `Σ R0ᴴ C⁻¹ R0`.
fn summarise(
    e: &ExperimentSpectra,
    fid: &[f64; N_PARAMS],
    masses: &Masses,
    tests: &[[f64; N_PARAMS]],
    tolerance: f64,
) -> Result<(Summary, f64), RelBinError> {
    let inputs: Vec<usize> = (0..2).filter(|&j| e.active[j]).collect();
    let comps: Vec<(usize, usize)> = inputs.iter().flat_map(|&j| [(0, j), (1, j)]).collect();
    let nc = comps.len();
    let nk = e.len();
    if nk < 2 {
        return Err(RelBinError::Invalid(format!(
            "experiment `{}` has {nk} bin in band; relative binning needs at least 2",
            e.name
        )));
    }
    let column = |th: &[f64; N_PARAMS], bc: &BinConsts, j: usize| {
        let mut unit = [ZERO; 2];
        unit[j] = Complex64::new(1.0, 0.0);
        response(th, bc, masses, unit)
    };
    // fiducial transfer elements and their ratios at every test point, on the fine grid
    let mut h0 = vec![ZERO; nk * nc];
    for k in 0..nk {
        for &j in &inputs {
            let col = column(fid, &e.consts[k], j);
            for (c, &(i, jj)) in comps.iter().enumerate() {
                if jj == j {
                    h0[k * nc + c] = col[i];
                }
            }
        }
    }
    if let Some(k) = (0..nk * nc).find(|&x| !(h0[x].norm() > 0.0 && h0[x].norm().is_finite())) {
        let (i, j) = comps[k % nc];
        return Err(RelBinError::Invalid(format!(
            "experiment `{}`: H_io[{i}][{j}] at the fiducial point is {} at {} Hz; cannot form ratios",
            e.name,
            h0[k],
            e.freqs[k / nc]
        )));
    }
    let np = tests.len();
    let mut dr = vec![ZERO; np * nk * nc];
    for (p, th) in tests.iter().enumerate() {
        for k in 0..nk {
            for &j in &inputs {
                let col = column(th, &e.consts[k], j);
                for (c, &(i, jj)) in comps.iter().enumerate() {
                    if jj == j {
                        dr[(p * nk + k) * nc + c] = col[i] / h0[k * nc + c] - 1.0;
                    }
                }
            }
        }
    }
    // interpolation error of the template inside fine bins k0..=k1, worst test point
    let cost = |k0: usize, k1: usize| -> f64 {
        let mut worst: f64 = 0.0;
        for p in 0..np {
            let mut s = 0.0;
            for k in k0 + 1..k1 {
                let x = (e.freqs[k] - e.freqs[k0]) / (e.freqs[k1] - e.freqs[k0]);
                let mut err = [ZERO; 2];
                for (c, &(i, j)) in comps.iter().enumerate() {
                    let a = dr[(p * nk + k0) * nc + c];
                    let b = dr[(p * nk + k1) * nc + c];
                    let lin = a + (b - a) * x;
                    err[i] += (dr[(p * nk + k) * nc + c] - lin) * h0[k * nc + c] * e.inj[k][j];
                }
                s += hermitian::quad(&e.cinv[k], err);
            }
            worst = worst.max(s);
        }
        worst
    };
    let mut edge_k = vec![0usize];
    let mut k0 = 0;
    while k0 + 1 < nk {
        // exponential search for a failing end, then bisection
        let mut good = k0 + 1;
        let mut step = 1;
        let mut bad = None;
        while good < nk - 1 {
            let t = (good + step).min(nk - 1);
            if cost(k0, t) <= tolerance {
                good = t;
                step *= 2;
            } else {
                bad = Some(t);
                break;
            }
        }
        if let Some(mut b) = bad {
            while b - good > 1 {
                let mid = (good + b) / 2;
                if cost(k0, mid) <= tolerance {
                    good = mid;
                } else {
                    b = mid;
                }
            }
        }
        edge_k.push(good);
        k0 = good;
    }
    let edge_f: Vec<f64> = edge_k.iter().map(|&k| e.freqs[k]).collect();
    let edges: Vec<BinConsts> = edge_k.iter().map(|&k| e.consts[k]).collect();
    let mut h0inv = Vec::with_capacity(edges.len() * nc);
    for &k in &edge_k {
        for c in 0..nc {
            h0inv.push(1.0 / h0[k * nc + c]);
        }
    }
    let nb = edges.len() - 1;
    let mut a = vec![[ZERO; 2]; nb * nc];
    let mut b = vec![[ZERO; 3]; nb * nc * nc];
    let mut r0sum = 0.0;
    let mut bin = 0;
    for k in 0..e.len() {
        let f = e.freqs[k];
        while bin + 1 < nb && f >= edge_f[bin + 1] {
            bin += 1;
        }
        let x = (f - edge_f[bin]) / (edge_f[bin + 1] - edge_f[bin]);
        let mut g = [ZERO; 4];
        let mut hf = [ZERO; 2];
        for (c, &(i, j)) in comps.iter().enumerate() {
            g[c] = h0[k * nc + c] * e.inj[k][j];
            hf[i] += g[c];
        }
        let r0 = [e.y[k][0] - hf[0], e.y[k][1] - hf[1]];
        let (ca, cb, cc) = e.cinv[k];
        r0sum += hermitian::quad(&e.cinv[k], r0);
        // C⁻¹ = [[a, b], [b*, c]]
        let cinv = [
            [Complex64::new(ca, 0.0), cb],
            [cb.conj(), Complex64::new(cc, 0.0)],
        ];
        let w = [
            cinv[0][0] * r0[0] + cinv[0][1] * r0[1],
            cinv[1][0] * r0[0] + cinv[1][1] * r0[1],
        ];
        let xp = [1.0, x, x * x];
        for c in 0..nc {
            let (i, _) = comps[c];
            let t = g[c].conj() * w[i];
            let slot = &mut a[bin * nc + c];
            slot[0] += t;
            slot[1] += t * x;
            for c2 in 0..nc {
                let (i2, _) = comps[c2];
                let t = g[c].conj() * cinv[i][i2] * g[c2];
                let slot = &mut b[(bin * nc + c) * nc + c2];
                for p in 0..3 {
                    slot[p] += t * xp[p];
                }
            }
        }
    }
    Ok((
        Summary {
            edges,
            comps,
            inputs,
            h0inv,
            a,
            b,
        },
        r0sum,
    ))
}

impl LogDensity for RelBinLikelihood {
    fn ln_likelihood(&self, theta: &[f64]) -> f64 {
        match <&[f64; N_PARAMS]>::try_from(theta) {
            Ok(th) => self.ln_likelihood_full(th),
            Err(_) => f64::NAN,
        }
    }

    fn prior(&self) -> &Prior {
        &self.prior
    }
}
