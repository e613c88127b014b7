//! Residual-signature expressions of the effect catalogue (`signature = "-10*p0*log10(range/r_ref)"`).
//!
//! A tiny recursive-descent parser compiled once into a tree; evaluation allocates nothing.
//! Grammar: `+ - * / ^`, unary minus, parentheses, numbers, variables (explanatory variables of a
//! residual row, catalogue constants, parameters `p0`, `p1`, `pi`) and the functions `log10`, `ln`,
//! `exp`, `sqrt`, `abs`, `cos`, `sin`, `atan`, `acos` (argument clamped to [−1, 1]), `cosd` (cosine of degrees), `min`, `max`, `npdf` (standard
//! normal density), `ncdf` (standard normal distribution function; censoring signatures) and `e1`
//! (the exponential integral E₁; the mean logarithm of a Rician power, physics.md §1.10).

use anyhow::{Result, bail};

/// A compiled expression.
#[derive(Debug, Clone, PartialEq)]
pub enum Expr {
    Num(f64),
    /// Explanatory variable by index into the row's variable vector.
    Var(usize),
    /// Parameter by index.
    Param(usize),
    Neg(Box<Expr>),
    Bin(char, Box<Expr>, Box<Expr>),
    Call(Func, Vec<Expr>),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Func {
    Log10,
    Ln,
    Exp,
    Sqrt,
    Abs,
    Cos,
    Sin,
    /// Arc tangent, rad.
    Atan,
    /// Arc cosine, rad, of the argument clamped to [−1, 1] (circle-overlap areas need no branches).
    Acos,
    Cosd,
    Min,
    Max,
    /// Standard normal density φ(x).
    Npdf,
    /// Standard normal distribution function Φ(x).
    Ncdf,
    /// Exponential integral E₁(x) = ∫ₓ^∞ e^{−t}/t dt (x > 0).
    E1,
    /// `fresnel(c, n)`: unpolarised Fresnel reflectance of one interface from air into index n at
    /// incidence cosine c, ½(r_s + r_p) (Born & Wolf §1.5).
    Fresnel,
}

impl Expr {
    /// Parses `text`; `vars` are the variable names (index = position), `consts` are substituted,
    /// `params` are the parameter names.
    pub fn parse(
        text: &str,
        vars: &[&str],
        consts: &[(String, f64)],
        params: &[String],
    ) -> Result<Expr> {
        let mut p = Parser {
            s: text.as_bytes(),
            i: 0,
            vars,
            consts,
            params,
            text,
        };
        let e = p.sum()?;
        p.ws();
        if p.i != p.s.len() {
            bail!(
                "signature `{text}`: unexpected `{}` at {}",
                &text[p.i..],
                p.i
            );
        }
        Ok(e)
    }

    /// Evaluates with variables `x` and parameters `p`.
    pub fn eval(&self, x: &[f64], p: &[f64]) -> f64 {
        match self {
            Expr::Num(v) => *v,
            Expr::Var(i) => x[*i],
            Expr::Param(i) => p[*i],
            Expr::Neg(a) => -a.eval(x, p),
            Expr::Bin(op, a, b) => {
                let (a, b) = (a.eval(x, p), b.eval(x, p));
                match op {
                    '+' => a + b,
                    '-' => a - b,
                    '*' => a * b,
                    '/' => a / b,
                    _ => a.powf(b),
                }
            }
            Expr::Call(f, args) => {
                let a = args[0].eval(x, p);
                match f {
                    Func::Log10 => a.log10(),
                    Func::Ln => a.ln(),
                    Func::Exp => a.exp(),
                    Func::Sqrt => a.sqrt(),
                    Func::Abs => a.abs(),
                    Func::Cos => a.cos(),
                    Func::Sin => a.sin(),
                    Func::Atan => a.atan(),
                    Func::Acos => a.clamp(-1.0, 1.0).acos(),
                    Func::Cosd => a.to_radians().cos(),
                    Func::Min => a.min(args[1].eval(x, p)),
                    Func::Max => a.max(args[1].eval(x, p)),
                    Func::Fresnel => fresnel(a, args[1].eval(x, p)),
                    Func::Npdf => npdf(a),
                    Func::Ncdf => ncdf(a),
                    Func::E1 => e1(a),
                }
            }
        }
    }

