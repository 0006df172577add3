//! The paper's Fig. 3 on disk: each model's residual ASD at its MAP over the reference noise and
//! the read-outs alone, one plot per experiment (`residual_psd_<experiment>.png/.svg`), and the
//! arrays in `residual_psd.npz`.

use super::error::ReportError;
#[cfg(test)]
use super::lines::LineFigure;
use super::lines::{LinePlot, line_plot};
use crate::likelihood::residual_psd::ResidualPsd;
use ndarray::Array1;
use ndarray_npy::NpzWriter;
use std::path::Path;

/// The legend name of the read-outs curve: the residual with no model subtracted, i.e. the
/// read-out channels alone with the injections' response in them (see
/// [`crate::likelihood::residual_psd`]).
pub const READOUT_LABEL: &str = "read-outs, no model subtracted (injection response + noise)";

/// `(legend name, points)` of a line plot.
type Series = Vec<(String, Vec<(f64, f64)>)>;

/// Title, vertical-axis title and `(legend name, ASD points)` of experiment `k`'s figure.
pub(crate) fn figure(curves: &[(String, Vec<ResidualPsd>)], k: usize) -> (String, String, Series) {
    let e = &curves[0].1[k];
    let asd = |f: &[f64], s: &[f64]| -> Vec<(f64, f64)> {
        f.iter().zip(s).map(|(&f, &s)| (f, s.sqrt())).collect()
    };
    let source = if e.reference_is_welch {
        "noise-only stretch"
    } else {
        "noise model"
    };
    let mut series = vec![(
        format!("reference noise ({source})"),
        asd(&e.reference_freqs, &e.reference),
    )];
    if let Some(r) = &e.readout {
        series.push((READOUT_LABEL.to_string(), asd(&e.freqs, r)));
    }
    for (m, c) in curves {
        series.push((
            format!("residual of {m} at its MAP"),
            asd(&c[k].freqs, &c[k].residual),
        ));
    }
    let unit = if e.unit.is_empty() {
        "its unit/√Hz".to_string()
    } else {
        format!("{}/√Hz", e.unit)
    };
    let title = format!(
        "residual {} of experiment {} (Fig. 3)",
        e.channel, e.experiment
    );
    (title, format!("ASD of {} ({unit})", e.channel), series)
}

