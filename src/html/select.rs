//! A select run's page parts, from `summary.json` ([`crate::jobs::select::SelectSummary`]): each
//! pair's verdict and jump statistics, every estimator's full note, each model's chains,
//! tempering and reversible-jump diagnostics.

use super::escape::esc;
use super::fmt::{at, bad, cell, dec, facts, numbers, range, sig, table};
use super::parts::Parts;
use serde_json::Value;

fn list(v: Option<&Value>) -> &[Value] {
    v.and_then(Value::as_array).map_or(&[], Vec::as_slice)
}

/// `accepted of proposed (rate)`.
fn jumps(acc: Option<&Value>, prop: Option<&Value>) -> String {
    let (a, p) = (
        acc.and_then(Value::as_f64).unwrap_or(f64::NAN),
        prop.and_then(Value::as_f64).unwrap_or(f64::NAN),
    );
    let rate = if p > 0.0 { sig(a / p) } else { "–".into() };
    let s = format!("{} of {} ({rate})", cell(acc), cell(prop));
    // proposals that were all refused: the estimators that count jumps have nothing to count
    if a == 0.0 && p > 0.0 { bad(s) } else { s }
}

/// Each pair's verdict and jumps; its estimator table too when the run's table file does not
/// already show it (`in_table`).
fn pairs(s: &Value, in_table: bool) -> String {
    let mut d = String::new();
    for pr in list(at(s, "pairs")) {
        let (x, y) = (cell(at(pr, "x")), cell(at(pr, "y")));
        d.push_str(&format!("<h3>{x} against {y}</h3>\n"));
        d.push_str(&facts(&[
            ("reference estimator", cell(at(pr, "reference"))),
            ("preferred model", cell(at(pr, "preferred"))),
            ("evidence", cell(at(pr, "kass_raftery"))),
            (
                "statistical estimators agree within errors",
                cell(at(pr, "all_agree")),
            ),
            (
                "Laplace estimates within 1 nat",
                cell(at(pr, "systematic_agree")),
            ),
            (
                "jumps X→Y accepted",
                jumps(
                    at(pr, "jumps.accepted_x_to_y"),
                    at(pr, "jumps.proposed_x_to_y"),
                ),
            ),
            (
                "jumps Y→X accepted",
                jumps(
                    at(pr, "jumps.accepted_y_to_x"),
                    at(pr, "jumps.proposed_y_to_x"),
                ),
            ),
            ("effective jumps", cell(at(pr, "jumps.effective_jumps"))),
            ("expected jumps (Σα)", cell(at(pr, "jumps.expected_jumps"))),
        ]));
        if in_table {
            d.push_str(
                "<p class=\"note\">Every estimator of this pair, with its notes: under Results.</p>\n",
            );
            continue;
        }
        let rows: Vec<Vec<String>> = list(at(pr, "estimates"))
            .iter()
            .map(|e| {
                let mut why = Vec::new();
                if let Some(a) = at(e, "assumes").and_then(Value::as_str) {
                    why.push(format!("assumes {}", esc(a)));
                }
                if let Some(n) = at(e, "note").and_then(Value::as_str) {
                    why.push(esc(n));
                }
                vec![
                    cell(at(e, "method")),
                    cell(at(e, "kind")),
                    dec(at(e, "ln_b"), 3),
                    cell(at(e, "std_err")),
                    cell(at(e, "agrees")),
                    why.join("; "),
                ]
            })
            .collect();
        d.push_str(&table(
            &[
                "estimator",
                "kind",
                "ln B",
                "± σ",
                "agrees",
                "assumptions and notes",
            ],
            &rows,
        ));
    }
    d
}

