//! Machine configuration: one TOML file, one section per axis, every value in the unit a CNC
//! engineer reads off the control (Kv in m/min/mm, K_s in N·m·s/rad, backlash in µm).
//!
//! The paper's machine is embedded as the preset `hvmc` (see `hvmc.toml`, which documents
//! every key with its unit and source). A user file starts from a preset (`base = "hvmc"`,
//! the default) and overrides only the keys it names. Loading validates the whole machine
//! before anything runs: a missing, negative, non-finite or inconsistent value is an error
//! naming the key and the file.
//!
//! The sections' types are here; the file is read and written in `file`, its keys' names,
//! units and ranges listed once in [`keys`].

mod alternatives;
mod base;
mod controller;
mod file;
pub mod keys;
pub mod locate;
pub mod realise;
mod sections;
mod validate;

pub use controller::{Amplifier, Controller, ControllerOutput, StateFeedback, TransferFunction};
pub use file::ConfigError;

use serde::{Deserialize, Serialize};

/// The embedded presets: name and TOML text.
pub const PRESETS: [(&str, &str); 2] = [
    ("hvmc", include_str!("hvmc.toml")),
    ("small-table", include_str!("small-table.toml")),
];

/// The most points a position map may have.
pub const POSITION_MAP_POINTS: usize = 256;

/// The default preset's name.
pub const DEFAULT_PRESET: &str = "hvmc";

/// The farthest an axis's travel may reach from zero (mm): a kilometre, beyond any machine.
pub const MAX_TRAVEL_MM: f64 = 1e6;

/// A whole machine: interpolation settings, the simulated X and Y axes, and Z — simulated
/// like them where the file gives its sections, else planned and carried.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MachineConfig {
    /// Short name, shown in reports.
    pub name: String,
    /// One-line description.
    pub description: String,
    /// Interpolator settings.
    pub interpolation: Interpolation,
    /// X axis.
    pub x: AxisConfig,
    /// Y axis.
    pub y: AxisConfig,
    /// Z axis: simulated like X and Y (`[z.*]` with their keys), or only its kinematic
    /// limits (`[z.limits]` alone: planned, and carried where it is commanded).
    pub z: ZAxis,
}

/// The Z axis of a machine.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(untagged)]
pub enum ZAxis {
    /// Planned (its moves take their time) but not simulated: the tool stands in Z where it
    /// is commanded.
    Carried(PlannedAxis),
    /// Simulated like X and Y.
    Simulated(Box<AxisConfig>),
}

impl ZAxis {
    /// Its kinematic limits.
    pub fn limits(&self) -> &Limits {
        match self {
            ZAxis::Carried(p) => &p.limits,
            ZAxis::Simulated(a) => &a.limits,
        }
    }

    /// Its kinematic limits, mutably.
    pub fn limits_mut(&mut self) -> &mut Limits {
        match self {
            ZAxis::Carried(p) => &mut p.limits,
            ZAxis::Simulated(a) => &mut a.limits,
        }
    }

    /// The axis, where it is simulated.
    pub(crate) fn simulated(&self) -> Option<&AxisConfig> {
        match self {
            ZAxis::Carried(_) => None,
            ZAxis::Simulated(a) => Some(a),
        }
    }
}

/// A section `[z]` with nothing but `limits` is a carried axis; any other section makes it
/// simulated, with all of an axis's sections. (The machine file's reader takes a simulated
/// Z apart first, so that its errors name the key; this serves other readers.)
impl<'de> Deserialize<'de> for ZAxis {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        use serde::de::Error;
        let table = toml::Table::deserialize(d)?;
        if table.keys().all(|k| k == "limits") {
            PlannedAxis::deserialize(toml::Value::Table(table))
                .map(ZAxis::Carried)
                .map_err(D::Error::custom)
        } else {
            AxisConfig::deserialize(toml::Value::Table(table))
                .map(|a| ZAxis::Simulated(Box::new(a)))
                .map_err(D::Error::custom)
        }
    }
}

