//! [`ConfigError`]: a configuration problem, naming the file and the field.

/// A configuration problem, naming the file and the field.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    #[error("{file}: cannot read the file: {source}")]
    Io {
        file: String,
        #[source]
        source: std::io::Error,
    },
    #[error("{file}: {msg}")]
    Parse { file: String, msg: String },
    #[error("{file}: `{field}`: {msg}")]
    Invalid {
        file: String,
        field: String,
        msg: String,
    },
}
