//! Checkpoints of a Metropolis–Hastings run, and the check that one belongs to a run.
//!
//! A checkpoint holds the run's identity (parameter names, prior, settings, initial proposal)
//! and every chain's complete state: position, RNG state, counters, adaptation state, kept
//! samples and best point. It is written in the common checkpoint format of every job
//! ([`crate::data::checkpoint`]: CBOR, every f64 bit kept, atomic writes), kind [`KIND`].

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::chain::ChainState;
use super::error::SamplerError;
use super::proposal::GaussianProposal;
use super::settings::{Adapt, Anneal, MhSettings};
use crate::density::LogDensity;
use crate::prior::{Prior, PriorKind};

/// The checkpoint kind of a Metropolis–Hastings run.
pub const KIND: &str = "mh";
/// 2: the common checkpoint format (1 was JSON, `occam-mh-checkpoint`).
const VERSION: u32 = 2;

/// What is written (borrows the live run, so writing copies nothing).
#[derive(Serialize)]
pub(crate) struct CheckpointRef<'a> {
    pub(crate) names: &'a [String],
    pub(crate) prior: &'a Prior,
    pub(crate) settings: &'a MhSettings,
    pub(crate) proposal: &'a GaussianProposal,
    pub(crate) chains: &'a [ChainState],
}

/// What is read back.
#[derive(Deserialize)]
pub(crate) struct Checkpoint {
    names: Vec<String>,
    prior: Prior,
    settings: MhSettings,
    proposal: GaussianProposal,
    pub(crate) chains: Vec<ChainState>,
}

impl<'a> CheckpointRef<'a> {
    pub(crate) fn new(
        names: &'a [String],
        prior: &'a Prior,
        settings: &'a MhSettings,
        proposal: &'a GaussianProposal,
        chains: &'a [ChainState],
    ) -> Self {
        Self {
            names,
            prior,
            settings,
            proposal,
            chains,
        }
    }
}

fn ckpt_err(path: &Path, e: crate::data::checkpoint::CheckpointError) -> SamplerError {
    SamplerError::Checkpoint {
        path: path.to_path_buf(),
        problem: e.to_string(),
    }
}

/// Writes `ckpt` of the run `identity` to `path` atomically.
pub(crate) fn write(
    path: &Path,
    ckpt: &CheckpointRef<'_>,
    identity: &str,
) -> Result<(), SamplerError> {
    crate::data::checkpoint::write(path, KIND, VERSION, identity, ckpt)
        .map_err(|e| ckpt_err(path, e))
}

/// Reads a checkpoint (format, kind, version and, when given, the run's identity checked;
/// contents not yet matched to a run).
pub(crate) fn read(path: &Path, identity: Option<&str>) -> Result<Checkpoint, SamplerError> {
    let mut ckpt: Checkpoint = crate::data::checkpoint::read(path, KIND, VERSION, identity)
        .map_err(|e| ckpt_err(path, e))?;
    for ch in &mut ckpt.chains {
        ch.upgrade();
    }
    Ok(ckpt)
}

/// How far the run saved in the checkpoint at `path` got: iterations done per chain and the
/// iterations each chain runs in all (for the "resuming from" line of a command).
pub fn progress(path: &Path) -> Result<(Vec<usize>, usize), SamplerError> {
    let c = read(path, None)?;
    Ok((c.chains.iter().map(|s| s.iter).collect(), c.settings.n_iter))
}

/// Equal bit for bit (the checkpoint keeps every bit; NaN equals NaN here).
fn close(a: f64, b: f64) -> bool {
    a.to_bits() == b.to_bits() || a == b
}

fn close_prior_kind(a: &PriorKind, b: &PriorKind) -> bool {
    use PriorKind::*;
    match (a, b) {
        (Uniform { lo: a1, hi: a2 }, Uniform { lo: b1, hi: b2 })
        | (LogUniform { lo: a1, hi: a2 }, LogUniform { lo: b1, hi: b2 })
        | (Gaussian { mu: a1, sigma: a2 }, Gaussian { mu: b1, sigma: b2 }) => {
            close(*a1, *b1) && close(*a2, *b2)
        }
        _ => false,
    }
}

fn close_anneal(a: &Option<Anneal>, b: &Option<Anneal>) -> bool {
    match (a, b) {
        (None, None) => true,
        (Some(a), Some(b)) => {
            a.tc1 == b.tc1
                && a.tc2 == b.tc2
                && close(a.heat, b.heat)
                && a.jumps.iter().zip(&b.jumps).all(|(x, y)| close(*x, *y))
        }
        _ => false,
    }
}

fn close_adapt(a: &Option<Adapt>, b: &Option<Adapt>) -> bool {
    match (a, b) {
        (None, None) => true,
        (Some(a), Some(b)) => {
            a.start == b.start
                && a.interval == b.interval
                && close(a.ridge, b.ridge)
                && match (a.scale, b.scale) {
                    (None, None) => true,
                    (Some(x), Some(y)) => close(x, y),
                    _ => false,
                }
        }
        _ => false,
    }
}

