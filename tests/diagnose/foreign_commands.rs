//! `diagnose` on records our own planner did not make. The commands come from a foreign
//! interpolator written here — a trapezoidal feed profile at 0.5 m/s², no look-ahead, a
//! stop at every block end, sampled at 1 kHz on its own clock — and the records carry what
//! real ones do: another sampling rate, encoder counts, a motor encoder as the measuring
//! point. The diagnosis gets the program, the nominal machine and the CSV text, nothing
//! else. Every catalogue cause, hidden on each axis in turn, must be found through those
//! commands; with nothing hidden nothing may be named; a record decimated to other rates
//! must give the same answer.

use crate::common;

use common::{assert_within_k_sigma_and_share, foreign_commands, program_text, sample_program};
use contourcheck::diagnose::causes::CauseId;
use contourcheck::diagnose::synth::{SynthSpec, synthesize};
use contourcheck::diagnose::{DiagnoseError, DiagnoseSettings, Diagnosis, diagnose};
use contourcheck::gcode::Program;
use contourcheck::machine::{AxisName, MachineConfig};
use contourcheck::sim::MeasuredAt;
use contourcheck::trace::measured::parse_trace;

/// A record of `program` on the nominal machine with `effect` hidden, driven by the foreign
/// interpolator's commands, as CSV text.
fn foreign_record(
    program: &Program,
    effect: Option<(CauseId, AxisName, Vec<f64>)>,
    spec: SynthSpec,
) -> String {
    let nominal = MachineConfig::default_preset();
    let spec = SynthSpec {
        effect,
        commands: Some(foreign_commands(program, 0.5, 1e-3, 0.37)),
        with_commands: true,
        ..spec
    };
    let mut csv = Vec::new();
    synthesize(program, &nominal, &spec)
        .unwrap()
        .write_csv(&mut csv)
        .unwrap();
    String::from_utf8(csv).unwrap()
}

fn diagnose_text(program: &Program, csv: &str, at: MeasuredAt) -> Result<Diagnosis, DiagnoseError> {
    let nominal = MachineConfig::default_preset();
    let measured = parse_trace(csv, "record.csv").unwrap();
    let mut settings = DiagnoseSettings::for_machine(&nominal);
    settings.compare.measured_at = at;
    diagnose(program, &nominal, &measured, &settings)
}

fn named(d: &Diagnosis) -> Vec<(CauseId, AxisName)> {
    d.causes.iter().map(|c| (c.id, c.axis)).collect()
}

/// How far a found value may lie from the hidden one, as a share of it. Stick-slip is judged
/// on the statistics of its slips, which no model times: over seeds 38–43 of the X case the
/// Stribeck velocity came out between 17.6 and 24.0 mm/min for a hidden 25 (mean 21, each
/// within 2.3 of its stated uncertainties), and which seed lands where changes with the
/// last bits of the simulation's rounding.
fn relative_tolerance(cause: CauseId) -> f64 {
    if cause == CauseId::Stribeck {
        0.30
    } else {
        0.25
    }
}

/// Hides `cause` on `axis` behind the foreign commands (1 kHz record, 0.3 µm noise) and
/// requires it named alone, its value within 25 % (see [`relative_tolerance`]) and four
/// stated uncertainties.
fn assert_found_through_foreign_commands(
    name: &str,
    cause: CauseId,
    axis: AxisName,
    hidden: &[f64],
    seed: u64,
) -> Diagnosis {
    let program = sample_program(name);
    let spec = SynthSpec {
        sample_s: 1e-3,
        offset_s: 0.21 + 0.011 * seed as f64,
        seed,
        ..SynthSpec::default()
    };
    let csv = foreign_record(&program, Some((cause, axis, hidden.to_vec())), spec);
    let d = diagnose_text(&program, &csv, MeasuredAt::Table).unwrap();
    assert_eq!(
        named(&d),
        vec![(cause, axis)],
        "{name}: {cause:?} on {axis}; not named: {:?}",
        d.rejected
            .iter()
            .map(|r| (r.id, r.axis, r.reason.as_str()))
            .collect::<Vec<_>>()
    );
    for (p, &truth) in d.causes[0].params.iter().zip(hidden) {
        let what = format!("{name}: {}", p.key);
        let share = relative_tolerance(cause);
        assert_within_k_sigma_and_share(&what, truth, p.value, p.uncertainty, 4.0, share);
    }
    // Held out: the half of the record the cause was not fitted on is predicted better.
    // (On stick-slip, whose slips no model times, on the window statistics' χ².)
    let h = d.causes[0].held_out;
    if d.causes[0].statistical {
        assert!(h.evidence > 0.0, "{h:?}");
    } else {
        assert!(h.rms_after_um < h.rms_before_um, "{h:?}");
    }
    d
}

