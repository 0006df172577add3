//! Data with gaps: an experiment whose fit stretch misses samples is analysed as its valid
//! runs, each a stretch of its own with its own DFT grid, and the log-likelihood is their sum.
//!
//! # Why per run, and what it costs
//! Filling a gap with zeros and taking one DFT of the whole stretch multiplies the data by the
//! gap mask: every bin then mixes its neighbours through the mask's spectrum, whose sidelobes
//! a few long gaps make broad, and the Whittle likelihood's independent bins no longer hold.
//! Accounting for that correlation exactly needs the dense `N × N` covariance of the masked
//! DFT. A valid run on its own is a gap-free series, for which the Whittle approximation is
//! as good as for the whole gap-free stretch, and runs separated by a gap are treated as
//! independent (exact for noise whose correlation time is shorter than the gap). The price:
//! - a run of length `T_r` has no bin below `1/T_r`, so information below the longest run's
//!   resolution is lost, and runs shorter than one fit bin's period add nothing;
//! - the response to the injections before a run starts (and after it ends) is not in the
//!   run's DFT: the loop's memory (the slowest closed-loop pole, τ ≈ 1200 s for the LTP)
//!   leaks a transient into the run. At high SNR that alone biases every parameter by tens
//!   to hundreds of σ, so it is corrected exactly at the reference point from the injections,
//!   which are known through the gaps (`correct_edges`);
//! - a run's noise is not periodic in it, and the read-out noise's steep low-frequency rise
//!   leaks through a rectangular edge. Both ends of every run are tapered by a raised cosine
//!   of `gap_taper` seconds (at most a quarter of the run), every channel alike (the noise
//!   normalisation `Σ w²` accounts for the lost weight);
//! - even so, the kernel of a run's taper carries power from far below a bin into it where
//!   the noise is steep (the `o12` read-out's `f⁻⁴`), most in the run's lowest bins: each
//!   run's bins take the covariance they have exactly under the stretch's noise
//!   ([`super::run_noise`]), not `S(f_k)`. That needs the noise below the band, down to the
//!   stretch's lowest frequency. The noise model (`noise = "model"`) knows it, and a run's
//!   bins start at its first period ([`min_cycles`]); the Welch estimate holds its lowest
//!   value below its first frequency, which underestimates the leakage into the runs' lowest
//!   bins, so with it a run's bins start at its third period (with the first two kept, the
//!   stiffnesses' errors were a third of their scatter short over 100 realisations);
//! - gap-free experiments take none of this: they give the numbers they always gave.
//!
//! The noise-only stretch's Welch estimate averages only segments that lie inside its valid
//! runs ([`crate::signal::welch_csd2_runs`]).

use super::run_noise::StretchNoise;
use super::spectra::{
    ExperimentSpectra, NoiseSource, SpectraError, SpectraOptions, consts_at, data_noise, edge_taper,
};
use crate::data::dataset::ExperimentData;
use crate::data::gaps;
use crate::hermitian::Mat2;
use crate::model::Bin;
use crate::model::Model;
use crate::signal::RealFft;
use num_complex::Complex64;
use serde::Serialize;

/// What the gaps of one experiment did to its analysis.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GapSummary {
    pub experiment: String,
    /// Number of gaps in the fit stretch.
    pub gaps: usize,
    /// Fraction of the fit stretch's samples that are missing.
    pub missing: f64,
    /// Number of gaps in the noise-only stretch and the fraction of its samples missing.
    pub noise_gaps: usize,
    pub noise_missing: f64,
    /// Valid runs analysed, and those left out (no DFT bin of their own in the band; see
    /// [`ExperimentSpectra::of_experiment`]).
    pub runs_used: usize,
    pub runs_dropped: usize,
    /// Samples in the runs left out.
    pub samples_dropped: usize,
}

impl GapSummary {
    /// One line for the terminal and the run's warnings.
    pub fn describe(&self) -> String {
        format!(
            "experiment `{}`: {} gap(s), {:.1} % of the fit stretch missing ({} gap(s), {:.1} % of the noise-only stretch); analysed as {} valid run(s){}",
            self.experiment,
            self.gaps,
            100.0 * self.missing,
            self.noise_gaps,
            100.0 * self.noise_missing,
            self.runs_used,
            if self.runs_dropped > 0 {
                format!(
                    ", {} run(s) of {} samples in all left out (no in-band bin)",
                    self.runs_dropped, self.samples_dropped
                )
            } else {
                String::new()
            }
        )
    }
}