/// Each model's parameter estimates (`models[].estimates`): MAP, posterior mean ± sd of its
/// in-model chains, Fisher σ at the MAP; nothing for a run that predates them.
fn estimates(s: &Value) -> String {
    let rows: Vec<Vec<String>> = list(at(s, "models"))
        .iter()
        .flat_map(|m| {
            list(at(m, "estimates")).iter().map(move |e| {
                vec![
                    cell(at(m, "name")),
                    cell(at(e, "name")),
                    cell(at(e, "map")),
                    cell(at(e, "mean")),
                    cell(at(e, "sd")),
                    cell(at(e, "fisher_sigma")),
                    cell(at(e, "unit")),
                ]
            })
        })
        .collect();
    if rows.is_empty() {
        return String::new();
    }
    format!(
        "<h3>Parameter estimates of each model</h3>\n{}",
        table(
            &[
                "model",
                "parameter",
                "MAP",
                "mean",
                "sd",
                "Fisher σ",
                "unit"
            ],
            &rows
        )
    )
}

/// The models' table, their parameter estimates unless the run's table file shows them
/// (`in_table`), and their tempering.
fn models(s: &Value, in_table: bool) -> String {
    let mut d = String::from("<h3>Models</h3>\n");
    let rows: Vec<Vec<String>> = list(at(s, "models"))
        .iter()
        .map(|m| {
            let rhat = at(m, "mcmc_max_rhat").and_then(Value::as_f64);
            let rhat = match rhat {
                Some(x) if x <= super::fit::RHAT_MAX => sig(x),
                Some(x) => bad(sig(x)),
                None => cell(at(m, "mcmc_max_rhat")),
            };
            let at_bound = list(at(m, "map_at_bound"));
            let at_bound = if at_bound.is_empty() {
                "–".into()
            } else {
                bad(cell(at(m, "map_at_bound")))
            };
            let notes: Vec<String> = list(at(m, "notes")).iter().map(|n| cell(Some(n))).collect();
            vec![
                cell(at(m, "name")),
                cell(at(m, "model")),
                cell(at(m, "free")),
                cell(at(m, "prior_probability")),
                cell(at(m, "map_found")),
                at_bound,
                range(&numbers(at(m, "mcmc_acceptance"))),
                cell(at(m, "mcmc_iterations")),
                rhat,
                cell(at(m, "jump_proposal")),
                notes.join("<br/>"),
            ]
        })
        .collect();
    d.push_str(&table(
        &[
            "model",
            "parent",
            "free",
            "prior probability",
            "MAP found",
            "MAP on a prior bound",
            "chains' acceptance",
            "chains' iterations",
            "max R-hat",
            "jump proposal",
            "notes",
        ],
        &rows,
    ));
    if !in_table {
        d.push_str(&estimates(s));
    }
    let tempered: Vec<&Value> = list(at(s, "models"))
        .iter()
        .filter(|m| at(m, "tempering").is_some_and(|t| !t.is_null()))
        .collect();
    if tempered.is_empty() {
        d.push_str("<p class=\"note\">No parallel tempering in this run (pt_temperatures = 0, or a run that predates it): no thermodynamic integration or stepping-stone.</p>\n");
    } else {
        d.push_str("<h3>Parallel tempering</h3>\n");
        let rows: Vec<Vec<String>> = tempered
            .iter()
            .map(|m| {
                let ln_z = |k: &str| {
                    format!(
                        "{} ± {}",
                        dec(at(m, &format!("{k}.ln_z")), 3),
                        cell(at(m, &format!("{k}.std_err")))
                    )
                };
                let swaps = numbers(at(m, "tempering.swap_acceptance"));
                let swap_html = if swaps.contains(&0.0) {
                    bad(range(&swaps))
                } else {
                    range(&swaps)
                };
                vec![
                    cell(at(m, "name")),
                    list(at(m, "tempering.betas")).len().to_string(),
                    swap_html,
                    range(&numbers(at(m, "tempering.in_rung_acceptance"))),
                    cell(at(m, "tempering.sweeps")),
                    cell(at(m, "tempering.burn_in")),
                    ln_z("thermodynamic"),
                    ln_z("stepping_stone"),
                    cell(at(m, "tempering.approximation_err")),
                ]
            })
            .collect();
        d.push_str(&table(
            &[
                "model",
                "rungs",
                "swap acceptance",
                "in-rung acceptance",
                "sweeps",
                "burn-in",
                "ln Z (thermodynamic) ± σ",
                "ln Z (stepping-stone) ± σ",
                "approximation error",
            ],
            &rows,
        ));
        d.push_str("<p class=\"note\">A swap acceptance of 0 between neighbouring rungs breaks the ladder: add temperatures.</p>\n");
    }
    d
}

