//! `[analysis] glitches = "gate"`: find glitches in an experiment's fit stretch and gate them.
//!
//! The residual time series of the fit stretch at the reference point `θ_ref` (the point the
//! noise and the gaps' edge correction are evaluated at), `r = IDFT(Σ_c M_c(θ_ref) X_c)`, is
//! noise plus whatever the model does not explain: a glitch. It is whitened against the Welch
//! estimate of the same residual on the noise-only stretch (on the fit stretch itself when
//! there is none) over the fit band, and the numerics of [`crate::signal::glitch_gate`] flag
//! the samples above the threshold, grow each region while the whitened envelope stays above
//! [`GLITCH_RELEASE`] σ and pad it. The regions become gaps of the experiment (the commanded
//! injections stay known), which the per-run likelihood then tapers smoothly at both ends
//! (`super::segments`).
//!
//! The whitened series is then scaled by the robust standard deviation (median absolute
//! value) of the noise-only residual whitened the same way: a Welch estimate from 16 averages
//! leaves the whitened noise with a variance of about 1.07, which alone makes a 5σ threshold
//! fire several times as often as it should. (The fit stretch's own median cannot serve: five
//! LPF-sized glitches hold its whitened o12 residual at tens of σ for most of the stretch.)
//!
//! Samples already missing are filled, for the detection only, by the straight line between
//! the residual's values at the gap's ends (a step there would whiten into a false glitch),
//! and can neither start nor hold open a region.

use super::spectra::{SpectraOptions, welch_segment_len};
use crate::data::dataset::ExperimentData;
use crate::data::gaps::{self, Span};
use crate::model::{Bin, Model};
use crate::signal::glitch_gate::{GateSettings, detect, moving_mean, robust_sd, whiten};
use crate::signal::{RealFft, WelchConfig, welch_csd2_runs};
use num_complex::Complex64;
use serde::{Deserialize, Serialize};

/// What `[analysis] glitches` does.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum GlitchTreatment {
    /// Nothing (listed `[[experiment]] glitches` are still gated).
    #[default]
    None,
    /// Detect glitches on the whitened residual and gate them.
    Gate,
    /// Detect glitches on the whitened residual and fit each as part of the model
    /// ([`crate::model::glitch`]).
    Model,
}

impl GlitchTreatment {
    /// Whether this is the default (serialisation skips it, so that resolved studies of
    /// glitch-free analyses are unchanged).
    pub fn is_none(&self) -> bool {
        *self == GlitchTreatment::None
    }
}

/// Default `[analysis] glitch_threshold` (σ of the whitened residual).
pub const DEFAULT_GLITCH_THRESHOLD: f64 = 5.0;
/// Default `[analysis] glitch_pad` (s on each side of a gated region).
pub const DEFAULT_GLITCH_PAD: f64 = 60.0;
/// Default `[analysis] glitch_tail` (s gated after a detected region, beyond its pad): the
/// LTP loop's slowest closed-loop time constant. The read-outs' response to a force glitch
/// rings for about this long after the force has faded below the detector's release; left in
/// the data it biased the stiffnesses and `d21` by up to 8.5σ on `examples/glitches.toml`
/// (docs/src/guide/glitches.md).
pub const DEFAULT_GLITCH_TAIL: f64 = 1200.0;
/// Default `[analysis] glitch_decay`: the prior range of a modelled glitch's decay time (s).
pub const DEFAULT_GLITCH_DECAY: [f64; 2] = [10.0, 3000.0];
/// Default `[analysis] glitch_amplitude`: a modelled glitch's peak force per unit mass on
/// either test mass lies in `[−A, A]` (m s⁻²), above every LPF glitch.
pub const DEFAULT_GLITCH_AMPLITUDE: f64 = 1e-10;
/// Default `[analysis] glitch_rise`: a modelled glitch's rise time (s), held fixed.
pub const DEFAULT_GLITCH_RISE: f64 = 2.0;
/// A gated region grows while the whitened envelope exceeds this (σ).
pub const GLITCH_RELEASE: f64 = 2.0;
/// Length of the whitened envelope's moving RMS window (s).
pub const ENVELOPE_SECONDS: f64 = 10.0;

