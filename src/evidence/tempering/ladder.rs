//! The tempering ladder as a [`Sampler`]: rungs that each take a random-walk step per sweep,
//! the even–odd swap round between them, and the burn-in's adaptation of the proposal scales and
//! of the ladder. Its whole state ([`Ladder`]) serialises, so a run continues from a checkpoint
//! bit for bit.

use super::options::{LADDER_KAPPA, N_PILOT, SNAPSHOTS, TemperingOptions};
use crate::density::LogDensity;
use crate::evidence::error::EvidenceError;
use crate::linalg::{Spd, SpdOptions, symmetrised};
use crate::prior::PriorKind;
use crate::sampler::{Sampler, chain_rng};
use nalgebra::DMatrix;
use rand::RngExt;
use rand_distr::{Distribution, StandardNormal};
use rand_xoshiro::Xoshiro256PlusPlus;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// One rung's chain: its state, random stream, proposal and counters (everything a checkpoint
/// needs; the proposal's scratch buffers are rebuilt on load).
#[derive(Serialize, Deserialize)]
pub(crate) struct Rung {
    pub(crate) beta: f64,
    pub(crate) theta: Vec<f64>,
    pub(crate) ln_l: f64,
    ln_prior: f64,
    rng: Xoshiro256PlusPlus,
    /// Row-major lower Cholesky factor of `Σ_i`.
    chol: Vec<f64>,
    /// `ln s_i`.
    pub(crate) ln_scale: f64,
    /// Largest allowed `ln s_i`.
    ln_scale_max: f64,
    #[serde(skip)]
    prop: Vec<f64>,
    #[serde(skip)]
    z: Vec<f64>,
    pub(crate) tried: u64,
    pub(crate) accepted: u64,
    pub(crate) non_finite: u64,
    pub(crate) evals: u64,
}

impl Rung {
    /// Sizes the scratch buffers (after construction or a checkpoint's load).
    fn prepare(&mut self) {
        let d = self.theta.len();
        self.prop.resize(d, 0.0);
        self.z.resize(d, 0.0);
    }

    /// One sweep's move on this rung: an exact prior draw at β = 0, else a random-walk
    /// Metropolis step on `L^β π`.
    pub(crate) fn step(&mut self, target: &dyn LogDensity) {
        let prior = target.prior();
        if self.beta == 0.0 {
            self.theta = prior.sample(&mut self.rng);
            self.ln_prior = prior.ln_pdf(&self.theta);
            let l = target.ln_likelihood(&self.theta);
            self.evals += 1;
            self.ln_l = if l.is_nan() || l == f64::INFINITY {
                self.non_finite += 1;
                f64::NEG_INFINITY
            } else {
                l
            };
            self.tried += 1;
            self.accepted += 1;
            return;
        }
        let d = self.theta.len();
        let s = self.ln_scale.exp();
        for zi in self.z.iter_mut() {
            *zi = StandardNormal.sample(&mut self.rng);
        }
        for i in 0..d {
            let row = &self.chol[i * d..i * d + i + 1];
            self.prop[i] = self.theta[i]
                + s * row
                    .iter()
                    .zip(&self.z[..=i])
                    .map(|(a, b)| a * b)
                    .sum::<f64>();
        }
        let u: f64 = self.rng.random();
        self.tried += 1;
        let lp = prior.ln_pdf(&self.prop);
        if lp == f64::NEG_INFINITY {
            return;
        }
        let l = target.ln_likelihood(&self.prop);
        self.evals += 1;
        if l.is_nan() || l == f64::INFINITY {
            self.non_finite += 1;
            return;
        }
        let ln_a = self.beta * (l - self.ln_l) + (lp - self.ln_prior);
        if u.ln() < ln_a {
            std::mem::swap(&mut self.theta, &mut self.prop);
            self.ln_l = l;
            self.ln_prior = lp;
            self.accepted += 1;
        }
    }
}

