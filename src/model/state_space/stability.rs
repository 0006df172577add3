//! Stability of a real state matrix from its eigenvalues.

use super::def::TimeDomain;
use nalgebra::DMatrix;

/// Largest entry of A whose eigenvalues are computed (the square root of the largest `f64`,
/// with room for sums of products).
const MAX_ENTRY: f64 = 1e150;

/// `Ok` when every eigenvalue of the `n × n` row-major `a` lies in the stable region
/// (continuous: real part < 0; discrete: modulus < 1); else the offending eigenvalue,
/// described for a message.
pub fn check_stable(a: &[f64], n: usize, time: TimeDomain) -> Result<(), String> {
    if let Some(x) = a.iter().find(|x| !x.is_finite()) {
        return Err(format!("the state matrix has an entry {x}, not finite"));
    }
    if n == 0 {
        return Ok(());
    }
    // the eigenvalue solver squares entries: beyond this it overflows and reports nonsense
    // (1e308 gave the eigenvalue 0)
    if let Some(x) = a.iter().find(|x| x.abs() > MAX_ENTRY) {
        return Err(format!(
            "the state matrix has an entry {x:e}, beyond ±{MAX_ENTRY:e}, where its eigenvalues \
             cannot be computed: write the states in units that keep A's entries (rates) moderate"
        ));
    }
    let m = DMatrix::from_row_slice(n, n, a);
    let eig = m.complex_eigenvalues();
    let mut worst: Option<num_complex::Complex<f64>> = None;
    for z in eig.iter() {
        let bad = match time {
            TimeDomain::Continuous => z.re >= 0.0,
            TimeDomain::Discrete => z.norm() >= 1.0,
        };
        let worse = |w: &num_complex::Complex<f64>| match time {
            TimeDomain::Continuous => z.re > w.re,
            TimeDomain::Discrete => z.norm() > w.norm(),
        };
        // nalgebra gives a real eigenvalue of a 2×2 block with a vanishing discriminant a NaN
        // imaginary part (seen at a corner of examples/cross-talk.toml's box): the real part,
        // which decides, is sound then; a NaN real part is not
        if !z.re.is_finite() {
            return Err(format!(
                "the eigenvalues of the state matrix could not be computed (got {z}): check A's \
                 entries"
            ));
        }
        if bad && worst.as_ref().is_none_or(worse) {
            worst = Some(num_complex::Complex::new(z.re, z.im));
        }
    }
    match worst {
        None => Ok(()),
        Some(z) => Err(match time {
            TimeDomain::Continuous => format!(
                "the system is unstable: A has the eigenvalue {:.4e} {} {:.4e}i with real part ≥ 0 \
                 (every eigenvalue of a continuous-time A needs a negative real part)",
                z.re,
                if z.im < 0.0 { "−" } else { "+" },
                z.im.abs()
            ),
            TimeDomain::Discrete => format!(
                "the system is unstable: A has the eigenvalue {:.4e} {} {:.4e}i of modulus {:.6} ≥ 1 \
                 (every eigenvalue of a discrete-time A must lie inside the unit circle)",
                z.re,
                if z.im < 0.0 { "−" } else { "+" },
                z.im.abs(),
                z.norm()
            ),
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn continuous_and_discrete_regions() {
        // oscillator with damping: eigenvalues −0.1 ± i·1.4
        let a = [0.0, 1.0, -2.0, -0.2];
        assert!(check_stable(&a, 2, TimeDomain::Continuous).is_ok());
        let e = check_stable(&[0.0, 1.0, -2.0, 0.2], 2, TimeDomain::Continuous).unwrap_err();
        assert!(e.contains("unstable") && e.contains("1.0000e-1"), "{e}");
        assert!(check_stable(&[0.5, 0.0, 0.0, -0.9], 2, TimeDomain::Discrete).is_ok());
        assert!(check_stable(&[1.0], 1, TimeDomain::Discrete).is_err());
        assert!(check_stable(&[f64::NAN], 1, TimeDomain::Continuous).is_err());
        // an entry the solver would square past the largest float is named, not "unstable"
        let e = check_stable(&[0.0, 1e308, -1.0, -0.2], 2, TimeDomain::Continuous).unwrap_err();
        assert!(e.contains("1e308") && !e.contains("unstable"), "{e}");
    }
}
