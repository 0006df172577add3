//! User-defined models, written in the study file (`[[model]]` with `kind = "user"`) and
//! compiled at load time: no recompiling.
//!
//! ```toml
//! [[model]]
//! kind = "user"                       # stripped by the study-file parser
//! name = "cl_user"
//! parameters = ["w1sq", "a_df", "dt1"] # θ order
//! data = ["o1", "i1"]                 # data channels d_c (columns of M), at most 8
//! residual = ["o1"]                   # residual channels r_r (rows of M), 1 or 2
//! [model.constants]                   # named real constants
//! e1 = 0.0046
//! [model.blocks]                      # named complex blocks of s = i2πf
//! cdf = { kind = "rational", num = [0.626, 0.138], den = [0.0317, 1, 0] }
//! t1  = { kind = "delay", tau = "dt1" }
//! [model.define]                      # intermediate complex expressions (any order)
//! h = "a_df*cdf*t1 / (s^2 + w1sq*(1 + e1) + a_df*cdf)"
//! [model.coefficients.o1]             # residual channel -> data channel -> expression
//! o1 = "1"
//! i1 = "-h"
//! ```
//!
//! The residual is `r_r = Σ_c M_rc d_c` with `M_rc` the expression of
//! `coefficients.<r>.<c>` (0 if absent).
//!
//! Blocks (every numeric field is a number or a real expression string of parameters and
//! constants, parsed by `exmex` with exact symbolic derivatives; `pi` is π):
//!
//! | kind           | fields          | response at `s = i2πf`            |
//! |----------------|-----------------|-----------------------------------|
//! | `gain`         | `value`         | `value`                           |
//! | `delay`        | `tau` (s, ≥ 0)  | `e^{−s τ}`                        |
//! | `pole`         | `f` (Hz, > 0)   | `1/(1 + s/(2π f))`                |
//! | `zero`         | `f` (Hz, ≠ 0)   | `1 + s/(2π f)`                    |
//! | `complex_pole` | `f` (> 0), `q` (> 0) | `ω0²/(s² + s ω0/q + ω0²)`, `ω0 = 2πf` |
//! | `s_power`      | `n` (integer literal, `|n| ≤ 16`) | `s^n`            |
//! | `rational`     | `num`, `den`    | polynomials in `s`, descending powers |
//!
//! Complex expressions (defines and coefficients): numbers, `+ − * /`, unary minus,
//! parentheses, `^` with an integer literal exponent, and the names of parameters (real),
//! constants (real), blocks, defines, `s` and `pi` (see [`expr`]).
//!
//! Blocks whose fields are all constant are evaluated once per bin ([`Model::bin_consts`]);
//! blocks and defines that no coefficient uses are validated but never evaluated.

pub mod block;
pub mod expr;
pub mod real;
#[cfg(test)]
mod tests;

use super::{Bin, MAX_CHANNELS, MAX_CONSTS, MAX_RESIDUALS, Model};
use block::{Block, MAX_S_POWER};
use expr::{MAX_STACK, Node, Op, Operand};
use num_complex::{Complex, Complex64};
use num_dual::{Dual64, DualNum};
use real::{RealExpr, VarSrc};
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, HashMap};
use std::f64::consts::PI;

/// Most blocks and defines (together) a model may evaluate.
pub const MAX_SLOTS: usize = 256;

/// A real field of a block: a number or an expression string of parameters and constants.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum RealValue {
    Number(f64),
    Expr(String),
}

/// One named block of `[model.blocks]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum BlockDef {
    /// `N(s)/D(s)`, coefficients in descending powers of `s`.
    Rational {
        num: Vec<RealValue>,
        den: Vec<RealValue>,
    },
    /// A real gain.
    Gain { value: RealValue },
    /// `e^{−s τ}`.
    Delay { tau: RealValue },
    /// `1/(1 + s/(2π f))`.
    Pole { f: RealValue },
    /// `1 + s/(2π f)`.
    Zero { f: RealValue },
    /// `ω0²/(s² + s ω0/q + ω0²)`, `ω0 = 2π f`.
    ComplexPole { f: RealValue, q: RealValue },
    /// `s^n`.
    SPower { n: i32 },
}

