//! Run settings for the Metropolis–Hastings driver, validated before anything runs.

use serde::{Deserialize, Serialize};

use super::error::SamplerError;

/// LTPDA's annealed search phase (ltp-model.md §9.1), run at the start of the burn-in.
///
/// With iteration `n`:
/// * `n ≤ tc1`: constant heat `β = 10^{−ξ(1 − tc1/tc2)}` and search jumps (see
///   [`Anneal::step_scale`]);
/// * `tc1 < n ≤ tc2`: `β = 10^{−ξ(1 − n/tc2)}` rising to 1, proposal `√jumps[0]`·(normal step);
/// * `n > tc2`: `β = 1` and the plain proposal.
///
/// The acceptance test is `ln u < β (ln π' + ln L' − ln π − ln L) + ln(Hastings ratio)`.
/// Tempered and jump iterations are not posterior draws, so validation demands
/// `tc2 ≤ burn_in`; the best point visited (see [`Chain::best`](super::Chain)) is the search
/// result.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Anneal {
    /// Last iteration of the hot, constant-β phase with search jumps.
    pub tc1: usize,
    /// Last iteration of the cool-down; β = 1 afterwards. Must satisfy `tc1 < tc2 ≤ burn_in`.
    pub tc2: usize,
    /// ξ (LTPDA `HEAT`, default 1): the hot phase runs at β = 10^{−ξ(1 − tc1/tc2)}.
    pub heat: f64,
    /// Standard-deviation multipliers `[normal, big₁, big₂, big₃]` of the proposal during the
    /// search (LTPDA `JUMPS`, default `[2, 10, 1e3, 1e4]`).
    pub jumps: [f64; 4],
}

impl Anneal {
    /// LTPDA's defaults (`HEAT` = 1, `JUMPS` = [2, 10, 1e3, 1e4]) with the given phase ends.
    pub fn new(tc1: usize, tc2: usize) -> Self {
        Self {
            tc1,
            tc2,
            heat: 1.0,
            jumps: [2.0, 10.0, 1e3, 1e4],
        }
    }
}

/// Haario-style adaptation of the proposal covariance during the burn-in.
///
/// From iteration `start + 1` to `burn_in` every chain accumulates the running mean and
/// covariance `C` of its own states (Welford). Every `interval` iterations the proposal becomes
/// `s · (C + ridge · diag C)` with `s = scale` (default `2.38²/D`, Gelman, Roberts & Gilks 1996),
/// provided the chain accepted at least `2D` moves since `start` (fewer distinct points give a
/// rank-deficient `C`) and the matrix factorises; otherwise the previous proposal stays.
///
/// Adaptation stops at `burn_in`: the kept chain runs with a fixed proposal, so it is a
/// homogeneous Markov chain with the target as its stationary law (an ever-adapting chain is
/// not Markov and needs diminishing-adaptation arguments to be trusted). Each chain adapts on
/// its own states only, which keeps chains independent and thread-count invariant.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Adapt {
    /// Adaptation uses iterations `n > start`. With [`Anneal`] it must be `≥ tc2` (tempered
    /// states do not describe the posterior). Must be `< burn_in`.
    pub start: usize,
    /// Iterations between covariance updates (≥ 1).
    pub interval: usize,
    /// Proposal scale `s`; `None` means `2.38²/D`.
    pub scale: Option<f64>,
    /// Relative ridge added to the diagonal (≥ 0) so near-degenerate directions keep a
    /// positive definite proposal.
    pub ridge: f64,
}

impl Default for Adapt {
    fn default() -> Self {
        Self {
            start: 0,
            interval: 500,
            scale: None,
            ridge: 1e-9,
        }
    }
}

/// Settings of a Metropolis–Hastings run.
///
/// ```
/// use occam::sampler::MhSettings;
/// let s = MhSettings { n_iter: 10_000, burn_in: 2_000, ..MhSettings::default() };
/// assert!(s.validate().is_ok());
/// assert_eq!(s.n_kept(), 8_000);
/// assert!(MhSettings { burn_in: 10_000, ..s }.validate().is_err());
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MhSettings {
    /// Iterations per chain, burn-in included (> 0).
    pub n_iter: usize,
    /// Leading iterations discarded (< `n_iter`).
    pub burn_in: usize,
    /// Keep every `thin`-th state after the burn-in (≥ 1).
    pub thin: usize,
    /// Number of independent chains (≥ 1), run in parallel.
    pub n_chains: usize,
    /// Run seed; chain `c` uses [`chain_rng`](super::chain_rng)`(seed, c)`.
    pub seed: u64,
    /// Optional LTPDA annealed search at the start of the burn-in.
    pub anneal: Option<Anneal>,
    /// Optional covariance adaptation during the burn-in.
    pub adapt: Option<Adapt>,
    /// Block length in iterations: after each block the driver writes the checkpoint (if one
    /// is configured) and asks the stop hook (≥ 1). Does not change the numbers.
    pub checkpoint_every: usize,
    /// The progress observer is called every this many iterations per chain (≥ 1).
    pub progress_every: usize,
}

