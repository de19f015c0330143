//! Every scalar number of a machine file in one table: each key's path, unit, meaning,
//! the range a machine can have, and how to read and set it. The table is what validation
//! checks ranges by, what the cause catalogue and identification fit by name, what a sweep
//! sets, and what `docs/machine-keys.md` is generated from (a test keeps that file equal to
//! [`reference_markdown`]). A key spelt wrong anywhere is found by the tests that run every
//! name through this table, not by a panic in a fit.
//!
//! Lists (tables of the errors, a transfer function's coefficients, travel ranges) and
//! words (the controller's structure, the feedback) are not in it: validation checks those
//! on their own.

use super::{AxisConfig, Controller, Interpolation, Limits, MachineConfig, ZAxis};

/// What a value must satisfy. The upper bounds are generous — beyond anything from a desktop
/// table to the heaviest machine — and there so that a slip of the exponent (a table of
/// 1e300 kg, 1e12 µm of backlash) is caught by validation rather than turned into silent
/// nonsense by the simulation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Rule {
    /// In (0, hi].
    Positive(f64),
    /// In [0, hi].
    NonNegative(f64),
    /// Within [lo, hi].
    Range(f64, f64),
}

/// A number as a reader takes it in: exponent form when it is huge or tiny.
pub(crate) fn number(v: f64) -> String {
    if v != 0.0 && !(1e-4..1e6).contains(&v.abs()) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

impl Rule {
    /// What is wrong with `value` under this rule, if anything.
    pub(crate) fn problem(self, value: f64) -> Option<String> {
        if !value.is_finite() {
            return Some("must be a finite number".to_string());
        }
        match self {
            Rule::Positive(_) if value <= 0.0 => Some("must be positive".to_string()),
            Rule::NonNegative(_) if value < 0.0 => Some("must not be negative".to_string()),
            Rule::Positive(hi) | Rule::NonNegative(hi) if value > hi => Some(format!(
                "must be at most {}: no machine axis has more",
                number(hi)
            )),
            Rule::Range(lo, hi) if !(lo..=hi).contains(&value) => Some(format!(
                "must lie between {} and {}",
                number(lo),
                number(hi)
            )),
            _ => None,
        }
    }

    /// The rule in a few symbols, for the reference: `> 0, ≤ 100`.
    pub(crate) fn describe(self) -> String {
        match self {
            Rule::Positive(hi) => format!("> 0, ≤ {}", number(hi)),
            Rule::NonNegative(hi) => format!("≥ 0, ≤ {}", number(hi)),
            Rule::Range(lo, hi) => format!("{} … {}", number(lo), number(hi)),
        }
    }
}

/// Which axes a key means something on, beyond its section being there.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Needs {
    /// Every axis.
    Always,
    /// An axis with the cascade controller (its position-loop gains).
    Cascade,
    /// An axis whose controller commands a velocity loop.
    VelocityLoop,
}

impl Needs {
    /// Whether `axis` reads the key.
    pub(crate) fn holds(self, axis: &AxisConfig) -> bool {
        match self {
            Needs::Always => true,
            Needs::Cascade => axis.controller.is_cascade(),
            Needs::VelocityLoop => axis.controller.uses_velocity_loop(),
        }
    }

    fn describe(self) -> &'static str {
        match self {
            Needs::Always => "",
            Needs::Cascade => "the cascade controller",
            Needs::VelocityLoop => "a controller that commands a velocity loop",
        }
    }
}

/// One numeric key of a part of the machine (`T`: an axis, its limits, the interpolation).
pub struct Key<T> {
    /// Path below the part, as in the machine file: `drive.backlash_um`.
    pub path: &'static str,
    /// Its unit, as the machine file gives it (empty for a ratio).
    pub unit: &'static str,
    /// The values a machine can have.
    pub rule: Rule,
    /// Which axes read it.
    pub needs: Needs,
    /// What it is, in a few words.
    pub meaning: &'static str,
    get: fn(&T) -> Option<f64>,
    set: fn(&mut T, f64) -> bool,
}

/// A key of an axis.
pub type AxisKey = Key<AxisConfig>;

