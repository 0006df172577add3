//! Nested sub-models: a parent density with some parameters held at fixed values.
//!
//! Model selection compares a model with the models obtained from it by freezing parameters
//! (a delay fixed at 0, a cross-talk coefficient fixed at 0, …). [`SubModel`] is that nested
//! model: it exposes only the free parameters, takes its prior as the parent prior restricted
//! to them, and evaluates the parent likelihood at the full vector `base` with the free entries
//! replaced. The frozen parameters carry no prior factor: the nested model *is* the parent
//! conditioned on them, so its evidence is `∫ L(θ_free, θ_fixed) π(θ_free) dθ_free`.

use crate::density::LogDensity;
use crate::prior::Prior;

/// Largest parent dimension a [`SubModel`] supports.
///
/// The full parameter vector is assembled in a stack buffer of this length on every likelihood
/// call, which keeps the hot path free of allocation. A model with modelled glitches carries
/// three parameters per candidate (`examples/glitches.toml`: 49 with 14 candidates; 32, the
/// old bound, stopped its `occam fit`); 2 KiB of stack cost nothing beside a likelihood.
pub const MAX_PARENT_DIM: usize = 256;

/// Why a sub-model could not be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum NestedError {
    /// The parent has more parameters than the stack buffer holds.
    #[error(
        "sub-model: the parent has {parent_dim} parameters, more than the supported maximum of {max}; split the model or raise MAX_PARENT_DIM"
    )]
    ParentTooLarge { parent_dim: usize, max: usize },
    /// `base` does not have one entry per parent parameter.
    #[error("sub-model: `base` has {got} entries but the parent has {expected} parameters")]
    BaseLength { got: usize, expected: usize },
    /// A free index does not name a parent parameter.
    #[error(
        "sub-model: free index {index} is out of range (the parent has {parent_dim} parameters, indices 0..{parent_dim})"
    )]
    IndexOutOfRange { index: usize, parent_dim: usize },
    /// A parameter is listed twice among the free indices.
    #[error(
        "sub-model: free index {index} (`{name}`) is listed twice; list each free parameter once"
    )]
    DuplicateIndex { index: usize, name: String },
    /// A fixed value is NaN or infinite.
    #[error(
        "sub-model: fixed value of `{name}` (index {index}) is {value}; fixed values must be finite"
    )]
    NonFiniteBase {
        index: usize,
        name: String,
        value: f64,
    },
}

/// A nested model of `parent`: the parameters at `free` vary, every other parameter stays at its
/// value in `base`.
///
/// The prior is `parent.prior().subset(free)` (in the order of `free`); the likelihood is the
/// parent likelihood at `base` with `base[free[k]] = θ[k]`.
///
/// ```
/// use occam::density::LogDensity;
/// use occam::nested::SubModel;
/// use occam::prior::{Prior, PriorKind};
///
/// struct Quadratic(Prior);
/// impl LogDensity for Quadratic {
///     fn ln_likelihood(&self, t: &[f64]) -> f64 { -0.5 * (t[0] * t[0] + (t[1] - 1.0).powi(2)) }
///     fn prior(&self) -> &Prior { &self.0 }
/// }
/// let u = PriorKind::Uniform { lo: -5.0, hi: 5.0 };
/// let parent = Quadratic(Prior::new(vec!["a".into(), "b".into()], vec![u, u]).unwrap());
/// // Freeze `a` at 0 and keep `b` free.
/// let sub = SubModel::new(&parent, vec![1], vec![0.0, 0.0]).unwrap();
/// assert_eq!(sub.dim(), 1);
/// assert_eq!(sub.ln_likelihood(&[1.0]), 0.0);
/// assert_eq!(sub.param_names(), vec!["b".to_string()]);
/// ```
#[derive(Debug, Clone)]
pub struct SubModel<D: LogDensity> {
    parent: D,
    free: Vec<usize>,
    base: Vec<f64>,
    prior: Prior,
}

impl<D: LogDensity> SubModel<D> {
    /// Builds the nested model. `free` lists the parent indices that stay free (any order, no
    /// repeats, may be empty); `base` is a full-length parent vector whose entries at the other
    /// indices are the fixed values (its entries at `free` are ignored).
    pub fn new(parent: D, free: Vec<usize>, base: Vec<f64>) -> Result<Self, NestedError> {
        let parent_dim = parent.dim();
        if parent_dim > MAX_PARENT_DIM {
            return Err(NestedError::ParentTooLarge {
                parent_dim,
                max: MAX_PARENT_DIM,
            });
        }
        if base.len() != parent_dim {
            return Err(NestedError::BaseLength {
                got: base.len(),
                expected: parent_dim,
            });
        }
        let names = parent.prior().names().to_vec();
        let mut seen = [false; MAX_PARENT_DIM];
        for &i in &free {
            if i >= parent_dim {
                return Err(NestedError::IndexOutOfRange {
                    index: i,
                    parent_dim,
                });
            }
            if seen[i] {
                return Err(NestedError::DuplicateIndex {
                    index: i,
                    name: names[i].clone(),
                });
            }
            seen[i] = true;
        }
        for (i, &v) in base.iter().enumerate() {
            if !seen[i] && !v.is_finite() {
                return Err(NestedError::NonFiniteBase {
                    index: i,
                    name: names[i].clone(),
                    value: v,
                });
            }
        }
        let prior = parent.prior().subset(&free);
        Ok(Self {
            parent,
            free,
            base,
            prior,
        })
    }

