//! The SINUMERIK 840D dialect, read by rewriting each line into the words of the RS274/NGC
//! front end, so that both dialects share one interpreter, one program model and one kind of
//! error (file, line, column — the column of the SINUMERIK text).
//!
//! What is read (SINUMERIK 840D sl programming manual, *Fundamentals*, for the meaning of each
//! command):
//! - `;` comments, `%_N_NAME_MPF` / `_SPF` headers, `N` and `:` block numbers, labels;
//! - addresses written `X10` or `X=10`, and `X=AC(…)` / `X=IC(…)` for one coordinate
//!   absolute or incremental against the block's `G90`/`G91`;
//! - `G710`/`G700` (metric or inch, feeds included) and `G71`/`G70` (geometric data only,
//!   feeds staying in the basic system, taken as metric) as `G21`/`G20`;
//! - arcs in the working plane (`G17`, `G18`, `G19`) by centre (`I`, `J`, `K`), by radius
//!   (`CR=`, negative above 180°) or by opening angle (`AR=`, with the end point or the
//!   centre), helical with `TURN=` full turns more (RS274/NGC's `P`, one more);
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
//!
//! Its parts: `words` reads a block's words and values, `calls` its subprogram call,
//! `frame` the programmable frames, `emit` writes the block as RS274/NGC; `flow`
//! matches and runs program control, `run` runs a program with its subprograms.

mod calls;
mod emit;
mod expr;
pub(crate) mod flow;
mod frame;
pub(crate) mod run;
mod words;

use super::error::GcodeErrorKind;
use calls::Call;
use emit::PathMode;
use expr::Variables;
use frame::{Frame, FrameChange};
use words::{Value, after_equals, number};

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
    /// Whether feeds stay in the basic system from this line on (`G70`/`G71`: geometric
    /// data only switch) or follow the inch/metric setting (`G700`/`G710`).
    pub feed_in_basic_system: Option<bool>,
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
            feed_in_basic_system: None,
            plain: true,
        }
    }
}

impl Rewritten {
    /// The RS274/NGC text of `line`: the line itself where it is plain.
    pub(crate) fn text<'a>(&'a self, line: &'a str) -> &'a str {
        if self.plain { line } else { &self.text }
    }

    /// The SINUMERIK line's byte offset for an offset in the rewritten text.
    pub(crate) fn original_offset(&self, rewritten: usize) -> usize {
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
    /// The working plane (`G17`, `G18`, `G19`): arcs and opening angles lie in it.
    plane: crate::path::Plane,
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
            plane: crate::path::Plane::Xy,
        }
    }
}

/// A rewriting failure: byte offset in the SINUMERIK line and the problem.
pub(crate) type Failure = (usize, GcodeErrorKind);

fn refuse(offset: usize, word: &str, reason: &'static str) -> Failure {
    (
        offset,
        GcodeErrorKind::Unsupported {
            word: word.to_string(),
            reason,
        },
    )
}

impl Translator {
    /// Rewrites one SINUMERIK line into RS274/NGC words.
    pub(crate) fn rewrite(&mut self, line: &str) -> Result<Rewritten, Failure> {
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
