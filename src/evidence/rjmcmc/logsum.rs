//! `ln(eᵃ + eᵇ)`: the sums of the chains and the estimators are kept in logs.

/// `ln(eᵃ + eᵇ)`, exact for `−∞` arguments.
#[inline]
pub(crate) fn lae(a: f64, b: f64) -> f64 {
    if a == f64::NEG_INFINITY {
        return b;
    }
    if b == f64::NEG_INFINITY {
        return a;
    }
    if a >= b {
        a + (b - a).exp().ln_1p()
    } else {
        b + (a - b).exp().ln_1p()
    }
}
