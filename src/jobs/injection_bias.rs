//! The bias an injection missing inside gaps causes, predicted at the fit's MAP.
//!
//! A telemetry gap drops the injection's read-back too. Without the experiment's design the
//! loop's response to what the injection did inside the gap is unknown, rings into the next
//! run, and the gaps' edge correction cannot remove it (docs: "Real data: gaps"). Its effect
//! on the estimates is predicted here: the injection is continued through each such gap by
//! linear prediction from both sides ([`crate::signal::prediction`]: exact for sines of
//! constant frequency, a plausible continuation otherwise), the likelihood is built again with
//! it, and its MAP `θ̂₂` is found by Fisher scoring in the prior box (the fit's own search)
//! from the fit's MAP `θ̂`. The bias is `θ̂ − θ̂₂`, in Cramér–Rao σ: how far the reported
//! estimate is from the one the injection, known, would give. Both are MAPs in the prior box:
//! with the injection missing the likelihood's maximum may lie outside it (on Table I's data
//! with gaps inside the tones, at `dt2` 4 000 σ below the reported MAP on the bound `dt2` = 0),
//! and at low SNR the MAP may sit on bounds of the box (a posterior wider than the box), where
//! an unconstrained search would not converge.
//!
//! It is an estimate, not a correction: where the injection changed inside a gap (a sine
//! train's tone ending or starting there), the continuation is not what was commanded. On
//! Table I's data it matched the shift the design removes to 1e−4 with every gap inside a
//! tone, and to 5 % (`dt1`) or better with eight gaps of which one ends a tone
//! (`cargo test --release --test gaps blanked`).

use crate::config::Study;
use crate::data::dataset::Dataset;
use crate::jobs::prepare::{AnalysisError, likelihood_at, missing_injections, spectra_options};
use crate::likelihood::{Likelihood, fisher_scoring};
use serde::Serialize;

/// A predicted bias above this many σ makes a fit invalid ([`crate::jobs::validity`]).
pub const BIAS_LIMIT: f64 = 0.2;

/// Highest order of the recursion an injection is continued with: two sinusoids (a sine
/// train's tone, and the next one where the gap straddles a change).
const ORDER: usize = 4;
/// Longest stretch (s) beside a gap the recursion is fitted to: a few periods of the slowest
/// ladder tone (1 mHz) without reaching far into the neighbouring tones of a sine train.
const FIT_SECONDS: f64 = 2000.0;
/// The MAP search with the injection continued: the fit's convergence criterion (steps below
/// 1e−3 Cramér–Rao σ) and iteration cap ([`crate::jobs::prepare::MAP_MAX_ITER`]).
const SCORING_TOL: f64 = 1e-3;
const SCORING_ITER: usize = crate::jobs::prepare::MAP_MAX_ITER;

/// What [`predict`] found: which injections were continued where, and the bias per free
/// parameter.
#[derive(Debug, Clone, Serialize, serde::Deserialize)]
pub struct InjectionBias {
    /// Per experiment with such gaps: which injections were continued, in how many gaps.
    pub experiments: Vec<MissingIn>,
    /// The predicted bias `θ̂ − θ̂_filled` of each free parameter, in its Cramér–Rao σ, by
    /// name.
    pub sigma: Vec<(String, f64)>,
}

/// The injections of one experiment continued through its gaps ([`InjectionBias`]).
#[derive(Debug, Clone, Serialize, serde::Deserialize)]
pub struct MissingIn {
    pub experiment: String,
    pub channels: Vec<String>,
    /// The gaps in which some of them run beside the gap.
    pub gaps: usize,
}

impl InjectionBias {
    /// The largest |bias| (σ) and its parameter.
    pub fn worst(&self) -> Option<(&str, f64)> {
        self.sigma
            .iter()
            .map(|(n, b)| (n.as_str(), b.abs()))
            .max_by(|a, b| a.1.total_cmp(&b.1))
    }

    /// The line a fit reports: the reason it is invalid when the bias exceeds [`BIAS_LIMIT`],
    /// else a note.
    pub fn line(&self) -> String {
        let mut by: Vec<&(String, f64)> = self.sigma.iter().collect();
        by.sort_by(|a, b| b.1.abs().total_cmp(&a.1.abs()));
        let listed: Vec<String> = by
            .iter()
            .filter(|(_, b)| b.abs() > BIAS_LIMIT)
            .map(|(n, b)| format!("`{n}` {b:+.2}σ"))
            .collect();
        let wher: Vec<String> = self
            .experiments
            .iter()
            .map(|m| {
                let c: Vec<String> = m.channels.iter().map(|c| format!("`{c}`")).collect();
                format!(
                    "{} in {} gap(s) of `{}`",
                    c.join(", "),
                    m.gaps,
                    m.experiment
                )
            })
            .collect();
        let how = "predicted by continuing the injection through the gaps by linear prediction — exact for a sine of constant frequency, an estimate where it changed inside a gap";
        match self.worst() {
            Some((_, w)) if w > BIAS_LIMIT => format!(
                "the injection missing inside gaps ({}) biases the estimates: {} ({how}); supply the commanded injection through the gaps, or give the experiment's design beside its data (docs: \"Real data: gaps\")",
                wher.join("; "),
                listed.join(", ")
            ),
            Some((n, w)) => format!(
                "the injection missing inside gaps ({}) biases the estimates by at most {w:.2}σ (`{n}`), below {BIAS_LIMIT}σ ({how})",
                wher.join("; ")
            ),
            None => String::new(),
        }
    }
}

