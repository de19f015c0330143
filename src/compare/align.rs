//! Building the timeline: the commands that drive the simulation (the program's plan or the
//! record's own, placed on the program), and the record's clock aligned to the program's —
//! one offset, or, for a control whose waits differ from the plan's, one per stretch
//! between standstills.

use super::context::{Context, Stepping};
use super::residual::rms;
use super::start::{
    Arrival, Start, StartKind, last_direction, run_in_to_state, settling_time, starts_in_motion,
    with_run_in,
};
use super::{CompareError, CompareSettings};
use crate::check::plan_commands;
use crate::gcode::Program;
use crate::machine::{AxisName, MachineConfig};
use crate::numeric::golden_section;
use crate::numeric::units::um_from_m;
use crate::plan::{Commands, Plan};
use crate::sim::AxisModel;
use crate::trace::measured::MeasuredTrace;
use crate::trace::placement::{Departure, place_in_space, place_on_path};
use crate::trace::recorded::{commands_from_record, local_derivatives};
use crate::trace::signal::sample;

/// The share of the record (at 500 samples spread over it) whose measured XY position lies
/// more than 1 mm from every segment of the program: a record of another program, or in
/// other coordinates, whatever its timing — which no alignment of waits can mend.
fn share_off_path(ctx: &Context) -> f64 {
    let m = ctx.measured;
    let n = m.x_m.len().min(m.y_m.len());
    if n == 0 || ctx.plan.segments.is_empty() {
        return 0.0;
    }
    let picks = 500.min(n);
    let off = (0..picks)
        .map(|k| k * (n - 1) / picks.saturating_sub(1).max(1))
        .filter(|&i| {
            let q = [m.x_m[i], m.y_m[i]];
            let nearest = ctx
                .plan
                .segments
                .iter()
                .map(|seg| seg.project_xy(q, 0.5).signed_distance_m.abs())
                .fold(f64::INFINITY, f64::min);
            nearest > 1e-3
        })
        .count();
    off as f64 / picks as f64
}

/// Builds the comparison timeline: commands, plan, samples, and a first clock offset.
pub(crate) fn context<'a>(
    program: &Program,
    machine: &MachineConfig,
    measured: &'a MeasuredTrace,
    settings: &CompareSettings,
) -> Result<(Context<'a>, f64), CompareError> {
    let (plan, plan_commands) = plan_commands(program, machine, &settings.check)?;
    let dt = plan_commands.dt_s;
    let driving = driving_commands(&plan, plan_commands, machine, measured, settings)?;
    let fixed_offset = driving.fixed_offset;
    let mut ctx = Context {
        measured,
        commands: driving.commands,
        plan,
        program_start_s: driving.program_start_s,
        dt,
        fixed_offset,
        extra_wait_s: Vec::new(),
        sim: settings.check.sim,
        stepping: Stepping::Full,
        settle_s: settings.check.settle_s,
        samples: Vec::new(),
        sample_dt_s: measured.dt_s,
        noise_sigma: 0.0,
        measured_at: settings.measured_at,
        timing_drift_s: None,
        rapids_compared: false,
        holding: Default::default(),
        unsettled: Default::default(),
        start: driving.start,
    };
    let nominal = [AxisName::X, AxisName::Y].map(|a| ctx.simulate_axis(machine, a));
    let [Some(x), Some(y)] = nominal else {
        let model = AxisModel::from_config(&machine.x);
        crate::sim::linear::check_stable(&model)?;
        return Err(cannot(
            measured,
            "the nominal machine cannot be simulated on these commands".into(),
        ));
    };
    let offset = match fixed_offset {
        Some(o) => o,
        None => coarse_offset(&ctx, &x, &y).ok_or_else(|| {
            cannot(
                measured,
                "the measurement and the program do not overlap in time".into(),
            )
        })?,
    };
    choose_samples(&mut ctx, offset)?;
    let offset = if fixed_offset.is_some() {
        offset
    } else {
        refine_offset(&ctx, &x, &y, offset)
    };
    if fixed_offset.is_none() {
        ctx.timing_drift_s = Some(timing_drift(&ctx, &x, &y, offset));
    }
    let (offset, x, y) = if fixed_offset.is_some() || !settings.align_stretches {
        (offset, x, y)
    } else {
        align_stretches(&mut ctx, machine, x, y, offset)
    };
    refuse_far_prediction(&ctx, settings, [&x, &y], offset)?;
    Ok((ctx, offset))
}

