//! Running a plan as the control runs it: the interpolator and the simulated axes (X and Y,
//! and Z where the machine simulates it) advance together, so that at every exact stop the
//! in-position check is made on the simulated axes themselves.
//!
//! A control holds the next block after an exact stop (a rapid's end, a G61 block) until
//! every axis's position reading lies within the exact-stop window of the commanded end
//! point, checking once per interpolation cycle. How long that takes depends on everything
//! the axis model holds — the loop gains, but also friction, backlash and the feed-forward —
//! so the planner's waits are only an estimate; here each wait is what the simulated check
//! gives, a whole number of interpolation cycles, and the plan is re-timed with it.
//!
//! Between two exact stops the axes do not influence each other, so each such stretch is
//! simulated for X and Y in parallel (three axes on two cores take turns in slices, so that
//! both cores stay busy); the waits are then stepped cycle by cycle.

use crate::gcode::Warning;
use crate::machine::MachineConfig;
use crate::numeric::units::um_from_m;
use crate::path::Segment;
use crate::plan::{Commands, Plan, Sampler, ends_in_exact_stop};
use crate::sim::{AxisModel, AxisRun, AxisTrace, SimConfig, SimError};

/// Settings of an execution.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExecConfig {
    /// Simulator settings.
    pub sim: SimConfig,
    /// Standing time after the program end, so the axes settle (s).
    pub settle_s: f64,
    /// The longest an in-position check may take before the run goes on with a warning
    /// (s). A control raises its positioning-monitoring alarm after such a time (on a
    /// SINUMERIK 840D machine data 36020 POSITIONING_TIME, 1 s by default).
    pub in_position_timeout_s: f64,
}

impl Default for ExecConfig {
    fn default() -> Self {
        ExecConfig {
            sim: SimConfig::default(),
            settle_s: 0.3,
            in_position_timeout_s: 1.0,
        }
    }
}

/// A piece of a run as [`execute_in_chunks`] hands it on: samples `first..first + n`.
#[derive(Debug)]
pub struct RunChunk<'a> {
    /// Index of the chunk's first sample in the run.
    pub first: usize,
    /// The plan, timed up to the chunk's end (later blocks' times and waits are not yet
    /// final).
    pub plan: &'a Plan,
    /// The chunk's commands.
    pub commands: &'a Commands,
    /// X trace of the chunk.
    pub x: AxisTrace,
    /// Y trace of the chunk.
    pub y: AxisTrace,
    /// Z trace of the chunk, where the machine simulates Z (else Z stands where commanded).
    pub z: Option<AxisTrace>,
}

/// Stretches shorter than this (samples) are simulated on one thread: splitting them over
/// two costs more than it saves.
const PARALLEL_FROM: usize = 256;

/// Samples handed on together (about a minute at a 2 ms cycle): long enough that X and Y on
/// two threads pay, short enough that a run's memory does not grow with its duration.
pub const CHUNK_SAMPLES: usize = 1 << 15;

/// The most interpolation cycles a run held whole holds (some 2.5 GB of commands and
/// traces; 11 h at a 2 ms cycle).
const MAX_CYCLES_HELD: f64 = 2.0e7;

/// The most interpolation cycles a run handed on in chunks is simulated for (55 h at a
/// 2 ms cycle, a few minutes of simulation).
const MAX_CYCLES_STREAMED: f64 = 1.0e8;

/// Refuses a plan whose run would be held whole and not fit in memory, naming the block that
/// takes longest.
pub(crate) fn check_run_length(plan: &Plan) -> Result<(), SimError> {
    check_cycles(
        plan,
        MAX_CYCLES_HELD,
        "(a run held whole must fit in memory)",
    )
}

fn check_cycles(plan: &Plan, max_cycles: f64, why: &'static str) -> Result<(), SimError> {
    let dt = plan.config.cycle_s;
    // The waits and settling come on top; a 5 % margin keeps their share from mattering.
    let cycles = plan.total_time_s * 1.05 / dt;
    // A NaN cycle count (none should arise) is let through to fail loudly later.
    if cycles.is_nan() || cycles <= max_cycles {
        return Ok(());
    }
    let (longest_line, longest_s) = plan
        .segments
        .iter()
        .zip(&plan.plans)
        .map(|(s, p)| (s.line, p.span_s()))
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .unwrap_or((0, 0.0));
    Err(SimError::TooLong {
        hours: plan.total_time_s / 3600.0,
        longest_line,
        longest_hours: longest_s / 3600.0,
        limit_hours: max_cycles * dt / 1.05 / 3600.0,
        why,
    })
}

