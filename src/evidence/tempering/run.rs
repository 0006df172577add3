//! Running a tempering ladder: fresh or from its checkpoint, on the one sampler
//! [`Driver`], and the estimates of its post-burn-in sweeps.

use super::checks::{self, TemperingChecks};
use super::integrate::{
    SteppingStoneEstimate, ThermodynamicEstimate, rung_moments, stepping_stone, thermodynamic,
};
use super::ladder::{Geometry, Ladder, Pilot, Sweeping, pilot_ladder};
use super::options::{TemperingOptions, validate};
use crate::data::checkpoint;
use crate::density::LogDensity;
use crate::evidence::error::EvidenceError;
use crate::sampler::{Driver, Ended};
use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::time::Duration;

/// The checkpoint kind of a tempering run ([`crate::data::checkpoint`]).
pub const KIND: &str = "tempering";
const VERSION: u32 = 1;

/// Output of [`run_tempering`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TemperingResult {
    /// The final (frozen) ladder, ascending: `β_0 = 0` (prior) … `β_{N−1} = 1` (posterior).
    pub betas: Vec<f64>,
    /// Post-burn-in swap acceptance of each adjacent pair `(i, i+1)`.
    pub swap_acceptance: Vec<f64>,
    /// Post-burn-in random-walk acceptance per rung (rung 0 draws the prior exactly: 1).
    pub in_rung_acceptance: Vec<f64>,
    /// Final random-walk scale `s_i` per rung (0 for rung 0).
    pub proposal_scale: Vec<f64>,
    /// `E_β[ln L]` per rung (post-burn-in mean; at β = 0 over the draws where `L > 0`, see
    /// [`ThermodynamicEstimate::ln_support`]).
    pub mean_ln_l: Vec<f64>,
    /// Batch-means standard error of each `mean_ln_l`.
    pub mean_ln_l_std_err: Vec<f64>,
    /// `Var_β(ln L)` per rung, the slope `d E_β[ln L]/dβ`.
    pub var_ln_l: Vec<f64>,
    /// Thermodynamic integration, or why it does not apply.
    pub thermodynamic: Result<ThermodynamicEstimate, String>,
    /// Stepping stone, or why it does not apply.
    pub stepping_stone: Result<SteppingStoneEstimate, String>,
    /// What the run's checks against itself found (the module docs, "Checks of a run against
    /// itself"): halves of the run that disagree (the estimate's error is then already
    /// widened) and rungs whose `E_β[ln L]` falls with β, each on the estimate it concerns.
    pub checks: TemperingChecks,
    /// Sweeps run.
    pub n_iter: usize,
    /// Burn-in sweeps.
    pub burn_in: usize,
    /// Batch size (sweeps) of the errors.
    pub batch_size: usize,
    /// `[rung][k]`: every rung's state at [`SNAPSHOTS`](super::SNAPSHOTS) evenly spaced post-burn-in sweeps, for
    /// checking an approximate likelihood where each rung goes (the hot rungs roam the whole
    /// prior, far beyond where an approximation was validated for the posterior).
    pub rung_samples: Vec<Vec<Vec<f64>>>,
    /// Likelihood evaluations, pilot included.
    pub ln_l_evals: u64,
    /// Proposals and prior draws whose `ln L` was NaN or `+∞` (rejected; at β = 0 the draw
    /// counts as `L = 0`).
    pub non_finite: u64,
}

/// How a tempering run ended.
#[derive(Debug, Clone, PartialEq)]
pub enum TemperingOutcome {
    /// All sweeps are done.
    Finished(Box<TemperingResult>),
    /// The stop hook asked to stop after `sweeps` sweeps; the checkpoint (if one was set)
    /// holds the state and [`ParallelTempering::resume`] continues it.
    Stopped {
        /// Sweeps done.
        sweeps: usize,
    },
}

/// What a checkpoint holds: the run's inputs, to refuse another run's file, and the ladder.
#[derive(Serialize)]
struct SavedRef<'a> {
    opts: &'a TemperingOptions,
    start: &'a [f64],
    cov: &'a [f64],
    ladder: &'a Ladder,
}

