//! From a study to a likelihood: get the data (load a dataset or simulate the study), reduce
//! each experiment to in-band spectra with a noise estimate, and build `ln L` with the
//! study's normalised prior. Shared by `occam fit` and `occam select`.

use crate::config::{ModelSpec, Study};
use crate::dataset::Dataset;
use crate::experiment::{SimError, System, simulate};
use crate::likelihood::{
    ExperimentSpectra, LtpLikelihood, RelBinLikelihood, RelBinOptions, SpectraError, SpectraOptions,
};
use crate::ltp::{Controllers, N_PARAMS};

/// Errors while preparing an analysis.
#[derive(Debug, thiserror::Error)]
pub enum AnalysisError {
    #[error(transparent)]
    Data(#[from] crate::dataset::DataError),
    #[error(transparent)]
    Simulation(#[from] SimError),
    #[error(transparent)]
    Spectra(#[from] SpectraError),
    #[error("{0}")]
    Likelihood(String),
}

/// Data and likelihood of a study, ready for samplers.
#[derive(Debug, Clone)]
pub struct Prepared {
    pub dataset: Dataset,
    /// Where the data came from (a path, or "simulated from <study>").
    pub origin: String,
    pub likelihood: LtpLikelihood,
}

/// Loads or simulates the data and builds the exact likelihood.
pub fn prepare(study: &Study) -> Result<Prepared, AnalysisError> {
    let (dataset, origin) = match &study.analysis.dataset {
        Some(p) => (Dataset::read(p)?, p.display().to_string()),
        None => (
            simulate(study)?.dataset,
            format!("simulated from {} (seed {})", study.source, study.seed),
        ),
    };
    let likelihood = likelihood_of(study, &dataset)?;
    Ok(Prepared {
        dataset,
        origin,
        likelihood,
    })
}

/// The spectral options of a study.
pub fn spectra_options(study: &Study) -> SpectraOptions {
    let a = &study.analysis;
    SpectraOptions {
        band: a.band,
        window: a.window,
        noise: a.noise,
        welch_averages: a.welch_averages,
        welch_window: a.welch_window,
        oms_delay: study.oms_delay,
    }
}

/// The exact likelihood of `dataset` under the study's analysis options and prior.
pub fn likelihood_of(study: &Study, dataset: &Dataset) -> Result<LtpLikelihood, AnalysisError> {
    let opts = spectra_options(study);
    let sys = System::of(study);
    let csd = |f: f64| sys.noise_csd(f);
    let ctrl = Controllers::default();
    let mut spectra = Vec::new();
    for e in &dataset.experiments {
        spectra.push(ExperimentSpectra::new(e, &opts, &ctrl, Some(&csd))?);
    }
    LtpLikelihood::new(spectra, study.masses, study.prior.clone())
        .map_err(|e| AnalysisError::Likelihood(e.to_string()))
}

/// The relative-binned likelihood around `fiducial` with the study's accuracy settings.
pub fn relbin_of(
    study: &Study,
    exact: &LtpLikelihood,
    fiducial: &[f64; N_PARAMS],
) -> Result<RelBinLikelihood, AnalysisError> {
    let opts = RelBinOptions {
        n_sigma: study.analysis.relbin_sigma,
        tolerance: study.analysis.relbin_tolerance,
    };
    RelBinLikelihood::new(exact, fiducial, &opts)
        .map_err(|e| AnalysisError::Likelihood(e.to_string()))
}

/// The start of a MAP search for `model`: given values, else the prior centre (box midpoint
/// or Gaussian mean; for a log-uniform box, the geometric mean).
pub fn default_start(study: &Study, model: &ModelSpec) -> [f64; N_PARAMS] {
    use crate::prior::PriorKind;
    let mut th = model.base;
    for &i in &model.free {
        th[i] = match study.prior.kinds()[i] {
            PriorKind::Uniform { lo, hi } => 0.5 * (lo + hi),
            PriorKind::Gaussian { mu, .. } => mu,
            PriorKind::LogUniform { lo, hi } => (lo * hi).sqrt(),
        };
        if let Some(v) = study
            .fit
            .start
            .as_ref()
            .and_then(|s| s.get(crate::ltp::PARAM_NAMES[i]))
        {
            th[i] = *v;
        }
    }
    th
}
