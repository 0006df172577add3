//! Fast likelihood by relative binning (heterodyning; Cornish 2010, arXiv:1007.4820; Zackay,
//! Dai & Venumadhav 2018, arXiv:1806.08792).
//!
//! Works for any [`crate::model::Model`]: its coefficients `M_rc(f; θ)` are smooth in `f`.
//! Around a fiducial θ0 (the MAP), the relative change `δ_rc(f; θ) = (M_rc(f; θ) −
//! M_rc(f; θ0))/s_rc(f)` of every θ-dependent coefficient is smooth in `f`, with the scale
//! `s_rc = M_rc(f; θ0)` (a ratio, as for the closed loop's `H_io(θ)/H_io(θ0)`) or, for a
//! coefficient that vanishes somewhere at θ0 (a cross-talk term at δ21 = 0), `s_rc = 1` (a
//! difference). Interpolating `δ` linearly across coarse bins turns the sums over all fine bins
//! into sums over coarse bins of precomputed summary data. The likelihood is written around the
//! fiducial residual `r0`, so no term is of order ρ² and nothing cancels catastrophically:
//!
//! ```text
//! ln L̃ = ln_norm − Σ r0ᴴC⁻¹r0 − 2 Re Σ Δrᴴ C⁻¹ r0 − Σ Δrᴴ C⁻¹ Δr,   Δr_r = Σ_c δ̃_rc g_rc,
//! g_rc,k = s_rc(f_k) d_c,k,   δ̃(x) = u + v x,  x = (f − f_lo)/(f_hi − f_lo)
//! ```
//!
//! With summaries `A_p = Σ x^p g*_rc (C⁻¹r0)_r` (p = 0, 1) and `B_p = Σ x^p g*_rc C⁻¹_{r r'}
//! g_r'c'` (p = 0, 1, 2) per coarse bin, `ln L̃` is *exact* for the interpolated residual; the
//! only approximation is the linear interpolation of `δ`. Coefficients that do not depend on θ
//! (the closed loop's identity on `o`) and inactive channels drop out of the summaries.

use super::exact::Likelihood;
use super::fisher::fisher_exact;
use super::spectra::ExperimentSpectra;
use crate::density::LogDensity;
use crate::hermitian;
use crate::linalg;
use crate::model::{BatchKernel, Bin, MAX_CHANNELS, MAX_RESIDUALS, Model, residual_into, tri_len};
use crate::prior::Prior;
use nalgebra::DMatrix;
use num_complex::Complex64;
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, StandardNormal};
use rand_xoshiro::Xoshiro256PlusPlus;
use serde::{Deserialize, Serialize};
use std::sync::Arc;

/// How the coarse bins are chosen and checked.
///
/// Bins are built greedily from the low end: a bin grows while, for every build point θ_p,
/// the interpolation error of the residual inside it stays below `tolerance`:
/// `max_p Σ_{k ∈ bin} e_kᴴ C_k⁻¹ e_k ≤ tolerance`, `e_k = r̃_k(θ_p) − r_k(θ_p)`. The error of
/// `ln L̃` is then bounded by `Σ_bins` of that plus a cross term `2 Re Σ eᴴC⁻¹r` of the
/// order of its square root times the residual. Measured on the Table I study (200 random
/// points of the 5σ ellipsoid, `tests/table1.rs`): tolerance 1e−9 → 363 coarse bins, worst
/// `|Δ ln L|` 6.7e−4; 1e−8 (the default) → 267 bins, 3.2e−3; 3e−8 → 228 bins, 4.4e−3.
///
/// The *region* the approximation must hold in is a Gaussian around the fiducial point (the
/// Fisher covariance there, or a covariance the caller passes, e.g. of a chain), out to
/// `n_sigma`, clipped to the prior box; along a parameter whose Gaussian σ exceeds a quarter
/// of its prior width (the posterior fills the box) the region is the whole box. Build
/// points: the fiducial, `±n_sigma` along each principal axis (each coordinate clamped to
/// the box, so a step is never shortened to nothing on a corner) and `n_build` random points
/// of the region. After building, `|ln L̃ − ln L|` is measured at `n_validation` further
/// random points of the region ([`RelBinValidation`]); while it exceeds `max_delta_ln_l`,
/// `tolerance` is divided by 10 and the bins rebuilt (at most [`MAX_REFINEMENTS`] times, and
/// not beyond `max_coarse` coarse bins). If that fails: [`RelBinError::ToleranceNotMet`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RelBinOptions {
    /// Radius (in standard deviations of the region's Gaussian) of the region the
    /// approximation must hold in.
    pub n_sigma: f64,
    /// Largest residual interpolation error `Σ eᴴC⁻¹e` allowed in one coarse bin (first
    /// build; refinement divides it by 10).
    pub tolerance: f64,
    /// Largest `|ln L̃ − ln L|` (nats) accepted at the validation points.
    pub max_delta_ln_l: f64,
    /// Random points of the region the bins are built on (besides the axis points).
    pub n_build: usize,
    /// Random points of the region (independent of the build points) the error is measured
    /// at.
    pub n_validation: usize,
    /// Cap on the number of coarse bins refinement may reach; `None`: no cap.
    pub max_coarse: Option<usize>,
    /// Seed of the random build and validation points.
    pub seed: u64,
}

impl Default for RelBinOptions {
    fn default() -> Self {
        Self {
            n_sigma: 6.0,
            tolerance: 1e-8,
            max_delta_ln_l: 0.05,
            n_build: 16,
            n_validation: 64,
            max_coarse: None,
            seed: 0x7265_6c62,
        }
    }
}

/// Refinements (tolerance ÷ 10 each) tried before giving up.
pub const MAX_REFINEMENTS: usize = 4;

/// Errors building the relative-binned likelihood.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum RelBinError {
    #[error("relative binning: {0}")]
    Invalid(String),
    /// The measured error stays above the limit after refinement: use the exact likelihood.
    #[error(
        "relative binning: worst |Δ ln L| = {worst:.3e} over {n_points} validation points exceeds {limit:.3e} with {n_coarse} coarse bins after {refinements} refinements{}; use the exact likelihood instead ([analysis] likelihood = \"exact\" in the study)",
        max_coarse.map_or(String::new(), |c| format!(" (cap {c} coarse bins)"))
    )]
    ToleranceNotMet {
        worst: f64,
        limit: f64,
        n_points: usize,
        n_coarse: usize,
        refinements: usize,
        max_coarse: Option<usize>,
    },
}

