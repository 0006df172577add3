//! Validation of every evidence estimator against exact Bayes factors.
//!
//! Linear-Gaussian problems (`ltp-model.md` §11) with n = 100 data values, σ = 1, design entries
//! N(0, 1), D = 1..=10 parameters and SNR = |Xθ_true|/σ ∈ {3, 10, 30, 100}; 50 seeds per cell.
//! The pair compared is the full model (D columns) against the nested model without the last
//! column, both built as `SubModel`s of the same density, so every estimator runs through the
//! code the LTP study uses. Prior widths scale with the signal size `s = σ·SNR/√n` (for D = 1
//! with the extra parameter absent there is no signal and the SNR only sets `s`).
//!
//! * **G**: Gaussian priors N(0, (3s)²), extra parameter absent in truth. LF must be exact.
//! * **U**: uniform priors U[−5s, 5s] (≥ 15 posterior σ wide), extra parameter absent. LF with
//!   and without the box term, LM with exact posterior draws (θ̂ = best draw, as in K14), RJMCMC
//!   (visit ratio, Rao-Blackwellised, bridge), and parallel tempering per model
//!   ([`run_tempering`], 12 rungs, 12 000 sweeps of which 2 000 burn-in) giving thermodynamic
//!   integration (TI; error bar of ln B = the Monte-Carlo errors and the pair's discretisation
//!   error in quadrature, `ThermodynamicEstimate::difference_err`) and
//!   stepping stone (SS), each with 1σ coverage of its error bars.
//! * **N**: narrow uniform priors U[−1.5σ/√n, 1.5σ/√n] (prior-dominated; the unconstrained
//!   maximum lies outside the box whenever the signal is strong): LF raw vs box-corrected.
//! * **P**: uniform U[−5s, 5s], extra parameter *present* (|ln B| up to thousands): the visit
//!   ratio fails (a model never visited), the bridge estimator stays finite.
//! * **C**: prior-dominated corners. Boxes `[−h, h]^D` with `h = w·σ/√n`, `w ∈ {0.2, 0.5}`
//!   (box width 0.4 and 1 likelihood widths), D ∈ {1, 2, 4, 8}; the truth is the corner
//!   `(h, …, h)` (so the extra parameter is present but unresolvable) and the noise is redrawn
//!   until the likelihood gradient at that corner points out of the box in every coordinate,
//!   which puts the full model's MAP on the corner. The Fisher Gaussian misses such a box, so
//!   each model's RJ jump proposal and PT covariance come from a short in-model random-walk
//!   chain (sample mean and covariance). Reported: LF with box term (bias), RJ visits /
//!   Rao-Blackwell / bridge, TI and SS, with bias and 1σ coverage per cell.
//!
//! Coverage: over n runs a calibrated 1σ interval covers the truth with Binomial(n, 0.683)
//! frequency (for n = 50: sd 0.066, so [0.49, 0.88] is ±3 sd); cells outside ±3 sd for their
//! own n are marked `!`. The QMC seeds of the box masses differ per problem, so the runs are
//! independent.
//!
//! Run with `cargo run --release --example evidence_validation`; `-- --blocks UC` (any subset of
//! `GUNPC`, default all) runs only the named blocks, and `-- --dims 1,8` only those dimensions.
//! Block C lists the reason of every estimate it could not give under its table.

use nalgebra::DMatrix;
use occam::density::LogDensity;
use occam::evidence::laplace::{
    LaplaceEstimate, LaplaceOptions, laplace_fisher, laplace_hessian, laplace_metropolis,
};
use occam::evidence::linear_gaussian::{LinearGaussian, RandomPrior, RandomSpec};
use occam::evidence::mvn::MvnOptions;
use occam::evidence::rjmcmc::{RjModel, RjOptions, run_rjmcmc};
use occam::evidence::robust::{McdOptions, MveOptions, RobustMethod};
use occam::evidence::schwarz::schwarz_ln_b;
use occam::evidence::tempering::{TemperingOptions, run_tempering};
use occam::nested::SubModel;
use occam::prior::{Prior, PriorKind};
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, StandardNormal};
use rand_xoshiro::Xoshiro256PlusPlus;
use rayon::prelude::*;
use std::time::Instant;

pub(crate) const N_DATA: usize = 100;
pub(crate) const SIGMA: f64 = 1.0;
const SEEDS: u64 = 50;
const SNRS: [f64; 4] = [3.0, 10.0, 30.0, 100.0];
const RJ_ITER: usize = 50_000;
const LM_DRAWS: usize = 1_000;
/// Parallel tempering per model: rungs, sweeps, burn-in sweeps.
const PT: (usize, usize, usize) = (12, 12_000, 2_000);
/// Block C: dimensions and box half-widths in units of the likelihood width σ/√n.
const C_DIMS: [usize; 4] = [1, 2, 4, 8];
pub(crate) const C_WIDTHS: [f64; 2] = [0.2, 0.5];
/// Nominal 1σ coverage of a calibrated error bar.
const COVER: f64 = 0.683;
const RJ_NAMES: [&str; 3] = ["RJ visits", "RJ Rao-Blackwell", "RJ bridge"];
const PT_NAMES: [&str; 2] = ["TI", "SS"];

/// An estimate that is missing: the estimator and the error text of the call that failed.
#[derive(Clone)]
struct Missing {
    name: &'static str,
    why: String,
}

