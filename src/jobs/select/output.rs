//! The Table II layout and the files of a select run.

use super::error::SelectError;
use super::pair::EstimateKind;
use super::summary::SelectSummary;
use crate::report::{Table, fmt_bayes_factor, fmt_fixed};
use std::path::Path;

/// The Table II layout: one row per estimator, for each pair. `B_XY` is a power of ten
/// (`10^868.6`) where `exp(ln B)` leaves the range of `f64` ([`fmt_bayes_factor`]). A row's
/// note is a marker (`[2]`) whose full text [`table_notes`] lists, each distinct text once:
/// the notes say why a row cannot be trusted, so they are never cut.
pub fn table(s: &SelectSummary) -> Table {
    table_parts(s, false).0
}

/// The notes the markers of [`table`] stand for, `[1] …` in order.
pub fn table_notes(s: &SelectSummary) -> Vec<String> {
    table_parts(s, false)
        .1
        .iter()
        .enumerate()
        .map(|(i, n)| format!("[{}] {n}", i + 1))
        .collect()
}

/// A row's note: why there is no number, or what a systematic row assumes.
fn row_note(e: &super::pair::PairEstimate) -> String {
    e.note
        .clone()
        .or_else(|| e.assumes.as_ref().map(|a| format!("assumes {a}")))
        .unwrap_or_default()
}

