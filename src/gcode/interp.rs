//! Modal interpretation: blocks of words in, path segments out.
//!
//! The interpreter keeps RS274/NGC's modal state (motion mode, plane, units, distance
//! modes, feed, path control, work offsets) and executes each block's codes in the standard's
//! order. Geometry is computed in millimetres (the program's own numbers, so tolerances read
//! as in LinuxCNC) and converted to metres when a segment is emitted.

use std::collections::BTreeMap;

use super::codes::{self, CodeClass};
use super::error::{GcodeErrorKind, Warning};
use super::lexer::Word;
use crate::path::{Arc, Blend, Geometry, Motion, Segment};
use crate::units::{MM_PER_INCH, m_from_mm, m_per_s_from_mm_per_min};

/// Settings of the interpreter that a machine or user provides.
#[derive(Debug, Clone, PartialEq)]
pub struct InterpretOptions {
    /// Work offsets G54, G55, …, G59, G59.1, G59.2, G59.3 (mm, machine coordinates).
    pub work_offsets_mm: [[f64; 3]; 9],
    /// Position that G28 returns to (mm, machine coordinates).
    pub g28_home_mm: [f64; 3],
    /// Position that G30 returns to (mm, machine coordinates).
    pub g30_home_mm: [f64; 3],
    /// Where the tool is when the program starts (mm, machine coordinates).
    pub start_mm: [f64; 3],
    /// Skip blocks that start with `/` (the block-delete switch).
    pub block_delete: bool,
    /// The program's dialect; `None`: told from the file's name and text.
    pub dialect: Option<super::Dialect>,
    /// Where a SINUMERIK program's subprograms are looked for when its own file does not
    /// hold them (the program's folder); `None`: only in its file.
    pub subprogram_folder: Option<std::path::PathBuf>,
}

