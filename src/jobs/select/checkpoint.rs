//! Checkpoints of `occam select`: every finished stage — one model's MAP, chains, tempering and
//! Laplace estimates, then the reversible-jump run — is saved as it ends, so a killed run
//! resumes at the first unfinished stage. Each stage is deterministic given its seed and the
//! stages before it, so a resumed run ends with the numbers of an uninterrupted one, bit for bit.
//!
//! The file is a checkpoint of the common format ([`crate::data::checkpoint`]: CBOR, every
//! `f64` bit kept). It carries an identity — a hash of the resolved study (without its output
//! directory) and of the data — and a checkpoint of another study or other data is refused.

use super::error::SelectError;
use super::model::{ModelRun, Sampled, sampled_around, walk_cov};
use super::outcome::ModelOutcome;
use super::plan::ModelPlan;
use crate::density::LogDensity;
use crate::evidence::RjResult;
use crate::likelihood::fisher_exact;
use crate::linalg::{self, SpdOptions};
use crate::nested::SubModel;
use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The checkpoint's file name inside the run directory.
pub const FILE: &str = "checkpoint.cbor";
/// The checkpoint kind ([`crate::data::checkpoint`]).
const KIND: &str = "select";
/// 3: the common checkpoint format of every job. (2: the in-model chains and the jump
/// chain's draws are saved too; 1: without them. Both are refused: rerun without `--resume`.)
const VERSION: u32 = 3;

/// One model's finished stage: what the reversible-jump run and the tables need from it.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub(super) struct ModelStage {
    pub outcome: ModelOutcome,
    pub base: Vec<f64>,
    pub jump_center: Vec<f64>,
    /// `jump_cov` in nalgebra's column-major order.
    pub jump_cov: Vec<f64>,
    /// Whether the samplers ran on the relative-binned likelihood.
    pub relbin: bool,
    pub tempering_start: Vec<f64>,
    pub seed: u64,
    /// Whether the tempering stage is in `outcome` too.
    pub tempered: bool,
    /// The in-model chains (`None` when they did not run).
    #[serde(default)]
    pub chains: Option<crate::sampler::Chains>,
}

/// The finished reversible-jump stage.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub(super) struct RjStage {
    pub rj: Option<RjResult>,
    pub note: Option<String>,
    /// Iterations per second of the run that computed it.
    pub rate: f64,
    /// The jump chains' draws (kept out of `rj`, whose serialisation skips them).
    #[serde(default)]
    pub draws: Option<crate::evidence::RjDraws>,
    /// The rounds of a run with `[select] target_error`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rounds: Option<Vec<super::target::TargetRound>>,
}

/// The saved stages of one select run.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct SelectCheckpoint {
    /// The run's [`identity`](crate::jobs::prepare::identity) (the envelope's; not repeated in the payload).
    #[serde(skip)]
    identity: String,
    /// How often the stage in progress is saved (not part of the file).
    #[serde(skip)]
    stage_every: Option<std::time::Duration>,
    /// Where the stage in progress is saved, when not `stage.cbor` beside the checkpoint.
    #[serde(skip)]
    stage_path: Option<std::path::PathBuf>,
    pub(super) models: Vec<ModelStage>,
    pub(super) rj: Option<RjStage>,
    /// The finished rounds of a reversible jump with a target error, before the last.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub(super) rj_rounds: Vec<super::target::TargetRound>,
}

impl SelectCheckpoint {
    /// An empty checkpoint of the run with this [`identity`](crate::jobs::prepare::identity).
    pub fn new(identity: String) -> Self {
        Self {
            identity,
            stage_every: None,
            stage_path: None,
            models: Vec::new(),
            rj: None,
            rj_rounds: Vec::new(),
        }
    }

    /// Saves the stage in progress (a sampler's state, in [`super::STAGE_FILE`]) at most this
    /// often rather than every 20 s: a killed run loses at most this much of a stage.
    pub fn save_stage_every(mut self, interval: std::time::Duration) -> Self {
        self.stage_every = Some(interval);
        self
    }

    /// Saves the stage in progress to `path` rather than to `stage.cbor` beside the
    /// checkpoint (for runs that share a directory, such as a sweep's tasks).
    pub fn stage_file_at(mut self, path: impl Into<std::path::PathBuf>) -> Self {
        self.stage_path = Some(path.into());
        self
    }

