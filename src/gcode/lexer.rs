//! Line lexer: one source line in, its words out.
//!
//! The grammar follows RS274/NGC as LinuxCNC reads it: letters in either case, optional
//! spaces between a letter and its value, numbers in every legal form (`.5`, `5.`, `-0.5`,
//! `+3`), bracketed constant expressions, `( … )` and `; …` comments, `/` block delete and
//! `%` tape markers. Values are parsed exactly as `str::parse::<f64>` parses the lexeme.
//! Parameters (`#`), o-word control flow and polar coordinates are refused here, with the
//! byte offset of the construct, because nothing downstream could model them faithfully.

use nom::{
    IResult, Parser,
    branch::alt,
    bytes::complete::{tag, take_till, take_while},
    character::complete::{char, digit1, one_of},
    combinator::{opt, recognize},
};

use super::error::GcodeErrorKind;
use super::expr;

/// One word of a block: an upper-case letter and its value.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Word {
    /// Upper-case ASCII letter.
    pub letter: u8,
    /// The value, as `str::parse::<f64>` reads the written number (or the expression's value).
    pub value: f64,
    /// Byte offset of the letter in its line.
    pub offset: u32,
}

/// A lexed line, reused from line to line so that lexing does not allocate.
#[derive(Debug, Default, Clone)]
pub struct LexedLine {
    /// The line began with `/` (block delete).
    pub block_delete: bool,
    /// The line is a `%` tape marker.
    pub tape_marker: bool,
    /// The words in source order.
    pub words: Vec<Word>,
}

/// A lexing failure: byte offset in the line and what went wrong.
#[derive(Debug, Clone, PartialEq)]
pub struct LexError {
    /// Byte offset in the line.
    pub offset: usize,
    /// The problem.
    pub kind: GcodeErrorKind,
}

/// Lexes one line (without its line terminator) into `out`.
pub(crate) fn lex_line(line: &str, out: &mut LexedLine) -> Result<(), LexError> {
    out.block_delete = false;
    out.tape_marker = false;
    out.words.clear();
    let mut rest = skip_blanks(line);
    if let Some(r) = rest.strip_prefix('%') {
        // A tape marker: the rest of the line is ignored, as RS274/NGC does.
        let _ = r;
        out.tape_marker = true;
        return Ok(());
    }
    if let Some(r) = rest.strip_prefix('/') {
        out.block_delete = true;
        rest = r;
    }
    loop {
        rest = skip_blanks(rest);
        let offset = line.len() - rest.len();
        let Some(c) = rest.chars().next() else {
            return Ok(());
        };
        match c {
            '(' => rest = skip_paren_comment(rest).map_err(|kind| LexError { offset, kind })?,
            ';' => return Ok(()),
            c if c.is_ascii_alphabetic() => {
                rest = lex_word(line, rest, out)?;
            }
            '#' => {
                return Err(LexError {
                    offset,
                    kind: GcodeErrorKind::Unsupported {
                        word: "#".into(),
                        reason: "parameters are not supported: the path must be explicit",
                    },
                });
            }
            '@' | '^' => {
                return Err(LexError {
                    offset,
                    kind: GcodeErrorKind::Unsupported {
                        word: c.to_string(),
                        reason: "polar coordinates are not supported",
                    },
                });
            }
            other => {
                return Err(LexError {
                    offset,
                    kind: GcodeErrorKind::UnexpectedChar(other),
                });
            }
        }
    }
}

fn skip_blanks(s: &str) -> &str {
    s.trim_start_matches([' ', '\t', '\r', '\u{feff}'])
}

/// Skips a `( … )` comment, returning what follows it.
fn skip_paren_comment(s: &str) -> Result<&str, GcodeErrorKind> {
    let body = &s[1..];
    match body.find(')') {
        Some(end) => Ok(&body[end + 1..]),
        None => Err(GcodeErrorKind::UnclosedComment),
    }
}

/// Lexes one word starting at `rest` (which begins with a letter) and pushes it.
fn lex_word<'a>(line: &'a str, rest: &'a str, out: &mut LexedLine) -> Result<&'a str, LexError> {
    let offset = line.len() - rest.len();
    let letter = rest.as_bytes()[0].to_ascii_uppercase();
    let after_letter = skip_blanks(&rest[1..]);
    if letter == b'O' {
        return lex_o_word(line, after_letter, offset);
    }
    let (remaining, value) = real_value(line, letter, after_letter)?;
    out.words.push(Word {
        letter,
        value,
        offset: offset as u32,
    });
    Ok(remaining)
}

