//! End-to-end checks of the plot functions: files written, complete, nothing left behind,
//! and bad input rejected with a typed error before any file is touched.

use super::*;
use std::path::Path;

const PNG_SIGNATURE: [u8; 8] = [137, 80, 78, 71, 13, 10, 26, 10];

/// Asserts that `dir` holds exactly `<stem>.png` and `<stem>.svg` (no temporaries), that the
/// PNG is complete (signature, IHDR first, IEND last, > 1 kB) and that the SVG is a whole
/// document containing every string in `svg_has`. Returns the PNG's (width, height).
pub(super) fn check_outputs(dir: &Path, stem: &str, svg_has: &[&str]) -> (u32, u32) {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names, [format!("{stem}.png"), format!("{stem}.svg")]);

    let png = std::fs::read(dir.join(format!("{stem}.png"))).unwrap();
    assert!(png.len() > 1024, "PNG only {} bytes", png.len());
    assert_eq!(png[..8], PNG_SIGNATURE);
    assert_eq!(&png[12..16], b"IHDR");
    assert_eq!(&png[png.len() - 8..png.len() - 4], b"IEND", "PNG truncated");
    let be = |i: usize| u32::from_be_bytes([png[i], png[i + 1], png[i + 2], png[i + 3]]);
    let size = (be(16), be(20));

    let svg = std::fs::read_to_string(dir.join(format!("{stem}.svg"))).unwrap();
    assert!(svg.contains("<svg"), "no <svg> element");
    assert!(svg.trim_end().ends_with("</svg>"), "SVG truncated");
    assert!(
        svg.contains(&format!("width=\"{}\"", size.0)),
        "SVG and PNG sizes differ"
    );
    for s in svg_has {
        assert!(svg.contains(s), "SVG lacks {s:?}");
    }
    size
}

fn names(n: &[&str]) -> Vec<String> {
    n.iter().map(|s| s.to_string()).collect()
}

pub(super) fn assert_invalid(r: Result<(), ReportError>, field: &str, dir: &Path) {
    match r {
        Err(ReportError::InvalidInput { field: f, .. }) => assert_eq!(f, field),
        other => panic!("expected InvalidInput on {field}, got {other:?}"),
    }
    assert_eq!(
        std::fs::read_dir(dir).unwrap().count(),
        0,
        "files written on bad input"
    );
}

#[test]
fn trace_plot_writes_both_formats_with_scaled_labels() {
    let dir = tempfile::tempdir().unwrap();
    // Parameter 0 at -1.3e-6 with a 1e-10 spread, parameter 1 constant, one NaN.
    let chains: Vec<Vec<Vec<f64>>> = (0..3)
        .map(|c| {
            (0..100)
                .map(|i| {
                    let w = -1.29998e-6 + 1e-10 * ((i + 10 * c) as f64 * 0.3).sin();
                    let a = if i == 50 { f64::NAN } else { 0.8 };
                    vec![w, a]
                })
                .collect()
        })
        .collect();
    let n = names(&["w", "A"]);
    trace_plot(dir.path(), "trace", &n, &chains, Some(&[-1.3e-6, 0.8])).unwrap();
    let (w, h) = check_outputs(
        dir.path(),
        "trace",
        &[
            "3 chains, 100 draws each",
            "w + 1.300×10⁻⁶ [10⁻¹⁰]",
            "sample index",
            "truth",
        ],
    );
    assert_eq!(w, 1400);
    assert!(h > 2 * 150, "{h}");
    // Rendering again replaces the files and still leaves no temporaries.
    trace_plot(dir.path(), "trace", &n, &chains, None).unwrap();
    check_outputs(dir.path(), "trace", &[]);
}

#[test]
fn trace_plot_marks_a_parameter_without_finite_values() {
    let dir = tempfile::tempdir().unwrap();
    let chain: Vec<Vec<f64>> = (0..20).map(|i| vec![i as f64, f64::NAN]).collect();
    trace_plot(dir.path(), "t", &names(&["x", "y"]), &[chain], None).unwrap();
    check_outputs(dir.path(), "t", &["no finite values"]);
}

#[test]
fn trace_plot_rejects_bad_shapes() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let ok = vec![vec![vec![1.0, 2.0]; 5]];
    assert_invalid(trace_plot(d, "t", &[], &ok, None), "names", d);
    assert_invalid(
        trace_plot(d, "t", &names(&["a", "b"]), &[], None),
        "chains",
        d,
    );
    assert_invalid(
        trace_plot(d, "t", &names(&["a", "b"]), &[vec![]], None),
        "chains",
        d,
    );
    let mut ragged = ok.clone();
    ragged[0][3].pop();
    assert_invalid(
        trace_plot(d, "t", &names(&["a", "b"]), &ragged, None),
        "chains[0][3]",
        d,
    );
    let n = names(&["a", "b"]);
    assert_invalid(trace_plot(d, "t", &n, &ok, Some(&[1.0])), "truth", d);
    assert_invalid(trace_plot(d, "a/b", &n, &ok, None), "stem", d);
    assert_invalid(trace_plot(d, "", &n, &ok, None), "stem", d);
}

