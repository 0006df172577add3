//! Bode plots: the measured transfer function from each injection to each read-out (points
//! with ±1σ error bars) against each fitted model's at its MAP (lines), gain (log–log) above
//! phase, one figure per experiment (`bode_<experiment>.png/.svg`), and the numbers in
//! `bode.npz`.

use super::error::ReportError;
use super::lines::{LineFigure, LinePlot, Stack};
use super::plots::render;
use crate::likelihood::transfer::MeasuredTransfer;
use ndarray::Array1;
use ndarray_npy::NpzWriter;
use num_complex::Complex64;
use std::path::Path;

/// A fitted model's transfer function for one pair: at the measured lines and on a grid.
#[derive(Debug, Clone, PartialEq)]
pub struct BodeModel {
    /// The model's name.
    pub name: String,
    /// At [`MeasuredTransfer::freqs`].
    pub at_lines: Vec<Complex64>,
    /// At [`BodeExperiment::grid`].
    pub on_grid: Vec<Complex64>,
}

/// One injection → read-out pair: what was measured and what each model says.
#[derive(Debug, Clone, PartialEq)]
pub struct BodePair {
    /// The measured transfer function (lines, values, coherence, errors).
    pub measured: MeasuredTransfer,
    /// Models that predict this pair (a model without the read-outs has none).
    pub models: Vec<BodeModel>,
}

/// One experiment's Bode plot.
#[derive(Debug, Clone, PartialEq)]
pub struct BodeExperiment {
    /// The experiment's name (the figure is `bode_<experiment>`).
    pub experiment: String,
    /// Frequencies (Hz) of the models' curves.
    pub grid: Vec<f64>,
    /// Every injection → read-out pair measured.
    pub pairs: Vec<BodePair>,
    /// The gain's unit when the read-outs share one and the injections another
    /// (`m per m s⁻²`); `None` for a gain of read-out per unit injected.
    pub gain_unit: Option<String>,
}

/// Phase in degrees.
fn degrees(h: Complex64) -> f64 {
    h.arg().to_degrees()
}

/// Writes `bode.npz` and `bode_<experiment>.png/.svg` for every experiment with a measured
/// line or a model's curve; nothing when there is none. The npz keys, with `<p>` = `<experiment>__<input>_to_<output>`:
/// `<experiment>__grid`; `<p>__freq`, `<p>__h_re`, `<p>__h_im`, `<p>__coherence`, `<p>__rel_err`
/// (relative error of |H|, also the phase error in radians); per model `<p>__<model>__re`,
/// `__im` (at the lines) and `__grid_re`, `__grid_im`.
pub fn write(dir: &Path, exps: &[BodeExperiment]) -> Result<(), ReportError> {
    let drawn: Vec<&BodeExperiment> = exps
        .iter()
        .filter(|e| {
            e.pairs
                .iter()
                .any(|p| !p.measured.h.is_empty() || !p.models.is_empty())
        })
        .collect();
    if drawn.is_empty() {
        return Ok(());
    }
    let path = dir.join("bode.npz");
    let io = |e: std::io::Error| ReportError::Io {
        file: path.clone(),
        source: e,
    };
    crate::atomic::write_with(&path, |w| {
        let to_io = |e: ndarray_npy::WriteNpzError| std::io::Error::other(e.to_string());
        let mut z = NpzWriter::new(w);
        let mut put = |key: String, v: Vec<f64>| z.add_array(key, &Array1::from(v)).map_err(to_io);
        for e in &drawn {
            put(format!("{}__grid", e.experiment), e.grid.clone())?;
            for p in &e.pairs {
                let m = &p.measured;
                let k = format!("{}__{}_to_{}", e.experiment, m.input, m.output);
                put(format!("{k}__freq"), m.freqs.clone())?;
                put(format!("{k}__h_re"), m.h.iter().map(|h| h.re).collect())?;
                put(format!("{k}__h_im"), m.h.iter().map(|h| h.im).collect())?;
                put(format!("{k}__coherence"), m.coherence.clone())?;
                put(format!("{k}__rel_err"), m.rel_err.clone())?;
                for b in &p.models {
                    let n = &b.name;
                    put(
                        format!("{k}__{n}__re"),
                        b.at_lines.iter().map(|h| h.re).collect(),
                    )?;
                    put(
                        format!("{k}__{n}__im"),
                        b.at_lines.iter().map(|h| h.im).collect(),
                    )?;
                    put(
                        format!("{k}__{n}__grid_re"),
                        b.on_grid.iter().map(|h| h.re).collect(),
                    )?;
                    put(
                        format!("{k}__{n}__grid_im"),
                        b.on_grid.iter().map(|h| h.im).collect(),
                    )?;
                }
            }
        }
        z.finish().map_err(to_io)?;
        Ok(())
    })
    .map_err(io)?;
    for e in drawn {
        draw(dir, e)?;
    }
    Ok(())
}

