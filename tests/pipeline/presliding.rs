//! Presliding (LuGre) friction against physics and against the independent integrator of
//! `common::reference`, which carries its own bristle state integrated by Runge–Kutta.
//!
//! The table of the `small-table` preset, read at a linear scale so that the loop holds the
//! table itself where it is commanded: 30 kg, Coulomb friction f_c = 0.1·30 kg·g = 29.4 N,
//! bristles of σ0 = 15 N/µm (a presliding range g/σ0 of about 2 µm).

use crate::common;

use common::reference::{Axis, Plant};
use contourcheck::machine::MachineConfig;
use contourcheck::sim::{AxisCommands, AxisModel, SimConfig, simulate};

const SIGMA0_N_PER_M: f64 = 15e6;
const CYCLE_S: f64 = 1e-3;

/// The small table with bristles, friction at rest `static_to_coulomb` of Coulomb's
/// passing into it over `fade_mm_per_min`.
fn machine(static_to_coulomb: f64, fade_mm_per_min: f64) -> MachineConfig {
    let text = format!(
        "base = \"small-table\"\n[x.position_loop]\nfeedback = \"linear_scale\"\n\
         [x.friction]\nstatic_to_coulomb = {static_to_coulomb}\n\
         stribeck_velocity_mm_per_min = {fade_mm_per_min}\n\
         bristle_stiffness_n_per_um = {}\nbristle_damping_n_s_per_m = 5000.0\n",
        SIGMA0_N_PER_M * 1e-6
    );
    MachineConfig::from_toml_str(&text, "bristles.toml").unwrap()
}

/// A reference through the knots (s, m), straight between them, held after the last.
fn path(knots: &[(f64, f64)]) -> impl Fn(f64) -> (f64, f64, f64) + '_ {
    move |t| {
        let last = knots[knots.len() - 1];
        if t >= last.0 {
            return (last.1, 0.0, 0.0);
        }
        let k = knots.iter().rposition(|&(tk, _)| tk <= t).unwrap_or(0);
        let ((t0, p0), (t1, p1)) = (knots[k], knots[k + 1]);
        let v = (p1 - p0) / (t1 - t0);
        (p0 + v * (t - t0).max(0.0), v, 0.0)
    }
}

/// The reference sampled every cycle for `duration_s`, as the control sends it.
fn commands(reference: &dyn Fn(f64) -> (f64, f64, f64), duration_s: f64) -> AxisCommands {
    let n = (duration_s / CYCLE_S).round() as usize;
    let samples: Vec<_> = (0..n).map(|k| reference(k as f64 * CYCLE_S)).collect();
    AxisCommands {
        pos_m: samples.iter().map(|s| s.0).collect(),
        vel_m_per_s: samples.iter().map(|s| s.1).collect(),
        acc_m_per_s2: samples.iter().map(|s| s.2).collect(),
    }
}

/// Mean of `values` over the samples from `from_s` to `to_s`.
fn mean(values: &[f64], from_s: f64, to_s: f64) -> f64 {
    let (a, b) = ((from_s / CYCLE_S) as usize, (to_s / CYCLE_S) as usize);
    values[a..b].iter().sum::<f64>() / (b - a) as f64
}