/// What gating did to one experiment.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GlitchGate {
    pub experiment: String,
    /// Regions found on the whitened residual (after padding and merging).
    pub detected: usize,
    /// Regions listed in the study (`[[experiment]] glitches`).
    pub listed: usize,
    /// Every gated region, `[t0, t1)` in seconds from the first sample, merged.
    pub regions: Vec<[f64; 2]>,
    /// Seconds gated that were not already missing.
    pub seconds: f64,
    /// Seconds of valid fit data left after gating (and the stretch's own gaps).
    pub remaining: f64,
    /// What the gate leaves of a glitch's response: the residual's response to a force
    /// impulse `glitch_tail` s after it, over its peak (the model's at the detection point;
    /// [`crate::model::force_envelope`]). `None` when nothing was detected or the model does
    /// not say how a force enters.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub outlasting: Option<f64>,
    /// The `glitch_tail` (s) after which that response is below [`OUTLASTING_LIMIT`] of its
    /// peak.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub settling: Option<f64>,
}

/// Above this share of a force's peak response left after the tail, gating leaves enough of
/// a glitch's response in the data to pull the fit, and the run says so. Measured on
/// `examples/glitches.toml` (five glitches of 2e−14 to 2e−13 m s⁻² per stretch; 40
/// realisations, docs/src/guide/glitches.md): with 23 % left (`glitch_tail` 1200 s) the
/// pulls of the stiffnesses, `dt2`, `a_sus` and `d21` scatter 1.3–2.7 times their errors
/// (1.4–3.2 before the runs between gates took their bins' exact noise covariance); with 8 %
/// (3600 s, measured before that) 0.8–1.4, a sample of 17.
pub const OUTLASTING_LIMIT: f64 = 0.1;

/// Above this share of an experiment's valid fit data gated, the gate's line says that a
/// parameter only that experiment constrains may be lost, and what to do.
pub const GATED_MOST: f64 = 0.5;

impl GlitchGate {
    /// One line for the terminal and the run's warnings.
    /// Whether the gates took more than [`GATED_MOST`] of the experiment's fit data.
    pub fn gated_most(&self) -> bool {
        self.seconds > GATED_MOST * (self.seconds + self.remaining)
    }

    pub fn describe(&self) -> String {
        format!(
            "experiment `{}`: glitch gating removed {:.0} s in {} region(s) ({} detected, {} listed){}{}",
            self.experiment,
            self.seconds,
            self.regions.len(),
            self.detected,
            self.listed,
            if self.regions.is_empty() {
                String::new()
            } else {
                format!(
                    ": {}",
                    self.regions
                        .iter()
                        .map(|r| format!("[{:.0}, {:.0}) s", r[0], r[1]))
                        .collect::<Vec<_>>()
                        .join(", ")
                )
            },
            if self.gated_most() {
                format!(
                    "; only {:.0} s of its fit data are left, and a parameter that only this experiment constrains may be lost (the MAP search then names it): raise glitch_threshold, lower glitch_tail, or fit the glitches (glitches = \"model\")",
                    self.remaining
                )
            } else {
                String::new()
            }
        )
    }
}

/// The residual series of `e` at `theta` (one per residual channel of `model`): of the fit
/// stretch, or of the noise-only stretch when `noise` (a channel without a noise-only series,
/// a commanded input, is zero there). The DC bin is left out (a model's coefficients may
/// diverge there).
pub fn residual_series(
    e: &ExperimentData,
    model: &dyn Model,
    theta: &[f64],
    noise: bool,
) -> Result<Vec<Vec<f64>>, String> {
    let n = if noise {
        e.n_noise_samples()
    } else {
        e.n_samples()
    };
    let chans = model.data_channels();
    let (nc, nr) = (chans.len(), model.residual_channels().len());
    let mut fft = RealFft::new(n).map_err(|x| x.to_string())?;
    let m = fft.spectrum_len();
    let zero = Complex64::new(0.0, 0.0);
    let mut x = vec![vec![zero; m]; nc];
    for (c, name) in chans.iter().enumerate() {
        let series = if noise {
            e.noise_channel(name)
        } else {
            Some(
                e.channel(name)
                    .ok_or_else(|| format!("no channel `{name}` in the data"))?,
            )
        };
        if let Some(s) = series {
            fft.forward(s, &mut x[c]).map_err(|x| x.to_string())?;
        }
    }
    let fs = e.fs;
    let mut consts = vec![zero; model.n_consts()];
    let mut coef = vec![zero; nr * nc];
    let mut p = vec![vec![zero; m]; nr];
    for k in 1..m {
        let f = k as f64 * fs / n as f64;
        model.bin_consts(f, fs, &mut consts);
        model.coefficients(
            theta,
            &Bin {
                f,
                fs,
                consts: &consts,
            },
            &mut coef,
        );
        for (r, pr) in p.iter_mut().enumerate() {
            pr[k] = (0..nc).map(|c| coef[r * nc + c] * x[c][k]).sum();
        }
    }
    let mut out = vec![vec![0.0; n]; nr];
    for (pr, o) in p.iter().zip(out.iter_mut()) {
        fft.inverse(pr, o).map_err(|x| x.to_string())?;
    }
    Ok(out)
}

