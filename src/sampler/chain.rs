//! One chain: its complete, serialisable state and the allocation-free MH loop.

use rand::{RngExt, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;
use serde::{Deserialize, Serialize};

use super::adapt::AdaptState;
use super::chains::{BestPoint, Chain, ChainCounts};
use super::error::SamplerError;
use super::independence::Independence;
use super::proposal::{GaussianProposal, Proposal};
use super::settings::{MhSettings, Start};
use crate::density::LogDensity;

/// The random stream of chain `chain` in a run seeded with `seed`:
/// `Xoshiro256PlusPlus::seed_from_u64(seed)` advanced by `chain` calls of `jump()` (2¹²⁸ steps
/// each), so streams never overlap and depend only on `(seed, chain)`, never on threads.
///
/// ```
/// use occam::sampler::chain_rng;
/// use rand::Rng;
/// assert_eq!(chain_rng(5, 2).next_u64(), chain_rng(5, 2).next_u64());
/// assert_ne!(chain_rng(5, 0).next_u64(), chain_rng(5, 1).next_u64());
/// ```
pub fn chain_rng(seed: u64, chain: usize) -> Xoshiro256PlusPlus {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    for _ in 0..chain {
        rng.jump();
    }
    rng
}

/// What the progress observer receives.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Progress {
    /// Chain index.
    pub chain: usize,
    /// Iterations this chain has completed.
    pub iteration: usize,
    /// Iterations this chain will run in total.
    pub n_iter: usize,
    /// Accepted / proposed over all iterations so far (burn-in included).
    pub acceptance: f64,
}

/// Everything needed to continue a chain bit-for-bit. Floats are stored as bit patterns
/// (see `bits`).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub(crate) struct ChainState {
    pub(crate) index: usize,
    rng: Xoshiro256PlusPlus,
    /// Iterations completed.
    pub(crate) iter: usize,
    #[serde(with = "super::bits::vec")]
    x: Vec<f64>,
    #[serde(with = "super::bits::scalar")]
    pub(crate) ln_post: f64,
    #[serde(with = "super::bits::scalar")]
    ln_like: f64,
    counts: ChainCounts,
    proposal: GaussianProposal,
    /// Drawn from instead of `proposal` in a share of the iterations. Absent from
    /// checkpoints of older versions (which had none).
    #[serde(default)]
    pub(crate) independence: Option<Independence>,
    adapt: Option<AdaptState>,
    #[serde(with = "super::bits::vec")]
    samples: Vec<f64>,
    #[serde(with = "super::bits::vec")]
    kept_ln_post: Vec<f64>,
    #[serde(with = "super::bits::vec")]
    kept_ln_like: Vec<f64>,
    /// Per kept draw: a proposal was accepted since the previous kept draw (the draw's own
    /// proposal when `thin` = 1). Absent from checkpoints of older versions: see
    /// [`ChainState::upgrade`].
    #[serde(default)]
    kept_accepted: Vec<bool>,
    /// A proposal was accepted in the current thinning window (since the last kept draw).
    #[serde(default)]
    moved: bool,
    #[serde(with = "super::bits::vec")]
    best_theta: Vec<f64>,
    #[serde(with = "super::bits::scalar")]
    best_ln_post: f64,
    #[serde(with = "super::bits::scalar")]
    best_ln_like: f64,
    #[serde(skip)]
    x_new: Vec<f64>,
}

/// `Err(problem)` if `theta` is outside the prior support (naming the parameter) or `ln L`
/// is not finite there; otherwise `(ln π + ln L, ln L)`.
fn evaluate_start<D: LogDensity>(target: &D, theta: &[f64]) -> Result<(f64, f64), String> {
    let prior = target.prior();
    if theta.len() != prior.dim() {
        return Err(format!(
            "has {} entries but the target has {} parameters",
            theta.len(),
            prior.dim()
        ));
    }
    for ((name, kind), &x) in prior.names().iter().zip(prior.kinds()).zip(theta) {
        if kind.ln_pdf(x) == f64::NEG_INFINITY || x.is_nan() {
            let (lo, hi) = kind.bounds();
            return Err(format!(
                "`{name}` = {x} is outside its prior support [{lo}, {hi}]; start inside the prior or use Start::Prior"
            ));
        }
    }
    let ll = target.ln_likelihood(theta);
    if !ll.is_finite() {
        return Err(format!(
            "ln L = {ll} is not finite there; start where the likelihood is defined"
        ));
    }
    Ok((prior.ln_pdf(theta) + ll, ll))
}