/// Out by 1.2 presliding ranges and back, slowly, holding in between: a table whose loop
/// holds it still carries exactly the bristles' force, which the drive's current shows
/// (F = K_t·i / r on a direct drive). From rest the bristles load along
/// F = g·(1 − exp(−σ0·x/g)); coming back they unload along their own curve, so that at the
/// start position they pull back with −g + (F_out + g)·exp(−σ0·Δx/g): the same place, a
/// different force — the presliding hysteresis.
#[test]
fn bristles_load_and_unload_along_the_lugre_curves() {
    let config = machine(1.0, 0.0);
    let model = AxisModel::from_config(&config.x);
    let g = model.f_c;
    let out = 1.2 * g / SIGMA0_N_PER_M;
    let knots = [(0.1, 0.0), (0.3, out), (1.3, out), (1.5, 0.0), (2.5, 0.0)];
    let trace = simulate(
        &model,
        &commands(&path(&knots), 2.5),
        CYCLE_S,
        &SimConfig::default(),
    )
    .unwrap();
    let force = |i: f64| model.kt * i / (model.r * model.it);
    let current = &trace.current_a;
    let (x0, x_out, x_back) = (
        mean(&trace.pos_m, 0.0, 0.1),
        mean(&trace.pos_m, 1.2, 1.3),
        mean(&trace.pos_m, 2.4, 2.5),
    );
    let f_out = force(mean(current, 1.2, 1.3));
    let f_back = force(mean(current, 2.4, 2.5));
    let loaded = g * (1.0 - (-SIGMA0_N_PER_M * (x_out - x0) / g).exp());
    let unloaded = -g + (loaded + g) * (-SIGMA0_N_PER_M * (x_out - x_back) / g).exp();
    // Held still, nothing but the bristles pushes: what remains is the loop's settling, a
    // few hundredths of a newton after 0.9 s (the integrator's zero is at 62.5 rad/s).
    let tolerance = 0.002 * g;
    assert!((x_out - x0 - out).abs() < 0.01 * out, "{x0} {x_out}");
    assert!(
        (f_out - loaded).abs() < tolerance,
        "{f_out} N vs {loaded} N"
    );
    assert!(
        (f_back - unloaded).abs() < tolerance,
        "{f_back} N vs {unloaded} N"
    );
    // At its start again, the table is held against −0.49 g: no stick-slip model has that.
    assert!(unloaded < -0.4 * g, "{unloaded}");
}

/// With friction near rest at 0.6 of Coulomb's, fading into it over 6 mm/min, bristles
/// pulled out at a creep (a twentieth of the fade speed) carry that lower level while they
/// creep: g(v) = f_c·(1 − 0.4·exp(−(v/v_s)²)), loaded along g·(1 − exp(−σ0·x/g)) (plus the
/// viscous f_v·v, a millinewton here) — not Coulomb's. (Read while creeping: at the stop a
/// few nanometres of the loop's settling back would unload the bristles along their steep
/// curve, σ0 = 15 N/µm.)
#[test]
fn a_level_near_rest_below_coulomb_is_what_creeping_bristles_carry() {
    let config = machine(0.6, 6.0);
    let model = AxisModel::from_config(&config.x);
    let f_c = model.f_c;
    let fade_m_per_s = 6.0 / 60_000.0;
    let out = 6.0 * 0.6 * f_c / SIGMA0_N_PER_M;
    let creep = 0.05 * fade_m_per_s;
    let t_out = 0.1 + out / creep;
    let knots = [(0.1, 0.0), (t_out, out), (t_out + 1.0, out)];
    let duration = t_out + 1.0;
    let trace = simulate(
        &model,
        &commands(&path(&knots), duration),
        CYCLE_S,
        &SimConfig::default(),
    )
    .unwrap();
    let force = |i: f64| model.kt * i / (model.r * model.it);
    let (from, to) = (t_out - 0.3, t_out - 0.1);
    let held = force(mean(&trace.current_a, from, to));
    let g = f_c * (1.0 - 0.4 * (-(0.05f64).powi(2)).exp());
    let travelled = mean(&trace.pos_m, from, to) - mean(&trace.pos_m, 0.0, 0.1);
    let loaded = g * (1.0 - (-SIGMA0_N_PER_M * travelled / g).exp()) + model.f_v * creep;
    assert!(
        (held - loaded).abs() < 0.01 * f_c,
        "{held} N held against {loaded} N (Coulomb {f_c} N)"
    );
    assert!(held < 0.7 * f_c, "{held} N: the level near rest acts");
}

