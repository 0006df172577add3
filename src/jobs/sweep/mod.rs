//! `occam sweep`: model selection over a grid of study keys with noise realisations per
//! point (the paper's Fig. 5 and Fig. 6).

pub mod grid;
pub mod record;
pub mod stats;
