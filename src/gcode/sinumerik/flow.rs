//! Program control of SINUMERIK programs: labels and jumps (`GOTOF`, `GOTOB`, `GOTO`,
//! `GOTOC`, `IF … GOTOF …`, `CASE (…) OF … GOTOF …`), and the structured forms
//! `IF`/`ELSE`/`ENDIF`, `WHILE`/`ENDWHILE`, `FOR`/`ENDFOR`, `REPEAT`/`UNTIL` and
//! `LOOP`/`ENDLOOP`. Each control
//! statement stands on a line of its own (after its block number or label), as the 840D
//! writes them; the structure is matched before the program runs, so an `ENDWHILE` without
//! its `WHILE` is an error at its line rather than a surprise half-way through.
//! A statement is run where the program reaches it, against the variables as they stand
//! there ([`Translator::control`]).

use std::collections::HashMap;

use super::super::error::GcodeErrorKind;
use super::Translator;
use super::expr::{ExprError, condition, evaluate};

/// A control statement and what it holds (the text after its keyword, upper case).
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Control {
    /// A jump to a label or a block number, searched forward, backward or both ways
    /// (forward first); `quiet` (`GOTOC`): no error when it is missing.
    Goto {
        target: String,
        way: Way,
        quiet: bool,
    },
    /// `IF cond GOTO… target`.
    IfGoto {
        condition: String,
        target: String,
        way: Way,
    },
    /// `IF cond` opening a block.
    If {
        condition: String,
    },
    Else,
    EndIf,
    While {
        condition: String,
    },
    EndWhile,
    /// `FOR var = from TO to`.
    For {
        var: String,
        from: String,
        to: String,
    },
    EndFor,
    Repeat,
    Until {
        condition: String,
    },
    Loop,
    EndLoop,
    /// `CASE (expr) OF c₁ GOTOF l₁ c₂ GOTOB l₂ … DEFAULT GOTOF l`: the jump of the first
    /// constant equal to the expression's value, else the default's, else on.
    Case {
        expr: String,
        branches: Vec<(String, String, Way)>,
        default: Option<(String, Way)>,
    },
}

/// Where a jump looks for its target.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Way {
    Forward,
    Backward,
    Both,
}

impl Way {
    fn of(word: &str) -> Way {
        match word.trim() {
            "GOTOF" => Way::Forward,
            "GOTOB" => Way::Backward,
            _ => Way::Both,
        }
    }
}

/// A failure: line index, byte offset in the line and the problem.
pub(crate) type FlowError = (usize, usize, GcodeErrorKind);

/// The program's control statements, labels and the statements that pair up.
#[derive(Debug, Default)]
pub(crate) struct Structure {
    controls: HashMap<usize, Control>,
    labels: HashMap<String, Vec<usize>>,
    /// Each opening statement's line to its closing one and back (an `IF` to its `ELSE`,
    /// or its `ENDIF`; an `ELSE` to its `ENDIF`).
    partner: HashMap<usize, usize>,
}

/// The block's content after its `N`/`:` number and label, upper case; its offset.
fn statement(line: &str) -> (String, usize, Option<String>, Option<String>) {
    let upper = line.to_ascii_uppercase();
    let code = upper.split(';').next().unwrap_or("");
    let mut rest = code.trim_start();
    let mut number = None;
    let mut label = None;
    if let Some(r) = rest.strip_prefix('N').or_else(|| rest.strip_prefix(':')) {
        let digits = r.find(|c: char| !c.is_ascii_digit()).unwrap_or(r.len());
        if digits > 0 {
            number = Some(r[..digits].to_string());
            rest = r[digits..].trim_start();
        }
    }
    let name_end = rest
        .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
        .unwrap_or(rest.len());
    if name_end > 1 && rest[name_end..].starts_with(':') {
        label = Some(rest[..name_end].to_string());
        rest = rest[name_end + 1..].trim_start();
    }
    let offset = code.len() - rest.len();
    (rest.trim_end().to_string(), offset, number, label)
}

