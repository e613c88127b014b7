//! Residual-signature expressions of the effect catalogue (`signature = "-10*p0*log10(range/r_ref)"`).
//!
//! A tiny recursive-descent parser compiled once into a tree; evaluation allocates nothing.
//! Grammar: `+ - * / ^`, unary minus, parentheses, numbers, variables (explanatory variables of a
//! residual row, catalogue constants, parameters `p0`, `p1`, `pi`) and the functions `log10`, `ln`,
//! `exp`, `sqrt`, `abs`, `cos`, `sin`, `cosd` (cosine of degrees), `min`, `max`.

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
    Cosd,
    Min,
    Max,
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
                    Func::Cosd => a.to_radians().cos(),
                    Func::Min => a.min(args[1].eval(x, p)),
                    Func::Max => a.max(args[1].eval(x, p)),
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
                        "cosd" => Func::Cosd,
                        "min" => Func::Min,
                        "max" => Func::Max,
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
                    let want = if matches!(func, Func::Min | Func::Max) {
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
        assert!(Expr::parse("range +", &vars, &consts, &params).is_err());
    }
}
