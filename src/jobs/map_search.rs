//! The multi-start MAP search of a fit or select model.

/// Fisher-scoring iterations of one MAP search of a fit or select model.
pub const MAP_MAX_ITER: usize = 200;

/// The multi-start MAP search over `free` on `exact` ([`crate::likelihood::multi_start_map`]):
/// from `start` (e.g. the study's `[fit] start` or prior centre), then from `n_quasi` (`[fit] map_starts`)
/// quasi-random points of the prior.
pub fn map_search(
    exact: &crate::likelihood::Likelihood,
    free: &[usize],
    start: &[f64],
    n_quasi: usize,
) -> Result<crate::likelihood::MultiStartMap, crate::likelihood::MapError> {
    use crate::density::LogDensity;
    use crate::likelihood::{MapStart, StartFrom, multi_start_map, quasi_random_starts};
    let mut starts = vec![MapStart {
        from: StartFrom::Given,
        theta: start.to_vec(),
    }];
    starts.extend(quasi_random_starts(exact.prior(), start, free, n_quasi));
    multi_start_map(
        exact,
        &starts,
        free,
        crate::model::map_tolerance(exact.model().as_ref()),
        MAP_MAX_ITER,
    )
}
