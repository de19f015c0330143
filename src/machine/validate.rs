//! Validation of a whole machine: every number finite and in range, and the values that
//! must agree with each other (static ≥ Coulomb friction, rapid ≥ cutting feed) agreeing.

use super::{
    AxisConfig, ConfigError, Controller, ControllerOutput, Limits, MachineConfig, TransferFunction,
};

/// What a value must satisfy. The upper bounds are generous — beyond anything from a desktop
/// table to the heaviest machine — and there so that a slip of the exponent (a table of
/// 1e300 kg, 1e12 µm of backlash) is caught here rather than turned into silent nonsense by
/// the simulation.
#[derive(Clone, Copy)]
enum Rule {
    /// In (0, hi].
    Positive(f64),
    /// In [0, hi].
    NonNegative(f64),
    /// Within [lo, hi].
    Range(f64, f64),
}

/// A number as a reader takes it in: exponent form when it is huge or tiny.
fn number(v: f64) -> String {
    if v != 0.0 && !(1e-4..1e6).contains(&v.abs()) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

struct Checker<'a> {
    file: &'a str,
}

impl Checker<'_> {
    fn check(&self, key: &str, value: f64, rule: Rule) -> Result<(), ConfigError> {
        let problem = if !value.is_finite() {
            Some("must be a finite number".to_string())
        } else {
            match rule {
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
        };
        match problem {
            Some(p) => Err(ConfigError::Invalid {
                file: self.file.to_string(),
                key: key.to_string(),
                problem: format!("{p} (got {})", number(value)),
            }),
            None => Ok(()),
        }
    }

    fn inconsistent(&self, key: &str, problem: String) -> ConfigError {
        ConfigError::Invalid {
            file: self.file.to_string(),
            key: key.to_string(),
            problem,
        }
    }
}

/// Validates a deserialised machine.
pub fn validate(m: &MachineConfig, file: &str) -> Result<(), ConfigError> {
    let c = Checker { file };
    c.check(
        "interpolation.cycle_ms",
        m.interpolation.cycle_ms,
        Rule::Range(0.05, 100.0),
    )?;
    c.check(
        "interpolation.in_position_window_mm",
        m.interpolation.in_position_window_mm,
        Rule::Positive(100.0),
    )?;
    c.check(
        "interpolation.arc_normal_share",
        m.interpolation.arc_normal_share,
        Rule::Range(0.01, 0.99),
    )?;
    if let Some(a) = m.interpolation.path_accel_m_per_s2 {
        c.check("interpolation.path_accel_m_per_s2", a, Rule::Positive(1e4))?;
    }
    if let Some(j) = m.interpolation.path_jerk_m_per_s3 {
        c.check("interpolation.path_jerk_m_per_s3", j, Rule::Positive(1e8))?;
    }
    validate_axis(&c, "x", &m.x)?;
    validate_axis(&c, "y", &m.y)?;
    validate_limits(&c, "z.limits", &m.z.limits)
}

