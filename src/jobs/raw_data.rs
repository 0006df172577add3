//! Prepares the raw-data plots of a run: each experiment's fit-stretch channels, their Welch
//! ASDs (the segmenting of the noise estimate) and the noise the likelihood assumes for the
//! read-outs.

use crate::config::Study;
use crate::data::dataset::ExperimentData;
use crate::likelihood::Likelihood;
use crate::report::raw::{RawChannel, RawData, RawSpectrum};
use crate::signal::{WelchConfig, welch_csd2_runs};

/// The read-out channels, in the order of [`ExperimentData::o`].
const OUTPUTS: [&str; 2] = ["o1", "o12"];
/// The injection channels, in the order of [`ExperimentData::i`].
const INPUTS: [&str; 2] = ["i1", "i12"];

/// The raw data of every experiment of `data`; the noise curves come from `lik` (its residual
/// channels that are read-outs). Warnings name what could not be estimated.
pub fn raw_data(
    study: &Study,
    lik: &Likelihood,
    data: &[ExperimentData],
) -> (Vec<RawData>, Vec<String>) {
    let opts = crate::jobs::prepare::spectra_options(study);
    let mut out = Vec::new();
    let mut warnings = Vec::new();
    for e in data {
        // data of a model's own channels, not the LTP read-outs: nothing drawn here yet
        if e.o.iter().all(|s| s.is_empty()) {
            continue;
        }
        let mut channels: Vec<RawChannel> = OUTPUTS
            .iter()
            .zip(&e.o)
            .map(|(n, s)| RawChannel {
                name: n.to_string(),
                unit: "m".into(),
                samples: s.clone(),
            })
            .collect();
        for (n, s) in INPUTS.iter().zip(&e.i) {
            if s.iter().any(|&v| v != 0.0) {
                channels.push(RawChannel {
                    name: n.to_string(),
                    unit: "m".into(),
                    samples: s.clone(),
                });
            }
        }
        let mut spectra = Vec::new();
        let runs = e.valid_runs();
        let seg = crate::likelihood::welch_segment_len_for(e.o[0].len(), &runs, &opts);
        match welch_csd2_runs(
            &e.o[0],
            &e.o[1],
            &WelchConfig::new(e.fs, opts.welch_window, seg.max(2)),
            &runs,
        ) {
            Ok(s) => {
                let keep = |f: &f64| *f >= opts.band[0] && *f <= opts.band[1];
                for (name, psd) in [("o1", &s.s11), ("o12", &s.s22)] {
                    let (freqs, psd): (Vec<f64>, Vec<f64>) = s
                        .freqs
                        .iter()
                        .zip(psd.iter())
                        .filter(|(f, _)| keep(f))
                        .unzip();
                    spectra.push(RawSpectrum {
                        name: format!("{name}, fit stretch (Welch)"),
                        freqs,
                        psd,
                    });
                }
            }
            Err(err) => warnings.push(format!(
                "experiment `{}`: no spectra of the read-outs: {err}",
                e.name
            )),
        }
        if let Some(k) = lik.spectra().iter().position(|s| s.name == e.name) {
            let sp = &lik.spectra()[k];
            let res = lik.model_of(k).residual_channels().to_vec();
            for (r, name) in res.iter().enumerate() {
                if OUTPUTS.contains(&name.as_str()) {
                    spectra.push(RawSpectrum {
                        name: format!("{name}, noise the likelihood assumes"),
                        freqs: sp.freqs.clone(),
                        psd: (0..sp.len())
                            .map(|b| sp.csd_at(b)[r * sp.nr + r].re)
                            .collect(),
                    });
                }
            }
        }
        out.push(RawData {
            experiment: e.name.clone(),
            fs: e.fs,
            channels,
            spectra,
            asd_unit: "m/√Hz".into(),
        });
    }
    (out, warnings)
}
