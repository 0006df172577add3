//! An independent reference for the evidence of every `[[select.model]]` of a study: importance
//! sampling from heavy-tailed proposals, on the exact likelihood that `occam select` builds
//! (same data, same statistic, no relative binning), and what select's one-sided reversible-jump
//! estimator does with the same likelihood.
//!
//!     cargo build --release --workspace --example evidence_is
//!     target/release/examples/evidence_is STUDY.toml [N_DRAWS] [SEED] [RECORDED]
//!
//! For every `[[select.model]]` (a sub-model of one of the study's models: its free parameters
//! vary, the others stay at their fixed values) the evidence is the quantity `select` reports,
//! `Z = ∫ L(θ_free, θ_fixed) π(θ_free) dθ_free` with `π` the normalised prior of the free
//! parameters. The data and likelihood are select's (`prepare_select`, one exact likelihood per
//! parent model, a model's own when its noise depends on θ); the MAP is found as select finds it
//! (the bounded multi-start search from the default start, `jobs::prepare::map_search`), and
//! the Fisher covariance `Σ` is taken there. Three proposals `q = (1 − w)·t_ν(μ, s²Σ) + w·π`
//! (a multivariate Student-t mixed with the prior box, `w` = 0.1) draw `N` points each (default
//! 2·10⁵): A: ν = 5, s = 1.5, around the MAP with the Fisher `Σ`; B: ν = 3, s = 2.5, likewise;
//! C: ν = 5, s = 1.5 around the posterior mean with the posterior covariance, both estimated
//! from the weighted draws of A or B (whichever has the lower k̂). Each gives, with weights
//! `w_i = L π / q` (0 outside the box):
//!
//! * `ln Z = ln mean(w)`, its error from the delta method `sd(w) / (√N mean(w))`;
//! * the effective sample size `(Σw)² / Σw²`;
//! * the Pareto k̂ of the largest `M = min(N/5, 3√N)` weights (the generalized-Pareto fit of
//!   Zhang & Stephens 2009 with the weak prior of PSIS, Vehtari et al.): below 0.5 the variance
//!   is finite and the error bar trustworthy, above 0.7 it is not.
//!
//! The proposals draw independently, so their agreement within the errors is evidence that none
//! misses posterior mass; the combined `ln Z` is their inverse-variance mean over those with
//! k̂ < 0.7. The Laplace–Fisher value at the MAP is printed beside them.
//!
//! **Select's one-sided estimator.** When a model is never visited, select's Rao-Blackwell and
//! bridge estimates of `Z_unvisited/Z_visited` become the importance-sampling identity
//! `mean_{k→l}[L_lπ_l/q_l(θ')] · mean_{k→l}[g_k(θ)/(L_kπ_k(θ))]` over the proposals from the
//! visited model k into the unvisited l (src/evidence/rjmcmc, module docs): an IS estimate of
//! `Z_l` with l's jump proposal `q_l` (the defensive mixture of `N(centre, c²Σ)` and the prior),
//! times a reciprocal IS estimate of `1/Z_k` from k's posterior draws with the Gaussian part
//! `g_k`. Both are means of skewed positive terms over `m` draws, so `ln` of them is biased low
//! for small `m` and their spread is what a delta-method error sees only when the tail has been
//! sampled. With select's `[select]` jump settings (`jump_scale`, `defensive`, `student_t`) and
//! the posterior mean and covariance in place of the in-model chains' (`J`), the program draws
//! `min(N, 50 000)` points of `q_l` and as many posterior draws (resampled from the best
//! proposal), and reports for blocks of `m` iid terms: the bias of `ln mean` against the
//! reference, the actual sd of the block values, and the median delta-method error a block
//! claims for itself. For a recorded one-sided pair it forms select's terms, the products of the
//! two sides' terms draw by draw, and reports the same for blocks of the pair's number of
//! proposals. (Select's visited-side draws are a Markov chain's, so its effective `m` is smaller
//! and its bias larger than these iid figures.)
//!
//! Then `ln B` of every pair (in `[[select.model]]` order, as `summary.json` lists them) from
//! each proposal and combined; finally everything as JSON on stdout (the tables go to stderr).
//!
//! With `RECORDED` (a `summary.json` of `occam select`, or a golden file of tests/golden whose
//! key `"summary.json"` holds that text as lines) the MAP and its `ln L` are checked against the
//! recorded `map` and `ln_l_map`, and every recorded ln Z and ln B is shown beside the IS one
//! with its z-score.
//!
//! Draws come from `Xoshiro256PlusPlus` streams seeded per (model, proposal, block of 4096
//! draws) from `SEED` (default 2024), and are reduced in a fixed order, so the output does not
//! depend on the number of threads. The likelihood costs about 0.35 ms per call here (10 499
//! bins): 2·10⁵ draws × 3 proposals + 5·10⁴ take about four CPU minutes per model.

use nalgebra::DMatrix;
use occam::config::Study;
use occam::density::LogDensity;
use occam::jobs::own_noise::own_noise_likelihood;
use occam::jobs::prepare::{
    default_start, likelihood_at, likelihood_of, map_search, prepare_select, reference_point,
};
use occam::likelihood::{Likelihood, fisher_exact, fisher_scoring};
use occam::nested::SubModel;
use occam::prior::Prior;
use rand::{RngExt, SeedableRng};
use rand_distr::{ChiSquared, Distribution, StandardNormal};
use rand_xoshiro::Xoshiro256PlusPlus;
use rayon::prelude::*;
use serde_json::{Value, json};
use statrs::function::gamma::ln_gamma;
use std::path::Path;
use std::time::Instant;