/// `(name, points)` and error bars of the gain and phase panels: measured lines as isolated
/// points (a NaN between two breaks the line) with ±1σ bars, models as lines, the phase of a
/// model broken where it wraps through ±180°.
type Panel = (Vec<(String, Vec<(f64, f64)>)>, Vec<Vec<f64>>);

fn panels(e: &BodeExperiment) -> (Panel, Panel) {
    let gap = (f64::NAN, f64::NAN);
    let (mut gain, mut phase): (Panel, Panel) = Default::default();
    for p in &e.pairs {
        let m = &p.measured;
        let pair = format!("{} → {}", m.input, m.output);
        let mut g = Vec::new();
        let mut ph = Vec::new();
        let mut ge = Vec::new();
        let mut pe = Vec::new();
        for (k, (&f, &h)) in m.freqs.iter().zip(&m.h).enumerate() {
            if k > 0 {
                g.push(gap);
                ph.push(gap);
                ge.push(f64::NAN);
                pe.push(f64::NAN);
            }
            g.push((f, h.norm()));
            ph.push((f, degrees(h)));
            let s = m.rel_err[k];
            ge.push(if s.is_finite() {
                s * h.norm()
            } else {
                f64::NAN
            });
            pe.push(if s.is_finite() {
                s.to_degrees().min(180.0)
            } else {
                f64::NAN
            });
        }
        // injections too slow to measure: the models' curves alone
        if !g.is_empty() {
            let name = format!("measured {pair} (±1σ)");
            gain.0.push((name.clone(), g));
            gain.1.push(ge);
            phase.0.push((name, ph));
            phase.1.push(pe);
        }
        for b in &p.models {
            let name = format!("{} at its MAP, {pair}", b.name);
            let g: Vec<(f64, f64)> = e
                .grid
                .iter()
                .zip(&b.on_grid)
                .map(|(&f, h)| (f, h.norm()))
                .collect();
            let mut ph: Vec<(f64, f64)> = Vec::new();
            for (&f, &h) in e.grid.iter().zip(&b.on_grid) {
                let d = degrees(h);
                if ph
                    .last()
                    .is_some_and(|&(_, last): &(f64, f64)| (d - last).abs() > 180.0)
                {
                    ph.push(gap);
                }
                ph.push((f, d));
            }
            gain.1.push(vec![f64::NAN; g.len()]);
            phase.1.push(vec![f64::NAN; ph.len()]);
            gain.0.push((name.clone(), g));
            phase.0.push((name, ph));
        }
    }
    (gain, phase)
}