fn cannot(measured: &MeasuredTrace, reason: String) -> CompareError {
    CompareError::CannotAlign {
        file: measured.file.clone(),
        reason,
    }
}

/// What drives the simulation: the commands, the record's clock offset when they fix it,
/// where the program starts on their timeline (s), and how the record's start was set.
struct Driving {
    commands: Commands,
    fixed_offset: Option<f64>,
    program_start_s: f64,
    start: Start,
}

/// The commands that drive the simulation. The record's own commands, where it has them,
/// drive the simulation on its own clock, whatever timing our plan gives the program — after
/// they have shown that they lie on the program's path from where they join it; the program
/// gives geometry and lines. A record whose commands begin in motion gets a run-in before
/// them and a settling stretch that is not compared ([`super::start`]).
fn driving_commands(
    plan: &Plan,
    plan_commands: Commands,
    machine: &MachineConfig,
    measured: &MeasuredTrace,
    settings: &CompareSettings,
) -> Result<Driving, CompareError> {
    let dt = plan_commands.dt_s;
    let Some([xc, yc]) = &measured.commands else {
        return Ok(Driving {
            commands: plan_commands,
            fixed_offset: None,
            program_start_s: 0.0,
            start: Start::planned(),
        });
    };
    let mut commands = recorded_commands(measured, [xc, yc], dt);
    let placement = place_recorded(plan, &mut commands, measured, settings);
    if let Some(worst) = placement.worst
        && (worst.distance_m > settings.command_tolerance_m || !placement.joined)
    {
        return Err(off_path(plan, &plan_commands, measured, settings, worst));
    }
    let join_s = placement.join as f64 * dt;
    let first_command_m = [commands.x.pos_m[0], commands.y.pos_m[0]];
    let kind = if placement.join > 0 {
        StartKind::BeforeProgram
    } else if starts_in_motion(&commands) {
        StartKind::InMotion
    } else {
        StartKind::AtRest
    };
    let whole = kind == StartKind::AtRest && placement.at_program_start;
    let Prepared {
        commands,
        run_in_s,
        settling_s,
        arrival,
        approach_simulated,
    } = prepare(
        kind,
        commands,
        placement.join,
        &plan_commands,
        machine,
        measured,
        settings,
    );
    let program_start_s = if whole {
        first_motion(&commands) - first_motion(&plan_commands)
    } else {
        // The program started before the record, or the record before the program: where
        // the plan would be where the comparison begins, on the commands' timeline.
        let k = (run_in_s / dt).round() as usize;
        let at = [commands.x.pos_m[k], commands.y.pos_m[k]];
        run_in_s - plan_time_at(&plan_commands, commands.segment[k], at)
    };
    Ok(Driving {
        commands,
        fixed_offset: Some(
            measured.t0_s
                + if approach_simulated {
                    0.0
                } else {
                    join_s - run_in_s
                },
        ),
        program_start_s,
        start: Start {
            kind,
            run_in_s,
            join_s,
            settling_s,
            first_command_m,
            at_program_start: placement.at_program_start,
            arrival,
            approach_simulated,
        },
    })
}

/// The commands a record's start is simulated on, by how it begins: from where they join the
/// program after an approach, with a run-in where they begin in motion, else as recorded.
fn prepare(
    kind: StartKind,
    commands: Commands,
    join: usize,
    plan_commands: &Commands,
    machine: &MachineConfig,
    measured: &MeasuredTrace,
    settings: &CompareSettings,
) -> Prepared {
    match kind {
        StartKind::BeforeProgram => from_join(commands, join, machine, measured, settings),
        StartKind::InMotion => in_motion(commands, plan_commands, machine, settings),
        StartKind::AtRest | StartKind::Planned => Prepared {
            commands,
            run_in_s: 0.0,
            settling_s: [0.0; 2],
            arrival: None,
            approach_simulated: false,
        },
    }
}

/// The commands a record's start is simulated on, with how its start was set.
struct Prepared {
    commands: Commands,
    /// Simulated before the comparison's first command (s).
    run_in_s: f64,
    /// Per axis, simulated but not compared after that (s).
    settling_s: [f64; 2],
    /// Where each model's run-in must bring it (a run-in to the record's state).
    arrival: Option<[Arrival; 2]>,
    /// The record's approach drives the model (it follows it), not a run-in.
    approach_simulated: bool,
}

