//! Arithmetic of SINUMERIK programs: R-parameters (`R1`) and `DEF REAL`/`DEF INT` variables
//! in expressions (`X=R1+2*(R2-5)`, `R3=SIN(30)*R1`), evaluated when the line is read.
//! Angles are in degrees, as the control takes them.

use std::collections::HashMap;

/// The program's variables by name (`R1`, or a `DEF`'s name), upper case.
pub(crate) type Variables = HashMap<String, f64>;

/// An evaluator: a value at the start of a text, and the bytes it took.
pub(crate) type Evaluator = fn(&str, &Variables) -> Result<(f64, usize), ExprError>;

/// Why an expression has no value: the byte offset (in the text given) and the problem.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum ExprError {
    /// A name no `DEF` declared and no R-parameter: a system variable or a typo.
    Unknown(usize, String),
    /// Malformed at this offset.
    Syntax(usize, String),
}

impl ExprError {
    /// The same error, its offset counted from `by` bytes earlier.
    fn shifted(self, by: usize) -> ExprError {
        match self {
            ExprError::Unknown(at, name) => ExprError::Unknown(at + by, name),
            ExprError::Syntax(at, problem) => ExprError::Syntax(at + by, problem),
        }
    }
}

struct Parser<'a> {
    s: &'a [u8],
    text: &'a str,
    i: usize,
    vars: &'a Variables,
}

/// Evaluates the expression at the start of `text` (upper case), stopping at a blank (but
/// for blanks around an operator), `;` or an unmatched `)` / `,` outside brackets; its value
/// and the bytes it took.
pub(crate) fn evaluate(text: &str, vars: &Variables) -> Result<(f64, usize), ExprError> {
    let mut p = Parser {
        s: text.as_bytes(),
        text,
        i: 0,
        vars,
    };
    let v = p.sum()?;
    if !v.is_finite() {
        return Err(ExprError::Syntax(
            0,
            "the value is not a finite number".into(),
        ));
    }
    Ok((v, p.i))
}

/// [`evaluate`] for the value of an assignment, which may be a comparison (`R11=R10>=100`:
/// 1 where it holds, else 0).
pub(crate) fn evaluate_assigned(text: &str, vars: &Variables) -> Result<(f64, usize), ExprError> {
    let (left, n) = evaluate(text, vars)?;
    let rest = &text[n..];
    let blanks = rest.len() - rest.trim_start_matches([' ', '\t']).len();
    let after = &rest[blanks..];
    let Some(op) = COMPARISONS.into_iter().find(|op| after.starts_with(op)) else {
        return Ok((left, n));
    };
    let mut at = n + blanks + op.len();
    at += text[at..].len() - text[at..].trim_start_matches([' ', '\t']).len();
    let (right, m) = evaluate(&text[at..], vars).map_err(|e| e.shifted(at))?;
    Ok((f64::from(u8::from(compare(op, left, right))), at + m))
}

/// Evaluates a condition: comparisons (`==`, `<>`, `<`, `>`, `<=`, `>=`) of expressions,
/// joined by `AND`, `OR` and `NOT`; the whole text must be the condition.
pub(crate) fn condition(text: &str, vars: &Variables) -> Result<bool, ExprError> {
    let text = text.trim();
    if let Some(i) = find_word(text, " OR ") {
        return Ok(condition(&text[..i], vars)? || condition(&text[i + 4..], vars)?);
    }
    if let Some(i) = find_word(text, " XOR ") {
        return Ok(condition(&text[..i], vars)? != condition(&text[i + 5..], vars)?);
    }
    if let Some(i) = find_word(text, " AND ") {
        return Ok(condition(&text[..i], vars)? && condition(&text[i + 5..], vars)?);
    }
    if let Some(rest) = text.strip_prefix("NOT ") {
        return Ok(!condition(rest, vars)?);
    }
    if text.starts_with('(')
        && text.ends_with(')')
        && find_word(text, " ").is_none()
        && let Ok(v) = condition(&text[1..text.len() - 1], vars)
    {
        return Ok(v);
    }
    for op in COMPARISONS {
        if let Some(i) = text.find(op) {
            let left = value_of(text[..i].trim(), vars)?;
            let right = value_of(text[i + op.len()..].trim(), vars)?;
            return Ok(compare(op, left, right));
        }
    }
    Ok(value_of(text, vars)? != 0.0)
}

