//! Linear prediction: a series continued through its gaps from both sides by the linear
//! recursion its samples beside each gap obey.
//!
//! Used where a signal is known beside a gap but not inside it, and an *estimate* of what it
//! did there is wanted — a commanded injection whose read-back a telemetry gap dropped, for
//! the bias its unknown response causes (`jobs::injection_bias`). A signal made of `p / 2`
//! sinusoids of constant frequency obeys an exact order-`p` recursion, so it is continued
//! exactly (to rounding) through any gap; one that changes inside the gap is not, and what
//! is filled in is then only a plausible continuation. Which order and how long a stretch
//! beside the gap to fit are chosen by how well each predicts the stretch's own last samples.
//!
//! Two choices make that hold for the injections of this field, sines of 1–50 mHz sampled at
//! 10 Hz (hundreds to 10 000 samples a period). The recursion links samples `lag` apart,
//! with `lag` set from the signal's own time scale (about half a radian of its RMS frequency
//! per lag): a recursion on neighbouring samples of so slow a signal is ill-conditioned by
//! ~10¹⁰, and an hour-long gap multiplies its coefficients' errors by 36 000 steps. And it is
//! fitted by least squares of minimum norm (an SVD), not by Burg's method, whose estimate of a
//! pure tone's frequency from a finite stretch is biased (measured: 14 % errors after an hour
//! at 1 and 3 mHz); an order higher than the signal needs then adds only decaying terms. A
//! continuation that grows beyond twice the peak of the samples beside the gap (noise, which
//! no recursion predicts) is not used.

use nalgebra::{DMatrix, DVector};

/// The coefficients `c[i]` of the recursion `x[n] ≈ Σ_{i=1}^{order} c[i−1] x[n − i·lag]`
/// fitted to `x` by least squares of minimum norm; `None` when `x` has fewer than
/// `order·lag + 2·order` samples.
///
/// ```
/// use occam::signal::prediction::fit_recursion;
/// // x[n] = cos(0.3 n) obeys x[n] = 2 cos(0.3) x[n−1] − x[n−2]
/// let x: Vec<f64> = (0..200).map(|n| (0.3 * n as f64).cos()).collect();
/// let c = fit_recursion(&x, 2, 1).unwrap();
/// assert!((c[0] - 2.0 * 0.3f64.cos()).abs() < 1e-9 && (c[1] + 1.0).abs() < 1e-9);
/// ```
pub fn fit_recursion(x: &[f64], order: usize, lag: usize) -> Option<Vec<f64>> {
    let lag = lag.max(1);
    let hist = order * lag;
    if order == 0 || x.len() < hist + 2 * order {
        return None;
    }
    let rows = x.len() - hist;
    let a = DMatrix::from_fn(rows, order, |r, i| x[hist + r - (i + 1) * lag]);
    let b = DVector::from_fn(rows, |r, _| x[hist + r]);
    let svd = a.svd(true, true);
    let top = svd.singular_values.max();
    if top == 0.0 {
        return Some(vec![0.0; order]);
    }
    svd.solve(&b, 1e-12 * top)
        .ok()
        .map(|c| c.iter().copied().collect())
}