#[derive(Clone, Copy)]
pub(crate) struct Case {
    pub(crate) d: usize,
    pub(crate) snr_idx: usize,
    pub(crate) seed: u64,
}

impl Case {
    fn snr(&self) -> f64 {
        SNRS[self.snr_idx]
    }
    fn scale(&self) -> f64 {
        LinearGaussian::signal_scale(N_DATA, self.snr(), SIGMA)
    }
    pub(crate) fn problem_seed(&self, block: u64) -> u64 {
        (block << 48) | ((self.d as u64) << 32) | ((self.snr_idx as u64) << 16) | self.seed
    }
    fn problem(&self, prior: RandomPrior, n_absent: usize, block: u64) -> LinearGaussian {
        LinearGaussian::random(&RandomSpec {
            n_data: N_DATA,
            dim: self.d,
            // D = 1 with the extra parameter absent has no signal at all; the SNR then only
            // sets the prior width s.
            snr: if n_absent >= self.d { 0.0 } else { self.snr() },
            n_absent,
            sigma: SIGMA,
            prior,
            seed: self.problem_seed(block),
        })
        .expect("valid random problem")
        .model
    }
}

/// An estimate minus the truth, and the combined one-sigma error when the estimator has one.
#[derive(Clone, Copy)]
struct Err {
    err: f64,
    se: Option<f64>,
}

pub(crate) struct Pair<'a> {
    lg: &'a LinearGaussian,
    full_cols: Vec<usize>,
    nested_cols: Vec<usize>,
    full: SubModel<&'a LinearGaussian>,
    nested: SubModel<&'a LinearGaussian>,
    truth: f64,
    truth_se: f64,
}

