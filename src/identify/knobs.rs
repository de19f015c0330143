//! The values identification fits, as keys of the machine file: which ones, by controller
//! structure, how each is searched (a factor on a positive value, or an increment in units of
//! its scale) and within what range.

use nalgebra::Complex;

use super::ComplexPair;
use crate::machine::{AxisConfig, Controller, DriveKind, Feedback, TransferFunction};
use crate::numeric::poly;
use crate::numeric::units::GRAVITY_M_PER_S2;
use crate::sim::MeasuredAt;

/// Relative (or, for increments, scaled) uncertainty beyond which a value counts as not
/// determined by the record.
const UNDETERMINED: f64 = 0.5;
/// The same for a controller's corner: one the record leaves more than 5 % open lies beyond
/// what the record excites (a derivative filter's pole far above the loop's bandwidth), and
/// fitted it would only follow the noise — each half of the record puts it elsewhere, and
/// the gain with it. The design's value is kept.
const CORNER_UNDETERMINED: f64 = 0.05;
/// The least relative uncertainty of any value: on records of known machines, the read-back
/// commands alone moved a fitted mass by 0.3 % while the noise allowed 0.05 %.
const INPUT_FLOOR: f64 = 0.005;
/// Static friction's: the breakaway comes where the commanded acceleration at a reversal
/// has built up enough force, and that acceleration is the one read back, not the
/// control's. On the tool's own records behind a foreign interpolator, an axis with play
/// had its static friction come back 9 % high, at 4 of its uncertainties by the floor
/// above.
const STATIC_INPUT_FLOOR: f64 = 0.1;

/// A value of an axis that identification fits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Knob {
    /// Key below the axis, as in the machine file (`friction.coulomb_n` for the Coulomb
    /// force, written back as the coefficient).
    pub key: &'static str,
    /// Unit as shown.
    pub unit: &'static str,
    /// Searched as a factor on its value (a positive value) rather than an increment.
    pub logarithmic: bool,
    /// For increments: the least scale of a step, and the yardstick of "not determined"
    /// (the value itself, where larger).
    pub least_scale: f64,
    /// Relative (or, for increments, scaled) uncertainty beyond which the record does not
    /// determine the value.
    pub undetermined_beyond: f64,
    /// The least relative uncertainty it is reported with: what driving the model with
    /// commands read back from the record (resampled, their velocity and acceleration fitted
    /// over a few milliseconds) rather than the control's own can move it by.
    pub input_floor: f64,
    /// Range the value is kept in.
    pub min: f64,
    /// Upper end.
    pub max: f64,
}

impl Knob {
    /// Whether an uncertainty `sigma` leaves `value` determined: within
    /// `undetermined_beyond` of its size (the value itself, or the knob's scale there).
    pub(crate) fn determines(&self, sigma: f64, value: f64) -> bool {
        let size = if self.logarithmic {
            value.abs()
        } else {
            self.scale_at(value)
        };
        sigma.is_finite() && sigma <= self.undetermined_beyond * size
    }

    /// Whether a fit that stays above the record's noise keeps the value at what it found
    /// rather than putting the template's back: where it determines it, and for a corner
    /// also where it is looser than its own bound but within the general one — such a
    /// corner is a model's value, not a measurement, and the design's corner it replaces may
    /// lie several times off (a controller tuned on the machine): put back, it would leave
    /// the fit of the rest worse than either. Whether the corners are kept at all the
    /// held-out halves decide. (A fit at the noise puts back what it does not determine.)
    pub(crate) fn stays_fitted(&self, sigma: f64, value: f64) -> bool {
        if self.is_corner() {
            sigma.is_finite() && sigma <= UNDETERMINED * value.abs()
        } else {
            self.determines(sigma, value)
        }
    }

    /// Whether it is one of a transfer function's corners.
    pub(crate) fn is_corner(&self) -> bool {
        corner_of(self.key).is_some()
    }

    /// The scale of an increment about `value`.
    pub(crate) fn scale_at(&self, value: f64) -> f64 {
        value.abs().max(self.least_scale)
    }
}

