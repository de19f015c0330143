//! Running a SINUMERIK program: its lines rewritten one after the other, its program control
//! choosing the next, and its subprograms called.
//!
//! A subprogram is found, by its name, first among the programs of the same file (an archive
//! holds them one after another, each under its `%_N_NAME_SPF` header), then in the program's
//! folder (`NAME.SPF`, `NAME_SPF`, any case). It runs with its own labels and its own `DEF`
//! variables and `PROC` parameters; R-parameters and the modal state are the program's. A
//! subprogram read from the folder has its lines numbered after the main file's (the
//! program's [`SourceFile`] list says where each file's lines start), so that a report can
//! name the file and line of a move.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::rc::Rc;

use super::super::error::GcodeErrorKind;
use super::super::interp::Interpreter;
use super::super::lexer::LexedLine;
use super::super::{Errors, run_line};
use super::Translator;
use super::calls::Call;
use super::flow::Structure;

/// A file of subprograms the program calls, and where its lines are numbered.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct SourceFile {
    /// The file as found (its path).
    pub file: String,
    /// The number its first line has in the program's line numbering, less one: its line
    /// `k` is the program's line `first_line + k`.
    pub first_line: u32,
    /// How many lines it has.
    pub lines: u32,
}

/// Blocks a SINUMERIK program may run, loops, jumps and calls included, before it is taken
/// to run for ever.
const MAX_RUN_BLOCKS: usize = 20_000_000;

/// How deep calls may nest (the 840D allows 16 program levels, the main program included).
const MAX_CALL_DEPTH: usize = 15;

/// A `PROC` parameter: its name and the value it takes when a call leaves it out.
#[derive(Debug, Clone, PartialEq)]
struct Param {
    name: String,
    default: f64,
}

/// A program text that runs: the main program, or a subprogram.
#[derive(Debug)]
struct Unit {
    /// The file it is in, for errors.
    file: String,
    text: Rc<str>,
    /// Byte ranges of its lines in `text`.
    lines: Vec<(usize, usize)>,
    /// Index in its file of its first line.
    first_index: usize,
    /// The program line number of its first line, less one.
    first_number: u32,
    structure: Structure,
    params: Vec<Param>,
}

impl Unit {
    fn line(&self, k: usize) -> &str {
        let (a, b) = self.lines[k];
        &self.text[a..b]
    }
}

/// A `%` header's program: its name and kind.
#[derive(Debug, Clone, PartialEq)]
enum Header {
    Main,
    Sub(String),
    /// Initial values, definitions and the like (`_INI`, `_DEF`, `_GUD`): not a program.
    Other(String),
}

fn header(line: &str) -> Option<Header> {
    let upper = line.trim().to_ascii_uppercase();
    let name = upper.strip_prefix('%')?;
    let name = name.strip_prefix("_N_").unwrap_or(name);
    Some(if let Some(sub) = name.strip_suffix("_SPF") {
        Header::Sub(sub.to_string())
    } else if name.ends_with("_MPF") || !name.contains('_') || !upper.starts_with("%_N_") {
        Header::Main
    } else {
        Header::Other(name.to_string())
    })
}

/// A piece of the main file under one header (or before any).
struct Section {
    header: Option<Header>,
    /// Line indices: from the header (or 0) to the next header.
    start: usize,
    end: usize,
}

fn sections(lines: &[(usize, usize)], text: &str) -> Vec<Section> {
    let mut out = vec![Section {
        header: None,
        start: 0,
        end: lines.len(),
    }];
    for (k, &(a, b)) in lines.iter().enumerate() {
        if let Some(h) = header(&text[a..b]) {
            if let Some(last) = out.last_mut() {
                last.end = k;
            }
            out.push(Section {
                header: Some(h),
                start: k,
                end: lines.len(),
            });
        }
    }
    // The part before the first header, when it holds nothing but blanks and comments.
    if out.len() > 1
        && lines[..out[0].end].iter().all(|&(a, b)| {
            let code = text[a..b].split(';').next().unwrap_or("");
            code.trim().is_empty()
        })
    {
        out.remove(0);
    }
    out
}

fn line_ranges(text: &str) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut start = 0;
    for (i, c) in text.bytes().enumerate() {
        if c == b'\n' {
            out.push((start, i));
            start = i + 1;
        }
    }
    out.push((start, text.len()));
    out
}