impl<'a> Pair<'a> {
    /// `seed` drives the QMC of the exact box masses; each problem gets its own, so the box-mass
    /// errors of different problems are independent and coverage over seeds is binomial.
    pub(crate) fn new(lg: &'a LinearGaussian, d: usize, seed: u64) -> Pair<'a> {
        let full_cols: Vec<usize> = (0..d).collect();
        let nested_cols: Vec<usize> = (0..d - 1).collect();
        let o = MvnOptions {
            seed,
            ..MvnOptions::default()
        };
        let zf = lg.exact_ln_evidence(&full_cols, &o).expect("exact full");
        let zn = lg
            .exact_ln_evidence(&nested_cols, &o)
            .expect("exact nested");
        Pair {
            lg,
            full: SubModel::new(lg, full_cols.clone(), vec![0.0; d]).expect("sub-model"),
            nested: SubModel::new(lg, nested_cols.clone(), vec![0.0; d]).expect("sub-model"),
            full_cols,
            nested_cols,
            truth: zf.ln_z - zn.ln_z,
            truth_se: zf.std_err.hypot(zn.std_err),
        }
    }

    fn err(&self, ln_b: f64, se: Option<f64>) -> Err {
        Err {
            err: ln_b - self.truth,
            se: se.map(|s| s.hypot(self.truth_se)),
        }
    }

    /// Laplace–Fisher of both models: `None` if either errors (e.g. θ̂ outside the box without
    /// the box term).
    fn laplace_fisher(&self, box_correction: bool, seed: u64) -> Option<[LaplaceEstimate; 2]> {
        let opts = LaplaceOptions {
            box_correction,
            mvn: MvnOptions {
                seed,
                ..MvnOptions::default()
            },
        };
        let one = |sub: &SubModel<&LinearGaussian>, cols: &[usize]| {
            let post = self.lg.gaussian_posterior(cols).ok()?;
            laplace_fisher(
                sub,
                post.mean.as_slice(),
                &self.lg.fisher(cols).ok()?,
                &opts,
            )
            .ok()
        };
        Some([
            one(&self.full, &self.full_cols)?,
            one(&self.nested, &self.nested_cols)?,
        ])
    }

    /// ln B error of the final Laplace values (box-corrected when the box term was computed).
    fn laplace_err(&self, e: &Option<[LaplaceEstimate; 2]>) -> Option<Err> {
        let [a, b] = e.as_ref()?;
        let se = match (a.std_err, b.std_err) {
            (None, None) => None,
            (x, y) => Some(x.unwrap_or(0.0).hypot(y.unwrap_or(0.0))),
        };
        Some(self.err(a.ln_z - b.ln_z, se))
    }

    /// ln B error of the plain formula (no box term) at the same θ̂.
    fn laplace_raw_err(&self, e: &Option<[LaplaceEstimate; 2]>) -> Option<Err> {
        let [a, b] = e.as_ref()?;
        Some(self.err(a.ln_z_raw - b.ln_z_raw, None))
    }

    fn laplace_hessian(&self) -> Option<Err> {
        let opts = LaplaceOptions::default();
        let one = |sub: &SubModel<&LinearGaussian>, cols: &[usize]| {
            let post = self.lg.gaussian_posterior(cols).ok()?;
            laplace_hessian(sub, post.mean.as_slice(), &opts).ok()
        };
        let a = one(&self.full, &self.full_cols)?;
        let b = one(&self.nested, &self.nested_cols)?;
        Some(self.err(a.ln_z - b.ln_z, None))
    }

    fn schwarz(&self) -> Err {
        let (_, la) = self.lg.max_likelihood(&self.full_cols).expect("ML");
        let (_, lb) = self.lg.max_likelihood(&self.nested_cols).expect("ML");
        let b = schwarz_ln_b(
            la,
            self.full_cols.len(),
            lb,
            self.nested_cols.len(),
            N_DATA as f64,
        )
        .expect("schwarz");
        self.err(b.ln_b, None)
    }

    /// LM with exact posterior draws; θ̂ = the best draw.
    fn laplace_metropolis(&self, seed: u64) -> [Option<Err>; 2] {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
        let draws = |cols: &[usize], rng: &mut Xoshiro256PlusPlus| {
            self.lg.sample_posterior(cols, LM_DRAWS, rng).ok()
        };
        let (Some(sf), Some(sn)) = (
            draws(&self.full_cols, &mut rng),
            draws(&self.nested_cols, &mut rng),
        ) else {
            return [None, None];
        };
        let best = |sub: &SubModel<&LinearGaussian>, s: &DMatrix<f64>| -> Vec<f64> {
            let mut best = (f64::NEG_INFINITY, 0);
            for i in 0..s.nrows() {
                let row: Vec<f64> = s.row(i).iter().cloned().collect();
                let lp = sub.ln_posterior(&row);
                if lp > best.0 {
                    best = (lp, i);
                }
            }
            s.row(best.1).iter().cloned().collect()
        };
        let (bf, bn) = (best(&self.full, &sf), best(&self.nested, &sn));
        let methods = [
            RobustMethod::Mve(MveOptions::default()),
            RobustMethod::Mcd(McdOptions::default()),
        ];
        methods.map(|m| {
            let a = laplace_metropolis(&self.full, &bf, &sf, &m).ok()?;
            let b = laplace_metropolis(&self.nested, &bn, &sn, &m).ok()?;
            Some(self.err(a.ln_z - b.ln_z, None))
        })
    }

    /// The Gaussian posterior of each model (mean, covariance): the Fisher-type jump proposal.
    fn fisher_proposals(&self) -> [(Vec<f64>, DMatrix<f64>); 2] {
        [&self.full_cols, &self.nested_cols].map(|cols| {
            let post = self.lg.gaussian_posterior(cols).expect("posterior");
            (post.mean.as_slice().to_vec(), post.cov)
        })
    }

    /// [visits, Rao-Blackwell, bridge] with the Fisher jump proposals.
    fn rjmcmc(&self, seed: u64) -> [Option<Err>; 3] {
        self.rjmcmc_with(seed, self.fisher_proposals()).0
    }

    /// [visits, Rao-Blackwell, bridge] with the given jump proposals `(center, cov)` per model,
    /// and the reason of every estimate that is missing.
    fn rjmcmc_with(
        &self,
        seed: u64,
        proposals: [(Vec<f64>, DMatrix<f64>); 2],
    ) -> ([Option<Err>; 3], Vec<Missing>) {
        let full: &dyn LogDensity = &self.full;
        let nested: &dyn LogDensity = &self.nested;
        let [(cf, vf), (cn, vn)] = proposals;
        let models = [
            RjModel {
                name: "full".into(),
                target: full,
                center: cf,
                cov: vf,
            },
            RjModel {
                name: "nested".into(),
                target: nested,
                center: cn,
                cov: vn,
            },
        ];
        let opts = RjOptions {
            n_iter: RJ_ITER,
            burn_in: 1_000,
            seed,
            box_mass: MvnOptions {
                seed: seed ^ 0x5eed,
                ..MvnOptions::default()
            },
            ..RjOptions::default()
        };
        let res = match run_rjmcmc(&models, &opts, None) {
            Ok(r) => r,
            Err(e) => {
                let why = format!("run_rjmcmc: {e}");
                let missing = RJ_NAMES.map(|name| Missing {
                    name,
                    why: why.clone(),
                });
                return ([None, None, None], missing.into());
            }
        };
        let p = res.pair(0, 1).expect("pair");
        let est = [p.visits, p.rao_blackwell, p.bridge];
        // The pair carries no text for an estimate it could not form; its counts say why.
        let missing = RJ_NAMES
            .iter()
            .zip(&est)
            .filter(|(_, e)| e.is_none())
            .map(|(&name, _)| Missing {
                name,
                why: format!(
                    "no estimate: visits {:?}, accepted jumps {}/{} and {}/{}",
                    res.visits,
                    p.accepted_k_to_l,
                    p.proposals_k_to_l,
                    p.accepted_l_to_k,
                    p.proposals_l_to_k
                ),
            })
            .collect();
        (est.map(|e| e.map(|e| self.err(e.ln_b, e.std_err))), missing)
    }

    /// [TI, SS]: parallel tempering on each model from `(start, cov)`; the TI error bar of ln B
    /// is the two Monte-Carlo errors and the pair's discretisation error in quadrature. A model
    /// without free parameters
    /// has `ln Z = ln L` exactly.
    fn tempering(&self, seed: u64, proposals: &[(Vec<f64>, DMatrix<f64>); 2]) -> [Option<Err>; 2] {
        self.tempering_why(seed, proposals).0
    }

    /// [`Pair::tempering`] with the reason of every estimate that is missing.
    fn tempering_why(
        &self,
        seed: u64,
        proposals: &[(Vec<f64>, DMatrix<f64>); 2],
    ) -> ([Option<Err>; 2], Vec<Missing>) {
        let (n_temps, n_iter, burn_in) = PT;
        let opts = TemperingOptions {
            n_temps,
            n_iter,
            burn_in,
            seed,
            parallel: false,
            ..TemperingOptions::default()
        };
        // Per model: [TI, SS] as (ln Z, se, signed discretisation error), or why not.
        type One = [Result<(f64, f64, f64), String>; 2];
        let one = |t: &dyn LogDensity, (start, cov): &(Vec<f64>, DMatrix<f64>)| -> One {
            if t.dim() == 0 {
                let l = t.ln_likelihood(&[]);
                return [Ok((l, 0.0, 0.0)), Ok((l, 0.0, 0.0))];
            }
            let start: Vec<f64> = start
                .iter()
                .zip(t.prior().bounds())
                .map(|(&m, (lo, hi))| m.clamp(lo, hi))
                .collect();
            let r = match run_tempering(t, &start, cov, &opts) {
                Ok(r) => r,
                Err(e) => {
                    let why = format!("run_tempering: {e}");
                    return [Err(why.clone()), Err(why)];
                }
            };
            [
                r.thermodynamic
                    .map(|ti| (ti.ln_z, ti.std_err, ti.discretisation_shift))
                    .map_err(|e| format!("thermodynamic: {e}")),
                r.stepping_stone
                    .map(|ss| (ss.ln_z, ss.std_err, 0.0))
                    .map_err(|e| format!("stepping_stone: {e}")),
            ]
        };
        let f = one(&self.full, &proposals[0]);
        let n = one(&self.nested, &proposals[1]);
        let mut missing = Vec::new();
        let est = [0, 1].map(|k| match (&f[k], &n[k]) {
            // TI: the Monte-Carlo errors in quadrature and the pair's discretisation error
            // (ThermodynamicEstimate::difference_err); SS has none
            (Ok(a), Ok(b)) => Some(self.err(a.0 - b.0, Some(a.1.hypot(b.1).hypot(a.2 - b.2)))),
            (a, b) => {
                for (model, r) in [("full", a), ("nested", b)] {
                    if let Err(e) = r {
                        missing.push(Missing {
                            name: PT_NAMES[k],
                            why: format!("{model} model: {e}"),
                        });
                    }
                }
                None
            }
        });
        (est, missing)
    }
}

/// Block C jump proposals `(mean, cov)` of [full, nested]: in-model chains from the box-aware
/// Gaussian (precision of the likelihood plus that of the box, variance h²/3 per parameter),
/// started at the corner-clamped maximum.
pub(crate) fn corner_chains(p: &Pair, h: f64, c: &Case) -> [(Vec<f64>, DMatrix<f64>); 2] {
    [
        (&p.full as &dyn LogDensity, &p.full_cols),
        (&p.nested as &dyn LogDensity, &p.nested_cols),
    ]
    .map(|(t, cols)| {
        let post = p.lg.gaussian_posterior(cols).expect("posterior");
        let mut prec = post.precision.clone();
        for i in 0..cols.len() {
            prec[(i, i)] += 3.0 / (h * h);
        }
        let cov0 = prec.try_inverse().unwrap_or_else(|| DMatrix::zeros(0, 0));
        let start: Vec<f64> = post.mean.iter().map(|m| m.clamp(-h, h)).collect();
        in_model_chain(t, &start, &cov0, c.problem_seed(36) + cols.len() as u64)
    })
}

/// Mean and covariance of a short in-model random-walk Metropolis chain on `t` (2 000 pilot
/// steps with `cov0`, then 6 000 with the pilot's covariance, the last 5 000 kept): the jump
/// proposal when the Fisher Gaussian misses the prior box.
fn in_model_chain(
    t: &dyn LogDensity,
    start: &[f64],
    cov0: &DMatrix<f64>,
    seed: u64,
) -> (Vec<f64>, DMatrix<f64>) {
    let d = t.dim();
    if d == 0 {
        return (vec![], DMatrix::zeros(0, 0));
    }
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let mut cur = start.to_vec();
    let mut lp = t.ln_posterior(&cur);
    let mut run = |cov: &DMatrix<f64>, n: usize, keep: usize, rng: &mut Xoshiro256PlusPlus| {
        let l =
            cov.clone().cholesky().expect("proposal covariance").l() * (2.38 / (d as f64).sqrt());
        let mut kept: Vec<Vec<f64>> = Vec::with_capacity(keep);
        // Accepted moves among the kept steps: fewer than d leave at most d distinct states,
        // whose sample covariance is singular whatever its round-off says.
        let mut moves = 0;
        for i in 0..n {
            let z = nalgebra::DVector::from_fn(d, |_, _| StandardNormal.sample(&mut *rng));
            let step = &l * z;
            let prop: Vec<f64> = cur.iter().zip(step.iter()).map(|(a, b)| a + b).collect();
            let lq = t.ln_posterior(&prop);
            if rng.random::<f64>().ln() < lq - lp {
                cur = prop;
                lp = lq;
                if i >= n - keep {
                    moves += 1;
                }
            }
            if i >= n - keep {
                kept.push(cur.clone());
            }
        }
        let (mean, cov) = moments(&kept);
        (mean, cov, moves)
    };
    let (_, pilot, moves) = run(cov0, 2_000, 1_000, &mut rng);
    let pilot = if pilot_usable(&pilot, moves) {
        pilot
    } else {
        cov0.clone()
    };
    let (mean, cov, _) = run(&pilot, 6_000, 5_000, &mut rng);
    (mean, cov)
}

/// Sample mean and covariance of `kept` (rows are states).
pub(crate) fn moments(kept: &[Vec<f64>]) -> (Vec<f64>, DMatrix<f64>) {
    let d = kept[0].len();
    let k = kept.len() as f64;
    let mean: Vec<f64> = (0..d)
        .map(|j| kept.iter().map(|x| x[j]).sum::<f64>() / k)
        .collect();
    let cov = DMatrix::from_fn(d, d, |a, b| {
        kept.iter()
            .map(|x| (x[a] - mean[a]) * (x[b] - mean[b]))
            .sum::<f64>()
            / (k - 1.0)
    });
    (mean, cov)
}

/// Whether a pilot chain's covariance can be the main run's proposal. A pilot that barely
/// moved has a singular covariance and the starting one is kept then. The Cholesky test alone
/// misses a pilot that never left the corner (h, …, h): every kept state is the same, the
/// covariance is (mean round-off)²·11ᵀ, about 1e-31, and nalgebra factors it. That happened
/// in 4 of the 100 D = 8 runs of block C: the main run then crawled along the diagonal with
/// steps of about 1e-14 and handed RJ and PT a rank-1 covariance, which both rejected.
pub(crate) fn pilot_usable(cov: &DMatrix<f64>, moves: usize) -> bool {
    moves >= cov.nrows() && cov.clone().cholesky().is_some()
}

/// Block C problem: design N(0, 1), box `[−h, h]^D`, truth on the corner `(h, …, h)`, noise
/// redrawn until the likelihood gradient at the corner points out of the box in every
/// coordinate (the KKT condition of the concave ln L: the MAP of the full model is the corner).
pub(crate) fn corner_problem(d: usize, h: f64, seed: u64) -> LinearGaussian {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let x: DMatrix<f64> = DMatrix::from_fn(N_DATA, d, |_, _| StandardNormal.sample(&mut rng));
    let corner = nalgebra::DVector::from_element(d, h);
    let signal = &x * &corner;
    for _ in 0..1_000_000 {
        let y = nalgebra::DVector::from_fn(N_DATA, |i, _| {
            signal[i]
                + SIGMA * {
                    let e: f64 = StandardNormal.sample(&mut rng);
                    e
                }
        });
        let grad = x.transpose() * (&y - &signal);
        if grad.iter().all(|&g| g > 0.0) {
            let names = (0..d).map(|i| format!("p{i}")).collect();
            let prior =
                Prior::new(names, vec![PriorKind::Uniform { lo: -h, hi: h }; d]).expect("prior");
            return LinearGaussian::new(x, y.iter().cloned().collect(), SIGMA, prior)
                .expect("problem");
        }
    }
    panic!("no noise draw put the MAP on the corner for D = {d}");
}

/// Mean and standard deviation of the errors that exist, and how many do not.
fn stats(v: &[Option<Err>]) -> (f64, f64, f64, usize) {
    let xs: Vec<f64> = v.iter().flatten().map(|e| e.err).collect();
    let missing = v.len() - xs.len();
    if xs.is_empty() {
        return (f64::NAN, f64::NAN, f64::NAN, missing);
    }
    let n = xs.len() as f64;
    let mean = xs.iter().sum::<f64>() / n;
    let sd = (xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0).max(1.0)).sqrt();
    let max = xs.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    (mean, sd, max, missing)
}

