//! State-space models written in the study file (`[[model]]` with `kind = "state_space"`),
//! and transfer matrices written entry by entry (`kind = "transfer_matrix"`).
//!
//! ```toml
//! [[model]]
//! kind = "state_space"
//! name = "osc"
//! parameters = ["k", "gamma"]     # θ order
//! inputs = ["u"]                  # data channels of the known inputs (injections)
//! outputs = ["y"]                 # data channels of the read-outs = residual channels
//! time = "continuous"             # or "discrete" (z = e^{i2πf/fs} at the data's rate)
//! a = [[0, 1], ["-k", "-gamma"]]  # states × states: numbers or real expressions
//! b = [[0], [1]]                  # states × inputs
//! c = [[1, 0]]                    # outputs × states
//! # d = [[0]]                     # outputs × inputs (default zero)
//! # delay = { u = "tau" }         # e^{−sτ} on an input or output channel
//! ```
//!
//! The transfer matrix at each bin is `H = C (sI − A)⁻¹ B + D` (times the delays), solved by
//! Gaussian elimination with partial pivoting on stack buffers (at most [`MAX_STATES`]
//! states), generically over dual numbers so the Fisher matrix is exact. The residual is
//! `r = y − H u`: coefficients `[I | −H]` over the data channels (outputs, then inputs).
//!
//! Optional white noise inputs `w` (`g`: states × noise inputs, `h`: outputs × noise inputs,
//! `noise`: their one-sided PSDs) give [`Model::data_noise_csd`](crate::model::Model::data_noise_csd):
//! `S_y = T S_w Tᴴ`, `T = C (sI − A)⁻¹ G + H`.

mod build;
mod compiled;
mod def;
mod noise;
mod solve;
mod stability;
#[cfg(test)]
mod tests;
mod transfer;

pub use compiled::{MAX_STATES, StateSpaceModel};
pub use def::{MatrixDef, StateSpaceDef, TimeDomain, TransferMatrixDef};
pub use solve::solve_in_place;
pub use stability::check_stable;
pub use transfer::{to_user_def, user_error};