/// Runs a plan on a machine, the in-position waits decided by the simulated axes, handing
/// the run on to `sink` in chunks of about [`CHUNK_SAMPLES`] as it goes instead of keeping
/// it: memory stays bounded however long the program runs. `progress` is told how many
/// samples of either axis are done, now and then. Returns the plan re-timed with the
/// simulated waits.
pub(crate) fn execute_in_chunks<E: From<SimError>>(
    mut plan: Plan,
    machine: &MachineConfig,
    config: &ExecConfig,
    progress: &(dyn Fn(u64) + Sync),
    sink: &mut dyn FnMut(RunChunk<'_>) -> Result<(), E>,
) -> Result<Plan, E> {
    check_cycles(
        &plan,
        MAX_CYCLES_STREAMED,
        "(longer ones would take too long)",
    )?;
    let models: Vec<AxisModel> = machine
        .simulated_configs()
        .into_iter()
        .map(AxisModel::from_config)
        .collect();
    let dt = plan.config.cycle_s;
    let mut runs = axis_runs(&models, &plan, config)?;
    let mut buffer = Buffer::new(dt);
    let n = plan.segments.len();
    let window_m = plan.config.in_position.map(|ip| ip.window_m);
    let mut first = 0;
    let mut t0 = 0.0;
    while first < n {
        let last = stretch_end(&plan.segments, first, window_m.is_some());
        let t_end = time_stretch(&mut plan, first, last, t0);
        let at_program_end = last + 1 == n;
        // Up to the first sample at or after the motion's end — included at the program
        // end, so that the end point is reached; otherwise the wait begins there.
        let k_end = (t_end / dt).ceil() as usize + usize::from(at_program_end);
        let mut sampler = Sampler::new(&plan, first, last);
        let axes = Axes {
            runs: &mut runs,
            progress,
        };
        buffer.run_until(k_end, &mut sampler, axes, &plan, sink)?;
        // The program's end is an exact stop too: the control reports it done when the
        // axes are in position.
        let Some(window_m) = window_m else {
            debug_assert!(at_program_end, "a stretch ends early only at an exact stop");
            break;
        };
        let waited = wait_in_position(&mut runs, &mut sampler, &mut buffer, window_m, config)
            .map_err(|e| placed(e, &plan))?;
        if let Some(misses) = waited.timed_out {
            plan.warnings.push(in_position_warning(
                plan.segments[last].line,
                misses,
                window_m,
                config.in_position_timeout_s,
            ));
        }
        t0 = buffer.next() as f64 * dt;
        plan.plans[last].wait_s = t0 - t_end;
        if at_program_end {
            break;
        }
        first = last + 1;
    }
    plan.total_time_s = plan.plans.last().map_or(0.0, |p| p.t_start_s + p.span_s());
    if n > 0 {
        // Standing at the end point (the interpolator holds it past the motion) while the
        // axes settle.
        let mut holder = Sampler::new(&plan, n - 1, n - 1);
        let k_settle = buffer.next() + (config.settle_s / dt).ceil() as usize;
        let axes = Axes {
            runs: &mut runs,
            progress,
        };
        buffer.run_until(k_settle, &mut holder, axes, &plan, sink)?;
    }
    buffer.hand_on(&mut runs, &plan, sink)?;
    Ok(plan)
}

/// Each simulated axis at rest at the program's start.
fn axis_runs<'a>(
    models: &'a [AxisModel],
    plan: &Plan,
    config: &ExecConfig,
) -> Result<Vec<AxisRun<'a>>, SimError> {
    let start = plan.segments.first().map_or([0.0; 3], |s| s.start_m);
    models
        .iter()
        .enumerate()
        .map(|(a, model)| {
            AxisRun::new(model, start[a], plan.config.cycle_s, &config.sim)
                .map_err(|e| e.on_axis(LETTERS[a], None))
        })
        .collect()
}

/// The simulated axes' letters, in the order of the runs.
const LETTERS: [char; 3] = ['X', 'Y', 'Z'];

/// The simulated axes and the progress callback they report to.
struct Axes<'r, 'a, 'p> {
    runs: &'r mut [AxisRun<'a>],
    progress: &'p (dyn Fn(u64) + Sync),
}

/// The commands of the chunk being run: samples `first..first + commands.len()`.
struct Buffer {
    first: usize,
    commands: Commands,
}

impl Buffer {
    fn new(dt_s: f64) -> Self {
        Buffer {
            first: 0,
            commands: Commands {
                dt_s,
                ..Default::default()
            },
        }
    }

    /// Index of the next sample.
    fn next(&self) -> usize {
        self.first + self.commands.len()
    }

    fn is_full(&self) -> bool {
        self.commands.len() >= CHUNK_SAMPLES
    }