    /// Whether the expression reads variable `i`.
    pub fn uses_var(&self, i: usize) -> bool {
        match self {
            Expr::Var(j) => *j == i,
            Expr::Num(_) | Expr::Param(_) => false,
            Expr::Neg(a) => a.uses_var(i),
            Expr::Bin(_, a, b) => a.uses_var(i) || b.uses_var(i),
            Expr::Call(_, args) => args.iter().any(|a| a.uses_var(i)),
        }
    }
}

/// One instruction of a [`Program`] (postfix).
#[derive(Debug, Clone, Copy, PartialEq)]
enum Op {
    Num(f64),
    Var(usize),
    Param(usize),
    Neg,
    Add,
    Sub,
    Mul,
    Div,
    Pow,
    /// Integer power with a constant exponent.
    PowI(i32),
    /// `b^a` with a constant base b > 0: exp(ln b · a).
    ExpBase(f64),
    Call1(Func),
    Call2(Func),
}

/// Stack depth a [`Program`] may use (deeper expressions are evaluated as trees).
const STACK: usize = 32;

/// An [`Expr`] compiled into postfix code with constant folding and fast paths for constant
/// integer exponents and constant bases: what the attribution's fits evaluate millions of times
/// (no recursion, no pointer chasing, no allocation).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Program {
    ops: Vec<Op>,
    /// The tree, when the code would need more than [`STACK`] stack slots.
    fallback: Option<Box<Expr>>,
}

impl Program {
    /// Compiles `e`.
    pub fn compile(e: &Expr) -> Program {
        let folded = e.fold();
        let mut ops = Vec::new();
        let depth = emit(&folded, &mut ops);
        if depth > STACK {
            return Program {
                ops: Vec::new(),
                fallback: Some(Box::new(folded)),
            };
        }
        Program {
            ops,
            fallback: None,
        }
    }

    /// Evaluates with variables `x` and parameters `p`; the same value as [`Expr::eval`] up to
    /// rounding of the fast paths.
    pub fn eval(&self, x: &[f64], p: &[f64]) -> f64 {
        if let Some(e) = &self.fallback {
            return e.eval(x, p);
        }
        let mut st = [0.0f64; STACK];
        let mut sp = 0usize;
        for op in &self.ops {
            match *op {
                Op::Num(v) => {
                    st[sp] = v;
                    sp += 1;
                }
                Op::Var(i) => {
                    st[sp] = x[i];
                    sp += 1;
                }
                Op::Param(i) => {
                    st[sp] = p[i];
                    sp += 1;
                }
                Op::Neg => st[sp - 1] = -st[sp - 1],
                Op::PowI(n) => st[sp - 1] = st[sp - 1].powi(n),
                Op::ExpBase(lnb) => st[sp - 1] = (lnb * st[sp - 1]).exp(),
                Op::Call1(f) => st[sp - 1] = call1(f, st[sp - 1]),
                Op::Add | Op::Sub | Op::Mul | Op::Div | Op::Pow | Op::Call2(_) => {
                    sp -= 1;
                    let (a, b) = (st[sp - 1], st[sp]);
                    st[sp - 1] = match *op {
                        Op::Add => a + b,
                        Op::Sub => a - b,
                        Op::Mul => a * b,
                        Op::Div => a / b,
                        Op::Pow => a.powf(b),
                        Op::Call2(Func::Min) => a.min(b),
                        Op::Call2(Func::Fresnel) => fresnel(a, b),
                        _ => a.max(b),
                    };
                }
            }
        }
        if sp == 1 { st[0] } else { f64::NAN }
    }
}

fn call1(f: Func, a: f64) -> f64 {
    match f {
        Func::Log10 => a.log10(),
        Func::Ln => a.ln(),
        Func::Exp => a.exp(),
        Func::Sqrt => a.sqrt(),
        Func::Abs => a.abs(),
        Func::Cos => a.cos(),
        Func::Sin => a.sin(),
        Func::Atan => a.atan(),
        Func::Acos => a.clamp(-1.0, 1.0).acos(),
        Func::Cosd => a.to_radians().cos(),
        Func::Npdf => npdf(a),
        Func::Ncdf => ncdf(a),
        Func::E1 => e1(a),
        Func::Min | Func::Max | Func::Fresnel => f64::NAN,
    }
}

