//! One axis as docs/model.md §1 specifies it, in SI units: the parameters derived once from the
//! user's configuration, and the piecewise-linear state-space matrices of each mode — for
//! the paper's cascade, and for the other controller structures of `machine::controller`
//! (a transfer function or state feedback on an ideal current amplifier, whose states take
//! the places the current loop leaves free).
//!
//! State (13): current-command filter, current-feedback filter, current PI integral,
//! armature current, velocity PI integral, motor angle and speed, screw angle and speed,
//! table position and speed, reference position and velocity. Inputs held over a step (6):
//! reference acceleration, the constant 1 (for friction, backlash and limits), a feedback
//! offset, a nut-travel offset, an external table force and extra static friction. The
//! reference is part of the state so that a step's polynomial reference x_ref + v_ref·t +
//! a_ref·t²/2 is integrated exactly, and so that a step can be split at an event without
//! re-sampling it.

use nalgebra::{SMatrix, SVector};

use crate::machine::realise::Realisation;
use crate::machine::{ControllerOutput, Feedback};
use crate::numeric::lookup::Lookup;

mod config;
mod ripple;

pub use ripple::ForceRipple;

/// Number of states.
pub const N: usize = 13;
/// Number of states plus held inputs.
pub const NA: usize = 19;

/// Filtered current command (A). With a current amplifier the current loop's states (`FC`,
/// `FF`, `ZI`) are not needed: a transfer-function controller keeps its states there (and
/// in `ZW` when no velocity loop needs it), see [`CONTROLLER_SLOTS`].
pub const FC: usize = 0;
/// Filtered current feedback (A).
pub const FF: usize = 1;
/// Integral of the current error (A·s).
pub const ZI: usize = 2;
/// Armature current (A).
pub const I: usize = 3;
/// Integral of the speed error (rad).
pub const ZW: usize = 4;
/// Motor angle (rad).
pub const TH_M: usize = 5;
/// Motor speed (rad/s).
pub const W_M: usize = 6;
/// Screw angle (rad).
pub const TH_S: usize = 7;
/// Screw speed (rad/s).
pub const W_S: usize = 8;
/// Table position (m).
pub const X2: usize = 9;
/// Table speed (m/s).
pub const V2: usize = 10;
/// Reference position (m).
pub const XR: usize = 11;
/// Reference velocity (m/s).
pub const VR: usize = 12;
/// Input: reference acceleration (m/s²).
pub const AR: usize = 13;
/// Input: the constant 1.
pub const ONE: usize = 14;
/// Input: offset added to the position feedback (m) — scale errors.
pub const FB: usize = 15;
/// Input: offset added to the nut's travel (m) — lead errors, lateral shift.
pub const DL: usize = 16;
/// Input: external force against the table (N) — Stribeck excess, disturbances.
pub const FX: usize = 17;
/// Input: static friction beyond `f_s` where the table stands (N) — a friction map.
pub const FSX: usize = 18;

/// Where a transfer-function controller's states live, in order.
pub const CONTROLLER_SLOTS: [usize; 4] = [FC, FF, ZI, ZW];

/// Augmented state vector: states then held inputs.
pub type Aug = SVector<f64, NA>;
/// A linear functional on the augmented state.
pub type Row = SMatrix<f64, 1, NA>;
/// Augmented dynamics matrix (the input rows are zero).
pub type AugMatrix = SMatrix<f64, NA, NA>;

