//! Posteriors the data leave nearly degenerate: two parameters correlated beyond
//! [`CORRELATION_LIMIT`], or a combination of several that the correlation matrix's condition
//! number ([`CONDITION_LIMIT`]) betrays. Their separate errors, R-hat and ESS then describe a
//! ridge, not the parameters, and a run says so ([`degeneracy_warning`]).
//!
//! A Fisher matrix that is singular to rounding is another case, named by
//! [`super::describe_unconstrained`]; this one is the wide range above it, where the
//! factorisation succeeds and every number looks ordinary (gating that left 18 % of an
//! experiment: σ(`w1sq`) 600× the ungated one, `w1sq`–`w2sq` at ρ = 0.99995, no word).

use crate::linalg::{SpdOptions, format_direction, symmetric_eigen, weakest_direction};
use nalgebra::DMatrix;

/// Two parameters whose posterior correlation exceeds this in magnitude are named: each one's
/// σ is then at least 7× the σ it would have were the other known.
pub const CORRELATION_LIMIT: f64 = 0.99;

/// A posterior correlation matrix whose condition number exceeds this is near-degenerate even
/// when no pair exceeds [`CORRELATION_LIMIT`] (a combination of three or more parameters):
/// its weakest direction is named. A pair at 0.99 alone gives 199; the project's studies
/// without a degeneracy give 9–94.
pub const CONDITION_LIMIT: f64 = 1e4;

/// What makes a posterior near-degenerate, from the Fisher matrix at its maximum.
#[derive(Debug, Clone, PartialEq)]
pub struct Degeneracy {
    /// Pairs `(i, j, ρ_ij)` of the matrix's rows with `|ρ| >` [`CORRELATION_LIMIT`], strongest
    /// first.
    pub pairs: Vec<(usize, usize, f64)>,
    /// Condition number of the posterior correlation matrix (largest ÷ smallest eigenvalue).
    pub condition: f64,
    /// Per row, `σ_i` ÷ the σ it would have with every other parameter known: `√(C_ii F_ii)`,
    /// with `C = F⁻¹` (1 for a parameter correlated with none).
    pub inflation: Vec<f64>,
}

impl Degeneracy {
    /// The degeneracy of the Gaussian posterior whose Fisher matrix is `fisher`; `None` when it
    /// is not near-degenerate, or singular (which [`super::describe_unconstrained`] names).
    pub fn of(fisher: &DMatrix<f64>) -> Option<Self> {
        let n = fisher.nrows();
        if n < 2 {
            return None;
        }
        let c = SpdOptions::lower().jacobi().factor(fisher).ok()?.inverse();
        let sd: Vec<f64> = (0..n).map(|i| c[(i, i)].sqrt()).collect();
        if sd.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
            return None;
        }
        let rho = DMatrix::from_fn(n, n, |i, j| c[(i, j)] / (sd[i] * sd[j]));
        let mut pairs: Vec<(usize, usize, f64)> = (0..n)
            .flat_map(|i| (i + 1..n).map(move |j| (i, j)))
            .map(|(i, j)| (i, j, rho[(i, j)]))
            .filter(|p| p.2.abs() > CORRELATION_LIMIT)
            .collect();
        pairs.sort_by(|p, q| q.2.abs().total_cmp(&p.2.abs()));
        let eig = symmetric_eigen(rho).eigenvalues;
        let (lo, hi) = eig
            .iter()
            .fold((f64::INFINITY, 0.0f64), |(l, h), &v| (l.min(v), h.max(v)));
        let condition = if lo > 0.0 { hi / lo } else { f64::INFINITY };
        let inflation = (0..n)
            .map(|i| (c[(i, i)] * fisher[(i, i)]).max(1.0).sqrt())
            .collect();
        (!pairs.is_empty() || condition > CONDITION_LIMIT).then_some(Self {
            pairs,
            condition,
            inflation,
        })
    }
}

