//! What a jump-chain run reports: [`RjResult`] with its pairs, trace, running estimates and
//! kept draws, and the progress passed along the way.

use serde::Serialize;

use crate::evidence::ln_b::LnB;

/// Passed to the progress callback about 100 times per run (from the calling thread).
#[derive(Debug, Clone, Copy)]
pub struct RjProgress<'a> {
    /// Iterations done, summed over the chains.
    pub iteration: usize,
    /// Total iterations, summed over the chains.
    pub n_iter: usize,
    /// Current model of chain 0.
    pub model: usize,
    /// Post-burn-in visits so far, summed over the chains.
    pub visits: &'a [u64],
}

/// Bayes-factor estimates for one pair, `ln B_kl = ln Z_k − ln Z_l`.
#[derive(Debug, Clone, PartialEq, Serialize, serde::Deserialize)]
pub struct RjPair {
    /// First model.
    pub k: usize,
    /// Second model.
    pub l: usize,
    /// Visit ratio (None if either model was never visited).
    pub visits: Option<LnB>,
    /// Mean-acceptance-probability ratio (None without accepted-probability mass both ways).
    pub rao_blackwell: Option<LnB>,
    /// Optimal bridge (None only without any in-box proposal between the two).
    pub bridge: Option<LnB>,
    /// Post-burn-in jump proposals k → l.
    pub proposals_k_to_l: u64,
    /// Post-burn-in jump proposals l → k.
    pub proposals_l_to_k: u64,
    /// Post-burn-in accepted jumps k → l.
    pub accepted_k_to_l: u64,
    /// Post-burn-in accepted jumps l → k.
    pub accepted_l_to_k: u64,
    /// Effective independent jumps: accepted jumps between k and l after burn-in, all chains.
    /// Each is the end of a sojourn, and sojourns are what the visit ratio averages over.
    pub effective_jumps: u64,
    /// Expected accepted jumps `Σα` over both directions: the number Rao-Blackwell and the
    /// bridge effectively average over when proposals are rarely accepted (the relative
    /// variance of a mean of `α ∈ [0, 1]` is at most `1/Σα`).
    pub expected_jumps: f64,
    /// Set when `effective_jumps` < [`MIN_EFFECTIVE_JUMPS`]: the visit ratio then rests on a
    /// handful of sojourns and its error bar is itself uncertain.
    ///
    /// [`MIN_EFFECTIVE_JUMPS`]: super::options::MIN_EFFECTIVE_JUMPS
    pub warning: Option<String>,
    /// Set instead of `warning` when the jumps are few but the answer does not need them
    /// (the models are too far apart for any run to exchange jumps, and the reference is not
    /// a jump row): a fact about the run, listed with its notes.
    #[serde(default)]
    pub note: Option<String>,
}

impl RjPair {
    /// Whether the Rao-Blackwell and bridge estimates are one-sided: no jump was proposed out
    /// of one of the two models after burn-in (never visited, or never left towards the
    /// other), so they average one direction's terms with the other's bound (module docs of
    /// [`super`]). A model visited in a sojourn or two that never proposed the jump is as
    /// one-sided as one never visited: its visit ratio has a number, its jump rows no more
    /// information.
    ///
    /// ```
    /// use occam::evidence::RjPair;
    /// let p = RjPair { k: 0, l: 1, visits: None, rao_blackwell: None, bridge: None,
    ///     proposals_k_to_l: 191, proposals_l_to_k: 0, accepted_k_to_l: 0, accepted_l_to_k: 0,
    ///     effective_jumps: 0, expected_jumps: 0.13, warning: None, note: None };
    /// assert!(p.one_sided()); // nothing proposed from the second model
    /// ```
    pub fn one_sided(&self) -> bool {
        self.visits.is_none() || self.proposals_k_to_l == 0 || self.proposals_l_to_k == 0
    }

    fn flipped(&self) -> RjPair {
        let neg = |b: &Option<LnB>| b.map(|b| LnB { ln_b: -b.ln_b, ..b });
        RjPair {
            k: self.l,
            l: self.k,
            visits: neg(&self.visits),
            rao_blackwell: neg(&self.rao_blackwell),
            bridge: neg(&self.bridge),
            proposals_k_to_l: self.proposals_l_to_k,
            proposals_l_to_k: self.proposals_k_to_l,
            accepted_k_to_l: self.accepted_l_to_k,
            accepted_l_to_k: self.accepted_k_to_l,
            effective_jumps: self.effective_jumps,
            expected_jumps: self.expected_jumps,
            warning: self.warning.clone(),
            note: self.note.clone(),
        }
    }
}

