//! The hybrid simulation of one axis: exact linear steps between mode switches, switches
//! located inside the step by bisection on the dyadic maps (to h/2^24, a few tens of ps).
//!
//! Each mode has guards — linear functionals of the augmented state that stay non-negative
//! while the mode holds (table speed sign, |net force| below static friction, nut inside or
//! outside the gap, controller outputs within or at their limits). A step whose end violates
//! a guard is bisected to the first violation, the mode is switched there (with the state
//! projected where the switch demands it: V2 = 0 on sticking, the integrator on its limit
//! when it starts to follow it), and the rest of the step is taken in the new mode.

use super::discrete::{LEVELS, MapCache};
use super::model::{
    Aug, AxisModel, ClampMode, ContactMode, FSX, FX, FrictionMode, Mode, N, NA, ONE, Row, Signals,
    V2, X2,
};
use super::{FrictionEvent, SimError};

/// Guard tolerances: a guard counts as violated only below −tolerance, so that a state just
/// placed on a switching surface does not trigger again.
const TOL_SPEED: f64 = 1e-12; // m/s
const TOL_FORCE: f64 = 1e-9; // N
const TOL_GAP: f64 = 1e-13; // m
const TOL_CURRENT: f64 = 1e-9; // A
const TOL_VOLTAGE: f64 = 1e-9; // V
const TOL_RATE: f64 = 1e-9; // A/s or V/s
/// More switches than this inside one step means the model chatters; it is reported.
const MAX_EVENTS_PER_STEP: usize = 2000;

/// A guard: valid while row·x ≥ −tol.
struct Guard {
    row: Row,
    tol: f64,
}

/// Rows of a kernel: the 13 states, then up to 8 guards (friction 2, contact 2, current 2,
/// voltage 2), then the table's acceleration while sliding. 24 keeps the columns a multiple
/// of four for vector units.
const ROWS: usize = 24;

/// A sliding table's speed may dip through zero and come back within one step: both ends
/// satisfy the guard, yet the table should have stuck in between (docs/model.md §1.6 puts the
/// switch at the zero crossing). The table's acceleration is a linear functional of the
/// state too, so a kernel of a sliding mode also yields it at the chunk's end; when it turns
/// from against the motion to with it inside the chunk, the speed has a minimum there,
/// located on the cubic through both ends' speeds and accelerations.
struct DipWatch {
    /// dV2/dt as a row on [x; u] (m/s² per unit of each entry).
    accel_row: Row,
    /// +1 sliding forwards, −1 backwards: the speed in the direction of motion is sign·V2.
    sign: f64,
    /// The chunk's duration (s).
    dt: f64,
}

/// One step of one mode at one level, fused with the mode's guards: a single column-major
/// product gives the next state and every guard's value at it.
struct Kernel {
    cols: [[f64; ROWS]; NA],
    guards: usize,
    tol: [f64; ROWS - N],
    dip: Option<DipWatch>,
}

/// g·[x'; u] with x' = M·[x; u], as a column entry per input j: the state part composed
/// with the map, plus the row's own input part.
fn compose(row: &Row, map: &super::discrete::StepMap, j: usize) -> f64 {
    let mut v = if j >= N { row[j] } else { 0.0 };
    for i in 0..N {
        v += row[i] * map[(i, j)];
    }
    v
}

impl Kernel {
    fn new(map: &super::discrete::StepMap, guards: &[Guard], dip: Option<DipWatch>) -> Kernel {
        let mut cols = [[0.0; ROWS]; NA];
        for (j, col) in cols.iter_mut().enumerate() {
            for i in 0..N {
                col[i] = map[(i, j)];
            }
        }
        let mut tol = [0.0; ROWS - N];
        for (k, g) in guards.iter().enumerate() {
            for (j, col) in cols.iter_mut().enumerate() {
                col[N + k] = compose(&g.row, map, j);
            }
            tol[k] = g.tol;
        }
        if let Some(d) = &dip {
            for (j, col) in cols.iter_mut().enumerate() {
                col[N + guards.len()] = compose(&d.accel_row, map, j);
            }
        }
        Kernel {
            cols,
            guards: guards.len(),
            tol,
            dip,
        }
    }

