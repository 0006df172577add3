//! The measured transfer function from each injected channel to each read-out, and the fitted
//! model's at the same frequencies: what LTPDA users look at first (Bode plots).
//!
//! * measured: `H(f) = S_io(f) / S_ii(f)` (the Welch CSD of input and output over the input's
//!   PSD, on the fit stretch, with as many averages as the noise estimate, `welch_averages`
//!   segments of the Welch window), at the bins where the injection has power (local maxima of
//!   `S_ii` at least [`LINE_POWER`] of its largest in the band; for sinusoidal injections, the
//!   lines' bins), from bin [`MIN_BIN`] up. The segments do not overlap: overlapping ones share noise, and for a
//!   sinusoid the shared part adds up with a phase that depends on the line's frequency, so no
//!   single effective number of averages would give the error. A line's frequency is
//!   interpolated from its bins (a parabola through the log power of the peak and its
//!   neighbours): for a sinusoid the ratio of the two DFTs is `H` at the sinusoid's frequency,
//!   not at the bin's.
//! * uncertainty: the coherence-based random error of Bendat & Piersol, *Random Data* (4th ed.,
//!   2010), §9.2.4, eqs. (9.52)–(9.53): `σ(|H|)/|H| ≈ σ(φ) ≈ √((1 − γ²)/(2 n γ²))` with
//!   `γ² = |S_io|²/(S_ii S_oo)` and `n` the number of (independent) segments averaged.
//! * model: the read-outs a model predicts for an injection, `o = −M_o⁻¹ M_i i` from its
//!   residual `r = M_o o + M_i i` (square `M_o`: as many read-outs as residual channels).

use super::spectra::SpectraOptions;
use crate::data::dataset::ExperimentData;
use crate::model::{ChannelRoles, Model, coefficients_at};
use crate::signal::{WelchConfig, welch_csd2_runs};
use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;

/// A bin counts as a line of the injection when its input PSD is a local maximum at least this
/// fraction of the largest in the band (−60 dB: above the Blackman–Harris sidelobes, which are
/// at −92 dB).
pub const LINE_POWER: f64 = 1e-6;

/// Lowest bin a line may be measured at: closer to DC, the mean removed from each segment and
/// a sinusoid's negative-frequency image fall inside the main lobe (four bins either side for
/// the Blackman–Harris window) and bias the ratio.
pub const MIN_BIN: usize = 5;

/// One measured transfer function: injection `input` to read-out `output` of one experiment.
#[derive(Debug, Clone, PartialEq)]
pub struct MeasuredTransfer {
    /// The experiment measured.
    pub experiment: String,
    /// The injection channel (`i1`, `i12`, a state-space model's input …).
    pub input: String,
    /// The read-out channel (`o1`, `o12`, a state-space model's output …).
    pub output: String,
    /// Frequency of each line (Hz): the centroid of its bins' input power.
    pub freqs: Vec<f64>,
    /// `H = S_io/S_ii` at each line.
    pub h: Vec<Complex64>,
    /// Magnitude-squared coherence `γ²` at each line.
    pub coherence: Vec<f64>,
    /// One-sigma relative error of `|H|`, which is also the phase error in radians.
    pub rel_err: Vec<f64>,
    /// Segments averaged (back to back, so independent).
    pub n_avg: usize,
}

/// The relative error of a transfer estimate of coherence `gamma2` from `n` independent
/// averages (Bendat & Piersol 2010, eqs. 9.52–9.53); infinite where there is no coherence.
pub fn coherence_error(gamma2: f64, n: f64) -> f64 {
    if gamma2 > 0.0 && n > 0.0 {
        ((1.0 - gamma2).max(0.0) / (2.0 * n * gamma2)).sqrt()
    } else {
        f64::INFINITY
    }
}

/// The fewest segments whose coherence-based error bars are checked to cover: with fewer, the
/// scatter and bias of the estimated coherence make them too small (χ²/n of the transfer
/// tests' pulls: 1.04 at 16 averages, 6.8 at 8, 31 at 4; the tests below).
pub const MIN_CHECKED_AVERAGES: usize = 16;

