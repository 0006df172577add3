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

use super::bin::{Bin, BinBlock};
use super::traits::{BatchKernel, BlockKernel, Model};
use num_complex::{Complex, Complex64};
use num_dual::Dual64;
use std::sync::Arc;

/// Most parameters of a parent model (the expanded θ is built on the stack).
pub const MAX_TIED_PARENT: usize = 32;

/// A model with tied parameters (see the module docs).
#[derive(Debug, Clone)]
pub struct TiedModel {
    name: String,
    parent: Arc<dyn Model>,
    names: Vec<String>,
    /// For each parent parameter, the index in this model's θ it takes its value from.
    source: Vec<usize>,
}

impl TiedModel {
    /// Ties `parent`'s parameters by `ties` (tied name, source name). A source must not itself
    /// be tied, a parameter may be tied once, and names must be the parent's.
    pub fn new(
        name: &str,
        parent: Arc<dyn Model>,
        ties: &[(String, String)],
    ) -> Result<Self, String> {
        let pn = parent.param_names();
        if pn.len() > MAX_TIED_PARENT {
            return Err(format!(
                "model `{}` has {} parameters; tying supports at most {MAX_TIED_PARENT}",
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
            .map(|i| pos(tied_to[i].unwrap_or(i)))
            .collect();
        Ok(Self {
            name: name.into(),
            names: kept.iter().map(|&i| pn[i].clone()).collect(),
            parent,
            source,
        })
    }

    /// The parent model.
    pub fn parent(&self) -> &Arc<dyn Model> {
        &self.parent
    }

    /// The parent's θ for this model's θ.
    pub fn expand(&self, theta: &[f64]) -> Vec<f64> {
        self.source.iter().map(|&s| theta[s]).collect()
    }

    #[inline]
    fn expand_into<T: Copy>(&self, theta: &[T], buf: &mut [T]) {
        for (b, &s) in buf.iter_mut().zip(&self.source) {
            *b = theta[s];
        }
    }
}

/// A parent's prepared kernel evaluated at the expanded θ.
#[derive(Debug)]
struct TiedKernel {
    inner: Arc<dyn BlockKernel>,
    source: Vec<usize>,
}

impl BlockKernel for TiedKernel {
    fn residual_power(&self, theta: &[f64]) -> f64 {
        let mut buf = [0.0; MAX_TIED_PARENT];
        let n = self.source.len();
        for (b, &s) in buf[..n].iter_mut().zip(&self.source) {
            *b = theta[s];
        }
        self.inner.residual_power(&buf[..n])
    }
}

/// The parent's prepared batch, read at the parent's θ.
#[derive(Debug)]
struct TiedBatch {
    inner: Arc<dyn BatchKernel>,
    source: Vec<usize>,
}

impl BatchKernel for TiedBatch {
    fn coefficients(&self, theta: &[f64], out: &mut [Complex64]) {
        let mut buf = [0.0; MAX_TIED_PARENT];
        let n = self.source.len();
        for (b, &s) in buf[..n].iter_mut().zip(&self.source) {
            *b = theta[s];
        }
        self.inner.coefficients(&buf[..n], out)
    }
}

impl Model for TiedModel {
    fn name(&self) -> &str {
        &self.name
    }

    fn param_names(&self) -> &[String] {
        &self.names
    }

    /// The parent's unit of each kept parameter.
    fn param_units(&self) -> Vec<String> {
        let (pn, pu) = (self.parent.param_names(), self.parent.param_units());
        self.names
            .iter()
            .map(|n| {
                pn.iter()
                    .position(|p| p == n)
                    .and_then(|i| pu.get(i).cloned())
                    .unwrap_or_default()
            })
            .collect()
    }

    fn data_channels(&self) -> &[String] {
        self.parent.data_channels()
    }

    fn residual_channels(&self) -> &[String] {
        self.parent.residual_channels()
    }

    fn n_consts(&self) -> usize {
        self.parent.n_consts()
    }

    fn bin_consts(&self, f: f64, fs: f64, out: &mut [Complex64]) {
        self.parent.bin_consts(f, fs, out)
    }

    fn coefficients(&self, theta: &[f64], bin: &Bin, out: &mut [Complex64]) {
        let mut buf = [0.0; MAX_TIED_PARENT];
        let n = self.source.len();
        self.expand_into(theta, &mut buf[..n]);
        self.parent.coefficients(&buf[..n], bin, out)
    }

    fn coefficients_dual(&self, theta: &[Dual64], bin: &Bin, out: &mut [Complex<Dual64>]) {
        // a tied parameter carries its source's derivative: the chain rule of θ_parent(θ)
        let mut buf = [Dual64::from(0.0); MAX_TIED_PARENT];
        let n = self.source.len();
        self.expand_into(theta, &mut buf[..n]);
        self.parent.coefficients_dual(&buf[..n], bin, out)
    }

    fn coefficients_batch(
        &self,
        theta: &[f64],
        freqs: &[f64],
        fs: f64,
        consts: &[Complex64],
        comps: &[usize],
        out: &mut [Complex64],
    ) {
        let mut buf = [0.0; MAX_TIED_PARENT];
        let n = self.source.len();
        self.expand_into(theta, &mut buf[..n]);
        self.parent
            .coefficients_batch(&buf[..n], freqs, fs, consts, comps, out)
    }

    fn prepare_batch(
        &self,
        freqs: &[f64],
        fs: f64,
        consts: &[Complex64],
        comps: &[usize],
    ) -> Option<Arc<dyn BatchKernel>> {
        let inner = self.parent.prepare_batch(freqs, fs, consts, comps)?;
        Some(Arc::new(TiedBatch {
            inner,
            source: self.source.clone(),
        }))
    }

    fn check(&self, theta: &[f64]) -> Result<(), String> {
        self.parent.check(&self.expand(theta))
    }

    fn data_noise_csd(&self, theta: &[f64], bin: &Bin, out: &mut [Complex64]) -> bool {
        self.parent.data_noise_csd(&self.expand(theta), bin, out)
    }

    fn residual_power(&self, theta: &[f64], block: &BinBlock) -> f64 {
        let mut buf = [0.0; MAX_TIED_PARENT];
        let n = self.source.len();
        self.expand_into(theta, &mut buf[..n]);
        self.parent.residual_power(&buf[..n], block)
    }

    fn prepare_kernel(&self, block: &BinBlock) -> Option<Arc<dyn BlockKernel>> {
        let inner = self.parent.prepare_kernel(block)?;
        Some(Arc::new(TiedKernel {
            inner,
            source: self.source.clone(),
        }))
    }

    fn prepare_joint_kernel(&self, blocks: &[BinBlock]) -> Option<Arc<dyn BlockKernel>> {
        let inner = self.parent.prepare_joint_kernel(blocks)?;
        Some(Arc::new(TiedKernel {
            inner,
            source: self.source.clone(),
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::accel::{AccelModel, AccelOptions};
    use crate::model::coefficients_at;

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
