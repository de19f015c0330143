//! Machine configuration: one TOML file, one section per axis, every value in the unit a CNC
//! engineer reads off the control (Kv in m/min/mm, K_s in N·m·s/rad, backlash in µm).
//!
//! The paper's machine is embedded as the preset `hvmc` (see `hvmc.toml`, which documents
//! every key with its unit and source). A user file starts from a preset (`base = "hvmc"`,
//! the default) and overrides only the keys it names. Loading validates the whole machine
//! before anything runs: a missing, negative, non-finite or inconsistent value is an error
//! naming the key and the file.

mod alternatives;
mod base;
mod controller;
pub mod keys;
pub mod locate;
pub mod realise;
mod sections;
mod validate;

pub use controller::{Amplifier, Controller, ControllerOutput, StateFeedback, TransferFunction};

use std::path::Path;

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

/// A whole machine: interpolation settings and the X, Y (simulated) and Z (planned) axes.
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
    /// Z axis: only its kinematic limits (Z is planned, not simulated).
    pub z: PlannedAxis,
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
    /// beyond the ends); the static friction rises by as much.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub friction_map_n: Vec<f64>,
    /// Friction that depends on the table's speed beyond the Coulomb, viscous and Stribeck
    /// terms: speeds (mm/min, increasing, from 0) …
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub friction_speed_mm_per_min: Vec<f64>,
    /// … and the sliding friction added there (N at the table, against the motion).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub friction_speed_n: Vec<f64>,
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
    /// Static-to-Coulomb ratio f_s/f_c (≥ 1).
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

/// Which of the two simulated axes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, PartialOrd, Ord)]
#[serde(rename_all = "lowercase")]
pub enum AxisName {
    /// X.
    X,
    /// Y.
    Y,
}

impl AxisName {
    /// Both simulated axes.
    pub const BOTH: [AxisName; 2] = [AxisName::X, AxisName::Y];

    /// Lower-case name as used in keys and on the command line.
    pub fn as_str(self) -> &'static str {
        match self {
            AxisName::X => "x",
            AxisName::Y => "y",
        }
    }

    /// The other simulated axis.
    pub fn other(self) -> AxisName {
        match self {
            AxisName::X => AxisName::Y,
            AxisName::Y => AxisName::X,
        }
    }

    /// Index into XY arrays.
    pub fn index(self) -> usize {
        match self {
            AxisName::X => 0,
            AxisName::Y => 1,
        }
    }
}

impl AxisName {
    /// `X` or `Y`.
    pub fn letter(self) -> char {
        match self {
            AxisName::X => 'X',
            AxisName::Y => 'Y',
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
            other => Err(format!("no simulated axis '{other}' (x or y)")),
        }
    }
}

impl MachineConfig {
    /// The axis by name.
    pub fn axis(&self, name: AxisName) -> &AxisConfig {
        match name {
            AxisName::X => &self.x,
            AxisName::Y => &self.y,
        }
    }

    /// The axis by name, mutably.
    pub fn axis_mut(&mut self, name: AxisName) -> &mut AxisConfig {
        match name {
            AxisName::X => &mut self.x,
            AxisName::Y => &mut self.y,
        }
    }

    /// The embedded default machine.
    pub fn default_preset() -> MachineConfig {
        Self::preset(DEFAULT_PRESET).expect("the embedded default preset is valid")
    }

    /// An embedded preset by name, validated.
    pub fn preset(name: &str) -> Result<MachineConfig, ConfigError> {
        let table = base::preset_table(name, "<command line>")?;
        from_table(table, &format!("<preset {name}>"))
    }

    /// Loads a machine file: its `base` preset (default `hvmc`, or `"none"`) with the file's
    /// keys laid over it, then validated.
    pub fn load(path: &Path) -> Result<MachineConfig, ConfigError> {
        Self::load_with_warnings(path).map(|(machine, _)| machine)
    }