/// The warning for a near-degenerate posterior whose Fisher matrix at `at` (e.g. "MAP") is
/// `fisher`, over the parameters `names` (its rows): the correlated pairs, how much each
/// named parameter's σ is inflated by the others, the condition number and, without a pair,
/// the weakest direction; and what to do. `None` when [`Degeneracy::of`] finds nothing.
///
/// ```
/// use nalgebra::DMatrix;
/// use occam::likelihood::degeneracy_warning;
/// // a and b with posterior correlation 0.999: C = [[1, .999], [.999, 1]], F = C⁻¹
/// let f = DMatrix::from_row_slice(2, 2, &[1.0, -0.999, -0.999, 1.0]) / (1.0 - 0.999f64.powi(2));
/// let names = ["a".to_string(), "b".to_string()];
/// let w = degeneracy_warning(&f, &names, "MAP").unwrap();
/// assert!(w.contains("`a` and `b` correlated at ρ = +0.9990"), "{w}");
/// let f = DMatrix::from_row_slice(2, 2, &[1.0, 0.5, 0.5, 1.0]);
/// assert!(degeneracy_warning(&f, &names, "MAP").is_none());
/// ```
pub fn degeneracy_warning(fisher: &DMatrix<f64>, names: &[String], at: &str) -> Option<String> {
    let d = Degeneracy::of(fisher)?;
    let name = |i: usize| names.get(i).cloned().unwrap_or_else(|| format!("#{i}"));
    let mut named: Vec<usize> = Vec::new();
    let what = if d.pairs.is_empty() {
        let dir = weakest_direction(fisher)?;
        named.extend(dir.weights.iter().map(|w| w.0));
        format!(
            "no two parameters are correlated beyond {CORRELATION_LIMIT}, but its weakest direction is {}",
            format_direction(&dir, names)
        )
    } else {
        d.pairs
            .iter()
            .map(|&(i, j, r)| {
                for k in [i, j] {
                    if !named.contains(&k) {
                        named.push(k);
                    }
                }
                format!(
                    "`{}` and `{}` correlated at ρ = {}",
                    name(i),
                    name(j),
                    fmt_correlation(r)
                )
            })
            .collect::<Vec<_>>()
            .join(", ")
    };
    let inflated = named
        .iter()
        .map(|&i| {
            format!(
                "σ(`{}`) {}×",
                name(i),
                crate::numfmt::fmt_short(d.inflation[i])
            )
        })
        .collect::<Vec<_>>()
        .join(", ");
    Some(format!(
        "the posterior is nearly degenerate (Fisher matrix at the {at}): {what}; {inflated} what each would be with the other parameters known; condition number of the correlation matrix {}. The data constrain a combination of these parameters, not each: their separate errors, R-hat and ESS describe that ridge. Quote the combination, fix one of them (`fixed`), or add data that separate them",
        crate::numfmt::fmt_short(d.condition)
    ))
}

