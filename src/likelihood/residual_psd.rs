//! The residual PSD of a model at a parameter point, beside the noise the likelihood assumes and
//! the read-outs alone: the paper's Fig. 3 ("equivalent residual acceleration" of each
//! actuator model at its MAP) for any model.
//!
//! * `residual`: the Welch PSD of the residual time series `r(t; θ) = IDFT(M(f; θ) d̃(f))` over
//!   the fit stretch (every DFT bin, BH92, 8 averages, every Welch bin in the band);
//! * `readout`: the same with only the read-out channels kept ([`ChannelRoles`]: `o1, o12`, a
//!   state-space model's outputs; for the acceleration domain, a12 without the commanded
//!   forces subtracted: the injected forces plus noise);
//! * `reference`: the residual-noise PSD `S_r` of the likelihood (from the noise-only stretch
//!   at the reference point, or the noise model), on the fit bins.
//!
//! A model that explains the data has `residual ≈ reference`; a wrong one leaves the injected
//! lines standing above it.

use super::exact::Likelihood;
use super::statistic::{LogPeriodogramOptions, LogPgExperiment};
use crate::data::dataset::ExperimentData;
use crate::model::{Bin, ChannelRoles, Model};
use crate::signal::Window;
use num_complex::{Complex, Complex64};
use num_dual::Dual64;
use std::sync::Arc;

/// One experiment's curves for the first residual channel (one-sided PSDs, the residual
/// channel's units squared per Hz).
#[derive(Debug, Clone, PartialEq)]
pub struct ResidualPsd {
    pub experiment: String,
    /// The residual channel.
    pub channel: String,
    /// Its SI unit (`""`: unknown).
    pub unit: String,
    /// Welch frequencies (Hz) of `residual` and `readout`.
    pub freqs: Vec<f64>,
    pub residual: Vec<f64>,
    /// Absent when the model reads no read-out channel.
    pub readout: Option<Vec<f64>>,
    /// Fit-bin frequencies (Hz) of `reference`.
    pub reference_freqs: Vec<f64>,
    pub reference: Vec<f64>,
    /// Where `reference` comes from: the Welch estimate of the noise-only stretch, or the noise
    /// model (the model's own noise, or the study's `[noise]`).
    pub reference_is_welch: bool,
}

/// `model` with every data channel but the read-outs zeroed.
#[derive(Debug)]
struct ReadoutOnly {
    inner: Arc<dyn Model>,
    keep: Vec<bool>,
}

impl ReadoutOnly {
    fn mask<T: Copy>(&self, out: &mut [T], zero: T) {
        let nc = self.keep.len();
        for (i, o) in out.iter_mut().enumerate() {
            if !self.keep[i % nc] {
                *o = zero;
            }
        }
    }
}

impl Model for ReadoutOnly {
    fn name(&self) -> &str {
        self.inner.name()
    }
    fn param_names(&self) -> &[String] {
        self.inner.param_names()
    }
    fn data_channels(&self) -> &[String] {
        self.inner.data_channels()
    }
    fn residual_channels(&self) -> &[String] {
        self.inner.residual_channels()
    }
    fn n_consts(&self) -> usize {
        self.inner.n_consts()
    }
    fn bin_consts(&self, f: f64, fs: f64, out: &mut [Complex64]) {
        self.inner.bin_consts(f, fs, out)
    }
    fn coefficients(&self, theta: &[f64], bin: &Bin, out: &mut [Complex64]) {
        self.inner.coefficients(theta, bin, out);
        self.mask(out, Complex64::new(0.0, 0.0));
    }
    fn coefficients_dual(&self, theta: &[Dual64], bin: &Bin, out: &mut [Complex<Dual64>]) {
        self.inner.coefficients_dual(theta, bin, out);
        self.mask(out, Complex::new(Dual64::from(0.0), Dual64::from(0.0)));
    }
}