/// Default number of draws per proposal and model.
const DEFAULT_DRAWS: usize = 200_000;
/// Draws per independently seeded block.
const BLOCK: usize = 4096;

/// A proposal: Student-t with `nu` degrees of freedom (Gaussian for `nu = ∞`) and scale
/// `scale²Σ`, mixed with the prior box at weight `defensive`. `Σ` is the Fisher covariance at
/// the MAP (centre: the MAP) or, for `adapted`, the posterior covariance estimated from the
/// weighted draws of A or B (centre: their posterior mean).
#[derive(Clone, Copy)]
struct ProposalSpec {
    name: &'static str,
    nu: f64,
    scale: f64,
    defensive: f64,
    adapted: bool,
}

const PROPOSALS: [ProposalSpec; 3] = [
    ProposalSpec {
        name: "A",
        nu: 5.0,
        scale: 1.5,
        defensive: 0.1,
        adapted: false,
    },
    ProposalSpec {
        name: "B",
        nu: 3.0,
        scale: 2.5,
        defensive: 0.1,
        adapted: false,
    },
    ProposalSpec {
        name: "C",
        nu: 5.0,
        scale: 1.5,
        defensive: 0.1,
        adapted: true,
    },
];

/// Pareto k̂ above which a proposal's estimate is not trusted (left out of the combination).
const KHAT_LIMIT: f64 = 0.7;

/// Draws of the one-sided diagnostics (select's jump proposal; resampled posterior draws).
const DIAG_DRAWS: usize = 50_000;

/// A proposal made concrete for one model.
struct Proposal {
    spec: ProposalSpec,
    mu: Vec<f64>,
    /// Lower Cholesky factor of `scale²Σ`.
    chol: DMatrix<f64>,
    /// `ln Γ((ν+d)/2) − ln Γ(ν/2) − (d/2) ln(νπ) − ln|chol|`.
    ln_const: f64,
    prior: Prior,
    /// `None` for a Gaussian.
    chi2: Option<ChiSquared<f64>>,
}

impl Proposal {
    fn new(
        spec: ProposalSpec,
        mu: &[f64],
        cov: &DMatrix<f64>,
        prior: &Prior,
    ) -> Result<Self, String> {
        let d = mu.len();
        let scaled = cov * (spec.scale * spec.scale);
        let chol = nalgebra::Cholesky::new(scaled)
            .ok_or("the proposal covariance is not positive definite")?
            .l();
        let ln_det: f64 = (0..d).map(|i| chol[(i, i)].ln()).sum();
        let (nu, df) = (spec.nu, d as f64);
        let gaussian = nu.is_infinite();
        let ln_const = if gaussian {
            -0.5 * df * (2.0 * std::f64::consts::PI).ln() - ln_det
        } else {
            ln_gamma(0.5 * (nu + df))
                - ln_gamma(0.5 * nu)
                - 0.5 * df * (nu * std::f64::consts::PI).ln()
                - ln_det
        };
        Ok(Proposal {
            spec,
            mu: mu.to_vec(),
            chol,
            ln_const,
            prior: prior.clone(),
            chi2: if gaussian {
                None
            } else {
                Some(ChiSquared::new(nu).map_err(|e| e.to_string())?)
            },
        })
    }

    /// `ln t(x)` of the Student-t (or Gaussian) component.
    fn ln_t(&self, x: &[f64], buf: &mut [f64]) -> f64 {
        let d = x.len();
        // forward substitution: buf = chol⁻¹ (x − μ)
        let mut q = 0.0;
        for i in 0..d {
            let mut s = x[i] - self.mu[i];
            for j in 0..i {
                s -= self.chol[(i, j)] * buf[j];
            }
            buf[i] = s / self.chol[(i, i)];
            q += buf[i] * buf[i];
        }
        let (nu, df) = (self.spec.nu, d as f64);
        if self.chi2.is_none() {
            return self.ln_const - 0.5 * q;
        }
        self.ln_const - 0.5 * (nu + df) * (q / nu).ln_1p()
    }

    /// `ln q(x)` of the mixture, given `ln π(x)`.
    fn ln_q(&self, x: &[f64], ln_prior: f64, buf: &mut [f64]) -> f64 {
        let w = self.spec.defensive;
        let a = (1.0 - w).ln() + self.ln_t(x, buf);
        if w == 0.0 || ln_prior == f64::NEG_INFINITY {
            return a;
        }
        log_add(a, w.ln() + ln_prior)
    }

    /// One draw from the mixture into `x`.
    fn draw(&self, rng: &mut Xoshiro256PlusPlus, x: &mut [f64], z: &mut [f64]) {
        if rng.random::<f64>() < self.spec.defensive {
            for (xi, k) in x.iter_mut().zip(self.prior.kinds()) {
                *xi = k.sample(rng);
            }
            return;
        }
        let d = x.len();
        for zi in z.iter_mut() {
            *zi = StandardNormal.sample(rng);
        }
        let f = match &self.chi2 {
            Some(c) => (self.spec.nu / c.sample(rng)).sqrt(),
            None => 1.0,
        };
        for i in 0..d {
            let s: f64 = (0..=i).map(|j| self.chol[(i, j)] * z[j]).sum();
            x[i] = self.mu[i] + f * s;
        }
    }
}

fn log_add(a: f64, b: f64) -> f64 {
    let m = a.max(b);
    if m == f64::NEG_INFINITY {
        return m;
    }
    m + ((a - m).exp() + (b - m).exp()).ln()
}

