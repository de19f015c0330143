//! What the interpreter hands on: the program's path with its events, notes and warnings,
//! and where each of its lines is written.

use super::super::SourceFile;
use super::super::error::Warning;
use crate::path::Segment;

/// A code that was accepted without changing the XY path, counted for the summary.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct CodeNote {
    /// The code, e.g. `G40`.
    pub code: String,
    /// What it means here.
    pub meaning: &'static str,
    /// How many blocks used it.
    pub count: usize,
    /// First line that used it.
    pub first_line: u32,
}

/// A machine event carried along the program (spindle, tool, coolant, stops).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Event {
    /// Source line.
    pub line: u32,
    /// The word, e.g. `M3`, `S12000`, `T4`.
    pub word: String,
    /// Index of the next path segment when the event happened.
    pub segment: usize,
}

/// An interpreted program: the path and what else was said in it.
#[derive(Debug, Clone, PartialEq)]
pub struct Program {
    /// The file name as given.
    pub file: String,
    /// The path, in order.
    pub segments: Vec<Segment>,
    /// Spindle, tool, coolant and stop events.
    pub events: Vec<Event>,
    /// Codes accepted without effect on the XY path, for the summary.
    pub notes: Vec<CodeNote>,
    /// Warnings (badly conditioned arcs and the like).
    pub warnings: Vec<Warning>,
    /// Number of blocks that held at least one word.
    pub blocks: usize,
    /// The block numbers (N words) the program gives, as (source line, N), by line: reports
    /// show them beside the file's line, as the control's display does.
    pub block_numbers: Vec<(u32, u32)>,
    /// Number of source lines.
    pub lines: usize,
    /// Files of subprograms the program called, whose lines are numbered after its own.
    pub sources: Vec<SourceFile>,
}

/// A program line as the user knows it: the file it is in (none: the program's own) and
/// its line there.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SourceLine<'p> {
    /// The subprogram's file, for lines of another file than the program's.
    pub file: Option<&'p str>,
    /// 1-based line in that file.
    pub line: u32,
}

impl std::fmt::Display for SourceLine<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.file {
            Some(file) => write!(f, "{file} line {}", self.line),
            None => write!(f, "line {}", self.line),
        }
    }
}

impl SourceLine<'_> {
    /// Where program line `line` is written, among the program's subprogram files `sources`.
    pub(crate) fn among(sources: &[SourceFile], line: u32) -> SourceLine<'_> {
        let file = sources
            .iter()
            .find(|s| line > s.first_line && line - s.first_line <= s.lines);
        match file {
            Some(s) => SourceLine {
                file: Some(&s.file),
                line: line - s.first_line,
            },
            None => SourceLine { file: None, line },
        }
    }

    /// The line as a table's column or a plot's label shows it: `29`, or `BOSS.SPF:8` in a
    /// subprogram's file (its name without the folder).
    #[cfg(feature = "html-report")]
    pub(crate) fn short(&self) -> String {
        match self.file {
            Some(f) => {
                let name = std::path::Path::new(f)
                    .file_name()
                    .and_then(|n| n.to_str())
                    .unwrap_or(f);
                format!("{name}:{}", self.line)
            }
            None => self.line.to_string(),
        }
    }
}

impl Program {
    /// Where program line `line` (the numbering of segments, hotspots and warnings) is
    /// written.
    pub fn source_line(&self, line: u32) -> SourceLine<'_> {
        SourceLine::among(&self.sources, line)
    }

    /// A warning about one of the program's lines, with the file and line named in its
    /// text when the line is in a subprogram's file.
    pub(crate) fn placed(&self, warning: Warning) -> Warning {
        let at = self.source_line(warning.line);
        match at.file {
            Some(_) => Warning {
                line: 0,
                message: format!("{at}: {}", warning.message),
            },
            None => warning,
        }
    }

    /// The block number (N word) of the block on source line `line`, if it has one.
    pub fn block_number(&self, line: u32) -> Option<u32> {
        self.block_numbers
            .binary_search_by_key(&line, |&(l, _)| l)
            .ok()
            .map(|i| self.block_numbers[i].1)
    }
}
