//! The catalogue of effects outside the nominal model (docs/model.md §5): what each one's
//! parameters are (as machine keys, in the machine file's units), how it extends an axis,
//! and its signature — a cheap test on the residual that says whether fitting it is worth
//! a try.

use serde::Serialize;

use crate::machine::{AxisConfig, Feedback};
use crate::sim::MeasuredAt;

/// The fixed vocabulary of causes.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, serde::Deserialize, PartialOrd, Ord,
)]
#[serde(rename_all = "snake_case")]
pub enum CauseId {
    /// Lost motion at reversals.
    Backlash,
    /// Friction larger than modelled: spikes at reversals.
    CoulombFriction,
    /// Extra friction at low speed.
    Stribeck,
    /// A position gain other than the one set (servo mismatch between axes).
    KvGain,
    /// A delay between interpolator and position controller.
    DeadTime,
    /// A cyclic error of the measuring system (lead or scale period).
    CyclicError,
    /// A scale or lead error proportional to position.
    ScaleError,
    /// A structural mode ringing after accelerations.
    Resonance,
    /// The axes out of square: X reads a share of Y's position more.
    Squareness,
    /// The other axis's travel bowed as seen on this one.
    Straightness,
    /// Play across the guides: a step on this axis at each reversal of the other.
    LateralPlay,
    /// Lost motion beyond the scale: this axis reads more travelling one way than the other.
    DirectionOffset,
    /// A force that repeats with the table's position (a motor's torque ripple or cogging, a
    /// screw's eccentricity), at the period the machine file names or the drive's turn gives
    /// (`diagnose::ripple`).
    ForceRipple,
}

impl CauseId {
    /// Every cause.
    pub const ALL: [CauseId; 13] = [
        CauseId::Backlash,
        CauseId::CoulombFriction,
        CauseId::Stribeck,
        CauseId::KvGain,
        CauseId::DeadTime,
        CauseId::CyclicError,
        CauseId::ScaleError,
        CauseId::Resonance,
        CauseId::Squareness,
        CauseId::Straightness,
        CauseId::LateralPlay,
        CauseId::DirectionOffset,
        CauseId::ForceRipple,
    ];