#[test]
fn backlash_and_friction_found_through_another_interpolators_commands() {
    assert_found_through_foreign_commands(
        "circle-r50.nc",
        CauseId::Backlash,
        AxisName::X,
        &[10.0],
        31,
    );
    assert_found_through_foreign_commands(
        "circle-r50.nc",
        CauseId::Backlash,
        AxisName::Y,
        &[6.0],
        41,
    );
    assert_found_through_foreign_commands(
        "circle-r50.nc",
        CauseId::CoulombFriction,
        AxisName::Y,
        &[0.03],
        32,
    );
    assert_found_through_foreign_commands(
        "circle-r50.nc",
        CauseId::CoulombFriction,
        AxisName::X,
        &[0.04],
        42,
    );
}

#[test]
fn servo_causes_found_through_another_interpolators_commands() {
    assert_found_through_foreign_commands(
        "circle-r50.nc",
        CauseId::KvGain,
        AxisName::Y,
        &[0.9],
        33,
    );
    assert_found_through_foreign_commands(
        "circle-r50.nc",
        CauseId::KvGain,
        AxisName::X,
        &[0.85],
        43,
    );
    assert_found_through_foreign_commands(
        "circle-r50.nc",
        CauseId::DeadTime,
        AxisName::X,
        &[4.0],
        34,
    );
    assert_found_through_foreign_commands(
        "circle-r50.nc",
        CauseId::DeadTime,
        AxisName::Y,
        &[3.0],
        44,
    );
}

#[test]
fn measuring_errors_found_through_another_interpolators_commands() {
    assert_found_through_foreign_commands(
        "back-and-forth.nc",
        CauseId::ScaleError,
        AxisName::Y,
        &[25.0],
        35,
    );
    assert_found_through_foreign_commands(
        "back-and-forth.nc",
        CauseId::ScaleError,
        AxisName::X,
        &[20.0],
        45,
    );
    assert_found_through_foreign_commands(
        "back-and-forth.nc",
        CauseId::CyclicError,
        AxisName::X,
        &[3.0, 40.0],
        36,
    );
    assert_found_through_foreign_commands(
        "back-and-forth.nc",
        CauseId::CyclicError,
        AxisName::Y,
        &[2.0, 120.0],
        46,
    );
    assert_found_through_foreign_commands(
        "circle-test.nc",
        CauseId::Squareness,
        AxisName::X,
        &[40.0],
        56,
    );
}

#[test]
fn lost_motion_beyond_the_scale_found_through_another_interpolators_commands() {
    // Y reads 5 µm more travelling + than −, beyond its scale; the record's commands fix
    // the clock, which would otherwise take it for an offset (v·Δt at one feed).
    let d = assert_found_through_foreign_commands(
        "circle-r50.nc",
        CauseId::DirectionOffset,
        AxisName::Y,
        &[5.0],
        58,
    );
    // A ballbar reads it as lost motion of the other sign (the tool leads), measured and by
    // the extended model alike.
    for test in [&d.circular.measured, &d.circular.extended] {
        let pair = test.pairs[0];
        assert!((pair.backlash_y_um + 5.0).abs() < 1.0, "{pair:?}");
    }
}

