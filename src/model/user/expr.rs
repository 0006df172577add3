//! The complex expression language of user-defined models: a hand-written recursive-descent
//! parser into a small syntax tree, compiled to a postfix program over fixed-size stacks and
//! evaluated generically over dual numbers without allocating.
//!
//! Grammar (whitespace is ignored):
//!
//! ```text
//! expr    := term (('+' | '-') term)*
//! term    := unary (('*' | '/') unary)*
//! unary   := ('-' | '+') unary | power
//! power   := primary ('^' exponent)?            exponent: an integer, e.g. 2, -1, (-2)
//! primary := number | identifier | '(' expr ')'
//! ```
//!
//! `-s^2` is `−(s²)`; chained powers `a^2^3` are rejected (write parentheses).

use num_complex::{Complex, Complex64};
use num_dual::DualNum;
use std::f64::consts::PI;

/// Most nodes (numbers, names, operators) in one expression.
pub const MAX_NODES: usize = 512;
/// Deepest evaluation stack of one expression.
pub const MAX_STACK: usize = 64;
/// Largest `|n|` in `x^n`.
pub const MAX_EXPONENT: i32 = 64;

/// Binary operators.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BinOp {
    Add,
    Sub,
    Mul,
    Div,
}

/// A parsed expression.
#[derive(Debug, Clone, PartialEq)]
pub enum Node {
    Num(f64),
    /// A name and its character position (for messages).
    Ident(String, usize),
    Neg(Box<Node>),
    Bin(BinOp, Box<Node>, Box<Node>),
    Pow(Box<Node>, i32),
}

impl Node {
    /// Every identifier with its position, in order of appearance.
    pub fn idents<'a>(&'a self, out: &mut Vec<(&'a str, usize)>) {
        match self {
            Node::Num(_) => {}
            Node::Ident(n, p) => out.push((n, *p)),
            Node::Neg(a) | Node::Pow(a, _) => a.idents(out),
            Node::Bin(_, a, b) => {
                a.idents(out);
                b.idents(out);
            }
        }
    }

    /// Stack depth needed to evaluate the postfix form.
    pub fn depth(&self) -> usize {
        match self {
            Node::Num(_) | Node::Ident(..) => 1,
            Node::Neg(a) | Node::Pow(a, _) => a.depth(),
            Node::Bin(_, a, b) => a.depth().max(b.depth() + 1),
        }
    }
}

/// One instruction of a compiled program.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Op {
    /// Push a constant.
    Const(Complex64),
    /// Push `s = i2πf`.
    S,
    /// Push the real parameter `θ_i`.
    Param(u16),
    /// Push a slot (a block or define value).
    Slot(u16),
    Add,
    Sub,
    Mul,
    Div,
    Neg,
    Pow(i32),
    /// Pop into a slot.
    Store(u16),
    /// Pop into an output coefficient.
    Out(u16),
}

/// What a name stands for when compiling.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Operand {
    Const(f64),
    S,
    Param(u16),
    Slot(u16),
}

/// Parses one expression; the error message says what is wrong and where (character offset).
pub fn parse(text: &str) -> Result<Node, String> {
    let mut p = Parser {
        s: text.as_bytes(),
        text,
        i: 0,
        nodes: 0,
    };
    p.skip_ws();
    if p.i == p.s.len() {
        return Err("the expression is empty".into());
    }
    let n = p.expr()?;
    p.skip_ws();
    if p.i < p.s.len() {
        return Err(format!(
            "unexpected `{}` at character {}",
            p.rest_char(),
            p.i
        ));
    }
    Ok(n)
}

struct Parser<'a> {
    s: &'a [u8],
    text: &'a str,
    i: usize,
    nodes: usize,
}

