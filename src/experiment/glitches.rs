//! Force glitches put into simulated data (`[simulation.glitches]`): LPF-like pulses of force
//! per unit mass on a test mass, with a fast rise and an exponential decay, drawn from their
//! own random stream so that the noise of a study is the same with and without them.
//!
//! A glitch is not known to the analysis: it enters the loop as a force on the test mass (no
//! actuator in between) and is written into no data channel; only the dataset's metadata
//! records it (`extra.glitches`).

use super::streams::stream;
use rand::{Rng, RngExt};
use serde::{Deserialize, Serialize};

/// Most glitches per stretch `[simulation.glitches]` accepts.
pub const MAX_GLITCHES: usize = 1000;

/// Which test mass the glitches of `[simulation.glitches]` push.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum GlitchTarget {
    /// Test mass 1 (the drag-free reference).
    #[default]
    Tm1,
    /// Test mass 2 (the suspended one).
    Tm2,
    /// Each glitch on either, drawn with equal probability.
    Both,
}

/// `[simulation.glitches]`: random force glitches in every simulated experiment.
///
/// `count` glitches per fit stretch (`noise_count` per noise-only stretch), start times uniform
/// in the stretch, peak amplitudes log-uniform in `amplitude` with a random sign, decay times
/// log-uniform in `decay`, one rise time `rise`. The shape is
/// `g(t) = A (e^{−(t−t0)/τ} − e^{−(t−t0)/τ_r}) / c` for `t ≥ t0`, `c` its peak, so that `A` is
/// the peak force per unit mass.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RandomGlitches {
    /// Glitches per fit stretch.
    pub count: usize,
    /// Glitches per noise-only stretch (default 0).
    #[serde(default)]
    pub noise_count: usize,
    /// `[lo, hi]` of the peak force per unit mass (m s⁻²).
    #[serde(deserialize_with = "super::pair::pair")]
    pub amplitude: [f64; 2],
    /// `[lo, hi]` of the exponential decay time (s).
    #[serde(deserialize_with = "super::pair::pair")]
    pub decay: [f64; 2],
    /// Rise time (s), below the shortest decay.
    #[serde(default = "default_rise")]
    pub rise: f64,
    /// Which test mass.
    #[serde(default)]
    pub on: GlitchTarget,
}

fn default_rise() -> f64 {
    2.0
}

/// One simulated glitch, as recorded in the dataset's metadata.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Glitch {
    /// Start (s from the stretch's first sample).
    pub t0: f64,
    /// Peak force per unit mass (m s⁻², signed).
    pub amplitude: f64,
    /// Decay time (s).
    pub decay: f64,
    /// Rise time (s).
    pub rise: f64,
    /// `1` or `2`: the test mass pushed.
    pub tm: u8,
}

impl Glitch {
    /// The force per unit mass at `t` seconds from the stretch's first sample.
    pub fn at(&self, t: f64) -> f64 {
        let s = t - self.t0;
        if s < 0.0 {
            return 0.0;
        }
        self.amplitude * shape(s, self.decay, self.rise) / peak(self.decay, self.rise)
    }
}

/// `e^{−s/τ} − e^{−s/τ_r}`.
fn shape(s: f64, tau: f64, rise: f64) -> f64 {
    (-s / tau).exp() - (-s / rise).exp()
}

/// The maximum of [`shape`], at `s* = ln(τ/τ_r) τ τ_r / (τ − τ_r)`.
fn peak(tau: f64, rise: f64) -> f64 {
    let s = (tau / rise).ln() * tau * rise / (tau - rise);
    shape(s, tau, rise)
}

impl RandomGlitches {
    /// Checks the settings; the message names the key and the fix.
    pub fn check(&self) -> Result<(), String> {
        for (key, n) in [("count", self.count), ("noise_count", self.noise_count)] {
            if n > MAX_GLITCHES {
                return Err(format!(
                    "{key} = {n}: at most {MAX_GLITCHES} glitches per stretch"
                ));
            }
        }
        let range = |key: &str, [lo, hi]: [f64; 2], unit: &str| -> Result<(), String> {
            if !(lo.is_finite() && hi.is_finite() && lo > 0.0 && hi >= lo) {
                return Err(format!(
                    "{key} = [{lo}, {hi}]: need [lo, hi] with 0 < lo ≤ hi ({unit}; drawn log-uniform)"
                ));
            }
            Ok(())
        };
        range(
            "amplitude",
            self.amplitude,
            "m s⁻², the peak force per unit mass",
        )?;
        if self.amplitude[1] > 1e-6 {
            return Err(format!(
                "amplitude = [{}, {}]: above 1e−6 m s⁻², far beyond any LPF glitch (1e−13 to 1e−11 m s⁻²); check the unit",
                self.amplitude[0], self.amplitude[1]
            ));
        }
        range("decay", self.decay, "s")?;
        if !(self.rise.is_finite() && self.rise > 0.0 && self.rise < self.decay[0]) {
            return Err(format!(
                "rise = {} s: need 0 < rise < the shortest decay ({} s)",
                self.rise, self.decay[0]
            ));
        }
        Ok(())
    }

