//! Prepares the raw-data plots of a run: each experiment's fit-stretch channels, their Welch
//! ASDs (the segmenting of the noise estimate) and the noise the likelihood assumes for the
//! read-outs.

use crate::config::Study;
use crate::data::dataset::ExperimentData;
use crate::likelihood::Likelihood;
use crate::model::{Channel, ChannelRoles};
use crate::report::raw::{RawChannel, RawData, RawSpectrum};
use crate::signal::{WelchConfig, welch_csd2_runs};

/// The raw data of every experiment of `data`: its read-outs and the injections it holds, as
/// the model of `lik` names them ([`ChannelRoles`]: the LTP's `o1, o12, i1, i12`, a
/// state-space model's outputs and inputs, …); the noise curves come from `lik` (its residual
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
        // the noise curve only for an experiment analysed whole (not as runs between gaps)
        let k_lik = lik.spectra().iter().position(|s| s.name == e.name);
        let model = lik.model_of(crate::jobs::prepare::spectra_index(lik, &e.name).unwrap_or(0));
        let roles = ChannelRoles::of(model.as_ref());
        let series = |c: &Channel| e.channel(&c.name).filter(|s| !s.is_empty());
        let readouts: Vec<(&Channel, &[f64])> = roles
            .readouts
            .iter()
            .filter_map(|c| Some((c, series(c)?)))
            .collect();
        if readouts.is_empty() {
            continue;
        }
        let raw = |c: &Channel, s: &[f64]| RawChannel {
            name: c.name.clone(),
            unit: c.unit.clone(),
            samples: s.to_vec(),
        };
        let mut channels: Vec<RawChannel> = readouts.iter().map(|(c, s)| raw(c, s)).collect();
        for c in &roles.injections {
            if let Some(s) = series(c).filter(|s| s.iter().any(|&v| v != 0.0)) {
                channels.push(raw(c, s));
            }
        }
        let mut spectra = Vec::new();
        let runs = e.valid_runs();
        let seg = crate::likelihood::welch_segment_len_for(readouts[0].1.len(), &runs, &opts);
        let cfg = WelchConfig::new(e.fs, opts.welch_window, seg.max(2));
        let keep = |f: &f64| *f >= opts.band[0] && *f <= opts.band[1];
        // the read-outs two by two (the auto-spectra of one cross-spectral estimate), a last
        // odd one with itself
        for pair in readouts.chunks(2) {
            let (a, b) = (pair[0], *pair.last().expect("chunks are not empty"));
            match welch_csd2_runs(a.1, b.1, &cfg, &runs) {
                Ok(s) => {
                    let both = [(a.0, &s.s11), (b.0, &s.s22)];
                    for (c, psd) in &both[..pair.len()] {
                        let (freqs, psd): (Vec<f64>, Vec<f64>) = s
                            .freqs
                            .iter()
                            .zip(psd.iter())
                            .filter(|(f, _)| keep(f))
                            .unzip();
                        spectra.push(RawSpectrum {
                            name: format!("{}, fit stretch (Welch)", c.name),
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
        }
        if let Some(k) = k_lik {
            let sp = &lik.spectra()[k];
            let res = lik.model_of(k).residual_channels().to_vec();
            for (r, name) in res.iter().enumerate() {
                if readouts.iter().any(|(c, _)| &c.name == name) {
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
            asd_unit: roles
                .readout_unit()
                .map_or("read-out unit/√Hz".into(), |u| format!("{u}/√Hz")),
        });
    }
    (out, warnings)
}