/// 1σ coverage among the estimates that exist and have a nonzero error (1-D box masses are
/// exact: se = 0, coverage "-"). A 1e−9 floor stands for round-off.
fn coverage(v: &[Option<Err>]) -> Option<(f64, usize)> {
    let with: Vec<&Err> = v
        .iter()
        .flatten()
        .filter(|e| e.se.is_some_and(|s| s > 0.0))
        .collect();
    if with.is_empty() {
        return None;
    }
    let c = with
        .iter()
        .filter(|e| e.err.abs() < e.se.unwrap() + 1e-9)
        .count();
    Some((c as f64 / with.len() as f64, with.len()))
}

fn mean_se(v: &[Option<Err>]) -> f64 {
    let s: Vec<f64> = v.iter().flatten().filter_map(|e| e.se).collect();
    s.iter().sum::<f64>() / s.len().max(1) as f64
}

fn mean_truth<T>(rows: &[T], truth: impl Fn(&T) -> f64) -> f64 {
    rows.iter().map(truth).sum::<f64>() / rows.len() as f64
}

/// Coverage with a `!` when it lies outside ±3 binomial sd of 0.683 for its number of runs.
fn fmt_cov(c: Option<(f64, usize)>) -> String {
    match c {
        None => "   -  ".into(),
        Some((c, n)) => {
            let band = 3.0 * (COVER * (1.0 - COVER) / n as f64).sqrt();
            let flag = if (c - COVER).abs() <= band { ' ' } else { '!' };
            format!("{c:5.2}{flag}")
        }
    }
}