/// A `[[model]]` table of kind `user` (without the `kind` key).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct UserModelDef {
    pub name: String,
    /// Parameter names, in θ order.
    pub parameters: Vec<String>,
    /// Data channels (columns of `M`).
    pub data: Vec<String>,
    /// Residual channels (rows of `M`).
    pub residual: Vec<String>,
    /// Named real constants.
    #[serde(default)]
    pub constants: BTreeMap<String, f64>,
    /// Named complex blocks.
    #[serde(default)]
    pub blocks: BTreeMap<String, BlockDef>,
    /// Named intermediate complex expressions (evaluated in dependency order).
    #[serde(default)]
    pub define: BTreeMap<String, String>,
    /// Residual channel → data channel → complex expression; missing entries are 0.
    pub coefficients: BTreeMap<String, BTreeMap<String, String>>,
}

/// A compiled user-defined model.
#[derive(Debug, Clone)]
pub struct UserModel {
    name: String,
    params: Vec<String>,
    data: Vec<String>,
    res: Vec<String>,
    /// Blocks some coefficient uses; block `k` lives in slot `k`.
    blocks: Vec<(String, Block)>,
    /// Per used block: its index among the per-bin constants, if θ-independent.
    const_of: Vec<Option<usize>>,
    n_consts: usize,
    /// Defines (stored into slots after the blocks) then coefficients (`Out`).
    ops: Vec<Op>,
    n_slots: usize,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Kind {
    Param(usize),
    Const(f64),
    Block(usize),
    Define(usize),
    S,
    Pi,
}

fn is_ident(s: &str) -> bool {
    let mut c = s.chars();
    matches!(c.next(), Some(x) if x.is_ascii_alphabetic() || x == '_')
        && c.all(|x| x.is_ascii_alphanumeric() || x == '_')
}

/// An expression for a message: at most 80 characters.
fn clip(t: &str) -> String {
    if t.chars().count() <= 80 {
        t.to_string()
    } else {
        format!("{}…", t.chars().take(79).collect::<String>())
    }
}

fn list(v: &[&str]) -> String {
    if v.is_empty() {
        "none".into()
    } else {
        v.join(", ")
    }
}

impl UserModel {
    /// Validates and compiles a definition. Every error names the model, the entry (e.g.
    /// `blocks.t1.tau`, `coefficients.o12.i1`, `define.p00`) and what is allowed.
    pub fn new(def: &UserModelDef) -> Result<UserModel, String> {
        let m = def.name.as_str();
        if m.trim().is_empty() {
            return Err("user model: `name` is empty".into());
        }
        let fail = |entry: &str, msg: String| format!("user model `{m}`: {entry}: {msg}");

        // --- names -------------------------------------------------------------------------
        for (field, v, max) in [
            ("parameters", &def.parameters, usize::MAX),
            ("data", &def.data, MAX_CHANNELS),
            ("residual", &def.residual, MAX_RESIDUALS),
        ] {
            if v.is_empty() {
                return Err(fail(field, "the list is empty".into()));
            }
            if v.len() > max {
                return Err(fail(
                    field,
                    format!("{} channels; at most {max} are supported", v.len()),
                ));
            }
            for (i, a) in v.iter().enumerate() {
                if !is_ident(a) {
                    return Err(fail(
                        field,
                        format!(
                            "`{a}` is not a valid name (letters, digits and `_`, not starting \
                             with a digit)"
                        ),
                    ));
                }
                if v[..i].contains(a) {
                    return Err(fail(field, format!("`{a}` is listed twice")));
                }
            }
        }
        let mut kinds: HashMap<&str, (Kind, String)> = HashMap::new();
        kinds.insert("s", (Kind::S, "the Laplace variable `s`".into()));
        kinds.insert("pi", (Kind::Pi, "the number `pi`".into()));
        let groups: [(&str, Vec<&str>); 4] = [
            (
                "parameters",
                def.parameters.iter().map(|s| s.as_str()).collect(),
            ),
            (
                "constants",
                def.constants.keys().map(|s| s.as_str()).collect(),
            ),
            ("blocks", def.blocks.keys().map(|s| s.as_str()).collect()),
            ("define", def.define.keys().map(|s| s.as_str()).collect()),
        ];
        for (g, names) in &groups {
            for (i, &n) in names.iter().enumerate() {
                let entry = if *g == "parameters" {
                    "parameters".to_string()
                } else {
                    format!("{g}.{n}")
                };
                if !is_ident(n) {
                    return Err(fail(
                        &entry,
                        format!(
                            "`{n}` is not a valid name (letters, digits and `_`, not starting \
                             with a digit)"
                        ),
                    ));
                }
                if matches!(*g, "parameters" | "constants")
                    && <real::Ex as exmex::Express<f64>>::parse(n)
                        .map(|e| exmex::Express::var_names(&e) != [n.to_string()])
                        .unwrap_or(true)
                {
                    return Err(fail(
                        &entry,
                        format!(
                            "`{n}` is a function or constant of the real-expression parser \
                             (exmex: sin, exp, PI, E, …); choose another name"
                        ),
                    ));
                }
                let kind = match *g {
                    "parameters" => Kind::Param(i),
                    "constants" => Kind::Const(def.constants[n]),
                    "blocks" => Kind::Block(i),
                    _ => Kind::Define(i),
                };
                if let Some((_, what)) = kinds.get(n) {
                    return Err(fail(
                        &entry,
                        format!(
                            "the name `{n}` is already taken by {what}; parameters, constants, \
                             blocks and defines share one namespace with `s` and `pi`"
                        ),
                    ));
                }
                let what = match *g {
                    "parameters" => format!("parameter `{n}`"),
                    "constants" => format!("constant `{n}`"),
                    "blocks" => format!("block `{n}`"),
                    _ => format!("define `{n}`"),
                };
                kinds.insert(n, (kind, what));
            }
        }
        for (n, v) in &def.constants {
            if !v.is_finite() {
                return Err(fail(
                    &format!("constants.{n}"),
                    format!("is {v}, not a finite number"),
                ));
            }
        }
        let allowed_complex = format!(
            "allowed names are the parameters ({}), constants ({}), blocks ({}), defines ({}), \
             `s` and `pi`",
            list(&groups[0].1),
            list(&groups[1].1),
            list(&groups[2].1),
            list(&groups[3].1)
        );
        let allowed_real = |n: &str| {
            let what = match kinds.get(n) {
                Some((_, what)) => format!("{what} is complex; "),
                None => String::new(),
            };
            format!(
                "{what}a real field may use numbers, the parameters ({}), the constants ({}), \
                 `pi` and exmex functions (sin, exp, sqrt, …); blocks, defines and `s` are \
                 complex and not allowed here",
                list(&groups[0].1),
                list(&groups[1].1)
            )
        };

        // --- blocks ------------------------------------------------------------------------
        let lookup = |n: &str| match kinds.get(n).map(|k| k.0) {
            Some(Kind::Param(i)) => Some(VarSrc::Param(i)),
            Some(Kind::Const(x)) => Some(VarSrc::Const(x)),
            Some(Kind::Pi) => Some(VarSrc::Const(PI)),
            _ => None,
        };
        let mut blocks: Vec<(String, Block)> = Vec::new();
        for (bn, b) in &def.blocks {
            let at = |field: &str| format!("blocks.{bn}.{field}");
            let real = |field: &str, v: &RealValue| -> Result<RealExpr, String> {
                match v {
                    RealValue::Number(x) => Ok(RealExpr::Num(*x)),
                    RealValue::Expr(t) => {
                        RealExpr::parse(t, &lookup, &allowed_real).map_err(|e| fail(&at(field), e))
                    }
                }
            };
            let poly = |field: &str, v: &[RealValue]| -> Result<Vec<RealExpr>, String> {
                if v.is_empty() {
                    return Err(fail(
                        &at(field),
                        "the polynomial is empty; give its coefficients in descending powers of s"
                            .into(),
                    ));
                }
                v.iter()
                    .enumerate()
                    .map(|(i, x)| real(&format!("{field}[{i}]"), x))
                    .collect()
            };
            let block = match b {
                BlockDef::Rational { num, den } => Block::Rational {
                    num: poly("num", num)?,
                    den: poly("den", den)?,
                },
                BlockDef::Gain { value } => Block::Gain(real("value", value)?),
                BlockDef::Delay { tau } => Block::Delay(real("tau", tau)?),
                BlockDef::Pole { f } => Block::Pole(real("f", f)?),
                BlockDef::Zero { f } => Block::Zero(real("f", f)?),
                BlockDef::ComplexPole { f, q } => Block::ComplexPole {
                    f: real("f", f)?,
                    q: real("q", q)?,
                },
                BlockDef::SPower { n } => {
                    if n.unsigned_abs() > MAX_S_POWER as u32 {
                        return Err(fail(
                            &at("n"),
                            format!("is {n}; |n| ≤ {MAX_S_POWER} is supported"),
                        ));
                    }
                    Block::SPower(*n)
                }
            };
            block
                .check_values(&|v| v.constant())
                .map_err(|(field, msg)| fail(&at(&field), msg))?;
            blocks.push((bn.clone(), block));
        }

        // --- complex expressions -----------------------------------------------------------
        let compile = |entry: &str, text: &str| -> Result<Node, String> {
            let n =
                expr::parse(text).map_err(|e| fail(entry, format!("{e} (in `{}`)", clip(text))))?;
            let mut ids = Vec::new();
            n.idents(&mut ids);
            for (id, pos) in ids {
                if !kinds.contains_key(id) {
                    return Err(fail(
                        entry,
                        format!(
                            "unknown name `{id}` at character {pos} of `{}`; {allowed_complex}",
                            clip(text)
                        ),
                    ));
                }
            }
            if n.depth() > MAX_STACK {
                return Err(fail(
                    entry,
                    format!(
                        "the expression nests too deeply (needs a stack of {}, at most \
                         {MAX_STACK}); split it with defines",
                        n.depth()
                    ),
                ));
            }
            Ok(n)
        };
        let defines: Vec<(&str, Node)> = def
            .define
            .iter()
            .map(|(k, v)| Ok((k.as_str(), compile(&format!("define.{k}"), v)?)))
            .collect::<Result<_, String>>()?;
        let nc = def.data.len();
        let mut coefs: Vec<(usize, Node)> = Vec::new();
        for (r, row) in &def.coefficients {
            let Some(ri) = def.residual.iter().position(|x| x == r) else {
                return Err(fail(
                    &format!("coefficients.{r}"),
                    format!(
                        "`{r}` is not a declared residual channel; residual = [{}]",
                        def.residual.join(", ")
                    ),
                ));
            };
            for (c, text) in row {
                let entry = format!("coefficients.{r}.{c}");
                let Some(ci) = def.data.iter().position(|x| x == c) else {
                    return Err(fail(
                        &entry,
                        format!(
                            "`{c}` is not a declared data channel; data = [{}]",
                            def.data.join(", ")
                        ),
                    ));
                };
                coefs.push((ri * nc + ci, compile(&entry, text)?));
            }
        }
        for (ri, r) in def.residual.iter().enumerate() {
            if !coefs.iter().any(|(k, _)| k / nc == ri) {
                return Err(fail(
                    &format!("coefficients.{r}"),
                    "the residual channel has no coefficients (every entry would be 0); give \
                     at least one `coefficients.<residual>.<data> = \"…\"`"
                        .into(),
                ));
            }
        }

        // --- dependency order of the defines -----------------------------------------------
        let deps = |n: &Node| -> Vec<Kind> {
            let mut ids = Vec::new();
            n.idents(&mut ids);
            ids.iter().map(|(id, _)| kinds[id].0).collect()
        };
        let dep_defines: Vec<Vec<usize>> = defines
            .iter()
            .map(|(_, n)| {
                deps(n)
                    .into_iter()
                    .filter_map(|k| match k {
                        Kind::Define(j) => Some(j),
                        _ => None,
                    })
                    .collect()
            })
            .collect();
        // depth-first post-order; state 1 = on the current path, 2 = done
        let mut state = vec![0u8; defines.len()];
        let mut order = Vec::with_capacity(defines.len());
        fn visit(
            i: usize,
            deps: &[Vec<usize>],
            state: &mut [u8],
            path: &mut Vec<usize>,
            order: &mut Vec<usize>,
        ) -> Result<(), Vec<usize>> {
            match state[i] {
                2 => return Ok(()),
                1 => {
                    let start = path.iter().position(|&p| p == i).unwrap_or(0);
                    let mut cyc = path[start..].to_vec();
                    cyc.push(i);
                    return Err(cyc);
                }
                _ => {}
            }
            state[i] = 1;
            path.push(i);
            for &j in &deps[i] {
                visit(j, deps, state, path, order)?;
            }
            path.pop();
            state[i] = 2;
            order.push(i);
            Ok(())
        }
        for i in 0..defines.len() {
            visit(i, &dep_defines, &mut state, &mut Vec::new(), &mut order).map_err(|cyc| {
                let names: Vec<&str> = cyc.iter().map(|&j| defines[j].0).collect();
                fail(
                    &format!("define.{}", names[0]),
                    format!(
                        "circular definition {}; a define may use only defines that do not \
                         depend on it",
                        names.join(" → ")
                    ),
                )
            })?;
        }

        // --- what the coefficients reach ---------------------------------------------------
        let mut used_define = vec![false; defines.len()];
        let mut used_block = vec![false; blocks.len()];
        let mut used_param = vec![false; def.parameters.len()];
        let mut stack: Vec<&Node> = coefs.iter().map(|(_, n)| n).collect();
        while let Some(n) = stack.pop() {
            for k in deps(n) {
                match k {
                    Kind::Param(i) => used_param[i] = true,
                    Kind::Block(b) if !used_block[b] => {
                        used_block[b] = true;
                        for i in blocks[b].1.params() {
                            used_param[i] = true;
                        }
                    }
                    Kind::Define(d) if !used_define[d] => {
                        used_define[d] = true;
                        stack.push(&defines[d].1);
                    }
                    _ => {}
                }
            }
        }
        let unused: Vec<&str> = def
            .parameters
            .iter()
            .zip(&used_param)
            .filter(|(_, u)| !**u)
            .map(|(p, _)| p.as_str())
            .collect();
        if !unused.is_empty() {
            return Err(fail(
                "parameters",
                format!(
                    "{} {} {} declared but not used by any coefficient (directly or through the \
                     blocks and defines the coefficients use); remove {} or use {}",
                    if unused.len() == 1 {
                        "parameter"
                    } else {
                        "parameters"
                    },
                    unused
                        .iter()
                        .map(|p| format!("`{p}`"))
                        .collect::<Vec<_>>()
                        .join(", "),
                    if unused.len() == 1 { "is" } else { "are" },
                    if unused.len() == 1 { "it" } else { "them" },
                    if unused.len() == 1 { "it" } else { "them" },
                ),
            ));
        }

        // --- slots, per-bin constants, program ---------------------------------------------
        let mut block_slot = vec![u16::MAX; blocks.len()];
        let mut kept_blocks = Vec::new();
        let mut const_of = Vec::new();
        let mut n_consts = 0;
        for (b, (bn, blk)) in blocks.into_iter().enumerate() {
            if !used_block[b] {
                continue;
            }
            block_slot[b] = kept_blocks.len() as u16;
            if blk.is_const() {
                const_of.push(Some(n_consts));
                n_consts += 1;
            } else {
                const_of.push(None);
            }
            kept_blocks.push((bn, blk));
        }
        if n_consts > MAX_CONSTS {
            return Err(fail(
                "blocks",
                format!("{n_consts} constant blocks are used; at most {MAX_CONSTS} are supported"),
            ));
        }
        let live_defines: Vec<usize> = order.into_iter().filter(|&d| used_define[d]).collect();
        let n_slots = kept_blocks.len() + live_defines.len();
        if n_slots > MAX_SLOTS {
            return Err(fail(
                "define",
                format!(
                    "the coefficients use {n_slots} blocks and defines; at most {MAX_SLOTS} are \
                     supported"
                ),
            ));
        }
        let mut define_slot = vec![u16::MAX; defines.len()];
        for (k, &d) in live_defines.iter().enumerate() {
            define_slot[d] = (kept_blocks.len() + k) as u16;
        }
        let resolve = |n: &str| match kinds[n].0 {
            Kind::Param(i) => Operand::Param(i as u16),
            Kind::Const(x) => Operand::Const(x),
            Kind::Block(b) => Operand::Slot(block_slot[b]),
            Kind::Define(d) => Operand::Slot(define_slot[d]),
            Kind::S => Operand::S,
            Kind::Pi => Operand::Const(PI),
        };
        let mut ops = Vec::new();
        for &d in &live_defines {
            expr::emit(&defines[d].1, &resolve, &mut ops);
            ops.push(Op::Store(define_slot[d]));
        }
        for (k, n) in &coefs {
            expr::emit(n, &resolve, &mut ops);
            ops.push(Op::Out(*k as u16));
        }

        let model = UserModel {
            name: def.name.clone(),
            params: def.parameters.clone(),
            data: def.data.clone(),
            res: def.residual.clone(),
            blocks: kept_blocks,
            const_of,
            n_consts,
            ops,
            n_slots,
        };
        super::validate_shape(&model)?;
        Ok(model)
    }