    /// What kind of record would tell this cause from `other` where a record explains both
    /// alike: where their signatures part.
    pub(crate) fn told_apart_from(self, other: CauseId) -> &'static str {
        use CauseId::*;
        let pair = |a: CauseId, b: CauseId| (self == a && other == b) || (self == b && other == a);
        if pair(KvGain, DeadTime) {
            "a start or stop at another acceleration, or a step: a delay shifts the whole \
             response in time, a gain changes how fast it settles"
        } else if pair(KvGain, ScaleError) || pair(KvGain, DirectionOffset) {
            "a record at another feed: a gain's lag grows with speed, the other does not"
        } else if pair(CoulombFriction, Stribeck) {
            "a record at several low feeds, below and above the Stribeck speed: Stribeck \
             friction fades with speed, Coulomb friction does not"
        } else if pair(Backlash, DirectionOffset) {
            "a record at the motor as well as the table: backlash is lost between them, a \
             direction offset lies beyond the scale"
        } else if pair(Backlash, CoulombFriction) || pair(Backlash, Stribeck) {
            "reversals at several feeds: a friction spike grows with the speed the axis \
             reverses from, lost motion does not"
        } else if pair(LateralPlay, DirectionOffset) {
            "a stroke of this axis while the other holds or keeps its direction: a direction \
             offset follows the axis's own direction of travel, lateral play the other's"
        } else if pair(ScaleError, Squareness) {
            "a stroke of this axis alone, or along another direction: a scale error follows \
             the axis's own position, out-of-squareness the other axis's"
        } else if pair(Squareness, Straightness) {
            "a stroke over the whole travel: out-of-squareness grows along it, a bow returns"
        } else if pair(ForceRipple, CyclicError) {
            "records at several feeds: the loop answers a force at the ripple's frequency \
             (feed over period) more or less with the speed, an error of the positions read \
             follows the position alone"
        } else if pair(ScaleError, CyclicError) {
            "a stroke over many screw turns: a scale error grows along it, a cyclic error repeats"
        } else {
            "a record of another program, with other feeds, reversals and strokes"
        }
    }

    /// The id as written in reports and on the command line.
    pub fn as_str(self) -> &'static str {
        match self {
            CauseId::Backlash => "backlash",
            CauseId::CoulombFriction => "coulomb_friction",
            CauseId::Stribeck => "stribeck",
            CauseId::KvGain => "kv_gain",
            CauseId::DeadTime => "dead_time",
            CauseId::CyclicError => "cyclic_error",
            CauseId::ScaleError => "scale_error",
            CauseId::Resonance => "resonance",
            CauseId::Squareness => "squareness",
            CauseId::Straightness => "straightness",
            CauseId::LateralPlay => "lateral_play",
            CauseId::DirectionOffset => "direction_offset",
            CauseId::ForceRipple => "force_ripple",
        }
    }

    /// The fitted parameters: each a machine key, with a typical step and the bounds the
    /// fit searches within.
    pub(crate) fn params(self) -> &'static [Param] {
        match self {
            CauseId::Backlash => const { &[param("drive.backlash_um", 10.0, 0.0..=1000.0)] },
            CauseId::CoulombFriction => {
                const { &[param("friction.coulomb_coefficient", 0.01, 0.0..=0.5)] }
            }
            CauseId::Stribeck => {
                const {
                    &[
                        param("friction.stribeck_level_n", 300.0, 1.0..=1e5),
                        param("friction.stribeck_velocity_mm_per_min", 20.0, 0.1..=1e4),
                    ]
                }
            }
            CauseId::KvGain => {
                const {
                    &[param(
                        "position_loop.kv_m_per_min_per_mm",
                        0.1,
                        0.01..=100.0,
                    )]
                }
            }
            CauseId::DeadTime => const { &[param("position_loop.dead_time_ms", 2.0, 0.0..=500.0)] },
            CauseId::CyclicError => {
                const {
                    &[
                        param("errors.cyclic_amplitude_um", 2.0, 0.0..=1e4),
                        param("errors.cyclic_phase_deg", 30.0, -1e6..=1e6),
                    ]
                }
            }
            CauseId::ScaleError => const { &[param("errors.scale_error_ppm", 10.0, -1e5..=1e5)] },
            CauseId::Resonance => {
                const {
                    &[
                        param("errors.resonance_hz", 5.0, 0.5..=5000.0),
                        param("errors.resonance_damping", 0.02, 0.002..=1.0),
                    ]
                }
            }
            CauseId::Squareness => const { &[param("errors.squareness_urad", 20.0, -1e5..=1e5)] },
            CauseId::Straightness => {
                const { &[param("errors.straightness_bow_um", 5.0, -1e4..=1e4)] }
            }
            CauseId::LateralPlay => const { &[param("errors.lateral_play_um", 5.0, -1e4..=1e4)] },
            CauseId::DirectionOffset => {
                const { &[param("errors.direction_offset_um", 5.0, -1e4..=1e4)] }
            }
            CauseId::ForceRipple => {
                const {
                    &[
                        param("errors.force_ripple_n", 5.0, 0.0..=1e5),
                        param("errors.force_ripple_phase_deg", 30.0, -1e6..=1e6),
                    ]
                }
            }
        }
    }

    /// Why the cause has no meaning on `axis`'s controller, or `None` when it has: a gain
    /// error is the cascade's Kv scaled, and another structure has no Kv.
    pub(crate) fn inapplicable_to(self, axis: &AxisConfig) -> Option<&'static str> {
        let linear_motor = axis.drive.kind == crate::machine::DriveKind::LinearMotor;
        match self {
            CauseId::KvGain if !axis.controller.is_cascade() => Some(
                "the axis's controller is not the cascade: it has no Kv (its gains are in \
                 [axis.controller])",
            ),
            CauseId::Backlash if linear_motor => {
                Some("a linear motor has no screw and nut to leave play")
            }
            CauseId::Stribeck
                if axis.friction.has_presliding() && axis.friction.static_to_coulomb < 1.0 =>
            {
                Some(
                    "the axis's presliding bristles put friction near rest below Coulomb's: a \
                     Stribeck excess above it contradicts the machine file",
                )
            }
            _ => None,
        }
    }

    /// Why a measurement at `point` cannot see the cause on an axis with `feedback`, or
    /// `None` when it can.
    pub(crate) fn unseen_at(self, point: MeasuredAt, feedback: Feedback) -> Option<&'static str> {
        match (point, self) {
            (MeasuredAt::Motor, CauseId::Backlash) => {
                Some("the gap lies between the motor and the table, beyond the motor encoder")
            }
            (MeasuredAt::Motor, CauseId::Resonance) => {
                Some("the structural mode lies between the table and the measured point")
            }
            (MeasuredAt::Motor, CauseId::CyclicError | CauseId::ScaleError)
                if feedback == Feedback::MotorEncoder =>
            {
                Some("a lead error moves the table, not the motor the loop closes on")
            }
            (
                MeasuredAt::Motor,
                CauseId::Squareness
                | CauseId::Straightness
                | CauseId::LateralPlay
                | CauseId::DirectionOffset,
            ) => Some("the axes' geometry lies between the scales and the tool"),
            _ => None,
        }
    }

    /// Whether the cause acts at reversals only (its residual lives in windows around them).
    pub(crate) fn is_local(self) -> bool {
        matches!(
            self,
            CauseId::Backlash | CauseId::CoulombFriction | CauseId::Stribeck | CauseId::Resonance
        )
    }
}

