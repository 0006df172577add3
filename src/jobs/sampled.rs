//! The relative-binned likelihood a model's samplers run on, built outside a run (the Python
//! package's `Likelihood(..., binned=True)`): the MAP search and the validation region exactly
//! as `fit` builds them for the `[fit]` model and `select` for a `[[select.model]]`, so that
//! its `ln L̃` is the one the command line's chains store.
//!
//! The two commands validate different regions: `fit` the Fisher Gaussian at the MAP over
//! every parameter of the model ([`RelBinLikelihood::new`]), `select` the capped Fisher
//! Gaussian over the sub-model's free parameters ([`RelBinLikelihood::with_covariance`]).

use crate::config::{ModelSpec, Study};
use crate::density::LogDensity;
use crate::jobs::prepare::{default_start, map_search, relbin_of, relbin_options};
use crate::likelihood::{Likelihood, MultiStartMap, RelBinLikelihood, fisher_exact};
use crate::linalg::{SpdOptions, spd_inverse};

/// Which command's samplers to reproduce.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Role {
    /// `occam fit` of the `[fit]` model.
    Fit,
    /// `occam select` of a `[[select.model]]`.
    Select,
}

/// The relative-binned likelihood and the MAP search it was built around.
pub struct Binned {
    /// The likelihood (full parameter vector, as [`Likelihood`]).
    pub relbin: RelBinLikelihood,
    /// The multi-start MAP search whose best maximum is the fiducial point.
    pub map: MultiStartMap,
}

/// Builds the relative-binned likelihood of `spec` on `exact` as `role`'s samplers do. Errors
/// say why it cannot be built: a statistic other than Whittle (relative binning approximates
/// the Whittle sum only), a failed MAP search, a singular Fisher matrix, or an approximation
/// that does not meet `[analysis] relbin_tolerance`.
pub fn relbin_as_sampled(
    study: &Study,
    spec: &ModelSpec,
    exact: &Likelihood,
    role: Role,
) -> anyhow::Result<Binned> {
    let stat = exact.statistic();
    if stat != crate::likelihood::Statistic::Whittle {
        anyhow::bail!(
            "binned=True: relative binning approximates the Whittle likelihood only, and the study's statistic is \"{}\" (its samplers run on the exact ln L); use binned=False",
            stat.name()
        );
    }
    let free = &spec.free;
    let start = default_start(study, spec);
    let map = map_search(exact, free, &start, study.fit.map_starts)
        .map_err(|e| anyhow::anyhow!("MAP search: {e}"))?;
    let base = map.best().result.theta.clone();
    let relbin = match role {
        Role::Fit => relbin_of(study, exact, &base)?,
        Role::Select => {
            let f = fisher_exact(exact, &base, free);
            let cov = spd_inverse(&f, &SpdOptions::lower().jacobi()).map_err(|e| {
                anyhow::anyhow!(
                    "the Fisher matrix at the MAP is singular ({e}): select samples this model on the exact likelihood; use binned=False"
                )
            })?;
            let walk = crate::sampler::cap_to_prior(&cov, &exact.prior().subset(free));
            RelBinLikelihood::with_covariance(exact, &base, &relbin_options(study), free, &walk)?
        }
    };
    Ok(Binned { relbin, map })
}