/// One axis in SI units (see docs/model.md §1 for the symbols).
#[derive(Debug, Clone, PartialEq)]
pub struct AxisModel {
    /// Position gain Kp (rad/s per m of error, at the motor).
    pub kp: f64,
    /// Velocity feed-forward factor.
    pub kf: f64,
    /// Acceleration feed-forward factor.
    pub ka: f64,
    /// Position feedback.
    pub feedback: Feedback,
    /// The controller's structure (the cascade uses `kp`, `ks`, `ts`).
    pub control: ControlModel,
    /// Time constant of an ideal current amplifier (s); `None`: the current loop and the
    /// armature are modelled (`ki`, `ti`, `tcf`, `u_max`, `ra`, `la`, `ke`).
    pub amplifier_tau: Option<f64>,
    /// Velocity P gain (A·s/rad).
    pub ks: f64,
    /// Velocity integral time (s).
    pub ts: f64,
    /// Limit of the current command (A): the velocity loop's, or the amplifier's peak.
    pub i_max: f64,
    /// Current P gain (V/A).
    pub ki: f64,
    /// Current integral time (s).
    pub ti: f64,
    /// Current filter time constant (s).
    pub tcf: f64,
    /// Voltage limit (V).
    pub u_max: f64,
    /// Armature resistance (Ω).
    pub ra: f64,
    /// Armature inductance (H).
    pub la: f64,
    /// Torque constant (N·m/A).
    pub kt: f64,
    /// Back-EMF constant (V·s/rad).
    pub ke: f64,
    /// Rotor inertia (kg·m²).
    pub jm: f64,
    /// Screw inertia (kg·m²).
    pub js: f64,
    /// Torsional stiffness (N·m/rad).
    pub k_theta: f64,
    /// Torsional damping (N·m·s/rad).
    pub c_theta: f64,
    /// Axial stiffness (N/m).
    pub k_m: f64,
    /// Axial damping while in contact (N·s/m).
    pub c_m: f64,
    /// Lead factor r = P/2π (m/rad).
    pub r: f64,
    /// Gear ratio i_t (screw angle per motor angle).
    pub it: f64,
    /// Table mass (kg); with a linear motor, the whole moving mass.
    pub mt: f64,
    /// A linear motor drives the table directly: no motor, coupling, screw or nut states.
    pub linear_motor: bool,
    /// Screw bearing damping (N·m·s/rad).
    pub b_screw: f64,
    /// Half of the backlash gap e = b/2 (m).
    pub half_gap: f64,
    /// Coulomb friction force (N).
    pub f_c: f64,
    /// Static friction force (N).
    pub f_s: f64,
    /// Viscous friction coefficient (N·s/m).
    pub f_v: f64,
    /// Lateral shift of the screw, if this axis carries the tool holder along a beam.
    pub lateral: Option<LateralShiftModel>,
    /// Dead time of the commands (s).
    pub dead_time_s: f64,
    /// Stribeck friction: extra level (N) and velocity (m/s); `None` when off.
    pub stribeck: Option<(f64, f64)>,
    /// Coulomb (and static) friction added by the table's position: N by m.
    pub friction_map: Lookup,
    /// Sliding friction added by the table's speed: N by m/s.
    pub friction_speed: Lookup,
    /// A force repeating with the table's position; `None` when off.
    pub force_ripple: Option<ForceRipple>,
    /// Presliding (LuGre) friction in place of stick and slip; `None` when off.
    pub presliding: Option<super::presliding::Presliding>,
    /// Error of the measuring system (scale, or lead in semi-closed loop).
    pub measuring: MeasuringError,
    /// Structural mode between the table and the measured point: ω (rad/s) and ζ.
    pub resonance: Option<(f64, f64)>,
    /// A vertical axis's load F_g = M_T·g − F_cb (N), pulling the table towards −; zero on
    /// a horizontal axis (docs/model.md §1.8).
    pub load_n: f64,
    /// A force the axis holds at rest at the start of its run (N, + pushing the table
    /// towards +): its integral action pushing against the friction that keeps the table
    /// where an earlier move left it (docs/model.md §1.10). A state of a record's start, not
    /// of the machine: no machine file sets it; zero from [`AxisModel::from_config`]. The
    /// run starts with at most the friction's level at rest of it
    /// ([`AxisModel::held_at_start_bounded_n`]).
    pub held_at_start_n: f64,
}

/// How the axis is controlled, in SI units.
#[derive(Debug, Clone, PartialEq)]
pub enum ControlModel {
    /// P position, PI velocity (`kp`, `kf`, `ks`, `ts`).
    Cascade,
    /// A position controller C(s) from the error (mm) to current (A) or table speed (m/min),
    /// its states in [`CONTROLLER_SLOTS`].
    Transfer {
        /// The controller's states.
        realisation: Realisation,
        /// What it commands.
        output: ControllerOutput,
    },
    /// Current = kx·e + kz·∫e + kd·(kf·v_ref − v), in SI (A/m, A/(m·s), A·s/m); ∫e in `ZW`.
    StateFeedback {
        /// On the position error.
        kx: f64,
        /// On its integral.
        kz: f64,
        /// On the speed error.
        kd: f64,
    },
}