/// Per-rung proposal geometry: `C⁻¹`, the prior precisions and widths.
pub(crate) struct Geometry {
    dim: usize,
    cov_inv: DMatrix<f64>,
    prior_prec: Vec<f64>,
    /// Per-coordinate prior width (∞ for a Gaussian prior): the cap on a step.
    width: Vec<f64>,
}

impl Geometry {
    /// Row-major Cholesky factor of `Σ_β = (β C⁻¹ + (1 − β) P⁻¹)⁻¹` and the largest `ln s`.
    pub(crate) fn rung(&self, beta: f64) -> Result<(Vec<f64>, f64), EvidenceError> {
        let d = self.dim;
        let mut m = &self.cov_inv * beta;
        for i in 0..d {
            m[(i, i)] += (1.0 - beta) * self.prior_prec[i];
        }
        let fix = "pass a symmetric positive definite covariance of sensible scale";
        let prec = Spd::new(&m).map_err(EvidenceError::matrix(
            "tempered precision β C⁻¹ + (1 − β) P⁻¹",
            fix,
        ))?;
        let sigma = symmetrised(&prec.inverse());
        let chol = Spd::new(&sigma)
            .map_err(EvidenceError::matrix("tempered covariance", fix))?
            .l_row_major();
        let mut cap = f64::INFINITY;
        for i in 0..d {
            cap = cap.min(self.width[i] / sigma[(i, i)].sqrt());
        }
        Ok((chol, cap.ln()))
    }
}

impl Geometry {
    /// `C⁻¹` from the posterior covariance `cov`, and the prior's precisions and widths.
    pub(crate) fn new(
        target: &dyn LogDensity,
        cov: &DMatrix<f64>,
    ) -> Result<Geometry, EvidenceError> {
        let cov_chol = SpdOptions::default()
            .names(target.prior().names())
            .factor(cov)
            .map_err(EvidenceError::matrix(
                "tempering proposal covariance",
                "pass the inverse Fisher matrix or an in-model chain's sample covariance",
            ))?;
        let cov_inv = symmetrised(&cov_chol.inverse());
        let (prior_prec, width): (Vec<f64>, Vec<f64>) = target
            .prior()
            .kinds()
            .iter()
            .map(|k| match *k {
                PriorKind::Uniform { lo, hi } | PriorKind::LogUniform { lo, hi } => {
                    (12.0 / (hi - lo).powi(2), hi - lo)
                }
                PriorKind::Gaussian { sigma, .. } => (1.0 / (sigma * sigma), f64::INFINITY),
            })
            .unzip();
        Ok(Geometry {
            dim: target.dim(),
            cov_inv,
            prior_prec,
            width,
        })
    }
}

/// The initial ladder and what choosing it cost.
pub(crate) struct Pilot {
    pub(crate) betas: Vec<f64>,
    /// Likelihood evaluations of the pilot draws.
    pub(crate) evals: u64,
    /// Pilot draws whose `ln L` was NaN or `+∞`.
    pub(crate) non_finite: u64,
}

/// The geometric ladder from the pilot `β_1 = 1/sd_π(ln L)` (from [`N_PILOT`] prior draws on
/// stream `N + 1`; capped at `1/(N−1)`) to 1.
pub(crate) fn pilot_ladder(target: &dyn LogDensity, opts: &TemperingOptions) -> Pilot {
    let prior = target.prior();
    let n_t = opts.n_temps;
    let mut evals = 0u64;
    let mut pilot_non_finite = 0u64;
    let mut rng = chain_rng(opts.seed, n_t + 1);
    let mut ls = Vec::with_capacity(N_PILOT);
    for _ in 0..N_PILOT {
        let l = target.ln_likelihood(&prior.sample(&mut rng));
        evals += 1;
        if l.is_finite() {
            ls.push(l);
        } else if !(l == f64::NEG_INFINITY) {
            pilot_non_finite += 1;
        }
    }
    let cap = 1.0 / (n_t - 1) as f64;
    let beta1 = if ls.len() >= 2 {
        let m = ls.iter().sum::<f64>() / ls.len() as f64;
        let sd = (ls.iter().map(|l| (l - m).powi(2)).sum::<f64>() / (ls.len() - 1) as f64).sqrt();
        if sd > 0.0 { (1.0 / sd).min(cap) } else { cap }
    } else {
        cap
    };
    let beta1 = beta1.max(1e-300);
    let mut b = vec![0.0];
    for i in 0..n_t - 1 {
        let f = i as f64 / (n_t - 2) as f64;
        b.push((beta1.ln() * (1.0 - f)).exp());
    }
    b[n_t - 1] = 1.0;
    Pilot {
        betas: b,
        evals,
        non_finite: pilot_non_finite,
    }
}