    /// Loads a machine file as [`MachineConfig::load`] does, with warnings: a file that
    /// gives no `base` (it starts from the default preset), values that look like a unit
    /// mixed up (0.005 µm of backlash: mm meant?).
    pub(crate) fn load_with_warnings(
        path: &Path,
    ) -> Result<(MachineConfig, Vec<String>), ConfigError> {
        let file = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| ConfigError::Io {
            file: file.clone(),
            message: e.to_string(),
        })?;
        let machine = Self::from_toml_str(&text, &file)?;
        // The text parsed once already; read as a table again for the keys the file gave.
        let over: toml::Table = text.parse().unwrap_or_default();
        let mut warnings = Vec::new();
        if !over.contains_key("base") {
            warnings.push(base::no_base_warning(&file));
        }
        warnings.extend(suspicious_values(&over, &text, &file));
        Ok((machine, warnings))
    }

    /// Parses a machine from TOML text; `file` names it in errors, and a `base` that names a
    /// file is found relative to its folder. A file that gives no `name` is named after
    /// itself (its file name without `.toml`), not after its base.
    pub fn from_toml_str(text: &str, file: &str) -> Result<MachineConfig, ConfigError> {
        Self::from_toml_chained(text, file, &[])
    }

    /// [`MachineConfig::from_toml_str`] for a file reached through the chain of bases
    /// `chain` (the files that named it, outermost first).
    pub(crate) fn from_toml_chained(
        text: &str,
        file: &str,
        chain: &[std::path::PathBuf],
    ) -> Result<MachineConfig, ConfigError> {
        let mut over: toml::Table =
            text.parse()
                .map_err(|e: toml::de::Error| ConfigError::Syntax {
                    file: file.to_string(),
                    message: syntax_message(text, &e),
                })?;
        let base::Base {
            mut table,
            label: base,
        } = base::resolve(over.remove("base"), file, chain).map_err(|e| {
            // A base file's errors name it, and where in it they are, already.
            if base::is_about(&e, file) {
                locate::located(e, text)
            } else {
                e
            }
        })?;
        if !over.contains_key("name")
            && !file.starts_with('<')
            && let Some(stem) = std::path::Path::new(file).file_stem()
        {
            table.insert(
                "name".into(),
                toml::Value::String(stem.to_string_lossy().into_owned()),
            );
        }
        let base_table = table.clone();
        merge(&mut table, over.clone());
        let located = |e: ConfigError| locate::located(e, text);
        alternatives::resolve(&over, &mut table, file).map_err(located)?;
        sections::resolve(&over, &base_table, &mut table, file).map_err(located)?;
        refuse_unused_keys(&over, &table, file).map_err(located)?;
        from_table(table, file)
            .map_err(|e| explain_missing(e, &base, &base_table))
            .map_err(located)
    }

    /// Checks the machine as a machine file is checked: its sections, every number in range,
    /// the values that must agree agreeing; errors name `file` and the key.
    pub fn validate(&self, file: &str) -> Result<(), ConfigError> {
        validate::validate(self, file)
    }

    /// The machine as TOML (every key its controllers read, no `base`): the cascade's gains
    /// are left out of an axis with another controller, and a velocity loop's of an axis
    /// whose drive closes none, as a file that gave them would be refused.
    pub fn to_toml(&self) -> String {
        let mut table = toml::Table::try_from(self).expect("a machine always serialises");
        for (axis, config) in [("x", &self.x), ("y", &self.y)] {
            let Some(toml::Value::Table(section)) = table.get_mut(axis) else {
                continue;
            };
            if !config.controller.is_cascade()
                && let Some(toml::Value::Table(position)) = section.get_mut("position_loop")
            {
                for key in [
                    "kv_m_per_min_per_mm",
                    "velocity_feedforward",
                    "accel_feedforward",
                ] {
                    position.remove(key);
                }
            }
            if !config.controller.uses_velocity_loop() {
                section.remove("velocity_loop");
            }
        }
        toml::to_string_pretty(&table).expect("a machine always serialises")
    }
}

