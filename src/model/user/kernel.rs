//! The prepared kernel of a user model ([`Model::prepare_kernel`]): its program
//! ([`super::ssa`], placed by [`super::plan`]) evaluated tier by tier — numbers once, frequency-only values once per bin
//! when prepared, θ-only values once per ln L — and the rest over chunks of bins, one
//! instruction at a time across the chunk, so the interpreter's dispatch is paid once per
//! instruction and chunk instead of once per instruction and bin, and the inner loops are
//! plain arithmetic over arrays.
//!
//! Its value equals the interpreter's ([`residual_power_generic`]) to rounding: every value is
//! computed by the same operations from the same operands, and the bins are summed in order —
//! bit for bit, except θ-dependent delays. Those are the one place where the interpreter pays a
//! `sin_cos` per bin; the kernel pays one per chunk, `e^{−iω_j τ} = e^{−iω_0 τ}·e^{−i j dω τ}`
//! with the steps `e^{−i j dω τ}` computed exactly once per θ, which is one more rounding
//! (about 1e−16 relative) per delay and bin.
//!
//! [`Model::prepare_kernel`]: crate::model::Model::prepare_kernel
//! [`residual_power_generic`]: crate::model::residual_power_generic

use super::block::Block;
use super::plan::{At, CHUNK, Lane, Plan, Program, Scratch, with_scratch};
use crate::model::bin::{BinBlock, quad};
use crate::model::traits::BlockKernel;
use num_complex::Complex64;
use std::f64::consts::PI;

/// A user model's kernel for one block of bins (see the module docs).
#[derive(Debug)]
pub(super) struct UserKernel {
    plan: Plan,
    nr: usize,
    nc: usize,
    /// Frequency-only values the plan keeps ([`Plan::bin_table`]).
    bins: Vec<f64>,
    /// Per block: where its phasor steps are, if it is a θ-dependent delay.
    step_at: Vec<Option<usize>>,
    f0: f64,
    df: f64,
    n: usize,
    /// The data by channel: real parts of channel `c` at `2c·n`, imaginary parts at
    /// `(2c + 1)·n`.
    data: Vec<f64>,
    cinv: Vec<(f64, Complex64, f64)>,
}

impl UserKernel {
    /// Prepares `m`'s kernel for `b`: the numbers and the frequency-only values.
    pub fn new(m: &Program, b: &BinBlock) -> UserKernel {
        let all: Vec<usize> = (0..m.nr * m.nc).collect();
        let plan = Plan::new(m, &all);
        let mut n_steps = 0;
        let step_at = m
            .blocks
            .iter()
            .zip(m.const_of)
            .map(|((_, blk), c)| match (blk, c) {
                (Block::Delay(_), None) => {
                    n_steps += CHUNK;
                    Some(n_steps - CHUNK)
                }
                _ => None,
            })
            .collect();
        let bins = plan.bin_table((0..b.n).map(|k| b.f0 + k as f64 * b.df), b.consts);
        let mut data = vec![0.0; 2 * m.nc * b.n];
        for (k, d) in b.data.chunks_exact(m.nc).enumerate() {
            for (c, d) in d.iter().enumerate() {
                data[2 * c * b.n + k] = d.re;
                data[(2 * c + 1) * b.n + k] = d.im;
            }
        }
        UserKernel {
            plan,
            nr: m.nr,
            nc: m.nc,
            bins,
            step_at,
            f0: b.f0,
            df: b.df,
            n: b.n,
            data,
            cinv: b.cinv.to_vec(),
        }
    }