/// Each model's MAP, one line per parameter with its unit.
fn map_values(s: &Value) -> String {
    let mut rows = Vec::new();
    for m in list(at(s, "models")) {
        let units = list(at(m, "units"));
        let map = list(at(m, "map"));
        for (k, p) in list(at(m, "params")).iter().enumerate() {
            let unit = units.get(k).and_then(Value::as_str).unwrap_or("");
            rows.push(vec![
                cell(at(m, "name")),
                cell(Some(p)),
                if unit.is_empty() {
                    "–".into()
                } else {
                    esc(unit)
                },
                cell(map.get(k)),
            ]);
        }
    }
    if rows.is_empty() {
        return String::new();
    }
    String::from("<h3>MAP per parameter</h3>\n")
        + &table(&["model", "parameter", "unit", "MAP"], &rows)
}

fn reversible_jump(s: &Value) -> String {
    let mut d = String::from("<h3>Reversible jump</h3>\n");
    let Some(rj) = at(s, "rj").filter(|v| !v.is_null()) else {
        let why = at(s, "rj_note")
            .and_then(Value::as_str)
            .map_or("no reason recorded".into(), esc);
        d.push_str(&format!(
            "<p class=\"note\">The reversible-jump run did not run: {why}</p>\n"
        ));
        return d;
    };
    let names = list(at(rj, "model_names"));
    let visits = numbers(at(rj, "visits"));
    let total: f64 = visits.iter().filter(|x| x.is_finite()).sum();
    let post = list(at(s, "posterior_model_probabilities"));
    let rows: Vec<Vec<String>> = names
        .iter()
        .enumerate()
        .map(|(k, n)| {
            let v = visits.get(k).copied().unwrap_or(f64::NAN);
            let visit_html = if v == 0.0 {
                bad("0 (never visited)".into())
            } else if total > 0.0 {
                format!(
                    "{} ({})",
                    cell(list(at(rj, "visits")).get(k)),
                    sig(v / total)
                )
            } else {
                cell(list(at(rj, "visits")).get(k))
            };
            vec![
                cell(Some(n)),
                cell(list(at(rj, "prior_model_probs")).get(k)),
                visit_html,
                cell(list(at(rj, "in_model_acceptance")).get(k)),
                cell(list(at(rj, "sojourns")).get(k)),
                cell(post.get(k)),
            ]
        })
        .collect();
    d.push_str(&table(
        &[
            "model",
            "prior probability",
            "visits (fraction)",
            "in-model acceptance",
            "sojourns",
            "posterior probability (reference ln B)",
        ],
        &rows,
    ));
    let mut jump_rows = Vec::new();
    let prop = list(at(rj, "jumps_proposed"));
    let acc = list(at(rj, "jumps_accepted"));
    for (k, from) in names.iter().enumerate() {
        for (l, to) in names.iter().enumerate() {
            if k == l {
                continue;
            }
            let p = prop.get(k).and_then(|r| r.get(l));
            let a = acc.get(k).and_then(|r| r.get(l));
            jump_rows.push(vec![
                format!("{} → {}", cell(Some(from)), cell(Some(to))),
                jumps(a, p),
            ]);
        }
    }
    d.push_str(&table(&["jump", "accepted of proposed (rate)"], &jump_rows));
    d.push_str(&facts(&[
        ("iterations", cell(at(rj, "n_iter"))),
        ("chains", cell(at(rj, "n_chains"))),
        ("burn-in", cell(at(rj, "burn_in"))),
        ("defensive weight", cell(at(rj, "defensive"))),
        ("regeneration units", cell(at(rj, "regeneration_units"))),
        ("non-finite ln posterior", cell(at(rj, "non_finite"))),
        ("likelihood calls", cell(at(rj, "likelihood_calls"))),
        (
            "iterations per second",
            cell(at(s, "rj_iterations_per_second")),
        ),
    ]));
    d
}

