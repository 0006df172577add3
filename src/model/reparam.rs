//! A model on new parameters: the parent's parameters as affine functions of this model's,
//! `θ_parent[p] = θ[b_p] + x_p·θ[s_p]` (the slope term optional). Tied parameters
//! ([`crate::model::tied`]: `a2 = a1`) and a parameter drifting between stretches
//! ([`crate::model::drift`]: `w1sq(t) = w1sq + (t − t̄)·dw1sq_dtime`, or one value per stretch)
//! are both of this form. The result is again a [`Model`], so fixing, priors, Fisher matrices,
//! samplers and every evidence estimator work on it unchanged, and the parent's fast kernels
//! are kept: they are evaluated at the expanded θ.

use super::bin::{Bin, BinBlock};
use super::covariates::Covariates;
use super::traits::{BatchKernel, BlockKernel, Model};
use num_complex::{Complex, Complex64};
use num_dual::Dual64;
use std::sync::Arc;

/// Most parameters of a parent model (the expanded θ is built on the stack).
pub const MAX_PARENT_PARAMS: usize = 32;

/// The affine map from a model's θ to its parent's: per parent parameter, the index of its
/// base value and an optional `(slope index, x)` term.
#[derive(Debug, Clone, PartialEq)]
pub struct Reparam {
    terms: Vec<(usize, Option<(usize, f64)>)>,
}

impl Reparam {
    /// The map with `terms[p] = (b_p, Some((s_p, x_p)))` or `(b_p, None)`.
    pub fn new(terms: Vec<(usize, Option<(usize, f64)>)>) -> Self {
        Self { terms }
    }

    /// Number of parent parameters.
    pub fn len(&self) -> usize {
        self.terms.len()
    }

    /// Whether the parent has no parameters.
    pub fn is_empty(&self) -> bool {
        self.terms.is_empty()
    }

    /// The parent's θ for `theta`.
    pub fn expand(&self, theta: &[f64]) -> Vec<f64> {
        let mut v = vec![0.0; self.len()];
        self.expand_into(theta, &mut v);
        v
    }

    /// [`Reparam::expand`] into `buf`, for reals or dual numbers (the slope term carries its
    /// derivative: the chain rule of `θ_parent(θ)`).
    #[inline]
    pub fn expand_into<T>(&self, theta: &[T], buf: &mut [T])
    where
        T: Copy + std::ops::Add<Output = T> + std::ops::Mul<f64, Output = T>,
    {
        for (b, &(base, slope)) in buf.iter_mut().zip(&self.terms) {
            *b = match slope {
                None => theta[base],
                Some((s, x)) => theta[base] + theta[s] * x,
            };
        }
    }

    /// Calls `f` with the parent's θ for `theta`, built on the stack.
    #[inline]
    fn with<R>(&self, theta: &[f64], f: impl FnOnce(&[f64]) -> R) -> R {
        let mut buf = [0.0; MAX_PARENT_PARAMS];
        let n = self.len();
        self.expand_into(theta, &mut buf[..n]);
        f(&buf[..n])
    }
}

/// The physical limits of a model's own parameters from its parent's (`parent[p]`), where
/// `base[p]` is the own parameter that is parent parameter `p`'s value (at the covariate's
/// reference, for a drift): a tied parameter gets every limit of the parameters tied to it
/// (the narrowest); slopes and the values of other stretches get the parent's limit through
/// `base` only where they are a base themselves.
pub(super) fn carried_limits(
    n: usize,
    parent: &[[Option<f64>; 2]],
    base: impl IntoIterator<Item = (usize, usize)>,
) -> Vec<[Option<f64>; 2]> {
    let mut out: Vec<[Option<f64>; 2]> = vec![[None, None]; n];
    for (p, own) in base {
        let ([lo, hi], [plo, phi]) = (&mut out[own], parent[p]);
        *lo = match (*lo, plo) {
            (Some(a), Some(b)) => Some(a.max(b)),
            (a, b) => a.or(b),
        };
        *hi = match (*hi, phi) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        };
    }
    out
}

/// A model whose parameters map affinely onto a parent's (see the module docs).
#[derive(Debug, Clone)]
pub struct ReparamModel {
    pub(super) name: String,
    pub(super) parent: Arc<dyn Model>,
    pub(super) names: Vec<String>,
    pub(super) units: Vec<String>,
    pub(super) map: Reparam,
}

impl ReparamModel {
    /// The model called `name` with parameters `names` (units `units`) on `parent` through
    /// `map`. The map's indices must lie inside `names` and it must cover every parent
    /// parameter.
    pub fn affine(
        name: &str,
        parent: Arc<dyn Model>,
        names: Vec<String>,
        units: Vec<String>,
        map: Reparam,
    ) -> Result<Self, String> {
        let np = parent.param_names().len();
        if np > MAX_PARENT_PARAMS {
            return Err(format!(
                "model `{}` has {np} parameters; a reparametrised model supports at most {MAX_PARENT_PARAMS}",
                parent.name()
            ));
        }
        let inside = |i: usize| i < names.len();
        if map.len() != np
            || !map
                .terms
                .iter()
                .all(|&(b, s)| inside(b) && s.is_none_or(|(s, x)| inside(s) && x.is_finite()))
            || units.len() != names.len()
        {
            return Err(format!(
                "model `{name}`: the map onto `{}` does not fit its {np} parameters",
                parent.name()
            ));
        }
        Ok(Self {
            name: name.into(),
            parent,
            names,
            units,
            map,
        })
    }