    /// Whether a sliding table's speed passes through zero strictly inside the chunk from
    /// `x` to `y` (the end itself is the guards' business).
    #[inline(always)]
    fn dips_through_zero(&self, x: &Aug, y: &[f64; ROWS]) -> bool {
        let Some(d) = &self.dip else {
            return false;
        };
        let a1 = d.sign * y[N + self.guards];
        if a1 <= 0.0 {
            return false; // still slowing at the end: any crossing is at the end
        }
        let a0 = d.sign * (d.accel_row * x)[0];
        if a0 >= 0.0 {
            return false; // speeding up from the start: no interior minimum
        }
        dips_below_tolerance(d.sign * x[V2], d.sign * y[V2], a0 * d.dt, a1 * d.dt)
    }

    /// Next state and guard values. Always inlined: compiled inside [`AxisSim::step_avx`]
    /// it takes that function's AVX instructions, twice as many of its rows per instruction
    /// as the portable copy. The same bits either way: each row is still one multiply and
    /// one add per column, in the columns' order (AVX brings no fused multiply-add, and no
    /// sum is reordered) — only rows side by side share an instruction.
    #[inline(always)]
    fn apply(&self, x: &Aug) -> [f64; ROWS] {
        let mut y = [0.0; ROWS];
        for (col, &xj) in self.cols.iter().zip(x.iter()) {
            // Inputs and controller states a model does not use stay zero: a quarter of
            // the columns on many axes, whose products would add nothing.
            if xj == 0.0 {
                continue;
            }
            for (yi, ci) in y.iter_mut().zip(col) {
                *yi += ci * xj;
            }
        }
        y
    }

    #[inline(always)]
    fn guards_hold(&self, y: &[f64; ROWS]) -> bool {
        (0..self.guards).all(|k| y[N + k] >= -self.tol[k])
    }
}

/// The simulator of one axis.
pub struct AxisSim<'a> {
    model: &'a AxisModel,
    signals: Signals,
    cache: MapCache,
    kernels: Vec<Option<Box<Kernel>>>,
    events_in_step: usize,
    /// Whether the steps run in the copy compiled for AVX (asked once, here, so that the
    /// step's loop is compiled for one instruction set whole, its product inlined).
    avx: bool,
}

impl<'a> AxisSim<'a> {
    /// A simulator with steps of `h` seconds.
    pub(crate) fn new(model: &'a AxisModel, h: f64) -> Self {
        AxisSim {
            model,
            signals: model.signals(),
            cache: MapCache::new(h),
            kernels: (0..Mode::COUNT * (LEVELS + 1)).map(|_| None).collect(),
            events_in_step: 0,
            avx: avx_available(),
        }
    }

    /// Runs the steps in the copy compiled for AVX (where the processor has it) or not.
    pub(crate) fn use_avx(&mut self, avx: bool) {
        self.avx = avx && avx_available();
    }

    fn build_guards(&mut self, mode: Mode) -> Vec<Guard> {
        let m = self.model;
        let s = &self.signals;
        let a = *self.cache.dynamics(m, mode);
        let mut g = Vec::new();
        let one = unit(ONE);
        match mode.friction {
            // Presliding friction never sticks: no speed or breakaway guard.
            _ if m.presliding.is_some() => {}
            FrictionMode::SlipPos => g.push(Guard {
                row: unit(V2),
                tol: TOL_SPEED,
            }),
            FrictionMode::SlipNeg => g.push(Guard {
                row: -unit(V2),
                tol: TOL_SPEED,
            }),
            FrictionMode::Stick => {
                let f_e = m.breakaway_force(s, mode.contact);
                let f_s = one * m.f_s + unit(FSX);
                g.push(Guard {
                    row: f_s - f_e,
                    tol: TOL_FORCE,
                });
                g.push(Guard {
                    row: f_s + f_e,
                    tol: TOL_FORCE,
                });
            }
        }
        if m.has_backlash() {
            let e = m.half_gap;
            match mode.contact {
                ContactMode::Pos => g.push(Guard {
                    row: s.delta - one * e,
                    tol: TOL_GAP,
                }),
                ContactMode::Neg => g.push(Guard {
                    row: -s.delta - one * e,
                    tol: TOL_GAP,
                }),
                ContactMode::Free => {
                    g.push(Guard {
                        row: one * e - s.delta,
                        tol: TOL_GAP,
                    });
                    g.push(Guard {
                        row: s.delta + one * e,
                        tol: TOL_GAP,
                    });
                }
            }
        }
        if let Some(current) = ClampSignals::of(Limit::Current, m, s, &a) {
            clamp_guards(&mut g, mode.current, &current, TOL_CURRENT);
        }
        if let Some(voltage) = ClampSignals::of(Limit::Voltage, m, s, &a) {
            clamp_guards(&mut g, mode.voltage, &voltage, TOL_VOLTAGE);
        }
        g
    }