fn validate_axis(c: &Checker, axis: &str, a: &AxisConfig) -> Result<(), ConfigError> {
    use Rule::{NonNegative, Positive, Range};
    let k = |s: &str| format!("{axis}.{s}");
    validate_control(c, axis, a)?;
    let p = &a.position_loop;
    if a.controller.is_cascade() {
        c.check(
            &k("position_loop.kv_m_per_min_per_mm"),
            p.kv_m_per_min_per_mm,
            Positive(100.0),
        )?;
    }
    c.check(
        &k("position_loop.velocity_feedforward"),
        p.velocity_feedforward,
        Range(0.0, 2.0),
    )?;
    c.check(
        &k("position_loop.accel_feedforward"),
        p.accel_feedforward,
        Range(0.0, 2.0),
    )?;
    c.check(&k("motor.jm_kg_m2"), a.motor.jm_kg_m2, Positive(1e3))?;
    let d = &a.drive;
    c.check(&k("drive.js_kg_m2"), d.js_kg_m2, Positive(1e3))?;
    c.check(
        &k("drive.k_theta_nm_per_rad"),
        d.k_theta_nm_per_rad,
        Positive(1e12),
    )?;
    c.check(&k("drive.k_m_n_per_m"), d.k_m_n_per_m, Positive(1e12))?;
    c.check(&k("drive.zeta_theta"), d.zeta_theta, Range(0.0, 2.0))?;
    c.check(&k("drive.zeta_m"), d.zeta_m, Range(0.0, 2.0))?;
    c.check(&k("drive.lead_mm"), d.lead_mm, Positive(1e4))?;
    c.check(&k("drive.gear_ratio"), d.gear_ratio, Positive(1e3))?;
    c.check(&k("drive.table_mass_kg"), d.table_mass_kg, Positive(1e6))?;
    c.check(
        &k("drive.screw_viscous_nm_s_per_rad"),
        d.screw_viscous_nm_s_per_rad,
        NonNegative(1e6),
    )?;
    c.check(&k("drive.backlash_um"), d.backlash_um, NonNegative(1e4))?;
    if d.kind == super::DriveKind::LinearMotor {
        if d.backlash_um != 0.0 {
            return Err(c.inconsistent(
                &k("drive.backlash_um"),
                format!(
                    "is {} µm on a linear motor, which has no screw and nut to leave play",
                    d.backlash_um
                ),
            ));
        }
        if a.lateral_shift.is_some() {
            return Err(c.inconsistent(
                &k("lateral_shift"),
                "tilts a ball screw: a linear motor has none".into(),
            ));
        }
    }
    let f = &a.friction;
    c.check(
        &k("friction.coulomb_coefficient"),
        f.coulomb_coefficient,
        Range(0.0, 1.0),
    )?;
    c.check(
        &k("friction.static_to_coulomb"),
        f.static_to_coulomb,
        Positive(10.0),
    )?;
    c.check(
        &k("friction.viscous_n_s_per_m"),
        f.viscous_n_s_per_m,
        NonNegative(1e8),
    )?;
    if f.static_to_coulomb < 1.0 {
        return Err(c.inconsistent(
            &k("friction.static_to_coulomb"),
            format!(
                "is {}: static friction below Coulomb friction would let a stuck table slide \
                 under less force than a sliding one needs (must be at least 1)",
                f.static_to_coulomb
            ),
        ));
    }
    c.check(
        &k("position_loop.dead_time_ms"),
        p.dead_time_ms,
        Range(0.0, 1000.0),
    )?;
    c.check(
        &k("friction.stribeck_level_n"),
        f.stribeck_level_n,
        NonNegative(1e7),
    )?;
    c.check(
        &k("friction.stribeck_velocity_mm_per_min"),
        f.stribeck_velocity_mm_per_min,
        NonNegative(1e6),
    )?;
    if f.stribeck_level_n > 0.0 && f.stribeck_velocity_mm_per_min <= 0.0 {
        return Err(c.inconsistent(
            &k("friction.stribeck_velocity_mm_per_min"),
            "must be positive when friction.stribeck_level_n is set".into(),
        ));
    }
    let e = &a.errors;
    c.check(
        &k("errors.scale_error_ppm"),
        e.scale_error_ppm,
        Range(-1e5, 1e5),
    )?;
    c.check(
        &k("errors.cyclic_amplitude_um"),
        e.cyclic_amplitude_um,
        Range(0.0, 1e4),
    )?;
    c.check(
        &k("errors.cyclic_period_mm"),
        e.cyclic_period_mm,
        NonNegative(1e4),
    )?;
    c.check(
        &k("errors.cyclic_phase_deg"),
        e.cyclic_phase_deg,
        Range(-1e6, 1e6),
    )?;
    c.check(&k("errors.resonance_hz"), e.resonance_hz, Range(0.0, 1e4))?;
    c.check(
        &k("errors.resonance_damping"),
        e.resonance_damping,
        Range(0.0, 2.0),
    )?;
    if e.resonance_hz > 0.0 && e.resonance_damping <= 0.0 {
        return Err(c.inconsistent(
            &k("errors.resonance_damping"),
            "must be positive when errors.resonance_hz is set".into(),
        ));
    }
    c.check(
        &k("errors.squareness_urad"),
        e.squareness_urad,
        Rule::Range(-1e5, 1e5),
    )?;
    c.check(
        &k("errors.straightness_bow_um"),
        e.straightness_bow_um,
        Rule::Range(-1e4, 1e4),
    )?;
    c.check(
        &k("errors.straightness_span_mm"),
        e.straightness_span_mm,
        Rule::Range(1.0, 1e5),
    )?;
    validate_tables(c, &k, e)?;
    c.check(
        &k("errors.lateral_play_um"),
        e.lateral_play_um,
        Rule::Range(-1e4, 1e4),
    )?;
    c.check(
        &k("errors.direction_offset_um"),
        e.direction_offset_um,
        Rule::Range(-1e4, 1e4),
    )?;
    if let Some(ls) = &a.lateral_shift {
        c.check(
            &k("lateral_shift.beam_length_m"),
            ls.beam_length_m,
            Positive(100.0),
        )?;
        c.check(
            &k("lateral_shift.bending_stiffness_n_m2"),
            ls.bending_stiffness_n_m2,
            Positive(1e13),
        )?;
        c.check(
            &k("lateral_shift.holder_load_n"),
            ls.holder_load_n,
            NonNegative(1e8),
        )?;
        c.check(
            &k("lateral_shift.holder_at_zero_m"),
            ls.holder_at_zero_m,
            Range(0.0, ls.beam_length_m),
        )?;
    }
    validate_limits(c, &k("limits"), &a.limits)
}

