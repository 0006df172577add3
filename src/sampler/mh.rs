//! The Metropolis–Hastings driver: blocks of iterations over parallel chains, with progress,
//! checkpoints and stopping between blocks.

use std::path::{Path, PathBuf};

use nalgebra::DMatrix;
use rayon::prelude::*;

use super::chain::{ChainState, Progress};
use super::chains::Chains;
use super::checkpoint::{self, CheckpointRef};
use super::driver::{Driver, Ended, Sampler};
use super::error::SamplerError;
use super::independence::Independence;
use super::proposal::{GaussianProposal, Proposal};
use super::settings::{MhSettings, Start};
use super::until::Until;
use crate::density::LogDensity;

/// How a run ended.
#[derive(Debug, Clone, PartialEq)]
pub enum RunOutcome {
    /// All `n_iter` iterations are done.
    Finished(Chains),
    /// The stop hook asked to stop after `iterations` iterations per chain. If a checkpoint
    /// path was set, the checkpoint holds this state and
    /// [`MetropolisHastings::resume`] continues it.
    Stopped {
        /// Iterations completed per chain.
        iterations: usize,
    },
    /// The chains met the convergence rule ([`MetropolisHastings::until`]) after `iterations`
    /// per chain, before `n_iter`; the run is over and these are its chains.
    Converged {
        /// The chains' draws up to `iterations`.
        chains: Chains,
        /// Iterations completed per chain.
        iterations: usize,
    },
}

impl RunOutcome {
    /// The chains of a run that ended (at `n_iter` or converged); `None` if it was stopped.
    pub fn into_chains(self) -> Option<Chains> {
        match self {
            RunOutcome::Finished(c) | RunOutcome::Converged { chains: c, .. } => Some(c),
            RunOutcome::Stopped { .. } => None,
        }
    }
}

/// Metropolis–Hastings with a multivariate Gaussian random walk on any [`LogDensity`].
///
/// * Proposal `θ' = θ + L z`, `L Lᵀ = Σ` given by the caller (for LTP, the scaled inverse
///   Fisher matrix), factored once; optional [`Adapt`](super::Adapt)ation during the burn-in
///   and LTPDA's [`Anneal`](super::Anneal)ed search at its start.
/// * Proposals outside the prior are rejected without evaluating `ln L`; a non-finite `ln L`
///   is a rejection too. Both are counted ([`PhaseCounts`](super::PhaseCounts)).
/// * `n_chains` chains run in parallel (rayon), chain `c` on
///   [`chain_rng`](super::chain_rng)`(seed, c)`: results are identical for any thread count.
/// * The driver runs `checkpoint_every` iterations at a time. After each block it writes the
///   checkpoint (if [`checkpoint`](Self::checkpoint) set a path) and then asks the
///   [`stop_when`](Self::stop_when) hook. [`resume`](Self::resume) continues a checkpoint and
///   ends with exactly the chains of an uninterrupted run.
/// * The optional observer receives a [`Progress`] every `progress_every` iterations per
///   chain, from the worker threads. The module prints nothing.
///
/// ```
/// use nalgebra::DMatrix;
/// use occam::density::LogDensity;
/// use occam::prior::{Prior, PriorKind};
/// use occam::sampler::{MetropolisHastings, MhSettings, Start};
///
/// /// Correlated 2-D Gaussian, mean (1, −2), unit variances, correlation 0.8.
/// struct Gauss2 { prior: Prior }
/// impl LogDensity for Gauss2 {
///     fn ln_likelihood(&self, t: &[f64]) -> f64 {
///         let (x, y) = (t[0] - 1.0, t[1] + 2.0);
///         let r = 0.8;
///         -(x * x - 2.0 * r * x * y + y * y) / (2.0 * (1.0 - r * r))
///     }
///     fn prior(&self) -> &Prior { &self.prior }
/// }
///
/// let box20 = PriorKind::Uniform { lo: -20.0, hi: 20.0 };
/// let target = Gauss2 { prior: Prior::new(vec!["x".into(), "y".into()], vec![box20, box20]).unwrap() };
/// // Proposal: the posterior covariance scaled by 2.38²/D, as one would scale an inverse Fisher.
/// let cov = DMatrix::from_row_slice(2, 2, &[1.0, 0.8, 0.8, 1.0]) * (2.38f64.powi(2) / 2.0);
/// let settings = MhSettings { n_iter: 6_000, burn_in: 1_000, n_chains: 2, seed: 42, ..MhSettings::default() };
/// let chains = MetropolisHastings::new(&target, &cov, settings)?
///     .run(&Start::Point(vec![0.0, 0.0]))?
///     .into_chains()
///     .unwrap();
/// assert_eq!(chains.n_kept(), 5_000);
/// let diag = chains.diagnostics()?;
/// let mean = chains.mean();
/// // Within 5 Monte-Carlo standard errors (unit variances, ESS from the chains themselves).
/// assert!((mean[0] - 1.0).abs() < 5.0 / diag.ess[0].sqrt());
/// assert!((mean[1] + 2.0).abs() < 5.0 / diag.ess[1].sqrt());
/// # Ok::<(), occam::sampler::SamplerError>(())
/// ```
pub struct MetropolisHastings<'a, D: LogDensity> {
    target: &'a D,
    settings: MhSettings,
    proposal: GaussianProposal,
    independence: Option<Independence>,
    observer: Option<&'a (dyn Fn(&Progress) + Sync)>,
    checkpoint: Option<PathBuf>,
    /// Save at most this often (wall-clock); zero: after every block.
    save_every: std::time::Duration,
    /// The run's identity in its checkpoints (empty: none is checked beyond the contents).
    identity: String,
    stop: Option<&'a dyn Fn(usize) -> bool>,
    until: Option<Until>,
}