/// A set of causes (the ones a diagnosis may try).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CauseSet(u16);

impl CauseSet {
    /// Every cause of the catalogue.
    pub const ALL: CauseSet = CauseSet((1 << CauseId::ALL.len()) - 1);
    /// No cause.
    pub const NONE: CauseSet = CauseSet(0);

    fn bit(cause: CauseId) -> u16 {
        1 << CauseId::ALL.iter().position(|&c| c == cause).unwrap_or(0)
    }

    /// The set holding `causes`.
    pub fn of(causes: &[CauseId]) -> CauseSet {
        CauseSet(causes.iter().fold(0, |m, &c| m | CauseSet::bit(c)))
    }

    /// Whether `cause` is in the set.
    pub fn contains(self, cause: CauseId) -> bool {
        self.0 & CauseSet::bit(cause) != 0
    }

    /// The set without `causes`.
    pub fn without(self, causes: &[CauseId]) -> CauseSet {
        CauseSet(self.0 & !CauseSet::of(causes).0)
    }

    /// Whether the set is empty.
    pub fn is_empty(self) -> bool {
        self.0 == 0
    }
}

/// A fitted parameter: a machine key below the axis, its unit, a typical magnitude (to
/// scale the fit) and the range it may take — within the values a machine can have (the
/// key's rule), where a fit is worth looking.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Param {
    /// Key below the axis, e.g. `drive.backlash_um`.
    pub key: &'static str,
    /// Unit as shown.
    pub unit: &'static str,
    /// Typical magnitude.
    pub scale: f64,
    /// Lower bound.
    pub min: f64,
    /// Upper bound.
    pub max: f64,
}

/// The parameter of machine key `key` (below the axis), its unit the key table's, with a
/// typical step `scale` and the bounds a fit searches within.
const fn param(key: &'static str, scale: f64, bounds: std::ops::RangeInclusive<f64>) -> Param {
    Param {
        key,
        unit: crate::machine::keys::axis_unit(key),
        scale,
        min: *bounds.start(),
        max: *bounds.end(),
    }
}

/// Reads a parameter's value from an axis (every cause parameter is in the machine's key
/// table: `tests::every_parameter_is_a_machine_key`).
pub(crate) fn get(axis: &AxisConfig, key: &str) -> f64 {
    crate::machine::keys::get(axis, key).unwrap_or(f64::NAN)
}

/// Sets a parameter on an axis.
pub(crate) fn set(axis: &mut AxisConfig, key: &str, v: f64) {
    crate::machine::keys::set(axis, key, v);
}

/// Applies a cause with parameter values (clamped to their ranges) to an axis.
pub(crate) fn apply(axis: &mut AxisConfig, cause: CauseId, values: &[f64]) {
    for (p, &v) in cause.params().iter().zip(values) {
        set(axis, p.key, v.clamp(p.min, p.max));
    }
}

/// Kinematic signals of one axis on the residual's time grid, for the signature tests.
pub struct Kinematics<'a> {
    /// Position (m): where the axis is, by the current model.
    pub pos_m: &'a [f64],
    /// Commanded velocity (m/s).
    pub vel_m_per_s: &'a [f64],
    /// Samples within a window around this axis's reversals.
    pub near_reversal: &'a [bool],
    /// Sampling step (s).
    pub dt_s: f64,
    /// The cyclic error's period (m).
    pub cyclic_period_m: f64,
    /// The force ripple's period (m): the machine file's, or the one `diagnose::ripple`
    /// chose for the search.
    pub ripple_period_m: f64,
    /// The other axis's position (m).
    pub other_pos_m: &'a [f64],
}

impl Kinematics<'_> {
    /// The direction the other axis last travelled (±1, 0 before it moved), per sample.
    pub(crate) fn other_direction(&self) -> Vec<f64> {
        travel_directions(self.other_pos_m)
    }

    /// The direction this axis last travelled, per sample.
    pub(crate) fn own_direction(&self) -> Vec<f64> {
        travel_directions(self.pos_m)
    }
}