#[test]
fn a_bowed_travel_found_through_another_interpolators_commands() {
    // X's travel bowed 80 µm over the preset's metre: Y reads up to 3.2 µm less at X = ±100 mm.
    let d = assert_found_through_foreign_commands(
        "circle-test.nc",
        CauseId::Straightness,
        AxisName::Y,
        &[80.0],
        59,
    );
    // The ballbar reads the bow over the circle's diameter: 80 µm·(200/1000)² = 3.2 µm.
    for test in [&d.circular.measured, &d.circular.extended] {
        let pair = test.pairs[0];
        assert!((pair.straightness_y_um - 3.2).abs() < 0.5, "{pair:?}");
    }
}

#[test]
fn lateral_play_found_through_another_interpolators_commands() {
    // X steps 6 µm at each reversal of Y (at the circle's ±Y points), against 0.3 µm of noise.
    let d = assert_found_through_foreign_commands(
        "circle-r50.nc",
        CauseId::LateralPlay,
        AxisName::X,
        &[6.0],
        57,
    );
    // The circle test reads it as a ballbar does, measured and by the extended model.
    for test in [&d.circular.measured, &d.circular.extended] {
        let pair = test.pairs[0];
        assert!((pair.lateral_play_x_um - 6.0).abs() < 1.0, "{pair:?}");
        assert!(pair.lateral_play_y_um.abs() < 1.0, "{pair:?}");
    }
    assert!(d.circular.nominal.pairs[0].lateral_play_x_um.abs() < 1.0);
}

#[test]
fn a_resonance_found_through_another_interpolators_commands() {
    assert_found_through_foreign_commands(
        "square.nc",
        CauseId::Resonance,
        AxisName::Y,
        &[25.0, 0.05],
        37,
    );
    assert_found_through_foreign_commands(
        "square.nc",
        CauseId::Resonance,
        AxisName::X,
        &[40.0, 0.03],
        47,
    );
}

/// Stick-slip through the foreign commands: on X named (its model predicts the record
/// better point by point); on Y, whose larger, rarer slips no model times, seen, not
/// determined — the model extended by it predicts Y worse point by point.
#[test]
fn stick_slip_found_through_another_interpolators_commands() {
    assert_found_through_foreign_commands(
        "slow-circle.nc",
        CauseId::Stribeck,
        AxisName::X,
        &[300.0, 25.0],
        38,
    );
    let program = sample_program("slow-circle.nc");
    let seed = 48;
    let spec = SynthSpec {
        sample_s: 1e-3,
        offset_s: 0.21 + 0.011 * seed as f64,
        seed,
        ..SynthSpec::default()
    };
    let effect = Some((CauseId::Stribeck, AxisName::Y, vec![500.0, 12.0]));
    let csv = foreign_record(&program, effect, spec);
    let d = diagnose_text(&program, &csv, MeasuredAt::Table).unwrap();
    common::assert_seen_not_named(&d, CauseId::Stribeck, AxisName::Y);
}

/// A 4 s program: a tangential lead-in, a full R10 circle at F3000, a lead-out.
const SMALL_CIRCLE: &str = "G21 G17 G90 G94 G64 P0.005\n\
     G0 X10 Y-5\n\
     G1 Y0 F3000\n\
     G3 X10 Y0 I-10 J0\n\
     G1 Y5\n\
     M30\n";

/// Every `step`-th line of a CSV (header kept): the same record at a lower rate.
fn decimate(csv: &str, step: usize) -> String {
    let mut lines = csv.lines();
    let header = lines.next().unwrap();
    std::iter::once(header)
        .chain(lines.step_by(step))
        .map(|l| format!("{l}\n"))
        .collect()
}

/// A motor-encoder record at 10 kHz in 0.1 µm counts, commands from the foreign
/// interpolator.
fn motor_record(effect: Option<(CauseId, AxisName, Vec<f64>)>) -> (Program, String) {
    let program = program_text(SMALL_CIRCLE);
    let spec = SynthSpec {
        sample_s: 1e-4,
        noise_m: 0.02e-6,
        quantization_m: 0.1e-6,
        measured_at: MeasuredAt::Motor,
        offset_s: 0.123,
        seed: 40,
        ..SynthSpec::default()
    };
    let csv = foreign_record(&program, effect, spec);
    (program, csv)
}