/// The Fig. 3 curves of every experiment of `lik` (prepared on `data`, in its order) at the
/// model's full parameter vector `theta`.
pub fn residual_psds(
    lik: &Likelihood,
    data: &[ExperimentData],
    theta: &[f64],
) -> Result<Vec<ResidualPsd>, String> {
    let opts = LogPeriodogramOptions {
        averages: 8,
        window: Window::Bh92,
        decimate: Some(1),
        whiten: true,
    };
    let roles = ChannelRoles::of(lik.model().as_ref());
    let keep: Vec<bool> = lik
        .model()
        .data_channels()
        .iter()
        .map(|c| roles.readouts.iter().any(|r| &r.name == c))
        .collect();
    let mut out = Vec::new();
    for (i, sp) in lik.spectra().iter().enumerate() {
        let model = lik.model_of(i);
        let readout_model: Option<Arc<dyn Model>> = keep.iter().any(|&k| k).then(|| {
            Arc::new(ReadoutOnly {
                inner: model.clone(),
                keep: keep.clone(),
            }) as Arc<dyn Model>
        });
        let e = data
            .iter()
            .find(|d| d.name == sp.name)
            .ok_or_else(|| format!("experiment `{}` is not in the data", sp.name))?;
        let welch = |plan: &LogPgExperiment, m: &dyn Model| {
            let mut s = vec![f64::NAN; plan.bins.len()];
            plan.eval(m, theta, Some(&mut |j, v: [Complex64; 3]| s[j] = v[0].re));
            s
        };
        let plan = if sp.nr <= 2 {
            LogPgExperiment::new(e, sp, model.as_ref(), &opts)?
        } else {
            LogPgExperiment::first_channel(e, sp, model.as_ref(), &opts)?
        };
        let channel = model.residual_channels()[0].clone();
        let unit = match roles.readouts.iter().find(|r| r.name == channel) {
            Some(r) => r.unit.clone(),
            // the acceleration domain's residual
            None if channel == "a12" => "m s⁻²".into(),
            None => String::new(),
        };
        out.push(ResidualPsd {
            experiment: sp.name.clone(),
            channel,
            unit,
            freqs: plan.freqs(),
            residual: welch(&plan, model.as_ref()),
            // the plan holds the data and the constants, not the coefficients: it serves the
            // read-out-only model as well
            readout: readout_model.as_deref().map(|m| welch(&plan, m)),
            reference_freqs: sp.freqs.clone(),
            reference: (0..sp.len()).map(|k| sp.csd_at(k)[0].re).collect(),
            reference_is_welch: sp.noise_dof.is_some(),
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Study;
    use crate::jobs::prepare::{likelihood_of, load_data, truth_of};
    use std::path::Path;

    /// On the acceleration domain at the truth, the residual PSD is the reference noise (within
    /// the Welch scatter) away from the injected lines, and the read-outs alone carry the
    /// injected force lines far above it.
    #[test]
    fn residual_at_the_truth_is_the_noise_and_the_readout_carries_the_lines() {
        let text = r#"seed = 4
output = "unused"
[simulation.actuators]
tm1 = { pole = 1.963 }
tm2 = { pole = 1.963 }
[[experiment]]
name = "forces"
fs = 10.0
pre_pad = 200.0
post_pad = 200.0
noise_duration = 8000.0
f2 = { kind = "sine", freq = 0.8, amplitude = 3e-8, duration = 1600.0 }
[analysis]
band = [1e-2, 3.0]
[[model]]
kind = "accel"
name = "pole"
[fit]
model = "pole"
"#;
        let s = Study::from_toml(text, "t.toml", Path::new(".")).unwrap();
        let (data, _) = load_data(&s).unwrap();
        let mi = s.fit_model.model;
        let lik = likelihood_of(&s, mi, &data).unwrap();
        let th: Vec<f64> = truth_of(&s, mi, &data)
            .unwrap()
            .into_iter()
            .map(Option::unwrap)
            .collect();
        let c = &residual_psds(&lik, &data.experiments, &th).unwrap()[0];
        assert_eq!(c.channel, "a12");
        let near = |f: f64| {
            let k = c
                .reference_freqs
                .iter()
                .position(|&x| x >= f)
                .unwrap_or(c.reference.len() - 1);
            c.reference[k]
        };
        // away from the line: residual / reference averages to 1 (8 averages: ±35 % per bin)
        let ratios: Vec<f64> = c
            .freqs
            .iter()
            .zip(&c.residual)
            .filter(|(f, _)| (**f - 0.8).abs() > 0.05)
            .map(|(f, s)| s / near(*f))
            .collect();
        let mean = ratios.iter().sum::<f64>() / ratios.len() as f64;
        assert!((mean - 1.0).abs() < 0.1, "mean residual/reference {mean}");
        // at the line the read-outs carry the force, the residual does not
        let line: Vec<usize> = (0..c.freqs.len())
            .filter(|&j| (c.freqs[j] - 0.8).abs() < 0.01)
            .collect();
        let readout = c.readout.as_ref().unwrap();
        let at = *line
            .iter()
            .max_by(|&&a, &&b| readout[a].total_cmp(&readout[b]))
            .unwrap();
        let ro = readout[at];
        assert!(
            ro > 1e4 * near(0.8),
            "read-out {ro:e} vs noise {:e}",
            near(0.8)
        );
        assert!(c.residual[at] < 10.0 * near(0.8), "{:e}", c.residual[at]);
    }
}
