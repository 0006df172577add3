//! The finished chains' pooled counts and every pair's Bayes-factor estimates.

use super::bridge::Grid;
use super::chain::{Chain, Layout};
use super::estimate::{self, Pool, Sojourns};
use super::options::{MIN_EFFECTIVE_JUMPS, RjModel};
use super::prepare::BoxMasses;
use super::result::{RjPair, RjTracePoint};

/// The chains' counts, summed.
pub(crate) struct Totals {
    pub(crate) visits: Vec<u64>,
    pub(crate) sojourns: Vec<u64>,
    pub(crate) rw_tried: Vec<u64>,
    pub(crate) rw_accepted: Vec<u64>,
    pub(crate) proposed: Vec<Vec<u64>>,
    pub(crate) accepted: Vec<Vec<u64>>,
    pub(crate) accepted_post: Vec<Vec<u64>>,
    pub(crate) non_finite: u64,
    pub(crate) trace: Vec<RjTracePoint>,
}

impl Totals {
    pub(crate) fn of(chains: &[Chain], k_models: usize) -> Totals {
        let sum_vec = |f: &dyn Fn(&Chain) -> &Vec<u64>| -> Vec<u64> {
            let mut v = vec![0u64; k_models];
            for c in chains {
                for (a, b) in v.iter_mut().zip(f(c)) {
                    *a += b;
                }
            }
            v
        };
        let sum_mat = |f: &dyn Fn(&Chain) -> &Vec<Vec<u64>>| -> Vec<Vec<u64>> {
            let mut m = vec![vec![0u64; k_models]; k_models];
            for c in chains {
                for (row, crow) in m.iter_mut().zip(f(c)) {
                    for (a, b) in row.iter_mut().zip(crow) {
                        *a += b;
                    }
                }
            }
            m
        };
        // traces: every chain has the same points; sum them
        let trace: Vec<RjTracePoint> = (0..chains[0].trace.len())
            .map(|i| {
                let mut p = RjTracePoint {
                    iteration: 0,
                    visits: vec![0; k_models],
                };
                for c in chains {
                    let q = &c.trace[i];
                    p.iteration += q.iteration;
                    for (a, b) in p.visits.iter_mut().zip(&q.visits) {
                        *a += b;
                    }
                }
                p
            })
            .collect();
        Totals {
            visits: sum_vec(&|c| &c.visits),
            sojourns: sum_vec(&|c| &c.sojourns),
            rw_tried: sum_vec(&|c| &c.rw_tried),
            rw_accepted: sum_vec(&|c| &c.rw_accepted),
            proposed: sum_mat(&|c| &c.proposed),
            accepted: sum_mat(&|c| &c.accepted),
            accepted_post: sum_mat(&|c| &c.accepted_post),
            non_finite: chains.iter().map(|c| c.non_finite).sum(),
            trace,
        }
    }
}

/// The three estimates of a pair from a pool of sums: one code path for the final numbers and
/// for every running point.
pub(crate) struct PairEstimator<'a> {
    pub(crate) prior_p: &'a [f64],
    pub(crate) ln_ratio: &'a [Vec<f64>],
    pub(crate) grid: &'a Grid,
    pub(crate) boxes: &'a BoxMasses,
}

impl PairEstimator<'_> {
    pub(crate) fn estimates(
        &self,
        pool: &Pool<'_>,
        soj: &Sojourns<'_>,
        a: usize,
        b: usize,
    ) -> estimate::PairEstimates {
        let BoxMasses {
            ln_p: ln_box,
            se: ln_box_se,
            se_g: ln_box_g_se,
            ..
        } = self.boxes;
        (
            estimate::visit_estimate(pool, a, b, self.prior_p, soj),
            estimate::acceptance_estimate(pool, a, b, self.ln_ratio[a][b]),
            estimate::bridge_estimate(
                pool,
                self.grid,
                a,
                b,
                [(ln_box[a], ln_box_se[a]), (ln_box[b], ln_box_se[b])],
                [ln_box_g_se[a], ln_box_g_se[b]],
            ),
        )
    }
}

/// Every pair `a < b`: its estimates, jump counts and a warning when too few jumps were
/// accepted after burn-in.
pub(crate) fn pairs(
    models: &[RjModel<'_>],
    est: &PairEstimator<'_>,
    pool: &Pool<'_>,
    soj: &Sojourns<'_>,
    layout: Layout,
    accepted_post: &[Vec<u64>],
) -> Vec<RjPair> {
    let k_models = models.len();
    let mut pairs = Vec::new();
    for a in 0..k_models {
        for b in a + 1..k_models {
            let effective_jumps = accepted_post[a][b] + accepted_post[b][a];
            let expected_jumps = pool.total.logs[layout.alpha(a, b)].exp()
                + pool.total.logs[layout.alpha(b, a)].exp();
            let warning = (effective_jumps < MIN_EFFECTIVE_JUMPS).then(|| {
                format!(
                    "only {effective_jumps} accepted jumps between `{}` and `{}` after burn-in (< {MIN_EFFECTIVE_JUMPS}): the visit ratio rests on a few sojourns and its error bar is itself uncertain by more than about 20 % (Rao-Blackwell and the bridge average over every proposal and rest on Σα = {expected_jumps:.3e} expected jumps instead); run longer ([select] rj_iterations) or raise [select] defensive",
                    models[a].name, models[b].name
                )
            });
            let (visits, rao_blackwell, bridge) = est.estimates(pool, soj, a, b);
            pairs.push(RjPair {
                k: a,
                l: b,
                visits,
                rao_blackwell,
                bridge,
                proposals_k_to_l: pool.total.counts[layout.prop(a, b)] as u64,
                proposals_l_to_k: pool.total.counts[layout.prop(b, a)] as u64,
                accepted_k_to_l: accepted_post[a][b],
                accepted_l_to_k: accepted_post[b][a],
                effective_jumps,
                expected_jumps,
                warning,
                note: None,
            });
        }
    }
    pairs
}
