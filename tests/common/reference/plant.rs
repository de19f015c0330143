//! The axis's constants in SI, read from the machine file, and the forces and errors that
//! repeat with its position or with time.

use contourcheck::machine::{AxisConfig, Controller, Feedback};

use super::controllers::{CurrentLaw, Law};

const GRAVITY: f64 = 9.80665;

/// The axis's constants in SI, read from the machine file as `docs/model.md` §1 defines them.
#[derive(Clone, Copy, Debug)]
pub struct Plant {
    pub(super) kp: f64,
    pub(super) kf: f64,
    pub(super) ka: f64,
    pub(super) ks: f64,
    pub(super) ts: f64,
    pub(super) i_max: f64,
    pub(super) ki: f64,
    pub(super) ti: f64,
    pub(super) tcf: f64,
    pub(super) u_max: f64,
    pub(super) ra: f64,
    pub(super) la: f64,
    pub(super) kt: f64,
    pub(super) ke: f64,
    pub(super) jm: f64,
    pub(super) js: f64,
    pub(super) k_theta: f64,
    pub(super) c_theta: f64,
    pub(super) k_m: f64,
    pub(super) c_m: f64,
    pub(super) r: f64,
    pub(super) it: f64,
    pub(super) mt: f64,
    pub(super) b_screw: f64,
    pub(super) half_gap: f64,
    pub(super) f_c: f64,
    pub(super) f_s: f64,
    /// Friction near rest moving towards − where bristles carry a level of their own that
    /// way (f_s otherwise).
    pub(super) f_s_negative: f64,
    pub(super) f_v: f64,
    /// Delay between the interpolator and the position controller (s).
    pub(super) dead_time: f64,
    /// How the motor's current is commanded.
    pub(super) law: Law,
    /// The position is read at the motor's encoder (else at the table).
    pub(super) motor_encoder: bool,
    /// A vertical axis's weight less its counterbalance, pulling the table down (N).
    pub(super) load: f64,
    /// The force the loops push with at the start, friction holding it (N, towards +).
    pub(super) held: f64,
    /// A force repeating with the table's position, towards −: A·sin(2π·x/period + φ).
    pub(super) ripple: Cycle,
    /// A cyclic error of the encoder: it reads the axis e·sin(2π·x/period + φ) too far.
    pub(super) encoder_error: Cycle,
    /// A force repeating with time, towards −: A·sin(2π·t/period + φ).
    pub(super) timed_force: Timed,
    /// LuGre bristles: stiffness σ0 (N/m, 0 = stick and slip instead), damping σ1 (N·s/m)
    /// and the speed over which friction at rest passes into Coulomb's (m/s).
    pub(super) bristles: (f64, f64, f64),
}

/// Something that repeats with position: amplitude (N or m) · sin(2π·x/period + phase).
#[derive(Clone, Copy, Debug, Default)]
pub struct Cycle {
    pub amplitude: f64,
    pub period_m: f64,
    pub phase_rad: f64,
}

impl Cycle {
    /// Its value with the axis at `x_m`; zero where it has no period.
    pub(super) fn at(&self, x_m: f64) -> f64 {
        sine(self.amplitude, x_m, self.period_m, self.phase_rad)
    }
}

/// A force that repeats with time, whatever the axis does (a pump's pulse, a machine beside
/// it): amplitude (N) · sin(2π·t/period + phase), t from the run's start.
#[derive(Clone, Copy, Debug, Default)]
pub struct Timed {
    pub amplitude_n: f64,
    pub period_s: f64,
    pub phase_rad: f64,
}

impl Timed {
    /// Its value at `t_s`; zero where it has no period.
    pub(super) fn at(&self, t_s: f64) -> f64 {
        sine(self.amplitude_n, t_s, self.period_s, self.phase_rad)
    }
}

/// `amplitude · sin(2π·at/period + phase)` (`at` and `period` in one unit: m or s); zero
/// where there is no period.
fn sine(amplitude: f64, at: f64, period: f64, phase_rad: f64) -> f64 {
    if period <= 0.0 {
        return 0.0;
    }
    amplitude * (std::f64::consts::TAU * at / period + phase_rad).sin()
}

impl Plant {
    /// The axis of `c`: a cascade with its current loop, or a controller on a current
    /// amplifier.
    pub fn new(c: &AxisConfig) -> Plant {
        if !matches!(c.controller, Controller::Cascade) {
            return Plant::amplified(c);
        }
        let v = c.velocity_loop.as_ref().expect("a cascade axis");
        let i = c.current_loop.as_ref().expect("a modelled current loop");
        let plant = Plant::mechanics(c);
        let (r, it, kt) = (plant.r, plant.it, plant.kt);
        Plant {
            // Kv in 1/s over r·i_t: rad/s of motor speed per metre of error.
            kp: c.position_loop.kv_m_per_min_per_mm * 1000.0 / 60.0 / (r * it),
            kf: c.position_loop.velocity_feedforward,
            ka: c.position_loop.accel_feedforward,
            ks: v.ks_nm_s_per_rad / kt,
            ts: v.ts_ms * 1e-3,
            i_max: v.i_max_a,
            ki: i.ki_v_per_a,
            ti: i.ti_ms * 1e-3,
            tcf: i.tcf_ms * 1e-3,
            u_max: i.u_max_v,
            ra: c.motor.ra_ohm.unwrap(),
            la: c.motor.la_mh.unwrap() * 1e-3,
            ke: c.motor.ke_v_s_per_rad.unwrap(),
            ..plant
        }
    }

