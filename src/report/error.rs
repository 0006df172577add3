//! [`ReportError`]: what went wrong while writing a report.

use std::path::PathBuf;

/// What went wrong while writing a report.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// The data handed to a plot function cannot be drawn.
    #[error("cannot draw {}: `{field}` {problem}", file.display())]
    InvalidInput {
        /// The figure, as `<dir>/<stem>.{png,svg}`.
        file: PathBuf,
        /// The argument (and index) at fault, e.g. `chains[1][40]`.
        field: String,
        /// What is wrong and how to fix it.
        problem: String,
    },
    /// Creating, writing or renaming a file failed.
    #[error("cannot write {}: {source}", file.display())]
    Io {
        /// The file being written.
        file: PathBuf,
        /// The operating-system error.
        #[source]
        source: std::io::Error,
    },
    /// The plotting library failed while rendering.
    #[error("rendering {} failed: {message}", file.display())]
    Draw {
        /// The file being rendered.
        file: PathBuf,
        /// The plotting library's message.
        message: String,
    },
    /// The font compiled into the binary could not be parsed (a corrupt build).
    #[error(
        "the embedded font assets/DejaVuSans.ttf could not be parsed; rebuild with an intact copy"
    )]
    Font,
    /// A table row has the wrong number of cells.
    #[error(
        "table row {row} has {found} cells but the header has {expected}; give one cell per column"
    )]
    RowWidth {
        /// Index of the offending row (0 = first row after the header).
        row: usize,
        /// Number of header columns.
        expected: usize,
        /// Number of cells given.
        found: usize,
    },
}
