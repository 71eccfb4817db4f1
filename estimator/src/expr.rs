//! Parser for linear expressions over link and payload parameters, the building block of the
//! coefficient-set file format (see [`crate::coefficients`] for the file format itself).
//!
//! An expression is built from numbers, named constants, `+ - * / ^` and parentheses. Its value
//! must be *linear and homogeneous* in the inertial parameters; the symbols are, for link `i`
//! (1-based) or the payload `L`:
//!
//! | symbol | meaning | unit |
//! |---|---|---|
//! | `m<i>` | mass | kg |
//! | `c<i>x`, `c<i>y`, `c<i>z` | CoM coordinate in frame i; only valid multiplied by `m<i>` | m |
//! | `mc<i>x`, `mc<i>y`, `mc<i>z` | first moment m·c | kg·m |
//! | `J<i>xx`, `J<i>xy`, `J<i>xz`, `J<i>yy`, `J<i>yz`, `J<i>zz` | inertia about the frame-i origin | kg·m² |
//!
//! so `c7y*m7 + cLy*mL` is read as the first moments `mc7y + mcLy`. Products of two parameters
//! other than `c<i>·m<i>` are rejected, as are constant terms.

use std::collections::BTreeMap;

/// Index of a parameter inside one body's 10-vector (m, mcx, mcy, mcz, Jxx, Jxy, Jxz, Jyy, Jyz, Jzz).
pub type ParamSlot = usize;

/// Names of the 10 slots of a body's parameter vector, in `InertialParameters::to_vector` order.
pub const SLOT_NAMES: [&str; 10] = [
    "m", "mcx", "mcy", "mcz", "Jxx", "Jxy", "Jxz", "Jyy", "Jyz", "Jzz",
];

/// A body referenced by an expression: a robot link (0-based) or the payload.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Body {
    /// Robot link, 0-based (written 1-based in the file).
    Link(usize),
    /// The payload (written `L`).
    Payload,
}

/// A linear form: coefficient per (body, slot); units depend on the expression.
pub type LinearForm = BTreeMap<(Body, ParamSlot), f64>;

/// Parse error with a message (the caller adds the line number).
#[derive(Debug, Clone, PartialEq)]
pub struct ExprError(pub String);

#[derive(Debug, Clone)]
enum Value {
    Const(f64),
    Linear(LinearForm),
    /// k · c_{body,axis}: a CoM coordinate waiting to be multiplied by the body's mass.
    Com(Body, usize, f64),
}

#[derive(Debug, Clone, PartialEq)]
enum Token {
    Num(f64),
    Ident(String),
    Op(char),
}

fn tokenize(text: &str) -> Result<Vec<Token>, ExprError> {
    let chars: Vec<char> = text.chars().collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i < chars.len() {
        let ch = chars[i];
        if ch.is_whitespace() {
            i += 1;
        } else if ch.is_ascii_digit() || ch == '.' {
            let start = i;
            while i < chars.len() && (chars[i].is_ascii_digit() || chars[i] == '.') {
                i += 1;
            }
            // exponent: 1e-3, 2.5E+4
            if i < chars.len() && (chars[i] == 'e' || chars[i] == 'E') {
                let mut j = i + 1;
                if j < chars.len() && (chars[j] == '+' || chars[j] == '-') {
                    j += 1;
                }
                if j < chars.len() && chars[j].is_ascii_digit() {
                    i = j;
                    while i < chars.len() && chars[i].is_ascii_digit() {
                        i += 1;
                    }
                }
            }
            let s: String = chars[start..i].iter().collect();
            let v = s
                .parse::<f64>()
                .map_err(|_| ExprError(format!("bad number `{s}`")))?;
            out.push(Token::Num(v));
        } else if ch.is_ascii_alphabetic() || ch == '_' {
            let start = i;
            while i < chars.len() && (chars[i].is_ascii_alphanumeric() || chars[i] == '_') {
                i += 1;
            }
            out.push(Token::Ident(chars[start..i].iter().collect()));
        } else if "+-*/^()".contains(ch) {
            out.push(Token::Op(ch));
            i += 1;
        } else {
            return Err(ExprError(format!("unexpected character `{ch}`")));
        }
    }
    Ok(out)
}