/// How far the nominal model may end its run of a record's approach from where the record
/// has the machine at the join, as a share of the machine's following error there, for the
/// approach to drive it (or 5 µm, whichever is more).
const APPROACH_FOLLOWED: f64 = 0.1;

/// A record whose commands join the program after an approach from where the machine stood.
/// Where the nominal model follows the approach — it ends it near where the record has the
/// machine — the approach drives it, as it drove the machine, and is simulated but not
/// compared: every model then meets the join in the state its own run of the approach
/// leaves, play and friction on the side the approach left them. Where it does not (a rapid
/// at 36 m/min on a machine file whose rapid rate is 6 m/min), the approach is left out and
/// each model is run in to where and how fast the record has the machine at the join. Either
/// way a settling stretch follows, as long as the two starts take to agree.
fn from_join(
    commands: Commands,
    join: usize,
    machine: &MachineConfig,
    measured: &MeasuredTrace,
    settings: &CompareSettings,
) -> Prepared {
    let dt = commands.dt_s;
    let join_s = join as f64 * dt;
    let sim = &settings.check.sim;
    let came_from = [&commands.x, &commands.y].map(|c| last_direction(c, join));
    let state = state_at(measured, join_s, came_from);
    let joined = tail(&commands, join);
    let (run, run_in_s) = run_in_to_state(&joined, machine, state, sim);
    let at_join = AxisName::BOTH.map(|a| {
        let model = AxisModel::from_config(machine.axis(a));
        let head = crate::plan::AxisCommands {
            pos_m: commands.axis(a).pos_m[..=join].to_vec(),
            vel_m_per_s: commands.axis(a).vel_m_per_s[..=join].to_vec(),
            acc_m_per_s2: commands.axis(a).acc_m_per_s2[..=join].to_vec(),
        };
        crate::sim::simulate(&model, &head, dt, sim)
            .ok()
            .map(|t| t.into_read_at(settings.measured_at)[join])
    });
    let follows = AxisName::BOTH.into_iter().all(|a| {
        let lag = (commands.axis(a).pos_m[join] - state[a.index()].x_m).abs();
        at_join[a.index()].is_some_and(|m| {
            (m - state[a.index()].x_m).abs() <= (APPROACH_FOLLOWED * lag).max(5e-6)
        })
    });
    let run_in_samples = (run_in_s / dt).round() as usize;
    if follows {
        let settling_s = settling_time(machine, (&commands, join), (&run, run_in_samples), sim);
        return Prepared {
            commands,
            run_in_s: join_s,
            settling_s,
            arrival: None,
            approach_simulated: true,
        };
    }
    // The other guess: the machine at rest where the record has it.
    let resting = state.map(|s| Arrival {
        v_m_per_s: 0.0,
        a_m_per_s2: 0.0,
        ..s
    });
    let (at_rest, rest_s) = run_in_to_state(&joined, machine, resting, sim);
    let settling_s = settling_time(
        machine,
        (&run, run_in_samples),
        (&at_rest, (rest_s / dt).round() as usize),
        sim,
    );
    Prepared {
        commands: run,
        run_in_s,
        settling_s,
        arrival: Some(state),
        approach_simulated: false,
    }
}

/// A record whose commands begin in motion on the program's path: a run-in on their first
/// speed, an axis standing there moved in from the side the program's previous move of it
/// came from, and a settling stretch as long as a start from rest takes to agree with it.
fn in_motion(
    commands: Commands,
    plan_commands: &Commands,
    machine: &MachineConfig,
    settings: &CompareSettings,
) -> Prepared {
    let dt = commands.dt_s;
    let first = [commands.x.pos_m[0], commands.y.pos_m[0]];
    let plan_k = plan_sample_at(plan_commands, commands.segment[0], first);
    let arrive = AxisName::BOTH.map(|a| {
        let c = commands.axis(a);
        Arrival {
            x_m: c.pos_m[0],
            v_m_per_s: c.vel_m_per_s[0],
            a_m_per_s2: c.acc_m_per_s2[0],
            came_from: last_direction(plan_commands.axis(a), plan_k),
        }
    });
    let (run, run_in_s) = with_run_in(&commands, machine, arrive);
    let settling_s = settling_time(
        machine,
        (&run, (run_in_s / dt).round() as usize),
        (&commands, 0),
        &settings.check.sim,
    );
    Prepared {
        commands: run,
        run_in_s,
        settling_s,
        arrival: None,
        approach_simulated: false,
    }
}