const KV: Knob = Knob {
    key: "position_loop.kv_m_per_min_per_mm",
    unit: "m/min/mm",
    logarithmic: true,
    least_scale: 0.0,
    undetermined_beyond: UNDETERMINED,
    input_floor: INPUT_FLOOR,
    min: 0.01,
    max: 100.0,
};
const VELOCITY_FEEDFORWARD: Knob = Knob {
    key: "position_loop.velocity_feedforward",
    unit: "",
    logarithmic: false,
    least_scale: 0.1,
    undetermined_beyond: UNDETERMINED,
    input_floor: INPUT_FLOOR,
    min: 0.0,
    max: 1.2,
};
const INTEGRAL_TIME: Knob = Knob {
    key: "velocity_loop.ts_ms",
    unit: "ms",
    logarithmic: true,
    least_scale: 0.0,
    undetermined_beyond: UNDETERMINED,
    input_floor: INPUT_FLOOR,
    min: 0.1,
    max: 1e4,
};
const MASS: Knob = Knob {
    key: "drive.table_mass_kg",
    unit: "kg",
    logarithmic: true,
    least_scale: 0.0,
    undetermined_beyond: UNDETERMINED,
    input_floor: INPUT_FLOOR,
    min: 0.1,
    max: 1e6,
};
const VISCOUS: Knob = Knob {
    key: "friction.viscous_n_s_per_m",
    unit: "N·s/m",
    logarithmic: false,
    least_scale: 100.0,
    undetermined_beyond: UNDETERMINED,
    input_floor: INPUT_FLOOR,
    min: 0.0,
    max: 1e8,
};
const DEAD_TIME: Knob = Knob {
    key: "position_loop.dead_time_ms",
    unit: "ms",
    logarithmic: false,
    least_scale: 1.0,
    undetermined_beyond: UNDETERMINED,
    input_floor: INPUT_FLOOR,
    min: 0.0,
    max: 100.0,
};
const COULOMB: Knob = Knob {
    key: "friction.coulomb_n",
    unit: "N",
    logarithmic: false,
    least_scale: 10.0,
    undetermined_beyond: UNDETERMINED,
    input_floor: INPUT_FLOOR,
    min: 0.0,
    max: 1e6,
};

/// The force the axis holds at rest at the record's start (docs/model.md §1.10): a state of
/// the record, not of the machine. Fitted beside the machine's values where the samples
/// fitted hold the axis's first start from rest ([`Fit::holds_start`]), searched within the
/// friction's level at rest (`Fit`'s bounds), never written to a file.
///
/// [`Fit::holds_start`]: super::solve::Fit::holds_start
pub(crate) const HELD_AT_START: Knob = Knob {
    key: "held_at_start_n",
    unit: "N",
    logarithmic: false,
    least_scale: 10.0,
    undetermined_beyond: UNDETERMINED,
    input_floor: INPUT_FLOOR,
    min: -1e6,
    max: 1e6,
};

/// The nut's free play, in the screw's travel: seen where the record or the control reads
/// the table (between motor and table it is lost motion at each reversal).
const BACKLASH: Knob = Knob {
    key: "drive.backlash_um",
    unit: "µm",
    logarithmic: false,
    least_scale: 1.0,
    undetermined_beyond: UNDETERMINED,
    input_floor: INPUT_FLOOR,
    min: 0.0,
    max: 500.0,
};
/// Static friction over Coulomb's: seen where the axis sticks (each start and reversal).
const STATIC: Knob = Knob {
    key: "friction.static_to_coulomb",
    unit: "",
    logarithmic: false,
    least_scale: 0.1,
    undetermined_beyond: UNDETERMINED,
    input_floor: STATIC_INPUT_FLOOR,
    min: 1.0,
    max: 5.0,
};
/// The same on an axis with presliding bristles, where friction near rest may lie below
/// Coulomb's down to the tenth the machine file allows.
pub(crate) const STATIC_WITH_BRISTLES: Knob = Knob { min: 0.1, ..STATIC };
/// The level near rest towards − on an axis with bristles, where it differs from the level
/// towards + ([`STATIC_WITH_BRISTLES`], which then holds towards + alone).
pub(crate) const STATIC_NEGATIVE_WITH_BRISTLES: Knob = Knob {
    key: "friction.static_to_coulomb_negative",
    ..STATIC_WITH_BRISTLES
};