/// Fills the samples of `gaps` by the straight line between the values beside each gap (the
/// nearest one at a stretch's end).
fn bridge(x: &mut [f64], gaps: &[Span]) {
    let n = x.len();
    for g in gaps {
        let (a, b) = (g[0], g[1].min(n));
        let left = if a > 0 { Some(x[a - 1]) } else { None };
        let right = if b < n { Some(x[b]) } else { None };
        let (l, r) = match (left, right) {
            (Some(l), Some(r)) => (l, r),
            (Some(l), None) => (l, l),
            (None, Some(r)) => (r, r),
            (None, None) => (0.0, 0.0),
        };
        let len = (b - a + 1) as f64;
        for (j, v) in x[a..b].iter_mut().enumerate() {
            let u = (j + 1) as f64 / len;
            *v = l + (r - l) * u;
        }
    }
}

/// The one-sided PSD of `x` over its valid runs `runs` (Welch with the analysis's window and
/// averages), as `(freqs, psd)` without the DC bin.
fn residual_psd(
    x: &[f64],
    fs: f64,
    runs: &[Span],
    opts: &SpectraOptions,
) -> Result<(Vec<f64>, Vec<f64>), String> {
    let valid: usize = runs.iter().map(|r| r[1] - r[0]).sum();
    let longest = runs.iter().map(|r| r[1] - r[0]).max().unwrap_or(0);
    let seg = welch_segment_len(valid, opts).min(longest);
    if seg < 16 {
        return Err(format!(
            "too few valid samples ({valid}) for a noise estimate to whiten the residual with"
        ));
    }
    let cfg = WelchConfig::new(fs, opts.welch_window, seg);
    let s = welch_csd2_runs(x, x, &cfg, runs).map_err(|e| e.to_string())?;
    Ok((s.freqs[1..].to_vec(), s.s11[1..].to_vec()))
}

/// `psd` at `f`: log-log interpolation, the nearest value outside the grid.
fn psd_at(freqs: &[f64], psd: &[f64], f: f64) -> f64 {
    let k = freqs.partition_point(|&x| x < f);
    if k == 0 {
        return psd[0];
    }
    if k >= freqs.len() {
        return psd[psd.len() - 1];
    }
    let (f0, f1, v0, v1) = (freqs[k - 1], freqs[k], psd[k - 1], psd[k]);
    if v0 > 0.0 && v1 > 0.0 {
        let u = (f / f0).ln() / (f1 / f0).ln();
        (v0.ln() + u * (v1 / v0).ln()).exp()
    } else {
        v0 + (v1 - v0) * (f - f0) / (f1 - f0)
    }
}

/// Per residual channel: the fit stretch's residual whitened against the noise reference
/// (unscaled), and the noise-only stretch's residual whitened alike (when there is one), each
/// with its gaps bridged.
type Whitened = Vec<(Vec<f64>, Option<Vec<f64>>)>;

