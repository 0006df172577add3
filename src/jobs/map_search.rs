//! The multi-start MAP search of a fit or select model.

/// Fisher-scoring iterations of one MAP search of a fit or select model.
pub const MAP_MAX_ITER: usize = 200;

/// The multi-start MAP search over `free` on `exact` ([`crate::likelihood::multi_start_map`]):
/// from `start` (e.g. the study's `[fit] start` or prior centre), then from `n_quasi` (`[fit] map_starts`)
/// quasi-random points of the prior. A model with modelled glitches varies only the loop's
/// parameters there: its glitches' starts come from the scan over their `(t0, τ)` with the
/// amplitude solved exactly (`jobs::glitch_model`), which a random point of a glitch's prior
/// (an amplitude up to 1e−10 m s⁻², a thousand times the glitches') cannot improve on, and a
/// search from there costs its 200 iterations.
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
    let model = exact.model();
    let glitches = crate::model::glitch::carries_glitches(model.as_ref());
    let vary: Vec<usize> = if glitches {
        let names = model.param_names();
        free.iter()
            .copied()
            .filter(|&i| !crate::model::glitch::is_glitch_param(&names[i]))
            .collect()
    } else {
        free.to_vec()
    };
    starts.extend(quasi_random_starts(exact.prior(), start, &vary, n_quasi));
    multi_start_map(
        exact,
        &starts,
        free,
        crate::model::map_tolerance(exact.model().as_ref()),
        MAP_MAX_ITER,
    )
}