/// The independent integrator, the same machine: out by a presliding range and back, then
/// 60 µm slowly (breaking away after about 3·g/σ0 of bending), then back 60 µm faster, the
/// friction at rest at 0.6 of Coulomb's passing into it over 6 mm/min. The two integrations
/// solve the same equations by different means (held force and exact bristle update over
/// sub-steps of a tenth of the bristles' time scale √(m/σ0), Runge–Kutta at 2 µs): the held
/// push errs by about (ω·h)²/2 = 0.5 % of the bristle force, so they agree to that share of
/// the presliding range g/σ0 wherever the table is.
#[test]
fn the_simulator_follows_the_independent_integrator() {
    let config = machine(0.6, 6.0);
    let model = AxisModel::from_config(&config.x);
    let range = model.f_c / SIGMA0_N_PER_M;
    let knots = [
        (0.1, 0.0),
        (0.3, range),
        (0.6, 0.0),
        (0.8, 0.0),
        (1.8, 60e-6),
        (2.0, 60e-6),
        (2.2, 0.0),
        (2.6, 0.0),
    ];
    let duration = 2.6;
    let reference = path(&knots);
    let trace = simulate(
        &model,
        &commands(&reference, duration),
        CYCLE_S,
        &SimConfig::default(),
    )
    .unwrap();
    let plant = Plant::new(&config.x);
    let mut axis = Axis::at_rest(&plant, 0.0, None);
    let h = 2e-6;
    let per_cycle = (CYCLE_S / h).round() as usize;
    let mut worst: f64 = 0.0;
    let mut moved: f64 = 0.0;
    for (k, &simulated) in trace.pos_m.iter().enumerate() {
        worst = worst.max((simulated - axis.table()).abs());
        moved = moved.max(axis.table().abs());
        for j in 0..per_cycle {
            axis.step((k * per_cycle + j) as f64 * h, h, &reference);
        }
    }
    assert!(moved > 50e-6, "the table slid: {moved}");
    assert!(
        worst < 0.005 * range,
        "{worst} m against a range of {range} m"
    );
}

/// The largest distance (m) between `trace` (one sample a cycle) and the independent
/// integrator of `plant` on `reference`, over each cycle before `split_s` and after.
fn disagreement(
    plant: &Plant,
    trace: &[f64],
    reference: &dyn Fn(f64) -> (f64, f64, f64),
    split_s: f64,
) -> (f64, f64) {
    let mut axis = Axis::at_rest(plant, 0.0, None);
    let h = 2e-6;
    let per_cycle = (CYCLE_S / h).round() as usize;
    let (mut before, mut after): (f64, f64) = (0.0, 0.0);
    for (k, &simulated) in trace.iter().enumerate() {
        let off = (simulated - axis.table()).abs();
        if (k as f64) * CYCLE_S < split_s {
            before = before.max(off);
        } else {
            after = after.max(off);
        }
        for j in 0..per_cycle {
            axis.step((k * per_cycle + j) as f64 * h, h, &reference);
        }
    }
    (before, after)
}

/// A start holding a force: the loops push with half the friction at rest towards −, the
/// bristles bent by it, and the table then moves 60 µm out, stands, and comes back faster.
/// The independent integrator starts from its own rest state holding the same force (its
/// integral, the drive's springs and the bristles set from the force alone). Out and
/// standing, where the force held acts, the two agree to the share of the presliding range
/// the test above allows; coming back (at 9 mm/min, beyond the fade of the level at rest)
/// they part by what the same run from an empty start parts by — the start adds nothing.
/// The same run starting with nothing held lies well off: the force held shows in the move.
#[test]
fn a_start_holding_a_force_follows_the_independent_integrator() {
    let config = machine(0.6, 6.0);
    let mut model = AxisModel::from_config(&config.x);
    // A force held at the start: towards −, half of what friction holds at rest.
    let held_n = -0.5 * model.f_s;
    let range = model.f_c / SIGMA0_N_PER_M;
    let knots = [
        (0.0, 0.0),
        (0.3, 0.0),
        (1.3, 60e-6),
        (1.6, 60e-6),
        (2.0, 0.0),
        (2.4, 0.0),
    ];
    let reference = path(&knots);
    let run = |model: &AxisModel| {
        simulate(
            model,
            &commands(&reference, 2.4),
            CYCLE_S,
            &SimConfig::default(),
        )
        .unwrap()
        .pos_m
    };
    let plain = run(&model);
    model.held_at_start_n = held_n;
    let holding = run(&model);
    let plant = Plant::new(&config.x).holding(held_n);
    let (out, back) = disagreement(&plant, &holding, &reference, 1.6);
    let (_, empty_back) = disagreement(&Plant::new(&config.x), &plain, &reference, 1.6);
    let (apart, _) = disagreement(&plant, &plain, &reference, 1.6);
    assert!(out < 0.005 * range, "{out} m against a range of {range} m");
    assert!(
        back < 1.01 * empty_back + 0.001 * range,
        "back {back} m, from an empty start {empty_back} m"
    );
    assert!(apart > 0.2 * range, "{apart} m: the force held shows");
}

