//! Linear time-invariant building blocks: rational transfer functions evaluated at
//! `s = i2πf`, their composition, pure delays, discretisation and IIR filtering.
//!
//! Nothing here knows about LISA Pathfinder; [`crate::ltp`] assembles the closed loop from
//! these pieces.

pub mod discrete;
mod rational;

pub use rational::{LtiError, Rational, StateSpace, delay};