    #[inline(always)]
    fn kernel(&mut self, mode: Mode, level: usize) -> &Kernel {
        let slot = mode.index() * (LEVELS + 1) + level;
        if self.kernels[slot].is_none() {
            self.build_kernel(mode, level, slot);
        }
        self.kernels[slot].as_ref().expect("just built")
    }

    /// The kernel of a mode and level the simulator meets for the first time.
    #[cold]
    fn build_kernel(&mut self, mode: Mode, level: usize, slot: usize) {
        let guards = self.build_guards(mode);
        let map = *self.cache.map(self.model, mode, level);
        let sign = match mode.friction {
            _ if self.model.presliding.is_some() => None,
            FrictionMode::SlipPos => Some(1.0),
            FrictionMode::SlipNeg => Some(-1.0),
            FrictionMode::Stick => None,
        };
        // At the finest level the end guard alone resolves the crossing.
        let dip = sign.filter(|_| level < LEVELS).map(|sign| DipWatch {
            accel_row: self.cache.dynamics(self.model, mode).row(V2).into_owned(),
            sign,
            dt: self.cache.step_s() / (1u64 << level) as f64,
        });
        self.kernels[slot] = Some(Box::new(Kernel::new(&map, &guards, dip)));
    }

    /// One step of h/2^level in place when the mode's guards hold at its end (returns true);
    /// otherwise `x` is left as it was (returns false).
    #[inline(always)]
    fn try_step(&mut self, mode: Mode, level: usize, x: &mut Aug) -> bool {
        let kernel = self.kernel(mode, level);
        let y = kernel.apply(x);
        let ok = kernel.guards_hold(&y) && !kernel.dips_through_zero(x, &y);
        if ok {
            x.as_mut_slice()[..N].copy_from_slice(&y[..N]);
        }
        ok
    }

    /// One step of h/2^level in place, whatever the guards say.
    #[inline(always)]
    fn force_step(&mut self, mode: Mode, level: usize, x: &mut Aug) {
        let y = self.kernel(mode, level).apply(x);
        x.as_mut_slice()[..N].copy_from_slice(&y[..N]);
    }

    /// Advances `x` by one full step h in `mode`, switching modes where guards demand.
    pub(crate) fn step(
        &mut self,
        x: &mut Aug,
        mode: &mut Mode,
        t: f64,
        events: Option<&mut Vec<FrictionEvent>>,
    ) -> Result<(), SimError> {
        #[cfg(target_arch = "x86_64")]
        if self.avx {
            // SAFETY: the processor was found to have AVX when the simulator was made.
            return unsafe { self.step_avx(x, mode, t, events) };
        }
        self.step_in_order(x, mode, t, events)
    }

