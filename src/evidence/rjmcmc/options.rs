//! The jump chain's inputs: [`RjModel`], [`RjOptions`] and their validation.

use nalgebra::DMatrix;
use serde::Serialize;

use crate::density::LogDensity;
use crate::evidence::error::EvidenceError;
use crate::evidence::mvn::MvnOptions;

/// Below this many accepted jumps between two models a pair carries a warning (see the module
/// docs: the error bar's own uncertainty then exceeds about 20 %).
pub const MIN_EFFECTIVE_JUMPS: u64 = 30;

/// Post-burn-in iterations per chain whose raw bridge inputs fix the bridge grid.
pub(crate) const PILOT_ITERS: usize = 1 << 17;

/// One model of the jump chain.
pub struct RjModel<'a> {
    /// Label for tables.
    pub name: String,
    /// The model's posterior target (its own dimension and normalised prior).
    pub target: &'a dyn LogDensity,
    /// Centre of the jump proposal and start point if this is the start model. The posterior
    /// mean of the model's own chain is the robust choice: in the low-SNR regime (posterior
    /// filling its prior box, MAP on a corner) a Fisher-based proposal around the MAP almost
    /// never lands where the posterior is.
    pub center: Vec<f64>,
    /// `Σ_k`: posterior covariance estimate (the model chain's sample covariance, or the inverse
    /// Fisher matrix). The jump proposal uses `c²Σ_k`, the random walk `s²Σ_k`.
    pub cov: DMatrix<f64>,
}

/// How the next model is proposed.
#[derive(Debug, Clone, PartialEq, Serialize, serde::Deserialize)]
pub enum JumpRule {
    /// Uniformly among the other models (the default; K = 1 means no jumps).
    UniformOthers,
    /// Uniformly among all models including the current one (LTPDA's choice; a self-jump is an
    /// independence move inside the model).
    UniformAll,
    /// `j(l|k) = matrix[k][l]`; rows sum to 1 and `j(l|k) > 0 ⇔ j(k|l) > 0`.
    Matrix(Vec<Vec<f64>>),
}

/// Shape of the independence jump proposal.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, serde::Deserialize)]
pub enum ProposalShape {
    /// Multivariate normal.
    Gaussian,
    /// Multivariate Student-t with `nu` degrees of freedom (heavier tails, for non-Gaussian
    /// posteriors; `ltp-model.md` suggests ν = 4).
    StudentT { nu: f64 },
}

/// Options of [`run_rjmcmc`](super::run::run_rjmcmc).
#[derive(Debug, Clone, PartialEq, Serialize, serde::Deserialize)]
pub struct RjOptions {
    /// Total iterations summed over the chains (each: one in-model step and one jump attempt).
    /// Each chain runs `⌊n_iter / n_chains⌋`, its burn-in included.
    pub n_iter: usize,
    /// Iterations each chain discards before counting.
    pub burn_in: usize,
    /// Seed; chain `j` uses the stream `seed_from_u64(seed)` advanced by `j` `jump()`s.
    pub seed: u64,
    /// Independent chains, run on the rayon pool and pooled. The result does not depend on the
    /// number of threads. Two chains use both cores of a small machine and let the between-chain
    /// spread show up in the pooled batch means.
    pub n_chains: usize,
    /// Weight `w ∈ [0, 1)` of the model's own prior in the jump proposal
    /// `q = (1 − w)·N/t(center, c²Σ) + w·π_k`. It keeps `q > 0` wherever `π > 0` and bounds the
    /// importance weights `Lπ/q ≤ L/w`, so a badly placed Gaussian cannot make the bridge's and
    /// Rao-Blackwell's weights unbounded. The default 0.1 costs at most a factor `1/(1 − w) ≈ 1.11`
    /// in useful proposals when the Gaussian is good (Hesterberg's defensive mixtures use
    /// 0.1–0.5) while guaranteeing one proposal in ten samples the whole prior box, which is what
    /// the low-SNR regime (posterior filling the box) needs. `0` gives the pure Gaussian/t
    /// proposal and the same random stream as before this option existed.
    pub defensive: f64,
    /// Prior model probabilities `P(k)` (normalised internally); `None`: uniform.
    pub prior_model_probs: Option<Vec<f64>>,
    /// Model proposal.
    pub jump: JumpRule,
    /// Shape of the parameter proposal.
    pub proposal: ProposalShape,
    /// `c` in `c²Σ_k` (`ltp-model.md`: 1–1.5; below √2 keeps the bridge estimator's variance
    /// finite for Gaussian posteriors).
    pub jump_scale: f64,
    /// Random-walk scale `s`; `None`: `2.38/√D_k`.
    pub rw_scale: Option<f64>,
    /// Record the visit counts every this many post-burn-in iterations (per chain); 0: about
    /// 1000 points. The trace is the only output whose size grows with `n_iter / trace_every`.
    pub trace_every: usize,
    /// Batch size for the errors; `None`: `⌊√N⌋` with N the post-burn-in iterations of one chain.
    pub batch_size: Option<usize>,
    /// Index of the starting model (it starts at its `center`).
    pub start_model: usize,
    /// QMC settings of the Gaussian proposals' box masses.
    pub box_mass: MvnOptions,
    /// Keep every post-burn-in draw (model, parameters, `ln L`) in [`RjResult::draws`]:
    /// `N − chains·burn_in` rows of `P + 2` numbers, `P` the union of the models' parameters.
    ///
    /// [`RjResult::draws`]: super::result::RjResult::draws
    pub keep_draws: bool,
}

