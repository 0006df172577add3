//! Normalised, independent (product) priors.
//!
//! # Formula
//! `ln π(θ) = Σ_i ln π_i(θ_i)` with, per parameter,
//! * uniform on `[a, b]`: `−ln(b − a)` inside, `−∞` outside;
//! * Gaussian `N(μ, σ²)`: `−½ ln 2π − ln σ − (θ − μ)²/(2σ²)`;
//! * log-uniform on `[a, b]`, `0 < a < b`: `−ln θ − ln ln(b/a)` inside, `−∞` outside.
//!
//! The prior is validated once in [`Prior::new`]; afterwards every method is infallible.

use rand::Rng;
use rand::RngExt;
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};

/// One parameter's prior.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum PriorKind {
    /// Uniform on `[lo, hi]`.
    Uniform { lo: f64, hi: f64 },
    /// Gaussian with mean `mu` and standard deviation `sigma`.
    Gaussian { mu: f64, sigma: f64 },
    /// Uniform in `ln θ` on `[lo, hi]`, `0 < lo < hi`.
    LogUniform { lo: f64, hi: f64 },
}

/// Narrowest prior width: its square, the variance a proposal and a Fisher step take, is then
/// still a normal `f64`.
pub const MIN_WIDTH: f64 = 1.5e-154;

/// Narrowest prior width relative to its centre: room for about 10⁴ distinct values.
pub const MIN_RELATIVE_WIDTH: f64 = 1e-12;

/// Why a prior could not be built.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum PriorError {
    #[error("prior of `{name}`: {what}")]
    Invalid { name: String, what: String },
    #[error("prior: {names} names for {kinds} parameters")]
    Length { names: usize, kinds: usize },
}

impl PriorKind {
    /// The `[prior]` entry that writes this prior, every number in its shortest round-tripping
    /// form: for messages that tell a person what to edit.
    ///
    /// ```
    /// use occam::prior::PriorKind;
    /// let k = PriorKind::Uniform { lo: -1e-3, hi: 1e-3 };
    /// assert_eq!(k.entry(), "{ kind = \"uniform\", lo = -0.001, hi = 0.001 }");
    /// ```
    pub fn entry(&self) -> String {
        use crate::numfmt::fmt_roundtrip as r;
        match *self {
            PriorKind::Uniform { lo, hi } => {
                format!("{{ kind = \"uniform\", lo = {}, hi = {} }}", r(lo), r(hi))
            }
            PriorKind::LogUniform { lo, hi } => {
                format!(
                    "{{ kind = \"log_uniform\", lo = {}, hi = {} }}",
                    r(lo),
                    r(hi)
                )
            }
            PriorKind::Gaussian { mu, sigma } => {
                format!(
                    "{{ kind = \"gaussian\", mu = {}, sigma = {} }}",
                    r(mu),
                    r(sigma)
                )
            }
        }
    }

    /// The centre of the prior: box midpoint, Gaussian mean, geometric mean of a
    /// log-uniform box.
    ///
    /// ```
    /// use occam::prior::PriorKind;
    /// assert_eq!(PriorKind::Uniform { lo: 0.0, hi: 2.0 }.centre(), 1.0);
    /// assert_eq!(PriorKind::LogUniform { lo: 1.0, hi: 100.0 }.centre(), 10.0);
    /// ```
    pub fn centre(&self) -> f64 {
        match *self {
            PriorKind::Uniform { lo, hi } => 0.5 * (lo + hi),
            PriorKind::Gaussian { mu, .. } => mu,
            PriorKind::LogUniform { lo, hi } => (lo * hi).sqrt(),
        }
    }

    /// The marginal's standard deviation: `(hi − lo)/√12` of a box (log-uniform included, a
    /// spread in the parameter itself), `σ` of a Gaussian — the spread a proposal never needs
    /// to exceed.
    ///
    /// ```
    /// use occam::prior::PriorKind;
    /// assert_eq!(PriorKind::Gaussian { mu: 0.0, sigma: 2.0 }.sd(), 2.0);
    /// assert!((PriorKind::Uniform { lo: 0.0, hi: 12f64.sqrt() }.sd() - 1.0).abs() < 1e-15);
    /// ```
    pub fn sd(&self) -> f64 {
        match *self {
            PriorKind::Uniform { lo, hi } | PriorKind::LogUniform { lo, hi } => {
                (hi - lo) / 12f64.sqrt()
            }
            PriorKind::Gaussian { sigma, .. } => sigma,
        }
    }

