//! The results of a check for people (a summary) and for scripts (JSON, CSV).
//!
//! The JSON report's schema is versioned by its `schema` field (`contourcheck.check/1`) and
//! documented field by field in `docs/report-schema.md`; a field is never removed or
//! changed in meaning without a new version. Lengths are in mm, errors in µm, times in s.

use crate::analysis::circular::CircularTest;
use serde::Serialize;

use crate::analysis::hotspot::Hotspot;
use crate::check::{CheckResult, CheckSettings, RunPlace, Summary};
use crate::gcode::{CodeNote, Program, Warning};
use crate::machine::MachineConfig;
use crate::numeric::units::{mm_from_m, um_from_m};
use crate::sim::AxisModel;

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
    /// Simulation step (ms): the finest any axis took.
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
    /// Largest |error| while cutting (µm): feed moves, not dwells.
    pub max_cutting: f64,
    /// Largest |error| including rapids, waits and dwells (µm).
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
    /// The planner's and simulator's settings a run used; the simulation step is the finest
    /// any axis took (presliding bristles may divide the cycle more finely than the settings).
    fn of(run: &CheckResult, settings: &CheckSettings, machine: &MachineConfig) -> Self {
        let substeps = machine
            .simulated_configs()
            .into_iter()
            .map(|c| AxisModel::from_config(c).substeps(run.dt_s, &settings.sim))
            .max()
            .unwrap_or(1);
        SettingsInfo {
            profile: run.plan.config.profile,
            interpolation_cycle_ms: run.plan.config.cycle_s * 1e3,
            simulation_step_ms: run.dt_s * 1e3 / substeps as f64,
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
            settings: SettingsInfo::of(run, settings, machine),
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
}

/// Warnings with the same message merged into one line listing where they occur
/// ("lines 11, 14, 17 … (143 places): message"), in order of first appearance: the command's
/// and the HTML page's words.
#[cfg(feature = "html-report")]
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
