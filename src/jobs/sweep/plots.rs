//! The sweep's figures: ln B against a 1-D axis with every estimator's median and 16–84 %
//! band over the Kass–Raftery zones (the paper's Fig. 5 and 6), and a map of the reference's
//! median ln B over a 2-D grid.

use super::study::{Sweep, SweepResult};
use crate::jobs::select::EstimateKind;
use crate::report::{BandPlot, BandSeries, HeatMap, band_plot, heat_map};
use std::path::{Path, PathBuf};

/// A log axis when every value is positive and they span more than a decade.
fn log_axis(v: &[f64]) -> bool {
    let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    lo > 0.0 && hi / lo > 10.0
}

/// The file stem of a key's plot: its last segment (`target_snr` → `snr`, the name the
/// single-axis sweep always used).
fn stem_of(key: &str) -> String {
    let leaf = key.rsplit('.').next().unwrap_or(key);
    let leaf = if leaf == "target_snr" { "snr" } else { leaf };
    leaf.chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect()
}

/// Keeps the scale of the statistical rows: a systematic row's point (a Laplace expansion
/// where its assumption fails can be off by thousands of nats) more than max(5, ¼ of the
/// statistical span) outside their bands is left out, and its legend entry says how many were.
fn clip_systematic(series: &mut [BandSeries], statistical: impl Fn(&str) -> bool) {
    let finite = |v: &[f64]| {
        v.iter()
            .copied()
            .filter(|x| x.is_finite())
            .collect::<Vec<_>>()
    };
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for s in series.iter().filter(|s| statistical(&s.name)) {
        for v in finite(&s.lo).into_iter().chain(finite(&s.median)) {
            lo = lo.min(v);
        }
        for v in finite(&s.hi).into_iter().chain(finite(&s.median)) {
            hi = hi.max(v);
        }
    }
    if !(lo.is_finite() && hi.is_finite()) {
        return;
    }
    let pad = (0.25 * (hi - lo)).max(5.0);
    let (lo, hi) = (lo - pad, hi + pad);
    for s in series.iter_mut().filter(|s| !statistical(&s.name)) {
        let mut off = 0;
        for k in 0..s.median.len() {
            let out = |v: f64| v.is_finite() && !(lo..=hi).contains(&v);
            if out(s.median[k]) || out(s.lo[k]) || out(s.hi[k]) {
                if s.median[k].is_finite() {
                    off += 1;
                }
                s.median[k] = f64::NAN;
                s.lo[k] = f64::NAN;
                s.hi[k] = f64::NAN;
            }
        }
        if off > 0 {
            s.name = format!("{} ({off} off scale)", s.name);
        }
    }
}

