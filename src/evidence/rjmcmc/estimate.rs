//! Bayes-factor estimators from the chains' streaming sums, and their errors.

use super::bridge::{GRID_OFFSETS, Grid, PairGrid, fixed_point};
use super::chain::{Chain, Layout, Sums};
use super::result::{MAX_RUNNING_POINTS, RjPair, RjRunningPair, RjRunningPoint};
use crate::evidence::error::EvidenceError;
use crate::evidence::ln_b::LnB;
use crate::evidence::method::Method;

/// Fixes the bridge function of every pair from the pooled pilot draws: `s_i` are the pilot's
/// draw fractions and the grid is centred on the pilot's optimal fixed point. When the pilot is
/// the whole run the grid's first point *is* the optimal bridge of Meng & Wong.
pub(crate) fn pilot_grid(chains: &[Chain], k: usize, shift: &[Vec<f64>]) -> Grid {
    let mut pairs = Vec::with_capacity(k * k);
    for a in 0..k {
        for b in 0..k {
            if b <= a {
                pairs.push(PairGrid {
                    ln_r: vec![0.0; GRID_OFFSETS.len()],
                    ln_s1: 0.0,
                    ln_s2: 0.0,
                });
                continue;
            }
            let mut x = Vec::new();
            let mut y = Vec::new();
            for c in chains {
                for (from, to, ln_rho) in c.pilot_inputs() {
                    if from == a && to == b {
                        x.push(ln_rho + shift[a][b]);
                    } else if from == b && to == a {
                        y.push(-ln_rho + shift[a][b]);
                    }
                }
            }
            let (n1, n2) = (x.len() as f64, y.len() as f64);
            let (ln_s1, ln_s2) = if n1 + n2 == 0.0 {
                (0.5f64.ln(), 0.5f64.ln())
            } else {
                ((n1 / (n1 + n2)).ln(), (n2 / (n1 + n2)).ln())
            };
            let centre = fixed_point(&x, &y).filter(|v| v.is_finite()).unwrap_or(0.0);
            pairs.push(PairGrid {
                ln_r: GRID_OFFSETS.iter().map(|o| centre + o).collect(),
                ln_s1,
                ln_s2,
            });
        }
    }
    Grid { k, pairs }
}

/// The pooled units of all chains.
pub(crate) struct Pool<'a> {
    pub layout: Layout,
    pub total: Sums,
    pub n: f64,
    pub batches: Vec<&'a Sums>,
    pub cycles: Vec<&'a Sums>,
    pub batch: usize,
}

impl<'a> Pool<'a> {
    pub fn new(chains: &'a [Chain], layout: Layout, batch: usize) -> Self {
        let mut total = Sums::new(&layout);
        for c in chains {
            for s in &c.cycles {
                total.add(s);
            }
        }
        let n = total.n(&layout);
        Pool {
            layout,
            total,
            n,
            batches: chains.iter().flat_map(|c| c.batches.iter()).collect(),
            cycles: chains
                .iter()
                .flat_map(|c| c.cycles.iter())
                .filter(|s| s.n(&layout) > 0.0)
                .collect(),
            batch,
        }
    }

    /// `Var(ū)` of the mean of a per-iteration series from batch means (batch size `b`,
    /// batches of all chains pooled; Flegal & Jones 2010). `u` gives a unit's sum of the series.
    pub fn batch_var(&self, u: &impl Fn(&Sums) -> f64) -> f64 {
        let a = self.batches.len() as f64;
        let b = self.batch as f64;
        let means: Vec<f64> = self.batches.iter().map(|s| u(s) / b).collect();
        let grand = means.iter().sum::<f64>() / a;
        let s2 = b * means.iter().map(|m| (m - grand).powi(2)).sum::<f64>() / (a - 1.0);
        s2 / self.n
    }

    /// `Var(ū)` from the regeneration units (entries into the reference model; the regenerative
    /// estimator of Crane & Iglehart / Mykland, Tierney & Yu 1995): `A/(A−1)·Σ(U_c − ū n_c)²/N²`.
    /// `None` with fewer than 2 units.
    pub fn regen_var(&self, u: &impl Fn(&Sums) -> f64) -> Option<f64> {
        let a = self.cycles.len();
        if a < 2 {
            return None;
        }
        let ubar = u(&self.total) / self.n;
        let ss: f64 = self
            .cycles
            .iter()
            .map(|s| (u(s) - ubar * s.n(&self.layout)).powi(2))
            .sum();
        Some(a as f64 / (a as f64 - 1.0) * ss / (self.n * self.n))
    }

    /// The larger of the two variance estimates (see the module docs, "Errors").
    fn var(&self, u: impl Fn(&Sums) -> f64) -> f64 {
        let bm = self.batch_var(&u);
        self.regen_var(&u).map_or(bm, |r| r.max(bm))
    }
}

/// What the visit estimator's error floor needs: sojourns and visits per model.
pub(crate) struct Sojourns<'a> {
    pub sojourns: &'a [u64],
    pub visits: &'a [u64],
}