/// An integrator behind a limited output y = … + g·z: its state, what it integrates and g.
pub struct Integrator {
    /// Its index in the state.
    pub slot: usize,
    /// What it integrates.
    pub integrand: Row,
    /// ∂y/∂z.
    pub gain: f64,
}

/// A limited controller output: the unclamped value, the limit and the integrator to hold.
pub struct Limited {
    /// The output before the limit.
    pub output: Row,
    /// Its limit (±).
    pub limit: f64,
    /// The integrator stopped at the limit (anti-windup), where the output has one.
    pub integrator: Option<Integrator>,
}

/// Error of the measuring system as a function of position: e(x) = s·x + A·sin(k·x + φ).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct MeasuringError {
    /// Scale factor error s.
    pub scale: f64,
    /// Cyclic amplitude A (m).
    pub amplitude_m: f64,
    /// Wavenumber k = 2π/period (rad/m).
    pub wavenumber_per_m: f64,
    /// Phase φ (rad).
    pub phase_rad: f64,
}

impl MeasuringError {
    /// True when there is any error.
    pub(crate) fn is_active(&self) -> bool {
        self.scale != 0.0 || self.amplitude_m != 0.0
    }

    /// e(x) (m).
    pub(crate) fn at(&self, x: f64) -> f64 {
        self.scale * x + self.amplitude_m * (self.wavenumber_per_m * x + self.phase_rad).sin()
    }
}

/// Beam sag that scales the lead (docs/model.md §1.7).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LateralShiftModel {
    /// Beam length l (m).
    pub l: f64,
    /// Bending stiffness EI (N·m²).
    pub ei: f64,
    /// Holder weight F (N).
    pub load: f64,
    /// Holder distance from the left end when the axis is at 0 (m).
    pub a0: f64,
}

impl LateralShiftModel {
    /// The lead scale K_λ = b/√(b² + y_a²) with the holder at axis position `x` (m), where
    /// y_a = F a² b² / (3 l EI) is the sag under the holder (a from the left end, b = l − a).
    pub(crate) fn k_lambda(&self, x: f64) -> f64 {
        let a = (self.a0 + x).clamp(0.0, self.l);
        let b = self.l - a;
        if b <= 0.0 {
            return 1.0;
        }
        let ya = self.load * a * a * b * b / (3.0 * self.l * self.ei);
        b / (b * b + ya * ya).sqrt()
    }
}

impl AxisModel {
    /// Whether the axis's inputs change within an interpolation cycle (Stribeck friction
    /// and measuring errors are evaluated at every simulation step). Without them every
    /// mode's dynamics is linear with inputs known in closed form over the cycle, integrated
    /// exactly, and mode switches are located inside a step: one step per cycle gives the
    /// same trace as finer ones.
    pub(crate) fn inputs_vary_within_cycle(&self) -> bool {
        self.has_friction_inputs() || self.measuring.is_active()
    }

    /// Whether friction beyond Coulomb's and the viscous term, or a force ripple, is held
    /// per sub-step (Stribeck, friction maps, the ripple).
    pub(crate) fn has_friction_inputs(&self) -> bool {
        self.stribeck.is_some()
            || self.has_friction_maps()
            || self.force_ripple.is_some()
            || self.presliding.is_some()
    }

    /// Whether friction maps (by position or speed) add to the friction.
    pub(crate) fn has_friction_maps(&self) -> bool {
        !self.friction_map.is_empty() || !self.friction_speed.is_empty()
    }

    /// The friction the maps add (N, ≥ −f_c in all: friction never pulls) with the table
    /// at `x` m: (sliding at `|v|` m/s, static).
    pub(crate) fn friction_added_n(&self, x: f64, v: f64) -> (f64, f64) {
        let here = self.friction_map.at(x).max(-self.f_c);
        let sliding = (here + self.friction_speed.at(v.abs())).max(-self.f_c);
        (sliding, here)
    }

    /// Total inertia reflected to the motor, J_m + i_t² J_s + (r i_t)² M_T (kg·m²).
    pub fn j_tot(&self) -> f64 {
        self.jm + self.it * self.it * self.js + (self.r * self.it).powi(2) * self.mt
    }