/// A record's commands on the simulation's step `dt`: X and Y, and Z where the record has
/// its commands — they drive a simulated Z in the record's coordinates, as its measured Z is.
fn recorded_commands(measured: &MeasuredTrace, [xc, yc]: [&[f64]; 2], dt: f64) -> Commands {
    let mut commands = commands_from_record(xc, yc, measured.dt_s, dt);
    if let Some(zc) = measured.z_cmd_m.as_deref().filter(|z| z.len() == xc.len()) {
        commands.z = commands_from_record(zc, zc, measured.dt_s, dt).x;
    }
    commands
}

/// The recorded commands placed on the plan: by X, Y and Z where the record holds Z's
/// commands, else by X and Y.
fn place_recorded(
    plan: &Plan,
    commands: &mut Commands,
    measured: &MeasuredTrace,
    settings: &CompareSettings,
) -> crate::trace::placement::Placement {
    let tolerance_m = settings.command_tolerance_m;
    if measured.z_cmd_m.is_some() {
        place_in_space(&plan.segments, commands, tolerance_m)
    } else {
        place_on_path(&plan.segments, commands, tolerance_m)
    }
}

/// The commands from sample `from` on.
fn tail(commands: &Commands, from: usize) -> Commands {
    let cut = |c: &crate::plan::AxisCommands| crate::plan::AxisCommands {
        pos_m: c.pos_m[from..].to_vec(),
        vel_m_per_s: c.vel_m_per_s[from..].to_vec(),
        acc_m_per_s2: c.acc_m_per_s2[from..].to_vec(),
    };
    Commands {
        dt_s: commands.dt_s,
        x: cut(&commands.x),
        y: cut(&commands.y),
        z: cut(&commands.z),
        segment: commands.segment[from..].to_vec(),
    }
}

/// Half-width of the fit that reads the machine's state from its measured positions (s):
/// wide against the noise of a measured position, short against a deceleration.
const STATE_HALF_WIDTH_S: f64 = 0.02;

/// Where the record has the machine at `t_s` after its start, how fast it moves and how it
/// accelerates, per axis — a local quadratic fit of its measured positions; `came_from`,
/// the direction each last moved in.
fn state_at(measured: &MeasuredTrace, t_s: f64, came_from: [f64; 2]) -> [Arrival; 2] {
    let half = STATE_HALF_WIDTH_S.max(1.5 * measured.dt_s);
    [&measured.x_m, &measured.y_m]
        .into_iter()
        .zip(came_from)
        .map(|(m, came_from)| {
            let (v, a) = local_derivatives(m, measured.dt_s, t_s, half);
            Arrival {
                x_m: sample(m, measured.dt_s, t_s),
                v_m_per_s: v,
                a_m_per_s2: a,
                came_from,
            }
        })
        .collect::<Vec<_>>()
        .try_into()
        .expect("two axes")
}

/// Why recorded commands cannot be placed on the program: where they leave its path, and
/// what the user may try.
fn off_path(
    plan: &Plan,
    plan_commands: &Commands,
    measured: &MeasuredTrace,
    settings: &CompareSettings,
    worst: Departure,
) -> CompareError {
    let dt = plan_commands.dt_s;
    let offsets = super::offset::work_offsets(plan, plan_commands, measured, dt, settings);
    let hint = offset_hint(&offsets);
    let hint = match measured.counts_hint() {
        Some(counts) => format!("{counts}; else {hint}"),
        None => hint,
    };
    CompareError::OffPath {
        file: measured.file.clone(),
        t_s: measured.t0_s + worst.t_s,
        line: worst.line,
        distance_um: um_from_m(worst.distance_m),
        tolerance_um: um_from_m(settings.command_tolerance_m),
        hint,
    }
}