impl<'a, D: LogDensity> MetropolisHastings<'a, D> {
    /// Validates the settings and the proposal covariance (square, symmetric, positive
    /// definite, of the target's dimension).
    pub fn new(
        target: &'a D,
        proposal_cov: &DMatrix<f64>,
        settings: MhSettings,
    ) -> Result<Self, SamplerError> {
        settings.validate()?;
        let dim = target.dim();
        if dim == 0 {
            return Err(SamplerError::Setting {
                field: "target",
                problem: "the target has no parameters".into(),
            });
        }
        if proposal_cov.nrows() != dim || proposal_cov.ncols() != dim {
            return Err(SamplerError::Covariance {
                problem: format!(
                    "is {}×{} but the target has {dim} parameters",
                    proposal_cov.nrows(),
                    proposal_cov.ncols()
                ),
            });
        }
        let proposal = GaussianProposal::with_names(proposal_cov, target.prior().names())?;
        Ok(Self {
            target,
            settings,
            proposal,
            independence: None,
            observer: None,
            checkpoint: None,
            save_every: std::time::Duration::ZERO,
            identity: String::new(),
            stop: None,
            until: None,
        })
    }

    /// Mixes an independence kernel into the random walk ([`Independence`]): each iteration
    /// draws from it with probability `share`, from the random walk otherwise. Its dimension
    /// must be the target's.
    pub fn independence(mut self, q: Independence) -> Result<Self, SamplerError> {
        if q.dim() != self.target.dim() {
            return Err(SamplerError::Covariance {
                problem: format!(
                    "the independence proposal has {} parameters but the target has {}",
                    q.dim(),
                    self.target.dim()
                ),
            });
        }
        self.independence = Some(q);
        Ok(self)
    }

    /// Progress observer, called from the worker threads every `progress_every` iterations
    /// of each chain and at its last iteration.
    pub fn observer(mut self, f: &'a (dyn Fn(&Progress) + Sync)) -> Self {
        self.observer = Some(f);
        self
    }

    /// Writes a checkpoint to `path` after every block of `checkpoint_every` iterations
    /// (atomically: temporary file, then rename).
    pub fn checkpoint(mut self, path: impl Into<PathBuf>) -> Self {
        self.checkpoint = Some(path.into());
        self
    }

    /// Writes the checkpoint at most this often (wall-clock) rather than after every block;
    /// always before a stop and at the end. A kill then loses at most this interval and one
    /// block.
    pub fn save_every(mut self, interval: std::time::Duration) -> Self {
        self.save_every = interval;
        self
    }

    /// Names the run in its checkpoints: [`MetropolisHastings::resume`] refuses a checkpoint
    /// of another identity (say, a hash of the study and its data, which the target and the
    /// settings alone do not pin down).
    pub fn checkpoint_identity(mut self, identity: impl Into<String>) -> Self {
        self.identity = identity.into();
        self
    }

    /// Called on the driver thread after each block (and after its checkpoint) with the
    /// iterations done per chain; returning `true` stops the run with
    /// [`RunOutcome::Stopped`]. Not called after the last block.
    pub fn stop_when(mut self, f: &'a dyn Fn(usize) -> bool) -> Self {
        self.stop = Some(f);
        self
    }

    /// Ends the run once its chains meet `rule` ([`Until`]: every parameter's ESS and R̂),
    /// checked every `rule.every()` iterations after the burn-in, with
    /// [`RunOutcome::Converged`]; `n_iter` stays the most it runs. Not part of the
    /// checkpoint: a resumed run may set another rule, as it may a longer `n_iter`.
    pub fn until(mut self, rule: Until) -> Self {
        self.until = Some(rule);
        self
    }

