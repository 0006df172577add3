//! A select run prepared from the study: every competing model with what its stages need
//! ([`ModelPlan`]), and the reversible-jump options, as plain values built once here. The
//! per-model pipeline ([`super::model`]) and the checkpoint's restore read these, never the
//! study.

use super::error::SelectError;
use crate::config::{CrossChecks, JumpProposal, LikelihoodKind, ModelSpec, Study};
use crate::evidence::{ProposalShape, RjOptions};
use crate::jobs::own_noise::{NoisePoint, own_noise_likelihood};
use crate::jobs::prepare::{
    Prepared, default_start, likelihood_at, likelihood_of, reference_point, relbin_options,
    sampled_kind,
};
use crate::likelihood::{Likelihood, RelBinOptions};
use std::borrow::Cow;

/// One exact likelihood per parent model in use (a model some `[[select.model]]` is a
/// sub-model of), by ascending model index; the prepared one is reused.
pub(super) struct Parents<'a> {
    exacts: Vec<(usize, Cow<'a, Likelihood>)>,
    /// Per `[[select.model]]`, in order: its own exact likelihood when the residual noise
    /// depends on its free parameters (noise at its own MAP, [`crate::jobs::own_noise`]).
    own: Vec<Option<(Likelihood, NoisePoint)>>,
}

impl<'a> Parents<'a> {
    /// Builds the exact likelihood of every parent model on the prepared data.
    pub fn new(study: &Study, prep: &'a Prepared) -> Result<Parents<'a>, SelectError> {
        let mut parents: Vec<usize> = study.select_models.iter().map(|m| m.spec.model).collect();
        parents.sort_unstable();
        parents.dedup();
        let mut exacts: Vec<(usize, Cow<Likelihood>)> = Vec::new();
        for &mi in &parents {
            let lik = if mi == prep.model {
                Cow::Borrowed(&prep.likelihood)
            } else {
                Cow::Owned(likelihood_of(study, mi, &prep.dataset).map_err(|e| {
                    SelectError::Model {
                        model: study.models.defs[mi].name().to_string(),
                        msg: e.to_string(),
                    }
                })?)
            };
            exacts.push((mi, lik));
        }
        let mut own = Vec::with_capacity(study.select_models.len());
        for m in &study.select_models {
            own.push(
                own_noise_likelihood(
                    study,
                    &m.spec,
                    &default_start(study, &m.spec),
                    reference_point(study, m.spec.model),
                    &|at: &[f64]| likelihood_at(study, m.spec.model, &prep.dataset, at),
                )
                .map_err(|e| SelectError::Model {
                    model: m.name.clone(),
                    msg: e.to_string(),
                })?,
            );
        }
        Ok(Parents { exacts, own })
    }

    /// The exact likelihood `[[select.model]]` number `k` (on parent `mi`) runs on: its own
    /// when its noise depends on its parameters, else its parent's.
    pub fn for_model(&self, k: usize, mi: usize) -> &Likelihood {
        match &self.own[k] {
            Some((l, _)) => l,
            None => self.of(mi),
        }
    }

    /// Where `[[select.model]]` number `k`'s noise was evaluated, when it depends on θ.
    pub fn noise_point(&self, k: usize) -> Option<&NoisePoint> {
        self.own[k].as_ref().map(|(_, p)| p)
    }

    /// The parent models' indices, ascending.
    pub fn indices(&self) -> impl Iterator<Item = usize> + '_ {
        self.exacts.iter().map(|(i, _)| *i)
    }

    /// The exact likelihood of parent model `mi`.
    pub fn of(&self, mi: usize) -> &Likelihood {
        &self.exacts.iter().find(|(i, _)| *i == mi).expect("built").1
    }
}

/// The `[select]` settings of the per-model stages.
#[derive(Debug, Clone, Copy)]
pub(super) struct StageSettings {
    /// In-model Metropolis–Hastings chains.
    pub chains: usize,
    /// Iterations per in-model chain, burn-in included.
    pub iterations: usize,
    /// Burn-in iterations of the in-model chains.
    pub burn_in: usize,
    /// The rule the in-model chains run on by, past `iterations` (`[select] until`).
    pub until: Option<crate::config::UntilOptions>,
    /// The most iterations an in-model chain runs ([`crate::config::SelectOptions::most_iterations`]).
    pub most_iterations: usize,
    /// Where the reversible-jump proposal comes from.
    pub jump_proposal: JumpProposal,
    /// How much of the run the tempering cross-checks get; the ladder below is already
    /// the one they get.
    pub cross_checks: CrossChecks,
    /// Rungs of the tempering ladder (0: no tempering).
    pub pt_temperatures: usize,
    /// Tempering sweeps, burn-in included.
    pub pt_iterations: usize,
    /// Tempering burn-in sweeps.
    pub pt_burn_in: usize,
}