/// What a user may pass as the record's work offset, from the offsets that put its commands
/// on the program (`offset::work_offsets`).
fn offset_hint(offsets: &[super::offset::Offset]) -> String {
    use super::offset::Offset;
    let words = |o: &Offset| format!("X {:.3} mm, Y {:.3} mm", o.mm[0], o.mm[1]);
    let flag = |o: &Offset| format!("--work-offset {:.3},{:.3}", o.mm[0], o.mm[1]);
    // At most `shown` of them in words, and how many more there are.
    let listed = |all: &[Offset], shown: usize| {
        let mut text = all
            .iter()
            .take(shown)
            .map(words)
            .collect::<Vec<_>>()
            .join("; ");
        if all.len() > shown {
            text.push_str(&format!(" and {} more", all.len() - shown));
        }
        text
    };
    match offsets {
        [] => "is this a record of this program, in the same coordinates?".into(),
        [one] => format!(
            "the commands run parallel to the program, offset by {} — a work offset; give it \
             with {}",
            words(one),
            flag(one)
        ),
        [first, others @ ..]
            if first.at_program_start
                && (!others[0].at_program_start || others[0].join > first.join) =>
        {
            format!(
                "the commands run parallel to the program, offset by {} if the record begins \
                 at the program's start, where it joins the program earliest — a work offset; \
                 give it with {} (a record begun further into the program would fit {} as well)",
                words(first),
                flag(first),
                listed(others, 3)
            )
        }
        several => format!(
            "the commands run parallel to the program offset by one of {} — a work offset the \
             record alone does not tell (it holds too little of the program); give the \
             program's with --work-offset X,Y",
            listed(several, 4)
        ),
    }
}

/// When the plan passes `at` (m) on segment `segment` (s on the plan's clock).
fn plan_time_at(plan_commands: &Commands, segment: u32, at: [f64; 2]) -> f64 {
    plan_sample_at(plan_commands, segment, at) as f64 * plan_commands.dt_s
}

/// The plan's sample on segment `segment` nearest `at` (m), or the first sample of a later
/// segment.
fn plan_sample_at(plan_commands: &Commands, segment: u32, at: [f64; 2]) -> usize {
    let c = plan_commands;
    let distance = |k: usize| (c.x.pos_m[k] - at[0]).hypot(c.y.pos_m[k] - at[1]);
    let on: Vec<usize> = (0..c.len()).filter(|&k| c.segment[k] == segment).collect();
    on.into_iter()
        .min_by(|&a, &b| distance(a).total_cmp(&distance(b)))
        .or_else(|| (0..c.len()).find(|&k| c.segment[k] > segment))
        .unwrap_or(0)
}

/// The samples compared at clock offset `offset`: those whose program time lies within the
/// simulation, with a margin so that the offset can move during the fits.
///
/// Rapids are left out: we cannot know how a control ran the rapids we planned (each axis
/// on its own, blended or not, at which rate), their millimetres of lag would drown the
/// micrometres the causes leave, and even recorded, a rapid's acceleration steps are read
/// back from sparse samples only roughly (a 15 ms logger's rapids pass for friction). The
/// standstill after each rapid goes with it. A record with its commands that is mostly
/// rapids is compared rapids and all rather than refused: the commands say what the
/// control did there.
///
/// One sample per command period is compared: the model's input changes no faster, so finer
/// samples add no evidence about it — only correlated copies of the same model error, which
/// would count as independent proof at 10 kHz and not at 2 ms, and make the diagnosis
/// depend on the sampling rate.
fn choose_samples(ctx: &mut Context, offset: f64) -> Result<(), CompareError> {
    let measured = ctx.measured;
    let duration = ctx.commands.duration_s();
    let fixed = ctx.fixed_offset.is_some();
    let margin = if fixed { 0.0 } else { 0.2 };
    // Nothing before the record's commands join the program or have settled.
    let from = ctx.start.compared_from_s().max(margin);
    let stride = ((ctx.dt / measured.dt_s) * (1.0 + 1e-9)).floor().max(1.0) as usize;
    ctx.sample_dt_s = stride as f64 * measured.dt_s;
    let expected =
        ((duration - from).max(0.0) / measured.dt_s).min(measured.len() as f64) / stride as f64;
    let compared = |ctx: &Context, with_rapids: bool| -> Vec<usize> {
        (0..measured.len())
            .step_by(stride)
            .filter(|&i| {
                let t = ctx.prog_time(i, offset);
                t >= from && t <= duration - margin && (with_rapids || !ctx.in_rapid(t))
            })
            .collect()
    };
    ctx.samples = compared(ctx, false);
    if (ctx.samples.len() as f64) < 0.5 * expected && fixed {
        ctx.samples = compared(ctx, true);
        ctx.rapids_compared = true;
    }
    if (ctx.samples.len() as f64) < 0.5 * expected {
        return Err(cannot(
            measured,
            format!(
                "only {} of the {:.0} samples compared fall within the program's {:.1} s",
                ctx.samples.len(),
                expected,
                duration
            ),
        ));
    }
    Ok(())
}

