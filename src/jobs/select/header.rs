//! The first lines of a select run's output: which models were compared and what differs
//! between them, then the answer — the preferred model, the reference `ln B` of each pair
//! with the preferred model, and the posterior model probabilities by name — so that a reader
//! has it before the table of every estimator (one row per estimator and pair: over two
//! hundred rows for seven models).

use super::outcome::ModelOutcome;
use super::pair::PairResult;
use super::summary::SelectSummary;
use crate::report::{Table, fmt_bayes_factor, fmt_fixed, fmt_pm, fmt_short, fmt_sig};

/// The header: the models, then the answer.
pub fn header(s: &SelectSummary) -> Vec<String> {
    let mut out = models(&s.models);
    out.extend(answer(s));
    out
}

/// `a, b and c`.
fn list(names: &[String]) -> String {
    match names {
        [] => String::new(),
        [one] => one.clone(),
        [rest @ .., last] => format!("{} and {last}", rest.join(", ")),
    }
}

/// A value with its unit.
fn with_unit(v: f64, unit: &str) -> String {
    if unit.is_empty() {
        fmt_sig(v, 4)
    } else {
        format!("{} {unit}", fmt_sig(v, 4))
    }
}

/// One line per model: its parent model, the free parameters it has beyond those every model
/// shares, and what it fixes.
fn models(models: &[ModelOutcome]) -> Vec<String> {
    let shared: Vec<String> = models
        .first()
        .map(|m| {
            m.free
                .iter()
                .filter(|p| models.iter().all(|o| o.free.contains(p)))
                .cloned()
                .collect()
        })
        .unwrap_or_default();
    let mut out = vec![format!(
        "models compared: {}{}",
        models.len(),
        if models.len() > 1 && !shared.is_empty() {
            format!("; all have {} free", list(&shared))
        } else {
            String::new()
        }
    )];
    let width = models
        .iter()
        .map(|m| m.name.chars().count())
        .max()
        .unwrap_or(0);
    for m in models {
        let own: Vec<String> = m
            .free
            .iter()
            .filter(|p| !shared.contains(p))
            .cloned()
            .collect();
        let fixed: Vec<String> = m
            .params
            .iter()
            .zip(&m.map)
            .enumerate()
            .filter(|(_, (p, _))| !m.free.contains(p))
            .map(|(i, (p, v))| {
                let unit = m.units.get(i).map_or("", String::as_str);
                format!("{p} = {}", with_unit(*v, unit))
            })
            .collect();
        let mut parts = vec![format!(
            "{} free parameter{} of model `{}`",
            m.free.len(),
            if m.free.len() == 1 { "" } else { "s" },
            m.model
        )];
        if models.len() > 1 && !shared.is_empty() {
            if !own.is_empty() {
                parts.push(format!("also {} free", list(&own)));
            }
        } else if !m.free.is_empty() {
            parts.push(format!("{} free", list(&m.free)));
        }
        if !fixed.is_empty() {
            parts.push(format!("fixes {}", list(&fixed)));
        }
        out.push(format!(
            "  {:<width$}  {}",
            m.name,
            parts.join("; "),
            width = width
        ));
    }
    out
}

/// `ln B_XY = -1.205 ± 0.007 (B_XY = 2.9970e-1, RJMCMC bridge)` of a pair's reference row.
fn reference_value(p: &PairResult) -> Option<String> {
    let e = p.estimates.iter().find(|e| e.method == p.reference)?;
    let lb = e.ln_b?;
    let pm = match e.std_err {
        Some(se) => format!("{} ± {}", fmt_fixed(lb, 3), fmt_fixed(se, 3)),
        None => fmt_fixed(lb, 3),
    };
    Some(format!(
        "ln B({}/{}) = {pm} (B = {}, {})",
        p.x,
        p.y,
        fmt_bayes_factor(lb),
        p.reference
    ))
}

