//! The model that generates a study's data (`[simulation] model`): its read-outs and inputs,
//! the noiseless read-outs for given inputs, and the read-outs' noise CSD. The simulation
//! itself is `model_sim.rs`.

use crate::model::{Bin, MAX_CONSTS, Model};
use num_complex::Complex64;
use std::sync::Arc;

/// The model that generates a study's data, at its true parameters.
#[derive(Debug, Clone)]
pub struct Generator {
    /// The model (a `[[model]]` of the study).
    pub model: Arc<dyn Model>,
    /// Its true parameters, in the order of [`Model::param_names`].
    pub theta: Vec<f64>,
}

/// The read-outs and inputs of a model, as indices into its data channels.
#[derive(Debug, Clone)]
pub struct Channels {
    /// Data-channel index of residual channel `r` (the read-out it is the residual of).
    pub outputs: Vec<usize>,
    /// Every other data channel: the known inputs.
    pub inputs: Vec<usize>,
}

impl Generator {
    /// Splits the model's data channels into read-outs and inputs; the error says why a model
    /// cannot generate data (a residual channel that is not one of its data channels).
    pub fn channels(&self) -> Result<Channels, String> {
        let m = &self.model;
        let data = m.data_channels();
        let mut outputs = Vec::new();
        for r in m.residual_channels() {
            let Some(c) = data.iter().position(|d| d == r) else {
                return Err(format!(
                    "model `{}` cannot generate data: its residual `{r}` is not one of the channels it reads ({data:?}); the simulator needs residuals that are read-outs (r = y − H u), as a state-space model's are",
                    m.name()
                ));
            };
            outputs.push(c);
        }
        let inputs = (0..data.len()).filter(|c| !outputs.contains(c)).collect();
        Ok(Channels { outputs, inputs })
    }

    /// The CSD `S_y(f)` of the read-outs' noise (row-major `R×R`), from the model's own noise.
    /// `false` when the model knows no noise of its own.
    pub fn noise_csd(&self, ch: &Channels, f: f64, fs: f64, out: &mut [Complex64]) -> bool {
        let m = &self.model;
        let nc = m.data_channels().len();
        let mut consts = [Complex64::new(0.0, 0.0); MAX_CONSTS];
        let consts = &mut consts[..m.n_consts()];
        m.bin_consts(f, fs, consts);
        let mut s = vec![Complex64::new(0.0, 0.0); nc * nc];
        let bin = Bin { f, fs, consts };
        if !m.data_noise_csd(&self.theta, &bin, &mut s) {
            return false;
        }
        let nr = ch.outputs.len();
        for (i, &a) in ch.outputs.iter().enumerate() {
            for (j, &b) in ch.outputs.iter().enumerate() {
                out[i * nr + j] = s[a * nc + b];
            }
        }
        true
    }

    /// The noiseless read-outs `−M_y⁻¹ M_u U_k` at bin `k ≥ 1` of a series of `n` samples at
    /// `fs`, for the input DFTs `u` (one per input channel, `None` for an input left at zero).
    pub(super) fn response(
        &self,
        ch: &Channels,
        f: f64,
        fs: f64,
        u: &[Option<Complex64>],
        out: &mut [Complex64],
    ) -> Result<(), String> {
        let m = &self.model;
        let nc = m.data_channels().len();
        let nr = ch.outputs.len();
        let mut consts = [Complex64::new(0.0, 0.0); MAX_CONSTS];
        let consts = &mut consts[..m.n_consts()];
        m.bin_consts(f, fs, consts);
        let mut coef = vec![Complex64::new(0.0, 0.0); nr * nc];
        m.coefficients(&self.theta, &Bin { f, fs, consts }, &mut coef);
        let mut my = vec![Complex64::new(0.0, 0.0); nr * nr];
        for r in 0..nr {
            let row = &coef[r * nc..(r + 1) * nc];
            for (j, &c) in ch.outputs.iter().enumerate() {
                my[r * nr + j] = row[c];
            }
            out[r] = -ch
                .inputs
                .iter()
                .zip(u)
                .filter_map(|(&c, v)| v.map(|v| row[c] * v))
                .sum::<Complex64>();
        }
        if !crate::model::state_space::solve_in_place(&mut my, nr, out, 1) {
            return Err(format!(
                "model `{}`: its read-out coefficients M_y are singular at {f} Hz (at the truth), so the read-outs are not determined by the inputs",
                m.name()
            ));
        }
        if let Some(v) = out.iter().find(|v| !(v.re.is_finite() && v.im.is_finite())) {
            return Err(format!(
                "model `{}`: the response at {f} Hz is {v} at the truth",
                m.name()
            ));
        }
        Ok(())
    }
}
