//! The lines `occam fit` prints after a run (the Table I layout, the MAP search, the chains,
//! the glitch count): one place, so that the command line and the Python package's `log`
//! say the same.

use super::output::table;
use super::summary::FitSummary;
use crate::config::{LikelihoodKind, Study};

/// What `occam fit` prints on standard output after the run of `study` summarised by `s`,
/// line by line (its warnings, on standard error, are `s.warnings`).
pub fn console(s: &FitSummary, study: &Study) -> Vec<String> {
    // split, not lines: the table ends with a newline, printed as the blank line after it
    let mut out = crate::jobs::validity::invalid_lines(&s.invalid_reasons);
    out.extend(table(s).to_string().split('\n').map(str::to_string));
    out.push(format!(
        "rho_opt at MAP = {}; MAP found in {} Fisher-scoring iterations ({:.2} s)",
        if s.rho_opt_at_map.is_finite() {
            format!("{:.4e}", s.rho_opt_at_map)
        } else {
            "– (no noiseless input channel)".into()
        },
        s.map_iterations,
        s.seconds_map
    ));
    out.push(format!(
        "MCMC: {} chains × {} iterations{}, {:.0} iterations/s ({} {} likelihood{}), acceptance {:?}",
        s.chains,
        s.converged_at.unwrap_or(study.fit.iterations),
        match (s.converged_at, study.fit.until) {
            (Some(_), Some(u)) => format!(
                " (converged: every ESS ≥ {} and R-hat ≤ {}; at most {})",
                u.ess, u.rhat, study.fit.iterations
            ),
            (None, Some(u)) => format!(
                " (not converged by then: [fit] until asks every ESS ≥ {} and R-hat ≤ {})",
                u.ess, u.rhat
            ),
            _ => String::new(),
        },
        s.iterations_per_second,
        s.statistic.name(),
        match s.likelihood {
            LikelihoodKind::Exact => "exact",
            LikelihoodKind::Relbin => "relative-binned",
        },
        s.n_coarse_bins
            .map_or(String::new(), |n| format!(", {n} coarse bins")),
        s.acceptance
            .iter()
            .map(|a| (a * 100.0).round() / 100.0)
            .collect::<Vec<_>>()
    ));
    if let Some(q) = &s.independence {
        out.push(format!(
            "  {:.0} % of the iterations drew from the Laplace approximation at the MAP; {:.0} % of those after the burn-in were accepted ({} of {})",
            100.0 * q.share,
            100.0 * q.accepted as f64 / q.proposed.max(1) as f64,
            q.accepted,
            q.proposed
        ));
    }
    if let Some(g) = &s.glitch_count {
        out.extend(g.describe());
        out.push("loop parameters marginalised over the number of glitches:".into());
        for r in &g.parameters {
            out.push(crate::jobs::glitch_count::marginal_line(r));
        }
    }
    out
}
