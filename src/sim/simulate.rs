//! An axis run over its commands: from rest, cycle by cycle, the commands delayed by the
//! dead time, the inputs that vary within a cycle set at each sub-step, the structural mode
//! seen at the measured point, and the trace recorded. Each sub-step is the hybrid
//! simulation's ([`super::hybrid`]).

use super::hybrid::{AxisSim, friction_inputs};
use super::model::{
    AR, Aug, AxisModel, ClampMode, ContactMode, DL, FB, FX, FrictionMode, Mode, ONE, Row, TH_S, V2,
    VR, X2, XR,
};
use super::{AxisTrace, FrictionEvent, SimConfig, SimError};
use crate::machine::Feedback;
use crate::sim::AxisCommands;

/// The state of an axis at rest at `x0` (m): everything aligned, no current, stuck, the nut
/// in the middle of its gap — or, on a vertical axis or one that holds a force at its start
/// ([`AxisModel::held_at_start_n`]), as its loops hold its weight and that force.
///
/// "At rest" means where the loop holds the axis: the feedback reads `x0`. With a measuring
/// error that is not where the table is — a scale reading e too long holds the table at
/// x0 − e, a lead error puts it at x0 + e — and starting elsewhere would make the axis creep
/// the difference out through static friction before anything else happens.
pub(crate) fn rest_state(model: &AxisModel, x0: f64) -> (Aug, Mode) {
    let mut x = Aug::zeros();
    let (screw_travel, table) = match model.feedback {
        Feedback::LinearScale => {
            // Solve X2 + e(X2) = x0 by fixed point (|e'| ≪ 1).
            let mut t = x0;
            for _ in 0..4 {
                t = x0 - model.measuring.at(t);
            }
            (t, t)
        }
        Feedback::MotorEncoder => (x0, x0 + model.measuring.at(x0)),
    };
    x[X2] = table;
    x[TH_S] = screw_travel / model.r;
    x[super::model::TH_M] = x[TH_S] / model.it;
    x[XR] = x0;
    x[ONE] = 1.0;
    x[FB] = if model.feedback == Feedback::LinearScale {
        table - screw_travel + model.measuring.at(table)
    } else {
        0.0
    };
    x[DL] = if model.feedback == Feedback::MotorEncoder {
        table - screw_travel
    } else {
        0.0
    };
    let contact = if model.has_backlash() {
        ContactMode::Free
    } else {
        ContactMode::Pos
    };
    let mut mode = Mode {
        friction: FrictionMode::Stick,
        contact,
        current: ClampMode::Linear,
        voltage: ClampMode::Linear,
    };
    // A vertical axis stands where its loops hold its weight, and every axis with the
    // force its integral action holds against friction at the start.
    let held_n = model.held_at_start_bounded_n(x[X2]);
    super::gravity::hold_load(model, &mut x, &mut mode, held_n);
    if model.presliding.is_some() {
        // Presliding friction has no stuck mode: the bristles hold the table.
        mode.friction = FrictionMode::SlipPos;
    }
    (x, mode)
}

/// The presliding bristles' deflection at rest (m) where the loops push with `held_n` (N):
/// the bristles carry that push, σ0·z = held.
fn bristles_at_rest_m(model: &AxisModel, held_n: f64) -> Option<f64> {
    model.presliding.map(|p| held_n / p.sigma0_n_per_m)
}

/// Simulates one axis following its commands (sampled every `dt_s`), recording the trace
/// at every command sample.
pub fn simulate(
    model: &AxisModel,
    commands: &AxisCommands,
    dt_s: f64,
    config: &SimConfig,
) -> Result<AxisTrace, SimError> {
    simulate_with_progress(model, commands, dt_s, config, &|_| {})
}

/// Samples between two progress reports.
const PROGRESS_EVERY: usize = 10_000;

