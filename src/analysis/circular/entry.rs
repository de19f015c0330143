//! How much of a circle's start its figures leave out: the entry transient worked out from
//! the commands alone. A first-order model of each axis's loop (the time constant of its
//! slowest closed-loop mode) follows the commands up to where the command runs round the
//! circle at its own speed (past its ramp from rest, which the lag still grows over; the
//! programmed feed or less); what its lag there differs from the lag it would carry had it run
//! round the circle at that speed forever is the transient, which decays at the loop's pace
//! while the turning circle brings its part along the path into the radius. The window's time
//! constants are counted at that speed. Reading only the commands, the window is the
//! same for every path compared on them (a measurement, a model's prediction), and no noise
//! enters it.

use std::collections::{HashMap, VecDeque};

use nalgebra::Complex;

use super::{Circle, Commanded};

/// The fewest of its slowest loop's time constants (1/Kv) a circle's start and end are left
/// out for: an entry transient that starts from the circle's own lag has fallen to e⁻⁵,
/// under 1 % of it, by then (a ballbar's overshoot arc leaves it out the same way).
pub(super) const ENTRY_TIME_CONSTANTS: f64 = 5.0;

/// What an entry transient may still amount to where a circle's figures begin (m): a tenth
/// of a micrometre, the finest step a ballbar or laser shows.
pub(super) const ENTRY_RESIDUE_M: f64 = 0.1e-6;

/// How far the command's speed over one of the slower loop's time constants may differ
/// from its speed over the one before (a share of the newer) for it to run at its own speed
/// on a circle: a ramp that ends within the older leaves at most √(2·share) of the circle's
/// lag still to build past where it is read, which the window's own time constants bring
/// to a small part of 0.1 µm where a ramp from rest needs more than eight (e⁻⁸ of 4.5 % of
/// a millimetre's lag: 0.015 µm). Recorded commands rounded to coarse counts at a slow feed
/// (1 µm at F100) can pass it a fraction of a time constant early with the speed read about
/// a percent low: the window is then counted that much short, which leaves about a tenth
/// more of the residue after eight time constants.
const STEADY_SPEED_SHARE: f64 = 1e-3;

/// How near its end (m) the command's last sample on a circle must lie, beyond two of its
/// steps, for it to have gone on to the end: a micrometre, past any rounding of the path.
const END_REACHED_M: f64 = 1e-6;

/// The slowest speed a command runs round a circle at (m/s; 6 µm/min, under any feed): a
/// command that stands still reads some 1e-16 m/s where it was resampled from a record
/// (its last bits), alike over every span, which no steady speed is.
const RUNNING_M_PER_S: f64 = 1e-7;

/// The most time constants a transient is given: more than ln(f64::MAX / 0.1 µm) plus
/// ln(1000), so that any finite transient has fallen below [`ENTRY_RESIDUE_M`] by then; the
/// quarter turn a window may take bounds it long before.
const MAX_TIME_CONSTANTS: f64 = 1000.0;

/// The position loops' time constants (1/Kv, s; X, Y, Z) that set how much of each circle's
/// start its figures leave out: the stretch the loop needs to settle into the circle.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct EntrySettling {
    /// Time constant of X, Y and Z (s); zero for an axis that arrives with its command.
    pub time_constant_s: [f64; 3],
}

