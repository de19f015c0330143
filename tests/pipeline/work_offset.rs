//! A record in machine coordinates brought without its work offset: refused with the offset
//! to give, found from the record and the program alone. The records are written by hand
//! here — the commands at constant speed along straight lines, sampled every 2 ms, the
//! measured positions equal to them (the refusal comes before any simulation) —, not by
//! this tool's planner.

use contourcheck::compare::CompareSettings;
use contourcheck::gcode::{InterpretOptions, Program, parse_program};
use contourcheck::identify::identify;
use contourcheck::machine::MachineConfig;
use contourcheck::trace::measured::parse_trace;

/// The program: from its origin along X, up Y, along X again — the last move is the first's
/// shape at another place.
const PROGRAM: &str = "G21 G90 G17 G61\nG0 X0 Y0\nG1 X10 Y0 F600\nG1 X10 Y10\nG1 X20 Y10\nM30\n";
/// The work offset (mm): the program's origin in the machine's coordinates.
const OFFSET_MM: [f64; 2] = [100.0, 50.0];
/// The machine's home (mm, machine coordinates).
const HOME_MM: [f64; 2] = [300.0, 200.0];
const DT_S: f64 = 0.002;

fn program() -> Program {
    parse_program(PROGRAM, "offset.nc", &InterpretOptions::default()).unwrap()
}

/// A CSV record of the commands through `stops` (machine coordinates, mm), each reached at
/// `speed` mm/s and held `hold_s`.
fn record(stops: &[([f64; 2], f64)], hold_s: f64) -> String {
    let stops: Vec<([f64; 3], f64)> = stops.iter().map(|&(p, v)| ([p[0], p[1], 0.0], v)).collect();
    let rows = rows_through([HOME_MM[0], HOME_MM[1], 0.0], &stops, hold_s);
    let mut csv = String::from("t_s,x_mm,y_mm,x_cmd_mm,y_cmd_mm\n");
    for (k, p) in rows.iter().enumerate() {
        let t = k as f64 * DT_S;
        csv.push_str(&format!(
            "{t:.4},{:.6},{:.6},{:.6},{:.6}\n",
            p[0], p[1], p[0], p[1]
        ));
    }
    csv
}

/// The same in space, with Z's positions and commands.
fn record_with_z(home: [f64; 3], stops: &[([f64; 3], f64)], hold_s: f64) -> String {
    let rows = rows_through(home, stops, hold_s);
    let mut csv = String::from("t_s,x_mm,y_mm,x_cmd_mm,y_cmd_mm,z_mm,z_cmd_mm\n");
    for (k, p) in rows.iter().enumerate() {
        let t = k as f64 * DT_S;
        csv.push_str(&format!(
            "{t:.4},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6}\n",
            p[0], p[1], p[0], p[1], p[2], p[2]
        ));
    }
    csv
}

/// The command every 2 ms: standing at `home` for `hold_s`, then along straight lines
/// through `stops`, each at its speed (mm/s) and held `hold_s`.
fn rows_through(home: [f64; 3], stops: &[([f64; 3], f64)], hold_s: f64) -> Vec<[f64; 3]> {
    let hold = (hold_s / DT_S).round() as usize;
    let mut rows = vec![home; hold + 1];
    let mut at = home;
    for &(to, speed) in stops {
        let length = (0..3).map(|i| (to[i] - at[i]).powi(2)).sum::<f64>().sqrt();
        let steps = (length / speed / DT_S).ceil() as usize;
        for k in 1..=steps {
            let s = k as f64 / steps as f64;
            rows.push([0, 1, 2].map(|i| at[i] + s * (to[i] - at[i])));
        }
        rows.extend(std::iter::repeat_n(to, hold));
        at = to;
    }
    rows
}

/// The program's point (mm) in machine coordinates.
fn machine(p: [f64; 2]) -> [f64; 2] {
    [p[0] + OFFSET_MM[0], p[1] + OFFSET_MM[1]]
}