/// [`simulate`], calling `progress(samples done since the last call)` now and then.
pub(crate) fn simulate_with_progress(
    model: &AxisModel,
    commands: &AxisCommands,
    dt_s: f64,
    config: &SimConfig,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<AxisTrace, SimError> {
    let x0 = commands.pos_m.first().copied().unwrap_or(0.0);
    let mut run = AxisRun::new(model, x0, dt_s, config)?;
    run.follow(commands, 0..commands.len(), progress)?;
    Ok(run.finish())
}

/// One axis simulated cycle by cycle, so that a caller can decide each next command from
/// what the axis has done so far — as a control's in-position check does at an exact stop.
/// [`simulate`] is this run fed with a whole command list.
pub struct AxisRun<'a> {
    model: &'a AxisModel,
    sim: AxisSim<'a>,
    x: Aug,
    mode: Mode,
    dt_s: f64,
    substeps: usize,
    divergence_limit_m: f64,
    trace: AxisTrace,
    friction_events: Option<Vec<FrictionEvent>>,
    per_substep_inputs: bool,
    lateral_dl: f64,
    /// The commands as the position controller receives them after the dead time.
    delay: Option<DelayLine>,
    /// The control's position reading as a row on the state.
    feedback: Row,
    /// The structural mode seen at the measured point, when the model has one.
    structure: Option<StructuralFilter>,
    /// Cycles whose samples were taken out with [`AxisRun::take_trace`].
    taken: usize,
    /// The presliding bristles' deflection (m), when the axis has them.
    bristle_m: Option<f64>,
}

impl AxisModel {
    /// The sub-steps a cycle of `dt_s` (s) is divided into on this axis: the settings'
    /// count, or more where presliding bristles need a finer step.
    pub fn substeps(&self, dt_s: f64, config: &SimConfig) -> usize {
        let set = config.substeps.max(1) as usize;
        match &self.presliding {
            Some(p) => p.substeps(dt_s, self.mt).max(set),
            None => set,
        }
    }
}

impl<'a> AxisRun<'a> {
    /// An axis at rest at `x0_m` (m), advanced in cycles of `dt_s` (s). An unstable gain
    /// setting is refused here, before any step.
    pub(crate) fn new(
        model: &'a AxisModel,
        x0_m: f64,
        dt_s: f64,
        config: &SimConfig,
    ) -> Result<Self, SimError> {
        super::linear::check_stable(model)?;
        let substeps = model.substeps(dt_s, config);
        let (x, mode) = rest_state(model, x0_m);
        Ok(AxisRun {
            model,
            sim: AxisSim::new(model, dt_s / substeps as f64),
            x,
            mode,
            dt_s,
            substeps,
            divergence_limit_m: config.divergence_limit_m,
            trace: AxisTrace::with_capacity(dt_s, 0),
            friction_events: config.record_friction_events.then(Vec::new),
            per_substep_inputs: model.inputs_vary_within_cycle(),
            lateral_dl: 0.0,
            delay: (model.dead_time_s > 0.0).then(|| DelayLine::new(model.dead_time_s, dt_s, x0_m)),
            feedback: model.signals().x_fb,
            structure: model
                .resonance
                .map(|(omega, zeta)| StructuralFilter::new(omega, zeta, dt_s)),
            taken: 0,
            bristle_m: bristles_at_rest_m(model, model.held_at_start_bounded_n(x[X2])),
        })
    }

    /// Cycles done so far (= samples recorded, taken out or not).
    pub(crate) fn cycles(&self) -> usize {
        self.taken + self.trace.len()
    }

    /// Where the control reads the axis now (m): its position feedback — the linear scale,
    /// or the motor encoder through the nominal lead — as the in-position check sees it.
    pub(crate) fn feedback_m(&self) -> f64 {
        (self.feedback * self.x)[0]
    }