/// Interpolator settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Interpolation {
    /// Interpolation (IPO) cycle: the period of the position commands (ms).
    pub cycle_ms: f64,
    /// Exact-stop window (mm): after a rapid or an exact stop (G61) the next block starts
    /// only when every axis's following error is this small.
    pub in_position_window_mm: f64,
    /// Share of an axis's acceleration an arc may spend on centripetal acceleration (0–1);
    /// the path's tangential acceleration gets √(1 − share²).
    #[serde(default = "default_arc_normal_share")]
    pub arc_normal_share: f64,
    /// Limit on the path (tangential) acceleration beside the axes' own (m/s²), as a
    /// control's path-acceleration setting; none: the axes alone limit it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub path_accel_m_per_s2: Option<f64>,
    /// Limit on the path jerk (m/s³); none: the axes alone limit it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub path_jerk_m_per_s3: Option<f64>,
}

fn default_arc_normal_share() -> f64 {
    0.5
}

/// One simulated feed axis.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AxisConfig {
    /// The controller's structure; the cascade when not given.
    #[serde(default, skip_serializing_if = "Controller::is_cascade")]
    pub controller: Controller,
    /// Position loop (P + feed-forward); its feedback and dead time hold for every
    /// controller structure.
    pub position_loop: PositionLoop,
    /// Velocity loop (PI): the cascade's, or a velocity-mode drive's.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub velocity_loop: Option<VelocityLoop>,
    /// Current loop (PI with filters), with the motor's electrical data; or …
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub current_loop: Option<CurrentLoop>,
    /// … a current amplifier taken as ideal up to its bandwidth.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub amplifier: Option<Amplifier>,
    /// Servo motor.
    pub motor: Motor,
    /// Coupling, ball screw, nut and table.
    pub drive: Drive,
    /// Guideway friction at the table.
    pub friction: Friction,
    /// Lateral shift of the screw from beam sag (only on the axis that moves the tool
    /// holder along the beam).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lateral_shift: Option<LateralShift>,
    /// Kinematic limits for the planner.
    pub limits: Limits,
    /// Errors outside the paper's model (measuring system, structure); all off by default.
    /// `contourcheck diagnose` fits them from measurements.
    #[serde(default)]
    pub errors: Errors,
    /// A vertical axis (+ up) carries its weight (docs/model.md §1.8); none on a horizontal
    /// one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gravity: Option<Gravity>,
    /// The force the axis holds at rest at a record's start (N, + pushing the table towards
    /// +; docs/model.md §1.10): a state of one record, not of the machine — set in memory
    /// while a record is identified, never read from or written to a machine file.
    #[serde(skip)]
    pub held_at_start_n: f64,
}

/// The weight a vertical axis carries: the moving mass's, less a counterbalance.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Gravity {
    /// The force of a counterbalance (a balancing cylinder or counterweight) pushing the
    /// axis up (N); 0 where there is none.
    #[serde(default)]
    pub counterbalance_n: f64,
}

fn default_straightness_span_mm() -> f64 {
    1000.0
}