impl ExperimentSpectra {
    /// The spectra of one experiment: itself when its fit stretch has no gap (exactly
    /// [`ExperimentSpectra::new`]), else one per valid run (module docs), named
    /// `<experiment>@<start>s`. A run is left out when no DFT bin of its own falls in the
    /// band; it is an error when every run is.
    pub fn of_experiment(
        e: &ExperimentData,
        opts: &SpectraOptions,
        model: &dyn Model,
        theta_ref: &[f64],
        model_csd: Option<&dyn Fn(f64) -> Mat2>,
    ) -> Result<Vec<Self>, SpectraError> {
        if e.gaps.is_empty() {
            return Ok(vec![Self::new(e, opts, model, theta_ref, model_csd)?]);
        }
        let [lo, hi] = opts.band;
        let taper_len = (opts.gap_taper.max(0.0) * e.fs).round() as usize;
        let stretch = stretch_noise(e, opts, model, theta_ref, model_csd).map_err(|msg| {
            SpectraError::Invalid {
                exp: e.name.clone(),
                msg,
            }
        })?;
        let mut out = Vec::new();
        let mut dropped = 0;
        for run in e.valid_runs() {
            let len = run[1] - run[0];
            if !has_bin_in_band(len, e.fs, opts) {
                dropped += 1;
                continue;
            }
            // both ends: a run's noise is not periodic in it, and the read-out noise's steep
            // low-frequency rise leaks through a rectangular edge
            let t = taper_len.min(len / 4);
            let taper = [t, t];
            let name = format!("{}@{}s", e.name, fmt_seconds(run[0] as f64 / e.fs));
            let sub = e.slice(&name, run);
            // the run's lowest bins see the window's main lobe over the steep noise: keep
            // bins from `min_cycles` periods per run up (half a bin below, so that rounding
            // of `k·fs/len` cannot drop that bin itself)
            let mut ro = opts.clone();
            ro.band[0] = lo.max((min_cycles(opts.noise) - 0.5) * e.fs / len as f64);
            let sp = Self::tapered(
                &sub,
                &ro,
                model,
                theta_ref,
                model_csd,
                taper,
                Some(&stretch),
            )?;
            out.push((sp, run, taper));
        }
        if out.is_empty() {
            return Err(SpectraError::Invalid {
                exp: e.name.clone(),
                msg: format!(
                    "none of its {} valid runs between gaps has a DFT bin in the band [{lo}, {hi}] Hz (the longest is {} s)",
                    dropped,
                    e.valid_runs()
                        .iter()
                        .map(|r| r[1] - r[0])
                        .max()
                        .unwrap_or(0) as f64
                        / e.fs
                ),
            });
        }
        let mut out: Vec<(Self, gaps::Span, [usize; 2])> = out;
        correct_edges(e, opts, model, theta_ref, &mut out).map_err(|msg| {
            SpectraError::Invalid {
                exp: e.name.clone(),
                msg,
            }
        })?;
        Ok(out.into_iter().map(|(s, _, _)| s).collect())
    }
}