/// What one proposal gave for one model.
struct IsResult {
    ln_z: f64,
    se: f64,
    ess: f64,
    khat: f64,
    /// Draws outside the prior box (weight 0).
    outside: usize,
    /// Draws inside the box where `ln L` was not finite (weight 0).
    non_finite: usize,
    /// Largest normalised weight.
    max_share: f64,
    /// Self-normalised posterior mean, covariance and sd of the free parameters.
    mean: Vec<f64>,
    cov: DMatrix<f64>,
    sd: Vec<f64>,
    seconds: f64,
}

/// The draws of one proposal: parameters (row-major), `ln(Lπ/q)` and `ln(Lπ)` (both −∞
/// outside the box or where `ln L` is not finite).
struct Sample {
    d: usize,
    xs: Vec<f64>,
    lw: Vec<f64>,
    lpost: Vec<f64>,
    outside: usize,
    non_finite: usize,
    seconds: f64,
}

/// `n` draws of `prop` with their importance weights for `sub`, from streams of `seed` (one
/// per block of [`BLOCK`] draws), in a fixed order.
fn draw_sample(sub: &SubModel<&Likelihood>, prop: &Proposal, n: usize, seed: u64) -> Sample {
    let t0 = Instant::now();
    let d = prop.mu.len();
    let blocks = n.div_ceil(BLOCK);
    type Block = (Vec<f64>, Vec<f64>, Vec<f64>, usize, usize);
    let out: Vec<Block> = (0..blocks)
        .into_par_iter()
        .map(|b| {
            let mut rng = Xoshiro256PlusPlus::seed_from_u64(
                seed ^ (b as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15),
            );
            let len = BLOCK.min(n - b * BLOCK);
            let mut lw = Vec::with_capacity(len);
            let mut lpost = Vec::with_capacity(len);
            let mut xs = Vec::with_capacity(len * d);
            let (mut x, mut z, mut buf) = (vec![0.0; d], vec![0.0; d], vec![0.0; d]);
            let (mut outside, mut non_finite) = (0, 0);
            for _ in 0..len {
                prop.draw(&mut rng, &mut x, &mut z);
                xs.extend_from_slice(&x);
                let lp = sub.prior().ln_pdf(&x);
                if lp == f64::NEG_INFINITY {
                    outside += 1;
                    lw.push(f64::NEG_INFINITY);
                    lpost.push(f64::NEG_INFINITY);
                    continue;
                }
                let ll = sub.ln_likelihood(&x);
                if !ll.is_finite() {
                    non_finite += 1;
                    lw.push(f64::NEG_INFINITY);
                    lpost.push(f64::NEG_INFINITY);
                    continue;
                }
                lw.push(ll + lp - prop.ln_q(&x, lp, &mut buf));
                lpost.push(ll + lp);
            }
            (lw, lpost, xs, outside, non_finite)
        })
        .collect();
    let mut sample = Sample {
        d,
        xs: Vec::with_capacity(n * d),
        lw: Vec::with_capacity(n),
        lpost: Vec::with_capacity(n),
        outside: 0,
        non_finite: 0,
        seconds: 0.0,
    };
    for (l, p, x, o, f) in out {
        sample.lw.extend(l);
        sample.lpost.extend(p);
        sample.xs.extend(x);
        sample.outside += o;
        sample.non_finite += f;
    }
    sample.seconds = t0.elapsed().as_secs_f64();
    sample
}

/// `ln mean(exp(l))` of log terms, and the weights `exp(l − max)`.
fn ln_mean(l: &[f64]) -> (f64, Vec<f64>) {
    let m = l.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    let w: Vec<f64> = l.iter().map(|&v| (v - m).exp()).collect();
    (m + (w.iter().sum::<f64>() / l.len() as f64).ln(), w)
}

/// The evidence estimate, its error, ESS, k̂ and the weighted posterior moments of a sample.
fn summarise(s: &Sample) -> IsResult {
    let (n, d) = (s.lw.len(), s.d);
    let (ln_z, w) = ln_mean(&s.lw);
    let nf = n as f64;
    let s1: f64 = w.iter().sum();
    let s2: f64 = w.iter().map(|v| v * v).sum();
    let mean_w = s1 / nf;
    let var_w = (s2 - nf * mean_w * mean_w) / (nf - 1.0);
    let mut mean = vec![0.0; d];
    for (i, &wi) in w.iter().enumerate() {
        for j in 0..d {
            mean[j] += wi * s.xs[i * d + j];
        }
    }
    mean.iter_mut().for_each(|v| *v /= s1);
    let mut cov = DMatrix::<f64>::zeros(d, d);
    for (i, &wi) in w.iter().enumerate() {
        if wi == 0.0 {
            continue;
        }
        for a in 0..d {
            let da = s.xs[i * d + a] - mean[a];
            for b in 0..=a {
                cov[(a, b)] += wi * da * (s.xs[i * d + b] - mean[b]);
            }
        }
    }
    for a in 0..d {
        for b in 0..=a {
            cov[(a, b)] /= s1;
            cov[(b, a)] = cov[(a, b)];
        }
    }
    IsResult {
        ln_z,
        se: var_w.max(0.0).sqrt() / (nf.sqrt() * mean_w),
        ess: s1 * s1 / s2,
        khat: pareto_khat(&s.lw),
        outside: s.outside,
        non_finite: s.non_finite,
        max_share: w.iter().cloned().fold(0.0, f64::max) / s1,
        sd: (0..d).map(|j| cov[(j, j)].sqrt()).collect(),
        mean,
        cov,
        seconds: s.seconds,
    }
}

/// The finite-sample behaviour of `ln mean` of `m` of the log terms `l` (consecutive disjoint
/// blocks of iid terms): the mean of `ln mean_block − ln_ref` (the estimator's bias when
/// `ln_ref` is the exact log expectation), its error over the blocks, the actual sd of the
/// block values and the median of the delta-method error each block would report for itself.
#[derive(Clone, Copy)]
struct BlockBias {
    m: usize,
    blocks: usize,
    bias: f64,
    bias_se: f64,
    sd: f64,
    median_claimed: f64,
}

