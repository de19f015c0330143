//! The results of a check for people (a summary) and for scripts (JSON, CSV).
//!
//! The JSON report's schema is versioned by its `schema` field (`contourcheck.check/1`) and
//! documented field by field in `docs/report-schema.md`; a field is never removed or
//! changed in meaning without a new version. Lengths are in mm, errors in µm, times in s.

use crate::analysis::circular::CircularTest;
use std::io::Write;

use serde::Serialize;

use crate::analysis::contour::ContourPoint;
use crate::analysis::hotspot::Hotspot;
use crate::check::{CheckResult, CheckSettings, RunPlace, Summary};
use crate::gcode::interp::SourceLine;
use crate::gcode::{CodeNote, Program, SourceFile, Warning};
use crate::machine::MachineConfig;
use crate::numeric::units::{mm_from_m, um_from_m};
use crate::plan::execute::RunChunk;

/// Version tag of the JSON report.
pub const SCHEMA: &str = "contourcheck.check/1";

/// The JSON report of a check.
#[derive(Debug, Clone, Serialize)]
pub struct CheckReport {
    /// Schema version tag.
    pub schema: &'static str,
    /// The program.
    pub program: ProgramInfo,
    /// The machine.
    pub machine: MachineInfo,
    /// Planner and simulator settings.
    pub settings: SettingsInfo,
    /// Planned cycle time (s).
    pub cycle_time_s: f64,
    /// Path length with rapids (mm).
    pub path_length_mm: f64,
    /// Length of the cutting moves (mm).
    pub cut_length_mm: f64,
    /// Contour error while cutting.
    pub contour_error_um: ContourInfo,
    /// Following error per axis.
    pub following_error_um: FollowingInfo,
    /// XY positioning error while a feed block moves Z alone or dwells (the axes settling
    /// after they arrived; not part of the contour).
    pub positioning_error_um: PositioningInfo,
    /// The tolerance given, if any (µm).
    pub tolerance_um: Option<f64>,
    /// Whether the largest contour error is within it (absent without a tolerance).
    pub within_tolerance: Option<bool>,
    /// Hotspots, ranked by |error|.
    pub hotspots: Vec<HotspotInfo>,
    /// Circular-test figures (ISO 230-4) of the program's full circles, predicted.
    pub circular_test: CircularTest,
    /// Warnings from the interpreter and the planner.
    pub warnings: Vec<Warning>,
    /// Codes accepted without effect on the XY path.
    pub accepted_codes: Vec<CodeNote>,
}

/// Program facts.
#[derive(Debug, Clone, Serialize)]
pub struct ProgramInfo {
    /// File name as given.
    pub file: String,
    /// Source lines.
    pub lines: usize,
    /// Blocks with words.
    pub blocks: usize,
    /// Path segments.
    pub segments: usize,
}

/// Machine facts.
#[derive(Debug, Clone, Serialize)]
pub struct MachineInfo {
    /// Name.
    pub name: String,
    /// Description.
    pub description: String,
}

/// Settings used.
#[derive(Debug, Clone, Serialize)]
pub struct SettingsInfo {
    /// Speed profile.
    pub profile: crate::plan::ProfileKind,
    /// Interpolation cycle (ms).
    pub interpolation_cycle_ms: f64,
    /// Simulation step (ms).
    pub simulation_step_ms: f64,
}

/// Contour error figures.
#[derive(Debug, Clone, Serialize)]
pub struct ContourInfo {
    /// Largest |error| (µm).
    pub max: f64,
    /// Root mean square (µm).
    pub rms: f64,
    /// Where the largest occurs.
    pub max_at: Option<Location>,
    /// The largest part of the error in the block's plane (µm), where Z is simulated.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_in_plane: Option<f64>,
    /// The largest part across the block's plane (µm), where Z is simulated.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_across: Option<f64>,
}

/// The largest XY positioning error while only Z moves or the program dwells.
#[derive(Debug, Clone, Serialize)]
pub struct PositioningInfo {
    /// Largest distance from the commanded point (µm).
    pub max: f64,
    /// Its source line, if any.
    pub line: Option<u32>,
    /// The subprogram's file the line is in, when it is not the program's own.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub file: Option<String>,
    /// Its time (s), if any.
    pub t_s: Option<f64>,
    /// The block number (N word) of its line, where the program gives one.
    pub block_number: Option<u32>,
}

