//! Constant bracketed expressions (`R[0.7071/4]`, `X[2*SIN[30]]`), evaluated while lexing.
//!
//! RS274/NGC's expression grammar without parameters: numbers, nested brackets, unary
//! functions (`ABS ACOS ASIN COS EXP FIX FUP ROUND LN SIN SQRT TAN`, angles in degrees),
//! `ATAN[y]/[x]`, and binary operators in five precedence levels (highest first):
//! `**`; `* / MOD`; `+ -`; `EQ NE GT GE LT LE`; `AND OR XOR`. Operators of one level
//! associate to the left. A parameter (`#`) anywhere is refused.

use nom::{IResult, Parser, bytes::complete::tag_no_case};

use super::error::GcodeErrorKind;
use super::lexer::number_lexeme;

/// An expression error with its byte offset relative to where the value started.
#[derive(Debug, Clone, PartialEq)]
pub struct ExprError {
    /// Byte offset from the start of the value.
    pub offset: usize,
    /// The problem.
    pub kind: GcodeErrorKind,
}

/// Nesting deeper than this is refused (it also bounds the recursion on hostile input).
const MAX_DEPTH: usize = 64;

const UNARY_FUNCTIONS: [&str; 12] = [
    "ABS", "ACOS", "ASIN", "COS", "EXP", "FIX", "FUP", "ROUND", "LN", "SIN", "SQRT", "TAN",
];

/// Parses a value that starts with an optional sign followed by `[` or a function name.
/// Returns `Ok(None)` when `s` does not start with one (so the caller can report a missing
/// value), and the remaining input with the value otherwise.
pub(crate) fn signed_expression(s: &str) -> Result<Option<(&str, f64)>, ExprError> {
    let mut p = ExprParser { start: s, depth: 0 };
    let (body, negative) = match s.as_bytes().first() {
        Some(b'-') => (&s[1..], true),
        Some(b'+') => (&s[1..], false),
        _ => (s, false),
    };
    let body = body.trim_start_matches([' ', '\t']);
    if !(body.starts_with('[') || starts_with_function(body)) {
        return Ok(None);
    }
    let (rest, v) = p.atom(body)?;
    Ok(Some((rest, if negative { -v } else { v })))
}

fn starts_with_function(s: &str) -> bool {
    let upper: String = s.chars().take(5).collect::<String>().to_ascii_uppercase();
    UNARY_FUNCTIONS.iter().any(|f| upper.starts_with(f)) || upper.starts_with("ATAN")
}

struct ExprParser<'a> {
    start: &'a str,
    depth: usize,
}

type PResult<'a> = Result<(&'a str, f64), ExprError>;

impl<'a> ExprParser<'a> {
    fn err(&self, at: &str, msg: impl Into<String>) -> ExprError {
        ExprError {
            offset: self.start.len() - at.len(),
            kind: GcodeErrorKind::Expression(msg.into()),
        }
    }

    fn blanks(s: &str) -> &str {
        s.trim_start_matches([' ', '\t'])
    }

