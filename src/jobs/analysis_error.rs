//! The error of preparing an analysis (data, spectra, likelihood), shared by the files that
//! build likelihoods for the jobs.

/// Errors while preparing an analysis.
#[derive(Debug, thiserror::Error)]
pub enum AnalysisError {
    #[error(transparent)]
    Data(#[from] crate::data::dataset::DataError),
    #[error(transparent)]
    Simulation(#[from] crate::experiment::SimError),
    #[error(transparent)]
    Spectra(#[from] crate::likelihood::SpectraError),
    #[error("{0}")]
    Likelihood(String),
    /// Relative binning could not be built or validated (match
    /// [`crate::likelihood::RelBinError::ToleranceNotMet`] to fall back to the exact
    /// likelihood).
    #[error(transparent)]
    RelBin(#[from] crate::likelihood::RelBinError),
}