/// A place in the run.
#[derive(Debug, Clone, Serialize)]
pub struct Location {
    /// Time (s).
    pub t_s: f64,
    /// Actual X (mm).
    pub x_mm: f64,
    /// Actual Y (mm).
    pub y_mm: f64,
    /// Source line of the block being executed.
    pub line: u32,
    /// The subprogram's file the line is in, when it is not the program's own.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub file: Option<String>,
    /// Its block number (N word), where the program gives one.
    pub block_number: Option<u32>,
}

/// Following error figures.
#[derive(Debug, Clone, Serialize)]
pub struct FollowingInfo {
    /// X axis.
    pub x: AxisFollowing,
    /// Y axis.
    pub y: AxisFollowing,
    /// Z axis, where simulated.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub z: Option<AxisFollowing>,
}

/// One axis's following error.
#[derive(Debug, Clone, Serialize)]
pub struct AxisFollowing {
    /// Largest |error| while cutting (µm).
    pub max_cutting: f64,
    /// Largest |error| including rapids (µm).
    pub max: f64,
}

/// One hotspot in the report.
#[derive(Debug, Clone, Serialize)]
pub struct HotspotInfo {
    /// 1-based rank.
    pub rank: usize,
    /// The hotspot.
    #[serde(flatten)]
    pub hotspot: Hotspot,
    /// Human-readable cause.
    pub label: String,
    /// The subprogram's file the line is in, when it is not the program's own.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub file: Option<String>,
    /// The block number (N word) of its line, where the program gives one.
    pub block_number: Option<u32>,
}

/// A line of the program as the report names it: its file (a subprogram's own file, else
/// none) and its line there.
fn placed(program: &Program, line: u32) -> (Option<String>, u32) {
    let at = program.source_line(line);
    (at.file.map(str::to_string), at.line)
}

impl SettingsInfo {
    /// The planner's and simulator's settings a run used.
    fn of(run: &CheckResult, settings: &CheckSettings) -> Self {
        SettingsInfo {
            profile: run.plan.config.profile,
            interpolation_cycle_ms: run.plan.config.cycle_s * 1e3,
            simulation_step_ms: run.dt_s * 1e3 / f64::from(settings.sim.substeps.max(1)),
        }
    }
}

impl Location {
    /// A place of the run, named by the program's file and line.
    fn of(p: &RunPlace, program: &Program) -> Self {
        let (file, line) = placed(program, p.line);
        Location {
            t_s: p.t_s,
            x_mm: mm_from_m(p.pos_m[0]),
            y_mm: mm_from_m(p.pos_m[1]),
            line,
            file,
            block_number: program.block_number(p.line),
        }
    }
}

impl FollowingInfo {
    /// The simulated axes' largest following errors, while cutting and with the rapids.
    fn of(s: &Summary) -> Self {
        let axis = |i: usize| AxisFollowing {
            max_cutting: um_from_m(s.max_following_error_cutting_m[i]),
            max: um_from_m(s.max_following_error_m[i]),
        };
        FollowingInfo {
            x: axis(0),
            y: axis(1),
            z: s.z_following_error_m.map(|[cutting, all]| AxisFollowing {
                max_cutting: um_from_m(cutting),
                max: um_from_m(all),
            }),
        }
    }
}

impl PositioningInfo {
    /// The largest settling error and where it is.
    fn of(s: &Summary, program: &Program) -> Self {
        let at = s.max_positioning_at;
        PositioningInfo {
            max: um_from_m(s.max_positioning_error_m),
            line: at.map(|a| placed(program, a.0).1),
            file: at.and_then(|a| placed(program, a.0).0),
            t_s: at.map(|a| a.1),
            block_number: at.and_then(|a| program.block_number(a.0)),
        }
    }
}

impl HotspotInfo {
    /// The run's hotspots, ranked as found, their lines named by file.
    fn ranked(hotspots: &[Hotspot], program: &Program) -> Vec<Self> {
        hotspots
            .iter()
            .enumerate()
            .map(|(i, h)| {
                let (file, line) = placed(program, h.line);
                HotspotInfo {
                    rank: i + 1,
                    hotspot: Hotspot { line, ..h.clone() },
                    label: h.label(),
                    file,
                    block_number: program.block_number(h.line),
                }
            })
            .collect()
    }
}

