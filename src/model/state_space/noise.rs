//! The CSD of a state-space model's outputs driven by its white noise inputs:
//! `S_y = T S_w Tᴴ`, `T = C (zI − A)⁻¹ G + H`.

use super::solve::{System, transfer};
use num_complex::Complex64;

/// Fills `out` (`nc × nc`, row-major, the outputs first) with the CSD of the outputs of `sys`
/// (whose `b` is `G` and `d` is `H`) at the point `z`, for independent white noise inputs of
/// one-sided PSDs `psd`; `phase[o]` is the delay factor of output `o`. The other channels (the
/// known inputs) are noiseless. `false` when `zI − A` is singular.
pub fn output_csd(
    sys: &System<f64>,
    psd: &[f64],
    phase: &[Complex64],
    z: Complex64,
    nc: usize,
    out: &mut [Complex64],
) -> bool {
    let (n, p, q) = (sys.n, sys.p, sys.m);
    let zero = Complex64::new(0.0, 0.0);
    let mut lu = vec![zero; n * n];
    let mut x = vec![zero; n * q];
    let mut t = vec![zero; p * q];
    let ok = transfer(sys, z, &mut lu, &mut x, &mut t);
    out[..nc * nc].fill(zero);
    if !ok {
        return false;
    }
    for (row, ph) in t.chunks_mut(q).zip(phase) {
        row.iter_mut().for_each(|v| *v *= ph);
    }
    for i in 0..p {
        for j in 0..p {
            out[i * nc + j] = (0..q)
                .map(|k| t[i * q + k] * psd[k] * t[j * q + k].conj())
                .sum();
        }
    }
    true
}
