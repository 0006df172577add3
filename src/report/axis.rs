//! Axis ranges, tick positions and tick labels, chosen here rather than by plotters so that
//! values like `-1.29998×10⁻⁶ ± 2×10⁻¹⁰` get short, distinct labels.
//!
//! A linear axis factors out a power of ten and, when the spread is tiny compared with the
//! values, subtracts a round offset near the middle of the range; both are reported in the
//! axis description, `(name + 1.300×10⁻⁶) / 10⁻¹⁰`, so the ticks read `-2`, `0`, `2`, …
//! A logarithmic axis works in `log10` of the data (callers transform their values), with
//! ticks at whole decades labelled `10ⁿ`, or at 1-2-5 steps when the range is under a decade.

use crate::numfmt::format::{fmt_axis_number, fmt_sig, superscript};

/// One axis: plotted range, tick positions (both in plotted coordinates) and label format.
#[derive(Debug, Clone)]
pub(crate) struct Axis {
    pub lo: f64,
    pub hi: f64,
    pub ticks: Vec<f64>,
    kind: Kind,
}

#[derive(Debug, Clone)]
enum Kind {
    Linear {
        offset: f64,
        /// Number of significant digits needed to print `offset`.
        offset_digits: usize,
        exp: i32,
        decimals: usize,
    },
    Log10 {
        /// The whole axis lies within [10⁻², 10⁴]: print `0.05`, `20`, not `5×10⁻²`.
        plain: bool,
    },
}

/// Number of multiples of `step` in `[lo, hi]`.
fn tick_count(lo: f64, hi: f64, step: f64) -> i64 {
    (hi / step).floor() as i64 - (lo / step).ceil() as i64 + 1
}

/// Tick spacing of the form {1, 2, 2.5, 5}×10ⁿ: the finest giving at most `max_ticks` ticks
/// in `[lo, hi]`, or the next finer one if that leaves fewer than two.
fn tick_step(lo: f64, hi: f64, max_ticks: usize) -> f64 {
    let top = (hi - lo).log10().floor() as i32 + 1;
    let steps = (top - 4..=top).flat_map(|k| [1.0, 2.0, 2.5, 5.0].map(|m| m * 10f64.powi(k)));
    let mut previous = None;
    for s in steps {
        let n = tick_count(lo, hi, s);
        if n <= max_ticks.max(1) as i64 {
            return match previous {
                Some(p) if n < 2 => p,
                _ => s,
            };
        }
        previous = Some(s);
    }
    10f64.powi(top)
}

/// Decimal places needed to print multiples of `step` exactly (`0.25` → 2).
fn decimals_of(step: f64) -> usize {
    (0..=15)
        .find(|&d| {
            let v = step * 10f64.powi(d);
            (v - v.round()).abs() <= 1e-6 * v
        })
        .unwrap_or(15) as usize
}

/// Min and max of the finite values, `None` if there are none.
pub(crate) fn finite_range(values: impl IntoIterator<Item = f64>) -> Option<(f64, f64)> {
    values
        .into_iter()
        .filter(|v| v.is_finite())
        .fold(None, |acc, v| match acc {
            None => Some((v, v)),
            Some((lo, hi)) => Some((lo.min(v), hi.max(v))),
        })
}

impl Axis {
    /// A linear axis covering `[min, max]` (finite) with 5 % padding and at most about
    /// `max_ticks` ticks. A constant series gets a ±5 % (or ±1 around zero) window.
    pub fn linear(min: f64, max: f64, max_ticks: usize) -> Axis {
        let (mut lo, mut hi) = if max > min {
            let pad = 0.05 * (max - min);
            (min - pad, max + pad)
        } else {
            let half = if min != 0.0 { 0.05 * min.abs() } else { 1.0 };
            (min - half, min + half)
        };
        // Guard against a span lost to rounding (e.g. 1e300 ± tiny).
        if hi - lo <= 0.0 || !(hi - lo).is_finite() {
            lo = min - 1.0;
            hi = min + 1.0;
        }
        let step = tick_step(lo, hi, max_ticks);
        let first = (lo / step).ceil() as i64;
        let last = (hi / step).floor() as i64;
        let ticks: Vec<f64> = (first..=last).map(|k| k as f64 * step).collect();

        let mag = lo.abs().max(hi.abs());
        // Labels would need 4+ significant digits: subtract a round offset instead.
        let (offset, offset_digits) = if mag / step >= 1e3 {
            let unit = 10f64.powi((hi - lo).log10().ceil() as i32);
            let offset = ((lo + hi) / 2.0 / unit).round() * unit;
            let digits = (offset.abs().log10().floor() - unit.log10().round()) as usize + 1;
            (offset, digits)
        } else {
            (0.0, 0)
        };
        let shifted = (lo - offset).abs().max((hi - offset).abs());
        let e = (shifted.log10() + 1e-9).floor() as i32;
        // Plain numbers up to 99999 (iteration counts) and down to 0.01.
        let exp = if (-2..=4).contains(&e) { 0 } else { e };
        let decimals = decimals_of(step / 10f64.powi(exp));
        Axis {
            lo,
            hi,
            ticks,
            kind: Kind::Linear {
                offset,
                offset_digits,
                exp,
                decimals,
            },
        }
    }