/// A configuration error, naming the file and the key.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ConfigError {
    /// The file could not be read.
    #[error("{file}: {message}")]
    Io {
        /// File.
        file: String,
        /// OS message.
        message: String,
    },
    /// Not valid TOML.
    #[error("{file}: {message}")]
    Syntax {
        /// File.
        file: String,
        /// Parser message with line and column.
        message: String,
    },
    /// A key that must be present is not.
    #[error("{file}: missing key `{key}`{why}")]
    Missing {
        /// File.
        file: String,
        /// Dotted key path.
        key: String,
        /// Why it was not taken from the base, when that is the reason (else empty).
        why: String,
    },
    /// A key the machine does not have (a typo, usually).
    #[error("{file}: unknown key `{key}`{hint}")]
    UnknownKey {
        /// File (with the key's line and column where the file's text shows them).
        file: String,
        /// Dotted key path.
        key: String,
        /// " — did you mean `…`?", or empty.
        hint: String,
    },
    /// Several unknown keys: all of them, each where it is.
    #[error("{file}: {} unknown keys:{}", .keys.len(), .keys.iter().map(|k| format!("\n  {k}")).collect::<String>())]
    UnknownKeys {
        /// File.
        file: String,
        /// Each with where it is and what was likely meant.
        keys: Vec<locate::UnknownKeyAt>,
    },
    /// A value of the wrong type, out of range or inconsistent with another.
    #[error("{file}: key `{key}` {problem}")]
    Invalid {
        /// File.
        file: String,
        /// Dotted key path.
        key: String,
        /// What is wrong.
        problem: String,
    },
    /// `base` names no embedded preset and no machine file.
    #[error(
        "{file}: key `base`: no preset or machine file `{name}` (presets: {available}; or \"none\"){hint}"
    )]
    UnknownPreset {
        /// File.
        file: String,
        /// The name given.
        name: String,
        /// The presets there are.
        available: String,
        /// " — did you mean `…`?", where the file looked for is, or empty.
        hint: String,
    },
}

/// A key the file gives that the axis's controller structure does not read is refused, so
/// that no setting is silently without effect: the cascade's gains on another controller, a
/// velocity loop's on a drive that has none.
fn refuse_unused_keys(
    over: &toml::Table,
    merged: &toml::Table,
    file: &str,
) -> Result<(), ConfigError> {
    for axis in ["x", "y"] {
        let given = |section: &str| {
            over.get(axis)
                .and_then(|a| a.get(section))
                .and_then(toml::Value::as_table)
                .map(|t| t.keys().cloned().collect::<Vec<_>>())
                .unwrap_or_default()
        };
        // The structure as the merged file names it (its own check comes later).
        let controller = merged
            .get(axis)
            .and_then(|a| a.get("controller"))
            .and_then(toml::Value::as_table);
        let field = |key: &str| {
            controller
                .and_then(|c| c.get(key))
                .and_then(toml::Value::as_str)
        };
        let structure = field("structure").unwrap_or("cascade");
        let velocity_loop = match structure {
            "cascade" => true,
            "transfer_function" => field("output") == Some("velocity"),
            _ => false,
        };
        let unused = |key: String, why: String| ConfigError::Invalid {
            file: file.into(),
            key,
            problem: format!("is not used: {why}"),
        };
        let upper = axis.to_uppercase();
        if structure != "cascade" {
            let cascade_gains = [
                "kv_m_per_min_per_mm",
                "velocity_feedforward",
                "accel_feedforward",
            ];
            if let Some(key) = given("position_loop")
                .into_iter()
                .find(|k| cascade_gains.contains(&k.as_str()))
            {
                return Err(unused(
                    format!("{axis}.position_loop.{key}"),
                    format!(
                        "the {upper} axis's controller is `{structure}`, whose gains and \
                         feed-forward are set in [{axis}.controller]; [{axis}.position_loop] \
                         gives only `feedback` and `dead_time_ms` to it"
                    ),
                ));
            }
        }
        if !velocity_loop && let Some(key) = given("velocity_loop").into_iter().next() {
            return Err(unused(
                format!("{axis}.velocity_loop.{key}"),
                format!(
                    "the {upper} axis's controller (`{structure}`) commands current, so its \
                     drive closes no velocity loop"
                ),
            ));
        }
    }
    Ok(())
}

/// Values the file gives that are possible but far more likely a unit mixed up: each with
/// its place and what it would be in the unit probably meant.
fn suspicious_values(over: &toml::Table, text: &str, file: &str) -> Vec<String> {
    let mut warnings = Vec::new();
    for axis in ["x", "y"] {
        let value = |section: &str, key: &str| {
            over.get(axis)
                .and_then(|a| a.get(section))
                .and_then(|s| s.get(key))
                .and_then(|v| v.as_float().or_else(|| v.as_integer().map(|i| i as f64)))
        };
        let mut warn = |section: &str, key: &str, why: String| {
            let dotted = format!("{axis}.{section}.{key}");
            let at =
                locate::find_key(text, &dotted).map_or(String::new(), |(l, c)| format!(":{l}:{c}"));
            warnings.push(format!("{file}{at}: {dotted} {why}"));
        };
        if let Some(b) = value("drive", "backlash_um")
            && b > 0.0
            && b < 0.1
        {
            warn(
                "drive",
                "backlash_um",
                format!(
                    "= {b} µm is below any machine's backlash: if mm were meant, write \
                     backlash_um = {}",
                    b * 1e3
                ),
            );
        }
        if let Some(kv) = value("position_loop", "kv_m_per_min_per_mm")
            && kv > 10.0
        {
            warn(
                "position_loop",
                "kv_m_per_min_per_mm",
                format!(
                    "= {kv} m/min/mm is far above a machine tool's position gain (0.3–5): if \
                     1/s were meant, write kv_m_per_min_per_mm = {:.3}",
                    kv / (1000.0 / 60.0)
                ),
            );
        }
    }
    warnings
}

