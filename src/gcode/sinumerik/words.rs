//! The words of a SINUMERIK block: addresses and their values (numbers, expressions,
//! `AC()`/`IC()`), keywords, R-parameters and `DEF` variables, and what is refused with why.

use super::super::error::GcodeErrorKind;
use super::expr::{Evaluator, ExprError, evaluate, evaluate_assigned};
use super::frame::FrameChange;
use super::{Failure, Rewritten, Translator, refuse};

const CONTROL_FLOW: &str = "this form of program control is not read (jumps, IF, WHILE, FOR, \
     REPEAT and LOOP on lines of their own are): expand the program before checking it";
const MODAL_CALL: &str = "modal and path-named calls (MCALL, PCALL) are not supported: call \
     the subprogram by its name or with CALL after each move instead";
const FRAME: &str = "solid-angle frames (ROTS, AROTS, CROTS) turn the working plane out of XY: \
     post the program in the workpiece's coordinates";
const CYCLE: &str =
    "cycles are not supported: expand the cycle into explicit moves (the CAM post can)";
const SPLINE: &str = "spline and polynomial moves are not supported";
const COMPRESSOR: &str = "the compressor replaces the programmed blocks by splines the \
     predictor does not model: check the program without COMPCURV/COMPCAD/COMPON";
const TRANSFORM: &str = "kinematic transformations (TRAORI, TRANSMIT, TRACYL) are not supported";
const CIRCLE_THROUGH: &str = "circles through an intermediate point (CIP) are not supported: \
     give the arc by its centre (I, J, K) or radius (CR=)";
pub(super) const CENTRE_AC_IC: &str = "AC()/IC() applies to coordinates and arc centres only";

/// Keywords that are refused whole, with why.
fn refused_keyword(name: &str) -> Option<&'static str> {
    let flow = [
        "GOTOF", "GOTOB", "GOTO", "GOTOC", "IF", "ELSE", "ENDIF", "WHILE", "ENDWHILE", "FOR",
        "ENDFOR", "REPEAT", "UNTIL", "LOOP", "ENDLOOP", "CASE", "STOPRE",
    ];
    let frames = ["ROTS", "AROTS", "CROTS"];
    Some(if flow.contains(&name) {
        CONTROL_FLOW
    } else if frames.contains(&name) {
        FRAME
    } else if name == "PCALL" || name == "MCALL" {
        MODAL_CALL
    } else if name.starts_with("CYCLE")
        || [
            "POCKET1", "POCKET2", "POCKET3", "POCKET4", "SLOT1", "SLOT2", "LONGHOLE",
        ]
        .contains(&name)
    {
        CYCLE
    } else if ["ASPLINE", "BSPLINE", "CSPLINE", "POLY", "BSPLINE"].contains(&name) {
        SPLINE
    } else if ["COMPON", "COMPCURV", "COMPCAD"].contains(&name) {
        COMPRESSOR
    } else if ["TRAORI", "TRANSMIT", "TRACYL"].contains(&name) {
        TRANSFORM
    } else if name == "CIP" {
        CIRCLE_THROUGH
    } else {
        return None;
    })
}

/// Where a value starts after the `=` of an assignment at `i`, blanks allowed around the
/// `=` (`R1 = 5`); none when no `=` follows.
pub(super) fn after_equals(b: &[u8], i: usize) -> Option<usize> {
    let blanks = |mut j: usize| {
        while b.get(j).is_some_and(|c| *c == b' ' || *c == b'\t') {
            j += 1;
        }
        j
    };
    let at = blanks(i);
    (b.get(at) == Some(&b'=') && b.get(at + 1) != Some(&b'=')).then(|| blanks(at + 1))
}

/// Why `NAME[…]` is refused.
const INDEXED: &str = "arrays and axis-indexed settings (ACC[X], FA[X], …) are not read: \
                       write the values out";

/// The opening angle `AR=` among a block's words, until its arc is resolved (a letter of
/// its own, `A` being a rotary axis).
pub(super) const OPENING_ANGLE: char = '∡';