/// Effects outside the nominal model (docs/model.md §5), each off at zero.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Errors {
    /// Scale (full closed loop) or lead (semi-closed loop) error proportional to position
    /// (ppm): the measuring system reads this much too long.
    pub scale_error_ppm: f64,
    /// Amplitude of a cyclic error of the measuring system (µm).
    pub cyclic_amplitude_um: f64,
    /// Its period (mm); 0 means the ball-screw lead.
    pub cyclic_period_mm: f64,
    /// Its phase at position 0 (degrees).
    pub cyclic_phase_deg: f64,
    /// Natural frequency of a structural mode between the table and the measured point,
    /// excited by the table's acceleration (Hz); 0 = none.
    pub resonance_hz: f64,
    /// Its damping ratio.
    pub resonance_damping: f64,
    /// Squareness of the other axis to this one (µrad): this axis reads α times the other
    /// axis's position more (on X: the Y axis leans towards +X). Geometric, between the
    /// scales and the tool: the servo loops do not see it.
    pub squareness_urad: f64,
    /// Straightness of the other axis's travel seen on this one: the bow (µm) of its middle
    /// towards + this axis from the line through the ends of the span below; this axis
    /// reads −bow·(2q/span)² more with the other axis at q.
    pub straightness_bow_um: f64,
    /// The span the bow is given over (mm), centred on the other axis's zero.
    #[serde(default = "default_straightness_span_mm")]
    pub straightness_span_mm: f64,
    /// A position-dependent error beyond the scale (the tool standing off where the scale
    /// says the axis is), as a compensation table holds it: positions (mm, increasing) …
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub position_map_mm: Vec<f64>,
    /// … and the error there (µm), linear in between and held beyond the ends. Learned by
    /// `diagnose` where a residual follows the axis's position and no catalogue cause
    /// explains it.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub position_map_um: Vec<f64>,
    /// Play across the other axis's reversals (µm): this axis reads +½ of it while the other
    /// axis last travelled towards its +, −½ towards its − (a step at each of its reversals).
    /// Geometric, beyond the scales.
    pub lateral_play_um: f64,
    /// Lost motion beyond the scale (µm): this axis reads +½ of it while it last travelled
    /// towards +, −½ towards −. The loop, closed on the scale, cannot take it out.
    pub direction_offset_um: f64,
    /// Friction that depends on where the table is (a tight spot on a guideway): positions
    /// (mm, increasing) …
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub friction_map_mm: Vec<f64>,
    /// … and the Coulomb friction added there (N at the table, linear in between, held
    /// beyond the ends); the static friction rises by as much. Negative where the guideway
    /// runs looser, never so far that the total goes below zero.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub friction_map_n: Vec<f64>,
    /// Friction that depends on the table's speed beyond the Coulomb, viscous and Stribeck
    /// terms: speeds (mm/min, increasing, from 0) …
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub friction_speed_mm_per_min: Vec<f64>,
    /// … and the sliding friction added there (N at the table, against the motion; with
    /// the position map's, never below zero in total).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub friction_speed_n: Vec<f64>,
    /// A force that repeats with the table's position (N at the table): a motor's torque
    /// ripple or cogging, a screw's eccentricity or a preload that varies over each turn.
    /// It pushes the table towards − by `force_ripple_n`·sin(2π·x/period + phase), moving
    /// or standing; 0 = none.
    pub force_ripple_n: f64,
    /// Its period (mm): a motor turn's travel for a ripple per turn. Needed with a ripple;
    /// it also asks `identify` to fit one.
    pub force_ripple_period_mm: f64,
    /// Its phase at position 0 (degrees).
    pub force_ripple_phase_deg: f64,
}

impl Default for Errors {
    fn default() -> Self {
        Errors {
            scale_error_ppm: 0.0,
            cyclic_amplitude_um: 0.0,
            cyclic_period_mm: 0.0,
            cyclic_phase_deg: 0.0,
            resonance_hz: 0.0,
            resonance_damping: 0.0,
            squareness_urad: 0.0,
            straightness_bow_um: 0.0,
            straightness_span_mm: default_straightness_span_mm(),
            position_map_mm: Vec::new(),
            position_map_um: Vec::new(),
            lateral_play_um: 0.0,
            direction_offset_um: 0.0,
            friction_map_mm: Vec::new(),
            friction_map_n: Vec::new(),
            friction_speed_mm_per_min: Vec::new(),
            friction_speed_n: Vec::new(),
            force_ripple_n: 0.0,
            force_ripple_period_mm: 0.0,
            force_ripple_phase_deg: 0.0,
        }
    }
}

/// An axis that is planned but not simulated.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlannedAxis {
    /// Kinematic limits for the planner.
    pub limits: Limits,
}

/// Where the position loop reads the axis position.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Feedback {
    /// Full closed loop: a linear scale on the table.
    LinearScale,
    /// Semi-closed loop: the motor encoder, translated by the nominal lead.
    MotorEncoder,
}

/// Position loop.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PositionLoop {
    /// Position gain Kv (m/min/mm; 1 m/min/mm = 16.667 1/s); the cascade's.
    #[serde(default)]
    pub kv_m_per_min_per_mm: f64,
    /// Velocity feed-forward factor k_f (0 = off, 1 = full); the cascade's.
    #[serde(default)]
    pub velocity_feedforward: f64,
    /// Acceleration feed-forward factor k_a (0 = off, 1 = full); the cascade's.
    #[serde(default)]
    pub accel_feedforward: f64,
    /// Position feedback.
    pub feedback: Feedback,
    /// Dead time between the interpolator and the position controller (ms); 0 in the
    /// paper's model.
    #[serde(default)]
    pub dead_time_ms: f64,
}