fn draw(dir: &Path, e: &BodeExperiment) -> Result<(), ReportError> {
    let stem = format!("bode_{}", e.experiment);
    let ((gs, ge), (ps, pe)) = panels(e);
    let measured = e.pairs.iter().any(|p| !p.measured.h.is_empty());
    let title = if measured {
        format!(
            "transfer functions of experiment {}: measured and fitted",
            e.experiment
        )
    } else {
        format!(
            "transfer functions of experiment {}: fitted (no line measured)",
            e.experiment
        )
    };
    let y_label = match &e.gain_unit {
        Some(u) => format!("gain |H| ({u})"),
        None => "gain |H| (read-out per unit injected)".into(),
    };
    let gain = LineFigure::new(
        dir,
        &stem,
        &LinePlot {
            title: &title,
            x_label: "frequency (Hz)",
            y_label: &y_label,
            series: &gs,
            y_err: Some(&ge),
            log_x: true,
            log_y: true,
        },
        None,
    )?
    .without_legend();
    let phase = LineFigure::new(
        dir,
        &stem,
        &LinePlot {
            title: "",
            x_label: "frequency (Hz)",
            y_label: "phase of H (°)",
            series: &ps,
            y_err: Some(&pe),
            log_x: true,
            log_y: false,
        },
        None,
    )?;
    render(dir, &stem, &Stack(vec![gain, phase]))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn experiment() -> BodeExperiment {
        let freqs = vec![1e-3, 3e-3, 1e-2, 3e-2];
        let h: Vec<Complex64> = freqs
            .iter()
            .map(|&f: &f64| Complex64::from_polar(1.0 / (1.0 + f * 30.0), -f * 200.0))
            .collect();
        let grid: Vec<f64> = (0..200).map(|k| 5e-4 * 1.02f64.powi(k)).collect();
        let on_grid = grid
            .iter()
            .map(|&f: &f64| Complex64::from_polar(1.0 / (1.0 + f * 30.0), -f * 200.0))
            .collect();
        BodeExperiment {
            experiment: "inv1".into(),
            gain_unit: None,
            grid,
            pairs: vec![BodePair {
                measured: MeasuredTransfer {
                    experiment: "inv1".into(),
                    input: "i1".into(),
                    output: "o1".into(),
                    freqs,
                    h: h.clone(),
                    coherence: vec![0.99; 4],
                    rel_err: vec![0.02, 0.05, f64::INFINITY, 0.01],
                    n_avg: 16,
                },
                models: vec![BodeModel {
                    name: "ltp".into(),
                    at_lines: h,
                    on_grid,
                }],
            }],
        }
    }

    #[test]
    fn writes_the_figure_and_the_numbers() {
        let dir = tempfile::tempdir().unwrap();
        write(dir.path(), &[experiment()]).unwrap();
        for f in ["bode.npz", "bode_inv1.png", "bode_inv1.svg"] {
            assert!(dir.path().join(f).exists(), "{f}");
        }
        let svg = std::fs::read_to_string(dir.path().join("bode_inv1.svg")).unwrap();
        assert!(svg.contains("measured i1 → o1") && svg.contains("ltp at its MAP"));
        let mut npz =
            ndarray_npy::NpzReader::new(std::fs::File::open(dir.path().join("bode.npz")).unwrap())
                .unwrap();
        let names = npz.names().unwrap();
        for k in [
            "inv1__grid",
            "inv1__i1_to_o1__h_re",
            "inv1__i1_to_o1__ltp__grid_im",
        ] {
            assert!(
                names.iter().any(|n| n.trim_end_matches(".npy") == k),
                "{k}: {names:?}"
            );
        }
    }

    #[test]
    fn the_model_phase_breaks_where_it_wraps() {
        let (_, (ps, pe)) = panels(&experiment());
        let model = &ps[1].1;
        assert!(
            model.iter().any(|p| p.0.is_nan()),
            "no break in a phase that wraps"
        );
        assert_eq!(pe[1].len(), model.len());
        for w in model.windows(2) {
            if w[0].1.is_finite() && w[1].1.is_finite() {
                assert!((w[0].1 - w[1].1).abs() <= 180.0);
            }
        }
    }

    #[test]
    fn nothing_measured_and_no_model_writes_nothing() {
        let mut e = experiment();
        e.pairs[0].measured.h.clear();
        e.pairs[0].models.clear();
        let dir = tempfile::tempdir().unwrap();
        write(dir.path(), &[e]).unwrap();
        assert!(std::fs::read_dir(dir.path()).unwrap().next().is_none());
    }

    /// Injections too slow to measure: the models' curves alone, with no empty "measured"
    /// series in the legend and a title that says so.
    #[test]
    fn nothing_measured_draws_the_models_alone() {
        let mut e = experiment();
        let m = &mut e.pairs[0].measured;
        for v in [&mut m.freqs, &mut m.coherence, &mut m.rel_err] {
            v.clear();
        }
        m.h.clear();
        e.pairs[0].models[0].at_lines.clear();
        e.gain_unit = Some("m per m s⁻²".into());
        let ((gs, _), _) = panels(&e);
        assert!(gs.iter().all(|(n, _)| !n.starts_with("measured")), "{gs:?}");
        assert_eq!(gs.len(), e.pairs[0].models.len());
        let dir = tempfile::tempdir().unwrap();
        write(dir.path(), &[e]).unwrap();
        let svg = std::fs::read_to_string(dir.path().join("bode_inv1.svg")).unwrap();
        assert!(svg.contains("fitted (no line measured)"));
        assert!(svg.contains("gain |H| (m per m s⁻²)"));
    }
}
