//! User-defined models, written in the study file (`[[model]]` with `kind = "user"`) and
//! compiled at load time: no recompiling.
//!
//! ```toml
//! [[model]]
//! kind = "user"                       # stripped by the study-file parser
//! name = "cl_user"
//! parameters = ["w1sq", "a_df", "dt1"] # θ order
//! data = ["o1", "i1"]                 # data channels d_c (columns of M), at most 32
//! residual = ["o1"]                   # residual channels r_r (rows of M), 1 to 16
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
//! Blocks whose fields are all constant are evaluated once per bin ([`Model::bin_consts`](crate::model::Model::bin_consts));
//! blocks and defines that no coefficient uses are validated but never evaluated.

mod batch;
pub mod block;
mod build;
mod compiled;
mod def;
pub mod expr;
mod kernel;
mod plan;
pub mod real;
mod ssa;
#[cfg(test)]
mod tests;

pub use build::{physical_limits, units};
pub use compiled::{MAX_SLOTS, UserModel};
pub use def::{BlockDef, LimitDef, RealValue, UserModelDef};
#[cfg(test)]
mod kernel_tests;