/// Velocity loop.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VelocityLoop {
    /// Proportional gain K_s as set on the CNC (N·m·s/rad; divided by K_t inside).
    pub ks_nm_s_per_rad: f64,
    /// Integral time T_s (ms).
    pub ts_ms: f64,
    /// Current command limit (A).
    pub i_max_a: f64,
}

/// Current loop.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CurrentLoop {
    /// Proportional gain K_i (V/A).
    pub ki_v_per_a: f64,
    /// Integral time T_i (ms).
    pub ti_ms: f64,
    /// Time constant of the current filters, forward and feedback (ms).
    pub tcf_ms: f64,
    /// Voltage limit (V).
    pub u_max_v: f64,
}

/// Servo motor.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Motor {
    /// Armature resistance R_a (Ω); needed with a current loop.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ra_ohm: Option<f64>,
    /// Armature inductance L_a (mH); needed with a current loop.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub la_mh: Option<f64>,
    /// Torque constant K_t (N·m/A).
    pub kt_nm_per_a: f64,
    /// Back-EMF constant K_e (V·s/rad); needed with a current loop.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ke_v_s_per_rad: Option<f64>,
    /// Rotor (+ sleeve) inertia J_m (kg·m²).
    pub jm_kg_m2: f64,
}

/// Mechanical drive: coupling, gear, ball screw, nut, table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Drive {
    /// What moves the table: a ball screw (the model's coupling, screw and nut), or a linear
    /// motor pushing it directly (the screw's keys are then not used, `motor.kt_nm_per_a` is
    /// the force constant in N/A, `table_mass_kg` the whole moving mass with the forcer, and
    /// the position is read at the table).
    #[serde(default, skip_serializing_if = "DriveKind::is_ball_screw")]
    pub kind: DriveKind,
    /// Screw (+ sleeve) inertia J_s (kg·m²).
    pub js_kg_m2: f64,
    /// Torsional stiffness at the coupling K_θ (N·m/rad).
    pub k_theta_nm_per_rad: f64,
    /// Axial stiffness screw–nut–table K_m (N/m).
    pub k_m_n_per_m: f64,
    /// Damping ratio of the torsional mode ζ_θ.
    pub zeta_theta: f64,
    /// Damping ratio of the axial mode ζ_m.
    pub zeta_m: f64,
    /// Ball-screw lead P (mm per screw revolution).
    pub lead_mm: f64,
    /// Gear ratio i_t (screw angle per motor angle).
    pub gear_ratio: f64,
    /// Table (+ nut) mass M_T (kg).
    pub table_mass_kg: f64,
    /// Viscous damping of the screw bearings B (N·m·s/rad).
    pub screw_viscous_nm_s_per_rad: f64,
    /// Total free play of the screw–nut b (µm).
    pub backlash_um: f64,
}

/// What moves the table.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DriveKind {
    /// A motor turning a ball screw through a coupling (docs/model.md §1).
    #[default]
    BallScrew,
    /// A linear motor: its force acts on the table itself.
    LinearMotor,
}

impl DriveKind {
    /// Whether this is the default ball screw (which the machine file need not name).
    pub(crate) fn is_ball_screw(&self) -> bool {
        *self == DriveKind::BallScrew
    }
}

/// Guideway friction (static, Coulomb, viscous).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Friction {
    /// Coulomb coefficient c: f_c = c·M_T·g.
    pub coulomb_coefficient: f64,
    /// Static-to-Coulomb ratio f_s/f_c: ≥ 1, or ≥ 0.1 with presliding bristles.
    pub static_to_coulomb: f64,
    /// Viscous coefficient f_v (N·s/m).
    pub viscous_n_s_per_m: f64,
    /// Stribeck effect: extra sliding friction at low speed, level·exp(−(v/v_s)²) (N);
    /// 0 in the paper's model.
    #[serde(default)]
    pub stribeck_level_n: f64,
    /// Stribeck velocity v_s (mm/min).
    #[serde(default)]
    pub stribeck_velocity_mm_per_min: f64,
    /// Presliding (LuGre) bristle stiffness σ0 (N/µm); 0: friction sticks or slides, with no
    /// presliding state.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub bristle_stiffness_n_per_um: f64,
    /// Presliding bristle damping σ1 (N·s/m); only with a bristle stiffness.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub bristle_damping_n_s_per_m: f64,
    /// With presliding bristles, friction near rest over Coulomb's while the table moves
    /// towards −, where it differs from its level towards + (`static_to_coulomb`, which then
    /// holds for + alone); absent: the same both ways.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub static_to_coulomb_negative: Option<f64>,
}

