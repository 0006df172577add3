//! Fisher information of any model's residual: exact (dual numbers) and by central
//! differences.
//!
//! `∂_a r_k = Σ_c ∂_a M_c(f_k; θ) d_c,k`; `F_ab = Σ_e Σ_k 2 Re(∂_a r_kᴴ C_k⁻¹ ∂_b r_k)`
//! (ltp-model.md §8.2; for the closed loop `∂r = −∂h`, the same matrix).

use super::exact::Likelihood;
use super::spectra::ExperimentSpectra;
use crate::hermitian;
use crate::linalg::{
    NULL_EIGENVALUE_TOL, NullKind, SpdOptions, format_direction, unconstrained_directions,
    weakest_direction,
};
use crate::model::{MAX_RESIDUALS, Model, residual_into};
use nalgebra::DMatrix;
use num_complex::{Complex, Complex64};
use num_dual::Dual64;

const ZERO: Complex64 = Complex64::new(0.0, 0.0);

/// One residual vector (`R` values used).
type Res = [Complex64; MAX_RESIDUALS];

/// `r_k` and `∂_a r_k` at bin `k` by forward-mode dual numbers in the direction of parameter
/// `a`, written into `r` and `dr` (one value per residual channel; `coef` holds the `R·C` dual
/// coefficients). In place: this runs once per bin and parameter of every Fisher scoring
/// step, where returning the residual arrays by value cost a tenth of a `select` in copies.
#[allow(clippy::too_many_arguments)]
fn dual_residual(
    m: &dyn Model,
    e: &ExperimentSpectra,
    k: usize,
    th: &[f64],
    a: usize,
    buf: &mut [Dual64],
    coef: &mut [Complex<Dual64>],
    (r, dr): (&mut [Complex64], &mut [Complex64]),
) {
    let nc = m.data_channels().len();
    for (b, &t) in buf.iter_mut().zip(th) {
        *b = Dual64::from(t);
    }
    buf[a] = Dual64::from(th[a]).derivative();
    coef.fill(Complex::new(Dual64::from(0.0), Dual64::from(0.0)));
    m.coefficients_dual(buf, &e.bin(k, m.n_consts()), coef);
    let d = e.data_at(k);
    for (i, (ri, dri)) in r.iter_mut().zip(dr.iter_mut()).enumerate() {
        *ri = ZERO;
        *dri = ZERO;
        for c in 0..nc {
            let x = coef[i * nc + c];
            *ri += Complex64::new(x.re.re, x.im.re) * d[c];
            *dri += Complex64::new(x.re.eps, x.im.eps) * d[c];
        }
    }
}

/// `Re(xᴴ C_k⁻¹ y)` for `R ≤ 2` (packed); for more, `x` and `y` are already whitened
/// ([`whiten_all`]) and it is `Re(xᴴ y)`.
#[inline]
fn inner(e: &ExperimentSpectra, k: usize, nr: usize, x: &Res, y: &Res) -> f64 {
    if nr <= 2 {
        return e.inner(k, &x[..nr], &y[..nr]);
    }
    x[..nr]
        .iter()
        .zip(&y[..nr])
        .map(|(a, b)| (a.conj() * b).re)
        .sum()
}

/// Replaces `r` and every `dr[i]` by `W_k r`, `W_k dr[i]`.
fn whiten_all(e: &ExperimentSpectra, k: usize, nr: usize, r: &mut Res, dr: &mut [Res]) {
    let w = e.whitener(k);
    let mut out = [ZERO; MAX_RESIDUALS];
    for x in std::iter::once(r).chain(dr.iter_mut()) {
        hermitian::whiten(w, &x[..nr], &mut out[..nr]);
        x[..nr].copy_from_slice(&out[..nr]);
    }
}

/// Fisher matrix over the parameters `free` (indices into θ) at `th`, with exact derivatives.
pub fn fisher_exact(lik: &Likelihood, th: &[f64], free: &[usize]) -> DMatrix<f64> {
    gradient_and_fisher(lik, th, free).1
}

/// Gradient of `ln L` and the Fisher matrix over `free` at `th`, in one pass over the bins.
///
/// # Formula
/// `∂_a ln L = −2 Re Σ ∂_a r_kᴴ C_k⁻¹ r_k`, `F_ab = 2 Re Σ ∂_a r_kᴴ C_k⁻¹ ∂_b r_k`.
pub fn gradient_and_fisher(
    lik: &Likelihood,
    th: &[f64],
    free: &[usize],
) -> (Vec<f64>, DMatrix<f64>) {
    whole_pass(lik, th, free, true)
}