impl<T> Key<T> {
    /// Its value; `None` where the part does not have its section (no velocity loop on a
    /// current amplifier, no state-feedback gains on the cascade).
    pub(crate) fn get(&self, on: &T) -> Option<f64> {
        (self.get)(on)
    }

    /// Sets it; whether it could (its section is there).
    pub(crate) fn set(&self, on: &mut T, value: f64) -> bool {
        (self.set)(on, value)
    }
}

/// A key of a section every part has.
macro_rules! key {
    ($path:literal, $unit:literal, $rule:expr, $needs:expr, $meaning:literal, |$a:ident| $field:expr) => {
        Key {
            path: $path,
            unit: $unit,
            rule: $rule,
            needs: $needs,
            meaning: $meaning,
            get: |$a| Some($field),
            set: |$a, v: f64| {
                $field = v;
                true
            },
        }
    };
}

/// A key of an optional section, or an optional value.
macro_rules! optional {
    ($path:literal, $unit:literal, $rule:expr, $needs:expr, $meaning:literal, |$a:ident| $section:expr, $s:ident => $field:expr) => {
        Key {
            path: $path,
            unit: $unit,
            rule: $rule,
            needs: $needs,
            meaning: $meaning,
            get: |$a| $section.as_ref().map(|$s| $field),
            set: |$a, value: f64| match $section.as_mut() {
                Some($s) => {
                    *(&mut $field) = value;
                    true
                }
                None => false,
            },
        }
    };
}

/// A key whose value may be left out of the file (`None`: the machine has no such limit or
/// setting): set, it is given — a sweep of a path acceleration limit on a machine without
/// one sets it.
macro_rules! optional_value {
    ($path:literal, $unit:literal, $rule:expr, $needs:expr, $meaning:literal, |$a:ident| $field:expr) => {
        Key {
            path: $path,
            unit: $unit,
            rule: $rule,
            needs: $needs,
            meaning: $meaning,
            get: |$a| $field,
            set: |$a, value: f64| {
                $field = Some(value);
                true
            },
        }
    };
}

/// A key of the state-feedback and transfer-function controllers, read from whichever the
/// axis has.
macro_rules! controller {
    ($path:literal, $unit:literal, $rule:expr, $meaning:literal, $($variant:ident)|+ => $field:ident) => {
        Key {
            path: $path,
            unit: $unit,
            rule: $rule,
            needs: Needs::Always,
            meaning: $meaning,
            get: |a| match &a.controller {
                $(Controller::$variant(c) => Some(c.$field),)+
                #[allow(unreachable_patterns)]
                _ => None,
            },
            set: |a, v: f64| match &mut a.controller {
                $(Controller::$variant(c) => {
                    c.$field = v;
                    true
                })+
                #[allow(unreachable_patterns)]
                _ => false,
            },
        }
    };
}

use Needs::{Always, Cascade, VelocityLoop};
use Rule::{NonNegative, Positive, Range};