#[test]
fn corner_plot_handles_constant_and_nan_columns() {
    let dir = tempfile::tempdir().unwrap();
    let samples: Vec<Vec<f64>> = (0..300)
        .map(|i| {
            let u = (i as f64 * 0.61).sin();
            let bad = if i % 7 == 0 { f64::NAN } else { 2e-6 * u };
            vec![u, 0.5, bad]
        })
        .collect();
    let n = names(&["a", "b", "c"]);
    corner_plot(dir.path(), "corner", &n, &samples, Some(&[0.0, 0.5, 0.0])).unwrap();
    let (w, h) = check_outputs(
        dir.path(),
        "corner",
        &[
            "300 samples (43 with non-finite values left out)",
            "c [10⁻⁶]",
        ],
    );
    assert!(w > 3 * 130 && h > 3 * 130, "{w}×{h}");
}

#[test]
fn corner_plot_rejects_bad_shapes() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let n = names(&["a", "b"]);
    assert_invalid(corner_plot(d, "c", &n, &[], None), "samples", d);
    assert_invalid(corner_plot(d, "c", &[], &[vec![]], None), "names", d);
    let s = vec![vec![1.0, 2.0], vec![1.0]];
    assert_invalid(corner_plot(d, "c", &n, &s, None), "samples[1]", d);
    assert_invalid(
        corner_plot(d, "c", &n, &s[..1], Some(&[0.0; 3])),
        "truth",
        d,
    );
}

#[test]
fn bayes_factor_evolution_linear_and_log() {
    let dir = tempfile::tempdir().unwrap();
    let run = |b0: f64| -> Vec<(f64, f64)> {
        (1..=40)
            .map(|i| (250.0 * i as f64, b0 / (1.0 + i as f64 / 8.0)))
            .collect()
    };
    let series = vec![
        ("SNR 5".to_string(), run(0.9)),
        ("SNR 60".to_string(), run(1e-3)),
    ];
    bayes_factor_evolution(dir.path(), "b", &series, true, "B_XY").unwrap();
    check_outputs(
        dir.path(),
        "b",
        &["SNR 5", "SNR 60", "B = 1", "iteration", "10⁻³"],
    );

    let dir = tempfile::tempdir().unwrap();
    // ln B with a NaN gap and a zero (drawable on a linear axis).
    let mut lnb = run(3.0);
    lnb[5].1 = f64::NAN;
    lnb[6].1 = 0.0;
    bayes_factor_evolution(dir.path(), "lnb", &[("run".into(), lnb)], false, "ln B_XY").unwrap();
    check_outputs(dir.path(), "lnb", &["ln B_XY"]);
}

#[test]
fn bayes_factor_evolution_rejects_nothing_drawable() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    assert_invalid(bayes_factor_evolution(d, "b", &[], true, "B"), "series", d);
    // All B ≤ 0: nothing can go on a log axis.
    let s = vec![(
        "r".to_string(),
        vec![(1.0, 0.0), (2.0, -1.0), (3.0, f64::NAN)],
    )];
    assert_invalid(bayes_factor_evolution(d, "b", &s, true, "B"), "series", d);
}

#[test]
fn model_histogram_short_and_long_labels() {
    let dir = tempfile::tempdir().unwrap();
    let labels = names(&["3-D", "4-D", "5-D", "6-D"]);
    model_histogram(dir.path(), "m", &labels, &[10.0, 90.0, 740.0, 0.0]).unwrap();
    check_outputs(dir.path(), "m", &["5-D", "0.88", "840 in total"]);

    let dir = tempfile::tempdir().unwrap();
    let labels: Vec<String> = (0..6)
        .map(|k| format!("ω₁, ω₂, A_df, δ₂₁, Δt{k}"))
        .collect();
    model_histogram(dir.path(), "long", &labels, &[0.1, 0.2, 0.3, 0.2, 0.1, 0.1]).unwrap();
    let (_, h) = check_outputs(dir.path(), "long", &["δ₂₁, Δt5"]);
    assert!(h > 520, "vertical labels need a taller canvas, got {h}");
}