    /// A linear axis for the finite values in `values`, or `[-1, 1]` if there are none.
    pub fn linear_for(values: impl IntoIterator<Item = f64>, max_ticks: usize) -> Axis {
        let (lo, hi) = finite_range(values).unwrap_or((-1.0, 1.0));
        Axis::linear(lo, hi, max_ticks)
    }

    /// A logarithmic axis for data whose `log10` spans `[min_log, max_log]` (finite).
    pub fn log10(min_log: f64, max_log: f64, max_ticks: usize) -> Axis {
        let (lo, hi) = if max_log > min_log {
            let pad = 0.05 * (max_log - min_log);
            (min_log - pad, max_log + pad)
        } else {
            (min_log - 0.5, min_log + 0.5)
        };
        let max_ticks = max_ticks.max(2);
        let (d0, d1) = (lo.ceil() as i64, hi.floor() as i64);
        let mut ticks: Vec<f64> = if d1 - d0 + 1 >= 2 {
            let stride = ((d1 - d0 + 1) as usize).div_ceil(max_ticks).max(1) as i64;
            (d0..=d1)
                .filter(|k| k.rem_euclid(stride) == 0)
                .map(|k| k as f64)
                .collect()
        } else {
            Vec::new()
        };
        if ticks.len() < 3 {
            // Under three decades visible: 1-2-5 ticks, then every mantissa if still sparse.
            for mantissas in [
                &[1.0, 2.0, 5.0][..],
                &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0],
            ] {
                ticks = (lo.floor() as i64..=hi.ceil() as i64)
                    .flat_map(|k| mantissas.iter().map(move |m| k as f64 + f64::log10(*m)))
                    .filter(|t| (lo..=hi).contains(t))
                    .collect();
                if ticks.len() >= 3 {
                    break;
                }
            }
        }
        Axis {
            lo,
            hi,
            ticks,
            kind: Kind::Log10 {
                plain: lo >= -2.0 - 1e-9 && hi < 4.0,
            },
        }
    }

    /// A logarithmic axis for the positive finite values in `values` (others are ignored),
    /// or `[10⁻¹, 10¹]` if there are none.
    pub fn log10_for(values: impl IntoIterator<Item = f64>, max_ticks: usize) -> Axis {
        let logs = values.into_iter().filter(|v| *v > 0.0).map(f64::log10);
        let (lo, hi) = finite_range(logs).unwrap_or((-1.0, 1.0));
        Axis::log10(lo, hi, max_ticks)
    }

    /// Drops ticks closer than `fraction` of the span to either end, keeping at least one, so
    /// labels of side-by-side panels do not run into each other.
    pub fn drop_edge_ticks(&mut self, fraction: f64) {
        let margin = fraction * (self.hi - self.lo);
        let inner: Vec<f64> = self
            .ticks
            .iter()
            .copied()
            .filter(|t| *t - self.lo >= margin && self.hi - *t >= margin)
            .collect();
        if !inner.is_empty() {
            self.ticks = inner;
        }
    }

    /// Data value → plotted coordinate; `None` for values that cannot be shown (non-finite,
    /// or ≤ 0 on a log axis).
    pub fn to_plot(&self, v: f64) -> Option<f64> {
        let p = match self.kind {
            Kind::Log10 { .. } if v > 0.0 => v.log10(),
            Kind::Log10 { .. } => return None,
            Kind::Linear { .. } => v,
        };
        p.is_finite().then_some(p)
    }

    /// The label printed at tick `t` (plotted coordinate).
    pub fn label(&self, t: f64) -> String {
        match self.kind {
            Kind::Linear {
                offset,
                exp,
                decimals,
                ..
            } => {
                let v = (t - offset) / 10f64.powi(exp);
                crate::numfmt::format::fix_negative_zero(format!("{v:.decimals$}"))
            }
            Kind::Log10 { plain: true } => fmt_sig(10f64.powf(t), 1),
            Kind::Log10 { plain: false } => {
                let k = t.round();
                if (t - k).abs() < 1e-6 {
                    format!("10{}", superscript(k as i32))
                } else {
                    let e = t.floor();
                    let m = 10f64.powf(t - e).round();
                    format!("{m:.0}×10{}", superscript(e as i32))
                }
            }
        }
    }

    /// The axis title for a quantity called `name` measured in `unit` (empty: none), the
    /// scale in brackets: `w1sq [10⁻⁶ s⁻²]`, `w1sq + 1.3×10⁻⁶ [10⁻¹⁰ s⁻²]` (ticks show
    /// `(w1sq + 1.3×10⁻⁶ s⁻²)/(10⁻¹⁰ s⁻²)`), `dt1 [s]`, `a_df`, `d21 [10⁻⁴]`.
    pub fn desc_unit(&self, name: &str, unit: &str) -> String {
        let (shifted, exp) = match self.kind {
            Kind::Linear {
                offset,
                offset_digits,
                exp,
                ..
            } => {
                if offset == 0.0 {
                    (name.to_string(), exp)
                } else {
                    let sign = if offset < 0.0 { '+' } else { '−' };
                    let off = fmt_axis_number(offset.abs(), offset_digits.max(1));
                    (format!("{name} {sign} {off}"), exp)
                }
            }
            Kind::Log10 { .. } => (name.to_string(), 0),
        };
        match (exp, unit.is_empty()) {
            (0, true) => shifted,
            (0, false) => format!("{shifted} [{unit}]"),
            (e, true) => format!("{shifted} [10{}]", superscript(e)),
            (e, false) => format!("{shifted} [10{} {unit}]", superscript(e)),
        }
    }

    /// The axis title for a quantity called `name`, stating any offset and power of ten.
    pub fn desc(&self, name: &str) -> String {
        match self.kind {
            Kind::Linear {
                offset,
                offset_digits,
                exp,
                ..
            } => {
                let shifted = if offset == 0.0 {
                    name.to_string()
                } else {
                    let sign = if offset < 0.0 { '+' } else { '−' };
                    let off = fmt_axis_number(offset.abs(), offset_digits.max(1));
                    format!("({name} {sign} {off})")
                };
                if exp == 0 {
                    shifted
                } else {
                    format!("{shifted} / 10{}", superscript(exp))
                }
            }
            Kind::Log10 { .. } => name.to_string(),
        }
    }
}