    /// [`AxisSim::step`] compiled for AVX's four-wide registers, its products inlined.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    fn step_avx(
        &mut self,
        x: &mut Aug,
        mode: &mut Mode,
        t: f64,
        events: Option<&mut Vec<FrictionEvent>>,
    ) -> Result<(), SimError> {
        self.step_in_order(x, mode, t, events)
    }

    /// The step itself, inlined into each instruction set's copy (mode switches and kernels
    /// built for the first time are rare: whether the compiler inlines them matters little).
    #[inline(always)]
    fn step_in_order(
        &mut self,
        x: &mut Aug,
        mode: &mut Mode,
        t: f64,
        events: Option<&mut Vec<FrictionEvent>>,
    ) -> Result<(), SimError> {
        let full: u64 = 1 << LEVELS;
        let mut done: u64 = 0;
        self.events_in_step = 0;
        let mut events = events;
        while done < full {
            let remaining = full - done;
            // The largest dyadic chunk that fits what is left (and aligns with it).
            // Maps are time-invariant, so any chunk may start anywhere.
            let level = LEVELS - (63 - remaining.leading_zeros() as usize).min(LEVELS);
            let chunk: u64 = 1 << (LEVELS - level);
            if self.try_step(*mode, level, x) {
                done += chunk;
                continue;
            }
            // Bisect the chunk to the last state where the guards hold.
            let mut consumed: u64 = 0;
            for lvl in level + 1..=LEVELS {
                if self.try_step(*mode, lvl, x) {
                    consumed += 1 << (LEVELS - lvl);
                }
            }
            // One finest tick further the guard is violated: switch there.
            self.force_step(*mode, LEVELS, x);
            consumed += 1;
            done += consumed;
            let before = *mode;
            self.switch_mode(x, mode);
            if let Some(ev) = events.as_deref_mut()
                && before.friction != mode.friction
            {
                let t_event = t + self.cache.step_s() * done as f64 / full as f64;
                ev.push(FrictionEvent {
                    t_s: t_event,
                    x_m: x[X2],
                    to: mode.friction,
                });
            }
            self.events_in_step += 1;
            if self.events_in_step > MAX_EVENTS_PER_STEP {
                return Err(SimError::Chattering {
                    t_s: t,
                    modes: format!("{before} ⇄ {mode}"),
                });
            }
        }
        Ok(())
    }

    /// Chooses the mode consistent with the state at a switching instant, projecting the
    /// state where a switch demands it. Guards find events with a tolerance; the decisions
    /// here compare strictly, so that a guard violated by just its tolerance (evaluated
    /// through the fused kernel, with its own rounding) still switches the mode instead of
    /// finding the same event again.
    fn switch_mode(&mut self, x: &mut Aug, mode: &mut Mode) {
        for _ in 0..8 {
            let mut changed = false;
            changed |= self.switch_contact(x, mode);
            changed |= self.switch_friction(x, mode);
            changed |= self.switch_clamp(x, mode, Limit::Current);
            changed |= self.switch_clamp(x, mode, Limit::Voltage);
            if !changed {
                return;
            }
        }
    }

    fn switch_contact(&mut self, x: &Aug, mode: &mut Mode) -> bool {
        let m = self.model;
        if !m.has_backlash() {
            return false;
        }
        let d = (self.signals.delta * x)[0];
        let e = m.half_gap;
        let want = if d > e && mode.contact != ContactMode::Pos {
            ContactMode::Pos
        } else if d < -e && mode.contact != ContactMode::Neg {
            ContactMode::Neg
        } else if (mode.contact == ContactMode::Pos && d < e)
            || (mode.contact == ContactMode::Neg && d > -e)
        {
            ContactMode::Free
        } else {
            mode.contact
        };
        let changed = want != mode.contact;
        mode.contact = want;
        changed
    }

    fn switch_friction(&mut self, x: &mut Aug, mode: &mut Mode) -> bool {
        let m = self.model;
        if m.presliding.is_some() {
            return false;
        }
        let v = x[V2];
        let f_e = (m.breakaway_force(&self.signals, mode.contact) * *x)[0]
            + Self::maps_sliding_held_n(m, x, mode.friction);
        let f_s = m.f_s + x[FSX];
        let want = match mode.friction {
            FrictionMode::SlipPos if v < 0.0 => Self::at_zero_speed(f_e, f_s),
            FrictionMode::SlipNeg if v > 0.0 => Self::at_zero_speed(f_e, f_s),
            FrictionMode::Stick if f_e.abs() > f_s - breakaway_margin_n(m) => {
                if f_e > 0.0 {
                    FrictionMode::SlipPos
                } else {
                    FrictionMode::SlipNeg
                }
            }
            current => current,
        };
        if want == mode.friction {
            return false;
        }
        if want == FrictionMode::Stick || mode.friction == FrictionMode::Stick {
            // Sticking: the table is still. Breaking away: it starts from rest.
            x[V2] = 0.0;
        }
        mode.friction = want;
        // A friction map's force held over the sub-step turns with the mode, from the
        // switch on. (The Stribeck excess alone keeps the sign it was held with until the
        // next sub-step, as the stick-slip figures were validated with.)
        if m.has_friction_maps() {
            friction_inputs(m, x, *mode);
        }
        true
    }

    /// The friction maps' sliding part that a sliding table's held input `FX` carries with
    /// the sign of its motion (N, as it enters the breakaway force's `−FX`); zero at rest.
    /// It is friction, not a force on the table: at a speed zero crossing the table meets
    /// the static level (`f_s` with the map's static part) instead, so the force that would
    /// move it leaves it out — as a lower `f_c` leaves nothing in `FX`. Kept in, a map taking
    /// away more than `f_s − f_c` made the table too "pushed" to stick yet too weakly driven
    /// to go on: it stayed sliding forward at a speed below zero, each tick the same event.
    /// Taken where the table is now rather than where the input was held: the same for a
    /// map that is flat over the sub-step, and within its change over one otherwise. (The
    /// Stribeck excess stays in, as the stick-slip figures were validated with.)
    fn maps_sliding_held_n(m: &AxisModel, x: &Aug, friction: FrictionMode) -> f64 {
        let sign = match friction {
            FrictionMode::SlipPos => 1.0,
            FrictionMode::SlipNeg => -1.0,
            FrictionMode::Stick => return 0.0,
        };
        if !m.has_friction_maps() {
            return 0.0;
        }
        sign * m.friction_added_n(x[X2], x[V2]).0
    }

    /// At a speed zero crossing: stick if static friction `f_s` can hold the net force `f_e`.
    fn at_zero_speed(f_e: f64, f_s: f64) -> FrictionMode {
        if f_e.abs() < f_s {
            FrictionMode::Stick
        } else if f_e > 0.0 {
            FrictionMode::SlipPos
        } else {
            FrictionMode::SlipNeg
        }
    }

    fn switch_clamp(&mut self, x: &mut Aug, mode: &mut Mode, which: Limit) -> bool {
        let a = *self.cache.dynamics(self.model, *mode);
        let Some(c) = ClampSignals::of(which, self.model, &self.signals, &a) else {
            return false;
        };
        let current = match which {
            Limit::Current => mode.current,
            Limit::Voltage => mode.voltage,
        };
        let y = (c.output * *x)[0];
        let held_rate = (c.held_rate * *x)[0];
        let natural_rate = (c.natural_rate * *x)[0];
        let l = c.limit;
        use ClampMode::*;
        let want = match (current, c.integrator) {
            // Without an integrator to hold, the output is clamped while beyond its limit.
            (_, None) if y > l => HeldHi,
            (_, None) if y < -l => HeldLo,
            (_, None) => Linear,
            (current, Some(_)) => match current {
                Linear if y > l => {
                    if held_rate > 0.0 {
                        HeldHi
                    } else {
                        SlideHi
                    }
                }
                Linear if y < -l => {
                    if held_rate < 0.0 {
                        HeldLo
                    } else {
                        SlideLo
                    }
                }
                HeldHi if y < l => {
                    if natural_rate > 0.0 {
                        SlideHi
                    } else {
                        Linear
                    }
                }
                HeldLo if y > -l => {
                    if natural_rate < 0.0 {
                        SlideLo
                    } else {
                        Linear
                    }
                }
                SlideHi if natural_rate < 0.0 => Linear,
                SlideHi if held_rate > 0.0 => HeldHi,
                SlideLo if natural_rate > 0.0 => Linear,
                SlideLo if held_rate < 0.0 => HeldLo,
                m => m,
            },
        };
        if want == current {
            return false;
        }
        // A sliding integrator sits exactly where the output equals the limit.
        if let (Some(side), Some((z_idx, z_gain))) = (
            match want {
                SlideHi => Some(1.0),
                SlideLo => Some(-1.0),
                _ => None,
            },
            c.integrator,
        ) {
            let without_z = y - z_gain * x[z_idx];
            x[z_idx] = (side * l - without_z) / z_gain;
        }
        match which {
            Limit::Current => mode.current = want,
            Limit::Voltage => mode.voltage = want,
        }
        true
    }
}

