//! The compiled program of a user model in single-assignment form, each value marked with what
//! it depends on, so that the kernel ([`super::kernel`]) computes every value exactly as often
//! as it must: θ- and frequency-independent values once, frequency-only values once per bin when
//! the kernel is prepared, θ-only values once per ln L, and only the rest per bin and θ.
//!
//! Every value is computed by [`apply`] with the very operations of the interpreter
//! ([`super::expr::run`]), in the same order, so the kernel's numbers equal the interpreter's
//! bit for bit: hoisting a value out of the bin loop changes when it is computed, not how.

use super::expr::{Op, powi};
use num_complex::Complex64;

/// What a value depends on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Tier {
    /// Neither θ nor the frequency: a number.
    Fixed,
    /// The frequency only (`s`, constant blocks).
    Bin,
    /// θ only.
    Theta,
    /// Both.
    Mixed,
}

impl Tier {
    fn join(self, o: Tier) -> Tier {
        use Tier::*;
        match (self, o) {
            (Fixed, t) | (t, Fixed) => t,
            (Bin, Bin) => Bin,
            (Theta, Theta) => Theta,
            _ => Mixed,
        }
    }
}

/// One instruction; operands are indices of earlier values.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Inst {
    Const(Complex64),
    /// `s = i2πf`.
    S,
    Param(u16),
    /// The response of block `k` (the model's `k`-th used block).
    Block(u16),
    Add(u32, u32),
    Sub(u32, u32),
    Mul(u32, u32),
    Div(u32, u32),
    Neg(u32),
    Pow(u32, i32),
}

/// A program in single-assignment form with the tier of every value and the value of every
/// output coefficient (`None`: zero).
#[derive(Debug, Clone)]
pub(super) struct Ssa {
    pub insts: Vec<Inst>,
    pub tiers: Vec<Tier>,
    pub outs: Vec<Option<u32>>,
}

impl Ssa {
    /// Translates the interpreter's postfix program. `block_is_const[k]`: whether block `k`
    /// depends on θ; `n_out` the number of coefficients.
    pub fn new(ops: &[Op], block_is_const: &[bool], n_out: usize) -> Ssa {
        let mut p = Ssa {
            insts: Vec::new(),
            tiers: Vec::new(),
            outs: vec![None; n_out],
        };
        let nb = block_is_const.len();
        // slots: blocks first (created when first read), then defines
        let mut slot: Vec<Option<u32>> = vec![None; nb];
        let mut stack: Vec<u32> = Vec::new();
        for op in ops {
            let v = match *op {
                Op::Const(c) => p.push(Inst::Const(c), Tier::Fixed),
                Op::S => p.push(Inst::S, Tier::Bin),
                Op::Param(i) => p.push(Inst::Param(i), Tier::Theta),
                Op::Slot(i) => {
                    let i = i as usize;
                    if i >= slot.len() {
                        slot.resize(i + 1, None);
                    }
                    match slot[i] {
                        Some(v) => v,
                        None => {
                            // only blocks can be read before they are stored
                            let t = if block_is_const[i] {
                                Tier::Bin
                            } else {
                                Tier::Mixed
                            };
                            let v = p.push(Inst::Block(i as u16), t);
                            slot[i] = Some(v);
                            v
                        }
                    }
                }
                Op::Store(i) => {
                    let i = i as usize;
                    if i >= slot.len() {
                        slot.resize(i + 1, None);
                    }
                    slot[i] = stack.pop();
                    continue;
                }
                Op::Out(i) => {
                    p.outs[i as usize] = stack.pop();
                    continue;
                }
                Op::Neg => {
                    let a = stack.pop().expect("compiled program");
                    p.push(Inst::Neg(a), p.tiers[a as usize])
                }
                Op::Pow(n) => {
                    let a = stack.pop().expect("compiled program");
                    p.push(Inst::Pow(a, n), p.tiers[a as usize])
                }
                Op::Add | Op::Sub | Op::Mul | Op::Div => {
                    let b = stack.pop().expect("compiled program");
                    let a = stack.pop().expect("compiled program");
                    let t = p.tiers[a as usize].join(p.tiers[b as usize]);
                    let inst = match op {
                        Op::Add => Inst::Add(a, b),
                        Op::Sub => Inst::Sub(a, b),
                        Op::Mul => Inst::Mul(a, b),
                        _ => Inst::Div(a, b),
                    };
                    p.push(inst, t)
                }
            };
            stack.push(v);
        }
        p
    }

    fn push(&mut self, i: Inst, t: Tier) -> u32 {
        self.insts.push(i);
        self.tiers.push(t);
        (self.insts.len() - 1) as u32
    }

    /// Which values the outputs `wanted` (coefficient indices) need, directly or through
    /// other values.
    pub fn live(&self, wanted: &[usize]) -> Vec<bool> {
        let mut live = vec![false; self.insts.len()];
        for o in wanted.iter().filter_map(|&c| self.outs[c]) {
            live[o as usize] = true;
        }
        // operands come before the values that read them
        for i in (0..self.insts.len()).rev() {
            if live[i] {
                for a in operands(&self.insts[i]) {
                    live[a as usize] = true;
                }
            }
        }
        live
    }

    /// Which values a later tier reads (the operands of the `live` `Mixed` values and the
    /// outputs `wanted`): the only ones a kernel keeps.
    pub fn read_later(&self, live: &[bool], wanted: &[usize]) -> Vec<bool> {
        let mut used = vec![false; self.insts.len()];
        for (i, inst) in self.insts.iter().enumerate() {
            if live[i] && self.tiers[i] == Tier::Mixed {
                for a in operands(inst) {
                    used[a as usize] = true;
                }
            }
        }
        for o in wanted.iter().filter_map(|&c| self.outs[c]) {
            used[o as usize] = true;
        }
        used
    }
}

/// The operands of an instruction.
pub(super) fn operands(i: &Inst) -> impl Iterator<Item = u32> {
    let (a, b) = match *i {
        Inst::Add(a, b) | Inst::Sub(a, b) | Inst::Mul(a, b) | Inst::Div(a, b) => (Some(a), Some(b)),
        Inst::Neg(a) | Inst::Pow(a, _) => (Some(a), None),
        _ => (None, None),
    };
    a.into_iter().chain(b)
}

/// The value of an arithmetic instruction from its operand values (`b` unused for unary ones),
/// with the interpreter's operations.
#[inline(always)]
pub(super) fn apply(i: &Inst, a: Complex64, b: Complex64) -> Complex64 {
    let mut x = a;
    match *i {
        Inst::Add(..) => x += b,
        Inst::Sub(..) => x -= b,
        Inst::Mul(..) => x *= b,
        Inst::Div(..) => x /= b,
        Inst::Neg(_) => x = -x,
        Inst::Pow(_, n) => x = powi(x, n),
        _ => unreachable!("not an arithmetic instruction"),
    }
    x
}