impl EntrySettling {
    /// The loops of `machine`: a cascade's Kv; for another controller the decay rate of its
    /// slowest closed-loop mode, not its bandwidth — a controller with integral action
    /// settles into the circle's steady lag at the pace its integrator's mode sets, often
    /// ten times slower than its bandwidth, and a window from the bandwidth keeps the entry
    /// transient in the figures.
    pub(crate) fn of(machine: &crate::machine::MachineConfig) -> Self {
        let kv = crate::plan::InPosition::kv_per_s_of(machine);
        let slowest_per_s = |a: &crate::machine::AxisConfig, kv_per_s: f64| {
            if a.controller.is_cascade() {
                kv_per_s
            } else {
                let rate =
                    crate::sim::linear::settling_rate_per_s(&crate::sim::AxisModel::from_config(a));
                if rate.is_finite() && rate > 0.0 {
                    rate
                } else {
                    kv_per_s
                }
            }
        };
        let z_per_s = machine
            .z
            .simulated()
            .map_or(kv[2], |z| slowest_per_s(z, kv[2]));
        let rate_per_s = [
            slowest_per_s(&machine.x, kv[0]),
            slowest_per_s(&machine.y, kv[1]),
            z_per_s,
        ];
        EntrySettling {
            time_constant_s: rate_per_s.map(|r| 1.0 / r),
        }
    }

    /// Five of the slower of circle `c`'s plane's loops' time constants at the programmed
    /// feed, as commanded path (m), at most a quarter turn: the start left out before the
    /// command sets off on the circle (from the set-off until its speed is known,
    /// [`Entries::enter`] leaves a quarter turn out), and the end until that speed is known.
    pub(super) fn lead_m(&self, c: &Circle) -> f64 {
        self.lead_for_m(c, ENTRY_TIME_CONSTANTS)
    }

    /// The commanded path left out at circle `c`'s start and end (m), the command running
    /// round it at `speed_m_per_s` from `reach_m` along it on, where the entry transient
    /// `transient_m` (radial, along the path; [`EntrySettling::transient_m`]) was read: the
    /// time constants [`settling_within`] gives from there, never fewer than five; five
    /// before the end. Each at most a quarter turn: the start's past `begun_m`, where the
    /// record's commands began on the circle (its start, or further round where the record
    /// began while the command ran round it).
    fn leads_m(
        &self,
        c: &Circle,
        transient_m: [f64; 2],
        [begun_m, reach_m]: [f64; 2],
        speed_m_per_s: f64,
    ) -> [f64; 2] {
        let tau_s = self.tau_s(c);
        let turned_m = speed_m_per_s / c.radius_m * tau_s * transient_m[1];
        let apart = Apart {
            size_m: 0.5 * transient_m[0].hypot(transient_m[1]),
            per_time_constant: self.apart_per_time_constant(c),
        };
        let needed = settling_within(transient_m[0], turned_m, apart, ENTRY_TIME_CONSTANTS);
        let path_m = |n: f64| n * tau_s * speed_m_per_s;
        let start_m = begun_m + quarter_turn_at_most(c, reach_m - begun_m + path_m(needed));
        [
            start_m,
            quarter_turn_at_most(c, path_m(ENTRY_TIME_CONSTANTS)),
        ]
    }

    /// How much faster the faster of circle `c`'s plane's loops settles than the slower, less
    /// one (τ_slow/τ_fast − 1); none where one axis arrives with its command (it carries no
    /// transient to part from the other's).
    fn apart_per_time_constant(&self, c: &Circle) -> f64 {
        let [a, b, _] = c.plane.axes();
        let (ta, tb) = (self.time_constant_s[a], self.time_constant_s[b]);
        let (fast, slow) = (ta.min(tb), ta.max(tb));
        let ratio = slow / fast - 1.0;
        if fast > 0.0 && ratio.is_finite() {
            ratio
        } else {
            0.0
        }
    }

    /// The slower of circle `c`'s plane's loops' time constants (s).
    fn tau_s(&self, c: &Circle) -> f64 {
        let [a, b, _] = c.plane.axes();
        self.time_constant_s[a].max(self.time_constant_s[b])
    }

    /// The angle the circle turns through in that time constant (rad), the command running
    /// round it at `speed_m_per_s`.
    pub(super) fn omega_tau(&self, c: &Circle, speed_m_per_s: f64) -> f64 {
        speed_m_per_s / c.radius_m * self.tau_s(c)
    }

