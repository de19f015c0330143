//! Records as users bring them, made by the independent reference (`common::reference`: its
//! own integrator, its own interpolator stopping at every block end) and then shaped the
//! way real traces come: a logger started mid-program with the axes moving and lagging, one
//! stopped after the program's first seconds, one started at the machine's home with an
//! approach the program does not hold. The diagnosis gets the program, the nominal machine
//! and the CSV text. What is hidden it must find at its value; with nothing hidden it must
//! name nothing; and its report must say which stretch it compared and how it set the start.

use crate::common;

use common::reference::{Recording, record};
use common::{assert_within_k_sigma_and_share, program_text};
use contourcheck::diagnose::causes::CauseId;
use contourcheck::diagnose::{DiagnoseSettings, Diagnosis, StartKind, diagnose};
use contourcheck::gcode::Program;
use contourcheck::machine::{AxisName, MachineConfig};
use contourcheck::trace::measured::parse_trace;
use rayon::prelude::*;

/// Two counter-clockwise laps of R30 at F1000 (11.3 s each).
const CIRCLE: &str = "G21 G90 G17 G94\nG0 X30 Y0\nG3 X30 Y0 I-30 J0 F1000\nG3 X30 Y0 I-30 J0\nM2\n";
/// A 60 mm square at F1000 with a stop at each corner (3.6 s a side).
const SQUARE: &str = "G21 G90 G17 G94\nG0 X0 Y0\nG1 X60 F1000\nY60\nX0\nY0\nM2\n";

/// The record of `program` the reference makes on `truth`, as CSV text; without its
/// commanded columns where `commands` is false.
fn reference_csv(
    program: &Program,
    truth: &MachineConfig,
    rec: &Recording,
    commands: bool,
) -> String {
    let csv = record(program, &truth.x, &truth.y, rec);
    if commands {
        return csv;
    }
    csv.lines()
        .map(|l| l.split(',').take(3).collect::<Vec<_>>().join(",") + "\n")
        .collect()
}

fn diagnose_csv(program: &Program, csv: &str) -> Diagnosis {
    let nominal = MachineConfig::default_preset();
    let measured = parse_trace(csv, "record.csv").unwrap();
    diagnose(
        program,
        &nominal,
        &measured,
        &DiagnoseSettings::for_machine(&nominal),
    )
    .unwrap()
}

fn named(d: &Diagnosis) -> Vec<(CauseId, AxisName)> {
    d.causes.iter().map(|c| (c.id, c.axis)).collect()
}

fn kv(axis: AxisName, value: f64) -> MachineConfig {
    let mut m = MachineConfig::default_preset();
    m.axis_mut(axis).position_loop.kv_m_per_min_per_mm = value;
    m
}

/// A logger started 8 s into the circle test, mid-lap, with the axes at 1000 mm/min and Y
/// lagging on a gain 8 % low: the gain error is found at its value on Y alone, X (nominal)
/// is explained to its noise, and the report says the record began in motion and was run
/// into; the same from a record cut at 5 s, mid-side of a square on a nominal machine, where
/// nothing may be named.
#[test]
fn a_record_begun_in_motion_is_run_into_and_diagnosed_right() {
    let cases = [
        (
            "circle cut at 8 s, Y Kv 0.92",
            CIRCLE,
            kv(AxisName::Y, 0.92),
            8.0,
        ),
        (
            "square cut at 5 s, nominal",
            SQUARE,
            MachineConfig::default_preset(),
            5.0,
        ),
    ];
    let failures: Vec<String> = cases
        .into_par_iter()
        .filter_map(|(name, text, truth, cut_s)| {
            let program = program_text(text);
            let rec = Recording {
                keep_s: Some((cut_s, f64::INFINITY)),
                ..Recording::default()
            };
            let d = diagnose_csv(&program, &reference_csv(&program, &truth, &rec, true));
            let mut wrong = Vec::new();
            let c = d.coverage;
            if c.start != StartKind::InMotion || c.from_program_start || !c.to_program_end {
                wrong.push(format!("coverage {c:?}"));
            }
            // Run in, and an axis moving at the cut settled within a fraction of the record
            // (one standing there waits for its first move).
            let settled = c.settling_s[0].min(c.settling_s[1]);
            if !(c.run_in_s >= 1.0 && settled > 0.0 && settled < 2.0) {
                wrong.push(format!("run-in {c:?}"));
            }
            // The program's plan reaches the cut about when the reference did (its
            // interpolator ramps at 0.5 m/s² like the plan, its rapid differs).
            if (c.into_program_s - cut_s).abs() > 1.0 {
                wrong.push(format!("into the program {} s", c.into_program_s));
            }
            let truth_kv = truth.y.position_loop.kv_m_per_min_per_mm;
            let hidden =
                (truth_kv != 1.0).then_some((CauseId::KvGain, AxisName::Y, truth_kv, 0.02));
            judge(&d, hidden, &mut wrong);
            (!wrong.is_empty()).then(|| format!("{name}: {}", wrong.join("; ")))
        })
        .collect();
    assert!(failures.is_empty(), "{failures:#?}");
}