/// The comparison operators, the two-character ones first (so that `<=` is not read as `<`).
const COMPARISONS: [&str; 6] = ["==", "<>", "<=", ">=", "<", ">"];

/// The comparison `op` (one of [`COMPARISONS`]) of two values.
fn compare(op: &str, left: f64, right: f64) -> bool {
    match op {
        "==" => left == right,
        "<>" => left != right,
        "<=" => left <= right,
        ">=" => left >= right,
        "<" => left < right,
        _ => left > right,
    }
}

/// The whole of `text` as one expression's value.
fn value_of(text: &str, vars: &Variables) -> Result<f64, ExprError> {
    let compact: String = text.chars().filter(|c| !c.is_whitespace()).collect();
    let (v, n) = evaluate(&compact, vars)?;
    if n != compact.len() {
        return Err(ExprError::Syntax(
            n,
            format!("'{}' is not part of the value", &compact[n..]),
        ));
    }
    Ok(v)
}

/// Where `word` stands in `text` outside brackets.
fn find_word(text: &str, word: &str) -> Option<usize> {
    let mut depth = 0i32;
    for (i, c) in text.char_indices() {
        match c {
            '(' | '[' => depth += 1,
            ')' | ']' => depth -= 1,
            _ if depth == 0 && text[i..].starts_with(word) => return Some(i),
            _ => {}
        }
    }
    None
}