/// The measured transfer functions of experiment `e` from every injection channel of `roles`
/// that carries a signal to every read-out the experiment holds, in band `opts.band`; none when
/// nothing is injected. Errors name the experiment (a fit stretch too short for the segments,
/// non-finite samples).
pub fn measured_transfer(
    e: &ExperimentData,
    opts: &SpectraOptions,
    roles: &ChannelRoles,
) -> Result<Vec<MeasuredTransfer>, String> {
    let Some(n) = roles
        .readouts
        .iter()
        .find_map(|c| e.channel(&c.name))
        .map(<[f64]>::len)
    else {
        return Ok(Vec::new());
    };
    let runs = e.valid_runs();
    // as many segments as the noise estimate averages, back to back
    let valid: usize = runs.iter().map(|r| r[1] - r[0]).sum();
    let seg = valid / opts.welch_averages.max(1);
    let outputs: Vec<(&str, &[f64])> = roles
        .readouts
        .iter()
        .filter_map(|c| {
            Some((
                c.name.as_str(),
                e.channel(&c.name).filter(|o| o.len() == n)?,
            ))
        })
        .collect();
    let mut out = Vec::new();
    for input in &roles.injections {
        let Some(i) = e.channel(&input.name) else {
            continue;
        };
        if i.len() != n || i.iter().all(|&v| v == 0.0) {
            continue;
        }
        if seg < 16 {
            return Err(format!(
                "experiment `{}`: the fit stretch ({n} samples) is too short for {} Welch averages of the transfer function",
                e.name, opts.welch_averages
            ));
        }
        let cfg = WelchConfig::new(e.fs, opts.welch_window, seg).with_overlap(0.0);
        for &(output, o) in &outputs {
            let s = welch_csd2_runs(i, o, &cfg, &runs).map_err(|err| {
                format!("experiment `{}`: {} → {output}: {err}", e.name, input.name)
            })?;
            let lines = line_bins(&s.freqs, &s.s11, opts.band);
            let mut t = MeasuredTransfer {
                experiment: e.name.clone(),
                input: input.name.clone(),
                output: output.to_string(),
                freqs: Vec::with_capacity(lines.len()),
                h: Vec::with_capacity(lines.len()),
                coherence: Vec::with_capacity(lines.len()),
                rel_err: Vec::with_capacity(lines.len()),
                n_avg: s.n_avg,
            };
            for b in lines {
                // S12 = E[I O*], so S_io = E[I* O] is its conjugate
                let s_io = s.s12[b].conj();
                let gamma2 = s_io.norm_sqr() / (s.s11[b] * s.s22[b]);
                t.freqs.push(line_frequency(&s.freqs, &s.s11, b));
                t.h.push(s_io / s.s11[b]);
                t.coherence.push(gamma2);
                t.rel_err.push(coherence_error(gamma2, s.n_avg as f64));
            }
            out.push(t);
        }
    }
    Ok(out)
}

/// The bins of the lines of an input PSD `p`: local maxima (above the left neighbour, not
/// below the right one) inside `band`, from bin [`MIN_BIN`] up and below Nyquist, of at least
/// [`LINE_POWER`] of the largest PSD in the band.
fn line_bins(freqs: &[f64], p: &[f64], band: [f64; 2]) -> Vec<usize> {
    let inside = |k: usize| freqs[k] >= band[0] && freqs[k] <= band[1];
    let top = (1..p.len().saturating_sub(1))
        .filter(|&k| inside(k))
        .map(|k| p[k])
        .fold(0.0, f64::max);
    if top <= 0.0 {
        return Vec::new();
    }
    (MIN_BIN..p.len().saturating_sub(1))
        .filter(|&k| inside(k) && p[k] > p[k - 1] && p[k] >= p[k + 1] && p[k] >= LINE_POWER * top)
        .collect()
}

/// The frequency of the line peaking at bin `b` (`0 < b < len − 1`): the vertex of the parabola
/// through the log power of `b` and its neighbours (the main lobe of a smooth window is close
/// to a Gaussian), within half a bin of the peak; the bin's own frequency when a neighbour
/// has no power.
fn line_frequency(freqs: &[f64], p: &[f64], b: usize) -> f64 {
    let (l, c, r) = (p[b - 1], p[b], p[b + 1]);
    if !(l > 0.0 && r > 0.0 && c > 0.0) {
        return freqs[b];
    }
    let (l, c, r) = (l.ln(), c.ln(), r.ln());
    let curve = l - 2.0 * c + r;
    let delta = if curve < 0.0 {
        (0.5 * (l - r) / curve).clamp(-0.5, 0.5)
    } else {
        0.0
    };
    freqs[b] + delta * (freqs[b + 1] - freqs[b])
}