impl Default for MhSettings {
    fn default() -> Self {
        Self {
            n_iter: 20_000,
            burn_in: 5_000,
            thin: 1,
            n_chains: 4,
            seed: 1,
            anneal: None,
            adapt: None,
            checkpoint_every: 5_000,
            progress_every: 100,
        }
    }
}

fn bad(field: &'static str, problem: String) -> Result<(), SamplerError> {
    Err(SamplerError::Setting { field, problem })
}

impl MhSettings {
    /// Kept samples per chain: `⌊(n_iter − burn_in)/thin⌋`.
    pub fn n_kept(&self) -> usize {
        self.n_iter.saturating_sub(self.burn_in) / self.thin.max(1)
    }

    /// Checks every field; the error names the field and the fix.
    pub fn validate(&self) -> Result<(), SamplerError> {
        if self.n_iter == 0 {
            return bad(
                "n_iter",
                "must be > 0: it is the number of iterations per chain, burn-in included".into(),
            );
        }
        if self.burn_in >= self.n_iter {
            return bad(
                "burn_in",
                format!(
                    "burn_in = {} must be < n_iter = {}, or nothing is kept; lower burn_in or raise n_iter",
                    self.burn_in, self.n_iter
                ),
            );
        }
        if self.thin == 0 {
            return bad("thin", "must be ≥ 1 (1 keeps every state)".into());
        }
        if self.n_kept() == 0 {
            return bad(
                "thin",
                format!(
                    "thin = {} exceeds the {} post-burn-in iterations, so no sample would be kept; lower thin",
                    self.thin,
                    self.n_iter - self.burn_in
                ),
            );
        }
        if self.n_chains == 0 {
            return bad("n_chains", "must be ≥ 1".into());
        }
        if self.checkpoint_every == 0 {
            return bad(
                "checkpoint_every",
                "must be ≥ 1 iteration (it is the block length)".into(),
            );
        }
        if self.progress_every == 0 {
            return bad("progress_every", "must be ≥ 1 iteration".into());
        }
        if let Some(a) = &self.anneal {
            if a.tc1 >= a.tc2 {
                return bad(
                    "anneal.tc1",
                    format!("needs tc1 < tc2 (got tc1 = {}, tc2 = {})", a.tc1, a.tc2),
                );
            }
            if a.tc2 > self.burn_in {
                return bad(
                    "anneal.tc2",
                    format!(
                        "tc2 = {} exceeds burn_in = {}: tempered and jump iterations are not posterior draws; set burn_in ≥ tc2",
                        a.tc2, self.burn_in
                    ),
                );
            }
            if !(a.heat.is_finite() && a.heat >= 0.0) {
                return bad(
                    "anneal.heat",
                    format!(
                        "must be finite and ≥ 0 (got {}); LTPDA's default is 1",
                        a.heat
                    ),
                );
            }
            if let Some(j) = a.jumps.iter().find(|j| !(j.is_finite() && **j > 0.0)) {
                return bad(
                    "anneal.jumps",
                    format!(
                        "every multiplier must be finite and > 0 (got {j}); LTPDA's default is [2, 10, 1e3, 1e4]"
                    ),
                );
            }
        }
        if let Some(ad) = &self.adapt {
            if ad.interval == 0 {
                return bad("adapt.interval", "must be ≥ 1 iteration".into());
            }
            if ad.start >= self.burn_in {
                return bad(
                    "adapt.start",
                    format!(
                        "start = {} must be < burn_in = {}: adaptation happens only during the burn-in, so the kept chain is Markov",
                        ad.start, self.burn_in
                    ),
                );
            }
            if let Some(a) = &self.anneal
                && ad.start < a.tc2
            {
                return bad(
                    "adapt.start",
                    format!(
                        "start = {} is inside the annealed search (tc2 = {}); tempered states do not describe the posterior, set start ≥ tc2",
                        ad.start, a.tc2
                    ),
                );
            }
            if let Some(s) = ad.scale
                && !(s.is_finite() && s > 0.0)
            {
                return bad(
                    "adapt.scale",
                    format!("must be finite and > 0 (got {s}); omit it for 2.38²/D"),
                );
            }
            if !(ad.ridge.is_finite() && ad.ridge >= 0.0) {
                return bad(
                    "adapt.ridge",
                    format!("must be finite and ≥ 0 (got {})", ad.ridge),
                );
            }
        }
        Ok(())
    }
}

