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
pub mod lexer;
pub mod sinumerik;

pub use error::{GcodeError, GcodeErrorKind, GcodeErrors, SourcePos, Warning};
pub use interp::{CodeNote, Event, InterpretOptions, Program};
pub use sinumerik::Dialect;

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
    let mut lexed = LexedLine::default();
    let mut errors = Vec::new();
    let mut lines = 0usize;
    let mut sinumerik = (opts.dialect.unwrap_or_else(|| Dialect::of(file, source))
        == Dialect::Sinumerik)
        .then(sinumerik::Translator::default);
    for (index, text) in source.split('\n').enumerate() {
        lines = index + 1;
        let line_no = u32::try_from(index + 1).unwrap_or(u32::MAX);
        let result = match &mut sinumerik {
            None => run_line(&mut interp, text, line_no, &mut lexed),
            Some(translator) => translator.rewrite(text).and_then(|rewritten| {
                for w in &rewritten.warnings {
                    interp.warn(line_no, w.clone());
                }
                run_line(&mut interp, rewritten.text(text), line_no, &mut lexed)
                    .map_err(|(offset, kind)| (rewritten.original_offset(offset), kind))
            }),
        };
        if let Err((offset, kind)) = result {
            errors.push(GcodeError {
                file: file.to_string(),
                pos: SourcePos {
                    line: line_no,
                    column: column_of(text, offset),
                },
                kind,
            });
            if errors.len() == MAX_REPORTED_ERRORS {
                errors.push(GcodeError {
                    file: file.to_string(),
                    pos: SourcePos {
                        line: line_no,
                        column: 1,
                    },
                    kind: GcodeErrorKind::TooMany(MAX_REPORTED_ERRORS),
                });
                break;
            }
        }
    }
    if source.ends_with('\n') {
        lines -= 1;
    }
    if errors.is_empty() {
        Ok(interp.finish(lines))
    } else {
        Err(GcodeErrors(errors))
    }
}

/// Lexes and runs one RS274/NGC line; a failure's byte offset in it.
fn run_line(
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