/// A transfer-function controller's gain at low frequency: the ratio of the lowest-order
/// coefficients of numerator and denominator (an integrating controller's integral gain, a
/// PD's proportional gain), the whole numerator scaled with it (its zeros kept). Measured
/// there, it does not trade with the corners above the loop's bandwidth, which a record
/// barely sees (a derivative filter's pole), as the leading coefficient would.
const TF_GAIN: Knob = Knob {
    key: "controller.gain",
    unit: "",
    logarithmic: true,
    least_scale: 0.0,
    undetermined_beyond: UNDETERMINED,
    input_floor: INPUT_FLOOR,
    min: 1e-9,
    max: 1e12,
};
const SF_POSITION: Knob = Knob {
    key: "controller.position_gain_a_per_mm",
    unit: "A/mm",
    logarithmic: true,
    least_scale: 0.0,
    undetermined_beyond: UNDETERMINED,
    input_floor: INPUT_FLOOR,
    min: 1e-6,
    max: 1e6,
};
const SF_INTEGRAL: Knob = Knob {
    key: "controller.integral_gain_a_per_mm_s",
    unit: "A/(mm·s)",
    logarithmic: true,
    least_scale: 0.0,
    undetermined_beyond: UNDETERMINED,
    input_floor: INPUT_FLOOR,
    min: 1e-6,
    max: 1e9,
};
const SF_VELOCITY: Knob = Knob {
    key: "controller.velocity_gain_a_s_per_mm",
    unit: "A·s/mm",
    logarithmic: true,
    least_scale: 0.0,
    undetermined_beyond: UNDETERMINED,
    input_floor: INPUT_FLOOR,
    min: 1e-9,
    max: 1e6,
};

/// A transfer function's real zeros and poles in the left half-plane, as corner frequencies,
/// lowest first (a repeated one moves as one): up to two of each are fitted. Integrators
/// (poles at 0), complex pairs and a digital controller's roots in z are the template's.
const fn corner(key: &'static str) -> Knob {
    Knob {
        key,
        unit: "Hz",
        logarithmic: true,
        least_scale: 0.0,
        undetermined_beyond: CORNER_UNDETERMINED,
        input_floor: INPUT_FLOOR,
        min: 0.01,
        max: 1e5,
    }
}

/// The share of its controller's Nyquist frequency a fitted corner stays below. A discrete
/// controller cannot place a corner at or above its Nyquist frequency at all; below it, its
/// Tustin realisation puts a continuous corner f at atan(π f T)/(π T), 15 % low at half the
/// Nyquist frequency and worse beyond — there the continuous model's corner no longer stands
/// for the controller's.
const CORNER_NYQUIST_SHARE: f64 = 0.5;

/// The highest corner (Hz) a fit searches on a controller that runs every `period_s` (s).
pub(crate) fn corner_ceiling_hz(period_s: f64) -> f64 {
    if period_s.is_finite() && period_s > 0.0 {
        CORNER_NYQUIST_SHARE * 0.5 / period_s
    } else {
        f64::INFINITY
    }
}

/// The period (s) an axis's controller runs at, where the machine file gives one: a transfer
/// function written in z runs every `sample_ms`. One written in s has none — the simulation
/// integrates its states exactly with the drive's, the reference a polynomial in time over
/// each interpolation cycle, so neither the interpolation cycle nor a record's sampling is
/// its period (a position controller often runs several times per interpolation cycle, and
/// a trace is logged at whatever rate its logger was set to): 0.
pub(crate) fn controller_period_s(axis: &AxisConfig) -> f64 {
    match &axis.controller {
        Controller::TransferFunction(tf) if tf.sample_ms > 0.0 => 1e-3 * tf.sample_ms,
        _ => 0.0,
    }
}

/// The highest corner (Hz) a fit searches on `axis`'s controller, from a record sampled
/// every `record_step_s` (s): below half its own Nyquist frequency where it has a period,
/// and below the record's Nyquist frequency always. A corner above the latter lies where
/// the record has no samples to place it: fitted there, it follows the noise of the few
/// points its tail bends (a pole at 92 kHz from a 10 kHz trace), a value no controller of
/// that record could be shown to have.
pub(crate) fn corner_ceiling_of(axis: &AxisConfig, record_step_s: f64) -> f64 {
    let record_nyquist_hz = if record_step_s.is_finite() && record_step_s > 0.0 {
        0.5 / record_step_s
    } else {
        f64::INFINITY
    };
    corner_ceiling_hz(controller_period_s(axis)).min(record_nyquist_hz)
}

const CORNERS: [Knob; 4] = [
    corner("controller.zero_1_hz"),
    corner("controller.zero_2_hz"),
    corner("controller.pole_1_hz"),
    corner("controller.pole_2_hz"),
];

/// Which polynomial and which of its corners a corner key names.
pub(crate) fn corner_of(key: &str) -> Option<(bool, usize)> {
    let rest = key.strip_prefix("controller.")?.strip_suffix("_hz")?;
    let (kind, k) = rest.split_once('_')?;
    let k: usize = k.parse().ok()?;
    match kind {
        "zero" => Some((true, k - 1)),
        "pole" => Some((false, k - 1)),
        _ => None,
    }
}