/// Reduces a polyline to at most four points per horizontal bucket (first, lowest, highest,
/// last; the "M4" scheme), which draws the same picture at `buckets` pixels of width while
/// keeping SVG files small. Points are in plotted coordinates; `x_range` is the visible range.
pub(crate) fn decimate(
    points: &[(f64, f64)],
    x_range: (f64, f64),
    buckets: usize,
) -> Vec<(f64, f64)> {
    if points.len() <= 4 * buckets.max(1) {
        return points.to_vec();
    }
    let (lo, hi) = x_range;
    let width = (hi - lo).max(f64::MIN_POSITIVE);
    let bucket_of = |x: f64| ((x - lo) / width * buckets as f64).floor() as i64;
    let mut out = Vec::with_capacity(4 * buckets + 4);
    let mut start = 0;
    while start < points.len() {
        let b = bucket_of(points[start].0);
        let mut end = start + 1;
        while end < points.len() && bucket_of(points[end].0) == b {
            end += 1;
        }
        let run = &points[start..end];
        let (mut imin, mut imax) = (0, 0);
        for (i, p) in run.iter().enumerate() {
            if p.1 < run[imin].1 {
                imin = i;
            }
            if p.1 > run[imax].1 {
                imax = i;
            }
        }
        let mut keep = [0, imin.min(imax), imin.max(imax), run.len() - 1];
        keep.sort_unstable();
        let mut prev = usize::MAX;
        for i in keep {
            if i != prev {
                out.push(run[i]);
                prev = i;
            }
        }
        start = end;
    }
    out
}

