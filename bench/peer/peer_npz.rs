//! The input file of the numpy peer of the exact `ln L` (bench/peer/numpy_lnl.py): one writer,
//! included by `benches/likelihood.rs` and `examples/peer_inputs.rs` (`#[path]`), so that the
//! layout the peer reads is defined once.

use ndarray::{Array1, Array2};
use ndarray_npy::NpzWriter;
use num_complex::Complex64;
use occam::likelihood::Likelihood;
use occam::ltp::{Masses, N_PARAMS};

/// Writes the in-band inputs of every experiment, the masses and the Rust ln L at a few
/// parameter points to `z` (the caller adds its own arrays and finishes the file).
pub fn write_peer_inputs<W: std::io::Write + std::io::Seek>(
    z: &mut NpzWriter<W>,
    lik: &Likelihood,
    masses: &Masses,
    truth: &[f64; N_PARAMS],
    checks: &[[f64; N_PARAMS]],
) -> Result<(), Box<dyn std::error::Error>> {
    let spectra = lik.spectra();
    z.add_array(
        "n_experiments",
        &Array1::from_vec(vec![spectra.len() as i64]),
    )?;
    for (j, e) in spectra.iter().enumerate() {
        let n = e.len();
        // data channels (o1, o12, i1, i12); constants (C_df, C_sus, E, E·C_df, E·C_sus)
        let pairs = |off: usize| Array2::from_shape_fn((n, 2), |(k, c)| e.data_at(k)[off + c]);
        let col = |g: &dyn Fn(usize) -> Complex64| Array1::from_iter((0..n).map(g));
        let cst = |k: usize, i: usize| e.consts[5 * k + i];
        z.add_array(format!("e{j}.freqs"), &Array1::from_vec(e.freqs.clone()))?;
        z.add_array(format!("e{j}.y"), &pairs(0))?;
        z.add_array(format!("e{j}.inj"), &pairs(2))?;
        z.add_array(
            format!("e{j}.cinv_a"),
            &Array1::from_iter(e.cinv.iter().map(|c| c.0)),
        )?;
        z.add_array(format!("e{j}.cinv_b"), &col(&|k| e.cinv[k].1))?;
        z.add_array(
            format!("e{j}.cinv_c"),
            &Array1::from_iter(e.cinv.iter().map(|c| c.2)),
        )?;
        z.add_array(format!("e{j}.cdf"), &col(&|k| cst(k, 0)))?;
        z.add_array(format!("e{j}.csus"), &col(&|k| cst(k, 1)))?;
        z.add_array(format!("e{j}.e_oms"), &col(&|k| cst(k, 2)))?;
    }
    let m = masses;
    z.add_array("masses", &Array1::from_vec(vec![m.m1, m.m2, m.msc]))?;
    z.add_array("theta_truth", &Array1::from_vec(truth.to_vec()))?;
    z.add_array(
        "theta",
        &Array2::from_shape_fn((checks.len(), N_PARAMS), |(i, a)| checks[i][a]),
    )?;
    z.add_array(
        "lnl",
        &Array1::from_iter(checks.iter().map(|t| lik.ln_likelihood_full(t))),
    )?;
    z.add_array("ln_norm", &Array1::from_vec(vec![lik.ln_norm()]))?;
    Ok(())
}