/// `ρ` with enough decimals that it does not round to ±1 (`round(−log₁₀(1 − |ρ|)) + 1`, at
/// least 4): `+0.9990`, `−0.99995`.
fn fmt_correlation(r: f64) -> String {
    let gap = 1.0 - r.abs();
    let decimals = if gap > 0.0 {
        ((-gap.log10()).round() as usize + 1).clamp(4, 15)
    } else {
        4
    };
    let s = format!("{:.*}", decimals, r.abs());
    format!("{}{s}", if r < 0.0 { '−' } else { '+' })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(n: usize) -> Vec<String> {
        (0..n).map(|i| format!("p{i}")).collect()
    }

    /// The Fisher matrix of a Gaussian posterior with standard deviations `sd` and correlation
    /// matrix `rho`.
    fn fisher_of(sd: &[f64], rho: &DMatrix<f64>) -> DMatrix<f64> {
        let n = sd.len();
        let c = DMatrix::from_fn(n, n, |i, j| rho[(i, j)] * sd[i] * sd[j]);
        c.try_inverse().unwrap()
    }

    #[test]
    fn a_pair_beyond_the_limit_is_named_with_its_correlation_and_inflation() {
        // units 10¹⁸ apart, as ω² and delays are: the correlation does not see them
        let sd = [1e-9, 1.0, 0.3];
        for (r, flagged) in [(0.995f64, true), (-0.9999, true), (0.985, false)] {
            let q = 0.05 * r.signum();
            let rho = DMatrix::from_row_slice(3, 3, &[1.0, r, 0.05, r, 1.0, q, 0.05, q, 1.0]);
            let f = fisher_of(&sd, &rho);
            let d = Degeneracy::of(&f);
            assert_eq!(d.is_some(), flagged, "ρ = {r}");
            let Some(d) = d else { continue };
            assert_eq!(d.pairs.len(), 1);
            let (i, j, got) = d.pairs[0];
            assert_eq!((i, j), (0, 1));
            assert!((got - r).abs() < 1e-9, "{got} against {r}");
            // with the third parameter nearly independent, σ_0 ÷ σ_0|rest ≈ 1/√(1 − ρ²)
            let want = 1.0 / (1.0 - r * r).sqrt();
            assert!(
                (d.inflation[0] / want - 1.0).abs() < 0.05,
                "{} against {want}",
                d.inflation[0]
            );
            assert!(d.inflation[2] < 1.1);
            let w = degeneracy_warning(&f, &names(3), "MAP").unwrap();
            assert!(
                w.contains(&format!(
                    "`p0` and `p1` correlated at ρ = {}",
                    fmt_correlation(r)
                )),
                "{w}"
            );
            assert!(!w.contains("`p2`"), "{w}");
        }
    }

    #[test]
    fn a_combination_of_three_without_a_strong_pair_is_found_by_the_condition_number() {
        // p2 = p0 + p1 to 1 part in 10³ of its spread: no pair beyond 0.99, the three together
        // degenerate
        let n = 200_000;
        let mut s = DMatrix::<f64>::zeros(3, 3);
        let mut rng = 1u64;
        let mut u = || {
            rng = rng
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (rng >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        for _ in 0..n {
            let (a, b) = (u(), u());
            let x = [a, b, a + b + 1e-3 * u()];
            for i in 0..3 {
                for j in 0..3 {
                    s[(i, j)] += x[i] * x[j] / n as f64;
                }
            }
        }
        let f = s.try_inverse().unwrap();
        let d = Degeneracy::of(&f).unwrap();
        assert!(d.pairs.is_empty(), "{:?}", d.pairs);
        assert!(d.condition > CONDITION_LIMIT, "{}", d.condition);
        let w = degeneracy_warning(&f, &names(3), "MAP").unwrap();
        assert!(w.contains("weakest direction"), "{w}");
        for p in ["p0", "p1", "p2"] {
            assert!(w.contains(&format!("σ(`{p}`)")), "{w}");
        }
    }

    #[test]
    fn a_correlation_never_reads_as_one() {
        assert_eq!(fmt_correlation(0.999), "+0.9990");
        assert_eq!(fmt_correlation(-0.99995), "−0.99995");
        assert_eq!(fmt_correlation(0.99999968), "+0.9999997");
        assert_eq!(fmt_correlation(0.9999999), "+0.99999990");
        assert_eq!(fmt_correlation(0.5), "+0.5000");
    }

    #[test]
    fn ordinary_singular_and_tiny_matrices_give_nothing() {
        // Table I's Fisher correlation (w1sq–w2sq 0.85) is far from the limits
        let rho = DMatrix::from_row_slice(2, 2, &[1.0, 0.854, 0.854, 1.0]);
        assert!(Degeneracy::of(&fisher_of(&[4.5e-10, 3.9e-10], &rho)).is_none());
        let singular = DMatrix::from_row_slice(2, 2, &[1.0, 1.0, 1.0, 1.0]);
        assert!(Degeneracy::of(&singular).is_none());
        assert!(Degeneracy::of(&DMatrix::from_element(1, 1, 2.0)).is_none());
        assert!(Degeneracy::of(&DMatrix::zeros(0, 0)).is_none());
        let nan = DMatrix::from_row_slice(2, 2, &[1.0, f64::NAN, f64::NAN, 1.0]);
        assert!(Degeneracy::of(&nan).is_none());
    }
}
