//! Real-valued block fields: a number, a parameter or constant name, or an `exmex` expression of
//! parameters and constants with exact symbolic partial derivatives.

use exmex::prelude::*;
use exmex::{FloatOpsFactory, MakeOperators, MatchLiteral};
use num_dual::DualNum;
use std::f64::consts::PI;

/// Most distinct names in one real expression.
pub const MAX_VARS: usize = 16;

/// What a name in a real expression stands for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum VarSrc {
    Param(usize),
    Const(f64),
}

/// Numeric literals of real expressions, with an optional decimal exponent (`1.5e-3`), which
/// `exmex`'s default matcher does not accept.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord, Default)]
pub struct SciNumber;

impl MatchLiteral for SciNumber {
    fn is_literal(text: &str) -> Option<&str> {
        let b = text.as_bytes();
        let digits = |mut i: usize| {
            while i < b.len() && b[i].is_ascii_digit() {
                i += 1;
            }
            i
        };
        let mut i = digits(0);
        let mut n = i;
        if b.get(i) == Some(&b'.') {
            let j = digits(i + 1);
            n += j - i - 1;
            i = j;
        }
        if n == 0 {
            return None;
        }
        if matches!(b.get(i), Some(b'e' | b'E')) {
            let mut j = i + 1;
            if matches!(b.get(j), Some(b'+' | b'-')) {
                j += 1;
            }
            let k = digits(j);
            if k > j {
                i = k;
            }
        }
        Some(&text[..i])
    }
}

pub type Ex = FlatEx<f64, FloatOpsFactory<f64>, SciNumber>;

/// The parser's functions (`sin`, `exp`, …), as the expressions may call them.
pub fn function_names() -> Vec<&'static str> {
    FloatOpsFactory::<f64>::make()
        .iter()
        .filter(|o| o.has_unary() && o.repr().chars().all(|c| c.is_ascii_alphanumeric()))
        .map(|o| o.repr())
        .collect()
}

/// The first name called as a function (`name(`) that the parser does not know: `exmex` then
/// says only that a name cannot stand before a parenthesis.
fn unknown_function(text: &str) -> Option<&str> {
    let known = function_names();
    let b = text.as_bytes();
    let mut i = 0;
    while i < b.len() {
        if b[i].is_ascii_alphabetic() || b[i] == b'_' {
            let start = i;
            while i < b.len() && (b[i].is_ascii_alphanumeric() || b[i] == b'_') {
                i += 1;
            }
            let name = &text[start..i];
            let mut j = i;
            while j < b.len() && b[j].is_ascii_whitespace() {
                j += 1;
            }
            if b.get(j) == Some(&b'(') && !known.contains(&name) {
                return Some(name);
            }
        } else if b[i].is_ascii_digit() || b[i] == b'.' {
            // a literal such as 1.5e-3: its `e` is not a name
            i += SciNumber::is_literal(&text[i..]).map_or(1, str::len);
        } else {
            i += 1;
        }
    }
    None
}

/// A parsed real field.
#[derive(Debug, Clone)]
pub enum RealExpr {
    /// A number (or an expression of constants, evaluated once).
    Num(f64),
    /// One parameter.
    Param(usize),
    /// An expression of parameters (and constants).
    Ex(Box<ExmexExpr>),
}

/// An `exmex` expression with its variables (alphabetical, as `exmex` orders them) and the
/// partial derivatives with respect to each parameter it reads.
#[derive(Debug, Clone)]
pub struct ExmexExpr {
    ex: Ex,
    vars: Vec<VarSrc>,
    partials: Vec<(usize, Ex)>,
}

impl RealExpr {
    /// Parses `text`; `lookup` resolves a name to a parameter or constant (or `None`, then the
    /// message ends with `unknown(name)`, which says what the name is and what is allowed).
    pub fn parse(
        text: &str,
        lookup: &dyn Fn(&str) -> Option<VarSrc>,
        unknown: &dyn Fn(&str) -> String,
    ) -> Result<RealExpr, String> {
        let t = text.trim();
        if t.is_empty() {
            return Err("the expression is empty".into());
        }
        if let Some(v) = lookup(t) {
            return Ok(match v {
                VarSrc::Param(i) => RealExpr::Param(i),
                VarSrc::Const(x) => RealExpr::Num(x),
            });
        }
        let ex = Ex::parse(t).map_err(|e| match unknown_function(t) {
            Some(f) => format!(
                "unknown function `{f}` in `{t}`; the functions are {}",
                function_names().join(", ")
            ),
            None => format!("cannot parse `{t}`: {e}"),
        })?;
        let names = ex.var_names().to_vec();
        if names.len() > MAX_VARS {
            return Err(format!(
                "`{t}` reads {} names; at most {MAX_VARS} are supported",
                names.len()
            ));
        }
        let mut vars = Vec::with_capacity(names.len());
        for n in &names {
            let v = match lookup(n) {
                Some(v) => v,
                None if n == "pi" => VarSrc::Const(PI),
                None => return Err(format!("unknown name `{n}` in `{t}`; {}", unknown(n))),
            };
            vars.push(v);
        }
        let mut partials = Vec::new();
        for (k, v) in vars.iter().enumerate() {
            if let VarSrc::Param(i) = *v {
                let d = ex.clone().partial(k).map_err(|e| {
                    format!(
                        "cannot differentiate `{t}` with respect to `{}`: {e}",
                        names[k]
                    )
                })?;
                partials.push((i, d));
            }
        }
        let e = ExmexExpr { ex, vars, partials };
        if e.partials.is_empty() {
            let x = e.value::<f64>(&[]);
            if !x.is_finite() {
                return Err(format!("`{t}` evaluates to {x}, not a finite number"));
            }
            return Ok(RealExpr::Num(x));
        }
        Ok(RealExpr::Ex(Box::new(e)))
    }