impl CheckReport {
    /// Assembles the report of a run.
    pub fn new(
        run: &CheckResult,
        settings: &CheckSettings,
        program: &Program,
        machine: &MachineConfig,
        tolerance_um: Option<f64>,
    ) -> Self {
        let s = &run.summary;
        let max_um = um_from_m(s.max_contour_error_m);
        CheckReport {
            schema: SCHEMA,
            program: ProgramInfo {
                file: program.file.clone(),
                lines: program.lines,
                blocks: program.blocks,
                segments: run.plan.segments.len(),
            },
            machine: MachineInfo {
                name: machine.name.clone(),
                description: machine.description.clone(),
            },
            settings: SettingsInfo::of(run, settings),
            cycle_time_s: s.cycle_time_s,
            path_length_mm: mm_from_m(s.path_length_m),
            cut_length_mm: mm_from_m(s.cut_length_m),
            contour_error_um: ContourInfo {
                max: max_um,
                rms: um_from_m(s.rms_contour_error_m),
                max_at: run.max_at.map(|p| Location::of(&p, program)),
                max_in_plane: s.max_components_m.map(|c| um_from_m(c[0])),
                max_across: s.max_components_m.map(|c| um_from_m(c[1])),
            },
            following_error_um: FollowingInfo::of(s),
            positioning_error_um: PositioningInfo::of(s, program),
            tolerance_um,
            within_tolerance: tolerance_um.map(|t| max_um <= t),
            hotspots: HotspotInfo::ranked(&run.hotspots, program),
            warnings: program
                .warnings
                .iter()
                .chain(&run.plan.warnings)
                .map(|w| program.placed(w.clone()))
                .collect(),
            accepted_codes: program.notes.clone(),
            circular_test: run.circular.clone(),
        }
    }

    /// The report as pretty JSON.
    pub(crate) fn write_json(&self, w: &mut dyn Write) -> std::io::Result<()> {
        serde_json::to_writer_pretty(&mut *w, self).map_err(std::io::Error::other)?;
        writeln!(w)
    }
}

/// A run written as CSV chunk by chunk as it is simulated, one row every `every` samples:
/// time, line, commanded and actual X/Y (mm), following errors and contour error (µm; empty
/// while not cutting); where Z is simulated and some block is measured in space, then
/// commanded and actual Z, its following error and the contour error's parts in the block's
/// plane and across it.
#[derive(Debug, Clone)]
pub struct TraceCsv {
    every: usize,
    started: bool,
    /// Whether the rows give Z: where it is simulated and some block is measured in space
    /// (a 2.5-D program's trace is the same with Z simulated or carried).
    with_z: bool,
    /// The program's subprogram files, whose lines the `line` column names by file.
    sources: Vec<SourceFile>,
}

impl TraceCsv {
    /// The trace of `program`, keeping every `every`-th sample.
    pub(crate) fn of(program: &Program, every: usize) -> Self {
        TraceCsv {
            sources: program.sources.clone(),
            ..TraceCsv::new(every)
        }
    }

    /// A trace keeping every `every`-th sample.
    pub(crate) fn new(every: usize) -> Self {
        TraceCsv {
            every: every.max(1),
            started: false,
            with_z: false,
            sources: Vec::new(),
        }
    }

    /// Writes the rows of the next chunk (with the header before the first).
    pub(crate) fn write_chunk(
        &mut self,
        w: &mut dyn Write,
        chunk: &RunChunk,
        points: &[ContourPoint],
    ) -> std::io::Result<()> {
        let mut out = csv::Writer::from_writer(w);
        if !self.started {
            let mut header = vec![
                "t_s",
                "line",
                "x_ref_mm",
                "y_ref_mm",
                "x_mm",
                "y_mm",
                "fe_x_um",
                "fe_y_um",
                "contour_um",
            ];
            self.with_z =
                chunk.z.is_some() && chunk.plan.segments.iter().any(|s| s.is_contour_in_space());
            if self.with_z {
                header.extend(["z_ref_mm", "z_mm", "fe_z_um", "in_plane_um", "across_um"]);
            }
            out.write_record(header)?;
            self.started = true;
        }
        let c = chunk.commands;
        let first_kept = chunk.first.next_multiple_of(self.every) - chunk.first;
        let um_or_empty = |e: f64| {
            if e.is_finite() {
                format!("{:.4}", um_from_m(e))
            } else {
                String::new()
            }
        };
        for i in (first_kept..points.len().min(chunk.x.len())).step_by(self.every) {
            let mut row = vec![
                format!("{:.4}", c.time_s(chunk.first + i)),
                SourceLine::among(
                    &self.sources,
                    chunk.plan.segments[c.segment[i] as usize].line,
                )
                .short(),
                format!("{:.6}", mm_from_m(c.x.pos_m[i])),
                format!("{:.6}", mm_from_m(c.y.pos_m[i])),
                format!("{:.6}", mm_from_m(chunk.x.pos_m[i])),
                format!("{:.6}", mm_from_m(chunk.y.pos_m[i])),
                format!("{:.4}", um_from_m(chunk.x.following_error_m(i))),
                format!("{:.4}", um_from_m(chunk.y.following_error_m(i))),
                um_or_empty(points[i].error_m),
            ];
            if let Some(z) = chunk.z.as_ref().filter(|_| self.with_z) {
                row.extend([
                    format!("{:.6}", mm_from_m(c.z.pos_m[i])),
                    format!("{:.6}", mm_from_m(z.pos_m[i])),
                    format!("{:.4}", um_from_m(z.following_error_m(i))),
                    um_or_empty(points[i].in_plane_m),
                    um_or_empty(points[i].across_m),
                ]);
            }
            out.write_record(&row)?;
        }
        out.flush()
    }
}