    /// `time_constants` of the slower of circle `c`'s plane's loops, as commanded path at its
    /// feed (m), at most a quarter turn.
    fn lead_for_m(&self, c: &Circle, time_constants: f64) -> f64 {
        quarter_turn_at_most(c, time_constants * self.tau_s(c) * c.feed_m_per_s)
    }

    /// The entry transient where the command stands at `command_m` on circle `c`, running
    /// round it at `speed_m_per_s`, with the loops' model lagging it by `lag_m` (X, Y, Z;
    /// [`LoopLag`]): that lag less the one the model carries on the circle at that speed
    /// for ever, split into its radial part and its part along the path (m, signed).
    pub(super) fn transient_m(
        &self,
        c: &Circle,
        command_m: [f64; 3],
        lag_m: [f64; 3],
        speed_m_per_s: f64,
    ) -> [f64; 2] {
        let (theta_rad, _) = c.polar(c.plane.coords(command_m));
        let [a, b, _] = c.plane.axes();
        // Round the centre, the command is z = R·e^{jθ} turning at ω (counter-clockwise
        // positive); a first-order loop of time constant τ lags it by z·jωτ/(1 + jωτ), the
        // first axis by its real part, the second by its imaginary part.
        let omega_rad_per_s = speed_m_per_s / c.radius_m * if c.ccw { 1.0 } else { -1.0 };
        let z = Complex::from_polar(c.radius_m, theta_rad);
        let steady = |tau_s: f64| {
            let jwt = Complex::new(0.0, omega_rad_per_s * tau_s);
            z * jwt / (1.0 + jwt)
        };
        let lag = c.plane.coords(lag_m);
        let delta = [
            lag[0] - steady(self.time_constant_s[a]).re,
            lag[1] - steady(self.time_constant_s[b]).im,
        ];
        let (sin, cos) = theta_rad.sin_cos();
        [
            delta[0] * cos + delta[1] * sin,
            -delta[0] * sin + delta[1] * cos,
        ]
    }
}

/// `lead_m` of commanded path on circle `c` (m), at most a quarter turn; none where no
/// number says how much.
fn quarter_turn_at_most(c: &Circle, lead_m: f64) -> f64 {
    if lead_m.is_finite() {
        lead_m.clamp(0.0, 0.25 * std::f64::consts::TAU * c.radius_m)
    } else {
        0.0
    }
}

/// What the plane's two loops settling at their own paces bring into the radius: the
/// transient's parts decay as e^(−t/τa) and e^(−t/τb), and their difference turns it, up to
/// `size_m` (half the transient) · min(1, n·`per_time_constant`) · e⁻ⁿ after n of the slower
/// loop's time constants, the circle standing still.
#[derive(Debug, Clone, Copy)]
pub(super) struct Apart {
    pub(super) size_m: f64,
    pub(super) per_time_constant: f64,
}