fn block_bias(l: &[f64], m: usize, ln_ref: f64) -> Option<BlockBias> {
    let blocks = l.len() / m;
    if blocks < 4 || m < 2 {
        return None;
    }
    let mut vals = Vec::with_capacity(blocks);
    let mut claimed = Vec::with_capacity(blocks);
    for c in l.chunks_exact(m).take(blocks) {
        let (lm, w) = ln_mean(c);
        let s1: f64 = w.iter().sum();
        let s2: f64 = w.iter().map(|v| v * v).sum();
        let mf = m as f64;
        let mean = s1 / mf;
        let var = ((s2 - mf * mean * mean) / (mf - 1.0)).max(0.0);
        vals.push(lm - ln_ref);
        claimed.push(var.sqrt() / (mf.sqrt() * mean));
    }
    let nb = blocks as f64;
    let bias = vals.iter().sum::<f64>() / nb;
    let sd = (vals.iter().map(|v| (v - bias).powi(2)).sum::<f64>() / (nb - 1.0)).sqrt();
    claimed.sort_by(|a, b| a.partial_cmp(b).expect("finite"));
    Some(BlockBias {
        m,
        blocks,
        bias,
        bias_se: sd / nb.sqrt(),
        sd,
        median_claimed: claimed[blocks / 2],
    })
}

/// Pareto k̂ of weights given by their logs (the library's, [`occam::evidence::pareto`]; the
/// zero weights of draws outside the box are left out), NaN where it has none.
fn pareto_khat(ln_w: &[f64]) -> f64 {
    occam::evidence::pareto::pareto_khat(ln_w).unwrap_or(f64::NAN)
}

/// The recorded select summary: from a `summary.json`, or from a golden file whose key
/// `"summary.json"` holds its lines (some clock lines stripped: trailing commas removed).
fn read_recorded(path: &Path) -> Result<Value, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let v: Value = serde_json::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))?;
    let Some(lines) = v.get("summary.json").and_then(Value::as_array) else {
        return Ok(v);
    };
    let joined: Vec<&str> = lines.iter().filter_map(Value::as_str).collect();
    let joined = joined.join("\n");
    // drop a comma followed (after whitespace) by a closing bracket
    let chars: Vec<char> = joined.chars().collect();
    let mut out = String::with_capacity(joined.len());
    for (i, &c) in chars.iter().enumerate() {
        if c == ',' {
            let next = chars[i + 1..].iter().find(|ch| !ch.is_whitespace());
            if matches!(next, Some('}') | Some(']')) {
                continue;
            }
        }
        out.push(c);
    }
    serde_json::from_str(&out).map_err(|e| format!("{} (summary.json lines): {e}", path.display()))
}

/// Everything about one model.
struct ModelReport {
    name: String,
    free: Vec<String>,
    map: Vec<f64>,
    ln_l_map: f64,
    laplace: f64,
    results: Vec<IsResult>,
    /// select's jump proposal used as the importance sampler of this model's Z (its role in
    /// the one-sided estimate when the model is never visited): `ln(Lπ/q)` per draw.
    unvisited_terms: Vec<f64>,
    unvisited: IsResult,
    /// `ln(g/(Lπ))` at posterior draws, `g` the Gaussian/t part of the jump proposal (its role
    /// when the model is the visited one), and `ln E_post[g/(Lπ)] = ln P_g(box) − ln Z`.
    visited_terms: Vec<f64>,
    visited_ln_ref: f64,
    visited_khat: f64,
}

/// Block sizes of the one-sided diagnostics.
const BLOCK_SIZES: [usize; 5] = [30, 100, 300, 1000, 3000];

impl ModelReport {
    /// Inverse-variance mean of the trusted proposals' ln Z (k̂ below [`KHAT_LIMIT`]; all of
    /// them when none is) and its error.
    fn combined(&self) -> (f64, f64) {
        let trusted = self.results.iter().any(|r| r.khat < KHAT_LIMIT);
        let (mut s, mut sw) = (0.0, 0.0);
        for r in &self.results {
            if trusted && !(r.khat < KHAT_LIMIT) {
                continue;
            }
            let wt = 1.0 / (r.se * r.se);
            s += wt * r.ln_z;
            sw += wt;
        }
        (s / sw, sw.recip().sqrt())
    }

    fn unvisited_bias(&self, m: usize) -> Option<BlockBias> {
        block_bias(&self.unvisited_terms, m, self.combined().0)
    }

    fn visited_bias(&self, m: usize) -> Option<BlockBias> {
        block_bias(&self.visited_terms, m, self.visited_ln_ref)
    }
}

fn fmt_bias(b: &Option<BlockBias>) -> String {
    match b {
        Some(b) => format!(
            "m {:>4}: bias {:+.3} ± {:.3}, sd {:.3}, claimed {:.3}",
            b.m, b.bias, b.bias_se, b.sd, b.median_claimed
        ),
        None => "too few draws".into(),
    }
}

fn bias_json(b: &Option<BlockBias>) -> Value {
    match b {
        Some(b) => json!({"m": b.m, "blocks": b.blocks, "bias": b.bias, "bias_se": b.bias_se,
            "sd": b.sd, "median_claimed_se": b.median_claimed}),
        None => Value::Null,
    }
}