/// One rung per β, all at `start` (`(ln L, ln π)` there), rung `i` on stream `i + 1`.
fn start_rungs(
    betas: &[f64],
    geom: &Geometry,
    start: &[f64],
    (ln_l0, ln_prior0): (f64, f64),
    opts: &TemperingOptions,
) -> Result<Vec<Rung>, EvidenceError> {
    let d = start.len();
    let init_ln_scale = (2.38 / (d as f64).sqrt()).ln();
    let mut rungs = Vec::with_capacity(betas.len());
    for (i, &beta) in betas.iter().enumerate() {
        let (chol, cap) = geom.rung(beta)?;
        rungs.push(Rung {
            beta,
            theta: start.to_vec(),
            ln_l: ln_l0,
            ln_prior: ln_prior0,
            rng: chain_rng(opts.seed, i + 1),
            chol,
            ln_scale: init_ln_scale.min(cap),
            ln_scale_max: cap,
            prop: vec![0.0; d],
            z: vec![0.0; d],
            tried: 0,
            accepted: 0,
            non_finite: 0,
            evals: 0,
        });
    }
    Ok(rungs)
}

/// The deterministic even–odd swap round of sweep `t`, counting each pair's proposals and
/// acceptances into `tried` and `acc`.
fn swap_round(
    rungs: &mut [Rung],
    t: usize,
    swap_rng: &mut Xoshiro256PlusPlus,
    tried: &mut [u64],
    acc: &mut [u64],
) {
    let n_t = rungs.len();
    let mut i = 1 + t % 2;
    while i < n_t {
        let (lo, hi) = rungs.split_at_mut(i);
        let (a, b) = (&mut lo[i - 1], &mut hi[0]);
        let ln_a = (b.beta - a.beta) * (a.ln_l - b.ln_l);
        let u: f64 = swap_rng.random();
        let ok = u.ln() < ln_a;
        if ok {
            std::mem::swap(&mut a.theta, &mut b.theta);
            std::mem::swap(&mut a.ln_l, &mut b.ln_l);
            std::mem::swap(&mut a.ln_prior, &mut b.ln_prior);
        }
        tried[i - 1] += 1;
        acc[i - 1] += ok as u64;
        i += 2;
    }
}

type Windows<'a> = (&'a mut [u64], &'a mut [u64], &'a mut [(u64, u64)]);