impl Default for InterpretOptions {
    fn default() -> Self {
        InterpretOptions {
            work_offsets_mm: [[0.0; 3]; 9],
            g28_home_mm: [0.0; 3],
            g30_home_mm: [0.0; 3],
            start_mm: [0.0; 3],
            block_delete: false,
            dialect: None,
            subprogram_folder: None,
        }
    }
}

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
    pub sources: Vec<super::SourceFile>,
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
    pub fn among(sources: &[super::SourceFile], line: u32) -> SourceLine<'_> {
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
    pub fn short(&self) -> String {
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
    pub fn placed(&self, warning: Warning) -> Warning {
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

/// An interpretation error at a byte offset of the current line.
#[derive(Debug, Clone, PartialEq)]
pub struct InterpError {
    /// Byte offset in the line.
    pub offset: u32,
    /// The problem.
    pub kind: GcodeErrorKind,
}

type IResult<T> = Result<T, InterpError>;

fn err<T>(offset: u32, kind: GcodeErrorKind) -> IResult<T> {
    Err(InterpError { offset, kind })
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum MotionMode {
    Rapid,
    Linear,
    ArcCw,
    ArcCcw,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Plane {
    Xy,
    Xz,
    Yz,
}

/// The words of one block, sorted into codes and letter values.
#[derive(Debug, Default)]
struct BlockWords {
    g: Vec<(u16, u32)>,
    m: Vec<(u16, u32)>,
    values: [Option<(f64, u32)>; 26],
}

impl BlockWords {
    fn get(&self, letter: u8) -> Option<f64> {
        self.values[(letter - b'A') as usize].map(|(v, _)| v)
    }

    fn offset_of(&self, letter: u8) -> u32 {
        self.values[(letter - b'A') as usize].map_or(0, |(_, o)| o)
    }

    fn has_g(&self, code10: u16) -> Option<u32> {
        self.g.iter().find(|(c, _)| *c == code10).map(|&(_, o)| o)
    }

    fn has_axis_words(&self) -> bool {
        [b'X', b'Y', b'Z'].iter().any(|&l| self.get(l).is_some())
    }
}

/// The interpreter: feed it lines' words with [`Interpreter::execute`], then
/// [`Interpreter::finish`].
pub struct Interpreter {
    opts: InterpretOptions,
    file: String,
    mm_per_unit: f64,
    absolute: bool,
    arc_absolute: bool,
    motion: Option<MotionMode>,
    plane: Plane,
    feed_mm_per_min: f64,
    blend: Blend,
    coord_index: usize,
    work_offsets_mm: [[f64; 3]; 9],
    /// XY rotation of each work coordinate system (degrees, CCW), set by G10 L2 R.
    rotation_deg: [f64; 9],
    g92_mm: [f64; 3],
    g92_saved_mm: [f64; 3],
    pos_mm: [f64; 3],
    ended: bool,
    /// The acceleration profile the program switched to (`SOFT`/`BRISK`), stamped on each
    /// segment; `None`: the planner's.
    jerk_limited: Option<bool>,
    /// Whether rapids follow the path mode (SINUMERIK: `G0` blends under `G64`/`G641`/`G642`)
    /// rather than ending in an exact stop (RS274/NGC here).
    rapids_blend: bool,
    block: BlockWords,
    line: u32,
    segments: Vec<Segment>,
    events: Vec<Event>,
    notes: BTreeMap<String, CodeNote>,
    unknown_m: codes::UnknownMCodes,
    warnings: Vec<Warning>,
    blocks: usize,
    block_numbers: Vec<(u32, u32)>,
    lines_after_end: usize,
}

/// LinuxCNC's absolute tolerance on the start/end radius difference of an I/J arc
/// (CENTER_ARC_RADIUS_TOLERANCE_MM = 2·0.01·√2 mm; the inch value, 2·0.001·√2 in, applies
/// under G20).
const ARC_RADIUS_TOL_MM: f64 = 2.0 * 0.01 * std::f64::consts::SQRT_2;
const ARC_RADIUS_TOL_INCH: f64 = 2.0 * 0.001 * std::f64::consts::SQRT_2;
/// LinuxCNC's relative tolerance on the same difference (SPIRAL_RELATIVE_TOLERANCE).
const ARC_RADIUS_REL_TOL: f64 = 0.001;
/// Slack for an R arc's radius against half its chord (RADIUS_TOLERANCE_INCH = 0.00005 in).
const R_ARC_SLACK_INCH: f64 = 0.00005;
/// R arcs within this angle of a half circle get a conditioning warning.
const R_ARC_NEAR_HALF_DEG: f64 = 5.0;
/// I/J arcs whose end lies within this distance of the start (but not on it) are warned.
const NEAR_COINCIDENT_MM: f64 = 0.001;

impl Interpreter {
    /// A fresh interpreter in RS274/NGC's start-up state: G17 G21 G40 G49 G54 G64 G80 G90
    /// G91.1 G94.
    pub fn new(file: &str, opts: InterpretOptions) -> Self {
        Interpreter {
            file: file.to_string(),
            mm_per_unit: 1.0,
            absolute: true,
            arc_absolute: false,
            motion: None,
            plane: Plane::Xy,
            feed_mm_per_min: 0.0,
            blend: Blend::Continuous {
                tolerance_m: None,
                naive_cam_m: None,
            },
            coord_index: 0,
            work_offsets_mm: opts.work_offsets_mm,
            rotation_deg: [0.0; 9],
            g92_mm: [0.0; 3],
            g92_saved_mm: [0.0; 3],
            pos_mm: opts.start_mm,
            ended: false,
            jerk_limited: None,
            rapids_blend: false,
            block: BlockWords::default(),
            line: 0,
            segments: Vec::new(),
            events: Vec::new(),
            notes: BTreeMap::new(),
            unknown_m: codes::UnknownMCodes::default(),
            warnings: Vec::new(),
            blocks: 0,
            block_numbers: Vec::new(),
            lines_after_end: 0,
            opts,
        }
    }

    /// Pre-sizes the output for a program of `bytes` bytes (one segment per ~25 bytes).
    pub(crate) fn reserve_for(&mut self, bytes: usize) {
        self.segments.reserve(bytes / 25);
    }

    /// Executes one block. `block_delete` is the block's `/` flag.
    pub fn execute(&mut self, line: u32, words: &[Word], block_delete: bool) -> IResult<()> {
        self.line = line;
        if words.is_empty() {
            return Ok(());
        }
        if self.ended {
            self.lines_after_end += 1;
            return Ok(());
        }
        if block_delete && self.opts.block_delete {
            return Ok(());
        }
        self.blocks += 1;
        self.sort_words(words)?;
        self.check_codes()?;
        self.run_block()
    }

    /// Notes `message` about line `line` among the program's warnings.
    /// Switches the acceleration profile of the segments that follow (SINUMERIK `SOFT`:
    /// jerk limited, `BRISK`: acceleration limited).
    pub(crate) fn switch_profile(&mut self, jerk_limited: bool) {
        self.jerk_limited = Some(jerk_limited);
    }

    /// Lets rapids take the path mode in force, as the 840D's `G0` does, instead of ending
    /// each in an exact stop.
    pub(crate) fn blend_rapids(&mut self) {
        self.rapids_blend = true;
    }

    /// Whether the program has ended (`M2`, `M30`).
    pub(crate) fn has_ended(&self) -> bool {
        self.ended
    }

    /// Counts `n` blocks left unrun after the program's end.
    pub(crate) fn skipped_after_end(&mut self, n: usize) {
        self.lines_after_end += n;
    }

    pub(crate) fn warn(&mut self, line: u32, message: String) {
        self.warnings.push(Warning { line, message });
    }

    /// The interpreted program.
    pub fn finish(mut self, lines: usize) -> Program {
        if let Some(message) = self.unknown_m.warning() {
            // The warning lists its lines itself: it concerns the whole program.
            self.warnings.push(Warning { line: 0, message });
        }
        if self.lines_after_end > 0 {
            self.warnings.push(Warning {
                line: 0,
                message: format!(
                    "{} block(s) after the program end (M2/M30) were not executed",
                    self.lines_after_end
                ),
            });
        }
        // Loops, jumps and calls run some lines more than once, and not in order.
        self.block_numbers.sort_unstable();
        self.block_numbers.dedup_by_key(|&mut (line, _)| line);
        Program {
            file: self.file,
            segments: self.segments,
            events: self.events,
            notes: self.notes.into_values().collect(),
            warnings: self.warnings,
            blocks: self.blocks,
            block_numbers: self.block_numbers,
            lines,
            sources: Vec::new(),
        }
    }

    fn sort_words(&mut self, words: &[Word]) -> IResult<()> {
        let b = &mut self.block;
        b.g.clear();
        b.m.clear();
        b.values = [None; 26];
        for w in words {
            match w.letter {
                b'G' | b'M' => {
                    let code10 = (w.value * 10.0).round();
                    if (w.value * 10.0 - code10).abs() > 1e-6 || !(0.0..=9999.0).contains(&code10) {
                        let name = format!("{}{}", w.letter as char, w.value);
                        return err(w.offset, GcodeErrorKind::UnknownCode(name));
                    }
                    let list = if w.letter == b'G' { &mut b.g } else { &mut b.m };
                    list.push((code10 as u16, w.offset));
                }
                b'N' => {
                    if w.value >= 0.0 && w.value.fract() == 0.0 && w.value < u32::MAX as f64 {
                        self.block_numbers.push((self.line, w.value as u32));
                    }
                }
                letter => {
                    let slot = &mut b.values[(letter - b'A') as usize];
                    if slot.is_some() {
                        return err(w.offset, GcodeErrorKind::DuplicateWord(letter as char));
                    }
                    *slot = Some((w.value, w.offset));
                }
            }
        }
        Ok(())
    }

    /// Refuses unknown and unsupported codes and letters, and modal-group conflicts.
    fn check_codes(&mut self) -> IResult<()> {
        let b = &self.block;
        for (letter, list, classify) in [
            ('G', &b.g, codes::classify_g as fn(u16) -> CodeClass),
            ('M', &b.m, codes::classify_m as fn(u16) -> CodeClass),
        ] {
            let mut groups: Vec<(u8, u16)> = Vec::new();
            for &(code, offset) in list.iter() {
                match classify(code) {
                    // A machine's own M function: listed in one warning at the end.
                    CodeClass::Unknown if letter == 'M' && code.is_multiple_of(10) => {
                        self.unknown_m.note(code, self.line);
                    }
                    CodeClass::Unknown => {
                        let name = codes::code_name(letter, code);
                        return err(offset, GcodeErrorKind::UnknownCode(name));
                    }
                    CodeClass::Refused(reason) => {
                        let word = codes::code_name(letter, code);
                        return err(offset, GcodeErrorKind::Unsupported { word, reason });
                    }
                    CodeClass::Accepted { group } => {
                        // Group 0 (non-modal) codes may share a block; coolant M7+M8 too.
                        // G80 beside another motion code (CAM preambles do this) is a cancel
                        // the other code overrides, as LinuxCNC reads it.
                        let shareable = group == 0 || (letter == 'M' && group == 8);
                        let g80_pair = |other: u16| letter == 'G' && (code == 800 || other == 800);
                        if let Some(&(_, other)) = groups
                            .iter()
                            .find(|&&(g, other)| g == group && !shareable && !g80_pair(other))
                        {
                            return err(
                                offset,
                                GcodeErrorKind::ModalGroupConflict {
                                    first: codes::code_name(letter, other),
                                    second: codes::code_name(letter, code),
                                },
                            );
                        }
                        groups.push((group, code));
                    }
                }
            }
        }
        self.check_letters()
    }

    fn check_letters(&self) -> IResult<()> {
        for (i, slot) in self.block.values.iter().enumerate() {
            let Some((value, offset)) = *slot else {
                continue;
            };
            let letter = b'A' + i as u8;
            let refuse = |reason| {
                err(
                    offset,
                    GcodeErrorKind::Unsupported {
                        word: format!("{}", letter as char),
                        reason,
                    },
                )
            };
            match letter {
                b'A' | b'B' | b'C' => {
                    return refuse("rotary axes are not supported: the predictor models X and Y");
                }
                b'U' | b'V' | b'W' => {
                    return refuse("extra linear axes (U/V/W) are not supported");
                }
                b'E' => return err(offset, GcodeErrorKind::Invalid("unknown word 'E'".into())),
                _ => {}
            }
            if !value.is_finite() {
                return err(
                    offset,
                    GcodeErrorKind::BadNumber {
                        letter: letter as char,
                        text: value.to_string(),
                    },
                );
            }
        }
        Ok(())
    }

    fn note(&mut self, letter: char, code10: u16) {
        let Some(meaning) = codes::accepted_note(letter, code10) else {
            return;
        };
        let code = codes::code_name(letter, code10);
        let line = self.line;
        self.notes
            .entry(code.clone())
            .and_modify(|n| n.count += 1)
            .or_insert(CodeNote {
                code,
                meaning,
                count: 1,
                first_line: line,
            });
    }

    /// Runs a block's codes in RS274/NGC's order of execution.
    fn run_block(&mut self) -> IResult<()> {
        self.set_feed()?;
        self.record_events();
        let gs: Vec<(u16, u32)> = self.block.g.clone();
        for &(code, _) in &gs {
            self.note('G', code);
        }
        if let Some(off) = self.block.has_g(40) {
            self.dwell(off)?;
        }
        self.set_modes(&gs)?;
        let non_modal_moved = self.run_non_modal(&gs)?;
        self.run_motion(&gs, non_modal_moved)?;
        self.run_stops();
        Ok(())
    }

    fn set_feed(&mut self) -> IResult<()> {
        if let Some(f) = self.block.get(b'F') {
            if f < 0.0 {
                return err(
                    self.block.offset_of(b'F'),
                    GcodeErrorKind::Invalid("negative feed rate".into()),
                );
            }
            self.feed_mm_per_min = f * self.mm_per_unit;
        }
        Ok(())
    }

    fn record_events(&mut self) {
        let segment = self.segments.len();
        let line = self.line;
        for letter in [b'S', b'T'] {
            if let Some(v) = self.block.get(letter) {
                self.events.push(Event {
                    line,
                    word: format!("{}{}", letter as char, v),
                    segment,
                });
            }
        }
        let ms: Vec<(u16, u32)> = self.block.m.clone();
        for (code, _) in ms {
            self.events.push(Event {
                line,
                word: codes::code_name('M', code),
                segment,
            });
            self.note('M', code);
        }
    }

    fn dwell(&mut self, offset: u32) -> IResult<()> {
        let Some(p) = self.block.get(b'P') else {
            return err(
                offset,
                GcodeErrorKind::Invalid("G4 needs a P word (seconds)".into()),
            );
        };
        if p < 0.0 {
            return err(
                offset,
                GcodeErrorKind::Invalid("G4 with a negative dwell time".into()),
            );
        }
        self.push_dwell(p);
        Ok(())
    }

    fn push_dwell(&mut self, seconds: f64) {
        let here = self.pos_m();
        self.segments.push(Segment {
            geometry: Geometry::Dwell { seconds },
            start_m: here,
            end_m: here,
            motion: Motion::Feed,
            feed_m_per_s: 0.0,
            blend: Blend::ExactStop,
            line: self.line,
            jerk_limited: self.jerk_limited,
        });
    }

    fn set_modes(&mut self, gs: &[(u16, u32)]) -> IResult<()> {
        for &(code, offset) in gs {
            match code {
                170 => self.plane = Plane::Xy,
                180 => self.plane = Plane::Xz,
                190 => self.plane = Plane::Yz,
                200 => self.mm_per_unit = MM_PER_INCH,
                210 => self.mm_per_unit = 1.0,
                540..=590 => self.coord_index = (code as usize - 540) / 10,
                591..=593 => self.coord_index = 6 + (code as usize - 591),
                610 | 611 => self.blend = Blend::ExactStop,
                640 => self.set_blend_tolerance(offset)?,
                900 => self.absolute = true,
                910 => self.absolute = false,
                901 => self.arc_absolute = true,
                911 => self.arc_absolute = false,
                _ => {}
            }
        }
        Ok(())
    }

    fn set_blend_tolerance(&mut self, offset: u32) -> IResult<()> {
        let tolerance = |letter: u8| match self.block.get(letter) {
            Some(v) if v < 0.0 => err(
                offset,
                GcodeErrorKind::Invalid(format!("G64 {} must not be negative", letter as char)),
            ),
            Some(v) if v > 0.0 => Ok(Some(m_from_mm(v * self.mm_per_unit))),
            _ => Ok(None),
        };
        let tolerance_m = tolerance(b'P')?;
        let naive_cam_m = tolerance(b'Q')?;
        self.blend = Blend::Continuous {
            tolerance_m,
            naive_cam_m,
        };
        Ok(())
    }

    /// G10, G28/G30, G52, G92 and friends. Returns true when one of them moved the tool or
    /// used the block's axis words.
    fn run_non_modal(&mut self, gs: &[(u16, u32)]) -> IResult<bool> {
        let mut used_axes = false;
        for &(code, offset) in gs {
            match code {
                100 => {
                    self.g10(offset)?;
                    used_axes |= self.block.has_axis_words();
                }
                280 | 300 => {
                    self.go_home(code);
                    used_axes = true;
                }
                281 => self.opts.g28_home_mm = self.pos_mm,
                301 => self.opts.g30_home_mm = self.pos_mm,
                920 => {
                    self.g92(offset)?;
                    used_axes = true;
                }
                520 => {
                    self.g52();
                    used_axes = true;
                }
                921 => {
                    self.g92_mm = [0.0; 3];
                    self.g92_saved_mm = [0.0; 3];
                }
                922 => self.g92_mm = [0.0; 3],
                923 => self.g92_mm = self.g92_saved_mm,
                _ => {}
            }
        }
        if used_axes
            && let Some(&(code, off)) = gs.iter().find(|(c, _)| matches!(c, 0 | 10 | 20 | 30))
        {
            let kind = GcodeErrorKind::Invalid(format!(
                "{} and a G10/G28/G30/G52/G92 in one block both want the axis words",
                codes::code_name('G', code)
            ));
            return err(off, kind);
        }
        Ok(used_axes)
    }

    /// Offset of the active work coordinate system plus G92 (mm).
    fn offset_mm(&self) -> [f64; 3] {
        let w = self.work_offsets_mm[self.coord_index];
        [
            w[0] + self.g92_mm[0],
            w[1] + self.g92_mm[1],
            w[2] + self.g92_mm[2],
        ]
    }

    /// Where the tool stands in the active system's coordinates, in the program's unit: the
    /// inverse of [`Interpreter::program_to_machine`].
    pub(crate) fn program_position(&self) -> [f64; 3] {
        let (sin, cos) = self.rotation_deg[self.coord_index].to_radians().sin_cos();
        let o = self.offset_mm();
        let d = [0, 1, 2].map(|i| self.pos_mm[i] - o[i]);
        [cos * d[0] + sin * d[1], -sin * d[0] + cos * d[1], d[2]].map(|v| v / self.mm_per_unit)
    }

    /// Program coordinates (mm, active system) → machine coordinates (mm): rotate about the
    /// system's origin, then offset, as LinuxCNC's canonical layer does.
    fn program_to_machine(&self, p: [f64; 3]) -> [f64; 3] {
        let (sin, cos) = self.rotation_deg[self.coord_index].to_radians().sin_cos();
        let o = self.offset_mm();
        [
            cos * p[0] - sin * p[1] + o[0],
            sin * p[0] + cos * p[1] + o[1],
            p[2] + o[2],
        ]
    }

    /// Machine coordinates (mm) → program coordinates of the active system (mm).
    fn machine_to_program(&self, m: [f64; 3]) -> [f64; 3] {
        let (sin, cos) = self.rotation_deg[self.coord_index].to_radians().sin_cos();
        let o = self.offset_mm();
        let (x, y) = (m[0] - o[0], m[1] - o[1]);
        [cos * x + sin * y, -sin * x + cos * y, m[2] - o[2]]
    }

    /// The block's X/Y/Z values in program millimetres, unnamed axes taken from `base`.
    fn block_point_mm(&self, base: [f64; 3], incremental: bool) -> [f64; 3] {
        let mut p = base;
        for (i, letter) in [b'X', b'Y', b'Z'].into_iter().enumerate() {
            if let Some(v) = self.block.get(letter) {
                let v_mm = v * self.mm_per_unit;
                p[i] = if incremental { p[i] + v_mm } else { v_mm };
            }
        }
        p
    }

    fn g10(&mut self, offset: u32) -> IResult<()> {
        let l = self.block.get(b'L').map(|v| v.round() as i64);
        match l {
            Some(1 | 10 | 11) => Ok(()), // tool table: no effect on the XY path
            Some(l @ (2 | 20)) => {
                let p = self.block.get(b'P').map_or(0, |p| p.round() as i64);
                let index = match p {
                    0 => self.coord_index,
                    1..=9 => p as usize - 1,
                    _ => {
                        let msg = format!("G10 P{p}: no such coordinate system");
                        return err(offset, GcodeErrorKind::Invalid(msg));
                    }
                };
                if l == 2 {
                    self.g10_l2(index);
                } else {
                    self.g10_l20(index);
                }
                Ok(())
            }
            _ => err(
                offset,
                GcodeErrorKind::Invalid("G10 needs L1, L2, L10, L11 or L20".into()),
            ),
        }
    }

    /// G10 L2: set a system's origin (and rotation, R degrees) directly.
    fn g10_l2(&mut self, index: usize) {
        let origin = self.block_point_mm(self.work_offsets_mm[index], false);
        self.work_offsets_mm[index] = origin;
        if let Some(r) = self.block.get(b'R') {
            self.rotation_deg[index] = r;
        }
    }

    /// G10 L20: set a system's origin so that the current point has the given coordinates.
    fn g10_l20(&mut self, index: usize) {
        let saved = self.coord_index;
        self.coord_index = index;
        let wanted = self.block_point_mm(self.machine_to_program(self.pos_mm), false);
        let (sin, cos) = self.rotation_deg[index].to_radians().sin_cos();
        let rotated = [
            cos * wanted[0] - sin * wanted[1],
            sin * wanted[0] + cos * wanted[1],
            wanted[2],
        ];
        for (i, r) in rotated.iter().enumerate() {
            self.work_offsets_mm[index][i] = self.pos_mm[i] - self.g92_mm[i] - r;
        }
        self.coord_index = saved;
    }

    fn g92(&mut self, offset: u32) -> IResult<()> {
        if !self.block.has_axis_words() {
            return err(
                offset,
                GcodeErrorKind::Invalid("G92 needs at least one axis word".into()),
            );
        }
        // Choose the G92 offset that gives the current point the named coordinates.
        let wanted = self.block_point_mm(self.machine_to_program(self.pos_mm), false);
        self.g92_mm = [0.0; 3];
        let unshifted = self.program_to_machine(wanted);
        for (i, u) in unshifted.iter().enumerate() {
            self.g92_mm[i] = self.pos_mm[i] - u;
        }
        self.g92_saved_mm = self.g92_mm;
        Ok(())
    }

    fn g52(&mut self) {
        for (i, letter) in [b'X', b'Y', b'Z'].into_iter().enumerate() {
            if let Some(v) = self.block.get(letter) {
                self.g92_mm[i] = v * self.mm_per_unit;
            }
        }
        self.g92_saved_mm = self.g92_mm;
    }

    /// G28/G30: a rapid to the optional intermediate point, then the named axes (all when
    /// none is named) to the stored home.
    fn go_home(&mut self, code: u16) {
        let home = if code == 280 {
            self.opts.g28_home_mm
        } else {
            self.opts.g30_home_mm
        };
        let named = [b'X', b'Y', b'Z'].map(|l| self.block.get(l).is_some());
        if named.iter().any(|&n| n) {
            let via = self.target_mm(false);
            self.push_line(via, Motion::Rapid);
        }
        // The home position is in machine coordinates.
        let mut end = self.pos_mm;
        for i in 0..3 {
            if named[i] || !named.iter().any(|&n| n) {
                end[i] = home[i];
            }
        }
        self.push_line(end, Motion::Rapid);
    }

    /// The block's target point in machine coordinates (mm). Under G53 the values are
    /// machine coordinates themselves.
    fn target_mm(&self, machine_coords: bool) -> [f64; 3] {
        if machine_coords {
            return self.block_point_mm(self.pos_mm, false);
        }
        let here = self.machine_to_program(self.pos_mm);
        self.program_to_machine(self.block_point_mm(here, !self.absolute))
    }

    fn run_motion(&mut self, gs: &[(u16, u32)], non_modal_moved: bool) -> IResult<()> {
        let explicit = gs
            .iter()
            .find(|(c, _)| matches!(c, 0 | 10 | 20 | 30 | 800))
            .copied();
        if let Some((code, _)) = explicit {
            self.motion = match code {
                0 => Some(MotionMode::Rapid),
                10 => Some(MotionMode::Linear),
                20 => Some(MotionMode::ArcCw),
                30 => Some(MotionMode::ArcCcw),
                _ => None,
            };
        }
        let has_axes = self.block.has_axis_words();
        let motion_offset = explicit.map_or(0, |(_, o)| o);
        let explicit_arc = explicit.is_some_and(|(c, _)| matches!(c, 20 | 30));
        if non_modal_moved || (!has_axes && !explicit_arc) {
            // Nothing moves: any arc word would be unused.
            return self.check_unused_arc_words();
        }
        let Some(mode) = self.motion else {
            let off = self.first_axis_offset();
            let msg = "axis words without a motion mode (G0/G1/G2/G3)";
            return err(off, GcodeErrorKind::Invalid(msg.into()));
        };
        let machine = gs.iter().any(|(c, _)| *c == 530);
        let target = self.target_mm(machine);
        match mode {
            MotionMode::Rapid => {
                self.check_unused_arc_words()?;
                self.push_line(target, Motion::Rapid);
            }
            MotionMode::Linear => {
                self.check_unused_arc_words()?;
                self.require_feed("G1", motion_offset)?;
                self.push_line(target, Motion::Feed);
            }
            MotionMode::ArcCw | MotionMode::ArcCcw => {
                if machine {
                    let msg = "G53 cannot be used with an arc";
                    return err(motion_offset, GcodeErrorKind::Invalid(msg.into()));
                }
                let name = if mode == MotionMode::ArcCw {
                    "G2"
                } else {
                    "G3"
                };
                self.require_feed(name, motion_offset)?;
                // Without axis words the arc ends where it starts: a full circle.
                self.arc(mode == MotionMode::ArcCcw, target, motion_offset)?;
            }
        }
        Ok(())
    }

    fn first_axis_offset(&self) -> u32 {
        [b'X', b'Y', b'Z']
            .iter()
            .filter_map(|&l| self.block.values[(l - b'A') as usize].map(|(_, o)| o))
            .min()
            .unwrap_or(0)
    }

    fn check_unused_arc_words(&self) -> IResult<()> {
        for letter in [b'I', b'J', b'K', b'R'] {
            if self.block.get(letter).is_some()
                && !(letter == b'R' && self.block.has_g(100).is_some())
            {
                let msg = format!("{} word with no arc (G2/G3) to use it", letter as char);
                return err(self.block.offset_of(letter), GcodeErrorKind::Invalid(msg));
            }
        }
        Ok(())
    }

    fn require_feed(&self, name: &str, offset: u32) -> IResult<()> {
        if self.feed_mm_per_min <= 0.0 {
            return err(offset, GcodeErrorKind::ZeroFeed(name.to_string()));
        }
        Ok(())
    }

    fn run_stops(&mut self) {
        let ms: Vec<u16> = self.block.m.iter().map(|&(c, _)| c).collect();
        for code in ms {
            match code {
                0 | 10 | 600 => self.push_dwell(0.0),
                20 | 300 => self.ended = true,
                _ => {}
            }
        }
    }

    fn pos_m(&self) -> [f64; 3] {
        self.pos_mm.map(m_from_mm)
    }

    fn push_line(&mut self, end_mm: [f64; 3], motion: Motion) {
        let start = self.pos_m();
        let end = end_mm.map(m_from_mm);
        self.pos_mm = end_mm;
        if start == end {
            return; // a null move takes no time and makes no path
        }
        self.segments.push(Segment {
            geometry: Geometry::Line,
            start_m: start,
            end_m: end,
            motion,
            feed_m_per_s: self.feed_for(motion),
            blend: self.blend_for(motion),
            line: self.line,
            jerk_limited: self.jerk_limited,
        });
    }

    /// The path mode a move of `motion` ends in. RS274/NGC rapids end in an exact stop, as
    /// on most controls (Fanuc's rapid in-position check; LinuxCNC is kept to the same
    /// conservative rule).
    fn blend_for(&self, motion: Motion) -> Blend {
        match motion {
            Motion::Rapid if !self.rapids_blend => Blend::ExactStop,
            _ => self.blend,
        }
    }

    fn feed_for(&self, motion: Motion) -> f64 {
        match motion {
            Motion::Rapid => f64::INFINITY,
            Motion::Feed => m_per_s_from_mm_per_min(self.feed_mm_per_min),
        }
    }

    /// G2/G3 in the XY plane, I/J or R form, optionally helical and multi-turn (P).
    fn arc(&mut self, ccw: bool, end_mm: [f64; 3], offset: u32) -> IResult<()> {
        if self.plane != Plane::Xy {
            let word = if ccw { "G3" } else { "G2" };
            let reason = "arcs outside the XY plane (G18/G19) are not supported";
            return err(
                offset,
                GcodeErrorKind::Unsupported {
                    word: word.into(),
                    reason,
                },
            );
        }
        if let Some(k) = self.block.values[(b'K' - b'A') as usize] {
            return err(
                k.1,
                GcodeErrorKind::Invalid("K word in an XY-plane arc".into()),
            );
        }
        let turns = self.arc_turns(offset)?;
        let has_ij = self.block.get(b'I').is_some() || self.block.get(b'J').is_some();
        let (center, r_start, r_end) = match (self.block.get(b'R'), has_ij) {
            (Some(_), true) => {
                let off = self.block.offset_of(b'R');
                return err(
                    off,
                    GcodeErrorKind::Invalid("arc with both R and I/J".into()),
                );
            }
            (None, false) => {
                return err(offset, GcodeErrorKind::Invalid("arc needs I/J or R".into()));
            }
            (Some(r), false) => self.r_arc_center(ccw, r, end_mm)?,
            (None, true) => self.ij_arc_center(end_mm)?,
        };
        let start = self.pos_mm;
        let th0 = (start[1] - center[1]).atan2(start[0] - center[0]);
        let th1 = (end_mm[1] - center[1]).atan2(end_mm[0] - center[0]);
        let mut sweep = if ccw {
            let d = (th1 - th0).rem_euclid(std::f64::consts::TAU);
            if d == 0.0 { std::f64::consts::TAU } else { d }
        } else {
            let d = (th0 - th1).rem_euclid(std::f64::consts::TAU);
            -(if d == 0.0 { std::f64::consts::TAU } else { d })
        };
        sweep += sweep.signum() * std::f64::consts::TAU * (turns - 1) as f64;
        self.warn_near_coincident(start, end_mm, sweep);
        let arc = Arc {
            center_m: [m_from_mm(center[0]), m_from_mm(center[1])],
            r_start_m: m_from_mm(r_start),
            r_end_m: m_from_mm(r_end),
            theta_start_rad: th0,
            sweep_rad: sweep,
        };
        self.segments.push(Segment {
            geometry: Geometry::Arc(arc),
            start_m: self.pos_m(),
            end_m: end_mm.map(m_from_mm),
            motion: Motion::Feed,
            feed_m_per_s: self.feed_for(Motion::Feed),
            blend: self.blend,
            line: self.line,
            jerk_limited: self.jerk_limited,
        });
        self.pos_mm = end_mm;
        Ok(())
    }

    fn arc_turns(&self, offset: u32) -> IResult<u32> {
        match self.block.get(b'P') {
            None => Ok(1),
            Some(p) if p >= 1.0 && p.fract() == 0.0 && p <= 10_000.0 => Ok(p as u32),
            Some(p) => err(
                offset,
                GcodeErrorKind::Invalid(format!("arc P{p}: turns must be a positive integer")),
            ),
        }
    }

    fn ij_arc_center(&self, end: [f64; 3]) -> IResult<([f64; 2], f64, f64)> {
        let start = self.pos_mm;
        let i = self.block.get(b'I').unwrap_or(0.0) * self.mm_per_unit;
        let j = self.block.get(b'J').unwrap_or(0.0) * self.mm_per_unit;
        let start_prog = self.machine_to_program(start);
        let center_prog = if self.arc_absolute {
            [i, j, 0.0]
        } else {
            [start_prog[0] + i, start_prog[1] + j, 0.0]
        };
        let c = self.program_to_machine(center_prog);
        let center = [c[0], c[1]];
        let r_start = (start[0] - center[0]).hypot(start[1] - center[1]);
        let r_end = (end[0] - center[0]).hypot(end[1] - center[1]);
        let slack = R_ARC_SLACK_INCH * MM_PER_INCH;
        if r_start < slack || r_end < slack {
            return err(
                self.block.offset_of(b'I').max(self.block.offset_of(b'J')),
                GcodeErrorKind::ZeroRadiusArc,
            );
        }
        // LinuxCNC's rule: an error beyond 100× the absolute tolerance, or beyond both the
        // absolute and the relative tolerance.
        let tol = if self.mm_per_unit == 1.0 {
            ARC_RADIUS_TOL_MM
        } else {
            ARC_RADIUS_TOL_INCH * MM_PER_INCH
        };
        let diff = (r_start - r_end).abs();
        let rel = diff / r_start.max(r_end);
        if diff > 100.0 * tol || (rel > ARC_RADIUS_REL_TOL && diff > tol) {
            let off = self.first_axis_offset();
            return err(
                off,
                GcodeErrorKind::ArcRadiusMismatch {
                    r_start_mm: r_start,
                    r_end_mm: r_end,
                    diff_mm: diff,
                    tolerance_mm: tol,
                },
            );
        }
        Ok((center, r_start, r_end))
    }

    fn r_arc_center(&mut self, ccw: bool, r: f64, end: [f64; 3]) -> IResult<([f64; 2], f64, f64)> {
        let start = self.pos_mm;
        let r_mm = r * self.mm_per_unit;
        let (dx, dy) = (end[0] - start[0], end[1] - start[1]);
        let chord = dx.hypot(dy);
        let off = self.block.offset_of(b'R');
        if chord == 0.0 {
            return err(off, GcodeErrorKind::RArcFullCircle);
        }
        let abs_r = r_mm.abs();
        let half = chord / 2.0;
        if abs_r < half - R_ARC_SLACK_INCH * MM_PER_INCH {
            return err(
                off,
                GcodeErrorKind::ArcRadiusTooSmall {
                    r_mm: abs_r,
                    chord_mm: chord,
                },
            );
        }
        let abs_r = abs_r.max(half);
        let h = (abs_r * abs_r - half * half).max(0.0).sqrt();
        // Centre on the left of the chord for a CCW minor arc (or a CW major arc).
        let left = ccw == (r_mm > 0.0);
        let (nx, ny) = if left {
            (-dy / chord, dx / chord)
        } else {
            (dy / chord, -dx / chord)
        };
        let center = [start[0] + dx / 2.0 + nx * h, start[1] + dy / 2.0 + ny * h];
        self.warn_badly_conditioned_r(abs_r, half, h);
        Ok((center, abs_r, abs_r))
    }

    fn warn_badly_conditioned_r(&mut self, r: f64, half: f64, h: f64) {
        let sweep_deg = 2.0 * (half / r).min(1.0).asin().to_degrees();
        if (180.0 - sweep_deg).abs() < R_ARC_NEAR_HALF_DEG {
            // d(centre)/d(end point) grows like half/h: how far 1 µm of rounding moves it.
            let moved_um = if h > 0.0 { half / h } else { f64::INFINITY };
            self.warnings.push(Warning {
                line: self.line,
                message: format!(
                    "R-format arc spans {:.2}° (near a half circle): its centre is badly \
                     conditioned, 1 µm of end-point rounding moves it by {:.0} µm; prefer I/J",
                    sweep_deg, moved_um
                ),
            });
        }
    }

    fn warn_near_coincident(&mut self, start: [f64; 3], end: [f64; 3], sweep: f64) {
        let d = (end[0] - start[0]).hypot(end[1] - start[1]);
        if d > 0.0 && d < NEAR_COINCIDENT_MM {
            self.warnings.push(Warning {
                line: self.line,
                message: format!(
                    "arc start and end nearly coincide ({:.3} µm apart): read as a {:.1}° arc",
                    d * 1000.0,
                    sweep.abs().to_degrees()
                ),
            });
        }
    }
}