fn fmt_bias(v: &[Option<Err>]) -> String {
    let (mean, sd, _, missing) = stats(v);
    if missing == v.len() {
        return format!("{:>15}", "n/a");
    }
    let m = if missing > 0 {
        format!("[{missing}na]")
    } else {
        String::new()
    };
    format!("{mean:+7.3}±{sd:5.3}{m}")
}

fn cases(dims: &[usize]) -> Vec<Case> {
    let mut v = Vec::new();
    for &d in dims {
        for snr_idx in 0..SNRS.len() {
            for seed in 0..SEEDS {
                v.push(Case { d, snr_idx, seed });
            }
        }
    }
    v
}

fn cells<T: Clone>(cs: &[Case], out: &[T]) -> Vec<((usize, usize), Vec<T>)> {
    let mut res: Vec<((usize, usize), Vec<T>)> = Vec::new();
    for (c, o) in cs.iter().zip(out) {
        let key = (c.d, c.snr_idx);
        match res.last_mut() {
            Some((k, v)) if *k == key => v.push(o.clone()),
            _ => res.push((key, vec![o.clone()])),
        }
    }
    res
}

/// Pooled 1σ coverage of [visits, Rao-Blackwell, bridge, TI, SS] over every run of a block.
fn pooled(all: &[Vec<Option<Err>>; 5]) {
    for (name, v) in ["RJ visits", "RJ Rao-Blackwell", "RJ bridge", "TI", "SS"]
        .iter()
        .zip(all)
    {
        let (c, n) = coverage(v).unwrap_or((f64::NAN, 0));
        let n = n as f64;
        // Pooled binomial: sd = √(0.683·0.317/n).
        let z = (c - COVER) / (COVER * (1.0 - COVER) / n).sqrt();
        println!(
            "  {name:>16}: pooled 1σ coverage over {n} runs = {c:.3} ({z:+.1} binomial sd from 0.683)"
        );
    }
}

