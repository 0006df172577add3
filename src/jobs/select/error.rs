//! The errors of a model-selection run.

/// Errors of a model-selection run.
#[derive(Debug, thiserror::Error)]
pub enum SelectError {
    #[error("{0}")]
    Config(String),
    #[error("model `{model}`: {msg}")]
    Model { model: String, msg: String },
    #[error(transparent)]
    Report(#[from] crate::report::ReportError),
    #[error("{0}")]
    Io(String),
    /// Stopped on request ([`crate::jobs::Work::request_stop`]); the checkpoint and the
    /// stage file keep the work done.
    #[error(transparent)]
    Interrupted(#[from] crate::jobs::progress::Interrupted),
}
