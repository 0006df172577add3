//! The evaluation plan shared by a user model's prepared kernels — [`super::kernel`] (the exact
//! likelihood over a block of bins) and [`super::batch`] (the coefficients at relative
//! binning's coarse-bin edges): its program ([`super::ssa`]) with a place for every value —
//! numbers and θ-only values once per θ, frequency-only values in a table filled once when the
//! kernel is prepared, the rest per chunk of frequencies, one instruction at a time across the
//! chunk — and the loops that fill those places.
//!
//! Every value is computed by the interpreter's operations ([`apply`]) from the same operands,
//! so a value of the plan equals the interpreter's bit for bit; a kernel that computes a block's
//! response differently (the exact kernel's delay phasors) says so.

use super::block::Block;
use super::expr::{Op, powi};
use super::ssa::{Inst, Ssa, Tier, apply, operands};
use num_complex::Complex64;
use std::cell::RefCell;
use std::f64::consts::PI;

/// Frequencies evaluated together.
pub(super) const CHUNK: usize = 64;

const ZERO: Complex64 = Complex64::new(0.0, 0.0);

/// What a kernel needs of a user model: its used blocks, which of them are per-bin
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

/// Where a value lives while a kernel runs.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Loc {
    /// In the per-θ scalars (numbers and θ-only values).
    Scalar,
    /// Row `r` of the frequency-only table.
    Bin(usize),
    /// Row `r` of the chunk's scratch.
    Chunk(usize),
    /// Read by nothing the kernel computes.
    Dead,
}

/// A value across one chunk: the same at every frequency, or one per frequency (real and
/// imaginary parts apart, so the loops over a chunk vectorise).
#[derive(Clone, Copy)]
pub(super) enum Lane<'a> {
    One(Complex64),
    Each(&'a [f64], &'a [f64]),
}

/// The per-θ and per-chunk buffers of one evaluation.
#[derive(Debug, Default)]
pub(super) struct Scratch {
    /// Per θ: numbers and θ-only values, by instruction.
    pub scalars: Vec<Complex64>,
    /// Per θ: the blocks' field values.
    pub fields: Vec<f64>,
    /// Per θ, for a kernel's own use (the exact kernel's delay phasors).
    pub steps: Vec<Complex64>,
    /// Per chunk: the values that depend on θ and the frequency; row `r` has its real parts
    /// at `2r·CHUNK`, its imaginary parts at `(2r + 1)·CHUNK`.
    pub rows: Vec<f64>,
}

thread_local! {
    /// Per-thread buffers of the kernels: allocated once per thread, reused by every
    /// evaluation.
    static SCRATCH: RefCell<Scratch> = RefCell::new(Scratch::default());
}

/// `f` with this thread's buffers.
pub(super) fn with_scratch<R>(f: impl FnOnce(&mut Scratch) -> R) -> R {
    SCRATCH.with(|s| match s.try_borrow_mut() {
        Ok(mut s) => f(&mut s),
        // re-entered on this thread (never in occam): own buffers
        Err(_) => f(&mut Scratch::default()),
    })
}

/// A user model's program with a place for every value (see the module docs).
#[derive(Debug)]
pub(super) struct Plan {
    pub blocks: Vec<Block>,
    const_of: Vec<Option<usize>>,
    n_consts: usize,
    ssa: Ssa,
    loc: Vec<Loc>,
    /// Every number of the program (θ-only entries are filled per θ).
    fixed: Vec<Complex64>,
    n_bin_rows: usize,
    n_chunk_rows: usize,
    /// The instructions computed per chunk, in order.
    chunk_insts: Vec<u32>,
    /// Offset of each block's field values in the per-θ field buffer.
    field_at: Vec<usize>,
    n_fields: usize,
}