impl Parser<'_> {
    fn skip_ws(&mut self) {
        while self.i < self.s.len() && self.s[self.i].is_ascii_whitespace() {
            self.i += 1;
        }
    }

    fn peek(&mut self) -> Option<u8> {
        self.skip_ws();
        self.s.get(self.i).copied()
    }

    fn rest_char(&self) -> char {
        self.text[self.i..].chars().next().unwrap_or(' ')
    }

    fn count(&mut self) -> Result<(), String> {
        self.nodes += 1;
        if self.nodes > MAX_NODES {
            return Err(format!(
                "the expression is too long: at most {MAX_NODES} numbers, names and operators"
            ));
        }
        Ok(())
    }

    fn expr(&mut self) -> Result<Node, String> {
        let mut a = self.term()?;
        while let Some(c @ (b'+' | b'-')) = self.peek() {
            self.i += 1;
            self.count()?;
            let b = self.term()?;
            let op = if c == b'+' { BinOp::Add } else { BinOp::Sub };
            a = Node::Bin(op, Box::new(a), Box::new(b));
        }
        Ok(a)
    }

    fn term(&mut self) -> Result<Node, String> {
        let mut a = self.unary()?;
        while let Some(c @ (b'*' | b'/')) = self.peek() {
            self.i += 1;
            self.count()?;
            let b = self.unary()?;
            let op = if c == b'*' { BinOp::Mul } else { BinOp::Div };
            a = Node::Bin(op, Box::new(a), Box::new(b));
        }
        Ok(a)
    }

    fn unary(&mut self) -> Result<Node, String> {
        match self.peek() {
            Some(b'-') => {
                self.i += 1;
                self.count()?;
                Ok(match self.unary()? {
                    Node::Num(x) => Node::Num(-x),
                    n => Node::Neg(Box::new(n)),
                })
            }
            Some(b'+') => {
                self.i += 1;
                self.unary()
            }
            _ => self.power(),
        }
    }

    fn power(&mut self) -> Result<Node, String> {
        let base = self.primary()?;
        if self.peek() != Some(b'^') {
            return Ok(base);
        }
        self.i += 1;
        self.count()?;
        let n = self.exponent()?;
        if self.peek() == Some(b'^') {
            return Err(format!(
                "chained `^` at character {}: write parentheses, e.g. (a^2)^3",
                self.i
            ));
        }
        Ok(Node::Pow(Box::new(base), n))
    }

    fn exponent(&mut self) -> Result<i32, String> {
        let at = self.i;
        let paren = self.peek() == Some(b'(');
        if paren {
            self.i += 1;
        }
        let neg = match self.peek() {
            Some(b'-') => {
                self.i += 1;
                true
            }
            Some(b'+') => {
                self.i += 1;
                false
            }
            _ => false,
        };
        self.skip_ws();
        let start = self.i;
        while self.i < self.s.len() && self.s[self.i].is_ascii_digit() {
            self.i += 1;
        }
        let bad = || {
            format!(
                "the exponent after `^` at character {at} must be an integer literal from \
                 -{MAX_EXPONENT} to {MAX_EXPONENT} (e.g. s^2, x^-1, x^(-2))"
            )
        };
        if start == self.i || matches!(self.s.get(self.i), Some(b'.' | b'e' | b'E')) {
            return Err(bad());
        }
        let n: i32 = self.text[start..self.i].parse().map_err(|_| bad())?;
        if n > MAX_EXPONENT {
            return Err(bad());
        }
        if paren {
            if self.peek() != Some(b')') {
                return Err(bad());
            }
            self.i += 1;
        }
        Ok(if neg { -n } else { n })
    }

    fn primary(&mut self) -> Result<Node, String> {
        self.count()?;
        let at = self.i;
        match self.peek() {
            None => Err("the expression ends where a number, name or `(` is expected".into()),
            Some(b'(') => {
                self.i += 1;
                let e = self.expr()?;
                if self.peek() != Some(b')') {
                    return Err(format!("missing `)` for the `(` at character {at}"));
                }
                self.i += 1;
                Ok(e)
            }
            Some(c) if c.is_ascii_digit() || c == b'.' => self.number(),
            Some(c) if c.is_ascii_alphabetic() || c == b'_' => {
                let start = self.i;
                while self.i < self.s.len()
                    && (self.s[self.i].is_ascii_alphanumeric() || self.s[self.i] == b'_')
                {
                    self.i += 1;
                }
                Ok(Node::Ident(self.text[start..self.i].to_string(), start))
            }
            Some(_) => Err(format!(
                "unexpected `{}` at character {}: expected a number, a name or `(`",
                self.rest_char(),
                self.i
            )),
        }
    }

    fn number(&mut self) -> Result<Node, String> {
        let start = self.i;
        let digits = |p: &mut Self| {
            let s = p.i;
            while p.i < p.s.len() && p.s[p.i].is_ascii_digit() {
                p.i += 1;
            }
            p.i - s
        };
        let mut n = digits(self);
        if self.s.get(self.i) == Some(&b'.') {
            self.i += 1;
            n += digits(self);
        }
        if n > 0 && matches!(self.s.get(self.i), Some(b'e' | b'E')) {
            let save = self.i;
            self.i += 1;
            if matches!(self.s.get(self.i), Some(b'+' | b'-')) {
                self.i += 1;
            }
            if digits(self) == 0 {
                self.i = save;
            }
        }
        let lex = &self.text[start..self.i];
        match lex.parse::<f64>() {
            Ok(x) if x.is_finite() && n > 0 => Ok(Node::Num(x)),
            _ => Err(format!(
                "`{lex}` at character {start} is not a finite number"
            )),
        }
    }
}

