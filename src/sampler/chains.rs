//! The output of a run: kept samples, their log densities and per-chain counters.

use serde::{Deserialize, Serialize};

use super::error::SamplerError;

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
    /// Of `sampling`, the iterations that drew from the independence proposal
    /// ([`super::MetropolisHastings::independence`]; zero without one).
    #[serde(default)]
    pub independent: PhaseCounts,
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
    /// Per kept sample: a proposal was accepted since the previous kept sample — with
    /// `thin` = 1 exactly "this iteration's proposal was accepted"; with thinning, "the state
    /// moved since the previous kept sample". Serialisations of older versions lack it; they
    /// get `backfill_accepted`.
    #[serde(default)]
    pub accepted: Vec<bool>,
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
///
/// Always holds at least one chain, every chain with the same number (≥ 1) of kept samples
/// of the same dimension ([`Chains::new`] and deserialisation check this).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "RawChains")]
pub struct Chains {
    names: Vec<String>,
    chains: Vec<Chain>,
}

#[derive(Deserialize)]
struct RawChains {
    names: Vec<String>,
    chains: Vec<Chain>,
}

impl TryFrom<RawChains> for Chains {
    type Error = SamplerError;
    fn try_from(mut r: RawChains) -> Result<Self, SamplerError> {
        let d = r.names.len();
        for ch in &mut r.chains {
            if ch.accepted.is_empty() && d > 0 && ch.samples.len() % d == 0 {
                ch.accepted = backfill_accepted(&ch.samples, d, ch.counts.sampling.accepted);
            }
        }
        Chains::new(r.names, r.chains)
    }
}

/// The acceptance flags of kept samples stored without them (by an older version): sample
/// `i ≥ 1` is flagged when it differs from sample `i − 1` (the state moved: exact, as a
/// continuous proposal never lands on the current state); sample 0 when the sampling phase
/// accepted more proposals (`sampling_accepted`) than the later flags account for — exact when
/// every sampling iteration was kept (`thin` = 1), and with thinning an upper bound (a later
/// window may hold several acceptances).
pub(crate) fn backfill_accepted(samples: &[f64], d: usize, sampling_accepted: u64) -> Vec<bool> {
    let rows: Vec<&[f64]> = samples.chunks_exact(d).collect();
    let mut flags: Vec<bool> = Vec::with_capacity(rows.len());
    if rows.is_empty() {
        return flags;
    }
    flags.push(false);
    flags.extend(rows.windows(2).map(|w| w[0] != w[1]));
    let later = flags.iter().filter(|&&f| f).count() as u64;
    flags[0] = sampling_accepted > later;
    flags
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
    /// Checks shapes: ≥ 1 chain; per chain the same `n ≥ 1` kept samples, `n × dim` sample
    /// values, `n` log densities of each kind, a best point of `dim` entries and a
    /// `dim × dim` proposal covariance, with `dim = names.len() ≥ 1`.
    pub fn new(names: Vec<String>, chains: Vec<Chain>) -> Result<Self, SamplerError> {
        let bad = |problem: String| Err(SamplerError::Chains { problem });
        let d = names.len();
        if d == 0 {
            return bad("no parameter names".into());
        }
        let Some(first) = chains.first() else {
            return bad("no chains".into());
        };
        let n = first.ln_posterior.len();
        if n == 0 {
            return bad("chain 0 has no kept samples".into());
        }
        for (c, ch) in chains.iter().enumerate() {
            if ch.ln_posterior.len() != n
                || ch.ln_likelihood.len() != n
                || ch.accepted.len() != n
                || ch.samples.len() != n * d
                || ch.best.theta.len() != d
                || ch.proposal_covariance.len() != d * d
            {
                return bad(format!(
                    "chain {c} has {} sample values, {} ln posteriors, {} ln likelihoods, {} acceptance flags, a best point of {} and a proposal covariance of {} entries; expected {}, {n}, {n}, {n}, {d} and {} for {n} samples of {d} parameters",
                    ch.samples.len(),
                    ch.ln_posterior.len(),
                    ch.ln_likelihood.len(),
                    ch.accepted.len(),
                    ch.best.theta.len(),
                    ch.proposal_covariance.len(),
                    n * d,
                    d * d
                ));
            }
        }
        Ok(Self { names, chains })
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
        self.chains[0].ln_posterior.len()
    }

    /// Sample `i` of chain `c` (panics if out of range, like slice indexing).
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
    pub fn max_posterior(&self) -> MaxPosterior<'_> {
        let mut best: Option<(usize, usize, f64)> = None;
        for (c, ch) in self.chains.iter().enumerate() {
            for (i, &lp) in ch.ln_posterior.iter().enumerate() {
                if best.is_none_or(|(_, _, b)| lp > b) {
                    best = Some((c, i, lp));
                }
            }
        }
        let (c, i, lp) = best.expect("Chains holds at least one sample");
        MaxPosterior {
            chain: c,
            index: i,
            theta: self.sample(c, i),
            ln_posterior: lp,
            ln_likelihood: self.chains[c].ln_likelihood[i],
        }
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
}