/// Every scalar key of an axis (`[x]`, `[y]`), in the machine file's order.
pub const AXIS_KEYS: &[AxisKey] = &[
    // A loop 0.001 m/min/mm (0.017 1/s) closes over a minute, where machines' close within
    // a tenth of a second (0.5 m/min/mm and more): below it a program never ends its waits.
    key!(
        "position_loop.kv_m_per_min_per_mm",
        "m/min/mm",
        Range(1e-3, 100.0),
        Cascade,
        "position-loop gain K_v (1 m/min/mm = 16.667 1/s)",
        |a| a.position_loop.kv_m_per_min_per_mm
    ),
    key!(
        "position_loop.velocity_feedforward",
        "",
        Range(0.0, 2.0),
        Cascade,
        "velocity feed-forward share (0 off, 1 full)",
        |a| a.position_loop.velocity_feedforward
    ),
    key!(
        "position_loop.accel_feedforward",
        "",
        Range(0.0, 2.0),
        Cascade,
        "acceleration feed-forward share (0 off, 1 full)",
        |a| a.position_loop.accel_feedforward
    ),
    key!(
        "position_loop.dead_time_ms",
        "ms",
        Range(0.0, 1000.0),
        Always,
        "delay between the interpolator and the position controller",
        |a| a.position_loop.dead_time_ms
    ),
    // Below 1e-5 A/mm the position error that gives the current carrying a table's friction
    // (a tenth of an ampere and more) runs to 10 m and more: no loop that holds a position.
    controller!("controller.position_gain_a_per_mm", "A/mm", Range(1e-5, 1e6),
        "state feedback: current per millimetre of position error", StateFeedback => position_gain_a_per_mm),
    controller!("controller.integral_gain_a_per_mm_s", "A/(mm·s)", NonNegative(1e9),
        "state feedback: current per integrated position error", StateFeedback => integral_gain_a_per_mm_s),
    controller!("controller.velocity_gain_a_s_per_mm", "A·s/mm", NonNegative(1e6),
        "state feedback: current per velocity", StateFeedback => velocity_gain_a_s_per_mm),
    controller!("controller.velocity_feedforward", "", Range(0.0, 2.0),
        "state feedback or transfer function: velocity feed-forward share", StateFeedback | TransferFunction => velocity_feedforward),
    controller!("controller.accel_feedforward", "", Range(0.0, 2.0),
        "state feedback or transfer function: acceleration feed-forward share", StateFeedback | TransferFunction => accel_feedforward),
    controller!("controller.sample_ms", "ms", Range(0.0, 100.0),
        "transfer function: sampling period in z (0: given in s)", TransferFunction => sample_ms),
    // The loops' gains and times have floors far below any drive's, each said why: near zero
    // a loop has no gain, or its dynamics' entries (a time's inverse) are too large to
    // simulate, and the error would name the stability or the simulation, not the key.
    // K_s: a drive's is some 0.01 N·m·s/rad and more.
    optional!("velocity_loop.ks_nm_s_per_rad", "N·m·s/rad", Range(1e-6, 1e5), VelocityLoop,
        "velocity-loop proportional gain K_s as set on the control", |a| a.velocity_loop, l => l.ks_nm_s_per_rad),
    // T_s: 1 µs, a tenth of the fastest velocity loop's sampling period.
    optional!("velocity_loop.ts_ms", "ms", Range(1e-3, 1e6), VelocityLoop,
        "velocity-loop integral time T_s", |a| a.velocity_loop, l => l.ts_ms),
    // Current limits: 10 mA carries no feed drive's friction (the small table's 29 N on a
    // 10 mm lead takes 0.1 A of its 0.49 N·m/A motor).
    optional!("velocity_loop.i_max_a", "A", Range(1e-2, 1e5), VelocityLoop,
        "current command limit", |a| a.velocity_loop, l => l.i_max_a),
    // K_i: a current loop's is some volts per ampere, a microvolt per ampere is none.
    optional!("current_loop.ki_v_per_a", "V/A", Range(1e-6, 1e5), Always,
        "current-loop proportional gain K_i", |a| a.current_loop, l => l.ki_v_per_a),
    // T_i and the filters' time constant: 1 µs, below any current loop's sampling period.
    optional!("current_loop.ti_ms", "ms", Range(1e-3, 1e6), Always,
        "current-loop integral time T_i", |a| a.current_loop, l => l.ti_ms),
    optional!("current_loop.tcf_ms", "ms", Range(1e-3, 1e3), Always,
        "time constant of the current filters", |a| a.current_loop, l => l.tcf_ms),
    // Below a volt no servo motor turns at a feed: its back-EMF alone takes more.
    optional!("current_loop.u_max_v", "V", Range(1.0, 1e5), Always,
        "voltage limit", |a| a.current_loop, l => l.u_max_v),
    // A current amplifier's bandwidth is hundreds of hertz and more: 1 Hz is none's.
    optional!("amplifier.current_bandwidth_hz", "Hz", Range(1.0, 1e5), Always,
        "current amplifier's bandwidth", |a| a.amplifier, l => l.current_bandwidth_hz),
    Key {
        path: "amplifier.i_max_a",
        unit: "A",
        rule: Range(1e-2, 1e5),
        needs: Always,
        meaning: "current amplifier's current limit",
        get: |a| a.amplifier.as_ref().and_then(|l| l.i_max_a),
        set: |a, value| match a.amplifier.as_mut() {
            Some(l) => {
                l.i_max_a = Some(value);
                true
            }
            None => false,
        },
    },
    // R_a and L_a: a winding's are some 0.1 Ω and 1 mH; a microohm and a microhenry are no
    // motor's (near zero the current's equation divides by L_a).
    optional!("motor.ra_ohm", "Ω", Range(1e-6, 1e3), Always,
        "armature resistance R_a (with a current loop)", |a| a.motor.ra_ohm, r => *r),
    optional!("motor.la_mh", "mH", Range(1e-3, 1e4), Always,
        "armature inductance L_a (with a current loop)", |a| a.motor.la_mh, l => *l),
    // K_t: the smallest servo motors give some 0.01 N·m/A; at 1e-4 no feed drive's current
    // moves its table (near zero the gains `identify` finds relative to it grow without bound).
    key!(
        "motor.kt_nm_per_a",
        "N·m/A",
        Range(1e-4, 1e3),
        Always,
        "torque constant K_t (force constant in N/A on a linear motor)",
        |a| a.motor.kt_nm_per_a
    ),
    optional!("motor.ke_v_s_per_rad", "V·s/rad", NonNegative(1e3), Always,
        "back-EMF constant K_e (with a current loop)", |a| a.motor.ke_v_s_per_rad, k => *k),
    // Inertias, masses, the lead and the gear ratio have floors far below any machine's:
    // near zero they make the dynamics' entries too large to simulate, and the error would
    // then name the simulation, not the key.
    key!(
        "motor.jm_kg_m2",
        "kg·m²",
        Range(1e-9, 1e3),
        Always,
        "rotor inertia J_m",
        |a| a.motor.jm_kg_m2
    ),
    key!(
        "drive.js_kg_m2",
        "kg·m²",
        Range(1e-9, 1e3),
        Always,
        "screw inertia J_s",
        |a| a.drive.js_kg_m2
    ),
    // Stiffnesses: a coupling and screw twist at some 10³ N·m/rad and more, a screw, nut and
    // bearings yield at some 10⁷ N/m and more; 1 N·m/rad and 1 N/mm hold no table.
    key!(
        "drive.k_theta_nm_per_rad",
        "N·m/rad",
        Range(1.0, 1e12),
        Always,
        "torsional stiffness of coupling and screw",
        |a| a.drive.k_theta_nm_per_rad
    ),
    key!(
        "drive.k_m_n_per_m",
        "N/m",
        Range(1e3, 1e12),
        Always,
        "axial stiffness of screw, nut and bearings",
        |a| a.drive.k_m_n_per_m
    ),
    key!(
        "drive.zeta_theta",
        "",
        Range(0.0, 2.0),
        Always,
        "damping ratio of the torsional mode",
        |a| a.drive.zeta_theta
    ),
    key!(
        "drive.zeta_m",
        "",
        Range(0.0, 2.0),
        Always,
        "damping ratio of the axial mode",
        |a| a.drive.zeta_m
    ),
    key!(
        "drive.lead_mm",
        "mm",
        Range(1e-3, 1e4),
        Always,
        "screw lead",
        |a| a.drive.lead_mm
    ),
    key!(
        "drive.gear_ratio",
        "",
        Range(1e-3, 1e3),
        Always,
        "motor turns per screw turn",
        |a| a.drive.gear_ratio
    ),
    key!(
        "drive.table_mass_kg",
        "kg",
        Range(1e-3, 1e6),
        Always,
        "moving mass (table and load)",
        |a| a.drive.table_mass_kg
    ),
    key!(
        "drive.screw_viscous_nm_s_per_rad",
        "N·m·s/rad",
        NonNegative(1e6),
        Always,
        "viscous damping in the screw's bearings",
        |a| a.drive.screw_viscous_nm_s_per_rad
    ),
    key!(
        "drive.backlash_um",
        "µm",
        NonNegative(1e4),
        Always,
        "lost motion at a reversal (ball screw only)",
        |a| a.drive.backlash_um
    ),
    key!(
        "friction.coulomb_coefficient",
        "",
        Range(0.0, 1.0),
        Always,
        "Coulomb friction as a share of the moving weight",
        |a| a.friction.coulomb_coefficient
    ),
    key!(
        "friction.static_to_coulomb",
        "",
        Positive(10.0),
        Always,
        "static friction over Coulomb friction: at least 1 without presliding bristles, 0.1 with them (the level near rest)",
        |a| a.friction.static_to_coulomb
    ),
    key!(
        "friction.viscous_n_s_per_m",
        "N·s/m",
        NonNegative(1e8),
        Always,
        "viscous friction at the table",
        |a| a.friction.viscous_n_s_per_m
    ),
    key!(
        "friction.stribeck_level_n",
        "N",
        NonNegative(1e7),
        Always,
        "extra friction at rest that fades with speed (Stribeck)",
        |a| a.friction.stribeck_level_n
    ),
    key!(
        "friction.stribeck_velocity_mm_per_min",
        "mm/min",
        NonNegative(1e6),
        Always,
        "speed over which the Stribeck friction fades",
        |a| a.friction.stribeck_velocity_mm_per_min
    ),
    key!(
        "friction.bristle_stiffness_n_per_um",
        "N/µm",
        NonNegative(1e6),
        Always,
        "presliding (LuGre) bristle stiffness σ0; 0 = stick or slide, no presliding",
        |a| a.friction.bristle_stiffness_n_per_um
    ),
    key!(
        "friction.bristle_damping_n_s_per_m",
        "N·s/m",
        NonNegative(1e8),
        Always,
        "presliding (LuGre) bristle damping σ1",
        |a| a.friction.bristle_damping_n_s_per_m
    ),
    optional!("friction.static_to_coulomb_negative", "", Positive(10.0), Always,
        "with presliding bristles, friction near rest over Coulomb friction moving towards − where it differs from towards + (friction.static_to_coulomb then holds towards + alone): at least 0.1, and not with friction.stribeck_level_n",
        |a| a.friction.static_to_coulomb_negative, r => *r),
    optional!("gravity.counterbalance_n", "N", NonNegative(1e7), Always,
        "force of a counterbalance holding a vertical axis up", |a| a.gravity, g => g.counterbalance_n),
    // A beam a holder rides along is some metres; a centimetre is none. How stiff it must be
    // for the holder it carries is checked with the load (`validate`).
    optional!("lateral_shift.beam_length_m", "m", Range(0.01, 100.0), Always,
        "length of the beam the holder moves along", |a| a.lateral_shift, l => l.beam_length_m),
    optional!("lateral_shift.bending_stiffness_n_m2", "N·m²", Range(1.0, 1e13), Always,
        "bending stiffness E·I of the beam", |a| a.lateral_shift, l => l.bending_stiffness_n_m2),
    optional!("lateral_shift.holder_load_n", "N", NonNegative(1e8), Always,
        "weight of the tool holder on the beam", |a| a.lateral_shift, l => l.holder_load_n),
    optional!("lateral_shift.holder_at_zero_m", "m", Range(0.0, 100.0), Always,
        "where the holder is on the beam at position 0 (within the beam)", |a| a.lateral_shift, l => l.holder_at_zero_m),
    // The limits' floors: no machine's highest feed or rapid is below 1 mm/min (the heavy
    // machine's slowest cutting feed is 0.1), no axis accelerates at less than 1 mm/s² or
    // with less jerk than 0.01 m/s³ (a tenth of a second to 1 mm/s²). A rapid the axis
    // cannot brake from within its travel is allowed: a short axis never reaches it.
    key!(
        "limits.max_feed_mm_per_min",
        "mm/min",
        Range(1.0, 1e6),
        Always,
        "highest cutting feed",
        |a| a.limits.max_feed_mm_per_min
    ),
    key!(
        "limits.rapid_mm_per_min",
        "mm/min",
        Range(1.0, 1e6),
        Always,
        "rapid traverse rate (≥ the cutting feed)",
        |a| a.limits.rapid_mm_per_min
    ),
    key!(
        "limits.max_accel_m_per_s2",
        "m/s²",
        Range(1e-3, 1e4),
        Always,
        "acceleration limit",
        |a| a.limits.max_accel_m_per_s2
    ),
    key!(
        "limits.max_jerk_m_per_s3",
        "m/s³",
        Range(1e-2, 1e8),
        Always,
        "jerk limit",
        |a| a.limits.max_jerk_m_per_s3
    ),
    key!(
        "errors.scale_error_ppm",
        "ppm",
        Range(-1e5, 1e5),
        Always,
        "measuring-system scale error",
        |a| a.errors.scale_error_ppm
    ),
    key!(
        "errors.cyclic_amplitude_um",
        "µm",
        Range(0.0, 1e4),
        Always,
        "amplitude of a cyclic error over position",
        |a| a.errors.cyclic_amplitude_um
    ),
    key!(
        "errors.cyclic_period_mm",
        "mm",
        NonNegative(1e4),
        Always,
        "its period (a screw's lead, a scale's pitch)",
        |a| a.errors.cyclic_period_mm
    ),
    key!(
        "errors.cyclic_phase_deg",
        "°",
        Range(-1e6, 1e6),
        Always,
        "its phase at position 0",
        |a| a.errors.cyclic_phase_deg
    ),
    key!(
        "errors.force_ripple_n",
        "N",
        NonNegative(1e7),
        Always,
        "a force repeating with position (torque ripple, cogging, a screw's eccentricity)",
        |a| a.errors.force_ripple_n
    ),
    key!(
        "errors.force_ripple_period_mm",
        "mm",
        NonNegative(1e4),
        Always,
        "its period (a motor turn's travel); set, identify fits the ripple",
        |a| a.errors.force_ripple_period_mm
    ),
    key!(
        "errors.force_ripple_phase_deg",
        "°",
        Range(-1e6, 1e6),
        Always,
        "its phase φ at position 0: the force F = A·sin(2π·x/period + φ) pushes the table \
         towards − (a positive F acts against the + direction)",
        |a| a.errors.force_ripple_phase_deg
    ),
    key!(
        "errors.resonance_hz",
        "Hz",
        Range(0.0, 1e4),
        Always,
        "a structural resonance between table and measuring point (0: none)",
        |a| a.errors.resonance_hz
    ),
    key!(
        "errors.resonance_damping",
        "",
        Range(0.0, 2.0),
        Always,
        "its damping ratio",
        |a| a.errors.resonance_damping
    ),
    key!(
        "errors.squareness_urad",
        "µrad",
        Range(-1e5, 1e5),
        Always,
        "out-of-squareness to the other axis",
        |a| a.errors.squareness_urad
    ),
    key!(
        "errors.straightness_bow_um",
        "µm",
        Range(-1e4, 1e4),
        Always,
        "straightness: bow at mid-span",
        |a| a.errors.straightness_bow_um
    ),
    key!(
        "errors.straightness_span_mm",
        "mm",
        Range(1.0, 1e5),
        Always,
        "span the bow is measured over",
        |a| a.errors.straightness_span_mm
    ),
    key!(
        "errors.lateral_play_um",
        "µm",
        Range(-1e4, 1e4),
        Always,
        "sideways play across this axis when the other reverses",
        |a| a.errors.lateral_play_um
    ),
    key!(
        "errors.direction_offset_um",
        "µm",
        Range(-1e4, 1e4),
        Always,
        "offset between the two directions of travel",
        |a| a.errors.direction_offset_um
    ),
];