/// `n` indices drawn with replacement in proportion to `exp(lw)` (sampling-importance
/// resampling).
fn resample(lw: &[f64], n: usize, seed: u64) -> Vec<usize> {
    let (_, w) = ln_mean(lw);
    let mut cum = Vec::with_capacity(w.len());
    let mut acc = 0.0;
    for v in &w {
        acc += v;
        cum.push(acc);
    }
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    (0..n)
        .map(|_| {
            let u = rng.random::<f64>() * acc;
            cum.partition_point(|&c| c <= u).min(w.len() - 1)
        })
        .collect()
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.is_empty() || args.len() > 4 {
        eprintln!(
            "usage: evidence_is STUDY.toml [N_DRAWS] [SEED] [RECORDED summary.json or golden]"
        );
        std::process::exit(2);
    }
    let n: usize = args
        .get(1)
        .map(|s| s.parse().expect("N_DRAWS: a positive integer"))
        .unwrap_or(DEFAULT_DRAWS);
    let seed: u64 = args
        .get(2)
        .map(|s| s.parse().expect("SEED: an integer"))
        .unwrap_or(2024);
    if let Err(e) = run(Path::new(&args[0]), n, seed, args.get(3).map(Path::new)) {
        eprintln!("evidence_is: {e}");
        std::process::exit(1);
    }
}