#[cfg(test)]
mod tests {
    use super::*;

    fn chain(n: usize, d: usize, offset: f64) -> Chain {
        Chain {
            samples: (0..n * d).map(|k| offset + k as f64).collect(),
            ln_posterior: (0..n).map(|k| -(k as f64) - offset).collect(),
            ln_likelihood: vec![-1.0; n],
            accepted: vec![true; n],
            counts: ChainCounts::default(),
            best: BestPoint {
                theta: vec![offset; d],
                ln_posterior: -offset,
                ln_likelihood: -1.0,
            },
            proposal_covariance: vec![1.0; d * d],
        }
    }

    #[test]
    fn backfilled_flags_follow_the_moves() {
        // 4 draws of 2 parameters: moves into draws 2 and 3, not 1
        let s = [0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 2.0];
        assert_eq!(backfill_accepted(&s, 2, 2), [false, false, true, true]);
        // one more acceptance than the later moves: the first draw's
        assert_eq!(backfill_accepted(&s, 2, 3), [true, false, true, true]);
        assert!(backfill_accepted(&[], 2, 5).is_empty());
        assert_eq!(backfill_accepted(&[1.0], 1, 0), [false]);
        // a serialisation without flags gets them on reading
        let names = vec!["a".to_string()];
        let mut c = chain(3, 1, 0.0);
        c.accepted.clear();
        c.counts.sampling.accepted = 3;
        let json = serde_json::to_string(&Chains {
            names: names.clone(),
            chains: vec![c],
        })
        .unwrap()
        .replace(",\"accepted\":[]", "");
        assert!(!json.contains("\"accepted\":["));
        let back: Chains = serde_json::from_str(&json).unwrap();
        assert_eq!(back.chains()[0].accepted, [true, true, true]);
    }

    #[test]
    fn shapes_are_checked_on_construction_and_deserialisation() {
        let names = vec!["a".to_string(), "b".to_string()];
        let ok = Chains::new(names.clone(), vec![chain(3, 2, 0.0), chain(3, 2, 0.5)]).unwrap();
        assert_eq!(ok.n_kept(), 3);
        assert_eq!(ok.sample(1, 2), &[4.5, 5.5]);
        assert_eq!(ok.series(0, 1), vec![1.0, 3.0, 5.0]);
        assert_eq!(ok.mean(), vec![2.25, 3.25]);
        // Highest ln posterior: sample 0 of chain 0 (−0 > −0.5); best visited: chain 0.
        let mp = ok.max_posterior();
        assert_eq!((mp.chain, mp.index, mp.theta), (0, 0, &[0.0, 1.0][..]));
        assert_eq!(ok.best_visited().theta, vec![0.0, 0.0]);
        for bad in [
            Chains::new(vec![], vec![chain(3, 0, 0.0)]),
            Chains::new(names.clone(), vec![]),
            Chains::new(names.clone(), vec![chain(0, 2, 0.0)]),
            Chains::new(names.clone(), vec![chain(3, 2, 0.0), chain(2, 2, 0.0)]),
            Chains::new(names.clone(), vec![chain(3, 3, 0.0)]),
        ] {
            assert!(matches!(bad, Err(SamplerError::Chains { .. })), "{bad:?}");
        }
        let json = serde_json::to_string(&ok).unwrap();
        let back: Chains = serde_json::from_str(&json).unwrap();
        assert_eq!(back, ok);
        let broken = json.replacen(
            "\"ln_likelihood\":[-1.0,-1.0,-1.0]",
            "\"ln_likelihood\":[-1.0]",
            1,
        );
        assert_ne!(broken, json);
        assert!(serde_json::from_str::<Chains>(&broken).is_err());
    }
}