    /// Errors if some parameter has no effect on any coefficient at `theta` over `freqs` (the
    /// dual derivative of every coefficient with respect to it is zero at every frequency).
    pub fn check_identifiable(&self, theta: &[f64], freqs: &[f64], fs: f64) -> Result<(), String> {
        let np = self.params.len();
        if theta.len() != np {
            return Err(format!(
                "user model `{}`: θ has {} values for {np} parameters",
                self.name,
                theta.len()
            ));
        }
        let ncoef = self.data.len() * self.res.len();
        let mut consts = vec![Complex64::new(0.0, 0.0); self.n_consts];
        let mut out = vec![Complex::new(Dual64::from(0.0), Dual64::from(0.0)); ncoef];
        let mut seen = vec![false; np];
        let mut th: Vec<Dual64> = theta.iter().map(|&x| Dual64::from(x)).collect();
        for &f in freqs {
            self.bin_consts(f, fs, &mut consts);
            let bin = Bin {
                f,
                fs,
                consts: &consts,
            };
            for a in 0..np {
                if seen[a] {
                    continue;
                }
                th[a] = Dual64::from(theta[a]).derivative();
                self.coefficients_dual(&th, &bin, &mut out);
                th[a] = Dual64::from(theta[a]);
                seen[a] = out.iter().any(|z| {
                    (z.re.eps != 0.0 && z.re.eps.is_finite())
                        || (z.im.eps != 0.0 && z.im.eps.is_finite())
                });
            }
        }
        let dead: Vec<String> = self
            .params
            .iter()
            .zip(&seen)
            .filter(|(_, s)| !**s)
            .map(|(p, _)| format!("`{p}`"))
            .collect();
        if dead.is_empty() {
            Ok(())
        } else {
            Err(format!(
                "user model `{}`: parameter{} {} ha{} no effect on any coefficient at this θ \
                 over the {} frequencies checked, so the data cannot determine {}",
                self.name,
                if dead.len() == 1 { "" } else { "s" },
                dead.join(", "),
                if dead.len() == 1 { "s" } else { "ve" },
                freqs.len(),
                if dead.len() == 1 { "it" } else { "them" },
            ))
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

    fn data_channels(&self) -> &[String] {
        &self.data
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
