//! The raw data of each experiment: its time series (`timeseries_<experiment>.png/.svg`, one
//! panel per channel, thinned for drawing to the lowest and highest sample of each pixel
//! column) and their amplitude spectral densities beside the noise the likelihood assumes
//! (`spectra_<experiment>.png/.svg`).

use super::error::ReportError;
use super::lines::{LineFigure, LinePlot, Stack, line_plot};
use super::plots::render;
use std::path::Path;

/// One sampled channel of the fit stretch.
#[derive(Debug, Clone, PartialEq)]
pub struct RawChannel {
    /// Channel name (`o1`, `i1`, …).
    pub name: String,
    /// Unit of the samples (`m`), for the axis title; empty when unknown.
    pub unit: String,
    /// The samples, at the experiment's rate from the start of the fit stretch.
    pub samples: Vec<f64>,
}

/// A one-sided PSD to draw as an ASD.
#[derive(Debug, Clone, PartialEq)]
pub struct RawSpectrum {
    /// Legend entry.
    pub name: String,
    /// Frequencies (Hz).
    pub freqs: Vec<f64>,
    /// One-sided PSD (unit²/Hz).
    pub psd: Vec<f64>,
}

/// One experiment's raw data.
#[derive(Debug, Clone, PartialEq)]
pub struct RawData {
    /// The experiment's name (the figures are `timeseries_<experiment>`, `spectra_<experiment>`).
    pub experiment: String,
    /// Sample rate (Hz).
    pub fs: f64,
    /// The channels drawn, one panel each.
    pub channels: Vec<RawChannel>,
    /// Data spectra and noise models, drawn together.
    pub spectra: Vec<RawSpectrum>,
    /// Unit of the spectra's ASD (`m/√Hz`).
    pub asd_unit: String,
}

/// Writes the two figures of every experiment of `raws` into `dir`.
pub fn write(dir: &Path, raws: &[RawData]) -> Result<(), ReportError> {
    for r in raws {
        if !r.channels.is_empty() {
            let stem = format!("timeseries_{}", r.experiment);
            let mut panels = Vec::with_capacity(r.channels.len());
            for c in &r.channels {
                // a channel the data lack (all NaN: every sample a gap) has nothing to draw
                if !c.samples.iter().any(|v| v.is_finite()) {
                    continue;
                }
                let pts: Vec<(f64, f64)> = c
                    .samples
                    .iter()
                    .enumerate()
                    .map(|(n, &v)| (n as f64 / r.fs, v))
                    .collect();
                let series = vec![(String::new(), pts)];
                let title = if panels.is_empty() {
                    format!("time series of experiment {} (fit stretch)", r.experiment)
                } else {
                    String::new()
                };
                let y = if c.unit.is_empty() {
                    c.name.clone()
                } else {
                    format!("{} ({})", c.name, c.unit)
                };
                panels.push(LineFigure::new(
                    dir,
                    &stem,
                    &LinePlot {
                        title: &title,
                        x_label: "time from the start of the fit stretch (s)",
                        y_label: &y,
                        series: &series,
                        ..Default::default()
                    },
                    None,
                )?);
            }
            if !panels.is_empty() {
                render(dir, &stem, &Stack(panels))?;
            }
        }
        let series: Vec<(String, Vec<(f64, f64)>)> = r
            .spectra
            .iter()
            .map(|s| {
                let pts = s
                    .freqs
                    .iter()
                    .zip(&s.psd)
                    .map(|(&f, &p)| (f, p.sqrt()))
                    .collect();
                (s.name.clone(), pts)
            })
            // on log axes only positive, finite points draw: a zero spectrum has none
            .filter(|(_, pts): &(String, Vec<(f64, f64)>)| {
                pts.iter()
                    .any(|&(f, a)| f > 0.0 && a > 0.0 && f.is_finite() && a.is_finite())
            })
            .collect();
        if !series.is_empty() {
            line_plot(
                dir,
                &format!("spectra_{}", r.experiment),
                &LinePlot {
                    title: &format!("spectra of experiment {}", r.experiment),
                    x_label: "frequency (Hz)",
                    y_label: &format!("ASD ({})", r.asd_unit),
                    series: &series,
                    log_x: true,
                    log_y: true,
                    ..Default::default()
                },
            )?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_long_series_is_drawn_thinned_and_both_figures_are_written() {
        let n = 200_000;
        let samples: Vec<f64> = (0..n)
            .map(|k| (k as f64 * 0.01).sin() + 1e-3 * ((k * 7919) % 13) as f64)
            .collect();
        let freqs: Vec<f64> = (1..500).map(|k| k as f64 * 1e-3).collect();
        let r = RawData {
            experiment: "inv1".into(),
            fs: 10.0,
            channels: vec![
                RawChannel {
                    name: "o1".into(),
                    unit: "m".into(),
                    samples: samples.clone(),
                },
                RawChannel {
                    name: "i1".into(),
                    unit: "m".into(),
                    samples,
                },
            ],
            spectra: vec![
                RawSpectrum {
                    name: "o1 (fit stretch)".into(),
                    freqs: freqs.clone(),
                    psd: vec![1e-24; 499],
                },
                RawSpectrum {
                    name: "o1 noise (likelihood)".into(),
                    freqs,
                    psd: vec![2e-24; 499],
                },
            ],
            asd_unit: "m/√Hz".into(),
        };
        let dir = tempfile::tempdir().unwrap();
        write(dir.path(), &[r]).unwrap();
        let svg = std::fs::read_to_string(dir.path().join("timeseries_inv1.svg")).unwrap();
        // 200 000 samples per panel, at most four kept per pixel column
        assert!(
            svg.len() < 2_000_000,
            "{} bytes: the series was not thinned",
            svg.len()
        );
        assert!(svg.contains("o1 (m)") && svg.contains("i1 (m)"));
        assert!(dir.path().join("spectra_inv1.png").exists());
        let s = std::fs::read_to_string(dir.path().join("spectra_inv1.svg")).unwrap();
        assert!(s.contains("noise (likelihood)"));
    }
}
