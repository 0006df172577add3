//! The Table II layout and the files of a select run.

use super::{EstimateKind, SelectError, SelectSummary};
use crate::report::Table;
use std::path::Path;

/// The Table II layout: one row per estimator, for each pair.
pub fn table(s: &SelectSummary) -> Table {
    let mut t = Table::new([
        "pair",
        "estimator",
        "B_XY",
        "ln B_XY",
        "± σ",
        "agrees",
        "note",
    ]);
    for p in &s.pairs {
        for e in &p.estimates {
            let b = e.ln_b.map_or("–".into(), |v| format!("{:.4e}", v.exp()));
            let lb = e.ln_b.map_or("–".into(), |v| format!("{v:.3}"));
            let se = match (e.kind, e.std_err, e.ln_b) {
                (_, Some(v), _) => format!("{v:.3}"),
                (EstimateKind::Systematic, None, Some(_)) => "systematic".into(),
                (EstimateKind::Criterion, None, Some(_)) => "O(1)".into(),
                _ => "–".into(),
            };
            let ag = e
                .agrees
                .map_or("–".into(), |a| if a { "yes" } else { "no" }.to_string());
            let note = e
                .note
                .clone()
                .or_else(|| e.assumes.as_ref().map(|a| format!("assumes {a}")))
                .unwrap_or_default();
            let note = if note.chars().count() > 60 {
                format!("{}…", note.chars().take(60).collect::<String>())
            } else {
                note
            };
            t.push_row([
                format!("{}/{}", p.x, p.y),
                e.method.clone(),
                b,
                lb,
                se,
                ag,
                note,
            ])
            .expect("row width matches the header");
        }
    }
    t
}

/// What a select directory held before `manifest.json` existed: the files a new run removes
/// when it does not write them itself ([`crate::rundir::RunDir::publish`]).
pub const LEGACY_OUTPUTS: &[&str] = &[
    "summary.json",
    "table.txt",
    "table.md",
    "residual_psd.npz",
    "residual_psd_*.png",
    "residual_psd_*.svg",
    "bayes_factor.png",
    "bayes_factor.svg",
    "model_visits.png",
    "model_visits.svg",
];

/// Writes `summary.json`, `table.txt`, `table.md`, the evolution of B (`bayes_factor`) and the
/// model-visit histogram (`model_visits`), each atomically.
pub fn write_outputs(s: &SelectSummary, out: &Path) -> Result<(), SelectError> {
    let io = |p: &Path, e: std::io::Error| SelectError::Io(format!("{}: {e}", p.display()));
    std::fs::create_dir_all(out).map_err(|e| io(out, e))?;
    let json = serde_json::to_string_pretty(s).expect("summary serialises") + "\n";
    let p = out.join("summary.json");
    crate::atomic::write_bytes(&p, json.as_bytes()).map_err(|e| io(&p, e))?;
    let t = table(s);
    let p = out.join("table.txt");
    crate::atomic::write_bytes(&p, t.to_text().as_bytes()).map_err(|e| io(&p, e))?;
    let p = out.join("table.md");
    crate::atomic::write_bytes(&p, t.to_markdown().as_bytes()).map_err(|e| io(&p, e))?;
    crate::report::residual_psd::write(out, &s.residual_psd)?;
    let Some(rj) = &s.rj else {
        return Ok(());
    };
    let series: Vec<(String, Vec<(f64, f64)>)> = s
        .pairs
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let (x, y) = pair_indices(s.models.len(), i);
            let pts = rj
                .ln_b_trace(x, y)
                .into_iter()
                .map(|(it, v)| (it as f64, v.map_or(f64::NAN, f64::exp)))
                .collect();
            (format!("B {}/{}", p.x, p.y), pts)
        })
        .collect();
    if series
        .iter()
        .any(|(_, v)| v.iter().any(|p| p.1.is_finite()))
    {
        crate::report::bayes_factor_evolution(
            out,
            "bayes_factor",
            &series,
            true,
            "B_XY (visit ratio)",
        )?;
    }
    let labels: Vec<String> = s.models.iter().map(|m| m.name.clone()).collect();
    let counts: Vec<f64> = rj.visits.iter().map(|&v| v as f64).collect();
    crate::report::model_histogram(out, "model_visits", &labels, &counts)?;
    Ok(())
}

fn pair_indices(k: usize, idx: usize) -> (usize, usize) {
    let mut n = 0;
    for x in 0..k {
        for y in x + 1..k {
            if n == idx {
                return (x, y);
            }
            n += 1;
        }
    }
    (0, 1)
}