/// A record without its commands that the nominal prediction misses by more than half a
/// millimetre is not taken to be of this program, with what may be wrong. With recorded
/// commands the record has shown itself to be of this program (its commands lie on the
/// path) and its clock is its own: a model far from it is for the diagnosis to explain,
/// or to say it cannot.
fn refuse_far_prediction(
    ctx: &Context,
    settings: &CompareSettings,
    [x, y]: [&[f64]; 2],
    offset: f64,
) -> Result<(), CompareError> {
    let rms = rms(&[
        ctx.residual(AxisName::X, x, offset),
        ctx.residual(AxisName::Y, y, offset),
    ]
    .concat());
    if rms <= 0.5e-3 || ctx.fixed_offset.is_some() {
        return Ok(());
    }
    let off_path = share_off_path(ctx);
    let hint = if let Some(counts) = ctx.measured.counts_hint() {
        format!(" {}{}.", counts[..1].to_uppercase(), &counts[1..])
    } else if off_path > 0.2 {
        format!(
            " Its measured path lies more than 1 mm from every block of the program over \
             {:.0} % of the record: no timing can mend that.",
            100.0 * off_path
        )
    } else if !settings.align_stretches && !standstills(&ctx.commands).is_empty() {
        " If the control's waits at exact stops differ from the plan's, align each stretch \
         between standstills on its own (--align-stretches) or record the commanded positions."
            .to_string()
    } else {
        String::new()
    };
    let drift = match ctx.timing_drift_s {
        Some(d) if d.abs() >= 0.005 && off_path <= 0.2 => format!(
            " Its second half runs {:+.0} ms against its first: the control's timing \
             departs from the plan.",
            d * 1e3
        ),
        _ => String::new(),
    };
    Err(cannot(
        ctx.measured,
        format!(
            "the best clock offset ({offset:.3} s) leaves {:.0} µm RMS between measurement and \
             prediction: is this a measurement of this program, in the same coordinates?{drift}{hint}",
            um_from_m(rms)
        ),
    ))
}

/// When the commands first move (s; 0 when they never do).
fn first_motion(c: &Commands) -> f64 {
    (0..c.len())
        .find(|&k| c.x.vel_m_per_s[k].hypot(c.y.vel_m_per_s[k]) > 1e-6)
        .map_or(0.0, |k| k as f64 * c.dt_s)
}

/// The clock offset that best lines the measurement up with the simulated path, searched
/// over every possible overlap: every 200 ms first, then every 20 ms around the best few.
fn coarse_offset(ctx: &Context, x: &[f64], y: &[f64]) -> Option<f64> {
    /// The first scan's step and sample spacing (s), and how many of its best offsets the
    /// second scan looks around.
    const FIRST_STEP_S: f64 = 0.2;
    const CANDIDATES: usize = 5;
    /// The second scan's step and sample spacing (s).
    const STEP_S: f64 = 0.02;
    let m = ctx.measured;
    let scan = |from: f64, to: f64, step: f64| -> Vec<(f64, f64)> {
        let n = ((to - from) / step).floor().max(0.0) as usize;
        (0..=n)
            .map(|k| from + k as f64 * step)
            .filter_map(|o| mismatch(ctx, x, y, o, step).map(|c| (o, c)))
            .collect()
    };
    let duration = ctx.commands.duration_s();
    let mut first = scan(m.t0_s - duration, m.time_s(m.len() - 1), FIRST_STEP_S);
    first.sort_by(|a, b| a.1.total_cmp(&b.1));
    first
        .iter()
        .take(CANDIDATES)
        .flat_map(|&(o, _)| scan(o - FIRST_STEP_S, o + FIRST_STEP_S, STEP_S))
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|b| b.0)
}

