//! Records no machine run should give, and some real ones do: a handful of samples, an axis
//! that never moves, a record that is all jumps (rapids sampled at 50 Hz), commands far from
//! the program (machine coordinates), a constant record, a clock that stalls. Reading,
//! inspecting, diagnosing and identifying each may refuse it, but only with an error: none
//! may panic.

use crate::common;

use common::program_text;
use contourcheck::diagnose::report::DiagnoseReport;
use contourcheck::diagnose::{DiagnoseSettings, diagnose};
use contourcheck::identify::identify;
use contourcheck::machine::MachineConfig;
use contourcheck::trace::inspect::summarise;
use contourcheck::trace::measured::parse_trace;

/// How one axis moves in an odd record.
#[derive(Debug, Clone, Copy)]
enum Motion {
    Still,
    Ramp,
    /// Jumps between a few positions, as rapids look at a low sampling rate.
    Jumps,
    /// Alternates between two positions every sample.
    Chatter,
}

/// The motions, in the order the table of records below numbers them.
const MOTIONS: [Motion; 4] = [Motion::Still, Motion::Ramp, Motion::Jumps, Motion::Chatter];

/// Position (mm) of an axis moving so at sample `k` of `n`.
fn position_mm(m: Motion, k: usize, n: usize) -> f64 {
    let s = k as f64 / n.max(1) as f64;
    match m {
        Motion::Still => 5.0,
        Motion::Ramp => 20.0 * s,
        Motion::Jumps => [0.0, 20.0, 20.0, 7.5, 0.0][(5 * k / n.max(1)).min(4)],
        Motion::Chatter => (k % 2) as f64 * 0.001,
    }
}

/// A CSV record: `n` samples `step_s` apart, each axis moving so, with commands (offset by
/// `command_offset_mm`, a work offset the program does not know) or without.
fn record_csv(
    n: usize,
    step_s: f64,
    x: Motion,
    y: Motion,
    commands: Option<f64>,
    lag_samples: usize,
) -> String {
    let mut csv = String::from(if commands.is_some() {
        "t_s,x_mm,y_mm,x_cmd_mm,y_cmd_mm\n"
    } else {
        "t_s,x_mm,y_mm\n"
    });
    for k in 0..n {
        let behind = k.saturating_sub(lag_samples);
        let (xm, ym) = (position_mm(x, behind, n), position_mm(y, behind, n));
        csv.push_str(&format!("{},{xm},{ym}", k as f64 * step_s));
        if let Some(offset) = commands {
            let (xc, yc) = (position_mm(x, k, n), position_mm(y, k, n));
            csv.push_str(&format!(",{},{}", xc + offset, yc + offset));
        }
        csv.push('\n');
    }
    csv
}

/// The odd records tried, by the index of each factor's value: length (10, 40, 150 or 399
/// samples), X's and Y's motion ([`MOTIONS`]), how many samples the axes lag their commands
/// (0 to 3), the commands (none, on the program, or 471.103 mm off it as in machine
/// coordinates) and the sampling (1 kHz or 50 Hz). Sixteen records in which every pair of two
/// factors' values meets at least once (an orthogonal array of the four-valued factors, the
/// other two spread over it).
const ODD_RECORDS: [[usize; 6]; 16] = [
    [0, 0, 0, 0, 0, 1],
    [0, 1, 1, 2, 2, 1],
    [0, 2, 2, 3, 1, 1],
    [0, 3, 3, 1, 2, 0],
    [1, 0, 1, 1, 1, 0],
    [1, 1, 0, 3, 2, 0],
    [1, 2, 3, 2, 0, 1],
    [1, 3, 2, 0, 2, 0],
    [2, 0, 2, 2, 2, 0],
    [2, 1, 3, 0, 1, 0],
    [2, 2, 0, 1, 2, 1],
    [2, 3, 1, 3, 0, 1],
    [3, 0, 3, 3, 2, 1],
    [3, 1, 2, 1, 0, 0],
    [3, 2, 1, 0, 2, 0],
    [3, 3, 0, 2, 1, 0],
];

/// Reads, inspects, diagnoses and identifies the odd record `row` of [`ODD_RECORDS`]: any of
/// them may refuse it with an error, none may panic.
fn no_panic_on(row: usize) {
    let program = program_text("G21 G17 G90 G94\nG0 X0 Y0\nG1 X20 F1200\nY7.5\nG0 X0 Y0\nM2\n");
    let machine = MachineConfig::default_preset();
    let settings = DiagnoseSettings::for_machine(&machine);
    let [n, x, y, lag_samples, commands, step] = ODD_RECORDS[row];
    let n = [10, 40, 150, 399][n];
    let (x, y) = (MOTIONS[x], MOTIONS[y]);
    let commands = [None, Some(0.0), Some(471.103)][commands];
    let step_s = [1e-3, 0.02][step];
    // Named on the standard error, which the test's failure shows.
    eprintln!("{n} samples {step_s} s apart, {x:?} and {y:?}, {lag_samples} behind {commands:?}");
    let csv = record_csv(n, step_s, x, y, commands, lag_samples);
    let Ok(trace) = parse_trace(&csv, "odd.csv") else {
        return;
    };
    let _ = summarise(&trace).text();
    if let Ok(d) = diagnose(&program, &machine, &trace, &settings) {
        let _ = DiagnoseReport::new(&d, "odd.nc", &trace, &machine).to_string();
    }
    let _ = identify(&program, &machine, &trace, &settings.compare);
}

