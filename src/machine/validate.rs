//! Validation of a whole machine: the sections its structure needs, every number finite and
//! in the range of its key ([`super::keys`]), and the values that must agree with each other
//! (static ≥ Coulomb friction, rapid ≥ cutting feed) agreeing.

use super::keys::{AXIS_KEYS, INTERPOLATION_KEYS, Key, LIMIT_KEYS, Rule, number};
use super::{
    AxisConfig, ConfigError, Controller, ControllerOutput, Limits, MachineConfig, TransferFunction,
    ZAxis,
};

struct Checker<'a> {
    file: &'a str,
}

impl Checker<'_> {
    fn check(&self, key: &str, value: f64, rule: Rule) -> Result<(), ConfigError> {
        match rule.problem(value) {
            Some(p) => Err(ConfigError::Invalid {
                file: self.file.to_string(),
                key: key.to_string(),
                problem: format!("{p} (got {})", number(value)),
            }),
            None => Ok(()),
        }
    }

    /// Every key of `keys` that `on` has and `reads`, in its range.
    fn check_keys<T>(
        &self,
        prefix: &str,
        keys: &[Key<T>],
        on: &T,
        reads: impl Fn(&Key<T>) -> bool,
    ) -> Result<(), ConfigError> {
        for k in keys.iter().filter(|k| reads(k)) {
            if let Some(v) = k.get(on) {
                self.check(&format!("{prefix}{}", k.path), v, k.rule)?;
            }
        }
        Ok(())
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
pub(crate) fn validate(m: &MachineConfig, file: &str) -> Result<(), ConfigError> {
    let c = Checker { file };
    c.check_keys(
        "interpolation.",
        INTERPOLATION_KEYS,
        &m.interpolation,
        |_| true,
    )?;
    validate_axis(&c, "x", &m.x)?;
    validate_axis(&c, "y", &m.y)?;
    match &m.z {
        ZAxis::Simulated(z) => validate_axis(&c, "z", z),
        ZAxis::Carried(planned) => {
            c.check_keys("z.limits.", LIMIT_KEYS, &planned.limits, |_| true)?;
            validate_limits(&c, "z.limits", &planned.limits)
        }
    }
}

/// An axis: its sections as its structure needs them, every key in range, and the values
/// that must agree with each other agreeing.
fn validate_axis(c: &Checker, axis: &str, a: &AxisConfig) -> Result<(), ConfigError> {
    validate_sections(c, axis, a)?;
    c.check_keys(&format!("{axis}."), AXIS_KEYS, a, |k| k.needs.holds(a))?;
    if let Controller::TransferFunction(tf) = &a.controller {
        validate_transfer_function(c, axis, tf)?;
    }
    let k = |s: &str| format!("{axis}.{s}");
    validate_mechanics(c, &k, a)?;
    validate_tables(c, &k, &a.errors)?;
    validate_friction_total(c, &k, a)?;
    validate_limits(c, &k("limits"), &a.limits)
}

/// What a linear motor cannot have, friction and error terms whose parts must agree, and a
/// tool holder on its beam.
fn validate_mechanics(
    c: &Checker,
    k: &dyn Fn(&str) -> String,
    a: &AxisConfig,
) -> Result<(), ConfigError> {
    let d = &a.drive;
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
    validate_presliding(c, k, f)?;
    validate_bristle_step(c, k, f, a.drive.table_mass_kg)?;
    if f.static_to_coulomb < 1.0 && !f.has_presliding() {
        return Err(c.inconsistent(
            &k("friction.static_to_coulomb"),
            format!(
                "is {}: static friction below Coulomb friction would let a stuck table slide \
                 under less force than a sliding one needs (must be at least 1)",
                f.static_to_coulomb
            ),
        ));
    }
    if f.stribeck_level_n > 0.0 && f.stribeck_velocity_mm_per_min <= 0.0 {
        return Err(c.inconsistent(
            &k("friction.stribeck_velocity_mm_per_min"),
            "must be positive when friction.stribeck_level_n is set".into(),
        ));
    }
    let e = &a.errors;
    if e.resonance_hz > 0.0 && e.resonance_damping <= 0.0 {
        return Err(c.inconsistent(
            &k("errors.resonance_damping"),
            "must be positive when errors.resonance_hz is set".into(),
        ));
    }
    if e.force_ripple_n > 0.0 && e.force_ripple_period_mm <= 0.0 {
        return Err(c.inconsistent(
            &k("errors.force_ripple_period_mm"),
            "must be positive when errors.force_ripple_n is set".into(),
        ));
    }
    if let Some(ls) = &a.lateral_shift {
        c.check(
            &k("lateral_shift.holder_at_zero_m"),
            ls.holder_at_zero_m,
            Rule::Range(0.0, ls.beam_length_m),
        )?;
        validate_beam(c, k, ls)?;
    }
    Ok(())
}

/// The largest share of its length a beam may sag by under the holder it carries at
/// mid-span: the sag formula (`docs/model.md` §1.7) is a small deflection's, and a machine's
/// beam sags micrometres; one bent by a hundredth of its length is a stiffness or a load
/// given in the wrong unit.
pub(crate) const MAX_BEAM_SAG_SHARE: f64 = 0.01;

/// The holder's weight at mid-span, F·l³/(48·EI), sags the beam by less than
/// [`MAX_BEAM_SAG_SHARE`] of its length.
fn validate_beam(
    c: &Checker,
    k: &dyn Fn(&str) -> String,
    ls: &super::LateralShift,
) -> Result<(), ConfigError> {
    let l = ls.beam_length_m;
    let sag_m = ls.holder_load_n * l.powi(3) / (48.0 * ls.bending_stiffness_n_m2);
    if sag_m <= MAX_BEAM_SAG_SHARE * l {
        return Ok(());
    }
    Err(c.inconsistent(
        &k("lateral_shift.bending_stiffness_n_m2"),
        format!(
            "is {} N·m²: the holder's {} N would sag the {l} m beam by {} mm at mid-span, \
             more than a hundredth of its length (no machine's beam bends so; is a unit off?)",
            number(ls.bending_stiffness_n_m2),
            number(ls.holder_load_n),
            // Computed, not the user's: four digits say it.
            number(
                format!("{:.4e}", sag_m * 1e3)
                    .parse()
                    .unwrap_or(sag_m * 1e3)
            )
        ),
    ))
}

/// Presliding friction's keys: a damping needs the bristles it damps; friction near rest may
/// lie below Coulomb's only with bristles (a stuck table of the hybrid model would then slide
/// under less force than a sliding one needs), not below a tenth of it, and not together
/// with a Stribeck excess above it; a level near rest other than Coulomb's needs the speed
/// it fades over.
fn validate_presliding(
    c: &Checker,
    k: &dyn Fn(&str) -> String,
    f: &super::Friction,
) -> Result<(), ConfigError> {
    if !f.has_presliding() {
        if f.static_to_coulomb_negative.is_some() {
            return Err(c.inconsistent(
                &k("friction.static_to_coulomb_negative"),
                "sets friction near rest towards − for presliding bristles: it needs \
                 friction.bristle_stiffness_n_per_um"
                    .into(),
            ));
        }
        if f.bristle_damping_n_s_per_m > 0.0 {
            return Err(c.inconsistent(
                &k("friction.bristle_damping_n_s_per_m"),
                "damps the presliding bristles: it needs friction.bristle_stiffness_n_per_um"
                    .into(),
            ));
        }
        return Ok(());
    }
    if f.static_to_coulomb < 0.1 {
        return Err(c.inconsistent(
            &k("friction.static_to_coulomb"),
            format!(
                "is {}: friction near rest below a tenth of Coulomb friction is no guideway's \
                 (must be at least 0.1 with presliding bristles)",
                f.static_to_coulomb
            ),
        ));
    }
    if f.static_to_coulomb_negative.is_some() && f.stribeck_level_n > 0.0 {
        return Err(c.inconsistent(
            &k("friction.static_to_coulomb_negative"),
            "sets friction near rest towards − while friction.stribeck_level_n sets it both \
             ways: give one of the two"
                .into(),
        ));
    }
    if let Some(ratio) = f.static_to_coulomb_negative.filter(|r| *r < 0.1) {
        return Err(c.inconsistent(
            &k("friction.static_to_coulomb_negative"),
            format!(
                "is {ratio}: friction near rest below a tenth of Coulomb friction is no \
                 guideway's (must be at least 0.1)"
            ),
        ));
    }
    if f.static_to_coulomb < 1.0 && f.stribeck_level_n > 0.0 {
        return Err(c.inconsistent(
            &k("friction.static_to_coulomb"),
            format!(
                "is {} while friction.stribeck_level_n puts friction near rest above Coulomb's: \
                 give one of the two",
                f.static_to_coulomb
            ),
        ));
    }
    let rest_differs = f.static_to_coulomb != 1.0
        || f.stribeck_level_n > 0.0
        || f.static_to_coulomb_negative.is_some_and(|r| r != 1.0);
    if rest_differs && f.stribeck_velocity_mm_per_min <= 0.0 {
        return Err(c.inconsistent(
            &k("friction.stribeck_velocity_mm_per_min"),
            "must be positive with presliding bristles whose level near rest differs from \
             Coulomb friction: it is the speed over which that level passes into Coulomb's"
                .into(),
        ));
    }
    Ok(())
}

/// Bristles so stiff or so strongly damped against the table's mass that their time scale
/// (√(m/σ0) or m/σ1) asks for simulation steps under a microsecond: no guideway's, and no
/// simulation would follow them accurately in a useful time.
fn validate_bristle_step(
    c: &Checker,
    k: &dyn Fn(&str) -> String,
    f: &super::Friction,
    mass_kg: f64,
) -> Result<(), ConfigError> {
    if !f.has_presliding() {
        return Ok(());
    }
    let [spring_s, damper_s] = super::bristle_steps_s(
        mass_kg,
        f.bristle_stiffness_n_per_um * 1e6,
        f.bristle_damping_n_s_per_m,
    );
    let shortest = super::SHORTEST_BRISTLE_STEP_S;
    let (key, value, unit, scale, step_s) = if spring_s <= damper_s {
        let v = f.bristle_stiffness_n_per_um;
        (
            "friction.bristle_stiffness_n_per_um",
            v,
            "N/µm",
            "√(m/σ0)",
            spring_s,
        )
    } else {
        let v = f.bristle_damping_n_s_per_m;
        (
            "friction.bristle_damping_n_s_per_m",
            v,
            "N·s/m",
            "m/σ1",
            damper_s,
        )
    };
    if step_s >= shortest {
        return Ok(());
    }
    Err(c.inconsistent(
        &k(key),
        format!(
            "is {value} {unit}: on a table of {mass_kg} kg the bristles' time scale {scale} is \
             {:.3} µs, which needs simulation steps under a microsecond (a tenth of it); \
             no guideway's bristles are that fast",
            step_s * 10.0 * 1e6
        ),
    ))
}

/// The sections the controller structure needs: a velocity loop where it commands one, a
/// current loop (with the motor's electrical data) or a current amplifier, not both.
fn validate_sections(c: &Checker, axis: &str, a: &AxisConfig) -> Result<(), ConfigError> {
    let k = |s: &str| format!("{axis}.{s}");
    let missing = |key: &str, why: &str| ConfigError::Missing {
        file: c.file.to_string(),
        key: k(key),
        why: format!(" ({why})"),
    };
    if a.velocity_loop.is_none() && a.controller.uses_velocity_loop() {
        return Err(missing(
            "velocity_loop",
            &format!(
                "the {} controller commands a velocity loop",
                a.controller.name()
            ),
        ));
    }
    match (&a.current_loop, &a.amplifier) {
        (Some(_), None) => {
            let mo = &a.motor;
            let electrical = "a modelled current loop needs the motor's electrical data";
            for (key, value) in [
                ("motor.ra_ohm", mo.ra_ohm),
                ("motor.la_mh", mo.la_mh),
                ("motor.ke_v_s_per_rad", mo.ke_v_s_per_rad),
            ] {
                if value.is_none() {
                    return Err(missing(key, electrical));
                }
            }
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
            Ok(())
        }
        (None, Some(amp)) if amp.i_max_a.is_none() && !a.controller.uses_velocity_loop() => {
            Err(missing(
                "amplifier.i_max_a",
                "no velocity loop limits the current command",
            ))
        }
        (None, Some(_)) => Ok(()),
        (None, None) => Err(missing(
            "current_loop",
            &format!("or [{axis}.amplifier]: the axis needs one or the other"),
        )),
        (Some(_), Some(_)) => Err(c.inconsistent(
            &k("amplifier"),
            format!("and [{axis}.current_loop] both describe the current control: give one"),
        )),
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
    let k = |s: &str| format!("{prefix}.{s}");
    if let Some([lo, hi]) = l.travel_mm {
        let far = super::MAX_TRAVEL_MM;
        c.check(&k("travel_mm"), lo, Rule::Range(-far, far))?;
        c.check(&k("travel_mm"), hi, Rule::Range(-far, far))?;
        if lo == hi {
            return Err(c.inconsistent(
                &k("travel_mm"),
                format!("is [{lo}, {hi}]: its two ends are equal, leaving the axis no travel"),
            ));
        }
        if lo > hi {
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

/// The friction the tables add keeps the total at or above zero everywhere: friction takes
/// force from the table's motion and never gives it. The tables are linear between their
/// points and held beyond, so their lowest points are the lowest anywhere: the position
/// map's lowest entry lowers the static level and, with the speed curve's lowest, the
/// sliding one.
fn validate_friction_total(
    c: &Checker,
    k: &dyn Fn(&str) -> String,
    a: &AxisConfig,
) -> Result<(), ConfigError> {
    let f = &a.friction;
    let e = &a.errors;
    let f_c = f.coulomb_n(a.drive.table_mass_kg);
    // Friction near rest is checked on its lower level where it differs by direction.
    let [plus_n, minus_n] = f.rest_n_by_direction(f_c);
    let f_s = plus_n.min(minus_n);
    let lowest = |values: &[f64]| {
        values
            .iter()
            .copied()
            .enumerate()
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .filter(|&(_, v)| v < 0.0)
    };
    let map = lowest(&e.friction_map_n);
    let speed = lowest(&e.friction_speed_n);
    let entry = |key: &str, (i, v): (usize, f64)| format!("{}[{i}] = {v} N", k(key));
    let map_entry = map.map(|m| entry("errors.friction_map_n", m));
    if let (Some((_, m)), Some(text)) = (map, &map_entry)
        && f_s + m < 0.0
    {
        return Err(negative_friction(
            c,
            k,
            "friction_map_n",
            text,
            "static",
            f_s,
            m,
        ));
    }
    let map_n = map.map_or(0.0, |(_, m)| m);
    if let Some(s) = speed
        && f_c + map_n + s.1 < 0.0
    {
        let text = match &map_entry {
            Some(m) => format!("{} with {m}", entry("errors.friction_speed_n", s)),
            None => entry("errors.friction_speed_n", s),
        };
        return Err(negative_friction(
            c,
            k,
            "friction_speed_n",
            &text,
            "sliding",
            f_c,
            map_n + s.1,
        ));
    }
    if let (Some(text), true) = (&map_entry, f_c + map_n < 0.0) {
        return Err(negative_friction(
            c,
            k,
            "friction_map_n",
            text,
            "sliding",
            f_c,
            map_n,
        ));
    }
    Ok(())
}

/// The error for a table `entry` whose `added_n` takes the axis's `level` friction of
/// `level_n` below zero.
fn negative_friction(
    c: &Checker,
    k: &dyn Fn(&str) -> String,
    key: &str,
    entry: &str,
    level: &str,
    level_n: f64,
    added_n: f64,
) -> ConfigError {
    c.inconsistent(
        &k(&format!("errors.{key}")),
        format!(
            "takes the {level} friction below zero: {entry} added to the axis's {level_n:.1} N \
             leaves {:.1} N, and friction never pushes the table (its tables may lower it to \
             zero at most)",
            level_n + added_n
        ),
    )
}

#[cfg(test)]
mod tests;