impl Friction {
    /// Whether the friction has a presliding (bristle) state.
    pub fn has_presliding(&self) -> bool {
        self.bristle_stiffness_n_per_um > 0.0
    }

    /// The Coulomb friction on a table of `table_mass_kg` (N), c·M_T·g.
    pub fn coulomb_n(&self, table_mass_kg: f64) -> f64 {
        self.coulomb_coefficient * table_mass_kg * crate::numeric::units::GRAVITY_M_PER_S2
    }

    /// The static friction (N) over a Coulomb friction of `coulomb_n`: the ratio's, and no
    /// less than Coulomb's with the Stribeck excess (the Stribeck curve starts at the static
    /// level) — except where bristles carry a level
    /// near rest below Coulomb's (validation refuses a Stribeck excess with it): friction
    /// that grows with speed at low speed.
    pub fn static_n(&self, coulomb_n: f64) -> f64 {
        if self.has_presliding() && self.static_to_coulomb < 1.0 {
            return self.static_to_coulomb * coulomb_n;
        }
        (self.static_to_coulomb * coulomb_n).max(coulomb_n + self.stribeck_level_n)
    }

    /// The friction near rest (N) towards + and towards − over a Coulomb friction of
    /// `coulomb_n`: [`Friction::static_n`] both ways, but where bristles carry a level of
    /// their own towards −.
    pub fn rest_n_by_direction(&self, coulomb_n: f64) -> [f64; 2] {
        let plus_n = self.static_n(coulomb_n);
        match self.static_to_coulomb_negative {
            Some(ratio) if self.has_presliding() => [plus_n, ratio * coulomb_n],
            _ => [plus_n; 2],
        }
    }
}

/// Simulation steps per bristle time scale (√(m/σ0) or m/σ1): the bristles' push, held over
/// a step, then errs by about (ω·h)²/2 < 1 % of their force per step and the loop is far
/// inside its stability limit (ω·h < 2).
const BRISTLE_STEPS_PER_TIME_SCALE: f64 = 10.0;

/// The shortest simulation step a machine file may ask for through its bristles (s).
pub(crate) const SHORTEST_BRISTLE_STEP_S: f64 = 1e-6;

/// The longest simulation steps (s) that presliding bristles of stiffness `sigma0_n_per_m`
/// and damping `sigma1_n_s_per_m` allow on a table of `mass_kg`: for the spring, a tenth of
/// √(m/σ0); for the damper, a tenth of m/σ1 (unbounded without damping).
pub fn bristle_steps_s(mass_kg: f64, sigma0_n_per_m: f64, sigma1_n_s_per_m: f64) -> [f64; 2] {
    let spring_s = (mass_kg / sigma0_n_per_m).sqrt();
    let damper_s = if sigma1_n_s_per_m > 0.0 {
        mass_kg / sigma1_n_s_per_m
    } else {
        f64::INFINITY
    };
    [spring_s, damper_s].map(|t| t / BRISTLE_STEPS_PER_TIME_SCALE)
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

/// Beam sag that tilts the screw and scales its lead (docs/model.md §1.7).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LateralShift {
    /// Beam length l (m).
    pub beam_length_m: f64,
    /// Bending stiffness EI (N·m²).
    pub bending_stiffness_n_m2: f64,
    /// Weight of tool holder, ram and slide F (N).
    pub holder_load_n: f64,
    /// Distance a of the holder from the beam's left end when the axis is at 0 (m).
    pub holder_at_zero_m: f64,
}

/// Kinematic limits of an axis, for the planner.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Limits {
    /// Highest cutting feed (mm/min).
    pub max_feed_mm_per_min: f64,
    /// Rapid traverse rate (mm/min).
    pub rapid_mm_per_min: f64,
    /// Acceleration limit (m/s²).
    pub max_accel_m_per_s2: f64,
    /// Jerk limit (m/s³).
    pub max_jerk_m_per_s3: f64,
    /// Travel (soft limits) as [lowest, highest] position in program coordinates (mm): a
    /// program that leaves it is refused, as a control refuses it. None: not checked.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub travel_mm: Option<[f64; 2]>,
}