fn axis_index(c: char) -> Option<usize> {
    match c {
        'x' => Some(0),
        'y' => Some(1),
        'z' => Some(2),
        _ => None,
    }
}

/// Splits `7y`/`Ly` style suffixes into (body, rest).
fn body_prefix(s: &str, links: usize) -> Option<(Body, &str)> {
    if let Some(rest) = s.strip_prefix('L') {
        return Some((Body::Payload, rest));
    }
    let digits = s.chars().take_while(|c| c.is_ascii_digit()).count();
    if digits == 0 {
        return None;
    }
    let idx: usize = s[..digits].parse().ok()?;
    if idx == 0 || idx > links {
        return None;
    }
    Some((Body::Link(idx - 1), &s[digits..]))
}

/// What a parameter symbol means, if `name` is one (None for constants/unknown names).
fn parse_symbol(name: &str, links: usize) -> Option<Value> {
    let one = |body, slot| {
        let mut f = LinearForm::new();
        f.insert((body, slot), 1.0);
        Some(Value::Linear(f))
    };
    if let Some(rest) = name.strip_prefix("mc") {
        let (body, axis) = body_prefix(rest, links)?;
        let mut it = axis.chars();
        let a = axis_index(it.next()?)?;
        return if it.next().is_none() {
            one(body, 1 + a)
        } else {
            None
        };
    }
    if let Some(rest) = name.strip_prefix('m') {
        let (body, tail) = body_prefix(rest, links)?;
        return if tail.is_empty() { one(body, 0) } else { None };
    }
    if let Some(rest) = name.strip_prefix('c') {
        let (body, axis) = body_prefix(rest, links)?;
        let mut it = axis.chars();
        let a = axis_index(it.next()?)?;
        return if it.next().is_none() {
            Some(Value::Com(body, a, 1.0))
        } else {
            None
        };
    }
    if let Some(rest) = name.strip_prefix('J') {
        let (body, axes) = body_prefix(rest, links)?;
        let mut it = axes.chars();
        let a = axis_index(it.next()?)?;
        let b = axis_index(it.next()?)?;
        if it.next().is_some() {
            return None;
        }
        let (lo, hi) = if a <= b { (a, b) } else { (b, a) };
        let slot = match (lo, hi) {
            (0, 0) => 4,
            (0, 1) => 5,
            (0, 2) => 6,
            (1, 1) => 7,
            (1, 2) => 8,
            _ => 9,
        };
        return one(body, slot);
    }
    None
}

/// True when `name` would be read as a parameter symbol (so it cannot name a constant).
pub fn is_parameter_symbol(name: &str, links: usize) -> bool {
    parse_symbol(name, links).is_some()
}

/// Deepest nesting of parentheses, signs and powers accepted: real coefficient expressions
/// need a handful, and the recursive-descent parser must not exhaust the stack on a damaged file.
pub const MAX_NESTING: usize = 64;

struct Parser<'a> {
    tokens: Vec<Token>,
    pos: usize,
    /// Current recursion depth of `unary` (every nesting path passes through it).
    depth: usize,
    links: usize,
    constants: &'a BTreeMap<String, f64>,
}

