//! Prepares the Bode plots of a run: the measured transfer function of every experiment with
//! injections ([`crate::likelihood::transfer`]) and each fitted model's at its MAP, at the
//! measured lines and on a grid for the curves.

use crate::config::Study;
use crate::data::dataset::ExperimentData;
use crate::likelihood::Likelihood;
use crate::likelihood::transfer::{measured_transfer, model_transfer};
use crate::report::bode::{BodeExperiment, BodeModel, BodePair};

/// Points of the models' curves.
const GRID_POINTS: usize = 240;

/// A fitted model: its name, the likelihood it was fitted on and its MAP (full θ).
pub struct Fitted<'a> {
    /// The model's name on the plot.
    pub name: &'a str,
    /// The likelihood it was fitted on (its per-experiment models give the response).
    pub likelihood: &'a Likelihood,
    /// The MAP, the full parameter vector of the likelihood's model.
    pub map: &'a [f64],
}

/// The Bode data of every experiment of `data` with injections, with every model of `fitted`
/// that predicts the read-outs; the warnings say what could not be measured or predicted.
pub fn bode_data(
    study: &Study,
    data: &[ExperimentData],
    fitted: &[Fitted<'_>],
) -> (Vec<BodeExperiment>, Vec<String>) {
    let opts = crate::jobs::prepare::spectra_options(study);
    let mut out = Vec::new();
    let mut warnings = Vec::new();
    let mut unpredicted: Vec<&str> = Vec::new();
    for e in data {
        let measured = match measured_transfer(e, &opts) {
            Ok(m) => m,
            Err(err) => {
                warnings.push(format!("no Bode plot: {err}"));
                continue;
            }
        };
        let lines: Vec<f64> = measured
            .iter()
            .flat_map(|m| m.freqs.iter().copied())
            .collect();
        if lines.is_empty() {
            continue;
        }
        let grid = grid(&lines, opts.band, e.fs);
        let mut pairs = Vec::new();
        for m in measured {
            let mut models = Vec::new();
            for f in fitted {
                let lik = f.likelihood;
                let Some(k) = lik.spectra().iter().position(|s| s.name == e.name) else {
                    continue;
                };
                let model = lik.model_of(k);
                let curve = |freqs: &[f64]| {
                    model_transfer(model.as_ref(), f.map, e.fs, freqs, &m.input, &m.output)
                };
                match (curve(&m.freqs), curve(&grid)) {
                    (Some(at_lines), Some(on_grid)) => models.push(BodeModel {
                        name: f.name.to_string(),
                        at_lines,
                        on_grid,
                    }),
                    _ if !unpredicted.contains(&f.name) => unpredicted.push(f.name),
                    _ => {}
                }
            }
            pairs.push(BodePair {
                measured: m,
                models,
            });
        }
        out.push(BodeExperiment {
            experiment: e.name.clone(),
            grid,
            pairs,
        });
    }
    for n in unpredicted {
        warnings.push(format!(
            "model `{n}`: not on the Bode plots: it does not predict the read-outs o1, o12 from the injections (it needs one residual per read-out)"
        ));
    }
    (out, warnings)
}

/// A log grid from half the lowest line to twice the highest, inside the band and below
/// Nyquist.
fn grid(lines: &[f64], band: [f64; 2], fs: f64) -> Vec<f64> {
    let lo = lines.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = lines.iter().copied().fold(0.0, f64::max);
    let a = (0.5 * lo).max(band[0]).max(1e-12);
    let b = (2.0 * hi).min(band[1]).min(0.5 * fs).max(a * 1.01);
    let n = GRID_POINTS - 1;
    (0..=n)
        .map(|k| a * (b / a).powf(k as f64 / n as f64))
        .collect()
}