/// The control statement a block's content is, if any.
fn control(text: &str) -> Option<Control> {
    if let Some(rest) = text.strip_prefix("CASE")
        && rest.trim_start().starts_with('(')
    {
        return case(rest.trim_start());
    }
    let (word, rest) = match text.find(|c: char| c.is_whitespace()) {
        Some(i) => (&text[..i], text[i..].trim()),
        None => (text, ""),
    };
    let target = |rest: &str| rest.split_whitespace().next().unwrap_or("").to_string();
    Some(match word {
        "GOTOF" | "GOTOB" | "GOTO" | "GOTOC" => Control::Goto {
            target: target(rest),
            way: Way::of(word),
            quiet: word == "GOTOC",
        },
        "IF" => {
            for jump in [" GOTOF ", " GOTOB ", " GOTOC ", " GOTO "] {
                if let Some(i) = rest.find(jump) {
                    return Some(Control::IfGoto {
                        condition: rest[..i].trim().to_string(),
                        target: target(&rest[i + jump.len()..]),
                        way: Way::of(jump),
                    });
                }
            }
            Control::If {
                condition: rest.to_string(),
            }
        }
        "ELSE" => Control::Else,
        "ENDIF" => Control::EndIf,
        "WHILE" => Control::While {
            condition: rest.to_string(),
        },
        "ENDWHILE" => Control::EndWhile,
        "FOR" => {
            let (var, range) = rest.split_once('=')?;
            let (from, to) = range.split_once(" TO ")?;
            Control::For {
                var: var.trim().to_string(),
                from: from.trim().to_string(),
                to: to.trim().to_string(),
            }
        }
        "ENDFOR" => Control::EndFor,
        "REPEAT" => Control::Repeat,
        "UNTIL" => Control::Until {
            condition: rest.to_string(),
        },
        "LOOP" => Control::Loop,
        "ENDLOOP" => Control::EndLoop,
        _ => return None,
    })
}

/// A `CASE`'s text after its keyword: `(expr) OF c₁ GOTOF l₁ … DEFAULT GOTOF l`.
fn case(rest: &str) -> Option<Control> {
    // The expression: up to its matching bracket.
    let mut depth = 0;
    let mut close = None;
    for (i, c) in rest.char_indices() {
        match c {
            '(' => depth += 1,
            ')' => {
                depth -= 1;
                if depth == 0 {
                    close = Some(i);
                    break;
                }
            }
            _ => {}
        }
    }
    let close = close?;
    let expr = rest[1..close].trim().to_string();
    let tail = rest[close + 1..].trim_start().strip_prefix("OF")?;
    let words: Vec<&str> = tail.split_whitespace().collect();
    let (mut branches, mut default) = (Vec::new(), None);
    for triple in words.chunks(3) {
        let [key, jump, target] = triple else {
            return None;
        };
        if !matches!(*jump, "GOTOF" | "GOTOB" | "GOTO") {
            return None;
        }
        let to = (target.to_string(), Way::of(jump));
        if *key == "DEFAULT" {
            default = Some(to);
        } else {
            branches.push((key.to_string(), to.0, to.1));
        }
    }
    Some(Control::Case {
        expr,
        branches,
        default,
    })
}

impl Structure {
    /// Reads the program's control statements and labels, and pairs the structured ones.
    pub(crate) fn of(lines: &[&str]) -> Result<Structure, FlowError> {
        let mut s = Structure::default();
        let mut open: Vec<(usize, &'static str)> = Vec::new();
        for (k, line) in lines.iter().enumerate() {
            let (text, offset, number, label) = statement(line);
            if let Some(n) = number {
                s.labels.entry(format!("N{n}")).or_default().push(k);
            }
            if let Some(l) = label {
                s.labels.entry(l).or_default().push(k);
            }
            let Some(c) = control(&text) else {
                if text.starts_with("FOR ") {
                    return Err((k, offset, bad("FOR needs VAR = FROM TO TO")));
                }
                continue;
            };
            let closes =
                |opener: &'static str, open: &mut Vec<(usize, &'static str)>| match open.pop() {
                    Some((at, o)) if o == opener => Ok(at),
                    _ => Err((k, offset, bad(&format!("no {opener} opens this block")))),
                };
            match &c {
                Control::If { .. } => open.push((k, "IF")),
                Control::Else => {
                    let at = closes("IF", &mut open)?;
                    s.partner.insert(at, k);
                    open.push((k, "IF"));
                }
                Control::EndIf => {
                    let at = closes("IF", &mut open)?;
                    s.partner.insert(at, k);
                }
                Control::While { .. } => open.push((k, "WHILE")),
                Control::EndWhile => pair(&mut s, closes("WHILE", &mut open)?, k),
                Control::For { .. } => open.push((k, "FOR")),
                Control::EndFor => pair(&mut s, closes("FOR", &mut open)?, k),
                Control::Repeat => open.push((k, "REPEAT")),
                Control::Until { .. } => pair(&mut s, closes("REPEAT", &mut open)?, k),
                Control::Loop => open.push((k, "LOOP")),
                Control::EndLoop => pair(&mut s, closes("LOOP", &mut open)?, k),
                _ => {}
            }
            s.controls.insert(k, c);
        }
        if let Some(&(k, opener)) = open.last() {
            let (_, offset, _, _) = statement(lines[k]);
            return Err((k, offset, bad(&format!("{opener} is not closed"))));
        }
        Ok(s)
    }