/// The edge correction (module docs): for each run, the DFT of the exact input-driven
/// residual over the run, `X = DFT_run(w · IDFT_full(Σ_u M_u(θ_ref) U_full))`, minus what the
/// run's own spectra give at `θ_ref`, `A = Σ_u M_u(θ_ref) DFT_run(w · u_run)`, is added to the
/// read-out whose coefficient is the identity, so that the run's residual at `θ_ref` is the
/// exact one. Inputs are the channels with no noise (`is_input`); a model whose residual is
/// not `read-out + Σ_u M_u u` with a θ-independent identity on the read-outs gets no
/// correction (the edge error is then reported by [`GapSummary`]).
fn correct_edges(
    e: &ExperimentData,
    opts: &SpectraOptions,
    model: &dyn Model,
    theta_ref: &[f64],
    runs: &mut [(ExperimentSpectra, gaps::Span, [usize; 2])],
) -> Result<(), String> {
    let Some((first, _, _)) = runs.first() else {
        return Ok(());
    };
    let nc = first.channels.len();
    let nr = first.nr;
    let inputs: Vec<usize> = (0..nc).filter(|&c| first.is_input[c]).collect();
    if inputs.is_empty() {
        return Ok(());
    }
    let Some(readout) = identity_readouts(model, theta_ref, first) else {
        return Ok(());
    };
    let n = e.n_samples();
    let fs = e.fs;
    let mut fft = RealFft::new(n).map_err(|x| x.to_string())?;
    let m = fft.spectrum_len();
    let zero = Complex64::new(0.0, 0.0);
    // the inputs' full-stretch DFTs (known through the gaps)
    let mut u = vec![vec![zero; m]; inputs.len()];
    for (j, &c) in inputs.iter().enumerate() {
        let x = e
            .channel(&first.channels[c])
            .ok_or_else(|| format!("no channel `{}`", first.channels[c]))?;
        fft.forward(x, &mut u[j]).map_err(|x| x.to_string())?;
    }
    // Σ_u M_u(θ_ref) U on every bin but DC (a model's coefficients may diverge there; the
    // inputs' means carry no information in any band)
    let ncst = model.n_consts();
    let mut consts = vec![zero; ncst];
    let mut coef = vec![zero; nr * nc];
    let mut p = vec![vec![zero; m]; nr];
    for k in 1..m {
        let f = k as f64 * fs / n as f64;
        model.bin_consts(f, fs, &mut consts);
        model.coefficients(
            theta_ref,
            &Bin {
                f,
                fs,
                consts: &consts,
            },
            &mut coef,
        );
        for r in 0..nr {
            let mut acc = zero;
            for (j, &c) in inputs.iter().enumerate() {
                acc += coef[r * nc + c] * u[j][k];
            }
            p[r][k] = acc;
        }
    }
    let mut series = vec![vec![0.0; n]; nr];
    for r in 0..nr {
        fft.inverse(&p[r], &mut series[r])
            .map_err(|x| x.to_string())?;
    }
    for (sp, run, taper) in runs.iter_mut() {
        let len = run[1] - run[0];
        let mut w = opts.window.values(len);
        edge_taper(&mut w, *taper);
        let mut rf = RealFft::new(len).map_err(|x| x.to_string())?;
        let mut buf = vec![0.0; len];
        let mut spec = vec![zero; rf.spectrum_len()];
        let df = fs / len as f64;
        for r in 0..nr {
            for ((b, x), wi) in buf.iter_mut().zip(&series[r][run[0]..run[1]]).zip(&w) {
                *b = x * wi;
            }
            rf.forward(&buf, &mut spec).map_err(|x| x.to_string())?;
            for k in 0..sp.len() {
                let kk = (sp.freqs[k] / df).round() as usize;
                let bin = sp.bin(k, ncst);
                model.coefficients(theta_ref, &bin, &mut coef);
                let d = sp.data_at(k);
                let approx: Complex64 = inputs.iter().map(|&c| coef[r * nc + c] * d[c]).sum();
                let fix = spec[kk] - approx;
                sp.data[k * nc + readout[r]] += fix;
            }
        }
    }
    Ok(())
}

/// For each residual channel `r`, the data channel whose coefficient is `δ_rr'` at `θ_ref`
/// and at a perturbed point on the first and last bins of `sp` (a θ-independent identity),
/// or `None` when the model's residual is not of that form.
fn identity_readouts(
    model: &dyn Model,
    theta_ref: &[f64],
    sp: &ExperimentSpectra,
) -> Option<Vec<usize>> {
    let (nc, nr) = (sp.channels.len(), sp.nr);
    let ncst = model.n_consts();
    let mut coef = vec![Complex64::new(0.0, 0.0); nr * nc];
    let perturbed: Vec<f64> = theta_ref
        .iter()
        .map(|t| if *t == 0.0 { 1e-3 } else { t * 1.01 })
        .collect();
    let mut pick: Option<Vec<usize>> = None;
    for k in [0, sp.len() - 1] {
        for th in [theta_ref, &perturbed[..]] {
            model.coefficients(th, &sp.bin(k, ncst), &mut coef);
            let mut this = Vec::with_capacity(nr);
            for r in 0..nr {
                let c = (0..nc).find(|&c| {
                    !sp.is_input[c]
                        && (0..nr).all(|q| {
                            let want = if q == r { 1.0 } else { 0.0 };
                            (coef[q * nc + c] - want).norm() == 0.0
                        })
                })?;
                this.push(c);
            }
            match &pick {
                None => pick = Some(this),
                Some(p) if *p != this => return None,
                Some(_) => {}
            }
        }
    }
    pick
}

/// The noise of the data channels over the whole fit stretch of `e`, on its DFT grid (DC
/// excluded), as the autocovariance the runs' exact bin covariances are taken from
/// ([`super::run_noise`]): the same source as the runs' (`[analysis] noise`), evaluated at
/// every frequency of the stretch, below the band too, for the leakage comes from there.
fn stretch_noise(
    e: &ExperimentData,
    opts: &SpectraOptions,
    model: &dyn Model,
    theta_ref: &[f64],
    model_csd: Option<&dyn Fn(f64) -> Mat2>,
) -> Result<StretchNoise, String> {
    let n = e.n_samples();
    let fs = e.fs;
    let freqs: Vec<f64> = (1..=n / 2).map(|j| j as f64 * fs / n as f64).collect();
    let consts = consts_at(model, &freqs, fs);
    let noise = data_noise(e, opts, model, theta_ref, model_csd, &freqs, &consts)?;
    let (noisy, sd) = noise.noise;
    StretchNoise::new(n, noisy.len(), &sd, fs)
}

