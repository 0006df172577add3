//! The `[[model]]` tables of kinds `state_space` and `transfer_matrix` as written.

use crate::model::user::{BlockDef, LimitDef, RealValue};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Whether the state equation is a differential or a difference equation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum TimeDomain {
    /// `ẋ = A x + B u`: the transfer matrix at `s = i2πf`.
    #[default]
    Continuous,
    /// `x[k+1] = A x[k] + B u[k]` at the data's sample rate: the transfer matrix at
    /// `z = e^{i2πf/fs}`.
    Discrete,
}

/// A matrix as written: rows of numbers or real expressions.
pub type MatrixDef = Vec<Vec<RealValue>>;

/// A `[[model]]` table of kind `state_space` (without the `kind` key).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StateSpaceDef {
    /// The model's name.
    pub name: String,
    /// Parameter names, in θ order.
    pub parameters: Vec<String>,
    /// SI unit of each parameter, by name (`unit = { k = "s⁻²", tau = "s" }`), for tables and
    /// plot axes; a parameter left out is dimensionless or of unknown unit.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub unit: BTreeMap<String, String>,
    /// Limits physics sets on parameters, by name (`physical_limits = { bc = { lo = 0.0 } }`):
    /// a MAP on a prior bound there is noted, not warned about. A parameter that is itself a
    /// channel's delay (`delay = { i1 = "dt1" }`) has the lower limit 0 without being named.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub physical_limits: BTreeMap<String, LimitDef>,
    /// Data channels of the known inputs `u` (the injections).
    pub inputs: Vec<String>,
    /// Data channels of the read-outs `y`; they are also the residual channels.
    pub outputs: Vec<String>,
    /// Names of the states, for messages (default `x0, x1, …`; the size comes from `a`).
    #[serde(default)]
    pub states: Option<Vec<String>>,
    /// `continuous` (default) or `discrete`.
    #[serde(default)]
    pub time: TimeDomain,
    /// Named real constants the entries may use.
    #[serde(default)]
    pub constants: BTreeMap<String, f64>,
    /// State matrix, states × states.
    pub a: MatrixDef,
    /// Input matrix, states × inputs.
    pub b: MatrixDef,
    /// Output matrix, outputs × states.
    pub c: MatrixDef,
    /// Feed-through, outputs × inputs (default zero).
    #[serde(default)]
    pub d: Option<MatrixDef>,
    /// Pure delays (s, ≥ 0) of input or output channels, by channel name: `u(t − τ)` enters
    /// the system, `y(t − τ)` is read.
    #[serde(default)]
    pub delay: BTreeMap<String, RealValue>,
    /// Noise-input matrix, states × noise inputs (optional).
    #[serde(default)]
    pub g: Option<MatrixDef>,
    /// Noise feed-through to the outputs, outputs × noise inputs (default zero).
    #[serde(default)]
    pub h: Option<MatrixDef>,
    /// One-sided PSD of each (white, independent) noise input.
    #[serde(default)]
    pub noise: Option<Vec<RealValue>>,
}

/// A `[[model]]` table of kind `transfer_matrix` (without the `kind` key): `y = H(s) u`
/// written entry by entry as complex expressions, with the blocks, defines and constants of a
/// user-defined model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TransferMatrixDef {
    /// The model's name.
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
    /// Data channels of the known inputs.
    pub inputs: Vec<String>,
    /// Data channels of the read-outs (also the residual channels).
    pub outputs: Vec<String>,
    /// Named real constants.
    #[serde(default)]
    pub constants: BTreeMap<String, f64>,
    /// Named complex blocks.
    #[serde(default)]
    pub blocks: BTreeMap<String, BlockDef>,
    /// Named intermediate complex expressions.
    #[serde(default)]
    pub define: BTreeMap<String, String>,
    /// Output → input → complex expression of `H`; missing entries are 0.
    pub h: BTreeMap<String, BTreeMap<String, String>>,
}