    fn validate(&self, name: &str) -> Result<(), PriorError> {
        let bad = |what: String| {
            Err(PriorError::Invalid {
                name: name.to_string(),
                what,
            })
        };
        match *self {
            PriorKind::Uniform { lo, hi } => {
                if !(lo.is_finite() && hi.is_finite()) {
                    return bad(format!(
                        "uniform bounds must be finite (got lo = {lo}, hi = {hi}); an infinite box has no normalised density"
                    ));
                }
                if hi <= lo || !(hi - lo).is_finite() || hi - lo == 0.0 {
                    return bad(format!(
                        "uniform needs lo < hi (got lo = {lo}, hi = {hi}); a zero-volume box has no density"
                    ));
                }
            }
            PriorKind::Gaussian { mu, sigma } => {
                if !mu.is_finite() || !sigma.is_finite() || sigma <= 0.0 {
                    return bad(format!(
                        "gaussian needs a finite mu and a finite sigma > 0 (got mu = {mu}, sigma = {sigma})"
                    ));
                }
            }
            PriorKind::LogUniform { lo, hi } => {
                if !(lo.is_finite() && hi.is_finite()) || lo <= 0.0 || hi <= lo {
                    return bad(format!(
                        "log_uniform needs finite 0 < lo < hi (got lo = {lo}, hi = {hi})"
                    ));
                }
            }
        }
        // a width whose square underflows gave "proposal covariance: diagonal entry (6, 6) =
        // 0" with no name; one at the last digits of its centre cannot be moved across
        let (width, what) = match *self {
            PriorKind::Gaussian { sigma, .. } => (sigma, "sigma"),
            PriorKind::Uniform { lo, hi } | PriorKind::LogUniform { lo, hi } => {
                (hi - lo, "hi − lo")
            }
        };
        let centre = self.centre().abs();
        if width < MIN_WIDTH || width < MIN_RELATIVE_WIDTH * centre {
            return bad(format!(
                "{what} = {width:e} is too narrow to sample: a prior's width must be at least \
                 {MIN_WIDTH:.1e} (its square, a variance, must not underflow) and at least \
                 {MIN_RELATIVE_WIDTH:e} of its centre ({centre:e}); write the parameter in units \
                 that make the width larger, or fix it ([fit] fixed)"
            ));
        }
        Ok(())
    }

    /// Natural-log density at `x` (`−∞` outside the support).
    pub fn ln_pdf(&self, x: f64) -> f64 {
        match *self {
            PriorKind::Uniform { lo, hi } => {
                if (lo..=hi).contains(&x) {
                    -(hi - lo).ln()
                } else {
                    f64::NEG_INFINITY
                }
            }
            PriorKind::Gaussian { mu, sigma } => {
                let z = (x - mu) / sigma;
                -0.5 * (2.0 * std::f64::consts::PI).ln() - sigma.ln() - 0.5 * z * z
            }
            PriorKind::LogUniform { lo, hi } => {
                if (lo..=hi).contains(&x) {
                    -x.ln() - (hi / lo).ln().ln()
                } else {
                    f64::NEG_INFINITY
                }
            }
        }
    }

    /// The support `[lo, hi]` (infinite for a Gaussian).
    pub fn bounds(&self) -> (f64, f64) {
        match *self {
            PriorKind::Uniform { lo, hi } | PriorKind::LogUniform { lo, hi } => (lo, hi),
            PriorKind::Gaussian { .. } => (f64::NEG_INFINITY, f64::INFINITY),
        }
    }