#[derive(Deserialize)]
struct Saved {
    opts: TemperingOptions,
    start: Vec<f64>,
    cov: Vec<f64>,
    ladder: Ladder,
}

/// Parallel tempering on one target, run by the sampler [`Driver`]: progress, checkpoints and
/// stopping between blocks of sweeps (see [`run_tempering`] for the method).
pub struct ParallelTempering<'a> {
    target: &'a dyn LogDensity,
    start: &'a [f64],
    cov: &'a DMatrix<f64>,
    opts: &'a TemperingOptions,
    geom: Geometry,
    start_values: (f64, f64),
    progress: Option<&'a mut dyn FnMut(usize)>,
    checkpoint: Option<(PathBuf, String)>,
    save_every: Duration,
    stop: Option<&'a dyn Fn(usize) -> bool>,
}

impl<'a> ParallelTempering<'a> {
    /// Checks the options, the start (inside the prior, finite `ln L`) and the covariance.
    pub fn new(
        target: &'a dyn LogDensity,
        start: &'a [f64],
        cov: &'a DMatrix<f64>,
        opts: &'a TemperingOptions,
    ) -> Result<Self, EvidenceError> {
        validate(opts)?;
        let (ln_prior0, ln_l0) = check_start(target, start, cov)?;
        let geom = Geometry::new(target, cov)?;
        Ok(Self {
            target,
            start,
            cov,
            opts,
            geom,
            start_values: (ln_l0, ln_prior0),
            progress: None,
            checkpoint: None,
            save_every: Duration::ZERO,
            stop: None,
        })
    }

    /// Called with the sweeps done after every block (1 % of the run).
    pub fn progress(mut self, f: &'a mut dyn FnMut(usize)) -> Self {
        self.progress = Some(f);
        self
    }

    /// Saves the ladder to `path` (the common checkpoint format, kind [`KIND`], with the
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

    /// Asked after each block with the sweeps done; `true` stops the run.
    pub fn stop_when(mut self, f: &'a dyn Fn(usize) -> bool) -> Self {
        self.stop = Some(f);
        self
    }

    /// Chooses the ladder (pilot), starts every rung and runs.
    pub fn run(self) -> Result<TemperingOutcome, EvidenceError> {
        let pilot = match &self.opts.betas {
            Some(b) => Pilot {
                betas: b.clone(),
                evals: 0,
                non_finite: 0,
            },
            None => pilot_ladder(self.target, self.opts),
        };
        let ladder = Ladder::new(
            self.target,
            pilot,
            &self.geom,
            self.start,
            self.start_values,
            self.opts,
        )?;
        self.drive(ladder)
    }

    /// Continues the run saved at `path`: it must be this run's (the identity given to
    /// [`checkpoint`](Self::checkpoint), the options, start and covariance, bit for bit);
    /// the result is that of an uninterrupted run.
    pub fn resume(self, path: &Path) -> Result<TemperingOutcome, EvidenceError> {
        let identity = self.checkpoint.as_ref().map(|(_, id)| id.as_str());
        let mut saved: Saved = checkpoint::read(path, KIND, VERSION, identity)?;
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<u64>>();
        let differs = if saved.opts != *self.opts {
            Some("options")
        } else if bits(&saved.start) != bits(self.start) {
            Some("start point")
        } else if bits(&saved.cov) != bits(self.cov.as_slice()) {
            Some("covariance")
        } else {
            None
        };
        let mismatch = |problem: String| EvidenceError::Checkpoint {
            path: path.display().to_string(),
            problem,
        };
        if let Some(what) = differs {
            return Err(mismatch(format!(
                "it was written by a tempering run with a different {what}; start the run afresh"
            )));
        }
        saved
            .ladder
            .check_and_prepare(self.opts, self.start.len())
            .map_err(mismatch)?;
        self.drive(saved.ladder)
    }

