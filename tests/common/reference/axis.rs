//! One axis's state — motor, coupling, screw, nut, table, the loops' and the controller's
//! states, the friction's bristles — integrated by Runge–Kutta at a fixed step, friction
//! switched by a sticking test at each step.

use super::controllers::{CurrentLaw, Law};
use super::plant::Plant;

/// Indices of the state.
pub(super) const TH_M: usize = 0;
pub(super) const W_M: usize = 1;
pub(super) const TH_S: usize = 2;
pub(super) const W_S: usize = 3;
pub(super) const X2: usize = 4;
pub(super) const V2: usize = 5;
pub(super) const I: usize = 6;
pub(super) const Z_V: usize = 7;
pub(super) const Z_I: usize = 8;
pub(super) const F_CMD: usize = 9;
pub(super) const F_I: usize = 10;
/// A transfer function's states (up to four), and state feedback's error integral.
pub(super) const C0: usize = 11;
pub(super) const Z_E: usize = 15;
/// The LuGre bristles' mean deflection (m).
pub(super) const Z_B: usize = 16;
pub(super) const STATES: usize = 17;

pub(super) type State = [f64; STATES];

/// The reference: position, speed and acceleration at a time.
pub type Reference<'a> = &'a dyn Fn(f64) -> (f64, f64, f64);

/// One axis integrated at `h` seconds a step from rest at the reference's start.
pub struct Axis<'p> {
    pub(super) plant: &'p Plant,
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

    pub(super) fn read_at(&self, x: &State) -> f64 {
        let p = self.plant;
        let at = if p.motor_encoder {
            x[TH_M] * p.r * p.it
        } else {
            x[X2]
        };
        at + p.encoder_error.at(at)
    }

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
            // g(v) = f_c + (f_s − f_c)·exp(−(v/v_s)²), f_s that of the direction moved.
            let v = x[V2];
            let f_s = if v < 0.0 { p.f_s_negative } else { p.f_s };
            let at_rest = if fade > 0.0 {
                (-(v / fade).powi(2)).exp()
            } else {
                0.0
            };
            let g = f_c + (f_s - p.f_c) * at_rest;
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