/// Emits postfix code for `e`; returns the stack depth it needs.
fn emit(e: &Expr, ops: &mut Vec<Op>) -> usize {
    match e {
        Expr::Num(v) => {
            ops.push(Op::Num(*v));
            1
        }
        Expr::Var(i) => {
            ops.push(Op::Var(*i));
            1
        }
        Expr::Param(i) => {
            ops.push(Op::Param(*i));
            1
        }
        Expr::Neg(a) => {
            let d = emit(a, ops);
            ops.push(Op::Neg);
            d
        }
        Expr::Bin('^', a, b) => match (&**a, &**b) {
            (_, Expr::Num(n)) if n.fract() == 0.0 && n.abs() <= 16.0 => {
                let d = emit(a, ops);
                ops.push(Op::PowI(*n as i32));
                d
            }
            (Expr::Num(base), _) if *base > 0.0 => {
                let d = emit(b, ops);
                ops.push(Op::ExpBase(base.ln()));
                d
            }
            _ => {
                let da = emit(a, ops);
                let db = emit(b, ops);
                ops.push(Op::Pow);
                da.max(db + 1)
            }
        },
        Expr::Bin(op, a, b) => {
            let da = emit(a, ops);
            let db = emit(b, ops);
            ops.push(match op {
                '+' => Op::Add,
                '-' => Op::Sub,
                '*' => Op::Mul,
                '/' => Op::Div,
                _ => Op::Pow,
            });
            da.max(db + 1)
        }
        Expr::Call(f, args) => {
            if args.len() == 2 {
                let da = emit(&args[0], ops);
                let db = emit(&args[1], ops);
                ops.push(Op::Call2(*f));
                da.max(db + 1)
            } else {
                let d = emit(&args[0], ops);
                ops.push(Op::Call1(*f));
                d
            }
        }
    }
}

impl Expr {
    /// Constant folding: every subtree without variables or parameters becomes a number.
    pub fn fold(&self) -> Expr {
        let is_const = |e: &Expr| matches!(e, Expr::Num(_));
        match self {
            Expr::Num(_) | Expr::Var(_) | Expr::Param(_) => self.clone(),
            Expr::Neg(a) => {
                let a = a.fold();
                if is_const(&a) {
                    Expr::Num(-a.eval(&[], &[]))
                } else {
                    Expr::Neg(Box::new(a))
                }
            }
            Expr::Bin(op, a, b) => {
                let e = Expr::Bin(*op, Box::new(a.fold()), Box::new(b.fold()));
                match &e {
                    Expr::Bin(_, a, b) if is_const(a) && is_const(b) => Expr::Num(e.eval(&[], &[])),
                    _ => e,
                }
            }
            Expr::Call(f, args) => {
                let args: Vec<Expr> = args.iter().map(Expr::fold).collect();
                let e = Expr::Call(*f, args);
                match &e {
                    Expr::Call(_, args) if args.iter().all(is_const) => Expr::Num(e.eval(&[], &[])),
                    _ => e,
                }
            }
        }
    }
}

/// Standard normal density φ(x) = exp(−x²/2)/√(2π).
pub fn npdf(x: f64) -> f64 {
    (-0.5 * x * x).exp() / (2.0 * std::f64::consts::PI).sqrt()
}

pub use osiris_models::special::{erfc, exp_integral_e1 as e1};

/// Standard normal distribution function Φ(x) = erfc(−x/√2)/2.
pub fn ncdf(x: f64) -> f64 {
    0.5 * erfc(-x / std::f64::consts::SQRT_2)
}

/// Unpolarised Fresnel reflectance ½(r_s + r_p) of an interface from air into index `n` at
/// incidence cosine `c` (clamped to [0, 1]): the models' own, lossless.
fn fresnel(c: f64, n: f64) -> f64 {
    osiris_models::environment::material::fresnel_unpolarised(n, 0.0, c)
}

struct Parser<'a> {
    s: &'a [u8],
    i: usize,
    vars: &'a [&'a str],
    consts: &'a [(String, f64)],
    params: &'a [String],
    text: &'a str,
}

