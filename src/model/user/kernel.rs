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
use super::expr::Op;
use super::ssa::{Inst, Ssa, Tier, apply, operands};
use crate::model::bin::{BinBlock, MAX_CHANNELS, quad};
use crate::model::traits::BlockKernel;
use num_complex::Complex64;
use std::cell::RefCell;
use std::f64::consts::PI;

/// Bins evaluated together.
const CHUNK: usize = 64;

/// Where a value lives while the kernel runs.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Loc {
    /// In the per-θ scalars (numbers and θ-only values).
    Scalar,
    /// Row `r` of the per-bin table.
    Bin(usize),
    /// Row `r` of the chunk's scratch.
    Chunk(usize),
    /// Read by nothing later.
    Dead,
}

/// A value across one chunk: the same for every bin, or one per bin.
#[derive(Clone, Copy)]
enum Lane<'a> {
    One(Complex64),
    Each(&'a [Complex64]),
}

/// Where an output coefficient is read per bin: the same value for every bin, or the start of
/// its row in the per-bin table (indexed by bin) or in the chunk's scratch (indexed by the bin
/// within the chunk).
#[derive(Clone, Copy)]
enum Out {
    One(Complex64),
    Bin(usize),
    Chunk(usize),
}

/// What the kernel needs of a user model: its used blocks, which of them are per-bin
/// constants, its program and its shape.
#[derive(Debug, Clone, Copy)]
pub(super) struct Program<'a> {
    pub blocks: &'a [(String, Block)],
    pub const_of: &'a [Option<usize>],
    pub ops: &'a [Op],
    pub n_consts: usize,
    /// Residual channels.
    pub nr: usize,
    /// Data channels.
    pub nc: usize,
}

/// A user model's kernel for one block of bins (see the module docs).
#[derive(Debug)]
pub(super) struct UserKernel {
    blocks: Vec<Block>,
    nr: usize,
    nc: usize,
    ssa: Ssa,
    loc: Vec<Loc>,
    /// Every number of the program (θ-only entries are filled per ln L).
    fixed: Vec<Complex64>,
    /// Frequency-only values read later, row-major: `bins[r·n + k]`.
    bins: Vec<Complex64>,
    n_chunk_rows: usize,
    /// Offset of each block's field values in the per-θ field buffer.
    field_at: Vec<usize>,
    n_fields: usize,
    /// Per block: where its phasor steps are, if it is a θ-dependent delay.
    step_at: Vec<Option<usize>>,
    f0: f64,
    df: f64,
    n: usize,
    data: Vec<Complex64>,
    cinv: Vec<(f64, Complex64, f64)>,
}

/// The buffers of one evaluation.
#[derive(Debug, Default)]
struct Scratch {
    /// Per θ: numbers and θ-only values, by instruction.
    scalars: Vec<Complex64>,
    /// Per θ: the blocks' field values.
    fields: Vec<f64>,
    /// Per θ: `e^{−i 2π j df τ}`, `j < CHUNK`, of each θ-dependent delay.
    steps: Vec<Complex64>,
    /// Per chunk: the values that depend on θ and the frequency.
    rows: Vec<Complex64>,
}

thread_local! {
    /// Per-thread buffers of the kernels: allocated once per thread, reused by every
    /// evaluation.
    static SCRATCH: RefCell<Scratch> = RefCell::new(Scratch::default());
}

impl UserKernel {
    /// Prepares `m`'s kernel for `b`: the numbers and the frequency-only values.
    pub fn new(m: &Program, b: &BinBlock) -> UserKernel {
        let is_const: Vec<bool> = m.const_of.iter().map(Option::is_some).collect();
        let ncoef = m.nr * m.nc;
        let ssa = Ssa::new(m.ops, &is_const, ncoef);
        let later = ssa.read_later();
        let mut loc = Vec::with_capacity(ssa.insts.len());
        let (mut nb, mut nm) = (0, 0);
        for (i, t) in ssa.tiers.iter().enumerate() {
            loc.push(match t {
                Tier::Fixed | Tier::Theta => Loc::Scalar,
                Tier::Bin if later[i] => {
                    nb += 1;
                    Loc::Bin(nb - 1)
                }
                Tier::Bin => Loc::Dead,
                Tier::Mixed => {
                    nm += 1;
                    Loc::Chunk(nm - 1)
                }
            });
        }
        let mut fixed = vec![Complex64::new(0.0, 0.0); ssa.insts.len()];
        for (i, inst) in ssa.insts.iter().enumerate() {
            if ssa.tiers[i] == Tier::Fixed {
                fixed[i] = scalar_value(inst, &fixed, &[]);
            }
        }
        let mut field_at = Vec::with_capacity(m.blocks.len());
        let mut n_fields = 0;
        for (_, blk) in m.blocks {
            field_at.push(n_fields);
            n_fields += blk.n_fields();
        }
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
        let bins = bin_table(m, &ssa, &loc, &fixed, b, nb);
        UserKernel {
            blocks: m.blocks.iter().map(|(_, b)| b.clone()).collect(),
            nr: m.nr,
            nc: m.nc,
            ssa,
            loc,
            fixed,
            bins,
            n_chunk_rows: nm,
            field_at,
            n_fields,
            step_at,
            f0: b.f0,
            df: b.df,
            n: b.n,
            data: b.data.to_vec(),
            cinv: b.cinv.to_vec(),
        }
    }

