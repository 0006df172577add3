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

    /// Number of samples the waveform occupies at sample rate `fs`, computed without rendering
    /// it (saturating at `usize::MAX` for absurd durations; see [`Waveform::len_f64`]).
    pub fn len(&self, fs: f64) -> usize {
        let n = self.len_f64(fs);
        if n >= usize::MAX as f64 {
            usize::MAX
        } else {
            n as usize
        }
    }

    /// Number of samples at `fs` as an `f64`, exact below 2⁵³ and never overflowing: the
    /// memory budget ([`crate::config::budget`]) sizes a study with it before anything is
    /// allocated, so a duration of 1e300 s gives 1e301, not a wrapped `usize`.
    pub fn len_f64(&self, fs: f64) -> f64 {
        match self {
            Waveform::None => 0.0,
            Waveform::Samples { values } => values.len() as f64,
            Waveform::Sine(s) => segment_len(s, fs),
            Waveform::SineTrain { segments, gap } => {
                let gap_n = round_count(gap * fs);
                segments.iter().map(|s| segment_len(s, fs)).sum::<f64>()
                    + gap_n * segments.len().saturating_sub(1) as f64
            }
        }
    }

    /// Whether the waveform has no samples.
    pub fn is_empty(&self, fs: f64) -> bool {
        self.len_f64(fs) == 0.0
    }

    /// The waveform sampled at `fs`, starting at its first sample.
    pub fn render(&self, fs: f64) -> Vec<f64> {
        match self {
            Waveform::None => Vec::new(),
            Waveform::Samples { values } => values.clone(),
            Waveform::Sine(s) => render_segment(s, fs),
            Waveform::SineTrain { segments, gap } => {
                let gap_n = round_count(gap * fs) as usize;
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

/// `x.round()` as a count, the way `as usize` converts it (NaN and negatives give 0), but in
/// `f64` so that nothing saturates.
fn round_count(x: f64) -> f64 {
    let r = x.round();
    if r > 0.0 { r } else { 0.0 }
}

/// The last sample index `n` of a segment (it has `n + 1` samples).
fn segment_last(s: &SineSegment, fs: f64) -> f64 {
    // whole half cycles: sin(2πf t) vanishes at t = m/(2f)
    let half_cycles = (2.0 * s.freq * s.duration).floor();
    round_count(half_cycles / (2.0 * s.freq) * fs)
}

fn segment_len(s: &SineSegment, fs: f64) -> f64 {
    segment_last(s, fs) + 1.0
}

fn render_segment(s: &SineSegment, fs: f64) -> Vec<f64> {
    let n = segment_last(s, fs) as usize;
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
        assert_eq!(w.len(10.0), w.render(10.0).len());
        let scaled = w.scaled(0.5).render(10.0);
        let max = scaled.iter().cloned().fold(0.0, f64::max);
        assert!((max - 1.0).abs() < 1e-9);
    }

    /// The analytic length is the rendered one for odd rates, durations and gaps, and stays
    /// finite (no render, no overflow) for absurd ones.
    #[test]
    fn length_without_rendering() {
        for (f, d, fs, gap) in [
            (0.0123, 500.0, 10.0, 0.0),
            (0.3, 7.7, 3.3, 1.26),
            (1.0 / 1200.0, 1200.0, 10.0, 120.0),
            (0.05, 10.0, 1.0, 0.49),
            (0.05, 10.0, 1.0, 0.5),
        ] {
            let s = SineSegment {
                freq: f,
                amplitude: 1.0,
                duration: d,
            };
            let one = Waveform::Sine(s);
            assert_eq!(one.len(fs), one.render(fs).len(), "{f} {d} {fs}");
            let w = Waveform::SineTrain {
                segments: vec![s, s, s],
                gap,
            };
            assert_eq!(w.len(fs), w.render(fs).len(), "{f} {d} {fs} {gap}");
        }
        let huge = Waveform::Sine(SineSegment {
            freq: 0.01,
            amplitude: 1.0,
            duration: 1e300,
        });
        assert!((huge.len_f64(10.0) - 1e301).abs() < 1e287);
        assert_eq!(huge.len(10.0), usize::MAX);
        assert_eq!(Waveform::None.len_f64(10.0), 0.0);
        assert!(Waveform::None.is_empty(10.0));
    }
}
