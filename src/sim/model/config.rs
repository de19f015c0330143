//! The model derived from an axis's section of the machine file: every unit conversion
//! happens here, and the parts a controller or drive does not use are left at values that
//! keep the matrices finite.

use super::{AxisModel, ControlModel, LateralShiftModel, MeasuringError};
use crate::machine::realise::realise;
use crate::machine::{AxisConfig, Controller, Drive, DriveKind, Feedback};
use crate::numeric::lookup::Lookup;
use crate::numeric::units::{
    GRAVITY_M_PER_S2, h_from_mh, m_from_mm, m_from_um, m_per_s_from_mm_per_min,
    per_s_from_kv_m_per_min_per_mm, s_from_ms,
};

impl AxisModel {
    /// Derives the SI model from an axis configuration (all conversions happen here).
    pub fn from_config(c: &AxisConfig) -> AxisModel {
        let m = Mechanics::of(c);
        let kt = c.motor.kt_nm_per_a;
        let f_c = c.friction.coulomb_n(m.mt);
        let (kf, ka) = feedforward(c);
        let drive = DriveLoops::of(c);
        let f_s = c.friction.static_n(f_c);
        let (friction_map, friction_speed) = friction_maps(&c.errors);
        AxisModel {
            kp: cascade_position_gain(c, &m),
            kf,
            ka,
            // A linear motor's position is read where it pushes: at the table.
            feedback: if m.linear_motor {
                Feedback::LinearScale
            } else {
                c.position_loop.feedback
            },
            control: ControlModel::from_config(&c.controller),
            amplifier_tau: c
                .amplifier
                .as_ref()
                .map(|amp| 1.0 / (std::f64::consts::TAU * amp.current_bandwidth_hz)),
            ks: drive.ks,
            ts: drive.ts,
            i_max: drive.i_max,
            ki: drive.ki,
            ti: drive.ti,
            tcf: drive.tcf,
            u_max: drive.u_max,
            ra: c.motor.ra_ohm.unwrap_or(0.0),
            la: h_from_mh(c.motor.la_mh.unwrap_or(1.0)),
            kt,
            ke: c.motor.ke_v_s_per_rad.unwrap_or(0.0),
            jm: m.jm,
            js: m.js,
            k_theta: m.k_theta,
            c_theta: m.c_theta,
            k_m: m.k_m,
            c_m: m.c_m,
            r: m.r,
            it: m.it,
            mt: m.mt,
            linear_motor: m.linear_motor,
            b_screw: m.b_screw,
            half_gap: 0.5 * m_from_um(c.drive.backlash_um),
            f_c,
            f_s,
            f_v: c.friction.viscous_n_s_per_m,
            lateral: c.lateral_shift.as_ref().map(LateralShiftModel::from_config),
            dead_time_s: s_from_ms(c.position_loop.dead_time_ms),
            stribeck: stribeck(c),
            friction_map,
            friction_speed,
            force_ripple: super::ForceRipple::from_config(&c.errors),
            presliding: crate::sim::presliding::Presliding::from_config(
                c,
                f_c,
                c.friction.rest_n_by_direction(f_c),
            ),
            measuring: MeasuringError::from_config(&c.errors, c.drive.lead_mm),
            resonance: (c.errors.resonance_hz > 0.0).then_some({
                (
                    std::f64::consts::TAU * c.errors.resonance_hz,
                    c.errors.resonance_damping,
                )
            }),
            load_n: c
                .gravity
                .as_ref()
                .map_or(0.0, |g| m.mt * GRAVITY_M_PER_S2 - g.counterbalance_n),
            // A record's start sets it (in memory), never the machine file.
            held_at_start_n: c.held_at_start_n,
        }
    }
}

/// The position loop's gain in the motor's own units (1/s per rad of the lead's radius and
/// gear), for the cascade only: another controller closes its loop itself.
fn cascade_position_gain(c: &AxisConfig, m: &Mechanics) -> f64 {
    match c.controller {
        Controller::Cascade => {
            per_s_from_kv_m_per_min_per_mm(c.position_loop.kv_m_per_min_per_mm) / (m.r * m.it)
        }
        _ => 0.0,
    }
}

/// The Stribeck excess (N) and the speed it falls over (m/s), where there is one.
fn stribeck(c: &AxisConfig) -> Option<(f64, f64)> {
    (c.friction.stribeck_level_n > 0.0).then(|| {
        (
            c.friction.stribeck_level_n,
            m_per_s_from_mm_per_min(c.friction.stribeck_velocity_mm_per_min),
        )
    })
}

/// The drive's mechanics in SI: lead radius and gear ratio, inertias and mass, springs and
/// their damping, the screw's viscous friction.
struct Mechanics {
    linear_motor: bool,
    r: f64,
    it: f64,
    jm: f64,
    js: f64,
    mt: f64,
    k_theta: f64,
    c_theta: f64,
    k_m: f64,
    c_m: f64,
    b_screw: f64,
}

impl Mechanics {
    /// A linear motor is its own table: a "motor radian" is a metre, its force constant
    /// the torque constant, and there is no screw, coupling or nut.
    fn of(c: &AxisConfig) -> Mechanics {
        let d = &c.drive;
        let mt = d.table_mass_kg;
        if d.kind == DriveKind::LinearMotor {
            return Mechanics {
                linear_motor: true,
                r: 1.0,
                it: 1.0,
                jm: 0.0,
                js: 0.0,
                mt,
                k_theta: 0.0,
                c_theta: 0.0,
                k_m: 0.0,
                c_m: 0.0,
                b_screw: 0.0,
            };
        }
        let (r, it) = (m_from_mm(d.lead_mm) / std::f64::consts::TAU, d.gear_ratio);
        let (jm, js) = (c.motor.jm_kg_m2, d.js_kg_m2);
        let (k_theta, c_theta, k_m, c_m) = springs(d, [jm, js, mt], r, it);
        Mechanics {
            linear_motor: false,
            r,
            it,
            jm,
            js,
            mt,
            k_theta,
            c_theta,
            k_m,
            c_m,
            b_screw: d.screw_viscous_nm_s_per_rad,
        }
    }
}

