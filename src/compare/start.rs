//! The record's own start. A record is seldom the whole program from rest: a logger started
//! late begins mid-block with the axes moving and lagging; a trace of a program's start
//! begins where the machine stood, its first move an approach the program does not hold;
//! a logger stopped early ends before the program does. What is compared, and from where:
//!
//! - **In motion**: the model cannot start at rest where the machine was half a millimetre
//!   behind its command. Before the record's first command it runs in on that command's
//!   speed (from rest, at the machine's acceleration, then a second at that speed) and so
//!   enters the record in the steady state of its own loops; what the run-in cannot know —
//!   how the machine came there — dies away in a settling stretch that is simulated but not
//!   compared, as long as the nominal model takes to forget a start from rest to a thousandth
//!   of it.
//! - **Before the program**: the comparison begins where the commands join the program's
//!   path (`trace::placement`). The approach before is not simulated — the model file may
//!   not follow a rapid the machine ran at 36 m/min — and the model starts at rest where the
//!   record has the machine at the join, which may still be arriving; a settling stretch
//!   lasts as long as the model takes to forget whether it started there or at the command.
//! - **An axis that stands** at the start of a record cut from a longer one stood for a time
//!   the record does not show, with whatever its integral action holds: it is compared from
//!   a little after it first moves (`Context::unknown_standing`).
//! - **Part of the program**: the record is compared on the blocks it covers, and the report
//!   names them.
//!
//! Without recorded commands the plan is the timeline and the model runs the program from
//! its start; the report says that the part before the record is taken as planned.

use serde::Serialize;

use crate::machine::{AxisName, MachineConfig};
use crate::plan::{AxisCommands, Commands};
use crate::sim::{AxisModel, SimConfig, simulate};

/// How a record begins against its program.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum StartKind {
    /// Its commands stand on the program's path at its first sample: the model starts at
    /// rest there, as the machine does.
    AtRest,
    /// Its commands move along the program's path at its first sample (a logger started
    /// mid-program): the model runs in on their speed before the record, and a settling
    /// stretch is simulated but not compared.
    InMotion,
    /// Its commands begin off the program's path (where the machine stood, its home): they
    /// drive the model from there, and the comparison begins where they join the path.
    BeforeProgram,
    /// No recorded commands: the program's plan is the timeline, from the program's start.
    Planned,
}

/// How a record's start was set, on the simulation's timeline.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Start {
    /// How it begins.
    pub kind: StartKind,
    /// Simulated before the comparison's first command (s): a run-in, or the one sample
    /// that starts the model where the record has the machine at the join.
    pub run_in_s: f64,
    /// Where the recorded commands join the program's path, after the record's start (s);
    /// the commands before (an approach the program does not hold) are left out.
    pub join_s: f64,
    /// Per axis (X, Y), simulated but not compared after the run-in (s).
    pub settling_s: [f64; 2],
    /// Where the record's commands begin (m), X and Y.
    pub first_command_m: [f64; 2],
    /// Whether the comparison starts at the program's start (before or at its first feed
    /// move in the plane); with the plan as timeline, the plan's start.
    pub at_program_start: bool,
    /// Where the commands join the program after an approach: where and how fast the
    /// record has the machine there, per axis, which every model's run-in is made to arrive
    /// at (`Context::simulate_axis`).
    pub(crate) arrival: Option<[Arrival; 2]>,
    /// Whether the approach before the join drove the model (it follows it), simulated but
    /// not compared; else it is left out and the model run in to the record's state.
    pub approach_simulated: bool,
}

impl Start {
    /// A record compared from its first sample on the plan's timeline.
    pub(crate) fn planned() -> Start {
        Start {
            kind: StartKind::Planned,
            run_in_s: 0.0,
            join_s: 0.0,
            settling_s: [0.0; 2],
            first_command_m: [0.0; 2],
            at_program_start: true,
            arrival: None,
            approach_simulated: false,
        }
    }

    /// The time on the simulation's timeline (s) before which nothing is compared: where
    /// the first axis has settled.
    pub fn compared_from_s(&self) -> f64 {
        self.run_in_s + self.settling_s[0].min(self.settling_s[1])
    }
}

/// A run-in's cruise at the record's first speed (s): long against any loop's time constant.
const RUN_IN_CRUISE_S: f64 = 1.0;

/// A command slower than this stands (m/s).
const MOVING_M_PER_S: f64 = 1e-5;