    /// Samples the interpolator up to sample `upto` (exclusive) and advances both axes
    /// through the new samples.
    fn sample_and_follow(
        &mut self,
        sampler: &mut Sampler,
        upto: usize,
        runs: &mut [AxisRun],
        progress: &(dyn Fn(u64) + Sync),
        plan: &Plan,
    ) -> Result<(), SimError> {
        let local_start = self.commands.len();
        for k in self.next()..upto {
            sampler.push(k as f64 * self.commands.dt_s, &mut self.commands);
        }
        follow_all(
            runs,
            &self.commands,
            local_start..self.commands.len(),
            progress,
        )
        .map_err(|e| placed(e, plan))
    }

    /// Hands the samples so far on to `sink` with the axes' traces of them, and starts
    /// the next chunk empty.
    /// Samples `sampler` and simulates the axes up to sample `k_end`, handing each full
    /// chunk on to `sink`.
    fn run_until<E: From<SimError>>(
        &mut self,
        k_end: usize,
        sampler: &mut Sampler,
        axes: Axes,
        plan: &Plan,
        sink: &mut dyn FnMut(RunChunk<'_>) -> Result<(), E>,
    ) -> Result<(), E> {
        while self.next() < k_end {
            let upto = (self.first + CHUNK_SAMPLES).clamp(self.next() + 1, k_end);
            self.sample_and_follow(sampler, upto, axes.runs, axes.progress, plan)?;
            if self.is_full() {
                self.hand_on(axes.runs, plan, sink)?;
            }
        }
        Ok(())
    }

    fn hand_on<E>(
        &mut self,
        runs: &mut [AxisRun],
        plan: &Plan,
        sink: &mut dyn FnMut(RunChunk<'_>) -> Result<(), E>,
    ) -> Result<(), E> {
        let [x, y] = [0, 1].map(|a| runs[a].take_trace());
        let z = runs.get_mut(2).map(AxisRun::take_trace);
        if self.commands.is_empty() {
            return Ok(());
        }
        sink(RunChunk {
            first: self.first,
            plan,
            commands: &self.commands,
            x,
            y,
            z,
        })?;
        self.first = self.next();
        self.commands.truncate(0);
        Ok(())
    }
}

/// The last segment of the stretch that starts at `first`: the first one the control
/// stops exactly after (when it checks positions at all), or the program's last.
fn stretch_end(segments: &[Segment], first: usize, checks_in_position: bool) -> usize {
    let n = segments.len();
    (first..n)
        .find(|&i| checks_in_position && ends_in_exact_stop(segments, i))
        .unwrap_or(n - 1)
}

/// Sets the start times of segments `first..=last` from `t0` with no waits between them
/// (none of them but the last ends in an exact stop), and returns when the motion ends.
fn time_stretch(plan: &mut Plan, first: usize, last: usize, t0: f64) -> f64 {
    let mut t = t0;
    for p in &mut plan.plans[first..=last] {
        p.t_start_s = t;
        p.wait_s = 0.0;
        t += p.duration_s;
    }
    t
}

/// Advances the axes through `commands[range]`: two in parallel when that pays, three in
/// slices two at a time.
fn follow_all(
    runs: &mut [AxisRun],
    commands: &Commands,
    range: std::ops::Range<usize>,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<(), SimError> {
    match runs {
        [rx, ry] => follow_both([rx, ry], commands, range, progress),
        _ => follow_in_turns(runs, commands, range, progress),
    }
}

/// Samples a turn of [`follow_in_turns`] advances an axis by.
const TURN_SAMPLES: usize = 2048;

/// Advances three (or more) axes through `commands[range]` on two threads: each turn the two
/// axes furthest behind advance by a slice side by side, so that three axes of equal cost
/// take one and a half times what one takes, not twice.
fn follow_in_turns(
    runs: &mut [AxisRun],
    commands: &Commands,
    range: std::ops::Range<usize>,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<(), SimError> {
    let mut done = vec![range.start; runs.len()];
    let slice = |from: usize| from..(from + TURN_SAMPLES).min(range.end);
    loop {
        let mut behind: Vec<usize> = (0..runs.len()).filter(|&a| done[a] < range.end).collect();
        behind.sort_by_key(|&a| done[a]);
        let (a, b) = match behind[..] {
            [] => return Ok(()),
            [a] => (a, None),
            [a, b, ..] => (a, Some(b)),
        };
        let (ra, rb) = (slice(done[a]), b.map(|b| slice(done[b])));
        let (first, second) = match b {
            None => (
                follow_one(&mut runs[a], a, commands, ra.clone(), progress),
                Ok(()),
            ),
            Some(b) => {
                let (run_a, run_b) = pair_mut(runs, a, b);
                let rb = rb.clone().unwrap_or_default();
                rayon::join(
                    || follow_one(run_a, a, commands, ra.clone(), progress),
                    || follow_one(run_b, b, commands, rb, progress),
                )
            }
        };
        first.and(second)?;
        done[a] = ra.end;
        if let (Some(b), Some(rb)) = (b, rb) {
            done[b] = rb.end;
        }
    }
}

/// Axis `a` (its run) through `commands[range]`.
fn follow_one(
    run: &mut AxisRun,
    a: usize,
    commands: &Commands,
    range: std::ops::Range<usize>,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<(), SimError> {
    run.follow(axis_commands(commands, a), range, progress)
        .map_err(|e| e.on_axis(LETTERS[a], None))
}

/// Axis `a`'s commands (0 X, 1 Y, 2 Z).
fn axis_commands(commands: &Commands, a: usize) -> &crate::sim::AxisCommands {
    match a {
        0 => &commands.x,
        1 => &commands.y,
        _ => &commands.z,
    }
}

/// Two distinct elements of a slice, both mutably.
fn pair_mut<T>(v: &mut [T], a: usize, b: usize) -> (&mut T, &mut T) {
    debug_assert_ne!(a, b);
    if a < b {
        let (lo, hi) = v.split_at_mut(b);
        (&mut lo[a], &mut hi[0])
    } else {
        let (lo, hi) = v.split_at_mut(a);
        (&mut hi[0], &mut lo[b])
    }
}

/// Advances X and Y through `commands[range]`, in parallel when that pays.
fn follow_both(
    runs: [&mut AxisRun; 2],
    commands: &Commands,
    range: std::ops::Range<usize>,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<(), SimError> {
    let [rx, ry] = runs;
    let (x, y) = if range.len() >= PARALLEL_FROM {
        rayon::join(
            || rx.follow(&commands.x, range.clone(), progress),
            || ry.follow(&commands.y, range.clone(), progress),
        )
    } else {
        (
            rx.follow(&commands.x, range.clone(), progress),
            ry.follow(&commands.y, range.clone(), progress),
        )
    };
    x.map_err(|e| e.on_axis('X', None))
        .and(y.map_err(|e| e.on_axis('Y', None)))
}

/// An axis's failure placed at the program line running when it happened.
fn placed(error: SimError, plan: &Plan) -> SimError {
    match error {
        SimError::OnAxis { axis, source, .. } => {
            let line = source.t_s().and_then(|t| plan.line_at(t));
            source.on_axis(axis, line)
        }
        other => other,
    }
}

/// How an in-position wait ended.
struct Waited {
    /// When the check timed out: each axis's distance from the end point then (m).
    timed_out: Option<Vec<f64>>,
}

/// Holds the commanded end point, one cycle at a time, until both axes read within the
/// window of it (checked at each cycle's start, as the control does) or the check times
/// out.
fn wait_in_position(
    runs: &mut [AxisRun],
    sampler: &mut Sampler,
    buffer: &mut Buffer,
    window_m: f64,
    config: &ExecConfig,
) -> Result<Waited, SimError> {
    let dt = buffer.commands.dt_s;
    let max_cycles = (config.in_position_timeout_s / dt).ceil() as usize;
    for cycle in 0..=max_cycles {
        let k = buffer.commands.len();
        // The held end point, as the interpolator gives it past the motion.
        sampler.push(buffer.next() as f64 * dt, &mut buffer.commands);
        let c = &buffer.commands;
        let misses: Vec<f64> = runs
            .iter()
            .enumerate()
            .map(|(a, run)| (axis_commands(c, a).pos_m[k] - run.feedback_m()).abs())
            .collect();
        if misses.iter().all(|&m| m <= window_m) || cycle == max_cycles {
            // The next block starts at this sample: it is not the wait's.
            buffer.commands.truncate(k);
            let timed_out =
                (cycle == max_cycles && misses.iter().any(|&m| m > window_m)).then_some(misses);
            return Ok(Waited { timed_out });
        }
        for (a, run) in runs.iter_mut().enumerate() {
            let axis = axis_commands(c, a);
            run.advance(axis.pos_m[k], axis.vel_m_per_s[k], axis.acc_m_per_s2[k])
                .map_err(|e| e.on_axis(LETTERS[a], None))?;
        }
    }
    unreachable!("the loop returns at its last cycle")
}

fn in_position_warning(line: u32, misses_m: Vec<f64>, window_m: f64, timeout_s: f64) -> Warning {
    let axes: Vec<String> = LETTERS
        .iter()
        .zip(misses_m)
        .filter(|(_, m)| *m > window_m)
        .map(|(a, m)| format!("{a} {:.1} µm", um_from_m(m)))
        .collect();
    Warning {
        line,
        message: format!(
            "the axes did not come within the {:.1} µm in-position window of this block's end \
             within {timeout_s} s (still off: {}); a control would stop with a \
             positioning-monitoring alarm — the run goes on",
            um_from_m(window_m),
            axes.join(", ")
        ),
    }
}
