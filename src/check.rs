//! The main job: a part program on a machine → where and by how much the machine will
//! leave the programmed contour, and why.
//!
//! plan → execute (interpolate and simulate X and Y, in-position checks on the simulated
//! axes) → contour error → hotspots. Pure: no I/O,
//! so that sweeps can run it many times in parallel.

use crate::circular::{CircularTest, circles, circular_test, radial_points};
use serde::Serialize;

use crate::contour::{ContourSeries, contour_errors};
use crate::execute::{ExecConfig, Execution, execute};
use crate::gcode::Program;
use crate::hotspot::{Hotspot, HotspotConfig, RunView, find_hotspots};
use crate::machine::MachineConfig;
use crate::path::Motion;
use crate::plan::{Commands, KinematicLimits, Plan, PlanConfig, plan};
use crate::sim::{AxisModel, AxisTrace, SimConfig, SimError};

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
    pub fn exec(&self) -> ExecConfig {
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

/// Figures of a run.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Summary {
    /// Planned cycle time (s).
    pub cycle_time_s: f64,
    /// Path length, rapids included (m).
    pub path_length_m: f64,
    /// Length of the cutting moves (m).
    pub cut_length_m: f64,
    /// Largest |contour error| while cutting (m).
    pub max_contour_error_m: f64,
    /// Sample of that maximum.
    pub max_contour_sample: Option<usize>,
    /// RMS contour error while cutting (m).
    pub rms_contour_error_m: f64,
    /// Largest |following error| of X and Y while cutting (m).
    pub max_following_error_cutting_m: [f64; 2],
    /// Largest |following error| of X and Y over the whole run, rapids included (m).
    pub max_following_error_m: [f64; 2],
}

/// Everything a check produced.
#[derive(Debug, Clone)]
pub struct CheckRun {
    /// The plan.
    pub plan: Plan,
    /// The commands (with the settling tail).
    pub commands: Commands,
    /// X trace.
    pub x: AxisTrace,
    /// Y trace.
    pub y: AxisTrace,
    /// Contour error.
    pub contour: ContourSeries,
    /// Hotspots, ranked.
    pub hotspots: Vec<Hotspot>,
    /// Figures.
    pub summary: Summary,
    /// Circular-test figures (ISO 230-4) of every full circle in the program.
    pub circular: CircularTest,
    /// The settings the run used.
    pub settings: CheckSettings,
}

/// Checks a program on a machine.
pub fn check(
    program: &Program,
    machine: &MachineConfig,
    settings: &CheckSettings,
) -> Result<CheckRun, SimError> {
    let run = execute_program(program, machine, settings, &|_| {})?;
    Ok(analyse(run, machine, settings))
}

