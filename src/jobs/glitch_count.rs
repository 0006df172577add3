//! `[analysis] glitch_count = "rj"`: how many of the modelled glitch candidates are glitches,
//! by the reversible jump ([`crate::sampler::birth_death()`]), with the loop's parameters
//! marginalised over that number.
//!
//! Each candidate the fit carries ([`crate::jobs::glitch_model`]) is a component that is on
//! (its three parameters in the model) or off (its amplitude zero). The birth proposal of a
//! candidate is the Gaussian of its three parameters conditional on the others at the fit's
//! MAP (the inverse of their Fisher block), mixed with its prior ([`PRIOR_MIX`]); block moves
//! use the same conditional covariances, and the loop's parameters one block with theirs. The
//! prior is uniform in the number of glitches (module docs of the sampler). One chain from the
//! MAP with every candidate on; a quarter of the iterations are burn-in.

use crate::config::{DEFAULT_GLITCH_COUNT_ITERATIONS, Study};
use crate::jobs::glitch_model::GlitchCandidate;
use crate::likelihood::Likelihood;
use crate::report::fmt_short;
use crate::sampler::{BirthDeathOptions, Component, Moves, birth_death};
use nalgebra::DMatrix;
use serde::Serialize;
use std::time::Instant;

/// The prior's share of a birth proposal: enough that a birth far from the fit's values (a
/// candidate whose conditional posterior is not Gaussian) has a finite chance and its death a
/// finite ratio, small enough that births near the fit are not diluted.
pub const PRIOR_MIX: f64 = 0.1;

/// One candidate's outcome.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CandidateCount {
    /// `g<j>`.
    pub name: String,
    pub experiment: String,
    /// The detected region (s from the fit stretch's first sample).
    pub region: [f64; 2],
    /// Posterior probability that it is a glitch, and its batch-means error (null when the
    /// chain never switched it after burn-in: then the probability is near 0 or 1, not known
    /// how near).
    pub probability: f64,
    pub error: f64,
    /// `ln(p/(1 − p))` and its error (null where `p` is 0 or 1 or has no error): the scale
    /// whose errors cover when the candidate switched only a few dozen times
    /// ([`crate::sampler::BirthDeathResult::inclusion_log_odds`]).
    pub log_odds: f64,
    pub log_odds_error: f64,
    pub births: Moves,
    pub deaths: Moves,
    /// Posterior mean and sd of `t0`, `tau`, `a` while on (NaN when never on).
    pub mean: [f64; 3],
    pub sd: [f64; 3],
}

/// A loop parameter marginalised over the number of glitches.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MarginalRow {
    pub name: String,
    pub mean: f64,
    pub sd: f64,
    pub truth: Option<f64>,
    /// `(mean − truth)/sd`.
    pub pull: Option<f64>,
}

/// What the reversible jump over the number of glitches found (`summary.json`'s
/// `glitch_count`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GlitchCount {
    pub iterations: usize,
    pub burn_in: usize,
    pub seconds: f64,
    /// `p(k | d)` and its error, `k = 0..=K` glitches.
    pub count: Vec<(f64, f64)>,
    pub candidates: Vec<CandidateCount>,
    pub parameters: Vec<MarginalRow>,
    /// Acceptance of the block moves: the loop's, then each candidate's.
    pub acceptance: Vec<f64>,
}

impl GlitchCount {
    /// The most probable number of glitches.
    pub fn most_probable(&self) -> usize {
        (0..self.count.len())
            .max_by(|&a, &b| self.count[a].0.total_cmp(&self.count[b].0))
            .unwrap_or(0)
    }

    /// Lines for the terminal: the number's posterior, then one line per candidate.
    pub fn describe(&self) -> Vec<String> {
        let k = self.most_probable();
        let probable: Vec<String> = self
            .count
            .iter()
            .enumerate()
            .filter(|(_, (p, _))| *p >= 0.005)
            .map(|(k, (p, e))| format!("{k}: {p:.3} ± {e:.3}"))
            .collect();
        let mut out = vec![format!(
            "glitch count (reversible jump, {} iterations, {} burn-in, {:.0} s): most probable {k} of {} candidates; p(k) {}",
            self.iterations,
            self.burn_in,
            self.seconds,
            self.candidates.len(),
            probable.join(", ")
        )];
        for c in &self.candidates {
            let switched = c.births.accepted + c.deaths.accepted;
            let p = if switched == 0 {
                format!(
                    "{} (never switched after burn-in: it resisted {} {}; the chain says only that p is near {}, not how near)",
                    c.probability,
                    c.births.proposed + c.deaths.proposed,
                    if c.probability > 0.5 {
                        "deaths"
                    } else {
                        "births"
                    },
                    c.probability
                )
            } else {
                format!(
                    "{:.3} ± {:.3}; {} of {} births and {} of {} deaths accepted",
                    c.probability,
                    c.error,
                    c.births.accepted,
                    c.births.proposed,
                    c.deaths.accepted,
                    c.deaths.proposed
                )
            };
            out.push(format!(
                "  {} ({}, {:.0}–{:.0} s): p = {p}",
                c.name, c.experiment, c.region[0], c.region[1]
            ));
        }
        out
    }