/// Block C: prior-dominated boxes with the truth and the MAP on a corner.
fn block_c(dims: &[usize]) {
    let t = Instant::now();
    let mut cs = Vec::new();
    for &d in C_DIMS.iter().filter(|d| dims.contains(d)) {
        for wi in 0..C_WIDTHS.len() {
            for seed in 0..SEEDS {
                cs.push(Case {
                    d,
                    snr_idx: wi,
                    seed,
                });
            }
        }
    }
    let rows: Vec<_> = cs
        .par_iter()
        .map(|c| {
            let h = C_WIDTHS[c.snr_idx] * SIGMA / (N_DATA as f64).sqrt();
            let lg = corner_problem(c.d, h, c.problem_seed(5));
            let p = Pair::new(&lg, c.d, c.problem_seed(35));
            let chains = corner_chains(&p, h, c);
            let lf = p.laplace_fisher(true, c.problem_seed(40));
            let (rj, mut missing) = p.rjmcmc_with(c.problem_seed(27), chains.clone());
            let (pt, pt_missing) = p.tempering_why(c.problem_seed(28), &chains);
            missing.extend(pt_missing);
            (p.truth, p.laplace_err(&lf), rj, pt, missing)
        })
        .collect();
    println!(
        "Block C: prior-dominated boxes [-h, h]^D, h = w·σ/√n (narrower than the likelihood), truth and MAP on the corner (h, …, h); RJ jump proposals and PT covariances from in-model chains"
    );
    println!(
        "{:>3} {:>4} | {:>8} | {:>15} | {:>15} {:>6} | {:>15} {:>6} | {:>15} {:>6} | {:>15} {:>6} | {:>15} {:>6} | {:>6} {:>6} {:>6}",
        "D",
        "w",
        "lnB mean",
        "LF box bias",
        "RJ visits bias",
        "cov1σ",
        "RJ RB bias",
        "cov1σ",
        "RJ bridge bias",
        "cov1σ",
        "TI bias",
        "cov1σ",
        "SS bias",
        "cov1σ",
        "se br",
        "se TI",
        "se SS"
    );
    let mut all: [Vec<Option<Err>>; 5] = Default::default();
    for ((d, wi), rows) in cells(&cs, &rows) {
        let lf: Vec<_> = rows.iter().map(|r| r.1).collect();
        let est: Vec<Vec<_>> = (0..5)
            .map(|k| {
                rows.iter()
                    .map(|r| if k < 3 { r.2[k] } else { r.3[k - 3] })
                    .collect()
            })
            .collect();
        for (acc, v) in all.iter_mut().zip(&est) {
            acc.extend(v.iter().cloned());
        }
        println!(
            "{d:>3} {:>4} | {:8.3} | {:>15} | {:>15} {} | {:>15} {} | {:>15} {} | {:>15} {} | {:>15} {} | {:6.3} {:6.3} {:6.3}",
            C_WIDTHS[wi],
            mean_truth(&rows, |r| r.0),
            fmt_bias(&lf),
            fmt_bias(&est[0]),
            fmt_cov(coverage(&est[0])),
            fmt_bias(&est[1]),
            fmt_cov(coverage(&est[1])),
            fmt_bias(&est[2]),
            fmt_cov(coverage(&est[2])),
            fmt_bias(&est[3]),
            fmt_cov(coverage(&est[3])),
            fmt_bias(&est[4]),
            fmt_cov(coverage(&est[4])),
            mean_se(&est[2]),
            mean_se(&est[3]),
            mean_se(&est[4]),
        );
    }
    pooled(&all);
    let missing: Vec<_> = cs
        .iter()
        .zip(&rows)
        .flat_map(|(c, r)| r.4.iter().map(move |m| (c, m)))
        .collect();
    if !missing.is_empty() {
        println!("  missing estimates (D, w, seed, estimator: reason):");
        for (c, m) in missing {
            println!(
                "  {:>3} {:>4} {:>3} {}: {}",
                c.d, C_WIDTHS[c.snr_idx], c.seed, m.name, m.why
            );
        }
    }
    println!("(block C: {:.1} s)\n", t.elapsed().as_secs_f64());
}