    /// Table travel per motor radian, r·i_t (m/rad).
    pub fn travel_per_motor_rad(&self) -> f64 {
        self.r * self.it
    }

    /// The whole drive's inertia as a mass moving with the table, J_tot/(r·i_t)² (kg).
    pub(crate) fn mass_at_table_kg(&self) -> f64 {
        self.j_tot() / self.travel_per_motor_rad().powi(2)
    }

    /// The position gain as the CNC shows it, Kv = Kp·r·i_t (1/s).
    pub fn kv_per_s(&self) -> f64 {
        self.kp * self.r * self.it
    }

    /// The friction's levels at rest with the table at `x` m (N), against a push towards +
    /// and towards −: the most that stuck friction (or the bristles) holds before the table
    /// slides — the static level (below Coulomb's, or another towards −, where the bristles
    /// have it so) plus what the position's map adds.
    pub fn rest_friction_n(&self, x: f64) -> [f64; 2] {
        let mapped = if self.has_friction_maps() {
            self.friction_added_n(x, 0.0).1
        } else {
            0.0
        };
        let rest_n = self.presliding.map_or([self.f_s; 2], |p| p.rest_n);
        rest_n.map(|level| (level + mapped).max(0.0))
    }

    /// The force held at the start (N), within the friction's level at rest at `x` m on its
    /// side: a table held by friction holds no more than that, and a push beyond it would
    /// have moved the table before the run began.
    pub fn held_at_start_bounded_n(&self, x: f64) -> f64 {
        let [plus, minus] = self.rest_friction_n(x);
        self.held_at_start_n.clamp(-minus, plus)
    }

    /// True when the axis has backlash (a gap to cross at reversals).
    pub(crate) fn has_backlash(&self) -> bool {
        self.half_gap > 0.0
    }
}

/// Friction state of the table.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum FrictionMode {
    /// Sliding forward (V2 > 0).
    SlipPos,
    /// Sliding backward (V2 < 0).
    SlipNeg,
    /// Stuck (V2 = 0).
    Stick,
}

/// Contact state of the screw–nut gap.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ContactMode {
    /// Driving forward (δ > e).
    Pos,
    /// Inside the gap (|δ| ≤ e): no force.
    Free,
    /// Driving backward (δ < −e).
    Neg,
}

/// State of a limited controller output with its integrator.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ClampMode {
    /// Within the limits; the integrator runs.
    Linear,
    /// At the upper limit, integrator held.
    HeldHi,
    /// At the upper limit, integrator following it (releasing would re-saturate at once).
    SlideHi,
    /// At the lower limit, integrator held.
    HeldLo,
    /// At the lower limit, integrator following it.
    SlideLo,
}

impl ClampMode {
    /// The output's value when clamped: Some(+1) high, Some(−1) low.
    fn side(self) -> Option<f64> {
        match self {
            ClampMode::Linear => None,
            ClampMode::HeldHi | ClampMode::SlideHi => Some(1.0),
            ClampMode::HeldLo | ClampMode::SlideLo => Some(-1.0),
        }
    }
}

impl std::fmt::Display for Mode {
    /// In words, e.g. "stuck, nut driving +, current linear, voltage linear".
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let friction = match self.friction {
            FrictionMode::SlipPos => "sliding +",
            FrictionMode::SlipNeg => "sliding −",
            FrictionMode::Stick => "stuck",
        };
        let contact = match self.contact {
            ContactMode::Pos => "nut driving +",
            ContactMode::Free => "nut in its gap",
            ContactMode::Neg => "nut driving −",
        };
        let clamp = |c: ClampMode| match c {
            ClampMode::Linear => "linear",
            ClampMode::HeldHi | ClampMode::SlideHi => "at its upper limit",
            ClampMode::HeldLo | ClampMode::SlideLo => "at its lower limit",
        };
        write!(
            f,
            "{friction}, {contact}, current {}, voltage {}",
            clamp(self.current),
            clamp(self.voltage)
        )
    }
}

/// The full mode of the piecewise-linear axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Mode {
    /// Table friction.
    pub friction: FrictionMode,
    /// Screw–nut contact.
    pub contact: ContactMode,
    /// Current-command limit (velocity controller output).
    pub current: ClampMode,
    /// Voltage limit (current controller output).
    pub voltage: ClampMode,
}