/// How many time constants an entry transient takes to fall to [`ENTRY_RESIDUE_M`] in the
/// radius, at least `floor`: a transient of radial part `radial_m` and of part along the path
/// d decays as e^(−t/τ) while the circle turns ωτ per time constant, bringing up to n·ωτ·|d|
/// (`turned_m` = ωτ·d) of it into the radius after n of them, so what remains in the radius
/// is at most (|radial| + n·|turned|)·e⁻ⁿ, and with what the loops' paces part ([`Apart`])
/// added. The smallest n from which that stays below the residue, by bisection (past its
/// one maximum, at n = 1 − |radial|/|turned|, and past n = 1 where the paces part, the bound
/// falls). Nothing known of the transient (NaN) gives the floor.
pub(super) fn settling_within(radial_m: f64, turned_m: f64, apart: Apart, floor: f64) -> f64 {
    let (a, b) = (radial_m.abs(), turned_m.abs());
    let (c, k) = (apart.size_m.abs(), apart.per_time_constant.abs());
    if a.is_nan() || b.is_nan() {
        return floor;
    }
    // NaN parts of the loops' difference count as none.
    let parted = |n: f64| {
        if (c * k).is_nan() {
            0.0
        } else {
            c * (n * k).min(1.0)
        }
    };
    // The bound's logarithm over the residue's: positive while more than it remains.
    let excess = |n: f64| (a + n * b + parted(n)).ln() - n - ENTRY_RESIDUE_M.ln();
    // Past the plain bound's one maximum, and past n = 1 where the paces part (each piece
    // of the bound falls from there).
    let parts: f64 = if c * k > 0.0 { 1.0 } else { 0.0 };
    let peak = parts.max(if b > 0.0 { 1.0 - a / b } else { 0.0 });
    let mut lo = floor.max(peak).min(MAX_TIME_CONSTANTS);
    if excess(lo) <= 0.0 {
        return floor;
    }
    let mut hi = MAX_TIME_CONSTANTS;
    for _ in 0..64 {
        let mid = 0.5 * (lo + hi);
        if excess(mid) > 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    hi
}

/// A first-order model of each axis's loop following the commands sample by sample: its
/// lag behind them (m), the state [`EntrySettling::transient_m`] reads.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct LoopLag {
    /// The previous command's time (s) and position (m); `None` before the first.
    last: Option<(f64, [f64; 3])>,
    /// The command less the model's position, X, Y, Z (m).
    pub(super) lag_m: [f64; 3],
}

impl LoopLag {
    /// Takes the command at `command_m` at time `t_s`, the loops' time constants `tau_s`.
    /// The model starts at rest on the first command.
    pub(super) fn advance(&mut self, tau_s: [f64; 3], t_s: f64, command_m: [f64; 3]) {
        if let Some((last_s, last_m)) = self.last {
            for axis in 0..3 {
                let moved_m = command_m[axis] - last_m[axis];
                self.lag_m[axis] = lag_step(self.lag_m[axis], moved_m, t_s - last_s, tau_s[axis]);
            }
        }
        self.last = Some((t_s, command_m));
    }
}

/// The lag of a first-order loop of time constant `tau_s` (m) a step of `step_s` after it
/// lagged by `lag_m`, its command having moved `moved_m` at an even speed meanwhile (how
/// commands run between samples): the lag tends to speed·τ at the loop's pace, exactly,
/// e·a + speed·τ·(1 − a) with a = e^(−step/τ). A command that jumps (no time between
/// samples, or a clock that turned back) adds its jump; a loop without lag (τ zero) or what
/// no number describes (a missing time's or position's NaN) leaves none.
fn lag_step(lag_m: f64, moved_m: f64, step_s: f64, tau_s: f64) -> f64 {
    if tau_s.is_nan() || tau_s <= 0.0 || step_s.is_nan() {
        return 0.0;
    }
    let next_m = if step_s > 0.0 {
        let x = step_s / tau_s;
        let rise = -(-x).exp_m1();
        lag_m * (1.0 - rise) + moved_m * rise / x
    } else {
        lag_m + moved_m
    };
    if next_m.is_finite() { next_m } else { 0.0 }
}

/// The loops' model following the commands, and each circle's entry until its window is
/// decided: where the command runs round it at its own speed.
#[derive(Debug, Clone, Default)]
pub(super) struct Entries {
    /// The loops' first-order model.
    pub(super) lag: LoopLag,
    /// By circle (its index among the circles gathered).
    entering: HashMap<usize, Entering>,
    /// The circle the last command lay on.
    on: Option<usize>,
}