/// One adaptation step at the end of a burn-in window: proposal scales toward the target
/// acceptance, then the ladder toward equal swap rates.
fn adapt(
    rungs: &mut [Rung],
    betas: &mut [f64],
    geom: &Geometry,
    opts: &TemperingOptions,
    k: usize,
    t0: f64,
    (win_tried, win_acc, win_rung): Windows<'_>,
) -> Result<(), EvidenceError> {
    let n_t = rungs.len();
    let gamma = 1.0 / ((k + 1) as f64).sqrt();
    for (r, w) in rungs.iter_mut().zip(win_rung.iter_mut()) {
        let (tried, acc) = (r.tried - w.0, r.accepted - w.1);
        *w = (r.tried, r.accepted);
        if r.beta > 0.0 && tried > 0 {
            let a = acc as f64 / tried as f64;
            r.ln_scale = (r.ln_scale + gamma * (a - opts.target_acceptance)).min(r.ln_scale_max);
        }
    }
    if opts.adapt_ladder && n_t > 2 {
        // Cold-first temperatures T_0 = 1 < … < T_{N−2}; T_{N−1} = ∞ is the prior.
        let rate = |j: usize| {
            // pair between cold j and j + 1 = ascending pair (N−2−j, N−1−j)
            let p = n_t - 2 - j;
            if win_tried[p] > 0 {
                win_acc[p] as f64 / win_tried[p] as f64
            } else {
                0.0
            }
        };
        let kappa = LADDER_KAPPA * t0 / (k as f64 + t0);
        let temps: Vec<f64> = (0..n_t - 1).map(|j| 1.0 / betas[n_t - 1 - j]).collect();
        let mut new_t = vec![1.0; n_t - 1];
        for j in 0..n_t - 2 {
            let dt = (temps[j + 1] - temps[j]) * (kappa * (rate(j) - rate(j + 1))).exp();
            new_t[j + 1] = new_t[j] + dt;
        }
        let mut changed = false;
        for j in 1..n_t - 1 {
            let b = 1.0 / new_t[j];
            let i = n_t - 1 - j;
            if b.is_finite() && b > 0.0 && b != betas[i] {
                betas[i] = b;
                changed = true;
            }
        }
        if changed {
            for (i, r) in rungs.iter_mut().enumerate() {
                if r.beta != betas[i] {
                    r.beta = betas[i];
                    let (chol, cap) = geom.rung(r.beta)?;
                    r.chol = chol;
                    r.ln_scale_max = cap;
                    r.ln_scale = r.ln_scale.min(cap);
                }
            }
        }
    }
    win_tried.fill(0);
    win_acc.fill(0);
    Ok(())
}

/// A tempering run between sweeps: everything needed to continue it bit for bit.
#[derive(Serialize, Deserialize)]
pub(crate) struct Ladder {
    pub(crate) rungs: Vec<Rung>,
    /// The current ladder (adapted during the burn-in, frozen afterwards).
    pub(crate) betas: Vec<f64>,
    swap_rng: Xoshiro256PlusPlus,
    /// Sweeps done.
    pub(crate) t: usize,
    /// `ln L` of every rung after each post-burn-in sweep, sweep-major (`[t * n_t + i]`).
    pub(crate) series: Vec<f64>,
    pub(crate) swaps_tried: Vec<u64>,
    pub(crate) swaps_acc: Vec<u64>,
    /// Swap counts of the current adaptation window.
    win_tried: Vec<u64>,
    win_acc: Vec<u64>,
    /// Each rung's `(tried, accepted)` at the start of the current window.
    win_rung: Vec<(u64, u64)>,
    pub(crate) rung_samples: Vec<Vec<Vec<f64>>>,
    /// Adaptation steps done.
    update: usize,
    /// What choosing the initial ladder cost.
    pub(crate) pilot_evals: u64,
    pub(crate) pilot_non_finite: u64,
}

impl Ladder {
    /// A ladder on `pilot.betas` with every rung at `start` (`(ln L, ln π)` there), before its
    /// first sweep; rung 0 has drawn its first prior point.
    pub(crate) fn new(
        target: &dyn LogDensity,
        pilot: Pilot,
        geom: &Geometry,
        start: &[f64],
        start_values: (f64, f64),
        opts: &TemperingOptions,
    ) -> Result<Self, EvidenceError> {
        let n_t = opts.n_temps;
        let mut rungs = start_rungs(&pilot.betas, geom, start, start_values, opts)?;
        // Rung 0 starts from a prior draw.
        rungs[0].step(target);
        Ok(Ladder {
            rungs,
            betas: pilot.betas,
            swap_rng: chain_rng(opts.seed, 0),
            t: 0,
            series: Vec::with_capacity((opts.n_iter - opts.burn_in) * n_t),
            swaps_tried: vec![0; n_t - 1],
            swaps_acc: vec![0; n_t - 1],
            win_tried: vec![0; n_t - 1],
            win_acc: vec![0; n_t - 1],
            win_rung: vec![(0, 0); n_t],
            rung_samples: vec![Vec::with_capacity(SNAPSHOTS); n_t],
            update: 0,
            pilot_evals: pilot.evals,
            pilot_non_finite: pilot.non_finite,
        })
    }