/// Whether this processor runs the step loop's AVX copy (asked once per simulator).
fn avx_available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// How close to static friction a stuck table's load may be and still count as breaking
/// away (N). The nut force is a stiffness times a difference of absolute positions (screw
/// travel, table), so its rounding grows with k_m·|x|: at 0.2 m on a 10⁹ N/m nut the fused
/// stick guard and a direct evaluation differ by ~10⁻⁸ N. Were the decision stricter than
/// that, a guard violated by rounding alone would switch nothing and be found again one
/// tick later, without end. The margin covers positions up to metres and is still 10⁻⁷ of
/// any real static friction.
fn breakaway_margin_n(m: &AxisModel) -> f64 {
    const POSITION_SCALE_M: f64 = 1.0;
    TOL_FORCE + 1e3 * f64::EPSILON * m.k_m * POSITION_SCALE_M
}

#[derive(Clone, Copy)]
enum Limit {
    Current,
    Voltage,
}

/// A limited output y (+ feed-forward) and its rates, for the guards and the switching
/// decisions.
struct ClampSignals {
    output: Row,
    /// dy/dt with the integrator held.
    held_rate: Row,
    /// dy/dt with the integrator running (the same without an integrator).
    natural_rate: Row,
    limit: f64,
    /// The integrator's index and ∂y/∂z; none: the output saturates with its states running.
    integrator: Option<(usize, f64)>,
}