/// Every scalar key of a planned-only axis's limits (`[z.limits]`).
pub const LIMIT_KEYS: &[Key<Limits>] = &[
    key!(
        "max_feed_mm_per_min",
        "mm/min",
        Range(1.0, 1e6),
        Always,
        "highest cutting feed",
        |l| l.max_feed_mm_per_min
    ),
    key!(
        "rapid_mm_per_min",
        "mm/min",
        Range(1.0, 1e6),
        Always,
        "rapid traverse rate",
        |l| l.rapid_mm_per_min
    ),
    key!(
        "max_accel_m_per_s2",
        "m/s²",
        Range(1e-3, 1e4),
        Always,
        "acceleration limit",
        |l| l.max_accel_m_per_s2
    ),
    key!(
        "max_jerk_m_per_s3",
        "m/s³",
        Range(1e-2, 1e8),
        Always,
        "jerk limit",
        |l| l.max_jerk_m_per_s3
    ),
];

/// Every scalar key of `[interpolation]`.
pub const INTERPOLATION_KEYS: &[Key<Interpolation>] = &[
    key!(
        "cycle_ms",
        "ms",
        Range(0.05, 100.0),
        Always,
        "interpolation cycle",
        |i| i.cycle_ms
    ),
    key!(
        "in_position_window_mm",
        "mm",
        Positive(100.0),
        Always,
        "in-position window at exact stops",
        |i| i.in_position_window_mm
    ),
    key!(
        "arc_normal_share",
        "",
        Range(0.01, 0.99),
        Always,
        "share of the acceleration limit an arc may spend on its centripetal part",
        |i| i.arc_normal_share
    ),
    optional_value!(
        "path_accel_m_per_s2",
        "m/s²",
        Positive(1e4),
        Always,
        "path acceleration limit (else the axes')",
        |i| i.path_accel_m_per_s2
    ),
    optional_value!(
        "path_jerk_m_per_s3",
        "m/s³",
        Positive(1e8),
        Always,
        "path jerk limit (else the axes')",
        |i| i.path_jerk_m_per_s3
    ),
];

