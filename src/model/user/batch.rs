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
    /// Frequency-only values the plan keeps, row-major: `bins[r·n + e]`.
    bins: Vec<Complex64>,
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
                |_, blk, v, out| {
                    for (o, &f) in out.iter_mut().zip(freqs) {
                        *o = blk.response(v, f);
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
                    Lane::Each(x) => o.zip(x).for_each(|(o, &x)| *o = x),
                }
            }
            k0 += len;
        }
    }
}

impl BatchKernel for UserBatch {
    fn coefficients(&self, theta: &[f64], out: &mut [Complex64]) {
        with_scratch(|s| self.eval(theta, out, s))
    }
}
