//! The laws the motor's current is commanded by — the paper's cascade, or a transfer
//! function or state feedback on a current amplifier — and their outputs at a state.

use contourcheck::machine::{Controller, ControllerOutput};

use super::axis::{Axis, C0, F_CMD, F_I, STATES, State, W_M, X2, Z_E, Z_I, Z_V};

/// How the motor's current is commanded.
#[derive(Clone, Copy, Debug)]
pub(super) enum Law {
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
pub(super) enum CurrentLaw {
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
    pub(super) fn of(controller: &Controller) -> CurrentLaw {
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

impl Axis<'_> {
    /// A controller on a current amplifier: the current command (limited), whether it is at
    /// the limit, and the rates of the controller's states.
    pub(super) fn amplified_control(
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
    pub(super) fn controls(
        &self,
        x: &State,
        (xr, vr, ar): (f64, f64, f64),
    ) -> (f64, bool, f64, bool) {
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
}