/// Whether recorded commands move at their first sample. A command that sets off from rest
/// at its first sample shows there, as a difference of samples, no more speed than its
/// acceleration there gives in a sample or two; one already moving shows its speed.
pub(crate) fn starts_in_motion(commands: &Commands) -> bool {
    if commands.len() < 2 {
        return false;
    }
    let peak_accel = (0..commands.len().min(3))
        .map(|k| commands.x.acc_m_per_s2[k].hypot(commands.y.acc_m_per_s2[k]))
        .fold(0.0, f64::max);
    let setting_off = 2.0 * peak_accel * commands.dt_s;
    commands.x.vel_m_per_s[0].hypot(commands.y.vel_m_per_s[0]) > MOVING_M_PER_S.max(setting_off)
}

/// How an axis arrives at the first command a run-in leads to.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Arrival {
    /// Where (m).
    pub x_m: f64,
    /// How fast (m/s).
    pub v_m_per_s: f64,
    /// Accelerating at (m/s²): a machine braking out of its approach pushes its table from
    /// the other side of its nut's play than one cruising.
    pub a_m_per_s2: f64,
    /// Standing there, the direction it last moved in (±1; 0 unknown): the side its nut's
    /// play and its friction were left on.
    pub came_from: f64,
}

/// How far a run-in to a standstill moves first (m): beyond any play of a nut.
const STANDING_APPROACH_M: f64 = 0.2e-3;
/// How long that move takes (s).
const STANDING_APPROACH_S: f64 = 0.3;

/// `commands` with a run-in before them that arrives at their first sample as `arrive`
/// says, per axis (X, Y): moving, from rest at the machine's acceleration limit to that
/// speed, then at that speed for [`RUN_IN_CRUISE_S`]; standing, by a short move from the
/// side it came from, then standing as long. The model enters the record in the steady
/// state of its own loops. The run-in's length (s).
pub(crate) fn with_run_in(
    commands: &Commands,
    machine: &MachineConfig,
    arrive: [Arrival; 2],
) -> (Commands, f64) {
    run_in_then(commands, machine, arrive)
}

/// `commands` (a record's from where they join the program) with a run-in before them that
/// brings the nominal machine to where and how fast the record has it there (`state`, per
/// axis): the run-in's command leads that place by the model's own lag at that speed, found
/// by running it once; then the record's commands take over. A machine still arriving from
/// its approach, a millimetre short of a command that already stands, is met moving, not at
/// rest. The run-in's length (s).
pub(crate) fn run_in_to_state(
    commands: &Commands,
    machine: &MachineConfig,
    state: [Arrival; 2],
    sim: &SimConfig,
) -> (Commands, f64) {
    let (first, run_in_s) = run_in_then(commands, machine, state);
    let n = (run_in_s / commands.dt_s).round() as usize;
    let lead = AxisName::BOTH.map(|a| {
        let at = state[a.index()];
        // The run-in alone, and one sample on it where the record's commands take over.
        let c = first.axis(a);
        let mut alone = AxisCommands {
            pos_m: c.pos_m[..n].to_vec(),
            vel_m_per_s: c.vel_m_per_s[..n].to_vec(),
            acc_m_per_s2: c.acc_m_per_s2[..n].to_vec(),
        };
        alone.push(at.x_m, at.v_m_per_s, at.a_m_per_s2);
        let model = AxisModel::from_config(machine.axis(a));
        simulate(&model, &alone, commands.dt_s, sim)
            .ok()
            .and_then(|t| t.pos_m.get(n).map(|reached| at.x_m - reached))
            .filter(|lag| lag.is_finite())
            .unwrap_or(0.0)
    });
    let arrive = AxisName::BOTH.map(|a| Arrival {
        x_m: state[a.index()].x_m + lead[a.index()],
        ..state[a.index()]
    });
    run_in_then(commands, machine, arrive)
}

/// How long a run-in accelerates as the record does where it arrives (s): a few of a
/// position loop's time constants, for its state to follow.
const ARRIVAL_ACCELERATION_S: f64 = 0.2;