/// Whether some gap of `dataset` misses an injection active beside it ([`predict`] has work).
pub fn applies(study: &Study, dataset: &Dataset) -> bool {
    let opts = spectra_options(study);
    dataset
        .experiments
        .iter()
        .any(|e| !missing_injections(study, e, &opts).is_empty())
}

/// The bias of the fit at `map` (over `free`, with Cramér–Rao σ `cr`) caused by injections
/// missing inside gaps of `dataset` (module docs); `None` when no gap misses an active
/// injection. `exact` is the fit's likelihood of model `mi`, built with
/// its residual noise and edge correction at `reference`.
#[allow(clippy::too_many_arguments)]
pub fn predict(
    study: &Study,
    mi: usize,
    dataset: &Dataset,
    exact: &Likelihood,
    reference: &[f64],
    map: &[f64],
    free: &[usize],
    cr: &[f64],
) -> Result<Option<InjectionBias>, AnalysisError> {
    let opts = spectra_options(study);
    let hots: Vec<_> = dataset
        .experiments
        .iter()
        .map(|e| missing_injections(study, e, &opts))
        .collect();
    if hots.iter().all(Vec::is_empty) {
        return Ok(None);
    }
    let mut filled = dataset.clone();
    let mut experiments = Vec::new();
    for (e, hot) in filled.experiments.iter_mut().zip(hots) {
        if hot.is_empty() {
            continue;
        }
        let mut channels: Vec<String> = hot.iter().flat_map(|(_, c)| c.clone()).collect();
        channels.sort();
        channels.dedup();
        let fit_len = (FIT_SECONDS * e.fs).round() as usize;
        for c in &channels {
            let given = e.channel(c).expect("listed from the experiment");
            let mut x = given.to_vec();
            crate::signal::prediction::predict_through_gaps(&mut x, &e.gaps, ORDER, fit_len);
            // only where it runs beside the gap: elsewhere it was quiet, as the data say
            for (j, g) in e.gaps.iter().enumerate() {
                if !hot.iter().any(|(h, cs)| *h == j && cs.contains(c)) {
                    x[g[0]..g[1]].copy_from_slice(&given[g[0]..g[1]]);
                }
            }
            e.set_channel(c, x);
            e.known_in_gaps.push(c.clone());
        }
        experiments.push(MissingIn {
            experiment: e.name.clone(),
            channels,
            gaps: hot.len(),
        });
    }
    let other = likelihood_at(study, mi, &filled, reference)?;
    let not_known = |m: String| {
        AnalysisError::Likelihood(format!(
            "with the injection continued through the gaps, {m}; the bias is not known — supply the commanded injection through the gaps"
        ))
    };
    let found = fisher_scoring(&other, map, free, SCORING_TOL, SCORING_ITER)
        .map_err(|e| not_known(format!("the MAP search failed: {e}")))?;
    if !found.converged {
        return Err(not_known(format!(
            "the MAP search did not converge in {SCORING_ITER} iterations"
        )));
    }
    let there = found.theta;
    let names = exact.model().param_names();
    let sigma = free
        .iter()
        .enumerate()
        .map(|(k, &i)| (names[i].clone(), (map[i] - there[i]) / cr[k]))
        .collect();
    Ok(Some(InjectionBias { experiments, sigma }))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bias(sigma: &[(&str, f64)]) -> InjectionBias {
        InjectionBias {
            experiments: vec![MissingIn {
                experiment: "inv1".into(),
                channels: vec!["i1".into()],
                gaps: 3,
            }],
            sigma: sigma.iter().map(|(n, b)| (n.to_string(), *b)).collect(),
        }
    }

    #[test]
    fn the_line_lists_what_exceeds_the_limit_largest_first() {
        let b = bias(&[("w1sq", -0.1), ("dt2", 2.5), ("a_sus", -40.0)]);
        assert_eq!(b.worst(), Some(("a_sus", 40.0)));
        let l = b.line();
        assert!(l.contains("`i1` in 3 gap(s) of `inv1`"), "{l}");
        assert!(l.contains("`a_sus` -40.00σ, `dt2` +2.50σ ("), "{l}");
        assert!(!l.contains("w1sq"), "{l}");
        assert!(l.contains("supply the commanded injection"), "{l}");
        let small = bias(&[("w1sq", -0.1), ("dt2", 0.15)]).line();
        assert!(
            small.contains("by at most 0.15σ (`dt2`), below 0.2σ"),
            "{small}"
        );
        assert!(!small.contains("supply"), "{small}");
    }
}