    /// The value below which a fraction `u` of the prior lies (the inverse CDF), `u` in
    /// `(0, 1)`; `u` outside is clamped to `[1e−12, 1 − 1e−12]` so a Gaussian's stays finite.
    /// Maps a quasi-random point of the unit cube onto the prior (multi-start searches).
    ///
    /// ```
    /// use occam::prior::PriorKind;
    /// assert_eq!(PriorKind::Uniform { lo: 0.0, hi: 2.0 }.quantile(0.25), 0.5);
    /// assert!((PriorKind::LogUniform { lo: 1.0, hi: 100.0 }.quantile(0.5) - 10.0).abs() < 1e-12);
    /// assert!((PriorKind::Gaussian { mu: 1.0, sigma: 2.0 }.quantile(0.8413447460685429) - 3.0).abs() < 1e-9);
    /// ```
    pub fn quantile(&self, u: f64) -> f64 {
        let u = if u.is_nan() {
            0.5
        } else {
            u.clamp(1e-12, 1.0 - 1e-12)
        };
        match *self {
            PriorKind::Uniform { lo, hi } => lo + (hi - lo) * u,
            PriorKind::Gaussian { mu, sigma } => {
                use statrs::distribution::ContinuousCDF;
                let n = statrs::distribution::Normal::standard();
                mu + sigma * n.inverse_cdf(u)
            }
            PriorKind::LogUniform { lo, hi } => (lo.ln() + (hi / lo).ln() * u).exp(),
        }
    }

    /// One draw from this prior.
    pub fn sample<R: Rng + ?Sized>(&self, rng: &mut R) -> f64 {
        match *self {
            PriorKind::Uniform { lo, hi } => lo + (hi - lo) * rng.random::<f64>(),
            PriorKind::Gaussian { mu, sigma } => {
                let z: f64 = StandardNormal.sample(rng);
                mu + sigma * z
            }
            PriorKind::LogUniform { lo, hi } => {
                (lo.ln() + (hi / lo).ln() * rng.random::<f64>()).exp()
            }
        }
    }
}

/// A normalised product prior over named parameters.
///
/// ```
/// use occam::prior::{Prior, PriorKind};
/// let p = Prior::new(
///     vec!["a".into(), "b".into()],
///     vec![PriorKind::Uniform { lo: 0.0, hi: 2.0 }, PriorKind::Uniform { lo: -1.0, hi: 1.0 }],
/// ).unwrap();
/// assert!((p.ln_pdf(&[1.0, 0.0]) - (-(4.0f64).ln())).abs() < 1e-15);
/// assert_eq!(p.ln_pdf(&[3.0, 0.0]), f64::NEG_INFINITY);
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Prior {
    names: Vec<String>,
    kinds: Vec<PriorKind>,
}

/// Why [`Prior::ln_pdf_extended`] has no value.
#[derive(Debug, Clone, PartialEq)]
pub enum ExtendedError {
    /// θ has `got` components, not the prior's dimension.
    Dimension { got: usize },
    /// A component is NaN or infinite.
    NonFinite { name: String, x: f64 },
    /// A log-uniform component at θ ≤ 0, where its formula is undefined.
    LogUniformAtNonPositive { name: String, x: f64 },
}

impl Prior {
    /// `ln π(θ)` with uniform and log-uniform densities continued beyond their bounds by
    /// their formula (constant, and `−ln θ − ln ln(b/a)`): the smooth function a Laplace
    /// expansion, and an optimiser looking for the unconstrained maximum, work with.
    pub fn ln_pdf_extended(&self, theta: &[f64]) -> Result<f64, ExtendedError> {
        if theta.len() != self.dim() {
            return Err(ExtendedError::Dimension { got: theta.len() });
        }
        let mut s = 0.0;
        for ((k, &x), name) in self.kinds().iter().zip(theta).zip(self.names()) {
            if !x.is_finite() {
                return Err(ExtendedError::NonFinite {
                    name: name.clone(),
                    x,
                });
            }
            s += match *k {
                PriorKind::Uniform { lo, hi } => -(hi - lo).ln(),
                PriorKind::Gaussian { .. } => k.ln_pdf(x),
                PriorKind::LogUniform { lo, hi } => {
                    if x <= 0.0 {
                        return Err(ExtendedError::LogUniformAtNonPositive {
                            name: name.clone(),
                            x,
                        });
                    }
                    -x.ln() - (hi / lo).ln().ln()
                }
            };
        }
        Ok(s)
    }

    /// Validates every component: finite, non-empty supports, positive widths.
    pub fn new(names: Vec<String>, kinds: Vec<PriorKind>) -> Result<Self, PriorError> {
        if names.len() != kinds.len() {
            return Err(PriorError::Length {
                names: names.len(),
                kinds: kinds.len(),
            });
        }
        for (n, k) in names.iter().zip(&kinds) {
            k.validate(n)?;
        }
        Ok(Self { names, kinds })
    }