impl ChainState {
    /// A chain at its start point, before iteration 1.
    pub(crate) fn new<D: LogDensity>(
        index: usize,
        target: &D,
        settings: &MhSettings,
        proposal: &GaussianProposal,
        independence: Option<&Independence>,
        start: &Start,
    ) -> Result<Self, SamplerError> {
        let err = |problem: String| SamplerError::Start {
            chain: index,
            problem,
        };
        let mut rng = chain_rng(settings.seed, index);
        let mut proposal = proposal.clone();
        proposal.prepare();
        let dim = proposal.dim();
        let (x, (ln_post, ln_like)) = match start {
            Start::Point(p) => (p.clone(), evaluate_start(target, p).map_err(err)?),
            Start::PerChain(ps) => {
                let p = ps.get(index).ok_or_else(|| SamplerError::Setting {
                    field: "start",
                    problem: format!(
                        "Start::PerChain holds {} points for n_chains = {}; give one per chain",
                        ps.len(),
                        settings.n_chains
                    ),
                })?;
                (p.clone(), evaluate_start(target, p).map_err(err)?)
            }
            Start::Prior => {
                let p = target.prior().sample(&mut rng);
                let v = evaluate_start(target, &p).map_err(err)?;
                (p, v)
            }
            Start::Around { centre, spread } => {
                if centre.len() != dim {
                    return Err(err(format!(
                        "Start::Around centre has {} entries but the target has {dim} parameters",
                        centre.len()
                    )));
                }
                if !(spread.is_finite() && *spread > 0.0) {
                    return Err(SamplerError::Setting {
                        field: "start",
                        problem: format!(
                            "Start::Around spread must be finite and > 0 (got {spread})"
                        ),
                    });
                }
                let mut p = vec![0.0; dim];
                let mut found = None;
                for _ in 0..1000 {
                    proposal.propose(centre, *spread, &mut rng, &mut p);
                    if let Ok(v) = evaluate_start(target, &p) {
                        found = Some(v);
                        break;
                    }
                }
                // in many dimensions with some of the centre on the prior's bounds (modelled
                // glitches: a candidate's amplitude or start at its box's edge) almost every
                // draw leaves the box: then the coordinates that do take the centre's value
                if found.is_none() {
                    let bounds = target.prior().bounds();
                    for _ in 0..1000 {
                        proposal.propose(centre, *spread, &mut rng, &mut p);
                        for ((x, c), (lo, hi)) in p.iter_mut().zip(centre).zip(&bounds) {
                            if !(*lo <= *x && *x <= *hi) {
                                *x = *c;
                            }
                        }
                        if let Ok(v) = evaluate_start(target, &p) {
                            found = Some(v);
                            break;
                        }
                    }
                }
                let v = found.ok_or_else(|| {
                    err(format!(
                        "2000 draws around the centre with spread {spread} (the last 1000 with the coordinates outside the prior set to the centre's) all fell outside the prior or where ln L is not finite; lower the spread or move the centre"
                    ))
                })?;
                (p, v)
            }
        };
        let mut s = Self {
            index,
            rng,
            iter: 0,
            best_theta: x.clone(),
            best_ln_post: ln_post,
            best_ln_like: ln_like,
            x,
            ln_post,
            ln_like,
            counts: ChainCounts::default(),
            proposal,
            independence: independence.cloned(),
            adapt: settings.adapt.as_ref().map(|_| AdaptState::new(dim)),
            samples: Vec::new(),
            kept_ln_post: Vec::new(),
            kept_ln_like: Vec::new(),
            kept_accepted: Vec::new(),
            moved: false,
            x_new: Vec::new(),
        };
        s.prepare(settings);
        Ok(s)
    }