/// `x`'s values inside `gaps` (`[start, end)` sample ranges, sorted, not overlapping)
/// replaced by a continuation of its values beside each gap: a recursion of order up to
/// `order` ([`fit_recursion`], module docs) fitted to at most `fit_len` samples before the
/// gap (back to the previous gap) is run forward through it, one fitted to at most `fit_len`
/// samples after it (up to the next gap) backward, and the two are blended with weights that
/// fall linearly across the gap away from each side (so that the fill meets the data at both ends) and with each
/// side's error in predicting its own last samples. A side with fewer than `2 order + 1`
/// samples, or whose continuation grows without bound, is not used; a gap with neither side
/// usable is filled with zeros.
///
/// ```
/// use occam::signal::prediction::predict_through_gaps;
/// let truth: Vec<f64> = (0..4000).map(|n| (2e-3 * n as f64).sin()).collect();
/// let mut x = truth.clone();
/// x[1500..2500].iter_mut().for_each(|v| *v = f64::NAN);
/// predict_through_gaps(&mut x, &[[1500, 2500]], 4, 1000);
/// let worst = x.iter().zip(&truth).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
/// assert!(worst < 1e-6, "{worst}");
/// ```
pub fn predict_through_gaps(x: &mut [f64], gaps: &[[usize; 2]], order: usize, fit_len: usize) {
    let n = x.len();
    let min_len = 2 * order + 1;
    for (j, g) in gaps.iter().enumerate() {
        let (a, b) = (g[0].min(n), g[1].min(n));
        if a >= b {
            continue;
        }
        let prev_end = if j == 0 { 0 } else { gaps[j - 1][1].min(a) };
        let next_start = gaps.get(j + 1).map_or(n, |h| h[0].clamp(b, n));
        let before = &x[prev_end.max(a.saturating_sub(fit_len))..a];
        let after = &x[b..next_start.min(b + fit_len)];
        let len = b - a;
        let forward = (before.len() >= min_len)
            .then(|| best_continuation(before, order, len))
            .flatten();
        let backward = (after.len() >= min_len)
            .then(|| {
                let rev: Vec<f64> = after.iter().rev().copied().collect();
                best_continuation(&rev, order, len).map(|(mut c, e)| {
                    c.reverse();
                    (c, e)
                })
            })
            .flatten();
        for t in 0..len {
            x[a + t] = match (&forward, &backward) {
                (Some((f, ef)), Some((r, er))) => {
                    // each side's weight falls linearly across the gap and with its error
                    // on its own last samples: a side that cut a tone short (a sine train's
                    // segment starting just before the gap) gives way to the other
                    let s = (t + 1) as f64 / (len + 1) as f64;
                    let (wf, wr) = ((1.0 - s) / (ef + 1e-12), s / (er + 1e-12));
                    (wf * f[t] + wr * r[t]) / (wf + wr)
                }
                (Some((f, _)), None) => f[t],
                (None, Some((r, _))) => r[t],
                (None, None) => 0.0,
            };
        }
    }
}

/// The next `len` values of `x` by the recursion that best predicts its own last samples:
/// each order up to `order` and each fitted stretch (the last whole, half, quarter and eighth
/// of `x`) is fitted without the last `h = min(len, |x|/4)` samples and scored on predicting
/// them; the best is refitted on its stretch up to the end and run on, within twice the peak
/// of `x`. A sine train changes frequency every few periods, so a stretch reaching back past
/// the last change fits neither tone; the hold-out finds the stretch since it. `None` when no
/// candidate predicts within bounds ([`continue_at`]). With the continuation, its relative error on the hold-out
/// (squared error over the held-out samples' energy).
fn best_continuation(x: &[f64], order: usize, len: usize) -> Option<(Vec<f64>, f64)> {
    let n = x.len();
    let h = len.min(n / 4).max(1);
    let mut stretches: Vec<usize> = [1, 2, 4, 8].iter().map(|d| n / d).collect();
    stretches.dedup();
    // a slow tone's short stretch may hold less than its amplitude: bounded by the whole side
    let bound = 2.0 * x.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    let mut best: Option<(f64, usize, usize)> = None;
    for p in 1..=order {
        for &m in &stretches {
            let train = &x[(n - m).min(n - h)..n - h];
            let Some(c) = continue_at(train, p, h, bound) else {
                continue;
            };
            let err: f64 = c
                .iter()
                .zip(&x[n - h..])
                .map(|(a, b)| (a - b).powi(2))
                .sum();
            if best.is_none_or(|(e, ..)| err < e) {
                best = Some((err, p, m));
            }
        }
    }
    let (err, p, m) = best?;
    let held: f64 = x[n - h..].iter().map(|v| v * v).sum();
    let rel = if held > 0.0 { err / held } else { 0.0 };
    continue_at(&x[n - m..], p, len, bound).map(|c| (c, rel))
}

