//! The errors of the signal-processing module, and the input checks that raise them.

/// Errors of the signal-processing module. Each names the offending input and how to fix it.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SignalError {
    /// A transform length of zero was requested.
    #[error("{what}: length must be at least {min}, got {got}")]
    TooShort {
        /// Which length (e.g. "FFT length", "segment_len").
        what: &'static str,
        /// Smallest accepted value.
        min: usize,
        /// The value given.
        got: usize,
    },
    /// A buffer handed to a planned transform has the wrong length.
    #[error("{what}: buffer has length {got}, expected {expected} for this plan")]
    BufferLength {
        /// Which buffer (e.g. "forward input").
        what: &'static str,
        /// Length required by the plan.
        expected: usize,
        /// Length given.
        got: usize,
    },
    /// Two series that must have the same length do not.
    #[error("series lengths differ: {first} has {len_first} samples, {second} has {len_second}")]
    LengthMismatch {
        /// Name of the first series.
        first: &'static str,
        /// Its length.
        len_first: usize,
        /// Name of the second series.
        second: &'static str,
        /// Its length.
        len_second: usize,
    },
    /// A sample or spectrum value is NaN or infinite.
    #[error("{what}[{index}] is not finite ({value}); remove NaN/inf samples before analysis")]
    NonFinite {
        /// Which array.
        what: &'static str,
        /// Index of the first bad value.
        index: usize,
        /// The value.
        value: f64,
    },
    /// A scalar parameter is outside its valid range.
    #[error("{name} = {value} is invalid: {requirement}")]
    InvalidParameter {
        /// Parameter name (e.g. "fs", "overlap").
        name: &'static str,
        /// The value given.
        value: f64,
        /// What it must satisfy.
        requirement: &'static str,
    },
    /// The Welch segment is longer than the data.
    #[error(
        "segment_len = {segment_len} exceeds the series length {len}; use a shorter segment or more data"
    )]
    SegmentTooLong {
        /// Requested segment length.
        segment_len: usize,
        /// Series length.
        len: usize,
    },
    /// A window name could not be parsed.
    #[error("unknown window {name:?}; expected one of \"rectangular\", \"hann\", \"bh92\"")]
    UnknownWindow {
        /// The name given.
        name: String,
    },
    /// A prescribed cross-spectral matrix is not a valid one-sided CSD at some frequency.
    #[error("CSD at f = {freq} Hz is invalid: {reason}")]
    InvalidCsd {
        /// Frequency (Hz) of the offending bin.
        freq: f64,
        /// What is wrong (non-finite, not Hermitian, not positive semi-definite).
        reason: String,
    },
    /// An interpolation grid is not strictly increasing.
    #[error(
        "interpolation grid: frequencies must be strictly increasing, but f[{index}] = {value}"
    )]
    UnsortedGrid {
        /// Index of the first out-of-order frequency.
        index: usize,
        /// Its value.
        value: f64,
    },
    /// An interpolation target lies outside the tabulated range (no extrapolation is done).
    #[error(
        "cannot interpolate at f = {freq} Hz: outside the usable range [{min}, {max}] Hz \
         (longer Welch segments lower the bottom end)"
    )]
    OutOfRange {
        /// The requested frequency.
        freq: f64,
        /// Lowest usable frequency.
        min: f64,
        /// Highest usable frequency.
        max: f64,
    },
    /// A PSD value that must be non-negative is negative.
    #[error("{what} at f = {freq} Hz is negative ({value}); a PSD must be >= 0")]
    NegativePsd {
        /// Which spectrum.
        what: &'static str,
        /// Frequency of the bad value.
        freq: f64,
        /// The value.
        value: f64,
    },
}

/// Checks that every value is finite; names the array and the first bad index otherwise.
pub(crate) fn check_finite(what: &'static str, x: &[f64]) -> Result<(), SignalError> {
    match x.iter().position(|v| !v.is_finite()) {
        Some(index) => Err(SignalError::NonFinite {
            what,
            index,
            value: x[index],
        }),
        None => Ok(()),
    }
}

/// Checks that a sampling frequency is finite and positive.
pub(crate) fn check_fs(fs: f64) -> Result<(), SignalError> {
    if fs.is_finite() && fs > 0.0 {
        Ok(())
    } else {
        Err(SignalError::InvalidParameter {
            name: "fs",
            value: fs,
            requirement: "the sampling frequency must be finite and > 0 Hz",
        })
    }
}