    /// The constant value, if the field does not depend on θ.
    pub fn constant(&self) -> Option<f64> {
        match self {
            RealExpr::Num(x) => Some(*x),
            _ => None,
        }
    }

    /// Indices of the parameters the field reads.
    pub fn params(&self) -> Vec<usize> {
        match self {
            RealExpr::Num(_) => vec![],
            RealExpr::Param(i) => vec![*i],
            RealExpr::Ex(e) => e.partials.iter().map(|(i, _)| *i).collect(),
        }
    }

    /// The value at θ with exact first derivatives for dual numbers:
    /// `v + Σ_a (∂v/∂θ_a)·(θ_a − re θ_a)`.
    #[inline]
    pub fn eval<T: DualNum<Primitive = f64> + Copy>(&self, th: &[T]) -> T {
        match self {
            RealExpr::Num(x) => T::from(*x),
            RealExpr::Param(i) => th[*i],
            RealExpr::Ex(e) => e.value(th),
        }
    }
}

impl ExmexExpr {
    fn value<T: DualNum<Primitive = f64> + Copy>(&self, th: &[T]) -> T {
        let mut vals = [0.0; MAX_VARS];
        let n = self.vars.len();
        for (slot, v) in vals.iter_mut().zip(&self.vars) {
            *slot = match *v {
                VarSrc::Param(i) => th[i].re(),
                VarSrc::Const(x) => x,
            };
        }
        let vals = &vals[..n];
        let mut r = T::from(self.ex.eval(vals).unwrap_or(f64::NAN));
        if T::NDERIV > 0 {
            for (i, d) in &self.partials {
                let dv = d.eval(vals).unwrap_or(f64::NAN);
                r += (th[*i] - T::from(th[*i].re())) * dv;
            }
        }
        r
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use num_dual::Dual64;

    fn lookup(n: &str) -> Option<VarSrc> {
        match n {
            "a" => Some(VarSrc::Param(0)),
            "b" => Some(VarSrc::Param(1)),
            "c" => Some(VarSrc::Const(2.0)),
            "a_df" => Some(VarSrc::Param(2)),
            "e1" => Some(VarSrc::Const(0.25)),
            _ => None,
        }
    }

    #[test]
    fn values_and_exact_derivatives() {
        let e = RealExpr::parse("b*exp(a) - c*sin(b) + pi", &lookup, &|_| String::new()).unwrap();
        assert_eq!(e.params(), vec![0, 1]);
        let (a, b) = (0.3, -1.7);
        let v = e.eval::<f64>(&[a, b]);
        let want = b * a.exp() - 2.0 * b.sin() + PI;
        assert!((v - want).abs() < 1e-15);
        let da = e.eval(&[Dual64::from(a).derivative(), Dual64::from(b)]);
        let db = e.eval(&[Dual64::from(a), Dual64::from(b).derivative()]);
        assert!((da.re - want).abs() < 1e-15);
        assert!((da.eps - b * a.exp()).abs() < 1e-14);
        assert!((db.eps - (a.exp() - 2.0 * b.cos())).abs() < 1e-14);
    }

    #[test]
    fn an_unknown_function_is_named_with_the_known_ones() {
        let e = RealExpr::parse("-(a + foo(c))", &lookup, &|_| String::new()).unwrap_err();
        assert!(
            e.starts_with("unknown function `foo` in `-(a + foo(c))`; the functions are")
                && e.contains("sin")
                && e.contains("sqrt")
                && !e.contains("wlog"),
            "{e}"
        );
        // a known function, a literal's exponent and a name before a bracket of its own
        let e = RealExpr::parse("a * (b + 1e2) + foo_2 (c)", &lookup, &|_| String::new());
        assert!(e.unwrap_err().contains("unknown function `foo_2`"));
        assert!(RealExpr::parse("sqrt(a) + 1e3*(b)", &lookup, &|_| String::new()).is_ok());
    }

    #[test]
    fn names_with_digits_and_underscores() {
        let e = RealExpr::parse("a_df*e1 + 1e-3*b", &lookup, &|_| String::new()).unwrap();
        assert_eq!(e.params(), vec![2, 1]); // exmex orders names alphabetically
        assert!((e.eval::<f64>(&[0.0, 2.0, 4.0]) - (1.0 + 2e-3)).abs() < 1e-15);
    }

    #[test]
    fn simple_fields_and_constant_folding() {
        assert!(matches!(
            RealExpr::parse(" a ", &lookup, &|_| String::new()).unwrap(),
            RealExpr::Param(0)
        ));
        assert_eq!(
            RealExpr::parse("c", &lookup, &|_| String::new())
                .unwrap()
                .constant(),
            Some(2.0)
        );
        assert_eq!(
            RealExpr::parse("c*c + 1", &lookup, &|_| String::new())
                .unwrap()
                .constant(),
            Some(5.0)
        );
        let e = RealExpr::parse("a + zz", &lookup, &|_| "allowed: a, b, c".into()).unwrap_err();
        assert!(
            e.contains("unknown name `zz`") && e.contains("allowed: a, b, c"),
            "{e}"
        );
        assert!(
            RealExpr::parse("1/0", &lookup, &|_| String::new())
                .unwrap_err()
                .contains("finite")
        );
        assert!(RealExpr::parse("a +* (", &lookup, &|_| String::new()).is_err());
        let e = RealExpr::parse("2.5E+2 + .5 + 1e1*c", &lookup, &|_| String::new()).unwrap();
        assert_eq!(e.constant(), Some(270.5));
    }
}
