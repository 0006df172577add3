//! The `[[model]]` table of kind `user` as written: [`UserModelDef`] and its blocks.

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// A real field of a block: a number or an expression string of parameters and constants.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum RealValue {
    Number(f64),
    Expr(String),
}

/// The limits physics sets on one parameter, as written in a model's `physical_limits`
/// table (`physical_limits = { bc = { lo = 0.0 } }`: a damping cannot be negative). A MAP on a
/// prior bound at such a limit is a fact the run notes, not a misplaced box it warns about.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct LimitDef {
    /// The lowest value physics allows.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lo: Option<f64>,
    /// The highest value physics allows.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hi: Option<f64>,
}

/// One named block of `[model.blocks]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum BlockDef {
    /// `N(s)/D(s)`, coefficients in descending powers of `s`.
    Rational {
        num: Vec<RealValue>,
        den: Vec<RealValue>,
    },
    /// A real gain.
    Gain { value: RealValue },
    /// `e^{−s τ}`.
    Delay { tau: RealValue },
    /// `1/(1 + s/(2π f))`.
    Pole { f: RealValue },
    /// `1 + s/(2π f)`.
    Zero { f: RealValue },
    /// `ω0²/(s² + s ω0/q + ω0²)`, `ω0 = 2π f`.
    ComplexPole { f: RealValue, q: RealValue },
    /// `s^n`.
    SPower { n: i32 },
}

/// A `[[model]]` table of kind `user` (without the `kind` key).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct UserModelDef {
    pub name: String,
    /// Parameter names, in θ order.
    pub parameters: Vec<String>,
    /// SI unit of each parameter, by name (`unit = { k = "s⁻²", tau = "s" }`), for tables and
    /// plot axes; a parameter left out is dimensionless or of unknown unit.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub unit: BTreeMap<String, String>,
    /// Limits physics sets on parameters, by name (`physical_limits = { bc = { lo = 0.0 } }`):
    /// a MAP on a prior bound there is noted, not warned about.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub physical_limits: BTreeMap<String, LimitDef>,
    /// Data channels (columns of `M`).
    pub data: Vec<String>,
    /// Residual channels (rows of `M`).
    pub residual: Vec<String>,
    /// Named real constants.
    #[serde(default)]
    pub constants: BTreeMap<String, f64>,
    /// Named complex blocks.
    #[serde(default)]
    pub blocks: BTreeMap<String, BlockDef>,
    /// Named intermediate complex expressions (evaluated in dependency order).
    #[serde(default)]
    pub define: BTreeMap<String, String>,
    /// Residual channel → data channel → complex expression; missing entries are 0.
    pub coefficients: BTreeMap<String, BTreeMap<String, String>>,
}