impl Mode {
    /// Number of distinct modes.
    pub const COUNT: usize = 3 * 3 * 5 * 5;

    /// A dense index in 0..COUNT.
    pub(crate) fn index(self) -> usize {
        let f = self.friction as usize;
        let c = self.contact as usize;
        ((f * 3 + c) * 5 + self.current as usize) * 5 + self.voltage as usize
    }

    /// A compact code for traces: friction (0 slip+, 1 slip−, 2 stick) + 3·contact
    /// (0 pos, 1 free, 2 neg) + 9 when a limit is active.
    pub(crate) fn code(self) -> u8 {
        let limited = self.current != ClampMode::Linear || self.voltage != ClampMode::Linear;
        self.friction as u8 + 3 * self.contact as u8 + if limited { 9 } else { 0 }
    }

    /// Whether a trace's mode code ([`Mode::code`]) has a current or voltage limit active.
    pub(crate) fn code_is_limited(code: u8) -> bool {
        code >= 9
    }
}

fn unit(i: usize) -> Row {
    let mut r = Row::zeros();
    r[i] = 1.0;
    r
}

/// The linear functionals the model is built from (rows over the augmented state).
pub struct Signals {
    /// Position feedback x_fb.
    pub x_fb: Row,
    /// Position error x_ref − x_fb.
    pub e: Row,
    /// Speed command ω_cmd (zero without a velocity loop).
    pub w_cmd: Row,
    /// Speed error e_ω (zero without a velocity loop).
    pub e_w: Row,
    /// Unclamped current command.
    pub i_cmd_raw: Row,
    /// Current error e_i (filtered).
    pub e_i: Row,
    /// Unclamped voltage.
    pub u_raw: Row,
    /// Screw–nut relative travel δ.
    pub delta: Row,
    /// Its rate.
    pub delta_rate: Row,
    /// Coupling torque.
    pub t_c: Row,
}

/// Millimetres per metre: transfer functions and state-feedback gains take the error in mm.
const MM_PER_M: f64 = 1e3;

impl AxisModel {
    /// Whether the drive closes a velocity loop (the cascade, a velocity-mode drive).
    pub(crate) fn has_velocity_loop(&self) -> bool {
        match &self.control {
            ControlModel::Cascade => true,
            ControlModel::Transfer { output, .. } => *output == ControllerOutput::Velocity,
            ControlModel::StateFeedback { .. } => false,
        }
    }

    /// Whether the current loop and the armature are modelled (else an ideal amplifier).
    pub(crate) fn has_current_loop(&self) -> bool {
        self.amplifier_tau.is_none()
    }

    /// The states the axis uses (indices below `XR`): the mechanics and the current always;
    /// the current loop's filters and integral, the velocity (or error) integral and a
    /// transfer function's states where the structure has them.
    pub(crate) fn active_states(&self) -> Vec<usize> {
        let mut states = if self.linear_motor {
            vec![I, X2, V2]
        } else {
            vec![I, TH_M, W_M, TH_S, W_S, X2, V2]
        };
        if self.has_current_loop() {
            states.extend([FC, FF, ZI]);
        }
        let integral = match &self.control {
            ControlModel::StateFeedback { kz, .. } => *kz > 0.0,
            _ => self.has_velocity_loop(),
        };
        if integral {
            states.push(ZW);
        }
        if let Some((_, slots)) = self.transfer_states() {
            states.extend(
                slots
                    .iter()
                    .filter(|s| !states.contains(s))
                    .collect::<Vec<_>>(),
            );
        }
        states.sort_unstable();
        states
    }

    /// The state the current command drives and the rate it does so with: the command
    /// filter of a current loop, or the current of an ideal amplifier.
    pub(crate) fn current_command_target(&self) -> (usize, f64) {
        match self.amplifier_tau {
            None => (FC, 1.0 / self.tcf),
            Some(tau) => (I, 1.0 / tau),
        }
    }

    /// A transfer-function controller's states (slot, realisation).
    fn transfer_states(&self) -> Option<(&Realisation, &[usize])> {
        match &self.control {
            ControlModel::Transfer { realisation, .. } => {
                Some((realisation, &CONTROLLER_SLOTS[..realisation.order()]))
            }
            _ => None,
        }
    }