fn whole_pass(
    lik: &Likelihood,
    th: &[f64],
    free: &[usize],
    ahead: bool,
) -> (Vec<f64>, DMatrix<f64>) {
    let mut g = vec![0.0; free.len()];
    let mut f = [DMatrix::<f64>::zeros(free.len(), free.len())];
    accumulate(lik, th, free, &mut g, &mut f, |_, _| Some(0), ahead);
    let [f] = f;
    (g, f)
}

/// [`gradient_and_fisher`] with every direction evaluated bin by bin in one thread (the
/// oracle of its parallel pass over modelled glitches' directions).
#[cfg(test)]
pub(crate) fn gradient_and_fisher_serial(
    lik: &Likelihood,
    th: &[f64],
    free: &[usize],
) -> (Vec<f64>, DMatrix<f64>) {
    whole_pass(lik, th, free, false)
}

/// The Fisher matrix over `free` at `th` split by where its information comes from: bin `k`
/// of experiment `e` (at frequency `f`) adds to part `group(e, f)`, or to none (a part
/// `≥ n_parts` is none). With a `group` that places every bin, the parts sum to
/// [`fisher_exact`]'s matrix. Used by [`super::information::Information`].
pub fn fisher_parts(
    lik: &Likelihood,
    th: &[f64],
    free: &[usize],
    n_parts: usize,
    group: impl Fn(usize, f64) -> Option<usize>,
) -> Vec<DMatrix<f64>> {
    let mut g = vec![0.0; free.len()];
    let mut f = vec![DMatrix::<f64>::zeros(free.len(), free.len()); n_parts];
    accumulate(
        lik,
        th,
        free,
        &mut g,
        &mut f,
        |e, x| group(e, x).filter(|&p| p < n_parts),
        true,
    );
    f
}

/// `∂_a r_k` of experiment `e` (the `e`-th of `lik`'s spectra) at `th` for every parameter
/// `a` of `free` and bin `k`: `out[(i·K + k)·R + r]` for `free[i]`, `K` bins, `R` residual
/// channels (zero where the experiment's model does not read the parameter). The columns a
/// scan that profiles those parameters correlates against (`jobs::glitch_model`).
pub fn residual_derivatives(
    lik: &Likelihood,
    e: usize,
    th: &[f64],
    free: &[usize],
) -> Vec<Complex64> {
    let m = lik.model_of(e).as_ref();
    let sp = &lik.spectra()[e];
    let nr = m.residual_channels().len();
    let nk = sp.len();
    let mut out = vec![ZERO; free.len() * nk * nr];
    let mut buf = vec![Dual64::from(0.0); th.len()];
    let z = Complex::new(Dual64::from(0.0), Dual64::from(0.0));
    let mut coef = vec![z; nr * m.data_channels().len()];
    let mut r = [ZERO; MAX_RESIDUALS];
    for (i, &a) in free.iter().enumerate() {
        if !m.reads_param(a) {
            continue;
        }
        for k in 0..nk {
            let at = (i * nk + k) * nr;
            let dr = &mut out[at..at + nr];
            dual_residual(m, sp, k, th, a, &mut buf, &mut coef, (&mut r[..nr], dr));
        }
    }
    out
}