fn whitened_pairs(
    e: &ExperimentData,
    model: &dyn Model,
    theta_ref: &[f64],
    opts: &SpectraOptions,
) -> Result<Whitened, String> {
    let fs = e.fs;
    let fit = residual_series(e, model, theta_ref, false)?;
    // the reference noise: the noise-only stretch's residual when there is one
    let noise = if e.n_noise_samples() >= 16 {
        Some(residual_series(e, model, theta_ref, true)?)
    } else {
        None
    };
    let mut out = Vec::with_capacity(fit.len());
    for (r, mut x) in fit.into_iter().enumerate() {
        bridge(&mut x, &e.gaps);
        let (freqs, psd) = match &noise {
            Some(ns) => residual_psd(&ns[r], fs, &e.noise_valid_runs(), opts)
                .or_else(|_| residual_psd(&x, fs, &e.valid_runs(), opts))?,
            None => residual_psd(&x, fs, &e.valid_runs(), opts)?,
        };
        let psd_f = |f: f64| psd_at(&freqs, &psd, f);
        // below three Welch bins the estimate is extrapolated or leaks (issue 22): whitening
        // against it there turns the noise's own low-frequency power into false glitches
        let band = [opts.band[0].max(3.0 * freqs[0]), opts.band[1].min(fs / 2.0)];
        let y = whiten(&x, fs, &psd_f, band).map_err(|x| x.to_string())?;
        let z = match &noise {
            Some(ns) => {
                let mut z = ns[r].clone();
                bridge(&mut z, &e.noise_gaps);
                Some(whiten(&z, fs, &psd_f, band).map_err(|x| x.to_string())?)
            }
            None => None,
        };
        out.push((y, z));
    }
    Ok(out)
}

/// `y` smoothed over `w` samples (its gaps `y_gaps` left out) and divided by the robust standard deviation of the noise
/// reference `z` smoothed alike, over the noise-only stretch's valid runs `runs` (of `y`
/// itself when there is no reference). The Welch estimate's few averages bias `1/S` high
/// (module docs), and the smoothed noise's spread depends on its correlation: both are taken
/// from the data rather than assumed.
fn standardised(
    y: &[f64],
    y_gaps: &[Span],
    z: Option<&[f64]>,
    runs: &[Span],
    w: usize,
) -> Vec<f64> {
    let mask = |n: usize, missing: &mut dyn Iterator<Item = Span>| {
        let mut v = vec![true; n];
        for g in missing {
            v[g[0]..g[1].min(n)].fill(false);
        }
        v
    };
    let ys = moving_mean(y, &mask(y.len(), &mut y_gaps.iter().copied()), w);
    let sd = match z {
        Some(z) => {
            let gaps_of_runs = gaps::valid_runs(z.len(), runs);
            let zs = moving_mean(z, &mask(z.len(), &mut gaps_of_runs.into_iter()), w);
            let valid: Vec<f64> = runs
                .iter()
                .flat_map(|g| zs[g[0]..g[1]].iter().copied())
                .collect();
            robust_sd(&valid)
        }
        None => robust_sd(&ys),
    };
    match sd {
        Some(sd) => ys.iter().map(|v| v / sd).collect(),
        None => ys,
    }
}

/// The whitened residuals of the fit stretch of `e` at `theta_ref` over `opts.band` (module
/// docs), one per residual channel, in σ of the noise: unit-variance white noise where the
/// model explains the data, with the stretch's gaps bridged by straight lines.
pub fn whitened_residuals(
    e: &ExperimentData,
    model: &dyn Model,
    theta_ref: &[f64],
    opts: &SpectraOptions,
) -> Result<Vec<Vec<f64>>, String> {
    let runs = e.noise_valid_runs();
    Ok(whitened_pairs(e, model, theta_ref, opts)?
        .iter()
        .map(|(y, z)| standardised(y, &e.gaps, z.as_deref(), &runs, 1))
        .collect())
}

/// The time scales (s) of the detection: the whitened residual itself, and its moving means
/// over these windows (longer ones, 300 s, gated 5 % of glitch-free data at 5σ: the noise
/// reference's spread over so few independent windows is too uncertain) (a slow glitch's whitened form keeps one sign for about its decay time,
/// so that averaging over it gains `√(window)` on the noise).
pub const GLITCH_SCALES: [f64; 2] = [30.0, 100.0];

/// Seconds at each end of the fit stretch and beside every gap where no detection starts: whitening a finite red
/// series leaves an artefact there (the line removed to match its ends leaves a kink at the
/// wrap, which whitening, about a second derivative below the read-out corner, turns into a
/// pulse that the 100 s mean sees at 5σ in most realisations). A glitch that starts and
/// fades inside them is not found; the pad of one found beside them still reaches in.
pub const EDGE_SECONDS: f64 = 120.0;

