//! The timeline a measurement is compared on: the commands that drive the simulation (the
//! program's plan, or the commands the measurement recorded), the measurement's clock
//! aligned to the program's, the samples the residual uses, and the residual itself.
//!
//! Without recorded commands the program's plan is the timeline, so the machine's own
//! in-position waits matter: a model with another gain is re-planned with its waits
//! ([`Context::simulate_axis`]). Rapids and the waits after them are left out of the
//! residual, except in a record with its commands that is mostly rapids.

use super::residual::{chatter_noise_power, chatter_windows, rms};
use super::{DiagnoseError, DiagnoseSettings};
use crate::check::plan_commands;
use crate::gcode::Program;
use crate::geometry;
use crate::machine::{AxisName, MachineConfig};
use crate::path::Motion;
use crate::plan::{Commands, InPosition, Plan};
use crate::sim::{AxisModel, MeasuredAt, SimConfig, simulate};
use crate::trace::measured::MeasuredTrace;
use crate::trace::recorded::{commands_from_record, place_on_path};
use crate::trace::signal::sample;
use crate::units::um_from_m;

/// How finely a context's simulations step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stepping {
    /// The simulator settings' steps: what the diagnosis's figures are computed at.
    Full,
    /// One step per control cycle where that gives the same trace — a model whose inputs do
    /// not vary within a cycle (see [`AxisModel::inputs_vary_within_cycle`]) — at a quarter
    /// of the cost: the search's fits.
    PerCycleWhereExact,
    /// One step per control cycle always: a first look, to choose where a fit starts.
    PerCycle,
}

/// The timeline everything is compared on: the program's clock, with the simulation's
/// commands, and the measured samples the residual uses.
#[derive(Clone)]
pub struct Context<'a> {
    /// The measurement.
    pub measured: &'a MeasuredTrace,
    /// Commands driving the simulation, on the program's clock (t = 0 at program start),
    /// each sample placed on its segment of the program: the plan's, or the recorded ones.
    pub commands: Commands,
    /// The program's plan, for geometry and source lines.
    pub plan: Plan,
    /// With recorded commands, how much later than in our plan they start to move (s), on
    /// the simulation's timeline: where the program starts.
    pub program_start_s: f64,
    /// Command period (s).
    pub dt: f64,
    /// The clock offset when it is known (the measurement recorded its commands).
    pub fixed_offset: Option<f64>,
    /// Per plan segment, how much longer than planned the control stood after it (s):
    /// measured when stretches are aligned on their own, zero otherwise. A control holds a
    /// standstill as long as its in-position check takes on the real machine, which the
    /// plan can only estimate.
    pub extra_wait_s: Vec<f64>,
    /// Simulator settings.
    pub sim: SimConfig,
    /// How finely the simulation steps.
    pub stepping: Stepping,
    /// Standing time after the program (s), as the commands were built.
    pub settle_s: f64,
    /// Measured samples the residual uses, one per command period at most.
    pub samples: Vec<usize>,
    /// Time between the samples the residual uses (s).
    pub sample_dt_s: f64,
    /// The measurement's noise floor (m), once estimated.
    pub noise_sigma: f64,
    /// Where the measurement read the positions: the simulated quantity compared.
    pub measured_at: MeasuredAt,
    /// On the plan's timeline: how much later the record's second half runs than its first
    /// half under one clock offset (s) — how far the machine's timing departs from our plan.
    pub timing_drift_s: Option<f64>,
    /// Whether the rapids are among the samples compared (a record with its commands that
    /// is mostly rapids).
    pub rapids_compared: bool,
}