    /// [`UserKernel::eval`] compiled for AVX2, so the chunk loops take four bins at a time;
    /// the operations are the same (no fused multiply-add), and so are the numbers.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn eval_avx2(&self, theta: &[f64], scratch: &mut Scratch) -> f64 {
        self.eval(theta, scratch)
    }

    /// `Σ_k r_kᴴ C_k⁻¹ r_k` with the buffers `scratch`.
    #[inline(always)]
    fn eval(&self, theta: &[f64], scratch: &mut Scratch) -> f64 {
        let Scratch {
            scalars,
            fields,
            steps,
            rows,
        } = scratch;
        self.plan.theta_values(theta, scalars, fields);
        steps.clear();
        for (k, at) in self.step_at.iter().enumerate() {
            if at.is_some() {
                let tau = self.plan.fields_of(k, fields)[0];
                steps.extend((0..CHUNK).map(|j| {
                    let (s, c) = (tau * (2.0 * PI * (j as f64 * self.df))).sin_cos();
                    Complex64::new(c, -s)
                }));
            }
        }
        self.plan.size_rows(rows);
        let (nc, nr, n) = (self.nc, self.nr, self.n);
        let mut s = 0.0;
        let mut k0 = 0;
        while k0 < n {
            let len = CHUNK.min(n - k0);
            let chunk_f0 = self.f0 + k0 as f64 * self.df;
            self.plan.run_chunk(
                scalars,
                fields,
                &self.bins,
                n,
                rows,
                k0,
                len,
                |k, blk, v, re, im| {
                    if let Some(at) = self.step_at[k] {
                        // e^{−iω_j τ} = e^{−iω_0 τ}·e^{−i j dω τ}: one sin_cos per chunk
                        let anchor = blk.response(v, chunk_f0);
                        for ((re, im), st) in re.iter_mut().zip(im).zip(&steps[at..at + len]) {
                            let z = anchor * st;
                            (*re, *im) = (z.re, z.im);
                        }
                    } else {
                        for (j, (re, im)) in re.iter_mut().zip(im).enumerate() {
                            let z = blk.response(v, self.f0 + (k0 + j) as f64 * self.df);
                            (*re, *im) = (z.re, z.im);
                        }
                    }
                },
            );
            let at = At {
                scalars,
                bins: &self.bins,
                n,
                rows,
                k0,
                len,
            };
            // r = M d as the interpreter sums it (row by row, channel by channel), a chunk at
            // a time
            let mut r = [[[0.0; CHUNK]; 2]; 2];
            for (ri, [are, aim]) in r.iter_mut().enumerate().take(nr) {
                let (are, aim) = (&mut are[..len], &mut aim[..len]);
                for c in 0..nc {
                    let dre = &self.data[2 * c * n + k0..][..len];
                    let dim = &self.data[(2 * c + 1) * n + k0..][..len];
                    let mut add = |j: usize, m: Complex64| {
                        let mut a = Complex64::new(are[j], aim[j]);
                        a += m * Complex64::new(dre[j], dim[j]);
                        (are[j], aim[j]) = (a.re, a.im);
                    };
                    match self.plan.output(ri * nc + c, &at) {
                        Lane::One(m) => (0..len).for_each(|j| add(j, m)),
                        Lane::Each(mre, mim) => {
                            let (mre, mim) = (&mre[..len], &mim[..len]);
                            (0..len).for_each(|j| add(j, Complex64::new(mre[j], mim[j])))
                        }
                    }
                }
            }
            let mut q = [0.0; CHUNK];
            let [[r0re, r0im], [r1re, r1im]] = &r;
            for (j, (q, cinv)) in q[..len]
                .iter_mut()
                .zip(&self.cinv[k0..k0 + len])
                .enumerate()
            {
                let r0 = Complex64::new(r0re[j], r0im[j]);
                let r1 = Complex64::new(r1re[j], r1im[j]);
                *q = quad(cinv, [r0, r1]);
            }
            // summed in bin order, as the interpreter sums
            for q in &q[..len] {
                s += q;
            }
            k0 += len;
        }
        s
    }
}

impl BlockKernel for UserKernel {
    fn residual_power(&self, theta: &[f64]) -> f64 {
        with_scratch(|s| {
            #[cfg(target_arch = "x86_64")]
            if std::arch::is_x86_feature_detected!("avx2") {
                // SAFETY: the CPU has the feature the function is compiled for.
                return unsafe { self.eval_avx2(theta, s) };
            }
            self.eval(theta, s)
        })
    }
}