#[test]
fn a_motor_encoder_record_at_10_khz_names_nothing_at_any_rate() {
    let (program, csv) = motor_record(None);
    for (step, rate) in [(1, "10 kHz"), (10, "1 ms"), (20, "2 ms")] {
        let d = diagnose_text(&program, &decimate(&csv, step), MeasuredAt::Motor).unwrap();
        assert!(d.causes.is_empty(), "{rate}: named {:?}", named(&d));
        assert!(d.learned.is_empty(), "{rate}: learned {:?}", d.learned);
        // The noise floor is not the encoder count's rounding alone, and never below it.
        assert!(
            d.noise_floor_um >= 0.1 / 12f64.sqrt() - 1e-9,
            "{rate}: {}",
            d.noise_floor_um
        );
        // Backlash lies beyond a motor encoder: not tried, and the report says why.
        assert!(
            d.skipped
                .iter()
                .any(|s| s.id == CauseId::Backlash && s.reason.contains("motor")),
            "{rate}: {:?}",
            d.skipped
        );
    }
}

#[test]
fn a_gain_error_at_the_motor_is_found_alike_at_10_khz_1_ms_and_2_ms() {
    let (program, csv) = motor_record(Some((CauseId::KvGain, AxisName::X, vec![0.9])));
    let mut found = Vec::new();
    for step in [1, 10, 20] {
        let d = diagnose_text(&program, &decimate(&csv, step), MeasuredAt::Motor).unwrap();
        assert_eq!(
            named(&d),
            vec![(CauseId::KvGain, AxisName::X)],
            "every {step}th row"
        );
        let p = &d.causes[0].params[0];
        found.push((p.value, p.uncertainty));
    }
    // Overlapping uncertainties: every pair agrees within their combined 4σ.
    for a in &found {
        for b in &found {
            assert!((a.0 - b.0).abs() <= 4.0 * a.1.hypot(b.1), "{found:?}");
        }
    }
}

#[test]
fn commands_that_leave_the_program_are_refused_with_the_place() {
    let program = sample_program("circle-test.nc");
    let mut stream = foreign_commands(&program, 0.5, 1e-3, 0.37);
    // 40 µm outward for 0.2 s from where the first (counter-clockwise) circle passes its
    // top, X0 Y100.
    let top = (0..stream.x_m.len())
        .find(|&k| stream.x_m[k].abs() < 1e-3 && stream.y_m[k] > 0.099)
        .unwrap();
    for k in top..top + 200 {
        let (x, y) = (stream.x_m[k], stream.y_m[k]);
        let grow = 1.0 + 40e-6 / x.hypot(y);
        stream.x_m[k] = x * grow;
        stream.y_m[k] = y * grow;
    }
    let spec = SynthSpec {
        commands: Some(stream),
        with_commands: true,
        sample_s: 1e-3,
        ..SynthSpec::default()
    };
    let mut csv = Vec::new();
    synthesize(&program, &MachineConfig::default_preset(), &spec)
        .unwrap()
        .write_csv(&mut csv)
        .unwrap();
    let err = diagnose_text(
        &program,
        std::str::from_utf8(&csv).unwrap(),
        MeasuredAt::Table,
    )
    .unwrap_err();
    let DiagnoseError::OffPath {
        distance_um,
        line,
        t_s,
        ..
    } = err
    else {
        panic!("{err}");
    };
    assert!((distance_um - 40.0).abs() < 2.0, "{distance_um}");
    // The place: within the stretch, on the first circle's block (line 13).
    let from_s = top as f64 * 1e-3;
    assert!((from_s..from_s + 0.2).contains(&t_s), "{t_s} vs {from_s}");
    assert_eq!(line, 13);
}

/// An axis under a controller that is not the model's cascade, simulated here on its own:
/// a rigid table of `mass_kg` with viscous friction, driven by a velocity-mode drive (a
/// proportional velocity loop of `velocity_hz` bandwidth, force limited), under a
/// proportional position loop of `kv_per_s` sampled at 1 kHz, or — with `integral_per_s2`
/// — a PI position loop, which leaves no steady lag at all. Integrated at 10 µs.
struct ForeignAxis {
    mass_kg: f64,
    viscous_n_s_per_m: f64,
    velocity_hz: f64,
    kv_per_s: f64,
    integral_per_s2: f64,
}