    /// The parent density.
    pub fn parent(&self) -> &D {
        &self.parent
    }

    /// Parent indices of the free parameters, in the order of this model's θ.
    pub fn free_indices(&self) -> &[usize] {
        &self.free
    }

    /// The full-length base vector (fixed values; entries at the free indices are unused).
    pub fn base(&self) -> &[f64] {
        &self.base
    }

    /// The full parent vector for this model's `theta` (allocates; for reporting, not hot paths).
    pub fn embed(&self, theta: &[f64]) -> Vec<f64> {
        assert_eq!(theta.len(), self.free.len());
        let mut full = self.base.clone();
        for (&i, &v) in self.free.iter().zip(theta) {
            full[i] = v;
        }
        full
    }
}

impl<D: LogDensity> LogDensity for SubModel<D> {
    fn dim(&self) -> usize {
        self.free.len()
    }

    fn ln_likelihood(&self, theta: &[f64]) -> f64 {
        assert_eq!(theta.len(), self.free.len());
        let n = self.base.len();
        let mut buf = [0.0; MAX_PARENT_DIM];
        buf[..n].copy_from_slice(&self.base);
        for (&i, &v) in self.free.iter().zip(theta) {
            buf[i] = v;
        }
        self.parent.ln_likelihood(&buf[..n])
    }

    fn prior(&self) -> &Prior {
        &self.prior
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::prior::PriorKind;

    /// ln L = −½ Σ_i (i+1)·(θ_i − i)²: every coordinate distinguishable.
    #[derive(Debug)]
    struct Sep(Prior);
    impl LogDensity for Sep {
        fn ln_likelihood(&self, t: &[f64]) -> f64 {
            t.iter()
                .enumerate()
                .map(|(i, &x)| -0.5 * (i as f64 + 1.0) * (x - i as f64).powi(2))
                .sum()
        }
        fn prior(&self) -> &Prior {
            &self.0
        }
    }

    fn parent(d: usize) -> Sep {
        let names = (0..d).map(|i| format!("p{i}")).collect();
        let kinds = (0..d)
            .map(|i| PriorKind::Uniform {
                lo: -10.0 - i as f64,
                hi: 10.0,
            })
            .collect();
        Sep(Prior::new(names, kinds).unwrap())
    }

    #[test]
    fn embeds_free_values_and_keeps_fixed_ones() {
        let p = parent(4);
        let base = vec![0.5, 1.5, 2.5, 3.5];
        let sub = SubModel::new(&p, vec![3, 1], base.clone()).unwrap();
        let theta = [7.0, -2.0];
        let full = sub.embed(&theta);
        assert_eq!(full, vec![0.5, -2.0, 2.5, 7.0]);
        assert_eq!(sub.ln_likelihood(&theta), p.ln_likelihood(&full));
        assert_eq!(sub.prior().names(), &["p3".to_string(), "p1".to_string()]);
        assert_eq!(sub.prior().kinds()[0], p.prior().kinds()[3]);
        // ln_posterior carries only the free parameters' prior: p3 ~ U[-13, 10], p1 ~ U[-11, 10].
        let lp = -(23.0f64).ln() - (21.0f64).ln();
        assert!((sub.ln_posterior(&theta) - (p.ln_likelihood(&full) + lp)).abs() < 1e-12);
    }

    #[test]
    fn empty_free_set_is_the_fixed_point_model() {
        let p = parent(3);
        let sub = SubModel::new(&p, vec![], vec![0.0, 1.0, 2.0]).unwrap();
        assert_eq!(sub.dim(), 0);
        assert_eq!(sub.ln_likelihood(&[]), 0.0);
        assert_eq!(sub.ln_posterior(&[]), 0.0);
    }

    #[test]
    fn rejects_bad_indices_and_bases() {
        let p = parent(3);
        assert_eq!(
            SubModel::new(&p, vec![0, 3], vec![0.0; 3]).unwrap_err(),
            NestedError::IndexOutOfRange {
                index: 3,
                parent_dim: 3
            }
        );
        assert!(matches!(
            SubModel::new(&p, vec![1, 1], vec![0.0; 3]),
            Err(NestedError::DuplicateIndex { index: 1, .. })
        ));
        assert_eq!(
            SubModel::new(&p, vec![0], vec![0.0; 2]).unwrap_err(),
            NestedError::BaseLength {
                got: 2,
                expected: 3
            }
        );
        assert!(matches!(
            SubModel::new(&p, vec![0], vec![0.0, f64::NAN, 0.0]),
            Err(NestedError::NonFiniteBase { index: 1, .. })
        ));
        // A non-finite entry at a free index is ignored: it is overwritten on every call.
        assert!(SubModel::new(&p, vec![1], vec![0.0, f64::NAN, 0.0]).is_ok());
        let big = parent(MAX_PARENT_DIM + 1);
        assert_eq!(
            SubModel::new(&big, vec![0], vec![0.0; MAX_PARENT_DIM + 1]).unwrap_err(),
            NestedError::ParentTooLarge {
                parent_dim: MAX_PARENT_DIM + 1,
                max: MAX_PARENT_DIM
            }
        );
        let full = parent(MAX_PARENT_DIM);
        assert!(SubModel::new(&full, vec![0, 31], vec![0.0; MAX_PARENT_DIM]).is_ok());
    }
}