impl ClampSignals {
    fn new(limited: super::model::Limited, a: &super::model::AugMatrix) -> Self {
        let rate = limited.output * a;
        let (held_rate, natural_rate, integrator) = match limited.integrator {
            Some(z) => {
                // `a` holds the mode's own integrator row: take it out for the held rate.
                let held = rate - a.row(z.slot) * z.gain;
                (held, held + z.integrand * z.gain, Some((z.slot, z.gain)))
            }
            None => (rate, rate, None),
        };
        ClampSignals {
            output: limited.output,
            held_rate,
            natural_rate,
            limit: limited.limit,
            integrator,
        }
    }

    fn of(which: Limit, m: &AxisModel, s: &Signals, a: &super::model::AugMatrix) -> Option<Self> {
        let limited = match which {
            Limit::Current => Some(m.current_command(s)),
            Limit::Voltage => m.voltage_command(s),
        };
        limited
            .filter(|l| l.limit.is_finite())
            .map(|l| ClampSignals::new(l, a))
    }
}

fn clamp_guards(g: &mut Vec<Guard>, mode: ClampMode, c: &ClampSignals, tol: f64) {
    let one = unit(ONE) * c.limit;
    match mode {
        ClampMode::Linear => {
            g.push(Guard {
                row: one - c.output,
                tol,
            });
            g.push(Guard {
                row: c.output + one,
                tol,
            });
        }
        ClampMode::HeldHi => g.push(Guard {
            row: c.output - one,
            tol,
        }),
        ClampMode::HeldLo => g.push(Guard {
            row: -c.output - one,
            tol,
        }),
        ClampMode::SlideHi => {
            g.push(Guard {
                row: c.natural_rate,
                tol: TOL_RATE,
            });
            g.push(Guard {
                row: -c.held_rate,
                tol: TOL_RATE,
            });
        }
        ClampMode::SlideLo => {
            g.push(Guard {
                row: -c.natural_rate,
                tol: TOL_RATE,
            });
            g.push(Guard {
                row: c.held_rate,
                tol: TOL_RATE,
            });
        }
    }
}