/// Adds the gradient of every bin to `g` and its Fisher matrix to `f[group(e, f_k)]`.
fn accumulate(
    lik: &Likelihood,
    th: &[f64],
    free: &[usize],
    g: &mut [f64],
    f: &mut [DMatrix<f64>],
    group: impl Fn(usize, f64) -> Option<usize>,
    ahead: bool,
) {
    let nr = lik.model().residual_channels().len();
    let d = free.len();
    let mut dr = vec![[ZERO; MAX_RESIDUALS]; d];
    let (mut r, mut scratch) = ([ZERO; MAX_RESIDUALS], [ZERO; MAX_RESIDUALS]);
    let mut buf = vec![Dual64::from(0.0); th.len()];
    let z = Complex::new(Dual64::from(0.0), Dual64::from(0.0));
    let mut coef = vec![z; nr * lik.model().data_channels().len()];
    for (ei, e) in lik.spectra().iter().enumerate() {
        let m = lik.model_of(ei).as_ref();
        let ahead = (ahead && crate::model::glitch::carries_glitches(m))
            .then(|| derivatives_ahead(m, e, th, free, nr));
        for k in 0..e.len() {
            // the residual's value is the same from every direction's dual evaluation
            let mut have_r = false;
            for (i, &a) in free.iter().enumerate() {
                // a parameter the experiment's model does not read has no derivative there
                if !m.reads_param(a) {
                    dr[i][..nr].fill(ZERO);
                    continue;
                }
                match &ahead {
                    Some((values, ds)) => {
                        r[..nr].copy_from_slice(&values[k * nr..(k + 1) * nr]);
                        dr[i][..nr].copy_from_slice(&ds[i][k * nr..(k + 1) * nr]);
                    }
                    None => {
                        let out = (&mut r[..nr], &mut dr[i][..nr]);
                        dual_residual(m, e, k, th, a, &mut buf, &mut coef, out);
                    }
                }
                have_r = true;
            }
            match (have_r, free.first()) {
                (true, _) => {}
                (false, Some(&a)) => {
                    let out = (&mut r[..nr], &mut scratch[..nr]);
                    dual_residual(m, e, k, th, a, &mut buf, &mut coef, out);
                }
                (false, None) => r[..nr].fill(ZERO),
            }
            if d == 0 {
                continue;
            }
            if nr > 2 {
                // whiten once per bin: the products are then plain dot products
                whiten_all(e, k, nr, &mut r, &mut dr);
            }
            let part = group(ei, e.freqs[k]);
            for i in 0..d {
                g[i] -= 2.0 * inner(e, k, nr, &dr[i], &r);
                if let Some(p) = part {
                    for j in i..d {
                        f[p][(i, j)] += 2.0 * inner(e, k, nr, &dr[i], &dr[j]);
                    }
                }
            }
        }
    }
    for fp in f.iter_mut() {
        for i in 0..d {
            for j in 0..i {
                fp[(i, j)] = fp[(j, i)];
            }
        }
    }
}

/// Every bin's residual `r_k` (`K × nr`) and, per direction of `free`, `∂_a r_k` (empty where
/// `m` does not read the parameter), the directions in parallel. For a model whose dual path
/// computes the whole record's response at a direction's first bin (modelled glitches: its
/// padded transforms, kept per thread), this spreads those over the cores; the values are the
/// serial pass's, bit for bit (each direction evaluated as there; every direction's residual
/// value is the same).
fn derivatives_ahead(
    m: &dyn Model,
    e: &ExperimentSpectra,
    th: &[f64],
    free: &[usize],
    nr: usize,
) -> (Vec<Complex64>, Vec<Vec<Complex64>>) {
    use rayon::prelude::*;
    let nk = e.len();
    let per: Vec<(Vec<Complex64>, Vec<Complex64>)> = free
        .par_iter()
        .map(|&a| {
            if !m.reads_param(a) {
                return (Vec::new(), Vec::new());
            }
            let mut buf = vec![Dual64::from(0.0); th.len()];
            let z = Complex::new(Dual64::from(0.0), Dual64::from(0.0));
            let mut coef = vec![z; nr * m.data_channels().len()];
            let (mut r, mut dr) = (vec![ZERO; nk * nr], vec![ZERO; nk * nr]);
            for k in 0..nk {
                let at = k * nr..(k + 1) * nr;
                let out = (&mut r[at.clone()], &mut dr[at]);
                dual_residual(m, e, k, th, a, &mut buf, &mut coef, out);
            }
            (r, dr)
        })
        .collect();
    let values = per
        .iter()
        .rev()
        .find(|(r, _)| !r.is_empty())
        .map_or_else(Vec::new, |(r, _)| r.clone());
    (values, per.into_iter().map(|(_, dr)| dr).collect())
}

/// The default central-difference step for parameter `name` at `value`: `ε^{1/3}` relative to
/// the value, with a floor on the scale the parameter is measured on, for parameters that may
/// sit at zero (delays, cross-talk).
pub fn default_step(name: &str, value: f64) -> f64 {
    let floor = match name {
        "w1sq" | "w2sq" => 1e-7,
        "dt1" | "dt2" | "a_df" | "a_sus" | "tau_df" => 1e-2,
        "d21" => 1e-4,
        _ => 1e-3,
    };
    f64::EPSILON.cbrt() * value.abs().max(floor)
}