/// Draws the sweep's plots; returns the files written.
pub fn write_plots(sweep: &Sweep, res: &SweepResult, dir: &Path) -> anyhow::Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    let axes = &sweep.grid.axes;
    let n_pairs = res.methods.len();
    for (j, names) in res.methods.iter().enumerate() {
        let Some(first) = res.points.iter().find_map(|p| p.pairs.get(j)) else {
            continue;
        };
        let suffix = if n_pairs > 1 {
            format!("_{}_{}", first.x, first.y)
        } else {
            String::new()
        };
        let y_label = format!("ln B({}/{})", first.x, first.y);
        if axes.len() == 1 {
            // the estimators with a number somewhere; Schwarz (never judged) left out
            let kinds = res
                .records
                .iter()
                .find_map(|r| r.outcome.as_ref())
                .and_then(|o| o.pairs.get(j))
                .map(|p| p.estimates.clone())
                .unwrap_or_default();
            let kind_of = |name: &str| {
                kinds
                    .iter()
                    .find(|e| e.method == name)
                    .map(|e| e.kind)
                    .unwrap_or(EstimateKind::Systematic)
            };
            let mut series = Vec::new();
            for (m, name) in names.iter().enumerate() {
                if kind_of(name) == EstimateKind::Criterion {
                    continue;
                }
                let col = |f: fn(&super::stats::EstimatorStats) -> Option<f64>| -> Vec<f64> {
                    res.points
                        .iter()
                        .map(|p| {
                            p.pairs
                                .get(j)
                                .and_then(|q| q.estimators.get(m + 1))
                                .and_then(f)
                                .unwrap_or(f64::NAN)
                        })
                        .collect()
                };
                let median = col(|e| e.median);
                if median.iter().all(|v| !v.is_finite()) {
                    continue;
                }
                series.push(BandSeries {
                    name: name.clone(),
                    x: res.points.iter().map(|p| p.values[0]).collect(),
                    median,
                    lo: col(|e| e.q16),
                    hi: col(|e| e.q84),
                });
            }
            if series.is_empty() {
                continue;
            }
            clip_systematic(&mut series, |n| kind_of(n) == EstimateKind::Statistical);
            let stem = format!("ln_b_vs_{}{suffix}", stem_of(&axes[0].key));
            let n = sweep.realisations;
            let title = format!(
                "median and 16–84 % of {n} realisation{}",
                if n == 1 { "" } else { "s" }
            );
            band_plot(
                dir,
                &stem,
                &BandPlot {
                    title: &title,
                    x_label: &axes[0].key,
                    y_label: &y_label,
                    series: &series,
                    log_x: log_axis(&axes[0].values),
                    zones: true,
                    sign: Some((&first.x, &first.y)),
                },
            )?;
            files.push(dir.join(format!("{stem}.png")));
            files.push(dir.join(format!("{stem}.svg")));
        } else {
            let (xs, ys) = (&axes[0].values, &axes[1].values);
            let z: Vec<Vec<f64>> = (0..ys.len())
                .map(|iy| {
                    (0..xs.len())
                        .map(|ix| {
                            res.points[ix * ys.len() + iy]
                                .pairs
                                .get(j)
                                .and_then(|q| q.estimators[0].median)
                                .unwrap_or(f64::NAN)
                        })
                        .collect()
                })
                .collect();
            let stem = format!("ln_b_map{suffix}");
            let title = format!(
                "median reference {y_label} over {} realisation(s); {}",
                sweep.realisations,
                crate::report::sign_note(&first.x, &first.y)
            );
            heat_map(
                dir,
                &stem,
                &HeatMap {
                    title: &title,
                    x_label: &axes[0].key,
                    y_label: &axes[1].key,
                    x: xs,
                    y: ys,
                    z: &z,
                    z_label: &y_label,
                    log_x: log_axis(xs),
                    log_y: log_axis(ys),
                    diverging: true,
                },
            )?;
            files.push(dir.join(format!("{stem}.png")));
            files.push(dir.join(format!("{stem}.svg")));
        }
    }
    Ok(files)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stems_and_log_axes() {
        assert_eq!(stem_of("simulation.target_snr"), "snr");
        assert_eq!(stem_of("experiment.scan.x1.freq"), "freq");
        assert_eq!(stem_of("a.b-c"), "b_c");
        assert!(log_axis(&[1e-4, 1.0]));
        assert!(!log_axis(&[1.0, 5.0]));
        assert!(!log_axis(&[-1.0, 100.0]));
    }

    #[test]
    fn a_runaway_laplace_row_does_not_set_the_scale() {
        let band = |name: &str, m: [f64; 3]| BandSeries {
            name: name.into(),
            x: vec![5.0, 20.0, 80.0],
            median: m.to_vec(),
            lo: m.iter().map(|v| v - 0.1).collect(),
            hi: m.iter().map(|v| v + 0.1).collect(),
        };
        let mut s = vec![
            band("bridge", [0.0, -0.1, -2.0]),
            band("Laplace box", [22945.0, -0.2, -2.1]),
            band("Laplace raw", [f64::NAN, 3.0, -6.5]),
        ];
        clip_systematic(&mut s, |n| n == "bridge");
        assert_eq!(s[0].name, "bridge");
        assert_eq!(s[1].name, "Laplace box (1 off scale)");
        assert!(s[1].median[0].is_nan() && s[1].median[1] == -0.2);
        assert_eq!(s[2].name, "Laplace raw", "within 5 nats of the bands stays");
    }
}
