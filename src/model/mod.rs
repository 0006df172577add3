//! The model layer: what a model is, independent of data files and samplers.
//!
//! A model has named real parameters θ. At a frequency `f` it gives the complex coefficients
//! `M_rc(f; θ)` that turn an experiment's data channels `d_c` (DFTs of named time series:
//! `o1`, `o12`, `i1`, `i12`, `g1`, …) into its residual channels `r_r`:
//!
//! ```text
//! r_r(f; θ) = Σ_c M_rc(f; θ) d_c(f)
//! ```
//!
//! The residual is what the model says is noise. The closed loop of the LTP is
//! `r = o − H_io(θ) i` (coefficients `[I | −H_io]`); the acceleration domain is
//! `r = P(θ) o − G(θ) g`. The likelihood (`crate::likelihood`) is written once for every model:
//! `ln L = −Σ_e Σ_k r_kᴴ C_k⁻¹ r_k + const`, with `C_k` the CSD of the residual noise.
//!
//! Coefficients come in two flavours with one implementation behind them: `f64` for the
//! likelihood and [`Dual64`](num_dual::Dual64) (forward-mode dual numbers) so that every model gets exact
//! parameter derivatives, hence an exact Fisher matrix.
//!
//! θ-independent per-bin factors (controller responses, fixed filters) are computed once per
//! bin by [`Model::bin_consts`] and handed back on every call in [`Bin::consts`]: the hot
//! path never recomputes them and never allocates.

pub mod accel;
mod bin;
mod channels;
mod checks;
mod covariates;
pub mod drift;
pub mod glitch;
mod glitch_kernel;
pub mod glitch_response;
pub mod ltp;
mod ltp_kernel;
pub mod reparam;
pub mod state_space;
pub mod tied;
mod traits;
pub mod user;

pub use accel::{AccelModel, AccelOptions};
pub use bin::{
    Bin, BinBlock, MAX_CHANNELS, MAX_CONSTS, MAX_RESIDUALS, quad, quad_whitened, residual,
    residual_into, tri_len, with_buffer,
};
pub use channels::{Channel, ChannelRoles};
pub use checks::{check_finite, check_identifiable, coefficients_at, validate_shape};
pub use covariates::Covariates;
pub use drift::{DriftModel, DriftRule};
pub use glitch::{GLITCH_CHANNEL, GlitchModel, map_tolerance};
pub use glitch_response::{GlitchScan, ScanGains, force_envelope, grid_index};
pub use ltp::{LoopResponse, LtpModel, LtpModelOptions, ThrusterResponse};
pub use reparam::{Reparam, ReparamModel};
pub use tied::TiedModel;
pub use traits::{
    BatchKernel, BlockKernel, Model, coefficients_batch_generic, residual_power_generic,
    residual_power_whitened,
};