/// The human-readable summary.
pub(crate) fn summary_text(r: &CheckReport, max_hotspots: usize) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "program   {} ({} lines, {} blocks)",
        r.program.file, r.program.lines, r.program.blocks
    );
    let _ = writeln!(
        s,
        "machine   {} — {}",
        r.machine.name, r.machine.description
    );
    let _ = writeln!(
        s,
        "settings  {} profile, interpolation {} ms, simulation step {} ms",
        r.settings.profile, r.settings.interpolation_cycle_ms, r.settings.simulation_step_ms
    );
    let _ = writeln!(
        s,
        "cycle     {:.2} s over {:.1} mm ({:.1} mm cutting)",
        r.cycle_time_s, r.path_length_mm, r.cut_length_mm
    );
    let at = r
        .contour_error_um
        .max_at
        .as_ref()
        .map_or(String::new(), |l| {
            format!(
                " at {}{} (X {:.3}, Y {:.3} mm, t {:.3} s)",
                in_file(l.file.as_deref(), l.line),
                l.block_number.map_or(String::new(), |n| format!(" N{n}")),
                l.x_mm,
                l.y_mm,
                l.t_s
            )
        });
    let _ = writeln!(
        s,
        "contour   max {:.2} µm{at}, RMS {:.2} µm",
        r.contour_error_um.max, r.contour_error_um.rms
    );
    let _ = writeln!(s, "{}", contour_note(r));
    let p = &r.positioning_error_um;
    if let (Some(line), Some(t)) = (p.line, p.t_s)
        && p.max >= 0.005
    {
        let block = p.block_number.map_or(String::new(), |n| format!(" N{n}"));
        let _ = writeln!(
            s,
            "settling max {:.2} µm at {}{block} (t {t:.3} s): XY still arriving while only Z \
             moves or the program dwells",
            p.max,
            in_file(p.file.as_deref(), line)
        );
    }
    let _ = writeln!(s, "{}", following_line(&r.following_error_um));
    if let (Some(t), Some(ok)) = (r.tolerance_um, r.within_tolerance) {
        let verdict = if ok { "within" } else { "EXCEEDS" };
        let _ = writeln!(s, "tolerance {t} µm: the predicted maximum {verdict} it");
    }
    if !r.circular_test.circles.is_empty() {
        let _ = writeln!(s, "\ncircular test (ISO 230-4 figures, predicted)");
        s.push_str(&r.circular_test.text());
    }
    if !r.hotspots.is_empty() {
        s.push_str(&hotspot_table(r, max_hotspots));
    }
    s
}

/// The line under the contour figure: how it was measured, and its parts where some blocks
/// were measured in space.
fn contour_note(r: &CheckReport) -> String {
    match (
        r.contour_error_um.max_in_plane,
        r.contour_error_um.max_across,
    ) {
        (Some(in_plane), Some(across)) => {
            format!(
                "          (3-D distance to the path on blocks that move Z or lie in ZX or YZ, XY \
                 elsewhere; largest part in the block's plane {in_plane:.2} µm, across it {across:.2} µm; signed + \
                 to the left of travel in the plane)"
            )
        }
        _ => "          (XY feed moves only; signed + to the left of the direction of travel: \
              inside a ccw circle, outside a cw one)"
            .to_string(),
    }
}