    /// Records the sample at the start of this cycle with the command (position m,
    /// velocity m/s, acceleration m/s²), then integrates over the cycle.
    pub(crate) fn advance(
        &mut self,
        pos_m: f64,
        vel_m_per_s: f64,
        acc_m_per_s2: f64,
    ) -> Result<(), SimError> {
        let k = self.cycles();
        let (p, v, a) = match &mut self.delay {
            Some(line) => line.push_and_read(pos_m, vel_m_per_s, acc_m_per_s2),
            None => (pos_m, vel_m_per_s, acc_m_per_s2),
        };
        // The reference of this interpolation cycle: x + v·τ + a·τ²/2, integrated exactly.
        self.x[XR] = p;
        self.x[VR] = v;
        self.x[AR] = a;
        if let Some(lat) = &self.model.lateral {
            // Nut travel K_λ·r·θ_s: the lead scale enters as an offset on δ. It changes by
            // parts in 1e10 over a cycle, so once per interpolation cycle is exact enough.
            self.lateral_dl = (lat.k_lambda(self.x[X2]) - 1.0) * self.model.r * self.x[TH_S];
            self.x[DL] = self.lateral_dl;
        }
        self.trace.push(&self.x, self.mode, self.model);
        if let Some(filter) = &mut self.structure
            && let Some(p) = self.trace.pos_m.last_mut()
        {
            *p = filter.seen_at(*p);
        }
        for sub in 0..self.substeps {
            if self.per_substep_inputs {
                substep_inputs(self.model, &mut self.x, self.mode, self.lateral_dl);
            }
            let t = (k as f64 + sub as f64 / self.substeps as f64) * self.dt_s;
            let bristles = self.bristles_push();
            self.sim.step(
                &mut self.x,
                &mut self.mode,
                t,
                self.friction_events.as_mut(),
            )?;
            self.bristles_follow(bristles);
        }
        let lag = self.x[XR] - self.x[X2];
        if !lag.is_finite() || lag.abs() > self.divergence_limit_m {
            return Err(SimError::Diverged {
                t_s: (k + 1) as f64 * self.dt_s,
                error_m: lag,
            });
        }
        Ok(())
    }

    /// Adds the presliding bristles' force, held over the next sub-step, to the table's
    /// external force; returns where the table starts it (m) and the sliding level (N).
    fn bristles_push(&mut self) -> Option<(f64, f64)> {
        let (p, z) = (self.model.presliding.as_ref()?, self.bristle_m?);
        let (x, v) = (self.x[X2], self.x[V2]);
        let level = p.level_n(v, self.maps_sliding_n(x, v));
        let h = self.dt_s / self.substeps as f64;
        self.x[FX] += p.held_force_n(z, v, h, level);
        Some((x, level))
    }

    /// Bends the bristles by the table's travel over the sub-step just taken, which started
    /// at `start`: what [`AxisRun::bristles_push`] returned.
    fn bristles_follow(&mut self, start: Option<(f64, f64)>) {
        if let (Some(p), Some(z), Some((x0, level))) = (
            self.model.presliding.as_ref(),
            self.bristle_m.as_mut(),
            start,
        ) {
            *z = p.bent(*z, self.x[X2] - x0, level);
        }
    }

    /// What the friction maps add to sliding friction at `x` m and `v` m/s (N).
    fn maps_sliding_n(&self, x: f64, v: f64) -> f64 {
        if self.model.has_friction_maps() {
            self.model.friction_added_n(x, v).0
        } else {
            0.0
        }
    }

    /// Advances through `commands[range]`, one cycle per sample.
    pub(crate) fn follow(
        &mut self,
        commands: &AxisCommands,
        range: std::ops::Range<usize>,
        progress: &(dyn Fn(u64) + Sync),
    ) -> Result<(), SimError> {
        self.trace.reserve(range.len());
        let mut since_report = 0;
        for k in range {
            self.advance(
                commands.pos_m[k],
                commands.vel_m_per_s[k],
                commands.acc_m_per_s2[k],
            )?;
            since_report += 1;
            if since_report == PROGRESS_EVERY {
                progress(since_report as u64);
                since_report = 0;
            }
        }
        Ok(())
    }

    /// The samples recorded since the last call (all of them at first), with the friction
    /// switches among them: a long run is taken out piece by piece, so that memory does not
    /// grow with its duration.
    pub(crate) fn take_trace(&mut self) -> AxisTrace {
        let mut taken = std::mem::replace(&mut self.trace, AxisTrace::with_capacity(self.dt_s, 0));
        self.taken += taken.len();
        if let Some(events) = &mut self.friction_events {
            taken.friction_events = std::mem::take(events);
        }
        taken
    }

    /// The recorded trace (one sample per cycle advanced since the last
    /// [`AxisRun::take_trace`]).
    pub(crate) fn finish(mut self) -> AxisTrace {
        self.take_trace()
    }
}