impl Default for RjOptions {
    fn default() -> Self {
        Self {
            n_iter: 100_000,
            burn_in: 1_000,
            seed: 1,
            n_chains: 2,
            defensive: 0.1,
            prior_model_probs: None,
            jump: JumpRule::UniformOthers,
            proposal: ProposalShape::Gaussian,
            jump_scale: 1.2,
            rw_scale: None,
            trace_every: 0,
            batch_size: None,
            start_model: 0,
            box_mass: MvnOptions::default(),
            keep_draws: false,
        }
    }
}

pub(crate) type Validated = (Vec<f64>, Vec<Vec<f64>>);

pub(crate) fn validate(
    models: &[RjModel<'_>],
    opts: &RjOptions,
) -> Result<Validated, EvidenceError> {
    let k = models.len();
    if k == 0 || k > u16::MAX as usize {
        return Err(EvidenceError::option(
            "rjmcmc models",
            k,
            "pass between 1 and 65535 models",
        ));
    }
    if opts.n_chains == 0 || opts.n_chains > 4096 {
        return Err(EvidenceError::option(
            "rjmcmc n_chains",
            opts.n_chains,
            "run between 1 and 4096 chains",
        ));
    }
    if !(opts.defensive.is_finite() && (0.0..1.0).contains(&opts.defensive)) {
        return Err(EvidenceError::option(
            "rjmcmc defensive",
            opts.defensive,
            "the prior weight of the jump proposal must be in [0, 1) (0.1 is a good default; 1 would drop the Gaussian part)",
        ));
    }
    let per_chain = opts.n_iter / opts.n_chains;
    if per_chain <= opts.burn_in || per_chain - opts.burn_in < 100 {
        return Err(EvidenceError::option(
            "rjmcmc n_iter",
            opts.n_iter,
            &format!(
                "need at least 100 iterations after burn_in in each of the {} chains (n_iter ≥ n_chains·(burn_in + 100))",
                opts.n_chains
            ),
        ));
    }
    let n_post = per_chain - opts.burn_in;
    if let Some(b) = opts.batch_size
        && (b == 0 || b > n_post / 2)
    {
        return Err(EvidenceError::option(
            "rjmcmc batch_size",
            b,
            "need 1 ≤ batch_size ≤ (n_iter/n_chains − burn_in)/2 so each chain has at least 2 batches",
        ));
    }
    if !(opts.jump_scale.is_finite() && opts.jump_scale > 0.0) {
        return Err(EvidenceError::option(
            "rjmcmc jump_scale",
            opts.jump_scale,
            "c must be finite and > 0 (typically 1–1.5)",
        ));
    }
    if let Some(s) = opts.rw_scale
        && !(s.is_finite() && s > 0.0)
    {
        return Err(EvidenceError::option(
            "rjmcmc rw_scale",
            s,
            "the random-walk scale must be finite and > 0",
        ));
    }
    if let ProposalShape::StudentT { nu } = opts.proposal
        && !(nu.is_finite() && nu > 0.0)
    {
        return Err(EvidenceError::option(
            "rjmcmc proposal nu",
            nu,
            "ν must be finite and > 0",
        ));
    }
    if opts.start_model >= k {
        return Err(EvidenceError::option(
            "rjmcmc start_model",
            opts.start_model,
            &format!("must be < {k}"),
        ));
    }
    let prior_p = match &opts.prior_model_probs {
        None => vec![1.0 / k as f64; k],
        Some(p) => {
            if p.len() != k {
                return Err(EvidenceError::dimension("prior_model_probs", k, p.len()));
            }
            if p.iter().any(|v| !(v.is_finite() && *v > 0.0)) {
                return Err(EvidenceError::option(
                    "rjmcmc prior_model_probs",
                    format!("{p:?}"),
                    "every prior model probability must be finite and > 0",
                ));
            }
            let s: f64 = p.iter().sum();
            p.iter().map(|v| v / s).collect()
        }
    };
    let jump = match &opts.jump {
        JumpRule::UniformOthers => (0..k)
            .map(|a| {
                (0..k)
                    .map(|b| {
                        if k == 1 {
                            1.0
                        } else if a == b {
                            0.0
                        } else {
                            1.0 / (k - 1) as f64
                        }
                    })
                    .collect()
            })
            .collect(),
        JumpRule::UniformAll => vec![vec![1.0 / k as f64; k]; k],
        JumpRule::Matrix(m) => {
            if m.len() != k || m.iter().any(|r| r.len() != k) {
                return Err(EvidenceError::option(
                    "rjmcmc jump matrix",
                    format!("{} rows", m.len()),
                    &format!("pass a {k}×{k} matrix"),
                ));
            }
            for (a, row) in m.iter().enumerate() {
                let s: f64 = row.iter().sum();
                if row.iter().any(|v| !(v.is_finite() && *v >= 0.0)) || (s - 1.0).abs() > 1e-9 {
                    return Err(EvidenceError::option(
                        "rjmcmc jump matrix",
                        format!("row {a} = {row:?}"),
                        "each row must hold probabilities ≥ 0 summing to 1",
                    ));
                }
                for (b, &v) in row.iter().enumerate() {
                    if (v > 0.0) != (m[b][a] > 0.0) {
                        return Err(EvidenceError::option(
                            "rjmcmc jump matrix",
                            format!("j({b}|{a}) = {v}, j({a}|{b}) = {}", m[b][a]),
                            "a jump must be possible in both directions or in neither (reversibility)",
                        ));
                    }
                }
            }
            m.clone()
        }
    };
    for (i, m) in models.iter().enumerate() {
        let d = m.target.dim();
        if m.center.len() != d {
            return Err(EvidenceError::dimension(
                format!("center of model `{}`", m.name),
                d,
                m.center.len(),
            ));
        }
        if m.cov.nrows() != d || m.cov.ncols() != d {
            return Err(EvidenceError::dimension(
                format!("cov rows of model `{}`", m.name),
                d,
                m.cov.nrows().max(m.cov.ncols()),
            ));
        }
        if let Some(v) = m.center.iter().find(|v| !v.is_finite()) {
            return Err(EvidenceError::non_finite(
                format!("center of model `{}`", m.name),
                *v,
                "pass the MAP",
            ));
        }
        if i == opts.start_model {
            let lp = m.target.ln_posterior(&m.center);
            if !lp.is_finite() {
                return Err(EvidenceError::non_finite(
                    format!("ln posterior at the center of start model `{}`", m.name),
                    lp,
                    "the start model's center must lie inside its prior with a finite likelihood",
                ));
            }
        }
    }
    Ok((prior_p, jump))
}