fn main() {
    let t0 = Instant::now();
    // `--blocks GUNPC` (any subset, default all) selects the blocks to run; `--dims 2,8`
    // restricts every block to those dimensions (default all).
    let args: Vec<String> = std::env::args().collect();
    let dims: Vec<usize> = match args.iter().position(|a| a == "--dims") {
        Some(i) => args
            .get(i + 1)
            .expect("--dims needs a comma-separated list")
            .split(',')
            .map(|d| d.trim().parse().expect("--dims: positive integers"))
            .collect(),
        None => (1..=10).collect(),
    };
    let all = cases(&dims);
    let blocks = args
        .iter()
        .position(|a| a == "--blocks")
        .and_then(|i| args.get(i + 1))
        .cloned()
        .unwrap_or_else(|| "GUNPC".into());
    let want = |b: char| blocks.contains(b);

    if want('G') {
        // Block G.
        let t = Instant::now();
        let g: Vec<_> = all
            .par_iter()
            .map(|c| {
                let s = c.scale();
                let lg = c.problem(
                    RandomPrior::Gaussian {
                        mu: 0.0,
                        sigma: 3.0 * s,
                    },
                    1,
                    1,
                );
                let p = Pair::new(&lg, c.d, c.problem_seed(31));
                let lf = p.laplace_fisher(true, c.problem_seed(40));
                (
                    p.truth,
                    p.laplace_err(&lf),
                    p.laplace_hessian(),
                    Some(p.schwarz()),
                )
            })
            .collect();
        println!(
            "Block G: Gaussian priors N(0, (3s)^2), extra parameter absent; ln B = full − nested"
        );
        println!(
            "{:>3} {:>5} | {:>8} | {:>10} | {:>10} | {:>15}",
            "D", "SNR", "lnB mean", "LF max|e|", "LH max|e|", "SBIC bias±sd"
        );
        for ((d, si), rows) in cells(&all, &g) {
            let lf: Vec<_> = rows.iter().map(|r| r.1).collect();
            let lh: Vec<_> = rows.iter().map(|r| r.2).collect();
            let sb: Vec<_> = rows.iter().map(|r| r.3).collect();
            println!(
                "{d:>3} {:>5} | {:8.3} | {:10.2e} | {:10.2e} | {}",
                SNRS[si],
                mean_truth(&rows, |r| r.0),
                stats(&lf).2,
                stats(&lh).2,
                fmt_bias(&sb)
            );
        }
        println!("(block G: {:.1} s)\n", t.elapsed().as_secs_f64());
    }

    if want('U') {
        // Block U.
        let t = Instant::now();
        let u: Vec<_> = all
            .par_iter()
            .map(|c| {
                let s = c.scale();
                let lg = c.problem(
                    RandomPrior::Uniform {
                        lo: -5.0 * s,
                        hi: 5.0 * s,
                    },
                    1,
                    2,
                );
                let p = Pair::new(&lg, c.d, c.problem_seed(32));
                let boxed = p.laplace_fisher(true, c.problem_seed(40));
                let lf = [p.laplace_raw_err(&boxed), p.laplace_err(&boxed)];
                (
                    p.truth,
                    lf,
                    p.laplace_metropolis(c.problem_seed(12)),
                    p.rjmcmc(c.problem_seed(22)),
                    p.tempering(c.problem_seed(26), &p.fisher_proposals()),
                )
            })
            .collect();
        println!("Block U: uniform priors U[-5s, 5s], extra parameter absent");
        println!(
            "{:>3} {:>5} | {:>8} | {:>9} {:>9} | {:>15} {:>15} | {:>15} {:>6} | {:>15} {:>6} | {:>15} {:>6} | {:>15} {:>6} | {:>15} {:>6} | {:>6} {:>6} {:>6} {:>6}",
            "D",
            "SNR",
            "lnB mean",
            "LFraw|e|",
            "LFbox|e|",
            "LM-MVE bias",
            "LM-MCD bias",
            "RJ visits bias",
            "cov1σ",
            "RJ RB bias",
            "cov1σ",
            "RJ bridge bias",
            "cov1σ",
            "TI bias",
            "cov1σ",
            "SS bias",
            "cov1σ",
            "se vis",
            "se br",
            "se TI",
            "se SS"
        );
        let mut rj_all: [Vec<Option<Err>>; 5] = Default::default();
        for ((d, si), rows) in cells(&all, &u) {
            let lf0: Vec<_> = rows.iter().map(|r| r.1[0]).collect();
            let lf1: Vec<_> = rows.iter().map(|r| r.1[1]).collect();
            let mve: Vec<_> = rows.iter().map(|r| r.2[0]).collect();
            let mcd: Vec<_> = rows.iter().map(|r| r.2[1]).collect();
            let rj: Vec<Vec<_>> = (0..5)
                .map(|k| {
                    rows.iter()
                        .map(|r| if k < 3 { r.3[k] } else { r.4[k - 3] })
                        .collect()
                })
                .collect();
            for (acc, v) in rj_all.iter_mut().zip(&rj) {
                acc.extend(v.iter().cloned());
            }
            println!(
                "{d:>3} {:>5} | {:8.3} | {:9.2e} {:9.2e} | {:>15} {:>15} | {:>15} {} | {:>15} {} | {:>15} {} | {:>15} {} | {:>15} {} | {:6.3} {:6.3} {:6.3} {:6.3}",
                SNRS[si],
                mean_truth(&rows, |r| r.0),
                stats(&lf0).2,
                stats(&lf1).2,
                fmt_bias(&mve),
                fmt_bias(&mcd),
                fmt_bias(&rj[0]),
                fmt_cov(coverage(&rj[0])),
                fmt_bias(&rj[1]),
                fmt_cov(coverage(&rj[1])),
                fmt_bias(&rj[2]),
                fmt_cov(coverage(&rj[2])),
                fmt_bias(&rj[3]),
                fmt_cov(coverage(&rj[3])),
                fmt_bias(&rj[4]),
                fmt_cov(coverage(&rj[4])),
                mean_se(&rj[0]),
                mean_se(&rj[2]),
                mean_se(&rj[3]),
                mean_se(&rj[4]),
            );
        }
        pooled(&rj_all);
        println!("(block U: {:.1} s)\n", t.elapsed().as_secs_f64());
    }

    if want('N') {
        // Block N.
        let t = Instant::now();
        let nb: Vec<_> = all
            .par_iter()
            .map(|c| {
                let h = 1.5 * SIGMA / (N_DATA as f64).sqrt();
                let lg = c.problem(RandomPrior::Uniform { lo: -h, hi: h }, 1, 3);
                let p = Pair::new(&lg, c.d, c.problem_seed(33));
                let boxed = p.laplace_fisher(true, c.problem_seed(40));
                (
                    p.truth,
                    p.laplace_fisher(false, c.problem_seed(40)).is_none(),
                    p.laplace_raw_err(&boxed),
                    p.laplace_err(&boxed),
                    Some(p.schwarz()),
                )
            })
            .collect();
        println!(
            "Block N: narrow uniform priors U[-1.5σ/√n, 1.5σ/√n] (prior-dominated), extra parameter absent"
        );
        println!(
            "{:>3} {:>5} | {:>9} | {:>5} | {:>15} | {:>15} {:>6} {:>9} | {:>15}",
            "D",
            "SNR",
            "lnB mean",
            "bound",
            "LF raw bias",
            "LF box bias",
            "cov1σ",
            "mean se",
            "SBIC bias"
        );
        for ((d, si), rows) in cells(&all, &nb) {
            let raw: Vec<_> = rows.iter().map(|r| r.2).collect();
            let bx: Vec<_> = rows.iter().map(|r| r.3).collect();
            let sb: Vec<_> = rows.iter().map(|r| r.4).collect();
            println!(
                "{d:>3} {:>5} | {:9.3} | {:5} | {:>15} | {:>15} {} {:9.1e} | {:>15}",
                SNRS[si],
                mean_truth(&rows, |r| r.0),
                rows.iter().filter(|r| r.1).count(),
                fmt_bias(&raw),
                fmt_bias(&bx),
                fmt_cov(coverage(&bx)),
                mean_se(&bx),
                fmt_bias(&sb)
            );
        }
        println!("(block N: {:.1} s)\n", t.elapsed().as_secs_f64());
    }

    if want('P') {
        // Block P.
        let t = Instant::now();
        let pc = cases(
            &[1, 3, 10]
                .into_iter()
                .filter(|d| dims.contains(d))
                .collect::<Vec<_>>(),
        );
        let pr: Vec<_> = pc
            .par_iter()
            .map(|c| {
                let s = c.scale();
                let lg = c.problem(
                    RandomPrior::Uniform {
                        lo: -5.0 * s,
                        hi: 5.0 * s,
                    },
                    0,
                    4,
                );
                let p = Pair::new(&lg, c.d, c.problem_seed(34));
                (p.truth, p.rjmcmc(c.problem_seed(24)))
            })
            .collect();
        println!("Block P: uniform priors U[-5s, 5s], extra parameter present (large ln B)");
        println!(
            "{:>3} {:>5} | {:>9} {:>9} | {:>15} {:>6} | {:>15} {:>6} | {:>15} {:>6}",
            "D",
            "SNR",
            "lnB mean",
            "lnB min",
            "RJ visits bias",
            "cov1σ",
            "RJ RB bias",
            "cov1σ",
            "RJ bridge bias",
            "cov1σ"
        );
        for ((d, si), rows) in cells(&pc, &pr) {
            let tmin = rows.iter().map(|r| r.0).fold(f64::INFINITY, f64::min);
            let rj: Vec<Vec<_>> = (0..3)
                .map(|k| rows.iter().map(|r| r.1[k]).collect())
                .collect();
            println!(
                "{d:>3} {:>5} | {:9.2} {tmin:9.2} | {:>15} {} | {:>15} {} | {:>15} {}",
                SNRS[si],
                mean_truth(&rows, |r| r.0),
                fmt_bias(&rj[0]),
                fmt_cov(coverage(&rj[0])),
                fmt_bias(&rj[1]),
                fmt_cov(coverage(&rj[1])),
                fmt_bias(&rj[2]),
                fmt_cov(coverage(&rj[2])),
            );
        }
        println!("(block P: {:.1} s)\n", t.elapsed().as_secs_f64());
    }

    if want('C') {
        block_c(&dims);
    }
    println!(
        "total {:.1} s on {} threads",
        t0.elapsed().as_secs_f64(),
        rayon::current_num_threads()
    );
}
