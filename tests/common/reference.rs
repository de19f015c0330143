//! An independent reference for the diagnosis: the servo-feed axis of `docs/model.md` §1
//! integrated here, apart from `contourcheck::sim` — the paper's cascade, or a transfer
//! function or state feedback commanding a current amplifier (a first-order lag) with the
//! position read at the motor's encoder where the machine file says so (the motor's own
//! angle, where the tool reads the screw's) — classical fourth-order Runge–Kutta at a
//! fixed step of a few microseconds, friction switched by a sticking test at each step rather
//! than by the simulator's exact switching instants — and driven by a continuous trapezoidal
//! interpolator that stops at every block end, evaluated at every step rather than once per
//! interpolation cycle. Records made here share with the tool only the machine file's numbers
//! and the model's equations; what the tool's own planner, command reconstruction and
//! integrator do differently shows up as residual.

use contourcheck::gcode::Program;
use contourcheck::machine::{AxisConfig, Controller, ControllerOutput, Feedback};
use contourcheck::path::{Geometry, Motion};
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};

const GRAVITY: f64 = 9.80665;

/// The axis's constants in SI, read from the machine file as `docs/model.md` §1 defines them.
#[derive(Clone, Copy, Debug)]
pub struct Plant {
    kp: f64,
    kf: f64,
    ka: f64,
    ks: f64,
    ts: f64,
    i_max: f64,
    ki: f64,
    ti: f64,
    tcf: f64,
    u_max: f64,
    ra: f64,
    la: f64,
    kt: f64,
    ke: f64,
    jm: f64,
    js: f64,
    k_theta: f64,
    c_theta: f64,
    k_m: f64,
    c_m: f64,
    r: f64,
    it: f64,
    mt: f64,
    b_screw: f64,
    half_gap: f64,
    f_c: f64,
    f_s: f64,
    f_v: f64,
    /// Delay between the interpolator and the position controller (s).
    dead_time: f64,
    /// How the motor's current is commanded.
    law: Law,
    /// The position is read at the motor's encoder (else at the table).
    motor_encoder: bool,
    /// A vertical axis's weight less its counterbalance, pulling the table down (N).
    load: f64,
    /// The force the loops push with at the start, friction holding it (N, towards +).
    held: f64,
    /// A force repeating with the table's position, towards −: A·sin(2π·x/period + φ).
    ripple: Cycle,
    /// A cyclic error of the encoder: it reads the axis e·sin(2π·x/period + φ) too far.
    encoder_error: Cycle,
    /// A force repeating with time, towards −: A·sin(2π·t/period + φ).
    timed_force: Timed,
    /// LuGre bristles: stiffness σ0 (N/m, 0 = stick and slip instead), damping σ1 (N·s/m)
    /// and the speed over which friction at rest passes into Coulomb's (m/s).
    bristles: (f64, f64, f64),
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
    fn at(&self, x_m: f64) -> f64 {
        if self.period_m <= 0.0 {
            return 0.0;
        }
        self.amplitude * (std::f64::consts::TAU * x_m / self.period_m + self.phase_rad).sin()
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
    fn at(&self, t_s: f64) -> f64 {
        if self.period_s <= 0.0 {
            return 0.0;
        }
        self.amplitude_n * (std::f64::consts::TAU * t_s / self.period_s + self.phase_rad).sin()
    }
}

/// How the motor's current is commanded.
#[derive(Clone, Copy, Debug)]
enum Law {
    /// The paper's cascade: P position, PI speed and PI current loops.
    Cascade,
    /// A position controller commanding the current of an amplifier that follows as a
    /// first-order lag of `tau` seconds, limited to `i_max`, with the current that
    /// accelerates the axis fed forward (`ka`).
    Amplified {
        control: CurrentLaw,
        tau: f64,
        i_max: f64,
        ka: f64,
    },
}

#[derive(Clone, Copy, Debug)]
enum CurrentLaw {
    /// C(s) from the error (mm) to the current (A), `n` states in controllable canonical
    /// form: z_k' = z_(k+1), z_n' = e − Σ a_(n+1−k) z_k, and the current d·e + Σ c_k z_k.
    Transfer {
        n: usize,
        a: [f64; 4],
        c: [f64; 4],
        d: f64,
    },
    /// i = kx·e + kz·∫e + kd·(kf·v_ref − v), e in mm, v the motor's speed as table speed.
    State { kx: f64, kz: f64, kd: f64, kf: f64 },
}

impl CurrentLaw {
    fn of(controller: &Controller) -> CurrentLaw {
        match controller {
            Controller::TransferFunction(tf) => {
                assert!(
                    tf.sample_ms == 0.0 && tf.output == ControllerOutput::Current,
                    "the reference takes C(s) commanding current"
                );
                let lead = tf.denominator[0];
                let n = tf.denominator.len() - 1;
                assert!((1..=4).contains(&n) && tf.numerator.len() <= n + 1);
                let den: Vec<f64> = tf.denominator.iter().map(|v| v / lead).collect();
                let mut num = vec![0.0; n + 1 - tf.numerator.len()];
                num.extend(tf.numerator.iter().map(|v| v / lead));
                let d = num[0];
                let (mut a, mut c) = ([0.0; 4], [0.0; 4]);
                for k in 0..n {
                    // z_(k+1) carries s^k: its coefficients are the (n−k)th ones.
                    a[k] = den[n - k];
                    c[k] = num[n - k] - d * den[n - k];
                }
                CurrentLaw::Transfer { n, a, c, d }
            }
            Controller::StateFeedback(sf) => CurrentLaw::State {
                kx: sf.position_gain_a_per_mm,
                kz: sf.integral_gain_a_per_mm_s,
                kd: sf.velocity_gain_a_s_per_mm,
                kf: sf.velocity_feedforward,
            },
            Controller::Cascade => unreachable!("the cascade has its own law"),
        }
    }
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
            f_s: if c.friction.has_presliding() && c.friction.static_to_coulomb < 1.0 {
                c.friction.static_to_coulomb * f_c
            } else {
                (c.friction.static_to_coulomb * f_c).max(f_c + c.friction.stribeck_level_n)
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

/// Indices of the state.
const TH_M: usize = 0;
const W_M: usize = 1;
const TH_S: usize = 2;
const W_S: usize = 3;
const X2: usize = 4;
const V2: usize = 5;
const I: usize = 6;
const Z_V: usize = 7;
const Z_I: usize = 8;
const F_CMD: usize = 9;
const F_I: usize = 10;
/// A transfer function's states (up to four), and state feedback's error integral.
const C0: usize = 11;
const Z_E: usize = 15;
/// The LuGre bristles' mean deflection (m).
const Z_B: usize = 16;
const STATES: usize = 17;

type State = [f64; STATES];

/// The reference: position, speed and acceleration at a time.
pub type Reference<'a> = &'a dyn Fn(f64) -> (f64, f64, f64);

/// One axis integrated at `h` seconds a step from rest at the reference's start.
pub struct Axis<'p> {
    plant: &'p Plant,
    x: State,
    stuck: bool,
    /// The direction the table slides in (±1): its speed's sign, or at the instant it
    /// breaks away (speed still zero) the nut's push.
    direction: f64,
    /// A tight spot: (from m, to m, factor on Coulomb friction).
    spot: Option<(f64, f64, f64)>,
    /// The time (s) of the step being taken: what the force repeating with time reads.
    now: f64,
}

impl<'p> Axis<'p> {
    pub fn at_rest(plant: &'p Plant, x0: f64, spot: Option<(f64, f64, f64)>) -> Axis<'p> {
        let mut x = [0.0; STATES];
        x[X2] = x0;
        x[TH_S] = x0 / plant.r;
        x[TH_M] = x[TH_S] / plant.it;
        if plant.load != 0.0 || plant.held != 0.0 {
            Axis::holding_load(plant, &mut x);
        }
        Axis {
            plant,
            x,
            // Bristles never stick: they bend.
            stuck: plant.bristles.0 == 0.0,
            direction: 1.0,
            spot,
            now: 0.0,
        }
    }

    /// The rest state in which the loops hold a vertical axis's weight and the force held
    /// at the start, friction carrying the force held (bent bristles, where there are any):
    /// the nut pushes the two through its flank (the gap closed), the screw's and the
    /// coupling's torque pass them to the motor, whose current an integral holds with no
    /// error — the cascade's velocity loop's (its current loop's integral the resistive
    /// drop), or a controller's on an amplifier. Where the control reads the motor's
    /// encoder, the motor stands at the command and the springs' give moves the table.
    fn holding_load(p: &Plant, x: &mut State) {
        let force = p.load + p.held;
        if p.bristles.0 > 0.0 {
            x[Z_B] = p.held / p.bristles.0;
        }
        let gap = p.half_gap * force.signum();
        let torque = p.r * force;
        if p.motor_encoder && !matches!(p.law, Law::Cascade) {
            x[TH_S] = p.it * x[TH_M] - torque / p.k_theta;
            x[X2] = p.r * x[TH_S] - gap - force / p.k_m;
        } else {
            x[TH_S] = (x[X2] + gap + force / p.k_m) / p.r;
            x[TH_M] = (x[TH_S] + torque / p.k_theta) / p.it;
        }
        let current = p.it * torque / p.kt;
        x[I] = current;
        match p.law {
            Law::Cascade => {
                x[F_CMD] = current;
                x[F_I] = current;
                x[Z_I] = p.ra * current * p.ti / p.ki;
                x[Z_V] = current * p.ts / p.ks;
            }
            // With no error only the integral's state stands off zero: i = c₁·z₁.
            Law::Amplified {
                control: CurrentLaw::Transfer { a, c, .. },
                ..
            } => {
                assert!(
                    a[0] == 0.0,
                    "the reference holds a force with an integral only"
                );
                x[C0] = current / c[0];
            }
            Law::Amplified {
                control: CurrentLaw::State { kz, .. },
                ..
            } => x[Z_E] = current / kz,
        }
    }

    /// The table's position (m).
    pub fn table(&self) -> f64 {
        self.x[X2]
    }

    /// Where the control reads the axis (m): the table, or the motor's encoder through the
    /// nominal lead.
    pub fn feedback(&self) -> f64 {
        self.read_at(&self.x)
    }

    fn read_at(&self, x: &State) -> f64 {
        let p = self.plant;
        let at = if p.motor_encoder {
            x[TH_M] * p.r * p.it
        } else {
            x[X2]
        };
        at + p.encoder_error.at(at)
    }

    /// A controller on a current amplifier: the current command (limited), whether it is at
    /// the limit, and the rates of the controller's states.
    fn amplified_control(
        &self,
        x: &State,
        (xr, vr, ar): (f64, f64, f64),
        control: CurrentLaw,
        i_max: f64,
        ka: f64,
    ) -> (f64, State) {
        let p = self.plant;
        let rit = p.r * p.it;
        let e_mm = (xr - self.read_at(x)) * 1e3;
        let j_tot = p.jm + p.it * p.it * p.js + rit * rit * p.mt;
        let i_ff = ka * j_tot * ar / (rit * p.kt);
        let mut dx = [0.0; STATES];
        let i_cmd = match control {
            CurrentLaw::Transfer { n, a, c, d } => {
                for k in 0..n - 1 {
                    dx[C0 + k] = x[C0 + k + 1];
                }
                dx[C0 + n - 1] = e_mm - (0..n).map(|k| a[k] * x[C0 + k]).sum::<f64>();
                d * e_mm + (0..n).map(|k| c[k] * x[C0 + k]).sum::<f64>() + i_ff
            }
            CurrentLaw::State { kx, kz, kd, kf } => {
                let v_mm = x[W_M] * rit * 1e3;
                let i = kx * e_mm + kz * x[Z_E] + kd * (kf * vr * 1e3 - v_mm) + i_ff;
                // The integral stops while the current sits at its limit.
                dx[Z_E] = if i.abs() > i_max && e_mm * i > 0.0 {
                    0.0
                } else {
                    e_mm
                };
                i
            }
        };
        (i_cmd.clamp(-i_max, i_max), dx)
    }

    /// The controller's outputs at state `x` and reference `(xr, vr, ar)`: the current
    /// command (limited) and the voltage (limited), and whether each is at its limit.
    fn controls(&self, x: &State, (xr, vr, ar): (f64, f64, f64)) -> (f64, bool, f64, bool) {
        let p = self.plant;
        let rit = p.r * p.it;
        let w_cmd = p.kp * (xr - x[X2]) + p.kf * vr / rit;
        let e_w = w_cmd - x[W_M];
        let j_tot = p.jm + p.it * p.it * p.js + rit * rit * p.mt;
        let i_ff = p.ka * j_tot * ar / (rit * p.kt);
        let i_cmd = p.ks * (e_w + x[Z_V] / p.ts) + i_ff;
        let i_limited = i_cmd.abs() > p.i_max;
        let e_i = x[F_CMD] - x[F_I];
        let u = p.ki * (e_i + x[Z_I] / p.ti);
        let u_limited = u.abs() > p.u_max;
        (
            i_cmd.clamp(-p.i_max, p.i_max),
            i_limited,
            u.clamp(-p.u_max, p.u_max),
            u_limited,
        )
    }

    /// Whether the controller reads the reference's speed and acceleration (feed-forward).
    pub fn feeds_forward(&self) -> bool {
        match self.plant.law {
            Law::Cascade => self.plant.kf != 0.0 || self.plant.ka != 0.0,
            Law::Amplified { control, ka, .. } => {
                ka != 0.0 || matches!(control, CurrentLaw::State { kf, .. } if kf != 0.0)
            }
        }
    }

    /// The nut's force on the table (N): the axial spring through the backlash gap, damped
    /// only in contact.
    fn nut_force(&self, x: &State) -> f64 {
        let p = self.plant;
        let delta = p.r * x[TH_S] - x[X2];
        let e = p.half_gap;
        let (d, contact) = if delta > e {
            (delta - e, true)
        } else if delta < -e {
            (delta + e, true)
        } else {
            (0.0, false)
        };
        let damping = if contact {
            p.c_m * (p.r * x[W_S] - x[V2])
        } else {
            0.0
        };
        p.k_m * d + damping
    }

    /// The state's rate of change; the table held while stuck.
    fn rates(&self, x: &State, reference: (f64, f64, f64), stuck: bool) -> State {
        let sliding_sign = if x[V2] != 0.0 {
            x[V2].signum()
        } else {
            self.direction
        };
        let p = self.plant;
        if let Law::Amplified {
            control,
            tau,
            i_max,
            ka,
        } = p.law
        {
            let (i_cmd, mut dx) = self.amplified_control(x, reference, control, i_max, ka);
            dx[I] = (i_cmd - x[I]) / tau;
            self.mechanics_rates(x, stuck, sliding_sign, &mut dx);
            return dx;
        }
        let (i_cmd, i_limited, u, u_limited) = self.controls(x, reference);
        let rit = p.r * p.it;
        let w_cmd = p.kp * (reference.0 - x[X2]) + p.kf * reference.1 / rit;
        let e_w = w_cmd - x[W_M];
        let e_i = x[F_CMD] - x[F_I];
        let mut dx = [0.0; STATES];
        self.mechanics_rates(x, stuck, sliding_sign, &mut dx);
        dx[I] = (u - p.ra * x[I] - p.ke * x[W_M]) / p.la;
        // An integrator stops while its output sits at the limit.
        dx[Z_V] = if i_limited && e_w * i_cmd > 0.0 {
            0.0
        } else {
            e_w
        };
        dx[Z_I] = if u_limited && e_i * u > 0.0 { 0.0 } else { e_i };
        dx[F_CMD] = (i_cmd - x[F_CMD]) / p.tcf;
        dx[F_I] = (x[I] - x[F_I]) / p.tcf;
        dx
    }

    /// The motor, coupling, screw, nut and table driven by the motor's current.
    fn mechanics_rates(&self, x: &State, stuck: bool, sliding_sign: f64, dx: &mut State) {
        let p = self.plant;
        let t_c = p.k_theta * (p.it * x[TH_M] - x[TH_S]) + p.c_theta * (p.it * x[W_M] - x[W_S]);
        let f_n = self.nut_force(x);
        let (f_c, _) = p.friction_at(x[X2], self.spot);
        dx[TH_M] = x[W_M];
        dx[W_M] = (p.kt * x[I] - p.it * t_c) / p.jm;
        dx[TH_S] = x[W_S];
        dx[W_S] = (t_c - p.b_screw * x[W_S] - p.r * f_n) / p.js;
        let (sigma0, sigma1, fade) = p.bristles;
        if sigma0 > 0.0 {
            // LuGre: dz/dt = v − σ0·|v|·z/g(v), F = σ0·z + σ1·dz/dt + f_v·v, with
            // g(v) = f_c + (f_s − f_c)·exp(−(v/v_s)²).
            let v = x[V2];
            let at_rest = if fade > 0.0 {
                (-(v / fade).powi(2)).exp()
            } else {
                0.0
            };
            let g = f_c + (p.f_s - p.f_c) * at_rest;
            dx[Z_B] = v - sigma0 * v.abs() * x[Z_B] / g;
            let friction = sigma0 * x[Z_B] + sigma1 * dx[Z_B] + p.f_v * v;
            dx[X2] = v;
            dx[V2] = (f_n - friction - self.pushed(x[X2])) / p.mt;
        } else if !stuck {
            dx[X2] = x[V2];
            let friction = p.f_v * x[V2] + f_c * sliding_sign;
            dx[V2] = (f_n - friction - self.pushed(x[X2])) / p.mt;
        }
    }

    /// The forces towards − other than the nut's and friction (N), the table at `x2`: the
    /// weight, the ripple with the position and the force with time.
    fn pushed(&self, x2: f64) -> f64 {
        let p = self.plant;
        p.load + p.ripple.at(x2) + p.timed_force.at(self.now)
    }

    /// One Runge–Kutta step of `h` from time `t`, then the friction's switches: a table that
    /// stands breaks away once the nut pushes beyond static friction; one that slides and
    /// whose speed changes sign within the step stops there, and sticks if static friction
    /// holds the nut's force.
    pub fn step(&mut self, t: f64, h: f64, reference: Reference) {
        let add = |a: &State, b: &State, k: f64| {
            let mut c = *a;
            for i in 0..STATES {
                c[i] += k * b[i];
            }
            c
        };
        let stuck = self.stuck;
        let x = self.x;
        // Held over the step, a few microseconds against the force's period.
        self.now = t + 0.5 * h;
        // The controller sees the interpolator's reference a dead time late.
        let t = t - self.plant.dead_time;
        let k1 = self.rates(&x, reference(t), stuck);
        let k2 = self.rates(&add(&x, &k1, 0.5 * h), reference(t + 0.5 * h), stuck);
        let k3 = self.rates(&add(&x, &k2, 0.5 * h), reference(t + 0.5 * h), stuck);
        let k4 = self.rates(&add(&x, &k3, h), reference(t + h), stuck);
        let mut next = x;
        for i in 0..STATES {
            next[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
        }
        if self.plant.bristles.0 > 0.0 {
            self.x = next;
            return;
        }
        let (_, f_s) = self.plant.friction_at(next[X2], self.spot);
        // What friction must hold: the nut's force less the weight and the ripple.
        let f_n = self.nut_force(&next) - self.pushed(next[X2]);
        if stuck {
            next[V2] = 0.0;
            if f_n.abs() >= f_s {
                self.stuck = false;
                self.direction = f_n.signum();
            }
        } else if next[V2] * x[V2] < 0.0 || next[V2] == 0.0 {
            next[V2] = 0.0;
            self.stuck = f_n.abs() < f_s;
            self.direction = f_n.signum();
        }
        self.x = next;
    }
}

/// A block of the interpolator: its duration and its XYZ position at a time into it.
type Block = (f64, Box<dyn Fn(f64) -> [f64; 3]>);

/// A block's distance travelled (m) at a time into it (s).
type Distance = Box<dyn Fn(f64) -> f64>;

/// A trapezoidal profile over `length` at feed `v` and `accel`: its duration and distance.
fn trapezoid(length: f64, v: f64, accel: f64) -> (f64, Distance) {
    let v = v.min((accel * length).sqrt());
    let t_acc = v / accel;
    let t_cruise = (length - v * t_acc) / v;
    let total = 2.0 * t_acc + t_cruise;
    let distance = move |t: f64| {
        if t < t_acc {
            0.5 * accel * t * t
        } else if t < t_acc + t_cruise {
            0.5 * v * t_acc + v * (t - t_acc)
        } else {
            let r = (total - t).max(0.0);
            length - 0.5 * accel * r * r
        }
    };
    (total, Box::new(distance))
}

/// A jerk-limited profile over `length` at feed `v`, rest to rest: the acceleration ramps at
/// `jerk` to `accel` (or to √(v·jerk) where the feed is reached before), holds, and ramps
/// back; the feed lowered where the block is too short to reach it. Its duration and
/// distance, exact (the jerk piecewise constant, each phase's motion a cubic).
fn s_curve(length: f64, v: f64, accel: f64, jerk: f64) -> (f64, Distance) {
    // The distance to reach `v` from rest and stop again.
    let there_and_back = |v: f64| {
        let a = accel.min((v * jerk).sqrt());
        v * (v / a + a / jerk)
    };
    let mut v = v;
    if there_and_back(v) > length {
        let (mut lo, mut hi) = (0.0, v);
        for _ in 0..100 {
            let mid = 0.5 * (lo + hi);
            if there_and_back(mid) > length {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        v = lo;
    }
    let a = accel.min((v * jerk).sqrt());
    let (ramp, hold) = (a / jerk, v / a - a / jerk);
    let cruise = (length - there_and_back(v)) / v;
    let phases = [
        (jerk, ramp),
        (0.0, hold),
        (-jerk, ramp),
        (0.0, cruise),
        (-jerk, ramp),
        (0.0, hold),
        (jerk, ramp),
    ];
    let total = phases.iter().map(|p| p.1).sum();
    let distance = move |t: f64| {
        let (mut s, mut v, mut a, mut left) = (0.0, 0.0, 0.0, t);
        for (j, d) in phases {
            let h = left.min(d);
            s += v * h + a * h * h / 2.0 + j * h * h * h / 6.0;
            v += a * h + j * h * h / 2.0;
            a += j * h;
            left -= h;
        }
        s.min(length)
    };
    (total, Box::new(distance))
}

/// A continuous interpolator: each block accelerates at `accel` (its acceleration stepped,
/// or ramped at a jerk: [`Trapezoids::s_curves`]), cruises at its feed and stops at its end
/// (rapids at 10 m/min); a dwell stands. Positions are exact at any time, speed and
/// acceleration along the path by differences over a microsecond.
pub struct Trapezoids {
    blocks: Vec<Block>,
    /// Total duration (s).
    pub duration_s: f64,
}

impl Trapezoids {
    pub fn new(program: &Program, accel: f64, pre_s: f64, post_s: f64) -> Trapezoids {
        Trapezoids::from_home(program, accel, pre_s, post_s, None)
    }

    /// [`Trapezoids::new`] for a machine standing at `home` (m), where given, rather than
    /// at the program's start: the program's first move runs from there — its first rapid
    /// from home to the rapid's end, or, where it begins with a feed move, a rapid from
    /// home to that move's start first. The approach is a move the program does not
    /// describe: a control starts it from wherever the machine stands.
    pub fn from_home(
        program: &Program,
        accel: f64,
        pre_s: f64,
        post_s: f64,
        home: Option<[f64; 2]>,
    ) -> Trapezoids {
        let ramp = move |length, v| trapezoid(length, v, accel);
        Trapezoids::build(program, &ramp, pre_s, post_s, home)
    }

    /// The same blocks, each on a jerk-limited profile (an S-curve): its acceleration
    /// ramps at `jerk` to at most `accel` and back, rest to rest.
    pub fn s_curves(program: &Program, accel: f64, jerk: f64, pre_s: f64, post_s: f64) -> Self {
        let ramp = move |length, v| s_curve(length, v, accel, jerk);
        Trapezoids::build(program, &ramp, pre_s, post_s, None)
    }

    /// The blocks of `program`, each moved along by `profile` (of its length and feed: its
    /// duration and the distance travelled at a time into it).
    fn build(
        program: &Program,
        profile: &dyn Fn(f64, f64) -> (f64, Distance),
        pre_s: f64,
        post_s: f64,
        home: Option<[f64; 2]>,
    ) -> Trapezoids {
        const RAPID_M_PER_S: f64 = 10.0 / 60.0;
        let mut blocks: Vec<Block> = Vec::new();
        let mut segments = program.segments.clone();
        if let Some([hx, hy]) = home {
            let first = segments[0];
            if first.motion == Motion::Rapid && matches!(first.geometry, Geometry::Line) {
                segments[0].start_m = [hx, hy, first.start_m[2]];
            } else {
                let mut approach = first;
                approach.geometry = Geometry::Line;
                approach.motion = Motion::Rapid;
                approach.start_m = [hx, hy, first.start_m[2]];
                approach.end_m = first.start_m;
                segments.insert(0, approach);
            }
        }
        let start = segments[0].start_m;
        blocks.push((pre_s, Box::new(move |_| start)));
        for seg in segments.iter().copied() {
            if let Geometry::Dwell { seconds } = seg.geometry {
                let p = seg.start_m;
                blocks.push((seconds, Box::new(move |_| p)));
                continue;
            }
            let length = seg.length_m();
            if length <= 0.0 {
                continue;
            }
            let v = if seg.motion == Motion::Rapid {
                RAPID_M_PER_S
            } else {
                seg.feed_m_per_s.min(RAPID_M_PER_S)
            };
            let (total, distance) = profile(length, v);
            blocks.push((
                total,
                Box::new(move |t| seg.eval(distance(t.clamp(0.0, total)), length).pos),
            ));
        }
        let end = segments.last().unwrap().end_m;
        blocks.push((post_s, Box::new(move |_| end)));
        let duration_s = blocks.iter().map(|b| b.0).sum();
        Trapezoids { blocks, duration_s }
    }

    /// The commanded XYZ position at `t` (m).
    pub fn position(&self, t: f64) -> [f64; 3] {
        let mut start = 0.0;
        for (k, (d, f)) in self.blocks.iter().enumerate() {
            if t < start + d || k + 1 == self.blocks.len() {
                return f((t - start).clamp(0.0, *d));
            }
            start += d;
        }
        unreachable!("the interpolator has blocks")
    }

    /// Axis `a`'s position, speed and acceleration at `t`.
    pub fn axis(&self, a: usize, t: f64) -> (f64, f64, f64) {
        const H: f64 = 1e-6;
        let (p0, p1, p2) = (
            self.position(t - H)[a],
            self.position(t)[a],
            self.position(t + H)[a],
        );
        (p1, (p2 - p0) / (2.0 * H), (p2 - 2.0 * p1 + p0) / (H * H))
    }
}

/// How a reference record is taken.
#[derive(Clone, Copy, Debug)]
pub struct Recording {
    /// Sampling period (s).
    pub sample_s: f64,
    /// Measurement noise, standard deviation (m).
    pub noise_m: f64,
    /// Encoder count (m), 0 for none.
    pub count_m: f64,
    /// Integration step (s).
    pub step_s: f64,
    /// Seed of the noise.
    pub seed: u64,
    /// The interpolator's path acceleration (m/s²).
    pub accel: f64,
    /// The interpolator's path jerk (m/s³), where it limits one: each block's acceleration
    /// then ramps at it (an S-curve); `None` steps it (a trapezoid).
    pub jerk: Option<f64>,
    /// A tight spot on X: (from m, to m, factor on Coulomb friction).
    pub tight_spot_x: Option<(f64, f64, f64)>,
    /// A cyclic error of X's encoder (amplitude in m), which the control reads too.
    pub encoder_error_x: Cycle,
    /// A force on X's table that repeats with time, not with its position.
    pub timed_force_x: Timed,
    /// The position is read where the control reads it (the motor's encoder on a
    /// semi-closed loop), else at the table.
    pub at_feedback: bool,
    /// Where the machine stands before the program (m): the run starts there and its first
    /// move comes from there ([`Trapezoids::from_home`]); `None` for the program's start.
    pub home_m: Option<[f64; 2]>,
    /// The stretch of the run the record keeps (s from the run's start, from and to): a
    /// logger started late or stopped early, its clock starting at zero where it starts.
    /// `None` keeps the whole run.
    pub keep_s: Option<(f64, f64)>,
    /// The force X's loops push with at the start, friction holding it (N, towards +).
    pub held_x_n: f64,
}

impl Default for Recording {
    fn default() -> Self {
        Recording {
            sample_s: 1e-3,
            noise_m: 0.3e-6,
            count_m: 0.0,
            step_s: 5e-6,
            seed: 1,
            accel: 0.5,
            jerk: None,
            tight_spot_x: None,
            encoder_error_x: Cycle::default(),
            timed_force_x: Timed::default(),
            at_feedback: false,
            home_m: None,
            keep_s: None,
            held_x_n: 0.0,
        }
    }
}

/// A record of `program` run by the reference on axes `x` and `y`: a CSV with the time (s),
/// the measured positions (at the table, or where the control reads them) and the
/// commanded positions (mm), as a control's trace would give them.
pub fn record(program: &Program, x: &AxisConfig, y: &AxisConfig, rec: &Recording) -> String {
    record_axes(program, &[x, y], rec)
}

/// [`record`] with Z run too, on `z`: its measured and commanded columns after X's and Y's.
pub fn record_xyz(program: &Program, [x, y, z]: [&AxisConfig; 3], rec: &Recording) -> String {
    record_axes(program, &[x, y, z], rec)
}

/// A record of the first `configs.len()` axes (X, Y and perhaps Z).
fn record_axes(program: &Program, configs: &[&AxisConfig], rec: &Recording) -> String {
    let interpolator = match rec.jerk {
        Some(jerk) => Trapezoids::s_curves(program, rec.accel, jerk, 0.3, 0.5),
        None => Trapezoids::from_home(program, rec.accel, 0.3, 0.5, rec.home_m),
    };
    let mut plants: Vec<Plant> = configs.iter().map(|c| Plant::new(c)).collect();
    plants[0].encoder_error = rec.encoder_error_x;
    plants[0].timed_force = rec.timed_force_x;
    plants[0] = plants[0].holding(rec.held_x_n);
    let start = interpolator.position(0.0);
    let mut axes: Vec<Axis> = plants
        .iter()
        .enumerate()
        .map(|(a, p)| Axis::at_rest(p, start[a], rec.tight_spot_x.filter(|_| a == 0)))
        .collect();
    let mut rng = rand::rngs::StdRng::seed_from_u64(rec.seed);
    let noise = Normal::new(0.0, rec.noise_m.max(1e-15)).unwrap();
    let steps_per_sample = (rec.sample_s / rec.step_s).round() as usize;
    let h = rec.sample_s / steps_per_sample as f64;
    let samples = (interpolator.duration_s / rec.sample_s).floor() as usize;
    let mut csv = String::from(if axes.len() == 3 {
        "t,x,y,z,x_cmd,y_cmd,z_cmd\n"
    } else {
        "t,x,y,x_cmd,y_cmd\n"
    });
    let read = |v: f64, rng: &mut rand::rngs::StdRng| {
        let m = v + noise.sample(rng);
        if rec.count_m > 0.0 {
            (m / rec.count_m).round() * rec.count_m
        } else {
            m
        }
    };
    let (keep_from, keep_to) = rec.keep_s.unwrap_or((0.0, f64::INFINITY));
    for k in 0..samples {
        let t = k as f64 * rec.sample_s;
        let cmd = interpolator.position(t);
        let kept = t >= keep_from - 1e-9 && t < keep_to - 1e-9;
        let at = |axis: &Axis| {
            if rec.at_feedback {
                axis.feedback()
            } else {
                axis.table()
            }
        };
        let measured: Vec<f64> = axes.iter().map(|a| read(at(a), &mut rng)).collect();
        if kept {
            let mut row = format!("{:.6}", t - keep_from);
            for v in measured.iter().chain(&cmd[..axes.len()]) {
                row.push_str(&format!(",{:.7}", v * 1e3));
            }
            csv.push_str(&row);
            csv.push('\n');
        } else if t >= keep_to {
            break;
        }
        for s in 0..steps_per_sample {
            let ts = t + s as f64 * h;
            for (a, axis) in axes.iter_mut().enumerate() {
                if axis.feeds_forward() {
                    axis.step(ts, h, &|tt| interpolator.axis(a, tt));
                } else {
                    axis.step(ts, h, &|tt| (interpolator.position(tt)[a], 0.0, 0.0));
                }
            }
        }
    }
    csv
}
