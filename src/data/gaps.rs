//! Missing samples of a uniformly sampled series: gaps as sorted, disjoint, half-open sample
//! ranges `[start, end)`, and the valid runs between them.
//!
//! In memory a gap's samples hold `0.0` and the gap list says they are missing, so that every
//! series stays finite; on disk (CSV, npz) a missing sample is a NaN (or an empty CSV cell, or
//! a missing time stamp), which [`take_nan_gaps`] turns into gaps.

/// A half-open sample range `[start, end)`.
pub type Span = [usize; 2];

/// Sorts `spans`, drops empty ones and merges those that overlap or touch.
///
/// ```
/// use occam::data::gaps::normalise;
/// assert_eq!(normalise(vec![[8, 9], [2, 4], [3, 6], [6, 7], [5, 5]]), vec![[2, 7], [8, 9]]);
/// ```
pub fn normalise(mut spans: Vec<Span>) -> Vec<Span> {
    spans.retain(|s| s[1] > s[0]);
    spans.sort_unstable();
    let mut out: Vec<Span> = Vec::with_capacity(spans.len());
    for s in spans {
        match out.last_mut() {
            Some(last) if s[0] <= last[1] => last[1] = last[1].max(s[1]),
            _ => out.push(s),
        }
    }
    out
}

/// The valid runs of a series of `n` samples with gaps `gaps` (normalised, within `[0, n)`):
/// the complement of the gaps, in order.
///
/// ```
/// use occam::data::gaps::valid_runs;
/// assert_eq!(valid_runs(10, &[[2, 4], [9, 10]]), vec![[0, 2], [4, 9]]);
/// assert_eq!(valid_runs(5, &[]), vec![[0, 5]]);
/// ```
pub fn valid_runs(n: usize, gaps: &[Span]) -> Vec<Span> {
    let mut out = Vec::with_capacity(gaps.len() + 1);
    let mut at = 0;
    for g in gaps {
        if g[0] > at {
            out.push([at, g[0].min(n)]);
        }
        at = at.max(g[1]);
    }
    if at < n {
        out.push([at, n]);
    }
    out
}

/// Number of samples inside `gaps`.
pub fn missing(gaps: &[Span]) -> usize {
    gaps.iter().map(|g| g[1] - g[0]).sum()
}

/// Checks that `gaps` are normalised (sorted, disjoint, not touching, non-empty) and inside a
/// series of `n` samples, and leave at least one valid sample.
pub fn check(gaps: &[Span], n: usize) -> Result<(), String> {
    for (k, g) in gaps.iter().enumerate() {
        if g[1] <= g[0] || g[1] > n {
            return Err(format!(
                "gap {k} covers samples [{}, {}), which is empty or outside the series' {n} samples",
                g[0], g[1]
            ));
        }
        if k > 0 && g[0] <= gaps[k - 1][1] {
            return Err(format!(
                "gaps {} and {k} overlap, touch or are out of order",
                k - 1
            ));
        }
    }
    if n > 0 && missing(gaps) >= n {
        return Err(format!("every one of the {n} samples is in a gap"));
    }
    Ok(())
}

/// The gaps of `series` (equal lengths): every sample that is NaN in any of them. A series
/// with a NaN in some gap is blanked over every gap ([`blank`]); one with none keeps its
/// values (a commanded injection recorded through a telemetry gap). All are finite afterwards
/// (infinities are left for the caller to refuse). Returns the gaps and, per series, whether
/// it kept its values.
pub fn take_nan_gaps_keeping(series: &mut [&mut Vec<f64>]) -> (Vec<Span>, Vec<bool>) {
    let n = series.iter().map(|s| s.len()).max().unwrap_or(0);
    let mut gaps: Vec<Span> = Vec::new();
    for k in 0..n {
        if series.iter().any(|s| s.get(k).is_some_and(|v| v.is_nan())) {
            match gaps.last_mut() {
                Some(g) if g[1] == k => g[1] = k + 1,
                _ => gaps.push([k, k + 1]),
            }
        }
    }
    let mut kept = Vec::with_capacity(series.len());
    for s in series.iter_mut() {
        let keep = !s.is_empty() && !s.iter().any(|v| v.is_nan());
        if !keep {
            blank(s, &gaps);
        }
        kept.push(keep);
    }
    (gaps, kept)
}

