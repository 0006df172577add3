//! The output of a run: kept samples, their log densities and per-chain counters.

use serde::{Deserialize, Serialize};

use super::SamplerError;
use super::diagnostics::{Diagnostics, Thresholds};

/// Proposal outcomes in one phase of a chain (burn-in or sampling).
///
/// `proposed = accepted + prior_rejected + non_finite + (rejected by the MH test)`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct PhaseCounts {
    /// Proposals made (one per iteration).
    pub proposed: u64,
    /// Proposals accepted.
    pub accepted: u64,
    /// Proposals outside the prior support (rejected without evaluating `ln L`).
    pub prior_rejected: u64,
    /// Proposals where `ln L` was NaN or ±∞ (rejected and counted here).
    pub non_finite: u64,
}

impl PhaseCounts {
    /// `accepted / proposed` (0 when nothing was proposed).
    pub fn acceptance(&self) -> f64 {
        if self.proposed == 0 {
            0.0
        } else {
            self.accepted as f64 / self.proposed as f64
        }
    }
}

/// Counters of one chain, split at the end of the burn-in.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct ChainCounts {
    /// Iterations `n ≤ burn_in` (including any annealed search).
    pub burn_in: PhaseCounts,
    /// Iterations `n > burn_in`.
    pub sampling: PhaseCounts,
}

/// A point with its log densities.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BestPoint {
    /// Parameters.
    pub theta: Vec<f64>,
    /// `ln L + ln π`.
    pub ln_posterior: f64,
    /// `ln L`.
    pub ln_likelihood: f64,
}

/// One chain's output.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Chain {
    /// Kept samples, row-major `n_kept × dim`.
    pub samples: Vec<f64>,
    /// `ln L + ln π` of each kept sample.
    pub ln_posterior: Vec<f64>,
    /// `ln L` of each kept sample.
    pub ln_likelihood: Vec<f64>,
    /// Proposal outcomes.
    pub counts: ChainCounts,
    /// Highest-posterior point this chain evaluated, burn-in and rejected proposals included:
    /// the result of the annealed search.
    pub best: BestPoint,
    /// The proposal covariance the kept samples were drawn with (the adapted one, if
    /// adaptation ran), row-major `dim × dim`.
    pub proposal_covariance: Vec<f64>,
}

/// The kept samples of every chain of a run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Chains {
    names: Vec<String>,
    chains: Vec<Chain>,
}

/// Where the highest-posterior kept sample is.
#[derive(Debug, Clone, PartialEq)]
pub struct MaxPosterior<'a> {
    /// Chain index.
    pub chain: usize,
    /// Sample index within the chain.
    pub index: usize,
    /// The sample.
    pub theta: &'a [f64],
    /// Its `ln L + ln π`.
    pub ln_posterior: f64,
    /// Its `ln L`.
    pub ln_likelihood: f64,
}

impl Chains {
    pub(crate) fn new(names: Vec<String>, chains: Vec<Chain>) -> Self {
        Self { names, chains }
    }

    /// Parameter names.
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// Number of parameters.
    pub fn dim(&self) -> usize {
        self.names.len()
    }

    /// The chains.
    pub fn chains(&self) -> &[Chain] {
        &self.chains
    }

    /// Kept samples per chain.
    pub fn n_kept(&self) -> usize {
        self.chains.first().map_or(0, |c| c.ln_posterior.len())
    }

    /// Sample `i` of chain `c`.
    pub fn sample(&self, c: usize, i: usize) -> &[f64] {
        let d = self.dim();
        &self.chains[c].samples[i * d..(i + 1) * d]
    }

    /// Parameter `k` of chain `c` as a series.
    pub fn series(&self, c: usize, k: usize) -> Vec<f64> {
        self.chains[c]
            .samples
            .chunks_exact(self.dim())
            .map(|s| s[k])
            .collect()
    }

    /// Highest-posterior kept sample over all chains (ties go to the lowest chain and
    /// index). This is the θ_MAP that Laplace–Metropolis needs (ltp-model.md §9.1).
    pub fn max_posterior(&self) -> Option<MaxPosterior<'_>> {
        let mut best: Option<(usize, usize, f64)> = None;
        for (c, ch) in self.chains.iter().enumerate() {
            for (i, &lp) in ch.ln_posterior.iter().enumerate() {
                if best.is_none_or(|(_, _, b)| lp > b) {
                    best = Some((c, i, lp));
                }
            }
        }
        best.map(|(c, i, lp)| MaxPosterior {
            chain: c,
            index: i,
            theta: self.sample(c, i),
            ln_posterior: lp,
            ln_likelihood: self.chains[c].ln_likelihood[i],
        })
    }

    /// Highest-posterior point evaluated by any chain, burn-in and search included.
    pub fn best_visited(&self) -> &BestPoint {
        let mut best = &self.chains[0].best;
        for ch in &self.chains[1..] {
            if ch.best.ln_posterior > best.ln_posterior {
                best = &ch.best;
            }
        }
        best
    }

    /// Mean of the pooled kept samples.
    pub fn mean(&self) -> Vec<f64> {
        let d = self.dim();
        let mut m = vec![0.0; d];
        let mut n = 0usize;
        for ch in &self.chains {
            for s in ch.samples.chunks_exact(d) {
                for (mk, sk) in m.iter_mut().zip(s) {
                    *mk += sk;
                }
                n += 1;
            }
        }
        m.iter_mut().for_each(|x| *x /= n as f64);
        m
    }

    /// Covariance of the pooled kept samples (denominator `N − 1`), row-major `dim × dim`.
    pub fn covariance(&self) -> Vec<f64> {
        let d = self.dim();
        let m = self.mean();
        let mut c = vec![0.0; d * d];
        let mut n = 0usize;
        for ch in &self.chains {
            for s in ch.samples.chunks_exact(d) {
                for i in 0..d {
                    for j in 0..d {
                        c[i * d + j] += (s[i] - m[i]) * (s[j] - m[j]);
                    }
                }
                n += 1;
            }
        }
        let denom = n.saturating_sub(1).max(1) as f64;
        c.iter_mut().for_each(|x| *x /= denom);
        c
    }

    /// Diagnostics with the default [`Thresholds`].
    pub fn diagnostics(&self) -> Result<Diagnostics, SamplerError> {
        Diagnostics::compute(self, Thresholds::default())
    }

    /// Diagnostics with the given thresholds for [`Diagnostics::warnings`].
    pub fn diagnostics_with(&self, thresholds: Thresholds) -> Result<Diagnostics, SamplerError> {
        Diagnostics::compute(self, thresholds)
    }
}