fn refusal(csv: &str) -> String {
    let template = MachineConfig::preset("small-table").unwrap();
    let measured = parse_trace(csv, "machine.csv").unwrap();
    let settings = CompareSettings::for_machine(&template);
    identify(&program(), &template, &measured, &settings)
        .expect_err("machine coordinates are not the program's")
        .to_string()
}

#[test]
fn a_record_of_the_whole_program_is_told_its_offset() {
    let stops = [
        (machine([0.0, 0.0]), 200.0),
        (machine([10.0, 0.0]), 10.0),
        (machine([10.0, 10.0]), 10.0),
        (machine([20.0, 10.0]), 10.0),
    ];
    let said = refusal(&record(&stops, 0.1));
    assert!(said.contains("--work-offset 100.000,50.000"), "{said}");
    assert!(!said.contains("as well"), "{said}");
}

#[test]
fn a_record_of_the_programs_start_is_told_its_offset_and_what_else_fits() {
    // From home to the program's origin, then 3 mm of the first move along X: the last
    // move, also along X from a standstill, fits a record begun there with the offset
    // shifted back by its start, (10, 10).
    let stops = [(machine([0.0, 0.0]), 200.0), (machine([3.0, 0.0]), 10.0)];
    let said = refusal(&record(&stops, 0.1));
    assert!(
        said.contains("--work-offset 100.000,50.000") && said.contains("program's start"),
        "{said}"
    );
    assert!(said.contains("X 90.000 mm, Y 40.000 mm"), "{said}");
}

#[test]
fn a_record_of_another_shape_is_not_told_an_offset() {
    // A diagonal the program never makes, at any offset.
    let stops = [(machine([0.0, 0.0]), 200.0), (machine([5.0, 5.0]), 10.0)];
    let said = refusal(&record(&stops, 0.1));
    assert!(!said.contains("--work-offset"), "{said}");
    assert!(said.contains("in the same coordinates?"), "{said}");
}

#[test]
fn a_record_with_z_is_told_its_offset_at_the_height_its_stops_stand() {
    // The program passes its origin at three heights (the start, a clearance, the plunge)
    // and plunges again at X20 before cutting along X once more. In machine coordinates
    // (offset 100, 50, −200 mm) the record comes from home to the clearance, plunges, and
    // cuts 3 mm: its two stops lie on the program's points only at the right height, which
    // the second plunge's place does not match in the plane.
    let program = "G21 G90 G17\nG0 X0 Y0 Z0\nG0 Z5\nG1 Z-1 F300\nG1 X10 F600\nG0 Z5\n\
                   G0 X20\nG1 Z-1 F300\nG1 X30 F600\nM30\n";
    let program = parse_program(program, "plunge.nc", &InterpretOptions::default()).unwrap();
    let at = |x: f64, z: f64| [x + OFFSET_MM[0], OFFSET_MM[1], z - 200.0];
    let stops = [
        (at(0.0, 5.0), 200.0),
        (at(0.0, -1.0), 5.0),
        (at(3.0, -1.0), 10.0),
    ];
    let csv = record_with_z([HOME_MM[0], HOME_MM[1], 0.0], &stops, 0.1);
    let template = MachineConfig::preset("small-table").unwrap();
    let measured = parse_trace(&csv, "machine.csv").unwrap();
    let settings = CompareSettings::for_machine(&template);
    let said = identify(&program, &template, &measured, &settings)
        .expect_err("machine coordinates are not the program's")
        .to_string();
    assert!(said.contains("--work-offset 100.000,50.000"), "{said}");
}

#[test]
fn the_offset_told_puts_the_record_on_the_program() {
    // Given back as the hint says, the record of the program's start is compared: no
    // longer refused for its coordinates.
    let stops = [(machine([0.0, 0.0]), 200.0), (machine([3.0, 0.0]), 10.0)];
    let template = MachineConfig::preset("small-table").unwrap();
    let measured = parse_trace(&record(&stops, 0.1), "machine.csv")
        .unwrap()
        .in_work_coordinates(OFFSET_MM.map(|v| v * 1e-3));
    let settings = CompareSettings::for_machine(&template);
    if let Err(e) = identify(&program(), &template, &measured, &settings) {
        assert!(!e.to_string().contains("leave the program's path"), "{e}");
    }
}