    /// `Err(problem)` if a loaded state does not fit `opts` and dimension `d`; otherwise sizes
    /// its buffers.
    pub(crate) fn check_and_prepare(
        &mut self,
        opts: &TemperingOptions,
        d: usize,
    ) -> Result<(), String> {
        let n_t = opts.n_temps;
        let n_post = self.t.saturating_sub(opts.burn_in);
        let ok = self.rungs.len() == n_t
            && self.betas.len() == n_t
            && self.t <= opts.n_iter
            && self.series.len() == n_post * n_t
            && [
                &self.swaps_tried,
                &self.swaps_acc,
                &self.win_tried,
                &self.win_acc,
            ]
            .iter()
            .all(|v| v.len() == n_t - 1)
            && self.win_rung.len() == n_t
            && self.rung_samples.len() == n_t
            && self
                .rungs
                .iter()
                .all(|r| r.theta.len() == d && r.chol.len() == d * d);
        if !ok {
            return Err(format!(
                "its ladder state does not fit {n_t} rungs of {d} parameters after {} sweeps",
                self.t
            ));
        }
        for r in &mut self.rungs {
            r.prepare();
        }
        Ok(())
    }

    /// Sweep `t`: every rung steps, then one even–odd swap round; the burn-in adapts scales
    /// and ladder every `adapt_interval` sweeps; a post-burn-in sweep is recorded.
    fn sweep(
        &mut self,
        target: &dyn LogDensity,
        geom: &Geometry,
        opts: &TemperingOptions,
    ) -> Result<(), EvidenceError> {
        let t = self.t;
        if opts.parallel {
            self.rungs.par_iter_mut().for_each(|r| r.step(target));
        } else {
            self.rungs.iter_mut().for_each(|r| r.step(target));
        }
        let (tried, acc) = if t >= opts.burn_in {
            (&mut self.swaps_tried, &mut self.swaps_acc)
        } else {
            (&mut self.win_tried, &mut self.win_acc)
        };
        swap_round(&mut self.rungs, t, &mut self.swap_rng, tried, acc);
        if t < opts.burn_in {
            if (t + 1).is_multiple_of(opts.adapt_interval) {
                let n_updates = opts.burn_in / opts.adapt_interval;
                let t0 = (n_updates as f64 / 4.0).max(1.0);
                adapt(
                    &mut self.rungs,
                    &mut self.betas,
                    geom,
                    opts,
                    self.update,
                    t0,
                    (&mut self.win_tried, &mut self.win_acc, &mut self.win_rung),
                )?;
                self.update += 1;
            }
            if t + 1 == opts.burn_in {
                for r in self.rungs.iter_mut() {
                    r.tried = 0;
                    r.accepted = 0;
                }
            }
        } else {
            let n_post = opts.n_iter - opts.burn_in;
            self.series.extend(self.rungs.iter().map(|r| r.ln_l));
            if (t - opts.burn_in + 1).is_multiple_of((n_post / SNAPSHOTS).max(1)) {
                for (keep, r) in self.rung_samples.iter_mut().zip(self.rungs.iter()) {
                    if keep.len() < SNAPSHOTS {
                        keep.push(r.theta.clone());
                    }
                }
            }
        }
        self.t = t + 1;
        Ok(())
    }
}

/// The ladder with what it sweeps on, as the [`Driver`](crate::sampler::Driver) runs it.
pub(crate) struct Sweeping<'a> {
    pub(crate) target: &'a dyn LogDensity,
    pub(crate) geom: &'a Geometry,
    pub(crate) opts: &'a TemperingOptions,
    pub(crate) ladder: Ladder,
}

impl Sampler for Sweeping<'_> {
    type Error = EvidenceError;

    fn done(&self) -> usize {
        self.ladder.t
    }

    fn total(&self) -> usize {
        self.opts.n_iter
    }

    fn advance(&mut self, until: usize) -> Result<(), EvidenceError> {
        while self.ladder.t < until {
            self.ladder.sweep(self.target, self.geom, self.opts)?;
        }
        Ok(())
    }
}