/// Fisher matrix by central differences of the residual with steps `steps[i]` (per free
/// parameter, or [`default_step`]); an oracle for [`fisher_exact`].
pub fn fisher_numeric(
    lik: &Likelihood,
    th: &[f64],
    free: &[usize],
    steps: Option<&[f64]>,
) -> DMatrix<f64> {
    let names = lik.model().param_names();
    let nc = lik.model().data_channels().len();
    let nr = lik.model().residual_channels().len();
    let d = free.len();
    let mut f = DMatrix::<f64>::zeros(d, d);
    let mut dr = vec![[ZERO; MAX_RESIDUALS]; d];
    let (mut rp, mut rm) = ([ZERO; MAX_RESIDUALS], [ZERO; MAX_RESIDUALS]);
    let mut cp = vec![ZERO; nr * nc];
    let mut cm = vec![ZERO; nr * nc];
    for (ei, e) in lik.spectra().iter().enumerate() {
        let m = lik.model_of(ei);
        for k in 0..e.len() {
            let bin = e.bin(k, m.n_consts());
            for (i, &a) in free.iter().enumerate() {
                let h = steps.map_or_else(|| default_step(&names[a], th[a]), |s| s[i]);
                let mut p = th.to_vec();
                let mut q = th.to_vec();
                p[a] += h;
                q[a] -= h;
                m.coefficients(&p, &bin, &mut cp);
                m.coefficients(&q, &bin, &mut cm);
                residual_into(&cp, e.data_at(k), &mut rp[..nr]);
                residual_into(&cm, e.data_at(k), &mut rm[..nr]);
                for c in 0..nr {
                    dr[i][c] = (rp[c] - rm[c]) / (2.0 * h);
                }
            }
            if nr > 2 {
                whiten_all(e, k, nr, &mut rp, &mut dr);
            }
            for i in 0..d {
                for j in i..d {
                    f[(i, j)] += 2.0 * inner(e, k, nr, &dr[i], &dr[j]);
                }
            }
        }
    }
    for i in 0..d {
        for j in 0..i {
            f[(i, j)] = f[(j, i)];
        }
    }
    f
}

/// Gradient and Hessian of any scalar function `f` of the full parameter vector over the
/// parameters `free` at `th`, by central differences with steps `steps` (per free
/// parameter): `∂_i f ≈ (f(+h_i) − f(−h_i))/2h_i`, `∂_i² f ≈ (f(+h_i) − 2f + f(−h_i))/h_i²`,
/// `∂_i∂_j f` from the four corners `(±h_i, ±h_j)`. Truncation error `O(h²)` times the third
/// (fourth) derivatives; exact for a quadratic up to rounding.
pub fn gradient_hessian_numeric(
    f: &dyn Fn(&[f64]) -> f64,
    th: &[f64],
    free: &[usize],
    steps: &[f64],
) -> (Vec<f64>, DMatrix<f64>) {
    let d = free.len();
    let mut g = vec![0.0; d];
    let mut h = DMatrix::<f64>::zeros(d, d);
    let f0 = f(th);
    let mut x = th.to_vec();
    let at = |x: &mut Vec<f64>, moves: &[(usize, f64)]| {
        for &(a, v) in moves {
            x[a] += v;
        }
        let v = f(x);
        x.copy_from_slice(th);
        v
    };
    for i in 0..d {
        let (a, hi) = (free[i], steps[i]);
        let fp = at(&mut x, &[(a, hi)]);
        let fm = at(&mut x, &[(a, -hi)]);
        g[i] = (fp - fm) / (2.0 * hi);
        h[(i, i)] = (fp - 2.0 * f0 + fm) / (hi * hi);
        for j in 0..i {
            let (b, hj) = (free[j], steps[j]);
            let pp = at(&mut x, &[(a, hi), (b, hj)]);
            let pm = at(&mut x, &[(a, hi), (b, -hj)]);
            let mp = at(&mut x, &[(a, -hi), (b, hj)]);
            let mm = at(&mut x, &[(a, -hi), (b, -hj)]);
            h[(i, j)] = (pp - pm - mp + mm) / (4.0 * hi * hj);
            h[(j, i)] = h[(i, j)];
        }
    }
    (g, h)
}