/// The mean squared distance between the measurement and the nominal traces `x`, `y` at
/// clock offset `offset`, on samples about `spacing_s` apart; `None` when they overlap for
/// less than half the program or the measurement, which proves nothing.
fn mismatch(ctx: &Context, x: &[f64], y: &[f64], offset: f64, spacing_s: f64) -> Option<f64> {
    let m = ctx.measured;
    let duration = ctx.commands.duration_s();
    let stride = ((spacing_s / m.dt_s).round() as usize).max(1);
    let (mut s, mut n) = (0.0, 0usize);
    for i in (0..m.len()).step_by(stride) {
        let t = m.time_s(i) - offset;
        if (0.0..=duration).contains(&t) {
            s += (m.x_m[i] - sample(x, ctx.dt, t)).powi(2)
                + (m.y_m[i] - sample(y, ctx.dt, t)).powi(2);
            n += 1;
        }
    }
    let needed = 0.5 * (duration.min(m.dt_s * m.len() as f64)) / (stride as f64 * m.dt_s);
    (n > 0 && n as f64 >= needed).then(|| s / n as f64)
}

/// Golden-section refinement of the offset within ±2 coarse steps, at full resolution.
fn refine_offset(ctx: &Context, x: &[f64], y: &[f64], start: f64) -> f64 {
    golden_section(start - 0.04, start + 0.04, 1e-6, &|o| {
        ctx.offset_cost(x, y, o)
    })
}

impl Context<'_> {
    /// Both axes' residual sum of squares at a clock offset, for traces `x`, `y`.
    fn offset_cost(&self, x: &[f64], y: &[f64], offset_s: f64) -> f64 {
        [
            self.residual(AxisName::X, x, offset_s),
            self.residual(AxisName::Y, y, offset_s),
        ]
        .iter()
        .flatten()
        .map(|v| v * v)
        .sum()
    }
}

/// The offsets that best align the first and the second half of the compared samples, each
/// on its own: their difference (second − first, s). Zero when the plan keeps the machine's
/// time; a control that interpolates slower or waits longer makes it grow.
fn timing_drift(ctx: &Context, x: &[f64], y: &[f64], offset: f64) -> f64 {
    /// How far either half may lie from the whole record's offset (s).
    const REACH_S: f64 = 0.5;
    let (n, half) = (ctx.samples.len(), ctx.samples.len() / 2);
    // Positions among the compared samples, every fourth: what the context's masks are
    // indexed by.
    let (first, second): (Vec<usize>, Vec<usize>) = (
        (0..half).step_by(4).collect(),
        (half..n).step_by(4).collect(),
    );
    let best = |part: &[usize]| {
        let sub = ctx.keeping(part);
        let cost = |o: f64| sub.offset_cost(x, y, o);
        // A 5 ms scan, then golden section about its best: over half a second the
        // mismatch need not be unimodal.
        let start = (0..=200)
            .map(|i| offset - REACH_S + i as f64 * 0.005)
            .min_by(|a, b| cost(*a).total_cmp(&cost(*b)))
            .unwrap_or(offset);
        golden_section(start - 0.005, start + 0.005, 1e-6, &cost)
    };
    best(&second) - best(&first)
}

/// The standstills inside the commands (both axes still for at least 10 ms, neither at the
/// start nor at the end): their start and end on the program's clock (s).
fn standstills(c: &Commands) -> Vec<(f64, f64)> {
    let still = |k: usize| c.x.vel_m_per_s[k].abs() < 1e-9 && c.y.vel_m_per_s[k].abs() < 1e-9;
    let n = c.len();
    let min_len = (0.01 / c.dt_s).ceil() as usize;
    let mut out = Vec::new();
    let mut k = 0;
    // Skip the still start.
    while k < n && still(k) {
        k += 1;
    }
    while k < n {
        if still(k) {
            let from = k;
            while k < n && still(k) {
                k += 1;
            }
            if k < n && k - from >= min_len {
                out.push((from as f64 * c.dt_s, (k - 1) as f64 * c.dt_s));
            }
        } else {
            k += 1;
        }
    }
    out
}

