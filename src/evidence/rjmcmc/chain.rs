//! One jump chain: its state, its random stream and its streaming accumulators.
//!
//! Nothing per iteration is stored: every estimator of [`super::estimate`] is a smooth function
//! of sums of per-iteration series, so the chain keeps those sums per batch (for batch means)
//! and per regeneration cycle (entries into the reference model; for the regenerative
//! variance), plus, during the short pilot phase only, the bridge's raw `ln ρ` values (the
//! bridge's terms depend on a constant that the pilot fixes; they are replayed into the sums
//! once it is known). Memory is `O(√N + cycles cap + pilot)` per chain, plus the post-burn-in
//! draws themselves (model, parameters, `ln L`) when [`Shared::columns`] asks for them.

use super::bridge::{GRID_OFFSETS, Grid};
use super::logsum::lae;
use super::options::{ProposalShape, RjOptions};
use super::prepare::{BoxMasses, Prepared};
use super::result::RjTracePoint;
use crate::evidence::error::EvidenceError;
use crate::sampler::chain_rng;
use rand::RngExt;
use rand_distr::{ChiSquared, Distribution, StandardNormal};
use rand_xoshiro::Xoshiro256PlusPlus;
use serde::{Deserialize, Serialize};

/// Most regeneration units a chain keeps; beyond it adjacent units are merged pairwise (a union
/// of consecutive cycles is still a valid unit of the regenerative variance).
const MAX_CYCLE_UNITS: usize = 1024;

/// Index layout of [`Sums`] for `k` models and `g` bridge grid points.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Layout {
    pub k: usize,
    pub g: usize,
}

impl Layout {
    fn n_counts(&self) -> usize {
        self.k + 2 * self.k * self.k
    }
    fn n_logs(&self) -> usize {
        self.k * self.k * (3 + self.g)
    }
    /// Iterations spent in model `m`.
    pub fn visits(&self, m: usize) -> usize {
        m
    }
    /// Jump proposals `i → j`.
    pub fn prop(&self, i: usize, j: usize) -> usize {
        self.k + i * self.k + j
    }
    /// In-box jump proposals `i → j`.
    pub fn inbox(&self, i: usize, j: usize) -> usize {
        self.k + self.k * self.k + i * self.k + j
    }
    /// `ln Σ α` of the proposals `i → j`.
    pub fn alpha(&self, i: usize, j: usize) -> usize {
        i * self.k + j
    }
    /// `ln Σ` of the importance-sampling terms `[L_jπ_j(θ')/q̃_j(θ')]·[g̃_i(θ)/L_iπ_i(θ)]` of the
    /// in-box proposals `i → j` (`g̃_i`: the Gaussian/t part truncated to the box).
    pub fn is(&self, i: usize, j: usize) -> usize {
        self.k * self.k + i * self.k + j
    }
    /// `ln Σ` of the bridge terms at grid point `g` (numerator for `i < j`, denominator for
    /// `i > j`).
    pub fn bridge(&self, i: usize, j: usize, g: usize) -> usize {
        3 * self.k * self.k + (i * self.k + j) * self.g + g
    }
    /// `ln Σ α_g` of the proposals `i → j`, with the current state's proposal density taken
    /// as the Gaussian/t part alone (the one-sided Rao-Blackwell estimate; equal to `alpha`
    /// when the defensive weight is 0).
    pub fn alpha_g(&self, i: usize, j: usize) -> usize {
        2 * self.k * self.k + i * self.k + j
    }
}

/// Sums of the per-iteration series over a stretch of iterations: counts in linear scale, the
/// rest as natural logs of sums of positive terms (`−∞` when empty).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) struct Sums {
    pub counts: Vec<f64>,
    pub logs: Vec<f64>,
}

impl Sums {
    pub fn new(l: &Layout) -> Self {
        Sums {
            counts: vec![0.0; l.n_counts()],
            logs: vec![f64::NEG_INFINITY; l.n_logs()],
        }
    }

    pub fn add(&mut self, o: &Sums) {
        for (a, b) in self.counts.iter_mut().zip(&o.counts) {
            *a += b;
        }
        for (a, b) in self.logs.iter_mut().zip(&o.logs) {
            *a = lae(*a, *b);
        }
    }

