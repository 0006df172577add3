//! The paper's Fig. 3 on disk: each model's residual ASD at its MAP over the reference noise and
//! the read-outs alone, one plot per experiment (`residual_psd_<experiment>.png/.svg`), and the
//! arrays in `residual_psd.npz`.

use super::error::ReportError;
use super::lines::{LinePlot, line_plot};
use crate::likelihood::residual_psd::ResidualPsd;
use ndarray::Array1;
use ndarray_npy::NpzWriter;
use std::path::Path;

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
    for (k, e) in first.iter().enumerate() {
        let asd = |f: &[f64], s: &[f64]| -> Vec<(f64, f64)> {
            f.iter().zip(s).map(|(&f, &s)| (f, s.sqrt())).collect()
        };
        let mut series = vec![(
            "reference noise (noise-only stretch)".to_string(),
            asd(&e.reference_freqs, &e.reference),
        )];
        if let Some(r) = &e.readout {
            series.push(("read-outs only".to_string(), asd(&e.freqs, r)));
        }
        for (m, c) in curves {
            series.push((
                format!("residual of `{m}` at its MAP"),
                asd(&c[k].freqs, &c[k].residual),
            ));
        }
        let unit = match e.channel.as_str() {
            "a12" => "m s⁻²/√Hz",
            "o1" | "o12" => "m/√Hz",
            _ => "units/√Hz",
        };
        let title = format!(
            "residual {} of experiment `{}` (Fig. 3)",
            e.channel, e.experiment
        );
        line_plot(
            dir,
            &format!("residual_psd_{}", e.experiment),
            &LinePlot {
                title: &title,
                x_label: "frequency (Hz)",
                y_label: &format!("ASD of {} ({unit})", e.channel),
                series: &series,
                log_x: true,
                log_y: true,
                ..Default::default()
            },
        )?;
    }
    Ok(())
}