#[test]
fn model_histogram_rejects_bad_counts() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let l = names(&["a", "b"]);
    assert_invalid(model_histogram(d, "m", &[], &[]), "counts", d);
    assert_invalid(model_histogram(d, "m", &l, &[1.0]), "labels", d);
    assert_invalid(model_histogram(d, "m", &l, &[0.0, 0.0]), "counts", d);
    assert_invalid(model_histogram(d, "m", &l, &[1.0, -1.0]), "counts[1]", d);
    assert_invalid(
        model_histogram(d, "m", &l, &[f64::NAN, 1.0]),
        "counts[0]",
        d,
    );
}

#[test]
fn line_plot_log_log_with_error_bars_and_gaps() {
    let dir = tempfile::tempdir().unwrap();
    let psd: Vec<(f64, f64)> = (0..400)
        .map(|k| {
            let f = k as f64 * 1e-3; // f = 0 cannot go on a log axis and is skipped
            (f, 1e-28 * (1.0 + (1e-2 / f).powi(2)))
        })
        .collect();
    let snr = vec![(5.0, 2.0), (10.0, -1.0), (20.0, 30.0)]; // -1 skipped on the log axis
    let series = vec![("PSD".to_string(), psd), ("ln B".to_string(), snr)];
    let err = vec![vec![f64::NAN; 400], vec![0.5, 0.5, 40.0]]; // 30 − 40 < 0: bar clipped
    let plot = LinePlot {
        title: "log-log",
        x_label: "frequency [Hz]",
        y_label: "PSD",
        series: &series,
        y_err: Some(&err),
        log_x: true,
        log_y: true,
    };
    line_plot(dir.path(), "ll", &plot).unwrap();
    let (w, h) = check_outputs(dir.path(), "ll", &["log-log", "frequency [Hz]", "10⁻²⁵"]);
    // the legend rows lie below the plot, on a canvas that grows for them
    assert_eq!(w, 680);
    assert!(h > 500, "{h}");
}

#[test]
fn line_plot_constant_series_and_single_point() {
    let dir = tempfile::tempdir().unwrap();
    let series = vec![(String::new(), vec![(1.0, 0.8), (2.0, 0.8), (3.0, 0.8)])];
    line_plot(
        dir.path(),
        "flat",
        &LinePlot {
            series: &series,
            ..Default::default()
        },
    )
    .unwrap();
    check_outputs(dir.path(), "flat", &["0.80"]);

    let dir = tempfile::tempdir().unwrap();
    let series = vec![("one".to_string(), vec![(2.0, 3.0)])];
    line_plot(
        dir.path(),
        "one",
        &LinePlot {
            series: &series,
            ..Default::default()
        },
    )
    .unwrap();
    check_outputs(dir.path(), "one", &["one", "<polygon"]);
}

#[test]
fn line_plot_rejects_mismatched_error_bars() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let series = vec![("a".to_string(), vec![(1.0, 1.0), (2.0, 2.0)])];
    let cases = [
        (vec![], "y_err"),
        (vec![vec![1.0]], "y_err[0]"),
        (vec![vec![1.0, -0.1]], "y_err[0][1]"),
    ];
    for (err, field) in &cases {
        let p = LinePlot {
            series: &series,
            y_err: Some(err),
            ..Default::default()
        };
        assert_invalid(line_plot(d, "l", &p), field, d);
    }
    let empty = LinePlot::default();
    assert_invalid(line_plot(d, "l", &empty), "series", d);
}

#[test]
fn errors_name_the_figure() {
    let dir = tempfile::tempdir().unwrap();
    let e = model_histogram(dir.path(), "models", &[], &[]).unwrap_err();
    let msg = e.to_string();
    assert!(
        msg.contains("models.{png,svg}") && msg.contains("`counts`"),
        "{msg}"
    );
}

