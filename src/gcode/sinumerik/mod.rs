//! The SINUMERIK 840D dialect, read by rewriting each line into the words of the RS274/NGC
//! front end, so that both dialects share one interpreter, one program model and one kind of
//! error (file, line, column — the column of the SINUMERIK text).
//!
//! What is read (SINUMERIK 840D sl programming manual, *Fundamentals*, for the meaning of each
//! command):
//! - `;` comments, `%_N_NAME_MPF` / `_SPF` headers, `N` and `:` block numbers, labels;
//! - addresses written `X10` or `X=10`, and `X=AC(…)` / `X=IC(…)` for one coordinate
//!   absolute or incremental against the block's `G90`/`G91`;
//! - `G710`/`G700` (metric or inch, feeds included) and `G71`/`G70` (positions only) as
//!   `G21`/`G20`;
//! - arcs by centre (`I`, `J`), by radius (`CR=`, negative above 180°) or by opening angle
//!   (`AR=`, with the end point or the centre);
//! - `G60` (exact stop, modal) and `G9` (exact stop in its block), `G64` (continuous path),
//!   `G641` with `ADIS=` and `G642` with `CTOL=`: the corners rounded within the given
//!   distance are planned with the planner's corner tolerance of that size (the 840D's
//!   rounding inserts a blend; the planner passes the corner at the speed a blend of that
//!   size allows, on the programmed path); rapids keep the path mode, as the 840D's `G0`
//!   does, rounded by `ADISPOS=` under `G641` and `CTOLG0=` (else `CTOL=`) under `G642`;
//! - `G4 F…` (dwell in seconds), `G500`, `G54`–`G57`, `G153`, `M17`/`RET` (program end, or a
//!   subprogram's return), `CYCLE832` (as `G642` within its tolerance),
//!   `D` (tool edge: lengths taken as zero), `MSG(…)`;
//! - R-parameters and `DEF REAL`/`DEF INT` variables, set and used in arithmetic
//!   ([`expr`]: `+ - * /`, brackets, `SIN`, `COS`, `TAN`, `ATAN2`, `SQRT`, `ABS`, `POT`, …),
//!   evaluated as the lines are read — programs run straight through, so each value is the
//!   one the control would have there;
//! - the programmable frames `TRANS`/`ATRANS` (a shift), `ROT`/`AROT` (a turn in the XY
//!   plane, `RPL=` or `Z`), `SCALE`/`ASCALE` and `MIRROR`/`AMIRROR`: coordinates are tracked
//!   in the workpiece's frame and written into the program's, arc centres and radii with
//!   them, a mirrored arc's direction reversed;
//! - program control on lines of its own ([`flow`]): labels, `GOTOF`/`GOTOB`/`GOTO`/`GOTOC`,
//!   `IF … GOTO…`, `IF`/`ELSE`/`ENDIF`, `WHILE`, `FOR`, `REPEAT`/`UNTIL`, `LOOP`, `CASE`,
//!   run as the control runs them (a program that runs more than 20 million blocks is an
//!   error);
//! - subprogram calls (`L123 P3`, `NAME(args)`, `CALL "NAME"`) of the same file's `_SPF`
//!   sections or the program folder's files, with `PROC` parameters ([`run`]).
//!
//! `BRISK`/`SOFT` switch the path's acceleration profile from their block on (acceleration
//! or jerk limited, stamped on the segments for the planner). `FFWON`/`FFWOF` are kept as
//! warnings: the feed-forward is the machine file's setting, not switched by the program.
//! Refused, with the word and the reason: system variables (`$…`), other `DEF` types,
//! control sharing a line with other words, modal calls (`MCALL`, `PCALL`), solid-angle
//! frames (`ROTS`), arcs under unequal scales (ellipses), machining cycles (`CYCLE…`,
//! `POCKET3`, …), splines, the compressor, transformations (`TRAORI`, `TRANSMIT`, `TRACYL`)
//! and cutter compensation — never a move skipped.

mod expr;
pub(crate) mod flow;
pub(crate) mod run;

use super::error::GcodeErrorKind;
use expr::{Evaluator, ExprError, Variables, condition, evaluate, evaluate_assigned};
use flow::{Control, Structure, Way};

/// The dialect a program is written in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Dialect {
    /// RS274/NGC as LinuxCNC reads it (and the Fanuc-like programs of most CAM posts).
    Rs274,
    /// SINUMERIK 840D.
    Sinumerik,
}

impl Dialect {
    /// The dialect a file is written in: SINUMERIK for the `.mpf`/`.spf` extensions, a
    /// `%_N_…_MPF`/`_SPF` header, or `G710`/`G700`/`CR=` before any RS274-only construct;
    /// RS274/NGC otherwise.
    pub fn of(file: &str, source: &str) -> Dialect {
        let lower = file.to_ascii_lowercase();
        if lower.ends_with(".mpf") || lower.ends_with(".spf") {
            return Dialect::Sinumerik;
        }
        for line in source.lines().take(200) {
            let upper = line.trim_start().to_ascii_uppercase();
            if upper.starts_with("%_N_") {
                return Dialect::Sinumerik;
            }
            // The code before a `;` comment, without RS274's `( … )` comments, where CAM
            // posts write a tool's `CR=`; `MSG(…)` is kept as the word it is.
            let mut code = String::new();
            let mut depth = 0;
            for c in upper.split(';').next().unwrap_or("").chars() {
                match c {
                    '(' if depth == 0 && code.ends_with("MSG") => code.push(c),
                    '(' => depth += 1,
                    ')' if depth > 0 => depth -= 1,
                    c if depth == 0 => code.push(c),
                    _ => {}
                }
            }
            if ["G710", "G700", "CR=", "ADIS=", "G641", "G642", "MSG("]
                .iter()
                .any(|k| code.contains(k))
            {
                return Dialect::Sinumerik;
            }
        }
        Dialect::Rs274
    }
}

/// One line rewritten: RS274/NGC text, and where each of its pieces came from.
#[derive(Debug)]
pub(crate) struct Rewritten {
    /// The RS274/NGC line.
    pub text: String,
    /// (offset in `text`, offset in the SINUMERIK line) at the start of each piece.
    spans: Vec<(usize, usize)>,
    /// Warnings about the line (words kept but not acted on).
    pub warnings: Vec<String>,
    /// The path's acceleration profile the line switches to: `SOFT` (jerk limited) or
    /// `BRISK` (acceleration limited).
    pub jerk_limited: Option<bool>,
    /// Whether every word reads the same in RS274/NGC, so that the line is passed on as it
    /// is (most of a CAM program's lines: `G1 X10.5 Y3`).
    plain: bool,
}

impl Default for Rewritten {
    fn default() -> Self {
        Rewritten {
            text: String::new(),
            spans: Vec::new(),
            warnings: Vec::new(),
            jerk_limited: None,
            plain: true,
        }
    }
}

impl Rewritten {
    /// The RS274/NGC text of `line`: the line itself where it is plain.
    pub fn text<'a>(&'a self, line: &'a str) -> &'a str {
        if self.plain { line } else { &self.text }
    }

    /// The SINUMERIK line's byte offset for an offset in the rewritten text.
    pub fn original_offset(&self, rewritten: usize) -> usize {
        if self.plain {
            return rewritten;
        }
        self.spans
            .iter()
            .take_while(|(r, _)| *r <= rewritten)
            .last()
            .map_or(0, |&(_, o)| o)
    }

    fn push(&mut self, original: usize, piece: &str) {
        if !self.text.is_empty() {
            self.text.push(' ');
        }
        self.spans.push((self.text.len(), original));
        self.text.push_str(piece);
    }
}