impl Plan {
    /// The plan of `m` for the output coefficients `wanted` (indices `r·C + c`): values that
    /// no wanted output reads are not computed.
    pub fn new(m: &Program, wanted: &[usize]) -> Plan {
        let is_const: Vec<bool> = m.const_of.iter().map(Option::is_some).collect();
        let ssa = Ssa::new(m.ops, &is_const, m.nr * m.nc);
        let live = ssa.live(wanted);
        let later = ssa.read_later(&live, wanted);
        let mut loc = Vec::with_capacity(ssa.insts.len());
        let (mut nb, mut nm) = (0, 0);
        for (i, t) in ssa.tiers.iter().enumerate() {
            loc.push(match t {
                Tier::Fixed | Tier::Theta => Loc::Scalar,
                Tier::Bin if later[i] => {
                    nb += 1;
                    Loc::Bin(nb - 1)
                }
                Tier::Mixed if live[i] => {
                    nm += 1;
                    Loc::Chunk(nm - 1)
                }
                Tier::Bin | Tier::Mixed => Loc::Dead,
            });
        }
        let mut fixed = vec![ZERO; ssa.insts.len()];
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
        let chunk_insts = (0..loc.len() as u32)
            .filter(|&i| matches!(loc[i as usize], Loc::Chunk(_)))
            .collect();
        Plan {
            blocks: m.blocks.iter().map(|(_, b)| b.clone()).collect(),
            const_of: m.const_of.to_vec(),
            n_consts: m.n_consts,
            ssa,
            loc,
            fixed,
            n_bin_rows: nb,
            n_chunk_rows: nm,
            chunk_insts,
            field_at,
            n_fields,
        }
    }

    /// The frequency-only values the plan keeps at the frequencies `freqs` (constants
    /// `consts`, `freqs.len() × n_consts`, bin-major): rows of `n = freqs.len()` values, row
    /// `r` with its real parts at `2r·n` and its imaginary parts at `(2r + 1)·n`.
    pub fn bin_table(
        &self,
        freqs: impl ExactSizeIterator<Item = f64>,
        consts: &[Complex64],
    ) -> Vec<f64> {
        let n = freqs.len();
        let ssa = &self.ssa;
        let mut out = vec![0.0; 2 * self.n_bin_rows * n];
        let mut vals = self.fixed.clone();
        for (k, f) in freqs.enumerate() {
            let consts = &consts[k * self.n_consts..(k + 1) * self.n_consts];
            for (i, inst) in ssa.insts.iter().enumerate() {
                if ssa.tiers[i] != Tier::Bin {
                    continue;
                }
                vals[i] = match *inst {
                    Inst::S => Complex64::new(0.0, 2.0 * PI * f),
                    Inst::Block(blk) => {
                        consts[self.const_of[blk as usize].expect("a frequency-only block")]
                    }
                    _ => {
                        let mut ops = operands(inst);
                        let a = vals[ops.next().expect("arithmetic") as usize];
                        let c = ops.next().map_or(ZERO, |c| vals[c as usize]);
                        apply(inst, a, c)
                    }
                };
                if let Loc::Bin(r) = self.loc[i] {
                    out[2 * r * n + k] = vals[i].re;
                    out[(2 * r + 1) * n + k] = vals[i].im;
                }
            }
        }
        out
    }

    /// The per-θ values: numbers and θ-only values into `scalars`, the blocks' field values
    /// into `fields`.
    pub fn theta_values(&self, theta: &[f64], scalars: &mut Vec<Complex64>, fields: &mut Vec<f64>) {
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
    }