    /// The value of `v` across the chunk starting at bin `k0` with `len` bins.
    #[inline(always)]
    fn lane<'a>(
        &'a self,
        v: u32,
        scalars: &[Complex64],
        rows: &'a [Complex64],
        k0: usize,
        len: usize,
    ) -> Lane<'a> {
        match self.loc[v as usize] {
            Loc::Scalar => Lane::One(scalars[v as usize]),
            Loc::Bin(r) => Lane::Each(&self.bins[r * self.n + k0..r * self.n + k0 + len]),
            Loc::Chunk(r) => Lane::Each(&rows[r * CHUNK..r * CHUNK + len]),
            Loc::Dead => unreachable!("a value read later is kept"),
        }
    }

    /// The chunk's per-bin values (rows of `rows`) for bins `k0..k0 + len`.
    fn run_chunk(
        &self,
        scalars: &[Complex64],
        fields: &[f64],
        steps: &[Complex64],
        rows: &mut [Complex64],
        k0: usize,
        len: usize,
    ) {
        for (i, inst) in self.ssa.insts.iter().enumerate() {
            let Loc::Chunk(r) = self.loc[i] else {
                continue;
            };
            let (done, rest) = rows.split_at_mut(r * CHUNK);
            let out = &mut rest[..len];
            if let Inst::Block(k) = *inst {
                let k = k as usize;
                let blk = &self.blocks[k];
                let v = &fields[self.field_at[k]..self.field_at[k] + blk.n_fields()];
                if let Some(at) = self.step_at[k] {
                    // e^{−iω_j τ} = e^{−iω_0 τ}·e^{−i j dω τ}: one sin_cos per chunk
                    let anchor = blk.response(v, self.f0 + k0 as f64 * self.df);
                    for (o, st) in out.iter_mut().zip(&steps[at..at + len]) {
                        *o = anchor * st;
                    }
                    continue;
                }
                for (j, o) in out.iter_mut().enumerate() {
                    let f = self.f0 + (k0 + j) as f64 * self.df;
                    *o = blk.response(v, f);
                }
                continue;
            }
            let mut ops = operands(inst);
            let a = self.lane(ops.next().expect("arithmetic"), scalars, done, k0, len);
            let b = match ops.next() {
                Some(b) => self.lane(b, scalars, done, k0, len),
                None => Lane::One(Complex64::new(0.0, 0.0)),
            };
            // one loop per operation, so the operation is not chosen per bin
            match *inst {
                Inst::Add(..) => each(a, b, out, apply_add),
                Inst::Sub(..) => each(a, b, out, |mut x, y| {
                    x -= y;
                    x
                }),
                Inst::Mul(..) => each(a, b, out, |mut x, y| {
                    x *= y;
                    x
                }),
                Inst::Div(..) => each(a, b, out, |mut x, y| {
                    x /= y;
                    x
                }),
                _ => each(a, b, out, |x, y| apply(inst, x, y)),
            }
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
        scalars.clear();
        scalars.extend_from_slice(&self.fixed);
        for (i, inst) in self.ssa.insts.iter().enumerate() {
            if self.ssa.tiers[i] == Tier::Theta {
                scalars[i] = scalar_value(inst, scalars, theta);
            }
        }
        fields.resize(self.n_fields, 0.0);
        for (blk, &at) in self.blocks.iter().zip(&self.field_at) {
            blk.field_values(theta, &mut fields[at..at + blk.n_fields()]);
        }
        steps.clear();
        for (k, at) in self.step_at.iter().enumerate() {
            if at.is_some() {
                let tau = fields[self.field_at[k]];
                steps.extend((0..CHUNK).map(|j| {
                    let (s, c) = (tau * (2.0 * PI * (j as f64 * self.df))).sin_cos();
                    Complex64::new(c, -s)
                }));
            }
        }
        rows.resize(self.n_chunk_rows * CHUNK, Complex64::new(0.0, 0.0));
        let (nc, nr) = (self.nc, self.nr);
        let zero = Complex64::new(0.0, 0.0);
        let mut outs = [Out::One(zero); MAX_CHANNELS * 2];
        for (o, v) in outs.iter_mut().zip(&self.ssa.outs) {
            *o = match v.map(|v| (v, self.loc[v as usize])) {
                None => Out::One(zero),
                Some((v, Loc::Scalar)) => Out::One(scalars[v as usize]),
                Some((_, Loc::Bin(r))) => Out::Bin(r * self.n),
                Some((_, Loc::Chunk(r))) => Out::Chunk(r * CHUNK),
                Some((_, Loc::Dead)) => unreachable!("an output is kept"),
            };
        }
        let outs = &outs[..nr * nc];
        let mut s = 0.0;
        let mut k0 = 0;
        while k0 < self.n {
            let len = CHUNK.min(self.n - k0);
            self.run_chunk(scalars, fields, steps, rows, k0, len);
            // r = M d as the interpreter sums it (row by row, channel by channel), a chunk at
            // a time
            let mut r = [[zero; CHUNK]; 2];
            for (ri, acc) in r.iter_mut().enumerate().take(nr) {
                for (c, o) in outs[ri * nc..(ri + 1) * nc].iter().enumerate() {
                    let m = match *o {
                        Out::One(x) => Lane::One(x),
                        Out::Bin(at) => Lane::Each(&self.bins[at + k0..at + k0 + len]),
                        Out::Chunk(at) => Lane::Each(&rows[at..at + len]),
                    };
                    let d = self.data[k0 * nc + c..].iter().step_by(nc);
                    match m {
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
        SCRATCH.with(|s| match s.try_borrow_mut() {
            Ok(mut s) => self.eval(theta, &mut s),
            // re-entered on this thread (never in occam): own buffers
            Err(_) => self.eval(theta, &mut Default::default()),
        })
    }
}

/// `x += y` as the interpreter writes it.
#[inline(always)]
fn apply_add(mut x: Complex64, y: Complex64) -> Complex64 {
    x += y;
    x
}

/// `out[j] = f(a[j], b[j])` over a chunk.
#[inline(always)]
fn each<F: Fn(Complex64, Complex64) -> Complex64>(a: Lane, b: Lane, out: &mut [Complex64], f: F) {
    match (a, b) {
        (Lane::Each(x), Lane::Each(y)) => {
            for ((o, &x), &y) in out.iter_mut().zip(x).zip(y) {
                *o = f(x, y);
            }
        }
        (Lane::Each(x), Lane::One(y)) => {
            for (o, &x) in out.iter_mut().zip(x) {
                *o = f(x, y);
            }
        }
        (Lane::One(x), Lane::Each(y)) => {
            for (o, &y) in out.iter_mut().zip(y) {
                *o = f(x, y);
            }
        }
        (Lane::One(x), Lane::One(y)) => out.fill(f(x, y)),
    }
}

/// The value of a number or θ-only instruction, its operands already in `vals`.
fn scalar_value(inst: &Inst, vals: &[Complex64], theta: &[f64]) -> Complex64 {
    match *inst {
        Inst::Const(c) => c,
        Inst::Param(i) => Complex64::new(theta[i as usize], 0.0),
        Inst::S | Inst::Block(_) => unreachable!("depends on the frequency"),
        _ => {
            let mut ops = operands(inst);
            let a = vals[ops.next().expect("arithmetic") as usize];
            let b = ops
                .next()
                .map_or(Complex64::new(0.0, 0.0), |b| vals[b as usize]);
            apply(inst, a, b)
        }
    }
}

/// The frequency-only values read later, `nb` rows of `b.n` bins.
fn bin_table(
    m: &Program,
    ssa: &Ssa,
    loc: &[Loc],
    fixed: &[Complex64],
    b: &BinBlock,
    nb: usize,
) -> Vec<Complex64> {
    let mut out = vec![Complex64::new(0.0, 0.0); nb * b.n];
    let mut vals = fixed.to_vec();
    for k in 0..b.n {
        let bin = b.bin(k, m.n_consts);
        for (i, inst) in ssa.insts.iter().enumerate() {
            if ssa.tiers[i] != Tier::Bin {
                continue;
            }
            vals[i] = match *inst {
                Inst::S => Complex64::new(0.0, 2.0 * PI * bin.f),
                Inst::Block(blk) => {
                    bin.consts[m.const_of[blk as usize].expect("a frequency-only block")]
                }
                _ => {
                    let mut ops = operands(inst);
                    let a = vals[ops.next().expect("arithmetic") as usize];
                    let c = ops
                        .next()
                        .map_or(Complex64::new(0.0, 0.0), |c| vals[c as usize]);
                    apply(inst, a, c)
                }
            };
            if let Loc::Bin(r) = loc[i] {
                out[r * b.n + k] = vals[i];
            }
        }
    }
    out
}
