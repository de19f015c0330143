//! The circular test's start window worked out independently of the code under test: from a
//! run's commands alone, a first-order loop of each axis, integrated by fourth-order
//! Runge-Kutta with the command linear between samples.

use nalgebra::Complex;

/// A ballbar's finest step: the entry transient is left out until this much of it remains
/// in the radius (m).
pub const ENTRY_RESIDUE_M: f64 = 0.1e-6;
/// The fewest time constants a start is left out for.
pub const ENTRY_TIME_CONSTANTS: f64 = 5.0;

/// How close a step's speed must come to the circle's running speed for the command to run
/// at it (a share of that speed).
const RUNNING_SHARE: f64 = 1e-3;

/// A circle's start window as the replica works it out; paths are commanded path from the
/// first command on the circle (m).
#[derive(Debug, Clone, Copy)]
pub struct EntryWindow {
    /// The speed the command runs round the circle at (m/s): its step's speed half a turn
    /// past the set-off.
    pub speed_m_per_s: f64,
    /// Where it reaches that speed to stay, and the entry transient is read.
    pub read_m: f64,
    /// The time constants of the slower loop counted from there.
    pub time_constants: f64,
    /// Where the start's window ends: `read_m` and that many time constants at the speed.
    pub start_m: f64,
}

/// The commands `rows` (time s, X and Y m) followed by a loop of time constant
/// `tau_axes_s[a]` on each axis, at rest on the first row: the model's lag behind the
/// command at each row (m).
fn model_lags(rows: &[(f64, [f64; 2])], tau_axes_s: [f64; 2]) -> Vec<[f64; 2]> {
    let Some(&(_, mut model)) = rows.first() else {
        return Vec::new();
    };
    let mut lags = vec![[0.0; 2]];
    for pair in rows.windows(2) {
        let ((t0, c0), (t1, c1)) = (pair[0], pair[1]);
        let h = t1 - t0;
        for a in 0..2 {
            let cmd = |t: f64| c0[a] + (c1[a] - c0[a]) * (t - t0) / h;
            let f = |t: f64, p: f64| (cmd(t) - p) / tau_axes_s[a];
            let p = model[a];
            let k1 = f(t0, p);
            let k2 = f(t0 + 0.5 * h, p + 0.5 * h * k1);
            let k3 = f(t0 + 0.5 * h, p + 0.5 * h * k2);
            let k4 = f(t1, p + h * k3);
            model[a] = p + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
        }
        lags.push([c1[0] - model[0], c1[1] - model[1]]);
    }
    lags
}

/// The rows on a circle, from the first row `on_circle` accepts until it accepts one no
/// more: each row's index and the commanded path run from that first row (m).
fn along(
    rows: &[(f64, [f64; 2])],
    on_circle: impl Fn(usize, [f64; 2]) -> bool,
) -> Vec<(usize, f64)> {
    let mut out: Vec<(usize, f64)> = Vec::new();
    for (k, &(_, c)) in rows.iter().enumerate() {
        if !on_circle(k, c) {
            if out.is_empty() {
                continue;
            }
            break;
        }
        let run_m = out.last().map_or(0.0, |&(j, run_m)| {
            let p = rows[j].1;
            run_m + (c[0] - p[0]).hypot(c[1] - p[1])
        });
        out.push((k, run_m));
    }
    out
}

/// The entry transient at row `k` (radial, along the path; m): the model's lag `lag` less
/// the steady lag z·jωτ/(1 + jωτ) of the command z = R·e^{jθ} about the origin turning at
/// ω (counter-clockwise positive; X its real part, Y its imaginary part).
fn transient_m(
    command: [f64; 2],
    lag: [f64; 2],
    radius_m: f64,
    omega_rad_per_s: f64,
    tau_axes_s: [f64; 2],
) -> [f64; 2] {
    let theta_rad = command[1].atan2(command[0]);
    let steady = |tau_s: f64| {
        let jwt = Complex::new(0.0, omega_rad_per_s * tau_s);
        Complex::from_polar(radius_m, theta_rad) * jwt / (1.0 + jwt)
    };
    let delta = [
        lag[0] - steady(tau_axes_s[0]).re,
        lag[1] - steady(tau_axes_s[1]).im,
    ];
    [
        delta[0] * theta_rad.cos() + delta[1] * theta_rad.sin(),
        -delta[0] * theta_rad.sin() + delta[1] * theta_rad.cos(),
    ]
}