fn run(
    path: &Path,
    n: usize,
    seed: u64,
    recorded: Option<&Path>,
) -> Result<(), Box<dyn std::error::Error>> {
    let t0 = Instant::now();
    let study0 = Study::load(path)?;
    let prep = prepare_select(&study0)?;
    let study = prep.study(&study0);
    let recorded = recorded.map(read_recorded).transpose()?;
    let rec_model = |name: &str| -> Option<&Value> {
        recorded
            .as_ref()?
            .get("models")?
            .as_array()?
            .iter()
            .find(|m| m.get("name").and_then(Value::as_str) == Some(name))
    };
    eprintln!(
        "{}: {} bins in band, data {}; {} draws per proposal, seed {seed}, {} threads",
        path.display(),
        prep.likelihood.n_bins(),
        prep.origin,
        n,
        rayon::current_num_threads()
    );
    eprintln!(
        "proposals: {}",
        PROPOSALS
            .iter()
            .map(|p| format!(
                "{} = {:.0}% prior + {:.0}% t(ν = {}, {}²{})",
                p.name,
                100.0 * p.defensive,
                100.0 * (1.0 - p.defensive),
                p.nu,
                p.scale,
                if p.adapted {
                    "Σ_post around the posterior mean, both from A or B (lower k̂)"
                } else {
                    "Σ_Fisher around the MAP"
                }
            ))
            .collect::<Vec<_>>()
            .join("; ")
    );
    // one exact likelihood per parent model, the prepared one reused (as select's Parents)
    let mut parents: Vec<(usize, Likelihood)> = Vec::new();
    let mut reports = Vec::new();
    for (k, sm) in study.select_models.iter().enumerate() {
        let spec = &sm.spec;
        let mi = spec.model;
        let own = own_noise_likelihood(
            study,
            spec,
            &default_start(study, spec),
            reference_point(study, mi),
            &|at: &[f64]| likelihood_at(study, mi, &prep.dataset, at),
        )?;
        if own.is_none() && mi != prep.model && !parents.iter().any(|(i, _)| *i == mi) {
            parents.push((mi, likelihood_of(study, mi, &prep.dataset)?));
        }
        let lik: &Likelihood = match &own {
            Some((l, _)) => l,
            None if mi == prep.model => &prep.likelihood,
            None => &parents.iter().find(|(i, _)| *i == mi).expect("built").1,
        };
        let names = lik.model().param_names().to_vec();
        let free = spec.free.clone();
        let free_names: Vec<String> = free.iter().map(|&i| names[i].clone()).collect();
        // the MAP as select finds it, and a single bounded search from the reference point
        let start = match &own {
            Some((_, p)) => p.theta.clone(),
            None => default_start(study, spec),
        };
        let search = map_search(lik, &free, &start, study.fit.map_starts)?;
        let map = search.best().result.theta.clone();
        let mut from_ref = reference_point(study, mi);
        for (i, v) in from_ref.iter_mut().enumerate() {
            if !free.contains(&i) {
                *v = spec.base[i];
            }
        }
        let tol = occam::model::map_tolerance(lik.model().as_ref());
        let single = fisher_scoring(lik, &from_ref, &free, tol, 200).ok();
        let ln_l_map = lik.ln_likelihood_full(&map);
        let f = fisher_exact(lik, &map, &free);
        let cov = occam::linalg::spd_inverse(&f, &occam::linalg::SpdOptions::lower().jacobi())
            .map_err(|e| format!("model `{}`: singular Fisher matrix: {e}", sm.name))?;
        let sub = SubModel::new(lik, free.clone(), map.clone())?;
        let mu: Vec<f64> = free.iter().map(|&i| map[i]).collect();
        let d = free.len();
        let ln_prior_map = sub.prior().ln_pdf(&mu);
        let ln_det_f = f.clone().cholesky().map_or(f64::NAN, |c| {
            2.0 * (0..d).map(|i| c.l()[(i, i)].ln()).sum::<f64>()
        });
        let laplace = ln_l_map + ln_prior_map + 0.5 * d as f64 * (2.0 * std::f64::consts::PI).ln()
            - 0.5 * ln_det_f;
        eprintln!();
        eprintln!(
            "model `{}` ({} free: {})",
            sm.name,
            d,
            free_names.join(", ")
        );
        let rec = rec_model(&sm.name);
        let rec_lnl = rec.and_then(|m| m.get("ln_l_map")).and_then(Value::as_f64);
        match rec_lnl {
            Some(r) => eprintln!(
                "  ln L at MAP {ln_l_map:.6}  recorded {r:.6}  diff {:+.3e} (rel {:.1e})",
                ln_l_map - r,
                ((ln_l_map - r) / r).abs()
            ),
            None => eprintln!("  ln L at MAP {ln_l_map:.6}"),
        }
        if let Some(s) = &single {
            eprintln!(
                "  single bounded Fisher scoring from the reference point: ln L {:.6} ({:+.2e} from the multi-start MAP)",
                lik.ln_likelihood_full(&s.theta),
                lik.ln_likelihood_full(&s.theta) - ln_l_map
            );
        }
        let rec_map: Option<Vec<f64>> = rec
            .and_then(|m| m.get("map"))
            .and_then(Value::as_array)
            .map(|a| a.iter().filter_map(Value::as_f64).collect());
        let sig: Vec<f64> = (0..d).map(|i| cov[(i, i)].sqrt()).collect();
        for (j, &i) in free.iter().enumerate() {
            let r = rec_map.as_ref().and_then(|m| m.get(i)).copied();
            eprintln!(
                "  {:8} MAP {:>14.7e}  Fisher σ {:.3e}{}",
                free_names[j],
                map[i],
                sig[j],
                r.map_or(String::new(), |r| format!(
                    "  recorded MAP {r:.7e} ({:+.2e} σ)",
                    (map[i] - r) / sig[j]
                ))
            );
        }
        eprintln!("  Laplace–Fisher at the MAP: ln Z = {laplace:.4}");
        let mut results: Vec<IsResult> = Vec::new();
        let mut samples: Vec<Sample> = Vec::new();
        for (p, ps) in PROPOSALS.iter().enumerate() {
            let prop = if ps.adapted {
                // centred and shaped by the earlier proposal of lowest k̂
                let src = results
                    .iter()
                    .min_by(|a, b| a.khat.total_cmp(&b.khat))
                    .expect("a Fisher proposal ran first");
                Proposal::new(*ps, &src.mean, &src.cov, sub.prior())?
            } else {
                Proposal::new(*ps, &mu, &cov, sub.prior())?
            };
            let s = seed ^ ((k as u64) << 40) ^ ((p as u64) << 32);
            let sample = draw_sample(&sub, &prop, n, s);
            let r = summarise(&sample);
            eprintln!(
                "  IS {}: ln Z = {:.4} ± {:.4}  ESS {:.0} ({:.2}%)  k̂ {:.3}  max share {:.1e}  outside box {}  ln L not finite {}  ({:.0} s)",
                ps.name,
                r.ln_z,
                r.se,
                r.ess,
                100.0 * r.ess / n as f64,
                r.khat,
                r.max_share,
                r.outside,
                r.non_finite,
                r.seconds
            );
            results.push(r);
            samples.push(sample);
        }
        for a in 0..results.len() {
            for b in a + 1..results.len() {
                let (ra, rb) = (&results[a], &results[b]);
                let e = ra.se.hypot(rb.se);
                eprint!(
                    "{}{} − {} = {:+.4} ± {:.4} ({:+.1}σ)",
                    if a + b == 1 { "  " } else { "; " },
                    PROPOSALS[a].name,
                    PROPOSALS[b].name,
                    ra.ln_z - rb.ln_z,
                    e,
                    (ra.ln_z - rb.ln_z) / e
                );
            }
        }
        eprintln!();
        // select's jump proposal around the posterior's moments from the trusted proposal of
        // highest ESS (select centres it on the in-model chains' mean and covariance)
        let best = (0..results.len())
            .filter(|&i| results[i].khat < KHAT_LIMIT)
            .max_by(|&a, &b| results[a].ess.total_cmp(&results[b].ess))
            .unwrap_or(0);
        let sel = &study.select;
        let jump = ProposalSpec {
            name: "J",
            nu: if sel.student_t > 0.0 {
                sel.student_t
            } else {
                f64::INFINITY
            },
            scale: sel.jump_scale,
            defensive: sel.defensive,
            adapted: true,
        };
        let (pm, pc) = (&results[best].mean, &results[best].cov);
        let jp = Proposal::new(jump, pm, pc, sub.prior())?;
        let n_diag = n.min(DIAG_DRAWS);
        let us = draw_sample(&sub, &jp, n_diag, seed ^ ((k as u64) << 40) ^ (3u64 << 32));
        let unvisited = summarise(&us);
        // the visited side: g/(Lπ) at posterior draws (resampled from the best proposal)
        let idx = resample(
            &samples[best].lw,
            n_diag,
            seed ^ ((k as u64) << 40) ^ (4u64 << 32),
        );
        let mut buf = vec![0.0; d];
        let bs = &samples[best];
        let visited_terms: Vec<f64> = idx
            .iter()
            .map(|&i| jp.ln_t(&bs.xs[i * d..(i + 1) * d], &mut buf) - bs.lpost[i])
            .collect();
        let visited_khat = pareto_khat(&visited_terms);
        // P_g(box) of the Gaussian/t part
        let g_only = Proposal::new(
            ProposalSpec {
                defensive: 0.0,
                ..jump
            },
            pm,
            pc,
            sub.prior(),
        )?;
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed ^ ((k as u64) << 40) ^ (5u64 << 32));
        let (mut x, mut z, mut inside) = (vec![0.0; d], vec![0.0; d], 0usize);
        const BOX_DRAWS: usize = 100_000;
        for _ in 0..BOX_DRAWS {
            g_only.draw(&mut rng, &mut x, &mut z);
            if sub.prior().ln_pdf(&x) > f64::NEG_INFINITY {
                inside += 1;
            }
        }
        let ln_pg = (inside as f64 / BOX_DRAWS as f64).ln();
        drop(samples);
        let rep = ModelReport {
            name: sm.name.clone(),
            free: free_names,
            map,
            ln_l_map,
            laplace,
            results,
            unvisited_terms: us.lw,
            unvisited,
            visited_ln_ref: 0.0,
            visited_terms,
            visited_khat,
        };
        let (c, ce) = rep.combined();
        let rep = ModelReport {
            visited_ln_ref: ln_pg - c,
            ..rep
        };
        eprintln!(
            "  combined ln Z (k̂ < {KHAT_LIMIT}) = {c:.4} ± {ce:.4}; IS − Laplace = {:+.4}",
            c - rep.laplace
        );
        for key in [
            "thermodynamic",
            "stepping_stone",
            "laplace_fisher_raw",
            "laplace_metropolis_mcd",
        ] {
            let Some(e) = rec.and_then(|m| m.get(key)) else {
                continue;
            };
            let Some(v) = e.get("ln_z").and_then(Value::as_f64) else {
                continue;
            };
            let se = e.get("std_err").and_then(Value::as_f64);
            eprintln!(
                "  recorded {key:22} ln Z = {v:.4}{}  minus IS {:+.4}{}",
                se.map_or("          ".into(), |s| format!(" ± {s:.4}")),
                v - c,
                se.map_or(String::new(), |s| format!(
                    "  z {:+.1}",
                    (v - c) / s.hypot(ce)
                ))
            );
        }
        for (j, name) in rep.free.iter().enumerate() {
            let cells: Vec<String> = rep
                .results
                .iter()
                .zip(&PROPOSALS)
                .map(|(r, p)| format!("{:>14.7e} sd {:.3e} ({})", r.mean[j], r.sd[j], p.name))
                .collect();
            eprintln!("  {name:8} posterior mean {}", cells.join("  "));
        }
        let u = &rep.unvisited;
        eprintln!(
            "  select's jump proposal J = {:.0}% prior + {:.0}% {}(posterior mean, {}²Σ_post):",
            100.0 * jump.defensive,
            100.0 * (1.0 - jump.defensive),
            if jump.nu.is_infinite() {
                "N".to_string()
            } else {
                format!("t_{}", jump.nu)
            },
            jump.scale
        );
        eprintln!(
            "    as IS of this model's Z (when unvisited): ln Z − combined = {:+.4} ± {:.4}, ESS {:.1}%, k̂ {:.3} ({} draws)",
            u.ln_z - c,
            u.se,
            100.0 * u.ess / n_diag as f64,
            u.khat,
            n_diag
        );
        for m in BLOCK_SIZES {
            eprintln!("      {}", fmt_bias(&rep.unvisited_bias(m)));
        }
        eprintln!(
            "    reciprocal g/(Lπ) on resampled posterior draws (when visited): k̂ {:.3}, ln P_g(box) {:.2e}",
            rep.visited_khat, ln_pg
        );
        for m in BLOCK_SIZES {
            eprintln!("      {}", fmt_bias(&rep.visited_bias(m)));
        }
        reports.push(rep);
    }

    // every pair, in select's order
    eprintln!();
    eprintln!("ln B_xy = ln Z_x − ln Z_y");
    let mut pairs_json = Vec::new();
    for x in 0..reports.len() {
        for y in x + 1..reports.len() {
            let (rx, ry) = (&reports[x], &reports[y]);
            let per: Vec<(f64, f64)> = (0..PROPOSALS.len())
                .map(|p| {
                    let (a, b) = (&rx.results[p], &ry.results[p]);
                    (a.ln_z - b.ln_z, a.se.hypot(b.se))
                })
                .collect();
            let ((cx, ex), (cy, ey)) = (rx.combined(), ry.combined());
            let (lb, le) = (cx - cy, ex.hypot(ey));
            let cells: Vec<String> = per
                .iter()
                .zip(&PROPOSALS)
                .map(|((b, e), p)| format!("{} {b:+9.4} ± {e:.4}", p.name))
                .collect();
            eprintln!(
                "{:>12}/{:<12} IS {}  combined {lb:+9.4} ± {le:.4}",
                rx.name,
                ry.name,
                cells.join("  ")
            );
            // a one-sided recorded pair: what select's estimator does with iid draws
            let one_sided = recorded.as_ref().and_then(|r| {
                let rj = r.get("rj")?;
                let names: Vec<&str> = rj
                    .get("model_names")?
                    .as_array()?
                    .iter()
                    .filter_map(Value::as_str)
                    .collect();
                let (ix, iy) = (
                    names.iter().position(|&v| v == rx.name)?,
                    names.iter().position(|&v| v == ry.name)?,
                );
                let p = rj.get("pairs")?.as_array()?.iter().find(|p| {
                    p.get("k").and_then(Value::as_u64) == Some(ix as u64)
                        && p.get("l").and_then(Value::as_u64) == Some(iy as u64)
                })?;
                let kl = p.get("proposals_k_to_l")?.as_u64()?;
                let lk = p.get("proposals_l_to_k")?.as_u64()?;
                match (kl, lk) {
                    // x never visited: ln B_xy = ln(Z_unvisited/Z_visited)
                    (0, m) if m > 0 => Some((rx, ry, m as usize, 1.0)),
                    (m, 0) if m > 0 => Some((ry, rx, m as usize, -1.0)),
                    _ => None,
                }
            });
            let mut one_sided_json = Value::Null;
            if let Some((unv, vis, m, sign)) = one_sided {
                // select averages the products ρ_g = [L_lπ_l/q_l](θ') · [g_k/(L_kπ_k)](θ) over
                // its proposals k → l: pair the two sides' iid terms draw by draw
                let terms: Vec<f64> = unv
                    .unvisited_terms
                    .iter()
                    .zip(&vis.visited_terms)
                    .map(|(a, b)| a + b)
                    .collect();
                let ln_ref = unv.combined().0 + vis.visited_ln_ref;
                let (bp, bu, bv) = (
                    block_bias(&terms, m, ln_ref),
                    unv.unvisited_bias(m),
                    vis.visited_bias(m),
                );
                match (bp, bu, bv) {
                    (Some(bp), Some(bu), Some(bv)) => {
                        eprintln!(
                            "{:27} one-sided in select: {m} proposals into `{}` from `{}`; its estimator on iid draws: bias of ln B {:+.3} ± {:.3}, sd {:.3}, claimed {:.3} (alone: unvisited side {:+.3}, visited side {:+.3})",
                            "",
                            unv.name,
                            vis.name,
                            sign * bp.bias,
                            bp.bias_se,
                            bp.sd,
                            bp.median_claimed,
                            bu.bias,
                            bv.bias
                        );
                        one_sided_json = json!({
                            "unvisited": unv.name, "visited": vis.name, "proposals": m,
                            "bias_ln_b": sign * bp.bias, "blocks": bias_json(&Some(bp)),
                            "unvisited_side": bias_json(&Some(bu)),
                            "visited_side": bias_json(&Some(bv)),
                        });
                    }
                    _ => eprintln!(
                        "{:27} one-sided in select: {m} proposals into `{}` from `{}` (too few diagnostic draws for blocks of {m})",
                        "", unv.name, vis.name
                    ),
                }
            }
            let mut recorded_rows = Vec::new();
            let rec_pair = recorded.as_ref().and_then(|r| {
                r.get("pairs")?.as_array()?.iter().find(|p| {
                    p.get("x").and_then(Value::as_str) == Some(rx.name.as_str())
                        && p.get("y").and_then(Value::as_str) == Some(ry.name.as_str())
                })
            });
            for e in rec_pair
                .and_then(|p| p.get("estimates"))
                .and_then(Value::as_array)
                .into_iter()
                .flatten()
            {
                let (Some(method), Some(v)) = (
                    e.get("method").and_then(Value::as_str),
                    e.get("ln_b").and_then(Value::as_f64),
                ) else {
                    continue;
                };
                let se = e.get("std_err").and_then(Value::as_f64);
                let z = se.map(|s| (v - lb) / s.hypot(le));
                eprintln!(
                    "{:27} recorded {:28} {:+9.4}{}  minus IS {:+.4}{}",
                    "",
                    method,
                    v,
                    se.map_or("          ".into(), |s| format!(" ± {s:.4}")),
                    v - lb,
                    z.map_or(String::new(), |z| format!("  z {z:+.1}"))
                );
                recorded_rows.push(json!({
                    "method": method, "ln_b": v, "std_err": se, "minus_is": v - lb, "z": z,
                }));
            }
            pairs_json.push(json!({
                "x": rx.name, "y": ry.name,
                "is": per.iter().zip(PROPOSALS.iter())
                    .map(|((b, e), p)| json!({"proposal": p.name, "ln_b": b, "std_err": e}))
                    .collect::<Vec<_>>(),
                "is_combined": {"ln_b": lb, "std_err": le},
                "recorded": recorded_rows,
                "one_sided": one_sided_json,
            }));
        }
    }
    let recorded_of = |r: &ModelReport| -> Value {
        let m: serde_json::Map<String, Value> =
            ["thermodynamic", "stepping_stone", "laplace_fisher_raw"]
                .iter()
                .filter_map(|k| Some((k.to_string(), rec_model(&r.name)?.get(*k)?.clone())))
                .collect();
        Value::Object(m)
    };
    let models_json: Vec<Value> = reports
        .iter()
        .map(|r| {
            json!({
                "name": r.name,
                "free": r.free,
                "map": r.map,
                "ln_l_map": r.ln_l_map,
                "recorded_ln_l_map": rec_model(&r.name).and_then(|m| m.get("ln_l_map")).and_then(Value::as_f64),
                "laplace_fisher": r.laplace,
                "recorded": recorded_of(r),
                "is_combined": {"ln_z": r.combined().0, "std_err": r.combined().1},
                "is": r.results.iter().zip(PROPOSALS.iter()).map(|(x, p)| json!({
                    "proposal": p.name, "nu": p.nu, "scale": p.scale, "defensive": p.defensive,
                    "ln_z": x.ln_z, "std_err": x.se, "ess": x.ess, "khat": x.khat,
                    "outside_box": x.outside, "non_finite": x.non_finite, "max_share": x.max_share,
                    "posterior_mean": x.mean, "posterior_sd": x.sd, "seconds": x.seconds,
                })).collect::<Vec<_>>(),
                "jump_proposal_diagnostics": {
                    "as_is_of_z": {"ln_z": r.unvisited.ln_z, "std_err": r.unvisited.se,
                        "ess": r.unvisited.ess, "khat": r.unvisited.khat},
                    "unvisited_blocks": BLOCK_SIZES.iter().map(|&m| bias_json(&r.unvisited_bias(m))).collect::<Vec<_>>(),
                    "reciprocal_khat": r.visited_khat,
                    "visited_blocks": BLOCK_SIZES.iter().map(|&m| bias_json(&r.visited_bias(m))).collect::<Vec<_>>(),
                },
            })
        })
        .collect();
    let out = json!({
        "study": path.display().to_string(),
        "draws": n,
        "seed": seed,
        "models": models_json,
        "pairs": pairs_json,
        "seconds": t0.elapsed().as_secs_f64(),
    });
    eprintln!();
    println!("{}", serde_json::to_string_pretty(&out)?);
    Ok(())
}