/// The unit of the axis key `path`, read from the table while the program is built: called
/// in a constant, a path the table does not have stops the build.
pub const fn axis_unit(path: &str) -> &'static str {
    let mut i = 0;
    while i < AXIS_KEYS.len() {
        if same_text(AXIS_KEYS[i].path, path) {
            return AXIS_KEYS[i].unit;
        }
        i += 1;
    }
    panic!("not an axis key of the machine file")
}

/// Whether two texts are equal, in a constant.
const fn same_text(a: &str, b: &str) -> bool {
    let (a, b) = (a.as_bytes(), b.as_bytes());
    if a.len() != b.len() {
        return false;
    }
    let mut i = 0;
    while i < a.len() {
        if a[i] != b[i] {
            return false;
        }
        i += 1;
    }
    true
}

/// The axis key of that path, if the table has it.
pub(crate) fn axis_key(path: &str) -> Option<&'static AxisKey> {
    AXIS_KEYS.iter().find(|k| k.path == path)
}

/// A key's value on an axis; `None` for a key not in the table or a section the axis does
/// not have.
pub fn get(axis: &AxisConfig, path: &str) -> Option<f64> {
    axis_key(path).and_then(|k| k.get(axis))
}

/// Sets a key on an axis; whether it could (the key is in the table and its section there).
pub(crate) fn set(axis: &mut AxisConfig, path: &str, value: f64) -> bool {
    axis_key(path).is_some_and(|k| k.set(axis, value))
}

