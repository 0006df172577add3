//! Gaps put into simulated data: listed ones (`[[experiment]] gaps`, `noise_gaps`, in seconds)
//! and random ones (`[simulation.gaps]`), drawn from their own random stream so that the
//! noise of a study is the same with and without them.

use super::design::ExperimentDesign;
use super::streams::stream;
use crate::data::dataset::ExperimentData;
use crate::data::gaps::{self, Span};
use rand::{Rng, RngExt};
use serde::{Deserialize, Serialize};

/// `[simulation.gaps]`: random gaps in every stretch of every simulated experiment.
///
/// Durations are log-uniform in `[shortest, longest]` seconds and starts uniform; gaps are
/// drawn until `fraction` of the stretch's samples are missing (overlapping gaps merge).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RandomGaps {
    /// Fraction of the samples to leave out, in `[0, 0.9]`.
    pub fraction: f64,
    /// Shortest gap (s).
    pub shortest: f64,
    /// Longest gap (s).
    pub longest: f64,
}

impl RandomGaps {
    /// Checks the settings; the message names the key.
    pub fn check(&self) -> Result<(), String> {
        if !(self.fraction.is_finite() && (0.0..=0.9).contains(&self.fraction)) {
            return Err(format!(
                "fraction = {}: need a number in [0, 0.9]",
                self.fraction
            ));
        }
        if !(self.shortest.is_finite() && self.shortest > 0.0) {
            return Err(format!("shortest = {} s: need > 0", self.shortest));
        }
        if !(self.longest.is_finite() && self.longest >= self.shortest) {
            return Err(format!(
                "longest = {} s: need ≥ shortest ({} s)",
                self.longest, self.shortest
            ));
        }
        Ok(())
    }

    /// Whether gaps of at least `shortest` can miss `fraction` of a stretch of `n` samples at
    /// `fs` Hz: [`RandomGaps::draw`] ends the last gap where the fraction is reached, so a
    /// `shortest` longer than the fraction's share of the stretch would be cut without a word.
    pub fn fits(&self, n: usize, fs: f64) -> Result<(), String> {
        let share = self.fraction * n as f64 / fs;
        if n == 0 || self.fraction == 0.0 || self.shortest <= share {
            return Ok(());
        }
        Err(format!(
            "shortest = {} s: {} % of the {:.1} s stretch is {share:.1} s, shorter than the \
             shortest gap, which could not be applied; set shortest to at most {share:.1} s (or \
             raise fraction)",
            self.shortest,
            (1e6 * 100.0 * self.fraction).round() / 1e6,
            n as f64 / fs,
        ))
    }

    /// Draws the gaps of a stretch of `n` samples at `fs` Hz from `rng`.
    pub fn draw(&self, n: usize, fs: f64, rng: &mut impl Rng) -> Vec<Span> {
        let want = (self.fraction * n as f64).round() as usize;
        let mut spans: Vec<Span> = Vec::new();
        let (a, b) = (self.shortest.ln(), self.longest.ln());
        // a gap longer than the stretch still ends it; the cap bounds the loop
        for _ in 0..100_000 {
            if gaps::missing(&spans) >= want || n == 0 {
                break;
            }
            let d = (a + (b - a) * rng.random::<f64>()).exp();
            let len = ((d * fs).round() as usize).clamp(1, n);
            let start = rng.random_range(0..n);
            let need = want - gaps::missing(&spans);
            let end = (start + len.min(need)).min(n);
            spans.push([start, end]);
            spans = gaps::normalise(spans);
        }
        spans
    }
}

/// Salt of the gaps' random stream: independent of the noise streams `2j`, `2j + 1`.
const GAP_SALT: u64 = 0x6761_7073_2d6f_6363;

/// Applies the listed gaps of `design` and the random ones of `random` to the simulated
/// experiment `e` (the `j`-th of a study with seed `seed`). The measured channels are blanked
/// in the gaps; the commanded inputs (channels with no noise-only series) keep their values,
/// which the likelihood's edge correction needs (a dataset written to disk has NaN in every
/// channel there).
pub fn apply(
    e: &mut ExperimentData,
    design: &ExperimentDesign,
    random: Option<&RandomGaps>,
    seed: u64,
    j: usize,
) -> Result<(), String> {
    let (n, m) = (e.n_samples(), e.n_noise_samples());
    // the commanded inputs (no noise-only series) are known through a telemetry gap
    e.known_in_gaps = e
        .channel_names()
        .into_iter()
        .filter(|c| e.noise_channel(c).is_none())
        .collect();
    let listed = gaps::from_times(&design.gaps, e.fs, n, "gaps")?;
    e.add_gaps(&listed);
    if m > 0 {
        let listed = gaps::from_times(&design.noise_gaps, e.fs, m, "noise_gaps")?;
        e.add_noise_gaps(&listed);
    } else if !design.noise_gaps.is_empty() {
        return Err("noise_gaps: the experiment has no noise-only stretch".into());
    }
    if let Some(r) = random {
        for (len, what) in [(n, "fit stretch"), (m, "noise-only stretch")] {
            r.fits(len, e.fs)
                .map_err(|x| format!("[simulation.gaps], in its {what}: {x}"))?;
        }
        let mut rng = stream(seed ^ GAP_SALT, j as u64);
        let g = r.draw(n, e.fs, &mut rng);
        e.add_gaps(&g);
        if m > 0 {
            let g = r.draw(m, e.fs, &mut rng);
            e.add_noise_gaps(&g);
        }
    }
    if e.gaps.is_empty() {
        e.known_in_gaps.clear();
    }
    gaps::check(&e.gaps, n).map_err(|x| format!("gaps: {x}"))?;
    gaps::check(&e.noise_gaps, m).map_err(|x| format!("noise_gaps: {x}"))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_shortest_gap_longer_than_the_fraction_s_share_is_refused() {
        let r = RandomGaps {
            fraction: 0.1,
            shortest: 1e5,
            longest: 2e5,
        };
        r.check().unwrap();
        let e = r.fits(14_000, 10.0).unwrap_err();
        assert!(
            e.contains("shortest = 100000 s")
                && e.contains("10 % of the 1400.0 s stretch is 140.0 s")
                && e.contains("at most 140.0 s"),
            "{e}"
        );
        let ok = RandomGaps {
            shortest: 140.0,
            ..r
        };
        ok.fits(14_000, 10.0).unwrap();
        ok.fits(0, 10.0).unwrap();
    }

    #[test]
    fn random_gaps_miss_the_fraction_asked_for() {
        let r = RandomGaps {
            fraction: 0.1,
            shortest: 10.0,
            longest: 3600.0,
        };
        r.check().unwrap();
        let n = 200_000;
        let mut rng = stream(3, 0);
        let g = r.draw(n, 1.0, &mut rng);
        gaps::check(&g, n).unwrap();
        assert_eq!(gaps::missing(&g), n / 10);
        assert!(g.iter().any(|s| s[1] - s[0] > 600), "{g:?}");
        // the same stream gives the same gaps
        assert_eq!(r.draw(n, 1.0, &mut stream(3, 0)), g);
        assert!(
            RandomGaps {
                fraction: 0.95,
                ..r
            }
            .check()
            .unwrap_err()
            .contains("fraction")
        );
        assert!(
            RandomGaps { longest: 1.0, ..r }
                .check()
                .unwrap_err()
                .contains("longest")
        );
    }
}
