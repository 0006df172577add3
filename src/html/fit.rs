//! A fit run's page parts, from `summary.json` ([`crate::jobs::fit::FitSummary`]).

use super::fmt::{at, bad, cell, facts, numbers, sig, table};
use super::parts::Parts;
use serde_json::Value;

/// R̂ above this is flagged: the threshold of the fit's own warning
/// (`sampler::diagnostics`, Vehtari et al. 2021).
pub(super) const RHAT_MAX: f64 = 1.01;

/// Facts, warnings and diagnostics of a fit summary.
pub fn parts(s: &Value) -> Parts {
    let mut p = Parts::default();
    let chains = format!(
        "{} × {} kept",
        cell(at(s, "chains")),
        cell(at(s, "kept_per_chain"))
    );
    p.facts = vec![
        ("model", cell(at(s, "model"))),
        ("data", cell(at(s, "origin"))),
        ("statistic", cell(at(s, "statistic"))),
        ("likelihood", cell(at(s, "likelihood"))),
        ("bins in band", cell(at(s, "n_bins"))),
        ("coarse bins", cell(at(s, "n_coarse_bins"))),
        ("chains", chains),
        ("ρ_opt at MAP", cell(at(s, "rho_opt_at_map"))),
        ("MAP ln posterior", cell(at(s, "map_ln_posterior"))),
    ];
    p.warnings.collect(s, "summary.json");

    let mut d = String::new();
    d.push_str("<h3>Convergence per parameter</h3>\n");
    let rows: Vec<Vec<String>> = at(s, "rows")
        .and_then(Value::as_array)
        .map(|rows| {
            rows.iter()
                .map(|r| {
                    let rhat = at(r, "rhat").and_then(Value::as_f64);
                    let rhat_html = match rhat {
                        Some(x) if x <= RHAT_MAX => sig(x),
                        Some(x) => bad(sig(x)),
                        // a non-finite R-hat: the chains did not move
                        None => bad("∞ (stuck)".into()),
                    };
                    let unit = at(r, "unit").and_then(Value::as_str).unwrap_or("");
                    vec![
                        cell(at(r, "name")),
                        if unit.is_empty() {
                            "–".into()
                        } else {
                            cell(at(r, "unit"))
                        },
                        rhat_html,
                        cell(at(r, "ess")),
                        cell(at(r, "mean")),
                        cell(at(r, "sd")),
                        cell(at(r, "cramer_rao")),
                    ]
                })
                .collect()
        })
        .unwrap_or_default();
    d.push_str(&table(
        &[
            "parameter",
            "unit",
            "R-hat",
            "ESS",
            "mean",
            "σ",
            "Cramér-Rao σ",
        ],
        &rows,
    ));
    d.push_str(&format!(
        "<p class=\"note\">R-hat above {RHAT_MAX} is marked: the chains have not converged to one distribution.</p>\n"
    ));
    d.push_str("<h3>Chains</h3>\n");
    let acc = numbers(at(s, "acceptance"));
    let nonfinite = at(s, "non_finite").and_then(Value::as_array);
    let rows: Vec<Vec<String>> = acc
        .iter()
        .enumerate()
        .map(|(i, a)| {
            let nf = nonfinite.and_then(|v| v.get(i));
            let nf_html = match nf.and_then(Value::as_u64) {
                Some(0) | None => cell(nf),
                Some(_) => bad(cell(nf)),
            };
            vec![i.to_string(), sig(*a), nf_html]
        })
        .collect();
    d.push_str(&table(
        &["chain", "acceptance", "non-finite ln posterior"],
        &rows,
    ));
    d.push_str(&facts(&[
        ("MAP search iterations", cell(at(s, "map_iterations"))),
        ("MAP search (s)", cell(at(s, "seconds_map"))),
        ("MCMC (s)", cell(at(s, "seconds_mcmc"))),
        (
            "iterations per second",
            cell(at(s, "iterations_per_second")),
        ),
        // absent (and left out) unless [fit] until ended the chains early
        (
            "iterations per chain when the chains converged ([fit] until)",
            cell(at(s, "converged_at")),
        ),
    ]));
    p.diagnostics = d;
    p
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn stuck_and_unconverged_chains_are_marked() {
        let s = json!({
            "model": "<m>", "chains": 2, "kept_per_chain": 10,
            "rows": [{"name": "a", "rhat": null, "ess": 3.0},
                     {"name": "b", "rhat": 1.5, "ess": 30.0},
                     {"name": "c", "rhat": 1.001, "ess": 300.0}],
            "acceptance": [0.0, 0.3], "non_finite": [4, 0],
            "warnings": ["R-hat of `b` is 1.5"]
        });
        let p = parts(&s);
        assert!(
            p.diagnostics
                .contains("<span class=\"bad\">∞ (stuck)</span>")
        );
        assert!(p.diagnostics.contains("<span class=\"bad\">1.500</span>"));
        assert!(p.diagnostics.contains("<td>1.001</td>"));
        assert!(p.diagnostics.contains("<span class=\"bad\">4</span>"));
        assert_eq!(p.facts[0].1, "&lt;m&gt;");
        assert_eq!(p.warnings.len(), 1);
    }

    #[test]
    fn an_empty_summary_gives_empty_tables_not_a_panic() {
        let p = parts(&json!({}));
        assert!(p.warnings.is_empty());
        assert!(p.diagnostics.contains("<th>R-hat</th>"));
    }
}
