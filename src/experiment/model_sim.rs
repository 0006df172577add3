//! Simulation by any model (`[simulation] model = "…"`): data with a known truth for every
//! study, whatever model it fits.
//!
//! A model turns data channels `d` into residuals `r = M(θ) d`. Its *read-outs* `y` are the
//! residual channels it also reads as data channels (a state-space model's outputs, whose
//! residual is `r = y − H u`); every other data channel `u` is a known input, which an
//! experiment injects (or leaves at zero). With `M = [M_y | M_u]`, per DFT bin `k ≥ 1`
//!
//! ```text
//! Y_k = −M_y⁻¹ M_u U_k + N_k,      E[N_k N_kᴴ] = (N fs/2) S_y(f_k)
//! ```
//!
//! where `S_y` is the one-sided CSD of the read-outs' noise that the model knows itself
//! ([`Model::data_noise_csd`]: a state-space model with noise inputs), drawn by
//! [`synth_channels`] exactly as the built-in simulator draws its two channels. The DC bin of
//! the response is zero (no fit band contains it; the read-outs have zero mean). The noise-only
//! stretch is noise alone; inputs have no noise series (they are known). Experiment `j` draws
//! its fit noise from stream `2j` and its noise-only stretch from stream `2j + 1` of the seed,
//! as the built-in simulator does.
//!
//! The optimal SNR is `ρ² = 2 Σ_{k ∈ band} h_kᴴ C_k⁻¹ h_k`, `C_k = (N fs/2) S_y(f_k)` (the
//! built-in simulator's definition, ltp-model.md §8.2), with `h` the noiseless read-outs.

use super::design::ExperimentDesign;
use super::generator::{Channels, Generator};
use super::options::NoiseSynthesis;
use super::simulate::{SimError, SimProgress, Simulation, SimulationPlan, stream};
use crate::data::dataset::{Dataset, ExperimentData};
use crate::signal::{RealFft, SynthMode, synth_channels};
use num_complex::Complex64;

/// A named series.
type Named = (String, Vec<f64>);

/// The noiseless read-out spectra (`R` channels, bins `0 … N/2`) of design `d`, and the named
/// input series it injects (every input of the model, zero where nothing is injected).
fn noiseless(
    g: &Generator,
    ch: &Channels,
    d: &ExperimentDesign,
) -> Result<(Vec<Vec<Complex64>>, Vec<Named>), SimError> {
    let n = d.n_samples();
    let sig = |e| SimError::Signal(d.name.clone(), e);
    let other = |m: String| SimError::Other(d.name.clone(), m);
    let data = g.model.data_channels();
    let mut injected = d.channel_injections();
    if let Some((c, _)) = injected
        .iter()
        .find(|(c, _)| !ch.inputs.iter().any(|&i| data[i] == *c))
    {
        let inputs: Vec<&String> = ch.inputs.iter().map(|&i| &data[i]).collect();
        return Err(other(format!(
            "injects `{c}`, which is not an input of the simulation model `{}` (its inputs are {inputs:?})",
            g.model.name()
        )));
    }
    let mut fft = RealFft::new(n).map_err(sig)?;
    let nb = fft.spectrum_len();
    let zero = Complex64::new(0.0, 0.0);
    let mut spectra: Vec<Option<Vec<Complex64>>> = vec![None; ch.inputs.len()];
    for (slot, &i) in spectra.iter_mut().zip(&ch.inputs) {
        if let Some((_, x)) = injected.iter().find(|(c, _)| *c == data[i]) {
            let mut s = vec![zero; nb];
            fft.forward(x, &mut s).map_err(sig)?;
            *slot = Some(s);
        }
    }
    let nr = ch.outputs.len();
    let mut y = vec![vec![zero; nb]; nr];
    let mut u = vec![None; ch.inputs.len()];
    let mut out = vec![zero; nr];
    if spectra.iter().any(Option::is_some) {
        for k in 1..nb {
            for (uk, s) in u.iter_mut().zip(&spectra) {
                *uk = s.as_ref().map(|s| s[k]);
            }
            let f = k as f64 * d.fs / n as f64;
            g.response(ch, f, d.fs, &u, &mut out).map_err(other)?;
            for (yc, o) in y.iter_mut().zip(&out) {
                yc[k] = *o;
            }
        }
    }
    for &i in &ch.inputs {
        if !injected.iter().any(|(c, _)| *c == data[i]) {
            injected.push((data[i].clone(), vec![0.0; n]));
        }
    }
    Ok((y, injected))
}

/// ρ_opt of the noiseless read-outs `y` of design `d` over `band` (module docs).
fn optimal_snr(
    g: &Generator,
    ch: &Channels,
    d: &ExperimentDesign,
    y: &[Vec<Complex64>],
    band: [f64; 2],
) -> Result<f64, SimError> {
    let n = d.n_samples();
    let nr = ch.outputs.len();
    let zero = Complex64::new(0.0, 0.0);
    let (mut s, mut w, mut h) = (
        vec![zero; nr * nr],
        vec![zero; crate::hermitian::tri_len(nr)],
        vec![zero; nr],
    );
    let scale = n as f64 * d.fs / 2.0;
    let mut rho2 = 0.0;
    for k in 1..y[0].len() {
        let f = k as f64 * d.fs / n as f64;
        if f < band[0] || f > band[1] || 2 * k == n {
            continue;
        }
        for (hc, yc) in h.iter_mut().zip(y) {
            *hc = yc[k];
        }
        if h.iter().all(|v| *v == zero) {
            continue;
        }
        g.noise_csd(ch, f, d.fs, &mut s);
        for v in s.iter_mut() {
            *v *= scale;
        }
        crate::hermitian::whitener(&s, nr, 1e-14, &mut w).map_err(|e| {
            SimError::Other(
                d.name.clone(),
                format!(
                    "the read-out noise of model `{}` is singular at {f} Hz (read-out `{}`), so ρ_opt is infinite there: give every read-out some noise",
                    g.model.name(),
                    g.model.residual_channels()[e.row]
                ),
            )
        })?;
        rho2 += 2.0 * crate::hermitian::quad_whitened(&w, &h);
    }
    Ok(rho2.sqrt())
}