    fn reset(&mut self) {
        self.counts.iter_mut().for_each(|v| *v = 0.0);
        self.logs.iter_mut().for_each(|v| *v = f64::NEG_INFINITY);
    }

    /// Iterations covered (every iteration visits one model).
    pub fn n(&self, l: &Layout) -> f64 {
        self.counts[..l.k].iter().sum()
    }
}

/// What every chain reads: the models and the constants of the run.
pub(crate) struct Shared<'a> {
    pub prepared: Vec<Prepared<'a>>,
    pub shape: ProposalShape,
    pub chi2: Option<ChiSquared<f64>>,
    /// Defensive weight `w` and its logs `ln(1 − w)`, `ln w`.
    pub defensive: (f64, f64, f64),
    pub ln_ratio: Vec<Vec<f64>>,
    pub cumulative: Vec<Vec<f64>>,
    /// `ln P_l − ln P_k` (box masses of the jump proposals), `[k][l]`.
    pub shift: Vec<Vec<f64>>,
    /// `ln P_l − ln P_{g,k}` (`P_g`: box mass of the Gaussian/t part alone), `[k][l]`.
    pub shift_g: Vec<Vec<f64>>,
    pub burn_in: usize,
    pub n_iter: usize,
    pub batch: usize,
    pub trace_every: usize,
    pub start_model: usize,
    pub layout: Layout,
    pub grid: Option<Grid>,
    /// Per model, the column of each of its parameters among the union of all models'
    /// parameters; `None`: no draws are kept.
    pub columns: Option<Vec<Vec<usize>>>,
    /// Width of a kept draw's parameter row (the union's size).
    pub n_columns: usize,
}

impl Shared<'_> {
    /// `(ln q_k(θ), ln g_k(θ))`: the (possibly defensive) jump proposal and its Gaussian/t
    /// part, given `ln π_k(θ)`.
    fn ln_q(&self, m: &Prepared<'_>, theta: &[f64], ln_prior: f64, buf: &mut [f64]) -> (f64, f64) {
        let g = m.ln_q(theta, self.shape, buf);
        let (w, ln_1mw, ln_w) = self.defensive;
        if w == 0.0 {
            (g, g)
        } else {
            (lae(ln_1mw + g, ln_w + ln_prior), g)
        }
    }
}

/// The constants every chain reads: jump ratios and cumulative jump rows from the validated
/// prior model probabilities `prior_p` and jump matrix `jump`, box-mass shifts, the proposal's
/// χ² (Student-t), batch size and trace spacing; `columns` is the union of the models'
/// parameters (each model's columns and the union's width).
pub(crate) fn shared<'a>(
    prepared: Vec<Prepared<'a>>,
    prior_p: &[f64],
    jump: &[Vec<f64>],
    boxes: &BoxMasses,
    opts: &RjOptions,
    per_chain: usize,
    columns: (Vec<Vec<usize>>, usize),
) -> Result<Shared<'a>, EvidenceError> {
    let k_models = prior_p.len();
    let (ln_box, ln_box_g) = (&boxes.ln_p, &boxes.ln_p_g);
    let n_post = per_chain - opts.burn_in;
    let batch = opts
        .batch_size
        .unwrap_or((n_post as f64).sqrt() as usize)
        .max(1);
    let trace_every = if opts.trace_every == 0 {
        (n_post / 1000).max(1)
    } else {
        opts.trace_every
    };
    // ln R[k][l] = ln P(l) + ln j(k|l) − ln P(k) − ln j(l|k).
    let ln_ratio: Vec<Vec<f64>> = (0..k_models)
        .map(|k| {
            (0..k_models)
                .map(|l| prior_p[l].ln() + jump[l][k].ln() - prior_p[k].ln() - jump[k][l].ln())
                .collect()
        })
        .collect();
    let cumulative: Vec<Vec<f64>> = jump
        .iter()
        .map(|row| {
            row.iter()
                .scan(0.0, |s, &p| {
                    *s += p;
                    Some(*s)
                })
                .collect()
        })
        .collect();
    let shift: Vec<Vec<f64>> = (0..k_models)
        .map(|k| (0..k_models).map(|l| ln_box[l] - ln_box[k]).collect())
        .collect();
    let shift_g: Vec<Vec<f64>> = (0..k_models)
        .map(|k| (0..k_models).map(|l| ln_box[l] - ln_box_g[k]).collect())
        .collect();
    let chi2 =
        match opts.proposal {
            ProposalShape::StudentT { nu } => Some(ChiSquared::new(nu).map_err(|_| {
                EvidenceError::option("proposal nu", nu, "ν must be finite and > 0")
            })?),
            ProposalShape::Gaussian => None,
        };
    let w = opts.defensive;
    let (columns, n_columns) = columns;
    Ok(Shared {
        prepared,
        shape: opts.proposal,
        chi2,
        defensive: (w, (1.0 - w).ln(), w.ln()),
        ln_ratio,
        cumulative,
        shift,
        shift_g,
        burn_in: opts.burn_in,
        n_iter: per_chain,
        batch,
        trace_every,
        start_model: opts.start_model,
        layout: Layout {
            k: k_models,
            g: GRID_OFFSETS.len(),
        },
        grid: None,
        columns: opts.keep_draws.then_some(columns),
        n_columns,
    })
}