/// Every full dotted key of a machine's table: `x.drive.backlash_um`, `z.limits.…`,
/// `interpolation.cycle_ms`.
pub fn machine_paths() -> Vec<String> {
    let axes = ["x", "y"]
        .iter()
        .flat_map(|a| AXIS_KEYS.iter().map(move |k| format!("{a}.{}", k.path)));
    let z = LIMIT_KEYS.iter().map(|k| format!("z.limits.{}", k.path));
    let interpolation = INTERPOLATION_KEYS
        .iter()
        .map(|k| format!("interpolation.{}", k.path));
    axes.chain(z).chain(interpolation).collect()
}

/// Why a full dotted key cannot be set on a machine.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum SetError {
    /// The table has no such key.
    Unknown,
    /// The machine does not have its section (no velocity loop on a current amplifier).
    Absent,
    /// The axis's controller does not read it.
    Unused(Needs),
}

impl std::fmt::Display for SetError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SetError::Unknown => write!(f, "is no numeric key of a machine"),
            SetError::Absent => write!(f, "is in a section this machine does not have"),
            SetError::Unused(needs) => {
                write!(
                    f,
                    "is not used: only an axis with {} reads it",
                    needs.describe()
                )
            }
        }
    }
}

impl std::error::Error for SetError {}

/// Sets a full dotted key (`x.drive.backlash_um`) on a machine.
pub(crate) fn set_on_machine(m: &mut MachineConfig, key: &str, value: f64) -> Result<(), SetError> {
    let (part, rest) = key.split_once('.').ok_or(SetError::Unknown)?;
    let done = match part {
        "x" | "y" => {
            let axis = if part == "x" { &mut m.x } else { &mut m.y };
            let k = axis_key(rest).ok_or(SetError::Unknown)?;
            if !k.needs.holds(axis) {
                return Err(SetError::Unused(k.needs));
            }
            k.set(axis, value)
        }
        "z" => match &mut m.z {
            ZAxis::Simulated(axis) => {
                let k = axis_key(rest).ok_or(SetError::Unknown)?;
                if !k.needs.holds(axis) {
                    return Err(SetError::Unused(k.needs));
                }
                k.set(axis, value)
            }
            ZAxis::Carried(planned) => {
                let leaf = rest.strip_prefix("limits.").ok_or(SetError::Unknown)?;
                let k = LIMIT_KEYS
                    .iter()
                    .find(|k| k.path == leaf)
                    .ok_or(SetError::Unknown)?;
                k.set(&mut planned.limits, value)
            }
        },
        "interpolation" => {
            let k = INTERPOLATION_KEYS
                .iter()
                .find(|k| k.path == rest)
                .ok_or(SetError::Unknown)?;
            k.set(&mut m.interpolation, value)
        }
        _ => return Err(SetError::Unknown),
    };
    if done { Ok(()) } else { Err(SetError::Absent) }
}