    /// Number of parameters.
    pub fn dim(&self) -> usize {
        self.kinds.len()
    }

    /// Parameter names.
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// Per-parameter priors.
    pub fn kinds(&self) -> &[PriorKind] {
        &self.kinds
    }

    /// `ln π(θ)`; `−∞` outside the support. `θ` must have [`Prior::dim`] entries.
    pub fn ln_pdf(&self, theta: &[f64]) -> f64 {
        assert_eq!(theta.len(), self.kinds.len());
        let mut s = 0.0;
        for (k, &x) in self.kinds.iter().zip(theta) {
            let l = k.ln_pdf(x);
            if l == f64::NEG_INFINITY || x.is_nan() {
                return f64::NEG_INFINITY;
            }
            s += l;
        }
        s
    }

    /// Whether θ lies in the support.
    pub fn contains(&self, theta: &[f64]) -> bool {
        self.ln_pdf(theta) > f64::NEG_INFINITY
    }

    /// Per-parameter supports `(lo, hi)`.
    pub fn bounds(&self) -> Vec<(f64, f64)> {
        self.kinds.iter().map(PriorKind::bounds).collect()
    }

    /// A draw from the prior.
    pub fn sample<R: Rng + ?Sized>(&self, rng: &mut R) -> Vec<f64> {
        self.kinds.iter().map(|k| k.sample(rng)).collect()
    }

    /// The prior restricted to the parameters at `idx` (in that order).
    pub fn subset(&self, idx: &[usize]) -> Prior {
        Prior {
            names: idx.iter().map(|&i| self.names[i].clone()).collect(),
            kinds: idx.iter().map(|&i| self.kinds[i]).collect(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rejects_degenerate_boxes() {
        let mk = |k| Prior::new(vec!["x".into()], vec![k]);
        assert!(mk(PriorKind::Uniform { lo: 1.0, hi: 1.0 }).is_err());
        assert!(
            mk(PriorKind::Uniform {
                lo: 0.0,
                hi: f64::INFINITY
            })
            .is_err()
        );
        assert!(
            mk(PriorKind::Gaussian {
                mu: 0.0,
                sigma: 0.0
            })
            .is_err()
        );
        assert!(mk(PriorKind::LogUniform { lo: 0.0, hi: 1.0 }).is_err());
        assert!(
            mk(PriorKind::Uniform {
                lo: f64::NAN,
                hi: 1.0
            })
            .is_err()
        );
        // widths whose square underflows, or at the last digits of the centre, are named
        let e = mk(PriorKind::Uniform {
            lo: 0.0,
            hi: 1e-310,
        })
        .unwrap_err()
        .to_string();
        assert!(
            e.starts_with("prior of `x`: hi − lo = 1e-310 is too narrow"),
            "{e}"
        );
        let narrow = PriorKind::Gaussian {
            mu: 1.0,
            sigma: 1e-13,
        };
        assert!(
            mk(narrow)
                .unwrap_err()
                .to_string()
                .contains("sigma = 1e-13")
        );
        for ok in [
            PriorKind::Uniform {
                lo: 0.0,
                hi: 1e-150,
            },
            PriorKind::Gaussian {
                mu: 1.0,
                sigma: 1e-11,
            },
            PriorKind::LogUniform {
                lo: 1e-28,
                hi: 1e-24,
            },
        ] {
            mk(ok).unwrap();
        }
    }

    #[test]
    fn densities_integrate_to_one() {
        // Trapezoid integration of exp(ln_pdf) over the support.
        for k in [
            PriorKind::Uniform { lo: -2.0, hi: 3.0 },
            PriorKind::Gaussian {
                mu: 1.0,
                sigma: 0.5,
            },
            PriorKind::LogUniform { lo: 0.1, hi: 10.0 },
        ] {
            let (lo, hi) = match k.bounds() {
                (a, b) if a.is_finite() => (a, b),
                _ => (-9.0, 11.0),
            };
            let n = 200_000;
            let h = (hi - lo) / n as f64;
            let mut s = 0.0;
            for i in 0..=n {
                let x = lo + h * i as f64;
                let w = if i == 0 || i == n { 0.5 } else { 1.0 };
                s += w * k.ln_pdf(x).exp();
            }
            assert!((s * h - 1.0).abs() < 1e-6, "{k:?}: {}", s * h);
        }
    }
}