/// The covariance `J` of the score `∂ ln L` over `free` at `th` when the noise's bins are
/// correlated by the window ([`ExperimentSpectra::window_lags`]: the tapers of the runs between
/// gaps, or a non-rectangular `window`).
///
/// # Formula
/// The Whittle `ln L` treats bins as independent, so its Fisher matrix `F` is the score's
/// covariance only when they are. With `E[r_k r_lᴴ] ≈ R_{k−l} C_k^{½} C_l^{½}` and the whitened
/// derivatives `ã_a,k = W_k ∂_a r_k`,
///
/// ```text
/// J_ab = 2 Re Σ_k Σ_l R_{k−l} ã_a,kᴴ ã_b,l
/// ```
///
/// over each experiment's contiguous in-band bins (`J = F` where every `R_m` with `m ≠ 0` is
/// zero). The pseudo-covariance `E[r_k r_lᵀ] ∝ R_{k+l}` of a real series is left out: it
/// reaches only the lowest bins: a run's bins start at `k ≥ 3` with the Welch estimate, and
/// at `k ≥ 1` with the noise model, where the score at the truth whitened by `J` still has
/// mean square 0.97 ± 0.05 over 100 gapped realisations (the gaps guide). The estimate's covariance is then the sandwich `F⁻¹ J F⁻¹`
/// ([`sandwich_errors`]), which is what covers when the bins are correlated.
///
/// # A noise PSD estimated with `ν` degrees of freedom
/// With the Whittle statistic and a Welch estimate `Ŝ = S X/ν` (`X ~ χ²_ν`, independent of the
/// fit stretch's noise), `F` (made with `Ŝ`) is on average `ν/(ν−2)` times the Fisher matrix
/// of the true `S`, and the score's covariance `ν²/((ν−2)(ν−4))` times it, so the estimate's
/// variance is `ν/(ν−4)` times `F⁻¹`: each bin's terms are scaled by `ν_k/(ν_k − 4)`
/// ([`ExperimentSpectra::noise_dof`], per bin where it varies; infinite for `ν ≤ 4`, where
/// the variance is). Derived for one residual channel; on Table I's two (ν = 29, a factor
/// 1.077 in σ) the gap-free pulls of 100 realisations scatter with sd 1.005–1.116, mean 1.078
/// (`cargo run --release --example gaps_coverage`). The Student-t and Wishart statistics
/// marginalise the estimate in `ln L` itself and get no factor.
pub fn score_covariance(lik: &Likelihood, th: &[f64], free: &[usize]) -> DMatrix<f64> {
    let nr = lik.model().residual_channels().len();
    let d = free.len();
    let mut j = DMatrix::<f64>::zeros(d, d);
    let mut buf = vec![Dual64::from(0.0); th.len()];
    let z = Complex::new(Dual64::from(0.0), Dual64::from(0.0));
    let mut coef = vec![z; nr * lik.model().data_channels().len()];
    let (mut r, mut dr) = ([ZERO; MAX_RESIDUALS], [ZERO; MAX_RESIDUALS]);
    let mut out = [ZERO; MAX_RESIDUALS];
    for (ei, e) in lik.spectra().iter().enumerate() {
        let m = lik.model_of(ei).as_ref();
        let nk = e.len();
        let welch = |k: usize| -> f64 {
            if lik.statistic() != super::statistic::Statistic::Whittle {
                return 1.0;
            }
            let nu = match (&e.noise_dof_per_bin, e.noise_dof) {
                (Some(b), _) => b[k],
                (None, Some(v)) => v,
                (None, None) => return 1.0,
            };
            if nu > 4.0 {
                nu / (nu - 4.0)
            } else {
                f64::INFINITY
            }
        };
        // ã[k·d·nr + i·nr + r]
        let mut a = vec![ZERO; nk * d * nr];
        for k in 0..nk {
            for (i, &p) in free.iter().enumerate() {
                if !m.reads_param(p) {
                    continue;
                }
                let o = (&mut r[..nr], &mut dr[..nr]);
                dual_residual(m, e, k, th, p, &mut buf, &mut coef, o);
                hermitian::whiten(e.whitener(k), &dr[..nr], &mut out[..nr]);
                let at = (k * d + i) * nr;
                a[at..at + nr].copy_from_slice(&out[..nr]);
            }
        }
        let dot = |k: usize, i: usize, l: usize, jj: usize| -> Complex64 {
            let x = &a[(k * d + i) * nr..(k * d + i + 1) * nr];
            let y = &a[(l * d + jj) * nr..(l * d + jj + 1) * nr];
            x.iter().zip(y).map(|(x, y)| x.conj() * y).sum()
        };
        for i in 0..d {
            for jj in i..d {
                let mut s = 0.0;
                for k in 0..nk {
                    let mut b = dot(k, i, k, jj).re;
                    for (mi, rm) in e.window_lags.iter().enumerate() {
                        let lag = mi + 1;
                        if k >= lag {
                            b += (rm * dot(k, i, k - lag, jj)).re;
                        }
                        if k + lag < nk {
                            b += (rm.conj() * dot(k, i, k + lag, jj)).re;
                        }
                    }
                    s += welch(k) * b;
                }
                j[(i, jj)] += 2.0 * s;
            }
        }
    }
    for i in 0..d {
        for jj in 0..i {
            j[(i, jj)] = j[(jj, i)];
        }
    }
    j
}