impl ForeignAxis {
    /// The table's positions at the command samples (`dt_s`), read in 0.1 µm counts.
    fn follow(&self, commands: &[f64], dt_s: f64) -> Vec<f64> {
        const SUBSTEPS: usize = 100;
        let h = dt_s / SUBSTEPS as f64;
        let k_vel = self.mass_kg * std::f64::consts::TAU * self.velocity_hz;
        let (mut x, mut v, mut integral) = (commands[0], 0.0, 0.0);
        let mut out = Vec::with_capacity(commands.len());
        for &x_ref in commands {
            out.push((x / 1e-7).round() * 1e-7);
            let error = x_ref - x;
            integral += error * dt_s;
            let v_cmd = self.kv_per_s * error + self.integral_per_s2 * integral;
            let force = (k_vel * (v_cmd - v)).clamp(-40e3, 40e3);
            for _ in 0..SUBSTEPS {
                v += h * (force - self.viscous_n_s_per_m * v) / self.mass_kg;
                x += h * v;
            }
        }
        out
    }
}

/// A record of `program` on two foreign axes, with the commands, as CSV text (ms, mm).
fn foreign_controller_record(program: &Program, axis: &ForeignAxis) -> String {
    let c = foreign_commands(program, 0.5, 1e-3, 0.4);
    let (x, y) = (axis.follow(&c.x_m, c.dt_s), axis.follow(&c.y_m, c.dt_s));
    let mut csv = String::from("t_ms,x_mm,y_mm,x_cmd_mm,y_cmd_mm\n");
    for k in 0..x.len() {
        csv += &format!(
            "{:.1},{:.4},{:.4},{:.6},{:.6}\n",
            k as f64 * c.dt_s * 1e3,
            x[k] * 1e3,
            y[k] * 1e3,
            c.x_m[k] * 1e3,
            c.y_m[k] * 1e3
        );
    }
    csv
}

/// Records of a controller other than the model's cascade. Under a proportional position
/// loop of Kv 0.7 m/min/mm (11.7 /s) with a velocity-mode drive, the lag is F/Kv as in the
/// model: the gain error is found on both axes at the controller's Kv. Under a PI position
/// loop, which leaves no lag at all, no gain of the model's cascade can follow; whatever is
/// named must make the record's residual smaller and have values a machine can have.
#[test]
fn records_of_other_controllers_are_read_as_the_model_can_and_never_worse() {
    let program = sample_program("square.nc");
    let kv_per_s = 0.7 * 1000.0 / 60.0;
    let p_loop = ForeignAxis {
        mass_kg: 6000.0,
        viscous_n_s_per_m: 200.0,
        velocity_hz: 40.0,
        kv_per_s,
        integral_per_s2: 0.0,
    };
    let d = diagnose_text(
        &program,
        &foreign_controller_record(&program, &p_loop),
        MeasuredAt::Table,
    )
    .unwrap();
    for axis in AxisName::BOTH {
        let kv = d
            .causes
            .iter()
            .find(|c| c.id == CauseId::KvGain && c.axis == axis)
            .unwrap_or_else(|| panic!("no gain error on {axis}: {:?}", d.rejected));
        let value = kv.params[0].value;
        assert!((value - 0.7).abs() < 0.05, "{axis}: Kv {value}");
    }
    assert!(
        d.after.contour.rms_um < 0.2 * d.before.contour.rms_um,
        "{:?}",
        d.after
    );

    let pi_loop = ForeignAxis {
        integral_per_s2: 0.25 * kv_per_s * kv_per_s,
        ..p_loop
    };
    let d = diagnose_text(
        &program,
        &foreign_controller_record(&program, &pi_loop),
        MeasuredAt::Table,
    )
    .unwrap();
    // What the cascade cannot be made to do (follow without lag) is placed where it lives:
    // the residual is the model's lag, proportional to velocity; nothing is learned from it.
    assert!(d.learned.is_empty(), "{:?}", d.learned);
    assert_eq!(d.unexplained.len(), 2, "{:?}", d.unexplained);
    for u in &d.unexplained {
        assert_eq!(
            u.variable,
            Some(contourcheck::diagnose::locate::Variable::Velocity),
            "{u:?}"
        );
    }
    for c in &d.causes {
        let [before, after] = [&c.before, &c.after];
        assert!(
            after.rms_um < before.rms_um,
            "{:?} on {}: worse",
            c.id,
            c.axis
        );
    }
    assert!(
        d.after.contour.rms_um <= d.before.contour.rms_um * 1.005,
        "{:?} → {:?}",
        d.before,
        d.after
    );
}