/// With the level at rest below Coulomb's, the keys are refused without bristles, and with
/// bristles need the speed the level fades over; a damping needs bristles to damp.
#[test]
fn validation_names_the_key_a_machine_could_not_have() {
    let refused = |text: &str, key: &str| {
        let e = MachineConfig::from_toml_str(&format!("base = \"small-table\"\n{text}"), "m.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains(key), "{e}");
    };
    refused(
        "[x.friction]\nstatic_to_coulomb = 0.6\n",
        "x.friction.static_to_coulomb",
    );
    refused(
        "[x.friction]\nstatic_to_coulomb = 0.6\nbristle_stiffness_n_per_um = 15.0\n",
        "x.friction.stribeck_velocity_mm_per_min",
    );
    refused(
        "[x.friction]\nstatic_to_coulomb = 0.05\nbristle_stiffness_n_per_um = 15.0\n\
         stribeck_velocity_mm_per_min = 6.0\n",
        "x.friction.static_to_coulomb",
    );
    refused(
        "[y.friction]\nbristle_damping_n_s_per_m = 100.0\n",
        "y.friction.bristle_damping_n_s_per_m",
    );
    assert!(machine(0.6, 6.0).x.friction.has_presliding());
}

/// Bristles whose time scale against the table's mass, √(m/σ0) or m/σ1, is so short that a
/// tenth of it (the simulation step they need) falls under a microsecond are refused, naming
/// the key; bristles just inside that limit are taken.
#[test]
fn bristles_too_fast_to_simulate_are_refused() {
    let plain = MachineConfig::from_toml_str("base = \"small-table\"\n", "a.toml").unwrap();
    let mass_kg = plain.x.drive.table_mass_kg;
    // √(m/σ0)/10 = 1 µs at σ0 = m/(10 µs)², and m/σ1/10 = 1 µs at σ1 = m/10 µs.
    let stiffest_n_per_um = mass_kg / (10e-6f64).powi(2) * 1e-6;
    let most_damping = mass_kg / 10e-6;
    let with = |stiffness: f64, damping: f64| {
        MachineConfig::from_toml_str(
            &format!(
                "base = \"small-table\"\n[x.friction]\nbristle_stiffness_n_per_um = {stiffness}\n\
                 bristle_damping_n_s_per_m = {damping}\n\
                 stribeck_velocity_mm_per_min = 6.0\n"
            ),
            "m.toml",
        )
        .map_err(|e| e.to_string())
    };
    let e = with(1.2 * stiffest_n_per_um, 0.0).unwrap_err();
    assert!(e.contains("x.friction.bristle_stiffness_n_per_um"), "{e}");
    assert!(e.contains("microsecond"), "{e}");
    let e = with(15.0, 1.2 * most_damping).unwrap_err();
    assert!(e.contains("x.friction.bristle_damping_n_s_per_m"), "{e}");
    let taken = with(0.8 * stiffest_n_per_um, 0.8 * most_damping).unwrap();
    // The run divides a cycle into steps no longer than the bristles allow.
    let model = AxisModel::from_config(&taken.x);
    let n = model.substeps(CYCLE_S, &SimConfig::default());
    let step_s = CYCLE_S / n as f64;
    let allowed_s = (mass_kg / (0.8 * stiffest_n_per_um * 1e6)).sqrt() / 10.0;
    assert!(step_s <= allowed_s && step_s > 0.99 * allowed_s * (n - 1) as f64 / n as f64);
}

/// Bristle keys at zero are the hybrid friction: the same model. Very stiff bristles whose
/// level near rest is Coulomb's (no fade) approach the hybrid friction: where the table has
/// settled they hold it within the presliding range f_c/σ0 of where stick and slip holds it
/// (they carry at most f_c), and the transients at a start or a stop, which last a few of the
/// bristles' time scale √(m/σ0), part the two traces less as the bristles stiffen — by at
/// least that time scale's √10 for ten times the stiffness.
#[test]
fn stiff_bristles_approach_stick_and_slip() {
    let plain = MachineConfig::from_toml_str("base = \"small-table\"\n", "a.toml").unwrap();
    let zeros = MachineConfig::from_toml_str(
        "base = \"small-table\"\n[x.friction]\nbristle_stiffness_n_per_um = 0.0\n\
         bristle_damping_n_s_per_m = 0.0\n",
        "b.toml",
    )
    .unwrap();
    assert_eq!(
        AxisModel::from_config(&plain.x),
        AxisModel::from_config(&zeros.x)
    );
    let mass_kg = plain.x.drive.table_mass_kg;
    let f_c = plain.x.friction.coulomb_coefficient * mass_kg * 9.81;
    // Out 1 mm, hold, back, hold: two starts, two stops.
    let knots = [(0.0, 0.0), (0.3, 1e-3), (0.4, 1e-3), (0.7, 0.0), (1.0, 0.0)];
    let settled = [399, 999];
    let gaps = |sigma0_n_per_m: f64| {
        // Bristles damped at half the critical: σ1 = √(σ0·m).
        let stiff = MachineConfig::from_toml_str(
            &format!(
                "base = \"small-table\"\n[x.position_loop]\nfeedback = \"linear_scale\"\n\
                 [x.friction]\nstatic_to_coulomb = 1.0\nstribeck_velocity_mm_per_min = 0.0\n\
                 bristle_stiffness_n_per_um = {}\nbristle_damping_n_s_per_m = {}\n",
                sigma0_n_per_m * 1e-6,
                (sigma0_n_per_m * mass_kg).sqrt()
            ),
            "c.toml",
        )
        .unwrap();
        let mut hybrid = stiff.x.clone();
        hybrid.friction.bristle_stiffness_n_per_um = 0.0;
        hybrid.friction.bristle_damping_n_s_per_m = 0.0;
        let run = |c: &contourcheck::machine::AxisConfig| {
            let m = AxisModel::from_config(c);
            let cmd = commands(&path(&knots), 1.0);
            simulate(&m, &cmd, CYCLE_S, &SimConfig::default())
                .unwrap()
                .pos_m
        };
        let (a, b) = (run(&stiff.x), run(&hybrid));
        let gap: Vec<f64> = a.iter().zip(&b).map(|(p, q)| (p - q).abs()).collect();
        let range_m = f_c / sigma0_n_per_m;
        for k in settled {
            assert!(
                gap[k] < range_m,
                "{} m at {k} ms, range {range_m} m",
                gap[k]
            );
        }
        gap.iter().copied().fold(0.0, f64::max)
    };
    let (worst, stiffer) = (gaps(1e10), gaps(1e11));
    assert!(
        stiffer < worst / 10f64.sqrt(),
        "{stiffer} m against {worst} m"
    );
}

/// The check report gives the finest simulation step any axis took: on the bristle axis the
/// cycle is cut into steps of at most a tenth of √(m/σ0), finer than the settings' sub-steps.
#[test]
fn the_report_gives_the_bristles_step() {
    use contourcheck::check::{CheckSettings, check, report::CheckReport};
    use contourcheck::gcode::{InterpretOptions, parse_program};
    let program = parse_program(
        "G90 G1 X0.2 Y0.1 F600\nM30\n",
        "t.nc",
        &InterpretOptions::default(),
    )
    .unwrap();
    let step_ms = |m: &MachineConfig| {
        let settings = CheckSettings::for_machine(m);
        let run = check(&program, m, &settings).unwrap();
        let report = CheckReport::new(&run.result, &settings, &program, m, None);
        (report.settings.simulation_step_ms, run.result.dt_s * 1e3)
    };
    let plain = MachineConfig::from_toml_str("base = \"small-table\"\n", "a.toml").unwrap();
    let (plain_ms, cycle_ms) = step_ms(&plain);
    assert_eq!(
        plain_ms,
        cycle_ms / f64::from(SimConfig::default().substeps)
    );
    let bristles = machine(0.6, 6.0);
    let allowed_ms = (bristles.x.drive.table_mass_kg / SIGMA0_N_PER_M).sqrt() / 10.0 * 1e3;
    let (step, cycle_ms) = step_ms(&bristles);
    let n = (cycle_ms / allowed_ms).ceil();
    assert!(n > f64::from(SimConfig::default().substeps), "{n}");
    assert!(
        (step - cycle_ms / n).abs() < 1e-12,
        "{step} ms against {allowed_ms} ms"
    );
}