/// Roots of a polynomial grouped as they repeat, and the indices (into that list) of its
/// real left-half-plane ones, lowest corner first.
pub(crate) fn corners(coefficients: &[f64]) -> (Vec<(Complex<f64>, usize)>, Vec<usize>) {
    // Coefficients typed to four or five figures split a double root by a few parts in a
    // thousand: within a hundredth, a pair is one root twice (damping above 0.99995).
    let mut groups = poly::distinct(&poly::roots(coefficients), 1e-2);
    // An integrator's pole at 0 comes out a rounding off it: put back at 0 (a written
    // controller keeps its exact integrator), and kept there.
    let size = groups.iter().map(|g| g.0.norm()).fold(0.0, f64::max);
    for g in &mut groups {
        if g.0.norm() <= 1e-9 * size {
            g.0 = Complex::new(0.0, 0.0);
        }
    }
    let mut real: Vec<usize> = (0..groups.len())
        .filter(|&i| groups[i].0.im == 0.0 && groups[i].0.re < -1e-9 * size)
        .collect();
    real.sort_by(|&a, &b| groups[b].0.re.total_cmp(&groups[a].0.re));
    (groups, real)
}

/// The corner (Hz) of `coefficients`' `k`-th real root, lowest first.
fn corner_hz(coefficients: &[f64], k: usize) -> f64 {
    let (groups, real) = corners(coefficients);
    real.get(k)
        .map_or(f64::NAN, |&i| -groups[i].0.re / std::f64::consts::TAU)
}

/// Where corner `key` of `axis`'s transfer function is no longer a real root (the fit took
/// two real corners into a complex pair): the lowest complex pair of that polynomial. None
/// for a real corner, another key or another controller.
pub(crate) fn complex_pair(axis: &AxisConfig, key: &str) -> Option<ComplexPair> {
    let (zero, _) = corner_of(key)?;
    let Controller::TransferFunction(tf) = &axis.controller else {
        return None;
    };
    if get(axis, key).is_finite() {
        return None;
    }
    let (groups, _) = corners(if zero { &tf.numerator } else { &tf.denominator });
    groups
        .iter()
        .map(|g| g.0)
        .filter(|r| r.im > 0.0)
        .min_by(|a, b| a.norm().total_cmp(&b.norm()))
        .map(|r| ComplexPair {
            natural_hz: r.norm() / std::f64::consts::TAU,
            damping: -r.re / r.norm(),
        })
}

/// `coefficients` with its real roots set to the corners given (by index, lowest first as
/// they were), the leading coefficient and the other roots kept.
fn with_corners(coefficients: &[f64], set: &[(usize, f64)]) -> Vec<f64> {
    let (mut groups, real) = corners(coefficients);
    for &(k, hz) in set {
        if let Some(&i) = real.get(k) {
            groups[i].0 = Complex::new(-std::f64::consts::TAU * hz, 0.0);
        }
    }
    let all: Vec<Complex<f64>> = groups
        .iter()
        .flat_map(|&(r, n)| std::iter::repeat_n(r, n))
        .collect();
    let fitted = poly::from_roots(leading(coefficients), &all);
    // As long as the polynomial was (leading zeros kept out).
    let mut out = vec![0.0; coefficients.len().saturating_sub(fitted.len())];
    out.extend(fitted);
    out
}

/// The keys of the controllers' gains, as the search refers to them.
pub const TF_GAIN_KEY: &str = TF_GAIN.key;
pub const SF_POSITION_KEY: &str = SF_POSITION.key;
pub const SF_INTEGRAL_KEY: &str = SF_INTEGRAL.key;
pub const SF_VELOCITY_KEY: &str = SF_VELOCITY.key;

/// The keys of the cascade's position gain, the velocity integral time, the mass and the
/// Coulomb force, as the search refers to them.
pub const KV_KEY: &str = KV.key;
pub const INTEGRAL_TIME_KEY: &str = INTEGRAL_TIME.key;
pub const MASS_KEY: &str = MASS.key;
pub const COULOMB_KEY: &str = COULOMB.key;
pub const VISCOUS_KEY: &str = VISCOUS.key;
pub const BACKLASH_KEY: &str = BACKLASH.key;
pub const STATIC_KEY: &str = STATIC.key;