/// Appends the postfix program of `n` to `ops`, resolving names with `resolve` (every name
/// must already have been checked).
pub fn emit(n: &Node, resolve: &dyn Fn(&str) -> Operand, ops: &mut Vec<Op>) {
    match n {
        Node::Num(x) => ops.push(Op::Const(Complex64::new(*x, 0.0))),
        Node::Ident(name, _) => ops.push(match resolve(name) {
            Operand::Const(x) => Op::Const(Complex64::new(x, 0.0)),
            Operand::S => Op::S,
            Operand::Param(i) => Op::Param(i),
            Operand::Slot(i) => Op::Slot(i),
        }),
        Node::Neg(a) => {
            emit(a, resolve, ops);
            ops.push(Op::Neg);
        }
        Node::Pow(a, k) => {
            emit(a, resolve, ops);
            ops.push(Op::Pow(*k));
        }
        Node::Bin(op, a, b) => {
            emit(a, resolve, ops);
            emit(b, resolve, ops);
            ops.push(match op {
                BinOp::Add => Op::Add,
                BinOp::Sub => Op::Sub,
                BinOp::Mul => Op::Mul,
                BinOp::Div => Op::Div,
            });
        }
    }
}

/// `z^n` by binary powering (negative `n`: the reciprocal).
#[inline]
pub fn powi<T: DualNum<Primitive = f64> + Copy>(z: Complex<T>, n: i32) -> Complex<T> {
    let mut base = z;
    let mut e = n.unsigned_abs();
    let mut acc = Complex::new(T::one(), T::zero());
    while e > 0 {
        if e & 1 == 1 {
            acc *= base;
        }
        e >>= 1;
        if e > 0 {
            base = base * base;
        }
    }
    if n < 0 { acc.inv() } else { acc }
}

#[inline(always)]
pub fn lift<T: DualNum<Primitive = f64> + Copy>(z: Complex64) -> Complex<T> {
    Complex::new(T::from(z.re), T::from(z.im))
}

/// Runs a compiled program: `s = i·omega`, parameters `th`, `slots` read and written, outputs
/// written to `out`. The stack holds at most [`MAX_STACK`] values (checked when compiling).
#[inline]
pub fn run<T: DualNum<Primitive = f64> + Copy>(
    ops: &[Op],
    th: &[T],
    omega: f64,
    slots: &mut [Complex<T>],
    out: &mut [Complex<T>],
) {
    let zero = Complex::new(T::zero(), T::zero());
    let mut st = [zero; MAX_STACK];
    let mut sp = 0usize;
    for op in ops {
        match *op {
            Op::Const(c) => {
                st[sp] = lift(c);
                sp += 1;
            }
            Op::S => {
                st[sp] = Complex::new(T::zero(), T::from(omega));
                sp += 1;
            }
            Op::Param(i) => {
                st[sp] = Complex::new(th[i as usize], T::zero());
                sp += 1;
            }
            Op::Slot(i) => {
                st[sp] = slots[i as usize];
                sp += 1;
            }
            Op::Add => {
                sp -= 1;
                st[sp - 1] += st[sp];
            }
            Op::Sub => {
                sp -= 1;
                st[sp - 1] -= st[sp];
            }
            Op::Mul => {
                sp -= 1;
                st[sp - 1] *= st[sp];
            }
            Op::Div => {
                sp -= 1;
                st[sp - 1] /= st[sp];
            }
            Op::Neg => st[sp - 1] = -st[sp - 1],
            Op::Pow(n) => st[sp - 1] = powi(st[sp - 1], n),
            Op::Store(i) => {
                sp -= 1;
                slots[i as usize] = st[sp];
            }
            Op::Out(i) => {
                sp -= 1;
                out[i as usize] = st[sp];
            }
        }
    }
}