/// One post-burn-in jump proposal, as the accumulators need it.
struct Proposal {
    from: usize,
    to: usize,
    inside: bool,
    ln_rho: f64,
    ln_alpha: f64,
    ln_alpha_g: f64,
}

/// A bridge input kept during the pilot: the in-box proposal's `ln ρ` and where it belongs.
#[derive(Clone, Copy, Serialize, Deserialize)]
struct PilotRecord {
    t_post: usize,
    cycle: u64,
    from: u16,
    to: u16,
    ln_rho: f64,
}

/// One independent chain: everything needed to continue it bit for bit (the proposal's scratch
/// buffers are rebuilt on load).
#[derive(Serialize, Deserialize)]
pub(crate) struct Chain {
    rng: Xoshiro256PlusPlus,
    /// Iterations done.
    pub t: usize,
    /// Current model.
    pub k: usize,
    cur: Vec<f64>,
    lp: f64,
    lpi: f64,
    /// `ln L` of the current state (`lp − lpi` without the rounding).
    ll: f64,
    lq: f64,
    lg: f64,
    #[serde(skip)]
    prop: Vec<f64>,
    #[serde(skip)]
    z: Vec<f64>,
    #[serde(skip)]
    scratch: Vec<f64>,
    /// Post-burn-in iterations per model.
    pub visits: Vec<u64>,
    pub rw_tried: Vec<u64>,
    pub rw_accepted: Vec<u64>,
    /// Whole run.
    pub proposed: Vec<Vec<u64>>,
    /// Whole run.
    pub accepted: Vec<Vec<u64>>,
    /// Post-burn-in accepted jumps.
    pub accepted_post: Vec<Vec<u64>>,
    /// Post-burn-in sojourns per model (entries, plus the model the post-burn-in part starts in).
    pub sojourns: Vec<u64>,
    pub non_finite: u64,
    /// `ln L` evaluations (proposals inside the prior support).
    pub likelihood_calls: u64,
    last_visited: Option<usize>,
    seg: Sums,
    /// Post-burn-in iterations before the first batch.
    pub batch_start: usize,
    pub batches: Vec<Sums>,
    pub cycles: Vec<Sums>,
    cycle_no: u64,
    level: u32,
    pilot: Vec<PilotRecord>,
    /// Pilot records already flushed out of the segment.
    pilot_flushed: usize,
    pub pilot_done: bool,
    pub trace: Vec<RjTracePoint>,
    /// The stretch of post-burn-in iterations before the first batch (`batch_start` of them),
    /// which only the regeneration units hold otherwise; the running estimates need it.
    pub head: Sums,
    /// Post-burn-in sojourns per model at the end of each batch (cumulative).
    pub batch_sojourns: Vec<Vec<u64>>,
    /// Kept post-burn-in draws: model index, parameters (row of `n_columns`, NaN where the
    /// model has no such parameter) and `ln L`.
    pub draw_model: Vec<i64>,
    pub draw_theta: Vec<f64>,
    pub draw_ln_l: Vec<f64>,
}