    /// A transfer function or state feedback on a current amplifier: the mechanics and
    /// friction of the cascade's plant, the cascade's own loops unused.
    fn amplified(c: &AxisConfig) -> Plant {
        let amplifier = c.amplifier.as_ref().expect("a current amplifier");
        let ka = match &c.controller {
            Controller::TransferFunction(tf) => tf.accel_feedforward,
            Controller::StateFeedback(sf) => sf.accel_feedforward,
            Controller::Cascade => unreachable!(),
        };
        let law = Law::Amplified {
            control: CurrentLaw::of(&c.controller),
            tau: 1.0 / (std::f64::consts::TAU * amplifier.current_bandwidth_hz),
            i_max: amplifier.i_max_a.expect("a current limit"),
            ka,
        };
        Plant {
            law,
            ..Plant::mechanics(c)
        }
    }

    /// The mechanics, friction and feedback of `c`, its loops left for the controller's
    /// constructor (the cascade's; unused by a controller on an amplifier).
    fn mechanics(c: &AxisConfig) -> Plant {
        let d = &c.drive;
        let r = d.lead_mm * 1e-3 / std::f64::consts::TAU;
        let it = d.gear_ratio;
        let (jm, js, mt) = (c.motor.jm_kg_m2, d.js_kg_m2, d.table_mass_kg);
        // Each spring's damping from the reduced inertia of the two bodies it joins.
        let reduced = |a: f64, b: f64| a * b / (a + b);
        let j_theta = reduced(jm / (it * it), js);
        let m_axial = reduced((jm / (it * it) + js) / (r * r), mt);
        let f_c = c.friction.coulomb_coefficient * mt * GRAVITY;
        let f_s = if c.friction.has_presliding() && c.friction.static_to_coulomb < 1.0 {
            c.friction.static_to_coulomb * f_c
        } else {
            (c.friction.static_to_coulomb * f_c).max(f_c + c.friction.stribeck_level_n)
        };
        Plant {
            kp: 0.0,
            kf: 0.0,
            ka: 0.0,
            ks: 0.0,
            ts: 1.0,
            i_max: 0.0,
            ki: 0.0,
            ti: 1.0,
            tcf: 1.0,
            u_max: 0.0,
            ra: 0.0,
            la: 1.0,
            kt: c.motor.kt_nm_per_a,
            ke: 0.0,
            jm,
            js,
            k_theta: d.k_theta_nm_per_rad,
            c_theta: 2.0 * d.zeta_theta * (d.k_theta_nm_per_rad * j_theta).sqrt(),
            k_m: d.k_m_n_per_m,
            c_m: 2.0 * d.zeta_m * (d.k_m_n_per_m * m_axial).sqrt(),
            r,
            it,
            mt,
            b_screw: d.screw_viscous_nm_s_per_rad,
            half_gap: 0.5e-6 * d.backlash_um,
            f_c,
            f_s,
            f_s_negative: match c.friction.static_to_coulomb_negative {
                Some(ratio) if c.friction.has_presliding() => ratio * f_c,
                _ => f_s,
            },
            f_v: c.friction.viscous_n_s_per_m,
            dead_time: c.position_loop.dead_time_ms * 1e-3,
            law: Law::Cascade,
            motor_encoder: c.position_loop.feedback == Feedback::MotorEncoder,
            load: c
                .gravity
                .as_ref()
                .map_or(0.0, |g| mt * GRAVITY - g.counterbalance_n),
            held: 0.0,
            ripple: Cycle {
                amplitude: c.errors.force_ripple_n,
                period_m: c.errors.force_ripple_period_mm * 1e-3,
                phase_rad: c.errors.force_ripple_phase_deg.to_radians(),
            },
            encoder_error: Cycle::default(),
            timed_force: Timed::default(),
            bristles: (
                c.friction.bristle_stiffness_n_per_um * 1e6,
                c.friction.bristle_damping_n_s_per_m,
                c.friction.stribeck_velocity_mm_per_min / 60_000.0,
            ),
        }
    }

    /// The same plant standing at its start with its loops pushing `held_n` (N, towards +)
    /// against the friction that holds the table there.
    pub fn holding(self, held_n: f64) -> Plant {
        Plant {
            held: held_n,
            ..self
        }
    }

    /// The same plant with Coulomb friction `factor` times as high between `from_m` and
    /// `to_m` of table travel (a tight spot on the guideway).
    pub fn friction_at(&self, x2: f64, spot: Option<(f64, f64, f64)>) -> (f64, f64) {
        match spot {
            Some((from, to, factor)) if (from..=to).contains(&x2) => {
                (self.f_c * factor, self.f_s + self.f_c * (factor - 1.0))
            }
            _ => (self.f_c, self.f_s),
        }
    }
}