/// The slow circle through the foreign interpolator, recorded at 1 kHz with `effect`.
fn slow_circle_at_1_khz(
    effect: Option<(CauseId, AxisName, Vec<f64>)>,
    offset_s: f64,
    seed: u64,
) -> (Program, String) {
    let program = sample_program("slow-circle.nc");
    let spec = SynthSpec {
        sample_s: 1e-3,
        offset_s,
        seed,
        ..SynthSpec::default()
    };
    let csv = foreign_record(&program, effect, spec);
    (program, csv)
}

/// The record as a logger writes it that reads the positions every `rows` rows and repeats
/// each reading until the next (all columns held alike, time running on).
fn hold_readings(csv: &str, rows: usize, phase: usize) -> String {
    let lines: Vec<&str> = csv.lines().collect();
    let mut out = format!("{}\n", lines[0]);
    let data = &lines[1..];
    for (i, line) in data.iter().enumerate() {
        let (time, _) = line.split_once(',').unwrap();
        // Rows before the first reading repeat the one taken before the record began.
        let held = if i < phase {
            0
        } else {
            phase + (i - phase) / rows * rows
        };
        let (_, values) = data[held].split_once(',').unwrap();
        out.push_str(&format!("{time},{values}\n"));
    }
    out
}

#[test]
fn a_logger_that_holds_its_readings_is_read_at_its_own_rate_and_not_taken_for_stick_slip() {
    // A slow circle, where a real stick-slip would show, on the nominal machine: positions
    // and commands read every 15 ms and written every millisecond. Each hold stands the
    // record still and ends in a jump — stick-slip's own shape, at the logger's rhythm;
    // read row by row, the rhythm passes for a 67 Hz resonance.
    let (program, record) = slow_circle_at_1_khz(None, 0.29, 61);
    let csv = hold_readings(&record, 15, 7);
    let trace = parse_trace(&csv, "record.csv").unwrap();
    assert_eq!(
        trace.held,
        Some(contourcheck::trace::measured::HeldRows {
            period: 15,
            phase: 7
        })
    );
    assert!((trace.dt_s - 0.015).abs() < 1e-12, "{}", trace.dt_s);
    let d = diagnose_text(&program, &csv, MeasuredAt::Table).unwrap();
    assert!(
        d.causes.is_empty(),
        "named {:?}; not named: {:?}",
        named(&d),
        d.rejected
            .iter()
            .map(|r| (r.id, r.axis, r.reason.as_str()))
            .collect::<Vec<_>>()
    );
}

/// Whether the diagnosis sees each axis sticking in `csv`.
fn sticking_seen(program: &Program, csv: &str, at: MeasuredAt) -> [bool; 2] {
    let nominal = MachineConfig::default_preset();
    let measured = parse_trace(csv, "record.csv").unwrap();
    let mut settings = DiagnoseSettings::for_machine(&nominal);
    settings.compare.measured_at = at;
    let c = contourcheck::compare::compare(
        program,
        &nominal,
        &measured,
        &settings.compare,
        contourcheck::compare::Stepping::Full,
    )
    .unwrap();
    AxisName::BOTH.map(|a| c.ctx.sticking_seen(a, c.offset_s))
}