/// The table with each note as a marker into the returned list (`full`: the whole text in
/// the cell instead, for Markdown, which wraps it).
fn table_parts(s: &SelectSummary, full: bool) -> (Table, Vec<String>) {
    let mut t = Table::new([
        "pair",
        "estimator",
        "B_XY",
        "ln B_XY",
        "± σ",
        "agrees",
        "note",
    ]);
    let mut notes: Vec<String> = Vec::new();
    for p in &s.pairs {
        for e in &p.estimates {
            let b = e.ln_b.map_or("–".into(), fmt_bayes_factor);
            let lb = e.ln_b.map_or("–".into(), |v| fmt_fixed(v, 3));
            let se = match (e.kind, e.std_err, e.ln_b) {
                (_, Some(v), _) => fmt_fixed(v, 3),
                (EstimateKind::Systematic, None, Some(_)) => "systematic".into(),
                (EstimateKind::Criterion, None, Some(_)) => "O(1)".into(),
                _ => "–".into(),
            };
            let ag = e
                .agrees
                .map_or("–".into(), |a| if a { "yes" } else { "no" }.to_string());
            let note = row_note(e);
            let note = if full || note.is_empty() {
                note
            } else {
                let k = match notes.iter().position(|n| *n == note) {
                    Some(k) => k,
                    None => {
                        notes.push(note);
                        notes.len() - 1
                    }
                };
                format!("[{}]", k + 1)
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
    (t, notes)
}

/// `table.txt` (`markdown` false) or `table.md`: the header (models, answer), the table with
/// its notes, each model's parameter estimates and how the run was sized.
pub fn document(s: &SelectSummary, markdown: bool) -> String {
    let header = super::header::header(s);
    let estimates = super::header::estimates_table(s);
    let below = run_lines(s);
    let mut out = String::new();
    if markdown {
        for l in &header {
            match l.strip_prefix("  ") {
                Some(rest) => out.push_str(&format!("    - {rest}\n")),
                None => out.push_str(&format!("- {l}\n")),
            }
        }
        out.push('\n');
        out.push_str(&table_parts(s, true).0.to_markdown());
        if !estimates.rows().is_empty() {
            out.push_str("\nParameter estimates of each model:\n\n");
            out.push_str(&estimates.to_markdown());
        }
    } else {
        for l in &header {
            out.push_str(l);
            out.push('\n');
        }
        out.push('\n');
        out.push_str(&table(s).to_text());
        for n in table_notes(s) {
            out.push_str(&n);
            out.push('\n');
        }
        if !estimates.rows().is_empty() {
            out.push_str("\nparameter estimates of each model:\n");
            out.push_str(&estimates.to_text());
        }
    }
    for l in below {
        out.push_str(&format!("\n{l}\n"));
    }
    out
}

/// The lines below the table that say how the run was sized, when it was not by fixed
/// lengths and full cross-checks: the target error with what was reached and the budget, and
/// the cross-checks' share.
pub fn run_lines(s: &SelectSummary) -> Vec<String> {
    let mut out = Vec::new();
    if let Some(t) = &s.target {
        out.push(t.line());
    }
    match s.cross_checks {
        crate::config::CrossChecks::Full => {}
        crate::config::CrossChecks::Light => out.push(
            "cross-checks light: thermodynamic integration and stepping-stone ran a quarter of pt_iterations".into(),
        ),
        crate::config::CrossChecks::Off => out.push(
            "cross-checks off: no tempering (thermodynamic integration, stepping-stone)".into(),
        ),
    }
    out
}

/// What a select directory held before `manifest.json` existed: the files a new run removes
/// when it does not write them itself ([`crate::data::rundir::RunDir::publish`]).
pub const LEGACY_OUTPUTS: &[&str] = &[
    "summary.json",
    "table.txt",
    "table.md",
    "residual_psd.npz",
    "residual_psd_*.png",
    "residual_psd_*.svg",
    "bayes_factor.png",
    "bayes_factor.svg",
    "bayes_factor_*.png",
    "bayes_factor_*.svg",
    "chains_*.npz",
    "rj_chain.npz",
    "model_visits.png",
    "model_visits.svg",
    // `occam report` records its page in the manifest; in an older directory only this finds it
    "report.html",
];

/// Writes `summary.json`, `table.txt`, `table.md`, the evolution of B (`bayes_factor`) and the
/// model-visit histogram (`model_visits`), each atomically.
pub fn write_outputs(s: &SelectSummary, out: &Path) -> Result<(), SelectError> {
    let io = |p: &Path, e: std::io::Error| SelectError::Io(format!("{}: {e}", p.display()));
    std::fs::create_dir_all(out).map_err(|e| io(out, e))?;
    let json = serde_json::to_string_pretty(s).expect("summary serialises") + "\n";
    let p = out.join("summary.json");
    crate::atomic::write_bytes(&p, json.as_bytes()).map_err(|e| io(&p, e))?;
    let p = out.join("table.txt");
    crate::atomic::write_bytes(&p, document(s, false).as_bytes()).map_err(|e| io(&p, e))?;
    let p = out.join("table.md");
    crate::atomic::write_bytes(&p, document(s, true).as_bytes()).map_err(|e| io(&p, e))?;
    crate::report::residual_psd::write(out, &s.residual_psd)?;
    crate::report::bode::write(out, &s.bode)?;
    crate::report::raw::write(out, &s.raw)?;
    for (name, chains) in &s.model_chains {
        if let Some(c) = chains {
            let p = out.join(chains_file(name));
            crate::data::npz_write::write_npz_file(&p, &crate::jobs::chains_npz::chains_arrays(c))
                .map_err(|e| io(&p, e))?;
        }
    }
    let Some(rj) = &s.rj else {
        return Ok(());
    };
    if let Some(d) = &rj.draws {
        let p = out.join("rj_chain.npz");
        crate::data::npz_write::write_npz_file(&p, &rj_chain_arrays(d)).map_err(|e| io(&p, e))?;
    }
    for fig in fig2(rj) {
        let pair = (fig.pair.0.as_str(), fig.pair.1.as_str());
        crate::report::running_bayes_factor(out, &fig.stem, &fig.title, pair, &fig.series)?;
    }
    let labels: Vec<String> = s.models.iter().map(|m| m.name.clone()).collect();
    let counts: Vec<f64> = rj.visits.iter().map(|&v| v as f64).collect();
    crate::report::model_histogram(out, "model_visits", &labels, &counts)?;
    Ok(())
}

/// The file of model `name`'s in-model chains. Model names are 1–64 of `[A-Za-z0-9_.+-]`
/// (`crate::config::check_name`), so the name goes in as it is.
pub fn chains_file(name: &str) -> String {
    format!("chains_{name}.npz")
}

/// The arrays of `rj_chain.npz`: `model_index` (chains × draws, into `model_names`),
/// `model_names`, `param_names` (the union of the models' parameters), `samples` (chains ×
/// draws × parameters, NaN where the current model has no such parameter), `ln_likelihood`
/// (chains × draws) and `thin` (0-d: every `thin`-th post-burn-in iteration is kept).
pub fn rj_chain_arrays(d: &crate::evidence::RjDraws) -> Vec<crate::data::npz_write::NpyArray> {
    use crate::data::npz_write::{NpyArray, NpyData};
    let (c, n, p) = (d.n_chains, d.n_draws, d.param_names.len());
    vec![
        NpyArray::new("model_index", &[c, n], NpyData::I64(d.model_index.clone())),
        NpyArray::new(
            "model_names",
            &[d.model_names.len()],
            NpyData::Str(d.model_names.clone()),
        ),
        NpyArray::new("param_names", &[p], NpyData::Str(d.param_names.clone())),
        NpyArray::new("samples", &[c, n, p], NpyData::F64(d.samples.clone())),
        NpyArray::new(
            "ln_likelihood",
            &[c, n],
            NpyData::F64(d.ln_likelihood.clone()),
        ),
        NpyArray::new("thin", &[], NpyData::I64(vec![d.thin as i64])),
    ]
}

/// One Fig. 2 panel: the running estimates of one pair.
pub struct Fig2 {
    /// `bayes_factor` with two models, `bayes_factor_<X>_<Y>` per pair with more.
    pub stem: String,
    pub title: String,
    /// The pair `(X, Y)`: ln B = ln Z_X − ln Z_Y.
    pub pair: (String, String),
    pub series: Vec<crate::report::RunningSeries>,
}

/// The Fig. 2 plots of a run: per pair `k < l` its three running estimators. A pair whose
/// estimators have no finite value anywhere is left out (see [`fig2_warnings`]).
pub fn fig2(rj: &crate::evidence::RjResult) -> Vec<Fig2> {
    use crate::report::RunningSeries;
    let names = &rj.model_names;
    let k = names.len();
    let mut out = Vec::new();
    for (i, p) in rj.pairs.iter().enumerate() {
        let (x, y) = (&names[p.k], &names[p.l]);
        let unvisited: Vec<&str> = [p.k, p.l]
            .iter()
            .filter(|&&m| rj.visits[m] == 0)
            .map(|&m| names[m].as_str())
            .collect();
        let pick = |f: &dyn Fn(&crate::evidence::RjRunningPair) -> Option<crate::evidence::LnB>| {
            rj.running
                .iter()
                .map(|pt| {
                    let v = pt.pairs.get(i).and_then(f);
                    (
                        pt.iteration as f64,
                        v.map(|b| (b.ln_b, b.std_err.unwrap_or(f64::NAN))),
                    )
                })
                .collect::<Vec<_>>()
        };
        let visit_name = if unvisited.is_empty() {
            "visit ratio".to_string()
        } else {
            format!(
                "visit ratio (absent: {} never visited)",
                unvisited.join(", ")
            )
        };
        let series = vec![
            RunningSeries {
                name: visit_name,
                points: pick(&|q| q.visits),
            },
            RunningSeries {
                name: "Rao-Blackwell".into(),
                points: pick(&|q| q.rao_blackwell),
            },
            RunningSeries {
                name: "bridge".into(),
                points: pick(&|q| q.bridge),
            },
        ];
        if !series.iter().any(RunningSeries::has_value) {
            continue;
        }
        let mut title = format!("ln B({x}/{y}) along the reversible-jump run");
        if !unvisited.is_empty() {
            title += &format!(" ({} never visited)", unvisited.join(", "));
        }
        out.push(Fig2 {
            stem: if k == 2 {
                "bayes_factor".into()
            } else {
                format!("bayes_factor_{x}_{y}")
            },
            title,
            pair: (x.clone(), y.clone()),
            series,
        });
    }
    out
}

/// Why a pair has no Fig. 2: none of its jump-chain estimators has a value. Returns the
/// warnings and the notes: a pair whose models are too far apart for any jump, and whose answer
/// does not need them (its `note`), misses its figure for the same reason, a fact.
pub fn fig2_warnings(rj: &crate::evidence::RjResult) -> (Vec<String>, Vec<String>) {
    let drawn: Vec<String> = fig2(rj).into_iter().map(|f| f.title).collect();
    let (mut warnings, mut notes) = (Vec::new(), Vec::new());
    for p in &rj.pairs {
        let (x, y) = (&rj.model_names[p.k], &rj.model_names[p.l]);
        let t = format!("ln B({x}/{y}) along");
        if drawn.iter().any(|d| d.starts_with(&t)) {
            continue;
        }
        let line = format!(
            "{x}/{y}: no Fig. 2 (bayes_factor): no reversible-jump estimator (visit ratio, Rao-Blackwell, bridge) has a value at any point of the run"
        );
        if p.note.is_some() {
            notes.push(format!(
                "{line}: the models exchange no jumps (the pair's note)"
            ));
        } else {
            warnings.push(line);
        }
    }
    (warnings, notes)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::jobs::select::{JumpStats, PairEstimate, PairResult};

    fn est(method: &str, ln_b: Option<f64>) -> PairEstimate {
        PairEstimate {
            method: method.into(),
            kind: EstimateKind::Statistical,
            ln_b,
            std_err: ln_b.map(|_| 1e300),
            agrees: None,
            assumes: None,
            note: None,
        }
    }

    #[test]
    fn the_table_prints_overflowing_bayes_factors_as_powers_of_ten() {
        let s = SelectSummary {
            valid: true,
            invalid_reasons: Vec::new(),
            origin: "test".into(),
            rho_opt_simulated: None,
            rho_opt: f64::NAN,
            n_bins: 1,
            statistic: crate::likelihood::Statistic::Whittle,
            noise_averages: None,
            glitch_gates: vec![],
            schwarz_n: 1.0,
            models: vec![],
            pairs: vec![PairResult {
                x: "X".into(),
                y: "Y".into(),
                estimates: vec![
                    est("big", Some(2000.0)),
                    est("small", Some(-2000.0)),
                    est("edge", Some(709.8)),
                    est("plain", Some(-29.9336)),
                    est("none", None),
                ],
                reference: "big".into(),
                preferred: "X".into(),
                kass_raftery: String::new(),
                all_agree: true,
                systematic_agree: None,
                jumps: JumpStats {
                    proposed_x_to_y: 0,
                    accepted_x_to_y: 0,
                    proposed_y_to_x: 0,
                    accepted_y_to_x: 0,
                    effective_jumps: 0,
                    expected_jumps: 0.0,
                    warning: None,
                    note: None,
                },
            }],
            posterior_model_probabilities: None,
            rj: None,
            rj_note: None,
            rj_iterations_per_second: 0.0,
            target: None,
            cross_checks: crate::config::CrossChecks::Full,
            seconds: 0.0,
            warnings: vec![],
            notes: vec![],
            residual_psd: vec![],
            model_chains: vec![],
            bode: vec![],
            raw: vec![],
        };
        let t = table(&s).to_text();
        let cells = |m: &str| -> Vec<String> {
            let l = t.lines().find(|l| l.contains(&format!(" {m} "))).unwrap();
            l.split("  ")
                .map(str::trim)
                .filter(|c| !c.is_empty())
                .map(String::from)
                .collect()
        };
        assert_eq!(
            cells("big")[2..5],
            ["10^868.6", "2000.000", "1.000e300"],
            "{t}"
        );
        assert_eq!(cells("small")[2..4], ["10^-868.6", "-2000.000"], "{t}");
        assert_eq!(cells("edge")[2], "10^308.3", "{t}");
        assert_eq!(cells("plain")[2], "1.0000e-13", "{t}");
        assert!(!t.contains("inf") && !t.contains(" 0.0000e0"), "{t}");
    }
}