impl Checkpoint {
    /// Checks that this checkpoint was written by a run with these settings, proposal and
    /// target; the error names the first field that differs. `n_iter` may grow (continuing a
    /// finished run is allowed) but not fall below the iterations already done.
    pub(crate) fn verify<D: LogDensity>(
        &self,
        path: &Path,
        target: &D,
        settings: &MhSettings,
        proposal: &GaussianProposal,
    ) -> Result<(), SamplerError> {
        let mismatch = |field: &'static str, ck: String, run: String| {
            Err(SamplerError::CheckpointMismatch {
                path: path.to_path_buf(),
                field,
                in_checkpoint: ck,
                in_run: run,
            })
        };
        let s = &self.settings;
        if self.names.len() != target.dim() {
            return mismatch(
                "dimension",
                self.names.len().to_string(),
                target.dim().to_string(),
            );
        }
        let names = target.param_names();
        if self.names != names {
            return mismatch(
                "parameter names",
                format!("{:?}", self.names),
                format!("{names:?}"),
            );
        }
        let prior = target.prior();
        let same_prior = self.prior.kinds().len() == prior.kinds().len()
            && self
                .prior
                .kinds()
                .iter()
                .zip(prior.kinds())
                .all(|(a, b)| close_prior_kind(a, b));
        if !same_prior {
            // the first parameter whose prior differs, as its [prior] entry (it printed both
            // whole prior vectors in Debug form)
            let k = (0..self.prior.kinds().len().min(prior.kinds().len()))
                .find(|&k| !close_prior_kind(&self.prior.kinds()[k], &prior.kinds()[k]));
            return match k {
                Some(k) => mismatch(
                    "prior",
                    format!("{} = {}", names[k], self.prior.kinds()[k].entry()),
                    format!("{} = {}", names[k], prior.kinds()[k].entry()),
                ),
                None => mismatch(
                    "prior",
                    format!("{} parameters", self.prior.kinds().len()),
                    format!("{} parameters", prior.kinds().len()),
                ),
            };
        }
        if s.n_chains != settings.n_chains {
            return mismatch(
                "n_chains",
                s.n_chains.to_string(),
                settings.n_chains.to_string(),
            );
        }
        if s.seed != settings.seed {
            return mismatch("seed", s.seed.to_string(), settings.seed.to_string());
        }
        if s.burn_in != settings.burn_in {
            return mismatch(
                "burn_in",
                s.burn_in.to_string(),
                settings.burn_in.to_string(),
            );
        }
        if s.thin != settings.thin {
            return mismatch("thin", s.thin.to_string(), settings.thin.to_string());
        }
        if !close_anneal(&s.anneal, &settings.anneal) {
            return mismatch(
                "anneal",
                format!("{:?}", s.anneal),
                format!("{:?}", settings.anneal),
            );
        }
        if !close_adapt(&s.adapt, &settings.adapt) {
            return mismatch(
                "adapt",
                format!("{:?}", s.adapt),
                format!("{:?}", settings.adapt),
            );
        }
        let (a, b) = (self.proposal.cholesky(), proposal.cholesky());
        let scale = b.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        if a.len() != b.len() || a.iter().zip(b).any(|(x, y)| (x - y).abs() > 1e-12 * scale) {
            // the first entry that differs, by its parameters (not two whole matrices)
            let (ca, cb) = (self.proposal.covariance(), proposal.covariance());
            let n = ca.nrows().min(cb.nrows());
            let tol = 1e-10 * cb.amax();
            let at = (0..n)
                .flat_map(|i| (0..=i).map(move |j| (i, j)))
                .find(|&(i, j)| (ca[(i, j)] - cb[(i, j)]).abs() > tol);
            let entry = |c: &nalgebra::DMatrix<f64>, (i, j): (usize, usize)| {
                format!("({}, {}) = {:e}", names[i], names[j], c[(i, j)])
            };
            return match at {
                Some(ij) => mismatch("proposal covariance", entry(&ca, ij), entry(&cb, ij)),
                None => mismatch(
                    "proposal covariance",
                    format!("{} × {}", ca.nrows(), ca.ncols()),
                    format!("{} × {}", cb.nrows(), cb.ncols()),
                ),
            };
        }
        let corrupt = |problem: String| {
            Err(SamplerError::Checkpoint {
                path: path.to_path_buf(),
                problem: format!("inconsistent contents: {problem}"),
            })
        };
        if self.chains.len() != settings.n_chains {
            return corrupt(format!(
                "{} chain states for n_chains = {}",
                self.chains.len(),
                settings.n_chains
            ));
        }
        let done = self.chains[0].iter;
        for (c, ch) in self.chains.iter().enumerate() {
            if ch.index != c || ch.iter != done {
                return corrupt(format!(
                    "chain {c} has index {} and {} iterations (expected {c} and {done})",
                    ch.index, ch.iter
                ));
            }
            ch.check_consistent(settings, target.dim())
                .or_else(corrupt)?;
        }
        if done > settings.n_iter {
            return mismatch(
                "n_iter",
                format!("{} (iterations already done: {done})", s.n_iter),
                settings.n_iter.to_string(),
            );
        }
        // The same prior and settings with different data would continue silently with a
        // wrong target; the stored ln posterior of each chain's state catches that. The
        // tolerance allows likelihood code whose last bits depend on the CPU (SIMD FFTs).
        for ch in &self.chains {
            let now = target.ln_posterior(ch.theta());
            if !(now.is_finite() && (now - ch.ln_post).abs() <= 1e-9 * (1.0 + now.abs())) {
                return mismatch(
                    "ln posterior at a checkpointed state (the target differs)",
                    format!("{} (chain {})", ch.ln_post, ch.index),
                    now.to_string(),
                );
            }
        }
        Ok(())
    }
}