/// Runs a SINUMERIK program whose text is `source`; the files of subprograms it read.
pub(crate) fn run(
    source: &str,
    interp: &mut Interpreter,
    errors: &mut Errors,
    folder: Option<&Path>,
) -> Vec<SourceFile> {
    let text: Rc<str> = Rc::from(source);
    let lines = line_ranges(&text);
    let main_file = errors.file.to_string();
    interp.blend_rapids();
    let mut runner = Runner {
        interp,
        errors,
        translator: Translator::default(),
        lexed: LexedLine::default(),
        loaded: HashMap::new(),
        in_file: HashMap::new(),
        broken: Vec::new(),
        main_text: Rc::clone(&text),
        main_lines: Rc::from(lines.as_slice()),
        folder: folder.map(Path::to_path_buf),
        folder_names: None,
        next_number: u32::try_from(lines.len()).unwrap_or(u32::MAX),
        run: 0,
        scopes: 0,
        sources: Vec::new(),
        stop: false,
    };
    let parts = sections(&lines, &text);
    let main = parts
        .iter()
        .position(|s| matches!(s.header, None | Some(Header::Main)))
        .unwrap_or(0);
    let unit = |s: &Section| (s.start, s.end);
    for (i, s) in parts.iter().enumerate() {
        if let (Some(Header::Sub(name)), true) = (&s.header, i != main) {
            runner.in_file.insert(name.clone(), unit(s));
        }
    }
    let Some(m) = parts.get(main) else {
        return Vec::new();
    };
    if let Some(u) = runner.unit(&main_file, &text, &lines, unit(m), 0) {
        runner.run_unit(&u, 0);
    }
    runner.note_unused(&parts, main);
    runner.sources
}

struct Runner<'r, 'f> {
    interp: &'r mut Interpreter,
    errors: &'r mut Errors<'f>,
    translator: Translator,
    lexed: LexedLine,
    /// Subprograms read so far, by name.
    loaded: HashMap<String, Rc<Unit>>,
    /// The main file's subprograms: their lines, by name.
    in_file: HashMap<String, (usize, usize)>,
    /// Subprograms that have errors of their own, reported once.
    broken: Vec<String>,
    main_text: Rc<str>,
    main_lines: Rc<[(usize, usize)]>,
    folder: Option<PathBuf>,
    /// The folder's file names, read once.
    folder_names: Option<Vec<String>>,
    /// The program line number the next file from the folder starts after.
    next_number: u32,
    run: usize,
    scopes: usize,
    sources: Vec<SourceFile>,
    /// Too many errors, a program that does not end, or its end (M2/M30) reached: nothing
    /// more runs.
    stop: bool,
}

impl Runner<'_, '_> {
    /// Records an error at line `k` of `unit`; stops the run once there are too many.
    fn fail(&mut self, unit: &Unit, k: usize, offset: usize, kind: GcodeErrorKind) {
        let index = unit.first_index + k;
        if !self
            .errors
            .push_in(&unit.file, index, unit.line(k), offset, kind)
        {
            self.stop = true;
        }
    }

    /// The program text of lines `range` of a file, with its control structure and its
    /// `PROC` parameters; none (the error recorded) when they do not match up.
    fn unit(
        &mut self,
        file: &str,
        text: &Rc<str>,
        lines: &[(usize, usize)],
        (start, end): (usize, usize),
        first_number: u32,
    ) -> Option<Rc<Unit>> {
        let own = &lines[start..end];
        let slices: Vec<&str> = own.iter().map(|&(a, b)| &text[a..b]).collect();
        let mut unit = Unit {
            file: file.to_string(),
            text: Rc::clone(text),
            lines: own.to_vec(),
            first_index: start,
            first_number,
            structure: Structure::default(),
            params: Vec::new(),
        };
        match Structure::of(&slices) {
            Ok(s) => unit.structure = s,
            Err((k, offset, kind)) => {
                self.fail(&unit, k, offset, kind);
                return None;
            }
        }
        match proc_params(&slices) {
            Ok(p) => unit.params = p,
            Err((k, offset, kind)) => {
                self.fail(&unit, k, offset, kind);
                return None;
            }
        }
        Some(Rc::new(unit))
    }

