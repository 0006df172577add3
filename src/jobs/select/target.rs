//! `[select] target_error`: the reversible jump run in rounds until every pair's reference
//! error is at most the target, within a budget of iterations.
//!
//! Each round is a fresh run of the jump chains on the same seed, of the length the last
//! round's error asks for (`n · (σ / target)²`, with a margin, at least 1.5 × the last, at
//! most the budget). So the published run is exactly the fixed-length run of its final length:
//! setting `rj_iterations` to it reproduces every number, and the error bars mean what they
//! mean in any run. The cost is the earlier rounds, at most about as much again as the final
//! one (the lengths grow at least geometrically) and usually a fraction of it.

use super::pair::{EstimateKind, PairResult};
use crate::evidence::RjResult;
use serde::{Deserialize, Serialize};

/// Above the length the last error asks for: Monte-Carlo errors are themselves uncertain,
/// and a round that ends just short of the target costs a whole further round.
const MARGIN: f64 = 1.15;
/// The least growth from one round to the next, so that the rounds are few.
const MIN_GROWTH: f64 = 1.5;
/// The most rounds (the budget ends them sooner in practice).
pub(super) const MAX_ROUNDS: usize = 8;

/// One round of the reversible jump.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TargetRound {
    /// Iterations of the round (all chains).
    pub iterations: usize,
    /// The largest reversible-jump reference error over the pairs after it (`None`: some
    /// pair had no error, or the run failed).
    pub error: Option<f64>,
}

/// How a run with `[select] target_error` went.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TargetOutcome {
    /// The standard error of `ln B` asked for.
    pub target: f64,
    /// The most iterations a round could have (`rj_max_iterations`).
    pub budget: usize,
    /// The rounds, in order; the last is the run published.
    pub rounds: Vec<TargetRound>,
    /// The largest standard error of the pairs' reference rows in the published run (`None`
    /// when some pair has no reference error).
    pub reached: Option<f64>,
    /// Whether `reached` is at most `target`.
    pub met: bool,
    /// Why the target was not met.
    pub note: Option<String>,
}

impl TargetOutcome {
    /// The outcome of `rounds` for the finished pairs: the error their targeted rows reached
    /// ([`targeted_row`]).
    pub(super) fn finish(
        target: f64,
        budget: usize,
        rounds: Vec<TargetRound>,
        pairs: &[PairResult],
    ) -> TargetOutcome {
        let mut reached = Some(0.0_f64);
        let mut note = None;
        for p in pairs {
            match targeted_row(p).and_then(|e| e.std_err) {
                Some(e) => reached = reached.map(|r| r.max(e)),
                None => {
                    reached = None;
                    note = Some(format!(
                        "{}/{}: the reference row ({}) has no standard error",
                        p.x,
                        p.y,
                        if p.reference.is_empty() {
                            "none"
                        } else {
                            &p.reference
                        }
                    ));
                    break;
                }
            }
        }
        let met = reached.is_some_and(|r| r <= target);
        if !met && note.is_none() {
            let last = rounds.last().map_or(0, |r| r.iterations);
            let steering = pairs.iter().find(|p| {
                targeted_row(p).is_none_or(|e| {
                    !(e.kind == EstimateKind::Statistical && e.method.starts_with("RJMCMC"))
                })
            });
            note = Some(match steering {
                Some(p) => format!(
                    "{}/{}: the reference row is {}, which the target does not lengthen (it lengthens the reversible jump)",
                    p.x, p.y, p.reference
                ),
                None if last >= budget => format!(
                    "the budget ({budget} reversible-jump iterations, `rj_max_iterations`) was reached; raise it, or accept the error reached"
                ),
                None => format!(
                    "stopped after {} rounds; the last ended at {last} iterations",
                    rounds.len()
                ),
            });
        }
        TargetOutcome {
            target,
            budget,
            rounds,
            reached,
            met,
            note,
        }
    }