/// Visit counts at one point of the run.
#[derive(Debug, Clone, PartialEq, Serialize, serde::Deserialize)]
pub struct RjTracePoint {
    /// Iterations done (including burn-in), summed over the chains.
    pub iteration: usize,
    /// Post-burn-in visits per model so far, summed over the chains.
    pub visits: Vec<u64>,
}

/// The three jump-chain estimates of one pair at one point of the run.
#[derive(Debug, Clone, PartialEq, Serialize, serde::Deserialize)]
pub struct RjRunningPair {
    /// First model.
    pub k: usize,
    /// Second model.
    pub l: usize,
    /// Visit ratio (`None` while either model is unvisited).
    pub visits: Option<LnB>,
    /// Rao-Blackwell (mean acceptance probabilities).
    pub rao_blackwell: Option<LnB>,
    /// Bridge.
    pub bridge: Option<LnB>,
}

/// Every pair's estimates from the first part of the run (the evolution of B, Fig. 2).
#[derive(Debug, Clone, PartialEq, Serialize, serde::Deserialize)]
pub struct RjRunningPoint {
    /// Iterations done (including burn-in), summed over the chains.
    pub iteration: usize,
    /// One entry per pair `k < l`, in the order of [`RjResult::pairs`].
    pub pairs: Vec<RjRunningPair>,
}

/// The kept post-burn-in draws of every jump chain (`keep_draws`), chain-major.
#[derive(Debug, Clone, PartialEq, Serialize, serde::Deserialize)]
pub struct RjDraws {
    /// Model names (what `model_index` indexes).
    pub model_names: Vec<String>,
    /// The union of the models' parameter names, in first-seen order (model by model).
    pub param_names: Vec<String>,
    /// Chains.
    pub n_chains: usize,
    /// Draws per chain.
    pub n_draws: usize,
    /// Every `thin`-th post-burn-in iteration is kept (1: all).
    pub thin: usize,
    /// `[chain][draw]`: the model the chain is in.
    pub model_index: Vec<i64>,
    /// `[chain][draw][param]`: its parameters, NaN where the model has no such parameter.
    pub samples: Vec<f64>,
    /// `[chain][draw]`: `ln L` of the state.
    pub ln_likelihood: Vec<f64>,
}

/// The union of the models' parameter names (first-seen order) and, per model, the column of
/// each of its parameters in it.
pub fn union_columns(names: &[&[String]]) -> (Vec<String>, Vec<Vec<usize>>) {
    let mut all: Vec<String> = Vec::new();
    let cols = names
        .iter()
        .map(|ns| {
            ns.iter()
                .map(|n| match all.iter().position(|a| a == n) {
                    Some(i) => i,
                    None => {
                        all.push(n.clone());
                        all.len() - 1
                    }
                })
                .collect()
        })
        .collect();
    (all, cols)
}

/// Output of [`run_rjmcmc`](super::run::run_rjmcmc).
#[derive(Debug, Clone, PartialEq, Serialize, serde::Deserialize)]
pub struct RjResult {
    /// Model names.
    pub model_names: Vec<String>,
    /// Iterations run, summed over the chains.
    pub n_iter: usize,
    /// Independent chains.
    pub n_chains: usize,
    /// Burn-in iterations of each chain.
    pub burn_in: usize,
    /// Defensive prior weight of the jump proposals.
    pub defensive: f64,
    /// Batch size used for the errors.
    pub batch_size: usize,
    /// Normalised prior model probabilities.
    pub prior_model_probs: Vec<f64>,
    /// Post-burn-in iterations spent in each model.
    pub visits: Vec<u64>,
    /// In-model random-walk acceptance rate per model (`None` for a model never visited or of
    /// dimension 0).
    pub in_model_acceptance: Vec<Option<f64>>,
    /// `[k][l]`: jump proposals k → l (whole run, all chains).
    pub jumps_proposed: Vec<Vec<u64>>,
    /// `[k][l]`: accepted jumps k → l (whole run, all chains).
    pub jumps_accepted: Vec<Vec<u64>>,
    /// Post-burn-in sojourns per model (all chains).
    pub sojourns: Vec<u64>,
    /// Regeneration units (entries into the start model, merged pairwise beyond 1024 per chain)
    /// behind the regenerative variance.
    pub regeneration_units: usize,
    /// Proposals with a non-finite likelihood inside the prior (counted as rejections).
    pub non_finite: u64,
    /// `ln L` evaluations, all chains (proposals outside the prior support cost none).
    pub likelihood_calls: u64,
    /// `ln P_k(box)` of each model's jump proposal: `ln[(1 − w)·P_gauss(box) + w]`.
    pub ln_box_mass: Vec<f64>,
    /// Standard errors of `ln_box_mass`.
    pub ln_box_mass_std_err: Vec<f64>,
    /// Estimates for every pair k < l.
    pub pairs: Vec<RjPair>,
    /// Visit counts along the run (for the evolution of B).
    pub trace: Vec<RjTracePoint>,
    /// Every estimator along the run, at most [`MAX_RUNNING_POINTS`] points; the last is the
    /// whole run (equal to `pairs`). Point `b` pools the first `b` batches of every chain (and
    /// the stretch before them), its errors from the batch means alone: the regeneration units
    /// that the final errors also use are not resolved in time.
    #[serde(default)]
    pub running: Vec<RjRunningPoint>,
    /// The post-burn-in draws, when [`RjOptions::keep_draws`] asked for them. Not serialised
    /// (they go to `rj_chain.npz`, not to `summary.json`).
    ///
    /// [`RjOptions::keep_draws`]: super::options::RjOptions::keep_draws
    #[serde(skip)]
    pub draws: Option<RjDraws>,
}