    /// Runs `unit`'s lines at call depth `depth`.
    fn run_unit(&mut self, unit: &Unit, depth: usize) {
        self.scopes += 1;
        let (scope, sub) = (self.translator.scope, self.translator.in_subprogram);
        self.translator.scope = self.scopes;
        self.translator.in_subprogram = depth > 0;
        let mut k = 0;
        while k < unit.lines.len() && !self.stop {
            self.run += 1;
            if self.run > MAX_RUN_BLOCKS {
                let kind = GcodeErrorKind::Invalid(format!(
                    "the program's jumps, loops and calls run more than {MAX_RUN_BLOCKS} \
                     blocks: it does not end"
                ));
                self.fail(unit, k, 0, kind);
                self.stop = true;
                break;
            }
            k = self.step(unit, k, depth);
            // The control stops at M2/M30, whatever jumps or calls follow (code after the
            // end is common in programs with jumps).
            if self.interp.has_ended() {
                let left = (k..unit.lines.len())
                    .filter(|&j| {
                        !unit
                            .line(j)
                            .split(';')
                            .next()
                            .unwrap_or("")
                            .trim()
                            .is_empty()
                    })
                    .count();
                self.interp.skipped_after_end(left);
                self.stop = true;
            }
        }
        self.translator.scope = scope;
        self.translator.in_subprogram = sub;
    }

    /// Runs line `k` of `unit`; the line to run next (past the end on a return).
    fn step(&mut self, unit: &Unit, k: usize, depth: usize) -> usize {
        if let Some(c) = unit.structure.control(k) {
            return match self.translator.control(c, k, &unit.structure) {
                Ok(next) => next,
                Err(kind) => {
                    self.fail(unit, k, 0, kind);
                    k + 1
                }
            };
        }
        let text = unit.line(k);
        let number = unit.first_number + u32::try_from(k + 1).unwrap_or(u32::MAX);
        let (interp, lexed) = (&mut *self.interp, &mut self.lexed);
        self.translator.where_unknown(interp.program_position());
        let result = self.translator.rewrite(text).and_then(|rewritten| {
            for w in &rewritten.warnings {
                interp.warn(number, w.clone());
            }
            if let Some(jerk_limited) = rewritten.jerk_limited {
                interp.switch_profile(jerk_limited);
            }
            if let Some(basic) = rewritten.feed_in_basic_system {
                interp.feed_in_basic_system(basic);
            }
            run_line(interp, rewritten.text(text), number, lexed)
                .map_err(|(offset, kind)| (rewritten.original_offset(offset), kind))
        });
        let call = self.translator.take_call();
        match result {
            Err((offset, kind)) => self.fail(unit, k, offset, kind),
            Ok(()) => {
                if let Some(call) = call {
                    self.call(unit, k, &call, depth);
                }
            }
        }
        if self.translator.take_returned() {
            return unit.lines.len();
        }
        k + 1
    }

    /// Runs the subprogram `call` names, from line `k` of `caller`.
    fn call(&mut self, caller: &Unit, k: usize, call: &Call, depth: usize) {
        if depth >= MAX_CALL_DEPTH {
            let kind = GcodeErrorKind::Invalid(format!(
                "{}: calls nest deeper than the control's {} program levels",
                call.word,
                MAX_CALL_DEPTH + 1
            ));
            self.fail(caller, k, call.offset, kind);
            return;
        }
        let unit = match self.find(&call.name) {
            Ok(Some(unit)) => unit,
            Ok(None) => return self.fail(caller, k, call.offset, self.missing(call)),
            Err(kind) => return self.fail(caller, k, call.offset, kind),
        };
        if call.args.len() > unit.params.len() {
            let kind = GcodeErrorKind::Invalid(format!(
                "{}: {} argument(s) given, its PROC takes {}",
                call.word,
                call.args.len(),
                unit.params.len()
            ));
            return self.fail(caller, k, call.offset, kind);
        }
        let saved = self.translator.vars.clone();
        for _ in 0..call.repeat {
            for (i, p) in unit.params.iter().enumerate() {
                let v = call.args.get(i).copied().flatten().unwrap_or(p.default);
                self.translator.vars.insert(p.name.clone(), v);
            }
            self.run_unit(&unit, depth + 1);
            if self.stop {
                break;
            }
        }
        // The subprogram's own variables end with it; R-parameters are the program's.
        let mut vars = saved;
        for (name, v) in self.translator.vars.drain() {
            if is_r_parameter(&name) {
                vars.insert(name, v);
            }
        }
        self.translator.vars = vars;
    }

