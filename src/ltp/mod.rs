//! The LISA Technology Package (LTP) one-dimensional closed loop: parameters and sign
//! conventions, the representative controllers, the closed-loop transfer matrices
//! `H_io`, `H_go`, `H_no`, the noise model and its exact output CSD.
//!
//! Physics and every convention: `shared/design/ltp-model.md` §2–§5. In short, with
//! `x = (x1, x12)`, `o = (o1, o12)`, `i = (i1, i12)` and `s = i2πf`:
//!
//! ```text
//! D x = M A u + g,   o = E S x + n_o,   u = −K (o − T i)
//! H_io = E S (D + E M A K S)⁻¹ M A K T
//! H_go = E S (D + E M A K S)⁻¹
//! H_no = I − E S (D + E M A K S)⁻¹ M A K
//! ```
//!
//! The stiffnesses use the physical sign convention `ẍ + ω² x = f/m` with `ω² < 0`.

pub mod a12;
pub mod accel_options;
mod closed_loop;
mod controllers;
pub mod discrete_response;
pub mod fpsder;
pub mod hurwitz;
mod noise;
mod params;
pub mod timedomain;

pub use closed_loop::{
    BinConsts, ClosedLoop, LoopError, LoopKernel, check_stable, closed_loop_poles, h_dg_column,
    h_io_matrix, h_io_matrix_actuated, response,
};
pub use controllers::{Controllers, design_lead_integrator};
pub use discrete_response::{
    DiscreteBinConsts, DiscreteControllers, DiscreteLoopKernel, N_DISCRETE_CONSTS, h_io_discrete,
};
pub use noise::NoiseModel;
pub use params::{LtpParams, Masses, N_PARAMS, PARAM_NAMES};
