//! Numbers of any size in a few characters: huge and tiny values in short scientific form,
//! non-finite values spelled out, and Bayes factors as powers of ten when `exp(ln B)` leaves
//! the range of `f64`.

use super::format::fmt_sig;

/// `x` in at most a dozen characters: 3 significant digits (plain between 1e-3 and 1e5,
/// scientific outside, as [`fmt_sig`]), `∞`, `−∞` or `NaN`.
///
/// ```
/// use occam::report::fmt_short;
/// assert_eq!(fmt_short(1.23456e300), "1.23e300");
/// assert_eq!(fmt_short(0.5), "0.500");
/// assert_eq!(fmt_short(f64::NEG_INFINITY), "−∞");
/// ```
pub fn fmt_short(x: f64) -> String {
    fmt_short_sig(x, 3)
}

/// As [`fmt_short`] with `digits` significant digits.
pub fn fmt_short_sig(x: f64, digits: usize) -> String {
    if x.is_nan() {
        "NaN".into()
    } else if x == f64::INFINITY {
        "∞".into()
    } else if x == f64::NEG_INFINITY {
        "−∞".into()
    } else {
        fmt_sig(x, digits)
    }
}

/// `x` with `decimals` digits after the point when `|x| < 10⁶` (a table column of ln B,
/// R-hat, σ ratios), else in short scientific form with `decimals + 1` significant digits, so
/// that `ln B = 1e300` takes 8 characters, not 304; `∞`, `−∞`, `NaN` spelled out.
///
/// ```
/// use occam::report::fmt_fixed;
/// assert_eq!(fmt_fixed(2.34567, 3), "2.346");
/// assert_eq!(fmt_fixed(-1e300, 3), "-1.000e300");
/// ```
pub fn fmt_fixed(x: f64, decimals: usize) -> String {
    if x.is_finite() && x.abs() < 1e6 {
        format!("{x:.decimals$}")
    } else {
        fmt_short_sig(x, decimals + 1)
    }
}

/// `x` exactly (the shortest string that reads back to the same `f64`), plain between 1e-4
/// and 1e6 and scientific outside: for values a user copies into a study file (TOML reads
/// both forms), e.g. `0.8`, `1.963e-7`, `2.5e12`.
///
/// ```
/// use occam::report::fmt_roundtrip;
/// assert_eq!(fmt_roundtrip(0.8), "0.8");
/// assert_eq!(fmt_roundtrip(-1.963e-7), "-1.963e-7");
/// ```
pub fn fmt_roundtrip(x: f64) -> String {
    if x == 0.0 || !x.is_finite() || (1e-4..1e6).contains(&x.abs()) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// A Bayes factor `B = exp(ln_b)` for a table: `{:.4e}` (`1.2346e3`, `1.2000e-13`) while `B`
/// is a normal `f64`; beyond (`|ln B| ≳ 708`, where `exp` overflows to ∞ or underflows to 0
/// or a subnormal without precision) the power of ten `10^868.6` (= exp(2000)), never `inf`
/// or `0`. An infinite `ln B` gives `∞` or `0` (the model has no mass at all), NaN `NaN`.
///
/// ```
/// use occam::report::fmt_bayes_factor;
/// assert_eq!(fmt_bayes_factor(2000.0), "10^868.6");
/// assert_eq!(fmt_bayes_factor(-2000.0), "10^-868.6");
/// assert_eq!(fmt_bayes_factor(0.0), "1.0000e0");
/// ```
pub fn fmt_bayes_factor(ln_b: f64) -> String {
    if ln_b.is_nan() {
        return "NaN".into();
    }
    if ln_b == f64::INFINITY {
        return "∞".into();
    }
    if ln_b == f64::NEG_INFINITY {
        return "0".into();
    }
    let b = ln_b.exp();
    if b.is_normal() {
        return format!("{b:.4e}");
    }
    let log10 = ln_b / std::f64::consts::LN_10;
    if log10.abs() < 1e6 {
        format!("10^{log10:.1}")
    } else {
        format!("10^{}", fmt_sig(log10, 4))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bayes_factor_edges() {
        // inside the normal range: exp(ln B) printed as before
        assert_eq!(fmt_bayes_factor(0.0), "1.0000e0");
        assert_eq!(fmt_bayes_factor(-29.9336), "1.0000e-13");
        assert_eq!(fmt_bayes_factor(709.78), "1.7928e308");
        // exp(709.8) overflows: 709.8 / ln 10 = 308.26
        assert_eq!(fmt_bayes_factor(709.8), "10^308.3");
        // exp(−709.8) is a subnormal (precision lost): the power of ten
        assert!(!(-709.8f64).exp().is_normal());
        assert_eq!(fmt_bayes_factor(-709.8), "10^-308.3");
        // exp(−708) = 3.3076e-308 is still normal
        assert_eq!(fmt_bayes_factor(-708.0), "3.3076e-308");
        // 2000 / ln 10 = 868.589
        assert_eq!(fmt_bayes_factor(2000.0), "10^868.6");
        // ±1e4 / ln 10 = ±4342.94
        assert_eq!(fmt_bayes_factor(1e4), "10^4342.9");
        assert_eq!(fmt_bayes_factor(-1e4), "10^-4342.9");
        // 1e300 / ln 10 = 4.343e299
        assert_eq!(fmt_bayes_factor(1e300), "10^4.343e299");
        assert_eq!(fmt_bayes_factor(f64::NAN), "NaN");
        assert_eq!(fmt_bayes_factor(f64::INFINITY), "∞");
        assert_eq!(fmt_bayes_factor(f64::NEG_INFINITY), "0");
        for v in [-1e4, -709.8, -2000.0, 0.0, 709.8, 2000.0, 1e4] {
            let s = fmt_bayes_factor(v);
            assert!(!s.contains("inf") && s != "0" && s.len() <= 12, "{v}: {s}");
        }
    }

    #[test]
    fn short_and_fixed_forms() {
        assert_eq!(fmt_short(1.23456e300), "1.23e300");
        assert_eq!(fmt_short(-4.5e-200), "-4.50e-200");
        assert_eq!(fmt_short(0.0), "0");
        assert_eq!(fmt_short(12345.0), "12300");
        assert_eq!(fmt_short(f64::INFINITY), "∞");
        assert_eq!(fmt_short(f64::NEG_INFINITY), "−∞");
        assert_eq!(fmt_short(f64::NAN), "NaN");
        assert_eq!(fmt_fixed(2.34567, 3), "2.346");
        assert_eq!(fmt_fixed(-2000.0, 3), "-2000.000");
        assert_eq!(fmt_fixed(999_999.0, 0), "999999");
        assert_eq!(fmt_fixed(1e6, 0), "1e6");
        assert_eq!(fmt_fixed(-1e300, 3), "-1.000e300");
        assert_eq!(fmt_fixed(f64::INFINITY, 4), "∞");
        assert_eq!(fmt_fixed(f64::NAN, 4), "NaN");
        assert_eq!(fmt_roundtrip(0.8), "0.8");
        assert_eq!(fmt_roundtrip(1e-4), "0.0001");
        assert_eq!(fmt_roundtrip(9.99e-5), "9.99e-5");
        assert_eq!(fmt_roundtrip(2.5e12), "2.5e12");
        assert_eq!(fmt_roundtrip(-0.0), "-0");
        for x in [0.1 + 0.2, 1.963e-7, -3.3e300, 123456.789] {
            assert_eq!(fmt_roundtrip(x).parse::<f64>().unwrap(), x);
        }
    }
}