/// A value: a number, a bracketed expression or a unary function of one, with an optional sign.
fn real_value<'a>(line: &'a str, letter: u8, s: &'a str) -> Result<(&'a str, f64), LexError> {
    let offset = line.len() - s.len();
    if let Ok((remaining, lexeme)) = number_lexeme(s) {
        return lexeme
            .parse::<f64>()
            .map(|v| (remaining, v))
            .map_err(|_| LexError {
                offset,
                kind: GcodeErrorKind::BadNumber {
                    letter: letter as char,
                    text: lexeme.to_string(),
                },
            });
    }
    match expr::signed_expression(s) {
        Ok(Some((remaining, value))) => Ok((remaining, value)),
        Ok(None) => Err(LexError {
            offset,
            kind: missing_value_or_param(letter, s),
        }),
        Err(e) => Err(LexError {
            offset: offset + e.offset,
            kind: e.kind,
        }),
    }
}

fn missing_value_or_param(letter: u8, s: &str) -> GcodeErrorKind {
    let s = s.trim_start_matches(['+', '-']);
    if s.starts_with('#') {
        GcodeErrorKind::Unsupported {
            word: format!("{}#", letter as char),
            reason: "parameters are not supported: the path must be explicit",
        }
    } else {
        GcodeErrorKind::MissingValue(letter as char)
    }
}

/// A decimal number as RS274/NGC writes it: optional sign, digits with an optional point, or
/// a point followed by digits. No exponent (`E` is a word letter).
///
/// `opt(digit1)` rather than `digit0`: inside `recognize`, nom 8's `digit0` at the end of the
/// input makes `recognize` drop the digits it consumed (rust-bakery/nom#1876).
pub(crate) fn number_lexeme(i: &str) -> IResult<&str, &str> {
    recognize((
        opt(one_of("+-")),
        alt((
            recognize((digit1, opt((char('.'), opt(digit1))))),
            recognize((char('.'), digit1)),
        )),
    ))
    .parse(i)
}