/// The direction last travelled at each of a series of positions (m) in time order.
fn travel_directions(positions_m: &[f64]) -> Vec<f64> {
    let mut travel = crate::sim::geometry::Travel::default();
    positions_m.iter().map(|&q| travel.direction(q)).collect()
}

/// How strongly the residual `r` shows a cause's signature: the share of its variance
/// (in the relevant samples) a least-squares fit of the signature's regressors explains,
/// from 0 (none) to 1 (all). Cheap: no simulation.
pub(crate) fn signature(cause: CauseId, r: &[f64], k: &Kinematics) -> f64 {
    let n = r.len().min(k.pos_m.len());
    let all = |_: usize| true;
    match cause {
        CauseId::ScaleError => explained(r, n, &[&|i| k.pos_m[i]], &all),
        CauseId::CyclicError | CauseId::ForceRipple => {
            let period_m = if cause == CauseId::CyclicError {
                k.cyclic_period_m
            } else {
                k.ripple_period_m
            };
            let w = std::f64::consts::TAU / period_m;
            explained(
                r,
                n,
                &[&|i| (w * k.pos_m[i]).sin(), &|i| (w * k.pos_m[i]).cos()],
                &all,
            )
        }
        CauseId::KvGain | CauseId::DeadTime => explained(r, n, &[&|i| k.vel_m_per_s[i]], &all),
        CauseId::Backlash | CauseId::CoulombFriction | CauseId::Stribeck => {
            // The residual's energy near reversals against elsewhere, as a share.
            let (mut near, mut far, mut n_near, mut n_far) = (0.0, 0.0, 0usize, 0usize);
            for (v, &is_near) in r[..n].iter().zip(k.near_reversal) {
                if is_near {
                    near += v * v;
                    n_near += 1;
                } else {
                    far += v * v;
                    n_far += 1;
                }
            }
            if n_near == 0 || n_far == 0 {
                return 0.0;
            }
            let (near, far) = (near / n_near as f64, far / n_far as f64);
            ((near - far) / (near + far)).max(0.0)
        }
        CauseId::Resonance => spectral_peak(r, k.dt_s),
        CauseId::Squareness => explained(
            r,
            n.min(k.other_pos_m.len()),
            &[&|i| k.other_pos_m[i]],
            &all,
        ),
        CauseId::Straightness => explained(
            r,
            n.min(k.other_pos_m.len()),
            &[&|i| k.other_pos_m[i] * k.other_pos_m[i]],
            &all,
        ),
        CauseId::LateralPlay | CauseId::DirectionOffset => {
            let dir = if cause == CauseId::LateralPlay {
                k.other_direction()
            } else {
                k.own_direction()
            };
            explained(r, n.min(dir.len()), &[&|i| dir[i]], &all)
        }
    }
}

/// The evidence of a hypothesis, as every one is weighed against another: the fall of the
/// residual's sum of squares it gives, `gain` (in noise variances), counted on the
/// independent share of the residual it leaves, `left` — a hypothesis that leaves a smooth
/// residual has bent towards a larger error it does not model — less ln n for each of its
/// `params` values, with n the `values` compared.
pub(crate) fn evidence(gain: f64, left: &[f64], params: usize, values: f64) -> f64 {
    gain * crate::compare::residual::independent_share(left) - params as f64 * values.ln()
}