    /// `[` binary-expression `]`
    fn bracketed(&mut self, s: &'a str) -> PResult<'a> {
        let Some(inner) = s.strip_prefix('[') else {
            return Err(self.err(s, "expected '['"));
        };
        self.depth += 1;
        if self.depth > MAX_DEPTH {
            return Err(self.err(s, "expression nested too deeply"));
        }
        let (rest, v) = self.binary(inner, 0)?;
        let rest = Self::blanks(rest);
        self.depth -= 1;
        match rest.strip_prefix(']') {
            Some(r) => Ok((r, v)),
            None => Err(self.err(rest, "expected ']' or an operator")),
        }
    }

    /// Precedence climbing over the five operator levels.
    fn binary(&mut self, s: &'a str, min_level: u8) -> PResult<'a> {
        let (mut rest, mut lhs) = self.operand(s)?;
        loop {
            let r = Self::blanks(rest);
            let Some((after_op, op)) = binary_operator(r) else {
                return Ok((rest, lhs));
            };
            let level = op.level();
            if level < min_level {
                return Ok((rest, lhs));
            }
            let (after_rhs, rhs) = self.binary(after_op, level + 1)?;
            lhs = op.apply(lhs, rhs).map_err(|m| self.err(r, m))?;
            rest = after_rhs;
        }
    }

    /// An operand inside brackets: a number, a nested expression, a function, or a sign
    /// applied to one of those.
    fn operand(&mut self, s: &'a str) -> PResult<'a> {
        let mut s = Self::blanks(s);
        if let Ok((rest, lexeme)) = number_lexeme(s) {
            let v = lexeme
                .parse::<f64>()
                .map_err(|_| self.err(s, "malformed number"))?;
            return Ok((rest, v));
        }
        // Signs in front of a bracket or function; a loop, so a long run of them cannot
        // exhaust the stack.
        let mut negative = false;
        while let Some(r) = s.strip_prefix(['-', '+']) {
            negative ^= s.starts_with('-');
            s = Self::blanks(r);
        }
        let (rest, v) = self.operand_unsigned(s)?;
        Ok((rest, if negative { -v } else { v }))
    }

    fn operand_unsigned(&mut self, s: &'a str) -> PResult<'a> {
        if let Ok((rest, lexeme)) = number_lexeme(s) {
            let v = lexeme
                .parse::<f64>()
                .map_err(|_| self.err(s, "malformed number"))?;
            return Ok((rest, v));
        }
        if s.starts_with('#') {
            return Err(ExprError {
                offset: self.start.len() - s.len(),
                kind: GcodeErrorKind::Unsupported {
                    word: "#".into(),
                    reason: "parameters are not supported: the path must be explicit",
                },
            });
        }
        self.atom(s)
    }

    /// A bracketed expression or a function call.
    fn atom(&mut self, s: &'a str) -> PResult<'a> {
        if s.starts_with('[') {
            return self.bracketed(s);
        }
        let atan: IResult<&str, &str> = tag_no_case("ATAN").parse(s);
        if let Ok((r, _)) = atan {
            let (r, y) = self.bracketed(Self::blanks(r))?;
            let r = Self::blanks(r);
            let Some(r) = r.strip_prefix('/') else {
                return Err(self.err(r, "ATAN needs two arguments: ATAN[y]/[x]"));
            };
            let (r, x) = self.bracketed(Self::blanks(r))?;
            return Ok((r, y.atan2(x).to_degrees()));
        }
        for name in UNARY_FUNCTIONS {
            let f: IResult<&str, &str> = tag_no_case(name).parse(s);
            if let Ok((r, _)) = f {
                let (r, arg) = self.bracketed(Self::blanks(r))?;
                let v = apply_function(name, arg).map_err(|m| self.err(s, m))?;
                return Ok((r, v));
            }
        }
        Err(self.err(s, "expected a number, '[' or a function"))
    }
}

fn apply_function(name: &str, x: f64) -> Result<f64, String> {
    let v = match name {
        "ABS" => x.abs(),
        "ACOS" if (-1.0..=1.0).contains(&x) => x.acos().to_degrees(),
        "ASIN" if (-1.0..=1.0).contains(&x) => x.asin().to_degrees(),
        "COS" => x.to_radians().cos(),
        "EXP" => x.exp(),
        "FIX" => x.floor(),
        "FUP" => x.ceil(),
        "ROUND" => x.round(),
        "LN" if x > 0.0 => x.ln(),
        "SIN" => x.to_radians().sin(),
        "SQRT" if x >= 0.0 => x.sqrt(),
        "TAN" => x.to_radians().tan(),
        _ => return Err(format!("{name}[{x}] is undefined")),
    };
    if v.is_finite() {
        Ok(v)
    } else {
        Err(format!("{name}[{x}] is not finite"))
    }
}

#[derive(Clone, Copy)]
enum BinOp {
    Pow,
    Mul,
    Div,
    Mod,
    Add,
    Sub,
    Eq,
    Ne,
    Gt,
    Ge,
    Lt,
    Le,
    And,
    Or,
    Xor,
}

impl BinOp {
    /// Higher binds tighter.
    fn level(self) -> u8 {
        match self {
            BinOp::Pow => 4,
            BinOp::Mul | BinOp::Div | BinOp::Mod => 3,
            BinOp::Add | BinOp::Sub => 2,
            BinOp::Eq | BinOp::Ne | BinOp::Gt | BinOp::Ge | BinOp::Lt | BinOp::Le => 1,
            BinOp::And | BinOp::Or | BinOp::Xor => 0,
        }
    }

    fn apply(self, a: f64, b: f64) -> Result<f64, String> {
        let truth = |c: bool| if c { 1.0 } else { 0.0 };
        let v = match self {
            BinOp::Pow => a.powf(b),
            BinOp::Mul => a * b,
            BinOp::Div if b == 0.0 => return Err("division by zero".into()),
            BinOp::Div => a / b,
            BinOp::Mod if b == 0.0 => return Err("MOD by zero".into()),
            BinOp::Mod => a.rem_euclid(b),
            BinOp::Add => a + b,
            BinOp::Sub => a - b,
            BinOp::Eq => truth(a == b),
            BinOp::Ne => truth(a != b),
            BinOp::Gt => truth(a > b),
            BinOp::Ge => truth(a >= b),
            BinOp::Lt => truth(a < b),
            BinOp::Le => truth(a <= b),
            BinOp::And => truth(a != 0.0 && b != 0.0),
            BinOp::Or => truth(a != 0.0 || b != 0.0),
            BinOp::Xor => truth((a != 0.0) != (b != 0.0)),
        };
        if v.is_finite() {
            Ok(v)
        } else {
            Err("result is not finite".into())
        }
    }
}

fn binary_operator(s: &str) -> Option<(&str, BinOp)> {
    const SYMBOLS: [(&str, BinOp); 5] = [
        ("**", BinOp::Pow),
        ("*", BinOp::Mul),
        ("/", BinOp::Div),
        ("+", BinOp::Add),
        ("-", BinOp::Sub),
    ];
    const WORDS: [(&str, BinOp); 10] = [
        ("MOD", BinOp::Mod),
        ("EQ", BinOp::Eq),
        ("NE", BinOp::Ne),
        ("GT", BinOp::Gt),
        ("GE", BinOp::Ge),
        ("LT", BinOp::Lt),
        ("LE", BinOp::Le),
        ("AND", BinOp::And),
        ("OR", BinOp::Or),
        ("XOR", BinOp::Xor),
    ];
    for (sym, op) in SYMBOLS {
        if let Some(r) = s.strip_prefix(sym) {
            return Some((r, op));
        }
    }
    for (word, op) in WORDS {
        let found: IResult<&str, &str> = tag_no_case(word).parse(s);
        if let Ok((r, _)) = found {
            return Some((r, op));
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    fn eval(s: &str) -> f64 {
        signed_expression(s).unwrap().unwrap().1
    }

    #[test]
    fn precedence_and_associativity() {
        assert_eq!(eval("[1+2*3]"), 7.0);
        assert_eq!(eval("[2**3**2]"), 64.0, "left associative like LinuxCNC");
        assert_eq!(eval("[10-4-3]"), 3.0);
        assert_eq!(eval("[7 MOD 4]"), 3.0);
        assert_eq!(eval("[1 LT 2 AND 3 GT 2]"), 1.0);
    }

    #[test]
    fn functions_in_degrees() {
        assert!((eval("SIN[30]") - 0.5).abs() < 1e-15);
        assert!((eval("ATAN[1]/[1]") - 45.0).abs() < 1e-12);
        assert_eq!(eval("-[2*ABS[-3]]"), -6.0);
    }

    #[test]
    fn errors_are_reported_not_panicked() {
        assert!(signed_expression("[1/0]").is_err());
        assert!(signed_expression("[1+#2]").is_err());
        assert!(signed_expression("[1+2").is_err());
        assert!(signed_expression(&"[".repeat(10_000)).is_err());
        assert_eq!(signed_expression("X").unwrap(), None);
    }
}