impl Chain {
    pub fn new(sh: &Shared<'_>, j: usize, seed: u64) -> Self {
        let k_models = sh.prepared.len();
        let max_dim = sh.prepared.iter().map(|p| p.dim).max().unwrap_or(0);
        let k = sh.start_model;
        let m = &sh.prepared[k];
        let d = m.dim;
        let mut cur = vec![0.0; max_dim];
        cur[..d].copy_from_slice(&m.center);
        let lpi = m.target.prior().ln_pdf(&cur[..d]);
        let ll = m.target.ln_likelihood(&cur[..d]);
        let lp = lpi + ll;
        let mut scratch = vec![0.0; max_dim];
        let (lq, lg) = sh.ln_q(m, &cur[..d], lpi, &mut scratch);
        let n_post = sh.n_iter - sh.burn_in;
        let n_batches = n_post / sh.batch;
        let l = &sh.layout;
        let kept = if sh.columns.is_some() { n_post } else { 0 };
        Chain {
            rng: chain_rng(seed, j),
            t: 0,
            k,
            cur,
            lp,
            lpi,
            ll,
            lq,
            lg,
            prop: vec![0.0; max_dim],
            z: vec![0.0; max_dim],
            scratch,
            visits: vec![0; k_models],
            rw_tried: vec![0; k_models],
            rw_accepted: vec![0; k_models],
            proposed: vec![vec![0; k_models]; k_models],
            accepted: vec![vec![0; k_models]; k_models],
            accepted_post: vec![vec![0; k_models]; k_models],
            sojourns: vec![0; k_models],
            non_finite: 0,
            likelihood_calls: 0,
            last_visited: None,
            seg: Sums::new(l),
            batch_start: n_post - n_batches * sh.batch,
            batches: vec![Sums::new(l); n_batches],
            cycles: vec![Sums::new(l)],
            cycle_no: 0,
            level: 0,
            pilot: Vec::new(),
            pilot_flushed: 0,
            pilot_done: false,
            trace: Vec::new(),
            head: Sums::new(l),
            batch_sojourns: Vec::with_capacity(n_batches),
            draw_model: Vec::with_capacity(kept),
            draw_theta: Vec::with_capacity(kept * sh.n_columns),
            draw_ln_l: Vec::with_capacity(kept),
        }
    }

    /// Sizes the scratch buffers for models of at most `max_dim` parameters (after a
    /// checkpoint's load); `Err` if the loaded state does not fit this run.
    pub fn prepare(&mut self, sh: &Shared<'_>) -> Result<(), String> {
        let k_models = sh.prepared.len();
        let max_dim = sh.prepared.iter().map(|p| p.dim).max().unwrap_or(0);
        let l = &sh.layout;
        let sums_fit = |s: &Sums| s.counts.len() == l.n_counts() && s.logs.len() == l.n_logs();
        let fits = self.k < k_models
            && self.t <= sh.n_iter
            && self.cur.len() == max_dim
            && self.visits.len() == k_models
            && self.proposed.len() == k_models
            && self.proposed.iter().all(|r| r.len() == k_models)
            && sums_fit(&self.seg)
            && sums_fit(&self.head)
            && self.batches.iter().all(sums_fit)
            && self.cycles.iter().all(sums_fit);
        if !fits {
            return Err(format!(
                "a jump chain's state does not fit {k_models} models of at most {max_dim} parameters after {} iterations",
                self.t
            ));
        }
        for v in [&mut self.prop, &mut self.z, &mut self.scratch] {
            v.resize(max_dim, 0.0);
        }
        Ok(())
    }

    /// Runs until `t_end` iterations are done (or the chain's end).
    pub fn run_to(&mut self, t_end: usize, sh: &Shared<'_>) {
        let t_end = t_end.min(sh.n_iter);
        while self.t < t_end {
            self.step(sh);
        }
    }