#[test]
fn sticking_is_seen_only_where_a_slip_follows_the_standstill() {
    // The foreign interpolator stops at every block end; at each start the motor stands
    // for a while as its command moves off (on Y, three times over 4 % of the moving time),
    // but never catches up faster than it follows: no slip, no stick-slip.
    let (program, csv) = motor_record(None);
    for step in [1, 10, 20] {
        let seen = sticking_seen(&program, &decimate(&csv, step), MeasuredAt::Motor);
        assert_eq!(seen, [false, false], "every {step}th row");
    }
    // Stribeck friction on X: the table stands, breaks loose and catches up, hundreds of
    // times around the slow circle.
    let effect = Some((CauseId::Stribeck, AxisName::X, vec![300.0, 25.0]));
    let (program, csv) = slow_circle_at_1_khz(effect, 0.33, 62);
    assert_eq!(
        sticking_seen(&program, &csv, MeasuredAt::Table),
        [true, false]
    );
}

#[test]
fn an_unlisted_bump_is_learned_through_another_interpolators_commands() {
    // The foreign interpolator runs the circle test at 1 kHz; the X scale reads a 6 µm
    // raised-cosine bump between X = 20 and 40 mm more, which no catalogue cause describes.
    let program = sample_program("circle-test.nc");
    let spec = SynthSpec {
        sample_s: 1e-3,
        offset_s: 0.27,
        seed: 63,
        ..SynthSpec::default()
    };
    let csv = foreign_record(&program, None, spec);
    let mut lines = csv.lines();
    let mut bumped = format!("{}\n", lines.next().unwrap());
    for line in lines {
        let mut f: Vec<String> = line.split(',').map(String::from).collect();
        let x: f64 = f[1].parse().unwrap();
        let bump = if (20.0..=40.0).contains(&x) {
            3e-3 * (1.0 - (std::f64::consts::TAU * (x - 20.0) / 20.0).cos())
        } else {
            0.0
        };
        f[1] = format!("{:.7}", x + bump);
        bumped.push_str(&(f.join(",") + "\n"));
    }
    let d = diagnose_text(&program, &bumped, MeasuredAt::Table).unwrap();
    assert!(d.causes.is_empty(), "named {:?}", named(&d));
    assert_eq!(d.learned.len(), 1, "{:?}", d.learned);
    let l = &d.learned[0];
    let (lo, hi) = l.interval.unwrap();
    assert!(l.axis == AxisName::X && lo >= 18.0 && hi <= 42.0, "{l:?}");
    assert!((l.peak - 6.0).abs() < 1.5, "{l:?}");
    assert!(l.held_out_after_um <= 0.5 * l.held_out_before_um, "{l:?}");
}

#[test]
fn a_tight_spot_is_learned_through_another_interpolators_commands() {
    // Friction doubled (589 N more) over X 60–80 mm; X shuttles over 150 mm four times,
    // commanded by the foreign interpolator (a stop at every block end), recorded at 1 kHz
    // with 0.05 µm of noise in 0.1 µm counts and its commands.
    let program = program_text(
        "G21 G17 G90 G94\nG0 X0 Y0\nG1 X150 F1000\nX0\nX150\nX0\nX150\nX0\nX150\nX0\nM2\n",
    );
    let mut truth = MachineConfig::default_preset();
    truth.x.errors.friction_map_mm = vec![59.0, 60.0, 80.0, 81.0];
    truth.x.errors.friction_map_n = vec![0.0, 589.0, 589.0, 0.0];
    let spec = SynthSpec {
        commands: Some(foreign_commands(&program, 0.5, 1e-3, 0.37)),
        with_commands: true,
        sample_s: 1e-3,
        noise_m: 0.05e-6,
        quantization_m: 0.1e-6,
        offset_s: 0.23,
        seed: 91,
        ..SynthSpec::default()
    };
    let mut csv = Vec::new();
    synthesize(&program, &truth, &spec)
        .unwrap()
        .write_csv(&mut csv)
        .unwrap();
    let d = diagnose_text(
        &program,
        std::str::from_utf8(&csv).unwrap(),
        MeasuredAt::Table,
    )
    .unwrap();
    common::assert_tight_spot_learned(&d);
}