/// Why the program `ops` (one define or coefficient, ending in a store) gives a non-finite
/// value at θ = `th`, `s = iω` and block/define values `slots`: the first operation that makes
/// one of finite operands — a division by zero (which a complex quotient turns into NaN) or
/// an overflow. `None` when every step is finite or a non-finite value comes in from a slot.
pub fn first_fault(
    ops: &[Op],
    th: &[f64],
    omega: f64,
    slots: &[Complex64],
) -> Option<&'static str> {
    let finite = |z: Complex64| z.re.is_finite() && z.im.is_finite();
    let mut st: Vec<Complex64> = Vec::with_capacity(MAX_STACK);
    for op in ops {
        let v = match *op {
            Op::Const(c) => c,
            Op::S => Complex64::new(0.0, omega),
            Op::Param(i) => Complex64::new(th[i as usize], 0.0),
            Op::Slot(i) => {
                let v = slots[i as usize];
                if !finite(v) {
                    return None;
                }
                v
            }
            Op::Store(_) | Op::Out(_) => return None,
            Op::Neg => -st.pop()?,
            Op::Pow(n) => {
                let a = st.pop()?;
                let v = powi(a, n);
                if !finite(v) {
                    return Some(if a == Complex64::new(0.0, 0.0) {
                        "a negative power of an expression that is zero here"
                    } else {
                        "an overflow (a power beyond 1.8e308)"
                    });
                }
                v
            }
            Op::Add | Op::Sub | Op::Mul | Op::Div => {
                let b = st.pop()?;
                let a = st.pop()?;
                let v = match *op {
                    Op::Add => a + b,
                    Op::Sub => a - b,
                    Op::Mul => a * b,
                    _ => a / b,
                };
                if !finite(v) {
                    return Some(match *op {
                        Op::Div if b == Complex64::new(0.0, 0.0) => {
                            "a division by an expression that is zero here"
                        }
                        _ => "an overflow (a value beyond 1.8e308)",
                    });
                }
                v
            }
        };
        st.push(v);
    }
    None
}

/// The value of `pi` in expressions.
pub const PI_VALUE: f64 = PI;

#[cfg(test)]
mod tests {
    use super::*;

    fn eval(text: &str, s: f64) -> Complex64 {
        let n = parse(text).unwrap();
        assert!(n.depth() <= MAX_STACK);
        let mut ops = Vec::new();
        let resolve = |name: &str| match name {
            "s" => Operand::S,
            "pi" => Operand::Const(PI),
            "x" => Operand::Param(0),
            "y" => Operand::Slot(0),
            _ => panic!("{name}"),
        };
        emit(&n, &resolve, &mut ops);
        ops.push(Op::Out(0));
        let mut slots = [Complex64::new(0.5, -1.0)];
        let mut out = [Complex64::new(0.0, 0.0)];
        run(&ops, &[3.0], s, &mut slots, &mut out);
        out[0]
    }

    #[test]
    fn precedence_and_powers() {
        let i = Complex64::new(0.0, 1.0);
        let close = |a: Complex64, b: Complex64| (a - b).norm() < 1e-14 * b.norm().max(1.0);
        assert!(close(eval("1 + 2*3 - 4/2", 0.0), Complex64::new(5.0, 0.0)));
        assert!(close(eval("-s^2", 2.0), Complex64::new(4.0, 0.0)));
        assert!(close(eval("(1 + s)^-1", 1.0), (1.0 + i).inv()));
        assert!(close(
            eval("x^(-2)*y", 0.0),
            Complex64::new(0.5, -1.0) / 9.0
        ));
        assert!(close(eval("2*pi*x", 0.0), Complex64::new(6.0 * PI, 0.0)));
        assert!(close(
            eval("1.5e-3 * -x", 0.0),
            Complex64::new(-4.5e-3, 0.0)
        ));
        assert!(close(eval("--x - +x", 0.0), Complex64::new(0.0, 0.0)));
        assert!(close(eval("s^0", 3.0), Complex64::new(1.0, 0.0)));
        assert!(close(eval("y^3", 0.0), Complex64::new(0.5, -1.0).powi(3)));
    }

    #[test]
    fn syntax_errors_are_located() {
        for (text, want) in [
            ("", "empty"),
            ("1 +", "ends where"),
            ("(1 + s", "missing `)`"),
            ("s^2^3", "chained"),
            ("s^1.5", "integer"),
            ("s^x", "integer"),
            ("s^99", "integer"),
            ("1 $ 2", "unexpected `$` at character 2"),
            ("2 3", "unexpected `3`"),
            ("1e400", "not a finite number"),
            (".", "not a finite number"),
        ] {
            let e = parse(text).unwrap_err();
            assert!(e.contains(want), "{text}: {e}");
        }
        let long = vec!["s"; 600].join("+");
        assert!(parse(&long).unwrap_err().contains("too long"));
    }
}