/// The next `len` values of `x` by the order-`p` recursion fitted to it at the lag of its
/// time scale; `None` when `x` is too short, or the continuation leaves `±bound` (noise,
/// which no recursion predicts, or a fit that grows).
fn continue_at(x: &[f64], p: usize, len: usize, bound: f64) -> Option<Vec<f64>> {
    let energy: f64 = x.iter().map(|v| v * v).sum();
    if energy == 0.0 {
        return Some(vec![0.0; len]);
    }
    // the RMS frequency in radians per sample: √(Σ Δx² / Σ x²)
    let slope: f64 = x.windows(2).map(|w| (w[1] - w[0]).powi(2)).sum();
    let omega = (slope / energy).sqrt();
    let room = (x.len().checked_sub(2 * p)? / p.max(1)).max(1);
    let lag = ((0.5 / omega.max(1e-300)).round() as usize).clamp(1, room);
    let c = fit_recursion(x, p, lag)?;
    let mut hist = x.to_vec();
    for _ in 0..len {
        let t = hist.len();
        let next: f64 = c
            .iter()
            .enumerate()
            .map(|(i, ci)| ci * hist[t - (i + 1) * lag])
            .sum();
        if !next.is_finite() || next.abs() > bound {
            return None;
        }
        hist.push(next);
    }
    Some(hist.split_off(x.len()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn worst(a: &[f64], b: &[f64]) -> f64 {
        a.iter()
            .zip(b)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max)
    }

    /// Two tones of the LTP's injection ladder at 10 Hz (1 and 3 mHz: 3 000 to 10 000
    /// samples a period), continued through an hour-long gap from 2 000 s on each side.
    #[test]
    fn slow_tones_are_continued_through_a_long_gap() {
        let fs = 10.0;
        let s = |t: f64| {
            (2.0 * std::f64::consts::PI * 1e-3 * t + 0.4).sin()
                + 0.5 * (2.0 * std::f64::consts::PI * 3e-3 * t).cos()
        };
        let truth: Vec<f64> = (0..80_000).map(|n| s(n as f64 / fs)).collect();
        let mut x = truth.clone();
        let g = [30_000, 66_000];
        x[g[0]..g[1]].iter_mut().for_each(|v| *v = 0.0);
        predict_through_gaps(&mut x, &[g], 4, 20_000);
        let w = worst(&x, &truth);
        assert!(w < 1e-4, "{w}");
    }

    /// Noise is not predictable: the fill stays bounded (the recursion is stable) and
    /// meets the data at both ends.
    #[test]
    fn a_noise_fill_stays_bounded() {
        let mut state = 12345u64;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 11) as f64 / (1u64 << 53) as f64) - 0.5
        };
        let mut x: Vec<f64> = (0..20_000).map(|_| next()).collect();
        predict_through_gaps(&mut x, &[[5_000, 15_000]], 8, 4_000);
        let peak = x.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        assert!(peak <= 0.5, "{peak}");
    }

    /// A side without enough samples is not used; a gap at the start is filled from after
    /// it only; a gap with no usable side is zero; neighbouring gaps' samples never enter a fit.
    #[test]
    fn sides_too_short_or_missing_are_not_used() {
        let truth: Vec<f64> = (0..3000).map(|n| (0.01 * n as f64).sin()).collect();
        let mut x = truth.clone();
        let gaps = [[0, 400], [1000, 1003], [1006, 1500]];
        for g in &gaps {
            x[g[0]..g[1]].iter_mut().for_each(|v| *v = 1e9);
        }
        predict_through_gaps(&mut x, &gaps, 2, 500);
        assert!(worst(&x[..400], &truth[..400]) < 1e-6);
        assert!(x.iter().all(|v| v.abs() < 2.0), "a gap's 1e9 entered a fit");
        assert!(worst(&x[1006..1500], &truth[1006..1500]) < 1e-6);
        let mut y = vec![f64::NAN; 10];
        y[4] = 1.0;
        predict_through_gaps(&mut y, &[[0, 4], [5, 10]], 2, 100);
        assert_eq!(y, [0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
    }

    /// An order higher than a tone needs (6 for one tone) still continues it exactly, at the
    /// lag of its time scale; a silent stretch continues as silence; a short one fits nothing.
    #[test]
    fn an_excess_order_adds_nothing_that_grows() {
        let truth: Vec<f64> = (0..30_000)
            .map(|n| (6.3e-4 * n as f64 + 1.0).sin())
            .collect();
        let fill = continue_at(&truth[..10_000], 6, 20_000, 2.0).unwrap();
        let w = worst(&fill, &truth[10_000..]);
        assert!(w < 1e-5, "{w}");
        assert_eq!(
            best_continuation(&[0.0; 50], 4, 3),
            Some((vec![0.0; 3], 0.0))
        );
        assert_eq!(fit_recursion(&[1.0; 9], 4, 1), None);
    }
}