/// Whether the cubic Hermite interpolant on [0, 1] with end speeds `v0`, `v1` and end slopes
/// `m0 < 0 < m1` falls below −[`TOL_SPEED`] inside.
///
/// The cubic lies inside the hull of its Bézier points v0, v0 + m0/3, v1 − m1/3 and v1:
/// with all of them above half the tolerance, its minimum is too, and the search would say
/// the same (its rounding is parts in 1e16 of a speed). Away from a reversal that is nearly
/// every chunk whose acceleration turns, so the search runs only near zero speed.
fn dips_below_tolerance(v0: f64, v1: f64, m0: f64, m1: f64) -> bool {
    let hull = v0.min(v1).min(v0 + m0 / 3.0).min(v1 - m1 / 3.0);
    if hull >= -0.5 * TOL_SPEED {
        return false;
    }
    hermite_minimum(v0, v1, m0, m1) < -TOL_SPEED
}

/// The lowest value of the cubic Hermite interpolant on [0, 1] with end values `v0`, `v1`
/// and end slopes `m0 < 0 < m1` (slopes per unit interval): its derivative changes sign
/// once inside, found by bisection.
fn hermite_minimum(v0: f64, v1: f64, m0: f64, m1: f64) -> f64 {
    let value = |u: f64| {
        let (u2, u3) = (u * u, u * u * u);
        (2.0 * u3 - 3.0 * u2 + 1.0) * v0
            + (u3 - 2.0 * u2 + u) * m0
            + (-2.0 * u3 + 3.0 * u2) * v1
            + (u3 - u2) * m1
    };
    let slope = |u: f64| {
        let u2 = u * u;
        (6.0 * u2 - 6.0 * u) * (v0 - v1)
            + (3.0 * u2 - 4.0 * u + 1.0) * m0
            + (3.0 * u2 - 2.0 * u) * m1
    };
    let (mut lo, mut hi) = (0.0, 1.0);
    for _ in 0..40 {
        let mid = 0.5 * (lo + hi);
        if slope(mid) < 0.0 { lo = mid } else { hi = mid }
    }
    value(0.5 * (lo + hi))
}

fn unit(i: usize) -> Row {
    let mut r = Row::zeros();
    r[i] = 1.0;
    r
}

