//! [`DataError`]: what went wrong reading or writing a data file, naming the file.

use std::path::Path;

/// Problems reading or writing data files; every message names the file.
#[derive(Debug, thiserror::Error)]
pub enum DataError {
    /// The I/O error is in the message and not a `source` as well: a chain printed with
    /// `{:#}` said its cause twice (`d.csv: a directory, …: a directory, …`).
    #[error("{file}: {error}")]
    Io { file: String, error: std::io::Error },
    #[error("{file}: {msg}")]
    Format { file: String, msg: String },
    /// The dataset's experiments are not the study's ([`Dataset::check_names`](crate::data::dataset::Dataset::check_names)); the caller
    /// knows which files are involved and says so.
    #[error("{msg}")]
    Names { msg: String },
    /// A dataset's sidecar and arrays tell different stories.
    #[error("{json} and {npz} disagree: {msg}")]
    Mismatch {
        json: String,
        npz: String,
        msg: String,
    },
}

pub(super) fn io_err(file: &Path) -> impl FnOnce(std::io::Error) -> DataError + '_ {
    move |error| DataError::Io {
        file: file.display().to_string(),
        error,
    }
}

pub(super) fn fmt_err(file: &Path, msg: impl Into<String>) -> DataError {
    DataError::Format {
        file: file.display().to_string(),
        msg: msg.into(),
    }
}