    fn drive(mut self, ladder: Ladder) -> Result<TemperingOutcome, EvidenceError> {
        let opts = self.opts;
        let mut run = Sweeping {
            target: self.target,
            geom: &self.geom,
            opts,
            ladder,
        };
        let (start, cov) = (self.start, self.cov.as_slice());
        let mut save = |s: &Sweeping<'_>| match &self.checkpoint {
            Some((path, identity)) => {
                let saved = SavedRef {
                    opts,
                    start,
                    cov,
                    ladder: &s.ladder,
                };
                Ok(checkpoint::write(path, KIND, VERSION, identity, &saved)?)
            }
            None => Ok(()),
        };
        let mut observe = |s: &Sweeping<'_>| {
            if let Some(f) = self.progress.as_mut() {
                f(s.ladder.t);
            }
        };
        let mut driver = Driver::new((opts.n_iter / 100).max(1))
            .observer(&mut observe)
            .save(&mut save)
            .save_every(self.save_every);
        if let Some(stop) = self.stop {
            driver = driver.stop_when(stop);
        }
        match driver.run(&mut run)? {
            Ended::Stopped { iterations } => Ok(TemperingOutcome::Stopped { sweeps: iterations }),
            Ended::Finished | Ended::Converged { .. } => Ok(TemperingOutcome::Finished(Box::new(
                result(run.ladder, opts),
            ))),
        }
    }
}

/// The estimates of a finished ladder.
fn result(ladder: Ladder, opts: &TemperingOptions) -> TemperingResult {
    let n_t = opts.n_temps;
    let n_post = opts.n_iter - opts.burn_in;
    let Ladder {
        rungs,
        betas,
        series,
        swaps_tried,
        swaps_acc,
        rung_samples,
        pilot_evals,
        pilot_non_finite,
        ..
    } = ladder;
    let batch = opts
        .batch_size
        .unwrap_or((n_post as f64).sqrt() as usize)
        .max(1);
    let moments = rung_moments(&series, n_t, n_post, batch);
    let mut thermodynamic = thermodynamic(&betas, &moments, &series, batch, true);
    let mut stepping_stone = stepping_stone(&betas, &series, batch, true);
    let mut notes = TemperingChecks::default();
    let (ti_halves, ss_halves) = checks::halves(&betas, &series);
    if let (Ok(t), Some(h)) = (&mut thermodynamic, ti_halves) {
        let (se, note) = checks::split_error(
            "thermodynamic integration",
            t.std_err,
            h.map(|x| (x.ln_z, x.std_err)),
        );
        t.std_err = se;
        notes.thermodynamic.extend(note);
    }
    if let (Ok(t), Some(h)) = (&mut stepping_stone, ss_halves) {
        let (se, note) =
            checks::split_error("stepping-stone", t.std_err, h.map(|x| (x.ln_z, x.std_err)));
        t.std_err = se;
        notes.stepping_stone.extend(note);
    }
    notes.ladder.extend(checks::falling_mean(
        &betas,
        &moments.mean,
        &moments.mean_se,
    ));
    let evals = pilot_evals + rungs.iter().map(|r| r.evals).sum::<u64>();
    TemperingResult {
        swap_acceptance: swaps_acc
            .iter()
            .zip(&swaps_tried)
            .map(|(&a, &n)| a as f64 / n.max(1) as f64)
            .collect(),
        in_rung_acceptance: rungs
            .iter()
            .map(|r| r.accepted as f64 / r.tried.max(1) as f64)
            .collect(),
        proposal_scale: rungs
            .iter()
            .map(|r| if r.beta == 0.0 { 0.0 } else { r.ln_scale.exp() })
            .collect(),
        betas,
        mean_ln_l: moments.mean,
        mean_ln_l_std_err: moments.mean_se,
        var_ln_l: moments.var,
        thermodynamic,
        stepping_stone,
        checks: notes,
        n_iter: opts.n_iter,
        burn_in: opts.burn_in,
        batch_size: batch,
        rung_samples,
        ln_l_evals: evals,
        non_finite: pilot_non_finite + rungs.iter().map(|r| r.non_finite).sum::<u64>(),
    }
}

