//! Validation and compilation of a [`UserModelDef`] into a [`UserModel`].

use super::block::{Block, MAX_FIELDS, MAX_S_POWER};
use super::compiled::{MAX_SLOTS, UserModel};
use super::def::{BlockDef, RealValue, UserModelDef};
use super::expr::{self, MAX_STACK, Node, Op, Operand};
use super::real::{self, RealExpr, VarSrc};
use crate::model::bin::{MAX_CHANNELS, MAX_CONSTS, MAX_RESIDUALS};
use crate::model::checks::validate_shape;
use std::collections::HashMap;
use std::f64::consts::PI;

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
        check_lists(def)?;
        let scope = Scope::new(def)?;
        let blocks = scope.blocks()?;
        let defines = scope.defines()?;
        let coefs = scope.coefficients()?;
        let order = scope.define_order(&defines)?;
        let reach = scope.reach(&blocks, &defines, &coefs)?;
        let model = scope.program(blocks, &defines, &coefs, order, &reach)?;
        validate_shape(&model)?;
        Ok(model)
    }
}

/// The longest unit a parameter may be given (it is printed in table cells and axis titles).
const MAX_UNIT_CHARS: usize = 32;

/// The units of `parameters` and of the data `channels` from a model's `unit` table (by
/// parameter or channel name; one not named gets `""`), in their orders. `what` names the
/// model in errors (`user model `m``); every key must be a parameter or a data channel and
/// every unit one short line.
pub fn units(
    what: &str,
    parameters: &[String],
    channels: &[String],
    unit: &std::collections::BTreeMap<String, String>,
) -> Result<(Vec<String>, Vec<String>), String> {
    for (k, u) in unit {
        if !parameters.contains(k) && !channels.contains(k) {
            return Err(format!(
                "{what}: unit.{k}: `{k}` is neither a parameter nor a data channel of the model; parameters = [{}], data channels = [{}]; give units by name, e.g. unit = {{ {} = \"s\" }}",
                parameters.join(", "),
                channels.join(", "),
                parameters.first().map_or("k", String::as_str)
            ));
        }
        if u.chars().any(char::is_control) || u.chars().count() > MAX_UNIT_CHARS {
            return Err(format!(
                "{what}: unit.{k}: {u:?} is not a unit: write one line of at most {MAX_UNIT_CHARS} characters, e.g. \"s⁻²\", \"m/s\" or \"Hz\""
            ));
        }
    }
    let of = |names: &[String]| {
        names
            .iter()
            .map(|p| unit.get(p).cloned().unwrap_or_default())
            .collect()
    };
    Ok((of(parameters), of(channels)))
}

/// The physical limits of `parameters` (in their order) from a model's `physical_limits`
/// table, over those `implied` by the model's structure (a parameter that is a delay: lower
/// limit 0), which a written entry replaces. `what` names the model in errors; every key must
/// be a parameter, every limit finite, and `lo < hi`.
pub fn physical_limits(
    what: &str,
    parameters: &[String],
    limits: &std::collections::BTreeMap<String, super::def::LimitDef>,
    implied: &[(usize, [Option<f64>; 2])],
) -> Result<Vec<[Option<f64>; 2]>, String> {
    let mut out = vec![[None, None]; parameters.len()];
    for &(i, l) in implied {
        out[i] = l;
    }
    for (k, l) in limits {
        let entry = format!("{what}: physical_limits.{k}");
        let Some(i) = parameters.iter().position(|p| p == k) else {
            return Err(format!(
                "{entry}: `{k}` is not a parameter of the model; parameters = [{}]",
                parameters.join(", ")
            ));
        };
        if l.lo.is_none() && l.hi.is_none() {
            return Err(format!(
                "{entry}: give `lo`, `hi` or both, e.g. {{ lo = 0.0 }} for a parameter physics keeps ≥ 0"
            ));
        }
        for (name, v) in [("lo", l.lo), ("hi", l.hi)] {
            if v.is_some_and(|v| !v.is_finite()) {
                return Err(format!(
                    "{entry}: {name} is not a finite number; leave it out where physics sets no limit"
                ));
            }
        }
        if let (Some(lo), Some(hi)) = (l.lo, l.hi)
            && lo >= hi
        {
            return Err(format!("{entry}: lo = {lo} is not below hi = {hi}"));
        }
        out[i] = [l.lo, l.hi];
    }
    Ok(out)
}