impl Parser<'_> {
    fn ws(&mut self) {
        while self.i < self.s.len() && self.s[self.i].is_ascii_whitespace() {
            self.i += 1;
        }
    }

    fn peek(&mut self) -> Option<u8> {
        self.ws();
        self.s.get(self.i).copied()
    }

    fn sum(&mut self) -> Result<Expr> {
        let mut e = self.product()?;
        while let Some(c @ (b'+' | b'-')) = self.peek() {
            self.i += 1;
            e = Expr::Bin(c as char, Box::new(e), Box::new(self.product()?));
        }
        Ok(e)
    }

    fn product(&mut self) -> Result<Expr> {
        let mut e = self.unary()?;
        while let Some(c @ (b'*' | b'/')) = self.peek() {
            self.i += 1;
            e = Expr::Bin(c as char, Box::new(e), Box::new(self.unary()?));
        }
        Ok(e)
    }

    fn unary(&mut self) -> Result<Expr> {
        if self.peek() == Some(b'-') {
            self.i += 1;
            return Ok(Expr::Neg(Box::new(self.unary()?)));
        }
        self.power()
    }

    fn power(&mut self) -> Result<Expr> {
        let base = self.atom()?;
        if self.peek() == Some(b'^') {
            self.i += 1;
            let exp = self.unary()?;
            return Ok(Expr::Bin('^', Box::new(base), Box::new(exp)));
        }
        Ok(base)
    }

    fn atom(&mut self) -> Result<Expr> {
        let text = self.text;
        match self.peek() {
            Some(b'(') => {
                self.i += 1;
                let e = self.sum()?;
                if self.peek() != Some(b')') {
                    bail!("signature `{text}`: missing `)` at {}", self.i);
                }
                self.i += 1;
                Ok(e)
            }
            Some(c) if c.is_ascii_digit() || c == b'.' => {
                let start = self.i;
                while self.i < self.s.len()
                    && (self.s[self.i].is_ascii_digit()
                        || self.s[self.i] == b'.'
                        || ((self.s[self.i] == b'e' || self.s[self.i] == b'E')
                            && self.i + 1 < self.s.len()
                            && (self.s[self.i + 1].is_ascii_digit() || self.s[self.i + 1] == b'-')))
                {
                    if self.s[self.i] == b'e' || self.s[self.i] == b'E' {
                        self.i += 1;
                    }
                    self.i += 1;
                }
                let lit = &text[start..self.i];
                lit.parse::<f64>()
                    .map(Expr::Num)
                    .map_err(|_| anyhow::anyhow!("signature `{text}`: bad number `{lit}`"))
            }
            Some(c) if c.is_ascii_alphabetic() || c == b'_' => {
                let start = self.i;
                while self.i < self.s.len()
                    && (self.s[self.i].is_ascii_alphanumeric() || self.s[self.i] == b'_')
                {
                    self.i += 1;
                }
                let name = &text[start..self.i];
                if self.peek() == Some(b'(') {
                    self.i += 1;
                    let func = match name {
                        "log10" => Func::Log10,
                        "ln" | "log" => Func::Ln,
                        "exp" => Func::Exp,
                        "sqrt" => Func::Sqrt,
                        "abs" => Func::Abs,
                        "cos" => Func::Cos,
                        "sin" => Func::Sin,
                        "atan" => Func::Atan,
                        "acos" => Func::Acos,
                        "cosd" => Func::Cosd,
                        "min" => Func::Min,
                        "max" => Func::Max,
                        "npdf" => Func::Npdf,
                        "ncdf" => Func::Ncdf,
                        "e1" => Func::E1,
                        "fresnel" => Func::Fresnel,
                        other => bail!("signature `{text}`: unknown function `{other}`"),
                    };
                    let mut args = vec![self.sum()?];
                    while self.peek() == Some(b',') {
                        self.i += 1;
                        args.push(self.sum()?);
                    }
                    if self.peek() != Some(b')') {
                        bail!("signature `{text}`: missing `)` after the arguments of `{name}`");
                    }
                    self.i += 1;
                    let want = if matches!(func, Func::Min | Func::Max | Func::Fresnel) {
                        2
                    } else {
                        1
                    };
                    if args.len() != want {
                        bail!("signature `{text}`: `{name}` takes {want} argument(s)");
                    }
                    return Ok(Expr::Call(func, args));
                }
                if name == "pi" {
                    return Ok(Expr::Num(std::f64::consts::PI));
                }
                if let Some(i) = self.params.iter().position(|p| p == name) {
                    return Ok(Expr::Param(i));
                }
                if let Some((_, v)) = self.consts.iter().find(|(c, _)| c == name) {
                    return Ok(Expr::Num(*v));
                }
                if let Some(i) = self.vars.iter().position(|v| *v == name) {
                    return Ok(Expr::Var(i));
                }
                bail!(
                    "signature `{text}`: unknown name `{name}` (variables: {}; parameters: {})",
                    self.vars.join(", "),
                    self.params.join(", ")
                )
            }
            _ => bail!("signature `{text}`: expected a value at {}", self.i),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_and_evaluates() {
        let vars = ["range", "azimuth"];
        let consts = vec![("r_ref".to_owned(), 10.0)];
        let params = vec!["p0".to_owned()];
        let e = Expr::parse("-10*p0*log10(range/r_ref)", &vars, &consts, &params).unwrap();
        assert!((e.eval(&[100.0, 0.0], &[2.0]) + 20.0).abs() < 1e-12);
        let e = Expr::parse(
            "-24*(azimuth/p0)^2 + max(1, 2e0) - -1",
            &vars,
            &consts,
            &params,
        )
        .unwrap();
        assert!((e.eval(&[0.0, 5.0], &[10.0]) - (-6.0 + 3.0)).abs() < 1e-12);
        assert!(Expr::parse("foo(range)", &vars, &consts, &params).is_err());
        // Φ and φ against tabulated values (Abramowitz & Stegun, Table 26.1).
        let e = Expr::parse("ncdf(range) + 0*npdf(azimuth)", &vars, &consts, &params).unwrap();
        assert!((e.eval(&[1.0, 0.0], &[0.0]) - 0.841_344_746).abs() < 1e-6);
        assert!((ncdf(-1.96) - 0.024_997_895).abs() < 1e-7);
        assert!((ncdf(0.0) - 0.5).abs() < 1e-7);
        assert!((npdf(1.0) - 0.241_970_725).abs() < 1e-9);
        assert!((erfc(0.5) - 0.479_500_122).abs() < 1e-7);
        // The compiled program agrees with the tree.
        let names = ["range", "azimuth", "prx"];
        let params = vec!["p0".to_owned(), "p1".to_owned()];
        for text in [
            "-10*p0*log10(range/r_ref)",
            "-24*(azimuth/p0)^2 + 2^3*range",
            "-10*log10(1 + 10^((prx - p0)/10))",
            "p1*npdf((p0 - prx)/p1)/max(ncdf((prx - p0)/p1), 1e-12)",
            "20*log10(max(abs(2*sin(2*pi*p0/(0.0039*range))), 0.03)) - -min(range, p1)",
            "2*fresnel(cosd(range), 1.52)/(1 + fresnel(cosd(range), p1))",
        ] {
            let e = Expr::parse(text, &names, &consts, &params).unwrap();
            let prog = Program::compile(&e);
            for x in [[3.0, -20.0, -60.0], [80.0, 7.5, -95.0], [150.0, 33.0, 10.0]] {
                let (a, b) = (e.eval(&x, &[1.7, 2.5]), prog.eval(&x, &[1.7, 2.5]));
                assert!(
                    (a - b).abs() <= 1e-9 * a.abs().max(1.0),
                    "{text}: {a} vs {b}"
                );
            }
        }
        assert!(Expr::parse("range +", &vars, &consts, &params).is_err());
    }

    /// Normal incidence ((n − 1)/(n + 1))²; Brewster's angle tan θ_B = n makes r_p vanish, so
    /// the unpolarised value is half of r_s = ((cos θ − n cos θt)/(cos θ + n cos θt))² there;
    /// grazing incidence reflects everything.
    #[test]
    fn fresnel_at_normal_brewster_and_grazing_incidence() {
        let n = 1.52f64;
        assert!((fresnel(1.0, n) - ((n - 1.0) / (n + 1.0)).powi(2)).abs() < 1e-15);
        let tb = n.atan();
        let ct = (1.0 - tb.sin().powi(2) / (n * n)).sqrt();
        let rs = ((tb.cos() - n * ct) / (tb.cos() + n * ct)).powi(2);
        assert!((fresnel(tb.cos(), n) - 0.5 * rs).abs() < 1e-12);
        assert!((fresnel(0.0, n) - 1.0).abs() < 1e-12);
        let e = Expr::parse("fresnel(1, 1.52)", &[], &[], &[]).unwrap();
        assert!((e.eval(&[], &[]) - 0.042_580_6).abs() < 1e-6);
        assert!(Expr::parse("fresnel(1)", &[], &[], &[]).is_err());
    }

    /// E₁ (`osiris_models::special::exp_integral_e1`, tested there against Abramowitz & Stegun)
    /// in a signature.
    #[test]
    fn exponential_integral_in_a_signature() {
        // In a signature: the compiled program agrees with the tree.
        let names = ["sim"];
        let e = Expr::parse("4.343*e1(10^(sim/10))", &names, &[], &[]).unwrap();
        let prog = Program::compile(&e);
        for x in [-20.0, 0.0, 3.0, 15.0] {
            assert!((e.eval(&[x], &[]) - prog.eval(&[x], &[])).abs() < 1e-12);
        }
    }
}