    /// Block `k`'s field values among the per-θ `fields`.
    pub fn fields_of<'a>(&self, k: usize, fields: &'a [f64]) -> &'a [f64] {
        &fields[self.field_at[k]..self.field_at[k] + self.blocks[k].n_fields()]
    }

    /// Sizes the chunk's scratch.
    pub fn size_rows(&self, rows: &mut Vec<f64>) {
        rows.resize(2 * self.n_chunk_rows * CHUNK, 0.0);
    }

    /// The value of `v` across the chunk of frequencies `k0..k0 + len` (`bins`: the table of
    /// [`Plan::bin_table`] over `n` frequencies).
    #[inline(always)]
    fn lane<'a>(&self, v: u32, at: &At<'a>) -> Lane<'a> {
        match self.loc[v as usize] {
            Loc::Scalar => Lane::One(at.scalars[v as usize]),
            Loc::Bin(r) => {
                let (re, im) = (2 * r * at.n + at.k0, (2 * r + 1) * at.n + at.k0);
                Lane::Each(&at.bins[re..re + at.len], &at.bins[im..im + at.len])
            }
            Loc::Chunk(r) => {
                let (re, im) = (2 * r * CHUNK, (2 * r + 1) * CHUNK);
                Lane::Each(&at.rows[re..re + at.len], &at.rows[im..im + at.len])
            }
            Loc::Dead => unreachable!("a value read later is kept"),
        }
    }

    /// Output coefficient `c` (index `r·C + c`) across the chunk of `at`, once
    /// [`Plan::run_chunk`] has filled `at.rows`.
    #[inline]
    pub fn output<'a>(&self, c: usize, at: &At<'a>) -> Lane<'a> {
        match self.ssa.outs[c] {
            None => Lane::One(ZERO),
            Some(v) => self.lane(v, at),
        }
    }

    /// The chunk's values that depend on θ and the frequency (rows of `rows`) for the
    /// frequencies `k0..k0 + len` of the `n` of `bins`. `block(k, v, re, im)` fills the
    /// response of the θ-dependent block `k` with field values `v` across the chunk.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub fn run_chunk(
        &self,
        scalars: &[Complex64],
        fields: &[f64],
        bins: &[f64],
        n: usize,
        rows: &mut [f64],
        k0: usize,
        len: usize,
        block: impl Fn(usize, &Block, &[f64], &mut [f64], &mut [f64]),
    ) {
        for &i in &self.chunk_insts {
            let (inst, i) = (&self.ssa.insts[i as usize], i as usize);
            let Loc::Chunk(r) = self.loc[i] else {
                unreachable!("a chunk value")
            };
            let (done, rest) = rows.split_at_mut(2 * r * CHUNK);
            let (re, im) = rest.split_at_mut(CHUNK);
            let out = (&mut re[..len], &mut im[..len]);
            if let Inst::Block(k) = *inst {
                let k = k as usize;
                block(k, &self.blocks[k], self.fields_of(k, fields), out.0, out.1);
                continue;
            }
            let at = At {
                scalars,
                bins,
                n,
                rows: done,
                k0,
                len,
            };
            let mut ops = operands(inst);
            let a = self.lane(ops.next().expect("arithmetic"), &at);
            let b = match ops.next() {
                Some(b) => self.lane(b, &at),
                None => Lane::One(ZERO),
            };
            // one loop per operation, so the operation is not chosen per frequency
            match *inst {
                Inst::Add(..) => each(a, b, out, |mut x, y| {
                    x += y;
                    x
                }),
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
                Inst::Neg(_) => each(a, b, out, |x, _| -x),
                Inst::Pow(_, p) => each(a, b, out, |x, _| powi(x, p)),
                _ => unreachable!("a block or a per-θ value in the chunk"),
            }
        }
    }
}

/// Where a chunk's values are read: the per-θ scalars, the frequency-only table (`n`
/// frequencies a row) and the chunk's rows, for the frequencies `k0..k0 + len`.
pub(super) struct At<'a> {
    pub scalars: &'a [Complex64],
    pub bins: &'a [f64],
    pub n: usize,
    pub rows: &'a [f64],
    pub k0: usize,
    pub len: usize,
}

/// `out[j] = f(a[j], b[j])` over a chunk, `out` as (real parts, imaginary parts).
#[inline(always)]
fn each<F: Fn(Complex64, Complex64) -> Complex64>(
    a: Lane,
    b: Lane,
    (ore, oim): (&mut [f64], &mut [f64]),
    f: F,
) {
    let len = ore.len();
    let (ore, oim) = (&mut ore[..len], &mut oim[..len]);
    let mut put = |j: usize, z: Complex64| {
        ore[j] = z.re;
        oim[j] = z.im;
    };
    match (a, b) {
        (Lane::Each(xr, xi), Lane::Each(yr, yi)) => {
            let (xr, xi, yr, yi) = (&xr[..len], &xi[..len], &yr[..len], &yi[..len]);
            for j in 0..len {
                put(
                    j,
                    f(Complex64::new(xr[j], xi[j]), Complex64::new(yr[j], yi[j])),
                );
            }
        }
        (Lane::Each(xr, xi), Lane::One(y)) => {
            let (xr, xi) = (&xr[..len], &xi[..len]);
            for j in 0..len {
                put(j, f(Complex64::new(xr[j], xi[j]), y));
            }
        }
        (Lane::One(x), Lane::Each(yr, yi)) => {
            let (yr, yi) = (&yr[..len], &yi[..len]);
            for j in 0..len {
                put(j, f(x, Complex64::new(yr[j], yi[j])));
            }
        }
        (Lane::One(x), Lane::One(y)) => {
            let z = f(x, y);
            for j in 0..len {
                put(j, z);
            }
        }
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
            let b = ops.next().map_or(ZERO, |b| vals[b as usize]);
            apply(inst, a, b)
        }
    }
}
