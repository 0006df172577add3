//! Prepares the Bode plots of a run: the measured transfer function of every experiment with
//! injections ([`crate::likelihood::transfer`]) and each fitted model's at its MAP, at the
//! measured lines and on a grid for the curves.

use crate::config::Study;
use crate::data::dataset::ExperimentData;
use crate::likelihood::Likelihood;
use crate::likelihood::transfer::{MIN_CHECKED_AVERAGES, measured_transfer, model_transfer};
use crate::model::ChannelRoles;
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
/// that predicts the read-outs: `(experiments, warnings, notes)`. The warnings say what could
/// not be measured or predicted; a note says where injections were too slow to be measured
/// (their models' curves are then drawn alone, over the band).
pub fn bode_data(
    study: &Study,
    data: &[ExperimentData],
    fitted: &[Fitted<'_>],
) -> (Vec<BodeExperiment>, Vec<String>, Vec<String>) {
    let opts = crate::jobs::prepare::spectra_options(study);
    let mut out = Vec::new();
    let mut warnings = Vec::new();
    let mut notes = Vec::new();
    // each model with no curve, and the read-outs it was asked for
    let mut unpredicted: Vec<(&str, String)> = Vec::new();
    for e in data {
        // the read-outs and injections as the first model that reads this experiment names them
        let Some(roles) = fitted.iter().find_map(|f| {
            let k = crate::jobs::prepare::spectra_index(f.likelihood, &e.name)?;
            Some(ChannelRoles::of(f.likelihood.model_of(k).as_ref()))
        }) else {
            continue;
        };
        let measured = match measured_transfer(e, &opts, &roles) {
            Ok(m) => m,
            Err(err) => {
                warnings.push(format!("no Bode plot: {err}"));
                continue;
            }
        };
        if measured.is_empty() {
            continue;
        }
        let lines: Vec<f64> = measured
            .iter()
            .flat_map(|m| m.freqs.iter().copied())
            .collect();
        let grid = if lines.is_empty() {
            band_grid(opts.band, e.fs)
        } else {
            grid(&lines, opts.band, e.fs)
        };
        // models without a curve here, reported only where a plot is drawn
        let mut unpredicted_here: Vec<(&str, String)> = Vec::new();
        let mut pairs = Vec::new();
        for m in measured {
            let mut models = Vec::new();
            for f in fitted {
                let lik = f.likelihood;
                let Some(k) = crate::jobs::prepare::spectra_index(lik, &e.name) else {
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
                    _ if !unpredicted_here.iter().any(|(n, _)| *n == f.name) => {
                        let outs: Vec<&str> =
                            roles.readouts.iter().map(|c| c.name.as_str()).collect();
                        unpredicted_here.push((f.name, outs.join(", ")))
                    }
                    _ => {}
                }
            }
            pairs.push(BodePair {
                measured: m,
                models,
            });
        }
        if lines.is_empty() {
            // nothing measured and no model to draw: no plot, as before models were drawn alone
            if pairs.iter().all(|p| p.models.is_empty()) {
                continue;
            }
            let lowest = lowest_line(e, &opts);
            notes.push(format!(
                "experiment `{}`: no injected line is measured on its Bode plot: a line must lie at or above the fifth bin of the transfer function's {} back-to-back segments of the fit stretch (`[analysis] welch_averages`), {lowest:.3e} Hz here: a longer stretch or faster injections put lines there (fewer averages do too, but the error bars are checked at {MIN_CHECKED_AVERAGES}); the models' curves are drawn alone",
                e.name, opts.welch_averages
            ));
        }
        for u in unpredicted_here {
            if !unpredicted.iter().any(|(n, _)| *n == u.0) {
                unpredicted.push(u);
            }
        }
        out.push(BodeExperiment {
            experiment: e.name.clone(),
            gain_unit: gain_unit(&roles, &pairs),
            grid,
            pairs,
        });
    }
    let measured_any = out
        .iter()
        .any(|e| e.pairs.iter().any(|p| !p.measured.h.is_empty()));
    if measured_any && opts.welch_averages < MIN_CHECKED_AVERAGES {
        warnings.push(format!(
            "the Bode plots' error bars are too small: they are measured from {} back-to-back segments (`[analysis] welch_averages`), and the coherence-based errors cover only from {MIN_CHECKED_AVERAGES} (χ²/n of their pulls 6.8 at 8 segments, docs/src/guide/outputs.md)",
            opts.welch_averages
        ));
    }
    for (n, outs) in unpredicted {
        warnings.push(format!(
            "model `{n}`: not on the Bode plots: it does not predict the read-outs {outs} from the injections (it needs one residual per read-out)"
        ));
    }
    (out, warnings, notes)
}

/// `<read-out unit> per <injection unit>` when the pairs' read-outs share a known unit and their
/// injections another; `None` when they are the same (a ratio of like quantities) or unknown.
fn gain_unit(roles: &ChannelRoles, pairs: &[BodePair]) -> Option<String> {
    let unit_of = |name: &str| {
        roles
            .readouts
            .iter()
            .chain(&roles.injections)
            .find(|c| c.name == name)
            .map(|c| c.unit.as_str())
    };
    let shared = |names: Vec<&str>| {
        let first = unit_of(names.first()?)?;
        (!first.is_empty() && names.iter().all(|n| unit_of(n) == Some(first))).then_some(first)
    };
    let out = shared(pairs.iter().map(|p| p.measured.output.as_str()).collect())?;
    let inp = shared(pairs.iter().map(|p| p.measured.input.as_str()).collect())?;
    (out != inp).then(|| format!("{out} per {inp}"))
}

/// The lowest frequency (Hz) a line of experiment `e` is measured at: the fifth bin
/// ([`MIN_BIN`](crate::likelihood::transfer::MIN_BIN)) of `welch_averages` back-to-back
/// segments of its valid samples.
fn lowest_line(e: &ExperimentData, opts: &crate::likelihood::SpectraOptions) -> f64 {
    let valid: usize = e.valid_runs().iter().map(|r| r[1] - r[0]).sum();
    let seg = (valid / opts.welch_averages.max(1)).max(1);
    crate::likelihood::transfer::MIN_BIN as f64 * e.fs / seg as f64
}

/// A log grid over the band, below Nyquist.
fn band_grid(band: [f64; 2], fs: f64) -> Vec<f64> {
    let a = band[0].max(1e-12);
    let b = band[1].min(0.5 * fs).max(a * 1.01);
    let n = GRID_POINTS - 1;
    (0..=n)
        .map(|k| a * (b / a).powf(k as f64 / n as f64))
        .collect()
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