    /// The parent model.
    pub fn parent(&self) -> &Arc<dyn Model> {
        &self.parent
    }

    /// The parent's θ for this model's θ.
    pub fn expand(&self, theta: &[f64]) -> Vec<f64> {
        self.map.expand(theta)
    }

    /// The same map on another parent (the parent specialised to an experiment).
    pub(super) fn on(&self, parent: Arc<dyn Model>) -> Self {
        Self {
            parent,
            ..self.clone()
        }
    }
}

/// A parent's prepared kernel evaluated at the expanded θ.
#[derive(Debug)]
struct ReparamKernel {
    inner: Arc<dyn BlockKernel>,
    map: Reparam,
}

impl BlockKernel for ReparamKernel {
    fn residual_power(&self, theta: &[f64]) -> f64 {
        self.map.with(theta, |p| self.inner.residual_power(p))
    }
}

/// The parent's prepared batch, read at the parent's θ.
#[derive(Debug)]
struct ReparamBatch {
    inner: Arc<dyn BatchKernel>,
    map: Reparam,
}

impl BatchKernel for ReparamBatch {
    fn coefficients(&self, theta: &[f64], out: &mut [Complex64]) {
        self.map.with(theta, |p| self.inner.coefficients(p, out))
    }
}

impl Model for ReparamModel {
    fn name(&self) -> &str {
        &self.name
    }

    fn param_names(&self) -> &[String] {
        &self.names
    }

    fn param_units(&self) -> Vec<String> {
        self.units.clone()
    }

    /// A parameter that is the base of a parent parameter (the value at the reference of a
    /// slope term, which the line passes through) keeps the parent's limits.
    fn physical_limits(&self) -> Vec<[Option<f64>; 2]> {
        let base = self.map.terms.iter().enumerate().map(|(p, &(b, _))| (p, b));
        carried_limits(self.names.len(), &self.parent.physical_limits(), base)
    }

    fn data_channels(&self) -> &[String] {
        self.parent.data_channels()
    }

    fn residual_channels(&self) -> &[String] {
        self.parent.residual_channels()
    }

    fn channel_units(&self) -> Vec<String> {
        self.parent.channel_units()
    }

    fn n_consts(&self) -> usize {
        self.parent.n_consts()
    }

    fn bin_consts(&self, f: f64, fs: f64, out: &mut [Complex64]) {
        self.parent.bin_consts(f, fs, out)
    }

    fn coefficients(&self, theta: &[f64], bin: &Bin, out: &mut [Complex64]) {
        self.map
            .with(theta, |p| self.parent.coefficients(p, bin, out))
    }

    fn coefficients_dual(&self, theta: &[Dual64], bin: &Bin, out: &mut [Complex<Dual64>]) {
        let mut buf = [Dual64::from(0.0); MAX_PARENT_PARAMS];
        let n = self.map.len();
        self.map.expand_into(theta, &mut buf[..n]);
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
        self.map.with(theta, |p| {
            self.parent
                .coefficients_batch(p, freqs, fs, consts, comps, out)
        })
    }

    fn prepare_batch(
        &self,
        freqs: &[f64],
        fs: f64,
        consts: &[Complex64],
        comps: &[usize],
    ) -> Option<Arc<dyn BatchKernel>> {
        let inner = self.parent.prepare_batch(freqs, fs, consts, comps)?;
        Some(Arc::new(ReparamBatch {
            inner,
            map: self.map.clone(),
        }))
    }

    fn check(&self, theta: &[f64]) -> Result<(), String> {
        self.parent.check(&self.expand(theta))
    }

    fn is_stable(&self, theta: &[f64]) -> bool {
        self.map.with(theta, |p| self.parent.is_stable(p))
    }

    fn data_noise_csd(&self, theta: &[f64], bin: &Bin, out: &mut [Complex64]) -> bool {
        self.parent.data_noise_csd(&self.expand(theta), bin, out)
    }

    fn residual_power(&self, theta: &[f64], block: &BinBlock) -> f64 {
        self.map
            .with(theta, |p| self.parent.residual_power(p, block))
    }

    fn prepare_kernel(&self, block: &BinBlock) -> Option<Arc<dyn BlockKernel>> {
        let inner = self.parent.prepare_kernel(block)?;
        Some(Arc::new(ReparamKernel {
            inner,
            map: self.map.clone(),
        }))
    }

    fn prepare_joint_kernel(&self, blocks: &[BinBlock]) -> Option<Arc<dyn BlockKernel>> {
        let inner = self.parent.prepare_joint_kernel(blocks)?;
        Some(Arc::new(ReparamKernel {
            inner,
            map: self.map.clone(),
        }))
    }

