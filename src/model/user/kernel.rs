//! The prepared kernel of a user model ([`Model::prepare_kernel`]): its program
//! ([`super::ssa`]) evaluated tier by tier — numbers once, frequency-only values once per bin
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
    /// Frequency-only values the plan keeps, row-major: `bins[r·n + k]`.
    bins: Vec<Complex64>,
    /// Per block: where its phasor steps are, if it is a θ-dependent delay.
    step_at: Vec<Option<usize>>,
    f0: f64,
    df: f64,
    n: usize,
    data: Vec<Complex64>,
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
        UserKernel {
            plan,
            nr: m.nr,
            nc: m.nc,
            bins,
            step_at,
            f0: b.f0,
            df: b.df,
            n: b.n,
            data: b.data.to_vec(),
            cinv: b.cinv.to_vec(),
        }
    }

    /// `Σ_k r_kᴴ C_k⁻¹ r_k` with the buffers `scratch`.
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
        let (nc, nr) = (self.nc, self.nr);
        let zero = Complex64::new(0.0, 0.0);
        let mut s = 0.0;
        let mut k0 = 0;
        while k0 < self.n {
            let len = CHUNK.min(self.n - k0);
            let chunk_f0 = self.f0 + k0 as f64 * self.df;
            self.plan.run_chunk(
                scalars,
                fields,
                &self.bins,
                self.n,
                rows,
                k0,
                len,
                |k, blk, v, out| {
                    if let Some(at) = self.step_at[k] {
                        // e^{−iω_j τ} = e^{−iω_0 τ}·e^{−i j dω τ}: one sin_cos per chunk
                        let anchor = blk.response(v, chunk_f0);
                        for (o, st) in out.iter_mut().zip(&steps[at..at + len]) {
                            *o = anchor * st;
                        }
                    } else {
                        for (j, o) in out.iter_mut().enumerate() {
                            *o = blk.response(v, self.f0 + (k0 + j) as f64 * self.df);
                        }
                    }
                },
            );
            let at = At {
                scalars,
                bins: &self.bins,
                n: self.n,
                rows,
                k0,
                len,
            };
            // r = M d as the interpreter sums it (row by row, channel by channel), a chunk at
            // a time
            let mut r = [[zero; CHUNK]; 2];
            for (ri, acc) in r.iter_mut().enumerate().take(nr) {
                for c in 0..nc {
                    let d = self.data[k0 * nc + c..].iter().step_by(nc);
                    match self.plan.output(ri * nc + c, &at) {
                        Lane::One(m) => {
                            for (a, x) in acc[..len].iter_mut().zip(d) {
                                *a += m * x;
                            }
                        }
                        Lane::Each(m) => {
                            for ((a, m), x) in acc[..len].iter_mut().zip(m).zip(d) {
                                *a += m * x;
                            }
                        }
                    }
                }
            }
            for (j, cinv) in self.cinv[k0..k0 + len].iter().enumerate() {
                s += quad(cinv, [r[0][j], r[1][j]]);
            }
            k0 += len;
        }
        s
    }
}

impl BlockKernel for UserKernel {
    fn residual_power(&self, theta: &[f64]) -> f64 {
        with_scratch(|s| self.eval(theta, s))
    }
}
