//! The timeline a measurement is compared on: the commands that drive the simulation (the
//! program's plan, or the commands the measurement recorded), the measurement's clock
//! aligned to the program's, the samples the residual uses, and the residual itself.
//!
//! Without recorded commands the program's plan is the timeline, so the machine's own
//! in-position waits matter: a model with another gain is re-planned with its waits
//! ([`Context::simulate_axis`]). Rapids and the waits after them are left out of the
//! residual, except in a record with its commands that is mostly rapids.

use super::residual::{chatter_noise_power, chatter_windows};
use crate::machine::{AxisName, MachineConfig};
use crate::path::Motion;
use crate::plan::{Commands, InPosition, Plan};
use crate::sim::geometry;
use crate::sim::{AxisModel, MeasuredAt, SimConfig, simulate};
use crate::trace::measured::MeasuredTrace;
use crate::trace::signal::sample;

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
    pub(crate) measured: &'a MeasuredTrace,
    /// Commands driving the simulation, on the program's clock (t = 0 at program start),
    /// each sample placed on its segment of the program: the plan's, or the recorded ones.
    pub(crate) commands: Commands,
    /// The program's plan, for geometry and source lines.
    pub(crate) plan: Plan,
    /// With recorded commands, how much later than in our plan they start to move (s), on
    /// the simulation's timeline: where the program starts.
    pub(crate) program_start_s: f64,
    /// Command period (s).
    pub(crate) dt: f64,
    /// The clock offset when it is known (the measurement recorded its commands).
    pub(crate) fixed_offset: Option<f64>,
    /// Per plan segment, how much longer than planned the control stood after it (s):
    /// measured when stretches are aligned on their own, zero otherwise. A control holds a
    /// standstill as long as its in-position check takes on the real machine, which the
    /// plan can only estimate.
    pub(crate) extra_wait_s: Vec<f64>,
    /// Simulator settings.
    pub(crate) sim: SimConfig,
    /// How finely the simulation steps.
    pub(crate) stepping: Stepping,
    /// Standing time after the program (s), as the commands were built.
    pub(crate) settle_s: f64,
    /// Measured samples the residual uses, one per command period at most.
    pub(crate) samples: Vec<usize>,
    /// Time between the samples the residual uses (s).
    pub(crate) sample_dt_s: f64,
    /// The measurement's noise floor (m), once estimated.
    pub(crate) noise_sigma: f64,
    /// Where the measurement read the positions: the simulated quantity compared.
    pub(crate) measured_at: MeasuredAt,
    /// On the plan's timeline: how much later the record's second half runs than its first
    /// half under one clock offset (s) — how far the machine's timing departs from our plan.
    pub(crate) timing_drift_s: Option<f64>,
    /// Whether the rapids are among the samples compared (a record with its commands that
    /// is mostly rapids).
    pub(crate) rapids_compared: bool,
    /// Per axis (X, Y, Z by [`AxisName::index`]), the compared samples left out of its
    /// point-by-point residual: where it holds still after settling and the nominal model
    /// hunts ([`Context::hunting_holds`]). Empty for none (Z's, where Z is not compared).
    pub(crate) holding: [Vec<bool>; 3],
    /// Per axis (X, Y, Z), the compared samples left out of its point-by-point residual
    /// because the axis has not settled from the record's start
    /// ([`Context::unsettled_at_start`]; for X and Y: Z's start is theirs). Empty for none.
    pub(crate) unsettled: [Vec<bool>; 3],
    /// How the record's start was set: a run-in before it, where its commands join the
    /// program, the settling stretch not compared.
    pub(crate) start: super::start::Start,
}