    fn force_response(&self, theta: &[f64], bin: &Bin, out: &mut [Complex64]) -> bool {
        self.map
            .with(theta, |p| self.parent.force_response(p, bin, out))
    }

    fn force_response_dual(
        &self,
        theta: &[Dual64],
        bin: &Bin,
        out: &mut [Complex<Dual64>],
    ) -> bool {
        let mut buf = [Dual64::from(0.0); MAX_PARENT_PARAMS];
        let n = self.map.len();
        self.map.expand_into(theta, &mut buf[..n]);
        self.parent.force_response_dual(&buf[..n], bin, out)
    }

    /// The same map on the parent specialised to the experiment (a tied model of a drifting
    /// one drifts too).
    fn specialise(&self, cov: &Covariates) -> Result<Option<Arc<dyn Model>>, String> {
        Ok(self
            .parent
            .specialise(cov)?
            .map(|p| Arc::new(self.on(p)) as Arc<dyn Model>))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::accel::{AccelModel, AccelOptions};
    use crate::model::coefficients_at;

    /// A slope term moves the parent's parameter by `x` per unit of the slope, and carries
    /// `x` times the parent's derivative.
    #[test]
    fn slope_term_is_affine_with_its_derivative() {
        let p: Arc<dyn Model> = Arc::new(AccelModel::new("a", AccelOptions::default()));
        let np = p.param_names().len();
        let mut names: Vec<String> = p.param_names().to_vec();
        names.push("dw1sq_dtime".into());
        let units = vec![String::new(); np + 1];
        let mut terms: Vec<_> = (0..np).map(|i| (i, None)).collect();
        terms[0] = (0, Some((np, 2.5)));
        let m = ReparamModel::affine("r", p.clone(), names, units, Reparam::new(terms)).unwrap();
        let mut th: Vec<f64> = (0..np)
            .map(|i| [-1.3e-6, -1.9e-6].get(i).copied().unwrap_or(1.0))
            .collect();
        th.push(4e-8);
        let mut full = th[..np].to_vec();
        full[0] += 2.5 * 4e-8;
        assert_eq!(m.expand(&th), full);
        let (f, fs) = (0.02, 10.0);
        assert_eq!(
            coefficients_at(&m, &th, f, fs),
            coefficients_at(p.as_ref(), &full, f, fs)
        );
        let mut c = vec![Complex64::new(0.0, 0.0); p.n_consts()];
        p.bin_consts(f, fs, &mut c);
        let bin = Bin { f, fs, consts: &c };
        let k = p.data_channels().len() * p.residual_channels().len();
        let deriv = |m: &dyn Model, x: &[f64], a: usize| {
            let mut d: Vec<Dual64> = x.iter().map(|&v| Dual64::from(v)).collect();
            d[a] = Dual64::from(x[a]).derivative();
            let mut out = vec![Complex::new(Dual64::from(0.0), Dual64::from(0.0)); k];
            m.coefficients_dual(&d, &bin, &mut out);
            out.iter()
                .map(|z| Complex64::new(z.re.eps, z.im.eps))
                .collect::<Vec<_>>()
        };
        let ds = deriv(&m, &th, np);
        let d0 = deriv(p.as_ref(), &full, 0);
        assert!(d0.iter().any(|z| z.norm() > 0.0));
        for (a, b) in ds.iter().zip(&d0) {
            assert!(
                (a - b * 2.5).norm() <= 1e-12 * b.norm().max(1e-30),
                "{a} {b}"
            );
        }
    }

    #[test]
    fn a_map_that_does_not_fit_is_refused() {
        let p: Arc<dyn Model> = Arc::new(AccelModel::new("a", AccelOptions::default()));
        let np = p.param_names().len();
        let names: Vec<String> = p.param_names().to_vec();
        let units = vec![String::new(); np];
        let short = Reparam::new((0..np - 1).map(|i| (i, None)).collect());
        assert!(ReparamModel::affine("r", p.clone(), names.clone(), units.clone(), short).is_err());
        let outside = Reparam::new((0..np).map(|i| (i, Some((np, 1.0)))).collect());
        assert!(ReparamModel::affine("r", p, names, units, outside).is_err());
    }
}

#[cfg(test)]
mod limit_tests {
    use super::carried_limits;

    /// A tied parameter keeps the narrowest of the limits tied to it; a parameter that is no
    /// parent parameter's base (a slope) has none.
    #[test]
    fn limits_carry_to_the_bases_and_tied_ones_narrow() {
        let parent = [[Some(0.0), None], [Some(-1.0), Some(2.0)], [None, None]];
        // own 0 is parent 0 and 1 (tied), own 1 is parent 2, own 2 is a slope
        let got = carried_limits(3, &parent, [(0, 0), (1, 0), (2, 1)]);
        assert_eq!(got, [[Some(0.0), Some(2.0)], [None, None], [None, None]]);
    }
}