/// Writes `residual_psd.npz` and one plot per experiment for `curves` (`(model, per-experiment
/// curves)`); nothing when `curves` is empty. The npz keys are `<experiment>__freq`,
/// `<experiment>__reference_freq`, `<experiment>__reference`, `<experiment>__readout` and
/// `<experiment>__<model>` (one-sided PSDs).
pub fn write(dir: &Path, curves: &[(String, Vec<ResidualPsd>)]) -> Result<(), ReportError> {
    let Some((_, first)) = curves.first() else {
        return Ok(());
    };
    let path = dir.join("residual_psd.npz");
    let io = |e: std::io::Error| ReportError::Io {
        file: path.clone(),
        source: e,
    };
    crate::atomic::write_with(&path, |w| {
        let to_io = |e: ndarray_npy::WriteNpzError| std::io::Error::other(e.to_string());
        let mut z = NpzWriter::new(w);
        for (k, e) in first.iter().enumerate() {
            let x = &e.experiment;
            let mut put =
                |key: String, v: &[f64]| z.add_array(key, &Array1::from(v.to_vec())).map_err(to_io);
            put(format!("{x}__freq"), &e.freqs)?;
            put(format!("{x}__reference_freq"), &e.reference_freqs)?;
            put(format!("{x}__reference"), &e.reference)?;
            if let Some(r) = &e.readout {
                put(format!("{x}__readout"), r)?;
            }
            for (m, c) in curves {
                put(format!("{x}__{m}"), &c[k].residual)?;
            }
        }
        z.finish().map_err(to_io)?;
        Ok(())
    })
    .map_err(io)?;
    for k in 0..first.len() {
        let (title, y_label, series) = figure(curves, k);
        line_plot(
            dir,
            &format!("residual_psd_{}", first[k].experiment),
            &LinePlot {
                title: &title,
                x_label: "frequency (Hz)",
                y_label: &y_label,
                series: &series,
                log_x: true,
                log_y: true,
                ..Default::default()
            },
        )?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Fig. 3 as a run draws it: noise, read-outs with tall lines, two residuals, spanning the
    /// plot from corner to corner.
    fn curves() -> Vec<(String, Vec<ResidualPsd>)> {
        let freqs: Vec<f64> = (1..=400).map(|k| 1e-3 * 1.02f64.powi(k)).collect();
        let noise = |f: f64| 1e-28 * (1.0 + (1e-2 / f).powi(4));
        let lines = |f: f64| {
            noise(f)
                + [0.005, 0.05, 0.5]
                    .iter()
                    .map(|l: &f64| 1e-18 / (1.0 + ((f - l) / (0.01 * l)).powi(2)))
                    .sum::<f64>()
        };
        let one = |scale: f64| ResidualPsd {
            experiment: "inv1".into(),
            channel: "o1".into(),
            unit: "m".into(),
            freqs: freqs.clone(),
            residual: freqs.iter().map(|&f| scale * noise(f)).collect(),
            readout: Some(freqs.iter().map(|&f| lines(f)).collect()),
            reference_freqs: freqs.clone(),
            reference: freqs.iter().map(|&f| noise(f)).collect(),
            reference_is_welch: true,
        };
        vec![
            ("ltp".into(), vec![one(1.0)]),
            ("ltp_delay".into(), vec![one(3.0)]),
        ]
    }

    #[test]
    fn the_legend_covers_no_curve() {
        let (title, y_label, series) = figure(&curves(), 0);
        let plot = LinePlot {
            title: &title,
            x_label: "frequency (Hz)",
            y_label: &y_label,
            series: &series,
            log_x: true,
            log_y: true,
            ..Default::default()
        };
        let dir = tempfile::tempdir().unwrap();
        let fig = LineFigure::new(dir.path(), "r", &plot, None).unwrap();
        super::super::plots::render(dir.path(), "r", &fig).unwrap();
        let g = fig.geometry.borrow().clone();
        let [(l, t), (r, b)] = g.legend.expect("a legend");
        assert!(!g.curves.is_empty());
        let hidden = g
            .curves
            .iter()
            .filter(|&&(x, y)| (l..=r).contains(&x) && (t..=b).contains(&y))
            .count();
        assert_eq!(
            hidden, 0,
            "{hidden} curve points under the legend {:?}",
            g.legend
        );
    }

    #[test]
    fn titles_and_labels_have_no_markup_and_name_the_readout_curve() {
        let (title, y_label, series) = figure(&curves(), 0);
        for t in std::iter::once(&title)
            .chain([&y_label])
            .chain(series.iter().map(|(n, _)| n))
        {
            assert!(!t.contains('`') && !t.contains("B_"), "{t}");
        }
        assert!(
            series
                .iter()
                .any(|(n, _)| n.contains("no model subtracted")),
            "{series:?}"
        );
    }

    /// The axis names the residual's unit and the legend where the reference noise comes
    /// from: under `noise = "model"` there is no noise-only stretch to name.
    #[test]
    fn the_axis_and_the_reference_say_what_they_are() {
        let mut c = curves();
        let (_, y, series) = figure(&c, 0);
        assert_eq!(y, "ASD of o1 (m/√Hz)");
        assert_eq!(series[0].0, "reference noise (noise-only stretch)");
        for (_, e) in &mut c {
            e[0].channel = "pos_a".into();
            e[0].unit = String::new();
            e[0].reference_is_welch = false;
        }
        let (_, y, series) = figure(&c, 0);
        assert_eq!(y, "ASD of pos_a (its unit/√Hz)");
        assert_eq!(series[0].0, "reference noise (noise model)");
    }
}
