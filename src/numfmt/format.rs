//! Number formatting for tables and axes: significant digits, values with uncertainties, and
//! the Kass–Raftery reading of a Bayes factor.

/// Decimal exponent of `x` after rounding to `digits` significant digits (`x` finite, ≠ 0).
///
/// Rust's `{:e}` formatting rounds exactly, so `9.9996` with 4 digits gives exponent 1
/// (`1.000e1`), which a `log10().floor()` would get wrong.
fn exponent_after_rounding(x: f64, digits: usize) -> i32 {
    let s = format!("{:.*e}", digits.saturating_sub(1), x);
    s.rsplit('e')
        .next()
        .and_then(|e| e.parse().ok())
        .unwrap_or(0)
}

/// Formats `value` with `digits` significant digits (clamped to 1..=17).
///
/// Plain notation when the decimal exponent is in `-3..=4` (digits beyond the requested ones
/// rounded to zero, `12345` → `12300`), otherwise Rust's scientific
/// notation (`1.30e-6`), which every spreadsheet and `numpy.loadtxt` reads back.
///
/// ```
/// use occam::report::fmt_sig;
/// assert_eq!(fmt_sig(0.812345, 3), "0.812");
/// assert_eq!(fmt_sig(-1.29998e-6, 3), "-1.30e-6");
/// assert_eq!(fmt_sig(99.96, 3), "100");
/// ```
pub fn fmt_sig(value: f64, digits: usize) -> String {
    let digits = digits.clamp(1, 17);
    if !value.is_finite() {
        return format!("{value}");
    }
    if value == 0.0 {
        return "0".into();
    }
    let e = exponent_after_rounding(value, digits);
    if (-3..=4).contains(&e) {
        let decimals = digits as i32 - 1 - e;
        if decimals >= 0 {
            let d = decimals as usize;
            format!("{value:.d$}")
        } else {
            // 12345 to 3 digits is 12300: don't print digits that were asked away.
            let unit = 10f64.powi(-decimals);
            format!("{:.0}", (value / unit).round() * unit)
        }
    } else {
        format!("{:.*e}", digits - 1, value)
    }
}

/// Formats a value with its one-sigma uncertainty, the number of digits set by `sigma`
/// (two significant digits of `sigma`, the value rounded at the same decimal place).
///
/// A shared power of ten is factored out when the value's exponent is outside `-2..=3`.
/// If `sigma` is not a positive finite number the value is shown with 6 significant digits
/// and `sigma` as given, so a table never hides that the uncertainty is missing.
///
/// ```
/// use occam::report::fmt_pm;
/// assert_eq!(fmt_pm(-1.29998e-6, 2.1e-10), "(-1.29998 ± 0.00021)e-6");
/// assert_eq!(fmt_pm(0.81234, 0.0034), "0.8123 ± 0.0034");
/// assert_eq!(fmt_pm(1234.0, 560.0), "1230 ± 560");
/// ```
pub fn fmt_pm(value: f64, sigma: f64) -> String {
    if !value.is_finite() {
        return format!("{value} ± {}", fmt_sig(sigma, 2));
    }
    if !(sigma.is_finite() && sigma > 0.0) {
        return format!("{} ± {sigma}", fmt_sig(value, 6));
    }
    // Position of the last digit shown: the second significant digit of sigma.
    let last = exponent_after_rounding(sigma, 2) - 1;
    let e_value = if value == 0.0 {
        i32::MIN
    } else {
        // Rounding at `last` may carry into a new leading digit (9.999996e-7 → 1.000000e-6);
        // the exponent that matters is the one after that rounding.
        let e = exponent_after_rounding(value, 17);
        let digits = e - last + 1;
        if digits < 1 {
            e
        } else {
            exponent_after_rounding(value, digits as usize)
        }
    };
    let common = e_value.max(last + 1);
    if (-2..=3).contains(&common) {
        if last >= 0 {
            let unit = 10f64.powi(last);
            let v = (value / unit).round() * unit;
            let s = (sigma / unit).round() * unit;
            format!("{} ± {s:.0}", fix_negative_zero(format!("{v:.0}")))
        } else {
            let d = (-last) as usize;
            format!(
                "{} ± {sigma:.d$}",
                fix_negative_zero(format!("{value:.d$}"))
            )
        }
    } else {
        let scale = 10f64.powi(common);
        let d = (common - last) as usize;
        let v = fix_negative_zero(format!("{:.d$}", value / scale));
        format!("({v} ± {:.d$})e{common}", sigma / scale)
    }
}