/// Whether a pair's estimators agree, in words.
fn agreement(p: &PairResult) -> String {
    let stat = if p.all_agree {
        "the statistical estimators agree".to_string()
    } else {
        let off: Vec<String> = p
            .estimates
            .iter()
            .filter(|e| e.agrees == Some(false) && e.kind == super::pair::EstimateKind::Statistical)
            .map(|e| {
                if super::pair::is_one_sided(e) {
                    format!("{}, one-sided", e.method)
                } else {
                    e.method.clone()
                }
            })
            .collect();
        format!(
            "the statistical estimators DISAGREE beyond their errors ({} against {})",
            off.join("; "),
            p.reference
        )
    };
    match p.systematic_agree {
        Some(true) => format!("{stat}, the Laplace estimates are within 1 nat"),
        Some(false) => format!("{stat}, a Laplace estimate is more than 1 nat off"),
        None => stat.to_string(),
    }
}

/// A posterior probability: four decimals, or `< 0.0001`.
fn prob(p: f64) -> String {
    if p < 5e-5 {
        "< 0.0001".into()
    } else {
        format!("{p:.4}")
    }
}

/// The answer: the preferred model and how sure the run is of it.
fn answer(s: &SelectSummary) -> Vec<String> {
    let mut out = Vec::new();
    let names: Vec<&str> = s.models.iter().map(|m| m.name.as_str()).collect();
    let best = s.posterior_model_probabilities.as_ref().and_then(|pp| {
        pp.iter()
            .enumerate()
            .filter(|(_, p)| p.is_finite())
            .max_by(|a, b| a.1.total_cmp(b.1))
            .map(|(i, p)| (names[i], *p))
    });
    match (s.pairs.as_slice(), best) {
        ([p], _) => {
            out.push(format!(
                "answer: {} preferred ({})",
                p.preferred, p.kass_raftery
            ));
            if let Some(v) = reference_value(p) {
                out.push(format!("  {v}; {}", agreement(p)));
            }
        }
        (_, Some((b, pb))) => {
            out.push(format!(
                "answer: {b} preferred (posterior probability {})",
                prob(pb)
            ));
            for p in s.pairs.iter().filter(|p| p.x == b || p.y == b) {
                match reference_value(p) {
                    Some(v) => out.push(format!("  {v}: {}; {}", p.kass_raftery, agreement(p))),
                    None => out.push(format!("  {}/{}: no estimate", p.x, p.y)),
                }
            }
        }
        (_, None) => {
            out.push("answer: no model can be named: a pair has no reference estimate (see the table's notes)".into());
            for p in &s.pairs {
                if let Some(v) = reference_value(p) {
                    out.push(format!("  {v}: {}", p.kass_raftery));
                }
            }
        }
    }
    if let Some(pp) = &s.posterior_model_probabilities {
        let mut order: Vec<usize> = (0..pp.len()).collect();
        order.sort_by(|&a, &b| pp[b].total_cmp(&pp[a]));
        let parts: Vec<String> = order
            .iter()
            .map(|&i| format!("{} {}", names[i], prob(pp[i])))
            .collect();
        out.push(format!(
            "posterior model probabilities (prior {}): {}",
            prior_text(&s.models),
            parts.join(", ")
        ));
    }
    out
}

/// The prior model probabilities: `equal` when they are, else each by name.
fn prior_text(models: &[ModelOutcome]) -> String {
    let first = models.first().map_or(0.0, |m| m.prior_probability);
    if models.iter().all(|m| m.prior_probability == first) {
        "equal".into()
    } else {
        models
            .iter()
            .map(|m| format!("{} {}", m.name, fmt_short(m.prior_probability)))
            .collect::<Vec<_>>()
            .join(", ")
    }
}

/// Each model's parameter estimates: MAP, posterior mean ± sd of its in-model chains, and the
/// Cramér–Rao σ at the MAP, one row per model and free parameter.
pub fn estimates_table(s: &SelectSummary) -> Table {
    let mut t = Table::new(["model", "parameter", "MAP", "mean ± sd", "Fisher σ", "unit"]);
    for m in &s.models {
        for e in &m.estimates {
            let pm = match (e.mean, e.sd) {
                (Some(v), Some(sd)) => fmt_pm(v, sd),
                _ => "– (no chains)".into(),
            };
            t.push_row([
                m.name.clone(),
                e.name.clone(),
                if m.map_found {
                    fmt_sig(e.map, 6)
                } else {
                    format!("{} (start: no MAP)", fmt_sig(e.map, 6))
                },
                pm,
                e.fisher_sigma.map_or("– (singular)".into(), fmt_short),
                e.unit.clone(),
            ])
            .expect("row width matches the header");
        }
    }
    t
}