    /// Sizes scratch buffers and reserves the sample storage of the whole run, so the loop
    /// never reallocates (after construction, deserialisation, or a longer `n_iter`).
    pub(crate) fn prepare(&mut self, settings: &MhSettings) {
        let d = self.x.len();
        self.proposal.prepare();
        if let Some(q) = &mut self.independence {
            q.prepare();
        }
        if let Some(a) = &mut self.adapt {
            a.prepare();
        }
        self.x_new.resize(d, 0.0);
        let total = settings.n_kept();
        let have = self.kept_ln_post.len();
        if total > have {
            self.samples.reserve_exact((total - have) * d);
            self.kept_ln_post.reserve_exact(total - have);
            self.kept_ln_like.reserve_exact(total - have);
            self.kept_accepted.reserve_exact(total - have);
        }
    }

    /// Checks a deserialised state against the run: buffer sizes and the number of kept
    /// samples implied by `iter`. `Err` describes the first inconsistency.
    pub(crate) fn check_consistent(&self, settings: &MhSettings, dim: usize) -> Result<(), String> {
        let kept = if self.iter > settings.burn_in {
            (self.iter - settings.burn_in) / settings.thin
        } else {
            0
        };
        let n = self.kept_ln_post.len();
        if self.x.len() != dim
            || self.best_theta.len() != dim
            || self.proposal.dim() != dim
            || self.proposal.cholesky().len() != dim * dim
        {
            return Err(format!(
                "chain {} has buffers of the wrong dimension",
                self.index
            ));
        }
        if n != kept
            || self.kept_ln_like.len() != n
            || self.kept_accepted.len() != n
            || self.samples.len() != n * dim
        {
            return Err(format!(
                "chain {} holds {n} kept samples after {} iterations, expected {kept}",
                self.index, self.iter
            ));
        }
        if self.adapt.is_some() != settings.adapt.is_some()
            || self.adapt.as_ref().is_some_and(|a| !a.has_dim(dim))
        {
            return Err(format!(
                "chain {} has an adaptation state that does not match the settings",
                self.index
            ));
        }
        Ok(())
    }

    /// Fills in the acceptance flags of a checkpoint written before they were recorded (a
    /// state with kept draws but no flags): see [`super::chains::backfill_accepted`]; the
    /// current window's flag is whether θ left the last kept draw (or, before the first, whether
    /// any sampling proposal was accepted). Does nothing to a current checkpoint.
    pub(crate) fn upgrade(&mut self) {
        let d = self.x.len();
        let n = self.kept_ln_post.len();
        if self.kept_accepted.len() == n || d == 0 || self.samples.len() != n * d {
            return;
        }
        self.kept_accepted =
            super::chains::backfill_accepted(&self.samples, d, self.counts.sampling.accepted);
        self.moved = match self.samples.len().checked_sub(d) {
            Some(last) => self.samples[last..] != self.x[..],
            None => self.counts.sampling.accepted > 0,
        };
    }

    /// Dimension of θ.
    pub(crate) fn dim(&self) -> usize {
        self.x.len()
    }

    /// The kept draws of parameter `k` so far.
    pub(crate) fn kept_series(&self, k: usize) -> Vec<f64> {
        self.samples
            .iter()
            .skip(k)
            .step_by(self.x.len().max(1))
            .copied()
            .collect()
    }

    /// Current state.
    pub(crate) fn theta(&self) -> &[f64] {
        &self.x
    }