/// One circle's entry and exit: the command's recent samples on it, from two of the slower
/// loop's time constants before the newest on; whether its start's window is decided; and
/// how far along it the command last ran at a steady speed.
#[derive(Debug, Clone, Default)]
struct Entering {
    recent: VecDeque<OnCircle>,
    /// The last sample at which the command stood on the circle before it set off.
    standing: Option<OnCircle>,
    /// The path from the circle's start to where the record's commands began on it (m):
    /// none where they stood at its start first.
    begun_m: Option<f64>,
    decided: bool,
    /// The path run (m) where the newer of the last two spans found steady began: the
    /// command's speed had not yet changed there, so neither had the loops' lag (they
    /// answer only to commands already given). Where the command later slows into the
    /// circle's end, its window reaches back to here.
    steady_until_m: Option<f64>,
    /// The path run at the last sample on the circle and that sample's step (m): whether
    /// the command went on to the circle's end, or the record stopped before it.
    last_m: (f64, f64),
}

/// A command on a circle: its time (s), the path it has run along the circle (m), where it
/// stands (m) and the loops' model's lag behind it then (m; X, Y, Z).
#[derive(Debug, Clone, Copy)]
struct OnCircle {
    t_s: f64,
    run_m: f64,
    command_m: [f64; 3],
    lag_m: [f64; 3],
}

impl Entries {
    /// Takes the command on circle `c` (the `i`th gathered), having run `run_m` along it
    /// (from where it set off, or from the circle's start where the record began as it ran
    /// round; `None` before it set off); the loops' model has taken it. Returns the
    /// circle's windows (start, end; m) where they change: a quarter turn past where the
    /// commands began on it at the start where the command sets off, none of the circle yet counting as settled; then, once its
    /// speed over the last of the slower loop's time constants has come within
    /// [`STEADY_SPEED_SHARE`] of its speed over the one before, the windows of the entry
    /// transient read where those began ([`EntrySettling::transient_m`]): where the command
    /// reached the speed it runs at, which a feed override or a small radius's acceleration
    /// may hold below the programmed feed, past the ramp onto it. From the set-off, at the
    /// programmed feed, where no loop's pace or no time is known; at the quarter turn where
    /// the speed never steadies before it. With the windows, the speed they were read at
    /// (m/s): the programmed feed where no speed was found.
    pub(super) fn enter(
        &mut self,
        i: usize,
        (entry, c): (&EntrySettling, &Circle),
        command: Commanded,
        run_m: Option<f64>,
    ) -> Option<([f64; 2], f64)> {
        let e = self.entering.entry(i).or_default();
        let at = |run_m: f64| OnCircle {
            t_s: command.t_s,
            run_m,
            command_m: command.pos_m,
            lag_m: self.lag.lag_m,
        };
        let Some(run_m) = run_m else {
            e.standing = Some(at(0.0));
            return None;
        };
        // From the circle's start where the command stood there first; further round where
        // the record began as it ran round.
        let begun_m = *(e.begun_m).get_or_insert(if e.standing.is_some() { 0.0 } else { run_m });
        e.last_m = (run_m, run_m - e.last_m.0);
        let tau_s = entry.tau_s(c);
        if e.decided {
            e.follow(tau_s, at(run_m));
            return None;
        }
        let quarter_m = begun_m + 0.25 * std::f64::consts::TAU * c.radius_m;
        // Until the speed is known: a quarter turn past where the commands began on the
        // circle, five time constants at the feed before the end.
        let undecided = ([quarter_m, entry.lead_m(c)], c.feed_m_per_s);
        let first = e.recent.is_empty();
        let read = |p: OnCircle, speed_m_per_s: f64| {
            let transient_m = entry.transient_m(c, p.command_m, p.lag_m, speed_m_per_s);
            (
                entry.leads_m(c, transient_m, [begun_m, p.run_m], speed_m_per_s),
                speed_m_per_s,
            )
        };
        let decided = if !(tau_s > 0.0 && tau_s.is_finite() && command.t_s.is_finite()) {
            Some(read(at(run_m), c.feed_m_per_s))
        } else if let Some(([reached, newer], speed_m_per_s)) = e.steady(tau_s, at(run_m)) {
            e.steady_until_m = Some(newer.run_m);
            Some(read(reached, speed_m_per_s))
        } else if run_m >= quarter_m {
            Some(undecided)
        } else {
            None
        };
        if decided.is_some() {
            e.decided = true;
            return decided;
        }
        first.then_some(undecided)
    }
}