impl Parser<'_> {
    fn peek(&self) -> Option<u8> {
        self.s.get(self.i).copied()
    }

    /// The next character after blanks when it is one of `ops`, the blanks then passed
    /// over: blanks may stand around an operator (`A + B`), while a blank before anything
    /// else ends the value (`X=A Y=B`).
    fn operator(&mut self, ops: &[u8]) -> Option<u8> {
        let mut j = self.i;
        while matches!(self.s.get(j), Some(b' ' | b'\t')) {
            j += 1;
        }
        let c = *self.s.get(j)?;
        ops.contains(&c).then(|| {
            self.i = j;
            c
        })
    }

    /// `DIV`, `MOD` or a bit-by-bit `B_AND`, `B_OR`, `B_XOR` between blanks, passed over
    /// with them.
    fn word_operator(&mut self) -> Option<&'static str> {
        let mut j = self.i;
        while matches!(self.s.get(j), Some(b' ' | b'\t')) {
            j += 1;
        }
        let word = ["DIV", "MOD", "B_AND", "B_OR", "B_XOR"]
            .into_iter()
            .find(|w| self.text[j..].starts_with(w))?;
        let after = j + word.len();
        if j == self.i || !matches!(self.s.get(after), Some(b' ' | b'\t' | b'(')) {
            return None;
        }
        self.i = after;
        self.skip_blanks();
        Some(word)
    }

    fn skip_blanks(&mut self) {
        while matches!(self.peek(), Some(b' ' | b'\t')) {
            self.i += 1;
        }
    }

    fn sum(&mut self) -> Result<f64, ExprError> {
        let mut v = self.product()?;
        while let Some(c) = self.operator(b"+-") {
            self.i += 1;
            self.skip_blanks();
            let r = self.product()?;
            v = if c == b'+' { v + r } else { v - r };
        }
        Ok(v)
    }

    fn product(&mut self) -> Result<f64, ExprError> {
        let mut v = self.factor()?;
        loop {
            if let Some(word) = self.word_operator() {
                let d = self.factor()?;
                if d == 0.0 && matches!(word, "DIV" | "MOD") {
                    return Err(ExprError::Syntax(self.i, "division by zero".into()));
                }
                // DIV: the integer quotient; MOD: the remainder, with the dividend's sign;
                // the bit-by-bit operators on the values as whole numbers.
                let bits = |f: fn(i64, i64) -> i64| f(v.round() as i64, d.round() as i64) as f64;
                v = match word {
                    "DIV" => (v / d).trunc(),
                    "MOD" => v % d,
                    "B_AND" => bits(|a, b| a & b),
                    "B_OR" => bits(|a, b| a | b),
                    _ => bits(|a, b| a ^ b),
                };
                continue;
            }
            match self.operator(b"*/") {
                Some(b'*') => {
                    self.i += 1;
                    self.skip_blanks();
                    v *= self.factor()?;
                }
                Some(_) => {
                    self.i += 1;
                    self.skip_blanks();
                    let d = self.factor()?;
                    if d == 0.0 {
                        return Err(ExprError::Syntax(self.i, "division by zero".into()));
                    }
                    v /= d;
                }
                _ => return Ok(v),
            }
        }
    }

    fn factor(&mut self) -> Result<f64, ExprError> {
        match self.peek() {
            Some(b'-') => {
                self.i += 1;
                Ok(-self.factor()?)
            }
            Some(b'+') => {
                self.i += 1;
                self.factor()
            }
            Some(b'(') => {
                self.i += 1;
                self.skip_blanks();
                let v = self.sum()?;
                self.skip_blanks();
                self.expect(b')')?;
                Ok(v)
            }
            Some(c) if c.is_ascii_digit() || c == b'.' => self.number(),
            Some(c) if c.is_ascii_alphabetic() || c == b'_' || c == b'$' => self.name(),
            _ => Err(ExprError::Syntax(self.i, "a value is missing".into())),
        }
    }

    fn expect(&mut self, c: u8) -> Result<(), ExprError> {
        if self.peek() == Some(c) {
            self.i += 1;
            Ok(())
        } else {
            Err(ExprError::Syntax(
                self.i,
                format!("'{}' expected", c as char),
            ))
        }
    }

    fn number(&mut self) -> Result<f64, ExprError> {
        let start = self.i;
        while matches!(self.peek(), Some(c) if c.is_ascii_digit() || c == b'.') {
            self.i += 1;
        }
        // An exponent, `1.5EX3`, as the 840D writes it.
        if self.text[self.i..].starts_with("EX") {
            self.i += 2;
            if matches!(self.peek(), Some(b'+' | b'-')) {
                self.i += 1;
            }
            while matches!(self.peek(), Some(c) if c.is_ascii_digit()) {
                self.i += 1;
            }
            let t = self.text[start..self.i].replacen("EX", "E", 1);
            return t
                .parse()
                .map_err(|_| ExprError::Syntax(start, format!("'{t}' is not a number")));
        }
        let t = &self.text[start..self.i];
        t.parse()
            .map_err(|_| ExprError::Syntax(start, format!("'{t}' is not a number")))
    }

    fn name(&mut self) -> Result<f64, ExprError> {
        let start = self.i;
        while matches!(self.peek(), Some(c) if c.is_ascii_alphanumeric() || c == b'_' || c == b'$')
        {
            self.i += 1;
        }
        let name = &self.text[start..self.i];
        if self.peek() == Some(b'(') {
            return self.function(name, start);
        }
        match name {
            "TRUE" => return Ok(1.0),
            "FALSE" => return Ok(0.0),
            _ => {}
        }
        self.vars
            .get(name)
            .copied()
            .ok_or_else(|| ExprError::Unknown(start, name.to_string()))
    }

    fn function(&mut self, name: &str, start: usize) -> Result<f64, ExprError> {
        self.i += 1;
        self.skip_blanks();
        let mut args = vec![self.sum()?];
        while self.operator(b",").is_some() {
            self.i += 1;
            self.skip_blanks();
            args.push(self.sum()?);
        }
        self.skip_blanks();
        self.expect(b')')?;
        let one = |f: fn(f64) -> f64| -> Result<f64, ExprError> {
            match args.as_slice() {
                [a] => Ok(f(*a)),
                _ => Err(ExprError::Syntax(start, format!("{name} takes one value"))),
            }
        };
        match name {
            "SIN" => one(|a| a.to_radians().sin()),
            "COS" => one(|a| a.to_radians().cos()),
            "TAN" => one(|a| a.to_radians().tan()),
            "ASIN" => one(|a| a.asin().to_degrees()),
            "ACOS" => one(|a| a.acos().to_degrees()),
            "ATAN2" => match args.as_slice() {
                [y, x] => Ok(y.atan2(*x).to_degrees()),
                _ => Err(ExprError::Syntax(start, "ATAN2 takes two values".into())),
            },
            "SQRT" => one(f64::sqrt),
            "ABS" => one(f64::abs),
            "POT" => one(|a| a * a),
            "TRUNC" => one(f64::trunc),
            "ROUND" => one(f64::round),
            "LN" => one(f64::ln),
            "EXP" => one(f64::exp),
            _ => Err(ExprError::Unknown(start, name.to_string())),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arithmetic_with_parameters_and_functions() {
        let mut vars = Variables::new();
        vars.insert("R1".into(), 10.0);
        vars.insert("_LEN".into(), 4.0);
        let eval = |t: &str| evaluate(t, &vars).map(|v| v.0);
        assert_eq!(eval("R1+2*(_LEN-1)"), Ok(16.0));
        assert_eq!(eval("-R1/4"), Ok(-2.5));
        assert!((eval("SIN(30)*R1").unwrap() - 5.0).abs() < 1e-12);
        assert!((eval("ATAN2(1,1)").unwrap() - 45.0).abs() < 1e-12);
        assert_eq!(eval("1.5EX3"), Ok(1500.0));
        assert_eq!(evaluate("R1 X5", &vars), Ok((10.0, 2)));
        // Blanks around operators and inside brackets belong to the value; before a word
        // they end it.
        assert_eq!(evaluate("R1 + 2 * ( _LEN - 1 ) X5", &vars), Ok((16.0, 21)));
        assert_eq!(evaluate("ATAN2( 1 , 1 )", &vars), Ok((45.0, 14)));
        assert_eq!(evaluate("R1 _LEN=2", &vars), Ok((10.0, 2)));
        assert_eq!(evaluate_assigned("R1 >= 100", &vars), Ok((0.0, 9)));
        assert_eq!(evaluate_assigned("R1==10 X5", &vars), Ok((1.0, 6)));
        assert_eq!(eval("6 B_AND 3"), Ok(2.0));
        assert_eq!(eval("6 B_OR 3"), Ok(7.0));
        assert_eq!(eval("6 B_XOR 3"), Ok(5.0));
        assert_eq!(eval("7 DIV 3"), Ok(2.0));
        assert_eq!(eval("2+6 DIV 4"), Ok(3.0));
        assert_eq!(eval("-7 MOD 3"), Ok(-1.0));
        assert_eq!(evaluate("R1 DIVX", &vars), Ok((10.0, 2)));
        assert!(matches!(eval("R2+1"), Err(ExprError::Unknown(0, _))));
        assert!(matches!(eval("$P_EP[X]"), Err(ExprError::Unknown(0, _))));
        assert!(matches!(eval("R1/0"), Err(ExprError::Syntax(..))));
        assert!(matches!(eval("(R1"), Err(ExprError::Syntax(..))));
    }

    #[test]
    fn conditions_compare_and_combine() {
        let mut vars = Variables::new();
        vars.insert("R1".into(), 3.0);
        let c = |t: &str| condition(t, &vars).unwrap();
        assert!(c("R1==3"));
        assert!(c("R1 < 5 AND R1 > 2"));
        assert!(!c("R1<>3 OR R1>=4"));
        assert!(c("NOT R1<=2"));
        assert!(c("R1*2 == 6"));
        assert!(c("(R1 == 3) XOR (R1 == 4)"));
        assert!(!c("(R1 == 3) XOR (R1 > 2)"));
        assert!(c("TRUE") && !c("FALSE"));
        assert!(condition("R9>1", &vars).is_err());
    }
}
