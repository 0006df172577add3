//! Injection waveforms: trains of finite-duration sinusoids, single sinusoids and user series.

use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// One finite-duration sinusoid `a·sin(2πf t)`, `0 ≤ t < duration`.
///
/// The duration is rounded down to a whole number of half cycles at build time, so the
/// segment starts and ends at zero (no step, hence no broadband leakage from the edges).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SineSegment {
    /// Frequency (Hz).
    pub freq: f64,
    /// Amplitude (m).
    pub amplitude: f64,
    /// Duration (s), before rounding to whole half cycles.
    pub duration: f64,
}

/// What is injected on one guidance channel.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Waveform {
    /// Nothing on this channel.
    None,
    /// Sinusoid segments one after the other, separated by `gap` seconds of zeros.
    SineTrain {
        segments: Vec<SineSegment>,
        #[serde(default)]
        gap: f64,
    },
    /// A single finite-duration sinusoid.
    Sine(SineSegment),
    /// A user-given series at the experiment's sample rate (m), injected as is.
    Samples { values: Vec<f64> },
}

impl Waveform {
    /// `Waveform::None` (a serde default).
    pub fn none() -> Self {
        Waveform::None
    }

    /// Whether this is `Waveform::None`.
    pub fn is_none(&self) -> bool {
        matches!(self, Waveform::None)
    }

    /// Number of samples the waveform occupies at sample rate `fs`.
    pub fn len(&self, fs: f64) -> usize {
        self.render(fs).len()
    }

    /// Whether the waveform has no samples.
    pub fn is_empty(&self, fs: f64) -> bool {
        self.len(fs) == 0
    }

    /// The waveform sampled at `fs`, starting at its first sample.
    pub fn render(&self, fs: f64) -> Vec<f64> {
        match self {
            Waveform::None => Vec::new(),
            Waveform::Samples { values } => values.clone(),
            Waveform::Sine(s) => render_segment(s, fs),
            Waveform::SineTrain { segments, gap } => {
                let gap_n = (gap * fs).round() as usize;
                let mut out = Vec::new();
                for (i, s) in segments.iter().enumerate() {
                    if i > 0 {
                        out.extend(std::iter::repeat_n(0.0, gap_n));
                    }
                    out.extend(render_segment(s, fs));
                }
                out
            }
        }
    }

    /// A copy with every amplitude multiplied by `k`.
    pub fn scaled(&self, k: f64) -> Waveform {
        let sc = |s: &SineSegment| SineSegment {
            amplitude: s.amplitude * k,
            ..*s
        };
        match self {
            Waveform::None => Waveform::None,
            Waveform::Samples { values } => Waveform::Samples {
                values: values.iter().map(|v| v * k).collect(),
            },
            Waveform::Sine(s) => Waveform::Sine(sc(s)),
            Waveform::SineTrain { segments, gap } => Waveform::SineTrain {
                segments: segments.iter().map(sc).collect(),
                gap: *gap,
            },
        }
    }

    /// The sine segments (empty for other kinds), for validation.
    pub fn segments(&self) -> &[SineSegment] {
        match self {
            Waveform::Sine(s) => std::slice::from_ref(s),
            Waveform::SineTrain { segments, .. } => segments,
            _ => &[],
        }
    }
}

fn render_segment(s: &SineSegment, fs: f64) -> Vec<f64> {
    // whole half cycles: sin(2πf t) vanishes at t = m/(2f)
    let half_cycles = (2.0 * s.freq * s.duration).floor();
    let n = (half_cycles / (2.0 * s.freq) * fs).round() as usize;
    (0..=n)
        .map(|k| s.amplitude * (2.0 * PI * s.freq * k as f64 / fs).sin())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn segments_start_and_end_at_zero() {
        let s = SineSegment {
            freq: 1.0 / 1200.0 * 8.0,
            amplitude: 1e-6,
            duration: 1200.0,
        };
        let v = Waveform::Sine(s).render(10.0);
        assert_eq!(v.len(), 12001);
        assert_eq!(v[0], 0.0);
        assert!(v[v.len() - 1].abs() < 1e-18);
        let odd = Waveform::Sine(SineSegment {
            freq: 0.0123,
            amplitude: 1.0,
            duration: 500.0,
        })
        .render(10.0);
        // 12 half cycles fit in 500 s at 12.3 mHz: the end sample is within one sample step of zero
        let step = 2.0 * PI * 0.0123 / 10.0;
        assert!(odd[odd.len() - 1].abs() < step);
    }

    #[test]
    fn train_concatenates_with_gaps() {
        let seg = SineSegment {
            freq: 0.01,
            amplitude: 2.0,
            duration: 100.0,
        };
        let w = Waveform::SineTrain {
            segments: vec![seg, seg],
            gap: 10.0,
        };
        assert_eq!(w.len(10.0), 1001 + 100 + 1001);
        let scaled = w.scaled(0.5).render(10.0);
        let max = scaled.iter().cloned().fold(0.0, f64::max);
        assert!((max - 1.0).abs() < 1e-9);
    }
}
