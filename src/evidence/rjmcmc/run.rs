//! Running the jump chains: fresh or from a checkpoint, on the one sampler [`Driver`], and the
//! estimates of the finished chains.

use super::bridge::Grid;
use super::chain::{Chain, Shared, shared};
use super::estimate::{self, Pool, Sojourns};
use super::options::{PILOT_ITERS, RjModel, RjOptions, validate};
use super::pairs::{PairEstimator, Totals, pairs};
use super::prepare::{BoxMasses, box_masses, prepare};
use super::result::{RjDraws, RjProgress, RjResult, union_columns};
use crate::data::checkpoint;
use crate::evidence::error::EvidenceError;
use crate::sampler::{Driver, Ended, Sampler};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::time::Duration;

/// The checkpoint kind of a reversible-jump run ([`crate::data::checkpoint`]).
pub const KIND: &str = "rjmcmc";
const VERSION: u32 = 1;

/// How a reversible-jump run ended.
#[derive(Debug, Clone, PartialEq)]
pub enum RjOutcome {
    /// Every chain ran all its iterations.
    Finished(Box<RjResult>),
    /// The stop hook asked to stop after `iterations` iterations per chain; the checkpoint (if
    /// one was set) holds the state and [`ReversibleJump::resume`] continues it.
    Stopped {
        /// Iterations done per chain.
        iterations: usize,
    },
}

/// One model as a checkpoint records it: what its jump proposal was built from.
#[derive(Serialize, Deserialize, PartialEq)]
struct ModelKey {
    name: String,
    center: Vec<u64>,
    cov: Vec<u64>,
}

fn keys(models: &[RjModel<'_>]) -> Vec<ModelKey> {
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect();
    models
        .iter()
        .map(|m| ModelKey {
            name: m.name.clone(),
            center: bits(&m.center),
            cov: bits(m.cov.as_slice()),
        })
        .collect()
}

#[derive(Serialize)]
struct SavedRef<'a> {
    opts: &'a RjOptions,
    models: &'a [ModelKey],
    grid: &'a Option<Grid>,
    chains: &'a [Chain],
}

#[derive(Deserialize)]
struct Saved {
    opts: RjOptions,
    models: Vec<ModelKey>,
    grid: Option<Grid>,
    chains: Vec<Chain>,
}

/// The chains with what they read, as the [`Driver`] advances them: in parallel, each on its
/// own stream, meeting once at the end of the pilot where the bridge grid is fixed.
struct Jumping<'s, 'a> {
    shared: &'s mut Shared<'a>,
    chains: Vec<Chain>,
    pilot_end: usize,
}

impl Jumping<'_, '_> {
    fn run_to(&mut self, until: usize) {
        let sh = &*self.shared;
        self.chains.par_iter_mut().for_each(|c| c.run_to(until, sh));
    }
}

impl Sampler for Jumping<'_, '_> {
    type Error = EvidenceError;

    fn done(&self) -> usize {
        self.chains[0].t
    }

    fn total(&self) -> usize {
        self.shared.n_iter
    }

    fn advance(&mut self, until: usize) -> Result<(), EvidenceError> {
        if self.shared.grid.is_none() && self.pilot_end <= until {
            self.run_to(self.pilot_end);
            let k_models = self.shared.layout.k;
            self.shared.grid = Some(estimate::pilot_grid(
                &self.chains,
                k_models,
                &self.shared.shift,
            ));
            let sh = &*self.shared;
            self.chains.par_iter_mut().for_each(|c| c.replay_pilot(sh));
        }
        self.run_to(until);
        Ok(())
    }
}

/// The reversible-jump chains over a set of models, run by the sampler [`Driver`] with
/// progress, a checkpoint and a stop hook (see [`run_rjmcmc`] for the method).
pub struct ReversibleJump<'m, 'a> {
    models: &'m [RjModel<'a>],
    opts: &'m RjOptions,
    prior_p: Vec<f64>,
    boxes: BoxMasses,
    shared: Shared<'a>,
    param_names: Vec<String>,
    progress: Option<&'m mut dyn FnMut(&RjProgress<'_>)>,
    checkpoint: Option<(PathBuf, String)>,
    save_every: Duration,
    stop: Option<&'m dyn Fn(usize) -> bool>,
}