impl Parser<'_> {
    fn peek(&self) -> Option<&Token> {
        self.tokens.get(self.pos)
    }

    fn expr(&mut self) -> Result<Value, ExprError> {
        let mut acc = self.term()?;
        while let Some(Token::Op(op @ ('+' | '-'))) = self.peek().cloned() {
            self.pos += 1;
            let rhs = self.term()?;
            acc = add(acc, rhs, if op == '-' { -1.0 } else { 1.0 })?;
        }
        Ok(acc)
    }

    fn term(&mut self) -> Result<Value, ExprError> {
        let mut acc = self.unary()?;
        while let Some(Token::Op(op @ ('*' | '/'))) = self.peek().cloned() {
            self.pos += 1;
            let rhs = self.unary()?;
            acc = if op == '*' {
                mul(acc, rhs)?
            } else {
                match rhs {
                    Value::Const(d) if d != 0.0 => scale(acc, 1.0 / d),
                    Value::Const(_) => return Err(ExprError("division by zero".into())),
                    _ => return Err(ExprError("can only divide by a constant".into())),
                }
            };
        }
        Ok(acc)
    }

    fn unary(&mut self) -> Result<Value, ExprError> {
        if self.depth >= MAX_NESTING {
            return Err(ExprError(format!(
                "expression nested deeper than {MAX_NESTING} levels (parentheses, signs or powers)"
            )));
        }
        self.depth += 1;
        let v = self.unary_inner();
        self.depth -= 1;
        v
    }

    fn unary_inner(&mut self) -> Result<Value, ExprError> {
        match self.peek() {
            Some(Token::Op('-')) => {
                self.pos += 1;
                Ok(scale(self.unary()?, -1.0))
            }
            Some(Token::Op('+')) => {
                self.pos += 1;
                self.unary()
            }
            _ => self.power(),
        }
    }

    fn power(&mut self) -> Result<Value, ExprError> {
        let base = self.atom()?;
        if let Some(Token::Op('^')) = self.peek() {
            self.pos += 1;
            let exp = self.unary()?;
            return match (base, exp) {
                (Value::Const(b), Value::Const(e)) => Ok(Value::Const(b.powf(e))),
                _ => Err(ExprError("`^` is only allowed between constants".into())),
            };
        }
        Ok(base)
    }

    fn atom(&mut self) -> Result<Value, ExprError> {
        let tok = self.peek().cloned();
        self.pos += 1;
        match tok {
            Some(Token::Num(v)) => Ok(Value::Const(v)),
            Some(Token::Ident(name)) => {
                if let Some(v) = parse_symbol(&name, self.links) {
                    Ok(v)
                } else if let Some(c) = self.constants.get(&name) {
                    Ok(Value::Const(*c))
                } else {
                    Err(ExprError(format!(
                        "unknown name `{name}` (not a constant and not a parameter of links 1..{} or the payload L)",
                        self.links
                    )))
                }
            }
            Some(Token::Op('(')) => {
                let v = self.expr()?;
                match self.peek() {
                    Some(Token::Op(')')) => {
                        self.pos += 1;
                        Ok(v)
                    }
                    _ => Err(ExprError("missing `)`".into())),
                }
            }
            Some(Token::Op(c)) => Err(ExprError(format!("unexpected `{c}`"))),
            None => Err(ExprError("unexpected end of expression".into())),
        }
    }
}

fn scale(v: Value, k: f64) -> Value {
    match v {
        Value::Const(c) => Value::Const(c * k),
        Value::Linear(mut f) => {
            f.values_mut().for_each(|x| *x *= k);
            Value::Linear(f)
        }
        Value::Com(b, a, c) => Value::Com(b, a, c * k),
    }
}

fn add(lhs: Value, rhs: Value, sign: f64) -> Result<Value, ExprError> {
    match (lhs, rhs) {
        (Value::Const(a), Value::Const(b)) => Ok(Value::Const(a + sign * b)),
        (Value::Linear(mut a), Value::Linear(b)) => {
            for (k, v) in b {
                *a.entry(k).or_insert(0.0) += sign * v;
            }
            Ok(Value::Linear(a))
        }
        (Value::Com(..), _) | (_, Value::Com(..)) => Err(ExprError(
            "a CoM coordinate c<i><axis> must be multiplied by the same body's mass m<i>".into(),
        )),
        _ => Err(ExprError("constant term added to a parameter term: coefficients must be linear and homogeneous in the parameters".into())),
    }
}

fn mul(lhs: Value, rhs: Value) -> Result<Value, ExprError> {
    match (lhs, rhs) {
        (Value::Const(a), v) | (v, Value::Const(a)) => Ok(scale(v, a)),
        (Value::Com(body, axis, k), Value::Linear(f))
        | (Value::Linear(f), Value::Com(body, axis, k)) => {
            // c_b,axis · (λ m_b)  →  λ k mc_b,axis
            let mut it = f.iter();
            match (it.next(), it.next()) {
                (Some((&(b, 0), &lambda)), None) if b == body => {
                    let mut out = LinearForm::new();
                    out.insert((body, 1 + axis), k * lambda);
                    Ok(Value::Linear(out))
                }
                _ => Err(ExprError(
                    "a CoM coordinate c<i><axis> can only multiply the same body's mass m<i>"
                        .into(),
                )),
            }
        }
        _ => Err(ExprError(
            "product of two parameters: coefficients must be linear in the parameters".into(),
        )),
    }
}

