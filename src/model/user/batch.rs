//! The prepared coefficients of a user model at fixed frequencies ([`Model::prepare_batch`]):
//! what relative binning asks of the model per θ at its coarse-bin edges. The plan
//! ([`super::plan`]) keeps only the values the requested components need, its frequency-only
//! values are computed once when prepared, and the rest per θ over the edges, one instruction
//! at a time across them.
//!
//! Its values equal the interpreter's ([`coefficients_batch_generic`]) bit for bit: every
//! value is computed by the same operations from the same operands, θ-dependent blocks
//! included (a delay pays its `sin_cos` per edge, as the interpreter does: the edges are not
//! evenly spaced).
//!
//! [`Model::prepare_batch`]: crate::model::Model::prepare_batch
//! [`coefficients_batch_generic`]: crate::model::coefficients_batch_generic

use super::plan::{At, CHUNK, Lane, Plan, Program, Scratch, with_scratch};
use crate::model::traits::BatchKernel;
use num_complex::Complex64;

/// A user model's coefficients at fixed frequencies (see the module docs).
#[derive(Debug)]
pub(super) struct UserBatch {
    plan: Plan,
    freqs: Vec<f64>,
    comps: Vec<usize>,
    /// Frequency-only values the plan keeps ([`Plan::bin_table`]).
    bins: Vec<f64>,
}

impl UserBatch {
    /// Prepares the components `comps` of `m` at `freqs` (constants `consts`, bin-major).
    pub fn new(m: &Program, freqs: &[f64], consts: &[Complex64], comps: &[usize]) -> UserBatch {
        let plan = Plan::new(m, comps);
        let bins = plan.bin_table(freqs.iter().copied(), consts);
        UserBatch {
            plan,
            freqs: freqs.to_vec(),
            comps: comps.to_vec(),
            bins,
        }
    }

    /// [`UserBatch::eval`] compiled for AVX2, so the loops over edges take four at a time;
    /// the operations are the same (no fused multiply-add), and so are the numbers.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn eval_avx2(&self, theta: &[f64], out: &mut [Complex64], scratch: &mut Scratch) {
        self.eval(theta, out, scratch)
    }

    #[inline(always)]
    fn eval(&self, theta: &[f64], out: &mut [Complex64], scratch: &mut Scratch) {
        let Scratch {
            scalars,
            fields,
            rows,
            ..
        } = scratch;
        let n = self.freqs.len();
        let nc = self.comps.len();
        assert_eq!(
            out.len(),
            n * nc,
            "one value per prepared edge and component"
        );
        self.plan.theta_values(theta, scalars, fields);
        self.plan.size_rows(rows);
        let mut k0 = 0;
        while k0 < n {
            let len = CHUNK.min(n - k0);
            let freqs = &self.freqs[k0..k0 + len];
            self.plan.run_chunk(
                scalars,
                fields,
                &self.bins,
                n,
                rows,
                k0,
                len,
                |_, blk, v, re, im| {
                    for ((re, im), &f) in re.iter_mut().zip(im).zip(freqs) {
                        let z = blk.response(v, f);
                        (*re, *im) = (z.re, z.im);
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
            let out = &mut out[k0 * nc..(k0 + len) * nc];
            for (i, &c) in self.comps.iter().enumerate() {
                let o = out[i..].iter_mut().step_by(nc);
                match self.plan.output(c, &at) {
                    Lane::One(x) => o.for_each(|o| *o = x),
                    Lane::Each(re, im) => o
                        .zip(re.iter().zip(im))
                        .for_each(|(o, (&re, &im))| *o = Complex64::new(re, im)),
                }
            }
            k0 += len;
        }
    }
}

impl BatchKernel for UserBatch {
    fn coefficients(&self, theta: &[f64], out: &mut [Complex64]) {
        with_scratch(|s| {
            #[cfg(target_arch = "x86_64")]
            if std::arch::is_x86_feature_detected!("avx2") {
                // SAFETY: the CPU has the feature the function is compiled for.
                return unsafe { self.eval_avx2(theta, out, s) };
            }
            self.eval(theta, out, s)
        })
    }
}