/// A logger stopped after the square's first 4 s (the first side and the corner): compared
/// on what it covers, to the noise, nothing named, and the report says the record ends
/// before the program; without its commands (the plan as timeline) too.
#[test]
fn a_record_of_the_programs_first_seconds_is_compared_on_what_it_covers() {
    let program = program_text(SQUARE);
    let rec = Recording {
        keep_s: Some((0.0, 4.0)),
        ..Recording::default()
    };
    let truth = MachineConfig::default_preset();
    let d = diagnose_csv(&program, &reference_csv(&program, &truth, &rec, true));
    let c = d.coverage;
    assert_eq!(c.start, StartKind::AtRest, "{c:?}");
    assert!(c.from_program_start && !c.to_program_end, "{c:?}");
    // The first side is line 3, the second line 4: the record stops just into the second.
    assert_eq!((c.first_line, c.last_line), (3, 4), "{c:?}");
    assert!(d.causes.is_empty(), "{:?}", d.causes);
    assert!(
        d.before.x.rms_um <= 1.1 * d.noise_floor_um,
        "{:?}",
        d.before
    );
    assert!(
        d.before.y.rms_um <= 1.1 * d.noise_floor_um,
        "{:?}",
        d.before
    );
    let d = diagnose_csv(&program, &reference_csv(&program, &truth, &rec, false));
    let c = d.coverage;
    assert_eq!(c.start, StartKind::Planned, "{c:?}");
    assert!(c.from_program_start && !c.to_program_end, "{c:?}");
    assert!(d.causes.is_empty(), "{:?}", d.causes);
}

/// A machine standing at its home (200, −50) mm before the program, its first rapid from
/// there: the approach is neither simulated nor compared, the comparison starts where the
/// commands join the program, and the report says where the machine stood. On a nominal
/// machine nothing is named and the residual is the noise; with 8 µm of backlash hidden on
/// X the backlash is found at its value.
#[test]
fn a_record_from_home_is_compared_from_where_its_commands_join_the_program() {
    let mut backlash = MachineConfig::default_preset();
    backlash.x.drive.backlash_um = 8.0;
    let cases = [
        (
            "square from home, nominal",
            SQUARE,
            MachineConfig::default_preset(),
        ),
        ("circle from home, backlash 8 µm on X", CIRCLE, backlash),
    ];
    let failures: Vec<String> = cases
        .into_par_iter()
        .filter_map(|(name, text, truth)| {
            let program = program_text(text);
            let rec = Recording {
                home_m: Some([0.2, -0.05]),
                ..Recording::default()
            };
            let d = diagnose_csv(&program, &reference_csv(&program, &truth, &rec, true));
            let mut wrong = Vec::new();
            let c = d.coverage;
            let home_ok = c
                .stood_at_mm
                .is_some_and(|[x, y]| (x - 200.0).abs() < 1e-3 && (y + 50.0).abs() < 1e-3);
            if c.start != StartKind::BeforeProgram || !home_ok || !c.from_program_start {
                wrong.push(format!("coverage {c:?}"));
            }
            // The reference stands 0.3 s, then rapids at 10 m/min with ramps at 0.5 m/s²:
            // 206 mm to the square's start in 1.57 s, 177 mm to the circle's in 1.40 s. The
            // approach is that long.
            let approach_s = if text == SQUARE { 1.87 } else { 1.70 };
            if (c.approach_s - approach_s).abs() > 0.05 {
                wrong.push(format!("approach {} s", c.approach_s));
            }
            let hidden = truth.x.drive.backlash_um;
            let hidden = (hidden > 0.0).then_some((CauseId::Backlash, AxisName::X, hidden, 0.05));
            judge(&d, hidden, &mut wrong);
            (!wrong.is_empty()).then(|| format!("{name}: {}", wrong.join("; ")))
        })
        .collect();
    assert!(failures.is_empty(), "{failures:#?}");
}