    /// Runs iterations `iter + 1 ..= until`. Allocation-free: every buffer was sized by
    /// [`ChainState::prepare`].
    pub(crate) fn advance<D: LogDensity>(
        &mut self,
        target: &D,
        settings: &MhSettings,
        until: usize,
        observer: Option<&(dyn Fn(&Progress) + Sync)>,
    ) {
        let prior = target.prior();
        let d = self.x.len();
        let adapt_scale = settings
            .adapt
            .as_ref()
            .map(|a| a.scale.unwrap_or(2.38 * 2.38 / d as f64));
        while self.iter < until {
            let n = self.iter + 1;
            let (beta, scale) = match &settings.anneal {
                Some(a) => (a.beta(n), a.step_scale(n)),
                None => (1.0, 1.0),
            };
            // the kernel is chosen independently of the state, so each keeps the target
            // invariant on its own and so does the mixture
            let (ln_hastings, independent) = match &mut self.independence {
                Some(q) if self.rng.random::<f64>() < q.share() => (
                    q.proposal()
                        .propose(&self.x, scale, &mut self.rng, &mut self.x_new),
                    true,
                ),
                _ => (
                    self.proposal
                        .propose(&self.x, scale, &mut self.rng, &mut self.x_new),
                    false,
                ),
            };
            let sampling = n > settings.burn_in;
            let phase = if sampling {
                &mut self.counts.sampling
            } else {
                &mut self.counts.burn_in
            };
            phase.proposed += 1;
            let counts_independent = independent && sampling;
            if counts_independent {
                self.counts.independent.proposed += 1;
            }
            let mut accepted = false;
            let lp = prior.ln_pdf(&self.x_new);
            if lp == f64::NEG_INFINITY {
                phase.prior_rejected += 1;
                if counts_independent {
                    self.counts.independent.prior_rejected += 1;
                }
            } else {
                let ll = target.ln_likelihood(&self.x_new);
                if !ll.is_finite() {
                    phase.non_finite += 1;
                    if counts_independent {
                        self.counts.independent.non_finite += 1;
                    }
                } else {
                    let post = lp + ll;
                    if post > self.best_ln_post {
                        self.best_theta.copy_from_slice(&self.x_new);
                        self.best_ln_post = post;
                        self.best_ln_like = ll;
                    }
                    let ln_alpha = beta * (post - self.ln_post) + ln_hastings;
                    let u: f64 = self.rng.random();
                    if ln_alpha >= 0.0 || u.ln() < ln_alpha {
                        accepted = true;
                        phase.accepted += 1;
                        if counts_independent {
                            self.counts.independent.accepted += 1;
                        }
                        self.x.copy_from_slice(&self.x_new);
                        self.ln_post = post;
                        self.ln_like = ll;
                    }
                }
            }
            if let (Some(state), Some(cfg), Some(s)) =
                (&mut self.adapt, &settings.adapt, adapt_scale)
                && n > cfg.start
                && n <= settings.burn_in
            {
                state.observe(&self.x, accepted);
                if (n - cfg.start).is_multiple_of(cfg.interval) {
                    state.update_cholesky(s, cfg.ridge, self.proposal.cholesky_mut());
                }
            }
            if n > settings.burn_in {
                // a new thinning window starts after each kept draw
                let opens = (n - settings.burn_in - 1).is_multiple_of(settings.thin);
                self.moved = accepted || (self.moved && !opens);
                if (n - settings.burn_in).is_multiple_of(settings.thin) {
                    self.samples.extend_from_slice(&self.x);
                    self.kept_ln_post.push(self.ln_post);
                    self.kept_ln_like.push(self.ln_like);
                    self.kept_accepted.push(self.moved);
                }
            }
            self.iter = n;
            if let Some(obs) = observer
                && (n.is_multiple_of(settings.progress_every) || n == settings.n_iter)
            {
                let c = &self.counts;
                let proposed = c.burn_in.proposed + c.sampling.proposed;
                let accepted = c.burn_in.accepted + c.sampling.accepted;
                obs(&Progress {
                    chain: self.index,
                    iteration: n,
                    n_iter: settings.n_iter,
                    acceptance: accepted as f64 / proposed as f64,
                });
            }
        }
        assert_eq!(self.x.len(), d);
    }

    /// The chain's output.
    pub(crate) fn into_chain(self) -> Chain {
        let cov = self.proposal.covariance();
        let d = self.x.len();
        let mut proposal_covariance = vec![0.0; d * d];
        for i in 0..d {
            for j in 0..d {
                proposal_covariance[i * d + j] = cov[(i, j)];
            }
        }
        Chain {
            samples: self.samples,
            ln_posterior: self.kept_ln_post,
            ln_likelihood: self.kept_ln_like,
            accepted: self.kept_accepted,
            counts: self.counts,
            best: BestPoint {
                theta: self.best_theta,
                ln_posterior: self.best_ln_post,
                ln_likelihood: self.best_ln_like,
            },
            proposal_covariance,
        }
    }
}
