//! The servo-feed axis simulator (docs/model.md §1): three-loop control (or another controller
//! structure, realised by `machine::realise`), ball-screw mechanics,
//! hybrid stick/slip friction, backlash, lateral shift, current and voltage limits.
//!
//! [`simulate`] is pure: model and commands in, trace out, no I/O, its result its arguments'
//! alone (the step maps it shares between simulations are keyed by dynamics and step bit for
//! bit), so axes and sweeps run in parallel; each of its sub-steps is `hybrid`'s, exact between
//! mode switches. [`linear`] gives the linearised loops (Bode, stability) and [`stickslip`] the
//! paper's stick-slip criterion.

#[doc(hidden)]
pub mod bench;
pub mod commands;
pub(crate) mod discrete;
pub mod geometry;
pub(crate) mod gravity;
pub(crate) mod hybrid;
pub mod linear;
pub mod margins;
pub mod model;
pub mod presliding;
pub mod simulate;
pub mod stickslip;

pub use commands::AxisCommands;
pub use model::AxisModel;
pub(crate) use model::{FrictionMode, Mode};
pub use simulate::{AxisRun, simulate};

use model::{Aug, I, X2, XR};

/// Simulation settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SimConfig {
    /// Simulation steps per command sample (the step is the interpolation cycle divided by
    /// this). The linear dynamics are exact at any step; the step bounds how finely the
    /// event search looks for mode switches (it finds every switch whose guard changes sign
    /// once within a step).
    pub substeps: u32,
    /// A following error beyond this (m) is reported as divergence.
    pub divergence_limit_m: f64,
    /// Record every friction mode switch (for stick-slip analysis).
    pub record_friction_events: bool,
}

impl Default for SimConfig {
    fn default() -> Self {
        SimConfig {
            substeps: 4,
            divergence_limit_m: 1.0,
            record_friction_events: false,
        }
    }
}

/// Why a simulation stopped.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SimError {
    /// The linearised closed loop has a growing mode: the gain setting is unstable.
    #[error(
        "unstable gain setting: a closed-loop mode at {frequency_hz:.1} Hz grows at \
         {growth_per_s:.3} 1/s — the loop gains are the keys position_loop.kv_m_per_min_per_mm, \
         velocity_loop.ks_nm_s_per_rad and ts_ms, current_loop.ki_v_per_a and ti_ms, or those \
         of [axis.controller]"
    )]
    Unstable {
        /// Frequency of the growing mode.
        frequency_hz: f64,
        /// Its growth rate (positive real part).
        growth_per_s: f64,
    },
    /// The linearised closed loop's modes cannot be computed: a setting, or one derived from
    /// the settings, is not a finite number, or the eigenvalue sweeps did not settle.
    #[error(
        "the closed loop's modes cannot be computed: a setting of the axis, or one derived from \
         its settings, is not a finite number, or the loop's matrix is too ill-conditioned for \
         its eigenvalues to settle"
    )]
    NoModes,
    /// The following error left every plausible bound.
    #[error("the axis diverged: following error {error_m:.3e} m at t = {t_s:.3} s")]
    Diverged {
        /// When.
        t_s: f64,
        /// How large.
        error_m: f64,
    },
    /// Mode switches without end inside one step.
    #[error(
        "the friction/backlash/limit modes switch without end at t = {t_s:.6} s (last: {modes}); \
         this is a defect of the simulator, not of the program"
    )]
    Chattering {
        /// When.
        t_s: f64,
        /// The modes it kept switching between, in words.
        modes: String,
    },
    /// The run is longer than is simulated: held whole, it would not fit in memory; streamed,
    /// it would take too long.
    #[error(
        "the program runs {hours:.1} h on this machine (line {longest_line} alone takes \
         {longest_hours:.1} h); runs of at most {limit_hours:.0} h at this interpolation cycle \
         are simulated {why}"
    )]
    TooLong {
        /// The planned cycle time (h).
        hours: f64,
        /// The block that takes longest.
        longest_line: u32,
        /// How long it takes (h).
        longest_hours: f64,
        /// The longest run simulated (h).
        limit_hours: f64,
        /// Why the limit is there.
        why: &'static str,
    },
    /// A failure of one axis, placed in the program.
    #[error("{axis} axis{}: {source}", near_line(*.line))]
    OnAxis {
        /// The axis (`X` or `Y`).
        axis: char,
        /// The program line running at the time, when there was one.
        line: Option<u32>,
        /// What went wrong.
        source: Box<SimError>,
    },
}

fn near_line(line: Option<u32>) -> String {
    line.map(|l| format!(", line {l}")).unwrap_or_default()
}

impl SimError {
    /// When it happened (s), if it happened during the run.
    pub(crate) fn t_s(&self) -> Option<f64> {
        match self {
            SimError::Diverged { t_s, .. } | SimError::Chattering { t_s, .. } => Some(*t_s),
            SimError::OnAxis { source, .. } => source.t_s(),
            SimError::Unstable { .. } | SimError::NoModes | SimError::TooLong { .. } => None,
        }
    }

    /// The failure itself, without the axis and line it was placed at.
    pub(crate) fn innermost(&self) -> &SimError {
        match self {
            SimError::OnAxis { source, .. } => source.innermost(),
            other => other,
        }
    }

