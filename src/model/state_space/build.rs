//! Validation and compilation of a [`StateSpaceDef`] into a [`StateSpaceModel`].

use super::compiled::{MAX_STATES, StateSpaceModel};
use super::def::{MatrixDef, StateSpaceDef};
use crate::model::bin::{MAX_CHANNELS, MAX_RESIDUALS};
use crate::model::checks::validate_shape;
use crate::model::user::RealValue;
use crate::model::user::real::{self, RealExpr, VarSrc};
use std::collections::HashMap;

fn is_ident(s: &str) -> bool {
    let mut c = s.chars();
    matches!(c.next(), Some(x) if x.is_ascii_alphabetic() || x == '_')
        && c.all(|x| x.is_ascii_alphanumeric() || x == '_')
}

/// Whether the real-expression parser reads `n` as a plain variable (not `sin`, `PI`, …).
fn is_plain_variable(n: &str) -> bool {
    <real::Ex as exmex::Express<f64>>::parse(n)
        .map(|e| exmex::Express::var_names(&e) == [n.to_string()])
        .unwrap_or(false)
}

fn list(v: &[String]) -> String {
    if v.is_empty() {
        "none".into()
    } else {
        v.join(", ")
    }
}

/// The names an entry may use and the messages about them.
struct Scope<'a> {
    def: &'a StateSpaceDef,
    vars: HashMap<&'a str, VarSrc>,
}

impl<'a> Scope<'a> {
    fn fail(&self, entry: &str, msg: impl std::fmt::Display) -> String {
        format!("state-space model `{}`: {entry}: {msg}", self.def.name)
    }