    /// The model's signals as functionals of the augmented state.
    pub(crate) fn signals(&self) -> Signals {
        let x_fb = match self.feedback {
            Feedback::LinearScale => unit(X2) + unit(FB),
            Feedback::MotorEncoder => unit(TH_S) * self.r + unit(FB),
        };
        let e = unit(XR) - x_fb;
        let rit = self.r * self.it;
        let speed = self.motor_speed_row();
        let velocity_ff = unit(VR) * (self.kf / rit);
        let i_ff = unit(AR) * (self.ka * self.j_tot() / (rit * self.kt));
        // The transfer function's output in its own unit (A or m/min).
        let transfer_output = self.transfer_states().map(|(r, slots)| {
            slots
                .iter()
                .zip(&r.c)
                .fold(e * (MM_PER_M * r.d), |acc, (&slot, &c)| {
                    acc + unit(slot) * c
                })
        });
        let w_cmd = match (&self.control, &transfer_output) {
            (ControlModel::Cascade, _) => e * self.kp + velocity_ff,
            (
                ControlModel::Transfer {
                    output: ControllerOutput::Velocity,
                    ..
                },
                Some(y),
            ) => {
                // m/min of table speed → rad/s at the motor.
                *y * (1.0 / (60.0 * rit)) + velocity_ff
            }
            _ => Row::zeros(),
        };
        let e_w = if self.has_velocity_loop() {
            w_cmd - speed
        } else {
            Row::zeros()
        };
        let i_cmd_raw = i_ff
            + match (&self.control, transfer_output) {
                (
                    ControlModel::Transfer {
                        output: ControllerOutput::Current,
                        ..
                    },
                    Some(y),
                ) => y,
                (ControlModel::StateFeedback { kx, kz, kd }, _) => {
                    e * *kx + unit(ZW) * *kz + (unit(VR) * self.kf - speed * rit) * *kd
                }
                _ => (e_w + unit(ZW) / self.ts) * self.ks,
            };
        let e_i = unit(FC) - unit(FF);
        let u_raw = (e_i + unit(ZI) / self.ti) * self.ki;
        let delta = unit(TH_S) * self.r - unit(X2) + unit(DL);
        let delta_rate = unit(W_S) * self.r - unit(V2);
        let t_c = (unit(TH_M) * self.it - unit(TH_S)) * self.k_theta
            + (unit(W_M) * self.it - unit(W_S)) * self.c_theta;
        Signals {
            x_fb,
            e,
            w_cmd,
            e_w,
            i_cmd_raw,
            e_i,
            u_raw,
            delta,
            delta_rate,
            t_c,
        }
    }

    /// The current command with its limit and the integrator that stops at it: the velocity
    /// loop's (cascade, velocity-mode drive), state feedback's error integral, or none (a
    /// transfer function's states run on at the limit).
    pub(crate) fn current_command(&self, s: &Signals) -> Limited {
        let integrator = match &self.control {
            ControlModel::StateFeedback { kz, .. } => (*kz > 0.0).then_some(Integrator {
                slot: ZW,
                integrand: s.e,
                gain: *kz,
            }),
            _ if self.has_velocity_loop() => Some(Integrator {
                slot: ZW,
                integrand: s.e_w,
                gain: self.ks / self.ts,
            }),
            _ => None,
        };
        Limited {
            output: s.i_cmd_raw,
            limit: self.i_max,
            integrator,
        }
    }

    /// The voltage with its limit and the current integral, where the current loop is
    /// modelled.
    pub(crate) fn voltage_command(&self, s: &Signals) -> Option<Limited> {
        self.has_current_loop().then(|| Limited {
            output: s.u_raw,
            limit: self.u_max,
            integrator: Some(Integrator {
                slot: ZI,
                integrand: s.e_i,
                gain: self.ki / self.ti,
            }),
        })
    }

    /// The motor's speed (rad/s; a linear motor's in m/s, its table's).
    pub(crate) fn motor_speed_row(&self) -> Row {
        if self.linear_motor {
            unit(V2)
        } else {
            unit(W_M)
        }
    }