/// The controller, the velocity loop, the current loop or amplifier and the motor's
/// electrical data: each present where the structure needs it, and in range.
fn validate_control(c: &Checker, axis: &str, a: &AxisConfig) -> Result<(), ConfigError> {
    use Rule::{NonNegative, Positive};
    let k = |s: &str| format!("{axis}.{s}");
    let missing = |key: &str, why: &str| ConfigError::Missing {
        file: c.file.to_string(),
        key: k(key),
        why: format!(" ({why})"),
    };
    match (&a.velocity_loop, a.controller.uses_velocity_loop()) {
        (Some(v), true) => {
            c.check(
                &k("velocity_loop.ks_nm_s_per_rad"),
                v.ks_nm_s_per_rad,
                Positive(1e5),
            )?;
            c.check(&k("velocity_loop.ts_ms"), v.ts_ms, Positive(1e6))?;
            c.check(&k("velocity_loop.i_max_a"), v.i_max_a, Positive(1e5))?;
        }
        (None, true) => {
            return Err(missing(
                "velocity_loop",
                &format!(
                    "the {} controller commands a velocity loop",
                    a.controller.name()
                ),
            ));
        }
        (_, false) => {}
    }
    match (&a.current_loop, &a.amplifier) {
        (Some(i), None) => {
            c.check(&k("current_loop.ki_v_per_a"), i.ki_v_per_a, Positive(1e5))?;
            c.check(&k("current_loop.ti_ms"), i.ti_ms, Positive(1e6))?;
            c.check(&k("current_loop.tcf_ms"), i.tcf_ms, Positive(1e3))?;
            c.check(&k("current_loop.u_max_v"), i.u_max_v, Positive(1e5))?;
            let mo = &a.motor;
            let electrical = "a modelled current loop needs the motor's electrical data";
            let ra = mo
                .ra_ohm
                .ok_or_else(|| missing("motor.ra_ohm", electrical))?;
            let la = mo.la_mh.ok_or_else(|| missing("motor.la_mh", electrical))?;
            let ke = mo
                .ke_v_s_per_rad
                .ok_or_else(|| missing("motor.ke_v_s_per_rad", electrical))?;
            c.check(&k("motor.ra_ohm"), ra, Positive(1e3))?;
            c.check(&k("motor.la_mh"), la, Positive(1e4))?;
            c.check(&k("motor.ke_v_s_per_rad"), ke, NonNegative(1e3))?;
            if !a.controller.is_cascade() {
                return Err(c.inconsistent(
                    &k("controller.structure"),
                    format!(
                        "= \"{}\" drives a current amplifier: give [{axis}.amplifier] \
                         (current_bandwidth_hz, i_max_a) instead of [{axis}.current_loop]",
                        a.controller.name()
                    ),
                ));
            }
        }
        (None, Some(amp)) => {
            c.check(
                &k("amplifier.current_bandwidth_hz"),
                amp.current_bandwidth_hz,
                Positive(1e5),
            )?;
            match (amp.i_max_a, a.controller.uses_velocity_loop()) {
                (Some(i_max), _) => c.check(&k("amplifier.i_max_a"), i_max, Positive(1e5))?,
                (None, false) => {
                    return Err(missing(
                        "amplifier.i_max_a",
                        "no velocity loop limits the current command",
                    ));
                }
                (None, true) => {}
            }
        }
        (None, None) => {
            return Err(missing(
                "current_loop",
                &format!("or [{axis}.amplifier]: the axis needs one or the other"),
            ));
        }
        (Some(_), Some(_)) => {
            return Err(c.inconsistent(
                &k("amplifier"),
                format!("and [{axis}.current_loop] both describe the current control: give one"),
            ));
        }
    }
    c.check(&k("motor.kt_nm_per_a"), a.motor.kt_nm_per_a, Positive(1e3))?;
    match &a.controller {
        Controller::Cascade => Ok(()),
        Controller::TransferFunction(tf) => validate_transfer_function(c, axis, tf),
        Controller::StateFeedback(sf) => {
            c.check(
                &k("controller.position_gain_a_per_mm"),
                sf.position_gain_a_per_mm,
                Positive(1e6),
            )?;
            c.check(
                &k("controller.integral_gain_a_per_mm_s"),
                sf.integral_gain_a_per_mm_s,
                NonNegative(1e9),
            )?;
            c.check(
                &k("controller.velocity_gain_a_s_per_mm"),
                sf.velocity_gain_a_s_per_mm,
                NonNegative(1e6),
            )?;
            c.check(
                &k("controller.velocity_feedforward"),
                sf.velocity_feedforward,
                Rule::Range(0.0, 2.0),
            )?;
            c.check(
                &k("controller.accel_feedforward"),
                sf.accel_feedforward,
                Rule::Range(0.0, 2.0),
            )
        }
    }
}