    fn missing(&self, call: &Call) -> GcodeErrorKind {
        let place = match &self.folder {
            Some(f) => format!("in this file or in {}", f.display()),
            None => "in this file".to_string(),
        };
        GcodeErrorKind::Invalid(format!(
            "{}: neither a SINUMERIK command this reads nor a subprogram {place} \
             (looked for {}.SPF)",
            call.word, call.name
        ))
    }

    /// The subprogram of that name: the file's own, or one read from the folder.
    fn find(&mut self, name: &str) -> Result<Option<Rc<Unit>>, GcodeErrorKind> {
        if let Some(u) = self.loaded.get(name) {
            return Ok(Some(Rc::clone(u)));
        }
        if self.broken.iter().any(|b| b == name) {
            return Err(Self::broken_error(name));
        }
        let unit = if let Some(&range) = self.in_file.get(name) {
            let (text, lines) = (Rc::clone(&self.main_text), self.main_lines.clone());
            let file = self.errors.file.to_string();
            self.unit(
                &file,
                &text,
                &lines,
                range,
                u32::try_from(range.0).unwrap_or(0),
            )
        } else {
            let Some(path) = self.path_of(name) else {
                return Ok(None);
            };
            // As the main program: bytes that are not UTF-8 (in comments, say) are replaced.
            let bytes = std::fs::read(&path).map_err(|e| {
                GcodeErrorKind::Invalid(format!("{name}: {} cannot be read: {e}", path.display()))
            })?;
            let text: Rc<str> = Rc::from(String::from_utf8_lossy(&bytes).as_ref());
            let lines = line_ranges(&text);
            let count = u32::try_from(lines.len()).unwrap_or(u32::MAX);
            let first = self.next_number;
            self.next_number = self.next_number.saturating_add(count);
            let file = path.display().to_string();
            self.sources.push(SourceFile {
                file: file.clone(),
                first_line: first,
                lines: count,
            });
            let all = (0, lines.len());
            self.unit(&file, &text, &lines, all, first)
        };
        match unit {
            Some(u) => {
                self.loaded.insert(name.to_string(), Rc::clone(&u));
                Ok(Some(u))
            }
            None => {
                self.broken.push(name.to_string());
                Err(Self::broken_error(name))
            }
        }
    }

    fn broken_error(name: &str) -> GcodeErrorKind {
        GcodeErrorKind::Invalid(format!(
            "{name}: the subprogram does not run, for the error reported in it"
        ))
    }

    /// The folder's file for subprogram `name`, in any case: `NAME.SPF`, `NAME.MPF`,
    /// `NAME_SPF` or `_N_NAME_SPF`.
    fn path_of(&mut self, name: &str) -> Option<PathBuf> {
        let folder = self.folder.clone()?;
        let names = self.folder_names.get_or_insert_with(|| {
            std::fs::read_dir(&folder)
                .map(|d| {
                    d.filter_map(|e| e.ok()?.file_name().into_string().ok())
                        .collect()
                })
                .unwrap_or_default()
        });
        let wanted = [
            format!("{name}.SPF"),
            format!("{name}.MPF"),
            format!("{name}_SPF"),
            format!("_N_{name}_SPF"),
        ];
        wanted.iter().find_map(|w| {
            names
                .iter()
                .find(|n| n.eq_ignore_ascii_case(w))
                .map(|n| folder.join(n))
        })
    }

    /// Warns of the file's subprograms that were never called, and of its sections that
    /// are not programs: none of their lines ran.
    fn note_unused(&mut self, parts: &[Section], main: usize) {
        for (i, s) in parts.iter().enumerate() {
            let what = match &s.header {
                _ if i == main => continue,
                Some(Header::Sub(name)) if self.loaded.contains_key(name) => continue,
                Some(Header::Sub(name)) => format!("subprogram {name} is never called"),
                Some(Header::Other(name)) => format!("{name} is not a program"),
                Some(Header::Main) | None => "a second main program is not run".to_string(),
            };
            let line = u32::try_from(s.start + 1).unwrap_or(u32::MAX);
            self.interp.warn(
                line,
                format!(
                    "{what}: lines {}–{} were not read",
                    s.start + 1,
                    s.end.max(s.start + 1)
                ),
            );
        }
    }
}