/// Plans a program and runs it on the machine as its control does (the in-position waits
/// from the simulated axes), with the settling tail. `progress` is told how many samples
/// of either axis are done, now and then.
pub fn execute_program(
    program: &Program,
    machine: &MachineConfig,
    settings: &CheckSettings,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<Execution, SimError> {
    let planned = plan(program, &KinematicLimits::of(machine), &settings.plan);
    execute(planned, machine, &settings.exec(), progress)
}

/// The plan of a program and its commands with the settling tail, the waits at exact stops
/// as the planner estimates them (a first-order position loop). This is the timeline
/// `diagnose` fits on: it moves continuously with the gains, where simulated waits move in
/// whole interpolation cycles and would make a fit's objective a staircase.
pub fn plan_commands(
    program: &Program,
    machine: &MachineConfig,
    settings: &CheckSettings,
) -> Result<(Plan, Commands), SimError> {
    let planned = plan(program, &KinematicLimits::of(machine), &settings.plan);
    crate::execute::check_run_length(&planned)?;
    let mut commands = crate::plan::sample(&planned);
    commands.hold(settings.settle_s);
    Ok((planned, commands))
}

/// The contour error, hotspots and figures of an executed program (the part of [`check`]
/// after the simulation).
pub fn analyse(run: Execution, machine: &MachineConfig, settings: &CheckSettings) -> CheckRun {
    let Execution {
        plan: mut planned,
        commands,
        x,
        y,
    } = run;
    for (axis, trace, config) in [('X', &x, &machine.x), ('Y', &y, &machine.y)] {
        if let Some(w) = limit_warning(axis, trace, config, &planned, &commands) {
            planned.warnings.push(w);
        }
    }
    let contour = contour_errors(&planned, &commands, &x.pos_m, &y.pos_m);
    let [mx, my] = [&machine.x, &machine.y].map(AxisModel::from_config);
    let view = RunView {
        plan: &planned,
        commands: &commands,
        traces: [&x, &y],
        backlash_m: [2.0 * mx.half_gap, 2.0 * my.half_gap],
        contour: &contour,
    };
    let kv = mx.kv_per_s().min(my.kv_per_s());
    let hotspots = find_hotspots(&view, &HotspotConfig::for_kv(kv), settings.max_hotspots);
    let summary = summarize(&planned, &commands, [&x, &y], &contour);
    let circular = circular_test(
        &circles(&planned.segments),
        &contour.segment,
        &x.pos_m,
        &y.pos_m,
    );
    CheckRun {
        plan: planned,
        commands,
        x,
        y,
        contour,
        hotspots,
        summary,
        circular,
        settings: *settings,
    }
}

/// A drive that spends time at its current or voltage limit cannot follow its command
/// there: the prediction includes it, but a wrong limit in the machine file (a 3 A current
/// limit on a 60 A drive) would show as a large error at every reversal with no other hint.
/// Says where (the first stretch's line), how long in all and which limit.
fn limit_warning(
    axis: char,
    trace: &AxisTrace,
    config: &crate::machine::AxisConfig,
    plan: &Plan,
    commands: &Commands,
) -> Option<crate::gcode::Warning> {
    let limited: Vec<usize> = (0..trace.mode.len())
        .filter(|&k| crate::sim::Mode::code_is_limited(trace.mode[k]))
        .collect();
    let &first = limited.first()?;
    let stretches = 1 + limited.windows(2).filter(|w| w[1] != w[0] + 1).count();
    let i_max = config.velocity_loop.i_max_a;
    let at_current_limit = limited
        .iter()
        .filter(|&&k| trace.current_a[k].abs() >= 0.95 * i_max)
        .count();
    let which = if 2 * at_current_limit >= limited.len() {
        format!("current limit (velocity_loop.i_max_a = {i_max} A)")
    } else {
        format!(
            "voltage limit (current_loop.u_max_v = {} V)",
            config.current_loop.u_max_v
        )
    };
    let segment = commands.segment.get(first).copied().unwrap_or(0) as usize;
    let line = plan.segments.get(segment).map_or(0, |s| s.line);
    Some(crate::gcode::Warning {
        line,
        message: format!(
            "the {axis} drive is at its {which} for {:.1} ms in {stretches} stretch{}, the \
             first at t = {:.3} s: it cannot follow the command there (included in the \
             prediction; check the limit if this is unexpected)",
            limited.len() as f64 * trace.dt_s * 1e3,
            if stretches == 1 { "" } else { "es" },
            first as f64 * trace.dt_s
        ),
    })
}

fn summarize(
    plan: &Plan,
    commands: &Commands,
    traces: [&AxisTrace; 2],
    contour: &ContourSeries,
) -> Summary {
    let cut_length_m = plan
        .segments
        .iter()
        .zip(&plan.plans)
        .filter(|(s, _)| s.motion == Motion::Feed)
        .map(|(_, p)| p.length_m)
        .sum();
    let mut fe_cut = [0.0f64; 2];
    let mut fe_all = [0.0f64; 2];
    for (i, t) in traces.iter().enumerate() {
        for k in 0..t.len() {
            let e = t.following_error_m(k).abs();
            fe_all[i] = fe_all[i].max(e);
            if plan.segments[commands.segment[k] as usize].motion == Motion::Feed {
                fe_cut[i] = fe_cut[i].max(e);
            }
        }
    }
    let max = contour.max_abs();
    Summary {
        cycle_time_s: plan.total_time_s,
        path_length_m: plan.path_length_m(),
        cut_length_m,
        max_contour_error_m: max.map_or(0.0, |m| m.1),
        max_contour_sample: max.map(|m| m.0),
        rms_contour_error_m: contour.rms(),
        max_following_error_cutting_m: fe_cut,
        max_following_error_m: fe_all,
    }
}

/// A full circle in the program: the ISO 230-4 circular test a ballbar would measure.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CircleTest {
    /// Index of the arc segment.
    pub segment: usize,
    /// Source line.
    pub line: u32,
    /// Centre (m).
    pub center_m: [f64; 2],
    /// Nominal radius (m).
    pub radius_m: f64,
    /// Counter-clockwise (G3) or clockwise (G2).
    pub ccw: bool,
    /// (angle rad, radial deviation m) of every sample on the circle.
    pub points: Vec<(f64, f64)>,
}

/// The full circles of a run with the radial deviation measured around them.
pub fn circle_tests(run: &CheckRun) -> Vec<CircleTest> {
    circles(&run.plan.segments)
        .into_iter()
        .map(|c| {
            let points = radial_points(&c, &run.contour.segment, &run.x.pos_m, &run.y.pos_m);
            CircleTest {
                segment: c.segment,
                line: c.line,
                center_m: c.center_m,
                radius_m: c.radius_m,
                ccw: c.ccw,
                points,
            }
        })
        .collect()
}