/// A command slower than this stands (m/s): recorded commands' speeds are fitted and carry
/// their rounding.
pub(super) const STILL_M_PER_S: f64 = 1e-7;
/// How close to its command a holding axis must have come to count as settled (m): beyond
/// the approach, which the comparison keeps, and wide enough for any hunting.
const SETTLED_M: f64 = 2e-6;
/// How far the model must move in a settled hold to count as hunting (m).
const HUNTING_M: f64 = 0.02e-6;
/// How long the model must stand within [`HUNTING_M`] to count as at rest (s): longer than a
/// stick at a reversal of the approach lasts, far shorter than a hunting cycle (its
/// integrator winds against static friction for a good part of a second).
const QUIET_S: f64 = 0.05;
/// How long after a hunting hold the axis's start is left out too (s): three time constants
/// of a position loop of Kv = 1 m/min/mm, where a difference in the state the hunting left
/// has fallen to a twentieth.
const START_AFTER_HUNTING_S: f64 = 0.2;

/// Length of the alternate blocks of time a record is cut into for fitting on one half and
/// judging on the other (s): long against a sample, short against the program's moves, so
/// that both halves see every kind of move.
const HALF_BLOCK_S: f64 = 0.2;

/// Why Z cannot be compared with a simulated Z.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum ZUncomparable {
    /// The record has no Z.
    NotRecorded,
    /// The machine carries Z without simulating it.
    Carried,
    /// The record holds X's and Y's commands but not Z's: Z's lag cannot be measured.
    NoCommand,
}