/// Most points of [`RjResult::running`].
pub const MAX_RUNNING_POINTS: usize = 200;

impl RjResult {
    /// The estimates for `ln B_kl` (either order).
    pub fn pair(&self, k: usize, l: usize) -> Option<RjPair> {
        self.pairs.iter().find_map(|p| {
            if p.k == k && p.l == l {
                Some(p.clone())
            } else if p.k == l && p.l == k {
                Some(p.flipped())
            } else {
                None
            }
        })
    }

    /// Evolution of the visit-ratio `ln B_kl` along the run: `(iteration, ln B)` with `None`
    /// while either model is unvisited.
    pub fn ln_b_trace(&self, k: usize, l: usize) -> Vec<(usize, Option<f64>)> {
        let lp = self.prior_model_probs[l].ln() - self.prior_model_probs[k].ln();
        self.trace
            .iter()
            .map(|t| {
                let (a, b) = (t.visits[k], t.visits[l]);
                let v = (a > 0 && b > 0).then(|| (a as f64).ln() - (b as f64).ln() + lp);
                (t.iteration, v)
            })
            .collect()
    }

    /// Jump acceptance `k → l` over the whole run: `(accepted, proposed, rate)`, the rate
    /// `None` without proposals.
    pub fn jump_acceptance(&self, k: usize, l: usize) -> (u64, u64, Option<f64>) {
        let (a, p) = (self.jumps_accepted[k][l], self.jumps_proposed[k][l]);
        (a, p, (p > 0).then(|| a as f64 / p as f64))
    }

    /// `[k][l]`: jump acceptance rates (None where nothing was proposed, e.g. the diagonal).
    pub fn jump_acceptance_rates(&self) -> Vec<Vec<Option<f64>>> {
        let k = self.jumps_proposed.len();
        (0..k)
            .map(|a| (0..k).map(|b| self.jump_acceptance(a, b).2).collect())
            .collect()
    }

    /// Visit fractions (estimates of the posterior model probabilities).
    pub fn visit_fractions(&self) -> Vec<f64> {
        let n: u64 = self.visits.iter().sum();
        self.visits.iter().map(|&v| v as f64 / n as f64).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::evidence::Method;

    /// One-sided is a property of the proposals, not of the visits: the pair of
    /// `examples/accel-asymmetry.toml` whose `full` model was entered once, from a third model,
    /// and never proposed the jump to `asym-pole`, had a visit ratio and two jump rows that
    /// were one-sided all the same (2.6 stated σ from importance sampling).
    #[test]
    fn a_pair_is_one_sided_when_one_model_never_proposed_the_jump() {
        let visits = Some(LnB {
            method: Method::RjVisits,
            ln_b: 7.0,
            std_err: Some(0.2),
        });
        let both = RjPair {
            k: 0,
            l: 1,
            visits,
            rao_blackwell: None,
            bridge: None,
            proposals_k_to_l: 191,
            proposals_l_to_k: 3,
            accepted_k_to_l: 1,
            accepted_l_to_k: 1,
            effective_jumps: 2,
            expected_jumps: 1.2,
            warning: None,
            note: None,
        };
        assert!(!both.one_sided());
        assert!(
            RjPair {
                proposals_l_to_k: 0,
                ..both.clone()
            }
            .one_sided()
        );
        assert!(
            RjPair {
                proposals_k_to_l: 0,
                ..both.clone()
            }
            .one_sided()
        );
        assert!(
            RjPair {
                visits: None,
                ..both.clone()
            }
            .one_sided()
        );
        // flipping the pair keeps it
        assert!(
            RjPair {
                proposals_l_to_k: 0,
                ..both
            }
            .flipped()
            .one_sided()
        );
    }
}