/// [`take_nan_gaps_keeping`], blanking every series over the gaps.
pub fn take_nan_gaps(series: &mut [&mut Vec<f64>]) -> Vec<Span> {
    let (gaps, _) = take_nan_gaps_keeping(series);
    for s in series.iter_mut() {
        blank(s, &gaps);
    }
    gaps
}

/// Sets the samples of `gaps` to `0.0` in `series` (the in-memory form of a gap).
pub fn blank(series: &mut [f64], gaps: &[Span]) {
    for g in gaps {
        let end = g[1].min(series.len());
        if g[0] < end {
            series[g[0]..end].fill(0.0);
        }
    }
}

/// `series` with the samples of `gaps` set to NaN (the on-disk form of a gap).
pub fn with_nan(series: &[f64], gaps: &[Span]) -> Vec<f64> {
    let mut v = series.to_vec();
    for g in gaps {
        let end = g[1].min(v.len());
        if g[0] < end {
            v[g[0]..end].fill(f64::NAN);
        }
    }
    v
}

/// Converts time intervals `[t0, t1]` (seconds from the first sample) into sample gaps of a
/// series of `n` samples at `fs` Hz: every sample `k` with `t0 ≤ k/fs < t1`, clipped to the
/// series; the result is normalised. `what` names the list in messages.
pub fn from_times(
    intervals: &[[f64; 2]],
    fs: f64,
    n: usize,
    what: &str,
) -> Result<Vec<Span>, String> {
    let mut spans = Vec::with_capacity(intervals.len());
    for (k, &[t0, t1]) in intervals.iter().enumerate() {
        if !(t0.is_finite() && t1.is_finite() && t1 > t0 && t0 >= 0.0) {
            return Err(format!(
                "{what}[{k}] = [{t0}, {t1}]: need finite times 0 ≤ t0 < t1 (seconds from the experiment's first sample)"
            ));
        }
        let a = (t0 * fs).ceil();
        let b = (t1 * fs).ceil();
        if a >= n as f64 {
            return Err(format!(
                "{what}[{k}] = [{t0}, {t1}] s starts after the series ends ({} s)",
                n as f64 / fs
            ));
        }
        spans.push([a as usize, (b.min(n as f64)) as usize]);
    }
    Ok(normalise(spans))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nan_gaps_are_taken_from_every_series_and_blanked() {
        let mut a = vec![1.0, f64::NAN, f64::NAN, 4.0, 5.0, 6.0];
        let mut b = vec![1.0, 2.0, 3.0, f64::NAN, 5.0, f64::NAN];
        let g = take_nan_gaps(&mut [&mut a, &mut b]);
        assert_eq!(g, vec![[1, 4], [5, 6]]);
        assert!(a.iter().chain(&b).all(|v| v.is_finite()));
        assert_eq!(a, vec![1.0, 0.0, 0.0, 0.0, 5.0, 0.0]);
        assert_eq!(b, vec![1.0, 0.0, 0.0, 0.0, 5.0, 0.0]);
        // round trip through the on-disk form
        let mut c = with_nan(&[1.0; 6], &g);
        assert_eq!(take_nan_gaps(&mut [&mut c]), g);
        check(&g, 6).unwrap();
    }

    #[test]
    fn runs_and_checks() {
        assert_eq!(valid_runs(10, &[[0, 3]]), vec![[3, 10]]);
        assert_eq!(valid_runs(10, &[[0, 3], [5, 10]]), vec![[3, 5]]);
        assert_eq!(missing(&[[0, 3], [5, 10]]), 8);
        assert!(check(&[[0, 10]], 10).unwrap_err().contains("every one"));
        assert!(check(&[[3, 5], [5, 6]], 10).unwrap_err().contains("touch"));
        assert!(check(&[[3, 11]], 10).unwrap_err().contains("outside"));
        assert!(check(&[[4, 4]], 10).is_err());
    }

    #[test]
    fn times_map_onto_samples() {
        // at 2 Hz: [1.0, 2.0) s is samples 2, 3; [4.2, 99] is clipped to the end
        let g = from_times(&[[4.2, 99.0], [1.0, 2.0]], 2.0, 10, "gaps").unwrap();
        assert_eq!(g, vec![[2, 4], [9, 10]]);
        assert!(
            from_times(&[[2.0, 1.0]], 2.0, 10, "gaps")
                .unwrap_err()
                .contains("gaps[0]")
        );
        assert!(
            from_times(&[[6.0, 7.0]], 2.0, 10, "noise_gaps")
                .unwrap_err()
                .contains("after")
        );
    }
}