pub(crate) fn visit_estimate(
    pool: &Pool<'_>,
    k: usize,
    l: usize,
    prior_p: &[f64],
    soj: &Sojourns<'_>,
) -> Option<LnB> {
    let lay = pool.layout;
    let nk = pool.total.counts[lay.visits(k)];
    let nl = pool.total.counts[lay.visits(l)];
    if nk == 0.0 || nl == 0.0 {
        return None;
    }
    let n = pool.n;
    let u = |s: &Sums| s.counts[lay.visits(k)] * n / nk - s.counts[lay.visits(l)] * n / nl;
    let var = pool.var(u).max(markov_floor(k, l, soj));
    Some(LnB {
        method: Method::RjVisits,
        ln_b: nk.ln() - nl.ln() + prior_p[l].ln() - prior_p[k].ln(),
        std_err: Some(var.sqrt()),
    })
}

/// `Var(ln N_k/N_l)` of a chain that leaves k and l with constant per-iteration probabilities
/// `a_k = m_k/N_k`, `a_l = m_l/N_l` (m: sojourns): `(1/m_k + 1/m_l)(1 − (a_k + a_l)/2)`, which
/// for two models is the exact asymptotic variance `2(2 − a − β)/n_switches` of the two-state
/// Markov chain. Sojourns whose leave probability varies (with θ) are mixtures of geometric
/// lengths, whose coefficient of variation is larger, so this is a lower bound.
pub(crate) fn markov_floor(k: usize, l: usize, s: &Sojourns<'_>) -> f64 {
    let (mk, ml) = (s.sojourns[k] as f64, s.sojourns[l] as f64);
    if mk == 0.0 || ml == 0.0 {
        return 0.0;
    }
    let ak = mk / s.visits[k] as f64;
    let al = ml / s.visits[l] as f64;
    (1.0 / mk + 1.0 / ml) * (1.0 - 0.5 * (ak + al)).max(0.0)
}

pub(crate) fn acceptance_estimate(
    pool: &Pool<'_>,
    k: usize,
    l: usize,
    ln_r_kl: f64,
) -> Option<LnB> {
    let lay = pool.layout;
    let t = &pool.total;
    let (c1, c2) = (t.counts[lay.prop(k, l)], t.counts[lay.prop(l, k)]);
    if c1 == 0.0 && c2 == 0.0 {
        return None;
    }
    // one-sided (a model never proposed from): the visited direction's α are taken with the
    // current state's Gaussian/t density, for which the bound ᾱ = 1 of the other direction
    // holds (see the module docs); with both directions present the true α are used
    let (ia, ib) = match (c1 > 0.0, c2 > 0.0) {
        (true, true) => (lay.alpha(k, l), lay.alpha(l, k)),
        _ => (lay.alpha_g(k, l), lay.alpha_g(l, k)),
    };
    let (sa, sb) = (t.logs[ia], t.logs[ib]);
    // a direction without proposals (its model was never visited) gets its bound ᾱ = 1
    let ln_a = if c1 == 0.0 { 0.0 } else { sa - c1.ln() };
    let ln_b = if c2 == 0.0 { 0.0 } else { sb - c2.ln() };
    if !(ln_a.is_finite() && ln_b.is_finite()) {
        return None;
    }
    let n = pool.n;
    let u = |s: &Sums| {
        let mut v = 0.0;
        if c1 > 0.0 {
            v += n * (s.counts[lay.prop(k, l)] / c1 - (s.logs[ia] - sa).exp());
        }
        if c2 > 0.0 {
            v += n * ((s.logs[ib] - sb).exp() - s.counts[lay.prop(l, k)] / c2);
        }
        v
    };
    Some(LnB {
        method: Method::RjRaoBlackwell,
        ln_b: ln_r_kl + ln_b - ln_a,
        std_err: Some(pool.var(u).sqrt()),
    })
}

