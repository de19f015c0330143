//! Diagnostics of the G-code front end: every error names the file, the line, the column and
//! the one thing that is wrong there.

use std::fmt;

/// Where in a program a diagnostic points: 1-based line and column (in characters).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct SourcePos {
    /// 1-based line number in the file.
    pub line: u32,
    /// 1-based column (characters, not bytes) of the offending word.
    pub column: u32,
}

/// The one problem a [`GcodeError`] reports.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GcodeErrorKind {
    /// A character that starts no G-code item.
    #[error("unexpected character {}", shown_char(*.0))]
    UnexpectedChar(char),
    /// A `(` comment that is not closed on its line.
    #[error("comment opened with '(' is not closed on this line")]
    UnclosedComment,
    /// A letter without a number after it.
    #[error("word '{0}' has no value")]
    MissingValue(char),
    /// A value too large or malformed.
    #[error("word '{letter}' has a malformed value '{text}'")]
    BadNumber {
        /// The word letter.
        letter: char,
        /// The text that failed to parse.
        text: String,
    },
    /// The same letter twice in one block.
    #[error("word '{0}' appears twice in one block")]
    DuplicateWord(char),
    /// Two codes of the same modal group in one block.
    #[error("{first} and {second} are in the same modal group and cannot share a block")]
    ModalGroupConflict {
        /// The first code, e.g. `G1`.
        first: String,
        /// The second code, e.g. `G2`.
        second: String,
    },
    /// A construct that would change the XY path or its timing in a way this predictor does
    /// not model: refused rather than silently skipped.
    #[error("{word}: {reason}")]
    Unsupported {
        /// The word as written, e.g. `G41` or `#1`.
        word: String,
        /// Why it is refused.
        reason: &'static str,
    },
    /// A G or M code that does not exist.
    #[error("unknown code {0}")]
    UnknownCode(String),
    /// An error inside a bracketed expression.
    #[error("expression: {0}")]
    Expression(String),
    /// A word that is not allowed with the block's codes.
    #[error("{0}")]
    Invalid(String),
    /// An arc whose end does not lie on the circle through its start.
    #[error(
        "arc end radius {r_end_mm:.4} mm differs from start radius {r_start_mm:.4} mm by \
         {diff_mm:.4} mm (tolerance {tolerance_mm:.4} mm and 0.1 % of the radius)"
    )]
    ArcRadiusMismatch {
        /// Radius from the centre to the start point.
        r_start_mm: f64,
        /// Radius from the centre to the end point.
        r_end_mm: f64,
        /// Their difference.
        diff_mm: f64,
        /// The absolute tolerance in force.
        tolerance_mm: f64,
    },
    /// An R-format arc whose radius cannot reach its end point.
    #[error("arc radius {r_mm:.4} mm is too small to reach the end point {chord_mm:.4} mm away")]
    ArcRadiusTooSmall {
        /// The programmed radius.
        r_mm: f64,
        /// Start-to-end distance.
        chord_mm: f64,
    },
    /// An arc with a (near) zero radius.
    #[error("arc radius is zero")]
    ZeroRadiusArc,
    /// An R-format arc whose end point equals its start point: the circle is undefined.
    #[error(
        "R-format arc ends where it starts: the circle is undefined (use I/J for a full circle)"
    )]
    RArcFullCircle,
    /// A feed move with no feed rate set.
    #[error("{0} with a zero feed rate: program F first")]
    ZeroFeed(String),
    /// Too many errors: the rest were not reported.
    #[error("too many errors; stopped after {0}")]
    TooMany(usize),
}

/// One G-code diagnostic: file, line, column and what is wrong.
#[derive(Debug, Clone, PartialEq)]
pub struct GcodeError {
    /// The program's file name as the user gave it.
    pub file: String,
    /// Where.
    pub pos: SourcePos,
    /// What.
    pub kind: GcodeErrorKind,
}

impl fmt::Display for GcodeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}:{}:{}: {}",
            self.file, self.pos.line, self.pos.column, self.kind
        )
    }
}

impl std::error::Error for GcodeError {}

/// All errors found in a program, in source order (capped, see
/// [`crate::gcode::MAX_REPORTED_ERRORS`]).
#[derive(Debug, Clone, PartialEq)]
pub struct GcodeErrors(pub Vec<GcodeError>);

impl GcodeErrors {
    /// The first error (there is always at least one).
    pub fn first(&self) -> &GcodeError {
        &self.0[0]
    }
}

impl fmt::Display for GcodeErrors {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, e) in self.0.iter().enumerate() {
            if i > 0 {
                writeln!(f)?;
            }
            write!(f, "{e}")?;
        }
        Ok(())
    }
}

impl std::error::Error for GcodeErrors {}

/// A warning about a construct that is legal but deserves a look (badly conditioned arcs,
/// clamped feeds and the like).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Warning {
    /// Source line of the block concerned (0 when it concerns the whole program).
    pub line: u32,
    /// What to look at.
    pub message: String,
}

impl fmt::Display for Warning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.line > 0 {
            write!(f, "line {}: {}", self.line, self.message)
        } else {
            write!(f, "{}", self.message)
        }
    }
}

/// A character as an error shows it: quoted where it prints, by its code where it does not (a
/// control or format character sent raw to the terminal would act, not show).
fn shown_char(c: char) -> String {
    // Controls, and the format characters that reorder or hide text on a terminal.
    let invisible = matches!(
        c,
        '\u{200B}'..='\u{200F}' | '\u{202A}'..='\u{202E}' | '\u{2066}'..='\u{2069}' | '\u{FEFF}'
    );
    if c.is_control() || invisible {
        format!("U+{:04X} (a character that does not print)", c as u32)
    } else {
        format!("'{c}'")
    }
}