    /// What a motor encoder reads (m of table travel) and the motor's speed (rad/s) in the
    /// state `x`.
    pub(crate) fn motor_reading(&self, x: &Aug) -> (f64, f64) {
        if self.linear_motor {
            (x[X2], x[V2])
        } else {
            (self.r * self.it * x[TH_M], x[W_M])
        }
    }

    /// The force that drives the table (N): the nut's in a contact mode, or a linear motor's.
    pub(crate) fn nut_force(&self, s: &Signals, contact: ContactMode) -> Row {
        if self.linear_motor {
            return unit(I) * self.kt;
        }
        let spring =
            |offset: f64| (s.delta + unit(ONE) * offset) * self.k_m + s.delta_rate * self.c_m;
        match contact {
            ContactMode::Pos => spring(-self.half_gap),
            ContactMode::Free => Row::zeros(),
            ContactMode::Neg => spring(self.half_gap),
        }
    }

    /// The force against the table besides friction (N): the held input `FX` and, on a
    /// vertical axis, the load.
    pub(crate) fn external_force(&self) -> Row {
        if self.load_n == 0.0 {
            unit(FX)
        } else {
            unit(FX) + unit(ONE) * self.load_n
        }
    }

    /// The force that would move a stuck table, F_e = F_n − F_ext (N), in a contact mode:
    /// it breaks away once |F_e| reaches the static friction.
    pub(crate) fn breakaway_force(&self, s: &Signals, contact: ContactMode) -> Row {
        self.nut_force(s, contact) - self.external_force()
    }

    /// The augmented dynamics matrix of a mode: d/dt [x; u] = A [x; u] (input rows zero).
    pub(crate) fn dynamics(&self, mode: Mode) -> AugMatrix {
        let s = self.signals();
        let mut a = AugMatrix::zeros();
        let mut set = |i: usize, row: Row| a.set_row(i, &row);
        let clamped = |m: ClampMode, raw: Row, limit: f64| match m.side() {
            Some(side) => unit(ONE) * (side * limit),
            None => raw,
        };
        let i_cmd = clamped(mode.current, s.i_cmd_raw, self.i_max);
        match self.amplifier_tau {
            None => {
                let u = clamped(mode.voltage, s.u_raw, self.u_max);
                set(FC, (i_cmd - unit(FC)) / self.tcf);
                set(FF, (unit(I) - unit(FF)) / self.tcf);
                let back_emf = self.motor_speed_row() * self.ke;
                set(I, (u - unit(I) * self.ra - back_emf) / self.la);
            }
            Some(tau) => set(I, (i_cmd - unit(I)) / tau),
        }
        if let Some((r, slots)) = self.transfer_states() {
            for (k, &slot) in slots.iter().enumerate() {
                let row = r
                    .a_row(k)
                    .into_iter()
                    .fold(s.e * (MM_PER_M * r.b(k)), |acc, (j, c)| {
                        acc + unit(slots[j]) * c
                    });
                set(slot, row);
            }
        }
        let f_n = self.nut_force(&s, mode.contact);
        if !self.linear_motor {
            set(TH_M, unit(W_M));
            set(W_M, (unit(I) * self.kt - s.t_c * self.it) / self.jm);
            set(TH_S, unit(W_S));
            set(
                W_S,
                (s.t_c - unit(W_S) * self.b_screw - f_n * self.r) / self.js,
            );
        }
        match mode.friction {
            FrictionMode::Stick => {}
            slip => {
                let sign = if slip == FrictionMode::SlipPos {
                    1.0
                } else {
                    -1.0
                };
                set(X2, unit(V2));
                // Presliding friction is all in the held input FX (sim::presliding).
                let coulomb = if self.presliding.is_some() {
                    0.0
                } else {
                    sign * self.f_c
                };
                let friction = unit(V2) * self.f_v + unit(ONE) * coulomb;
                set(V2, (f_n - friction - self.external_force()) / self.mt);
            }
        }
        set(XR, unit(VR));
        set(VR, unit(AR));
        // Integrators last: a sliding one follows its limit, which needs the other rows.
        let rows: Vec<(usize, Row)> = [
            (mode.voltage, self.voltage_command(&s)),
            (mode.current, Some(self.current_command(&s))),
        ]
        .into_iter()
        .filter_map(|(m, limited)| {
            let limited = limited?;
            let z = limited.integrator.as_ref()?;
            Some((z.slot, integrator_row(m, &limited, z, &a)))
        })
        .collect();
        for (slot, row) in rows {
            a.set_row(slot, &row);
        }
        a
    }
}