    /// The failure placed on `axis` and, when known, the program line running then.
    pub(crate) fn on_axis(self, axis: char, line: Option<u32>) -> SimError {
        SimError::OnAxis {
            axis,
            line,
            source: Box::new(self),
        }
    }
}

/// A friction mode switch (for stick-slip analysis).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrictionEvent {
    /// Time (s).
    pub t_s: f64,
    /// Table position at the switch (m).
    pub x_m: f64,
    /// The new friction mode.
    pub to: FrictionMode,
}

/// Where along an axis's drive train a measurement reads its position.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "snake_case")]
pub enum MeasuredAt {
    /// A linear scale on the table (the model's table position, with its structural mode).
    #[default]
    Table,
    /// The motor's encoder: the screw, nut and their backlash lie beyond it.
    Motor,
    /// At the tool (a laser or ballbar between spindle and table). The model has no
    /// structure between table and tool beyond the structural mode, so it reads as `Table`.
    Tool,
}

impl MeasuredAt {
    /// The name as written on the command line and in reports.
    pub fn as_str(self) -> &'static str {
        match self {
            MeasuredAt::Table => "table",
            MeasuredAt::Motor => "motor",
            MeasuredAt::Tool => "tool",
        }
    }
}

/// What one axis did, sampled at the command period.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct AxisTrace {
    /// Sample period (s).
    pub dt_s: f64,
    /// Table position X2 (m), with the structural mode at the measured point when the
    /// model has one.
    pub pos_m: Vec<f64>,
    /// The motor's angle as table travel, r·i_t·θ_m (m): what a motor encoder reads.
    pub motor_pos_m: Vec<f64>,
    /// Reference position x_ref (m).
    pub ref_m: Vec<f64>,
    /// Motor speed (rad/s).
    pub motor_speed_rad_per_s: Vec<f64>,
    /// Armature current (A).
    pub current_a: Vec<f64>,
    /// Mode code ([`Mode::code`]).
    pub mode: Vec<u8>,
    /// Friction switches, when recorded.
    pub friction_events: Vec<FrictionEvent>,
}

impl AxisTrace {
    pub(crate) fn with_capacity(dt_s: f64, n: usize) -> Self {
        AxisTrace {
            dt_s,
            pos_m: Vec::with_capacity(n),
            motor_pos_m: Vec::with_capacity(n),
            ref_m: Vec::with_capacity(n),
            motor_speed_rad_per_s: Vec::with_capacity(n),
            current_a: Vec::with_capacity(n),
            mode: Vec::with_capacity(n),
            friction_events: Vec::new(),
        }
    }

    fn reserve(&mut self, more: usize) {
        self.pos_m.reserve(more);
        self.motor_pos_m.reserve(more);
        self.ref_m.reserve(more);
        self.motor_speed_rad_per_s.reserve(more);
        self.current_a.reserve(more);
        self.mode.reserve(more);
    }

    fn push(&mut self, x: &Aug, mode: Mode, model: &AxisModel) {
        let (motor_pos_m, motor_speed) = model.motor_reading(x);
        self.pos_m.push(x[X2]);
        self.motor_pos_m.push(motor_pos_m);
        self.ref_m.push(x[XR]);
        self.motor_speed_rad_per_s.push(motor_speed);
        self.current_a.push(x[I]);
        self.mode.push(mode.code());
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.pos_m.len()
    }

    /// Appends the samples (and friction switches) of the trace that follows this one.
    pub(crate) fn append(&mut self, mut next: AxisTrace) {
        self.pos_m.append(&mut next.pos_m);
        self.motor_pos_m.append(&mut next.motor_pos_m);
        self.ref_m.append(&mut next.ref_m);
        self.motor_speed_rad_per_s
            .append(&mut next.motor_speed_rad_per_s);
        self.current_a.append(&mut next.current_a);
        self.mode.append(&mut next.mode);
        self.friction_events.append(&mut next.friction_events);
    }

    /// True when empty.
    pub fn is_empty(&self) -> bool {
        self.pos_m.is_empty()
    }

    /// Takes the series a measurement at `point` reads, dropping the rest.
    pub(crate) fn into_read_at(self, point: MeasuredAt) -> Vec<f64> {
        match point {
            MeasuredAt::Table | MeasuredAt::Tool => self.pos_m,
            MeasuredAt::Motor => self.motor_pos_m,
        }
    }

    /// Following error x_ref − x_table at sample k (m).
    pub fn following_error_m(&self, k: usize) -> f64 {
        self.ref_m[k] - self.pos_m[k]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_placed_failure_names_axis_line_and_modes() {
        let e = SimError::Chattering {
            t_s: 297.999,
            modes: "stuck, nut driving +, current linear, voltage linear".into(),
        }
        .on_axis('X', Some(888));
        let shown = e.to_string();
        assert!(shown.starts_with("X axis, line 888: "), "{shown}");
        assert!(
            shown.contains("t = 297.999000 s") && shown.contains("stuck"),
            "{shown}"
        );
        assert_eq!(e.t_s(), Some(297.999));
        assert!(matches!(e.innermost(), SimError::Chattering { .. }));
    }
}