    fn step(&mut self, sh: &Shared<'_>) {
        let k_models = sh.prepared.len();
        let t = self.t;
        let post = t >= sh.burn_in;
        let rng = &mut self.rng;
        let mut k = self.k;
        // (i) in-model random walk
        {
            let m = &sh.prepared[k];
            let d = m.dim;
            if d > 0 {
                for zi in self.z[..d].iter_mut() {
                    *zi = StandardNormal.sample(rng);
                }
                for i in 0..d {
                    let row = &m.lrw[i * d..i * d + i + 1];
                    self.prop[i] = self.cur[i]
                        + row
                            .iter()
                            .zip(&self.z[..=i])
                            .map(|(a, b)| a * b)
                            .sum::<f64>();
                }
                let lpi_new = m.target.prior().ln_pdf(&self.prop[..d]);
                let (lp_new, ll_new) = if lpi_new == f64::NEG_INFINITY {
                    (f64::NEG_INFINITY, f64::NEG_INFINITY)
                } else {
                    self.likelihood_calls += 1;
                    let ll = m.target.ln_likelihood(&self.prop[..d]);
                    (lpi_new + ll, ll)
                };
                self.rw_tried[k] += 1;
                if lp_new.is_nan() || lp_new == f64::INFINITY {
                    self.non_finite += 1;
                } else if rng.random::<f64>().ln() < lp_new - self.lp {
                    self.cur[..d].copy_from_slice(&self.prop[..d]);
                    self.lp = lp_new;
                    self.lpi = lpi_new;
                    self.ll = ll_new;
                    (self.lq, self.lg) = sh.ln_q(m, &self.cur[..d], lpi_new, &mut self.scratch);
                    self.rw_accepted[k] += 1;
                }
            }
        }
        // (ii)–(iv) model jump with an independence proposal
        let mut regenerated = false;
        if k_models > 1 {
            let u: f64 = rng.random();
            let kn = sh.cumulative[k]
                .iter()
                .position(|&c| u < c)
                .unwrap_or(k_models - 1);
            let m = &sh.prepared[kn];
            let dn = m.dim;
            let (w, _, _) = sh.defensive;
            let from_prior = w > 0.0 && rng.random::<f64>() < w;
            if from_prior {
                for (p, kind) in self.prop[..dn].iter_mut().zip(m.target.prior().kinds()) {
                    *p = kind.sample(rng);
                }
            } else {
                for zi in self.z[..dn].iter_mut() {
                    *zi = StandardNormal.sample(rng);
                }
                let scale = match (&sh.chi2, sh.shape) {
                    (Some(c), ProposalShape::StudentT { nu }) => (nu / c.sample(rng)).sqrt(),
                    _ => 1.0,
                };
                for i in 0..dn {
                    let row = &m.lq[i * dn..i * dn + i + 1];
                    self.prop[i] = m.center[i]
                        + scale
                            * row
                                .iter()
                                .zip(&self.z[..=i])
                                .map(|(a, b)| a * b)
                                .sum::<f64>();
                }
            }
            self.proposed[k][kn] += 1;
            let lpi_new = m.target.prior().ln_pdf(&self.prop[..dn]);
            let inside = lpi_new > f64::NEG_INFINITY;
            let ll_new = if inside {
                self.likelihood_calls += 1;
                m.target.ln_likelihood(&self.prop[..dn])
            } else {
                f64::NEG_INFINITY
            };
            let mut lp_new = if inside {
                lpi_new + ll_new
            } else {
                f64::NEG_INFINITY
            };
            if lp_new.is_nan() || lp_new == f64::INFINITY {
                self.non_finite += 1;
                lp_new = f64::NEG_INFINITY;
            }
            let (lq_new, lg_new) = if inside {
                sh.ln_q(m, &self.prop[..dn], lpi_new, &mut self.scratch)
            } else {
                // only the Gaussian part has mass outside the prior support
                let g = m.ln_q(&self.prop[..dn], sh.shape, &mut self.scratch);
                (g, g)
            };
            let (ln_rho, ln_rho_g) = if lp_new == f64::NEG_INFINITY {
                (f64::NEG_INFINITY, f64::NEG_INFINITY)
            } else {
                (
                    (lp_new - lq_new) - (self.lp - self.lq),
                    (lp_new - lq_new) - (self.lp - self.lg),
                )
            };
            let ln_r = ln_rho + sh.ln_ratio[k][kn];
            let u_accept: f64 = rng.random();
            if post && kn != k {
                let ln_alpha_g = (ln_rho_g + sh.ln_ratio[k][kn]).min(0.0);
                self.record_proposal(
                    sh,
                    Proposal {
                        from: k,
                        to: kn,
                        inside,
                        ln_rho,
                        ln_alpha: ln_r.min(0.0),
                        ln_alpha_g,
                    },
                );
            }
            if u_accept.ln() < ln_r {
                self.accepted[k][kn] += 1;
                if post {
                    self.accepted_post[k][kn] += 1;
                }
                regenerated = kn != k && kn == sh.start_model;
                k = kn;
                self.cur[..dn].copy_from_slice(&self.prop[..dn]);
                self.lp = lp_new;
                self.lpi = lpi_new;
                self.ll = ll_new;
                self.lq = lq_new;
                self.lg = lg_new;
            }
        }
        self.k = k;
        if post {
            let t_post = t - sh.burn_in;
            if regenerated && self.last_visited.is_some() {
                self.flush(sh, t_post);
                self.cycle_no += 1;
                if (self.cycle_no >> self.level) as usize >= MAX_CYCLE_UNITS {
                    self.merge_cycles();
                }
                let idx = (self.cycle_no >> self.level) as usize;
                if idx >= self.cycles.len() {
                    self.cycles.push(Sums::new(&sh.layout));
                }
            }
            if self.last_visited != Some(k) {
                self.sojourns[k] += 1;
                self.last_visited = Some(k);
            }
            self.visits[k] += 1;
            self.seg.counts[sh.layout.visits(k)] += 1.0;
            if let Some(cols) = &sh.columns {
                self.draw_model.push(k as i64);
                let row = self.draw_theta.len();
                self.draw_theta.resize(row + sh.n_columns, f64::NAN);
                for (&c, &x) in cols[k].iter().zip(&self.cur) {
                    self.draw_theta[row + c] = x;
                }
                self.draw_ln_l.push(self.ll);
            }
            let done = t_post + 1;
            let batch_end =
                done > self.batch_start && (done - self.batch_start).is_multiple_of(sh.batch);
            if done == self.batch_start || batch_end {
                self.flush(sh, t_post);
            }
            if batch_end {
                self.batch_sojourns.push(self.sojourns.clone());
            }
            if done.is_multiple_of(sh.trace_every) || t + 1 == sh.n_iter {
                self.trace.push(RjTracePoint {
                    iteration: t + 1,
                    visits: self.visits.clone(),
                });
            }
            if t + 1 == sh.n_iter {
                self.flush(sh, t_post);
            }
        }
        self.t += 1;
    }

