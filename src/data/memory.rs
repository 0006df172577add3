//! The memory budget's size and where it comes from: `OCCAM_MEMORY_BUDGET`, else
//! [`DEFAULT_BUDGET`]. The study loader sizes a whole study against it
//! (`crate::config::budget`); the file readers check each array against it before allocating.

use super::error::{DataError, fmt_err};

/// One gibibyte.
pub const GIB: f64 = 1024.0 * 1024.0 * 1024.0;

/// The budget when `OCCAM_MEMORY_BUDGET` is not set: 8 GiB, a third of a 24 GiB workstation,
/// so that a study that passes leaves room for the operating system and a second job.
pub const DEFAULT_BUDGET: f64 = 8.0 * GIB;

/// The environment variable that overrides [`DEFAULT_BUDGET`].
pub const BUDGET_ENV: &str = "OCCAM_MEMORY_BUDGET";

/// The memory budget in bytes: `OCCAM_MEMORY_BUDGET` if set, else [`DEFAULT_BUDGET`].
pub fn budget_from_env() -> Result<f64, String> {
    match std::env::var(BUDGET_ENV) {
        Ok(s) => parse_size(&s).map_err(|e| format!("{BUDGET_ENV} = \"{s}\": {e}")),
        Err(std::env::VarError::NotPresent) => Ok(DEFAULT_BUDGET),
        Err(std::env::VarError::NotUnicode(_)) => Err(format!(
            "{BUDGET_ENV} is not valid Unicode; write a size such as \"16GiB\""
        )),
    }
}

/// Parses a size: a number with an optional unit. `KiB`, `MiB`, `GiB`, `TiB` and the short
/// `K`, `M`, `G`, `T` are powers of 1024; `kB`, `MB`, `GB`, `TB` powers of 1000; `B` or no
/// unit is bytes. Case is ignored, spaces between number and unit allowed.
///
/// ```
/// use occam::data::memory::parse_size;
/// assert_eq!(parse_size("16GiB").unwrap(), 16.0 * 1024f64.powi(3));
/// assert_eq!(parse_size("500 MB").unwrap(), 5e8);
/// assert_eq!(parse_size("2e9").unwrap(), 2e9);
/// assert!(parse_size("lots").is_err());
/// ```
pub fn parse_size(s: &str) -> Result<f64, String> {
    let t = s.trim();
    let split = t
        .find(|c: char| c.is_ascii_alphabetic() && c != 'e' && c != 'E')
        .unwrap_or(t.len());
    let (num, unit) = t.split_at(split);
    let v: f64 = num.trim().parse().map_err(|_| {
        format!("`{t}` is not a size; write a number with an optional unit, e.g. \"16GiB\", \"500MB\" or \"2e9\"")
    })?;
    let k = 1024f64;
    let mult = match unit.trim().to_ascii_lowercase().as_str() {
        "" | "b" => 1.0,
        "k" | "kib" => k,
        "m" | "mib" => k * k,
        "g" | "gib" => k * k * k,
        "t" | "tib" => k * k * k * k,
        "kb" => 1e3,
        "mb" => 1e6,
        "gb" => 1e9,
        "tb" => 1e12,
        u => {
            return Err(format!(
                "unknown unit `{u}`; use B, KiB, MiB, GiB, TiB (powers of 1024) or kB, MB, GB, TB"
            ));
        }
    };
    let bytes = v * mult;
    if !(bytes.is_finite() && bytes > 0.0) {
        return Err(format!("must be a finite size > 0 (got `{t}`)"));
    }
    Ok(bytes)
}

/// The memory budget for data read from files, in bytes: the one budget of the study loader
/// ([`budget_from_env`]: `OCCAM_MEMORY_BUDGET`, else 8 GiB). Readers
/// compare the sizes a file implies with it before allocating anything, so that a damaged or
/// enormous file is an error naming the file rather than an abort. An unreadable value is an
/// error naming the variable (never silently the default).
pub fn memory_budget() -> Result<u64, String> {
    // saturating: a budget above 2⁶⁴ bytes is no limit
    budget_from_env().map(|b| b as u64)
}

/// [`memory_budget`], or the default budget when the variable cannot be read (for callers
/// that have already reported that error through `check_budget`).
pub fn memory_budget_bytes() -> u64 {
    memory_budget().unwrap_or(DEFAULT_BUDGET as u64)
}

/// Checks that reading `what` of `file`, which needs `bytes` bytes, fits the memory budget.
pub(crate) fn check_budget(
    file: &std::path::Path,
    what: &str,
    bytes: u64,
) -> Result<(), DataError> {
    let budget = memory_budget().map_err(|m| fmt_err(file, m))?;
    if bytes > budget {
        return Err(fmt_err(
            file,
            format!(
                "{what} needs {bytes} bytes, more than the memory budget of {budget} bytes; raise OCCAM_MEMORY_BUDGET if the machine has the memory, or split the data"
            ),
        ));
    }
    Ok(())
}