/// Facts, warnings and diagnostics of a select run's summary `s`. `in_table`: the run's table
/// file (`table.md`, shown under Results) holds the estimator table and each model's parameter
/// estimates (every run since those were added to the summary), so they are not repeated here.
pub fn parts(s: &Value, in_table: bool) -> Parts {
    let mut p = Parts::default();
    let names: Vec<String> = list(at(s, "models"))
        .iter()
        .map(|m| cell(at(m, "name")))
        .collect();
    p.facts = vec![
        ("models", names.join(", ")),
        ("data", cell(at(s, "origin"))),
        ("statistic", cell(at(s, "statistic"))),
        ("bins in band", cell(at(s, "n_bins"))),
        ("ρ_opt (analysis noise)", cell(at(s, "rho_opt"))),
        ("ρ_opt (simulation)", cell(at(s, "rho_opt_simulated"))),
        ("Schwarz n", cell(at(s, "schwarz_n"))),
        ("took (s)", cell(at(s, "seconds"))),
    ];
    if let Some(t) = at(s, "target").filter(|v| !v.is_null()) {
        let rounds = list(at(t, "rounds"));
        let mut line = format!(
            "± {}: reached ± {} with {} reversible-jump iterations ({} rounds; budget {})",
            cell(at(t, "target")),
            cell(at(t, "reached")),
            cell(rounds.last().and_then(|r| at(r, "iterations"))),
            rounds.len(),
            cell(at(t, "budget"))
        );
        if let Some(n) = at(t, "note").and_then(Value::as_str) {
            line.push_str(&format!(" — not met: {}", esc(n)));
        }
        p.facts.push(("target error", line));
    }
    if let Some(c) = at(s, "cross_checks").and_then(Value::as_str) {
        p.facts.push(("cross-checks", esc(c)));
    }
    p.warnings.collect(s, "summary.json");
    if let Some(n) = at(s, "rj_note").and_then(Value::as_str) {
        p.warnings.add(n, "summary.json (rj_note)");
    }
    // the MAP is a column of the table file's estimates, when the summary has them
    let estimated = list(at(s, "models"))
        .iter()
        .any(|m| at(m, "estimates").is_some());
    let maps = if in_table && estimated {
        String::new()
    } else {
        map_values(s)
    };
    p.diagnostics = pairs(s, in_table) + &models(s, in_table) + &maps + &reversible_jump(s);
    p
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn never_visited_models_zero_jumps_and_missing_rj_are_shown() {
        let s = json!({
            "models": [{"name": "X", "tempering": null, "map_at_bound": ["a_df"]},
                       {"name": "<Y>", "tempering": {"betas": [0, 1], "swap_acceptance": [0.0]}}],
            "pairs": [{"x": "X", "y": "<Y>", "jumps": {"accepted_x_to_y": 0, "proposed_x_to_y": 10},
                       "estimates": [{"method": "RJMCMC visits", "ln_b": null,
                                      "note": "a model was never visited"}]}],
            "rj": {"model_names": ["X", "<Y>"], "visits": [10, 0],
                   "jumps_proposed": [[0, 10], [0, 0]], "jumps_accepted": [[0, 0], [0, 0]]},
            "warnings": []
        });
        let p = parts(&s, false);
        let d = &p.diagnostics;
        assert!(d.contains("X against &lt;Y&gt;"), "{d}");
        assert!(d.contains("0 (never visited)"));
        assert!(d.contains("<span class=\"bad\">0 of 10 (0)</span>"), "{d}");
        assert!(d.contains("a model was never visited"));
        assert!(d.contains("Parallel tempering") && d.contains("<span class=\"bad\">0</span>"));
        assert!(!d.contains("<Y>"));
        let s = json!({"rj": null, "rj_note": "one model <only>"});
        let p = parts(&s, false);
        assert!(
            p.diagnostics
                .contains("did not run: one model &lt;only&gt;")
        );
        assert_eq!(p.warnings.0[0].text, "one model <only>");
    }

    #[test]
    fn each_models_parameter_estimates_are_a_table() {
        let s = json!({"models": [
            {"name": "X", "estimates": [{"name": "dt1", "unit": "s", "map": 0.25, "mean": 0.3,
                                          "sd": 0.2, "fisher_sigma": 0.31}]},
            {"name": "Y", "estimates": [{"name": "a_df", "map": 0.8, "mean": null, "sd": null,
                                          "fisher_sigma": null}]}]});
        let d = parts(&s, false).diagnostics;
        assert!(d.contains("Parameter estimates of each model"), "{d}");
        assert!(
            d.contains(
                "<td>X</td><td>dt1</td><td>0.2500</td><td>0.3000</td><td>0.2000</td><td>0.3100</td><td>s</td>"
            ),
            "{d}"
        );
        assert!(
            d.contains("<td>Y</td><td>a_df</td><td>0.8000</td><td>–</td>"),
            "{d}"
        );
        // a run that predates the estimates has no such table
        assert!(
            !parts(&json!({"models": [{"name": "X"}]}), false)
                .diagnostics
                .contains("Parameter estimates")
        );
    }

    #[test]
    fn with_the_table_file_shown_the_estimates_and_estimators_are_not_repeated() {
        let s = json!({
            "models": [{"name": "X", "params": ["dt1"], "map": [0.25], "estimates": [
                {"name": "dt1", "unit": "s", "map": 0.25, "mean": 0.3, "sd": 0.2,
                 "fisher_sigma": 0.31}]}],
            "pairs": [{"x": "X", "y": "Y", "jumps": {"accepted_x_to_y": 3, "proposed_x_to_y": 10},
                       "estimates": [{"method": "RJMCMC visits", "ln_b": 1.0,
                                      "note": "a note only the table shows"}]}]});
        let d = parts(&s, true).diagnostics;
        assert!(!d.contains("Parameter estimates of each model"), "{d}");
        assert!(!d.contains("MAP per parameter"), "{d}");
        assert!(!d.contains("a note only the table shows"), "{d}");
        assert!(d.contains("under Results"), "{d}");
        // the pair's jumps are only here
        assert!(d.contains("3 of 10"), "{d}");
        let full = parts(&s, false).diagnostics;
        assert!(full.contains("Parameter estimates of each model"));
        assert!(full.contains("a note only the table shows"));
    }

    #[test]
    fn each_models_map_is_listed_per_parameter_with_its_unit() {
        let s = json!({"models": [{"name": "m", "params": ["k", "g"], "units": ["s⁻²", ""],
                                   "map": [-1.3e-6, 0.8]}]});
        let d = parts(&s, false).diagnostics;
        assert!(d.contains("MAP per parameter"), "{d}");
        assert!(d.contains("<td>k</td><td>s⁻²</td>"), "{d}");
        assert!(d.contains("<td>g</td><td>–</td>"), "{d}");
    }

    #[test]
    fn an_empty_summary_gives_a_page_not_a_panic() {
        let p = parts(&json!({}), false);
        assert!(p.diagnostics.contains("did not run: no reason recorded"));
    }
}