/// The regions of the fit stretch of `e` to gate: glitches found on the residual at
/// `theta_ref`, whitened over `opts.band`, at `threshold` σ on the whitened residual or on any
/// of its moving means over [`GLITCH_SCALES`] (each in σ of the noise reference smoothed
/// alike), each region padded by `pad` seconds (module docs). Regions already missing are not
/// reported again; the result is normalised and leaves the stretch's gaps out.
pub fn detect_glitches(
    e: &ExperimentData,
    model: &dyn Model,
    theta_ref: &[f64],
    opts: &SpectraOptions,
    threshold: f64,
    pad: f64,
) -> Result<Vec<Span>, String> {
    let fs = e.fs;
    let n = e.n_samples();
    let runs = e.noise_valid_runs();
    let edge = ((EDGE_SECONDS * fs).round() as usize).min(n / 2);
    // the ends of every valid run alike: the bridge across a gap kinks there too
    let mut ignore: Vec<Span> = e
        .gaps
        .iter()
        .map(|g| [g[0].saturating_sub(edge), (g[1] + edge).min(n)])
        .collect();
    ignore.push([0, edge]);
    ignore.push([n - edge, n]);
    let ignore = gaps::normalise(ignore);
    let mut regions: Vec<Span> = Vec::new();
    for (y, z) in whitened_pairs(e, model, theta_ref, opts)? {
        let windows = std::iter::once(1).chain(
            GLITCH_SCALES
                .iter()
                .map(|s| ((s * fs).round() as usize).max(1)),
        );
        for w in windows {
            let ys = standardised(&y, &e.gaps, z.as_deref(), &runs, w);
            let settings = GateSettings {
                threshold,
                release: GLITCH_RELEASE,
                smooth: ((ENVELOPE_SECONDS * fs).round() as usize).max(8).max(w),
                pad: (pad * fs).round() as usize,
            };
            regions.extend(detect(&ys, &ignore, &settings));
        }
    }
    let regions = gaps::normalise(regions);
    // only what is not missing already
    let mut mask = vec![false; n];
    for g in &regions {
        mask[g[0]..g[1]].fill(true);
    }
    for g in &e.gaps {
        mask[g[0]..g[1].min(n)].fill(false);
    }
    let mut out: Vec<Span> = Vec::new();
    for (k, on) in mask.iter().enumerate() {
        if *on {
            match out.last_mut() {
                Some(s) if s[1] == k => s[1] = k + 1,
                _ => out.push([k, k + 1]),
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A gate that leaves less than half of an experiment's data says what may be lost and
    /// what to do; one that leaves most of it does not.
    #[test]
    fn a_gate_that_removes_most_of_an_experiment_says_so() {
        let gate = |seconds: f64, remaining: f64| GlitchGate {
            experiment: "inv2".into(),
            detected: 3,
            listed: 0,
            regions: vec![[100.0, 100.0 + seconds]],
            seconds,
            remaining,
            outlasting: None,
            settling: None,
        };
        let most = gate(12_000.0, 7_000.0).describe();
        assert!(
            most.contains("only 7000 s") && most.contains("glitch_tail"),
            "{most}"
        );
        let some = gate(6_000.0, 13_000.0).describe();
        assert!(!some.contains("only"), "{some}");
    }

    #[test]
    fn bridges_are_straight_lines_between_the_neighbours() {
        let mut x = vec![1.0, 0.0, 0.0, 0.0, 5.0, 7.0, 0.0];
        bridge(&mut x, &[[1, 4], [6, 7]]);
        assert_eq!(x, vec![1.0, 2.0, 3.0, 4.0, 5.0, 7.0, 7.0]);
    }

    #[test]
    fn psd_interpolation_is_log_log_and_clamped() {
        let f = [1.0, 10.0];
        let s = [1.0, 100.0];
        assert!((psd_at(&f, &s, 3.0) - 9.0).abs() < 1e-9);
        assert_eq!(psd_at(&f, &s, 0.1), 1.0);
        assert_eq!(psd_at(&f, &s, 50.0), 100.0);
    }
}