/// The lowest bin of a run, in its periods (`k ≥ min_cycles`): the first with the noise
/// model, which knows the noise below the band that leaks into a run's lowest bins; the
/// third with the Welch estimate, which does not (module docs).
pub(super) fn min_cycles(noise: NoiseSource) -> f64 {
    match noise {
        NoiseSource::Model => 1.0,
        NoiseSource::Welch => 3.0,
    }
}

/// Whether a valid run of `len` samples has a regular DFT bin of its own in the band of
/// `opts`, from [`min_cycles`] up.
fn has_bin_in_band(len: usize, fs: f64, opts: &SpectraOptions) -> bool {
    let [lo, hi] = opts.band;
    let df = fs / len as f64;
    let first = (lo / df).ceil().max(min_cycles(opts.noise)) * df;
    len >= 16 && first <= hi && first < fs / 2.0
}

impl GapSummary {
    /// The summary of experiment `e` analysed with `opts`, `None` when it has no gap: the
    /// runs [`ExperimentSpectra::of_experiment`] uses and leaves out.
    pub fn of(e: &ExperimentData, opts: &SpectraOptions) -> Option<GapSummary> {
        if !e.has_gaps() {
            return None;
        }
        let runs = e.valid_runs();
        let (keep, drop): (Vec<&gaps::Span>, Vec<&gaps::Span>) = runs
            .iter()
            .partition(|r| has_bin_in_band(r[1] - r[0], e.fs, opts));
        Some(summary(
            e,
            keep.len(),
            drop.len(),
            drop.iter().map(|r| r[1] - r[0]).sum(),
        ))
    }
}

fn summary(e: &ExperimentData, used: usize, dropped: usize, samples_dropped: usize) -> GapSummary {
    let frac = |g: &[gaps::Span], n: usize| {
        if n == 0 {
            0.0
        } else {
            gaps::missing(g) as f64 / n as f64
        }
    };
    GapSummary {
        experiment: e.name.clone(),
        gaps: e.gaps.len(),
        missing: frac(&e.gaps, e.n_samples()),
        noise_gaps: e.noise_gaps.len(),
        noise_missing: frac(&e.noise_gaps, e.n_noise_samples()),
        runs_used: used,
        runs_dropped: dropped,
        samples_dropped,
    }
}

/// Seconds without a trailing `.0` when whole (`1200`, `12.5`).
fn fmt_seconds(t: f64) -> String {
    if t.fract() == 0.0 {
        format!("{t:.0}")
    } else {
        format!("{t}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hermitian::Mat2;
    use crate::likelihood::NoiseSource;
    use crate::likelihood::tests::{ltp_model, small_study};

    /// A run whose only in-band bin is its third (the band's bottom at 2.5 of its periods):
    /// `3·(fs/len)` rounds below `3·fs/len` for `len = 136` at 1 Hz, which once dropped the bin
    /// and failed the whole experiment.
    #[test]
    fn a_run_keeps_its_lowest_bin_despite_rounding() {
        let len = 136usize;
        let fs = 1.0;
        assert!(
            3.0 * (fs / len as f64) < 3.0 * fs / len as f64,
            "the rounding case"
        );
        let study = small_study(7, 1e-9, "circular");
        let sim = crate::experiment::simulate(&study.simulation_plan()).unwrap();
        let mut e = sim.dataset.experiments[0].clone();
        let n = e.n_samples();
        e.add_gaps(&[[n - len - 60, n - len]]);
        let sys = study.system();
        let csd = |f: f64| -> Mat2 { sys.noise_csd(f) };
        let opts = SpectraOptions {
            noise: NoiseSource::Model,
            band: [2.5 / len as f64, 3.5 / len as f64],
            ..Default::default()
        };
        let m = ltp_model();
        let runs = ExperimentSpectra::of_experiment(
            &e,
            &opts,
            m.as_ref(),
            &study.truth.to_array(),
            Some(&csd),
        )
        .unwrap();
        let last = runs.last().unwrap();
        assert_eq!(last.n, len);
        assert_eq!(last.freqs.len(), 1);
        assert!((last.freqs[0] - 3.0 * fs / len as f64).abs() < 1e-15);
    }
}