/// A full dotted key's value on a machine; `None` for a key not in the table or a section
/// the machine does not have.
pub fn get_on_machine(m: &MachineConfig, key: &str) -> Option<f64> {
    let (part, rest) = key.split_once('.')?;
    match part {
        "x" => get(&m.x, rest),
        "y" => get(&m.y, rest),
        "z" => match &m.z {
            ZAxis::Simulated(axis) => get(axis, rest),
            ZAxis::Carried(planned) => {
                let leaf = rest.strip_prefix("limits.")?;
                LIMIT_KEYS
                    .iter()
                    .find(|k| k.path == leaf)?
                    .get(&planned.limits)
            }
        },
        "interpolation" => INTERPOLATION_KEYS
            .iter()
            .find(|k| k.path == rest)?
            .get(&m.interpolation),
        _ => None,
    }
}

/// A full dotted key's unit (empty for a ratio); `None` for a key not in the table.
#[cfg(feature = "cli")]
pub(crate) fn unit_on_machine(key: &str) -> Option<&'static str> {
    let (part, rest) = key.split_once('.')?;
    match part {
        "x" | "y" => axis_key(rest).map(|k| k.unit),
        "z" => {
            let leaf = rest.strip_prefix("limits.")?;
            LIMIT_KEYS.iter().find(|k| k.path == leaf).map(|k| k.unit)
        }
        "interpolation" => INTERPOLATION_KEYS
            .iter()
            .find(|k| k.path == rest)
            .map(|k| k.unit),
        _ => None,
    }
}