/// Why the score's covariance ([`score_covariance`]) differs from the Fisher matrix of `lik`,
/// for a message (`"the window … correlates neighbouring bins"`, `"the Welch noise estimate has
/// ν = 29 degrees of freedom"`, or both joined by "and"); `None` when it equals it (every
/// window rectangular over contiguous bins, and the noise PSD the model's or marginalised by
/// the statistic), so the Fisher errors are the estimate's and no sandwich is needed.
pub fn score_covariance_differs(lik: &Likelihood) -> Option<String> {
    let spectra = lik.spectra();
    let mut why = Vec::new();
    if spectra.iter().any(|e| !e.window_lags.is_empty()) {
        why.push(
            "the window (the tapers of the runs between gaps, or a non-rectangular `window`) correlates neighbouring bins"
                .to_string(),
        );
    }
    if lik.statistic() == super::statistic::Statistic::Whittle {
        let nu = spectra
            .iter()
            .filter_map(|e| {
                e.noise_dof_per_bin
                    .as_ref()
                    .and_then(|b| b.iter().copied().reduce(f64::min))
                    .or(e.noise_dof)
            })
            .reduce(f64::min);
        if let Some(nu) = nu {
            why.push(format!(
                "the noise PSD is a Welch estimate with ν = {nu:.0} degrees of freedom (at the fewest), which widens the estimate by √(ν/(ν−4))"
            ));
        }
    }
    (!why.is_empty()).then(|| why.join(" and "))
}

/// Standard deviations `√diag(F⁻¹ J F⁻¹)` of the estimate whose Fisher matrix is `f` and score
/// covariance `j` ([`score_covariance`]); `None` if `f` is singular.
pub fn sandwich_errors(f: &DMatrix<f64>, j: &DMatrix<f64>) -> Option<Vec<f64>> {
    let inv = SpdOptions::lower().factor(f).ok()?.inverse();
    let s = &inv * j * &inv;
    Some((0..f.nrows()).map(|i| s[(i, i)].max(0.0).sqrt()).collect())
}

/// Cramér–Rao standard deviations `√diag(F⁻¹)`; `None` if `F` is singular.
pub fn cramer_rao(f: &DMatrix<f64>) -> Option<Vec<f64>> {
    let inv = SpdOptions::lower().factor(f).ok()?.inverse();
    Some((0..f.nrows()).map(|i| inv[(i, i)].sqrt()).collect())
}