fn is_r_parameter(name: &str) -> bool {
    name.len() > 1 && name.starts_with('R') && name[1..].bytes().all(|c| c.is_ascii_digit())
}

/// A failure at a line of a program text: line index, byte offset and the problem.
type LineError = (usize, usize, GcodeErrorKind);

/// The parameters of the `PROC` heading a subprogram (none without one): `PROC NAME(REAL A,
/// INT B=2) SAVE`.
fn proc_params(lines: &[&str]) -> Result<Vec<Param>, LineError> {
    for (k, line) in lines.iter().enumerate() {
        let upper = line.to_ascii_uppercase();
        let code = upper.split(';').next().unwrap_or("").trim();
        if code.is_empty() || code.starts_with('%') {
            continue;
        }
        let Some(rest) = code.strip_prefix("PROC ") else {
            return Ok(Vec::new());
        };
        let at = upper.find("PROC").unwrap_or(0);
        let Some(open) = rest.find('(') else {
            return Ok(Vec::new());
        };
        let close = rest.rfind(')').filter(|&c| c > open).ok_or_else(|| {
            let kind = GcodeErrorKind::Invalid("PROC ( … ) is not closed".into());
            (k, at, kind)
        })?;
        let list = &rest[open + 1..close];
        if list.trim().is_empty() {
            return Ok(Vec::new());
        }
        return list
            .split(',')
            .map(|p| param(p).map_err(|kind| (k, at, kind)))
            .collect();
    }
    Ok(Vec::new())
}

/// One `PROC` parameter: `REAL A`, `INT N=3`.
fn param(text: &str) -> Result<Param, GcodeErrorKind> {
    let (decl, default) = match text.split_once('=') {
        Some((d, v)) => (d, Some(v.trim())),
        None => (text, None),
    };
    let mut words = decl.split_whitespace();
    let (ty, name) = (words.next().unwrap_or(""), words.next().unwrap_or(""));
    if ty == "VAR" {
        return Err(GcodeErrorKind::Unsupported {
            word: format!("VAR {name}"),
            reason: "parameters passed by reference (VAR) are not supported",
        });
    }
    if !matches!(ty, "REAL" | "INT") || name.is_empty() || words.next().is_some() {
        return Err(GcodeErrorKind::Invalid(format!(
            "PROC parameter '{}': only REAL and INT parameters, written `REAL NAME` or \
             `REAL NAME=value`, are read",
            text.trim()
        )));
    }
    let default = match default {
        None => 0.0,
        Some(v) => v.parse::<f64>().map_err(|_| {
            GcodeErrorKind::Invalid(format!(
                "PROC parameter {name}: default '{v}' is not a number"
            ))
        })?,
    };
    Ok(Param {
        name: name.to_string(),
        default,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn headers_name_programs_and_other_sections() {
        assert_eq!(header("%_N_MAIN_MPF"), Some(Header::Main));
        assert_eq!(header("%_n_pock_spf"), Some(Header::Sub("POCK".into())));
        assert_eq!(
            header("%_N_MAIN_INI"),
            Some(Header::Other("MAIN_INI".into()))
        );
        assert_eq!(header("%MPF100"), Some(Header::Main));
        assert_eq!(header("G1 X1"), None);
    }

    #[test]
    fn proc_parameters_are_read_with_their_defaults() {
        let p =
            proc_params(&["; pocket", "PROC POCK(REAL DEPTH=2.5, INT N) SAVE", "G1 X1"]).unwrap();
        assert_eq!(
            p,
            vec![
                Param {
                    name: "DEPTH".into(),
                    default: 2.5
                },
                Param {
                    name: "N".into(),
                    default: 0.0
                }
            ]
        );
        let e = proc_params(&["PROC P(VAR REAL A)"]).unwrap_err();
        assert!(e.2.to_string().contains("by reference"), "{}", e.2);
        assert!(
            proc_params(&["G1 X1", "PROC P(REAL A)"])
                .unwrap()
                .is_empty()
        );
        // A closing bracket before the opening one is an error, not a panic.
        assert!(proc_params(&["PROC P) (REAL A"]).is_err());
    }
}