/// The continuous-path mode a program set, which a `G9` block interrupts for itself.
#[derive(Debug, Clone, Copy, PartialEq)]
enum PathMode {
    /// `G60`.
    ExactStop,
    /// `G64`, or `G641`/`G642` with their distance (mm or inch, as the program's unit).
    Continuous(Option<f64>),
}

/// The dialect's state from line to line.
#[derive(Debug)]
pub(crate) struct Translator {
    path_mode: PathMode,
    /// Whether `G641` (else `G642`) is the rounding mode in force, when one is.
    rounding: Option<bool>,
    /// `ADIS=`: the rounding distance of `G641` between feed moves (`G1`–`G3`).
    adis: Option<f64>,
    /// `ADISPOS=`: the rounding distance of `G641` after a rapid (`G0`).
    adispos: Option<f64>,
    /// Whether a rotary axis's positioning has been noted.
    rotary_noted: bool,
    /// `CTOL=`: the contour tolerance of `G642`.
    ctol: Option<f64>,
    /// `CTOLG0=`: the contour tolerance of `G642` after a rapid.
    ctol_g0: Option<f64>,
    absolute: bool,
    /// Where X, Y, Z stand in the workpiece's coordinates (the frame's), where known.
    position: [Option<f64>; 3],
    /// What an incremental value (`IC()`, `G91`) adds to, per axis: the value last
    /// programmed, kept as it was across a frame change, so that the next incremental move
    /// also travels the change of the frame's offset — the 840D's default (setting data
    /// `FRAME_OFFSET_INCR_PROG` = 1). `None`: the position.
    incremental_base: [Option<f64>; 3],
    /// The last block was a `G9` block: the next one restores the path mode.
    restore_mode: bool,
    /// No block yet: the first one sets the control's initial path mode.
    first_block: bool,
    /// The line upper-cased, a buffer reused from line to line.
    upper: String,
    /// R-parameters and `DEF` variables, with their values so far.
    vars: Variables,
    /// The programmable frame in force: the workpiece's coordinates turned and shifted
    /// into the program's.
    frame: Frame,
    /// The frame instruction of the block being read, whose X, Y, Z (and `RPL=`) are its
    /// arguments rather than a move.
    frame_change: Option<FrameChange>,
    /// `RPL=` of the block being read: a rotation in the working plane (degrees).
    rpl: Option<f64>,
    /// Each running `FOR`'s end value, by the run of its program text (its scope) and its
    /// line.
    for_end: std::collections::HashMap<(usize, usize), f64>,
    /// The run of a program text the lines come from: a new one for each subprogram call,
    /// so that a `FOR` keeps its end apart from the same line's in another call.
    pub scope: usize,
    /// Whether the lines are a subprogram's: `M17` and `RET` then return to the caller.
    pub in_subprogram: bool,
    /// The subprogram the block calls, once its other words have run.
    call: Option<Call>,
    /// The block returned from the subprogram (`M17`, `RET`).
    returned: bool,
    /// The motion mode the program set (`G0`–`G3`), and the one the interpreter holds:
    /// they differ on arcs under a mirror.
    motion: Option<u32>,
    emitted_motion: Option<u32>,
}

/// A subprogram call: `L123 P3`, `POCKET(5, , 2)`, `CALL "NAME"`.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Call {
    /// Where the call is written in its line.
    pub offset: usize,
    /// The call as written (for messages).
    pub word: String,
    /// The subprogram's name, upper case (`L123`, `POCKET`).
    pub name: String,
    /// The arguments, by position; `None` where one is left out (`POCKET(, 3)`).
    pub args: Vec<Option<f64>>,
    /// How many times it runs (`P`).
    pub repeat: u32,
}

/// A programmable frame: a point p of the workpiece is at `shift + rotation(angle)·S·p` in
/// the program's coordinates, S the scale per axis (negative where mirrored) — the 840D's
/// order of a frame's parts: translation, rotation, scale, mirror.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Frame {
    shift: [f64; 3],
    angle_deg: f64,
    scale: [f64; 3],
}

impl Default for Frame {
    fn default() -> Self {
        Frame {
            shift: [0.0; 3],
            angle_deg: 0.0,
            scale: [1.0; 3],
        }
    }
}

impl Frame {
    fn is_identity(&self) -> bool {
        *self == Frame::default()
    }

    /// A vector of the workpiece (an increment, an arc's centre offset) in the program's
    /// coordinates.
    fn turn(&self, [x, y]: [f64; 2]) -> [f64; 2] {
        let (x, y) = (self.scale[0] * x, self.scale[1] * y);
        let (s, c) = self.angle_deg.to_radians().sin_cos();
        [c * x - s * y, s * x + c * y]
    }

    /// A point of the workpiece in the program's coordinates.
    fn place(&self, p: [f64; 3]) -> [f64; 3] {
        let [x, y] = self.turn([p[0], p[1]]);
        [
            x + self.shift[0],
            y + self.shift[1],
            self.scale[2] * p[2] + self.shift[2],
        ]
    }

    /// The workpiece point at the program's point `p`.
    fn back(&self, p: [f64; 3]) -> [f64; 3] {
        let (x, y) = (p[0] - self.shift[0], p[1] - self.shift[1]);
        let (s, c) = self.angle_deg.to_radians().sin_cos();
        let (x, y) = (c * x + s * y, -s * x + c * y);
        [
            x / self.scale[0],
            y / self.scale[1],
            (p[2] - self.shift[2]) / self.scale[2],
        ]
    }

    /// Whether one of X and Y is mirrored (not both: that is a half turn), so that a
    /// clockwise arc of the workpiece runs counter-clockwise in the program.
    fn mirrored(&self) -> bool {
        self.scale[0] * self.scale[1] < 0.0
    }

    /// Whether X and Y are scaled alike, so that an arc stays an arc.
    fn round(&self) -> bool {
        (self.scale[0].abs() - self.scale[1].abs()).abs() <= 1e-12 * self.scale[0].abs()
    }
}

/// A frame instruction: `TRANS`, `ROT`, `SCALE` and `MIRROR` replace the programmable frame,
/// `ATRANS`, `AROT`, `ASCALE` and `AMIRROR` add to it (in its own coordinates).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum FrameChange {
    Trans,
    ATrans,
    Rot,
    ARot,
    Scale,
    AScale,
    Mirror,
    AMirror,
}

impl Default for Translator {
    fn default() -> Self {
        Translator {
            path_mode: PathMode::ExactStop,
            rounding: None,
            adis: None,
            adispos: None,
            ctol_g0: None,
            rotary_noted: false,
            ctol: None,
            absolute: true,
            position: [None; 3],
            incremental_base: [None; 3],
            restore_mode: false,
            first_block: true,
            upper: String::new(),
            vars: Variables::new(),
            frame: Frame::default(),
            frame_change: None,
            rpl: None,
            for_end: std::collections::HashMap::new(),
            scope: 0,
            in_subprogram: false,
            call: None,
            returned: false,
            motion: None,
            emitted_motion: None,
        }
    }
}

/// A rewriting failure: byte offset in the SINUMERIK line and the problem.
pub(crate) type Failure = (usize, GcodeErrorKind);