/// `O` words: a bare program number (`O1000`) is accepted and ignored; anything that makes
/// it control flow (`O100 sub`, `O<name> call`) is refused.
fn lex_o_word<'a>(line: &'a str, s: &'a str, offset: usize) -> Result<&'a str, LexError> {
    let unsupported = |word: &str| LexError {
        offset,
        kind: GcodeErrorKind::Unsupported {
            word: word.to_string(),
            reason: "o-word subroutines and control flow are not supported",
        },
    };
    let parsed: IResult<&str, &str> = alt((
        recognize((tag("<"), take_till(|c| c == '>'), tag(">"))),
        digit1,
    ))
    .parse(s);
    let Ok((after_name, name)) = parsed else {
        return Err(LexError {
            offset,
            kind: GcodeErrorKind::MissingValue('O'),
        });
    };
    let after_name = skip_blanks(after_name);
    let keyword: IResult<&str, &str> = take_while(|c: char| c.is_ascii_alphabetic())(after_name);
    let (_, kw) = keyword.unwrap_or((after_name, ""));
    if name.starts_with('<') || !kw.is_empty() {
        let end = line.len() - after_name.len() + kw.len();
        return Err(unsupported(line[offset..end].trim()));
    }
    Ok(after_name)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// A character that starts nothing is named; one that does not print, by its code (sent
    /// raw, an escape would act on the terminal instead of showing).
    #[test]
    fn an_unexpected_character_is_shown_as_it_can_be_read() {
        let message = |line: &str| {
            let mut out = LexedLine::default();
            lex_line(line, &mut out).unwrap_err().kind.to_string()
        };
        assert_eq!(message("G1 X1 ?"), "unexpected character '?'");
        let escaped = message("G1 X1 \u{1b}[31m");
        assert!(
            escaped.contains("U+001B") && !escaped.contains('\u{1b}'),
            "{escaped:?}"
        );
        let reversed = message("G1 X1 \u{202e}");
        assert!(reversed.contains("U+202E"), "{reversed:?}");
    }

    fn words(line: &str) -> Vec<(char, f64)> {
        let mut out = LexedLine::default();
        lex_line(line, &mut out).unwrap();
        out.words
            .iter()
            .map(|w| (w.letter as char, w.value))
            .collect()
    }

    #[test]
    fn packed_words_without_spaces() {
        assert_eq!(
            words("G01X10Y-5.F600"),
            vec![('G', 1.0), ('X', 10.0), ('Y', -5.0), ('F', 600.0)]
        );
    }

    #[test]
    fn every_number_form() {
        assert_eq!(
            words("x.5 Y5. z-0.5 i+3"),
            vec![('X', 0.5), ('Y', 5.0), ('Z', -0.5), ('I', 3.0)]
        );
    }

    #[test]
    fn comments_and_block_delete() {
        let mut out = LexedLine::default();
        lex_line("/N10 G0 (rapid) X1 ; the rest", &mut out).unwrap();
        assert!(out.block_delete);
        assert_eq!(out.words.len(), 3);
        assert_eq!(out.words[2].offset, 16);
    }

    #[test]
    fn unclosed_comment_points_at_it() {
        let mut out = LexedLine::default();
        let e = lex_line("G1 X1 (oops", &mut out).unwrap_err();
        assert_eq!(e.offset, 6);
        assert_eq!(e.kind, GcodeErrorKind::UnclosedComment);
    }

    #[test]
    fn parameters_and_subroutines_are_refused() {
        let mut out = LexedLine::default();
        assert!(matches!(
            lex_line("G1 X#1", &mut out).unwrap_err().kind,
            GcodeErrorKind::Unsupported { .. }
        ));
        assert!(matches!(
            lex_line("o100 sub", &mut out).unwrap_err().kind,
            GcodeErrorKind::Unsupported { .. }
        ));
        assert!(lex_line("O1000 (program number)", &mut out).is_ok());
    }

    /// Regression: with `digit0` inside `recognize`, "Y-59.286" at the end of a line lexed as
    /// -59.0 (rust-bakery/nom#1876), which moved arc end points and broke radius checks.
    #[test]
    fn fraction_digits_at_end_of_line_are_kept() {
        assert_eq!(
            words("X55.038 Y-59.286"),
            vec![('X', 55.038), ('Y', -59.286)]
        );
        assert_eq!(number_lexeme("5."), Ok(("", "5.")));
        assert_eq!(number_lexeme("-.25"), Ok(("", "-.25")));
    }

    #[test]
    fn expressions_are_values() {
        assert_eq!(words("R[0.75/4]"), vec![('R', 0.75 / 4.0)]);
    }

    /// Decimal numbers in every RS274/NGC form, including large and tiny ones.
    fn number_text() -> impl Strategy<Value = String> {
        (
            prop::sample::select(vec!["", "+", "-"]),
            prop::option::of("[0-9]{1,12}"),
            prop::option::of("[0-9]{0,12}"),
        )
            .prop_map(|(sign, int, frac)| match (int, frac) {
                (Some(i), Some(f)) => format!("{sign}{i}.{f}"),
                (Some(i), None) => format!("{sign}{i}"),
                (None, Some(f)) if !f.is_empty() => format!("{sign}.{f}"),
                _ => format!("{sign}0"),
            })
    }

    /// Fragments real and broken programs are made of.
    fn token() -> impl Strategy<Value = String> {
        prop_oneof![
            prop::sample::select(vec![
                "G0",
                "G1",
                "G2",
                "G3",
                "G4",
                "G17",
                "G18",
                "G20",
                "G21",
                "G28",
                "G40",
                "G41",
                "G43",
                "G53",
                "G54",
                "G61",
                "G64",
                "G80",
                "G81",
                "G90",
                "G90.1",
                "G91",
                "G91.1",
                "G92",
                "G10",
                "L2",
                "L20",
                "M2",
                "M3",
                "M30",
                "M6",
                "M99",
                "O100",
                "sub",
                "call",
                "#1",
                "[",
                "]",
                "[1+2]",
                "SIN[30]",
                "ATAN[1]/[2]",
                "(",
                ")",
                "(comment)",
                ";",
                "/",
                "%",
                " ",
                "\t",
                "\n",
                "\r\n",
                "@",
                "^",
                "$",
                "P",
                "R",
                "Q",
                "E",
                "**",
                "MOD",
            ])
            .prop_map(str::to_string),
            (
                prop::sample::select(vec![
                    'X', 'Y', 'Z', 'I', 'J', 'K', 'R', 'F', 'P', 'x', 'g', 'A'
                ]),
                number_text()
            )
                .prop_map(|(l, n)| format!("{l}{n}")),
            any::<char>().prop_map(|c| c.to_string()),
        ]
    }

    // Every number is read exactly as `str::parse::<f64>` reads the same text.
    proptest! {
        #![proptest_config(ProptestConfig { cases: 2000, ..ProptestConfig::default() })]

        #[test]
        fn numbers_read_exactly_as_str_parse(n in number_text(), letter in prop::sample::select(vec!['X', 'y', 'F', 'r'])) {
            let mut out = LexedLine::default();
            lex_line(&format!("{letter}{n}"), &mut out).unwrap();
            let expected: f64 = n.parse().unwrap();
            prop_assert_eq!(out.words.len(), 1);
            prop_assert_eq!(out.words[0].value.to_bits(), expected.to_bits());
            prop_assert_eq!(out.words[0].letter, letter.to_ascii_uppercase() as u8);
        }

        #[test]
        fn packed_words_split_where_letters_start(a in number_text(), b in number_text()) {
            let mut out = LexedLine::default();
            lex_line(&format!("G01X{a}Y{b}F600"), &mut out).unwrap();
            prop_assert_eq!(out.words.len(), 4);
            prop_assert_eq!(out.words[1].value.to_bits(), a.parse::<f64>().unwrap().to_bits());
            prop_assert_eq!(out.words[2].value.to_bits(), b.parse::<f64>().unwrap().to_bits());
        }

        // Whatever the lexer's tokens make, the front end reads or refuses, never panics.
        #[test]
        fn token_soups_never_panic(tokens in prop::collection::vec(token(), 0..60)) {
            let text: String = tokens.concat();
            let _ = crate::gcode::parse_program(&text, "soup.nc", &crate::gcode::InterpretOptions::default());
        }
    }
}