    /// Draws the glitches of a stretch of `duration` seconds: `count` of them from `rng`.
    pub fn draw(&self, count: usize, duration: f64, rng: &mut impl Rng) -> Vec<Glitch> {
        let log_uniform = |[lo, hi]: [f64; 2], rng: &mut dyn FnMut() -> f64| {
            (lo.ln() + (hi.ln() - lo.ln()) * rng()).exp()
        };
        let mut out = Vec::with_capacity(count);
        for _ in 0..count {
            let mut u = || rng.random::<f64>();
            let t0 = duration * u();
            let a = log_uniform(self.amplitude, &mut u);
            let sign = if u() < 0.5 { -1.0 } else { 1.0 };
            let decay = log_uniform(self.decay, &mut u);
            let tm = match self.on {
                GlitchTarget::Tm1 => 1,
                GlitchTarget::Tm2 => 2,
                GlitchTarget::Both => {
                    if u() < 0.5 {
                        1
                    } else {
                        2
                    }
                }
            };
            out.push(Glitch {
                t0,
                amplitude: sign * a,
                decay,
                rise: self.rise,
                tm,
            });
        }
        out.sort_by(|a, b| a.t0.total_cmp(&b.t0));
        out
    }
}

/// Salt of the glitches' random stream: independent of the noise streams `2j`, `2j + 1` and of
/// the gaps' stream.
const GLITCH_SALT: u64 = 0x676c_6974_6368_6573;

/// The glitches of experiment `j` of a study with seed `seed`: those of its fit stretch
/// (`n` samples) and of its noise-only stretch (`m` samples) at `fs` Hz.
pub fn draw_experiment(
    g: &RandomGlitches,
    n: usize,
    m: usize,
    fs: f64,
    seed: u64,
    j: usize,
) -> (Vec<Glitch>, Vec<Glitch>) {
    let mut rng = stream(seed ^ GLITCH_SALT, j as u64);
    let fit = g.draw(g.count, n as f64 / fs, &mut rng);
    let noise = if m > 0 {
        g.draw(g.noise_count, m as f64 / fs, &mut rng)
    } else {
        Vec::new()
    };
    (fit, noise)
}

/// The force per unit mass on each test mass, `[tm1, tm2]`, of `glitches` over `n` samples at
/// `fs` Hz.
pub fn force_series(glitches: &[Glitch], n: usize, fs: f64) -> [Vec<f64>; 2] {
    let mut out = [vec![0.0; n], vec![0.0; n]];
    for g in glitches {
        let first = ((g.t0 * fs).ceil() as usize).min(n);
        let v = &mut out[usize::from(g.tm == 2)];
        for (k, x) in v.iter_mut().enumerate().skip(first) {
            *x += g.at(k as f64 / fs);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cfg() -> RandomGlitches {
        RandomGlitches {
            count: 5,
            noise_count: 0,
            amplitude: [1e-13, 1e-11],
            decay: [30.0, 3000.0],
            rise: 2.0,
            on: GlitchTarget::Both,
        }
    }

    #[test]
    fn the_shape_peaks_at_the_amplitude() {
        let g = Glitch {
            t0: 10.0,
            amplitude: -3e-12,
            decay: 100.0,
            rise: 2.0,
            tm: 1,
        };
        assert_eq!(g.at(9.9), 0.0);
        assert_eq!(g.at(10.0), 0.0);
        let max = (0..100_000)
            .map(|k| g.at(10.0 + k as f64 * 1e-3))
            .fold(0.0, |a: f64, b| a.min(b));
        assert!((max / -3e-12 - 1.0).abs() < 1e-6, "{max}");
        // the decay: e-folds every 100 s long after the rise
        let r = g.at(610.0) / g.at(510.0);
        assert!((r - (-1.0f64).exp()).abs() < 1e-9, "{r}");
    }

    #[test]
    fn draws_are_in_range_and_reproducible() {
        let c = cfg();
        c.check().unwrap();
        let (fit, noise) = draw_experiment(&c, 100_000, 50_000, 10.0, 7, 1);
        assert_eq!(fit.len(), 5);
        assert!(noise.is_empty());
        for g in &fit {
            assert!((0.0..10_000.0).contains(&g.t0));
            assert!((1e-13..=1e-11).contains(&g.amplitude.abs()));
            assert!((30.0..=3000.0).contains(&g.decay));
        }
        assert_eq!(draw_experiment(&c, 100_000, 50_000, 10.0, 7, 1).0, fit);
        assert_ne!(draw_experiment(&c, 100_000, 50_000, 10.0, 7, 2).0, fit);
        let f = force_series(&fit, 100_000, 10.0);
        let peak = f[0]
            .iter()
            .chain(&f[1])
            .fold(0.0, |a: f64, b| a.max(b.abs()));
        assert!(peak > 0.9e-13);
    }

    #[test]
    fn bad_settings_name_the_key() {
        let c = cfg();
        let err = |r: RandomGlitches| r.check().unwrap_err();
        assert!(err(RandomGlitches { count: 5000, ..c }).contains("count"));
        assert!(
            err(RandomGlitches {
                amplitude: [1e-11, 1e-13],
                ..c
            })
            .contains("amplitude")
        );
        assert!(
            err(RandomGlitches {
                amplitude: [0.0, 1e-13],
                ..c
            })
            .contains("amplitude")
        );
        assert!(
            err(RandomGlitches {
                decay: [300.0, 30.0],
                ..c
            })
            .contains("decay")
        );
        assert!(err(RandomGlitches { rise: 50.0, ..c }).contains("rise"));
        assert!(
            err(RandomGlitches {
                amplitude: [1e-3, 1e-2],
                ..c
            })
            .contains("unit")
        );
    }
}