/// The friction inputs for `mode` at the state `x`: beyond Coulomb's while sliding (the
/// Stribeck excess and what the maps add, against the motion), none while stuck, and the
/// static friction the map adds where the table is; a force ripple in every mode.
pub(super) fn friction_inputs(model: &AxisModel, x: &mut Aug, mode: Mode) {
    let ripple = model.force_ripple.map_or(0.0, |r| r.at(x[X2]));
    if model.presliding.is_some() {
        // The bristles' force is added by the run, which keeps their state.
        x[FX] = ripple;
        x[FSX] = 0.0;
        return;
    }
    let (v, stribeck) = (x[V2], model.stribeck);
    let excess = stribeck.map_or(0.0, |(level, v_s)| level * (-(v / v_s).powi(2)).exp());
    let (added_sliding, added_static) = model.friction_added_n(x[X2], v);
    // The ripple pushes whether the table slides or stands (a standing table breaks away
    // from the nut's force less the ripple there).
    x[FX] = ripple
        + match mode.friction {
            FrictionMode::SlipPos => excess + added_sliding,
            FrictionMode::SlipNeg => -(excess + added_sliding),
            FrictionMode::Stick => 0.0,
        };
    x[FSX] = added_static;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::machine::MachineConfig;
    use crate::sim::model::{AR, TH_S, VR, XR};
    use crate::sim::simulate::rest_state;

    /// Regression: a standing Y axis chattered (`SimError::Chattering` at t = 191.6 s of a
    /// ten-minute pocket) because the stick guard, evaluated through the fused kernel, fired
    /// at |F_e| = f_s + 1e-9 N while the switching decision, comparing with a tolerance of
    /// its own, kept the axis stuck — and the same event was found again and again.
    #[test]
    fn stick_guard_violated_within_its_tolerance_still_breaks_away() {
        let model = AxisModel::from_config(&MachineConfig::default_preset().y);
        let mut sim = AxisSim::new(&model, 5e-4);
        let (mut x, mut mode) = rest_state(&model, 0.06);
        // Wind the screw so that the nut pushes with just over the static friction.
        let push = model.f_s + 0.5 * TOL_FORCE;
        x[TH_S] += push / model.k_m / model.r;
        sim.switch_mode(&mut x, &mut mode);
        assert_eq!(mode.friction, FrictionMode::SlipPos);
        assert_eq!(x[V2], 0.0);
    }

    /// Where the hull of the cubic's Bézier points says "no dip", the search over the cubic
    /// says so too: speeds and slopes from 1e-13 m/s (around the tolerance) to 0.1 m/s, the
    /// slopes up to four times the speeds. Both answers occur often.
    #[test]
    fn the_hull_tells_a_dip_as_the_search_does() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand::rngs::StdRng::seed_from_u64(7);
        let (mut by_hull, mut dips) = (0, 0);
        for _ in 0..100_000 {
            let scale = 10f64.powf(rng.random_range(-13.0..-1.0));
            let mut speed = || scale * rng.random_range(0.0..1.0);
            let (v0, v1) = (speed(), speed());
            let m0 = -scale * rng.random_range(0.0..4.0);
            let m1 = scale * rng.random_range(0.0..4.0);
            let searched = hermite_minimum(v0, v1, m0, m1) < -TOL_SPEED;
            assert_eq!(
                dips_below_tolerance(v0, v1, m0, m1),
                searched,
                "{v0} {v1} {m0} {m1}"
            );
            let hull = v0.min(v1).min(v0 + m0 / 3.0).min(v1 - m1 / 3.0);
            by_hull += usize::from(hull >= -0.5 * TOL_SPEED);
            dips += usize::from(searched);
        }
        assert!(by_hull > 10_000 && dips > 10_000, "{by_hull} {dips}");
    }

    /// The step compiled for AVX gives the portable step's bits: every row of a product one
    /// multiply and one add per column in the same order, no fused multiply-add. Checked on
    /// a backlash axis with friction following a reference that reverses again and again
    /// (so sticking, breakaway, the gap's crossings and bisection at every level), state and
    /// mode after every step.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn the_avx_step_gives_the_portable_steps_bits() {
        if !std::arch::is_x86_feature_detected!("avx") {
            return;
        }
        let mut machine = MachineConfig::default_preset();
        machine.x.drive.backlash_um = 10.0;
        let model = AxisModel::from_config(&machine.x);
        let h = 1e-4;
        let mut avx = AxisSim::new(&model, h);
        avx.use_avx(true);
        assert!(
            avx.avx,
            "the processor has AVX: the AVX copy must be the one stepping"
        );
        let mut portable = AxisSim::new(&model, h);
        portable.use_avx(false);
        assert!(!portable.avx);
        let (mut xa, mut ma) = rest_state(&model, 0.0);
        let (mut xp, mut mp) = (xa, ma);
        let mut switches = 0;
        for k in 0..20_000 {
            // 5 mm at 5 Hz: reversals every 0.1 s.
            let t = k as f64 * h;
            let w = std::f64::consts::TAU * 5.0;
            for x in [&mut xa, &mut xp] {
                x[XR] = 5e-3 * (w * t).sin();
                x[VR] = 5e-3 * w * (w * t).cos();
                x[AR] = -5e-3 * w * w * (w * t).sin();
            }
            let before = mp;
            avx.step(&mut xa, &mut ma, t, None).unwrap();
            portable.step(&mut xp, &mut mp, t, None).unwrap();
            assert_eq!(ma, mp, "step {k}");
            for (a, b) in xa.iter().zip(xp.iter()) {
                assert_eq!(a.to_bits(), b.to_bits(), "step {k}: {a} against {b}");
            }
            switches += usize::from(mp != before);
        }
        assert!(switches > 20, "{switches} mode switches");
    }
}