    /// Warnings: candidates whose probability rests on few accepted jumps, so that its own
    /// error is not to be trusted ([`FEW_JUMPS`]); one line naming them all.
    pub fn warnings(&self) -> Vec<String> {
        let few: Vec<String> = self
            .candidates
            .iter()
            .filter(|c| {
                let n = c.births.accepted + c.deaths.accepted;
                n > 0 && n < FEW_JUMPS && c.probability > 0.02 && c.probability < 0.98
            })
            .map(|c| {
                format!(
                    "`{}` ({} switches: p = {:.2} ± {:.2}, log-odds {:.2} ± {:.2})",
                    c.name,
                    c.births.accepted + c.deaths.accepted,
                    c.probability,
                    c.error,
                    c.log_odds,
                    c.log_odds_error
                )
            })
            .collect();
        if few.is_empty() {
            return Vec::new();
        }
        vec![format!(
            "glitch count: {} switched fewer than {FEW_JUMPS} times: a probability's own error is then too small (its z-scores' RMS 1.18–1.24 at 35–70 switches, measured), its log-odds error is not — quote the log-odds ± its error (`log_odds`, `log_odds_error` in summary.json), or raise glitch_count_iterations",
            few.join(", ")
        )]
    }
}

/// Fewer accepted jumps than this for a candidate that is neither certainly on nor off earns a
/// warning ([`crate::sampler::FEW_SWITCHES`]: where the probability's own error stops being
/// short on the rare-jump toy).
pub const FEW_JUMPS: u64 = crate::sampler::FEW_SWITCHES;

