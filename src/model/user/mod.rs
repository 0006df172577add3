//! User-defined models, written in the study file (`[[model]]` with `kind = "user"`) and
//! compiled at load time: no recompiling.
//!
//! ```toml
//! [[model]]
//! kind = "user"                       # stripped by the study-file parser
//! name = "cl_user"
//! parameters = ["w1sq", "a_df", "dt1"] # θ order
//! data = ["o1", "i1"]                 # data channels d_c (columns of M), at most 8
//! residual = ["o1"]                   # residual channels r_r (rows of M), 1 or 2
//! [model.constants]                   # named real constants
//! e1 = 0.0046
//! [model.blocks]                      # named complex blocks of s = i2πf
//! cdf = { kind = "rational", num = [0.626, 0.138], den = [0.0317, 1, 0] }
//! t1  = { kind = "delay", tau = "dt1" }
//! [model.define]                      # intermediate complex expressions (any order)
//! h = "a_df*cdf*t1 / (s^2 + w1sq*(1 + e1) + a_df*cdf)"
//! [model.coefficients.o1]             # residual channel -> data channel -> expression
//! o1 = "1"
//! i1 = "-h"
//! ```
//!
//! The residual is `r_r = Σ_c M_rc d_c` with `M_rc` the expression of
//! `coefficients.<r>.<c>` (0 if absent).
//!
//! Blocks (every numeric field is a number or a real expression string of parameters and
//! constants, parsed by `exmex` with exact symbolic derivatives; `pi` is π):
//!
//! | kind           | fields          | response at `s = i2πf`            |
//! |----------------|-----------------|-----------------------------------|
//! | `gain`         | `value`         | `value`                           |
//! | `delay`        | `tau` (s, ≥ 0)  | `e^{−s τ}`                        |
//! | `pole`         | `f` (Hz, > 0)   | `1/(1 + s/(2π f))`                |
//! | `zero`         | `f` (Hz, ≠ 0)   | `1 + s/(2π f)`                    |
//! | `complex_pole` | `f` (> 0), `q` (> 0) | `ω0²/(s² + s ω0/q + ω0²)`, `ω0 = 2πf` |
//! | `s_power`      | `n` (integer literal, `|n| ≤ 16`) | `s^n`            |
//! | `rational`     | `num`, `den`    | polynomials in `s`, descending powers |
//!
//! Complex expressions (defines and coefficients): numbers, `+ − * /`, unary minus,
//! parentheses, `^` with an integer literal exponent, and the names of parameters (real),
//! constants (real), blocks, defines, `s` and `pi` (see [`expr`]).
//!
//! Blocks whose fields are all constant are evaluated once per bin ([`Model::bin_consts`]);
//! blocks and defines that no coefficient uses are validated but never evaluated.

pub mod block;
mod build;
pub mod expr;
pub mod real;
#[cfg(test)]
mod tests;

use super::{Bin, Model};
use block::Block;
use expr::Op;
use num_complex::{Complex, Complex64};
use num_dual::{Dual64, DualNum};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::f64::consts::PI;

/// Most blocks and defines (together) a model may evaluate.
pub const MAX_SLOTS: usize = 256;

/// A real field of a block: a number or an expression string of parameters and constants.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum RealValue {
    Number(f64),
    Expr(String),
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

/// A compiled user-defined model.
#[derive(Debug, Clone)]
pub struct UserModel {
    name: String,
    params: Vec<String>,
    data: Vec<String>,
    res: Vec<String>,
    /// Blocks some coefficient uses; block `k` lives in slot `k`.
    blocks: Vec<(String, Block)>,
    /// Per used block: its index among the per-bin constants, if θ-independent.
    const_of: Vec<Option<usize>>,
    n_consts: usize,
    /// Defines (stored into slots after the blocks) then coefficients (`Out`).
    ops: Vec<Op>,
    n_slots: usize,
}

impl UserModel {
    fn fill<T: DualNum<Primitive = f64> + Copy>(
        &self,
        th: &[T],
        bin: &Bin,
        out: &mut [Complex<T>],
    ) {
        match self.n_slots {
            0..=16 => self.fill_n::<T, 16>(th, bin, out),
            17..=64 => self.fill_n::<T, 64>(th, bin, out),
            _ => self.fill_n::<T, MAX_SLOTS>(th, bin, out),
        }
    }

    #[inline]
    fn fill_n<T: DualNum<Primitive = f64> + Copy, const N: usize>(
        &self,
        th: &[T],
        bin: &Bin,
        out: &mut [Complex<T>],
    ) {
        let zero = Complex::new(T::zero(), T::zero());
        let mut slots = [zero; N];
        for (k, (_, b)) in self.blocks.iter().enumerate() {
            slots[k] = match self.const_of[k] {
                Some(c) => expr::lift(bin.consts[c]),
                None => b.eval(th, bin.f),
            };
        }
        out.fill(zero);
        expr::run(&self.ops, th, 2.0 * PI * bin.f, &mut slots, out);
    }
}

impl Model for UserModel {
    fn name(&self) -> &str {
        &self.name
    }

    fn param_names(&self) -> &[String] {
        &self.params
    }

    fn data_channels(&self) -> &[String] {
        &self.data
    }

    fn residual_channels(&self) -> &[String] {
        &self.res
    }

    fn n_consts(&self) -> usize {
        self.n_consts
    }

    fn bin_consts(&self, f: f64, _fs: f64, out: &mut [Complex64]) {
        for ((_, b), c) in self.blocks.iter().zip(&self.const_of) {
            if let Some(c) = *c {
                out[c] = b.eval::<f64>(&[], f);
            }
        }
    }

    fn coefficients(&self, theta: &[f64], bin: &Bin, out: &mut [Complex64]) {
        self.fill(theta, bin, out);
    }

    fn coefficients_dual(&self, theta: &[Dual64], bin: &Bin, out: &mut [Complex<Dual64>]) {
        self.fill(theta, bin, out);
    }

    /// θ has the right length and finite values, and every θ-dependent block field is
    /// possible (pole frequencies and quality factors > 0, delays ≥ 0, a denominator that is
    /// not identically zero).
    fn check(&self, theta: &[f64]) -> Result<(), String> {
        let m = &self.name;
        if theta.len() != self.params.len() {
            return Err(format!(
                "user model `{m}`: θ has {} values for {} parameters",
                theta.len(),
                self.params.len()
            ));
        }
        if let Some((p, x)) = self.params.iter().zip(theta).find(|(_, x)| !x.is_finite()) {
            return Err(format!(
                "user model `{m}`: parameter `{p}` is {x}, not finite"
            ));
        }
        for (bn, b) in &self.blocks {
            b.check_values(&|v| Some(v.eval::<f64>(theta)))
                .map_err(|(field, msg)| {
                    format!("user model `{m}`: blocks.{bn}.{field} {msg} at this θ")
                })?;
        }
        Ok(())
    }
}
