//! Experiment designs: which waveform goes on which guidance channel, the padding around it and
//! the noise-only stretch, plus the built-in TN3045-like ladders of ltp-model.md §6.1.

use super::waveform::{SineSegment, Waveform};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// One system-identification experiment.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExperimentDesign {
    /// Name, used for array names in the dataset.
    pub name: String,
    /// Sample rate (Hz).
    pub fs: f64,
    /// Quiet time before the first injection (s).
    pub pre_pad: f64,
    /// Quiet time after the last injection (s): lets the slowest closed-loop pole
    /// (≈0.13 mHz, τ ≈ 1200 s) decay.
    pub post_pad: f64,
    /// Length of the separate noise-only stretch used for noise estimation (s).
    pub noise_duration: f64,
    /// Injection on the x1 guidance channel.
    pub x1: Waveform,
    /// Injection on the x12 guidance channel.
    pub x12: Waveform,
    /// Commanded force per unit mass injected on TM1 (m s⁻²), an "out of loop force" of the
    /// last TN3045 experiments.
    #[serde(default = "Waveform::none", skip_serializing_if = "Waveform::is_none")]
    pub f1: Waveform,
    /// Commanded force per unit mass injected on TM2 (m s⁻²), added to the suspension command.
    #[serde(default = "Waveform::none", skip_serializing_if = "Waveform::is_none")]
    pub f2: Waveform,
    /// Commanded force per unit mass injected on the spacecraft (m s⁻², per unit spacecraft
    /// mass), added to the drag-free command.
    #[serde(default = "Waveform::none", skip_serializing_if = "Waveform::is_none")]
    pub fsc: Waveform,
    /// Injections on named input channels of the model that generates the data
    /// (`[simulation] model`), in the channel's own unit; placed like the others.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub inject: BTreeMap<String, Waveform>,
    /// Missing data of the fit stretch: `[t0, t1]` in seconds from its first sample.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub gaps: Vec<[f64; 2]>,
    /// Missing data of the noise-only stretch: `[t0, t1]` in seconds from its first sample.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub noise_gaps: Vec<[f64; 2]>,
}

/// Names of the force-injection channels `(f1, f2, fsc)`, in study files and datasets.
pub const FORCE_CHANNELS: [&str; 3] = ["f1", "f2", "fsc"];

/// Frequencies of the TN3045-like ladder: 7 segments of 1200 s with 1, 2, 4, … 64 cycles.
pub fn ladder_freqs() -> [f64; 7] {
    std::array::from_fn(|j| (1u32 << j) as f64 / 1200.0)
}

impl ExperimentDesign {
    /// TN3045 "experiment 1", investigation 1 (x1 channel): ltp-model.md §6.1, digitised
    /// amplitudes 1 µm for the first four segments, then 0.59, 0.29 and 0.146 µm.
    pub fn tn3045_x1() -> Self {
        let amps = [1e-6, 1e-6, 1e-6, 1e-6, 0.59e-6, 0.29e-6, 0.146e-6];
        Self::ladder("tn3045_x1", amps, true)
    }

    /// TN3045 "experiment 1", investigation 2 (x12 channel). Not public: ltp-model.md §6.1 \[REC\],
    /// the same ladder with 1 µm up to 1.7 mHz, then ∝ 1/f² so that the TM2 commanded
    /// acceleration stays below about 1e−9 m s⁻².
    pub fn tn3045_x12() -> Self {
        let f = ladder_freqs();
        let amps: [f64; 7] = std::array::from_fn(|j| {
            if j < 2 {
                1e-6
            } else {
                1e-6 * (f[1] / f[j]).powi(2)
            }
        });
        Self::ladder("tn3045_x12", amps, false)
    }

