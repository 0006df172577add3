//! Test support: does a set of standardised errors cover at the nominal 1σ rate, and would the
//! check notice errors 20 % off?

/// Asserts [`nominal_coverage`].
pub(crate) fn assert_nominal_coverage(name: &str, z: &[f64]) {
    if let Err(e) = nominal_coverage(name, z) {
        panic!("{e}");
    }
}

/// Checks that the 1σ intervals, given as `z = (estimate − truth)/σ`, cover at 0.683 within 3
/// binomial sd — and, so that the check has power, that the same intervals with the errors
/// scaled by 0.8 and by 1.2 fall outside that band.
pub(crate) fn nominal_coverage(name: &str, z: &[f64]) -> Result<(), String> {
    let n = z.len() as f64;
    let cover = |f: f64| z.iter().filter(|v| v.abs() < f).count() as f64 / n;
    let sd = (0.683f64 * 0.317 / n).sqrt();
    let band = 0.683 - 3.0 * sd..=0.683 + 3.0 * sd;
    let (c, small, large) = (cover(1.0), cover(0.8), cover(1.2));
    println!(
        "{name}: coverage {c:.3} (band {band:.3?}); errors ×0.8: {small:.3}, ×1.2: {large:.3}"
    );
    if !band.contains(&c) {
        return Err(format!("{name}: coverage {c} outside {band:?}"));
    }
    if !(small < *band.start() && large > *band.end()) {
        return Err(format!(
            "{name}: no power: errors ×0.8 cover {small}, ×1.2 cover {large}"
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Exact normal quantiles on a fine grid stand in for a perfect estimator: they pass; the
    /// same values with errors stated 20 % too small or too large fail.
    #[test]
    fn passes_nominal_errors_and_refuses_errors_20_percent_off() {
        let z: Vec<f64> = (0..800)
            .map(|i| crate::evidence::normal::quantile((i as f64 + 0.5) / 800.0))
            .collect();
        assert_eq!(nominal_coverage("exact", &z), Ok(()));
        for f in [0.8, 1.2] {
            let scaled: Vec<f64> = z.iter().map(|v| v / f).collect();
            let e = nominal_coverage("scaled", &scaled).unwrap_err();
            assert!(e.contains("outside"), "errors ×{f}: {e}");
        }
        // 30 values cannot tell errors 20 % off from right: refused as without power
        let few: Vec<f64> = (0..30)
            .map(|i| crate::evidence::normal::quantile((i as f64 + 0.5) / 30.0))
            .collect();
        let e = nominal_coverage("few", &few).unwrap_err();
        assert!(e.contains("no power"), "{e}");
    }
}