/// One competing model, prepared for its stages.
pub(super) struct ModelPlan<'a> {
    /// The `[[select.model]]` name.
    pub name: String,
    pub prior_probability: f64,
    /// The sub-model: parent model, free parameters, fixed values.
    pub spec: ModelSpec,
    /// The parent model's exact likelihood (its model, parameter names and prior).
    pub exact: &'a Likelihood,
    /// The parent's parameter names.
    pub param_names: Vec<String>,
    /// The free parameters' names.
    pub free_names: Vec<String>,
    /// Start of the MAP search (full parameter vector).
    pub start: Vec<f64>,
    /// Quasi-random starts of the MAP search besides `start` (`[fit] map_starts`).
    pub map_starts: usize,
    /// The likelihood the samplers run on, and why it is not the configured one.
    pub sampled_kind: LikelihoodKind,
    pub sampled_why: Option<String>,
    /// Relative-binning accuracy settings.
    pub relbin: RelBinOptions,
    /// Where the residual noise was evaluated, when it depends on this model's parameters
    /// (`exact` is then this model's own).
    pub noise_point: Option<NoisePoint>,
    /// Seed of this model's samplers.
    pub seed: u64,
    /// Schwarz's `n` (real data points).
    pub n_sbic: f64,
    pub stages: StageSettings,
}

/// A select run, prepared.
pub(super) struct SelectPlan<'a> {
    /// Every competing model, in `[[select.model]]` order.
    pub models: Vec<ModelPlan<'a>>,
    /// The reversible-jump run over all of them.
    pub rj: RjOptions,
    /// Schwarz's `n`.
    pub n_sbic: f64,
    /// The reference error to reach, and the budget (`[select] target_error`).
    pub target: Option<RjTarget>,
}

/// A reversible jump run until the reference rows' error reaches `error`, in rounds of at most
/// `budget` iterations.
#[derive(Debug, Clone, Copy)]
pub(super) struct RjTarget {
    pub error: f64,
    pub budget: usize,
}

impl<'a> SelectPlan<'a> {
    /// The plan of `study`'s `[[select.model]]` list on the parents' likelihoods.
    pub fn new(study: &Study, parents: &'a Parents<'_>) -> SelectPlan<'a> {
        let sel = &study.select;
        let first = parents.of(study.select_models[0].spec.model);
        let seed = sel.seed.unwrap_or(study.seed.wrapping_add(2));
        let n_sbic = sel.schwarz_n.unwrap_or(first.n_real_data() as f64);
        let (pt_temperatures, pt_iterations, pt_burn_in) = sel.tempering_ladder();
        let stages = StageSettings {
            chains: sel.chains,
            iterations: sel.iterations,
            burn_in: sel.burn_in,
            until: sel.until,
            most_iterations: sel.most_iterations(),
            jump_proposal: sel.jump_proposal,
            cross_checks: sel.cross_checks,
            pt_temperatures,
            pt_iterations,
            pt_burn_in,
        };
        let models = study
            .select_models
            .iter()
            .enumerate()
            .map(|(k, m)| {
                let exact = parents.for_model(k, m.spec.model);
                let param_names = exact.model().param_names().to_vec();
                let free_names = m
                    .spec
                    .free
                    .iter()
                    .map(|&i| param_names[i].clone())
                    .collect();
                let (sampled_kind, sampled_why) = sampled_kind(study, exact);
                ModelPlan {
                    name: m.name.clone(),
                    prior_probability: m.prior_probability,
                    spec: m.spec.clone(),
                    exact,
                    param_names,
                    free_names,
                    // a noise point is the model's MAP already: its search starts there
                    start: parents
                        .noise_point(k)
                        .map_or_else(|| default_start(study, &m.spec), |p| p.theta.clone()),
                    map_starts: study.fit.map_starts,
                    sampled_kind,
                    sampled_why,
                    relbin: relbin_options(study),
                    noise_point: parents.noise_point(k).cloned(),
                    seed: seed.wrapping_add(k as u64),
                    n_sbic,
                    stages,
                }
            })
            .collect();
        let rj = RjOptions {
            n_iter: sel.rj_iterations,
            burn_in: sel.rj_burn_in,
            seed,
            prior_model_probs: Some(
                study
                    .select_models
                    .iter()
                    .map(|m| m.prior_probability)
                    .collect(),
            ),
            proposal: if sel.student_t > 0.0 {
                ProposalShape::StudentT { nu: sel.student_t }
            } else {
                ProposalShape::Gaussian
            },
            jump_scale: sel.jump_scale,
            n_chains: sel.rj_chains,
            defensive: sel.defensive,
            keep_draws: true,
            ..Default::default()
        };
        let target = sel.target_error.map(|error| RjTarget {
            error,
            budget: sel.rj_budget(),
        });
        SelectPlan {
            models,
            rj,
            n_sbic,
            target,
        }
    }
}