/// The reference of every key as Markdown: `docs/machine-keys.md` is this text.
pub fn reference_markdown() -> String {
    fn rows<T>(out: &mut String, prefix: &str, keys: &[Key<T>]) {
        out.push_str("| key | unit | range | meaning |\n|---|---|---|---|\n");
        for k in keys {
            let needs = match k.needs {
                Needs::Always => String::new(),
                n => format!("; only with {}", n.describe()),
            };
            let unit = if k.unit.is_empty() { "—" } else { k.unit };
            out.push_str(&format!(
                "| `{prefix}{}` | {unit} | {} | {}{needs} |\n",
                k.path,
                k.rule.describe(),
                k.meaning
            ));
        }
    }
    let mut out = String::from(
        "# Machine file keys\n\n\
         Generated from the key table in `src/machine/keys.rs` (a test keeps the two equal). \
         Every number of a machine file, its unit and the range validation accepts; \
         `docs/machine-file.md` explains the file and its sections. Lists (the error tables, \
         a transfer function's coefficients, `limits.travel_mm`) and words (`controller.structure`, \
         `position_loop.feedback`, `drive.kind`) are described there.\n\n\
         ## `[interpolation]`\n\n",
    );
    rows(&mut out, "interpolation.", INTERPOLATION_KEYS);
    out.push_str("\n## `[x]` and `[y]`\n\n");
    rows(&mut out, "", AXIS_KEYS);
    out.push_str("\n## `[z.limits]`\n\n");
    rows(&mut out, "z.limits.", LIMIT_KEYS);
    out
}

#[cfg(test)]
mod tests;