    fn ladder(name: &str, amps: [f64; 7], on_x1: bool) -> Self {
        let f = ladder_freqs();
        let segments = (0..7)
            .map(|j| SineSegment {
                freq: f[j],
                amplitude: amps[j],
                duration: 1200.0,
            })
            .collect();
        let train = Waveform::SineTrain {
            segments,
            gap: 120.0,
        };
        let (x1, x12) = if on_x1 {
            (train, Waveform::None)
        } else {
            (Waveform::None, train)
        };
        Self {
            name: name.into(),
            fs: 10.0,
            pre_pad: 2000.0,
            post_pad: 8000.0,
            noise_duration: 20000.0,
            x1,
            x12,
            f1: Waveform::None,
            f2: Waveform::None,
            fsc: Waveform::None,
            inject: BTreeMap::new(),
            gaps: Vec::new(),
            noise_gaps: Vec::new(),
        }
    }

    /// Looks up a built-in design by name.
    pub fn builtin(name: &str) -> Option<Self> {
        match name {
            "tn3045_x1" => Some(Self::tn3045_x1()),
            "tn3045_x12" => Some(Self::tn3045_x12()),
            _ => None,
        }
    }

    /// Names accepted by [`ExperimentDesign::builtin`].
    pub const BUILTINS: [&'static str; 2] = ["tn3045_x1", "tn3045_x12"];

    /// Number of samples of the fit stretch (saturating: a study's sizes are checked against
    /// the memory budget with [`ExperimentDesign::n_samples_f64`] before this is used to
    /// allocate).
    pub fn n_samples(&self) -> usize {
        to_count(self.n_samples_f64())
    }

    /// Number of samples of the noise-only stretch (saturating, as [`Self::n_samples`]).
    pub fn n_noise_samples(&self) -> usize {
        to_count(self.n_noise_samples_f64())
    }

    /// [`Self::n_samples`] in `f64`: the same count, computed so that no input overflows it
    /// (`pre_pad = 1e308` gives about 1e309 = ∞, which the budget refuses).
    pub fn n_samples_f64(&self) -> f64 {
        let longest = [&self.x1, &self.x12, &self.f1, &self.f2, &self.fsc]
            .into_iter()
            .chain(self.inject.values())
            .map(|w| w.len_f64(self.fs))
            .fold(0.0, f64::max);
        self.pad_samples(self.pre_pad) + longest + self.pad_samples(self.post_pad)
    }

    /// [`Self::n_noise_samples`] in `f64`.
    pub fn n_noise_samples_f64(&self) -> f64 {
        self.pad_samples(self.noise_duration)
    }

    /// Samples of a quiet stretch of `t` seconds, rounded as `as usize` would (NaN, negative → 0).
    fn pad_samples(&self, t: f64) -> f64 {
        let r = (t * self.fs).round();
        if r > 0.0 { r } else { 0.0 }
    }

    /// The commanded injection series `(i1, i12)` over the fit stretch: padding, waveform, padding.
    pub fn injections(&self) -> [Vec<f64>; 2] {
        [&self.x1, &self.x12].map(|w| self.place(w))
    }

    /// The commanded force injections `(f1, f2, fsc)` (m s⁻²) over the fit stretch, placed
    /// like the guidance injections.
    pub fn force_injections(&self) -> [Vec<f64>; 3] {
        [&self.f1, &self.f2, &self.fsc].map(|w| self.place(w))
    }

    /// Whether any force channel carries an injection.
    pub fn has_forces(&self) -> bool {
        [&self.f1, &self.f2, &self.fsc].iter().any(|w| !w.is_none())
    }

    /// The waveform on every injected channel, by the name of the channel it drives: `x1` →
    /// `i1`, `x12` → `i12`, the force channels by their own names, then [`Self::inject`].
    /// Channels without an injection are left out.
    pub fn channel_waveforms(&self) -> Vec<(String, &Waveform)> {
        [
            ("i1", &self.x1),
            ("i12", &self.x12),
            ("f1", &self.f1),
            ("f2", &self.f2),
            ("fsc", &self.fsc),
        ]
        .into_iter()
        .map(|(c, w)| (c.to_string(), w))
        .chain(self.inject.iter().map(|(c, w)| (c.clone(), w)))
        .filter(|(_, w)| !w.is_none())
        .collect()
    }

    /// The series of [`Self::channel_waveforms`] over the fit stretch.
    pub fn channel_injections(&self) -> Vec<(String, Vec<f64>)> {
        self.channel_waveforms()
            .into_iter()
            .map(|(c, w)| (c, self.place(w)))
            .collect()
    }

    /// Every waveform of the experiment, named as in the study file (`x1`, …, `inject.<ch>`).
    pub fn waveforms(&self) -> Vec<(String, &Waveform)> {
        [
            ("x1", &self.x1),
            ("x12", &self.x12),
            ("f1", &self.f1),
            ("f2", &self.f2),
            ("fsc", &self.fsc),
        ]
        .into_iter()
        .map(|(c, w)| (c.to_string(), w))
        .chain(self.inject.iter().map(|(c, w)| (format!("inject.{c}"), w)))
        .collect()
    }

    fn place(&self, w: &Waveform) -> Vec<f64> {
        let n = self.n_samples();
        let pre = to_count(self.pad_samples(self.pre_pad));
        let mut v = vec![0.0; n];
        // n ≥ pre + the waveform's length by construction; zipping keeps absurd (saturated)
        // sizes from indexing out of bounds
        for (slot, x) in v.iter_mut().skip(pre).zip(w.render(self.fs)) {
            *slot = x;
        }
        v
    }

    /// A copy with every injection amplitude (guidance and force) multiplied by `k`.
    pub fn scaled(&self, k: f64) -> Self {
        Self {
            x1: self.x1.scaled(k),
            x12: self.x12.scaled(k),
            f1: self.f1.scaled(k),
            f2: self.f2.scaled(k),
            fsc: self.fsc.scaled(k),
            inject: self
                .inject
                .iter()
                .map(|(c, w)| (c.clone(), w.scaled(k)))
                .collect(),
            ..self.clone()
        }
    }
}

/// A non-negative whole `f64` as a `usize`, saturating.
fn to_count(x: f64) -> usize {
    if x >= usize::MAX as f64 {
        usize::MAX
    } else {
        x as usize
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ladder_matches_the_digitised_figure() {
        let d = ExperimentDesign::tn3045_x1();
        // ltp-model.md §6.1: segments start ≈130, 1440, 2750, 4090, 5400 s apart by ≈1310–1340 s
        // and the train lasts ≈9300 s: our 1200 s + 120 s gap gives starts every 1320 s and 9120 s.
        let [i1, i12] = d.injections();
        assert!(i12.iter().all(|&v| v == 0.0));
        let active = i1.iter().rposition(|&v| v != 0.0).unwrap()
            - i1.iter().position(|&v| v != 0.0).unwrap();
        assert!((active as f64 / d.fs - 9120.0).abs() < 1.0);
        // 7 segments of 12 001 samples (both zero ends included) and 6 gaps of 1200 samples
        assert_eq!(d.n_samples(), 20000 + 7 * 12001 + 6 * 1200 + 80000);
        assert!((ladder_freqs()[0] - 0.833e-3).abs() < 1e-6);
        // x12 amplitudes fall as 1/f² above 1.7 mHz
        let x12 = ExperimentDesign::tn3045_x12();
        let segs = x12.x12.segments();
        assert_eq!(segs[1].amplitude, 1e-6);
        assert!((segs[2].amplitude - 0.25e-6).abs() < 1e-15);
    }

    /// Absurd pads give saturated counts and an infinite `f64` count, never a wrapped sum.
    #[test]
    fn sizes_do_not_overflow() {
        let mut d = ExperimentDesign::tn3045_x1();
        assert_eq!(d.n_samples() as f64, d.n_samples_f64());
        assert_eq!(d.n_noise_samples(), 200_000);
        d.pre_pad = 1e308;
        assert!(d.n_samples_f64().is_infinite());
        assert_eq!(d.n_samples(), usize::MAX);
        d.pre_pad = f64::NAN;
        d.post_pad = -5.0;
        assert_eq!(d.n_samples(), ExperimentDesign::tn3045_x1().x1.len(10.0));
    }
}
