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
    /// `total` without one regeneration unit, for every unit (the jackknife's pools); empty
    /// with fewer than [`JACKKNIFE_MIN_UNITS`] units.
    pub leave_one_out: Vec<Sums>,
}

/// Fewest regeneration units for which the jackknife is formed.
pub(crate) const JACKKNIFE_MIN_UNITS: usize = 3;

impl<'a> Pool<'a> {
    pub fn new(chains: &'a [Chain], layout: Layout, batch: usize) -> Self {
        let mut total = Sums::new(&layout);
        for c in chains {
            for s in &c.cycles {
                total.add(s);
            }
        }
        let n = total.n(&layout);
        let cycles: Vec<&Sums> = chains
            .iter()
            .flat_map(|c| c.cycles.iter())
            .filter(|s| s.n(&layout) > 0.0)
            .collect();
        Pool {
            layout,
            total,
            n,
            batches: chains.iter().flat_map(|c| c.batches.iter()).collect(),
            leave_one_out: leave_one_out(&cycles, &layout),
            cycles,
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

    /// The delete-one-unit jackknife variance of an estimate computed from pooled sums by
    /// `point`: `(A−1)/A·Σ_c (θ̂₍c₎ − θ̄)²` over the regeneration units (see the module docs,
    /// "Errors"). `None` with fewer than [`JACKKNIFE_MIN_UNITS`] units or when the estimate
    /// without some unit is not finite (the estimate rests on that unit alone; the Markov floor
    /// and the other two estimates still apply).
    pub fn jackknife_var(&self, point: &impl Fn(&Sums) -> f64) -> Option<f64> {
        let a = self.leave_one_out.len();
        if a < JACKKNIFE_MIN_UNITS {
            return None;
        }
        let mut vals = Vec::with_capacity(a);
        for s in &self.leave_one_out {
            let v = point(s);
            if !v.is_finite() {
                return None;
            }
            vals.push(v);
        }
        let mean = vals.iter().sum::<f64>() / a as f64;
        let ss: f64 = vals.iter().map(|v| (v - mean).powi(2)).sum();
        Some((a as f64 - 1.0) / a as f64 * ss)
    }

    /// The largest of the variance estimates (see the module docs, "Errors"): batch means and
    /// regenerative for the linearised series `u`, the jackknife for the estimate `point`.
    fn var(&self, u: impl Fn(&Sums) -> f64, point: impl Fn(&Sums) -> f64) -> f64 {
        let bm = self.batch_var(&u);
        let linear = self.regen_var(&u).map_or(bm, |r| r.max(bm));
        self.jackknife_var(&point).map_or(linear, |j| j.max(linear))
    }
}

/// Most groups the jackknife deletes one at a time: beyond this many units, consecutive
/// units are grouped (a grouped jackknife), which bounds its memory whatever the chain count.
const MAX_JACKKNIFE_GROUPS: usize = 1024;

/// `Σ_{c' ≠ c} group[c']` for every group `c` of consecutive units (one unit per group up to
/// [`MAX_JACKKNIFE_GROUPS`]), from prefix sums and a running suffix; empty with fewer than
/// [`JACKKNIFE_MIN_UNITS`] units.
fn leave_one_out(units: &[&Sums], layout: &Layout) -> Vec<Sums> {
    if units.len() < JACKKNIFE_MIN_UNITS {
        return Vec::new();
    }
    let size = units.len().div_ceil(MAX_JACKKNIFE_GROUPS);
    let groups: Vec<Sums> = units
        .chunks(size)
        .map(|chunk| {
            let mut g = Sums::new(layout);
            chunk.iter().for_each(|u| g.add(u));
            g
        })
        .collect();
    let mut out = Vec::with_capacity(groups.len());
    let mut prefix = Sums::new(layout);
    for g in &groups {
        out.push(prefix.clone());
        prefix.add(g);
    }
    let mut suffix = Sums::new(layout);
    for (o, g) in out.iter_mut().zip(&groups).rev() {
        o.add(&suffix);
        suffix.add(g);
    }
    out
}

/// `Var(ln m̄)` floor of a mean over a direction's `m` proposals of non-negative terms (α, or a
/// bridge's terms): the shift `ln((m+1)/m) ≈ 1/(m+1)` that one more proposal with a zero term
/// would make, for every direction with proposals. A deficit a sample of `m` has not seen (all
/// `m` jumps accepted, while some fixed share of proposals — the defensive mixture's prior
/// draws, a tail of `g` — would be rejected) is invisible to every variance estimate built
/// from those `m` terms; `1/m` is the Jeffreys 84 % bound on the rate of events seen zero
/// times in `m` trials. See the module docs, "Errors".
pub(crate) fn unseen_floor(proposals: &[f64]) -> f64 {
    proposals
        .iter()
        .filter(|&&m| m > 0.0)
        .map(|&m| (m + 1.0).powi(-2))
        .sum()
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
    let point = |s: &Sums| {
        s.counts[lay.visits(k)].ln() - s.counts[lay.visits(l)].ln() + prior_p[l].ln()
            - prior_p[k].ln()
    };
    let var = pool.var(u, point).max(markov_floor(k, l, soj));
    Some(LnB {
        method: Method::RjVisits,
        ln_b: point(&pool.total),
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
    let indices = |c1: f64, c2: f64| match (c1 > 0.0, c2 > 0.0) {
        (true, true) => (lay.alpha(k, l), lay.alpha(l, k)),
        _ => (lay.alpha_g(k, l), lay.alpha_g(l, k)),
    };
    let (ia, ib) = indices(c1, c2);
    // the estimate from any pooled sums, in the form those sums call for: the jackknife's
    // pools without one unit may have lost a direction's only proposals, and the estimate
    // without that unit is then the one-sided one (the spread this shows is the estimate's
    // dependence on a few sojourns); a direction without proposals (its model never visited)
    // gets its bound ᾱ = 1
    let point = |s: &Sums| {
        let (d1, d2) = (s.counts[lay.prop(k, l)], s.counts[lay.prop(l, k)]);
        if d1 == 0.0 && d2 == 0.0 {
            return f64::NAN;
        }
        let (ia, ib) = indices(d1, d2);
        let ln_a = if d1 == 0.0 { 0.0 } else { s.logs[ia] - d1.ln() };
        let ln_b = if d2 == 0.0 { 0.0 } else { s.logs[ib] - d2.ln() };
        ln_r_kl + ln_b - ln_a
    };
    let ln_b = point(t);
    if !ln_b.is_finite() {
        return None;
    }
    let (sa, sb) = (t.logs[ia], t.logs[ib]);
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
        ln_b,
        std_err: Some(pool.var(u, point).max(unseen_floor(&[c1, c2])).sqrt()),
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
    // `ln r̂` in each form: importance sampling from k (no proposals l → k), from l (none
    // k → l), and the bridge at grid point g
    let from_k = |x: &Sums| x.logs[lay.is(k, l)] - x.counts[lay.inbox(k, l)].ln();
    let from_l = |x: &Sums| x.counts[lay.inbox(l, k)].ln() - x.logs[lay.is(l, k)];
    let bridge = |x: &Sums, g: usize| {
        (x.logs[lay.bridge(k, l, g)] - x.counts[lay.inbox(k, l)].ln())
            - (x.logs[lay.bridge(l, k, g)] - x.counts[lay.inbox(l, k)].ln())
    };
    // the estimate from any pooled sums, in the form those sums call for (the jackknife's
    // pools without one unit may have lost a direction's only proposals: the estimate without
    // that unit is then the one-sided one, and the spread shows how much rests on it)
    let any_form = |x: &Sums, g: usize| match (x.counts[lay.inbox(k, l)], x.counts[lay.inbox(l, k)])
    {
        (m1, m2) if m1 + m2 == 0.0 => f64::NAN,
        (_, 0.0) => from_k(x),
        (0.0, _) => from_l(x),
        _ => bridge(x, g),
    };
    let (ln_r, var) = if n1 + n2 == 0.0 {
        return None;
    } else if n2 == 0.0 {
        // importance sampling: Z_l/Z_k = E_{f₁}[ρ]
        let s = t.logs[lay.is(k, l)];
        box_var = se_gk * se_gk + se_l * se_l;
        let u = |x: &Sums| n * ((x.logs[lay.is(k, l)] - s).exp() - x.counts[lay.inbox(k, l)] / n1);
        (from_k(t), pool.var(u, |x: &Sums| any_form(x, 0)))
    } else if n1 == 0.0 {
        let s = t.logs[lay.is(l, k)];
        box_var = se_k * se_k + se_gl * se_gl;
        let u = |x: &Sums| n * (x.counts[lay.inbox(l, k)] / n2 - (x.logs[lay.is(l, k)] - s).exp());
        (from_l(t), pool.var(u, |x: &Sums| any_form(x, 0)))
    } else {
        let pg = grid.pair(k, l);
        // the grid point closest to its own fixed point: the near-optimal fixed-h bridge
        let mut best: Option<(f64, usize, f64)> = None;
        for (g, &lr0) in pg.ln_r.iter().enumerate() {
            let lr = bridge(t, g);
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
        (lr, pool.var(u, |x: &Sums| any_form(x, g)))
    };
    if !ln_r.is_finite() {
        return None;
    }
    let var = var.max(unseen_floor(&[n1, n2]));
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
            leave_one_out: Vec::new(),
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

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_xoshiro::Xoshiro256PlusPlus;

    /// Units of a two-model chain: per unit, `n_c` iterations of which a random share in
    /// model 0 (the estimate: the log visit ratio).
    fn units(a: usize, seed: u64) -> (Layout, Vec<Sums>) {
        let layout = Layout { k: 2, g: 1 };
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
        let units = (0..a)
            .map(|_| {
                let mut s = Sums::new(&layout);
                let n = rng.random_range(5..50) as f64;
                let share: f64 = rng.random_range(0.2..0.8);
                s.counts[layout.visits(0)] = (n * share).round();
                s.counts[layout.visits(1)] = n - (n * share).round();
                s
            })
            .collect();
        (layout, units)
    }

    fn pool<'a>(layout: Layout, u: &'a [Sums]) -> Pool<'a> {
        let cycles: Vec<&Sums> = u.iter().collect();
        let mut total = Sums::new(&layout);
        u.iter().for_each(|s| total.add(s));
        Pool {
            layout,
            n: total.n(&layout),
            total,
            batches: Vec::new(),
            leave_one_out: leave_one_out(&cycles, &layout),
            cycles,
            batch: 1,
        }
    }

    #[test]
    fn unseen_floor_is_one_zero_term_per_direction() {
        assert_eq!(unseen_floor(&[0.0, 0.0]), 0.0);
        assert_eq!(unseen_floor(&[3.0, 0.0]), 1.0 / 16.0);
        assert!((unseen_floor(&[4.0, 9.0]) - (0.04 + 0.01)).abs() < 1e-15);
        // one more zero term shifts a log-mean of m terms all equal by ln((m+1)/m) ≈ 1/(m+1)
        let m = 200.0f64;
        assert!((unseen_floor(&[m]).sqrt() - ((m + 1.0) / m).ln()).abs() < 1e-4);
    }

    #[test]
    fn leave_one_out_removes_exactly_one_group() {
        let (layout, u) = units(10, 1);
        let p = pool(layout, &u);
        assert_eq!(p.leave_one_out.len(), 10);
        for (c, s) in p.leave_one_out.iter().enumerate() {
            let want = p.total.counts[0] - u[c].counts[0];
            assert!((s.counts[0] - want).abs() < 1e-9);
        }
        // beyond the cap, consecutive units are grouped: 2500 units → groups of 3
        let (layout, u) = units(2500, 2);
        let p = pool(layout, &u);
        assert_eq!(p.leave_one_out.len(), 834);
        let first3: f64 = u[..3].iter().map(|s| s.counts[1]).sum();
        assert!((p.leave_one_out[0].counts[1] - (p.total.counts[1] - first3)).abs() < 1e-9);
        // too few units: no jackknife
        let (layout, u) = units(2, 3);
        assert!(
            pool(layout, &u)
                .jackknife_var(&|s: &Sums| s.counts[0])
                .is_none()
        );
    }

    /// With many units the jackknife and the linearised regenerative variance of a smooth
    /// estimate agree (to O(1/A)); an estimate that is infinite without some unit has none.
    #[test]
    fn jackknife_agrees_with_the_regenerative_variance_for_many_units() {
        let (layout, u) = units(800, 4);
        let p = pool(layout, &u);
        let (n0, n1, n) = (p.total.counts[0], p.total.counts[1], p.n);
        let point = |s: &Sums| s.counts[0].ln() - s.counts[1].ln();
        let lin = |s: &Sums| s.counts[0] * n / n0 - s.counts[1] * n / n1;
        let jk = p.jackknife_var(&point).unwrap();
        let rg = p.regen_var(&lin).unwrap();
        assert!((jk / rg - 1.0).abs() < 0.02, "{jk} vs {rg}");
        let mut lone = units(5, 5).1;
        lone.iter_mut().for_each(|s| s.counts[1] = 0.0);
        lone[2].counts[1] = 7.0;
        let p = pool(layout, &lone);
        assert!(p.jackknife_var(&point).is_none());
    }
}
