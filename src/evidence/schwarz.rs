//! Schwarz criterion (SBIC, `ltp-model.md` §9.4).
//!
//! ```text
//! ln B_XY ≈ S = ln L(θ̂_X) − ln L(θ̂_Y) − ½ (D_X − D_Y) ln n
//! ```
//!
//! with `θ̂` the maximum-likelihood points and `n` the number of data values that make the Hessian
//! grow (for frequency-domain fits: 2 × bins × channels × experiments). The relative error
//! `(S − ln B)/ln B` vanishes as n → ∞ (Kass & Raftery 1995), but the absolute error is O(1):
//! the prior volume never enters. Written with ln L, so no χ² sign pitfall.

use super::error::EvidenceError;
use super::ln_b::LnB;
use super::method::Method;

/// The Schwarz proxy of one model, `ln L̂ − (D/2) ln n`.
pub fn schwarz_ln_z(ln_l_hat: f64, dim: usize, n: f64) -> Result<f64, EvidenceError> {
    check_n(n)?;
    if !ln_l_hat.is_finite() {
        return Err(EvidenceError::non_finite(
            "maximum ln L",
            ln_l_hat,
            "pass the finite log likelihood at the maximum",
        ));
    }
    Ok(ln_l_hat - 0.5 * dim as f64 * n.ln())
}

/// `ln B_XY ≈ Δ ln L̂ − ½ ΔD ln n`.
///
/// ```
/// use occam::evidence::schwarz::schwarz_ln_b;
/// // X has one more parameter and improves ln L by 3 on n = 100 data values.
/// let b = schwarz_ln_b(-50.0, 3, -53.0, 2, 100.0).unwrap();
/// assert!((b.ln_b - (3.0 - 0.5 * 100f64.ln())).abs() < 1e-12);
/// assert!(b.std_err.is_none());
/// ```
pub fn schwarz_ln_b(
    ln_l_hat_x: f64,
    dim_x: usize,
    ln_l_hat_y: f64,
    dim_y: usize,
    n: f64,
) -> Result<LnB, EvidenceError> {
    Ok(LnB {
        method: Method::Schwarz,
        ln_b: schwarz_ln_z(ln_l_hat_x, dim_x, n)? - schwarz_ln_z(ln_l_hat_y, dim_y, n)?,
        std_err: None,
    })
}

fn check_n(n: f64) -> Result<(), EvidenceError> {
    if !(n.is_finite() && n >= 1.0) {
        return Err(EvidenceError::option(
            "schwarz n",
            n,
            "the number of data values must be finite and ≥ 1",
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sign_and_validation() {
        // More parameters with no likelihood gain must be penalised.
        let b = schwarz_ln_b(-10.0, 5, -10.0, 3, 1000.0).unwrap();
        assert!((b.ln_b + 1000f64.ln()).abs() < 1e-12);
        assert!(schwarz_ln_b(-10.0, 5, -10.0, 3, 0.5).is_err());
        assert!(schwarz_ln_b(f64::NAN, 5, -10.0, 3, 10.0).is_err());
        assert!(schwarz_ln_z(-1.0, 1, f64::INFINITY).is_err());
    }
}