/// The plant's nonlinear parts a template sets that a record may show: static friction
/// where the axis has Coulomb friction to stick with, and the nut's play where the record
/// or the control reads the table beyond it (a ball screw's). Fitted on top of the
/// template's values where those alone leave the record above its noise.
pub(crate) fn nonlinear_for(axis: &AxisConfig, measured_at: MeasuredAt) -> Vec<Knob> {
    let mut knobs = Vec::new();
    let screw = axis.drive.kind != DriveKind::LinearMotor;
    let table_seen =
        measured_at != MeasuredAt::Motor || axis.position_loop.feedback == Feedback::LinearScale;
    if screw && table_seen {
        knobs.push(BACKLASH);
    }
    let f = &axis.friction;
    if f.coulomb_coefficient > 0.0 {
        if !f.has_presliding() {
            knobs.push(STATIC);
        } else if f.stribeck_velocity_mm_per_min > 0.0 {
            // Bristles without a fade speed slide at Coulomb's level from rest: the level
            // near rest acts nowhere, so there is nothing to fit.
            knobs.push(STATIC_WITH_BRISTLES);
        }
    }
    knobs
}

/// What is fitted on an axis: the controller's gains with the mechanics — users rarely know
/// the gains the drive really runs with (set in its own units and scalings, retuned on site).
///
/// A gain and the moving mass would act on the record only through their ratio if the mass
/// were all there is to move; the motor's and the screw's inertia (the data sheet's, kept)
/// tell them apart, and where the record cannot, the uncertainty says so and the template's
/// value stays. What no record separates is kept from the template: on the cascade (and a
/// transfer function commanding a velocity loop) the velocity loop's K_s, which the whole
/// drive's inertia is found relative to; on a controller that commands current, the torque
/// constant, which multiplies every gain. Zeros and poles are the template's.
pub(crate) fn for_axis(axis: &AxisConfig) -> Vec<Knob> {
    match &axis.controller {
        Controller::Cascade => vec![
            KV,
            VELOCITY_FEEDFORWARD,
            INTEGRAL_TIME,
            MASS,
            VISCOUS,
            DEAD_TIME,
            COULOMB,
        ],
        Controller::TransferFunction(tf) => {
            let mut knobs = vec![TF_GAIN, MASS, VISCOUS, DEAD_TIME, COULOMB];
            if tf.sample_ms == 0.0 {
                knobs.extend(CORNERS.iter().filter(|k| get(axis, k.key).is_finite()));
            }
            knobs
        }
        Controller::StateFeedback(sf) => {
            let mut knobs = vec![SF_POSITION, SF_VELOCITY, MASS];
            if sf.integral_gain_a_per_mm_s > 0.0 {
                knobs.push(SF_INTEGRAL);
            }
            knobs.extend([VISCOUS, DEAD_TIME, COULOMB]);
            knobs
        }
    }
}

/// What the template gives that the record cannot tell apart from a fitted value, said in the
/// report.
pub(crate) fn kept(axis: &AxisConfig) -> &'static str {
    if axis.controller.uses_velocity_loop() {
        "velocity_loop.ks_nm_s_per_rad (mass and friction are found relative to it)"
    } else {
        "motor.kt_nm_per_a and the motor's and screw's inertia (the gains are found relative \
         to the torque constant, the table's mass to the rotating inertia), the controller's \
         integrators and complex zeros and poles"
    }
}

/// A knob's value on an axis (the Coulomb friction as a force at the table; the others
/// through the machine's key table).
pub(crate) fn get(axis: &AxisConfig, key: &str) -> f64 {
    match key {
        "controller.gain" => match &axis.controller {
            Controller::TransferFunction(tf) => low_frequency_gain(tf),
            _ => f64::NAN,
        },
        corner if corner_of(corner).is_some() => match (&axis.controller, corner_of(corner)) {
            (Controller::TransferFunction(tf), Some((true, k))) => corner_hz(&tf.numerator, k),
            (Controller::TransferFunction(tf), Some((false, k))) => corner_hz(&tf.denominator, k),
            _ => f64::NAN,
        },
        "friction.coulomb_n" => {
            axis.friction.coulomb_coefficient * axis.drive.table_mass_kg * GRAVITY_M_PER_S2
        }
        "held_at_start_n" => axis.held_at_start_n,
        // Where the machine gives no level of its own towards −, the one level holds both ways.
        "friction.static_to_coulomb_negative" => {
            (axis.friction.static_to_coulomb_negative).unwrap_or(axis.friction.static_to_coulomb)
        }
        other => crate::machine::keys::get(axis, other).unwrap_or(f64::NAN),
    }
}

