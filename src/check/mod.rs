//! The main job: a part program on a machine → where and by how much the machine will
//! leave the programmed contour, and why.
//!
//! plan → execute (interpolate and simulate X and Y, in-position checks on the simulated
//! axes) → contour error → hotspots, the run handed from one stage to the next in chunks so
//! that a program of any length is checked in bounded memory. Pure: no I/O (a caller that
//! writes the run out does so from the chunks it is handed), so that sweeps can run it many
//! times in parallel.

pub mod envelope;
pub mod report;
use serde::Serialize;

use crate::analysis::RunAnalyser;
use crate::analysis::circular::{Circle, CirclePath};
use crate::analysis::contour::{ContourPoint, ContourSeries};
pub use crate::analysis::{CheckResult, RunPlace, Summary};
use crate::gcode::Program;
use crate::machine::MachineConfig;
use crate::plan::execute::{ExecConfig, RunChunk, execute_in_chunks};
use crate::plan::{Commands, KinematicLimits, Plan, PlanConfig, plan};
use crate::sim::{AxisTrace, SimConfig, SimError};

/// Settings of a check.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CheckSettings {
    /// Planner settings.
    pub plan: PlanConfig,
    /// Simulator settings.
    pub sim: SimConfig,
    /// Standing time after the program end, so the axes settle (s).
    pub settle_s: f64,
    /// Most hotspots reported.
    pub max_hotspots: usize,
}

impl CheckSettings {
    /// The execution settings within these.
    pub(crate) fn exec(&self) -> ExecConfig {
        ExecConfig {
            sim: self.sim,
            settle_s: self.settle_s,
            ..ExecConfig::default()
        }
    }

    /// Defaults for a machine.
    pub fn for_machine(machine: &MachineConfig) -> Self {
        CheckSettings {
            plan: PlanConfig::for_machine(machine),
            sim: SimConfig::default(),
            settle_s: 0.3,
            max_hotspots: 50,
        }
    }
}

/// A check with the whole run kept: every sample's commands, axis states and contour error
/// besides the report's figures. For programs that fit in memory; the command-line `check`
/// uses [`check_in_chunks`], which keeps only the figures.
#[derive(Debug, Clone)]
pub struct CheckRun {
    /// The figures.
    pub result: CheckResult,
    /// The commands (with the settling tail).
    pub commands: Commands,
    /// X trace.
    pub x: AxisTrace,
    /// Y trace.
    pub y: AxisTrace,
    /// Contour error.
    pub contour: ContourSeries,
}

/// Checks a program on a machine and keeps the whole run.
pub fn check(
    program: &Program,
    machine: &MachineConfig,
    settings: &CheckSettings,
) -> Result<CheckRun, SimError> {
    let planned = plan(program, &KinematicLimits::of(machine), &settings.plan);
    crate::plan::execute::check_run_length(&planned)?;
    let dt_s = planned.config.cycle_s;
    let mut commands = Commands {
        dt_s,
        ..Default::default()
    };
    let (mut x, mut y) = (AxisTrace::default(), AxisTrace::default());
    let mut contour = ContourSeries::default();
    let result = check_planned(planned, machine, settings, &|_| {}, &mut |chunk, points| {
        commands.append(chunk.commands);
        x.append(chunk.x.clone());
        y.append(chunk.y.clone());
        points.iter().for_each(|&p| contour.push(p));
        Ok::<(), SimError>(())
    })?;
    x.dt_s = dt_s;
    y.dt_s = dt_s;
    Ok(CheckRun {
        result,
        commands,
        x,
        y,
        contour,
    })
}

/// What a caller of [`check_in_chunks`] does with each chunk of the run and its samples'
/// contour errors (write it out, keep it).
pub type OnChunk<'a, E> = dyn FnMut(&RunChunk, &[ContourPoint]) -> Result<(), E> + 'a;

/// Checks a program on a machine, handing each chunk of the run (with its samples' contour
/// errors) to `on_chunk` as it is simulated and keeping only the figures: memory is bounded
/// by the report, however long the program runs. `progress` is told how many samples of
/// either axis are done, now and then.
pub fn check_in_chunks<E: From<SimError>>(
    program: &Program,
    machine: &MachineConfig,
    settings: &CheckSettings,
    progress: &(dyn Fn(u64) + Sync),
    on_chunk: &mut OnChunk<'_, E>,
) -> Result<CheckResult, E> {
    let planned = plan(program, &KinematicLimits::of(machine), &settings.plan);
    check_planned(planned, machine, settings, progress, on_chunk)
}

/// [`check_in_chunks`] from the plan on.
pub(crate) fn check_planned<E: From<SimError>>(
    planned: Plan,
    machine: &MachineConfig,
    settings: &CheckSettings,
    progress: &(dyn Fn(u64) + Sync),
    on_chunk: &mut OnChunk<'_, E>,
) -> Result<CheckResult, E> {
    let mut analyser = RunAnalyser::new(&planned, machine, settings.max_hotspots);
    let planned = execute_in_chunks(planned, machine, &settings.exec(), progress, &mut |chunk| {
        let points = analyser.take(&chunk);
        on_chunk(&chunk, &points)
    })?;
    Ok(analyser.finish(planned, machine))
}

/// The plan of a program and its commands with the settling tail, the waits at exact stops
/// as the planner estimates them (a first-order position loop). This is the timeline
/// `diagnose` fits on: it moves continuously with the gains, where simulated waits move in
/// whole interpolation cycles and would make a fit's objective a staircase.
pub(crate) fn plan_commands(
    program: &Program,
    machine: &MachineConfig,
    settings: &CheckSettings,
) -> Result<(Plan, Commands), SimError> {
    let planned = plan(program, &KinematicLimits::of(machine), &settings.plan);
    crate::plan::execute::check_run_length(&planned)?;
    let mut commands = crate::plan::sample(&planned);
    commands.hold(settings.settle_s);
    Ok((planned, commands))
}

/// A full circle in the program: the ISO 230-4 circular test a ballbar would measure.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CircleTest {
    /// The programmed circle: its segment, source line, plane and height along the plane's
    /// normal, centre in the plane (m), radius (m) and direction.
    #[serde(flatten)]
    pub circle: Circle,
    /// (angle rad, radial deviation m) of every sample on the circle.
    pub points: Vec<(f64, f64)>,
}

/// The full circles of a run with the radial deviation measured around them.
pub fn circle_tests(result: &CheckResult) -> Vec<CircleTest> {
    result
        .circle_paths
        .iter()
        .map(
            |CirclePath {
                 circle: c,
                 points_m,
             }| CircleTest {
                circle: *c,
                points: points_m.iter().map(|&p| c.polar(p)).collect(),
            },
        )
        .collect()
}