impl<'m, 'a> ReversibleJump<'m, 'a> {
    /// Checks the models and options and prepares the jump proposals and their box masses.
    pub fn new(models: &'m [RjModel<'a>], opts: &'m RjOptions) -> Result<Self, EvidenceError> {
        let (prior_p, jump) = validate(models, opts)?;
        let per_chain = opts.n_iter / opts.n_chains;
        let prepared = prepare(models, opts)?;
        let boxes = box_masses(&prepared, opts)?;
        let model_params: Vec<&[String]> =
            models.iter().map(|m| m.target.prior().names()).collect();
        let (param_names, columns) = union_columns(&model_params);
        let shared = shared(
            prepared,
            &prior_p,
            &jump,
            &boxes,
            opts,
            per_chain,
            (columns, param_names.len()),
        )?;
        Ok(Self {
            models,
            opts,
            prior_p,
            boxes,
            shared,
            param_names,
            progress: None,
            checkpoint: None,
            save_every: Duration::ZERO,
            stop: None,
        })
    }

    /// Called about 100 times per run with the visits so far.
    pub fn progress(mut self, f: &'m mut dyn FnMut(&RjProgress<'_>)) -> Self {
        self.progress = Some(f);
        self
    }

    /// Saves the chains to `path` (the common checkpoint format, kind [`KIND`], with the
    /// caller's `identity` of the run) at most every `every`, before a stop and at the end.
    pub fn checkpoint(
        mut self,
        path: impl Into<PathBuf>,
        identity: impl Into<String>,
        every: Duration,
    ) -> Self {
        self.checkpoint = Some((path.into(), identity.into()));
        self.save_every = every;
        self
    }

    /// Asked after each block (1 % of the run) with the iterations done per chain; `true`
    /// stops the run.
    pub fn stop_when(mut self, f: &'m dyn Fn(usize) -> bool) -> Self {
        self.stop = Some(f);
        self
    }

    /// Starts every chain in the start model and runs them.
    pub fn run(self) -> Result<RjOutcome, EvidenceError> {
        let chains = (0..self.opts.n_chains)
            .map(|j| Chain::new(&self.shared, j, self.opts.seed))
            .collect();
        self.drive(chains)
    }

    /// Continues the run saved at `path`: it must be this run's (the identity given to
    /// [`checkpoint`](Self::checkpoint), the options, the models' names and jump proposals,
    /// bit for bit); the result is that of an uninterrupted run.
    pub fn resume(mut self, path: &Path) -> Result<RjOutcome, EvidenceError> {
        let identity = self.checkpoint.as_ref().map(|(_, id)| id.as_str());
        let saved: Saved = checkpoint::read(path, KIND, VERSION, identity)?;
        let mismatch = |problem: String| EvidenceError::Checkpoint {
            path: path.display().to_string(),
            problem,
        };
        let differs = if saved.opts != *self.opts {
            Some("options")
        } else if saved.models != keys(self.models) {
            Some("set of models or jump proposals")
        } else if saved.chains.len() != self.opts.n_chains {
            Some("number of chains")
        } else {
            None
        };
        if let Some(what) = differs {
            return Err(mismatch(format!(
                "it was written by a reversible-jump run with a different {what}; start the run afresh"
            )));
        }
        self.shared.grid = saved.grid;
        let mut chains = saved.chains;
        for c in &mut chains {
            c.prepare(&self.shared).map_err(mismatch)?;
        }
        self.drive(chains)
    }

    fn drive(mut self, chains: Vec<Chain>) -> Result<RjOutcome, EvidenceError> {
        let opts = self.opts;
        let per_chain = self.shared.n_iter;
        let pilot = (per_chain - opts.burn_in).min(PILOT_ITERS);
        let mut run = Jumping {
            shared: &mut self.shared,
            chains,
            pilot_end: opts.burn_in + pilot,
        };
        let keys = keys(self.models);
        let checkpoint = &self.checkpoint;
        let mut save = |s: &Jumping<'_, '_>| match checkpoint {
            Some((path, identity)) => {
                let saved = SavedRef {
                    opts,
                    models: &keys,
                    grid: &s.shared.grid,
                    chains: &s.chains,
                };
                Ok(checkpoint::write(path, KIND, VERSION, identity, &saved)?)
            }
            None => Ok(()),
        };
        let mut progress = self.progress.take();
        let mut observe = |s: &Jumping<'_, '_>| {
            if let Some(cb) = progress.as_mut() {
                let mut visits = vec![0u64; s.shared.layout.k];
                for c in &s.chains {
                    for (v, cv) in visits.iter_mut().zip(&c.visits) {
                        *v += cv;
                    }
                }
                cb(&RjProgress {
                    iteration: s.done() * s.chains.len(),
                    n_iter: per_chain * s.chains.len(),
                    model: s.chains[0].k,
                    visits: &visits,
                });
            }
        };
        let mut driver = Driver::new((per_chain / 100).max(1))
            .observer(&mut observe)
            .save(&mut save)
            .save_every(self.save_every);
        if let Some(stop) = self.stop {
            driver = driver.stop_when(stop);
        }
        let ended = driver.run(&mut run)?;
        let chains = run.chains;
        if let Ended::Stopped { iterations } = ended {
            return Ok(RjOutcome::Stopped { iterations });
        }
        estimate::check_chains(&chains)?;
        Ok(RjOutcome::Finished(Box::new(self.result(&chains))))
    }

    /// The estimates of the finished chains.
    fn result(&self, chains: &[Chain]) -> RjResult {
        let (models, opts, shared) = (self.models, self.opts, &self.shared);
        let (prior_p, boxes, param_names) = (&self.prior_p, &self.boxes, &self.param_names);
        let k_models = models.len();
        let n_chains = opts.n_chains;
        let per_chain = shared.n_iter;
        let n_post = per_chain - opts.burn_in;
        let totals = Totals::of(chains, k_models);
        let (layout, batch) = (shared.layout, shared.batch);
        let pool = Pool::new(chains, layout, batch);
        let soj = Sojourns {
            sojourns: &totals.sojourns,
            visits: &totals.visits,
        };
        let est = PairEstimator {
            prior_p,
            ln_ratio: &shared.ln_ratio,
            grid: shared.grid.as_ref().expect("set after the pilot"),
            boxes,
        };
        let pairs = pairs(models, &est, &pool, &soj, layout, &totals.accepted_post);
        let running = estimate::running_points(
            chains,
            layout,
            batch,
            opts.burn_in,
            &pairs,
            &|pool, soj, a, b| est.estimates(pool, soj, a, b),
        );
        let draws = opts.keep_draws.then(|| RjDraws {
            model_names: models.iter().map(|m| m.name.clone()).collect(),
            param_names: param_names.clone(),
            n_chains,
            n_draws: n_post,
            thin: 1,
            model_index: chains
                .iter()
                .flat_map(|c| c.draw_model.iter().copied())
                .collect(),
            samples: chains
                .iter()
                .flat_map(|c| c.draw_theta.iter().copied())
                .collect(),
            ln_likelihood: chains
                .iter()
                .flat_map(|c| c.draw_ln_l.iter().copied())
                .collect(),
        });
        RjResult {
            model_names: models.iter().map(|m| m.name.clone()).collect(),
            n_iter: per_chain * n_chains,
            n_chains,
            burn_in: opts.burn_in,
            defensive: opts.defensive,
            batch_size: batch,
            prior_model_probs: prior_p.clone(),
            visits: totals.visits,
            in_model_acceptance: totals
                .rw_accepted
                .iter()
                .zip(&totals.rw_tried)
                .map(|(&a, &t)| (t > 0).then(|| a as f64 / t as f64))
                .collect(),
            jumps_proposed: totals.proposed,
            jumps_accepted: totals.accepted,
            sojourns: totals.sojourns,
            regeneration_units: pool.cycles.len(),
            non_finite: totals.non_finite,
            likelihood_calls: chains.iter().map(|c| c.likelihood_calls).sum(),
            ln_box_mass: boxes.ln_p.clone(),
            ln_box_mass_std_err: boxes.se.clone(),
            pairs,
            trace: totals.trace,
            running,
            draws,
        }
    }
}

