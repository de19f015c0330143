//! The G-code front end: RS274/NGC-style milling programs in, an XY path out.
//!
//! [`parse_program`] lexes each line ([`lexer`]), evaluates constant expressions ([`expr`])
//! and runs the modal interpreter ([`interp`]) over the blocks. A SINUMERIK 840D program
//! ([`Dialect`], told by its extension, header or codes) is read through [`sinumerik`], which
//! rewrites each of its lines into the same words. Errors are collected per
//! block — every wrong block is reported, up to [`MAX_REPORTED_ERRORS`] — each naming the
//! file, line, column and the one problem there. No input makes it panic.

pub mod codes;
pub mod error;
pub mod expr;
pub mod interp;
pub(crate) mod lexer;
pub mod sinumerik;

pub use error::{GcodeError, GcodeErrorKind, GcodeErrors, SourcePos, Warning};
pub use interp::{CodeNote, Event, InterpretOptions, Program};
pub use sinumerik::Dialect;
pub use sinumerik::run::SourceFile;

use interp::Interpreter;
use lexer::LexedLine;

/// At most this many errors are reported for one program.
pub const MAX_REPORTED_ERRORS: usize = 20;

/// Parses and interprets a whole program. `file` names it in diagnostics.
pub fn parse_program(
    source: &str,
    file: &str,
    opts: &InterpretOptions,
) -> Result<Program, GcodeErrors> {
    let mut interp = Interpreter::new(file, opts.clone());
    interp.reserve_for(source.len());
    let mut errors = Errors {
        file,
        list: Vec::new(),
    };
    let lines: Vec<&str> = source.split('\n').collect();
    let mut sources = Vec::new();
    match opts.dialect.unwrap_or_else(|| Dialect::of(file, source)) {
        Dialect::Rs274 => run_rs274(&lines, &mut interp, &mut errors),
        Dialect::Sinumerik => {
            let folder = opts.subprogram_folder.as_deref();
            sources = sinumerik::run::run(source, &mut interp, &mut errors, folder);
        }
    }
    let count = lines.len() - usize::from(source.ends_with('\n'));
    if errors.list.is_empty() {
        let mut program = interp.finish(count);
        program.sources = sources;
        name_subprogram_warnings(&mut program);
        Ok(program)
    } else {
        Err(GcodeErrors(errors.list))
    }
}

/// Warnings about lines of a subprogram's file say which file and line, in their text.
fn name_subprogram_warnings(program: &mut Program) {
    if program.sources.is_empty() {
        return;
    }
    let warnings = std::mem::take(&mut program.warnings);
    program.warnings = warnings.into_iter().map(|w| program.placed(w)).collect();
}

/// The errors of a program, each where it is, up to [`MAX_REPORTED_ERRORS`].
pub(crate) struct Errors<'f> {
    /// The program's file.
    pub file: &'f str,
    list: Vec<GcodeError>,
}

impl Errors<'_> {
    /// Records `kind` at byte `offset` of line `index` (`text`); false once there are too
    /// many to go on.
    fn push(&mut self, index: usize, text: &str, offset: usize, kind: GcodeErrorKind) -> bool {
        let file = self.file;
        self.push_in(file, index, text, offset, kind)
    }

    /// [`Errors::push`] for a line of another file (a subprogram's).
    pub(crate) fn push_in(
        &mut self,
        file: &str,
        index: usize,
        text: &str,
        offset: usize,
        kind: GcodeErrorKind,
    ) -> bool {
        let line = u32::try_from(index + 1).unwrap_or(u32::MAX);
        let error = GcodeError {
            file: file.to_string(),
            pos: SourcePos {
                line,
                column: column_of(text, offset),
            },
            kind,
        };
        // A line run again (a loop, a subprogram called twice) fails the same way again:
        // said once.
        if self.list.contains(&error) {
            return true;
        }
        self.list.push(error);
        if self.list.len() == MAX_REPORTED_ERRORS {
            self.list.push(GcodeError {
                file: file.to_string(),
                pos: SourcePos { line, column: 1 },
                kind: GcodeErrorKind::TooMany(MAX_REPORTED_ERRORS),
            });
            return false;
        }
        true
    }
}

/// Runs an RS274/NGC program line after line. A program that opens with a `%` line (only
/// blank or comment lines before it) ends at the next `%` line: what follows is not run,
/// and lines there with anything but blanks and comments are counted for a warning.
fn run_rs274(lines: &[&str], interp: &mut Interpreter, errors: &mut Errors) {
    let mut lexed = LexedLine::default();
    let mut opened = false;
    let mut only_blank_so_far = true;
    for (index, text) in lines.iter().enumerate() {
        let line_no = u32::try_from(index + 1).unwrap_or(u32::MAX);
        let run = lexer::lex_line(text, &mut lexed)
            .map_err(|e| (e.offset, e.kind))
            .and_then(|()| {
                if lexed.tape_marker && opened {
                    return Ok(true);
                }
                opened |= lexed.tape_marker && only_blank_so_far;
                only_blank_so_far &= lexed.words.is_empty() && !lexed.tape_marker;
                interp
                    .execute(line_no, &lexed.words, lexed.block_delete)
                    .map(|()| false)
                    .map_err(|e| (e.offset as usize, e.kind))
            });
        match run {
            Ok(true) => {
                let rest = &lines[index + 1..];
                let left = rest.iter().filter(|t| !is_blank(t, &mut lexed)).count();
                interp.end_at_tape_marker(left);
                return;
            }
            Ok(false) => {}
            Err((offset, kind)) => {
                only_blank_so_far = false;
                if !errors.push(index, text, offset, kind) {
                    return;
                }
            }
        }
    }
}

/// Whether a line holds nothing but blanks and comments.
fn is_blank(text: &str, lexed: &mut LexedLine) -> bool {
    lexer::lex_line(text, lexed).is_ok() && lexed.words.is_empty() && !lexed.tape_marker
}

/// Lexes and runs one RS274/NGC line; a failure's byte offset in it.
pub(crate) fn run_line(
    interp: &mut Interpreter,
    text: &str,
    line_no: u32,
    lexed: &mut LexedLine,
) -> Result<(), (usize, GcodeErrorKind)> {
    match lexer::lex_line(text, lexed) {
        Ok(()) => interp
            .execute(line_no, &lexed.words, lexed.block_delete)
            .map_err(|e| (e.offset as usize, e.kind)),
        Err(e) => Err((e.offset, e.kind)),
    }
}

/// 1-based character column of a byte offset (clamped to the line, and to a character
/// boundary, so that any offset is safe).
fn column_of(line: &str, offset: usize) -> u32 {
    let mut end = offset.min(line.len());
    while !line.is_char_boundary(end) {
        end -= 1;
    }
    u32::try_from(line[..end].chars().count() + 1).unwrap_or(u32::MAX)
}