/// The structural mode (a resonance, docs/model.md §5) as the measured point sees it: a second-order
/// oscillator excited by the table's acceleration, added to the table position. Applied as
/// the samples come, so that a run taken out piece by piece reads the same as a whole one;
/// the acceleration is the centred second difference, so each sample's offset uses the
/// samples up to its own.
struct StructuralFilter {
    /// Exact discretisation of (q, q̇) driven by a constant acceleration over one cycle.
    step: nalgebra::Matrix3<f64>,
    dt_s: f64,
    /// Modal displacement and velocity at the latest sample.
    q: f64,
    qd: f64,
    /// The two latest table positions as simulated (m), the older first.
    recent: Option<[f64; 2]>,
}

impl StructuralFilter {
    fn new(omega: f64, zeta: f64, dt_s: f64) -> Self {
        #[rustfmt::skip]
        let a = nalgebra::Matrix3::new(
            0.0, 1.0, 0.0,
            -omega * omega, -2.0 * zeta * omega, -1.0,
            0.0, 0.0, 0.0,
        );
        StructuralFilter {
            step: (a * dt_s).exp(),
            dt_s,
            q: 0.0,
            qd: 0.0,
            recent: None,
        }
    }

    /// The measured point's position for the next simulated table position `p` (m).
    fn seen_at(&mut self, p: f64) -> f64 {
        // Before the first sample the axis stood where it starts.
        let [older, prev] = self.recent.unwrap_or([p, p]);
        if self.recent.is_some() {
            // The acceleration at the previous sample moves the mode on to this one.
            let acc = (p - 2.0 * prev + older) / (self.dt_s * self.dt_s);
            let e = &self.step;
            (self.q, self.qd) = (
                e[(0, 0)] * self.q + e[(0, 1)] * self.qd + e[(0, 2)] * acc,
                e[(1, 0)] * self.q + e[(1, 1)] * self.qd + e[(1, 2)] * acc,
            );
        }
        self.recent = Some([prev, p]);
        p + self.q
    }
}

/// The commands as the position controller receives them a dead time later: each sample
/// re-evaluated that long back on the interpolator's own polynomial (standing still before
/// the first).
struct DelayLine {
    dead_s: f64,
    dt_s: f64,
    x0_m: f64,
    /// Recent commands; `first` is the cycle index of the front.
    recent: std::collections::VecDeque<(f64, f64, f64)>,
    first: usize,
    next: usize,
}

impl DelayLine {
    fn new(dead_s: f64, dt_s: f64, x0_m: f64) -> Self {
        DelayLine {
            dead_s,
            dt_s,
            x0_m,
            recent: std::collections::VecDeque::new(),
            first: 0,
            next: 0,
        }
    }

    fn push_and_read(&mut self, p: f64, v: f64, a: f64) -> (f64, f64, f64) {
        self.recent.push_back((p, v, a));
        let k = self.next;
        self.next += 1;
        let t = k as f64 * self.dt_s - self.dead_s;
        if t < 0.0 {
            return (self.x0_m, 0.0, 0.0);
        }
        let j = ((t / self.dt_s).floor() as usize).min(k);
        // Older commands are never read again.
        while self.first < j {
            self.recent.pop_front();
            self.first += 1;
        }
        let tau = t - j as f64 * self.dt_s;
        let (p, v, a) = self.recent[j - self.first];
        (p + v * tau + 0.5 * a * tau * tau, v + a * tau, a)
    }
}

/// Inputs held over one sub-step that depend on the state: the friction beyond Coulomb's
/// while sliding (the Stribeck excess and what the friction maps add, against the motion),
/// the static friction a friction map adds where the table stands, and the measuring
/// system's error — on the feedback (linear scale) or on the nut's travel (motor encoder).
fn substep_inputs(model: &AxisModel, x: &mut Aug, mode: Mode, lateral_dl: f64) {
    friction_inputs(model, x, mode);
    if model.measuring.is_active() {
        match model.feedback {
            Feedback::LinearScale => x[FB] = model.measuring.at(x[X2]),
            Feedback::MotorEncoder => x[DL] = lateral_dl + model.measuring.at(model.r * x[TH_S]),
        }
    }
}