    /// Adds a post-burn-in jump proposal `from → to` to the current segment.
    fn record_proposal(&mut self, sh: &Shared<'_>, p: Proposal) {
        let Proposal {
            from,
            to,
            inside,
            ln_rho,
            ln_alpha,
            ln_alpha_g,
        } = p;
        let l = &sh.layout;
        let s = &mut self.seg;
        s.counts[l.prop(from, to)] += 1.0;
        let ia = l.alpha(from, to);
        s.logs[ia] = lae(s.logs[ia], ln_alpha);
        let ig = l.alpha_g(from, to);
        s.logs[ig] = lae(s.logs[ig], ln_alpha_g);
        if !inside {
            return;
        }
        s.counts[l.inbox(from, to)] += 1.0;
        // ln ρ_g − ln ρ = ln g(θ) − ln q(θ) of the current state, which the α_g term holds too
        let is_term = ln_alpha_g_free(ln_rho, self.lq, self.lg) + sh.shift_g[from][to];
        let ii = l.is(from, to);
        s.logs[ii] = lae(s.logs[ii], is_term);
        match &sh.grid {
            Some(grid) => add_bridge_terms(s, l, grid, sh, from, to, ln_rho),
            None => self.pilot.push(PilotRecord {
                t_post: self.t - sh.burn_in,
                cycle: self.cycle_no,
                from: from as u16,
                to: to as u16,
                ln_rho,
            }),
        }
    }