/// A delay of 4 ms between X's interpolator and its position loop, recorded on a 60° line at
/// F500 from 2 s to 6 s: at constant speed throughout, the record holds no start or stop,
/// and there a delay τ lags the axis by v·τ just as a gain lowered from Kv to
/// 1/(1/Kv + τ) does — 16.67 /s → 15.625 /s, i.e.
/// 1 → 0.9375 m/min/mm for the nominal gain. One of the two is named on X, alone, the other
/// given as its alternative with the record that would tell them apart, and the value named
/// is the one that lag implies.
#[test]
fn a_delay_seen_only_at_speed_is_said_to_be_indistinguishable_from_a_gain() {
    let program = program_text("G21 G90 G17 G94\nG0 X0 Y0\nG1 X30 Y52 F500\nM2\n");
    let mut truth = MachineConfig::default_preset();
    truth.x.position_loop.dead_time_ms = 4.0;
    let rec = Recording {
        keep_s: Some((2.0, 6.0)),
        ..Recording::default()
    };
    let d = diagnose_csv(&program, &reference_csv(&program, &truth, &rec, true));
    assert_eq!(d.coverage.start, StartKind::InMotion, "{:?}", d.coverage);
    assert_eq!(d.causes.len(), 1, "{:?}", named(&d));
    let c = &d.causes[0];
    assert_eq!(c.axis, AxisName::X);
    let kv_nominal_per_s = 1000.0 / 60.0;
    let kv_equivalent = 1.0 / (1.0 / kv_nominal_per_s + 4e-3) * 60.0 / 1000.0;
    let (other, hidden) = match c.id {
        CauseId::KvGain => (CauseId::DeadTime, kv_equivalent),
        CauseId::DeadTime => (CauseId::KvGain, 4.0),
        id => panic!("named {id:?}; alternatives {:?}", c.alternatives),
    };
    let alternative = c.alternatives.iter().find(|a| a.id == other);
    assert!(
        alternative.is_some_and(|a| a.axis == AxisName::X && !a.told_apart_by.is_empty()),
        "{:?}",
        c.alternatives
    );
    let p = &c.params[0];
    let what = format!("{:?}", c.id);
    assert_within_k_sigma_and_share(&what, hidden, p.value, p.uncertainty, 4.0, 0.01);
}

/// A square recorded in 0.1 µm encoder counts under plain headers, as a logger writes them:
/// read as millimetres the positions are whole numbers up to 600 000 "mm", and the record
/// is refused with a hint that names counts and spells out the `--columns` mapping that
/// reads them; with that mapping the same text is diagnosed, nothing named on the nominal
/// machine.
#[test]
fn positions_in_encoder_counts_get_a_hint_with_the_columns_spelling() {
    use contourcheck::trace::format::ColumnMap;
    use contourcheck::trace::measured::parse_trace_with;
    let program = program_text(SQUARE);
    let truth = MachineConfig::default_preset();
    let csv = reference_csv(&program, &truth, &Recording::default(), true);
    let counts: String = csv
        .lines()
        .enumerate()
        .map(|(k, line)| {
            if k == 0 {
                return format!("{line}\n");
            }
            let cells: Vec<String> = line
                .split(',')
                .enumerate()
                .map(|(j, c)| match j {
                    0 => c.to_string(),
                    _ => format!("{}", (c.parse::<f64>().unwrap() * 1e4).round()),
                })
                .collect();
            cells.join(",") + "\n"
        })
        .collect();
    let nominal = MachineConfig::default_preset();
    let settings = DiagnoseSettings::for_machine(&nominal);
    let as_mm = parse_trace(&counts, "counts.csv").unwrap();
    let refused = diagnose(&program, &nominal, &as_mm, &settings)
        .expect_err("millimetres 10⁴ times too large are refused")
        .to_string();
    let spelling = "t=t[s],x=x[counts:0.1um],y=y[counts:0.1um],x_cmd=x_cmd[counts:0.1um],\
                    y_cmd=y_cmd[counts:0.1um]";
    assert!(
        refused.contains("encoder counts") && refused.contains(spelling),
        "{refused}"
    );
    let map = ColumnMap::parse(spelling).unwrap();
    let as_counts = parse_trace_with(&counts, "counts.csv", Some(&map)).unwrap();
    let d = diagnose(&program, &nominal, &as_counts, &settings).unwrap();
    assert!(d.causes.is_empty(), "{:?}", named(&d));
}

/// What a diagnosis of a record with one `hidden` effect (its cause, axis, true value and the
/// relative tolerance on it) or none must show: that cause alone, within 4σ and the tolerance,
/// or nothing named and nothing learned; and both axes explained to the noise.
fn judge(d: &Diagnosis, hidden: Option<(CauseId, AxisName, f64, f64)>, wrong: &mut Vec<String>) {
    match hidden {
        Some((cause, axis, ..)) if named(d) != [(cause, axis)] => {
            wrong.push(format!("named {:?}; not named {:?}", named(d), d.rejected));
        }
        Some((_, _, truth, relative)) => {
            let p = &d.causes[0].params[0];
            let err = (p.value - truth).abs();
            if err > 4.0 * p.uncertainty || err > relative * truth {
                wrong.push(format!(
                    "{:?} {} ± {}",
                    d.causes[0].id, p.value, p.uncertainty
                ));
            }
        }
        None if !d.causes.is_empty() || !d.learned.is_empty() => {
            wrong.push(format!("named {:?}, learned {:?}", named(d), d.learned));
        }
        None => {}
    }
    for (axis, r) in [("X", d.after.x.rms_um), ("Y", d.after.y.rms_um)] {
        if r > 1.1 * d.noise_floor_um {
            wrong.push(format!("{axis} residual {r:.3} µm"));
        }
    }
}
