//! Fisher information of the LTP template: exact (dual numbers) and by central differences.

use super::exact::LtpLikelihood;
use crate::hermitian;
use crate::ltp::{N_PARAMS, response};
use nalgebra::DMatrix;
use num_complex::Complex64;
use num_dual::Dual64;

/// Fisher matrix over the parameters `free` (indices into the 7-vector) at `th`.
///
/// # Formula
/// `F_ab = Σ_e Σ_k 2 Re(∂_a h_kᴴ C_k⁻¹ ∂_b h_k)` (ltp-model.md §8.2), with `∂_a h` exact by
/// forward-mode dual numbers through the closed loop.
pub fn fisher_exact(lik: &LtpLikelihood, th: &[f64; N_PARAMS], free: &[usize]) -> DMatrix<f64> {
    fisher_with(lik, free, |e, k, a| {
        let mut d: [Dual64; N_PARAMS] = th.map(Dual64::from);
        d[a] = Dual64::from(th[a]).derivative();
        let h = response(&d, &e.consts[k], lik.masses(), e.inj[k]);
        [0, 1].map(|i| Complex64::new(h[i].re.eps, h[i].im.eps))
    })
}

/// Gradient of `ln L` and the Fisher matrix over `free` at `th`, in one pass over the bins.
///
/// # Formula
/// `∂_a ln L = 2 Re Σ ∂_a h_kᴴ C_k⁻¹ R_k`, `F_ab = 2 Re Σ ∂_a h_kᴴ C_k⁻¹ ∂_b h_k`.
pub fn gradient_and_fisher(
    lik: &LtpLikelihood,
    th: &[f64; N_PARAMS],
    free: &[usize],
) -> (Vec<f64>, DMatrix<f64>) {
    let d = free.len();
    let mut g = vec![0.0; d];
    let mut f = DMatrix::<f64>::zeros(d, d);
    let mut dh = vec![[Complex64::new(0.0, 0.0); 2]; d];
    for e in lik.spectra() {
        for k in 0..e.len() {
            let mut h = [Complex64::new(0.0, 0.0); 2];
            for (i, &a) in free.iter().enumerate() {
                let mut x: [Dual64; N_PARAMS] = th.map(Dual64::from);
                x[a] = Dual64::from(th[a]).derivative();
                let hd = response(&x, &e.consts[k], lik.masses(), e.inj[k]);
                dh[i] = [0, 1].map(|c| Complex64::new(hd[c].re.eps, hd[c].im.eps));
                h = [0, 1].map(|c| Complex64::new(hd[c].re.re, hd[c].im.re));
            }
            let r = [e.y[k][0] - h[0], e.y[k][1] - h[1]];
            for i in 0..d {
                g[i] += 2.0 * hermitian::inner(&e.cinv[k], dh[i], r);
                for j in i..d {
                    f[(i, j)] += 2.0 * hermitian::inner(&e.cinv[k], dh[i], dh[j]);
                }
            }
        }
    }
    for i in 0..d {
        for j in 0..i {
            f[(i, j)] = f[(j, i)];
        }
    }
    (g, f)
}

/// The default central-difference step for parameter `a`: `ε^{1/3}` relative to the value,
/// with a floor for parameters that may sit at zero (delays, cross-talk).
pub fn default_step(a: usize, value: f64) -> f64 {
    // floors: the scale each parameter is measured on (s⁻², s, gain, cross-talk)
    const FLOOR: [f64; N_PARAMS] = [1e-7, 1e-7, 1e-2, 1e-2, 1e-2, 1e-2, 1e-4];
    f64::EPSILON.cbrt() * value.abs().max(FLOOR[a])
}

/// Fisher matrix by central differences of the template with steps `steps[a]` (or
/// [`default_step`]); an oracle for [`fisher_exact`] and a fallback for other models.
pub fn fisher_numeric(
    lik: &LtpLikelihood,
    th: &[f64; N_PARAMS],
    free: &[usize],
    steps: Option<&[f64]>,
) -> DMatrix<f64> {
    fisher_with(lik, free, |e, k, a| {
        let i = free.iter().position(|&x| x == a).expect("a is free");
        let h = steps.map_or_else(|| default_step(a, th[a]), |s| s[i]);
        let mut p = *th;
        let mut m = *th;
        p[a] += h;
        m[a] -= h;
        let hp = response(&p, &e.consts[k], lik.masses(), e.inj[k]);
        let hm = response(&m, &e.consts[k], lik.masses(), e.inj[k]);
        [0, 1].map(|c| (hp[c] - hm[c]) / (2.0 * h))
    })
}

fn fisher_with(
    lik: &LtpLikelihood,
    free: &[usize],
    deriv: impl Fn(&super::ExperimentSpectra, usize, usize) -> [Complex64; 2],
) -> DMatrix<f64> {
    let d = free.len();
    let mut f = DMatrix::<f64>::zeros(d, d);
    let mut dh = vec![[Complex64::new(0.0, 0.0); 2]; d];
    for e in lik.spectra() {
        for k in 0..e.len() {
            for (i, &a) in free.iter().enumerate() {
                dh[i] = deriv(e, k, a);
            }
            for i in 0..d {
                for j in i..d {
                    let v = 2.0 * hermitian::inner(&e.cinv[k], dh[i], dh[j]);
                    f[(i, j)] += v;
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

/// Cramér–Rao standard deviations `√diag(F⁻¹)`; `None` if `F` is singular.
pub fn cramer_rao(f: &DMatrix<f64>) -> Option<Vec<f64>> {
    let inv = f.clone().cholesky()?.inverse();
    Some((0..f.nrows()).map(|i| inv[(i, i)].sqrt()).collect())
}
