//! A finished sweep on disk: `sweep.json` (every number), `sweep.npz` (the arrays),
//! `table.txt` and the plots.

use super::stats::REFERENCE;
use super::study::{Sweep, SweepResult};
use anyhow::Context;
use ndarray::{Array, ArrayD, IxDyn};
use std::path::{Path, PathBuf};

/// What a sweep directory held before `manifest.json` existed: the files a new run removes
/// when it does not write them itself ([`crate::data::rundir::RunDir::publish`]).
pub const LEGACY_OUTPUTS: &[&str] = &[
    "sweep.json",
    "sweep.npz",
    "table.txt",
    "ln_b_vs_*.png",
    "ln_b_vs_*.svg",
    "ln_b_map*.png",
    "ln_b_map*.svg",
    // `occam report` records its page in the manifest; in an older directory only this finds it
    "report.html",
];

/// Writes the sweep's outputs into the staging area of the run directory `run` and publishes
/// them together; returns the published file names.
pub fn publish(
    sweep: &Sweep,
    res: &SweepResult,
    run: &crate::data::rundir::RunDir,
) -> anyhow::Result<Vec<String>> {
    write_outputs(sweep, res, &run.staging()?)?;
    Ok(run.publish("sweep", LEGACY_OUTPUTS)?)
}

/// Writes the sweep's outputs into `dir` (the run directory, or its staging directory: see
/// [`crate::data::rundir`]); returns the files written.
pub fn write_outputs(sweep: &Sweep, res: &SweepResult, dir: &Path) -> anyhow::Result<Vec<PathBuf>> {
    let out = dir;
    let mut files = Vec::new();
    let p = out.join("sweep.json");
    let json = serde_json::to_string_pretty(&json(sweep, res))? + "\n";
    crate::atomic::write_bytes(&p, json.as_bytes())
        .with_context(|| format!("writing {}", p.display()))?;
    files.push(p);
    let p = out.join("sweep.npz");
    write_npz(sweep, res, &p)?;
    files.push(p);
    let p = out.join("table.txt");
    crate::atomic::write_bytes(&p, table(sweep, res).as_bytes())
        .with_context(|| format!("writing {}", p.display()))?;
    files.push(p);
    let p = out.join(crate::config::RESOLVED_FILE);
    crate::atomic::write_bytes(&p, sweep.resolved.as_bytes())
        .with_context(|| format!("writing {}", p.display()))?;
    files.push(p);
    files.extend(super::plots::write_plots(sweep, res, out)?);
    Ok(files)
}

/// `sweep.json`: the grid, each point's statistics and every realisation's rows. Each point
/// also keeps the keys of the single-realisation `sweep.json` of earlier versions
/// (`target_snr` when it is swept, `pairs` and `rj_visits` of realisation 0).
fn json(sweep: &Sweep, res: &SweepResult) -> serde_json::Value {
    let r = sweep.realisations;
    let points: Vec<serde_json::Value> = res
        .points
        .iter()
        .map(|ps| {
            let recs = &res.records[ps.index * r..(ps.index + 1) * r];
            let mut v = serde_json::json!({
                "values": ps.values,
                "stats": ps,
                "realisations": recs,
                "pairs": recs[0].outcome.as_ref().map(|o| &o.pairs),
                "rj_visits": recs[0].outcome.as_ref().and_then(|o| o.rj_visits.as_ref()),
            });
            for (a, x) in sweep.grid.axes.iter().zip(&ps.values) {
                if a.key == "simulation.target_snr" {
                    v["target_snr"] = serde_json::json!(x);
                }
            }
            v
        })
        .collect();
    let threshold: Vec<serde_json::Value> = match (&sweep.truth, sweep.grid.axes.len()) {
        (Some(t), 1) => (0..res.methods.len())
            .map(|k| {
                serde_json::json!({
                    "pair": k,
                    "from": super::stats::threshold(&res.points, k, t),
                })
            })
            .collect(),
        _ => Vec::new(),
    };
    serde_json::json!({
        "study": sweep.file,
        "seed": sweep.seed,
        "axes": sweep.grid.axes.iter().map(|a| serde_json::json!({"key": a.key, "values": a.values})).collect::<Vec<_>>(),
        "realisations": r,
        "truth": sweep.truth,
        "models": sweep.models,
        "estimators": res.methods.iter().map(|m| {
            let mut v = vec![REFERENCE.to_string()];
            v.extend(m.iter().cloned());
            v
        }).collect::<Vec<_>>(),
        "threshold": threshold,
        "points": points,
    })
}