/// Splits a sequence of plotted points at the `None`s (values that cannot be shown), so a
/// NaN leaves a gap instead of a line to nowhere.
pub(crate) fn segments(
    points: impl IntoIterator<Item = Option<(f64, f64)>>,
) -> Vec<Vec<(f64, f64)>> {
    let mut out = vec![Vec::new()];
    for p in points {
        match p {
            Some(p) => out.last_mut().expect("never empty").push(p),
            None if !out.last().expect("never empty").is_empty() => out.push(Vec::new()),
            None => {}
        }
    }
    out.retain(|s| !s.is_empty());
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn labels(a: &Axis) -> Vec<String> {
        a.ticks.iter().map(|&t| a.label(t)).collect()
    }

    #[test]
    fn tiny_spread_gets_an_offset_and_short_distinct_labels() {
        let a = Axis::linear(-1.29998e-6 - 4e-10, -1.29998e-6 + 4e-10, 5);
        let l = labels(&a);
        assert!(l.len() >= 3, "{l:?}");
        let mut dedup = l.clone();
        dedup.dedup();
        assert_eq!(dedup, l, "labels must be distinct");
        assert!(l.iter().all(|s| s.len() <= 5), "{l:?}");
        assert_eq!(a.desc("ω₁²"), "(ω₁² + 1.300×10⁻⁶) / 10⁻¹⁰");
        // Every tick lies in the visible range.
        assert!(a.ticks.iter().all(|t| (a.lo..=a.hi).contains(t)));
    }

    #[test]
    fn unit_titles_put_scale_and_unit_in_brackets() {
        let a = Axis::linear(0.0, 3e-6, 5);
        assert_eq!(a.desc_unit("w1sq", "s⁻²"), "w1sq [10⁻⁶ s⁻²]");
        assert_eq!(a.desc_unit("d21", ""), "d21 [10⁻⁶]");
        let b = Axis::linear(0.2, 0.9, 5);
        assert_eq!(b.desc_unit("dt1", "s"), "dt1 [s]");
        assert_eq!(b.desc_unit("a_df", ""), "a_df");
        let c = Axis::linear(-1.29998e-6 - 4e-10, -1.29998e-6 + 4e-10, 5);
        assert_eq!(c.desc_unit("w1sq", "s⁻²"), "w1sq + 1.300×10⁻⁶ [10⁻¹⁰ s⁻²]");
        let d = Axis::log10(-2.0, 1.0, 5);
        assert_eq!(d.desc_unit("f", "Hz"), "f [Hz]");
    }

    #[test]
    fn small_magnitudes_factor_out_a_power_of_ten() {
        let a = Axis::linear(0.0, 3e-6, 5);
        assert_eq!(a.desc("x"), "x / 10⁻⁶");
        assert_eq!(labels(&a), ["0", "1", "2", "3"]);
        let b = Axis::linear(0.2, 0.9, 5);
        assert_eq!(b.desc("A"), "A");
        assert_eq!(labels(&b), ["0.2", "0.4", "0.6", "0.8"]);
    }

    #[test]
    fn constant_series_still_gets_ticks() {
        let a = Axis::linear(0.8, 0.8, 5);
        assert!(a.lo < 0.8 && a.hi > 0.8);
        assert!(a.ticks.len() >= 3);
        let z = Axis::linear(0.0, 0.0, 5);
        assert_eq!((z.lo, z.hi), (-1.0, 1.0));
    }

    #[test]
    fn log_axis_ticks_decades_or_mantissas() {
        let a = Axis::log10(-6.0, 2.0, 5);
        assert_eq!(labels(&a), ["10⁻⁶", "10⁻⁴", "10⁻²", "10⁰", "10²"]);
        // Under a decade: every mantissa, printed plainly inside [10⁻², 10⁴].
        let b = Axis::log10(0.1, 0.9, 5);
        assert_eq!(labels(&b), ["2", "3", "4", "5", "6", "7", "8"]);
        // SNR 5..100: 1-2-5 steps.
        let c = Axis::log10_for([5.0, 100.0], 5);
        assert_eq!(labels(&c), ["5", "10", "20", "50", "100"]);
        // Mixed: 2×10⁻⁵ .. 3×10⁻⁴ Hz, outside the plain window.
        let d = Axis::log10_for([2e-5, 3e-4], 5);
        assert_eq!(labels(&d), ["2×10⁻⁵", "5×10⁻⁵", "10⁻⁴", "2×10⁻⁴"]);
        assert!(a.to_plot(-1.0).is_none() && a.to_plot(0.0).is_none());
        assert_eq!(a.to_plot(100.0), Some(2.0));
    }

    #[test]
    fn decimation_keeps_extremes_and_endpoints() {
        let pts: Vec<(f64, f64)> = (0..10_000)
            .map(|i| (i as f64, ((i * 7919) % 1000) as f64))
            .collect();
        let d = decimate(&pts, (0.0, 10_000.0), 100);
        assert!(d.len() <= 400, "{}", d.len());
        assert_eq!(d.first(), pts.first());
        assert_eq!(d.last(), pts.last());
        let max = d.iter().map(|p| p.1).fold(f64::MIN, f64::max);
        let min = d.iter().map(|p| p.1).fold(f64::MAX, f64::min);
        assert_eq!((min, max), (0.0, 999.0));
        // x stays in order, so the polyline is drawn left to right.
        assert!(d.windows(2).all(|w| w[0].0 < w[1].0));
    }

    #[test]
    fn nan_splits_segments() {
        let s = segments([
            Some((0.0, 1.0)),
            None,
            None,
            Some((2.0, 3.0)),
            Some((3.0, 4.0)),
            None,
        ]);
        assert_eq!(s, vec![vec![(0.0, 1.0)], vec![(2.0, 3.0), (3.0, 4.0)]]);
    }
}
