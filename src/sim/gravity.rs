//! A vertical axis's weight (docs/model.md §1.8), and the force an axis holds at rest at the
//! start of a run (§1.10): the load enters the table's equation and the break-away guard
//! through [`AxisModel::external_force`]; here is the state in which the loops already hold
//! it, where a standing axis starts.
//!
//! At rest every rate is zero, the table stuck: the nut (or a linear motor) carries the load
//! and the force held, friction the force held; the motor's torque balances the nut through
//! the coupling, the current loop's integral holds the voltage that drives that current and
//! the velocity loop's (or a controller's) integral the current command. Those conditions
//! are linear in the states, so the state is one linear solve: each used state's rate set to
//! zero, plus the nut force equal to the load and the force held. A structure without an
//! integral (a PD controller) holds them only with a position error; the solve gives that
//! sag.

use nalgebra::{DMatrix, DVector};

use super::model::{
    Aug, AxisModel, ClampMode, ContactMode, FrictionMode, Mode, NA, TH_M, TH_S, V2, W_M, W_S, X2,
};

/// Turns `x`, a state of the axis at rest with nothing loaded (everything aligned, no
/// current), into the one where its loops hold its load and push with `held_n` (N, + towards
/// +) against stuck friction, and `mode` into that state's mode (stuck, the nut on the flank
/// that carries the two). Leaves both as they are when the axis carries neither, or when no
/// state holds them (a loop that cannot: the run then shows the axis sagging from its start).
pub(crate) fn hold_load(model: &AxisModel, x: &mut Aug, mode: &mut Mode, held_n: f64) {
    let nut_n = model.load_n + held_n;
    if model.load_n == 0.0 && held_n == 0.0 {
        return;
    }
    let held_mode = Mode {
        friction: FrictionMode::Stick,
        contact: if nut_n > 0.0 || !model.has_backlash() {
            ContactMode::Pos
        } else {
            ContactMode::Neg
        },
        current: ClampMode::Linear,
        voltage: ClampMode::Linear,
    };
    if let Some(held) = solve_held(model, x, held_mode, nut_n) {
        *x = held;
        *mode = held_mode;
    }
}