impl Translator {
    /// Enters the `FOR` of line `k`: its variable set to `from`, its end `to` kept; whether
    /// the loop runs at all.
    fn for_entry(
        &mut self,
        k: usize,
        var: &str,
        from: &str,
        to: &str,
    ) -> Result<bool, GcodeErrorKind> {
        let value = |t: &Translator, text: &str| {
            evaluate(&text.replace(' ', ""), &t.vars)
                .map(|(v, _)| v)
                .map_err(|_| GcodeErrorKind::Invalid(format!("FOR: '{text}' has no value")))
        };
        let (a, b) = (value(self, from)?, value(self, to)?);
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

    /// Runs the control statement of line `k`; the line to run next.
    pub fn control(
        &mut self,
        c: &Control,
        k: usize,
        structure: &Structure,
    ) -> Result<usize, GcodeErrorKind> {
        let test = |t: &Translator, text: &str| {
            condition(text, &t.vars).map_err(|e| match e {
                ExprError::Unknown(_, name) if name.starts_with('$') => {
                    GcodeErrorKind::Unsupported {
                        word: name,
                        reason: "system variables are not supported yet",
                    }
                }
                ExprError::Unknown(_, name) => GcodeErrorKind::Invalid(format!(
                    "{name}: no R-parameter or DEF variable of that name has a value here"
                )),
                ExprError::Syntax(_, problem) => GcodeErrorKind::Expression(problem),
            })
        };
        let jump = |target: &str, way: Way, quiet: bool| match structure.label(target, k, way) {
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
        };
        let after = |line: Option<usize>| line.map_or(k + 1, |l| l + 1);
        Ok(match c {
            Control::Goto { target, way, quiet } => jump(target, *way, *quiet)?,
            Control::IfGoto {
                condition,
                target,
                way,
            } => {
                if test(self, condition)? {
                    jump(target, *way, false)?
                } else {
                    k + 1
                }
            }
            // A structure entered (or, for UNTIL, left) while its condition holds; else past
            // its partner.
            Control::If { condition }
            | Control::While { condition }
            | Control::Until { condition } => {
                if test(self, condition)? {
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
            } => {
                let value = |t: &Translator, text: &str| {
                    evaluate(&text.replace(' ', ""), &t.vars)
                        .map(|(v, _)| v)
                        .map_err(|_| {
                            GcodeErrorKind::Invalid(format!("CASE: '{text}' has no value"))
                        })
                };
                let v = value(self, expr)?;
                let mut chosen = None;
                for (constant, target, way) in branches {
                    if value(self, constant)? == v {
                        chosen = Some((target, *way));
                        break;
                    }
                }
                match chosen.or(default.as_ref().map(|(t, w)| (t, *w))) {
                    Some((target, way)) => jump(target, way, false)?,
                    None => k + 1,
                }
            }
            Control::Repeat | Control::Loop | Control::EndIf => k + 1,
        })
    }
}

fn refuse(offset: usize, word: &str, reason: &'static str) -> Failure {
    (
        offset,
        GcodeErrorKind::Unsupported {
            word: word.to_string(),
            reason,
        },
    )
}

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
const CENTRE_AC_IC: &str = "AC()/IC() applies to coordinates and arc centres only";

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
    } else {
        return None;
    })
}