/// The transfer function from data channel `input` to data channel `output` that `model`
/// predicts at `theta`, at `freqs` for data sampled at `fs`: `−(M_o⁻¹ M_i)` where `M_o` holds
/// the columns of the model's read-outs (its data channels that are residual channels,
/// [`ChannelRoles`]) and `M_i` the column of `input`.
/// `None` when the model does not read both, has other than one residual per read-out, or
/// `M_o` is singular at some frequency.
pub fn model_transfer(
    model: &dyn Model,
    theta: &[f64],
    fs: f64,
    freqs: &[f64],
    input: &str,
    output: &str,
) -> Option<Vec<Complex64>> {
    let data = model.data_channels();
    let nc = data.len();
    let nr = model.residual_channels().len();
    // the read-outs: the data channels that are residual channels (r = o − H i)
    let res = model.residual_channels();
    let outs: Vec<usize> = data
        .iter()
        .enumerate()
        .filter(|(_, c)| res.contains(c))
        .map(|(k, _)| k)
        .collect();
    let col_in = data.iter().position(|c| c == input)?;
    let row_out = outs.iter().position(|&k| data[k] == output)?;
    if outs.len() != nr {
        return None;
    }
    freqs
        .iter()
        .map(|&f| {
            let m = coefficients_at(model, theta, f, fs);
            let a = DMatrix::from_fn(nr, nr, |r, c| m[r * nc + outs[c]]);
            let b = DVector::from_fn(nr, |r, _| -m[r * nc + col_in]);
            let x = a.lu().solve(&b)?;
            x[row_out].is_finite().then_some(x[row_out])
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{LtpModel, LtpModelOptions};
    use crate::signal::Window;
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal, Uniform};
    use rand_xoshiro::Xoshiro256PlusPlus;
    use std::f64::consts::PI;

    const FS: f64 = 1.0;
    const N: usize = 40_000;

    fn opts() -> SpectraOptions {
        SpectraOptions {
            band: [1e-3, 0.4],
            welch_averages: 16,
            welch_window: Window::Bh92,
            ..SpectraOptions::default()
        }
    }

    /// The LTP closed loop at its nominal parameters (the paper's truth).
    fn ltp() -> (LtpModel, Vec<f64>) {
        let m = LtpModel::new("ltp", LtpModelOptions::default());
        let th = crate::ltp::LtpParams::default().to_array().to_vec();
        (m, th)
    }

    /// An experiment injecting `lines` sinusoids `(f, amplitude)` into i1, with the read-outs
    /// the model's exact response plus white noise of one-sided PSD `2 σ²/fs`.
    fn experiment(lines: &[(f64, f64)], sigma: f64, seed: u64) -> ExperimentData {
        let (m, th) = ltp();
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
        let turn = Uniform::new(0.0, 2.0 * PI).unwrap();
        let mut i = vec![0.0; N];
        let mut o = [vec![0.0; N], vec![0.0; N]];
        for &(f, a) in lines {
            let ph = turn.sample(&mut rng);
            let h: Vec<Complex64> = ["o1", "o12"]
                .iter()
                .map(|out| model_transfer(&m, &th, FS, &[f], "i1", out).unwrap()[0])
                .collect();
            for n in 0..N {
                let t = n as f64 / FS;
                i[n] += a * (2.0 * PI * f * t + ph).cos();
                for c in 0..2 {
                    o[c][n] += a * h[c].norm() * (2.0 * PI * f * t + ph + h[c].arg()).cos();
                }
            }
        }
        for c in &mut o {
            for v in c.iter_mut() {
                let z: f64 = StandardNormal.sample(&mut rng);
                *v += sigma * z;
            }
        }
        ExperimentData {
            name: "sim".into(),
            fs: FS,
            o,
            i: [i, vec![0.0; N]],
            noise: [Vec::new(), Vec::new()],
            extra: Default::default(),
            noise_extra: Default::default(),
            gaps: Vec::new(),
            noise_gaps: Vec::new(),
            known_in_gaps: Vec::new(),
        }
    }

    /// The LTP loop's read-outs and injections.
    fn ltp_roles() -> ChannelRoles {
        ChannelRoles::of(&ltp().0)
    }

    /// Lines spread over the band with amplitudes that give coherences from about 0.5 to
    /// 0.9999, well apart (≥ 5 bins of the 2500-sample segments, beyond the main lobe) so that
    /// no line leaks into another's bins, off the bin centres by varying fractions.
    fn lines() -> Vec<(f64, f64)> {
        (0..40)
            .map(|k| {
                let f = 4e-3 + 2.3e-3 * k as f64 + 1.7e-5 * (k % 7) as f64;
                (f, 1e-3 * 10f64.powf(-((k % 5) as f64) * 0.3))
            })
            .collect()
    }

    /// Pulls of the gain (`ln |H|` over its relative error) and phase of every line with real
    /// coherence, over several noise realisations.
    fn pulls(scale_err: f64) -> Vec<f64> {
        pulls_at(scale_err, opts().welch_averages)
    }

    fn pulls_at(scale_err: f64, averages: usize) -> Vec<f64> {
        let (m, th) = ltp();
        let mut z = Vec::new();
        let o = SpectraOptions {
            welch_averages: averages,
            ..opts()
        };
        for seed in 0..6 {
            let e = experiment(&lines(), 1e-3, seed);
            for t in measured_transfer(&e, &o, &ltp_roles()).unwrap() {
                assert_eq!(t.input, "i1");
                let truth = model_transfer(&m, &th, FS, &t.freqs, "i1", &t.output).unwrap();
                for k in 0..t.h.len() {
                    if t.coherence[k] < 0.5 {
                        continue;
                    }
                    let s = t.rel_err[k] * scale_err;
                    let r = t.h[k] / truth[k];
                    z.push(r.norm().ln() / s);
                    z.push(r.arg() / s);
                }
            }
        }
        z
    }

    #[test]
    fn the_measured_transfer_agrees_with_the_true_model_within_its_error() {
        let z = pulls(1.0);
        assert!(z.len() >= 400, "only {} pulls", z.len());
        let n = z.len() as f64;
        let within = z.iter().filter(|v| v.abs() < 2.0).count() as f64 / n;
        let chi2 = z.iter().map(|v| v * v).sum::<f64>() / n;
        let band = 3.0 * (2.0 / n).sqrt();
        assert!(within >= 0.9, "{within} of the pulls within 2σ");
        assert!((chi2 - 1.0).abs() < band, "χ²/n = {chi2} (±{band})");
        // an error bar 20 % too large or too small fails the same check
        for wrong in [0.8, 1.2] {
            let c = pulls(wrong).iter().map(|v| v * v).sum::<f64>() / n;
            assert!((c - 1.0).abs() > band, "σ × {wrong} passes: χ²/n = {c}");
        }
    }

    /// Below [`MIN_CHECKED_AVERAGES`] the error bars are too small, which is why the Bode
    /// plots say so there: at 8 averages χ²/n of the same pulls is far above 1 (6.8 measured),
    /// while at 16 it is 1 (the test above).
    #[test]
    fn with_fewer_averages_than_checked_the_error_bars_are_too_small() {
        assert_eq!(opts().welch_averages, MIN_CHECKED_AVERAGES);
        let z = pulls_at(1.0, MIN_CHECKED_AVERAGES / 2);
        let chi2 = z.iter().map(|v| v * v).sum::<f64>() / z.len() as f64;
        assert!(chi2 > 3.0, "χ²/n = {chi2} at 8 averages");
    }

    /// H, γ² and the error at each line against a direct computation: every segment's naive
    /// DFT at the line's bin, averaged.
    #[test]
    fn the_estimate_equals_a_slow_oracle() {
        let e = experiment(&lines()[..6], 1e-3, 9);
        let got = measured_transfer(&e, &opts(), &ltp_roles()).unwrap();
        let l = N / opts().welch_averages;
        let (step, m) = (l, opts().welch_averages);
        let w = Window::Bh92.values(l);
        let dft = |x: &[f64], k: usize| -> Complex64 {
            let mean = x.iter().sum::<f64>() / l as f64;
            x.iter()
                .enumerate()
                .map(|(n, v)| {
                    (v - mean)
                        * w[n]
                        * Complex64::from_polar(1.0, -2.0 * PI * (k * n) as f64 / l as f64)
                })
                .sum()
        };
        for t in &got {
            let oc = if t.output == "o1" { 0 } else { 1 };
            assert_eq!(t.h.len(), 6, "{} lines found", t.h.len());
            for (q, &f) in t.freqs.iter().enumerate() {
                let k = (f * l as f64 / FS).round() as usize;
                let (mut sii, mut soo, mut sio) = (0.0, 0.0, Complex64::new(0.0, 0.0));
                for s in 0..m {
                    let a = dft(&e.i[0][s * step..s * step + l], k);
                    let b = dft(&e.o[oc][s * step..s * step + l], k);
                    sii += a.norm_sqr();
                    soo += b.norm_sqr();
                    sio += a.conj() * b;
                }
                let h = sio / sii;
                let g2 = sio.norm_sqr() / (sii * soo);
                assert!((t.h[q] - h).norm() < 1e-9 * h.norm(), "{} vs {h}", t.h[q]);
                assert!(
                    (t.coherence[q] - g2).abs() < 1e-9,
                    "{} vs {g2}",
                    t.coherence[q]
                );
                let want = ((1.0 - g2) / (2.0 * m as f64 * g2)).sqrt();
                assert!((t.rel_err[q] - want).abs() < 1e-6 * want);
            }
        }
    }

    #[test]
    fn nothing_injected_gives_nothing_and_a_model_without_readouts_gives_no_curve() {
        let mut e = experiment(&[], 1e-3, 1);
        e.i[0].fill(0.0);
        assert!(
            measured_transfer(&e, &opts(), &ltp_roles())
                .unwrap()
                .is_empty()
        );
        let acc = crate::model::AccelModel::new("a", Default::default());
        let th = vec![0.0; acc.param_names().len()];
        assert!(model_transfer(&acc, &th, 1.0, &[0.01], "i1", "o1").is_none());
    }
}