    /// The control statement of line `k`, if it is one.
    pub(crate) fn control(&self, k: usize) -> Option<&Control> {
        self.controls.get(&k)
    }

    /// The line of the label or block number a jump from line `k` reaches.
    pub(crate) fn label(&self, name: &str, k: usize, way: Way) -> Option<usize> {
        // A block number may be named without its `N` (`GOTOF 90`).
        let lines = match self.labels.get(name) {
            None if name.bytes().all(|b| b.is_ascii_digit()) => {
                self.labels.get(&format!("N{name}"))?
            }
            found => found?,
        };
        let forward = || lines.iter().copied().find(|&l| l > k);
        let backward = || lines.iter().copied().rev().find(|&l| l < k);
        match way {
            Way::Forward => forward(),
            Way::Backward => backward(),
            Way::Both => forward().or_else(backward),
        }
    }

    /// The line that closes (or, from a closing one, opens) the structure of line `k`.
    pub(crate) fn partner(&self, k: usize) -> Option<usize> {
        self.partner.get(&k).copied()
    }
}

fn pair(s: &mut Structure, open: usize, close: usize) {
    s.partner.insert(open, close);
    s.partner.insert(close, open);
}

fn bad(problem: &str) -> GcodeErrorKind {
    GcodeErrorKind::Invalid(problem.to_string())
}

/// Running a control statement: its conditions and values read from the variables as
/// they stand when the program reaches it.
impl Translator {
    /// The value of `text` (a `FOR`'s bounds, a `CASE`'s expression and constants), for the
    /// statement `what`.
    fn statement_value(&self, text: &str, what: &str) -> Result<f64, GcodeErrorKind> {
        evaluate(&text.replace(' ', ""), &self.vars)
            .map(|(v, _)| v)
            .map_err(|_| GcodeErrorKind::Invalid(format!("{what}: '{text}' has no value")))
    }

    /// Whether the condition `text` holds with the variables as they stand.
    fn holds(&self, text: &str) -> Result<bool, GcodeErrorKind> {
        condition(text, &self.vars).map_err(|e| match e {
            ExprError::Unknown(_, name) if name.starts_with('$') => GcodeErrorKind::Unsupported {
                word: name,
                reason: "system variables are not supported yet",
            },
            ExprError::Unknown(_, name) => GcodeErrorKind::Invalid(format!(
                "{name}: no R-parameter or DEF variable of that name has a value here"
            )),
            ExprError::Syntax(_, problem) => GcodeErrorKind::Expression(problem),
        })
    }

    /// Enters the `FOR` of line `k`: its variable set to `from`, its end `to` kept; whether
    /// the loop runs at all.
    fn for_entry(
        &mut self,
        k: usize,
        var: &str,
        from: &str,
        to: &str,
    ) -> Result<bool, GcodeErrorKind> {
        let (a, b) = (
            self.statement_value(from, "FOR")?,
            self.statement_value(to, "FOR")?,
        );
        self.vars.insert(var.to_string(), a);
        self.for_end.insert((self.scope, k), b);
        Ok(a <= b)
    }

    /// The `ENDFOR` of line `k`: the variable stepped, and the line to run next (the
    /// loop's first, or past its end).
    fn for_next(&mut self, k: usize, structure: &Structure) -> usize {
        let start = structure.partner(k).unwrap_or(k);
        let Some(Control::For { var, .. }) = structure.control(start) else {
            return k + 1;
        };
        let v = self.vars.get(var).copied().unwrap_or(0.0) + 1.0;
        self.vars.insert(var.clone(), v);
        let end = self
            .for_end
            .get(&(self.scope, start))
            .copied()
            .unwrap_or(f64::NEG_INFINITY);
        if v <= end { start + 1 } else { k + 1 }
    }

