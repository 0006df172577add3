//! One task's result on disk: the numbers of a model selection at one (point, realisation),
//! written atomically when the task ends, and read back on a rerun instead of recomputing.

use crate::data::checkpoint;
use crate::jobs::select::{EstimateKind, SelectSummary};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// FNV-1a, 64 bits: a stable hash (unlike `std`'s) for file names and study identities.
pub fn fnv1a(bytes: &[u8]) -> u64 {
    crate::data::Fnv1a::of(bytes)
}

/// What identifies a task: the base study (hash of the file without `output` and `[sweep]`),
/// the swept keys and values, the realisation and its seed. A stored task is reused only when
/// all of these match.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TaskId {
    pub study: String,
    pub keys: Vec<String>,
    pub values: Vec<f64>,
    pub realisation: usize,
    pub seed: u64,
}

impl TaskId {
    /// `snr=5 r=0`: the grid values and the realisation, for messages.
    pub fn label(&self) -> String {
        let mut parts: Vec<String> = self
            .keys
            .iter()
            .zip(&self.values)
            .map(|(k, v)| format!("{k}={}", crate::numfmt::fmt_short(*v)))
            .collect();
        parts.push(format!("r={}", self.realisation));
        parts.join(" ")
    }

    /// `tasks/<hash>.cbor` under the sweep's directory (a checkpoint of kind
    /// [`TASK_KIND`]; the `.json` files of earlier versions are not reused).
    pub fn path(&self, dir: &Path) -> PathBuf {
        let id = serde_json::to_vec(self).expect("a TaskId serialises");
        dir.join("tasks").join(format!("{:016x}.cbor", fnv1a(&id)))
    }
}

/// One estimator's row, as the sweep keeps it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Estimate {
    pub method: String,
    pub kind: EstimateKind,
    pub ln_b: Option<f64>,
    pub std_err: Option<f64>,
    pub agrees: Option<bool>,
}

/// One pair's rows and verdict.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Pair {
    pub x: String,
    pub y: String,
    pub reference: String,
    pub preferred: String,
    pub kass_raftery: String,
    pub all_agree: bool,
    pub systematic_agree: Option<bool>,
    pub estimates: Vec<Estimate>,
}

impl Pair {
    /// The reference row's ln B_XY.
    pub fn reference_ln_b(&self) -> Option<f64> {
        self.estimates
            .iter()
            .find(|e| e.method == self.reference)
            .and_then(|e| e.ln_b)
    }
}

/// A model selection's numbers.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Outcome {
    pub models: Vec<String>,
    pub pairs: Vec<Pair>,
    pub posterior_model_probabilities: Option<Vec<f64>>,
    /// ρ_opt under the analysis's noise estimate; absent (null) for models without noiseless
    /// input channels (the acceleration domain).
    pub rho_opt: Option<f64>,
    pub rho_opt_simulated: Option<f64>,
    pub rj_visits: Option<Vec<u64>>,
    pub warnings: Vec<String>,
}

impl Outcome {
    /// The selection's numbers without the chains.
    pub fn from_summary(s: &SelectSummary) -> Self {
        Self {
            models: s.models.iter().map(|m| m.name.clone()).collect(),
            pairs: s
                .pairs
                .iter()
                .map(|p| Pair {
                    x: p.x.clone(),
                    y: p.y.clone(),
                    reference: p.reference.clone(),
                    preferred: p.preferred.clone(),
                    kass_raftery: p.kass_raftery.clone(),
                    all_agree: p.all_agree,
                    systematic_agree: p.systematic_agree,
                    estimates: p
                        .estimates
                        .iter()
                        .map(|e| Estimate {
                            method: e.method.clone(),
                            kind: e.kind,
                            ln_b: e.ln_b.filter(|v| v.is_finite()),
                            std_err: e.std_err.filter(|v| v.is_finite()),
                            agrees: e.agrees,
                        })
                        .collect(),
                })
                .collect(),
            posterior_model_probabilities: s.posterior_model_probabilities.clone(),
            rho_opt: s.rho_opt.is_finite().then_some(s.rho_opt),
            rho_opt_simulated: s.rho_opt_simulated,
            rj_visits: s.rj.as_ref().map(|r| r.visits.clone()),
            warnings: s.warnings.clone(),
        }
    }

    /// The model the selection prefers (highest posterior probability), by index.
    pub fn pick(&self) -> Option<usize> {
        let p = self.posterior_model_probabilities.as_ref()?;
        let mut best: Option<usize> = None;
        for (i, v) in p.iter().enumerate() {
            if v.is_finite() && best.is_none_or(|b| *v > p[b]) {
                best = Some(i);
            }
        }
        best
    }
}

