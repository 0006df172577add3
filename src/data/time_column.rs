//! The checks of a time column: strictly increasing, uniformly spaced; its sample rate.

/// `x` rounded to 10 significant digits, for messages (`0.1`, not `0.10000000000000009`).
fn sig(x: f64) -> f64 {
    format!("{x:.9e}").parse().unwrap_or(x)
}

/// Relative tolerance on the spacing of a time column.
pub const TIME_TOLERANCE: f64 = 1e-6;

/// The sample rate of a time column `t` (named `column` in messages), checking that it is
/// strictly increasing and uniformly spaced: every step within [`TIME_TOLERANCE`] (relative)
/// of the median step, plus the rounding of `t` itself (a few ulp, which matters for absolute
/// times such as GPS seconds). `at(k)` locates sample `k` in messages (`"line 7"`,
/// `"sample 5"`). Returns `(n − 1) / (t_last − t_0)`.
pub fn uniform_rate(t: &[f64], column: &str, at: impl Fn(usize) -> String) -> Result<f64, String> {
    if t.len() < 2 {
        return Err(format!(
            "time column `{column}` needs at least two samples to give a sample rate"
        ));
    }
    for k in 1..t.len() {
        if !(t[k] > t[k - 1]) {
            return Err(format!(
                "{}, column `{column}`: time {} s does not increase (it follows {} s on {}); the time column must be strictly increasing",
                at(k),
                t[k],
                t[k - 1],
                at(k - 1)
            ));
        }
    }
    let mut steps: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
    steps.sort_by(f64::total_cmp);
    let dt = steps[steps.len() / 2];
    for k in 1..t.len() {
        let step = t[k] - t[k - 1];
        let tol = TIME_TOLERANCE * dt + 4.0 * f64::EPSILON * t[k].abs().max(t[k - 1].abs());
        if (step - dt).abs() > tol {
            return Err(format!(
                "{}, column `{column}`: not uniformly sampled: the step from {} is {} s but the series' spacing is {} s (tolerance {TIME_TOLERANCE} relative); gaps must be filled or the series split",
                at(k),
                at(k - 1),
                sig(step),
                sig(dt)
            ));
        }
    }
    Ok((t.len() - 1) as f64 / (t[t.len() - 1] - t[0]))
}

/// The sample rate of a time column `t` with missing time stamps, and the position of every
/// row on the uniform grid. Every step must be within [`TIME_TOLERANCE`] (relative, plus the
/// rounding of `t`) of a whole number of the median step `dt`; a step of `m dt` with `m > 1`
/// leaves `m − 1` missing samples (a gap). Returns `(fs, positions)`, with `positions` `None`
/// when no stamp is missing (then `fs` is exactly [`uniform_rate`]'s). The grid has
/// `positions.last() + 1` samples; the caller bounds it before allocating.
pub fn time_grid(
    t: &[f64],
    column: &str,
    at: impl Fn(usize) -> String,
) -> Result<(f64, Option<Vec<usize>>), String> {
    match uniform_rate(t, column, &at) {
        Ok(fs) => return Ok((fs, None)),
        Err(e) if !e.contains("not uniformly sampled") => return Err(e),
        Err(_) => {}
    }
    let mut steps: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
    steps.sort_by(f64::total_cmp);
    let dt = steps[steps.len() / 2];
    let mut pos = Vec::with_capacity(t.len());
    pos.push(0usize);
    for k in 1..t.len() {
        let step = t[k] - t[k - 1];
        let m = (step / dt).round();
        let tol =
            TIME_TOLERANCE * dt * m.max(1.0) + 4.0 * f64::EPSILON * t[k].abs().max(t[k - 1].abs());
        if m < 1.0 || (step - m * dt).abs() > tol || m > (usize::MAX / 4) as f64 {
            return Err(format!(
                "{}, column `{column}`: the step from {} is {} s, which is not a whole number of the series' spacing {} s (tolerance {TIME_TOLERANCE} relative); missing time stamps are read as gaps, but every stamp must lie on one uniform grid",
                at(k),
                at(k - 1),
                sig(step),
                sig(dt)
            ));
        }
        pos.push(pos[k - 1].saturating_add(m as usize));
    }
    let last = *pos.last().expect("two samples or more");
    Ok((last as f64 / (t[t.len() - 1] - t[0]), Some(pos)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uniform_rate_accepts_gps_times_and_rejects_gaps() {
        let t: Vec<f64> = (0..1000).map(|k| 1.1e9 + 0.1 * k as f64).collect();
        let fs = uniform_rate(&t, "t", |k| format!("sample {k}")).unwrap();
        assert!((fs - 10.0).abs() < 1e-5, "{fs}");
        let mut g = t.clone();
        g.remove(500);
        let e = uniform_rate(&g, "t", |k| format!("sample {k}")).unwrap_err();
        assert!(e.contains("sample 500") && e.contains("sample 499"), "{e}");
        let e = uniform_rate(&[0.0, 1.0, 1.0], "time", |k| format!("line {}", k + 2)).unwrap_err();
        assert!(
            e.contains("line 4") && e.contains("`time`") && e.contains("increas"),
            "{e}"
        );
    }

    #[test]
    fn missing_stamps_become_positions_on_the_grid() {
        let mut t: Vec<f64> = (0..1000).map(|k| 1.1e9 + 0.1 * k as f64).collect();
        let (fs, pos) = time_grid(&t, "t", |k| format!("sample {k}")).unwrap();
        assert!(pos.is_none() && (fs - 10.0).abs() < 1e-5);
        t.drain(500..530);
        let (fs, pos) = time_grid(&t, "t", |k| format!("sample {k}")).unwrap();
        let pos = pos.unwrap();
        assert!((fs - 10.0).abs() < 1e-5, "{fs}");
        assert_eq!((pos[499], pos[500], pos[969]), (499, 530, 999));
        // a step of 1.5 dt is on no grid
        t[700] += 0.05;
        let e = time_grid(&t, "t", |k| format!("sample {k}")).unwrap_err();
        assert!(
            e.contains("sample 700") && e.contains("whole number"),
            "{e}"
        );
        let e = time_grid(&[0.0, 1.0, 1.0], "t", |k| format!("line {k}")).unwrap_err();
        assert!(e.contains("increas"), "{e}");
    }
}
