//! Numbers as people read them: significant digits, `value ± error`, round-trip decimals,
//! Bayes factors as powers of ten, and the Kass–Raftery scale. Plain functions of numbers,
//! below every layer that reports one (the likelihood's diagnostics, tables, plots);
//! [`crate::report`] re-exports them.

pub mod format;
mod numbers;

pub use format::{fmt_pm, fmt_sig, kass_raftery, kass_raftery_named};
pub use numbers::{fmt_bayes_factor, fmt_fixed, fmt_roundtrip, fmt_short, fmt_short_sig};