    pub(super) fn stage_path(&self) -> Option<&Path> {
        self.stage_path.as_deref()
    }

    pub(super) fn stage_every(&self) -> std::time::Duration {
        self.stage_every.unwrap_or(super::stage::EVERY)
    }

    pub(super) fn identity(&self) -> &str {
        &self.identity
    }

    /// Reads the checkpoint at `path` and checks that it belongs to the run `identity`.
    pub fn read(path: &Path, identity: &str) -> Result<Self, SelectError> {
        let mut c: SelectCheckpoint =
            crate::data::checkpoint::read(path, KIND, VERSION, Some(identity))
                .map_err(|e| SelectError::Io(e.to_string()))?;
        c.identity = identity.into();
        Ok(c)
    }

    /// Writes the checkpoint atomically.
    pub fn write(&self, path: &Path) -> Result<(), SelectError> {
        crate::data::checkpoint::write(path, KIND, VERSION, &self.identity, self)
            .map_err(|e| SelectError::Io(e.to_string()))
    }

    /// What is done and what is left, for the "resuming from" line.
    pub fn describe(&self, model_names: &[String]) -> String {
        let done: Vec<String> = self
            .models
            .iter()
            .map(|m| {
                if m.tempered {
                    m.outcome.name.clone()
                } else {
                    format!("{} (but its tempering)", m.outcome.name)
                }
            })
            .collect();
        let left: Vec<&str> = model_names
            .iter()
            .skip(self.models.len())
            .map(String::as_str)
            .collect();
        let rj = if self.rj.is_some() { "done" } else { "to run" };
        format!(
            "models done: {}; to run: {}; reversible jump {rj}",
            if done.is_empty() {
                "none".into()
            } else {
                done.join(", ")
            },
            if left.is_empty() {
                "none".into()
            } else {
                left.join(", ")
            },
        )
    }
}

impl ModelStage {
    /// The saved form of a finished model stage.
    pub(super) fn of(run: &ModelRun, tempered: bool) -> Self {
        Self {
            outcome: run.outcome.clone(),
            base: run.base.clone(),
            jump_center: run.jump_center.clone(),
            jump_cov: run.jump_cov.as_slice().to_vec(),
            relbin: matches!(run.sampled, Sampled::RelBin(_)),
            tempering_start: run.tempering_start.clone(),
            seed: run.seed,
            tempered,
            chains: run.chains.clone(),
        }
    }

    /// The model stage again, its sampled likelihood rebuilt exactly as the run built it.
    pub(super) fn restore(self, m: &ModelPlan<'_>) -> Result<ModelRun, String> {
        let (exact, spec) = (m.exact, &m.spec);
        let d = spec.free.len();
        if self.jump_center.len() != d || self.jump_cov.len() != d * d {
            return Err(format!(
                "the checkpoint's stage of `{}` has {} free parameters, the study {d}",
                self.outcome.name,
                self.jump_center.len()
            ));
        }
        let sub = SubModel::new(exact, spec.free.clone(), self.base.clone())
            .map_err(|e| e.to_string())?;
        // the arithmetic of `run_model`'s proposal covariance (Jacobi-scaled inverse)
        let fisher_cov = linalg::spd_inverse(
            &fisher_exact(exact, &self.base, &spec.free),
            &SpdOptions::lower().jacobi(),
        )
        .ok();
        let cov = walk_cov(fisher_cov.as_ref(), sub.prior());
        let (sampled, _) = sampled_around(m, &self.base, &cov);
        if matches!(sampled, Sampled::RelBin(_)) != self.relbin {
            return Err(format!(
                "the sampled likelihood of `{}` does not rebuild as checkpointed",
                self.outcome.name
            ));
        }
        Ok(ModelRun {
            outcome: self.outcome,
            spec: spec.clone(),
            sampled,
            base: self.base,
            jump_center: self.jump_center,
            jump_cov: DMatrix::from_column_slice(d, d, &self.jump_cov),
            tempering_start: self.tempering_start,
            seed: self.seed,
            chains: self.chains,
        })
    }
}