/// Runs parallel tempering on `target` and returns the TI and SS evidence estimates.
///
/// `start` (inside the prior, finite `ln L`) is where every rung with `β > 0` starts; `cov` is a
/// posterior covariance estimate at β = 1 (inverse Fisher matrix or an in-model chain's sample
/// covariance) that shapes the random walks.
///
/// ```
/// use nalgebra::DMatrix;
/// use occam::evidence::linear_gaussian::LinearGaussian;
/// use occam::evidence::mvn::MvnOptions;
/// use occam::evidence::tempering::{TemperingOptions, run_tempering};
/// use occam::prior::{Prior, PriorKind};
/// let x = DMatrix::from_row_slice(4, 1, &[1.0, 2.0, 3.0, 4.0]);
/// let prior = Prior::new(vec!["a".into()], vec![PriorKind::Uniform { lo: -5.0, hi: 5.0 }]).unwrap();
/// let lg = LinearGaussian::new(x, vec![1.1, 1.9, 3.2, 3.9], 0.5, prior).unwrap();
/// let post = lg.gaussian_posterior(&[0]).unwrap();
/// let opts = TemperingOptions { n_temps: 10, n_iter: 6_000, burn_in: 1_000, parallel: false,
///     ..TemperingOptions::default() };
/// let res = run_tempering(&lg, post.mean.as_slice(), &post.cov, &opts).unwrap();
/// let exact = lg.exact_ln_evidence(&[0], &MvnOptions::default()).unwrap().ln_z;
/// let ss = res.stepping_stone.unwrap();
/// assert!((ss.ln_z - exact).abs() < 5.0 * ss.std_err);
/// ```
pub fn run_tempering(
    target: &dyn LogDensity,
    start: &[f64],
    cov: &DMatrix<f64>,
    opts: &TemperingOptions,
) -> Result<TemperingResult, EvidenceError> {
    run_tempering_observed(target, start, cov, opts, &mut |_| {})
}

/// [`run_tempering`], calling `progress` with the sweeps done after every 1 % of them (a
/// progress bar's hook; it cannot change the numbers).
pub fn run_tempering_observed(
    target: &dyn LogDensity,
    start: &[f64],
    cov: &DMatrix<f64>,
    opts: &TemperingOptions,
    progress: &mut dyn FnMut(usize),
) -> Result<TemperingResult, EvidenceError> {
    match ParallelTempering::new(target, start, cov, opts)?
        .progress(progress)
        .run()?
    {
        TemperingOutcome::Finished(r) => Ok(*r),
        TemperingOutcome::Stopped { .. } => unreachable!("no stop hook was set"),
    }
}

/// `(ln π(start), ln L(start))`, checking the target has parameters, `start` and `cov` its
/// dimension, and `start` lies inside the prior where the likelihood is finite.
fn check_start(
    target: &dyn LogDensity,
    start: &[f64],
    cov: &DMatrix<f64>,
) -> Result<(f64, f64), EvidenceError> {
    let d = target.dim();
    if d == 0 {
        return Err(EvidenceError::option(
            "tempering target dimension",
            0,
            "the target has no parameters: its evidence is its likelihood, nothing to integrate",
        ));
    }
    if start.len() != d {
        return Err(EvidenceError::dimension("tempering start", d, start.len()));
    }
    if cov.nrows() != d || cov.ncols() != d {
        return Err(EvidenceError::dimension(
            "tempering covariance rows and columns",
            d * d,
            cov.nrows() * cov.ncols(),
        ));
    }
    let ln_prior0 = target.prior().ln_pdf(start);
    if ln_prior0 == f64::NEG_INFINITY {
        return Err(EvidenceError::non_finite(
            "ln π(start)",
            ln_prior0,
            "start inside the prior support",
        ));
    }
    let ln_l0 = target.ln_likelihood(start);
    if !ln_l0.is_finite() {
        return Err(EvidenceError::non_finite(
            "ln L(start)",
            ln_l0,
            "start where the likelihood is positive and finite (e.g. at the MAP)",
        ));
    }
    Ok((ln_prior0, ln_l0))
}