impl Context<'_> {
    /// Whether the record's Z can be compared with `machine`'s simulated Z: the record
    /// measured Z, the machine simulates it, and where the record holds X's and Y's
    /// commands it holds Z's too.
    pub(crate) fn z_comparable(&self, machine: &MachineConfig) -> Result<(), ZUncomparable> {
        let m = self.measured;
        if m.z_m.is_none() {
            Err(ZUncomparable::NotRecorded)
        } else if !machine.simulates_z() {
            Err(ZUncomparable::Carried)
        } else if m.commands.is_some() && m.z_cmd_m.is_none() {
            Err(ZUncomparable::NoCommand)
        } else {
            Ok(())
        }
    }

    /// The record's noise floor (m), as [`super::compare`] estimated it.
    pub(crate) fn noise_m(&self) -> f64 {
        self.noise_sigma
    }

    /// Program time of each compared sample (s).
    pub(crate) fn sample_times(&self, offset_s: f64) -> Vec<f64> {
        self.samples
            .iter()
            .map(|&i| self.prog_time(i, offset_s))
            .collect()
    }

    /// Which half each compared sample of `axis` belongs to; none where the axis is not
    /// compared (a hunting hold).
    pub(crate) fn axis_halves(&self, axis: AxisName, offset_s: f64) -> Vec<Option<bool>> {
        self.halves(offset_s)
            .into_iter()
            .enumerate()
            .map(|(k, h)| self.compared(axis, k).then_some(h))
            .collect()
    }

    /// Which half each compared sample belongs to: alternate blocks of time.
    pub(crate) fn halves(&self, offset_s: f64) -> Vec<bool> {
        self.sample_times(offset_s)
            .iter()
            .map(|t| (t / HALF_BLOCK_S).floor().rem_euclid(2.0) == 0.0)
            .collect()
    }

    /// Simulates one axis of a machine on the context's commands; `None` if it cannot run.
    /// The axis holds its configuration's force at rest at the record's start where the
    /// record starts at rest (docs/model.md §1.10); elsewhere the start's unknown state is
    /// left out of the comparison, and the force is not held.
    pub(crate) fn simulate_axis(
        &self,
        machine: &MachineConfig,
        axis: AxisName,
    ) -> Option<Vec<f64>> {
        match self.replanned(machine) {
            None => self.read_on(machine, axis, &self.commands, None),
            // The machine runs on its own plan's clock.
            Some(commands) => self.read_on(machine, axis, &commands, None),
        }
    }

    /// [`Context::simulate_axis`] with the axis holding `held_n` (N) at rest at the record's
    /// start.
    pub(crate) fn simulate_axis_holding(
        &self,
        machine: &MachineConfig,
        axis: AxisName,
        held_n: f64,
    ) -> Option<Vec<f64>> {
        let mut holding = machine.clone();
        holding.axis_mut(axis).held_at_start_n = held_n;
        self.simulate_axis(&holding, axis)
    }

    /// How many of the context's command cycles come before the record's first command: the
    /// run-in the comparison puts before a record begun in motion (or arriving from where
    /// the machine stood), on which the model is moved into the record's state; none where
    /// the commands begin with the record's.
    pub(crate) fn run_in_cycles(&self) -> usize {
        (self.start.run_in_s / self.dt).round() as usize
    }

    /// The context's commands up to the one the sample at program time `until_s` (s) is
    /// read from, for [`Context::simulate_axis_on`]; none where that is all of them. The
    /// simulator steps cycle by cycle on each cycle's command alone, so a trace on them is
    /// the whole run's bit for bit up to there: a caller that reads no sample after it
    /// needs nothing later.
    pub(crate) fn commands_until(&self, until_s: f64) -> Option<Commands> {
        // A sample between cycles i and i + 1 is interpolated from cycles i − 1 to i + 2
        // (`sample`); the run-in is moved on its own commands, which are kept whole.
        let run_in = self.run_in_cycles();
        let cycles = ((until_s / self.dt).floor().max(0.0) as usize + 3).max(run_in + 1);
        (cycles < self.commands.len()).then(|| self.commands.first(cycles))
    }

    /// [`Context::simulate_axis`] on `commands`, the first of the context's
    /// ([`Context::commands_until`]): the trace ends with them. A machine that runs on its
    /// own plan's clock is simulated whole.
    pub(crate) fn simulate_axis_on(
        &self,
        machine: &MachineConfig,
        axis: AxisName,
        commands: &Commands,
    ) -> Option<Vec<f64>> {
        match self.replanned(machine) {
            None => self.read_on(machine, axis, commands, None),
            Some(commands) => self.read_on(machine, axis, &commands, None),
        }
    }

    /// `axis` of `machine` on `commands` as the measurement sees it: with the axes'
    /// squareness, from `other` (the other axis on the same commands) or, when not given and
    /// needed, a simulation of it.
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
    pub(crate) fn simulate_pair<'b>(
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
    /// the context says, holding its configuration's force at its start where the record
    /// starts at rest.
    fn simulate_on(
        &self,
        machine: &MachineConfig,
        axis: AxisName,
        commands: &Commands,
    ) -> Option<Vec<f64>> {
        let mut model = AxisModel::from_config(machine.axis(axis));
        if self.start.kind != super::start::StartKind::AtRest {
            model.held_at_start_n = 0.0;
        }
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
        let own;
        let axis_commands = match self.start.arrival.filter(|_| axis != AxisName::Z) {
            Some(arrival) => {
                own = self.run_in_for(&model, axis, commands, arrival[axis.index()], &sim)?;
                &own
            }
            None => commands.axis(axis),
        };
        simulate(&model, axis_commands, self.dt, &sim)
            .ok()
            .map(|t| t.into_read_at(self.measured_at))
    }

    /// `axis`'s commands with their run-in moved so that `model` arrives where and how fast
    /// the record has the machine where its commands join the program (`arrival`): each
    /// model — the nominal one and each with a cause — enters the record in the state the
    /// record shows, not in the nominal model's. The run-in is run once on its own, and
    /// moved by what it leaves between the model and the record's place.
    fn run_in_for(
        &self,
        model: &AxisModel,
        axis: AxisName,
        commands: &Commands,
        arrival: super::start::Arrival,
        sim: &SimConfig,
    ) -> Option<crate::plan::AxisCommands> {
        let c = commands.axis(axis);
        let n = self.run_in_cycles().min(c.len());
        if n == 0 {
            return Some(c.clone());
        }
        let mut alone = crate::plan::AxisCommands {
            pos_m: c.pos_m[..n].to_vec(),
            vel_m_per_s: c.vel_m_per_s[..n].to_vec(),
            acc_m_per_s2: c.acc_m_per_s2[..n].to_vec(),
        };
        let (v, a) = (c.vel_m_per_s[n - 1], c.acc_m_per_s2[n - 1]);
        alone.push(
            c.pos_m[n - 1] + v * self.dt + 0.5 * a * self.dt * self.dt,
            v + a * self.dt,
            a,
        );
        let reached = simulate(model, &alone, self.dt, sim)
            .ok()?
            .into_read_at(self.measured_at);
        let shift = arrival.x_m - reached.get(n)?;
        let mut own = c.clone();
        own.pos_m[..n].iter_mut().for_each(|p| *p += shift);
        Some(own)
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
                kv_per_s: [0, 1, 2].map(|i| computed[i].unwrap_or(ip.kv_per_s[i])),
                ..ip
            }
        });
        if in_position == nominal {
            return None;
        }
        let plan = self.plan.with_waits(in_position, &self.extra_wait_s);
        Some(commands_of(&plan, self.settle_s))
    }

    pub(crate) fn measured_axis(&self, axis: AxisName) -> &[f64] {
        match axis {
            AxisName::X => &self.measured.x_m,
            AxisName::Y => &self.measured.y_m,
            // Z where the record has it (compared only where the machine simulates Z).
            AxisName::Z => self.measured.z_m.as_deref().unwrap_or(&[]),
        }
    }

    /// Time of measured sample `i` on the program's clock, for a clock offset.
    pub(crate) fn prog_time(&self, i: usize, offset_s: f64) -> f64 {
        self.measured.time_s(i) - offset_s
    }

    /// measured − simulated at the context's samples (what point-by-point fits minimise).
    ///
    /// At the samples left out for hunting ([`Context::hunting_holds`]) it is zero for every
    /// model: they weigh in no fit and no evidence.
    pub(crate) fn residual(&self, axis: AxisName, trace: &[f64], offset_s: f64) -> Vec<f64> {
        let m = self.measured_axis(axis);
        self.samples
            .iter()
            .enumerate()
            .map(|(k, &i)| {
                if self.compared(axis, k) {
                    m[i] - sample(trace, self.dt, self.prog_time(i, offset_s))
                } else {
                    0.0
                }
            })
            .collect()
    }

    /// The context on the compared samples at `positions` (indices into its samples, not
    /// record indices): the samples, and with them each axis's masks of samples left out.
    /// The masks are indexed by position among the samples, so a part that took them over
    /// as they were would read them at the wrong samples: a hold late in the record would
    /// never reach a half, and an early one would cover other time. Positions beyond the
    /// samples are skipped.
    pub(crate) fn keeping(&self, positions: &[usize]) -> Self {
        let kept: Vec<usize> = positions
            .iter()
            .copied()
            .filter(|&k| k < self.samples.len())
            .collect();
        let part = |mask: &Vec<bool>| -> Vec<bool> {
            // An empty mask leaves nothing out, in the part as in the whole.
            if mask.is_empty() {
                Vec::new()
            } else {
                kept.iter()
                    .map(|&k| mask.get(k).copied().unwrap_or(false))
                    .collect()
            }
        };
        Context {
            samples: kept.iter().map(|&k| self.samples[k]).collect(),
            holding: self.holding.each_ref().map(part),
            unsettled: self.unsettled.each_ref().map(part),
            ..self.clone()
        }
    }

    /// How many samples of `axis` its point-by-point residual holds.
    pub(crate) fn compared_count(&self, axis: AxisName) -> usize {
        (0..self.samples.len())
            .filter(|&k| self.compared(axis, k))
            .count()
    }

    /// Whether compared sample `k` of `axis` is in its point-by-point residual.
    pub(crate) fn compared(&self, axis: AxisName, k: usize) -> bool {
        let left_out = |mask: &[Vec<bool>; 3]| mask[axis.index()].get(k).copied().unwrap_or(false);
        let own = !left_out(&self.holding) && !left_out(&self.unsettled);
        // Z's start is X's and Y's (it has no arrival of its own worked out): it is compared
        // only where both of them are, and away from its own hunting holds.
        own && (axis != AxisName::Z || AxisName::BOTH.iter().all(|&a| self.compared(a, k)))
    }

    /// How far `axis`'s commands travel between its compared samples (m).
    pub(crate) fn command_travel_m(&self, axis: AxisName, offset_s: f64) -> f64 {
        let (lo, hi) = self
            .sample_times(offset_s)
            .iter()
            .enumerate()
            .filter(|&(k, _)| self.compared(axis, k))
            .map(|(_, &t)| self.command_at(axis, t).0)
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| {
                (l.min(v), h.max(v))
            });
        (hi - lo).max(0.0)
    }

    /// How long `axis` is left out because it holds still while the model hunts (s).
    pub(crate) fn hunting_left_out_s(&self, axis: AxisName) -> f64 {
        self.holding[axis.index()].iter().filter(|&&h| h).count() as f64 * self.sample_dt_s
    }

    /// The compared samples at which `axis` has not settled from the record's start: before
    /// its settling time after the run-in, and, unless the record starts at rest at the
    /// program's start, from an axis standing there until [`START_AFTER_HUNTING_S`] after
    /// it first moves — how long it stood, and what its integral action holds against
    /// friction, the record does not show.
    pub(crate) fn unsettled_at_start(&self, axis: AxisName, offset_s: f64) -> Vec<bool> {
        let start = &self.start;
        // Settling is measured on X and Y; an axis beyond them waits for the slower.
        let settling_s = start.settling_s.get(axis.index()).copied();
        let settled_s =
            start.run_in_s + settling_s.unwrap_or(start.settling_s[0].max(start.settling_s[1]));
        let times = self.sample_times(offset_s);
        let whole = match start.kind {
            super::start::StartKind::Planned => true,
            super::start::StartKind::AtRest => start.at_program_start,
            _ => false,
        };
        let first_move = if whole {
            None
        } else {
            let c = &self.commands;
            let begin = self.run_in_cycles().min(c.len());
            let moves = |k: usize| c.axis(axis).vel_m_per_s[k].abs() >= STILL_M_PER_S;
            (!moves(begin.min(c.len().saturating_sub(1)))).then(|| {
                (begin..c.len())
                    .find(|&k| moves(k))
                    .map_or(f64::INFINITY, |k| k as f64 * self.dt)
            })
        };
        times
            .iter()
            .map(|&t| t < settled_s || first_move.is_some_and(|m| t < m + START_AFTER_HUNTING_S))
            .collect()
    }

    /// The samples of `axis` at which it holds still and the model `trace` hunts: from where
    /// the model has settled within [`SETTLED_M`] of the command ([`settled_at`]) until
    /// [`START_AFTER_HUNTING_S`] after the command moves again, in every hold where the model
    /// moves by more than [`HUNTING_M`] after settling.
    ///
    /// An axis held by a proportional-plus-integral loop against static friction above its
    /// Coulomb friction does not rest: its integrator winds until the table breaks away, slips
    /// past, sticks, and winds back — a limit cycle of a fraction of a micrometre whose phase
    /// depends on every detail of the stop. Two models of the same machine, or a model and the
    /// machine, hunt out of phase, and compared point by point that mismatch reads as a
    /// systematic residual that friction causes bend to fit (independent records of squares,
    /// where each axis holds while the other moves, named Stribeck and Coulomb friction that
    /// way). So those samples are left out of the axis's residual; the settling before them,
    /// and the other axis, are compared as ever.
    pub(crate) fn hunting_holds(&self, axis: AxisName, trace: &[f64], offset_s: f64) -> Vec<bool> {
        let times = self.sample_times(offset_s);
        let n = times.len();
        let mut mask = vec![false; n];
        let still = |t: f64| self.command_at(axis, t).1.abs() < STILL_M_PER_S;
        let mut k = 0;
        while k < n {
            if !still(times[k]) {
                k += 1;
                continue;
            }
            let start = k;
            while k < n && still(times[k]) {
                k += 1;
            }
            let model: Vec<f64> = (start..k)
                .map(|j| sample(trace, self.dt, times[j]))
                .collect();
            let command: Vec<f64> = (start..k)
                .map(|j| self.command_at(axis, times[j]).0)
                .collect();
            let quiet = (QUIET_S / self.sample_dt_s).ceil().max(3.0) as usize;
            let settled = settled_at(&model, &command, quiet);
            if settled + 2 > model.len() {
                continue;
            }
            let (lo, hi) = model[settled..]
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
                    (l.min(v), h.max(v))
                });
            let measured = self.measured_axis(axis);
            let record: Vec<f64> = (start + settled..k)
                .filter_map(|j| measured.get(self.samples[j]).copied())
                .collect();
            if hi - lo > HUNTING_M || self.record_hunts(&record, quiet) {
                // And the start that follows: when the table breaks away depends on where
                // in its cycle the hunting left it, a difference the loop takes a few of its
                // time constants to forget.
                let t_start = times.get(k).copied().unwrap_or(f64::INFINITY);
                let end = (k..n)
                    .find(|&j| times[j] - t_start > START_AFTER_HUNTING_S)
                    .unwrap_or(n);
                mask[start + settled..end]
                    .iter_mut()
                    .for_each(|m| *m = true);
            }
        }
        mask
    }

    /// Whether the record of an axis holding still (`record`, from where its model came to
    /// rest) moves by more than [`SETTLED_M`] between its averages over `quiet` samples, and
    /// beyond what its noise moves them: the machine hunts there even where its model, come to
    /// rest a little differently, holds (a table stuck within its loop's elastic give stays,
    /// one stuck a little further out breaks away), and the two cannot be compared point by
    /// point either.
    fn record_hunts(&self, record: &[f64], quiet: usize) -> bool {
        let means: Vec<f64> = record
            .chunks_exact(quiet)
            .map(|c| c.iter().sum::<f64>() / quiet as f64)
            .collect();
        let (lo, hi) = means
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
                (l.min(v), h.max(v))
            });
        let noise_of_mean = self.noise_sigma / (quiet as f64).sqrt();
        means.len() >= 2 && hi - lo > SETTLED_M.max(6.0 * noise_of_mean)
    }

    /// The measured axis at the context's samples.
    pub(crate) fn measured_at_samples(&self, axis: AxisName) -> Vec<f64> {
        let m = self.measured_axis(axis);
        self.samples.iter().map(|&i| m[i]).collect()
    }

    /// A trace at the context's samples.
    pub(crate) fn at_samples(&self, trace: &[f64], offset_s: f64) -> Vec<f64> {
        self.samples
            .iter()
            .map(|&i| sample(trace, self.dt, self.prog_time(i, offset_s)))
            .collect()
    }

    /// d(simulated)/dt at the samples: how the residual changes with the offset.
    pub(crate) fn residual_rate(&self, trace: &[f64], offset_s: f64) -> Vec<f64> {
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
    pub(crate) fn statistical_residual(
        &self,
        axis: AxisName,
        trace: &[f64],
        offset_s: f64,
    ) -> Vec<f64> {
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
    pub(crate) fn chatter_excess(&self, axis: AxisName, trace: &[f64], offset_s: f64) -> f64 {
        let w = self.window_statistics(axis, trace, offset_s);
        let m = w.len() as f64;
        (w.iter().map(|(_, p)| p * p).sum::<f64>() - m) / (2.0 * m).sqrt()
    }

    /// How far the measurement's own chatter exceeds its noise, in standard deviations of
    /// that χ² (the model's chatter taken as none): an axis that chatters stays in the
    /// statistical domain whatever the model does.
    pub(crate) fn measured_chatter_excess(&self, axis: AxisName, offset_s: f64) -> f64 {
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
    pub(crate) fn command_at(&self, axis: AxisName, t: f64) -> (f64, f64) {
        let c = self.commands.axis(axis);
        (
            sample(&c.pos_m, self.dt, t),
            sample(&c.vel_m_per_s, self.dt, t),
        )
    }
}

/// Where in a hold the model has settled (index into `model`, one sample per entry, with its
/// `command`): just after the last sample outside [`SETTLED_M`] of the command, or, where
/// earlier, the first sample from which the model stands still for `quiet` samples. An
/// approach ends where the table first comes to rest; what moves it after that is its
/// integrator winding against static friction. A loop that hunts by more than the band (a
/// stiff integrator breaks the table away and slips it micrometres past its target) would
/// otherwise count every excursion of its hunting as part of the approach.
fn settled_at(model: &[f64], command: &[f64], quiet: usize) -> usize {
    let band = (0..model.len())
        .rposition(|i| (model[i] - command[i]).abs() >= SETTLED_M)
        .map_or(0, |i| i + 1);
    let at_rest = |i: usize| {
        let (lo, hi) = model[i..i + quiet]
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
                (l.min(v), h.max(v))
            });
        hi - lo <= HUNTING_M
    };
    let rest = (0..(model.len() + 1).saturating_sub(quiet).min(band)).find(|&i| at_rest(i));
    rest.unwrap_or(band)
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

/// A plan's commands with the settling tail.
pub(super) fn commands_of(plan: &Plan, settle_s: f64) -> Commands {
    let mut commands = crate::plan::sample(plan);
    commands.hold(settle_s);
    commands
}

impl Context<'_> {
    /// Per-axis masks at the residual samples: near a reversal, and near any event
    /// (reversal or acceleration).
    pub(crate) fn event_masks(
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

impl Context<'_> {
    /// Which stretch of the program the compared samples cover, and how the record's start
    /// was set, at clock offset `offset_s`.
    pub(crate) fn coverage(&self, offset_s: f64) -> super::start::Coverage {
        let segs = &self.plan.segments;
        let line_at = |t: f64| {
            let c = &self.commands;
            let k = (t / c.dt_s).round().clamp(0.0, (c.len().max(1) - 1) as f64) as usize;
            c.segment.get(k).map_or(0, |&s| s as usize)
        };
        let times = self.sample_times(offset_s);
        let (first_t, last_t) = (
            times.first().copied().unwrap_or(0.0),
            times.last().copied().unwrap_or(0.0),
        );
        let (first_seg, last_seg) = (line_at(first_t), line_at(last_t));
        let feeds: Vec<usize> = (0..segs.len())
            .filter(|&j| segs[j].motion == Motion::Feed)
            .collect();
        let line = |j: usize| segs.get(j).map_or(0, |s| s.line);
        let start = &self.start;
        // Where the program's first feed move begins by the plan: a record compared from
        // there (after the rapids that open a program) covers it from its start.
        let first_feed_t = feeds.first().map_or(0.0, |&f| {
            let c = &self.commands;
            c.segment
                .iter()
                .position(|&s| s as usize >= f)
                .map_or(0.0, |k| k as f64 * c.dt_s)
        });
        let from_program_start = match start.kind {
            super::start::StartKind::Planned => first_t <= first_feed_t + 0.5,
            _ => start.at_program_start,
        };
        super::start::Coverage {
            start: start.kind,
            first_line: line(first_seg),
            last_line: line(last_seg),
            program_first_line: line(0),
            program_last_line: line(segs.len().saturating_sub(1)),
            compared_from_s: first_t + offset_s,
            compared_to_s: last_t + offset_s,
            stood_at_mm: (start.kind == super::start::StartKind::BeforeProgram)
                .then(|| start.first_command_m.map(|v| v * 1e3)),
            approach_s: start.join_s,
            approach_simulated: start.approach_simulated,
            run_in_s: if start.kind == super::start::StartKind::InMotion {
                start.run_in_s
            } else {
                0.0
            },
            settling_s: AxisName::BOTH.map(|a| {
                let dropped = start.compared_from_s() - start.run_in_s;
                let left_out = self.unsettled[a.index()].iter().filter(|&&u| u).count();
                dropped + left_out as f64 * self.sample_dt_s
            }),
            from_program_start,
            to_program_end: feeds.last().is_none_or(|&f| last_seg >= f),
            into_program_s: match start.kind {
                super::start::StartKind::Planned => first_t,
                _ => (start.run_in_s - self.program_start_s).max(0.0),
            },
            z_span_mm: match (self.samples.first(), self.samples.last()) {
                (Some(&from), Some(&to)) => self
                    .measured
                    .z_span_m(from, to)
                    .map(|(lo, hi)| [lo * 1e3, hi * 1e3]),
                _ => None,
            },
            // The command that compares Z says whether it did (see the field).
            z_compared: false,
        }
    }
}
