//! The stage in progress: while one of `select`'s samplers runs (a model's in-model chains, its
//! tempering ladder, the reversible jump), its own checkpoint is saved to [`FILE`] beside the
//! run's `checkpoint.cbor` at most every [`EVERY`], so a killed run loses at most that much of
//! the stage. The file names its stage in its identity; once the stage is done and saved into
//! `checkpoint.cbor` the file is removed, and a file of another stage (or another run) is never
//! resumed.

use std::path::PathBuf;
use std::time::Duration;

/// The stage file's name inside the run directory.
pub const FILE: &str = "stage.cbor";
/// How often a stage in progress is saved (wall-clock).
pub const EVERY: Duration = Duration::from_secs(20);

/// The environment variable that sets how often a stage in progress is saved, in seconds.
pub const ENV: &str = "OCCAM_CHECKPOINT_SECONDS";

/// The interval `ENV` asks for (`None` when unset); an error names the variable and the fix
/// when it is not a number of seconds ≥ 0.
pub fn every_from_env() -> anyhow::Result<Option<Duration>> {
    let Ok(v) = std::env::var(ENV) else {
        return Ok(None);
    };
    match v.trim().parse::<f64>() {
        Ok(s) if (0.0..1e9).contains(&s) => Ok(Some(Duration::from_secs_f64(s))),
        _ => anyhow::bail!(
            "{ENV} = `{v}`: expected a number of seconds ≥ 0 (how often `select` saves the stage in progress; 0 saves after every block); unset it for the default of {} s",
            EVERY.as_secs()
        ),
    }
}

/// Where the stage in progress is saved, for the run of one select identity.
#[derive(Debug, Clone)]
pub struct StageFile {
    /// The file.
    pub path: PathBuf,
    /// The select run's identity ([`crate::jobs::prepare::identity`]).
    pub run: String,
    /// How often to save.
    pub every: Duration,
}

impl StageFile {
    /// The identity of `stage` (`chains`, `tempering`, `rj`) of `model` in this run.
    pub fn identity(&self, model: &str, stage: &str) -> String {
        format!("{}/{model}/{stage}", self.run)
    }

    /// Whether the file holds a saved state of checkpoint kind `kind` with this `identity`.
    pub fn holds(&self, kind: &str, identity: &str) -> bool {
        crate::data::checkpoint::head(&self.path).is_ok_and(|(k, id)| k == kind && id == identity)
    }

    /// Removes the file (its stage is saved in the run's checkpoint, or the run starts afresh).
    pub fn clear(&self) {
        // absent is fine: nothing was saved yet
        let _ = std::fs::remove_file(&self.path);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn holds_only_its_own_stage() {
        let dir = tempfile::tempdir().unwrap();
        let f = StageFile {
            path: dir.path().join(FILE),
            run: "abc".into(),
            every: Duration::ZERO,
        };
        let id = f.identity("delay", "tempering");
        assert!(!f.holds("tempering", &id));
        crate::data::checkpoint::write(&f.path, "tempering", 1, &id, &1u8).unwrap();
        assert!(f.holds("tempering", &id));
        assert!(!f.holds("mh", &id));
        assert!(!f.holds("tempering", &f.identity("pole", "tempering")));
        f.clear();
        assert!(!f.path.exists());
        f.clear();
    }
}