/// The velocity and current loops in the model's terms; a loop the axis does not close (a
/// controller that commands current, an ideal amplifier) at values that keep the matrices
/// finite.
struct DriveLoops {
    ks: f64,
    ts: f64,
    i_max: f64,
    ki: f64,
    ti: f64,
    tcf: f64,
    u_max: f64,
}

impl DriveLoops {
    fn of(c: &AxisConfig) -> DriveLoops {
        let velocity = c
            .velocity_loop
            .as_ref()
            .filter(|_| c.controller.uses_velocity_loop());
        let current = c.current_loop.as_ref().filter(|_| c.amplifier.is_none());
        DriveLoops {
            ks: velocity.map_or(0.0, |v| v.ks_nm_s_per_rad / c.motor.kt_nm_per_a),
            ts: velocity.map_or(1.0, |v| s_from_ms(v.ts_ms)),
            i_max: match (velocity, &c.amplifier) {
                (Some(v), _) => v.i_max_a,
                (None, Some(amp)) => amp.i_max_a.unwrap_or(f64::INFINITY),
                (None, None) => f64::INFINITY,
            },
            ki: current.map_or(0.0, |i| i.ki_v_per_a),
            ti: current.map_or(1.0, |i| s_from_ms(i.ti_ms)),
            tcf: current.map_or(1.0, |i| s_from_ms(i.tcf_ms)),
            u_max: current.map_or(f64::INFINITY, |i| i.u_max_v),
        }
    }
}

/// The friction the maps add, by position (mm → m) and by speed (mm/min → m/s).
fn friction_maps(e: &crate::machine::Errors) -> (Lookup, Lookup) {
    (
        Lookup::scaled(&e.friction_map_mm, &e.friction_map_n, 1e-3, 1.0),
        Lookup::scaled(
            &e.friction_speed_mm_per_min,
            &e.friction_speed_n,
            m_per_s_from_mm_per_min(1.0),
            1.0,
        ),
    )
}

impl ControlModel {
    fn from_config(c: &Controller) -> ControlModel {
        match c {
            Controller::Cascade => ControlModel::Cascade,
            Controller::TransferFunction(tf) => ControlModel::Transfer {
                realisation: realise(tf).expect("validated with the machine"),
                output: tf.output,
            },
            Controller::StateFeedback(sf) => ControlModel::StateFeedback {
                kx: sf.position_gain_a_per_mm * 1e3,
                kz: sf.integral_gain_a_per_mm_s * 1e3,
                kd: sf.velocity_gain_a_s_per_mm * 1e3,
            },
        }
    }
}

/// The torsional and axial springs and their damping, (K_θ, C_θ, K_M, C_M), from the
/// drive and the inertias `[J_m, J_s, M_T]` at lead radius `r` and gear ratio `it`. Each
/// damping comes from its spring's two sides' reduced inertia: C = 2ζ√(K·m_eq).
fn springs(d: &Drive, [jm, js, mt]: [f64; 3], r: f64, it: f64) -> (f64, f64, f64, f64) {
    let reduced = |a: f64, b: f64| a * b / (a + b);
    let j_theta = reduced(jm / (it * it), js);
    let m_axial = reduced((jm / (it * it) + js) / (r * r), mt);
    (
        d.k_theta_nm_per_rad,
        2.0 * d.zeta_theta * (d.k_theta_nm_per_rad * j_theta).sqrt(),
        d.k_m_n_per_m,
        2.0 * d.zeta_m * (d.k_m_n_per_m * m_axial).sqrt(),
    )
}

/// The velocity and acceleration feed-forward shares of the axis's controller.
fn feedforward(c: &AxisConfig) -> (f64, f64) {
    match &c.controller {
        Controller::Cascade => (
            c.position_loop.velocity_feedforward,
            c.position_loop.accel_feedforward,
        ),
        Controller::TransferFunction(tf) => (tf.velocity_feedforward, tf.accel_feedforward),
        Controller::StateFeedback(sf) => (sf.velocity_feedforward, sf.accel_feedforward),
    }
}

impl MeasuringError {
    /// From the machine file's error terms; a cyclic error without a period repeats with
    /// the screw's lead.
    fn from_config(e: &crate::machine::Errors, lead_mm: f64) -> MeasuringError {
        MeasuringError {
            scale: e.scale_error_ppm * 1e-6,
            amplitude_m: m_from_um(e.cyclic_amplitude_um),
            wavenumber_per_m: std::f64::consts::TAU
                / m_from_mm(if e.cyclic_period_mm > 0.0 {
                    e.cyclic_period_mm
                } else {
                    lead_mm
                }),
            phase_rad: e.cyclic_phase_deg.to_radians(),
        }
    }
}

impl LateralShiftModel {
    fn from_config(l: &crate::machine::LateralShift) -> LateralShiftModel {
        LateralShiftModel {
            l: l.beam_length_m,
            ei: l.bending_stiffness_n_m2,
            load: l.holder_load_n,
            a0: l.holder_at_zero_m,
        }
    }
}