    /// The `CASE` of line `k`: the jump of the first constant equal to the expression's
    /// value, else the default's, else the next line.
    fn case(
        &self,
        k: usize,
        expr: &str,
        branches: &[(String, String, Way)],
        default: Option<&(String, Way)>,
        structure: &Structure,
    ) -> Result<usize, GcodeErrorKind> {
        let v = self.statement_value(expr, "CASE")?;
        let mut chosen = None;
        for (constant, target, way) in branches {
            if self.statement_value(constant, "CASE")? == v {
                chosen = Some((target, *way));
                break;
            }
        }
        match chosen.or(default.map(|(t, w)| (t, *w))) {
            Some((target, way)) => jump(structure, k, target, way, false),
            None => Ok(k + 1),
        }
    }

    /// Runs the control statement of line `k`; the line to run next.
    pub(crate) fn control(
        &mut self,
        c: &Control,
        k: usize,
        structure: &Structure,
    ) -> Result<usize, GcodeErrorKind> {
        let after = |line: Option<usize>| line.map_or(k + 1, |l| l + 1);
        Ok(match c {
            Control::Goto { target, way, quiet } => jump(structure, k, target, *way, *quiet)?,
            Control::IfGoto {
                condition,
                target,
                way,
            } => {
                if self.holds(condition)? {
                    jump(structure, k, target, *way, false)?
                } else {
                    k + 1
                }
            }
            // A structure entered (or, for UNTIL, left) while its condition holds; else past
            // its partner.
            Control::If { condition }
            | Control::While { condition }
            | Control::Until { condition } => {
                if self.holds(condition)? {
                    k + 1
                } else {
                    after(structure.partner(k))
                }
            }
            // Reached from the end of the IF's part: past the ENDIF.
            Control::Else => after(structure.partner(k)),
            Control::EndWhile => structure.partner(k).unwrap_or(k + 1),
            Control::For { var, from, to } => {
                if self.for_entry(k, var, from, to)? {
                    k + 1
                } else {
                    after(structure.partner(k))
                }
            }
            Control::EndFor => self.for_next(k, structure),
            Control::EndLoop => after(structure.partner(k)),
            Control::Case {
                expr,
                branches,
                default,
            } => self.case(k, expr, branches, default.as_ref(), structure)?,
            Control::Repeat | Control::Loop | Control::EndIf => k + 1,
        })
    }
}

/// The line a jump from line `k` to `target` lands on, searched `way`; a `quiet` jump
/// (`GOTOC`) to no such label goes on with the next line.
fn jump(
    structure: &Structure,
    k: usize,
    target: &str,
    way: Way,
    quiet: bool,
) -> Result<usize, GcodeErrorKind> {
    match structure.label(target, k, way) {
        Some(line) => Ok(line),
        None if quiet => Ok(k + 1),
        None => Err(GcodeErrorKind::Invalid(format!(
            "{target}: no label or block number of that name {}",
            match way {
                Way::Forward => "after this block (GOTOF)",
                Way::Backward => "before this block (GOTOB)",
                Way::Both => "in the program",
            }
        ))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn structures_pair_up_and_unmatched_ones_are_errors() {
        let lines = [
            "N10 DEF INT I",
            "N20 FOR I=1 TO 3",
            "N30 WHILE R1<5",
            "N40 ENDWHILE",
            "N50 ENDFOR",
            "BACK: IF R2==1",
            "N70 ELSE",
            "N80 ENDIF",
            "N90 GOTOB BACK",
        ];
        let s = Structure::of(&lines).unwrap();
        assert_eq!(s.partner(1), Some(4));
        assert_eq!(s.partner(2), Some(3));
        assert_eq!(s.partner(5), Some(6));
        assert_eq!(s.partner(6), Some(7));
        assert_eq!(s.label("BACK", 8, Way::Backward), Some(5));
        assert_eq!(s.label("BACK", 8, Way::Forward), None);
        assert_eq!(s.label("N90", 0, Way::Both), Some(8));
        let err = Structure::of(&["N10 ENDWHILE"]).unwrap_err();
        assert_eq!((err.0, err.1), (0, 4));
        assert!(Structure::of(&["WHILE R1<1"]).is_err());
    }
}