/// Runs the reversible jump on `lik` (the fit's model with the candidates) from the MAP
/// `map` (all parameters) with the Fisher matrix `fisher` over `free`; `truth` the true
/// values (all parameters) where known.
pub fn glitch_count(
    study: &Study,
    lik: &Likelihood,
    candidates: &[GlitchCandidate],
    free: &[usize],
    map: &[f64],
    fisher: &DMatrix<f64>,
    truth: Option<&[Option<f64>]>,
) -> Result<GlitchCount, String> {
    let t0 = Instant::now();
    let names = lik.model().param_names();
    let at = |n: &str| -> Result<usize, String> {
        let i = names
            .iter()
            .position(|p| p == n)
            .ok_or_else(|| format!("glitch count: the model has no parameter `{n}`"))?;
        free.iter()
            .position(|&f| f == i)
            .ok_or_else(|| format!("glitch count: `{n}` is not free"))
    };
    // (positions in `free` of each candidate's t0, tau, a)
    let mut blocks = Vec::with_capacity(candidates.len());
    for c in candidates {
        blocks.push([
            at(&format!("{}_t0", c.name))?,
            at(&format!("{}_tau", c.name))?,
            at(&format!("{}_a", c.name))?,
        ]);
    }
    let base: Vec<usize> = (0..free.len())
        .filter(|k| !blocks.iter().any(|b| b.contains(k)))
        .collect();
    let conditional = |idx: &[usize]| -> Option<Vec<f64>> {
        let d = idx.len();
        let f = DMatrix::from_fn(d, d, |i, j| fisher[(idx[i], idx[j])]);
        let inv = nalgebra::Cholesky::new(f)?.inverse();
        Some((0..d * d).map(|q| inv[(q / d, q % d)]).collect())
    };
    let components: Vec<Component> = blocks
        .iter()
        .map(|b| {
            let params: Vec<usize> = b.iter().map(|&k| free[k]).collect();
            Component {
                switch: (params[2], 0.0),
                centre: params.iter().map(|&i| map[i]).collect(),
                cov: conditional(b),
                params,
            }
        })
        .collect();
    let base_full: Vec<usize> = base.iter().map(|&k| free[k]).collect();
    let base_cov = conditional(&base);
    let iterations = study
        .analysis
        .glitch_count_iterations
        .unwrap_or(DEFAULT_GLITCH_COUNT_ITERATIONS);
    let opts = BirthDeathOptions {
        iterations,
        burn: iterations / 4,
        seed: study.fit.seed.unwrap_or(study.seed).wrapping_add(7),
        prior_mix: PRIOR_MIX,
    };
    let r = birth_death(
        lik,
        map,
        &vec![true; candidates.len()],
        &base_full,
        base_cov.as_deref(),
        &components,
        &opts,
    )?;
    let out_candidates = candidates
        .iter()
        .zip(&components)
        .zip(r.inclusion.iter().zip(&r.jumps))
        .zip(r.inclusion_log_odds())
        .map(|(((c, comp), (&(p, e), j)), (lo, lo_e))| CandidateCount {
            name: c.name.clone(),
            experiment: c.experiment.clone(),
            region: c.region,
            probability: p,
            error: e,
            log_odds: lo,
            log_odds_error: lo_e,
            births: j[0],
            deaths: j[1],
            mean: [0, 1, 2].map(|q| r.mean[comp.params[q]]),
            sd: [0, 1, 2].map(|q| r.sd[comp.params[q]]),
        })
        .collect();
    let parameters = base_full
        .iter()
        .map(|&i| {
            let tr = truth.and_then(|t| t.get(i).copied().flatten());
            MarginalRow {
                name: names[i].clone(),
                mean: r.mean[i],
                sd: r.sd[i],
                truth: tr,
                pull: tr.map(|t| (r.mean[i] - t) / r.sd[i]),
            }
        })
        .collect();
    Ok(GlitchCount {
        iterations,
        burn_in: opts.burn,
        seconds: t0.elapsed().as_secs_f64(),
        count: r.count,
        candidates: out_candidates,
        parameters,
        acceptance: r
            .blocks
            .iter()
            .map(|m| m.accepted as f64 / (m.proposed.max(1)) as f64)
            .collect(),
    })
}

/// A row of the marginal parameters for the terminal.
pub fn marginal_line(r: &MarginalRow) -> String {
    format!(
        "  {}: {} ± {}{}",
        r.name,
        fmt_short(r.mean),
        fmt_short(r.sd),
        r.pull.map_or(String::new(), |p| format!(" (pull {p:+.2})"))
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn candidate(name: &str, switches: u64, probability: f64) -> CandidateCount {
        let m = |n: u64| Moves {
            proposed: 10 * n + 1,
            accepted: n,
        };
        CandidateCount {
            name: name.into(),
            experiment: "inv1".into(),
            region: [0.0, 100.0],
            probability,
            error: 0.05,
            log_odds: (probability / (1.0 - probability)).ln(),
            log_odds_error: 0.3,
            births: m(switches / 2),
            deaths: m(switches - switches / 2),
            mean: [0.0; 3],
            sd: [0.0; 3],
        }
    }

    /// Below [`FEW_JUMPS`] switches an undecided candidate is named, once for all, with its
    /// log-odds to quote; one switched enough, one never switched or one all but certain is not.
    #[test]
    fn the_few_jumps_warning_names_the_undecided_candidates_below_the_threshold() {
        let g = GlitchCount {
            iterations: 1,
            burn_in: 0,
            seconds: 0.0,
            count: Vec::new(),
            candidates: vec![
                candidate("g0", 70, 0.4),
                candidate("g1", FEW_JUMPS, 0.4),
                candidate("g2", 0, 0.5),
                candidate("g3", 30, 0.99),
                candidate("g4", 99, 0.7),
            ],
            parameters: Vec::new(),
            acceptance: Vec::new(),
        };
        let w = g.warnings();
        assert_eq!(w.len(), 1, "{w:?}");
        assert!(
            w[0].contains("`g0` (70 switches: p = 0.40 ± 0.05, log-odds -0.41 ± 0.30)"),
            "{}",
            w[0]
        );
        assert!(w[0].contains("`g4` (99 switches"), "{}", w[0]);
        assert!(
            !w[0].contains("g1") && !w[0].contains("g2") && !w[0].contains("g3"),
            "{}",
            w[0]
        );
        assert!(w[0].contains("quote the log-odds"), "{}", w[0]);
    }
}