/// A transfer function the simulation can realise: finite coefficients, a denominator that
/// is not zero, proper, of an order the axis has room for, and (given in z) without a pole at
/// z = −1, which has no continuous equivalent.
fn validate_transfer_function(
    c: &Checker,
    axis: &str,
    tf: &TransferFunction,
) -> Result<(), ConfigError> {
    let k = |s: &str| format!("{axis}.controller.{s}");
    for (key, coefficients) in [
        ("numerator", &tf.numerator),
        ("denominator", &tf.denominator),
    ] {
        if coefficients.is_empty() {
            return Err(c.inconsistent(&k(key), "has no coefficients".into()));
        }
        for &v in coefficients.iter() {
            c.check(&k(key), v, Rule::Range(-1e15, 1e15))?;
        }
    }
    c.check(&k("sample_ms"), tf.sample_ms, Rule::Range(0.0, 100.0))?;
    c.check(
        &k("velocity_feedforward"),
        tf.velocity_feedforward,
        Rule::Range(0.0, 2.0),
    )?;
    c.check(
        &k("accel_feedforward"),
        tf.accel_feedforward,
        Rule::Range(0.0, 2.0),
    )?;
    if tf.output == ControllerOutput::Current && tf.velocity_feedforward != 0.0 {
        return Err(c.inconsistent(
            &k("velocity_feedforward"),
            "feeds a velocity command forward, and this controller commands current (use \
             accel_feedforward)"
                .into(),
        ));
    }
    crate::machine::realise::realise(tf)
        .map(|_| ())
        .map_err(|problem| c.inconsistent(&k("denominator"), problem))
}