/// Where the chains start.
///
/// A start point outside the prior support, or one where `ln L` is not finite, is an error
/// naming the chain and parameter (LTPDA silently replaced it by a prior draw; use
/// [`Start::Prior`] to ask for that explicitly).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Start {
    /// Every chain starts at this point.
    Point(Vec<f64>),
    /// One point per chain (`n_chains` of them).
    PerChain(Vec<Vec<f64>>),
    /// Chain `c` starts at `centre + spread · L z`, with `L` the Cholesky factor of the proposal
    /// covariance and `z` standard normal drawn from the chain's own stream; redrawn (up to
    /// 1000 times) until inside the prior with a finite `ln L`. Dispersed starts make R̂
    /// meaningful.
    Around {
        /// Centre of the dispersion, e.g. the MAP estimate.
        centre: Vec<f64>,
        /// Multiplier of the proposal's standard deviations (> 0).
        spread: f64,
    },
    /// Chain `c` starts at a draw from the prior, taken from its own stream.
    Prior,
}

#[cfg(test)]
mod tests {
    use super::*;

    fn field_of(s: &MhSettings) -> &'static str {
        match s.validate() {
            Err(SamplerError::Setting { field, .. }) => field,
            other => panic!("expected a setting error, got {other:?}"),
        }
    }

    #[test]
    fn default_is_valid() {
        MhSettings::default().validate().unwrap();
    }

    #[test]
    fn each_bad_field_is_named() {
        let ok = MhSettings {
            n_iter: 1000,
            burn_in: 500,
            ..MhSettings::default()
        };
        let cases: Vec<(MhSettings, &str)> = vec![
            (
                MhSettings {
                    n_iter: 0,
                    burn_in: 0,
                    ..ok.clone()
                },
                "n_iter",
            ),
            (
                MhSettings {
                    burn_in: 1000,
                    ..ok.clone()
                },
                "burn_in",
            ),
            (
                MhSettings {
                    thin: 0,
                    ..ok.clone()
                },
                "thin",
            ),
            (
                MhSettings {
                    thin: 501,
                    ..ok.clone()
                },
                "thin",
            ),
            (
                MhSettings {
                    n_chains: 0,
                    ..ok.clone()
                },
                "n_chains",
            ),
            (
                MhSettings {
                    checkpoint_every: 0,
                    ..ok.clone()
                },
                "checkpoint_every",
            ),
            (
                MhSettings {
                    progress_every: 0,
                    ..ok.clone()
                },
                "progress_every",
            ),
            (
                MhSettings {
                    anneal: Some(Anneal::new(200, 200)),
                    ..ok.clone()
                },
                "anneal.tc1",
            ),
            (
                MhSettings {
                    anneal: Some(Anneal::new(100, 600)),
                    ..ok.clone()
                },
                "anneal.tc2",
            ),
            (
                MhSettings {
                    anneal: Some(Anneal {
                        heat: f64::NAN,
                        ..Anneal::new(100, 200)
                    }),
                    ..ok.clone()
                },
                "anneal.heat",
            ),
            (
                MhSettings {
                    anneal: Some(Anneal {
                        jumps: [2.0, 0.0, 1e3, 1e4],
                        ..Anneal::new(100, 200)
                    }),
                    ..ok.clone()
                },
                "anneal.jumps",
            ),
            (
                MhSettings {
                    adapt: Some(Adapt {
                        interval: 0,
                        ..Adapt::default()
                    }),
                    ..ok.clone()
                },
                "adapt.interval",
            ),
            (
                MhSettings {
                    adapt: Some(Adapt {
                        start: 500,
                        ..Adapt::default()
                    }),
                    ..ok.clone()
                },
                "adapt.start",
            ),
            (
                MhSettings {
                    anneal: Some(Anneal::new(100, 200)),
                    adapt: Some(Adapt {
                        start: 150,
                        ..Adapt::default()
                    }),
                    ..ok.clone()
                },
                "adapt.start",
            ),
            (
                MhSettings {
                    adapt: Some(Adapt {
                        scale: Some(-1.0),
                        ..Adapt::default()
                    }),
                    ..ok.clone()
                },
                "adapt.scale",
            ),
            (
                MhSettings {
                    adapt: Some(Adapt {
                        ridge: f64::INFINITY,
                        ..Adapt::default()
                    }),
                    ..ok.clone()
                },
                "adapt.ridge",
            ),
        ];
        for (s, want) in cases {
            assert_eq!(field_of(&s), want, "{s:?}");
        }
        ok.validate().unwrap();
        MhSettings {
            anneal: Some(Anneal::new(100, 200)),
            adapt: Some(Adapt {
                start: 200,
                ..Adapt::default()
            }),
            ..ok
        }
        .validate()
        .unwrap();
    }
}
