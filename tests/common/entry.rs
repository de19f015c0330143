//! The circular test's start window worked out independently of the code under test: from a
//! run's commands alone, a first-order loop of each axis, integrated by fourth-order
//! Runge-Kutta with the command linear between samples.

use nalgebra::Complex;

/// A ballbar's finest step: the entry transient is left out until this much of it remains
/// in the radius (m).
pub const ENTRY_RESIDUE_M: f64 = 0.1e-6;
/// The fewest time constants a start is left out for.
pub const ENTRY_TIME_CONSTANTS: f64 = 5.0;

/// The time constants the start of a circle of `radius_m` about the origin is left out for.
/// `rows` are the commands (time s, X and Y m); a loop of time constant `tau_axes_s[a]` on
/// each axis, at rest on the first, follows them up to the first row `sets_off(k, command)`
/// accepts, where it lags them by e. Less the steady lag z·jωτ/(1 + jωτ) of the command
/// z = R·e^{jθ} turning at `omega_rad_per_s` (counter-clockwise positive; X its real part,
/// Y its imaginary part), e is split along the radius (r) and the path (d), and n solved by
/// n ← ln((|r| + n·|ω|τ·|d| + p(n)) / residue) from above, τ the slower loop's. p is what the
/// loops of their own paces bring into the radius with the circle standing still: the parts
/// of e decaying as e^(−t/τx) and e^(−t/τy) turn it by their difference, at most
/// |e|/2 · min(1, n·(τslow/τfast − 1)). Five at the least; five where nothing sets off.
pub fn entry_time_constants(
    rows: &[(f64, [f64; 2])],
    mut sets_off: impl FnMut(usize, [f64; 2]) -> bool,
    radius_m: f64,
    omega_rad_per_s: f64,
    tau_axes_s: [f64; 2],
) -> f64 {
    let Some(&(_, first)) = rows.first() else {
        return ENTRY_TIME_CONSTANTS;
    };
    let mut model = first;
    let mut set_off = None;
    for (k, pair) in rows.windows(2).enumerate() {
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
        if sets_off(k + 1, c1) {
            set_off = Some((c1, [c1[0] - model[0], c1[1] - model[1]]));
            break;
        }
    }
    let Some((command, lag)) = set_off else {
        return ENTRY_TIME_CONSTANTS;
    };
    let theta_rad = command[1].atan2(command[0]);
    let steady = |tau_s: f64| {
        let jwt = Complex::new(0.0, omega_rad_per_s * tau_s);
        Complex::from_polar(radius_m, theta_rad) * jwt / (1.0 + jwt)
    };
    let delta = [
        lag[0] - steady(tau_axes_s[0]).re,
        lag[1] - steady(tau_axes_s[1]).im,
    ];
    let radial = (delta[0] * theta_rad.cos() + delta[1] * theta_rad.sin()).abs();
    let along = (-delta[0] * theta_rad.sin() + delta[1] * theta_rad.cos()).abs();
    let [tx, ty] = tau_axes_s;
    let tau_s = tx.max(ty);
    let paces_apart = tau_s / tx.min(ty) - 1.0;
    let parted = |n: f64| 0.5 * delta[0].hypot(delta[1]) * (n * paces_apart).min(1.0);
    let turned = (omega_rad_per_s * tau_s).abs() * along;
    let mut n: f64 = 50.0;
    for _ in 0..200 {
        n = ((radial + n * turned + parted(n)) / ENTRY_RESIDUE_M).ln();
    }
    n.max(ENTRY_TIME_CONSTANTS)
}