impl Context<'_> {
    /// Simulates one axis of a machine on the context's commands; `None` if it cannot run.
    pub fn simulate_axis(&self, machine: &MachineConfig, axis: AxisName) -> Option<Vec<f64>> {
        match self.replanned(machine) {
            None => self.read_on(machine, axis, &self.commands, None),
            // The machine runs on its own plan's clock.
            Some(commands) => self.read_on(machine, axis, &commands, None),
        }
    }

    /// `axis` of `machine` on `commands` as the measurement sees it: with the axes'
    /// squareness, from `other` (the other axis on the same commands) or, when not given
    /// and needed, a simulation of it.
    fn read_on(
        &self,
        machine: &MachineConfig,
        axis: AxisName,
        commands: &Commands,
        other: Option<&[f64]>,
    ) -> Option<Vec<f64>> {
        let mut own = self.simulate_on(machine, axis, commands)?;
        let cross = geometry::CrossTerms::of(machine, axis);
        if !cross.is_zero() && self.measured_at != MeasuredAt::Motor {
            let simulated;
            let other = match other {
                Some(o) => o,
                None => {
                    simulated = self.simulate_on(machine, axis.other(), commands)?;
                    &simulated
                }
            };
            cross.add(&mut own, other);
        }
        Some(own)
    }

    /// Simulates `axis` of `machine`, and the other axis too when `machine` changes the
    /// program's timing (a gain changes the in-position waits, which both axes keep);
    /// otherwise the other axis keeps `other`.
    pub fn simulate_pair<'b>(
        &self,
        machine: &MachineConfig,
        axis: AxisName,
        other: &'b [f64],
    ) -> Option<(Vec<f64>, std::borrow::Cow<'b, [f64]>)> {
        Some(match self.replanned(machine) {
            None => (
                self.read_on(machine, axis, &self.commands, Some(other))?,
                std::borrow::Cow::Borrowed(other),
            ),
            Some(commands) => {
                let raw_own = self.simulate_on(machine, axis, &commands)?;
                let mut other = self.simulate_on(machine, axis.other(), &commands)?;
                let mut own = raw_own.clone();
                if self.measured_at != MeasuredAt::Motor {
                    geometry::CrossTerms::of(machine, axis).add(&mut own, &other);
                    geometry::CrossTerms::of(machine, axis.other()).add(&mut other, &raw_own);
                }
                (own, std::borrow::Cow::Owned(other))
            }
        })
    }

    /// One axis of `machine` on `commands`, read where the measurement was taken, stepped as
    /// the context says.
    fn simulate_on(
        &self,
        machine: &MachineConfig,
        axis: AxisName,
        commands: &Commands,
    ) -> Option<Vec<f64>> {
        let model = AxisModel::from_config(machine.axis(axis));
        let per_cycle = match self.stepping {
            Stepping::Full => false,
            Stepping::PerCycleWhereExact => !model.inputs_vary_within_cycle(),
            Stepping::PerCycle => true,
        };
        let sim = if per_cycle {
            SimConfig {
                substeps: 1,
                ..self.sim
            }
        } else {
            self.sim
        };
        simulate(&model, commands.axis(axis), self.dt, &sim)
            .ok()
            .map(|t| t.into_read_at(self.measured_at))
    }

    /// The commands of `machine` when its in-position waits differ from those of the plan
    /// the context was built on (its gains differ); `None` when that plan serves, and always
    /// when the timeline is measured (recorded commands, or waits measured stretch by
    /// stretch).
    fn replanned(&self, machine: &MachineConfig) -> Option<Commands> {
        // Recorded commands, or waits measured stretch by stretch, fix the timeline.
        if self.fixed_offset.is_some() || !self.extra_wait_s.is_empty() {
            return None;
        }
        let nominal = self.plan.config.in_position;
        // Another controller's time scale (its closed loop's bandwidth, costly to find) does
        // not change with any cause's values — none touches its gains or the mass — so the
        // nominal plan's serves; a cascade's is its Kv, which a gain error changes.
        let in_position = nominal.map(|ip| {
            let computed = InPosition::kv_per_s_of_cascades(machine);
            InPosition {
                kv_per_s: [0, 1].map(|i| computed[i].unwrap_or(ip.kv_per_s[i])),
                ..ip
            }
        });
        if in_position == nominal {
            return None;
        }
        let plan = self.plan.with_waits(in_position, &self.extra_wait_s);
        Some(commands_of(&plan, self.settle_s))
    }

    fn measured_axis(&self, axis: AxisName) -> &[f64] {
        match axis {
            AxisName::X => &self.measured.x_m,
            AxisName::Y => &self.measured.y_m,
        }
    }

    /// Time of measured sample `i` on the program's clock, for a clock offset.
    pub fn prog_time(&self, i: usize, offset_s: f64) -> f64 {
        self.measured.time_s(i) - offset_s
    }

    /// measured − simulated at the context's samples (what point-by-point fits minimise).
    pub fn residual(&self, axis: AxisName, trace: &[f64], offset_s: f64) -> Vec<f64> {
        let m = self.measured_axis(axis);
        self.samples
            .iter()
            .map(|&i| m[i] - sample(trace, self.dt, self.prog_time(i, offset_s)))
            .collect()
    }

    /// The measured axis at the context's samples.
    pub fn measured_at_samples(&self, axis: AxisName) -> Vec<f64> {
        let m = self.measured_axis(axis);
        self.samples.iter().map(|&i| m[i]).collect()
    }

    /// A trace at the context's samples.
    pub fn at_samples(&self, trace: &[f64], offset_s: f64) -> Vec<f64> {
        self.samples
            .iter()
            .map(|&i| sample(trace, self.dt, self.prog_time(i, offset_s)))
            .collect()
    }

    /// d(simulated)/dt at the samples: how the residual changes with the offset.
    pub fn residual_rate(&self, trace: &[f64], offset_s: f64) -> Vec<f64> {
        let h = 0.25 * self.dt;
        self.samples
            .iter()
            .map(|&i| {
                let t = self.prog_time(i, offset_s);
                (sample(trace, self.dt, t + h) - sample(trace, self.dt, t - h)) / (2.0 * h)
            })
            .collect()
    }

    /// The residual in the statistical domain, for an axis in stick-slip, whose chatter is
    /// deterministic in its statistics but not in its phase. Per 0.25 s window, two values:
    /// the mismatch of the mean position and the mismatch of the chatter power (the variance
    /// about a ±10 ms running mean, the measurement's noise share removed). Each is in units
    /// of its sampling spread, which counts the chatter itself as noise: a window holds
    /// about a dozen slips whose timing no model predicts.
    pub fn statistical_residual(&self, axis: AxisName, trace: &[f64], offset_s: f64) -> Vec<f64> {
        self.window_statistics(axis, trace, offset_s)
            .into_iter()
            .flat_map(|(mean, power)| [mean, power])
            .collect()
    }

    /// Per window: the mean mismatch and the chatter-power mismatch, in spreads.
    fn window_statistics(&self, axis: AxisName, trace: &[f64], offset_s: f64) -> Vec<(f64, f64)> {
        self.window_statistics_against(axis, trace, offset_s, false)
    }

    /// [`Context::window_statistics`]; with `no_model_chatter` the model is taken to have no
    /// chatter at all (its trace then only matters for the means).
    fn window_statistics_against(
        &self,
        axis: AxisName,
        trace: &[f64],
        offset_s: f64,
        no_model_chatter: bool,
    ) -> Vec<(f64, f64)> {
        /// Independent slips in a window (a slip cycle lasts some 20 ms).
        const SLIPS_PER_WINDOW: f64 = 12.0;
        let sigma = self.noise_sigma;
        let meas = self.measured_at_samples(axis);
        let model = self.at_samples(trace, offset_s);
        let noise_power = chatter_noise_power(sigma, self.sample_dt_s);
        chatter_windows(&meas, &model, self.sample_dt_s, sigma)
            .into_iter()
            .map(|w| {
                let pmod = if no_model_chatter { 0.0 } else { w.model_power };
                let chatter = w.measured_power + pmod;
                let mean_spread = (sigma * sigma / w.n + chatter / SLIPS_PER_WINDOW)
                    .sqrt()
                    .max(1e-30);
                let power_spread = (chatter + noise_power)
                    * (2.0 / SLIPS_PER_WINDOW.min(w.n)).sqrt()
                    + noise_power * (2.0 / w.n).sqrt();
                (
                    w.mean_mismatch / mean_spread,
                    (w.measured_power - pmod) / power_spread.max(1e-30),
                )
            })
            .collect()
    }

    /// How far the measurement's chatter departs from the model's, in standard deviations
    /// of its χ²: above a few, the axis is in stick-slip the model does not reproduce, and
    /// point-by-point comparison means nothing there.
    pub fn chatter_excess(&self, axis: AxisName, trace: &[f64], offset_s: f64) -> f64 {
        let w = self.window_statistics(axis, trace, offset_s);
        let m = w.len() as f64;
        (w.iter().map(|(_, p)| p * p).sum::<f64>() - m) / (2.0 * m).sqrt()
    }

    /// How far the measurement's own chatter exceeds its noise, in standard deviations of
    /// that χ² (the model's chatter taken as none): an axis that chatters stays in the
    /// statistical domain whatever the model does.
    pub fn measured_chatter_excess(&self, axis: AxisName, offset_s: f64) -> f64 {
        let flat: Vec<f64> = vec![0.0; self.commands.len()];
        let w = self.window_statistics_against(axis, &flat, offset_s, true);
        let m = w.len() as f64;
        (w.iter().map(|(_, p)| p * p).sum::<f64>() - m) / (2.0 * m).sqrt()
    }

    /// Whether the measurement shows the axis sticking: stretches of 10 ms in which it
    /// stands (its readings spread less than four noise deviations, or a fifth of the
    /// command's travel) while the command moves on, each ended by a slip, in at least three
    /// places and a fiftieth of the moving time. Stick-slip chatter is recognised by that,
    /// not by the spread of positions about a running mean, which any servo oscillation
    /// has. (A logger that holds each value for several rows also looks like this; the
    /// trace reader has already read such a record at its true rate.)
    pub fn sticking_seen(&self, axis: AxisName, offset_s: f64) -> bool {
        let seen = self.standstills_while_commanded(axis, offset_s);
        let slipped = seen
            .stretches
            .iter()
            .filter(|s| self.slip_follows(axis, s, offset_s))
            .count();
        slipped >= 3 && seen.stuck_samples as f64 >= 0.02 * seen.moving_samples as f64
    }

    /// The stretches in which the measured axis stands while its command moves.
    fn standstills_while_commanded(&self, axis: AxisName, offset_s: f64) -> Standstills {
        const WINDOW_S: f64 = 0.01;
        let m = self.measured_axis(axis);
        let span = ((WINDOW_S / self.measured.dt_s).round() as usize).max(2);
        let sigma = self.noise_sigma;
        let mut seen = Standstills::default();
        let mut open: Option<(usize, usize)> = None;
        for &i in &self.samples {
            if i + span >= m.len() {
                break;
            }
            let t = self.prog_time(i, offset_s);
            let travel = (self.command_at(axis, t + WINDOW_S).0 - self.command_at(axis, t).0).abs();
            let stands = travel >= 6.0 * sigma && {
                seen.moving_samples += 1;
                let (lo, hi) = m[i..=i + span]
                    .iter()
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
                        (l.min(v), h.max(v))
                    });
                hi - lo < (4.0 * sigma).max(0.2 * travel)
            };
            if stands {
                seen.stuck_samples += 1;
                open = Some(open.map_or((i, i + span), |(first, _)| (first, i + span)));
            } else if let Some(stretch) = open.take() {
                seen.stretches.push(stretch);
            }
        }
        seen.stretches.extend(open);
        seen
    }

    /// Whether a standstill `(first, last)` (measured samples) ends in a slip: within as
    /// long again (at least 20 ms) the axis gains on its command at least half the lag the
    /// standstill built — it catches up, as a table does when it breaks loose. Lost motion
    /// (backlash, a dead time) also stands the axis while the command moves, but the lag it
    /// builds stays.
    fn slip_follows(&self, axis: AxisName, &(first, last): &(usize, usize), offset_s: f64) -> bool {
        let m = self.measured_axis(axis);
        let dt = self.measured.dt_s;
        let end = (last + (last - first).max((0.02 / dt).round() as usize)).min(m.len() - 1);
        let command = |i: usize| self.command_at(axis, self.prog_time(i, offset_s));
        let direction = command(first).1.signum();
        let lag = |i: usize| (command(i).0 - m[i]) * direction;
        let built = lag(last) - lag(first);
        let recovered = lag(last) - (last..=end).map(lag).fold(f64::INFINITY, f64::min);
        recovered >= 0.5 * built && recovered > 4.0 * std::f64::consts::SQRT_2 * self.noise_sigma
    }

    /// Whether the program is in a rapid (or the in-position wait after it) at time `t`.
    pub(crate) fn in_rapid(&self, t: f64) -> bool {
        let pc = &self.commands;
        let k = (t / pc.dt_s)
            .round()
            .clamp(0.0, (pc.len().max(1) - 1) as f64) as usize;
        pc.segment
            .get(k)
            .is_some_and(|&s| self.plan.segments[s as usize].motion == Motion::Rapid)
    }

    /// Commanded position and velocity of an axis at time `t`.
    pub fn command_at(&self, axis: AxisName, t: f64) -> (f64, f64) {
        let c = self.commands.axis(axis);
        (
            sample(&c.pos_m, self.dt, t),
            sample(&c.vel_m_per_s, self.dt, t),
        )
    }
}