/// Sets `keys` on an axis to `values`. The Coulomb force stays the force it was (fitted or
/// not) whatever mass is set with it: the machine file holds it as a share of the weight.
pub(crate) fn set_all(axis: &mut AxisConfig, keys: &[&str], values: &[f64]) {
    let mut coulomb_n = get(axis, "friction.coulomb_n");
    // Corners are set together, by their order before any moved.
    let (mut zeros, mut poles) = (Vec::new(), Vec::new());
    for (&key, &v) in keys.iter().zip(values) {
        if let Some((zero, k)) = corner_of(key) {
            if zero { &mut zeros } else { &mut poles }.push((k, v));
        }
    }
    if let Controller::TransferFunction(tf) = &mut axis.controller
        && (!zeros.is_empty() || !poles.is_empty())
    {
        // The corners move with the low-frequency gain held.
        let gain = low_frequency_gain(tf);
        tf.numerator = with_corners(&tf.numerator, &zeros);
        tf.denominator = with_corners(&tf.denominator, &poles);
        scale_to_gain(tf, gain);
    }
    for (&key, &v) in keys.iter().zip(values) {
        if corner_of(key).is_some() {
            continue;
        }
        if key == "friction.coulomb_n" {
            coulomb_n = v;
        } else if key == HELD_AT_START.key {
            axis.held_at_start_n = v;
        } else if key == "controller.gain" {
            if let Controller::TransferFunction(tf) = &mut axis.controller {
                scale_to_gain(tf, v);
            }
        } else {
            crate::machine::keys::set(axis, key, v);
        }
    }
    axis.friction.coulomb_coefficient = coulomb_n / (axis.drive.table_mass_kg * GRAVITY_M_PER_S2);
}

/// The ratio of the lowest-order coefficients (the last that are not zero) of the
/// numerator and the denominator.
fn low_frequency_gain(tf: &TransferFunction) -> f64 {
    let last = |c: &[f64]| {
        c.iter()
            .rev()
            .copied()
            .find(|v| *v != 0.0)
            .unwrap_or(f64::NAN)
    };
    last(&tf.numerator) / last(&tf.denominator)
}

/// The numerator scaled so that the low-frequency gain is `gain`.
fn scale_to_gain(tf: &mut TransferFunction, gain: f64) {
    let factor = gain / low_frequency_gain(tf);
    if factor.is_finite() {
        tf.numerator.iter_mut().for_each(|c| *c *= factor);
    }
}

