//! Tied parameters: a nested model whose parameters are the parent's with some set equal to
//! others (`a2 = a1`: symmetric actuators). Any [`Model`] can be tied; the tied model is again
//! a [`Model`], so fixing, priors, Fisher matrices, samplers and every evidence estimator work on
//! it unchanged.
//!
//! ```toml
//! [[model]]
//! kind = "tied"
//! name = "symmetric"
//! of = "asymmetric"                                   # any model defined in the file
//! tie = { a2 = "a1", f_o2 = "f_o1" }                  # parameter = the parameter it copies
//! ```
//!
//! The tied model's parameters are the parent's in the parent's order without the tied ones;
//! its prior is taken by name like any model's. Its evidence is that of the parent restricted
//! to the subspace `a2 = a1`, with the prior of `a1` alone.

use super::reparam::{MAX_PARENT_PARAMS, Reparam, ReparamModel};
use super::traits::Model;
use std::sync::Arc;

/// A model with tied parameters (see the module docs): a [`ReparamModel`] whose map copies
/// each tied parameter from its source.
pub type TiedModel = ReparamModel;

impl ReparamModel {
    /// Ties `parent`'s parameters by `ties` (tied name, source name). A source must not itself
    /// be tied, a parameter may be tied once, and names must be the parent's.
    pub fn new(
        name: &str,
        parent: Arc<dyn Model>,
        ties: &[(String, String)],
    ) -> Result<Self, String> {
        let pn = parent.param_names();
        if pn.len() > MAX_PARENT_PARAMS {
            return Err(format!(
                "model `{}` has {} parameters; tying supports at most {MAX_PARENT_PARAMS}",
                parent.name(),
                pn.len()
            ));
        }
        let find = |n: &str| {
            pn.iter().position(|p| p == n).ok_or_else(|| {
                format!(
                    "`{n}` is not a parameter of model `{}`; its parameters are {pn:?}",
                    parent.name()
                )
            })
        };
        let mut tied_to = vec![None; pn.len()];
        for (t, s) in ties {
            let (ti, si) = (find(t)?, find(s)?);
            if ti == si {
                return Err(format!("`{t}` is tied to itself"));
            }
            if tied_to[ti].is_some() {
                return Err(format!("`{t}` is tied twice"));
            }
            tied_to[ti] = Some(si);
        }
        for (t, s) in ties {
            if tied_to[find(s)?].is_some() {
                return Err(format!(
                    "`{t}` is tied to `{s}`, which is itself tied: tie `{t}` to what `{s}` is tied to"
                ));
            }
        }
        if ties.is_empty() {
            return Err("`tie` is empty: a tied model needs at least one tie".into());
        }
        let kept: Vec<usize> = (0..pn.len()).filter(|&i| tied_to[i].is_none()).collect();
        let pos = |i: usize| kept.iter().position(|&k| k == i).expect("kept");
        let source = (0..pn.len())
            .map(|i| (pos(tied_to[i].unwrap_or(i)), None))
            .collect();
        let units = parent.param_units();
        let names = kept.iter().map(|&i| pn[i].clone()).collect();
        let units = kept
            .iter()
            .map(|&i| units.get(i).cloned().unwrap_or_default())
            .collect();
        let map = Reparam::new(source);
        ReparamModel::affine(name, parent, names, units, map)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Bin;
    use crate::model::accel::{AccelModel, AccelOptions};
    use crate::model::coefficients_at;
    use num_complex::{Complex, Complex64};
    use num_dual::Dual64;

    fn parent() -> Arc<dyn Model> {
        Arc::new(AccelModel::new(
            "full",
            AccelOptions {
                pole: true,
                delay: true,
                ..Default::default()
            },
        ))
    }

    fn ties(v: &[(&str, &str)]) -> Vec<(String, String)> {
        v.iter()
            .map(|(a, b)| (a.to_string(), b.to_string()))
            .collect()
    }

    #[test]
    fn tied_model_is_the_parent_on_the_tied_subspace() {
        let t = TiedModel::new("sym", parent(), &ties(&[("a2", "a1"), ("f_o2", "f_o1")])).unwrap();
        assert_eq!(
            t.param_names(),
            ["w1sq", "w2sq", "a1", "f_o1", "tau_c1", "tau_c2"]
        );
        assert_eq!(t.param_units(), ["s⁻²", "s⁻²", "", "Hz", "s", "s"]);
        let th = [-1.3e-6, -1.9e-6, 1.02, 1.963, 0.01, 0.03];
        let full = [-1.3e-6, -1.9e-6, 1.02, 1.02, 1.963, 1.963, 0.01, 0.03];
        assert_eq!(t.expand(&th), full);
        for f in [1e-3, 0.1, 1.5] {
            assert_eq!(
                coefficients_at(&t, &th, f, 10.0),
                coefficients_at(parent().as_ref(), &full, f, 10.0)
            );
        }
    }

    /// d/d a1 of the tied model is the sum of the parent's d/d a1 and d/d a2 (chain rule).
    #[test]
    fn tied_derivative_is_the_sum_of_the_parents() {
        let p = parent();
        let t = TiedModel::new("sym", p.clone(), &ties(&[("a2", "a1")])).unwrap();
        let th = [-1.3e-6, -1.9e-6, 1.02, 1.9, 2.1, 0.01, 0.03];
        let full = t.expand(&th);
        let (f, fs) = (0.5, 10.0);
        let mut c = [Complex64::new(0.0, 0.0); 2];
        p.bin_consts(f, fs, &mut c);
        let bin = Bin { f, fs, consts: &c };
        let deriv = |m: &dyn Model, x: &[f64], a: usize| {
            let mut d: Vec<Dual64> = x.iter().map(|&v| Dual64::from(v)).collect();
            d[a] = Dual64::from(x[a]).derivative();
            let mut out = [Complex::new(Dual64::from(0.0), Dual64::from(0.0)); 4];
            m.coefficients_dual(&d, &bin, &mut out);
            out.map(|z| Complex64::new(z.re.eps, z.im.eps))
        };
        let dt = deriv(&t, &th, 2);
        let (d1, d2) = (deriv(p.as_ref(), &full, 2), deriv(p.as_ref(), &full, 3));
        for c in 0..4 {
            assert!((dt[c] - (d1[c] + d2[c])).norm() < 1e-12, "coef {c}");
        }
        assert!(dt[2].norm() > 0.0 && dt[3].norm() > 0.0);
    }

    #[test]
    fn bad_ties_are_refused_with_the_reason() {
        let e = |v: &[(&str, &str)]| TiedModel::new("x", parent(), &ties(v)).unwrap_err();
        assert!(e(&[("a3", "a1")]).contains("`a3` is not a parameter"));
        assert!(e(&[("a2", "a2")]).contains("itself"));
        assert!(e(&[("a2", "a1"), ("a2", "w1sq")]).contains("tied twice"));
        assert!(e(&[("a2", "a1"), ("a1", "w1sq")]).contains("itself tied"));
        assert!(e(&[]).contains("empty"));
    }
}