fn validate_limits(c: &Checker, prefix: &str, l: &Limits) -> Result<(), ConfigError> {
    use Rule::Positive;
    let k = |s: &str| format!("{prefix}.{s}");
    c.check(
        &k("max_feed_mm_per_min"),
        l.max_feed_mm_per_min,
        Positive(1e6),
    )?;
    c.check(&k("rapid_mm_per_min"), l.rapid_mm_per_min, Positive(1e6))?;
    c.check(
        &k("max_accel_m_per_s2"),
        l.max_accel_m_per_s2,
        Positive(1e4),
    )?;
    c.check(&k("max_jerk_m_per_s3"), l.max_jerk_m_per_s3, Positive(1e8))?;
    if let Some([lo, hi]) = l.travel_mm {
        c.check(&k("travel_mm"), lo, Rule::Range(-1e6, 1e6))?;
        c.check(&k("travel_mm"), hi, Rule::Range(-1e6, 1e6))?;
        if lo >= hi {
            return Err(c.inconsistent(
                &k("travel_mm"),
                format!("is [{lo}, {hi}]: the lowest position must come first"),
            ));
        }
    }
    if l.rapid_mm_per_min < l.max_feed_mm_per_min {
        return Err(c.inconsistent(
            &k("rapid_mm_per_min"),
            format!(
                "is {} mm/min, below the maximum cutting feed {} mm/min",
                l.rapid_mm_per_min, l.max_feed_mm_per_min
            ),
        ));
    }
    Ok(())
}

/// A table of the machine file (`at` keys, `values` keys, the range of a value): as many
/// values as points, at most `POSITION_MAP_POINTS`, points increasing, every number finite
/// and within its range.
fn validate_table(
    c: &Checker,
    (at_key, at): (&str, &[f64]),
    (value_key, values): (&str, &[f64]),
    value_range: (f64, f64),
) -> Result<(), ConfigError> {
    if at.len() != values.len() {
        let short = |k: &str| k.rsplit('.').next().unwrap_or(k).to_string();
        return Err(c.inconsistent(
            value_key,
            format!(
                "has {} values for {} points in {}",
                values.len(),
                at.len(),
                short(at_key)
            ),
        ));
    }
    if at.len() > crate::machine::POSITION_MAP_POINTS {
        return Err(c.inconsistent(
            at_key,
            format!(
                "has {} points; at most {} are kept",
                at.len(),
                crate::machine::POSITION_MAP_POINTS
            ),
        ));
    }
    for (&p, &v) in at.iter().zip(values) {
        c.check(at_key, p, Rule::Range(-1e6, 1e6))?;
        c.check(value_key, v, Rule::Range(value_range.0, value_range.1))?;
    }
    if at.windows(2).any(|w| w[1] <= w[0]) {
        return Err(c.inconsistent(at_key, "must increase from point to point".into()));
    }
    Ok(())
}

/// The tables in `[axis.errors]`: the position map (µm within a millimetre), the friction
/// map and the friction curve over speed (N, from speed 0 up).
fn validate_tables(
    c: &Checker,
    k: &dyn Fn(&str) -> String,
    e: &crate::machine::Errors,
) -> Result<(), ConfigError> {
    let keys = |a: &str, b: &str| (k(&format!("errors.{a}")), k(&format!("errors.{b}")));
    let (pa, pv) = keys("position_map_mm", "position_map_um");
    validate_table(
        c,
        (&pa, &e.position_map_mm),
        (&pv, &e.position_map_um),
        (-1e3, 1e3),
    )?;
    let (fa, fv) = keys("friction_map_mm", "friction_map_n");
    validate_table(
        c,
        (&fa, &e.friction_map_mm),
        (&fv, &e.friction_map_n),
        (-1e6, 1e6),
    )?;
    let (sa, sv) = keys("friction_speed_mm_per_min", "friction_speed_n");
    validate_table(
        c,
        (&sa, &e.friction_speed_mm_per_min),
        (&sv, &e.friction_speed_n),
        (-1e6, 1e6),
    )?;
    if let Some(&first) = e.friction_speed_mm_per_min.first() {
        c.check(&sa, first, Rule::Range(0.0, 1e6))?;
    }
    Ok(())
}
