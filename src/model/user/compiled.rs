//! [`UserModel`]: a compiled user-defined model, evaluated through the [`Model`] trait.

use super::batch::UserBatch;
use super::block::Block;
use super::expr::{self, Op};
use super::kernel::UserKernel;
use super::plan::Program;
use crate::model::bin::{Bin, BinBlock};
use crate::model::traits::{BatchKernel, BlockKernel, Model};
use num_complex::{Complex, Complex64};
use num_dual::{Dual64, DualNum};
use std::f64::consts::PI;
use std::sync::Arc;

/// Most blocks and defines (together) a model may evaluate.
pub const MAX_SLOTS: usize = 256;

/// A compiled user-defined model.
#[derive(Debug, Clone)]
pub struct UserModel {
    pub(super) name: String,
    pub(super) params: Vec<String>,
    /// Unit of each parameter, in θ order (empty: dimensionless or unknown).
    pub(super) units: Vec<String>,
    /// The physical limits of each parameter (`physical_limits`), in θ order.
    pub(super) limits: Vec<[Option<f64>; 2]>,
    pub(super) data: Vec<String>,
    /// Unit of each data channel, in the order of `data` (empty: unknown).
    pub(super) channel_units: Vec<String>,
    pub(super) res: Vec<String>,
    /// Blocks some coefficient uses; block `k` lives in slot `k`.
    pub(super) blocks: Vec<(String, Block)>,
    /// Per used block: its index among the per-bin constants, if θ-independent.
    pub(super) const_of: Vec<Option<usize>>,
    pub(super) n_consts: usize,
    /// Defines (stored into slots after the blocks) then coefficients (`Out`).
    pub(super) ops: Vec<Op>,
    pub(super) n_slots: usize,
    /// `blocks.<name>` per block slot, then `define.<name>` per define slot (for messages).
    pub(super) slot_names: Vec<String>,
}

impl UserModel {
    /// What the prepared kernels read.
    fn program(&self) -> Program<'_> {
        Program {
            blocks: &self.blocks,
            const_of: &self.const_of,
            ops: &self.ops,
            n_consts: self.n_consts,
            nr: self.res.len(),
            nc: self.data.len(),
        }
    }

    fn fill<T: DualNum<Primitive = f64> + Copy>(
        &self,
        th: &[T],
        bin: &Bin,
        out: &mut [Complex<T>],
    ) {
        match self.n_slots {
            0..=16 => self.fill_n::<T, 16>(th, bin, out),
            17..=64 => self.fill_n::<T, 64>(th, bin, out),
            _ => self.fill_n::<T, MAX_SLOTS>(th, bin, out),
        }
    }

    #[inline]
    fn fill_n<T: DualNum<Primitive = f64> + Copy, const N: usize>(
        &self,
        th: &[T],
        bin: &Bin,
        out: &mut [Complex<T>],
    ) {
        let zero = Complex::new(T::zero(), T::zero());
        let mut slots = [zero; N];
        for (k, (_, b)) in self.blocks.iter().enumerate() {
            slots[k] = match self.const_of[k] {
                Some(c) => expr::lift(bin.consts[c]),
                None => b.eval(th, bin.f),
            };
        }
        out.fill(zero);
        expr::run(&self.ops, th, 2.0 * PI * bin.f, &mut slots, out);
    }
}

impl Model for UserModel {
    fn name(&self) -> &str {
        &self.name
    }

    fn param_names(&self) -> &[String] {
        &self.params
    }

    fn param_units(&self) -> Vec<String> {
        self.units.clone()
    }

    fn physical_limits(&self) -> Vec<[Option<f64>; 2]> {
        self.limits.clone()
    }

    fn data_channels(&self) -> &[String] {
        &self.data
    }

    fn channel_units(&self) -> Vec<String> {
        self.channel_units.clone()
    }

    fn residual_channels(&self) -> &[String] {
        &self.res
    }

    fn n_consts(&self) -> usize {
        self.n_consts
    }

    fn bin_consts(&self, f: f64, _fs: f64, out: &mut [Complex64]) {
        for ((_, b), c) in self.blocks.iter().zip(&self.const_of) {
            if let Some(c) = *c {
                out[c] = b.eval::<f64>(&[], f);
            }
        }
    }