/// `sweep.npz`: `axis0` (and `axis1`), `grid_shape`; per point, realisation, pair and
/// estimator (the reference first, as in `sweep.json`'s `estimators`): `ln_b`, `std_err`;
/// per point, pair and estimator: `median`, `q16`, `q84`; `agree` (point, pair), `picks`
/// (point, model), `rho_opt` (point, realisation). NaN where there is no number.
fn write_npz(sweep: &Sweep, res: &SweepResult, path: &std::path::Path) -> anyhow::Result<()> {
    let np = res.points.len();
    let r = sweep.realisations;
    let npair = res.methods.len();
    let ne = res.methods.iter().map(|m| m.len() + 1).max().unwrap_or(1);
    let mut ln_b = ArrayD::<f64>::from_elem(IxDyn(&[np, r, npair, ne]), f64::NAN);
    let mut se = ln_b.clone();
    let mut rho = ArrayD::<f64>::from_elem(IxDyn(&[np, r]), f64::NAN);
    for (t, rec) in res.records.iter().enumerate() {
        let (p, k) = (t / r, t % r);
        let Some(o) = &rec.outcome else { continue };
        rho[[p, k]] = o.rho_opt.unwrap_or(f64::NAN);
        for (j, (pair, names)) in o.pairs.iter().zip(&res.methods).enumerate() {
            ln_b[[p, k, j, 0]] = pair.reference_ln_b().unwrap_or(f64::NAN);
            if let Some(e) = pair.estimates.iter().find(|e| e.method == pair.reference) {
                se[[p, k, j, 0]] = e.std_err.unwrap_or(f64::NAN);
            }
            for (m, name) in names.iter().enumerate() {
                if let Some(e) = pair.estimates.iter().find(|e| &e.method == name) {
                    ln_b[[p, k, j, m + 1]] = e.ln_b.unwrap_or(f64::NAN);
                    se[[p, k, j, m + 1]] = e.std_err.unwrap_or(f64::NAN);
                }
            }
        }
    }
    let mut q = [
        ArrayD::<f64>::from_elem(IxDyn(&[np, npair, ne]), f64::NAN),
        ArrayD::<f64>::from_elem(IxDyn(&[np, npair, ne]), f64::NAN),
        ArrayD::<f64>::from_elem(IxDyn(&[np, npair, ne]), f64::NAN),
    ];
    let mut agree = ArrayD::<f64>::from_elem(IxDyn(&[np, npair]), f64::NAN);
    let mut picks = ArrayD::<f64>::from_elem(IxDyn(&[np, sweep.models.len()]), f64::NAN);
    for ps in &res.points {
        for (j, pair) in ps.pairs.iter().enumerate() {
            agree[[ps.index, j]] = pair.agree;
            for (m, e) in pair.estimators.iter().enumerate() {
                for (arr, v) in q.iter_mut().zip([e.median, e.q16, e.q84]) {
                    arr[[ps.index, j, m]] = v.unwrap_or(f64::NAN);
                }
            }
        }
        for (k, v) in ps.picks.iter().enumerate() {
            picks[[ps.index, k]] = *v;
        }
    }
    let shape: Vec<i64> = sweep
        .grid
        .axes
        .iter()
        .map(|a| a.values.len() as i64)
        .collect();
    crate::atomic::write_with(path, |w| {
        let io = |e: ndarray_npy::WriteNpzError| std::io::Error::other(e.to_string());
        let mut z = ndarray_npy::NpzWriter::new(w);
        for (k, a) in sweep.grid.axes.iter().enumerate() {
            z.add_array(format!("axis{k}"), &Array::from_vec(a.values.clone()))
                .map_err(io)?;
        }
        z.add_array("grid_shape", &Array::from_vec(shape.clone()))
            .map_err(io)?;
        z.add_array("ln_b", &ln_b).map_err(io)?;
        z.add_array("std_err", &se).map_err(io)?;
        let [median, q16, q84] = &q;
        z.add_array("median", median).map_err(io)?;
        z.add_array("q16", q16).map_err(io)?;
        z.add_array("q84", q84).map_err(io)?;
        z.add_array("agree", &agree).map_err(io)?;
        z.add_array("picks", &picks).map_err(io)?;
        z.add_array("rho_opt", &rho).map_err(io)?;
        z.finish().map_err(io)?;
        Ok(())
    })
    .with_context(|| format!("writing {}", path.display()))
}

/// Keys along which more is more signal (a threshold "from here on" makes sense).
fn monotone_key(key: &str) -> bool {
    ["snr", "amplitude", "duration"]
        .iter()
        .any(|k| key.rsplit('.').next().is_some_and(|leaf| leaf.contains(k)))
}

/// The Kass–Raftery grade of a median ln B_XY, short: `bare`, `positive X`, `strong Y`, …
/// (2 ln B at 2, 6 and 10).
fn grade(ln_b: Option<f64>, x: &str, y: &str) -> String {
    let Some(v) = ln_b else { return "–".into() };
    let w = if v > 0.0 { x } else { y };
    match v.abs() {
        a if a <= 1.0 => "bare".into(),
        a if a <= 3.0 => format!("positive {w}"),
        a if a <= 5.0 => format!("strong {w}"),
        _ => format!("very strong {w}"),
    }
}