/// What the Fisher matrix `f` over the parameters `names` (its rows, in order) leaves
/// unconstrained, for a message: `` the data do not constrain `a1`, `f_o1`: ln L does not
/// depend on `a1`, `f_o1` (zero Fisher columns) `` or `` the data do not constrain `w1sq`,
/// `w2sq`: null direction 0.71·w1sq − 0.70·w2sq (relative eigenvalue 3.1e-17) ``. When
/// nothing is below [`NULL_EIGENVALUE_TOL`] (a matrix that failed a factorisation by
/// rounding) it names the least-constrained direction instead. The second element is the
/// parameters named, in the order named (for a "fix them" hint).
pub fn describe_unconstrained(f: &DMatrix<f64>, names: &[String]) -> (String, Vec<String>) {
    let mut dirs = unconstrained_directions(f, NULL_EIGENVALUE_TOL);
    let weakest = dirs.is_empty();
    if weakest {
        dirs.extend(weakest_direction(f));
    }
    let name = |i: usize| names.get(i).cloned().unwrap_or_else(|| format!("#{i}"));
    let quoted = |v: &[usize]| {
        v.iter()
            .map(|&i| format!("`{}`", name(i)))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let mut named: Vec<String> = Vec::new();
    for d in &dirs {
        for &(i, _) in &d.weights {
            if !named.contains(&name(i)) {
                named.push(name(i));
            }
        }
    }
    let of_kind = |k: NullKind| -> Vec<usize> {
        dirs.iter()
            .filter(|d| d.kind == k)
            .map(|d| d.weights[0].0)
            .collect()
    };
    let mut parts = Vec::new();
    let zero = of_kind(NullKind::ZeroColumn);
    if !zero.is_empty() {
        parts.push(format!(
            "ln L does not depend on {} (zero Fisher column{})",
            quoted(&zero),
            if zero.len() == 1 { "" } else { "s" }
        ));
    }
    let bad = of_kind(NullKind::NonFinite);
    if !bad.is_empty() {
        parts.push(format!(
            "the Fisher matrix is not finite in the rows of {}",
            quoted(&bad)
        ));
    }
    for d in dirs.iter().filter(|d| d.kind == NullKind::Degenerate) {
        parts.push(format!(
            "null direction {} (relative eigenvalue {})",
            format_direction(d, names),
            crate::numfmt::fmt_short(d.relative_eigenvalue)
        ));
    }
    let all = named
        .iter()
        .map(|n| format!("`{n}`"))
        .collect::<Vec<_>>()
        .join(", ");
    let text = if parts.is_empty() {
        "no parameter to name (the matrix is empty)".to_string()
    } else if weakest {
        format!(
            "no direction is below the relative eigenvalue {NULL_EIGENVALUE_TOL:e}, but the least constrained involves {all}: {}",
            parts[0]
        )
    } else {
        format!("the data do not constrain {all}: {}", parts.join("; "))
    };
    (text, named)
}

#[cfg(test)]
mod null_tests {
    //! The message; the directions themselves are tested in `crate::linalg`.
    use super::*;

    fn names(v: &[&str]) -> Vec<String> {
        v.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn a_null_direction_is_described_with_its_parameters() {
        // G = I − v vᵀ with v = (1, 1, 0)/√2 has null vector v, in the units D of F = D G D
        let v = [1.0 / 2f64.sqrt(), 1.0 / 2f64.sqrt(), 0.0];
        let d = [1e9, 1.0, 1e-3];
        let f = DMatrix::from_fn(3, 3, |i, j| {
            ((if i == j { 1.0 } else { 0.0 }) - v[i] * v[j]) * d[i] * d[j]
        });
        let (text, named) = describe_unconstrained(&f, &names(&["w1sq", "a1", "tau_c1"]));
        assert_eq!(named, ["w1sq", "a1"]);
        assert!(
            text.starts_with("the data do not constrain `w1sq`, `a1`: null direction 0.71·w1sq + 0.71·a1 (relative eigenvalue "),
            "{text}"
        );
        // a well-conditioned matrix: its weakest direction is named on demand
        let ok = DMatrix::from_row_slice(2, 2, &[2.0, 0.5, 0.5, 1.0]);
        let (text, _) = describe_unconstrained(&ok, &names(&["x", "y"]));
        assert!(
            text.contains("least constrained involves `x`, `y`: null direction 0.71·x − 0.71·y"),
            "{text}"
        );
    }

    #[test]
    fn a_parameter_with_a_zero_column_is_named_alone() {
        let f = DMatrix::from_row_slice(3, 3, &[4.0, 0.0, 1.8, 0.0, 0.0, 0.0, 1.8, 0.0, 9.0]);
        let (text, named) = describe_unconstrained(&f, &names(&["w1sq", "a1", "w2sq"]));
        assert_eq!(named, ["a1"]);
        assert_eq!(
            text,
            "the data do not constrain `a1`: ln L does not depend on `a1` (zero Fisher column)"
        );
    }

    #[test]
    fn a_two_dimensional_null_space_names_every_parameter_in_it() {
        // rank 1 over 3 parameters (all columns proportional) and a fourth independent one
        let g = [
            [1.0, 2.0, 0.0],
            [2.0, 4.0, 0.0],
            [-1.0, -2.0, 0.0],
            [0.0, 0.0, 1.0],
        ];
        let f = DMatrix::from_fn(4, 4, |i, j| (0..3).map(|k| g[i][k] * g[j][k]).sum());
        let (_, mut named) = describe_unconstrained(&f, &names(&["p", "q", "r", "s"]));
        named.sort();
        assert_eq!(named, ["p", "q", "r"]);
    }
}
