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
}