/// A simulated axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, PartialOrd, Ord)]
#[serde(rename_all = "lowercase")]
pub enum AxisName {
    /// X.
    X,
    /// Y.
    Y,
    /// Z, on a machine that simulates it.
    Z,
}

impl AxisName {
    /// The axes of the XY plane: every machine simulates both.
    pub const BOTH: [AxisName; 2] = [AxisName::X, AxisName::Y];

    /// All three axes.
    pub const ALL: [AxisName; 3] = [AxisName::X, AxisName::Y, AxisName::Z];

    /// Lower-case name as used in keys and on the command line.
    pub(crate) fn as_str(self) -> &'static str {
        match self {
            AxisName::X => "x",
            AxisName::Y => "y",
            AxisName::Z => "z",
        }
    }

    /// The other axis of the XY pair (the squareness, straightness and play between them
    /// are read on it); Z has no partner and names itself.
    pub(crate) fn other(self) -> AxisName {
        match self {
            AxisName::X => AxisName::Y,
            AxisName::Y => AxisName::X,
            AxisName::Z => AxisName::Z,
        }
    }

    /// Index into X, Y, Z arrays.
    pub fn index(self) -> usize {
        match self {
            AxisName::X => 0,
            AxisName::Y => 1,
            AxisName::Z => 2,
        }
    }
}

impl AxisName {
    /// `X`, `Y` or `Z`.
    pub(crate) fn letter(self) -> char {
        match self {
            AxisName::X => 'X',
            AxisName::Y => 'Y',
            AxisName::Z => 'Z',
        }
    }
}

impl std::fmt::Display for AxisName {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.letter())
    }
}

impl std::str::FromStr for AxisName {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.to_ascii_lowercase().as_str() {
            "x" => Ok(AxisName::X),
            "y" => Ok(AxisName::Y),
            "z" => Ok(AxisName::Z),
            other => Err(format!("no axis '{other}' (x, y or z)")),
        }
    }
}

impl MachineConfig {
    /// A simulated axis by name; Z only where the machine simulates it (see
    /// [`MachineConfig::simulated_axes`]; [`MachineConfig::try_axis`] asks).
    pub fn axis(&self, name: AxisName) -> &AxisConfig {
        self.try_axis(name)
            .expect("Z is named only on a machine that simulates it")
    }

    /// A simulated axis by name, mutably (as [`MachineConfig::axis`]).
    pub fn axis_mut(&mut self, name: AxisName) -> &mut AxisConfig {
        match name {
            AxisName::X => &mut self.x,
            AxisName::Y => &mut self.y,
            AxisName::Z => match &mut self.z {
                ZAxis::Simulated(a) => a,
                ZAxis::Carried(_) => panic!("Z is named only on a machine that simulates it"),
            },
        }
    }

    /// A simulated axis by name; `None` for Z where it is carried.
    pub(crate) fn try_axis(&self, name: AxisName) -> Option<&AxisConfig> {
        match name {
            AxisName::X => Some(&self.x),
            AxisName::Y => Some(&self.y),
            AxisName::Z => self.z.simulated(),
        }
    }

    /// The simulated axes: X, Y and, where simulated, Z.
    pub fn simulated_axes(&self) -> Vec<AxisName> {
        AxisName::ALL
            .into_iter()
            .filter(|&a| self.try_axis(a).is_some())
            .collect()
    }

    /// The simulated axes' configurations, in the order X, Y, Z.
    pub(crate) fn simulated_configs(&self) -> Vec<&AxisConfig> {
        [&self.x, &self.y]
            .into_iter()
            .chain(self.z.simulated())
            .collect()
    }

    /// Whether Z is simulated.
    pub fn simulates_z(&self) -> bool {
        self.z.simulated().is_some()
    }

    /// An axis's kinematic limits, simulated or carried.
    pub fn limits(&self, name: AxisName) -> &Limits {
        match name {
            AxisName::X => &self.x.limits,
            AxisName::Y => &self.y.limits,
            AxisName::Z => self.z.limits(),
        }
    }
}