/// Share of the variance of r (over samples where `keep`) that regressors explain.
pub(crate) fn explained(
    r: &[f64],
    n: usize,
    regressors: &[&dyn Fn(usize) -> f64],
    keep: &dyn Fn(usize) -> bool,
) -> f64 {
    let m = regressors.len() + 1;
    let mut ata = nalgebra::DMatrix::<f64>::zeros(m, m);
    let mut atb = nalgebra::DVector::<f64>::zeros(m);
    let (mut sum, mut sum2, mut count) = (0.0, 0.0, 0usize);
    let mut row = vec![0.0; m];
    for i in (0..n).filter(|&i| keep(i) && r[i].is_finite()) {
        row[0] = 1.0;
        for (j, f) in regressors.iter().enumerate() {
            row[j + 1] = f(i);
        }
        for a in 0..m {
            atb[a] += row[a] * r[i];
            for b in 0..m {
                ata[(a, b)] += row[a] * row[b];
            }
        }
        sum += r[i];
        sum2 += r[i] * r[i];
        count += 1;
    }
    if count < 2 * m {
        return 0.0;
    }
    let variance = sum2 - sum * sum / count as f64;
    let Some(coef) = ata.clone().lu().solve(&atb) else {
        return 0.0;
    };
    // Explained sum of squares beyond the mean.
    let fitted: f64 = coef.dot(&atb) - sum * sum / count as f64;
    if variance > 0.0 {
        (fitted / variance).clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// The share of the residual's power in its strongest narrow band (5–500 Hz), from a
/// periodogram evaluated on a logarithmic grid — a ringing mode concentrates it there.
fn spectral_peak(r: &[f64], dt: f64) -> f64 {
    let finite: Vec<f64> = r.iter().copied().filter(|v| v.is_finite()).collect();
    let n = finite.len();
    if n < 64 {
        return 0.0;
    }
    let mean = finite.iter().sum::<f64>() / n as f64;
    let total: f64 = finite.iter().map(|v| (v - mean).powi(2)).sum();
    if total <= 0.0 {
        return 0.0;
    }
    let nyquist = 0.5 / dt;
    let mut best = 0.0f64;
    let mut f = 5.0;
    while f < nyquist.min(500.0) {
        let w = std::f64::consts::TAU * f * dt;
        let (mut c, mut s) = (0.0, 0.0);
        for (i, v) in finite.iter().enumerate() {
            let (sn, cs) = (w * i as f64).sin_cos();
            c += (v - mean) * cs;
            s += (v - mean) * sn;
        }
        // Power of this frequency's component, as a share of the total (2/n (c² + s²)).
        best = best.max(2.0 * (c * c + s * s) / n as f64 / total);
        f *= 1.02;
    }
    best.min(1.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::machine::MachineConfig;

    #[test]
    fn every_parameter_is_a_machine_key() {
        let x = MachineConfig::default_preset().x;
        for id in CauseId::ALL {
            for p in id.params() {
                let key = crate::machine::keys::axis_key(p.key);
                assert!(
                    key.is_some(),
                    "{}: {} is not in the key table",
                    id.as_str(),
                    p.key
                );
                assert!(crate::machine::keys::get(&x, p.key).is_some(), "{}", p.key);
            }
        }
    }

    #[test]
    fn every_parameters_bounds_lie_within_what_a_machine_can_have() {
        for id in CauseId::ALL {
            for p in id.params() {
                let rule = crate::machine::keys::axis_key(p.key).unwrap().rule;
                for bound in [p.min, p.max] {
                    assert_eq!(rule.problem(bound), None, "{}: {bound}", p.key);
                }
                assert!(p.min < p.max && p.scale > 0.0, "{}", p.key);
            }
        }
    }

    #[test]
    fn a_gain_error_is_the_cascades_alone_and_backlash_the_screws() {
        let small = MachineConfig::preset("small-table").unwrap();
        let why = CauseId::KvGain.inapplicable_to(&small.x).unwrap();
        assert!(why.contains("no Kv"), "{why}");
        assert!(CauseId::Backlash.inapplicable_to(&small.x).is_none());
        let hvmc = MachineConfig::default_preset();
        assert!(CauseId::KvGain.inapplicable_to(&hvmc.x).is_none());
        let mut linear = hvmc.x.clone();
        linear.drive.kind = crate::machine::DriveKind::LinearMotor;
        assert!(CauseId::Backlash.inapplicable_to(&linear).is_some());
        assert!(CauseId::Backlash.inapplicable_to(&hvmc.x).is_none());
    }

    /// Bristles with friction near rest below Coulomb's leave no room for a Stribeck excess:
    /// even its least level makes a machine file that validation refuses, so it is not tried.
    #[test]
    fn no_stribeck_excess_over_bristles_below_coulomb() {
        let mut m = MachineConfig::preset("small-table").unwrap();
        let f = &mut m.x.friction;
        (f.bristle_stiffness_n_per_um, f.static_to_coulomb) = (50.0, 0.7);
        f.stribeck_velocity_mm_per_min = 600.0;
        m.validate("m.toml").unwrap();
        assert!(CauseId::Stribeck.inapplicable_to(&m.x).is_some());
        let least: Vec<f64> = CauseId::Stribeck.params().iter().map(|p| p.min).collect();
        apply(&mut m.x, CauseId::Stribeck, &least);
        assert!(m.validate("m.toml").is_err());
        m.x.friction.static_to_coulomb = 1.0;
        assert!(CauseId::Stribeck.inapplicable_to(&m.x).is_none());
        m.validate("m.toml").unwrap();
    }
}
