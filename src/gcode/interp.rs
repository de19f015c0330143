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
use crate::numeric::units::{MM_PER_INCH, m_from_mm, m_per_s_from_mm_per_min};
use crate::path::{Blend, Geometry, Motion, Plane, Segment};

mod arc;
mod coords;
mod program;

pub use program::{CodeNote, Event, Program, SourceLine};

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
    /// Millimetres per unit of the feed where it does not follow `mm_per_unit` (SINUMERIK
    /// `G70`/`G71`: the feed stays in the basic system, metric here).
    feed_mm_per_unit: Option<f64>,
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
    /// What ended the program: `M2/M30`, or the closing `%` of a `%`-demarcated program.
    end_word: &'static str,
}
impl Interpreter {
    /// A fresh interpreter in RS274/NGC's start-up state: G17 G21 G40 G49 G54 G64 G80 G90
    /// G91.1 G94.
    pub(crate) fn new(file: &str, opts: InterpretOptions) -> Self {
        Interpreter {
            file: file.to_string(),
            mm_per_unit: 1.0,
            feed_mm_per_unit: None,
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
            end_word: "M2/M30",
            opts,
        }
    }

    /// Pre-sizes the output for a program of `bytes` bytes (one segment per ~25 bytes).
    pub(crate) fn reserve_for(&mut self, bytes: usize) {
        self.segments.reserve(bytes / 25);
    }

    /// Executes one block. `block_delete` is the block's `/` flag.
    pub(crate) fn execute(&mut self, line: u32, words: &[Word], block_delete: bool) -> IResult<()> {
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

    /// Keeps feeds in the basic system (metric) whatever the length unit of the geometry
    /// (`true`: SINUMERIK `G70`/`G71`), or lets them follow it (`false`: `G700`/`G710`, and
    /// RS274/NGC's `G20`/`G21`).
    pub(crate) fn feed_in_basic_system(&mut self, basic: bool) {
        self.feed_mm_per_unit = basic.then_some(1.0);
    }

    /// Whether the program has ended (`M2`, `M30`).
    pub(crate) fn has_ended(&self) -> bool {
        self.ended
    }

    /// Counts `n` blocks left unrun after the program's end.
    pub(crate) fn skipped_after_end(&mut self, n: usize) {
        self.lines_after_end += n;
    }

    /// Ends the program at its closing `%` (RS274/NGC: a program opened by a `%` line ends
    /// at the next), unless it ended before; `n` lines with words follow it.
    pub(crate) fn end_at_tape_marker(&mut self, n: usize) {
        if !self.ended {
            self.ended = true;
            self.end_word = "the closing %";
        }
        self.lines_after_end += n;
    }

    pub(crate) fn warn(&mut self, line: u32, message: String) {
        self.warnings.push(Warning { line, message });
    }

    /// The interpreted program.
    pub(crate) fn finish(mut self, lines: usize) -> Program {
        if let Some(message) = self.unknown_m.warning() {
            // The warning lists its lines itself: it concerns the whole program.
            self.warnings.push(Warning { line: 0, message });
        }
        if self.lines_after_end > 0 {
            self.warnings.push(Warning {
                line: 0,
                message: format!(
                    "{} block(s) after the program end ({}) were not executed",
                    self.lines_after_end, self.end_word
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
            self.feed_mm_per_min = f * self.feed_mm_per_unit.unwrap_or(self.mm_per_unit);
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
            plane: self.plane,
        });
    }

    fn set_modes(&mut self, gs: &[(u16, u32)]) -> IResult<()> {
        for &(code, offset) in gs {
            match code {
                170 => self.plane = Plane::Xy,
                180 => self.plane = Plane::Zx,
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
            plane: self.plane,
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
}
