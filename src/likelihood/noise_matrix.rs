//! The residual-noise matrix of one bin, `S_r = M(θ_ref) S_d M(θ_ref)ᴴ`, its factorisation
//! for the likelihood, and the data-channel CSD a model knows itself
//! ([`Model::data_noise_csd`]).
//!
//! One or two residual channels keep the packed 2×2 inverse (and its messages) of every result
//! so far; every `R` also gets the inverse Cholesky factor `W` (`C⁻¹ = WᴴW`) and `ln det C`,
//! which the general path and the normalisation of `R > 2` use.

use crate::hermitian::{self, tri_len};
use crate::model::{Bin, Model};
use num_complex::Complex64;

/// The factorised noise of one bin: `(packed inverse for R ≤ 2, W packed, ln det C)`.
pub(super) type BinFactors = (Option<(f64, Complex64, f64)>, Vec<Complex64>, f64);

/// The noisy data channels (indices into the model's) and their CSD `S_d` per bin
/// (`noisy.len()²`, row-major).
pub(super) type DataNoise = (Vec<usize>, Vec<Vec<Complex64>>);

/// `S_r = M S_d Mᴴ` over the noisy channels `noisy` (indices into the `nc` data channels;
/// `sd` is their CSD, `noisy.len()²`, row-major), `nr × nr` row-major into `out`.
pub(super) fn residual_csd(
    coef: &[Complex64],
    nr: usize,
    nc: usize,
    noisy: &[usize],
    sd: &[Complex64],
    out: &mut [Complex64],
) {
    let nn = noisy.len();
    for r1 in 0..nr {
        for r2 in 0..nr {
            let mut acc = Complex64::new(0.0, 0.0);
            for (a, &ca) in noisy.iter().enumerate() {
                for (b, &cb) in noisy.iter().enumerate() {
                    acc += coef[r1 * nc + ca] * sd[a * nn + b] * coef[r2 * nc + cb].conj();
                }
            }
            out[r1 * nr + r2] = acc;
        }
    }
}

/// Factorises `C = scale · S` (`S` the `nr × nr` residual CSD at `f` Hz); the message says why
/// `C` cannot be used (`residuals` names the rows).
pub(super) fn factorise(
    s: &[Complex64],
    nr: usize,
    scale: f64,
    f: f64,
    residuals: &[String],
) -> Result<BinFactors, String> {
    let c: Vec<Complex64> = s.iter().map(|v| v * scale).collect();
    let mut w = vec![Complex64::new(0.0, 0.0); tri_len(nr)];
    if nr <= 2 {
        let bad = || {
            let s22 = if nr == 2 { s[3].re } else { 0.0 };
            let s12 = if nr == 2 { s[1].norm() } else { 0.0 };
            format!(
                "the residual noise CSD is singular (or not positive definite) at {f:.6e} Hz: S11 = {:.3e}, S22 = {s22:.3e}, |S12| = {s12:.3e}; a channel without noise cannot be fitted: check the noise-only stretch or the noise levels",
                s[0].re,
            )
        };
        let packed = if nr == 2 {
            hermitian::inverse(&[[c[0], c[1]], [c[2], c[3]]]).ok_or_else(bad)?
        } else {
            let v = s[0].re * scale;
            if !(v > 0.0 && v.is_finite()) {
                return Err(bad());
            }
            (1.0 / v, Complex64::new(0.0, 0.0), 0.0)
        };
        // the packed test above is the stricter one: the factor exists
        let ln_det = hermitian::whitener(&c, nr, 0.0, &mut w).map_err(|_| bad())?;
        return Ok((Some(packed), w, ln_det));
    }
    let ln_det = hermitian::whitener(&c, nr, 1e-14, &mut w).map_err(|e| {
        format!(
            "the {nr}×{nr} residual noise CSD is not positive definite at {f:.6e} Hz: residual channel `{}` has variance {:.3e}, of which {:.3e} is not explained by the channels before it; a residual channel without noise, or one whose noise is a combination of the others', cannot be fitted: check the noise-only stretch or the noise levels",
            residuals[e.row],
            e.diag / scale,
            e.pivot / scale,
        )
    })?;
    Ok((None, w, ln_det))
}

/// The data-channel CSD the model knows itself ([`Model::data_noise_csd`] at `theta`), per
/// bin over the channels that carry noise: `Ok(None)` if the model does not know its noise,
/// else the noisy channels and their CSD (`noisy.len()²` per bin, row-major).
pub(super) fn model_noise(
    model: &dyn Model,
    theta: &[f64],
    fs: f64,
    freqs: &[f64],
    consts: &[Complex64],
) -> Result<Option<DataNoise>, String> {
    let nc = model.data_channels().len();
    let ncst = model.n_consts();
    let mut full = Vec::with_capacity(freqs.len());
    for (k, &f) in freqs.iter().enumerate() {
        let bin = Bin {
            f,
            fs,
            consts: &consts[k * ncst..(k + 1) * ncst],
        };
        let mut s = vec![Complex64::new(0.0, 0.0); nc * nc];
        if !model.data_noise_csd(theta, &bin, &mut s) {
            if k == 0 {
                return Ok(None);
            }
            return Err(format!(
                "model `{}` knows the noise of its data channels at {} Hz but not at {f} Hz",
                model.name(),
                freqs[0]
            ));
        }
        full.push(s);
    }
    let noisy: Vec<usize> = (0..nc)
        .filter(|&c| full.iter().any(|s| s[c * nc + c].re > 0.0))
        .collect();
    if noisy.is_empty() {
        return Err(format!(
            "model `{}` says none of its data channels carries noise in the band",
            model.name()
        ));
    }
    let sd = full
        .iter()
        .map(|s| {
            let mut out = Vec::with_capacity(noisy.len() * noisy.len());
            for &a in &noisy {
                for &b in &noisy {
                    out.push(s[a * nc + b]);
                }
            }
            out
        })
        .collect();
    Ok(Some((noisy, sd)))
}