    /// Moves the current segment into its batch and its cycle unit.
    fn flush(&mut self, sh: &Shared<'_>, t_post: usize) {
        if t_post >= self.batch_start {
            let bi = (t_post - self.batch_start) / sh.batch;
            if let Some(b) = self.batches.get_mut(bi) {
                b.add(&self.seg);
            }
        } else {
            self.head.add(&self.seg);
        }
        let ci = (self.cycle_no >> self.level) as usize;
        self.cycles[ci].add(&self.seg);
        self.seg.reset();
        self.pilot_flushed = self.pilot.len();
    }

    fn merge_cycles(&mut self) {
        let old = std::mem::take(&mut self.cycles);
        for pair in old.chunks(2) {
            let mut s = pair[0].clone();
            if let Some(b) = pair.get(1) {
                s.add(b);
            }
            self.cycles.push(s);
        }
        self.level += 1;
    }

    /// Pilot records for the grid (in order).
    pub fn pilot_inputs(&self) -> impl Iterator<Item = (usize, usize, f64)> + '_ {
        self.pilot
            .iter()
            .map(|r| (r.from as usize, r.to as usize, r.ln_rho))
    }

    /// Adds the pilot's bridge terms (now that the grid is known) and frees the records.
    pub fn replay_pilot(&mut self, sh: &Shared<'_>) {
        let l = &sh.layout;
        let grid = sh.grid.as_ref().expect("grid is set before the replay");
        // records after the last flush are still in the current segment
        let records = std::mem::take(&mut self.pilot);
        for (i, r) in records.into_iter().enumerate() {
            let (from, to) = (r.from as usize, r.to as usize);
            if i >= self.pilot_flushed {
                add_bridge_terms(&mut self.seg, l, grid, sh, from, to, r.ln_rho);
                continue;
            }
            if r.t_post >= self.batch_start {
                if let Some(b) = self
                    .batches
                    .get_mut((r.t_post - self.batch_start) / sh.batch)
                {
                    add_bridge_terms(b, l, grid, sh, from, to, r.ln_rho);
                }
            } else {
                add_bridge_terms(&mut self.head, l, grid, sh, from, to, r.ln_rho);
            }
            let ci = (r.cycle >> self.level) as usize;
            add_bridge_terms(&mut self.cycles[ci], l, grid, sh, from, to, r.ln_rho);
        }
        self.pilot_flushed = 0;
        self.pilot_done = true;
    }
}

/// `ln ρ_g = ln ρ + ln q(θ) − ln g(θ)`: the proposal's weight ratio with the current state's
/// density taken as the Gaussian/t part.
fn ln_alpha_g_free(ln_rho: f64, lq: f64, lg: f64) -> f64 {
    if ln_rho == f64::NEG_INFINITY {
        f64::NEG_INFINITY
    } else {
        ln_rho + lg - lq
    }
}

fn add_bridge_terms(
    s: &mut Sums,
    l: &Layout,
    grid: &Grid,
    sh: &Shared<'_>,
    from: usize,
    to: usize,
    ln_rho: f64,
) {
    let (a, b) = (from.min(to), from.max(to));
    let pg = grid.pair(a, b);
    for (g, &lr) in pg.ln_r.iter().enumerate() {
        let term = if from == a {
            let x = ln_rho + sh.shift[a][b];
            if x == f64::NEG_INFINITY {
                f64::NEG_INFINITY
            } else {
                x - lae(pg.ln_s1 + lr, pg.ln_s2 + x)
            }
        } else {
            let y = -ln_rho + sh.shift[a][b];
            if y == f64::INFINITY {
                f64::NEG_INFINITY
            } else {
                -lae(pg.ln_s1 + lr, pg.ln_s2 + y)
            }
        };
        let i = l.bridge(from, to, g);
        s.logs[i] = lae(s.logs[i], term);
    }
}