/// The checkpoint kind of a sweep task's file.
pub const TASK_KIND: &str = "sweep-task";
/// Its version (1: the first in the common checkpoint format; the JSON files before it are
/// recomputed).
pub const TASK_VERSION: u32 = 1;

/// A finished task: its identity and its numbers, or why it has none (a study that cannot be
/// simulated at that point, a model with no finite likelihood, …).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TaskRecord {
    pub id: TaskId,
    pub outcome: Option<Outcome>,
    pub error: Option<String>,
}

impl TaskRecord {
    /// The stored record of `id` in `dir`, if one exists and is for exactly this task. A file
    /// that cannot be read or parsed (a foreign file, a different study) is not reused.
    pub fn load(dir: &Path, id: &TaskId) -> Option<TaskRecord> {
        let r: TaskRecord = checkpoint::read(&id.path(dir), TASK_KIND, TASK_VERSION, None).ok()?;
        (r.id == *id).then_some(r)
    }

    /// The bytes written to the task's file (and passed between workers): a checkpoint
    /// ([`crate::data::checkpoint`]), so every number, NaN included, comes back bit for bit.
    pub fn to_bytes(&self) -> Vec<u8> {
        checkpoint::to_bytes(TASK_KIND, TASK_VERSION, "", self)
    }

    /// The record in bytes from [`TaskRecord::to_bytes`].
    pub fn from_bytes(bytes: &[u8]) -> Result<TaskRecord, checkpoint::CheckpointError> {
        checkpoint::from_bytes(bytes, TASK_KIND, TASK_VERSION, None)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn id(r: usize) -> TaskId {
        TaskId {
            study: "abc".into(),
            keys: vec!["simulation.target_snr".into()],
            values: vec![0.1 + 0.2],
            realisation: r,
            seed: 99,
        }
    }

    #[test]
    fn records_round_trip_exactly_and_only_match_their_own_id() {
        let dir = tempfile::tempdir().unwrap();
        let rec = TaskRecord {
            id: id(0),
            outcome: Some(Outcome {
                models: vec!["X".into(), "Y".into()],
                pairs: vec![Pair {
                    x: "X".into(),
                    y: "Y".into(),
                    reference: "RJMCMC bridge".into(),
                    preferred: "Y".into(),
                    kass_raftery: "positive".into(),
                    all_agree: true,
                    systematic_agree: None,
                    estimates: vec![Estimate {
                        method: "RJMCMC bridge".into(),
                        kind: EstimateKind::Statistical,
                        ln_b: Some(-1.0 / 3.0),
                        std_err: Some(0.01),
                        agrees: None,
                    }],
                }],
                posterior_model_probabilities: Some(vec![0.4, 0.6]),
                rho_opt: Some(28.000000000000004),
                rho_opt_simulated: None,
                rj_visits: Some(vec![4, 6]),
                warnings: vec![],
            }),
            error: None,
        };
        let p = rec.id.path(dir.path());
        crate::atomic::write_bytes(&p, &rec.to_bytes()).unwrap();
        let back = TaskRecord::load(dir.path(), &id(0)).unwrap();
        assert_eq!(back, rec);
        assert_eq!(back.outcome.as_ref().unwrap().pick(), Some(1));
        assert_eq!(
            back.outcome.unwrap().pairs[0].reference_ln_b(),
            Some(-1.0 / 3.0)
        );
        assert!(TaskRecord::load(dir.path(), &id(1)).is_none());
        // a model without noiseless inputs has no ρ_opt: it round-trips as null
        let mut none = rec.clone();
        none.outcome.as_mut().unwrap().rho_opt = None;
        crate::atomic::write_bytes(&p, &none.to_bytes()).unwrap();
        assert_eq!(TaskRecord::load(dir.path(), &id(0)).unwrap(), none);
        crate::atomic::write_bytes(&p, &rec.to_bytes()).unwrap();
        // a file at the right name holding another task is not reused
        std::fs::copy(&p, id(1).path(dir.path())).unwrap();
        assert!(TaskRecord::load(dir.path(), &id(1)).is_none());
        std::fs::write(&p, b"{ truncated").unwrap();
        assert!(TaskRecord::load(dir.path(), &id(0)).is_none());
    }

    #[test]
    fn fnv_is_the_published_function() {
        // FNV-1a 64 test vectors (Fowler/Noll/Vo)
        assert_eq!(fnv1a(b""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv1a(b"a"), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(fnv1a(b"foobar"), 0x8594_4171_f739_67e8);
    }
}