/// One test per odd record (the table's length is in its type: a row added needs its test
/// here), so that the records run side by side.
mod no_odd_record_makes_inspect_diagnose_or_identify_panic {
    macro_rules! records {
        ($($name:ident: $row:expr),* $(,)?) => {
            $(
                #[test]
                fn $name() {
                    super::no_panic_on($row);
                }
            )*
        };
    }

    records! {
        record_00: 0, record_01: 1, record_02: 2, record_03: 3,
        record_04: 4, record_05: 5, record_06: 6, record_07: 7,
        record_08: 8, record_09: 9, record_10: 10, record_11: 11,
        record_12: 12, record_13: 13, record_14: 14, record_15: 15,
    }
}

/// The program's own path (X to 20 mm, Y to 7.5 mm, a rapid back), at sample `k` of `n`:
/// standing for a fifth of the record at each end.
fn along_program_mm(k: usize, n: usize) -> [f64; 2] {
    let s = k as f64 / n.max(1) as f64;
    let f = |a: f64, b: f64| ((s - a) / (b - a)).clamp(0.0, 1.0);
    match s {
        s if s < 0.5 => [20.0 * f(0.2, 0.5), 0.0],
        s if s < 0.7 => [20.0, 7.5 * f(0.5, 0.7)],
        _ => [20.0 * (1.0 - f(0.7, 0.8)), 7.5 * (1.0 - f(0.7, 0.8))],
    }
}

/// A record that does follow the program, with its commands: `seconds` long, sampled every
/// `step_s`, the axes lagging by `lag_samples`. Far enough along for `identify` to fit, and
/// then its values, determined or not, are numbers and nothing panics.
fn identify_gets_past_its_checks_along_the_program(seconds: f64, step_s: f64, lag_samples: usize) {
    let program = program_text("G21 G17 G90 G94\nG0 X0 Y0\nG1 X20 F1200\nY7.5\nG0 X0 Y0\nM2\n");
    let machine = MachineConfig::default_preset();
    let settings = DiagnoseSettings::for_machine(&machine);
    let n = (seconds / step_s) as usize;
    let mut csv = String::from("t_s,x_mm,y_mm,x_cmd_mm,y_cmd_mm\n");
    for k in 0..n {
        let [xm, ym] = along_program_mm(k.saturating_sub(lag_samples), n);
        let [xc, yc] = along_program_mm(k, n);
        csv.push_str(&format!("{},{xm},{ym},{xc},{yc}\n", k as f64 * step_s));
    }
    let trace = parse_trace(&csv, "along.csv").unwrap();
    let _ = diagnose(&program, &machine, &trace, &settings);
    let case = format!("{seconds} s at {step_s} s, {lag_samples} behind");
    match identify(&program, &machine, &trace, &settings.compare) {
        Ok(id) => {
            // Every value written is a number; a value the record determines has a finite
            // uncertainty (one it does not is the template's, its uncertainty NaN).
            for v in id.axes.iter().flat_map(|a| &a.values) {
                assert!(v.value.is_finite(), "{case}: {v:?}");
                assert!(!v.fitted() || v.uncertainty.is_finite(), "{case}: {v:?}");
                assert!(v.fitted() || v.value == v.template, "{case}: {v:?}");
            }
        }
        Err(e) => {
            // Refusals are allowed only for what the record is (its kinked commands can
            // be beyond what the 6 t table follows), never for its shape.
            let e = e.to_string();
            assert!(
                !e.contains("no commands") && !e.contains("still"),
                "{case}: {e}"
            );
        }
    }
}

/// Records that follow the program at 1 kHz and 50 Hz, each rate with two lags; the two at
/// 1 kHz are records that once failed. One test each, so that they run side by side.
mod records_along_the_program_get_identify_past_its_checks {
    use super::identify_gets_past_its_checks_along_the_program as along;

    #[test]
    fn at_1_khz_3_behind() {
        along(2.4402356369088447, 1e-3, 3);
    }

    #[test]
    fn at_1_khz_1_behind() {
        along(2.142401907344457, 1e-3, 1);
    }

    #[test]
    fn at_50_hz_2_behind() {
        along(2.5, 0.02, 2);
    }

    #[test]
    fn at_50_hz_3_behind() {
        along(3.0, 0.02, 3);
    }
}