/// The run-in of one axis: position, speed and acceleration `before` seconds before the
/// first sample, for a run-in of `run_in_s`. Moving: from rest at `accel_limit` to the
/// speed it cruises at, then for [`ARRIVAL_ACCELERATION_S`] at the arrival's acceleration
/// into the arrival's speed. Standing: a raised-cosine move of [`STANDING_APPROACH_M`] from
/// the side it came from, then standing.
fn run_in_at(arrive: Arrival, accel_limit: f64, run_in_s: f64, before: f64) -> (f64, f64, f64) {
    let Arrival {
        x_m: x0,
        v_m_per_s: v0,
        a_m_per_s2: a0,
        came_from,
    } = arrive;
    if v0.abs() <= MOVING_M_PER_S {
        let into = run_in_s - before;
        let u = (into / STANDING_APPROACH_S).clamp(0.0, 1.0);
        let w = std::f64::consts::PI / STANDING_APPROACH_S;
        let d = STANDING_APPROACH_M * came_from;
        let moving = u < 1.0;
        return (
            x0 - d * 0.5 * (1.0 + (std::f64::consts::PI * u).cos()),
            if moving {
                d * 0.5 * w * (w * into).sin()
            } else {
                0.0
            },
            if moving {
                d * 0.5 * w * w * (w * into).cos()
            } else {
                0.0
            },
        );
    }
    let tb = ARRIVAL_ACCELERATION_S;
    // The last stretch at the arrival's acceleration, from the cruise speed v1.
    if before <= tb {
        let t = -before;
        return (x0 + v0 * t + 0.5 * a0 * t * t, v0 + a0 * t, a0);
    }
    let v1 = v0 - a0 * tb;
    let x1 = x0 - v0 * tb + 0.5 * a0 * tb * tb;
    let t_ramp = v1.abs() / accel_limit;
    let accel = if t_ramp > 0.0 { v1 / t_ramp } else { 0.0 };
    let cruise = (run_in_s - tb - t_ramp).max(0.0);
    let before = before - tb;
    if before <= cruise {
        (x1 - v1 * before, v1, 0.0)
    } else {
        let into_ramp = (run_in_s - tb - before).max(0.0);
        let x_ramp_start = x1 - v1 * cruise - 0.5 * v1 * t_ramp;
        (
            x_ramp_start + 0.5 * accel * into_ramp * into_ramp,
            accel * into_ramp,
            accel,
        )
    }
}

/// `commands` after a run-in that arrives at their first sample as `arrive` says, per axis.
/// The run-in's length (s).
fn run_in_then(
    commands: &Commands,
    machine: &MachineConfig,
    arrive: [Arrival; 2],
) -> (Commands, f64) {
    let dt = commands.dt_s;
    let accel_limit = |a: AxisName| machine.axis(a).limits.max_accel_m_per_s2.max(1e-3);
    let lead_s = |a: AxisName| {
        let at = arrive[a.index()];
        if at.v_m_per_s.abs() <= MOVING_M_PER_S {
            STANDING_APPROACH_S
        } else {
            let v1 = at.v_m_per_s - at.a_m_per_s2 * ARRIVAL_ACCELERATION_S;
            v1.abs() / accel_limit(a) + ARRIVAL_ACCELERATION_S
        }
    };
    let lead = lead_s(AxisName::X).max(lead_s(AxisName::Y));
    let samples = ((lead + RUN_IN_CRUISE_S) / dt).ceil() as usize;
    let run_in_s = samples as f64 * dt;
    let axis = |a: AxisName| {
        let c = commands.axis(a);
        let mut out = AxisCommands {
            pos_m: Vec::with_capacity(samples + c.len()),
            vel_m_per_s: Vec::with_capacity(samples + c.len()),
            acc_m_per_s2: Vec::with_capacity(samples + c.len()),
        };
        for k in 0..samples {
            let before = (samples - k) as f64 * dt;
            let (x, v, acc) = run_in_at(arrive[a.index()], accel_limit(a), run_in_s, before);
            out.push(x, v, acc);
        }
        for k in 0..c.len() {
            out.push(c.pos_m[k], c.vel_m_per_s[k], c.acc_m_per_s2[k]);
        }
        out
    };
    // Z is not read from a record: its run-in stands where its commands begin.
    let mut z = AxisCommands {
        pos_m: vec![commands.z.pos_m.first().copied().unwrap_or(0.0); samples],
        vel_m_per_s: vec![0.0; samples],
        acc_m_per_s2: vec![0.0; samples],
    };
    for k in 0..commands.z.len() {
        let c = &commands.z;
        z.push(c.pos_m[k], c.vel_m_per_s[k], c.acc_m_per_s2[k]);
    }
    let mut segment = vec![commands.segment.first().copied().unwrap_or(0); samples];
    segment.extend_from_slice(&commands.segment);
    let run = Commands {
        dt_s: dt,
        x: axis(AxisName::X),
        y: axis(AxisName::Y),
        z,
        segment,
    };
    (run, run_in_s)
}

