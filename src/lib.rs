//! occam: Bayesian model selection for LISA Pathfinder system identification.
//!
//! Data flow (one way): experiment → spectra → likelihood → samplers → evidence → report.
//!
//! Conventions, written once: SI units; one-sided PSDs; the DFT is
//! `Y[k] = Σ_n y[n] e^{−2πikn/N}` (unnormalised) at `f_k = k fs/N`; likelihoods are natural
//! logs (`ln L`, never χ²).

pub mod atomic;
pub mod config;
pub mod data;
pub mod density;
pub mod evidence;
pub mod experiment;
pub mod hermitian;
pub mod html;
pub mod jobs;
pub mod likelihood;
pub mod linalg;
pub mod lti;
pub mod ltp;
pub mod model;
pub mod nested;
pub mod numfmt;
pub mod prior;
pub mod report;
pub mod sampler;
pub mod signal;
