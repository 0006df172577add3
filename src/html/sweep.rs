//! A sweep run's page parts, from `sweep.json` (`jobs::sweep::output`): the grid, each point's
//! failures and agreement, and every task's errors and warnings grouped by text.

use super::fmt::{at, bad, cell, facts, table};
use super::parts::Parts;
use serde_json::Value;

fn list(v: Option<&Value>) -> &[Value] {
    v.and_then(Value::as_array).map_or(&[], Vec::as_slice)
}

/// `key = value, …` of a point (plain text).
fn point_label(keys: &[String], values: Option<&Value>) -> String {
    let vals = list(values);
    if keys.is_empty() || vals.is_empty() {
        return "–".into();
    }
    keys.iter()
        .zip(vals)
        .map(|(k, v)| format!("{k} = {v}"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// Facts, warnings and diagnostics of a sweep's `sweep.json`.
pub fn parts(s: &Value) -> Parts {
    let mut p = Parts::default();
    let keys: Vec<String> = list(at(s, "axes"))
        .iter()
        .map(|a| {
            at(a, "key")
                .and_then(Value::as_str)
                .unwrap_or("?")
                .to_string()
        })
        .collect();
    let axes: Vec<String> = list(at(s, "axes"))
        .iter()
        .map(|a| format!("{}: {}", cell(at(a, "key")), cell(at(a, "values"))))
        .collect();
    p.facts = vec![
        ("study", cell(at(s, "study"))),
        ("seed", cell(at(s, "seed"))),
        ("axes", axes.join("; ")),
        ("realisations per point", cell(at(s, "realisations"))),
        ("models", cell(at(s, "models"))),
        ("truth", cell(at(s, "truth"))),
    ];
    let points = list(at(s, "points"));
    let mut rows = Vec::new();
    for (i, pt) in points.iter().enumerate() {
        let label = point_label(&keys, at(pt, "values"));
        for (r, rec) in list(at(pt, "realisations")).iter().enumerate() {
            let place = format!("point {i} ({label}), realisation {r}");
            if let Some(e) = at(rec, "error").and_then(Value::as_str) {
                p.warnings.add(&format!("a task failed: {e}"), &place);
            }
            if let Some(o) = at(rec, "outcome") {
                p.warnings.collect(o, &place);
            }
        }
        let failed = at(pt, "stats.failed");
        let failed_html = match failed.and_then(Value::as_u64) {
            Some(0) => "0".into(),
            Some(_) => bad(cell(failed)),
            None => cell(failed),
        };
        let agree: Vec<String> = list(at(pt, "stats.pairs"))
            .iter()
            .map(|q| cell(at(q, "agree")))
            .collect();
        let mut row = vec![i.to_string()];
        // one cell per axis, whatever the point holds, so the columns stay aligned
        let vals = list(at(pt, "values"));
        row.extend((0..keys.len()).map(|k| cell(vals.get(k))));
        row.extend([
            failed_html,
            cell(at(pt, "stats.correct")),
            agree.join(", "),
            cell(at(pt, "stats.rho_opt_median")),
            cell(at(pt, "stats.first_error")),
        ]);
        rows.push(row);
    }
    let mut header: Vec<&str> = vec!["point"];
    header.extend(keys.iter().map(String::as_str));
    header.extend([
        "failed tasks",
        "picks the truth",
        "agree (per pair)",
        "median ρ_opt",
        "first error",
    ]);
    let mut d = String::from("<h3>Points</h3>\n");
    d.push_str(&table(&header, &rows));
    d.push_str("<p class=\"note\">picks the truth: the fraction of realisations whose reference estimator prefers the true model; agree: the fraction whose statistical estimators agree within errors.</p>\n");
    let thresholds: Vec<String> = list(at(s, "threshold"))
        .iter()
        .map(|t| {
            format!(
                "pair {}: the truth wins from {} on",
                cell(at(t, "pair")),
                cell(at(t, "from"))
            )
        })
        .collect();
    if !thresholds.is_empty() {
        d.push_str(&facts(&[("thresholds", thresholds.join("; "))]));
    }
    p.diagnostics = d;
    p
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn task_errors_and_repeated_warnings_are_grouped_by_text() {
        let s = json!({
            "axes": [{"key": "simulation.target_snr", "values": [20.0, 30.0]}],
            "points": [
                {"values": [20.0], "stats": {"failed": 1, "first_error": "boom <x>"},
                 "realisations": [{"error": "boom <x>", "outcome": null},
                                  {"error": null, "outcome": {"warnings": ["MAP on a bound"]}}]},
                {"values": [30.0], "stats": {"failed": 0, "pairs": [{"agree": 0.5}]},
                 "realisations": [{"error": null, "outcome": {"warnings": ["MAP on a bound"]}}]}
            ]
        });
        let p = parts(&s);
        assert_eq!(p.warnings.len(), 2);
        assert_eq!(p.warnings.0[0].text, "a task failed: boom <x>");
        assert_eq!(
            p.warnings.0[1].places,
            [
                "point 0 (simulation.target_snr = 20.0), realisation 1",
                "point 1 (simulation.target_snr = 30.0), realisation 0"
            ]
        );
        assert!(p.diagnostics.contains("<span class=\"bad\">1</span>"));
        assert!(p.diagnostics.contains("boom &lt;x&gt;"));
        assert!(p.diagnostics.contains("<td>0.5000</td>"));
    }

    #[test]
    fn an_empty_sweep_gives_a_page_not_a_panic() {
        let p = parts(&json!({}));
        assert!(p.warnings.is_empty() && p.diagnostics.contains("Points"));
    }
}