/// The simulated axes' largest following errors, while cutting and with the rapids.
fn following_line(fe: &FollowingInfo) -> String {
    match &fe.z {
        None => {
            format!(
                "following max while cutting: X {:.1} µm, Y {:.1} µm (with rapids: X {:.1} µm, \
                 Y {:.1} µm)",
                fe.x.max_cutting, fe.y.max_cutting, fe.x.max, fe.y.max
            )
        }
        Some(z) => {
            format!(
                "following max while cutting: X {:.1} µm, Y {:.1} µm, Z {:.1} µm (with rapids: \
                 X {:.1} µm, Y {:.1} µm, Z {:.1} µm)",
                fe.x.max_cutting, fe.y.max_cutting, z.max_cutting, fe.x.max, fe.y.max, z.max
            )
        }
    }
}

/// "line 16", or "L1.SPF line 7" for a line of a subprogram's file.
fn in_file(file: Option<&str>, line: u32) -> String {
    match file {
        Some(f) => format!("{} line {line}", file_name(f)),
        None => format!("line {line}"),
    }
}

/// A file's name without its folder.
fn file_name(path: &str) -> &str {
    std::path::Path::new(path)
        .file_name()
        .and_then(|n| n.to_str())
        .unwrap_or(path)
}

/// The hotspot table: the largest `max_hotspots`, with the program's own block numbers
/// beside the file's lines where it gives them.
fn hotspot_table(r: &CheckReport, max_hotspots: usize) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let _ = writeln!(s, "\nhotspots (largest first)");
    let numbered = r.hotspots.iter().any(|h| h.block_number.is_some());
    let line_of = |h: &HotspotInfo| match &h.file {
        Some(file) => format!("{}:{}", file_name(file), h.hotspot.line),
        None => h.hotspot.line.to_string(),
    };
    let shown = || r.hotspots.iter().take(max_hotspots);
    let width = shown().map(|h| line_of(h).len()).max().unwrap_or(4).max(4);
    let with_z = r.hotspots.iter().any(|h| h.hotspot.z_mm.is_some());
    let _ = writeln!(
        s,
        "  rank  {:>width$}{}   time (s)     X (mm)     Y (mm){}   error (µm)  spike (µm)  cause",
        "line",
        if numbered { "  block" } else { "" },
        if with_z { "     Z (mm)" } else { "" }
    );
    for h in shown() {
        let hs = &h.hotspot;
        let block = match (numbered, h.block_number) {
            (false, _) => String::new(),
            (true, Some(n)) => format!("  {:>5}", format!("N{n}")),
            (true, None) => format!("  {:>5}", ""),
        };
        let line = line_of(h);
        let z = hs.z_mm.map_or(String::new(), |z| format!("  {z:>9.3}"));
        let _ = writeln!(
            s,
            "  {:>4}  {line:>width$}{block}  {:>9.3}  {:>9.3}  {:>9.3}{z}  {:>11.2}  {:>10.2}  {}",
            h.rank, hs.t_s, hs.x_mm, hs.y_mm, hs.error_um, hs.excess_um, h.label
        );
    }
    if r.hotspots.len() > max_hotspots {
        let _ = writeln!(
            s,
            "  … {} more (--json lists them all)",
            r.hotspots.len() - max_hotspots
        );
    }
    s
}

/// Warnings with the same message merged into one line listing where they occur
/// ("lines 11, 14, 17 … (143 places): message"), in order of first appearance.
pub(crate) fn group_warnings(warnings: &[crate::gcode::Warning]) -> Vec<String> {
    let mut groups: Vec<(&str, Vec<u32>)> = Vec::new();
    for w in warnings {
        match groups.iter_mut().find(|(m, _)| *m == w.message) {
            Some((_, lines)) => {
                // A line run more than once (a loop, a subprogram) is named once.
                if !lines.contains(&w.line) {
                    lines.push(w.line);
                }
            }
            None => groups.push((&w.message, vec![w.line])),
        }
    }
    groups
        .into_iter()
        .map(|(message, lines)| match lines.as_slice() {
            [0] => message.to_string(),
            [one] => format!("line {one}: {message}"),
            many => {
                let shown: Vec<String> = many.iter().take(3).map(u32::to_string).collect();
                let more = if many.len() > 3 {
                    format!(" … ({} places)", many.len())
                } else {
                    String::new()
                };
                format!("lines {}{more}: {message}", shown.join(", "))
            }
        })
        .collect()
}