/// `-0.00` reads as a sign error in a table; the value is zero at the shown precision.
pub(crate) fn fix_negative_zero(s: String) -> String {
    if s.starts_with('-') && s.bytes().all(|b| matches!(b, b'-' | b'0' | b'.')) {
        s[1..].to_string()
    } else {
        s
    }
}

/// Unicode superscript of an integer, e.g. `-6` → `⁻⁶`, for axis labels.
pub(crate) fn superscript(n: i32) -> String {
    const DIGITS: [char; 10] = ['⁰', '¹', '²', '³', '⁴', '⁵', '⁶', '⁷', '⁸', '⁹'];
    let mut out = String::new();
    if n < 0 {
        out.push('⁻');
    }
    for c in n.unsigned_abs().to_string().bytes() {
        out.push(DIGITS[(c - b'0') as usize]);
    }
    out
}

/// `value` with `digits` significant digits for an axis: plain when its exponent is in
/// `-2..=3`, else `1.30×10⁻⁶`.
pub(crate) fn fmt_axis_number(value: f64, digits: usize) -> String {
    if !value.is_finite() || value == 0.0 {
        return fmt_sig(value, digits);
    }
    let digits = digits.clamp(1, 17);
    let e = exponent_after_rounding(value, digits);
    if (-2..=3).contains(&e) {
        return fmt_sig(value, digits);
    }
    let m = value / 10f64.powi(e);
    let d = digits - 1;
    format!("{m:.d$}×10{}", superscript(e))
}

/// Kass & Raftery (1995) reading of `ln_b = ln B_XY = ln Z_X − ln Z_Y`, X being the model
/// in the numerator.
///
/// On the scale of `|2 ln B|`: up to 2 "not worth more than a bare mention", above 2 up to 6
/// "positive", above 6 up to 10 "strong", above 10 "very strong". Each upper bound belongs to
/// the weaker class, matching the table's "> 10" for the strongest. The sign says which model
/// is preferred.
///
/// ```
/// use occam::report::kass_raftery;
/// assert_eq!(kass_raftery(0.5), "not worth more than a bare mention");
/// assert_eq!(kass_raftery(-4.0), "strong evidence for Y");
/// assert_eq!(kass_raftery(13.8), "very strong evidence for X");
/// ```
pub fn kass_raftery(ln_b: f64) -> &'static str {
    if ln_b.is_nan() {
        return "undefined (ln B is not a number)";
    }
    let two_ln_b = 2.0 * ln_b.abs();
    let x = ln_b > 0.0;
    if two_ln_b <= 2.0 {
        "not worth more than a bare mention"
    } else if two_ln_b <= 6.0 {
        if x {
            "positive evidence for X"
        } else {
            "positive evidence for Y"
        }
    } else if two_ln_b <= 10.0 {
        if x {
            "strong evidence for X"
        } else {
            "strong evidence for Y"
        }
    } else if x {
        "very strong evidence for X"
    } else {
        "very strong evidence for Y"
    }
}