/// Lays `over` onto `base`, table by table; values in `over` win.
fn merge(base: &mut toml::Table, over: toml::Table) {
    for (key, value) in over {
        match (base.get_mut(&key), value) {
            (Some(toml::Value::Table(b)), toml::Value::Table(o)) => merge(b, o),
            (_, v) => {
                base.insert(key, v);
            }
        }
    }
}

/// A missing key in a section the base does not have: the file gave part of a section
/// (an optional one, as `[y.lateral_shift]` on `hvmc`) that has nothing to be laid over.
fn explain_missing(e: ConfigError, base: &str, base_table: &toml::Table) -> ConfigError {
    let ConfigError::Missing { file, key, why } = e else {
        return e;
    };
    let Some((section, _)) = key.rsplit_once('.') else {
        return ConfigError::Missing { file, key, why };
    };
    let mut at = Some(base_table);
    for part in section.split('.') {
        at = at.and_then(|t| t.get(part)).and_then(|v| v.as_table());
    }
    let why = if at.is_none() && base != "none" {
        format!(
            " (the base `{base}` has no [{section}], so a file that adds it gives all its keys)"
        )
    } else {
        why
    };
    ConfigError::Missing { file, key, why }
}

fn from_table(mut table: toml::Table, file: &str) -> Result<MachineConfig, ConfigError> {
    // Every unknown key is reported at once: each is taken out and the rest read again.
    let mut unknown = Vec::new();
    let machine = loop {
        match serde_path_to_error::deserialize::<_, MachineConfig>(toml::Value::Table(
            table.clone(),
        )) {
            Ok(machine) => break Some(machine),
            Err(e) => {
                let error =
                    classify_serde_error(file, &e.path().to_string(), &e.inner().to_string());
                if let ConfigError::UnknownKey { key, hint, .. } = &error
                    && unknown.len() < 100
                    && locate::remove_key(&mut table, key)
                {
                    unknown.push(locate::UnknownKeyAt::new(key, hint));
                    continue;
                }
                if unknown.is_empty() {
                    return Err(error);
                }
                // What else is wrong may follow from the unknown keys: they come first.
                break None;
            }
        }
    };
    match (machine, unknown.len()) {
        (Some(machine), 0) => {
            validate::validate(&machine, file)?;
            Ok(machine)
        }
        (_, 1) => {
            let only = unknown.remove(0);
            Err(ConfigError::UnknownKey {
                file: file.into(),
                key: only.key,
                hint: only.hint,
            })
        }
        _ => Err(ConfigError::UnknownKeys {
            file: file.into(),
            keys: unknown,
        }),
    }
}

fn classify_serde_error(file: &str, path: &str, message: &str) -> ConfigError {
    // serde_path_to_error's path ends at the unknown key itself but at the parent of a
    // missing one.
    let join = |leaf: &str| {
        if path.is_empty() || path == "." {
            leaf.to_string()
        } else if path == leaf || path.ends_with(&format!(".{leaf}")) {
            path.to_string()
        } else {
            format!("{path}.{leaf}")
        }
    };
    let quoted = message.split('`').nth(1).unwrap_or("").to_string();
    if message.starts_with("missing field") {
        ConfigError::Missing {
            file: file.into(),
            key: join(&quoted),
            why: String::new(),
        }
    } else if message.starts_with("unknown field") {
        ConfigError::UnknownKey {
            file: file.into(),
            key: join(&quoted),
            hint: locate::did_you_mean(&quoted, message),
        }
    } else {
        ConfigError::Invalid {
            file: file.into(),
            key: path.to_string(),
            problem: locate::plain_words(path, message),
        }
    }
}