/// Each stretch of the program between standstills (`stops`) aligned on its own clock
/// offset, in order: a stretch's offset is searched from the one before it, since waits that
/// differ from the plan's add up. The search keeps the standstill between them of positive
/// length. Stretches too short to align follow their neighbour.
fn stretch_offsets(
    ctx: &Context,
    x: &[f64],
    y: &[f64],
    global: f64,
    stops: &[(f64, f64)],
) -> Vec<f64> {
    /// How much longer than planned a wait may be (s); the first stretch may lie this far
    /// either side of the whole record's offset.
    const MAX_SLIP_S: f64 = 0.3;
    let m = ctx.measured;
    let mut bounds = vec![0.0];
    for s in stops {
        bounds.extend([s.0, s.1]);
    }
    bounds.push(ctx.commands.duration_s());
    // Mean squared mismatch of the stretch [from, to) (program time) at clock offset o.
    let cost = |from: f64, to: f64, o: f64| {
        let (mut s, mut n) = (0.0, 0usize);
        for &i in &ctx.samples {
            let t = m.time_s(i) - o;
            if (from..to).contains(&t) {
                s += (m.x_m[i] - sample(x, ctx.dt, t)).powi(2)
                    + (m.y_m[i] - sample(y, ctx.dt, t)).powi(2);
                n += 1;
            }
        }
        if n < 50 { f64::INFINITY } else { s / n as f64 }
    };
    // A 5 ms scan, then golden section about the best: a stretch's mismatch need not be
    // unimodal over a few hundred ms.
    let search = |from: f64, to: f64, lo: f64, hi: f64| -> Option<f64> {
        let steps = ((hi - lo) / 0.005).ceil().max(1.0) as usize;
        let (best, best_cost) = (0..=steps)
            .map(|i| lo + (hi - lo) * i as f64 / steps as f64)
            .map(|o| (o, cost(from, to, o)))
            .min_by(|a, b| a.1.total_cmp(&b.1))?;
        best_cost
            .is_finite()
            .then(|| golden_section(best - 0.005, best + 0.005, 1e-6, &|o| cost(from, to, o)))
    };
    let mut own: Vec<Option<f64>> = vec![None; stops.len() + 1];
    let mut previous: Option<f64> = None;
    for (k, span) in bounds.chunks(2).enumerate() {
        let (lo, hi) = match previous {
            None => (global - MAX_SLIP_S, global + MAX_SLIP_S),
            // The standstill before may be up to 90 % shorter, or longer, than planned.
            Some(p) => (p - 0.9 * (stops[k - 1].1 - stops[k - 1].0), p + MAX_SLIP_S),
        };
        // Matched over the whole stretch: its start alone would date it to a fraction of a
        // millisecond, micrometres at feed. The price: a lag the nominal model lacks (a gain
        // error, a dead time) passes in part for a later start.
        own[k] = search(span[0], span[1], lo, hi);
        previous = own[k].or(previous);
    }
    let first = own.iter().flatten().next().copied().unwrap_or(global);
    let mut filled: Vec<f64> = Vec::with_capacity(own.len());
    for o in &own {
        filled.push(o.unwrap_or(filled.last().copied().unwrap_or(first)));
    }
    filled
}

/// Measures how much longer than planned the control stood at each standstill (from each
/// stretch's own clock offset), rebuilds the context's plan and commands with those waits,
/// and returns the first stretch's offset with both axes simulated on the new commands.
fn align_stretches(
    ctx: &mut Context,
    machine: &MachineConfig,
    x: Vec<f64>,
    y: Vec<f64>,
    global: f64,
) -> (f64, Vec<f64>, Vec<f64>) {
    let stops = standstills(&ctx.commands);
    if stops.is_empty() {
        return (global, x, y);
    }
    let offsets = stretch_offsets(ctx, &x, &y, global, &stops);
    let mut extra = vec![0.0; ctx.plan.segments.len()];
    for (k, &(_, stop_end)) in stops.iter().enumerate() {
        // The wait belongs to the segment the standstill ends in.
        let sample = ((stop_end / ctx.dt).floor() as usize).min(ctx.commands.len() - 1);
        extra[ctx.commands.segment[sample] as usize] += offsets[k + 1] - offsets[k];
    }
    ctx.plan = ctx.plan.with_waits(ctx.plan.config.in_position, &extra);
    ctx.commands = super::context::commands_of(&ctx.plan, ctx.settle_s);
    ctx.extra_wait_s = extra;
    let resimulate = |a| ctx.simulate_axis(machine, a);
    match (resimulate(AxisName::X), resimulate(AxisName::Y)) {
        (Some(x), Some(y)) => {
            let offset = refine_offset(ctx, &x, &y, offsets[0]);
            (offset, x, y)
        }
        _ => (global, x, y),
    }
}