    fn new(def: &'a StateSpaceDef) -> Result<Scope<'a>, String> {
        let mut s = Scope {
            def,
            vars: HashMap::new(),
        };
        for (i, p) in def.parameters.iter().enumerate() {
            s.declare("parameters", p, VarSrc::Param(i))?;
        }
        for (c, v) in &def.constants {
            let entry = format!("constants.{c}");
            if !v.is_finite() {
                return Err(s.fail(&entry, format!("is {v}, not a finite number")));
            }
            s.declare(&entry, c, VarSrc::Const(*v))?;
        }
        Ok(s)
    }

    fn declare(&mut self, entry: &str, n: &'a str, v: VarSrc) -> Result<(), String> {
        if !is_ident(n) {
            return Err(self.fail(
                entry,
                format!(
                    "`{n}` is not a valid name (letters, digits and `_`, not starting with a digit)"
                ),
            ));
        }
        if n == "pi" || !is_plain_variable(n) {
            return Err(self.fail(
                entry,
                format!(
                    "`{n}` is a function or constant of the expression parser (pi, sin, exp, \
                     PI, E, …); choose another name"
                ),
            ));
        }
        if self.vars.insert(n, v).is_some() {
            return Err(self.fail(
                entry,
                format!("the name `{n}` is declared twice (parameters and constants share one namespace)"),
            ));
        }
        Ok(())
    }

    /// One entry: a finite number or an expression of known names.
    fn real(&self, entry: &str, v: &RealValue) -> Result<RealExpr, String> {
        match v {
            RealValue::Number(x) if x.is_finite() => Ok(RealExpr::Num(*x)),
            RealValue::Number(x) => Err(self.fail(entry, format!("is {x}, not a finite number"))),
            RealValue::Expr(t) => RealExpr::parse(t, &|n| self.vars.get(n).copied(), &|_| {
                format!(
                    "an entry may use numbers, the parameters ({}), the constants ({}), `pi` and \
                     the parser's functions (sin, exp, sqrt, …)",
                    list(&self.def.parameters),
                    list(&self.def.constants.keys().cloned().collect::<Vec<_>>())
                )
            })
            .map_err(|e| self.fail(entry, e)),
        }
    }

    /// Matrix `name`, `rows × cols` (what the sizes mean in `shape`), row-major.
    fn matrix(
        &self,
        name: &str,
        v: &MatrixDef,
        (rows, cols): (usize, usize),
        shape: &str,
    ) -> Result<Vec<RealExpr>, String> {
        if v.len() != rows {
            return Err(self.fail(
                name,
                format!(
                    "has {} rows; it must be {shape} = {rows} × {cols} (a list of {rows} rows)",
                    v.len()
                ),
            ));
        }
        let mut out = Vec::with_capacity(rows * cols);
        for (i, row) in v.iter().enumerate() {
            if row.len() != cols {
                return Err(self.fail(
                    &format!("{name}[{i}]"),
                    format!(
                        "the row has {} entries; {name} is {shape} = {rows} × {cols}, so every \
                         row needs {cols}",
                        row.len()
                    ),
                ));
            }
            for (j, x) in row.iter().enumerate() {
                out.push(self.real(&format!("{name}[{i}][{j}]"), x)?);
            }
        }
        Ok(out)
    }
}

impl StateSpaceModel {
    /// Validates and compiles a definition. Every error names the model, the entry (e.g.
    /// `a[2][1]`, `delay.i1`, `outputs`) and what is allowed. Stability is a property of θ: see
    /// [`Model::check`](crate::model::Model::check).
    pub fn new(def: &StateSpaceDef) -> Result<StateSpaceModel, String> {
        if def.name.trim().is_empty() {
            return Err("state-space model: `name` is empty".into());
        }
        let scope = Scope::new(def)?;
        check_lists(&scope)?;
        let n = def.a.len();
        let states = state_names(&scope, n)?;
        let (m, p) = (def.inputs.len(), def.outputs.len());
        let a = scope.matrix("a", &def.a, (n, n), "states × states")?;
        let b = scope.matrix("b", &def.b, (n, m), "states × inputs")?;
        let c = scope.matrix("c", &def.c, (p, n), "outputs × states")?;
        let d = match &def.d {
            Some(d) => scope.matrix("d", d, (p, m), "outputs × inputs")?,
            None => Vec::new(),
        };
        let (g, h, noise) = noise_inputs(&scope, n, p)?;
        let delays = delays(&scope)?;
        let data: Vec<String> = def.outputs.iter().chain(&def.inputs).cloned().collect();
        let (units, channel_units) = crate::model::user::units(
            &format!("state-space model `{}`", def.name),
            &def.parameters,
            &data,
            &def.unit,
        )?;
        // a parameter that is itself a delay is ≥ 0: causality (the check refuses less)
        let implied: Vec<(usize, [Option<f64>; 2])> = def
            .delay
            .values()
            .filter_map(|v| match v {
                RealValue::Expr(e) => def.parameters.iter().position(|p| p == e.trim()),
                RealValue::Number(_) => None,
            })
            .map(|i| (i, [Some(0.0), None]))
            .collect();
        let limits = crate::model::user::physical_limits(
            &format!("state-space model `{}`", def.name),
            &def.parameters,
            &def.physical_limits,
            &implied,
        )?;
        let model = StateSpaceModel {
            name: def.name.clone(),
            params: def.parameters.clone(),
            units,
            limits,
            channel_units,
            data,
            outputs: def.outputs.clone(),
            states,
            time: def.time,
            a,
            b,
            c,
            d,
            g,
            h,
            noise,
            delays,
        };
        all_parameters_used(&scope, &model)?;
        validate_shape(&model)?;
        Ok(model)
    }
}

/// `parameters`, `inputs`, `outputs`: sizes, names, no name twice or in both lists.
fn check_lists(s: &Scope) -> Result<(), String> {
    let def = s.def;
    for (field, v, max) in [
        ("parameters", &def.parameters, usize::MAX),
        ("inputs", &def.inputs, MAX_CHANNELS - 1),
        ("outputs", &def.outputs, MAX_RESIDUALS),
    ] {
        if v.is_empty() {
            return Err(s.fail(field, "the list is empty"));
        }
        if v.len() > max {
            return Err(s.fail(
                field,
                format!("{} channels; at most {max} are supported", v.len()),
            ));
        }
        for (i, a) in v.iter().enumerate() {
            if !is_ident(a) {
                return Err(s.fail(field, format!("`{a}` is not a valid name")));
            }
            if v[..i].contains(a) {
                return Err(s.fail(field, format!("`{a}` is listed twice")));
            }
        }
    }
    if let Some(x) = def.inputs.iter().find(|x| def.outputs.contains(x)) {
        return Err(s.fail(
            "inputs",
            format!("`{x}` is both an input and an output; a data channel is one or the other"),
        ));
    }
    if def.inputs.len() + def.outputs.len() > MAX_CHANNELS {
        return Err(s.fail(
            "inputs",
            format!(
                "{} inputs and {} outputs read {} data channels; at most {MAX_CHANNELS} are \
                 supported",
                def.inputs.len(),
                def.outputs.len(),
                def.inputs.len() + def.outputs.len()
            ),
        ));
    }
    Ok(())
}

/// The state names: declared (as many as `a` has rows) or `x0, x1, …`.
fn state_names(s: &Scope, n: usize) -> Result<Vec<String>, String> {
    if n == 0 || n > MAX_STATES {
        return Err(s.fail(
            "a",
            format!("has {n} rows: a model has 1 to {MAX_STATES} states (A is states × states)"),
        ));
    }
    let Some(names) = &s.def.states else {
        return Ok((0..n).map(|i| format!("x{i}")).collect());
    };
    if names.len() != n {
        return Err(s.fail(
            "states",
            format!(
                "names {} states but `a` has {n} rows; give one name per state or leave \
                 `states` out",
                names.len()
            ),
        ));
    }
    for (i, x) in names.iter().enumerate() {
        if !is_ident(x) {
            return Err(s.fail("states", format!("`{x}` is not a valid name")));
        }
        if names[..i].contains(x) {
            return Err(s.fail("states", format!("`{x}` is listed twice")));
        }
    }
    Ok(names.clone())
}

/// The noise part of a model: `g`, `h` and the PSDs, row-major.
type NoiseInputs = (Vec<RealExpr>, Vec<RealExpr>, Vec<RealExpr>);

/// `g`, `h` and `noise`: all absent, or `g` (states × q) with `noise` (q PSDs ≥ 0) and
/// optionally `h` (outputs × q).
fn noise_inputs(s: &Scope, n: usize, p: usize) -> Result<NoiseInputs, String> {
    let def = s.def;
    let (g, noise) = match (&def.g, &def.noise) {
        (None, None) => {
            if def.h.is_some() {
                return Err(s.fail("h", "is given without `g` and `noise`; give all three"));
            }
            return Ok((Vec::new(), Vec::new(), Vec::new()));
        }
        (Some(_), None) => {
            return Err(s.fail(
                "noise",
                "is missing: `g` needs the one-sided PSD of each noise input",
            ));
        }
        (None, Some(_)) => {
            return Err(s.fail(
                "g",
                "is missing: `noise` needs `g`, the states × noise-inputs matrix",
            ));
        }
        (Some(g), Some(noise)) => (g, noise),
    };
    let q = noise.len();
    if q == 0 || q > MAX_CHANNELS {
        return Err(s.fail(
            "noise",
            format!("has {q} entries; 1 to {MAX_CHANNELS} noise inputs are supported"),
        ));
    }
    // `g`'s rows say how many noise inputs there are; a `noise` list of another length is
    // what is wrong then, not the rows of `g`
    if let Some(cols) = g.first().map(Vec::len)
        && cols != q
        && g.iter().all(|r| r.len() == cols)
    {
        return Err(s.fail(
            "noise",
            format!(
                "has {q} entries, but `g` has {cols} columns (one per noise input): give the \
                 one-sided PSD of each of the {cols} noise inputs"
            ),
        ));
    }
    let g = s.matrix("g", g, (n, q), "states × noise inputs")?;
    let h = match &def.h {
        Some(h) => s.matrix("h", h, (p, q), "outputs × noise inputs")?,
        None => Vec::new(),
    };
    let mut psd = Vec::with_capacity(q);
    for (k, v) in noise.iter().enumerate() {
        let e = s.real(&format!("noise[{k}]"), v)?;
        if let Some(x) = e.constant()
            && x < 0.0
        {
            return Err(s.fail(&format!("noise[{k}]"), format!("is {x}; a PSD is ≥ 0")));
        }
        psd.push(e);
    }
    Ok((g, h, psd))
}

/// Delays by channel name, in the model's order: inputs, then outputs.
fn delays(s: &Scope) -> Result<Vec<Option<RealExpr>>, String> {
    let def = s.def;
    let channels: Vec<&String> = def.inputs.iter().chain(&def.outputs).collect();
    let mut out = vec![None; channels.len()];
    for (ch, v) in &def.delay {
        let entry = format!("delay.{ch}");
        let Some(k) = channels.iter().position(|c| *c == ch) else {
            return Err(s.fail(
                &entry,
                format!(
                    "`{ch}` is not an input or output; inputs = [{}], outputs = [{}]",
                    def.inputs.join(", "),
                    def.outputs.join(", ")
                ),
            ));
        };
        let e = s.real(&entry, v)?;
        if let Some(x) = e.constant()
            && x < 0.0
        {
            return Err(s.fail(&entry, format!("is {x} s; a delay is ≥ 0")));
        }
        out[k] = Some(e);
    }
    Ok(out)
}

/// Every parameter must enter `a`, `b`, `c`, `d` or a delay: the noise PSDs are not part of
/// the likelihood's θ-dependence.
fn all_parameters_used(s: &Scope, m: &StateSpaceModel) -> Result<(), String> {
    let mut used = vec![false; s.def.parameters.len()];
    let entries = m.a.iter().chain(&m.b).chain(&m.c).chain(&m.d);
    for e in entries.chain(m.delays.iter().flatten()) {
        for i in e.params() {
            used[i] = true;
        }
    }
    let unused: Vec<String> = s
        .def
        .parameters
        .iter()
        .zip(&used)
        .filter(|(_, u)| !**u)
        .map(|(p, _)| format!("`{p}`"))
        .collect();
    if unused.is_empty() {
        return Ok(());
    }
    Err(s.fail(
        "parameters",
        format!(
            "{} not used by any entry of a, b, c, d or delay (noise PSDs do not count: the \
             likelihood does not fit them); remove {} or use {}",
            if unused.len() == 1 {
                format!("{} is", unused[0])
            } else {
                format!("{} are", unused.join(", "))
            },
            if unused.len() == 1 { "it" } else { "them" },
            if unused.len() == 1 { "it" } else { "them" },
        ),
    ))
}