/// The word from `name_start` to the next blank or `;`, searched from `from` (for messages).
fn rest_of_word(upper: &str, name_start: usize, from: usize) -> &str {
    let end = upper[from..]
        .find(|c: char| c.is_whitespace() || c == ';')
        .map_or(upper.len(), |e| from + e);
    &upper[name_start..end]
}

/// A keyword refused whole (see [`refused_keyword`]), or a system variable, at
/// `name_start`: the error, naming the word.
fn refused_word(
    upper: &str,
    name: &str,
    name_start: usize,
    ident_end: usize,
    i: usize,
) -> Result<(), Failure> {
    if let Some(reason) = refused_keyword(name).or(refused_keyword(&upper[name_start..ident_end])) {
        return Err(refuse(
            name_start,
            rest_of_word(upper, name_start, i),
            reason,
        ));
    }
    if name.starts_with('$') {
        return Err(refuse(
            name_start,
            rest_of_word(upper, name_start, i),
            CONTROL_FLOW,
        ));
    }
    Ok(())
}

/// A tool by its name, `T="MILL_10"`: a tool change, taken as instantaneous; the offset
/// after it, or none for any other word.
fn tool_by_name(
    upper: &str,
    name: &str,
    name_start: usize,
    i: usize,
) -> Result<Option<usize>, Failure> {
    if name != "T" || !upper[i..].starts_with("=\"") {
        return Ok(None);
    }
    let close = upper[i + 2..].find('"').ok_or((
        name_start,
        GcodeErrorKind::Invalid("T=\" is not closed".into()),
    ))?;
    Ok(Some(i + 2 + close + 1))
}

/// `CYCLE800()` without arguments: the swivel plane deselected. No swivel is ever in force
/// here (a `CYCLE800` with a plane is refused), so only a note is left. The offset after it.
fn swivel_deselected(
    upper: &str,
    name_start: usize,
    i: usize,
    out: &mut Rewritten,
) -> Result<usize, Failure> {
    let end = skip_parenthesised(upper, i, name_start, "CYCLE800")?;
    let open = upper[i..end].find('(').map_or(end, |o| i + o + 1);
    let inner = &upper[open..end.saturating_sub(1).max(open)];
    if inner.split(',').any(|a| !a.trim().is_empty()) {
        return Err(refuse(name_start, &upper[name_start..end], CYCLE));
    }
    out.plain = false;
    out.warnings.push(
        "CYCLE800(): the swivel plane deselected; none was selected (the XY path is the \
         machine's)"
            .to_string(),
    );
    Ok(end)
}

/// A word's value as written after its address: a number, or `AC(n)` / `IC(n)`.
#[derive(Debug, Clone, Copy)]
pub(super) enum Value {
    Number(f64),
    Absolute(f64),
    Incremental(f64),
}

/// Scans a number at the start of `s`: its value and length.
pub(super) fn number(s: &str) -> Option<(f64, usize)> {
    let bytes = s.as_bytes();
    let mut end = 0;
    if end < bytes.len() && (bytes[end] == b'+' || bytes[end] == b'-') {
        end += 1;
    }
    let digits_start = end;
    while end < bytes.len() && (bytes[end].is_ascii_digit() || bytes[end] == b'.') {
        end += 1;
    }
    if end == digits_start {
        return None;
    }
    s[..end].parse::<f64>().ok().map(|v| (v, end))
}