/// An error of model `m`: `user model `m`: <entry>: <msg>`.
fn fail(m: &str, entry: &str, msg: String) -> String {
    format!("user model `{m}`: {entry}: {msg}")
}

/// The message of a name that is not an identifier.
fn not_a_name(n: &str) -> String {
    format!("`{n}` is not a valid name (letters, digits and `_`, not starting with a digit)")
}

/// The lists `parameters`, `data` and `residual`: not empty, not too long, valid names, no
/// name twice.
fn check_lists(def: &UserModelDef) -> Result<(), String> {
    let fail = |entry: &str, msg: String| fail(&def.name, entry, msg);
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
                return Err(fail(field, not_a_name(a)));
            }
            if v[..i].contains(a) {
                return Err(fail(field, format!("`{a}` is listed twice")));
            }
        }
    }
    Ok(())
}

/// What the coefficients reach, directly or through blocks and defines.
struct Reach {
    define: Vec<bool>,
    block: Vec<bool>,
}

/// The model's one namespace (parameters, constants, blocks, defines, `s` and `pi`), each name
/// with its kind and how a message calls it.
struct Scope<'a> {
    def: &'a UserModelDef,
    kinds: HashMap<&'a str, (Kind, String)>,
    /// Parameter, constant, block and define names, for the lists of allowed names.
    groups: [(&'static str, Vec<&'a str>); 4],
    /// The names a complex expression may use, for messages.
    allowed_complex: String,
}