/// Where a value starts after the `=` of an assignment at `i`, blanks allowed around the
/// `=` (`R1 = 5`); none when no `=` follows.
fn after_equals(b: &[u8], i: usize) -> Option<usize> {
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
const OPENING_ANGLE: char = '∡';

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

/// A piece of the rewritten line, written out only when the line is rewritten.
enum Piece {
    Text(&'static str),
    G(u32),
    Word(char, f64),
    Blend(f64),
}

/// A word's value as written after its address: a number, or `AC(n)` / `IC(n)`.
#[derive(Debug, Clone, Copy)]
enum Value {
    Number(f64),
    Absolute(f64),
    Incremental(f64),
}

/// Scans a number at the start of `s`: its value and length.
fn number(s: &str) -> Option<(f64, usize)> {
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
    /// Rewrites one SINUMERIK line into RS274/NGC words.
    pub fn rewrite(&mut self, line: &str) -> Result<Rewritten, Failure> {
        let mut upper = std::mem::take(&mut self.upper);
        upper.clear();
        upper.push_str(line);
        upper.make_ascii_uppercase();
        let result = self.rewrite_upper(line, &upper);
        self.upper = upper;
        result
    }

    /// [`Translator::rewrite`] with the line upper-cased as `upper`.
    fn rewrite_upper(&mut self, line: &str, upper: &str) -> Result<Rewritten, Failure> {
        let mut out = Rewritten::default();
        let start = upper.len() - upper.trim_start().len();
        if upper[start..].starts_with('%') {
            // `%_N_NAME_MPF` and `%MPF…` headers: no block.
            out.plain = false;
            return Ok(out);
        }
        let mut g_codes: Vec<(usize, u32)> = Vec::new();
        let mut words: Vec<(usize, char, Value)> = Vec::new();
        let mut i = start;
        let b = upper.as_bytes();
        if i < b.len() && b[i] == b'/' {
            out.push(i, "/");
            i += 1;
        }
        while i < b.len() {
            let c = b[i];
            if c == b' ' || c == b'\t' || c == b'\r' {
                i += 1;
                continue;
            }
            if c == b';' {
                break;
            }
            if c == b':' {
                // A main block number, `:10`: read as an N number.
                out.plain = false;
                i += 1;
                let (v, n) = number(&upper[i..]).ok_or((i, GcodeErrorKind::MissingValue(':')))?;
                words.push((i - 1, 'N', Value::Number(v)));
                i += n;
                continue;
            }
            if !(c.is_ascii_alphabetic() || c == b'_' || c == b'$') {
                return Err((
                    i,
                    GcodeErrorKind::UnexpectedChar(line[i..].chars().next().unwrap_or('?')),
                ));
            }
            let name_start = i;
            while i < b.len() && (b[i].is_ascii_alphabetic() || b[i] == b'_' || b[i] == b'$') {
                i += 1;
            }
            let name = &upper[name_start..i];
            // A label: `NAME:` (digits allowed after its first two letters), a jump's target.
            let label_end = upper[i..]
                .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
                .map_or(upper.len(), |e| i + e);
            if b.get(label_end) == Some(&b':') && label_end - name_start > 1 {
                out.plain = false;
                i = label_end + 1;
                continue;
            }
            // Anything but a one-letter address directly followed by its number is rewritten.
            if name.len() > 1 || after_equals(b, i).is_some() {
                out.plain = false;
            }
            i = self.word(
                upper,
                name,
                name_start,
                i,
                &mut g_codes,
                &mut words,
                &mut out,
            )?;
        }
        self.emit(g_codes, words, &mut out)?;
        // Plain, the words mean in RS274/NGC what they mean here: the line is read as it is.
        Ok(out)
    }

    /// Reads the word whose name (letters) runs from `name_start` to `i`; the offset after
    /// it.
    #[allow(clippy::too_many_arguments)]
    fn word(
        &mut self,
        upper: &str,
        name: &str,
        name_start: usize,
        mut i: usize,
        g_codes: &mut Vec<(usize, u32)>,
        words: &mut Vec<(usize, char, Value)>,
        out: &mut Rewritten,
    ) -> Result<usize, Failure> {
        let b = upper.as_bytes();
        let rest_word = |i: usize| {
            let end = upper[i..]
                .find(|c: char| c.is_whitespace() || c == ';')
                .map_or(upper.len(), |e| i + e);
            &upper[name_start..end]
        };
        // The whole identifier, digits included (`POCKET3`, `CYCLE832`).
        let ident_end = upper[name_start..]
            .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
            .map_or(upper.len(), |e| name_start + e);
        if &upper[name_start..ident_end] == "CYCLE832" {
            return self.cycle832(upper, name_start, ident_end, g_codes, out);
        }
        if b.get(ident_end) == Some(&b'[') {
            return Err(refuse(name_start, rest_word(ident_end), INDEXED));
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
        if let Some(reason) =
            refused_keyword(name).or(refused_keyword(&upper[name_start..ident_end]))
        {
            return Err(refuse(name_start, rest_word(i), reason));
        }
        if name.starts_with('$') {
            return Err(refuse(name_start, rest_word(i), CONTROL_FLOW));
        }
        // A tool by its name, `T="MILL_10"`: a tool change, taken as instantaneous.
        if name == "T" && upper[i..].starts_with("=\"") {
            let close = upper[i + 2..].find('"').ok_or((
                name_start,
                GcodeErrorKind::Invalid("T=\" is not closed".into()),
            ))?;
            return Ok(i + 2 + close + 1);
        }
        if let Some(end) = self.assignment(upper, name, name_start, i, out)? {
            return Ok(end);
        }
        if let Some(end) = self.keyword(upper, name, name_start, i, words, out)? {
            return Ok(end);
        }
        // An assignment: `X=…`, `CR=…`, `ADIS=…`.
        let value_at = after_equals(b, i);
        let assigned = value_at.is_some();
        if let Some(at) = value_at {
            i = at;
        }
        // A single letter followed by digits directly: `X10`, `G710`, `R1` …
        if name.len() == 1 || assigned {
            let letter = name.chars().next().unwrap_or('?');
            if name.len() == 1 && letter == 'L' && !assigned {
                return self.numbered_call(upper, name_start, i, out);
            }
            let (value, n) = self.value(upper, i, name_start, assigned)?;
            i += n;
            match (name, value) {
                ("G", Value::Number(v)) => g_codes.push((name_start, v.round() as u32)),
                ("CR", v) => words.push((name_start, 'R', v)),
                // The opening angle, resolved into a radius or an end point once the
                // block's other words are known.
                ("AR", v) => words.push((name_start, OPENING_ANGLE, v)),
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
                        rest_word(name_start + name.len()),
                        "unknown SINUMERIK address",
                    ));
                }
            }
            return Ok(i);
        }
        // A word of several letters that is none of the above: a subprogram called by its
        // name (the runner says so if there is none of that name).
        self.named_call(upper, name, name_start, i, out)
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

    /// `L123` at `name_start` (`i` after the `L`): a call of subprogram `L123`; the offset
    /// after it.
    fn numbered_call(
        &mut self,
        upper: &str,
        name_start: usize,
        i: usize,
        out: &mut Rewritten,
    ) -> Result<usize, Failure> {
        let end = upper[i..]
            .find(|c: char| !c.is_ascii_digit())
            .map_or(upper.len(), |e| i + e);
        if end == i {
            return Err((name_start, GcodeErrorKind::MissingValue('L')));
        }
        self.set_call(name_start, &upper[name_start..end], Vec::new(), out)?;
        Ok(end)
    }

    /// `NAME` or `NAME(a, , c)` at `name_start` (`i` after the name): a call of subprogram
    /// `NAME`; the offset after it.
    fn named_call(
        &mut self,
        upper: &str,
        name: &str,
        name_start: usize,
        mut i: usize,
        out: &mut Rewritten,
    ) -> Result<usize, Failure> {
        // A name may go on with digits and underscores: `POCKET_2`.
        while upper
            .as_bytes()
            .get(i)
            .is_some_and(|c| c.is_ascii_alphanumeric() || *c == b'_')
        {
            i += 1;
        }
        let name = if i > name_start + name.len() {
            &upper[name_start..i]
        } else {
            name
        };
        let mut args = Vec::new();
        if upper.as_bytes().get(i) == Some(&b'(') {
            i += 1;
            loop {
                while upper.as_bytes().get(i) == Some(&b' ') {
                    i += 1;
                }
                match upper.as_bytes().get(i) {
                    Some(b',') => {
                        args.push(None);
                        i += 1;
                        continue;
                    }
                    Some(b')') => {
                        // `NAME()` has no argument; `NAME(1,)` leaves its last one out.
                        if upper.as_bytes()[i - 1] == b',' {
                            args.push(None);
                        }
                        i += 1;
                        break;
                    }
                    None => {
                        return Err((
                            name_start,
                            GcodeErrorKind::Invalid(format!("{name}( … ) is not closed")),
                        ));
                    }
                    Some(_) => {}
                }
                let (v, n) = self.expression(upper, i, name_start)?;
                args.push(Some(v));
                i += n;
                while upper.as_bytes().get(i) == Some(&b' ') {
                    i += 1;
                }
                match upper.as_bytes().get(i) {
                    Some(b',') => i += 1,
                    Some(b')') => {
                        i += 1;
                        break;
                    }
                    _ => {
                        return Err((
                            i,
                            GcodeErrorKind::Invalid(format!(
                                "{name}( … ): ',' or ')' expected after an argument"
                            )),
                        ));
                    }
                }
            }
        }
        self.set_call(name_start, name, args, out)?;
        Ok(i)
    }

    /// Records the block's subprogram call (one per block).
    fn set_call(
        &mut self,
        offset: usize,
        name: &str,
        args: Vec<Option<f64>>,
        out: &mut Rewritten,
    ) -> Result<(), Failure> {
        out.plain = false;
        if let Some(first) = &self.call {
            return Err((
                offset,
                GcodeErrorKind::Invalid(format!(
                    "{name}: a block calls one subprogram, and this one calls {} already",
                    first.name
                )),
            ));
        }
        self.call = Some(Call {
            offset,
            word: name.to_string(),
            name: name.to_string(),
            args,
            repeat: 1,
        });
        Ok(())
    }

    /// `CALL "NAME"` at `name_start` (`i` after `CALL`): the offset after it.
    fn quoted_call(
        &mut self,
        upper: &str,
        name_start: usize,
        i: usize,
        out: &mut Rewritten,
    ) -> Result<usize, Failure> {
        let open = i + upper[i..].len() - upper[i..].trim_start().len();
        let closed = upper[open..]
            .strip_prefix('"')
            .and_then(|rest| rest.find('"'))
            .map(|e| open + 1 + e);
        let Some(close) = closed else {
            return Err((
                name_start,
                GcodeErrorKind::Invalid("CALL needs the subprogram's name in quotes".into()),
            ));
        };
        let path = &upper[open + 1..close];
        // A name with its folder, `"/_N_SPF_DIR/_N_POCK_SPF"`: the subprogram's own name.
        let file = path.rsplit('/').next().unwrap_or(path);
        let name = file
            .strip_prefix("_N_")
            .unwrap_or(file)
            .trim_end_matches("_SPF")
            .trim_end_matches("_MPF");
        self.set_call(name_start, name, Vec::new(), out)?;
        if let Some(call) = &mut self.call {
            call.word = upper[name_start..=close].to_string();
        }
        Ok(close + 1)
    }

    /// The subprogram the last block calls, to be run after its other words.
    pub fn take_call(&mut self) -> Option<Call> {
        self.call.take()
    }

    /// Whether the last block returned from the subprogram (`M17`, `RET`).
    pub fn take_returned(&mut self) -> bool {
        std::mem::take(&mut self.returned)
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
    fn expression(
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

    /// Writes the block's codes and words as RS274/NGC, in its order of meaning.
    fn emit(
        &mut self,
        g_codes: Vec<(usize, u32)>,
        words: Vec<(usize, char, Value)>,
        out: &mut Rewritten,
    ) -> Result<(), Failure> {
        if g_codes.is_empty() && words.is_empty() {
            if let Some(change) = self.frame_change.take() {
                self.change_frame(change, Vec::new())?;
            }
            return Ok(());
        }
        // The 840D starts in exact stop (G60) unless its machine data say otherwise.
        if std::mem::take(&mut self.first_block) {
            self.restore_mode = true;
        }
        let mut pieces: Vec<(usize, Piece)> = Vec::new();
        let dwell = self.emit_codes(&g_codes, &mut pieces, out);
        let mut words = words;
        if let Some(call) = &mut self.call {
            // `L123 P3`: P is how many times the subprogram runs.
            if let Some(k) = words.iter().position(|w| w.1 == 'P') {
                let (offset, _, value) = words.remove(k);
                let n = match value {
                    Value::Number(n) if n >= 1.0 && n.fract() == 0.0 && n <= 1e6 => n as u32,
                    _ => {
                        return Err((
                            offset,
                            GcodeErrorKind::Invalid(
                                "P: the number of runs is a whole number from 1 up".into(),
                            ),
                        ));
                    }
                };
                call.repeat = n;
            }
        }
        if self.in_subprogram
            && let Some(k) = words
                .iter()
                .position(|(_, l, v)| *l == 'M' && matches!(v, Value::Number(x) if *x == 17.0))
        {
            words.remove(k);
            self.returned = true;
            out.plain = false;
        }
        if let Some(change) = self.frame_change.take() {
            words = self.change_frame(change, words)?;
        }
        self.motion_under_frame(&g_codes, &words, &mut pieces, out)?;
        self.rotary_positioning(&mut words, out)?;
        if let Some(k) = words.iter().position(|w| w.1 == OPENING_ANGLE) {
            let (offset, _, value) = words.remove(k);
            out.plain = false;
            self.opening_angle(offset, value, &mut words)?;
        }
        let framed = !self.frame.is_identity();
        // Words RS274/NGC reads otherwise, or not at all: the line is rewritten.
        let rewritten_word = |(_, l, v): &(usize, char, Value)| {
            !matches!(v, Value::Number(_))
                || *l == 'D'
                || (*l == 'M' && matches!(v, Value::Number(x) if *x == 17.0))
                || (framed && matches!(l, 'X' | 'Y' | 'Z' | 'I' | 'J' | 'R'))
        };
        // An increment that also travels a frame's change of offset is rewritten.
        let offset_left = |(_, l, _): &(usize, char, Value)| {
            "XYZ".find(*l).is_some_and(|a| {
                matches!((self.incremental_base[a], self.position[a]), (Some(b), Some(p)) if b != p)
            })
        };
        if dwell
            || words.iter().any(rewritten_word)
            || (!self.absolute && words.iter().any(offset_left))
        {
            out.plain = false;
        }
        self.emit_words(words, dwell, &mut pieces, out)?;
        if g_codes.iter().any(|&(_, g)| g == 53 || g == 153) {
            self.position = [None; 3];
            self.incremental_base = [None; 3];
        }
        if !out.plain {
            write_pieces(pieces, out);
        }
        Ok(())
    }

    /// The motion code the interpreter is to hold for this block under the frame: a
    /// mirrored frame turns a clockwise arc of the workpiece counter-clockwise, so `G2` is
    /// written `G3` and back — in the block that names it, and in a block that moves on the
    /// modal arc whenever the interpreter holds the other one. An arc under a scale that
    /// differs on X and Y (an ellipse) is refused.
    fn motion_under_frame(
        &mut self,
        g_codes: &[(usize, u32)],
        words: &[(usize, char, Value)],
        pieces: &mut Vec<(usize, Piece)>,
        out: &mut Rewritten,
    ) -> Result<(), Failure> {
        let named = g_codes.iter().copied().find(|&(_, g)| g <= 3);
        if let Some((_, g)) = named {
            self.motion = Some(g);
        }
        let moving = words
            .iter()
            .find(|w| matches!(w.1, 'X' | 'Y' | 'I' | 'J' | 'R'))
            .map(|w| w.0);
        let arc = matches!(self.motion, Some(2 | 3));
        if let Some(offset) = moving
            && arc
            && !self.frame.round()
        {
            return Err(refuse(
                offset,
                &format!("G{}", self.motion.unwrap_or(2)),
                "an arc under a scale that differs on X and Y is an ellipse, which G2/G3 \
                 cannot describe",
            ));
        }
        let wanted = match self.motion {
            Some(g @ (2 | 3)) if self.frame.mirrored() => Some(5 - g),
            m => m,
        };
        if let Some((offset, g)) = named {
            if Some(g) != wanted {
                out.plain = false;
                for piece in pieces.iter_mut() {
                    if piece.0 == offset && matches!(piece.1, Piece::G(code) if code == g) {
                        piece.1 = Piece::G(wanted.unwrap_or(g));
                    }
                }
            }
            self.emitted_motion = wanted;
        } else if let (Some(offset), Some(w)) = (moving, wanted)
            && self.emitted_motion != wanted
        {
            out.plain = false;
            pieces.push((offset, Piece::G(w)));
            self.emitted_motion = wanted;
        }
        Ok(())
    }

    /// Rotary axes (`A`, `B`, `C`): the model has none, and the XY path is the machine's. A
    /// rotary axis positioned in a rapid, or in a block that moves no linear axis, leaves the
    /// path alone: it is taken out and noted (once). Turning while a feed move runs along
    /// X, Y or Z machines a path this cannot follow, and is refused.
    fn rotary_positioning(
        &mut self,
        words: &mut Vec<(usize, char, Value)>,
        out: &mut Rewritten,
    ) -> Result<(), Failure> {
        let is_rotary = |w: &(usize, char, Value)| matches!(w.1, 'A' | 'B' | 'C');
        let Some(&(offset, axis, _)) = words.iter().find(|w| is_rotary(w)) else {
            return Ok(());
        };
        let linear = words
            .iter()
            .any(|w| matches!(w.1, 'X' | 'Y' | 'Z' | 'I' | 'J' | 'R' | OPENING_ANGLE));
        if linear && self.motion != Some(0) {
            return Err(refuse(
                offset,
                &axis.to_string(),
                "a rotary axis turning during a feed move: the model has X, Y and Z only",
            ));
        }
        out.plain = false;
        if !std::mem::replace(&mut self.rotary_noted, true) {
            out.warnings.push(format!(
                "{axis}: a rotary axis positioned (here and wherever else the program positions \
                 one in a rapid or on its own): not modelled; the XY path is taken as the \
                 machine's"
            ));
        }
        words.retain(|w| !is_rotary(w));
        Ok(())
    }

    /// An arc given by its opening angle `AR=` (degrees): with its end point, the radius
    /// that spans it (`R`, negative above 180°); with its centre, the end point the angle
    /// reaches from the start, counter-clockwise on `G3`, clockwise on `G2`.
    fn opening_angle(
        &self,
        offset: usize,
        value: Value,
        words: &mut Vec<(usize, char, Value)>,
    ) -> Result<(), Failure> {
        let invalid = |what: &str| (offset, GcodeErrorKind::Invalid(format!("AR: {what}")));
        let Value::Number(angle) = value else {
            return Err(invalid("the opening angle is a plain number"));
        };
        if !(angle > 0.0 && angle < 360.0) {
            return Err(invalid("the opening angle lies between 0 and 360°"));
        }
        let ccw = match self.motion {
            Some(3) => true,
            Some(2) => false,
            _ => return Err(invalid("an opening angle belongs to a G2 or G3 arc")),
        };
        let [Some(x0), Some(y0)] = [self.position[0], self.position[1]] else {
            return Err(invalid("the arc's start is not known yet"));
        };
        let has = |l: char| words.iter().any(|w| w.1 == l);
        let end_given = has('X') || has('Y');
        let centre_given = has('I') || has('J');
        let half = (angle / 2.0).to_radians();
        if end_given && !centre_given && !has('R') {
            let start = self.position;
            let mut end = [x0, y0];
            for (o, l, v) in words.iter() {
                if let Some(a) = "XY".find(*l) {
                    let v = self.coordinate(*o, *l, *v, &start)?;
                    end[a] = if self.absolute { v } else { [x0, y0][a] + v };
                }
            }
            let chord = (end[0] - x0).hypot(end[1] - y0);
            if chord == 0.0 {
                return Err(invalid("an arc to its own start needs its centre (I, J)"));
            }
            let radius = chord / 2.0 / half.sin();
            let signed = if angle > 180.0 { -radius } else { radius };
            words.push((offset, 'R', Value::Number(signed)));
            return Ok(());
        }
        if centre_given && !end_given && !has('R') {
            let start = self.position;
            let mut centre = [x0, y0];
            for (o, l, v) in words.iter() {
                if let Some(a) = "IJ".find(*l) {
                    centre[a] += self.coordinate(*o, *l, *v, &start)?;
                }
            }
            let turn = if ccw { angle } else { -angle }.to_radians();
            let (s, c) = turn.sin_cos();
            let (dx, dy) = (x0 - centre[0], y0 - centre[1]);
            let end = [centre[0] + c * dx - s * dy, centre[1] + s * dx + c * dy];
            words.push((offset, 'X', Value::Absolute(end[0])));
            words.push((offset, 'Y', Value::Absolute(end[1])));
            return Ok(());
        }
        Err(invalid(
            "give the arc's end point (X, Y) or its centre (I, J) with it, not both, nor CR=",
        ))
    }

    /// The block's G codes as RS274/NGC and the path mode they leave; whether the block
    /// dwells.
    fn emit_codes(
        &mut self,
        g_codes: &[(usize, u32)],
        pieces: &mut Vec<(usize, Piece)>,
        out: &mut Rewritten,
    ) -> bool {
        let (mut exact_here, mut mode_changed, mut dwell) = (false, false, false);
        // A `G60` writes its own `G61`: the mode needs no restoring on top of it.
        let mut mode_written = false;
        // Where the block's path-mode code was written (a restoring one goes with the
        // block's first G code, or last).
        let mut mode_offset = g_codes.first().map_or(usize::MAX, |g| g.0);
        const REWRITTEN: [u32; 12] = [710, 71, 700, 70, 60, 9, 64, 641, 642, 500, 153, 4];
        if g_codes.iter().any(|(_, g)| REWRITTEN.contains(g)) {
            out.plain = false;
        }
        for &(offset, g) in g_codes {
            let rs = match g {
                710 | 71 => Some(Piece::Text("G21")),
                700 | 70 => Some(Piece::Text("G20")),
                60 => {
                    self.path_mode = PathMode::ExactStop;
                    self.rounding = None;
                    mode_written = true;
                    Some(Piece::Text("G61"))
                }
                9 | 64 | 641 | 642 => {
                    match g {
                        9 => exact_here = true,
                        64 => {
                            self.path_mode = PathMode::Continuous(None);
                            self.rounding = None;
                        }
                        _ => self.rounding = Some(g == 641),
                    }
                    mode_changed |= g != 9;
                    mode_offset = offset;
                    None
                }
                500 => None,
                153 => Some(Piece::Text("G53")),
                4 => {
                    dwell = true;
                    Some(Piece::Text("G4"))
                }
                90 | 91 => {
                    self.absolute = g == 90;
                    Some(Piece::G(g))
                }
                g => Some(Piece::G(g)),
            };
            if let Some(rs) = rs {
                pieces.push((offset, rs));
            }
        }
        // The rounding distance in force, should the block set one: `G641` rounds after a
        // rapid by `ADISPOS`, after a feed move by `ADIS`; `G642` by the contour tolerance,
        // after a rapid by `CTOLG0` where one is set (else by `CTOL`: the machine data's
        // factor for G0 tolerances is taken as 1).
        if let Some(is_641) = self.rounding {
            let rapid = g_codes
                .iter()
                .rev()
                .find(|g| g.1 <= 3)
                .map(|g| g.1)
                .or(self.motion)
                == Some(0);
            let distance = match (is_641, rapid) {
                (true, true) => self.adispos,
                (true, false) => self.adis,
                (false, true) => self.ctol_g0.or(self.ctol),
                (false, false) => self.ctol,
            };
            if matches!(self.path_mode, PathMode::Continuous(d) if d != distance) {
                mode_changed = true;
            }
            self.path_mode = PathMode::Continuous(distance);
        }
        if exact_here || mode_changed || self.restore_mode {
            out.plain = false;
        }
        if exact_here {
            if !mode_written {
                pieces.push((mode_offset, Piece::Text("G61")));
            }
            self.restore_mode = true;
        } else if mode_written && !mode_changed {
            self.restore_mode = false;
        } else if mode_changed || self.restore_mode {
            self.restore_mode = false;
            pieces.push((
                mode_offset,
                match self.path_mode {
                    PathMode::ExactStop => Piece::Text("G61"),
                    PathMode::Continuous(None) => Piece::Text("G64"),
                    PathMode::Continuous(Some(d)) => Piece::Blend(d),
                },
            ));
        }
        dwell
    }

    /// The block's words as RS274/NGC: coordinates resolved against the position and, under
    /// a frame, written turned and shifted (X and Y both, once either is given; I and J
    /// turned) into the program's coordinates.
    fn emit_words(
        &mut self,
        words: Vec<(usize, char, Value)>,
        dwell: bool,
        pieces: &mut Vec<(usize, Piece)>,
        out: &Rewritten,
    ) -> Result<(), Failure> {
        let framed = !self.frame.is_identity();
        let mut framed_xy: Option<usize> = None;
        let mut framed_z: Option<usize> = None;
        let mut framed_ij: Option<(usize, [f64; 2])> = None;
        // Where the block starts: an arc centre given absolute is taken from there.
        let start = self.position;
        // Under a frame in G91: the block's increments (workpiece coordinates).
        let mut increment = [0.0f64; 3];
        for (offset, letter, value) in words {
            let axis = "XYZ".find(letter);
            let mut v = self.coordinate(offset, letter, value, &start)?;
            if let Some(a) = axis {
                let base = self.incremental_base[a].or(start[a]);
                self.position[a] = if self.absolute {
                    Some(v)
                } else {
                    base.map(|p| p + v)
                };
                self.incremental_base[a] = self.position[a];
                if framed {
                    increment[a] = if self.absolute { 0.0 } else { v };
                    let first = if a == 2 {
                        &mut framed_z
                    } else {
                        &mut framed_xy
                    };
                    first.get_or_insert(offset);
                    continue;
                }
                // G91 without a frame: the increment, plus the offset a frame left behind.
                if let (false, Some(b), Some(p)) = (self.absolute, base, start[a])
                    && b != p
                {
                    v += b - p;
                }
            }
            if framed && (letter == 'I' || letter == 'J') {
                let slot = framed_ij.get_or_insert((offset, [0.0; 2]));
                slot.1[usize::from(letter == 'J')] = v;
                continue;
            }
            let (letter, v) = match (letter, dwell) {
                // `G4 F2`: two seconds' dwell; RS274 gives it as P.
                ('F', true) => ('P', v),
                ('D', _) => continue,
                ('M', _) if v == 17.0 => ('M', 2.0),
                // An arc's radius scaled with the frame (alike on X and Y, or refused).
                ('R', _) if framed => ('R', v * self.frame.scale[0].abs()),
                other => (other.0, v),
            };
            if !out.plain {
                pieces.push((offset, Piece::Word(letter, v)));
            }
        }
        if let Some(offset) = framed_xy {
            let [x, y] = if self.absolute {
                let p = self.framed_target(offset)?;
                [p[0], p[1]]
            } else if let (Ok(to), [Some(x), Some(y), Some(z)]) =
                (self.framed_target(offset), start)
            {
                // From where the block starts to its end, both in the program's coordinates.
                let from = self.frame.place([x, y, z]);
                [to[0] - from[0], to[1] - from[1]]
            } else {
                self.frame.turn([increment[0], increment[1]])
            };
            pieces.push((offset, Piece::Word('X', x)));
            pieces.push((offset, Piece::Word('Y', y)));
        }
        if let Some(offset) = framed_z {
            let z = if self.absolute {
                self.framed_target(offset)?[2]
            } else if let (Ok(to), [Some(x), Some(y), Some(z)]) =
                (self.framed_target(offset), start)
            {
                to[2] - self.frame.place([x, y, z])[2]
            } else {
                increment[2]
            };
            pieces.push((offset, Piece::Word('Z', z)));
        }
        if let Some((offset, ij)) = framed_ij {
            let [i, j] = self.frame.turn(ij);
            pieces.push((offset, Piece::Word('I', i)));
            pieces.push((offset, Piece::Word('J', j)));
        }
        Ok(())
    }

    /// A word's value in the block's mode: `AC`/`IC` resolved against the position (or,
    /// for an arc centre, the block's start `start`).
    fn coordinate(
        &self,
        offset: usize,
        letter: char,
        value: Value,
        start: &[Option<f64>; 3],
    ) -> Result<f64, Failure> {
        let axis = "XYZ".find(letter);
        let centre = "IJK".find(letter);
        Ok(match (value, axis) {
            (Value::Number(v), _) => v,
            // A centre is incremental to the start already; `AC` gives it absolute.
            (Value::Incremental(v), None) if centre.is_some() => v,
            (Value::Absolute(v), None) if centre.is_some() => {
                let c = centre.unwrap_or(0);
                let at = start[c].ok_or_else(|| unknown_position(offset, letter))?;
                v - at
            }
            (Value::Absolute(_) | Value::Incremental(_), None) => {
                return Err(refuse(offset, &format!("{letter}=AC/IC"), CENTRE_AC_IC));
            }
            (Value::Absolute(v), Some(a)) if !self.absolute => {
                let at = self.position[a].ok_or_else(|| unknown_position(offset, letter))?;
                v - at
            }
            (Value::Incremental(v), Some(a)) if self.absolute => {
                let at = self.incremental_base[a]
                    .or(self.position[a])
                    .ok_or_else(|| unknown_position(offset, letter))?;
                at + v
            }
            (Value::Absolute(v) | Value::Incremental(v), Some(_)) => v,
        })
    }
}

/// The pieces of a rewritten line, in the order written (a stable sort keeps a mode code
/// after the code it follows).
fn write_pieces(mut pieces: Vec<(usize, Piece)>, out: &mut Rewritten) {
    pieces.sort_by_key(|p| p.0);
    for (offset, piece) in pieces {
        let text = match piece {
            Piece::Text(t) => t.to_string(),
            Piece::G(g) => format!("G{g}"),
            // Rounded to 0.1 nm: a turned coordinate's last bits are not the program's.
            Piece::Word(letter, v) => format!("{letter}{}", (v * 1e7).round() / 1e7 + 0.0),
            Piece::Blend(d) => format!("G64 P{d}"),
        };
        out.push(offset, &text);
    }
}

impl Translator {
    /// Takes the tool's place (program coordinates) for the axes whose programmed position
    /// is not known: before the program first names them, and after a move in machine
    /// coordinates — the control always knows where its axes stand.
    pub(crate) fn where_unknown(&mut self, place: [f64; 3]) {
        for (known, at) in self.position.iter_mut().zip(place) {
            known.get_or_insert(at);
        }
    }

    /// The block's target (workpiece coordinates, as tracked) in the program's.
    fn framed_target(&self, offset: usize) -> Result<[f64; 3], Failure> {
        let [Some(x), Some(y), Some(z)] = self.position else {
            return Err((
                offset,
                GcodeErrorKind::Invalid(
                    "a move under a frame needs X, Y and Z set before it (the frame turns \
                     them together)"
                        .into(),
                ),
            ));
        };
        Ok(self.frame.place([x, y, z]))
    }

    /// Applies a frame instruction whose arguments are the block's X, Y, Z and `RPL=`;
    /// the block's other words.
    fn change_frame(
        &mut self,
        change: FrameChange,
        words: Vec<(usize, char, Value)>,
    ) -> Result<Vec<(usize, char, Value)>, Failure> {
        let mut args = [0.0f64; 3];
        let mut given = [false; 3];
        let mut rest = Vec::new();
        for (offset, letter, value) in words {
            let axis = match letter {
                'X' => 0,
                'Y' => 1,
                'Z' => 2,
                _ => {
                    rest.push((offset, letter, value));
                    continue;
                }
            };
            let Value::Number(v) = value else {
                return Err(refuse(
                    offset,
                    "AC/IC",
                    "a frame's values are plain numbers",
                ));
            };
            if matches!(change, FrameChange::Rot | FrameChange::ARot) && axis != 2 {
                return Err(refuse(
                    offset,
                    &format!("{letter}{v}"),
                    "a rotation about X or Y leaves the XY plane",
                ));
            }
            if matches!(change, FrameChange::Scale | FrameChange::AScale)
                && !(v.is_finite() && v != 0.0)
            {
                return Err((
                    offset,
                    GcodeErrorKind::Invalid(format!("{letter}{v}: a scale factor is not 0")),
                ));
            }
            args[axis] = v;
            given[axis] = true;
        }
        let angle = self.rpl.take().unwrap_or(args[2]);
        // The workpiece position where the axes are, kept across the change.
        let at = match self.position {
            [Some(x), Some(y), Some(z)] => Some(self.frame.place([x, y, z])),
            _ => None,
        };
        let old = self.frame;
        let per_axis = |f: &dyn Fn(usize) -> f64| [f(0), f(1), f(2)];
        self.frame = match change {
            FrameChange::Trans => Frame {
                shift: args,
                ..Frame::default()
            },
            FrameChange::ATrans => {
                let [x, y] = old.turn([args[0], args[1]]);
                Frame {
                    shift: [
                        old.shift[0] + x,
                        old.shift[1] + y,
                        old.shift[2] + old.scale[2] * args[2],
                    ],
                    ..old
                }
            }
            FrameChange::Rot => Frame {
                angle_deg: angle,
                ..Frame::default()
            },
            FrameChange::ARot => Frame {
                angle_deg: old.angle_deg + angle,
                ..old
            },
            FrameChange::Scale => Frame {
                scale: per_axis(&|a| if given[a] { args[a] } else { 1.0 }),
                ..Frame::default()
            },
            FrameChange::AScale => Frame {
                scale: per_axis(&|a| old.scale[a] * if given[a] { args[a] } else { 1.0 }),
                ..old
            },
            FrameChange::Mirror => Frame {
                scale: per_axis(&|a| if given[a] { -1.0 } else { 1.0 }),
                ..Frame::default()
            },
            FrameChange::AMirror => Frame {
                scale: per_axis(&|a| old.scale[a] * if given[a] { -1.0 } else { 1.0 }),
                ..old
            },
        };
        if let Some(p) = at {
            // The same point of the machine, in the new frame's workpiece coordinates.
            self.position = self.frame.back(p).map(Some);
        }
        Ok(rest)
    }
}

fn unknown_position(offset: usize, letter: char) -> Failure {
    (
        offset,
        GcodeErrorKind::Invalid(format!(
            "{letter}=AC()/IC() against a position the program has not set yet"
        )),
    )
}

/// Skips `( … )` after `MSG` (quotes may hold parentheses); the offset after it.
fn skip_parenthesised(
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

#[cfg(test)]
mod tests {
    use super::*;

    fn rewrite(lines: &[&str]) -> Vec<String> {
        let mut t = Translator::default();
        lines
            .iter()
            .map(|l| t.rewrite(l).unwrap().text(l).to_string())
            .collect()
    }

    #[test]
    fn the_dialect_is_told_by_extension_header_or_codes() {
        assert_eq!(Dialect::of("part.MPF", ""), Dialect::Sinumerik);
        assert_eq!(Dialect::of("p.nc", "%_N_PART_MPF\n"), Dialect::Sinumerik);
        assert_eq!(Dialect::of("p.nc", "N10 G710 G90\n"), Dialect::Sinumerik);
        assert_eq!(
            Dialect::of("p.nc", "G21 G90 (a comment)\nG1 X1 F100\n"),
            Dialect::Rs274
        );
        // A tool's corner radius in an RS274 comment is no SINUMERIK code.
        assert_eq!(
            Dialect::of("p.nc", "(T1 D=6 CR=0.5)\nG21 G1 X1 F100\n"),
            Dialect::Rs274
        );
        assert_eq!(
            Dialect::of("p.nc", "N10 MSG(\"hello\")\n"),
            Dialect::Sinumerik
        );
    }

    #[test]
    fn words_codes_and_modes_are_rewritten() {
        let out = rewrite(&[
            "%_N_PART_MPF",
            ";$PATH=/_N_WKS_DIR/_N_PART_WPD",
            "N10 G710 G17 G90 G64 ; metric",
            "N20 G0 X=0 Y0 MSG(\"roughing (1)\")",
            "N30 G1 X=IC(10) Y=AC(5) F500",
            "N40 G2 X20 Y15 CR=5 G9",
            "N50 G641 ADIS=0.2 G3 X30 Y5 I0 J-10",
            "N60 G4 F1.5",
            "M30",
        ]);
        assert_eq!(
            out,
            vec![
                "",
                ";$PATH=/_N_WKS_DIR/_N_PART_WPD",
                "N10 G21 G17 G90 G64",
                "N20 G0 X0 Y0",
                "N30 G1 X10 Y5 F500",
                "N40 G2 X20 Y15 R5 G61",
                "N50 G64 P0.2 G3 X30 Y5 I0 J-10",
                "N60 G4 P1.5",
                "M30"
            ]
        );
    }

    #[test]
    fn what_is_not_read_is_refused_at_its_column() {
        for (line, column, word) in [
            ("N10 DEF STRING[8] A", 4, "DEF STRING"),
            ("N10 GOTOF END", 4, "GOTOF"),
            ("N10 ROTS X30 Y45", 4, "ROTS"),
            ("N10 CYCLE72(\"C\")", 4, "CYCLE72(\"C\")"),
            ("N10 X=$P_EP[X]", 6, "$P_EP"),
            ("N10 MCALL MYSUB", 4, "MCALL"),
            ("N10 G2 X1 F=AC(5)", 10, "F=AC/IC"),
        ] {
            let mut t = Translator {
                position: [Some(0.0); 3],
                ..Translator::default()
            };
            let (offset, kind) = t.rewrite(line).unwrap_err();
            assert_eq!(offset, column, "{line}: {kind}");
            let GcodeErrorKind::Unsupported { word: w, .. } = kind else {
                panic!("{line}: {kind}");
            };
            assert_eq!(w, word, "{line}");
        }
    }

    #[test]
    fn calls_are_read_with_their_arguments_and_runs() {
        let mut t = Translator::default();
        let call = |t: &mut Translator, line: &str| {
            t.rewrite(line).unwrap_or_else(|e| panic!("{line}: {e:?}"));
            t.take_call().unwrap()
        };
        let c = call(&mut t, "N10 L0123 P3");
        assert_eq!((c.name.as_str(), c.repeat, c.offset), ("L0123", 3, 4));
        t.rewrite("R2=4").unwrap();
        let c = call(&mut t, "POCKET_2(1.5, , R2*2,)");
        assert_eq!(c.name, "POCKET_2");
        assert_eq!(c.args, vec![Some(1.5), None, Some(8.0), None]);
        let c = call(&mut t, "CALL \"/_N_SPF_DIR/_N_ROUGH_SPF\"");
        assert_eq!(c.name, "ROUGH");
        assert!(t.rewrite("L1 P0").is_err());
        assert!(t.rewrite("A(1 2)").is_err());
        assert!(t.rewrite("L1 L2").is_err());
        t.take_call();
        // A subprogram's M17 and RET return; the main program's end it.
        t.in_subprogram = true;
        assert_eq!(t.rewrite("G1 X1 M17").unwrap().text, "G1 X1");
        assert!(t.take_returned());
        t.in_subprogram = false;
        assert_eq!(t.rewrite("RET").unwrap().text, "M2");
        assert!(!t.take_returned());
    }

    #[test]
    fn parameters_and_variables_are_evaluated_where_they_are_read() {
        let out = rewrite(&[
            "N10 DEF REAL SIDE=40, HALF",
            "N20 R1=5 HALF=SIDE/2",
            "N30 G1 X=SIDE Y=HALF+R1 F=R1*200",
            "N40 R1=R1*2 G1 X=IC(-R1)",
        ]);
        assert_eq!(
            out,
            vec!["N10 G61", "N20", "N30 G1 X40 Y25 F1000", "N40 G1 X30"]
        );
        let mut t = Translator::default();
        let (offset, kind) = t.rewrite("N10 G1 X=R7").unwrap_err();
        assert_eq!(offset, 9, "{kind}");
    }

    #[test]
    fn frames_turn_and_shift_the_workpiece_into_the_program() {
        let out = rewrite(&[
            "G90 G0 X0 Y0 Z0",
            "TRANS X10 Y5",
            "G1 X10 F100",
            "AROT RPL=90",
            "G1 X20",
            "G91 G1 X5",
            "G90 G2 X25 Y0 I0 J5",
            "TRANS",
            "G1 X0 Y0",
        ]);
        assert_eq!(
            out,
            vec![
                "G90 G61 G0 X0 Y0 Z0",
                "",
                "G1 X20 Y0 F100",
                "",
                "G1 X20 Y25",
                "G91 G1 X0 Y5",
                "G90 G2 X10 Y30 I-5 J0",
                "",
                "G1 X0 Y0"
            ]
        );
    }

    #[test]
    fn an_incremental_coordinate_needs_a_known_position() {
        let mut t = Translator::default();
        assert!(t.rewrite("N10 G1 X=IC(5) F100").is_err());
    }

    #[test]
    fn exact_stop_in_one_block_restores_the_path_mode_after_it() {
        let out = rewrite(&["G64", "G1 X1 F100 G9", "G1 X2"]);
        assert_eq!(out, vec!["G64", "G1 X1 F100 G61", "G1 G64 X2"]);
    }
}