impl Translator {
    /// Reads the word whose name (letters) runs from `name_start` to `i`; the offset after
    /// it.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn word(
        &mut self,
        upper: &str,
        name: &str,
        name_start: usize,
        mut i: usize,
        g_codes: &mut Vec<(usize, u32)>,
        words: &mut Vec<(usize, char, Value)>,
        out: &mut Rewritten,
    ) -> Result<usize, Failure> {
        // The whole identifier, digits included (`POCKET3`, `CYCLE832`).
        let ident_end = upper[name_start..]
            .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
            .map_or(upper.len(), |e| name_start + e);
        if &upper[name_start..ident_end] == "CYCLE832" {
            return self.cycle832(upper, name_start, ident_end, g_codes, out);
        }
        if upper.as_bytes().get(ident_end) == Some(&b'[') {
            return Err(refuse(
                name_start,
                rest_of_word(upper, name_start, ident_end),
                INDEXED,
            ));
        }
        if &upper[name_start..ident_end] == "CYCLE800" {
            return swivel_deselected(upper, name_start, ident_end, out);
        }
        // Addresses whose name ends in a digit.
        let name = match &upper[name_start..ident_end] {
            whole @ ("CTOLG0" | "OTOLG0") => {
                i = ident_end;
                whole
            }
            _ => name,
        };
        refused_word(upper, name, name_start, ident_end, i)?;
        if let Some(end) = tool_by_name(upper, name, name_start, i)? {
            return Ok(end);
        }
        if let Some(end) = self.assignment(upper, name, name_start, i, out)? {
            return Ok(end);
        }
        if let Some(end) = self.keyword(upper, name, name_start, i, words, out)? {
            return Ok(end);
        }
        // An assignment: `X=…`, `CR=…`, `ADIS=…`; or a single letter followed by digits
        // directly: `X10`, `G710`, `R1` …
        let value_at = after_equals(upper.as_bytes(), i);
        if name.len() == 1 || value_at.is_some() {
            let at = value_at.unwrap_or(i);
            return self.address(
                upper,
                name,
                name_start,
                at,
                value_at.is_some(),
                g_codes,
                words,
                out,
            );
        }
        // A word of several letters that is none of the above: a subprogram called by its
        // name (the runner says so if there is none of that name).
        self.named_call(upper, name, name_start, i, out)
    }

    /// The address `name` at `name_start` with its value at `i` (after the `=` when
    /// `assigned`): a G code, a coordinate or another one-letter word, an arc's radius or
    /// opening angle, a rounding distance or tolerance; or `L123`, a call. The offset after
    /// it.
    #[allow(clippy::too_many_arguments)]
    fn address(
        &mut self,
        upper: &str,
        name: &str,
        name_start: usize,
        i: usize,
        assigned: bool,
        g_codes: &mut Vec<(usize, u32)>,
        words: &mut Vec<(usize, char, Value)>,
        out: &mut Rewritten,
    ) -> Result<usize, Failure> {
        let letter = name.chars().next().unwrap_or('?');
        if name.len() == 1 && letter == 'L' && !assigned {
            return self.numbered_call(upper, name_start, i, out);
        }
        let (value, n) = self.value(upper, i, name_start, assigned)?;
        match (name, value) {
            ("G", Value::Number(v)) => g_codes.push((name_start, v.round() as u32)),
            ("CR", v) => words.push((name_start, 'R', v)),
            // The opening angle, resolved into a radius or an end point once the
            // block's other words are known.
            ("AR", v) => words.push((name_start, OPENING_ANGLE, v)),
            // A helix's further full turns; RS274/NGC counts the turns themselves.
            ("TURN", Value::Number(n)) if n >= 0.0 && n.fract() == 0.0 && n < 10_000.0 => {
                words.push((name_start, 'P', Value::Number(n + 1.0)))
            }
            ("TURN", _) => {
                return Err((
                    name_start,
                    GcodeErrorKind::Invalid(
                        "TURN: the number of full turns is a whole number from 0".into(),
                    ),
                ));
            }
            ("ADIS", Value::Number(v)) => self.adis = Some(v),
            ("ADISPOS", Value::Number(v)) => self.adispos = Some(v),
            ("CTOL", Value::Number(v)) => self.ctol = Some(v),
            ("CTOLG0", Value::Number(v)) => self.ctol_g0 = Some(v),
            // Tolerances of the tool's orientation: no rotary axes move it here.
            ("OTOL" | "OTOLG0", Value::Number(_)) => out.warnings.push(format!(
                "{name}: an orientation tolerance, with no orientation axes to apply to"
            )),
            ("RPL", Value::Number(v)) => self.rpl = Some(v),
            ("SPOS" | "SPOSA", _) => {}
            (n, v) if n.len() == 1 => words.push((name_start, letter, v)),
            _ => {
                return Err(refuse(
                    name_start,
                    rest_of_word(upper, name_start, name_start + name.len()),
                    "unknown SINUMERIK address",
                ));
            }
        }
        Ok(i + n)
    }

    /// `CYCLE832(tolerance, machining type, …)` at `name_start` (`i` after the name): the
    /// 840D's high-speed settings, read as `G642` with `CTOL=` the tolerance (mm), or as
    /// `G64` when switched off (`_OFF`, or no tolerance); the offset after it.
    fn cycle832(
        &mut self,
        upper: &str,
        name_start: usize,
        i: usize,
        g_codes: &mut Vec<(usize, u32)>,
        out: &mut Rewritten,
    ) -> Result<usize, Failure> {
        out.plain = false;
        let end = skip_parenthesised(upper, i, name_start, "CYCLE832")?;
        let open = upper[i..end].find('(').map_or(end, |o| i + o + 1);
        let inner = &upper[open..end - 1];
        let mut args = inner.split(',').map(str::trim);
        let tolerance = match args.next().filter(|t| !t.is_empty()) {
            None => 0.0,
            Some(_) => {
                let at = open + (inner.len() - inner.trim_start().len());
                let (v, _) = self.expression(upper, at, name_start)?;
                v
            }
        };
        let kind = args.next().unwrap_or("");
        let off = tolerance <= 0.0 || kind == "_OFF" || kind == "0";
        if off {
            g_codes.push((name_start, 64));
        } else {
            self.ctol = Some(tolerance);
            g_codes.push((name_start, 642));
            out.warnings.push(format!(
                "CYCLE832: read as G642 with CTOL={tolerance} (corners rounded within the \
                 tolerance); the compressor, SOFT and FFWON it also switches on are not \
                 followed: the blocks are planned as programmed, with the planner's profile \
                 and the machine file's feed-forward"
            ));
        }
        Ok(end)
    }

    /// `R1=…` (an R-parameter set), `DEF REAL A=…` (variables declared) or `A=…` (one
    /// set) at `name_start`: the offset after it; none when the word is none of these.
    fn assignment(
        &mut self,
        upper: &str,
        name: &str,
        name_start: usize,
        i: usize,
        out: &mut Rewritten,
    ) -> Result<Option<usize>, Failure> {
        let b = upper.as_bytes();
        if name == "R" && b.get(i).is_some_and(u8::is_ascii_digit) {
            out.plain = false;
            let digits = upper[i..]
                .find(|c: char| !c.is_ascii_digit())
                .map_or(upper.len(), |e| i + e);
            let Some(value_at) = after_equals(b, digits) else {
                let word = &upper[name_start..digits];
                return Err(refuse(name_start, word, CONTROL_FLOW));
            };
            let (v, n) = self.assigned_value(upper, value_at, name_start)?;
            self.vars.insert(upper[name_start..digits].to_string(), v);
            return Ok(Some(value_at + n));
        }
        if name == "DEF" {
            out.plain = false;
            return self.define(upper, i, name_start).map(Some);
        }
        let ident_end = upper[name_start..]
            .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
            .map_or(upper.len(), |e| name_start + e);
        if self.vars.contains_key(&upper[name_start..ident_end])
            && let Some(value_at) = after_equals(b, ident_end)
        {
            out.plain = false;
            let var = upper[name_start..ident_end].to_string();
            let (v, n) = self.assigned_value(upper, value_at, name_start)?;
            self.vars.insert(var, v);
            return Ok(Some(value_at + n));
        }
        Ok(None)
    }

    /// A command word of several letters (a frame, a message, a mode the program cannot
    /// switch here, a program end): the offset after it; none for any other word.
    fn keyword(
        &mut self,
        upper: &str,
        name: &str,
        name_start: usize,
        i: usize,
        words: &mut Vec<(usize, char, Value)>,
        out: &mut Rewritten,
    ) -> Result<Option<usize>, Failure> {
        let change = match name {
            "TRANS" => Some(FrameChange::Trans),
            "ATRANS" => Some(FrameChange::ATrans),
            "ROT" => Some(FrameChange::Rot),
            "AROT" => Some(FrameChange::ARot),
            "SCALE" => Some(FrameChange::Scale),
            "ASCALE" => Some(FrameChange::AScale),
            "MIRROR" => Some(FrameChange::Mirror),
            "AMIRROR" => Some(FrameChange::AMirror),
            _ => None,
        };
        if let Some(change) = change {
            out.plain = false;
            self.frame_change = Some(change);
            return Ok(Some(i));
        }
        let warn = |what: &str| format!("{name}: {what}, not switched by the program");
        match name {
            "MSG" => return skip_parenthesised(upper, i, name_start, "MSG").map(Some),
            // The path's acceleration profile from this block on.
            "BRISK" => out.jerk_limited = Some(false),
            "SOFT" => out.jerk_limited = Some(true),
            "BRISKA" | "SOFTA" | "DRIVE" | "DRIVEA" => {
                out.warnings.push(warn(
                    "the positioning axes' profile is not modelled (the path's is BRISK/SOFT)",
                ));
            }
            "FFWON" | "FFWOF" => out
                .warnings
                .push(warn("feed-forward is the machine file's setting")),
            // Switching off what is not modelled, the programmed feed's default meaning, and
            // the choice of master spindle: nothing on the XY path.
            "COMPOF" | "TRAFOOF" | "CFC" | "CFTCP" | "CFIN" | "SUPA" | "FNORM" => {}
            "SETMS" => return skip_parenthesised(upper, i, name_start, "SETMS").map(Some),
            "RET" if self.in_subprogram => self.returned = true,
            "RET" => words.push((name_start, 'M', Value::Number(2.0))),
            // Declarations: `EXTERN NAME(REAL, INT)` of a subprogram, and `PROC NAME(…)`
            // heading one, whose parameters the runner reads.
            "EXTERN" | "PROC" => {
                out.plain = false;
                return Ok(Some(upper.len()));
            }
            "CALL" => return self.quoted_call(upper, name_start, i, out).map(Some),
            _ => return Ok(None),
        }
        Ok(Some(i))
    }

    /// The value after an address at `i`: a number, or after `=` an expression, `AC(…)` or
    /// `IC(…)`; and its length.
    fn value(
        &self,
        upper: &str,
        i: usize,
        name_start: usize,
        assigned: bool,
    ) -> Result<(Value, usize), Failure> {
        let s = &upper[i..];
        if !assigned {
            return number(s)
                .map(|(v, n)| (Value::Number(v), n))
                .ok_or_else(|| {
                    let letter = upper[name_start..].chars().next().unwrap_or('?');
                    (name_start, GcodeErrorKind::MissingValue(letter))
                });
        }
        for (prefix, absolute) in [("AC(", true), ("IC(", false)] {
            if s.starts_with(prefix) {
                let inner = i + prefix.len();
                let (v, n) = self.expression(upper, inner, name_start)?;
                if upper.as_bytes().get(inner + n) != Some(&b')') {
                    return Err((
                        inner + n,
                        GcodeErrorKind::Invalid(format!("{prefix}…) is not closed")),
                    ));
                }
                let value = if absolute {
                    Value::Absolute(v)
                } else {
                    Value::Incremental(v)
                };
                return Ok((value, prefix.len() + n + 1));
            }
        }
        let (v, n) = self.expression(upper, i, name_start)?;
        Ok((Value::Number(v), n))
    }

    /// The expression at `i`: its value and length. A name no `DEF` declared and no
    /// R-parameter holds — a system variable, a typo — is an error at its place.
    pub(super) fn expression(
        &self,
        upper: &str,
        i: usize,
        name_start: usize,
    ) -> Result<(f64, usize), Failure> {
        self.value_at(upper, i, name_start, evaluate)
    }

    /// [`Translator::expression`] for a variable's assignment, which may be a comparison.
    fn assigned_value(
        &self,
        upper: &str,
        i: usize,
        name_start: usize,
    ) -> Result<(f64, usize), Failure> {
        self.value_at(upper, i, name_start, evaluate_assigned)
    }

    fn value_at(
        &self,
        upper: &str,
        i: usize,
        name_start: usize,
        eval: Evaluator,
    ) -> Result<(f64, usize), Failure> {
        if i >= upper.len() || upper[i..].starts_with([' ', '\t', ';']) {
            let letter = upper[name_start..].chars().next().unwrap_or('?');
            return Err((name_start, GcodeErrorKind::MissingValue(letter)));
        }
        eval(&upper[i..], &self.vars).map_err(|e| match e {
            ExprError::Unknown(at, name) if name.starts_with('$') => {
                refuse(i + at, &name, "system variables are not supported yet")
            }
            ExprError::Unknown(at, name) => (
                i + at,
                GcodeErrorKind::Invalid(format!(
                    "{name}: no R-parameter or DEF variable of that name has a value here"
                )),
            ),
            ExprError::Syntax(at, problem) => (i + at, GcodeErrorKind::Expression(problem)),
        })
    }

    /// `DEF REAL A, B=2` / `DEF INT N=3`: the variables declared, with their values (zero
    /// unless given); the offset after the declaration.
    fn define(&mut self, upper: &str, mut i: usize, name_start: usize) -> Result<usize, Failure> {
        let b = upper.as_bytes();
        let skip_blanks = |mut j: usize| {
            while j < b.len() && b[j] == b' ' {
                j += 1;
            }
            j
        };
        i = skip_blanks(i);
        let type_end = upper[i..]
            .find(|c: char| !c.is_ascii_alphabetic())
            .map_or(upper.len(), |e| i + e);
        let integer = match &upper[i..type_end] {
            "REAL" => false,
            "INT" => true,
            other => {
                let word = format!("DEF {other}");
                return Err(refuse(
                    name_start,
                    &word,
                    "only DEF REAL and DEF INT variables are read",
                ));
            }
        };
        i = type_end;
        loop {
            i = skip_blanks(i);
            let start = i;
            while i < b.len() && (b[i].is_ascii_alphanumeric() || b[i] == b'_') {
                i += 1;
            }
            if i == start {
                return Err((
                    i,
                    GcodeErrorKind::Invalid("DEF needs a variable name".into()),
                ));
            }
            if b.get(i) == Some(&b'[') {
                return Err(refuse(start, &upper[start..=i], INDEXED));
            }
            let var = upper[start..i].to_string();
            let mut value = 0.0;
            if let Some(value_at) = after_equals(b, i) {
                let (v, n) = self.expression(upper, value_at, start)?;
                value = if integer { v.round() } else { v };
                i = value_at + n;
            }
            self.vars.insert(var, value);
            i = skip_blanks(i);
            if b.get(i) == Some(&b',') {
                i += 1;
            } else {
                return Ok(i);
            }
        }
    }
}

/// Skips `( … )` after `MSG` (quotes may hold parentheses); the offset after it.
pub(super) fn skip_parenthesised(
    upper: &str,
    i: usize,
    name_start: usize,
    what: &str,
) -> Result<usize, Failure> {
    let b = upper.as_bytes();
    let mut j = i;
    while j < b.len() && b[j] == b' ' {
        j += 1;
    }
    if j >= b.len() || b[j] != b'(' {
        return Err((
            name_start,
            GcodeErrorKind::Invalid(format!("{what} needs its arguments in ( … )")),
        ));
    }
    let (mut depth, mut quoted) = (0, false);
    while j < b.len() {
        match b[j] {
            b'"' => quoted = !quoted,
            b'(' if !quoted => depth += 1,
            b')' if !quoted => {
                depth -= 1;
                if depth == 0 {
                    return Ok(j + 1);
                }
            }
            _ => {}
        }
        j += 1;
    }
    Err((
        name_start,
        GcodeErrorKind::Invalid(format!("{what}( is not closed")),
    ))
}
