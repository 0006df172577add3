//! [`ConfigError`]: a configuration problem, naming the file and the field.

/// A configuration problem, naming the file and the field.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// The study file cannot be read. The I/O error is part of the message, not a source
    /// (a chain would print it twice).
    #[error("{file}: cannot read the file: {error}")]
    Io { file: String, error: std::io::Error },
    #[error("{file}: {msg}")]
    Parse { file: String, msg: String },
    #[error("{file}: `{field}`: {msg}")]
    Invalid {
        file: String,
        field: String,
        msg: String,
    },
}
