//! Arithmetic of SINUMERIK programs: R-parameters (`R1`) and `DEF REAL`/`DEF INT` variables
//! in expressions (`X=R1+2*(R2-5)`, `R3=SIN(30)*R1`), evaluated when the line is read.
//! Angles are in degrees, as the control takes them.

use std::collections::HashMap;

/// The program's variables by name (`R1`, or a `DEF`'s name), upper case.
pub(crate) type Variables = HashMap<String, f64>;

/// Why an expression has no value: the byte offset (in the text given) and the problem.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum ExprError {
    /// A name no `DEF` declared and no R-parameter: a system variable or a typo.
    Unknown(usize, String),
    /// Malformed at this offset.
    Syntax(usize, String),
}

struct Parser<'a> {
    s: &'a [u8],
    text: &'a str,
    i: usize,
    vars: &'a Variables,
}

/// Evaluates the expression at the start of `text` (upper case), stopping at a blank,
/// `;` or an unmatched `)` / `,` outside brackets; its value and the bytes it took.
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

/// Evaluates a condition: comparisons (`==`, `<>`, `<`, `>`, `<=`, `>=`) of expressions,
/// joined by `AND`, `OR` and `NOT`; the whole text must be the condition.
pub(crate) fn condition(text: &str, vars: &Variables) -> Result<bool, ExprError> {
    let text = text.trim();
    if let Some(i) = find_word(text, " OR ") {
        return Ok(condition(&text[..i], vars)? || condition(&text[i + 4..], vars)?);
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
    for op in ["==", "<>", "<=", ">=", "<", ">"] {
        if let Some(i) = text.find(op) {
            let left = value_of(text[..i].trim(), vars)?;
            let right = value_of(text[i + op.len()..].trim(), vars)?;
            return Ok(match op {
                "==" => left == right,
                "<>" => left != right,
                "<=" => left <= right,
                ">=" => left >= right,
                "<" => left < right,
                _ => left > right,
            });
        }
    }
    Ok(value_of(text, vars)? != 0.0)
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

    fn sum(&mut self) -> Result<f64, ExprError> {
        let mut v = self.product()?;
        while let Some(c @ (b'+' | b'-')) = self.peek() {
            self.i += 1;
            let r = self.product()?;
            v = if c == b'+' { v + r } else { v - r };
        }
        Ok(v)
    }

    fn product(&mut self) -> Result<f64, ExprError> {
        let mut v = self.factor()?;
        loop {
            match self.peek() {
                Some(b'*') => {
                    self.i += 1;
                    v *= self.factor()?;
                }
                Some(b'/') => {
                    self.i += 1;
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
                let v = self.sum()?;
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
        self.vars
            .get(name)
            .copied()
            .ok_or_else(|| ExprError::Unknown(start, name.to_string()))
    }

    fn function(&mut self, name: &str, start: usize) -> Result<f64, ExprError> {
        self.i += 1;
        let mut args = vec![self.sum()?];
        while self.peek() == Some(b',') {
            self.i += 1;
            args.push(self.sum()?);
        }
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
        assert!(condition("R9>1", &vars).is_err());
    }
}