impl<'a> Scope<'a> {
    /// Collects the namespace, checking every name once, and that constants are finite.
    fn new(def: &'a UserModelDef) -> Result<Scope<'a>, String> {
        let fail = |entry: &str, msg: String| fail(&def.name, entry, msg);
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
                    return Err(fail(&entry, not_a_name(n)));
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
        Ok(Scope {
            def,
            kinds,
            groups,
            allowed_complex,
        })
    }

    fn fail(&self, entry: &str, msg: String) -> String {
        fail(&self.def.name, entry, msg)
    }

    /// The message of a name a real field may not use.
    fn allowed_real(&self, n: &str) -> String {
        let what = match self.kinds.get(n) {
            Some((_, what)) => format!("{what} is complex; "),
            None => String::new(),
        };
        format!(
            "{what}a real field may use numbers, the parameters ({}), the constants ({}), \
             `pi` and exmex functions (sin, exp, sqrt, …); blocks, defines and `s` are \
             complex and not allowed here",
            list(&self.groups[0].1),
            list(&self.groups[1].1)
        )
    }

    /// What a real field's name stands for; `None` if a real field may not use it.
    fn real_var(&self, n: &str) -> Option<VarSrc> {
        match self.kinds.get(n).map(|k| k.0) {
            Some(Kind::Param(i)) => Some(VarSrc::Param(i)),
            Some(Kind::Const(x)) => Some(VarSrc::Const(x)),
            Some(Kind::Pi) => Some(VarSrc::Const(PI)),
            _ => None,
        }
    }

    /// Every block, compiled and checked where its fields are constant, in name order.
    fn blocks(&self) -> Result<Vec<(String, Block)>, String> {
        let mut blocks: Vec<(String, Block)> = Vec::new();
        for (bn, b) in &self.def.blocks {
            blocks.push((bn.clone(), self.block(bn, b)?));
        }
        Ok(blocks)
    }

    /// One block `bn`.
    fn block(&self, bn: &str, b: &BlockDef) -> Result<Block, String> {
        let at = |field: &str| format!("blocks.{bn}.{field}");
        let real = |field: &str, v: &RealValue| -> Result<RealExpr, String> {
            match v {
                RealValue::Number(x) => Ok(RealExpr::Num(*x)),
                RealValue::Expr(t) => {
                    RealExpr::parse(t, &|n| self.real_var(n), &|n| self.allowed_real(n))
                        .map_err(|e| self.fail(&at(field), e))
                }
            }
        };
        let poly = |field: &str, v: &[RealValue]| -> Result<Vec<RealExpr>, String> {
            if v.is_empty() {
                return Err(self.fail(
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
            BlockDef::Rational { num, den } if num.len() + den.len() > MAX_FIELDS => {
                return Err(self.fail(
                    &at("num"),
                    format!(
                        "{} numerator and {} denominator coefficients; at most {MAX_FIELDS} \
                         together are supported (split the block into a product of blocks)",
                        num.len(),
                        den.len()
                    ),
                ));
            }
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
                    return Err(self.fail(
                        &at("n"),
                        format!("is {n}; |n| ≤ {MAX_S_POWER} is supported"),
                    ));
                }
                Block::SPower(*n)
            }
        };
        block
            .check_values(&|v| v.constant())
            .map_err(|(field, msg)| self.fail(&at(&field), msg))?;
        Ok(block)
    }

    /// Parses the complex expression of `entry`: known names only, a bounded stack.
    fn compile(&self, entry: &str, text: &str) -> Result<Node, String> {
        let n = expr::parse(text)
            .map_err(|e| self.fail(entry, format!("{e} (in `{}`)", clip(text))))?;
        let mut ids = Vec::new();
        n.idents(&mut ids);
        for (id, pos) in ids {
            if !self.kinds.contains_key(id) {
                return Err(self.fail(
                    entry,
                    format!(
                        "unknown name `{id}` at character {pos} of `{}`; {}",
                        clip(text),
                        self.allowed_complex
                    ),
                ));
            }
        }
        if n.depth() > MAX_STACK {
            return Err(self.fail(
                entry,
                format!(
                    "the expression nests too deeply (needs a stack of {}, at most \
                     {MAX_STACK}); split it with defines",
                    n.depth()
                ),
            ));
        }
        Ok(n)
    }

    /// Every define, compiled, in name order.
    fn defines(&self) -> Result<Vec<(&'a str, Node)>, String> {
        self.def
            .define
            .iter()
            .map(|(k, v)| Ok((k.as_str(), self.compile(&format!("define.{k}"), v)?)))
            .collect()
    }

    /// Every coefficient, compiled, with its index `r·n_data + c` in `M`; every residual
    /// channel has one at least.
    fn coefficients(&self) -> Result<Vec<(usize, Node)>, String> {
        let def = self.def;
        let nc = def.data.len();
        let mut coefs: Vec<(usize, Node)> = Vec::new();
        for (r, row) in &def.coefficients {
            let Some(ri) = def.residual.iter().position(|x| x == r) else {
                return Err(self.fail(
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
                    return Err(self.fail(
                        &entry,
                        format!(
                            "`{c}` is not a declared data channel; data = [{}]",
                            def.data.join(", ")
                        ),
                    ));
                };
                coefs.push((ri * nc + ci, self.compile(&entry, text)?));
            }
        }
        for (ri, r) in def.residual.iter().enumerate() {
            if !coefs.iter().any(|(k, _)| k / nc == ri) {
                return Err(self.fail(
                    &format!("coefficients.{r}"),
                    "the residual channel has no coefficients (every entry would be 0); give \
                     at least one `coefficients.<residual>.<data> = \"…\"`"
                        .into(),
                ));
            }
        }
        Ok(coefs)
    }

    /// The kinds of the names an expression uses, in order of appearance.
    fn deps(&self, n: &Node) -> Vec<Kind> {
        let mut ids = Vec::new();
        n.idents(&mut ids);
        ids.iter().map(|(id, _)| self.kinds[id].0).collect()
    }

    /// The defines in dependency order (each after the defines it uses); a cycle is an error.
    fn define_order(&self, defines: &[(&str, Node)]) -> Result<Vec<usize>, String> {
        let dep_defines: Vec<Vec<usize>> = defines
            .iter()
            .map(|(_, n)| {
                self.deps(n)
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
        for i in 0..defines.len() {
            visit(i, &dep_defines, &mut state, &mut Vec::new(), &mut order).map_err(|cyc| {
                let names: Vec<&str> = cyc.iter().map(|&j| defines[j].0).collect();
                self.fail(
                    &format!("define.{}", names[0]),
                    format!(
                        "circular definition {}; a define may use only defines that do not \
                         depend on it",
                        names.join(" → ")
                    ),
                )
            })?;
        }
        Ok(order)
    }

    /// The blocks and defines the coefficients reach; every parameter must be reached.
    fn reach(
        &self,
        blocks: &[(String, Block)],
        defines: &[(&str, Node)],
        coefs: &[(usize, Node)],
    ) -> Result<Reach, String> {
        let mut used_define = vec![false; defines.len()];
        let mut used_block = vec![false; blocks.len()];
        let mut used_param = vec![false; self.def.parameters.len()];
        let mut stack: Vec<&Node> = coefs.iter().map(|(_, n)| n).collect();
        while let Some(n) = stack.pop() {
            for k in self.deps(n) {
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
        self.all_parameters_used(&used_param)?;
        Ok(Reach {
            define: used_define,
            block: used_block,
        })
    }

    /// An error naming the parameters no coefficient uses, if any.
    fn all_parameters_used(&self, used_param: &[bool]) -> Result<(), String> {
        let unused: Vec<&str> = self
            .def
            .parameters
            .iter()
            .zip(used_param)
            .filter(|(_, u)| !**u)
            .map(|(p, _)| p.as_str())
            .collect();
        if unused.is_empty() {
            return Ok(());
        }
        let one = unused.len() == 1;
        Err(self.fail(
            "parameters",
            format!(
                "{} {} {} declared but not used by any coefficient (directly or through the \
                 blocks and defines the coefficients use); remove {} or use {}",
                if one { "parameter" } else { "parameters" },
                unused
                    .iter()
                    .map(|p| format!("`{p}`"))
                    .collect::<Vec<_>>()
                    .join(", "),
                if one { "is" } else { "are" },
                if one { "it" } else { "them" },
                if one { "it" } else { "them" },
            ),
        ))
    }

    /// Slots, per-bin constants and the program of the reached blocks and defines: defines
    /// stored in dependency order, then the coefficients.
    fn program(
        &self,
        blocks: Vec<(String, Block)>,
        defines: &[(&str, Node)],
        coefs: &[(usize, Node)],
        order: Vec<usize>,
        reach: &Reach,
    ) -> Result<UserModel, String> {
        let def = self.def;
        let mut block_slot = vec![u16::MAX; blocks.len()];
        let mut kept_blocks = Vec::new();
        let mut const_of = Vec::new();
        let mut n_consts = 0;
        for (b, (bn, blk)) in blocks.into_iter().enumerate() {
            if !reach.block[b] {
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
            return Err(self.fail(
                "blocks",
                format!("{n_consts} constant blocks are used; at most {MAX_CONSTS} are supported"),
            ));
        }
        let live_defines: Vec<usize> = order.into_iter().filter(|&d| reach.define[d]).collect();
        let n_slots = kept_blocks.len() + live_defines.len();
        if n_slots > MAX_SLOTS {
            return Err(self.fail(
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
        let resolve = |n: &str| match self.kinds[n].0 {
            Kind::Param(i) => Operand::Param(i as u16),
            Kind::Const(x) => Operand::Const(x),
            Kind::Block(b) => Operand::Slot(block_slot[b]),
            Kind::Define(d) => Operand::Slot(define_slot[d]),
            Kind::S => Operand::S,
            Kind::Pi => Operand::Const(PI),
        };
        let slot_names: Vec<String> = kept_blocks
            .iter()
            .map(|(n, _)| format!("blocks.{n}"))
            .chain(
                live_defines
                    .iter()
                    .map(|&d| format!("define.{}", defines[d].0)),
            )
            .collect();
        let mut ops = Vec::new();
        for &d in &live_defines {
            expr::emit(&defines[d].1, &resolve, &mut ops);
            ops.push(Op::Store(define_slot[d]));
        }
        for (k, n) in coefs {
            expr::emit(n, &resolve, &mut ops);
            ops.push(Op::Out(*k as u16));
        }
        let (units, channel_units) = units(
            &format!("user model `{}`", def.name),
            &def.parameters,
            &def.data,
            &def.unit,
        )?;
        let limits = physical_limits(
            &format!("user model `{}`", def.name),
            &def.parameters,
            &def.physical_limits,
            &[],
        )?;
        Ok(UserModel {
            name: def.name.clone(),
            params: def.parameters.clone(),
            units,
            limits,
            channel_units,
            data: def.data.clone(),
            res: def.residual.clone(),
            blocks: kept_blocks,
            const_of,
            n_consts,
            ops,
            n_slots,
            slot_names,
        })
    }
}

/// Depth-first post-order visit of define `i` (`state`: 1 = on the current path, 2 = done);
/// a cycle comes back as the path that closes it.
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