/// toml's message, reduced to "line L, column C: …".
fn syntax_message(text: &str, e: &toml::de::Error) -> String {
    match e.span() {
        Some(span) => {
            let before = &text[..span.start.min(text.len())];
            let line = before.matches('\n').count() + 1;
            let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
            format!("line {line}, column {column}: {}", e.message())
        }
        None => e.message().to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn preset_loads_and_round_trips() {
        let m = MachineConfig::default_preset();
        assert_eq!(m.x.position_loop.kv_m_per_min_per_mm, 1.0);
        assert!(m.x.lateral_shift.is_some() && m.y.lateral_shift.is_none());
        let again = MachineConfig::from_toml_str(&format!("base = \"none\"\n{}", m.to_toml()), "t")
            .unwrap();
        assert_eq!(again, m);
    }

    #[test]
    fn every_preset_round_trips_and_refuses_keys_its_controller_does_not_read() {
        for (name, _) in PRESETS {
            let m = MachineConfig::preset(name).unwrap();
            let again =
                MachineConfig::from_toml_str(&format!("base = \"none\"\n{}", m.to_toml()), "t")
                    .unwrap();
            assert_eq!(again, m, "{name}");
        }
        let e = MachineConfig::from_toml_str(
            "base = \"small-table\"\n[x.position_loop]\nkv_m_per_min_per_mm = 2.0\n",
            "m.toml",
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.starts_with("m.toml:3:1: key `x.position_loop.kv_m_per_min_per_mm` is not used"),
            "{e}"
        );
        let e = MachineConfig::from_toml_str(
            "base = \"small-table\"\n[y.velocity_loop]\nts_ms = 5.0\n",
            "m.toml",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("closes no velocity loop"), "{e}");
    }

    #[test]
    fn a_unit_mixed_up_is_warned_about_with_the_likely_value() {
        let text =
            "[x.drive]\nbacklash_um = 0.005\n[y.position_loop]\nkv_m_per_min_per_mm = 16.7\n";
        let warnings = suspicious_values(&text.parse().unwrap(), text, "m.toml");
        assert_eq!(warnings.len(), 2, "{warnings:?}");
        assert!(warnings[0].starts_with("m.toml:2:1: x.drive.backlash_um = 0.005 µm"));
        assert!(warnings[0].ends_with("backlash_um = 5"), "{}", warnings[0]);
        assert!(
            warnings[1].ends_with("kv_m_per_min_per_mm = 1.002"),
            "{}",
            warnings[1]
        );
    }

    #[test]
    fn every_unknown_key_is_reported_at_once_with_its_line() {
        let text = "base = \"hvmc\"\n[x.drive]\nbacklsh_um = 5.0\n[y.position_loop]\n\
                    kv_m_per_mim_per_mm = 1.0\n";
        let e = MachineConfig::from_toml_str(text, "m.toml")
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "m.toml: 2 unknown keys:\n  line 3, column 1: `x.drive.backlsh_um` — did you mean \
             `backlash_um`?\n  line 5, column 1: `y.position_loop.kv_m_per_mim_per_mm` — did \
             you mean `kv_m_per_min_per_mm`?"
        );
        let e = MachineConfig::from_toml_str("[x.drive]\nbacklash_um = \"5 um\"\n", "m.toml")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("m.toml:2:1:") && e.contains("write `backlash_um = 5`"),
            "{e}"
        );
    }

    #[test]
    fn a_file_overrides_only_what_it_names() {
        let m = MachineConfig::from_toml_str("[x.drive]\nbacklash_um = 12.5\n", "m.toml").unwrap();
        assert_eq!(m.x.drive.backlash_um, 12.5);
        assert_eq!(m.y.drive.backlash_um, 0.0);
        assert_eq!(m.x.drive.lead_mm, 16.0);
    }

    #[test]
    fn errors_name_the_key_and_the_file() {
        let e = MachineConfig::from_toml_str("[x.drive]\nbacklash_um = -1.0\n", "m.toml");
        assert_eq!(
            e.unwrap_err().to_string(),
            "m.toml:2:1: key `x.drive.backlash_um` must not be negative (got -1)"
        );
        let e = MachineConfig::from_toml_str("[x.drive]\nbaklash_um = 1.0\n", "m.toml");
        assert_eq!(
            e.unwrap_err().to_string(),
            "m.toml:2:1: unknown key `x.drive.baklash_um` — did you mean `backlash_um`?"
        );
        let e = MachineConfig::from_toml_str("base = \"none\"\nname = \"a\"\n", "m.toml");
        assert!(matches!(e.unwrap_err(), ConfigError::Missing { .. }));
        let e = MachineConfig::from_toml_str("[x.motor]\nra_ohm = \"a\"\n", "m.toml");
        assert!(e.unwrap_err().to_string().contains("x.motor.ra_ohm"));
        let e = MachineConfig::from_toml_str("[x.motor\n", "m.toml");
        assert!(
            e.unwrap_err()
                .to_string()
                .starts_with("m.toml: line 1, column")
        );
    }

    /// Friction force at the table (N) as the model will use it.
    fn coulomb_force_n(a: &AxisConfig) -> f64 {
        a.friction.coulomb_coefficient * a.drive.table_mass_kg * crate::units::GRAVITY_M_PER_S2
    }

    #[test]
    fn friction_in_absolute_units_is_the_same_force_whatever_the_mass() {
        let light =
            "[x.drive]\ntable_mass_kg = 80.0\n[x.friction]\ncoulomb_n = 150.0\nstatic_n = 200.0\n";
        let m = MachineConfig::from_toml_str(light, "m.toml").unwrap();
        assert!((coulomb_force_n(&m.x) - 150.0).abs() < 1e-9);
        assert!((m.x.friction.static_to_coulomb - 200.0 / 150.0).abs() < 1e-12);
        // The other axis keeps the base's coefficient.
        assert_eq!(m.y.friction.coulomb_coefficient, 0.010);
        let heavy = light.replace("80.0", "6000.0");
        let m = MachineConfig::from_toml_str(&heavy, "m.toml").unwrap();
        assert!((coulomb_force_n(&m.x) - 150.0).abs() < 1e-9);
        // At the motor: 2 N·m through a 16 mm lead at 1:4 pushes with 2·2π/(0.25·0.016) N.
        let motor =
            "[x.friction]\ncoulomb_nm_at_motor = 2.0\nviscous_nm_s_per_rad_at_motor = 0.01\n";
        let m = MachineConfig::from_toml_str(motor, "m.toml").unwrap();
        let travel_per_rad = 0.25 * 0.016 / std::f64::consts::TAU;
        assert!((coulomb_force_n(&m.x) - 2.0 / travel_per_rad).abs() < 1e-6);
        assert!((m.x.friction.viscous_n_s_per_m - 0.01 / travel_per_rad.powi(2)).abs() < 1e-6);
        // Written out, the machine carries the model's keys and reads back the same.
        let again = MachineConfig::from_toml_str(&format!("base = \"none\"\n{}", m.to_toml()), "t")
            .unwrap();
        assert_eq!(again, m);
    }

    #[test]
    fn a_partial_section_the_base_has_on_the_other_axis_is_completed_from_it() {
        // hvmc has a beam on X only: a partial one on Y takes the rest from X's.
        let m = MachineConfig::from_toml_str("[y.lateral_shift]\nbeam_length_m = 3.0\n", "m.toml")
            .unwrap();
        let (x, y) = (m.x.lateral_shift.unwrap(), m.y.lateral_shift.unwrap());
        assert_eq!(y.beam_length_m, 3.0);
        assert_eq!(y.bending_stiffness_n_m2, x.bending_stiffness_n_m2);
        assert_eq!(y.holder_at_zero_m, x.holder_at_zero_m);
        assert_eq!(x.beam_length_m, 4.0);
    }

    #[test]
    fn friction_said_twice_or_a_partial_new_section_is_refused_with_the_key() {
        let both = "[x.friction]\ncoulomb_coefficient = 0.01\ncoulomb_n = 150.0\n";
        let e = MachineConfig::from_toml_str(both, "m.toml")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("x.friction.coulomb_n") && e.contains("give one"),
            "{e}"
        );
        let negative = "[y.friction]\ncoulomb_n = -3.0\n";
        let e = MachineConfig::from_toml_str(negative, "m.toml")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("y.friction.coulomb_n") && e.contains("≥ 0"),
            "{e}"
        );
        // The small table has no beam at all: part of one cannot be laid over anything.
        let partial = "base = \"small-table\"\n[y.lateral_shift]\nbeam_length_m = 3.0\n";
        let e = MachineConfig::from_toml_str(partial, "m.toml")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("missing key `y.lateral_shift.")
                && e.contains("the base `small-table` has no [y.lateral_shift]"),
            "{e}"
        );
    }
}