/// How well the relative-binned likelihood was measured to hold (for `summary.json`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RelBinValidation {
    /// Validation points where `ln L` was compared (the fiducial and `n_validation` random
    /// points of the region).
    pub n_points: usize,
    /// Worst `|ln L̃ − ln L|` over them (nats).
    pub worst_abs_delta_ln_l: f64,
    /// Where it occurred (full parameter vector).
    pub worst_point: Vec<f64>,
    /// The limit it was checked against (`max_delta_ln_l`).
    pub limit: f64,
    /// Residual tolerance per coarse bin of the final build.
    pub tolerance: f64,
    /// Refinements needed.
    pub refinements: usize,
    /// Coarse bins of the final build.
    pub n_coarse: usize,
    /// Per parameter: the fraction of its prior width the validation points span (1 for a
    /// parameter drawn over the whole box, 0 for a fixed one; `NaN` for an unbounded prior).
    pub coverage: Vec<f64>,
    /// Names of the parameters whose region is the whole prior box (Gaussian wider than it).
    pub box_params: Vec<String>,
}

const ZERO: Complex64 = Complex64::new(0.0, 0.0);
const MAX_COMPS: usize = MAX_CHANNELS * MAX_RESIDUALS;

/// One experiment's summary data.
#[derive(Debug, Clone)]
struct Summary {
    /// The model as it applies to this experiment ([`Likelihood::model_of`]).
    model: Arc<dyn Model>,
    /// Frequencies of the coarse-bin edges.
    edge_f: Vec<f64>,
    /// The model's constants at the edges, `edges × n_consts`.
    edge_consts: Vec<Complex64>,
    /// Varying components: `r·C + c` indices into the coefficient matrix.
    comps: Vec<usize>,
    /// `δ = M·inv_s − off` per (edge, component).
    inv_s: Vec<Complex64>,
    off: Vec<Complex64>,
    /// `[A0, A1]` per (coarse bin, component).
    a: Vec<[Complex64; 2]>,
    /// `[B0, B1, B2]` per (coarse bin, component, component).
    b: Vec<[Complex64; 3]>,
    /// The same summaries per edge, for the batched evaluation: with `δ̃ = δ_L (1 − x) + δ_R x`
    /// the linear term is `Re Σ_e δ_eᴴ w_e` (`w` per (edge, component) gathers `Σ (1−x) g*C⁻¹r0`
    /// of the bin to the right and `Σ x g*C⁻¹r0` of the bin to the left), the quadratic term
    /// `Σ_e δ_eᴴ h_e δ_e + 2 Re Σ_b δ_bᴴ x_b δ_{b+1}` (`h` per (edge, component, component)
    /// gathers `Σ (1−x)² g*C⁻¹g` and `Σ x² g*C⁻¹g`; `x` per (coarse bin, component,
    /// component) is `Σ (1−x) x g*C⁻¹g`).
    /// Structure of arrays: `w` at `[c·edges + e]`, `h` at `[(c·nc + c')·edges + e]`, `x` at
    /// `[(c·nc + c')·bins + b]`, real and imaginary parts apart (so the contraction vectorises
    /// over edges).
    w_re: Vec<f64>,
    w_im: Vec<f64>,
    h_re: Vec<f64>,
    h_im: Vec<f64>,
    x_re: Vec<f64>,
    x_im: Vec<f64>,
    fs: f64,
    /// The model's prepared coefficients ([`Model::prepare_batch`]) per chunk of edges of the
    /// batched evaluation ([`edges_per_chunk`]); empty when the model prepares none.
    batch: Vec<Arc<dyn BatchKernel>>,
}

/// Edges per chunk of the batched evaluation when the widest experiment has `widest`
/// components: the `EC1 − 1` that [`RelBinLikelihood::ln_likelihood_full`] chooses.
fn edges_per_chunk(widest: usize) -> usize {
    match widest {
        0..=16 => CHUNK1 - 1,
        17..=64 => 32,
        _ => 8,
    }
}

/// Edges per chunk of the batched evaluation (stack buffer of coefficients), plus one: the
/// buffers of `δ` also hold the edge before the chunk. Up to 16 components; wider models take
/// shorter chunks (`eval`'s `EC1`).
const CHUNK1: usize = 65;

/// `ln L` by relative binning around a fiducial point; same value convention as
/// [`Likelihood`].
#[derive(Debug, Clone)]
pub struct RelBinLikelihood {
    exps: Vec<Summary>,
    model: Arc<dyn Model>,
    prior: Prior,
    /// `ln_norm − Σ r0ᴴ C⁻¹ r0` at the fiducial point.
    base: f64,
    fiducial: Vec<f64>,
    n_coarse: usize,
    /// Boxed: the struct is held by value in enums next to small variants.
    validation: Box<RelBinValidation>,
    /// Evaluations refused at unstable parameter values ([`super::stability`]).
    unstable: super::stability::UnstableCount,
}

impl RelBinLikelihood {
    /// Summarises `exact`'s data around the fiducial point `fid` (usually the MAP), with
    /// coarse bins chosen and validated in the region of the Fisher covariance at `fid` over
    /// all parameters (see [`RelBinOptions`]).
    pub fn new(exact: &Likelihood, fid: &[f64], opts: &RelBinOptions) -> Result<Self, RelBinError> {
        check_inputs(exact, fid, opts)?;
        let region = Region::from_fisher(exact, fid);
        Self::build(exact, fid, opts, &region)
    }

    /// As [`RelBinLikelihood::new`], with the region given by the covariance `cov` of the
    /// parameters `free` (e.g. the inverse Fisher matrix at the MAP over a model's free
    /// parameters, or a chain's covariance); the other parameters stay at `fid`.
    pub fn with_covariance(
        exact: &Likelihood,
        fid: &[f64],
        opts: &RelBinOptions,
        free: &[usize],
        cov: &DMatrix<f64>,
    ) -> Result<Self, RelBinError> {
        check_inputs(exact, fid, opts)?;
        let region = Region::from_covariance(fid.len(), free, cov)?;
        Self::build(exact, fid, opts, &region)
    }