/// The bridge for the pair `k < l`; see the module docs.
pub(crate) fn bridge_estimate(
    pool: &Pool<'_>,
    grid: &Grid,
    k: usize,
    l: usize,
    [(ln_pk, se_k), (ln_pl, se_l)]: [(f64, f64); 2],
    [se_gk, se_gl]: [f64; 2],
) -> Option<LnB> {
    if !(ln_pk.is_finite() && ln_pl.is_finite()) {
        return None;
    }
    let lay = pool.layout;
    let t = &pool.total;
    let (n1, n2) = (t.counts[lay.inbox(k, l)], t.counts[lay.inbox(l, k)]);
    let n = pool.n;
    // the one-sided forms use P_g of the model sitting and P of the model proposed
    let mut box_var = se_k * se_k + se_l * se_l;
    let (ln_r, var) = if n1 + n2 == 0.0 {
        return None;
    } else if n2 == 0.0 {
        // importance sampling: Z_l/Z_k = E_{f₁}[ρ]
        let s = t.logs[lay.is(k, l)];
        box_var = se_gk * se_gk + se_l * se_l;
        let u = |x: &Sums| n * ((x.logs[lay.is(k, l)] - s).exp() - x.counts[lay.inbox(k, l)] / n1);
        (s - n1.ln(), pool.var(u))
    } else if n1 == 0.0 {
        let s = t.logs[lay.is(l, k)];
        box_var = se_k * se_k + se_gl * se_gl;
        let u = |x: &Sums| n * (x.counts[lay.inbox(l, k)] / n2 - (x.logs[lay.is(l, k)] - s).exp());
        (n2.ln() - s, pool.var(u))
    } else {
        let pg = grid.pair(k, l);
        // the grid point closest to its own fixed point: the near-optimal fixed-h bridge
        let mut best: Option<(f64, usize, f64)> = None;
        for (g, &lr0) in pg.ln_r.iter().enumerate() {
            let (sn, sd) = (t.logs[lay.bridge(k, l, g)], t.logs[lay.bridge(l, k, g)]);
            let lr = (sn - n1.ln()) - (sd - n2.ln());
            if !lr.is_finite() {
                continue;
            }
            let gap = (lr - lr0).abs();
            if best.is_none_or(|(bg, _, _)| gap < bg) {
                best = Some((gap, g, lr));
            }
        }
        let (_, g, lr) = best?;
        let (sn, sd) = (t.logs[lay.bridge(k, l, g)], t.logs[lay.bridge(l, k, g)]);
        let u = |x: &Sums| {
            n * ((x.logs[lay.bridge(k, l, g)] - sn).exp() - x.counts[lay.inbox(k, l)] / n1
                + x.counts[lay.inbox(l, k)] / n2
                - (x.logs[lay.bridge(l, k, g)] - sd).exp())
        };
        (lr, pool.var(u))
    };
    if !ln_r.is_finite() {
        return None;
    }
    Some(LnB {
        method: Method::RjBridge,
        ln_b: -ln_r,
        std_err: Some((var + box_var).sqrt()),
    })
}

/// Checks shared by the estimators' inputs.
pub(crate) fn check_chains(chains: &[Chain]) -> Result<(), EvidenceError> {
    if chains.iter().any(|c| !c.pilot_done) {
        return Err(EvidenceError::option(
            "rjmcmc pilot",
            "unfinished",
            "internal: the bridge grid was not fixed before the end of the run",
        ));
    }
    Ok(())
}

/// The visit-ratio, Rao-Blackwell and bridge estimates of one pair.
pub(crate) type PairEstimates = (Option<LnB>, Option<LnB>, Option<LnB>);

/// The estimates along the run ([`super::result::RjResult::running`]): at up to
/// [`MAX_RUNNING_POINTS`] prefixes of `b` batches (evenly spread, each pooling every chain's
/// head stretch and first `b` batches, errors from those batch means), then the whole run
/// (`final_pairs`, the pooled result itself). A prefix of fewer than 2 batches in all has no
/// error and is skipped.
pub(crate) fn running_points(
    chains: &[Chain],
    layout: Layout,
    batch: usize,
    burn_in: usize,
    final_pairs: &[RjPair],
    estimates: &dyn Fn(&Pool<'_>, &Sojourns<'_>, usize, usize) -> PairEstimates,
) -> Vec<RjRunningPoint> {
    let n_chains = chains.len();
    let k = layout.k;
    let nb = chains[0].batches.len();
    let at = |b: usize| (burn_in + chains[0].batch_start + b * batch) * n_chains;
    let points = MAX_RUNNING_POINTS.min(nb);
    let mut total = Sums::new(&layout);
    for c in chains {
        total.add(&c.head);
    }
    let mut added = 0;
    let mut out = Vec::with_capacity(points);
    for j in 1..points {
        let b = (j * nb).div_ceil(points);
        while added < b {
            for c in chains {
                total.add(&c.batches[added]);
            }
            added += 1;
        }
        if b * n_chains < 2
            || out
                .last()
                .is_some_and(|p: &RjRunningPoint| p.iteration == at(b))
        {
            continue;
        }
        let pool = Pool {
            layout,
            n: total.n(&layout),
            total: total.clone(),
            batches: chains.iter().flat_map(|c| c.batches[..b].iter()).collect(),
            cycles: Vec::new(),
            batch,
        };
        let mut sojourns = vec![0u64; k];
        for c in chains {
            for (s, cs) in sojourns.iter_mut().zip(&c.batch_sojourns[b - 1]) {
                *s += cs;
            }
        }
        let visits: Vec<u64> = (0..k)
            .map(|m| total.counts[layout.visits(m)] as u64)
            .collect();
        let soj = Sojourns {
            sojourns: &sojourns,
            visits: &visits,
        };
        let mut pairs = Vec::new();
        for a in 0..k {
            for l in a + 1..k {
                let (visits, rao_blackwell, bridge) = estimates(&pool, &soj, a, l);
                pairs.push(RjRunningPair {
                    k: a,
                    l,
                    visits,
                    rao_blackwell,
                    bridge,
                });
            }
        }
        out.push(RjRunningPoint {
            iteration: at(b),
            pairs,
        });
    }
    out.push(RjRunningPoint {
        iteration: at(nb),
        pairs: final_pairs
            .iter()
            .map(|p| RjRunningPair {
                k: p.k,
                l: p.l,
                visits: p.visits,
                rao_blackwell: p.rao_blackwell,
                bridge: p.bridge,
            })
            .collect(),
    });
    out
}