/// Evaluates a constant expression (numbers and previously defined constants only).
pub fn parse_constant(text: &str, constants: &BTreeMap<String, f64>) -> Result<f64, ExprError> {
    match parse_value(text, 0, constants)? {
        Value::Const(c) => Ok(c),
        _ => Err(ExprError("a constant must not contain parameters".into())),
    }
}

/// Parses a coefficient expression into its linear form over the parameters of `links` links
/// and the payload.
pub fn parse_linear(
    text: &str,
    links: usize,
    constants: &BTreeMap<String, f64>,
) -> Result<LinearForm, ExprError> {
    match parse_value(text, links, constants)? {
        Value::Linear(mut f) => {
            f.retain(|_, v| *v != 0.0);
            if f.is_empty() {
                return Err(ExprError("the expression is identically zero".into()));
            }
            Ok(f)
        }
        Value::Const(_) => Err(ExprError("the expression contains no parameter".into())),
        Value::Com(..) => Err(ExprError(
            "a CoM coordinate c<i><axis> must be multiplied by the same body's mass m<i>".into(),
        )),
    }
}

fn parse_value(
    text: &str,
    links: usize,
    constants: &BTreeMap<String, f64>,
) -> Result<Value, ExprError> {
    let tokens = tokenize(text)?;
    if tokens.is_empty() {
        return Err(ExprError("empty expression".into()));
    }
    let mut p = Parser {
        tokens,
        pos: 0,
        depth: 0,
        links,
        constants,
    };
    let v = p.expr()?;
    if p.pos != p.tokens.len() {
        return Err(ExprError(format!(
            "unexpected trailing input at token {}",
            p.pos + 1
        )));
    }
    let finite = match &v {
        Value::Const(c) | Value::Com(_, _, c) => c.is_finite(),
        Value::Linear(f) => f.values().all(|c| c.is_finite()),
    };
    if !finite {
        return Err(ExprError(
            "the value is not finite (a number out of range or an overflow)".into(),
        ));
    }
    Ok(v)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn consts() -> BTreeMap<String, f64> {
        let mut c = BTreeMap::new();
        c.insert("a2".to_string(), 0.5);
        c
    }

    #[test]
    fn com_times_mass_becomes_first_moment() {
        let f = parse_linear("c7y*m7 + cLy*mL", 7, &BTreeMap::new()).unwrap();
        assert_eq!(f.len(), 2);
        assert_eq!(f[&(Body::Link(6), 2)], 1.0);
        assert_eq!(f[&(Body::Payload, 2)], 1.0);
    }

    #[test]
    fn eq29_first_coefficient() {
        let f = parse_linear("0.5*(m2*a2^2 + J2zz) + a2*c2x*m2", 2, &consts()).unwrap();
        assert_eq!(f[&(Body::Link(1), 0)], 0.125);
        assert_eq!(f[&(Body::Link(1), 9)], 0.5);
        assert_eq!(f[&(Body::Link(1), 1)], 0.5);
        assert_eq!(f.len(), 3);
    }

    #[test]
    fn subtraction_and_division() {
        let f = parse_linear("(c5z*m5 - c6y*m6)/2 - -J6yx", 7, &BTreeMap::new()).unwrap();
        assert_eq!(f[&(Body::Link(4), 3)], 0.5);
        assert_eq!(f[&(Body::Link(5), 2)], -0.5);
        assert_eq!(f[&(Body::Link(5), 5)], 1.0);
    }

    #[test]
    fn rejects_nonlinear_and_bad_input() {
        let c = BTreeMap::new();
        assert!(parse_linear("m1*m2", 2, &c).is_err());
        assert!(parse_linear("c1x*m2", 2, &c).is_err());
        assert!(parse_linear("c1x", 2, &c).is_err());
        assert!(parse_linear("m1 + 1", 2, &c).is_err());
        assert!(parse_linear("m3", 2, &c).is_err());
        assert!(parse_linear("m1 +", 2, &c).is_err());
        assert!(parse_linear("(m1", 2, &c).is_err());
        assert!(parse_linear("m1 $ m2", 2, &c).is_err());
        assert!(parse_linear("m1 - m1", 2, &c).is_err());
        assert!(parse_constant("2^3 * 1e-1", &c).is_ok_and(|v| (v - 0.8).abs() < 1e-15));
    }
}