    /// The validated settings.
    pub fn settings(&self) -> &MhSettings {
        &self.settings
    }

    /// Starts all chains at `start` and runs them.
    pub fn run(&self, start: &Start) -> Result<RunOutcome, SamplerError> {
        if let Start::PerChain(ps) = start
            && ps.len() != self.settings.n_chains
        {
            return Err(SamplerError::Setting {
                field: "start",
                problem: format!(
                    "Start::PerChain holds {} points for n_chains = {}; give one per chain",
                    ps.len(),
                    self.settings.n_chains
                ),
            });
        }
        let states = (0..self.settings.n_chains)
            .map(|c| {
                ChainState::new(
                    c,
                    self.target,
                    &self.settings,
                    &self.proposal,
                    self.independence.as_ref(),
                    start,
                )
            })
            .collect::<Result<Vec<_>, _>>()?;
        self.drive(states)
    }

    /// Continues the run stored at `path`. The checkpoint must come from a run with the same
    /// target, settings (except a larger `n_iter`, which extends it) and proposal covariance;
    /// otherwise the error names the field that differs.
    pub fn resume(&self, path: impl AsRef<Path>) -> Result<RunOutcome, SamplerError> {
        let path = path.as_ref();
        let ckpt = checkpoint::read(path, (!self.identity.is_empty()).then_some(&*self.identity))?;
        ckpt.verify(path, self.target, &self.settings, &self.proposal)?;
        if let Some(c) = ckpt
            .chains
            .iter()
            .find(|c| c.independence != self.independence)
        {
            return Err(SamplerError::CheckpointMismatch {
                path: path.to_path_buf(),
                field: "independence proposal",
                in_checkpoint: describe(c.independence.as_ref()),
                in_run: describe(self.independence.as_ref()),
            });
        }
        self.drive(ckpt.chains)
    }

    fn drive(&self, mut states: Vec<ChainState>) -> Result<RunOutcome, SamplerError> {
        let settings = &self.settings;
        for s in &mut states {
            s.prepare(settings);
        }
        let names = self.target.param_names();
        let mut run = Running {
            target: self.target,
            settings,
            observer: self.observer,
            states,
        };
        let mut save = |r: &Running<'_, D>| match &self.checkpoint {
            Some(path) => {
                let ck = CheckpointRef::new(
                    &names,
                    self.target.prior(),
                    settings,
                    &self.proposal,
                    &r.states,
                );
                checkpoint::write(path, &ck, &self.identity)
            }
            None => Ok(()),
        };
        let mut driver = Driver::new(settings.checkpoint_every)
            .save(&mut save)
            .save_every(self.save_every);
        if let Some(stop) = self.stop {
            driver = driver.stop_when(stop);
        }
        let burn_in = settings.burn_in;
        let converged = |r: &Running<'_, D>| {
            r.done() > burn_in && self.until.is_some_and(|u| u.met_by(&r.states))
        };
        if let Some(u) = &self.until {
            driver = driver.until_from(u.first_check(), u.every(), &converged);
        }
        let ended = driver.run(&mut run)?;
        if let Ended::Stopped { iterations } = ended {
            return Ok(RunOutcome::Stopped { iterations });
        }
        assert!(run.states.iter().all(|s| s.dim() == self.proposal.dim()));
        let chains = Chains::new(
            names,
            run.states.into_iter().map(ChainState::into_chain).collect(),
        )?;
        Ok(match ended {
            Ended::Converged { iterations } => RunOutcome::Converged { chains, iterations },
            _ => RunOutcome::Finished(chains),
        })
    }
}

fn describe(q: Option<&Independence>) -> String {
    q.map_or_else(
        || "none".into(),
        |q| format!("share {} of a Student-t around the MAP", q.share()),
    )
}

/// The chains of a run as the [`Driver`] advances them: in parallel, each on its own stream.
struct Running<'r, D: LogDensity> {
    target: &'r D,
    settings: &'r MhSettings,
    observer: Option<&'r (dyn Fn(&Progress) + Sync)>,
    states: Vec<ChainState>,
}

impl<D: LogDensity> Sampler for Running<'_, D> {
    type Error = SamplerError;

    fn done(&self) -> usize {
        self.states[0].iter
    }

    fn total(&self) -> usize {
        self.settings.n_iter
    }

    fn advance(&mut self, until: usize) -> Result<(), SamplerError> {
        let (target, settings, observer) = (self.target, self.settings, self.observer);
        self.states
            .par_iter_mut()
            .for_each(|s| s.advance(target, settings, until, observer));
        Ok(())
    }
}