/// Simulates the plan's experiments with its generator (module docs).
pub(super) fn simulate_model(
    plan: &SimulationPlan,
    g: &Generator,
    progress: Option<SimProgress>,
) -> Result<Simulation, SimError> {
    let ch = g
        .channels()
        .map_err(|m| SimError::Other("study".into(), m))?;
    let names = g.model.data_channels();
    let mut designs = plan.experiments.clone();
    let mut amplitude_factor = 1.0;
    if let Some(target) = plan.target_snr {
        let mut rho2 = 0.0;
        for d in &designs {
            let (y, _) = noiseless(g, &ch, d)?;
            rho2 += optimal_snr(g, &ch, d, &y, plan.snr_band)?.powi(2);
        }
        if !(rho2 > 0.0 && rho2.is_finite()) {
            return Err(SimError::Other(
                "study".into(),
                format!(
                    "the injections give ρ_opt² = {rho2:e} in the SNR band, so no amplitude gives the target SNR"
                ),
            ));
        }
        amplitude_factor = target / rho2.sqrt();
        designs = designs.iter().map(|d| d.scaled(amplitude_factor)).collect();
    }
    let mode = match plan.noise {
        NoiseSynthesis::None => None,
        NoiseSynthesis::Circular => Some(SynthMode::Circular),
        NoiseSynthesis::Realistic => Some(SynthMode::Realistic { oversample: 4 }),
    };
    let nr = ch.outputs.len();
    let (mut experiments, mut snr) = (Vec::new(), Vec::new());
    if let Some(p) = progress {
        p(0, designs.len() as u64);
    }
    for (j, d) in designs.iter().enumerate() {
        if let Some(p) = progress
            && j > 0
        {
            p(j as u64, designs.len() as u64);
        }
        let sig = |e| SimError::Signal(d.name.clone(), e);
        let (y, inputs) = noiseless(g, &ch, d)?;
        snr.push(optimal_snr(g, &ch, d, &y, plan.snr_band)?);
        let n = d.n_samples();
        let mut fft = RealFft::new(n).map_err(sig)?;
        let mut outputs = vec![vec![0.0; n]; nr];
        for (o, spec) in outputs.iter_mut().zip(&y) {
            fft.inverse(spec, o).map_err(sig)?;
        }
        let noise_of = |len: usize, idx: u64| -> Result<Vec<Vec<f64>>, SimError> {
            let Some(mode) = mode else {
                return Ok(vec![vec![0.0; len]; nr]);
            };
            let mut rng = stream(plan.seed, idx);
            synth_channels(
                len,
                d.fs,
                nr,
                |f, s| {
                    g.noise_csd(&ch, f, d.fs, s);
                },
                &mut rng,
                mode,
            )
            .map_err(sig)
        };
        let fit_noise = noise_of(n, 2 * j as u64)?;
        let quiet = noise_of(d.n_noise_samples(), 2 * j as u64 + 1)?;
        let none = || [Vec::new(), Vec::new()];
        let mut e = ExperimentData::new(&d.name, d.fs, none(), none(), none());
        for (((&c, o), nz), q) in ch.outputs.iter().zip(outputs).zip(fit_noise).zip(quiet) {
            e.set_channel(&names[c], o.iter().zip(&nz).map(|(a, b)| a + b).collect());
            e.set_noise_channel(&names[c], q);
        }
        for (c, x) in inputs {
            e.set_channel(&c, x);
        }
        experiments.push(e);
    }
    let snr_total = snr.iter().map(|r| r * r).sum::<f64>().sqrt();
    let truth: serde_json::Map<String, serde_json::Value> = g
        .model
        .param_names()
        .iter()
        .zip(&g.theta)
        .map(|(n, v)| (n.clone(), serde_json::json!(v)))
        .collect();
    let extra = serde_json::json!({
        "source": plan.source,
        "generator": g.model.name(),
        "truth_values": truth,
        "read_outs": ch.outputs.iter().map(|&c| &names[c]).collect::<Vec<_>>(),
        "inputs": ch.inputs.iter().map(|&c| &names[c]).collect::<Vec<_>>(),
        "noise_synthesis": plan.noise,
        "snr_band": plan.snr_band,
        "snr_definition": "rho_opt = sqrt(<h|h>) over snr_band, with the model's own read-out noise",
        "snr": snr,
        "snr_total": snr_total,
        "amplitude_factor": amplitude_factor,
        "designs": designs,
    });
    Ok(Simulation {
        dataset: Dataset {
            experiments,
            seed: Some(plan.seed),
            truth: None,
            extra,
        },
        designs,
        snr,
        snr_total,
        amplitude_factor,
    })
}