/// The direction (±1, 0 for none) `c` last moved in before sample `k`.
pub(crate) fn last_direction(c: &AxisCommands, k: usize) -> f64 {
    (0..k.min(c.len()))
        .rev()
        .map(|j| c.vel_m_per_s[j])
        .find(|v| v.abs() > MOVING_M_PER_S)
        .map_or(0.0, f64::signum)
}

/// How much of a record's start to simulate without comparing, per axis (s): until the
/// nominal machine driven by `used` (from sample `used_from`, the record's first command)
/// and by `other` (from `other_from`) — the same commands with another guess of the state
/// at the record's start — have come within a thousandth of their largest difference (or a
/// hundredth of a micrometre) of each other, and stay there: an upper bound on how long a
/// wrong guess of that state shows. An axis that comes to rest against friction keeps the
/// difference until it moves again. At most a third of the record.
pub(crate) fn settling_time(
    machine: &MachineConfig,
    (used, used_from): (&Commands, usize),
    (other, other_from): (&Commands, usize),
    sim: &SimConfig,
) -> [f64; 2] {
    /// How much of the record is looked at (s).
    const WINDOW_S: f64 = 6.0;
    let dt = used.dt_s;
    let record = used.len().saturating_sub(used_from);
    let cap_s = record as f64 * dt / 3.0;
    let window = ((WINDOW_S / dt) as usize)
        .min(record)
        .min(other.len().saturating_sub(other_from));
    let head = |c: &AxisCommands, from: usize| AxisCommands {
        pos_m: c.pos_m[..from + window].to_vec(),
        vel_m_per_s: c.vel_m_per_s[..from + window].to_vec(),
        acc_m_per_s2: c.acc_m_per_s2[..from + window].to_vec(),
    };
    AxisName::BOTH.map(|a| {
        let model = AxisModel::from_config(machine.axis(a));
        let (Ok(u), Ok(o)) = (
            simulate(&model, &head(used.axis(a), used_from), dt, sim),
            simulate(&model, &head(other.axis(a), other_from), dt, sim),
        ) else {
            return cap_s;
        };
        let diff: Vec<f64> = (0..window)
            .map(|k| (u.pos_m[used_from + k] - o.pos_m[other_from + k]).abs())
            .collect();
        let largest = diff.iter().copied().fold(0.0, f64::max);
        let threshold = (1e-3 * largest).max(1e-8);
        let last_above = diff
            .iter()
            .rposition(|&d| d > threshold)
            .map_or(0, |k| k + 1);
        if last_above >= window.saturating_sub(1) && window < record {
            return cap_s;
        }
        (last_above as f64 * dt).min(cap_s)
    })
}

/// Which stretch of the program a record was compared on, and how its start was set.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Coverage {
    /// How the record begins.
    pub start: StartKind,
    /// Source lines of the first and last samples compared.
    pub first_line: u32,
    /// See `first_line`.
    pub last_line: u32,
    /// The program's first and last path lines.
    pub program_first_line: u32,
    /// See `program_first_line`.
    pub program_last_line: u32,
    /// The stretch compared, on the record's own clock (s).
    pub compared_from_s: f64,
    /// See `compared_from_s`.
    pub compared_to_s: f64,
    /// Where the record's commands begin, off the program's path (mm, program coordinates):
    /// where the machine stood before its approach; `null` unless the record begins there.
    pub stood_at_mm: Option<[f64; 2]>,
    /// The approach before the commands join the program, not compared (s).
    pub approach_s: f64,
    /// Whether the approach drove the model (the model follows it); else it was left out and
    /// the model run in to where and how fast the record has the machine at the join.
    pub approach_simulated: bool,
    /// The run-in before a record that begins in motion (s).
    pub run_in_s: f64,
    /// Per axis (X, Y), simulated but not compared after the record's start (s).
    pub settling_s: [f64; 2],
    /// Whether the record covers the program from its first feed move.
    pub from_program_start: bool,
    /// Whether it covers the program to its last feed move.
    pub to_program_end: bool,
    /// How far into the program the comparison begins by the plan's timing (s).
    pub into_program_s: f64,
    /// Where the record has Z: the lowest and highest Z over the stretch compared (mm, the
    /// record's own coordinates; its commands where recorded). Z is compared where the
    /// machine simulates it (`z_compared`), and carried as read otherwise.
    pub z_span_mm: Option<[f64; 2]>,
    /// Whether Z was compared with a simulated Z (the diagnosis says how it compares).
    ///
    /// Set by the command that compared Z, not derived from the comparison's context: the
    /// context knows whether Z *can* be compared (`Context::z_comparable`: the record has
    /// Z, the machine simulates it, the commands drive it), but whether it *was* is each
    /// command's own rule on the same record — `diagnose` compares a Z commanded to travel
    /// 0.1 mm or more whose nominal simulation ran; `identify` compares (to fit) only a Z
    /// commanded to travel 1 mm or more, on a template, not a loop model, whose Z follows
    /// the record. A record whose Z moves 0.5 mm is compared by the one and not the other.
    pub z_compared: bool,
}