    fn coefficients(&self, theta: &[f64], bin: &Bin, out: &mut [Complex64]) {
        self.fill(theta, bin, out);
    }

    fn coefficients_dual(&self, theta: &[Dual64], bin: &Bin, out: &mut [Complex<Dual64>]) {
        self.fill(theta, bin, out);
    }

    /// The compiled coefficients (`batch.rs`): the interpreter's numbers, bit for bit,
    /// with only what the components `comps` need computed per θ.
    fn prepare_batch(
        &self,
        freqs: &[f64],
        _fs: f64,
        consts: &[Complex64],
        comps: &[usize],
    ) -> Option<Arc<dyn BatchKernel>> {
        Some(Arc::new(UserBatch::new(
            &self.program(),
            freqs,
            consts,
            comps,
        )))
    }

    /// The compiled kernel (`kernel.rs`): the interpreter's numbers (to 1e−12) without
    /// its per-bin dispatch, for one or two residual channels (the packed noise inverse); more
    /// channels take the generic whitened path.
    fn prepare_kernel(&self, block: &BinBlock) -> Option<Arc<dyn BlockKernel>> {
        (self.res.len() <= 2)
            .then(|| Arc::new(UserKernel::new(&self.program(), block)) as Arc<dyn BlockKernel>)
    }

    /// Evaluates the blocks, then each define and coefficient on its own (each is one run of
    /// the program ending in a store), and names the first that is not finite with the cause
    /// its value points to.
    fn explain_non_finite(&self, theta: &[f64], f: f64, _fs: f64) -> Option<String> {
        let zero = Complex64::new(0.0, 0.0);
        let mut slots = vec![zero; self.n_slots];
        let bad = |z: Complex64| !(z.re.is_finite() && z.im.is_finite());
        for (k, (name, b)) in self.blocks.iter().enumerate() {
            slots[k] = b.eval::<f64>(theta, f);
            if bad(slots[k]) {
                return Some(format!("blocks.{name} is {} here", slots[k]));
            }
        }
        let mut out = vec![zero; self.data.len() * self.res.len()];
        let (mut start, omega) = (0, 2.0 * PI * f);
        for (i, op) in self.ops.iter().enumerate() {
            let (value, what) = match *op {
                Op::Store(s) => {
                    expr::run(&self.ops[start..=i], theta, omega, &mut slots, &mut out);
                    (slots[s as usize], self.slot_names[s as usize].clone())
                }
                Op::Out(c) => {
                    expr::run(&self.ops[start..=i], theta, omega, &mut slots, &mut out);
                    let (r, d) = (c as usize / self.data.len(), c as usize % self.data.len());
                    (
                        out[c as usize],
                        format!("coefficients.{}.{}", self.res[r], self.data[d]),
                    )
                }
                _ => continue,
            };
            let segment = &self.ops[start..=i];
            start = i + 1;
            if bad(value) {
                let why = expr::first_fault(segment, theta, omega, &slots)
                    .unwrap_or("a non-finite intermediate value");
                return Some(format!("{what} is {value}: {why}"));
            }
        }
        None
    }

    /// θ has the right length and finite values, and every θ-dependent block field is
    /// possible (pole frequencies and quality factors > 0, delays ≥ 0, a denominator that is
    /// not identically zero).
    fn check(&self, theta: &[f64]) -> Result<(), String> {
        let m = &self.name;
        if theta.len() != self.params.len() {
            return Err(format!(
                "user model `{m}`: θ has {} values for {} parameters",
                theta.len(),
                self.params.len()
            ));
        }
        if let Some((p, x)) = self.params.iter().zip(theta).find(|(_, x)| !x.is_finite()) {
            return Err(format!(
                "user model `{m}`: parameter `{p}` is {x}, not finite"
            ));
        }
        for (bn, b) in &self.blocks {
            b.check_values(&|v| Some(v.eval::<f64>(theta)))
                .map_err(|(field, msg)| {
                    format!("user model `{m}`: blocks.{bn}.{field} {msg} at this θ")
                })?;
        }
        Ok(())
    }
}