/// The Kass & Raftery (1995) grade of `ln B_XY` naming the models, e.g. `"strong evidence for
/// Y over X"` with `x = "X"`, `y = "Y"` (the grades of [`kass_raftery`]).
///
/// ```
/// use occam::report::kass_raftery_named;
/// assert_eq!(kass_raftery_named(-4.0, "delay", "pole"), "strong evidence for pole over delay");
/// assert_eq!(kass_raftery_named(0.3, "delay", "pole"), "not worth more than a bare mention");
/// ```
pub fn kass_raftery_named(ln_b: f64, x: &str, y: &str) -> String {
    let grade = kass_raftery(ln_b);
    let (win, lose) = if ln_b > 0.0 { (x, y) } else { (y, x) };
    match grade
        .strip_suffix(" for X")
        .or_else(|| grade.strip_suffix(" for Y"))
    {
        Some(g) => format!("{g} for {win} over {lose}"),
        None => grade.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pm_digits_follow_sigma() {
        assert_eq!(fmt_pm(-1.29998e-6, 2.1e-10), "(-1.29998 ± 0.00021)e-6");
        assert_eq!(fmt_pm(-1.29998e-6, 2.14e-10), "(-1.29998 ± 0.00021)e-6");
        assert_eq!(fmt_pm(0.81234, 0.0034), "0.8123 ± 0.0034");
        assert_eq!(fmt_pm(0.81234, 0.034), "0.812 ± 0.034");
        assert_eq!(fmt_pm(12.345, 1.2), "12.3 ± 1.2");
        assert_eq!(fmt_pm(1234.0, 56.0), "1234 ± 56");
        assert_eq!(fmt_pm(1234.0, 560.0), "1230 ± 560");
        assert_eq!(fmt_pm(1.963, 0.001), "1.9630 ± 0.0010");
        assert_eq!(fmt_pm(3.2e7, 1.5e5), "(3.200 ± 0.015)e7");
    }

    #[test]
    fn pm_rounding_carries_into_the_exponent() {
        // 9.999996e-7 rounded at 1e-12 is 1.00000e-6: the exponent moves up, digits stay put.
        assert_eq!(fmt_pm(9.999996e-7, 2.1e-11), "(1.000000 ± 0.000021)e-6");
        // sigma 0.0996 rounds to 0.10 (two significant digits).
        assert_eq!(fmt_pm(0.5, 0.0996), "0.50 ± 0.10");
    }

    #[test]
    fn pm_value_smaller_than_sigma_and_degenerate_sigma() {
        assert_eq!(fmt_pm(1e-12, 2.1e-10), "(0.0 ± 2.1)e-10");
        assert_eq!(fmt_pm(0.0, 0.25), "0.00 ± 0.25");
        assert_eq!(fmt_pm(-0.001, 0.25), "0.00 ± 0.25");
        assert_eq!(fmt_pm(0.8, 0.0), "0.800000 ± 0");
        assert_eq!(fmt_pm(0.8, f64::NAN), "0.800000 ± NaN");
        assert_eq!(fmt_pm(f64::NAN, 0.1), "NaN ± 0.10");
    }

    #[test]
    fn sig_switches_notation_outside_the_plain_range() {
        assert_eq!(fmt_sig(0.812345, 3), "0.812");
        assert_eq!(fmt_sig(12345.0, 3), "12300");
        assert_eq!(fmt_sig(123456.0, 3), "1.23e5");
        assert_eq!(fmt_sig(0.001234, 2), "0.0012");
        assert_eq!(fmt_sig(0.0001234, 2), "1.2e-4");
        assert_eq!(fmt_sig(9.9996, 4), "10.00");
        assert_eq!(fmt_sig(0.0, 4), "0");
        assert_eq!(fmt_sig(f64::INFINITY, 4), "inf");
    }

    #[test]
    fn axis_numbers_use_superscripts() {
        assert_eq!(superscript(-10), "⁻¹⁰");
        assert_eq!(superscript(7), "⁷");
        assert_eq!(fmt_axis_number(-1.3e-6, 4), "-1.300×10⁻⁶");
        assert_eq!(fmt_axis_number(0.25, 2), "0.25");
    }

    #[test]
    fn kass_raftery_boundaries() {
        let bare = "not worth more than a bare mention";
        // |2 ln B| = 2 exactly is still a bare mention; just above is positive.
        assert_eq!(kass_raftery(0.0), bare);
        assert_eq!(kass_raftery(1.0), bare);
        assert_eq!(kass_raftery(-1.0), bare);
        assert_eq!(kass_raftery(1.0 + 1e-12), "positive evidence for X");
        assert_eq!(kass_raftery(-1.0 - 1e-12), "positive evidence for Y");
        assert_eq!(kass_raftery(3.0), "positive evidence for X");
        assert_eq!(kass_raftery(3.0 + 1e-12), "strong evidence for X");
        assert_eq!(kass_raftery(-5.0), "strong evidence for Y");
        assert_eq!(kass_raftery(5.0 + 1e-12), "very strong evidence for X");
        assert_eq!(kass_raftery(-50.0), "very strong evidence for Y");
        assert_eq!(kass_raftery(f64::INFINITY), "very strong evidence for X");
        assert_eq!(kass_raftery(f64::NAN), "undefined (ln B is not a number)");
    }
}
