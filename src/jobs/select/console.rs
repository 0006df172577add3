//! What `occam select` prints when it ends: first the answer (the models, the preferred one,
//! the posterior model probabilities by name), then Table II with its notes, each model's
//! parameter estimates, the verdict per pair, the jumps and the SNR (the command line prints
//! it; the warnings go to standard error separately, merged: [`crate::report::group_warnings`]).

use super::output::{table, table_notes};
use super::summary::SelectSummary;

/// The lines printed after a select run (without its warnings).
pub fn console(s: &SelectSummary) -> String {
    let mut out = crate::jobs::validity::invalid_lines(&s.invalid_reasons);
    out.extend(super::header::header(s));
    out.push(String::new());
    out.push(table(s).to_string());
    out.extend(table_notes(s));
    let estimates = super::header::estimates_table(s);
    if !estimates.rows().is_empty() {
        out.push(String::new());
        out.push("parameter estimates of each model:".into());
        out.push(estimates.to_string());
    }
    let yes_no = |b: bool| if b { "yes" } else { "no" };
    for p in &s.pairs {
        out.push(format!(
            "{}/{}: reference {}; preferred model {} ({}); statistical estimators agree within errors: {}; Laplace estimates within 1 nat: {}",
            p.x,
            p.y,
            p.reference,
            p.preferred,
            p.kass_raftery,
            yes_no(p.all_agree),
            p.systematic_agree.map_or("–", yes_no)
        ));
    }
    for p in &s.pairs {
        let j = &p.jumps;
        let rate = |a: u64, n: u64| {
            if n == 0 {
                "–".to_string()
            } else {
                format!("{:.3}", a as f64 / n as f64)
            }
        };
        // the counts run over the whole run, burn-in included; the estimators (and the
        // few-jumps warning) use only the jumps after burn-in, so say both
        out.push(format!(
            "jumps {x}→{y}: {} of {} accepted ({}); {y}→{x}: {} of {} ({}); burn-in included — after burn-in {} accepted both ways",
            j.accepted_x_to_y,
            j.proposed_x_to_y,
            rate(j.accepted_x_to_y, j.proposed_x_to_y),
            j.accepted_y_to_x,
            j.proposed_y_to_x,
            rate(j.accepted_y_to_x, j.proposed_y_to_x),
            j.effective_jumps,
            x = p.x,
            y = p.y,
        ));
    }
    out.extend(super::output::run_lines(s));
    let rj = match &s.rj {
        Some(rj) => format!(
            "RJ visits {:?} over {} iterations in {} chains ({:.0} iterations/s)",
            rj.visits, rj.n_iter, rj.n_chains, s.rj_iterations_per_second
        ),
        None => "no RJ run".into(),
    };
    let rho = |r: f64| {
        if r.is_finite() {
            format!("{r:.4e}")
        } else {
            "–".into()
        }
    };
    out.push(format!(
        "rho_opt = {} (simulation noise model), {} (analysis noise estimate); {rj}",
        s.rho_opt_simulated.map_or("–".into(), rho),
        rho(s.rho_opt),
    ));
    // how long each model's chains ran: past `[select] iterations` where they had not
    // converged by then
    let ran: Vec<String> = s
        .models
        .iter()
        .filter_map(|m| m.mcmc_iterations.map(|n| format!("{} {n}", m.name)))
        .collect();
    if !ran.is_empty() {
        out.push(format!(
            "in-model chains: {} iterations per chain, burn-in included",
            ran.join(", ")
        ));
    }
    out.push(format!("ln L statistic: {}", s.statistic.name()));
    for n in s.noise_averages.iter().flatten() {
        let d: Vec<String> = n
            .decades
            .iter()
            .map(|d| {
                format!(
                    "[{:.0e}, {:.0e}) Hz {:.1}–{:.1}",
                    d.band[0], d.band[1], d.m_eff_min, d.m_eff_max
                )
            })
            .collect();
        out.push(format!(
            "noise reference `{}`, effective Welch averages per decade: {}",
            n.experiment,
            d.join("; ")
        ));
    }
    out.join("\n")
}