/// The start window of a circle of `radius_m` about the origin (counter-clockwise where
/// `ccw`): the rows `on_circle` accepts are its commands. The command sets off where it has
/// moved a micrometre from its first row on the circle; the speed it runs at is its step's
/// half a turn later, and it runs at it from the first row after which every step's speed
/// to there is within [`RUNNING_SHARE`] of it. There the model's lag less the steady lag at
/// that speed is e, split along the radius (r) and the path (d), and n solved by
/// n ← ln((|r| + n·|ω|τ·|d| + p(n)) / residue) from above, τ the slower loop's. p is what the
/// loops of their own paces bring into the radius with the circle standing still: the parts
/// of e decaying as e^(−t/τx) and e^(−t/τy) turn it by their difference, at most
/// |e|/2 · min(1, n·(τslow/τfast − 1)). Five at the least. `None` where the command does not
/// run half a turn.
pub fn entry_window(
    rows: &[(f64, [f64; 2])],
    on_circle: impl Fn(usize, [f64; 2]) -> bool,
    radius_m: f64,
    ccw: bool,
    tau_axes_s: [f64; 2],
) -> Option<EntryWindow> {
    let on = along(rows, on_circle);
    let set_off = on.iter().position(|&(_, run_m)| run_m > 1e-6)?;
    let half = on
        .iter()
        .position(|&(_, run_m)| run_m >= on[set_off].1 + std::f64::consts::PI * radius_m)?;
    let step_speed = |i: usize| {
        let ((k0, run0), (k1, run1)) = (on[i - 1], on[i]);
        (run1 - run0) / (rows[k1].0 - rows[k0].0)
    };
    let speed_m_per_s = step_speed(half);
    let off_speed = (set_off..half)
        .rev()
        .find(|&i| (step_speed(i) - speed_m_per_s).abs() > RUNNING_SHARE * speed_m_per_s);
    let read = off_speed.map_or(set_off, |i| i);
    let (k, read_m) = on[read];
    let lags = model_lags(rows, tau_axes_s);
    let omega_rad_per_s = speed_m_per_s / radius_m * if ccw { 1.0 } else { -1.0 };
    let e = transient_m(rows[k].1, lags[k], radius_m, omega_rad_per_s, tau_axes_s);
    let [tx, ty] = tau_axes_s;
    let tau_s = tx.max(ty);
    let paces_apart = tau_s / tx.min(ty) - 1.0;
    let parted = |n: f64| 0.5 * e[0].hypot(e[1]) * (n * paces_apart).min(1.0);
    let turned = (omega_rad_per_s * tau_s).abs() * e[1].abs();
    let mut n: f64 = 50.0;
    for _ in 0..200 {
        n = ((e[0].abs() + n * turned + parted(n)) / ENTRY_RESIDUE_M).ln();
    }
    let time_constants = n.max(ENTRY_TIME_CONSTANTS);
    Some(EntryWindow {
        speed_m_per_s,
        read_m,
        time_constants,
        start_m: read_m + time_constants * tau_s * speed_m_per_s,
    })
}

/// What remains of the entry transient in the radius (m, the model's own, not a bound) where
/// the command has run `at_m` along the circle (from its first row on it), the circle
/// turning at `speed_m_per_s`: the model's lag there less the steady lag at that speed, its
/// radial part.
pub fn residue_at_m(
    rows: &[(f64, [f64; 2])],
    on_circle: impl Fn(usize, [f64; 2]) -> bool,
    (radius_m, ccw, speed_m_per_s): (f64, bool, f64),
    tau_axes_s: [f64; 2],
    at_m: f64,
) -> f64 {
    let on = along(rows, on_circle);
    let Some(&(k, _)) = on.iter().find(|&&(_, run_m)| run_m >= at_m) else {
        return f64::NAN;
    };
    let lags = model_lags(rows, tau_axes_s);
    let omega_rad_per_s = speed_m_per_s / radius_m * if ccw { 1.0 } else { -1.0 };
    transient_m(rows[k].1, lags[k], radius_m, omega_rad_per_s, tau_axes_s)[0].abs()
}