/// Z travel below this (mm) is a standing Z, not worth a word.
const Z_STANDS_MM: f64 = 1e-3;

/// Which stretch was compared and how the start was set, a line each: what the command prints.
impl std::fmt::Display for Coverage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.describe().join("\n"))
    }
}

impl Coverage {
    /// How long each axis was simulated but not compared at the start, in words.
    fn settling_text(&self) -> String {
        let [x, y] = self.settling_s;
        format!(
            ": X the first {x:.2} s, Y the first {y:.2} s (until a wrong guess of the state there has died away; an axis standing there, until shortly after it first moves)"
        )
    }

    /// Lines saying which stretch was compared and how the start was set.
    pub(crate) fn describe(&self) -> Vec<String> {
        let mut lines = vec![format!(
            "compared: lines {}–{} of the program's {}–{} ({:.2}–{:.2} s on the record's clock){}",
            self.first_line,
            self.last_line,
            self.program_first_line,
            self.program_last_line,
            self.compared_from_s,
            self.compared_to_s,
            match (self.from_program_start, self.to_program_end) {
                (true, true) => "",
                (true, false) => "; the record ends before the program does",
                (false, true) => "; the record begins after the program's start",
                (false, false) => "; the record covers a part of the program",
            }
        )];
        let start = match self.start {
            StartKind::AtRest => None,
            StartKind::InMotion => Some(format!(
                "start: in motion ({:.1} s into the program by its plan): the model ran in for \
                 {:.2} s on the record's first command speed; simulated but not compared{}",
                self.into_program_s,
                self.run_in_s,
                self.settling_text()
            )),
            StartKind::BeforeProgram => Some(format!(
                "start: off the program's path{}; its first {:.2} s — an approach the program \
                 does not hold — are not compared, {}; simulated but not compared after it{}",
                self.stood_at_mm.map_or(String::new(), |[x, y]| format!(
                    " at X {x:.3} Y {y:.3} mm, where the machine stood"
                )),
                self.approach_s,
                if self.approach_simulated {
                    "but drive the model from there as they drove the machine"
                } else {
                    "nor simulated (the model does not follow them): the model is run in to where \
                     and how fast the record has the machine where its commands join the program"
                },
                self.settling_text()
            )),
            StartKind::Planned if !self.from_program_start => Some(format!(
                "start: {:.1} s into the program by its plan: without recorded commands the \
                 model runs the program from its start as planned, and how the control ran the \
                 part before the record cannot be known (record x_cmd, y_cmd to compare from \
                 the record's own start)",
                self.into_program_s
            )),
            StartKind::Planned => None,
        };
        lines.extend(start);
        lines.extend(self.z_span_mm.and_then(|[lo, hi]| {
            (hi - lo > Z_STANDS_MM).then(|| {
                if self.z_compared {
                    return format!(
                        "Z: moves {:.3} mm in the stretch compared (Z {lo:.3} to {hi:.3} mm on \
                         the record's own scale); compared with the simulated Z, in its own \
                         figures",
                        hi - lo
                    );
                }
                format!(
                    "Z: moves {:.3} mm in the stretch compared (Z {lo:.3} to {hi:.3} mm on the \
                     record's own scale); it is read but not compared, diagnosed or fitted: \
                     the figures are of X and Y, and a machine file written keeps Z as it was",
                    hi - lo
                )
            })
        }));
        lines
    }
}