    fn build(
        exact: &Likelihood,
        fid: &[f64],
        opts: &RelBinOptions,
        region: &Region,
    ) -> Result<Self, RelBinError> {
        let bounds = exact.prior().bounds();
        let names = exact.model().param_names();
        let box_params: Vec<usize> = (0..fid.len())
            .filter(|&i| region.spans_box(i, &bounds))
            .collect();
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(opts.seed);
        let mut build = region.axis_points(fid, &bounds, opts.n_sigma);
        build.extend(region.random_points(fid, &bounds, opts.n_sigma, opts.n_build, &mut rng));
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(opts.seed ^ 0x05ee_d0f7_a11d);
        let mut check = vec![fid.to_vec()];
        check.extend(region.random_points(fid, &bounds, opts.n_sigma, opts.n_validation, &mut rng));
        let exact_at: Vec<f64> = check
            .iter()
            .map(|t| exact.ln_likelihood_whittle(t))
            .collect();
        let coverage = (0..fid.len())
            .map(|i| {
                let (lo, hi) = bounds[i];
                let (mn, mx) = check
                    .iter()
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), t| {
                        (a.min(t[i]), b.max(t[i]))
                    });
                (mx - mn) / (hi - lo)
            })
            .collect();
        let n_fine: usize = exact.spectra().iter().map(|e| e.len() - 1).sum();
        let mut tolerance = opts.tolerance;
        let mut refinements = 0;
        loop {
            let mut rb = Self::summarise_all(exact, fid, &build, tolerance)?;
            let mut worst = 0.0;
            let mut worst_point = fid.to_vec();
            let mut n_points = 0;
            for (t, &l) in check.iter().zip(&exact_at) {
                if !l.is_finite() {
                    continue;
                }
                n_points += 1;
                let d = (rb.ln_likelihood_full(t) - l).abs();
                // NaN counts as the worst possible
                if !(d <= worst) {
                    worst = d;
                    worst_point = t.clone();
                }
            }
            if worst <= opts.max_delta_ln_l {
                rb.validation = Box::new(RelBinValidation {
                    n_points,
                    worst_abs_delta_ln_l: worst,
                    worst_point,
                    limit: opts.max_delta_ln_l,
                    tolerance,
                    refinements,
                    n_coarse: rb.n_coarse,
                    coverage,
                    box_params: box_params.iter().map(|&i| names[i].clone()).collect(),
                });
                return Ok(rb);
            }
            let capped = opts.max_coarse.is_some_and(|c| rb.n_coarse >= c);
            if capped || refinements == MAX_REFINEMENTS || rb.n_coarse >= n_fine {
                return Err(RelBinError::ToleranceNotMet {
                    worst,
                    limit: opts.max_delta_ln_l,
                    n_points,
                    n_coarse: rb.n_coarse,
                    refinements,
                    max_coarse: opts.max_coarse,
                });
            }
            tolerance /= 10.0;
            refinements += 1;
        }
    }

    /// Summaries of every experiment with bins built on the points `tests`.
    fn summarise_all(
        exact: &Likelihood,
        fid: &[f64],
        tests: &[Vec<f64>],
        tolerance: f64,
    ) -> Result<Self, RelBinError> {
        let model = exact.model().clone();
        let mut base = exact.ln_norm();
        let mut exps = Vec::new();
        let mut n_coarse = 0;
        for (ei, e) in exact.spectra().iter().enumerate() {
            let (s, r0) = summarise(exact.model_of(ei), e, fid, tests, tolerance)?;
            base -= r0;
            n_coarse += s.edge_f.len() - 1;
            exps.push(s);
        }
        let widest = exps.iter().map(|s| s.comps.len()).max().unwrap_or(0);
        let chunk = edges_per_chunk(widest);
        let ncst = model.n_consts();
        for s in &mut exps {
            let ne = s.edge_f.len();
            s.batch = (0..ne)
                .step_by(chunk)
                .map_while(|e0| {
                    let e1 = (e0 + chunk).min(ne);
                    s.model.prepare_batch(
                        &s.edge_f[e0..e1],
                        s.fs,
                        &s.edge_consts[e0 * ncst..e1 * ncst],
                        &s.comps,
                    )
                })
                .collect();
            if s.batch.len() != ne.div_ceil(chunk) {
                s.batch.clear();
            }
        }
        Ok(Self {
            exps,
            model,
            prior: exact.prior().clone(),
            base,
            fiducial: fid.to_vec(),
            n_coarse,
            unstable: Default::default(),
            validation: Box::new(RelBinValidation {
                n_points: 0,
                worst_abs_delta_ln_l: f64::NAN,
                worst_point: Vec::new(),
                limit: f64::NAN,
                tolerance,
                refinements: 0,
                n_coarse,
                coverage: Vec::new(),
                box_params: Vec::new(),
            }),
        })
    }

    /// How the approximation was validated: worst measured `|Δ ln L|`, points, coverage.
    pub fn validation(&self) -> &RelBinValidation {
        &self.validation
    }

    /// The fiducial point.
    pub fn fiducial(&self) -> &[f64] {
        &self.fiducial
    }

    /// Number of coarse bins over all experiments.
    pub fn n_coarse(&self) -> usize {
        self.n_coarse
    }

    /// Evaluations refused so far because the model's system was unstable there
    /// ([`super::stability`]).
    pub fn unstable_evaluations(&self) -> u64 {
        self.unstable.get()
    }

    /// `ln L̃` at a full parameter vector (`−∞` where the model's system is unstable).
    /// Allocation-free.
    ///
    /// Per experiment: the model's coefficients at every edge in one call per chunk of edges
    /// (the batch the model prepared for that chunk, [`Model::prepare_batch`], else
    /// [`Model::coefficients_batch`]), then the per-edge summaries contracted in real
    /// arithmetic.
    pub fn ln_likelihood_full(&self, th: &[f64]) -> f64 {
        if th.len() != self.fiducial.len() {
            return f64::NAN;
        }
        if !self.unstable.admit(self.model.as_ref(), th) {
            return f64::NEG_INFINITY;
        }
        // stack buffers sized for the widest experiment (zeroing them is not free); wide ones
        // take shorter chunks of edges so the buffers stay within ~150 KiB of stack
        let widest = self.exps.iter().map(|s| s.comps.len()).max().unwrap_or(0);
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx2")
                && std::arch::is_x86_feature_detected!("fma")
            {
                // SAFETY: the CPU has the features the functions are compiled for.
                return unsafe {
                    match widest {
                        0..=4 => self.eval_avx2::<4, CHUNK1>(th),
                        5..=16 => self.eval_avx2::<16, CHUNK1>(th),
                        17..=64 => self.eval_avx2::<64, 33>(th),
                        _ => self.eval_avx2::<MAX_COMPS, 9>(th),
                    }
                };
            }
        }
        match widest {
            0..=4 => self.eval::<4, CHUNK1>(th),
            5..=16 => self.eval::<16, CHUNK1>(th),
            17..=64 => self.eval::<64, 33>(th),
            _ => self.eval::<MAX_COMPS, 9>(th),
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn eval_avx2<const NB: usize, const EC1: usize>(&self, th: &[f64]) -> f64 {
        self.eval::<NB, EC1>(th)
    }

    /// The batched evaluation with buffers for at most `NB` components and chunks of
    /// `EC1 − 1` edges.
    #[inline(always)]
    fn eval<const NB: usize, const EC1: usize>(&self, th: &[f64]) -> f64 {
        assert_eq!(
            EC1 - 1,
            edges_per_chunk(self.exps.iter().map(|s| s.comps.len()).max().unwrap_or(0)),
            "the prepared batches are chunked as the evaluation"
        );
        let mut buf = [[ZERO; EC1]; NB];
        // δ per component, structure of arrays; index 0 is the edge before the chunk
        let mut dre = [[0.0; EC1]; NB];
        let mut dim = [[0.0; EC1]; NB];
        let mut lin = 0.0;
        let mut quad = 0.0;
        for s in &self.exps {
            // constant component counts let the compiler specialise the loops
            let (l, q) = match s.comps.len() {
                1 => self.eval_exp(s, th, 1, &mut buf, &mut dre, &mut dim),
                2 => self.eval_exp(s, th, 2, &mut buf, &mut dre, &mut dim),
                n => self.eval_exp(s, th, n, &mut buf, &mut dre, &mut dim),
            };
            lin += l;
            quad += q;
        }
        self.base - 2.0 * lin - quad
    }

    /// The linear and quadratic terms of one experiment (`nc` components).
    #[inline(always)]
    fn eval_exp<const NB: usize, const EC1: usize>(
        &self,
        s: &Summary,
        th: &[f64],
        nc: usize,
        buf: &mut [[Complex64; EC1]; NB],
        dre: &mut [[f64; EC1]; NB],
        dim: &mut [[f64; EC1]; NB],
    ) -> (f64, f64) {
        let m = s.model.as_ref();
        let ncst = m.n_consts();
        let ne = s.edge_f.len();
        let (mut lin, mut quad) = (0.0, 0.0);
        let mut e0 = 0;
        while e0 < ne {
            let len = (EC1 - 1).min(ne - e0);
            let d = &mut buf.as_flattened_mut()[..len * nc];
            if s.batch.is_empty() {
                m.coefficients_batch(
                    th,
                    &s.edge_f[e0..e0 + len],
                    s.fs,
                    &s.edge_consts[e0 * ncst..(e0 + len) * ncst],
                    &s.comps,
                    d,
                );
            } else {
                s.batch[e0 / (EC1 - 1)].coefficients(th, d);
            }
            let is = &s.inv_s[e0 * nc..(e0 + len) * nc];
            let off = &s.off[e0 * nc..(e0 + len) * nc];
            for c in 0..nc {
                let (dr, di) = (&mut dre[c][1..=len], &mut dim[c][1..=len]);
                for i in 0..len {
                    let j = i * nc + c;
                    let v = d[j] * is[j] - off[j];
                    dr[i] = v.re;
                    di[i] = v.im;
                }
            }
            let (l, q) = contract(nc, s, e0, len, dre, dim);
            lin += l;
            quad += q;
            for c in 0..nc {
                dre[c][0] = dre[c][len];
                dim[c][0] = dim[c][len];
            }
            e0 += len;
        }
        (lin, quad)
    }

    /// `ln L̃` by the first, unbatched evaluation ([`Model::coefficients`] edge by edge,
    /// polynomial summaries per coarse bin): the reference the batched
    /// [`RelBinLikelihood::ln_likelihood_full`] is tested against.
    pub fn ln_likelihood_unbatched(&self, th: &[f64]) -> f64 {
        if th.len() != self.fiducial.len() {
            return f64::NAN;
        }
        let ncst = self.model.n_consts();
        let ncoef = self.model.data_channels().len() * self.model.residual_channels().len();
        let mut coef = [ZERO; MAX_COMPS];
        let mut lin = 0.0;
        let mut quad = 0.0;
        for s in &self.exps {
            let m = s.model.as_ref();
            let nc = s.comps.len();
            // δ at the previous edge, per component
            let mut prev = [ZERO; MAX_COMPS];
            for (ei, &f) in s.edge_f.iter().enumerate() {
                let bin = Bin {
                    f,
                    fs: s.fs,
                    consts: &s.edge_consts[ei * ncst..(ei + 1) * ncst],
                };
                m.coefficients(th, &bin, &mut coef[..ncoef]);
                let mut cur = [ZERO; MAX_COMPS];
                for (c, &idx) in s.comps.iter().enumerate() {
                    cur[c] = coef[idx] * s.inv_s[ei * nc + c] - s.off[ei * nc + c];
                }
                if ei > 0 {
                    let b = ei - 1;
                    let u = &prev;
                    let mut v = [ZERO; MAX_COMPS];
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
        self.base - 2.0 * lin - quad
    }
}

/// Re-lays `v` (`n × m`, row-major) out as `m × n`, one part of each complex value.
fn soa(v: &[Complex64], n: usize, m: usize, part: impl Fn(&Complex64) -> f64) -> Vec<f64> {
    (0..m)
        .flat_map(|j| (0..n).map(move |i| (i, j)))
        .map(|(i, j)| part(&v[i * m + j]))
        .collect()
}

/// The linear and quadratic terms of the `len` edges `e0..e0 + len` of one experiment; `δ` of
/// component `c` at edge `e0 + i` is `(dre, dim)[c][1 + i]`, at the edge before the chunk
/// `[c][0]`. Loops run over edges, so they vectorise.
#[inline(always)]
fn contract<const NB: usize, const EC1: usize>(
    nc: usize,
    s: &Summary,
    e0: usize,
    len: usize,
    dre: &[[f64; EC1]; NB],
    dim: &[[f64; EC1]; NB],
) -> (f64, f64) {
    let ne = s.edge_f.len();
    let nb = ne - 1;
    let mut lb = [0.0; EC1];
    let mut qb = [0.0; EC1];
    let (lb, qb) = (&mut lb[..len], &mut qb[..len]);
    for c in 0..nc {
        let (dr, di) = (&dre[c][1..=len], &dim[c][1..=len]);
        let (wr, wi) = (
            &s.w_re[c * ne + e0..c * ne + e0 + len],
            &s.w_im[c * ne + e0..c * ne + e0 + len],
        );
        let hr = &s.h_re[(c * nc + c) * ne + e0..(c * nc + c) * ne + e0 + len];
        for i in 0..len {
            lb[i] += dr[i] * wr[i] + di[i] * wi[i];
            qb[i] += (dr[i] * dr[i] + di[i] * di[i]) * hr[i];
        }
        for c2 in c + 1..nc {
            let o = (c * nc + c2) * ne + e0;
            let (hr, hi) = (&s.h_re[o..o + len], &s.h_im[o..o + len]);
            let (d2r, d2i) = (&dre[c2][1..=len], &dim[c2][1..=len]);
            for i in 0..len {
                let yr = hr[i] * d2r[i] - hi[i] * d2i[i];
                let yi = hr[i] * d2i[i] + hi[i] * d2r[i];
                qb[i] += 2.0 * (dr[i] * yr + di[i] * yi);
            }
        }
    }
    // coarse bins (e − 1, e) for the edges e of the chunk (none left of edge 0)
    let i0 = usize::from(e0 == 0);
    let n = len - i0;
    for c in 0..nc {
        let (pr, pi) = (&dre[c][i0..i0 + n], &dim[c][i0..i0 + n]);
        for c2 in 0..nc {
            let o = (c * nc + c2) * nb + e0 + i0 - 1;
            let (xr, xi) = (&s.x_re[o..o + n], &s.x_im[o..o + n]);
            let (d2r, d2i) = (&dre[c2][i0 + 1..i0 + 1 + n], &dim[c2][i0 + 1..i0 + 1 + n]);
            let q = &mut qb[i0..];
            for i in 0..n {
                let yr = xr[i] * d2r[i] - xi[i] * d2i[i];
                let yi = xr[i] * d2i[i] + xi[i] * d2r[i];
                q[i] += 2.0 * (pr[i] * yr + pi[i] * yi);
            }
        }
    }
    (sum_lanes(lb), sum_lanes(qb))
}

/// `Σ x` with 8 independent accumulators (so that it vectorises).
#[inline(always)]
fn sum_lanes(x: &[f64]) -> f64 {
    let mut acc = [0.0; 8];
    let mut it = x.chunks_exact(8);
    for c in &mut it {
        for (a, x) in acc.iter_mut().zip(c) {
            *a += x;
        }
    }
    acc.iter().sum::<f64>() + it.remainder().iter().sum::<f64>()
}

/// Checks shared by the constructors.
fn check_inputs(exact: &Likelihood, fid: &[f64], opts: &RelBinOptions) -> Result<(), RelBinError> {
    if !(opts.n_sigma > 0.0
        && opts.n_sigma.is_finite()
        && opts.tolerance > 0.0
        && opts.max_delta_ln_l > 0.0)
    {
        return Err(RelBinError::Invalid(format!(
            "n_sigma, tolerance and max_delta_ln_l must be > 0 (got {}, {} and {})",
            opts.n_sigma, opts.tolerance, opts.max_delta_ln_l
        )));
    }
    if fid.len() != exact.model().param_names().len() {
        return Err(RelBinError::Invalid(format!(
            "the fiducial point has {} entries; model `{}` has {} parameters",
            fid.len(),
            exact.model().name(),
            exact.model().param_names().len()
        )));
    }
    if !exact.prior().contains(fid) {
        return Err(RelBinError::Invalid(format!(
            "the fiducial point {fid:?} is outside the prior box; pass the (bounded) MAP"
        )));
    }
    Ok(())
}

/// A Gaussian `fid + Σ_m z_m a_m` (full-length axes `a_m`), with per-parameter marginal σ
/// (infinite along directions the data do not constrain).
struct Region {
    axes: Vec<Vec<f64>>,
    sigma: Vec<f64>,
}

impl Region {
    /// The Fisher covariance at `fid` over all parameters. Directions the data do not
    /// constrain (eigenvalues of the unit-diagonal Fisher matrix below 1e−12 of the largest)
    /// get no axis, and the parameters in them an infinite σ (their region is the box).
    fn from_fisher(exact: &Likelihood, fid: &[f64]) -> Self {
        let np = fid.len();
        let free: Vec<usize> = (0..np).collect();
        let f = fisher_exact(exact, fid, &free);
        // scale to unit diagonal so the eigen-decomposition is well conditioned
        let (fs, d) = linalg::unit_diagonal(&f);
        let eig = linalg::symmetric_eigen(fs);
        let lmax = eig.eigenvalues.iter().cloned().fold(0.0, f64::max);
        let mut axes = Vec::new();
        let mut sigma = vec![0.0f64; np];
        for (m, &lam) in eig.eigenvalues.iter().enumerate() {
            let v = eig.eigenvectors.column(m);
            if !(lam > 1e-12 * lmax) {
                for i in 0..np {
                    if v[i].abs() > 1e-6 {
                        sigma[i] = f64::INFINITY;
                    }
                }
                continue;
            }
            let a: Vec<f64> = (0..np)
                .map(|i| {
                    if d[i] > 0.0 {
                        v[i] / (lam.sqrt() * d[i])
                    } else {
                        0.0
                    }
                })
                .collect();
            for i in 0..np {
                sigma[i] += a[i] * a[i];
            }
            axes.push(a);
        }
        for i in 0..np {
            sigma[i] = if d[i] > 0.0 {
                sigma[i].sqrt()
            } else {
                f64::INFINITY
            };
        }
        Self { axes, sigma }
    }

    fn from_covariance(np: usize, free: &[usize], cov: &DMatrix<f64>) -> Result<Self, RelBinError> {
        let k = free.len();
        if cov.shape() != (k, k) || free.iter().any(|&i| i >= np) {
            return Err(RelBinError::Invalid(format!(
                "the region covariance is {}×{} for {k} free parameters (indices {free:?} of {np})",
                cov.nrows(),
                cov.ncols()
            )));
        }
        if cov.iter().any(|v| !v.is_finite()) {
            return Err(RelBinError::Invalid(
                "the region covariance has non-finite entries".into(),
            ));
        }
        let sym = linalg::symmetrised(cov);
        let eig = linalg::symmetric_eigen(sym.clone());
        let lmax = eig.eigenvalues.iter().cloned().fold(0.0, f64::max);
        if eig.eigenvalues.iter().any(|&l| l < -1e-9 * lmax) || !(lmax > 0.0) {
            return Err(RelBinError::Invalid(format!(
                "the region covariance is not positive semi-definite (eigenvalues {:?})",
                eig.eigenvalues.as_slice()
            )));
        }
        let mut axes = Vec::new();
        for (m, &lam) in eig.eigenvalues.iter().enumerate() {
            if lam <= 0.0 {
                continue;
            }
            let mut a = vec![0.0; np];
            for (j, &i) in free.iter().enumerate() {
                a[i] = lam.sqrt() * eig.eigenvectors[(j, m)];
            }
            axes.push(a);
        }
        let mut sigma = vec![0.0; np];
        for (j, &i) in free.iter().enumerate() {
            sigma[i] = sym[(j, j)].max(0.0).sqrt();
        }
        Ok(Self { axes, sigma })
    }

    /// Whether parameter `i`'s region is its whole prior box: its Gaussian σ exceeds a
    /// quarter of the (finite) prior width, so ±2σ spans the box.
    fn spans_box(&self, i: usize, bounds: &[(f64, f64)]) -> bool {
        let (lo, hi) = bounds[i];
        (hi - lo).is_finite() && self.sigma[i] > 0.0 && 4.0 * self.sigma[i] >= hi - lo
    }

    /// The fiducial and `fid ± n_sigma a_m`, each coordinate clamped to the box.
    fn axis_points(&self, fid: &[f64], bounds: &[(f64, f64)], n_sigma: f64) -> Vec<Vec<f64>> {
        let mut pts = vec![fid.to_vec()];
        for a in &self.axes {
            for sign in [-1.0, 1.0] {
                pts.push(
                    (0..fid.len())
                        .map(|i| (fid[i] + sign * n_sigma * a[i]).clamp(bounds[i].0, bounds[i].1))
                        .collect(),
                );
            }
        }
        pts
    }

    /// `n` points uniform in the `n_sigma` ellipsoid, with the parameters that span their box
    /// drawn uniformly over it, every coordinate clamped to the box.
    fn random_points(
        &self,
        fid: &[f64],
        bounds: &[(f64, f64)],
        n_sigma: f64,
        n: usize,
        rng: &mut Xoshiro256PlusPlus,
    ) -> Vec<Vec<f64>> {
        let m = self.axes.len();
        let wide: Vec<bool> = (0..fid.len()).map(|i| self.spans_box(i, bounds)).collect();
        (0..n)
            .map(|_| {
                let mut z: Vec<f64> = (0..m).map(|_| StandardNormal.sample(rng)).collect();
                let norm = z.iter().map(|v| v * v).sum::<f64>().sqrt();
                let u: f64 = rng.random();
                let r = if m > 0 {
                    n_sigma * u.powf(1.0 / m as f64)
                } else {
                    0.0
                };
                if norm > 0.0 {
                    z.iter_mut().for_each(|v| *v *= r / norm);
                }
                let mut x = fid.to_vec();
                for (a, zm) in self.axes.iter().zip(&z) {
                    for i in 0..x.len() {
                        x[i] += zm * a[i];
                    }
                }
                for i in 0..x.len() {
                    let (lo, hi) = bounds[i];
                    if wide[i] {
                        x[i] = lo + (hi - lo) * rng.random::<f64>();
                    }
                    x[i] = x[i].clamp(lo, hi);
                }
                x
            })
            .collect()
    }
}

/// `C_k⁻¹` (`R × R` row-major) into `cinv` and `C_k⁻¹ r0`: from the packed inverse for
/// `R ≤ 2` (the arithmetic of every result so far), else `WᴴW` and `Wᴴ(W r0)`.
fn inverse_at(
    e: &ExperimentSpectra,
    k: usize,
    nr: usize,
    r0: &[Complex64; MAX_RESIDUALS],
    cinv: &mut [Complex64],
) -> [Complex64; MAX_RESIDUALS] {
    let mut cr0 = [ZERO; MAX_RESIDUALS];
    if nr <= 2 {
        // C⁻¹ = [[a, b], [b*, c]]
        let (ca, cb, cc) = e.cinv[k];
        let c2 = [
            [Complex64::new(ca, 0.0), cb],
            [cb.conj(), Complex64::new(cc, 0.0)],
        ];
        for i in 0..nr {
            cr0[i] = c2[i][0] * r0[0] + c2[i][1] * r0[1];
            for j in 0..nr {
                cinv[i * nr + j] = c2[i][j];
            }
        }
        return cr0;
    }
    let w = e.whitener(k);
    let at = |i: usize, j: usize| w[tri_len(i) + j];
    let mut wr = [ZERO; MAX_RESIDUALS];
    hermitian::whiten(w, &r0[..nr], &mut wr[..nr]);
    for i in 0..nr {
        for j in 0..nr {
            cinv[i * nr + j] = (i.max(j)..nr).map(|l| at(l, i).conj() * at(l, j)).sum();
        }
        cr0[i] = (i..nr).map(|l| at(l, i).conj() * wr[l]).sum();
    }
    cr0
}

/// Summary data of one experiment; returns it and `Σ r0ᴴ C⁻¹ r0`.
fn summarise(
    model: &Arc<dyn Model>,
    e: &ExperimentSpectra,
    fid: &[f64],
    tests: &[Vec<f64>],
    tolerance: f64,
) -> Result<(Summary, f64), RelBinError> {
    let m = model.as_ref();
    let nk = e.len();
    if nk < 2 {
        return Err(RelBinError::Invalid(format!(
            "experiment `{}` has {nk} bin in band; relative binning needs at least 2",
            e.name
        )));
    }
    let ndc = m.data_channels().len();
    let nr = m.residual_channels().len();
    let ncoef = nr * ndc;
    let ncst = m.n_consts();
    let coefs = |th: &[f64]| -> Vec<Complex64> {
        let mut out = vec![ZERO; nk * ncoef];
        for k in 0..nk {
            m.coefficients(th, &e.bin(k, ncst), &mut out[k * ncoef..(k + 1) * ncoef]);
        }
        out
    };
    let m0 = coefs(fid);
    let at_tests: Vec<Vec<Complex64>> = tests.iter().map(|t| coefs(t)).collect();
    if let Some(x) = m0
        .iter()
        .position(|z| !(z.re.is_finite() && z.im.is_finite()))
    {
        return Err(RelBinError::Invalid(format!(
            "experiment `{}`: coefficient {} of model `{}` at the fiducial point is {} at {} Hz",
            e.name,
            x % ncoef,
            m.name(),
            m0[x],
            e.freqs[x / ncoef]
        )));
    }
    // the varying components of active channels; ratio where M0 never vanishes
    let mut comps = Vec::new();
    let mut ratio = Vec::new();
    for idx in 0..ncoef {
        let c = idx % ndc;
        if !e.active[c] {
            continue;
        }
        let varies = at_tests
            .iter()
            .any(|t| (0..nk).any(|k| t[k * ncoef + idx] != m0[k * ncoef + idx]));
        if !varies {
            continue;
        }
        comps.push(idx);
        ratio.push((0..nk).all(|k| m0[k * ncoef + idx].norm() > 0.0));
    }
    let nc = comps.len();
    let scale = |k: usize, c: usize| {
        if ratio[c] {
            m0[k * ncoef + comps[c]]
        } else {
            Complex64::new(1.0, 0.0)
        }
    };
    let delta = |t: &[Complex64], k: usize, c: usize| {
        let idx = comps[c];
        if ratio[c] {
            t[k * ncoef + idx] / m0[k * ncoef + idx] - 1.0
        } else {
            t[k * ncoef + idx] - m0[k * ncoef + idx]
        }
    };
    let np = tests.len();
    let mut dr = vec![ZERO; np * nk * nc];
    for (p, t) in at_tests.iter().enumerate() {
        for k in 0..nk {
            for c in 0..nc {
                dr[(p * nk + k) * nc + c] = delta(t, k, c);
            }
        }
    }
    // interpolation error of the residual inside fine bins k0..=k1, worst test point
    let cost = |k0: usize, k1: usize| -> f64 {
        let mut worst: f64 = 0.0;
        for p in 0..np {
            let mut s = 0.0;
            for k in k0 + 1..k1 {
                let x = (e.freqs[k] - e.freqs[k0]) / (e.freqs[k1] - e.freqs[k0]);
                let mut err = [ZERO; MAX_RESIDUALS];
                for (c, &idx) in comps.iter().enumerate() {
                    let a = dr[(p * nk + k0) * nc + c];
                    let b = dr[(p * nk + k1) * nc + c];
                    let lin = a + (b - a) * x;
                    err[idx / ndc] +=
                        (dr[(p * nk + k) * nc + c] - lin) * scale(k, c) * e.data_at(k)[idx % ndc];
                }
                s += e.quad(k, &err[..nr]);
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
    let mut edge_consts = Vec::with_capacity(edge_k.len() * ncst);
    let mut inv_s = Vec::with_capacity(edge_k.len() * nc);
    let mut off = Vec::with_capacity(edge_k.len() * nc);
    for &k in &edge_k {
        edge_consts.extend_from_slice(&e.consts[k * ncst..(k + 1) * ncst]);
        for c in 0..nc {
            if ratio[c] {
                inv_s.push(1.0 / m0[k * ncoef + comps[c]]);
                off.push(Complex64::new(1.0, 0.0));
            } else {
                inv_s.push(Complex64::new(1.0, 0.0));
                off.push(m0[k * ncoef + comps[c]]);
            }
        }
    }
    let nb = edge_k.len() - 1;
    let mut a = vec![[ZERO; 2]; nb * nc];
    let mut b = vec![[ZERO; 3]; nb * nc * nc];
    let mut w = vec![ZERO; (nb + 1) * nc];
    let mut hm = vec![ZERO; (nb + 1) * nc * nc];
    let mut xm = vec![ZERO; nb * nc * nc];
    let mut r0sum = 0.0;
    let mut bin = 0;
    let mut g = [ZERO; MAX_COMPS];
    let mut cinv = vec![ZERO; nr * nr];
    for k in 0..nk {
        let f = e.freqs[k];
        while bin + 1 < nb && f >= edge_f[bin + 1] {
            bin += 1;
        }
        let x = (f - edge_f[bin]) / (edge_f[bin + 1] - edge_f[bin]);
        let d = e.data_at(k);
        for (c, &idx) in comps.iter().enumerate() {
            g[c] = scale(k, c) * d[idx % ndc];
        }
        let mut r0 = [ZERO; MAX_RESIDUALS];
        residual_into(&m0[k * ncoef..(k + 1) * ncoef], d, &mut r0[..nr]);
        r0sum += e.quad(k, &r0[..nr]);
        let cr0 = inverse_at(e, k, nr, &r0, &mut cinv);
        let xp = [1.0, x, x * x];
        let y = 1.0 - x;
        for c in 0..nc {
            let i = comps[c] / ndc;
            let t = g[c].conj() * cr0[i];
            let slot = &mut a[bin * nc + c];
            slot[0] += t;
            slot[1] += t * x;
            w[bin * nc + c] += t * y;
            w[(bin + 1) * nc + c] += t * x;
            for c2 in 0..nc {
                let i2 = comps[c2] / ndc;
                let t = g[c].conj() * cinv[i * nr + i2] * g[c2];
                let slot = &mut b[(bin * nc + c) * nc + c2];
                for p in 0..3 {
                    slot[p] += t * xp[p];
                }
                hm[(bin * nc + c) * nc + c2] += t * (y * y);
                hm[((bin + 1) * nc + c) * nc + c2] += t * (x * x);
                xm[(bin * nc + c) * nc + c2] += t * (y * x);
            }
        }
    }
    Ok((
        Summary {
            model: model.clone(),
            edge_f,
            edge_consts,
            comps,
            inv_s,
            off,
            a,
            b,
            w_re: soa(&w, nb + 1, nc, |z| z.re),
            w_im: soa(&w, nb + 1, nc, |z| z.im),
            h_re: soa(&hm, nb + 1, nc * nc, |z| z.re),
            h_im: soa(&hm, nb + 1, nc * nc, |z| z.im),
            x_re: soa(&xm, nb, nc * nc, |z| z.re),
            x_im: soa(&xm, nb, nc * nc, |z| z.im),
            fs: e.fs,
            batch: Vec::new(),
        },
        r0sum,
    ))
}

impl LogDensity for RelBinLikelihood {
    fn ln_likelihood(&self, theta: &[f64]) -> f64 {
        self.ln_likelihood_full(theta)
    }

    fn prior(&self) -> &Prior {
        &self.prior
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::likelihood::tests::{likelihood_of, small_study};
    use crate::likelihood::{NoiseSource, SpectraOptions};
    use crate::ltp::LtpParams;

    /// A model without a batch override: the default `coefficients_batch` path.
    #[derive(Debug)]
    struct Plain(Arc<dyn Model>);
    impl Model for Plain {
        fn name(&self) -> &str {
            "plain"
        }
        fn param_names(&self) -> &[String] {
            self.0.param_names()
        }
        fn data_channels(&self) -> &[String] {
            self.0.data_channels()
        }
        fn residual_channels(&self) -> &[String] {
            self.0.residual_channels()
        }
        fn n_consts(&self) -> usize {
            self.0.n_consts()
        }
        fn bin_consts(&self, f: f64, fs: f64, out: &mut [Complex64]) {
            self.0.bin_consts(f, fs, out)
        }
        fn coefficients(&self, th: &[f64], bin: &Bin, out: &mut [Complex64]) {
            self.0.coefficients(th, bin, out)
        }
        fn coefficients_dual(
            &self,
            th: &[num_dual::Dual64],
            bin: &Bin,
            out: &mut [num_complex::Complex<num_dual::Dual64>],
        ) {
            self.0.coefficients_dual(th, bin, out)
        }
    }

    #[test]
    fn batched_evaluation_equals_the_unbatched_one() {
        let opts = SpectraOptions {
            noise: NoiseSource::Welch,
            band: [1e-3, 0.3],
            ..Default::default()
        };
        let lik = likelihood_of(&small_study(11, 1e-7, "circular"), &opts);
        let truth = LtpParams::default().to_array();
        let rb = RelBinLikelihood::new(&lik, &truth, &Default::default()).unwrap();
        let plain = Likelihood::new(
            Arc::new(Plain(lik.model().clone())),
            lik.spectra().to_vec(),
            lik.prior().clone(),
        )
        .unwrap();
        let rb_plain = RelBinLikelihood::new(&plain, &truth, &Default::default()).unwrap();
        assert_eq!(rb.n_coarse(), rb_plain.n_coarse());
        let mut pts = vec![truth];
        for (i, dt) in [(2, 1.0), (3, 0.0), (4, 1e-3), (0, 2e-7), (6, 1e-4)] {
            let mut t = truth;
            t[i] += if (2..=3).contains(&i) { dt - t[i] } else { dt };
            pts.push(t);
        }
        pts.push([3e-6, -4.9e-6, 0.9, 0.05, 1.45, 0.55, -9e-4]);
        let mut worst: f64 = 0.0;
        for t in &pts {
            let reference = rb.ln_likelihood_unbatched(t);
            for got in [rb.ln_likelihood_full(t), rb_plain.ln_likelihood_full(t)] {
                let rel = (got - reference).abs() / reference.abs();
                // and relative to the θ-dependent part, so the constant cannot hide anything
                let part = (got - reference).abs() / (rb.base - reference).abs().max(1e-300);
                worst = worst.max(rel);
                assert!(rel <= 1e-12, "{t:?}: {got} vs {reference}");
                assert!(
                    part <= 1e-9,
                    "{t:?}: {got} vs {reference} ({part:e} of the θ part)"
                );
            }
        }
        eprintln!("batched relative binning vs unbatched: worst relative difference {worst:.2e}");
    }

    /// A user model's prepared batches ([`Model::prepare_batch`]) give relative binning the
    /// interpreter's coefficients bit for bit: the same ln L̃ as without them, to the last bit.
    #[test]
    fn prepared_batches_give_the_interpreters_ln_l() {
        let text = include_str!("../../examples/user-model-closed-loop.toml");
        let v: toml::Table = toml::from_str(text).unwrap();
        let mut t = v["model"].as_array().unwrap()[0]
            .as_table()
            .unwrap()
            .clone();
        t.remove("kind");
        let def: crate::model::user::UserModelDef = toml::Value::Table(t).try_into().unwrap();
        let user: Arc<dyn Model> = Arc::new(crate::model::user::UserModel::new(&def).unwrap());
        let opts = SpectraOptions {
            noise: NoiseSource::Welch,
            band: [1e-3, 0.3],
            ..Default::default()
        };
        let study = small_study(11, 1e-7, "circular");
        let truth = LtpParams::default().to_array();
        let spectra = crate::likelihood::tests::spectra_for(&study, &opts, user.as_ref(), &truth);
        let prior = crate::likelihood::tests::wide_prior();
        let lik = Likelihood::new(user.clone(), spectra.clone(), prior.clone()).unwrap();
        let plain = Likelihood::new(Arc::new(Plain(user)), spectra, prior).unwrap();
        let rb = RelBinLikelihood::new(&lik, &truth, &Default::default()).unwrap();
        let rb_plain = RelBinLikelihood::new(&plain, &truth, &Default::default()).unwrap();
        assert!(rb.exps.iter().all(|s| !s.batch.is_empty()));
        assert!(rb_plain.exps.iter().all(|s| s.batch.is_empty()));
        assert_eq!(rb.n_coarse(), rb_plain.n_coarse());
        for (i, x) in [(2, 0.7), (3, 0.05), (4, 0.9), (0, 2e-7), (6, -1e-4)] {
            let mut t = truth;
            t[i] = x;
            let (a, b) = (rb.ln_likelihood_full(&t), rb_plain.ln_likelihood_full(&t));
            assert!(a.is_finite());
            assert_eq!(a.to_bits(), b.to_bits(), "{t:?}: {a} against {b}");
        }
    }

    /// The small study at low SNR (ρ ≈ 5, `Likelihood::snr` at the truth):
    /// the posterior of the delays and the gains fills their prior boxes.
    fn low_snr() -> (Likelihood, Vec<f64>) {
        let opts = SpectraOptions {
            noise: NoiseSource::Model,
            band: [1e-3, 0.3],
            ..Default::default()
        };
        let study = small_study(31, 4e-11, "circular");
        let lik = likelihood_of(&study, &opts);
        let truth = study.truth.to_array().to_vec();
        (lik, truth)
    }

    /// A corner of the box in the delays and gains (the rest at the truth).
    fn corner(truth: &[f64], lik: &Likelihood) -> Vec<f64> {
        let b = lik.prior().bounds();
        let mut fid = truth.to_vec();
        // dt1, dt2 on their lower bound; a_df on its upper, a_sus on its lower bound
        fid[2] = b[2].0;
        fid[3] = b[3].0;
        fid[4] = b[4].1;
        fid[5] = b[5].0;
        fid
    }

    #[test]
    fn validation_on_a_prior_corner_covers_the_box_and_reports_the_true_worst() {
        let (lik, truth) = low_snr();
        assert!(lik.snr(&truth) < 10.0, "{}", lik.snr(&truth));
        let fid = corner(&truth, &lik);
        let opts = RelBinOptions::default();
        let rb = RelBinLikelihood::new(&lik, &fid, &opts).unwrap();
        let v = rb.validation().clone();
        // at ρ ≈ 5 every parameter's Gaussian spans its box: the validation points cover
        // the boxes, not the few steps left inside them from the corner
        for i in 0..lik.param_names().len() {
            assert!(
                v.box_params.contains(&lik.param_names()[i]),
                "{:?}",
                v.box_params
            );
            assert!(v.coverage[i] > 0.8, "parameter {i}: {:?}", v.coverage);
        }
        assert_eq!(v.n_points, opts.n_validation + 1);
        assert!(v.worst_abs_delta_ln_l <= opts.max_delta_ln_l);
        // an independent set of 200 uniform points of the box: the worst error there is
        // within the limit and of the order of the reported worst
        let b = lik.prior().bounds();
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(99);
        let mut worst: f64 = 0.0;
        for _ in 0..200 {
            let t: Vec<f64> = b
                .iter()
                .map(|&(lo, hi)| lo + (hi - lo) * rng.random::<f64>())
                .collect();
            worst = worst.max((rb.ln_likelihood_full(&t) - lik.ln_likelihood_full(&t)).abs());
        }
        eprintln!(
            "relbin on a corner at low SNR: {} coarse bins, reported worst {:.3e} over {} points, independent worst {worst:.3e} over 200",
            rb.n_coarse(),
            v.worst_abs_delta_ln_l,
            v.n_points
        );
        assert!(worst <= opts.max_delta_ln_l, "{worst}");
        assert!(
            worst <= 3.0 * v.worst_abs_delta_ln_l + 1e-3,
            "independent worst {worst} vs reported {}",
            v.worst_abs_delta_ln_l
        );
    }

    #[test]
    fn impossible_tolerance_with_capped_bins_is_a_distinct_error() {
        let (lik, truth) = low_snr();
        let fid = corner(&truth, &lik);
        let opts = RelBinOptions {
            max_delta_ln_l: 1e-14,
            max_coarse: Some(40),
            ..Default::default()
        };
        let err = RelBinLikelihood::new(&lik, &fid, &opts).unwrap_err();
        match &err {
            RelBinError::ToleranceNotMet {
                worst,
                limit,
                n_coarse,
                ..
            } => {
                assert!(*worst > *limit && *n_coarse >= 1, "{err}");
            }
            e => panic!("expected ToleranceNotMet, got {e:?}"),
        }
        assert!(err.to_string().contains("exact likelihood"), "{err}");
    }

    #[test]
    fn given_covariance_sets_the_region_and_is_checked() {
        let (lik, truth) = low_snr();
        let free = [0usize, 1, 6];
        let f = crate::likelihood::fisher_exact(&lik, &truth, &free);
        let cov = linalg::Spd::new(&f).unwrap().inverse();
        let rb = RelBinLikelihood::with_covariance(&lik, &truth, &Default::default(), &free, &cov)
            .unwrap();
        let v = rb.validation();
        // parameters outside `free` never move
        for i in 2..6 {
            assert_eq!(v.coverage[i], 0.0);
        }
        assert!(v.worst_abs_delta_ln_l <= 0.05);
        let bad = DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 0.0, 1.0]);
        assert!(matches!(
            RelBinLikelihood::with_covariance(&lik, &truth, &Default::default(), &free, &bad),
            Err(RelBinError::Invalid(_))
        ));
        let neg = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![1e-14, -1e-12, 1e-8]));
        assert!(matches!(
            RelBinLikelihood::with_covariance(&lik, &truth, &Default::default(), &free, &neg),
            Err(RelBinError::Invalid(_))
        ));
    }
}