/// The held state: the used states but the table's speed are the unknowns; the equations
/// are their rates (but the table's position's, which a stuck table does not have) set to
/// zero and the force on the nut equal to `nut_n` (N).
fn solve_held(model: &AxisModel, rest: &Aug, mode: Mode, nut_n: f64) -> Option<Aug> {
    let a = model.dynamics(mode);
    let signals = model.signals();
    let nut = model.nut_force(&signals, mode.contact);
    let unknowns: Vec<usize> = model
        .active_states()
        .into_iter()
        .filter(|&i| i != V2)
        .collect();
    let rates: Vec<usize> = unknowns.iter().copied().filter(|&i| i != X2).collect();
    let n = unknowns.len();
    let mut m = DMatrix::<f64>::zeros(n, n);
    let mut rhs = DVector::<f64>::zeros(n);
    // Everything not solved for stays as in `rest`: inputs, references, unused states.
    let known = |row: &dyn Fn(usize) -> f64| -> f64 {
        (0..NA)
            .filter(|j| !unknowns.contains(j))
            .map(|j| row(j) * rest[j])
            .sum()
    };
    for (e, &state) in rates.iter().enumerate() {
        for (u, &j) in unknowns.iter().enumerate() {
            m[(e, u)] = a[(state, j)];
        }
        rhs[e] = -known(&|j| a[(state, j)]);
    }
    let last = n - 1;
    for (u, &j) in unknowns.iter().enumerate() {
        m[(last, u)] = nut[j];
    }
    rhs[last] = nut_n - known(&|j| nut[j]);
    let solution = m.clone().lu().solve(&rhs)?;
    let residual = (&m * &solution - &rhs).amax();
    if !solution.iter().all(|v| v.is_finite()) || residual > 1e-6 * (1.0 + rhs.amax()) {
        return None;
    }
    let mut held = *rest;
    for (u, &j) in unknowns.iter().enumerate() {
        held[j] = solution[u];
    }
    // Rates are zero at rest; the solve gives them to rounding.
    for j in [W_M, W_S, V2] {
        held[j] = 0.0;
    }
    debug_assert!(held[TH_M].is_finite() && held[TH_S].is_finite());
    Some(held)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::machine::{AxisName, MachineConfig};
    use crate::sim::model::{FX, I, ONE, XR, ZW};

    /// X of the preset stood on end: a 6000 kg table hanging on its screw.
    fn hanging() -> AxisModel {
        let mut m = AxisModel::from_config(&MachineConfig::default_preset().x);
        m.load_n = m.mt * crate::numeric::units::GRAVITY_M_PER_S2;
        m
    }

    fn at_rest(model: &AxisModel, x0: f64) -> (Aug, Mode) {
        let mut x = Aug::zeros();
        x[X2] = x0;
        x[TH_S] = x0 / model.r;
        x[TH_M] = x[TH_S] / model.it;
        x[XR] = x0;
        x[ONE] = 1.0;
        let mode = Mode {
            friction: FrictionMode::Stick,
            contact: ContactMode::Pos,
            current: ClampMode::Linear,
            voltage: ClampMode::Linear,
        };
        (x, mode)
    }

    #[test]
    fn the_held_state_is_at_rest_with_the_weight_on_the_motor() {
        let m = hanging();
        let (mut x, mut mode) = at_rest(&m, 0.25);
        hold_load(&m, &mut x, &mut mode, 0.0);
        // Every rate zero, and nothing left for friction to hold: the nut carries the load.
        // (A 98 rad screw angle times K_θ = 4e7 N·m/rad rounds to ~1e-5 N·m: the
        // accelerations are zero to that.)
        let dx = m.dynamics(mode) * x;
        for i in 0..crate::sim::model::N {
            assert!(dx[i].abs() < 1e-3, "state {i}: rate {}", dx[i]);
        }
        let f_e = (m.breakaway_force(&m.signals(), mode.contact) * x)[0];
        assert!(f_e.abs() < 1e-6 * m.load_n, "F_e = {f_e} N");
        // The torque at the motor lifts the table: K_t·I = F_g·r·i_t.
        let expected_a = m.load_n * m.r * m.it / m.kt;
        assert!((x[I] - expected_a).abs() < 1e-9 * expected_a, "{} A", x[I]);
        // The scale reads the command: no sag, the velocity integral holds the current.
        assert!((x[X2] - 0.25).abs() < 1e-12);
        assert!((m.ks * x[ZW] / m.ts - expected_a).abs() < 1e-6 * expected_a);
        assert_eq!(x[FX], 0.0);
    }

    /// hvmc's X (a modelled current loop), with presliding bristles of 50 N/µm where asked,
    /// holding `share` of its friction's level at rest at its start.
    fn holding(share: f64, bristles: bool) -> AxisModel {
        let mut c = MachineConfig::preset("hvmc").unwrap().x;
        if bristles {
            let f = &mut c.friction;
            f.bristle_stiffness_n_per_um = 50.0;
            f.bristle_damping_n_s_per_m = 2e4;
        }
        let mut m = AxisModel::from_config(&c);
        m.held_at_start_n = share * m.f_s;
        m
    }

    /// `model` standing at 0.1 m for `seconds` with its command there: the table's
    /// positions (m) and the motor's currents (A) every cycle.
    fn standing(model: &AxisModel, seconds: f64) -> (Vec<f64>, Vec<f64>) {
        let dt = 1e-3;
        let commands = crate::sim::AxisCommands::ramp(0.1, 0.0, dt, (seconds / dt) as usize);
        let t = crate::sim::simulate(model, &commands, dt, &crate::sim::SimConfig::default())
            .expect("a stable axis");
        (t.pos_m, t.current_a)
    }

    #[test]
    fn an_axis_holding_a_force_at_its_start_stands_with_friction_carrying_it() {
        let m = holding(-0.6, false);
        let held = -0.6 * m.f_s;
        assert!(held < -1.0, "a force to hold: {held} N");
        let (x, mode) = crate::sim::simulate::rest_state(&m, 0.1);
        // At rest: the drive's rates are zero, and the push on the stuck table is the force
        // held — friction carries it.
        let dx = m.dynamics(mode) * x;
        for i in 0..crate::sim::model::N {
            assert!(dx[i].abs() < 1e-3, "state {i}: rate {}", dx[i]);
        }
        let f_e = (m.breakaway_force(&m.signals(), mode.contact) * x)[0];
        assert!((f_e - held).abs() < 1e-6 * held.abs(), "F_e = {f_e} N");
        // Torque balance at the motor: K_t·I = F·r·i_t (to the solve's rounding: a screw
        // angle of 10³ rad times stiffnesses of 10⁷ N·m/rad).
        let expected_a = held * m.r * m.it / m.kt;
        assert!(
            (x[I] - expected_a).abs() < 1e-5 * expected_a.abs(),
            "{} A",
            x[I]
        );
        // Left standing, nothing moves and the current stays: the loops were at rest.
        let (pos, current) = standing(&m, 0.3);
        let moved = pos.iter().map(|p| (p - 0.1).abs()).fold(0.0, f64::max);
        assert!(moved < 1e-9, "the table moved {moved:e} m");
        let drift = current
            .iter()
            .map(|c| (c - expected_a).abs())
            .fold(0.0, f64::max);
        assert!(
            drift < 1e-3 * expected_a.abs(),
            "the current drifted {drift} A"
        );
    }

    #[test]
    fn a_force_held_beyond_the_friction_at_rest_is_held_at_that_level() {
        let m = holding(3.0, false);
        let (x, _) = crate::sim::simulate::rest_state(&m, 0.1);
        let expected_a = m.f_s * m.r * m.it / m.kt;
        assert!(
            (x[I] - expected_a).abs() < 1e-5 * expected_a,
            "{} A, {expected_a} A",
            x[I]
        );
    }

    #[test]
    fn bristles_holding_a_force_at_the_start_are_bent_by_it_and_the_table_stands() {
        let m = holding(0.8, true);
        let sigma0 = m.presliding.expect("bristles").sigma0_n_per_m;
        // Unbent bristles would let the push move the table by held/σ0 before they carry it.
        let yield_m = 0.8 * m.f_s / sigma0;
        assert!(yield_m > 0.1e-6, "a yield to see: {yield_m:e} m");
        let (pos, current) = standing(&m, 0.3);
        let moved = pos.iter().map(|p| (p - 0.1).abs()).fold(0.0, f64::max);
        assert!(
            moved < 0.02 * yield_m,
            "moved {moved:e} m of a yield of {yield_m:e} m"
        );
        let expected_a = 0.8 * m.f_s * m.r * m.it / m.kt;
        let last = current[current.len() - 1];
        assert!(
            (last - expected_a).abs() < 0.01 * expected_a,
            "{last} A, {expected_a} A"
        );
        // The bristles hold it, in their sliding mode: no stuck mode to carry it.
        let (_, mode) = crate::sim::simulate::rest_state(&m, 0.1);
        assert_eq!(mode.friction, FrictionMode::SlipPos);
    }

    /// The preset's ram released with its loops not yet holding it (integrators empty, no
    /// current): the table's deviation over `seconds`, simulated by the hybrid model.
    fn released_ram(seconds: f64) -> Vec<f64> {
        let m = AxisModel::from_config(MachineConfig::default_preset().axis(AxisName::Z));
        let (mut x, mut mode) = at_rest(&m, 0.0);
        let h = 0.5e-3;
        let mut sim = crate::sim::hybrid::AxisSim::new(&m, h);
        (0..(seconds / h) as usize)
            .map(|k| {
                sim.step(&mut x, &mut mode, k as f64 * h, None)
                    .expect("a stable loop");
                x[X2]
            })
            .collect()
    }

    /// The same release by a separate calculation: the linear two-mass model of the drive
    /// (the rotor's inertia at the table against the ram, joined by the nut's spring), the
    /// cascade's P and PI loops around it, the current loop as a first-order lag of its
    /// closed-loop bandwidth, and the ram sliding down against its Coulomb friction — the
    /// linear model of the fall, integrated by fourth-order Runge–Kutta at 1 µs. Returns
    /// the table's deviation every 0.5 ms.
    fn released_ram_linear(seconds: f64) -> Vec<f64> {
        let c = MachineConfig::default_preset();
        let z = c.axis(AxisName::Z);
        let g = crate::numeric::units::GRAVITY_M_PER_S2;
        let (lead, it) = (z.drive.lead_mm * 1e-3, z.drive.gear_ratio);
        let rit = lead / std::f64::consts::TAU * it;
        let kt = z.motor.kt_nm_per_a;
        let rotor = (z.motor.jm_kg_m2 + it * it * z.drive.js_kg_m2) / (rit * rit);
        let ram = z.drive.table_mass_kg;
        let k_m = z.drive.k_m_n_per_m;
        let reduced = rotor * ram / (rotor + ram);
        let c_m = 2.0 * z.drive.zeta_m * (k_m * reduced).sqrt();
        let kv = z.position_loop.kv_m_per_min_per_mm * 1000.0 / 60.0;
        let v = z.velocity_loop.as_ref().expect("a cascade");
        let (ks, ts) = (v.ks_nm_s_per_rad / kt, v.ts_ms * 1e-3);
        let tau_i = 1.0 / (std::f64::consts::TAU * 931.0);
        let f_c = z.friction.coulomb_coefficient * ram * g;
        // Falling, the friction holds up against the weight.
        let load = ram * g - f_c;
        let f_v = z.friction.viscous_n_s_per_m;
        // State: rotor and ram positions and speeds (as table travel), velocity integral
        // (rad), current (A).
        let rate = |s: [f64; 6]| {
            let [xm, vm, xt, vt, zi, i] = s;
            let e_w = kv / rit * (0.0 - xt) - vm / rit;
            let i_cmd = ks * (e_w + zi / ts);
            let spring = k_m * (xm - xt) + c_m * (vm - vt);
            [
                vm,
                (kt * i / rit - spring) / rotor,
                vt,
                (spring - load - f_v * vt) / ram,
                e_w,
                (i_cmd - i) / tau_i,
            ]
        };
        let h = 1e-6;
        let mut s = [0.0; 6];
        let mut out = Vec::new();
        for k in 0..(seconds / h) as usize {
            let add =
                |a: [f64; 6], b: [f64; 6], f: f64| [0, 1, 2, 3, 4, 5].map(|j| a[j] + f * b[j]);
            let k1 = rate(s);
            let k2 = rate(add(s, k1, h / 2.0));
            let k3 = rate(add(s, k2, h / 2.0));
            let k4 = rate(add(s, k3, h));
            s = [0, 1, 2, 3, 4, 5]
                .map(|j| s[j] + h / 6.0 * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j]));
            if (k + 1) % 500 == 0 {
                out.push(s[2]);
            }
        }
        out
    }

    #[test]
    fn a_released_ram_sags_as_the_linear_model_says_and_its_integral_takes_the_sag_out() {
        let simulated = released_ram(2.0);
        let linear = released_ram_linear(0.3);
        let lowest = |v: &[f64]| v.iter().copied().fold(f64::INFINITY, f64::min);
        let (sag, expected) = (lowest(&simulated[..600]), lowest(&linear));
        eprintln!(
            "SAG {sag:e} {expected:e} last {:e}",
            simulated[simulated.len() - 1]
        );
        assert!(expected < -10e-6, "the model sags {expected:e} m");
        assert!(
            (sag - expected).abs() < 0.03 * expected.abs(),
            "sag {:.3} µm, the linear model {:.3} µm",
            sag * 1e6,
            expected * 1e6
        );
        // The velocity loop's integral holds the weight: no lasting sag. (Friction leaves the
        // ram wherever the loop's last push moved it within its static band.)
        let last = simulated[simulated.len() - 1];
        assert!(
            last.abs() < 0.01 * expected.abs(),
            "after 2 s: {:.4} µm",
            last * 1e6
        );
    }
}