impl Entries {
    /// How much of the `i`th circle gathered, `c`, its figures leave out before its end
    /// (m), at least `lead_m`: where the command slowed into the end after it last ran at a
    /// steady speed, the path from there on (the loops' lag changes with the speed, and
    /// what it leaves in the radius is no part of the circle's form), at most a quarter
    /// turn. Known only once the command has left the circle.
    pub(super) fn end_lead_m(&self, i: usize, c: &Circle, lead_m: f64) -> f64 {
        let Some(e) = self.entering.get(&i) else {
            return lead_m;
        };
        // A record that stops before the circle's end has not seen the command slow.
        let (last_m, step_m) = e.last_m;
        let to_end_m = c.length_m - last_m;
        let slowing_m = e
            .steady_until_m
            .filter(|_| to_end_m <= 2.0 * step_m.abs() + END_REACHED_M)
            .map_or(0.0, |run_m| c.length_m - run_m);
        lead_m.max(quarter_turn_at_most(c, slowing_m))
    }

    /// Takes that the command lies on the `i`th circle gathered (`None`: on none): the
    /// samples kept for the speed of a circle it has left are dropped.
    pub(super) fn on_circle(&mut self, i: Option<usize>) {
        if self.on == i {
            return;
        }
        if let Some(e) = self.on.and_then(|j| self.entering.get_mut(&j)) {
            e.recent = VecDeque::new();
        }
        self.on = i;
    }
}

impl Entering {
    /// Takes the command's sample `p` once its start's window is decided, and notes where
    /// it last ran at a steady speed.
    fn follow(&mut self, tau_s: f64, p: OnCircle) {
        if !(tau_s > 0.0 && tau_s.is_finite()) {
            return;
        }
        if let Some(([_, newer], _)) = self.steady(tau_s, p) {
            self.steady_until_m = Some(newer.run_m);
        }
    }

    /// Takes the command's sample `p`; where its speed over the last `tau_s` agrees with
    /// its speed over the `tau_s` before (each at least a sample's step), the samples where
    /// the older and the newer of the two spans began, and the speed over the newer (m/s).
    fn steady(&mut self, tau_s: f64, p: OnCircle) -> Option<([OnCircle; 2], f64)> {
        if self.recent.is_empty() {
            // The last sample before the set-off: the circle's run starts there (run 0).
            if let Some(standing) = self.standing.filter(|s| s.t_s < p.t_s) {
                self.recent.push_back(standing);
            }
        }
        // A clock that stands or turns back, or no number, says nothing of a speed.
        let newer = self.recent.back().is_none_or(|last| p.t_s > last.t_s);
        if !(newer && p.run_m.is_finite()) {
            return None;
        }
        self.recent.push_back(p);
        let since_s = p.t_s - 2.0 * tau_s;
        while self.recent.len() > 3 && self.recent[1].t_s <= since_s {
            self.recent.pop_front();
        }
        let n = self.recent.len();
        let first = self.recent[0];
        if n < 3 || first.t_s > since_s {
            return None;
        }
        let mid = (self.recent.partition_point(|q| q.t_s <= p.t_s - tau_s)).clamp(2, n - 1) - 1;
        let mid = self.recent[mid];
        let before = (mid.run_m - first.run_m) / (mid.t_s - first.t_s);
        let last = (p.run_m - mid.run_m) / (p.t_s - mid.t_s);
        // The newer of the two: what the speed still gained over the older is behind it.
        ((last - before).abs() <= STEADY_SPEED_SHARE * last && last > RUNNING_M_PER_S)
            .then_some(([first, mid], last))
    }
}