/// A polynomial's first coefficient that is not zero.
fn leading(coefficients: &[f64]) -> f64 {
    coefficients
        .iter()
        .copied()
        .find(|c| *c != 0.0)
        .unwrap_or(f64::NAN)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_corner_stays_where_a_controller_at_the_records_rate_can_place_it() {
        // The real table's controller: 10 kHz.
        let t = 1e-4;
        let ceiling = corner_ceiling_hz(t);
        let nyquist = 0.5 / t;
        assert!(ceiling < nyquist, "{ceiling} Hz");
        // Tustin at period T realises a continuous corner f at atan(π f T)/(π T): at the
        // ceiling 15 % low; at the Nyquist frequency 36 % low.
        let realised = |f: f64| (std::f64::consts::PI * f * t).atan() / (std::f64::consts::PI * t);
        assert!(
            realised(ceiling) / ceiling > 0.84,
            "{}",
            realised(ceiling) / ceiling
        );
        assert!(realised(nyquist) / nyquist < 0.65);
        // A controller without a period bounds nothing.
        assert!(corner_ceiling_hz(0.0).is_infinite());
    }

    #[test]
    fn a_corner_is_bounded_by_its_controllers_period_and_by_its_records_nyquist() {
        // A 10 kHz controller written in z (sample_ms 0.1), its lead's pole at 400 Hz: half
        // its Nyquist frequency of 5 kHz is 2.5 kHz on a trace of every cycle; logged at
        // 1 kHz, that record's Nyquist frequency of 500 Hz (not half of it, 250 Hz, below
        // the pole).
        let mut axis = MachineConfig::preset("small-table").unwrap().x;
        let Controller::TransferFunction(tf) = &mut axis.controller else {
            panic!("the small table runs a transfer function");
        };
        tf.sample_ms = 0.1;
        assert!((controller_period_s(&axis) - 1e-4).abs() < 1e-15);
        let ceiling = corner_ceiling_of(&axis, 1e-4);
        assert!((ceiling - 2500.0).abs() < 1e-9, "{ceiling} Hz");
        assert!(ceiling > 400.0);
        assert!((corner_ceiling_of(&axis, 1e-3) - 500.0).abs() < 1e-9);
        // Written in s, the controller runs in continuous time in the simulation: no period,
        // no ceiling but the corner's own range.
        let Controller::TransferFunction(tf) = &mut axis.controller else {
            unreachable!()
        };
        tf.sample_ms = 0.0;
        assert_eq!(controller_period_s(&axis), 0.0);
        assert!(corner_ceiling_of(&axis, 0.0).is_infinite());
        // Nor has the cascade one. A record logged at 1 kHz bounds either below its Nyquist
        // frequency of 500 Hz, above the 400 Hz pole.
        assert!((corner_ceiling_of(&axis, 1e-3) - 500.0).abs() < 1e-9);
        axis.controller = Controller::Cascade;
        assert!(corner_ceiling_of(&axis, 0.0).is_infinite());
    }
    use crate::machine::MachineConfig;

    #[test]
    fn every_knob_is_a_machine_key_or_the_coulomb_force() {
        let x = MachineConfig::default_preset().x;
        for controller in [
            Controller::Cascade,
            MachineConfig::preset("small-table").unwrap().x.controller,
        ] {
            let mut axis = x.clone();
            axis.controller = controller;
            for k in for_axis(&axis) {
                assert!(
                    k.key == "friction.coulomb_n"
                        || k.key == "controller.gain"
                        || corner_of(k.key).is_some()
                        || crate::machine::keys::axis_key(k.key).is_some(),
                    "{}",
                    k.key
                );
                assert!(get(&axis, k.key).is_finite(), "{}", k.key);
            }
        }
    }

    #[test]
    fn corners_gone_complex_are_shown_as_their_pair() {
        // A lead-lag whose two zeros became the pair s² + 2ζω s + ω², ω = 2π·50 Hz, ζ = 0.3
        // (roots −15π ± 5π·√91·i), over a pole at 200 Hz and an integrator.
        let w = std::f64::consts::TAU * 50.0;
        let mut axis = MachineConfig::preset("small-table").unwrap().x;
        let Controller::TransferFunction(tf) = &mut axis.controller else {
            panic!("the small table runs a transfer function");
        };
        tf.numerator = vec![1.0, 2.0 * 0.3 * w, w * w];
        tf.denominator = vec![1.0, std::f64::consts::TAU * 200.0, 0.0];
        assert!(get(&axis, "controller.zero_1_hz").is_nan());
        for key in ["controller.zero_1_hz", "controller.zero_2_hz"] {
            let pair = complex_pair(&axis, key).unwrap();
            assert!((pair.natural_hz - 50.0).abs() < 1e-9 && (pair.damping - 0.3).abs() < 1e-12);
        }
        // The pole is real: its corner is a value, no pair.
        assert!((get(&axis, "controller.pole_1_hz") - 200.0).abs() < 1e-9);
        assert!(complex_pair(&axis, "controller.pole_1_hz").is_none());
        let shown = crate::identify::report::shown(&crate::identify::IdentifiedValue {
            key: "controller.zero_1_hz",
            unit: "Hz",
            template: 30.0,
            value: f64::NAN,
            uncertainty: f64::NAN,
            determined: false,
            measured: false,
            traded_with: Some("controller.gain"),
            loose: false,
            complex_pair: complex_pair(&axis, "controller.zero_1_hz"),
        });
        assert!(
            shown.starts_with("complex pair near 50.00 Hz, damping 0.300")
                && !shown.contains("NaN"),
            "{shown}"
        );
    }

    #[test]
    fn play_is_fitted_only_where_the_table_is_seen() {
        let keys = |axis: &AxisConfig, at: MeasuredAt| -> Vec<&str> {
            nonlinear_for(axis, at).iter().map(|k| k.key).collect()
        };
        // The heavy preset reads a scale: its play is in the loop, seen wherever the record
        // is read.
        let heavy = MachineConfig::default_preset().x;
        assert_eq!(keys(&heavy, MeasuredAt::Motor), [BACKLASH_KEY, STATIC_KEY]);
        // The small table reads its motors: the nut's play lies beyond what a record at the
        // motor sees, but not beyond a laser on the table.
        let small = MachineConfig::preset("small-table").unwrap().x;
        assert_eq!(keys(&small, MeasuredAt::Motor), [STATIC_KEY]);
        assert_eq!(keys(&small, MeasuredAt::Table), [BACKLASH_KEY, STATIC_KEY]);
        // Without Coulomb friction there is nothing to stick with.
        let mut smooth = small.clone();
        smooth.friction.coulomb_coefficient = 0.0;
        assert!(keys(&smooth, MeasuredAt::Motor).is_empty());
    }

    /// Bristles allow friction near rest down to a tenth of Coulomb's: a template's 0.7
    /// stays 0.7 where the fit has not moved it, and the fit may search down to 0.1. Without
    /// a fade speed the level near rest acts nowhere and is not fitted.
    #[test]
    fn a_presliding_level_below_coulomb_is_kept() {
        let mut axis = MachineConfig::preset("small-table").unwrap().x;
        axis.friction.bristle_stiffness_n_per_um = 50.0;
        axis.friction.static_to_coulomb = 0.7;
        axis.friction.stribeck_level_n = 0.0;
        axis.friction.stribeck_velocity_mm_per_min = 600.0;
        let knobs = nonlinear_for(&axis, MeasuredAt::Motor);
        let j = knobs.iter().position(|k| k.key == STATIC_KEY).unwrap();
        let at_zero = crate::identify::solve::values_at(
            &knobs,
            &axis,
            &nalgebra::DVector::zeros(knobs.len()),
        );
        assert_eq!(at_zero[j], 0.7);
        assert_eq!(knobs[j].min, 0.1);
        axis.friction.static_to_coulomb = 1.0;
        axis.friction.stribeck_velocity_mm_per_min = 0.0;
        assert!(
            !nonlinear_for(&axis, MeasuredAt::Motor)
                .iter()
                .any(|k| k.key == STATIC_KEY)
        );
    }

    #[test]
    fn a_fitted_mass_keeps_the_coulomb_force() {
        let mut x = MachineConfig::default_preset().x;
        let force = get(&x, COULOMB_KEY);
        set_all(&mut x, &[MASS_KEY], &[7500.0]);
        assert!((get(&x, COULOMB_KEY) - force).abs() < 1e-9);
        set_all(&mut x, &[COULOMB_KEY, MASS_KEY], &[1000.0, 5000.0]);
        assert!((get(&x, COULOMB_KEY) - 1000.0).abs() < 1e-9);
        assert_eq!(x.drive.table_mass_kg, 5000.0);
    }

    #[test]
    fn a_current_commanding_controllers_gains_are_fitted_with_the_mass() {
        let small = MachineConfig::preset("small-table").unwrap();
        let keys: Vec<&str> = for_axis(&small.x).iter().map(|k| k.key).collect();
        assert!(
            keys.contains(&TF_GAIN_KEY) && keys.contains(&MASS_KEY) && !keys.contains(&KV_KEY),
            "{keys:?}"
        );
        assert!(kept(&small.x).starts_with("motor.kt_nm_per_a"));
        // The gain scales the numerator, its zeros kept.
        let mut x = small.x.clone();
        let before = get(&x, TF_GAIN_KEY);
        set_all(&mut x, &[TF_GAIN_KEY], &[1.5 * before]);
        let (Controller::TransferFunction(a), Controller::TransferFunction(b)) =
            (&small.x.controller, &x.controller)
        else {
            panic!("a transfer function");
        };
        for (p, q) in a.numerator.iter().zip(&b.numerator) {
            assert!((q - 1.5 * p).abs() <= 1e-12 * p.abs());
        }
        assert!(kept(&MachineConfig::default_preset().x).starts_with("velocity_loop"));
        // Its corners: the double zero at 62.5 rad/s moves as one, the integrator stays, the
        // derivative filter's pole at 1250 rad/s moves alone.
        let keys: Vec<&str> = for_axis(&small.x).iter().map(|k| k.key).collect();
        assert!(keys.contains(&"controller.zero_1_hz") && !keys.contains(&"controller.zero_2_hz"));
        assert!(keys.contains(&"controller.pole_1_hz") && !keys.contains(&"controller.pole_2_hz"));
        let zero = get(&small.x, "controller.zero_1_hz");
        assert!((zero - 62.5 / std::f64::consts::TAU).abs() < 1e-6, "{zero}");
        let mut x = small.x.clone();
        set_all(
            &mut x,
            &["controller.zero_1_hz", "controller.pole_1_hz", TF_GAIN_KEY],
            &[20.0, 100.0, 200.0],
        );
        let Controller::TransferFunction(tf) = &x.controller else {
            panic!("a transfer function");
        };
        // The gain is the low-frequency one: K·w²/p = 200.
        let w = std::f64::consts::TAU * 20.0;
        let p = std::f64::consts::TAU * 100.0;
        let k = 200.0 * p / (w * w);
        let want_num = [k, 2.0 * k * w, k * w * w];
        for (a, b) in tf.numerator.iter().zip(want_num) {
            assert!((a - b).abs() < 1e-9 * b.abs(), "{:?}", tf.numerator);
        }
        let want_den = [1.0, p, 0.0];
        for (a, b) in tf.denominator.iter().zip(want_den) {
            assert!(
                (a - b).abs() < 1e-9 * b.abs().max(1.0),
                "{:?}",
                tf.denominator
            );
        }
    }
}