/// An estimator's median this many nats from the reference's is flagged in the table.
const FAR_NATS: f64 = 5.0;

/// Whether an estimator's median is flagged: more than [`FAR_NATS`] from the reference's
/// (5 nats is the span of the Kass–Raftery scale from "bare" to "very strong": a difference
/// that alone could turn a verdict).
fn far_from_reference(median: Option<f64>, reference: Option<f64>) -> bool {
    matches!((median, reference), (Some(m), Some(r)) if (m - r).abs() > FAR_NATS)
}

/// A median ln B towards the truth (positive: the truth favoured) by its Kass–Raftery
/// grade: `Greater` beyond a bare mention, `Equal` a bare mention (|ln B| ≤ 1), `Less` the
/// other model favoured beyond one.
fn decided(towards_truth: f64) -> std::cmp::Ordering {
    if towards_truth > 1.0 {
        std::cmp::Ordering::Greater
    } else if towards_truth < -1.0 {
        std::cmp::Ordering::Less
    } else {
        std::cmp::Ordering::Equal
    }
}

fn opt(v: Option<f64>, prec: usize) -> String {
    v.map_or("–".into(), |x| crate::report::fmt_fixed(x, prec))
}

/// The text table: per pair and point, the reference's median ln B with its 16–84 % band,
/// how often the estimators agree, how often each model is picked, and every estimator's
/// median.
pub fn table(sweep: &Sweep, res: &SweepResult) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    let keys: Vec<&str> = sweep.grid.axes.iter().map(|a| a.key.as_str()).collect();
    let _ = writeln!(
        s,
        "{} realisation(s) per point; ln B_XY median [16 %, 84 %] over realisations; agree: fraction with the statistical estimators within errors; below, each estimator's median",
        sweep.realisations
    );
    let shortened: Vec<String> = SHORT
        .iter()
        .filter(|(long, _)| res.methods.iter().flatten().any(|m| m == long))
        .map(|(long, short)| format!("{short} = {long}"))
        .collect();
    // a few to a line: the legend is no wider than the tables it explains
    for (k, chunk) in shortened.chunks(4).enumerate() {
        let head = if k == 0 { "estimators:" } else { "           " };
        let _ = writeln!(s, "{head} {}", chunk.join(", "));
    }
    for (j, names) in res.methods.iter().enumerate() {
        let Some(first) = res.points.iter().find_map(|p| p.pairs.get(j)) else {
            continue;
        };
        let _ = writeln!(s, "\npair {}/{}", first.x, first.y);
        let mut head: Vec<String> = keys.iter().map(|k| k.to_string()).collect();
        head.extend(
            ["ok", "reference ln B [16, 84]", "median's grade", "agree"]
                .iter()
                .map(|h| h.to_string()),
        );
        let mut t = crate::report::Table::new(head);
        // the estimators' medians in a table of their own: one row of both was ~150
        // characters, wider than a terminal and than the report's page
        let mut medians_head: Vec<String> = keys.iter().map(|k| k.to_string()).collect();
        medians_head.extend(names.iter().map(|n| short(n).to_string()));
        let mut m = crate::report::Table::new(medians_head);
        let mut flagged = false;
        for p in &res.points {
            let Some(pair) = p.pairs.get(j) else { continue };
            let axes: Vec<String> = p.values.iter().map(|v| format!("{v:.4e}")).collect();
            let mut row = axes.clone();
            let r = &pair.estimators[0];
            row.push(format!("{}/{}", p.realisations - p.failed, p.realisations));
            row.push(format!(
                "{} [{}, {}]",
                opt(r.median, 3),
                opt(r.q16, 2),
                opt(r.q84, 2)
            ));
            row.push(grade(r.median, &pair.x, &pair.y));
            row.push(opt(Some(pair.agree).filter(|v| v.is_finite()), 2));
            let mut medians = axes;
            for e in &pair.estimators[1..] {
                let far = far_from_reference(e.median, r.median);
                flagged |= far;
                medians.push(opt(e.median, 3) + if far { " !" } else { "" });
            }
            if t.push_row(row).is_err() || m.push_row(medians).is_err() {
                continue;
            }
        }
        s.push_str(&t.to_text());
        let _ = writeln!(s, "each estimator's median ln B ({}/{}):", first.x, first.y);
        s.push_str(&m.to_text());
        if flagged {
            let _ = writeln!(
                s,
                "!: the estimator's median is more than {FAR_NATS} nats from the reference's: its approximation does not hold there (each realisation's table says why)"
            );
        }
        if let (Some(truth), 1) = (&sweep.truth, keys.len()) {
            let sign = if *truth == first.x { 1.0 } else { -1.0 };
            // by the median's Kass–Raftery grade: a bare mention (|ln B| ≤ 1) decides nothing,
            // whichever its sign
            let at = |class: std::cmp::Ordering| {
                let v: Vec<String> = res
                    .points
                    .iter()
                    .filter(|p| {
                        p.pairs
                            .get(j)
                            .and_then(|q| q.estimators[0].median)
                            .is_some_and(|m| decided(m * sign) == class)
                    })
                    .map(|p| format!("{}", p.values[0]))
                    .collect();
                if v.is_empty() {
                    "none".into()
                } else {
                    v.join(", ")
                }
            };
            use std::cmp::Ordering::{Equal, Greater, Less};
            let _ = writeln!(
                s,
                "{truth} (the truth) is favoured by the reference's median (beyond a bare mention) at {} = {}; undecided (|median| ≤ 1 nat, a bare mention) at {}; misidentified (the other model favoured beyond a bare mention) at {}",
                keys[0],
                at(Greater),
                at(Equal),
                at(Less)
            );
            if monotone_key(keys[0]) {
                let _ = writeln!(
                    s,
                    "{truth} wins (median at least positive evidence) and the estimators agree in ≥ half the realisations {}",
                    match super::stats::threshold(&res.points, j, truth) {
                        Some(v) => format!("from {} = {v} on", keys[0]),
                        None => "at no point from the top of the grid down".into(),
                    }
                );
            }
        }
        for p in res.points.iter().filter(|p| p.failed > 0) {
            let _ = writeln!(
                s,
                "note: {}: {} of {} realisations failed: {}",
                sweep.grid.label(p.index),
                p.failed,
                p.realisations,
                p.first_error.as_deref().unwrap_or("")
            );
        }
    }
    picks_table(&mut s, sweep, res, &keys);
    s
}