/// The fit's trace: ln posterior panel, burn-in shaded, iterations on the axis, units; one
/// chain, a NaN draw and a parameter that never moves.
#[test]
fn draw_trace_with_ln_posterior_and_burn_in() {
    let dir = tempfile::tempdir().unwrap();
    let chain: Vec<Vec<f64>> = (0..400)
        .map(|i| {
            let w = if i == 17 {
                f64::NAN
            } else {
                -1.3e-6 + 2e-8 * (i as f64 * 0.2).sin()
            };
            vec![w, 0.2]
        })
        .collect();
    let lp = vec![
        chain
            .iter()
            .map(|s| -1e15 * (s[0] + 1.3e-6).powi(2))
            .collect::<Vec<_>>(),
    ];
    let (n, u) = (names(&["w1sq", "dt1"]), names(&["s⁻²", "s"]));
    let chains = vec![chain];
    draw_trace(
        dir.path(),
        "trace",
        &TracePlot {
            names: &n,
            units: &u,
            chains: &chains,
            ln_posterior: &lp,
            truth: Some(&[-1.3e-6, f64::NAN]),
            iterations: Some((2000, 5)),
        },
    )
    .unwrap();
    check_outputs(
        dir.path(),
        "trace",
        &[
            "1 chain, 400 draws each; burn-in 2000 (shaded, not stored), thin 5",
            "ln posterior",
            "w1sq [10⁻⁶ s⁻²]",
            "dt1 [s]",
            "iteration",
            "burn-in",
        ],
    );
    // the refusals write into a fresh directory, which must stay empty
    let d2 = tempfile::tempdir().unwrap();
    let d = d2.path();
    let bad = |lp: &[Vec<f64>], it: Option<(usize, usize)>, units: &[String]| {
        draw_trace(
            d,
            "t",
            &TracePlot {
                names: &n,
                units,
                chains: &chains,
                ln_posterior: lp,
                iterations: it,
                ..Default::default()
            },
        )
    };
    let none: &[String] = &[];
    assert_invalid(bad(&[vec![], vec![]], None, none), "ln_posterior", d);
    assert_invalid(bad(&[vec![0.0; 3]], None, none), "ln_posterior[0]", d);
    assert_invalid(bad(&[], Some((10, 0)), none), "iterations", d);
    assert_invalid(bad(&[], None, &names(&["s"])), "units", d);
}

/// The fit's corner: contours, quantile titles, truth and MAP, units; a parameter that never
/// moves and a NaN column do not stop it.
#[test]
fn draw_corner_with_map_units_and_edge_cases() {
    let dir = tempfile::tempdir().unwrap();
    let samples: Vec<Vec<f64>> = (0..2000)
        .map(|i| {
            let (u, v) = ((i as f64 * 0.61).sin(), (i as f64 * 1.37).cos());
            let bad = if i % 50 == 0 { f64::NAN } else { 1e-3 * v };
            vec![-1.3e-6 + 1e-8 * u, 0.5, 0.2 + 0.01 * (u + v), bad]
        })
        .collect();
    let n = names(&["w1sq", "a_df", "dt1", "d21"]);
    let u = names(&["s⁻²", "", "s", ""]);
    let plot = CornerPlot {
        names: &n,
        units: &u,
        samples: &samples,
        truth: Some(&[-1.3e-6, 0.5, 0.2, f64::NAN]),
        map: Some(&[-1.3e-6, 0.5, 0.21, 0.0]),
    };
    draw_corner(dir.path(), "corner", &plot).unwrap();
    let (w, _) = check_outputs(
        dir.path(),
        "corner",
        &[
            "2000 samples (40 with non-finite values left out)",
            "1σ (39 %)",
            "2σ (86 %)",
            "truth",
            "MAP",
            "a_df = 0.5000",
            "+0 −0",
            "dt1 [s]",
        ],
    );
    assert!(w >= 1400 - 40, "{w}");
    // One sample, one parameter.
    let one = [vec![3.0]];
    let dir = tempfile::tempdir().unwrap();
    draw_corner(
        dir.path(),
        "one",
        &CornerPlot {
            names: &n[..1],
            samples: &one,
            ..Default::default()
        },
    )
    .unwrap();
    check_outputs(dir.path(), "one", &["1 sample", "w1sq = 3.000"]);
    let d2 = tempfile::tempdir().unwrap();
    let d = d2.path();
    let with = |map: Option<&[f64]>, units: &[String]| {
        draw_corner(
            d,
            "c",
            &CornerPlot {
                names: &n,
                units,
                samples: &samples,
                map,
                ..Default::default()
            },
        )
    };
    assert_invalid(with(Some(&[1.0]), &[]), "map", d);
    assert_invalid(with(None, &u[..2]), "units", d);
}

/// A sweep of one point with one realisation: the band collapses onto the median (16, 50 and
/// 84 % of one value are that value), and the plot still shows the marker and the zones.
#[test]
fn band_plot_single_point_single_realisation() {
    let dir = tempfile::tempdir().unwrap();
    let series = vec![
        BandSeries {
            name: "RJMCMC".into(),
            x: vec![30.0],
            median: vec![4.2],
            lo: vec![4.2],
            hi: vec![4.2],
        },
        BandSeries {
            name: "bridge".into(),
            x: vec![30.0],
            median: vec![3.9],
            lo: vec![3.9],
            hi: vec![3.9],
        },
    ];
    band_plot(
        dir.path(),
        "one",
        &BandPlot {
            title: "median and 16–84 % of 1 realisation",
            x_label: "simulation.target_snr",
            y_label: "ln B_XY",
            series: &series,
            log_x: false,
            zones: true,
            sign: None,
        },
    )
    .unwrap();
    check_outputs(
        dir.path(),
        "one",
        &["RJMCMC", "bridge", "strong", "<polygon"],
    );
}