/// Where a measured axis stood while its command moved.
#[derive(Default)]
struct Standstills {
    /// Compared samples at which the command moved.
    moving_samples: usize,
    /// Those at which the axis stood.
    stuck_samples: usize,
    /// Each run of standing, as (first, last) measured sample.
    stretches: Vec<(usize, usize)>,
}

/// The constant offset (m) by which a record's commands run beside the program, if shifting
/// them back by it puts them on the program's path: the centres of the two ranges of travel,
/// confirmed by placing the shifted commands on the path within the tolerance.
fn parallel_offset(
    plan: &Plan,
    planned: &Commands,
    measured: &MeasuredTrace,
    dt: f64,
    settings: &DiagnoseSettings,
) -> Option<[f64; 2]> {
    let [xc, yc] = measured.commands.as_ref()?;
    let centre = |v: &[f64]| {
        let (lo, hi) = v
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &x| {
                (l.min(x), h.max(x))
            });
        0.5 * (lo + hi)
    };
    let offset = [
        centre(xc) - centre(&planned.x.pos_m),
        centre(yc) - centre(&planned.y.pos_m),
    ];
    if !offset.iter().all(|o| o.is_finite()) {
        return None;
    }
    let shift = |v: &[f64], o: f64| v.iter().map(|p| p - o).collect::<Vec<f64>>();
    let mut shifted = commands_from_record(
        &shift(xc, offset[0]),
        &shift(yc, offset[1]),
        measured.dt_s,
        dt,
    );
    match place_on_path(plan, &mut shifted) {
        Some(worst) if worst.distance_m > settings.command_tolerance_m => None,
        _ => Some(offset),
    }
}

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
pub fn context<'a>(
    program: &Program,
    machine: &MachineConfig,
    measured: &'a MeasuredTrace,
    settings: &DiagnoseSettings,
) -> Result<(Context<'a>, f64), DiagnoseError> {
    let (plan, plan_commands) = plan_commands(program, machine, &settings.check)?;
    let dt = plan_commands.dt_s;
    let cannot = |reason: String| DiagnoseError::CannotAlign {
        file: measured.file.clone(),
        reason,
    };
    let (commands, fixed_offset, program_start_s) = match &measured.commands {
        Some([xc, yc]) => {
            // The measurement's commands drive the simulation on its own clock, whatever
            // timing our plan gives the program; the program gives geometry and lines.
            let mut commands = commands_from_record(xc, yc, measured.dt_s, dt);
            if let Some(worst) = place_on_path(&plan, &mut commands)
                && worst.distance_m > settings.command_tolerance_m
            {
                let hint = match parallel_offset(&plan, &plan_commands, measured, dt, settings) {
                    Some([x, y]) => format!(
                        "the commands run parallel to the program, offset by X {:.3} mm, Y {:.3} \
                         mm — a work offset; give it with --work-offset {:.3},{:.3}",
                        x * 1e3,
                        y * 1e3,
                        x * 1e3,
                        y * 1e3
                    ),
                    None => "is this a record of this program, in the same coordinates?".into(),
                };
                return Err(DiagnoseError::OffPath {
                    file: measured.file.clone(),
                    t_s: measured.t0_s + worst.t_s,
                    line: worst.line,
                    distance_um: um_from_m(worst.distance_m),
                    tolerance_um: um_from_m(settings.command_tolerance_m),
                    hint,
                });
            }
            let start = first_motion(&commands) - first_motion(&plan_commands);
            (commands, Some(measured.t0_s), start)
        }
        None => (plan_commands, None, 0.0),
    };
    let mut ctx = Context {
        measured,
        commands,
        plan,
        program_start_s,
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
    };
    let nominal = [AxisName::X, AxisName::Y].map(|a| ctx.simulate_axis(machine, a));
    let [Some(x), Some(y)] = nominal else {
        let model = AxisModel::from_config(&machine.x);
        crate::sim::linear::check_stable(&model)?;
        return Err(cannot(
            "the nominal machine cannot be simulated on these commands".into(),
        ));
    };
    let offset = match fixed_offset {
        Some(o) => o,
        None => coarse_offset(&ctx, &x, &y).ok_or_else(|| {
            cannot("the measurement and the program do not overlap in time".into())
        })?,
    };
    // Residual samples: those whose program time lies within the simulation, with a margin
    // so that the offset can move during the fits.
    let duration = ctx.commands.duration_s();
    let margin = if fixed_offset.is_some() { 0.0 } else { 0.2 };
    // Rapids are left out: we cannot know how a control ran the rapids we planned (each axis
    // on its own, blended or not, at which rate), their millimetres of lag would drown the
    // micrometres the causes leave, and even recorded, a rapid's acceleration steps are
    // read back from sparse samples only roughly (a 15 ms logger's rapids pass for
    // friction). The standstill after each rapid goes with it. A record with its commands
    // that is mostly rapids is compared rapids and all rather than refused: the commands
    // say what the control did there.
    //
    // One sample per command period is compared: the model's input changes no faster, so
    // finer samples add no evidence about it — only correlated copies of the same model
    // error, which would count as independent proof at 10 kHz and not at 2 ms, and make the
    // diagnosis depend on the sampling rate.
    let stride = ((dt / measured.dt_s) * (1.0 + 1e-9)).floor().max(1.0) as usize;
    ctx.sample_dt_s = stride as f64 * measured.dt_s;
    let expected = (duration / measured.dt_s).min(measured.len() as f64) / stride as f64;
    let compared = |ctx: &Context, with_rapids: bool| -> Vec<usize> {
        (0..measured.len())
            .step_by(stride)
            .filter(|&i| {
                let t = ctx.prog_time(i, offset);
                t >= margin && t <= duration - margin && (with_rapids || !ctx.in_rapid(t))
            })
            .collect()
    };
    ctx.samples = compared(&ctx, false);
    if (ctx.samples.len() as f64) < 0.5 * expected && fixed_offset.is_some() {
        ctx.samples = compared(&ctx, true);
        ctx.rapids_compared = true;
    }
    if (ctx.samples.len() as f64) < 0.5 * expected {
        return Err(cannot(format!(
            "only {} of the {:.0} samples compared fall within the program's {:.1} s",
            ctx.samples.len(),
            expected,
            duration
        )));
    }
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
    let rms = rms(&[
        ctx.residual(AxisName::X, &x, offset),
        ctx.residual(AxisName::Y, &y, offset),
    ]
    .concat());
    // With recorded commands the record has shown itself to be of this program (its
    // commands lie on the path) and its clock is its own: a model far from it is for the
    // diagnosis to explain, or to say it cannot.
    if rms > 0.5e-3 && fixed_offset.is_none() {
        let off_path = share_off_path(&ctx);
        let hint = if off_path > 0.2 {
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
        return Err(cannot(format!(
            "the best clock offset ({offset:.3} s) leaves {:.0} µm RMS between measurement and \
             prediction: is this a measurement of this program, in the same coordinates?{drift}{hint}",
            um_from_m(rms)
        )));
    }
    Ok((ctx, offset))
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
    let half = ctx.samples.len() / 2;
    let (first, second) = ctx.samples.split_at(half);
    let best = |part: &[usize]| {
        let mut sub = ctx.clone();
        sub.samples = part.iter().step_by(4).copied().collect();
        let cost = |o: f64| sub.offset_cost(x, y, o);
        // A 5 ms scan, then golden section about its best: over half a second the
        // mismatch need not be unimodal.
        let start = (0..=200)
            .map(|i| offset - REACH_S + i as f64 * 0.005)
            .min_by(|a, b| cost(*a).total_cmp(&cost(*b)))
            .unwrap_or(offset);
        golden_section(start - 0.005, start + 0.005, 1e-6, &cost)
    };
    best(second) - best(first)
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
    ctx.commands = commands_of(&ctx.plan, ctx.settle_s);
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

/// A plan's commands with the settling tail.
fn commands_of(plan: &Plan, settle_s: f64) -> Commands {
    let mut commands = crate::plan::sample(plan);
    commands.hold(settle_s);
    commands
}

/// Golden-section minimum of `f` on [a, b] to a bracket of `tol`.
pub(crate) fn golden_section(mut a: f64, mut b: f64, tol: f64, f: &dyn Fn(f64) -> f64) -> f64 {
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let (mut c, mut d) = (b - g * (b - a), a + g * (b - a));
    let (mut fc, mut fd) = (f(c), f(d));
    while b - a > tol {
        if fc < fd {
            (b, d, fd) = (d, c, fc);
            c = b - g * (b - a);
            fc = f(c);
        } else {
            (a, c, fc) = (c, d, fd);
            d = a + g * (b - a);
            fd = f(d);
        }
    }
    0.5 * (a + b)
}

impl Context<'_> {
    /// Per-axis masks at the residual samples: near a reversal, and near any event
    /// (reversal or acceleration).
    pub fn event_masks(
        &self,
        axis: AxisName,
        offset: f64,
        half_window_s: f64,
    ) -> (Vec<bool>, Vec<bool>) {
        let ctx = self;
        let c = ctx.commands.axis(axis);
        let n = c.len();
        let w = (half_window_s / ctx.dt).ceil() as isize;
        let mut reversal = vec![false; n];
        let mut event = vec![false; n];
        let mark = |mask: &mut Vec<bool>, k: usize| {
            for j in (k as isize - w).max(0)..(k as isize + w).min(n as isize) {
                mask[j as usize] = true;
            }
        };
        let mut last_sign = 0.0;
        for k in 0..n {
            let v = c.vel_m_per_s[k];
            if v.abs() > 1e-9 {
                if last_sign != 0.0 && v.signum() != last_sign {
                    mark(&mut reversal, k);
                    mark(&mut event, k);
                }
                last_sign = v.signum();
            }
            if c.acc_m_per_s2[k].abs() > 0.02 {
                mark(&mut event, k);
            }
        }
        let at = |mask: &[bool]| -> Vec<bool> {
            ctx.samples
                .iter()
                .map(|&i| {
                    let k = (ctx.prog_time(i, offset) / ctx.dt)
                        .round()
                        .clamp(0.0, (n - 1) as f64) as usize;
                    mask[k]
                })
                .collect()
        };
        (at(&reversal), at(&event))
    }
}