/// The estimators' names as the sweep table's column headers: short, so that a pair's row fits
/// a terminal (the table's first lines give each in full).
const SHORT: &[(&str, &str)] = &[
    ("RJMCMC visits", "RJ visits"),
    ("RJMCMC Rao-Blackwell", "RJ RB"),
    ("RJMCMC bridge", "RJ bridge"),
    ("Thermodynamic integration", "TI"),
    ("Stepping-stone", "SS"),
    ("Bridge sampling", "BS"),
    ("Laplace-Fisher raw", "LF raw"),
    ("Laplace-Fisher box", "LF box"),
    ("Laplace-Metropolis MVE", "LM MVE"),
    ("Laplace-Metropolis MCD", "LM MCD"),
    ("Schwarz (SBIC)", "SBIC"),
];

/// `method`'s column header (itself when it has no short name).
fn short(method: &str) -> &str {
    SHORT
        .iter()
        .find(|(long, _)| *long == method)
        .map_or(method, |(_, s)| s)
}

/// How often each model is picked, per point: one table for the sweep (not a column of every
/// pair's, where it repeated and made the rows ~370 characters wide).
fn picks_table(s: &mut String, sweep: &Sweep, res: &SweepResult, keys: &[&str]) {
    use std::fmt::Write;
    if sweep.models.is_empty() || res.points.is_empty() {
        return;
    }
    let _ = writeln!(
        s,
        "\npicks: fraction of realisations in which each model has the highest posterior probability"
    );
    let mut head: Vec<String> = keys.iter().map(|k| k.to_string()).collect();
    head.push("ok".into());
    head.extend(sweep.models.iter().cloned());
    let mut t = crate::report::Table::new(head);
    for p in &res.points {
        let mut row: Vec<String> = p.values.iter().map(|v| format!("{v:.4e}")).collect();
        row.push(format!("{}/{}", p.realisations - p.failed, p.realisations));
        row.extend(
            p.picks
                .iter()
                .map(|v| opt(Some(*v).filter(|v| v.is_finite()), 2)),
        );
        let _ = t.push_row(row);
    }
    s.push_str(&t.to_text());
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::cmp::Ordering::{Equal, Greater, Less};

    #[test]
    fn a_bare_mention_is_undecided_whatever_its_sign() {
        assert_eq!(decided(1.01), Greater);
        assert_eq!(decided(0.4), Equal);
        assert_eq!(decided(-0.99), Equal);
        assert_eq!(decided(-1.5), Less);
    }

    #[test]
    fn medians_far_from_the_reference_are_flagged() {
        assert!(far_from_reference(Some(197_950.0), Some(-1.0)));
        assert!(far_from_reference(Some(-7.0), Some(-1.0)));
        assert!(!far_from_reference(Some(-5.9), Some(-1.0)));
        assert!(!far_from_reference(None, Some(-1.0)));
        assert!(!far_from_reference(Some(3.0), None));
    }
}