/// Row of the integrator z behind a limited output y = … + g·z: running (dz = its
/// integrand), held (dz = 0), or following the limit (dz = −(dy/dt with z held)/g, which keeps
/// y constant). `a` has the integrators' rows still zero.
fn integrator_row(mode: ClampMode, limited: &Limited, z: &Integrator, a: &AugMatrix) -> Row {
    match mode {
        ClampMode::Linear => z.integrand,
        ClampMode::HeldHi | ClampMode::HeldLo => Row::zeros(),
        ClampMode::SlideHi | ClampMode::SlideLo => (limited.output * a) * (-1.0 / z.gain),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::machine::MachineConfig;

    fn hvmc() -> AxisModel {
        AxisModel::from_config(&MachineConfig::default_preset().x)
    }

    /// A force held at the start lies within the friction's level on its own side: a guideway
    /// holding 0.1 of Coulomb's near rest towards + and 1.4 towards − holds a push of 0.5
    /// of Coulomb's towards − as it is, and the same push towards + only up to 0.1.
    #[test]
    fn a_held_force_is_bounded_by_the_level_on_its_side() {
        let mut x = MachineConfig::preset("small-table").unwrap().x;
        let f = &mut x.friction;
        (f.bristle_stiffness_n_per_um, f.bristle_damping_n_s_per_m) = (50.0, 1e4);
        (f.static_to_coulomb, f.static_to_coulomb_negative) = (0.1, Some(1.4));
        (f.stribeck_level_n, f.stribeck_velocity_mm_per_min) = (0.0, 600.0);
        let f_c = f.coulomb_n(x.drive.table_mass_kg);
        let mut held = |force_n: f64| {
            x.held_at_start_n = force_n;
            AxisModel::from_config(&x).held_at_start_bounded_n(0.0)
        };
        assert!((held(-0.5 * f_c) + 0.5 * f_c).abs() < 1e-9);
        assert!((held(0.5 * f_c) - 0.1 * f_c).abs() < 1e-9);
        assert!((held(-2.0 * f_c) + 1.4 * f_c).abs() < 1e-9);
    }

    #[test]
    fn derived_parameters_match_model_md() {
        let m = hvmc();
        // Kp = 26.18e3 rad/s/m is Kv = 1 m/min/mm with P = 16 mm, i_t = 0.25.
        assert!((m.kp - 26_179.94).abs() < 0.01, "{}", m.kp);
        assert!((m.j_tot() - 0.024557).abs() < 1e-6, "{}", m.j_tot());
        assert!((m.ks - 16.0 / 2.34).abs() < 1e-12);
        assert!((m.f_c - 588.6).abs() < 1e-9);
        assert!((m.f_s - m.f_c - 76.518).abs() < 1e-9);
        // K_λ − 1 at the beam centre ≈ −5.6e-10 (docs/model.md §2).
        let k = m.lateral.unwrap().k_lambda(0.0) - 1.0;
        assert!((k + 5.6e-10).abs() < 0.1e-10, "{k:e}");
    }

    #[test]
    fn rigid_motion_is_an_equilibrium_of_the_mechanics() {
        // Everything displaced together, no current: no acceleration anywhere.
        let m = hvmc();
        let a = m.dynamics(Mode {
            friction: FrictionMode::SlipPos,
            contact: ContactMode::Pos,
            current: ClampMode::Linear,
            voltage: ClampMode::Linear,
        });
        let mut x = Aug::zeros();
        x[X2] = 0.3;
        x[TH_S] = 0.3 / m.r;
        x[TH_M] = x[TH_S] / m.it;
        x[XR] = 0.3;
        let dx = a * x;
        // Rounding of the 118 rad screw angle times K_θ = 4e7 N·m/rad leaves ~1e-6 N·m.
        for i in [W_M, W_S, V2, FC, I] {
            assert!(dx[i].abs() < 1e-3, "state {i}: {}", dx[i]);
        }
    }
}