    /// One line for the tables: the target, what was reached, and at what cost.
    pub fn line(&self) -> String {
        let last = self.rounds.last().map_or(0, |r| r.iterations);
        let reached = match self.reached {
            Some(r) => format!("reached ± {}", crate::numfmt::fmt_sig(r, 2)),
            None => "no reference error".into(),
        };
        let mut s = format!(
            "target ± {} on every pair's reference: {reached} with {last} reversible-jump iterations ({} round{}; budget {})",
            crate::numfmt::fmt_sig(self.target, 2),
            self.rounds.len(),
            if self.rounds.len() == 1 { "" } else { "s" },
            self.budget
        );
        if let Some(n) = &self.note {
            s.push_str(&format!(" — not met: {n}"));
        }
        s
    }
}

/// The row of a pair whose error the target is on: its first jump row with an error in the
/// reference order (bridge, Rao–Blackwell, visits) — the rows the rounds lengthen, so a pair
/// with a model never visited is held on its one-sided rows, as before bridge sampling became
/// such a pair's reference — else its reference row (tempering took over: the target cannot
/// move it, and says so).
fn targeted_row(p: &PairResult) -> Option<&super::pair::PairEstimate> {
    ["RJMCMC bridge", "RJMCMC Rao-Blackwell", "RJMCMC visits"]
        .iter()
        .find_map(|m| {
            p.estimates
                .iter()
                .find(|e| e.method == *m && e.std_err.is_some())
        })
        .or_else(|| p.estimates.iter().find(|e| e.method == p.reference))
}

/// The largest reference error over the pairs of a reversible-jump run, each pair's taken
/// from its first row with one in the reference order (bridge, Rao–Blackwell, visits);
/// `None` when some pair has none.
pub(super) fn rj_error(rj: &RjResult) -> Option<f64> {
    let mut worst = 0.0_f64;
    for p in &rj.pairs {
        let e = [p.bridge, p.rao_blackwell, p.visits]
            .iter()
            .find_map(|b| b.and_then(|b| b.std_err))?;
        worst = worst.max(e);
    }
    Some(worst)
}

/// The length of the next round after one of `n` iterations that reached `error`, or `None`
/// when no further round can help (the target is met, or the budget is spent). A multiple of
/// `chains`.
pub(super) fn next_length(
    n: usize,
    error: f64,
    target: f64,
    budget: usize,
    chains: usize,
) -> Option<usize> {
    if error <= target || n >= budget {
        return None;
    }
    let want = n as f64 * (error / target).powi(2) * MARGIN;
    let want = want.max(n as f64 * MIN_GROWTH).min(budget as f64).ceil() as usize;
    let rounded = want.div_ceil(chains) * chains;
    Some(
        if rounded > budget {
            want / chains * chains
        } else {
            rounded
        }
        .max(n + chains),
    )
    .filter(|&m| m <= budget)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_next_round_asks_for_the_length_the_error_needs() {
        // twice the target: four times as long, with the margin
        assert_eq!(
            next_length(100_000, 0.02, 0.01, 10_000_000, 2),
            Some(460_000)
        );
        // just short of the target: at least 1.5 × the last
        assert_eq!(
            next_length(100_000, 0.0101, 0.01, 10_000_000, 2),
            Some(150_000)
        );
        // met: no further round
        assert_eq!(next_length(100_000, 0.01, 0.01, 10_000_000, 2), None);
        // capped at the budget, then done
        assert_eq!(next_length(100_000, 0.1, 0.01, 300_000, 2), Some(300_000));
        assert_eq!(next_length(300_000, 0.02, 0.01, 300_000, 2), None);
        // a multiple of the chains within the budget
        assert_eq!(next_length(1000, 0.1, 0.01, 3001, 4), Some(3000));
        assert_eq!(next_length(999, 0.02, 0.01, 100_000, 3), Some(4596));
    }
}