/// Runs the jump chains over `models` and estimates every pairwise Bayes factor.
///
/// ```
/// use nalgebra::DMatrix;
/// use occam::evidence::linear_gaussian::{LinearGaussian, RandomPrior, RandomSpec};
/// use occam::evidence::mvn::MvnOptions;
/// use occam::evidence::rjmcmc::{run_rjmcmc, RjModel, RjOptions};
/// use occam::nested::SubModel;
/// // y = a·x0 + b·x1 + noise with b = 0 in truth: compare {a, b} with {a}.
/// let p = LinearGaussian::random(&RandomSpec { n_data: 30, dim: 2, snr: 5.0, n_absent: 1,
///     sigma: 1.0, prior: RandomPrior::Uniform { lo: -3.0, hi: 3.0 }, seed: 4 }).unwrap();
/// let lg = &p.model;
/// let full = SubModel::new(lg, vec![0, 1], vec![0.0; 2]).unwrap();
/// let small = SubModel::new(lg, vec![0], vec![0.0; 2]).unwrap();
/// let model = |name: &str, t, cols: &[usize]| {
///     let post = lg.gaussian_posterior(cols).unwrap();
///     RjModel { name: name.into(), target: t, center: post.mean.as_slice().to_vec(), cov: post.cov }
/// };
/// let models = [model("full", &full, &[0, 1]), model("small", &small, &[0])];
/// let opts = RjOptions { n_iter: 20_000, ..RjOptions::default() };
/// let res = run_rjmcmc(&models, &opts, None).unwrap();
/// let exact = lg.exact_ln_evidence(&[0, 1], &MvnOptions::default()).unwrap().ln_z
///     - lg.exact_ln_evidence(&[0], &MvnOptions::default()).unwrap().ln_z;
/// let v = res.pair(0, 1).unwrap().visits.unwrap();
/// assert!((v.ln_b - exact).abs() < 5.0 * v.std_err.unwrap());
/// ```
pub fn run_rjmcmc(
    models: &[RjModel<'_>],
    opts: &RjOptions,
    progress: Option<&mut dyn FnMut(&RjProgress<'_>)>,
) -> Result<RjResult, EvidenceError> {
    let mut rj = ReversibleJump::new(models, opts)?;
    if let Some(f) = progress {
        rj = rj.progress(f);
    }
    match rj.run()? {
        RjOutcome::Finished(r) => Ok(*r),
        RjOutcome::Stopped { .. } => unreachable!("no stop hook was set"),
    }
}
