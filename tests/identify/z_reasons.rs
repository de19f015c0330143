//! Where `identify` does not identify Z it says why, and the machine it writes keeps the
//! template's Z: a record without Z's commands, a template that carries Z without simulating
//! it, a loop model (`--template none`), and Z barely moving. One short record of the
//! independent reference (`common::reference`) serves all four: a line out in X, Y and Z and
//! back, Z going down 0.5 mm — half the travel Z's values need.

use crate::common;

use std::sync::OnceLock;

use common::program_text;
use common::reference::{Recording, record_xyz};
use contourcheck::compare::CompareSettings;
use contourcheck::identify::{Identification, identify, identify_loop, loop_template};
use contourcheck::machine::{AxisName, MachineConfig, PlannedAxis, ZAxis};
use contourcheck::trace::measured::{MeasuredTrace, parse_trace};

/// Out to X1.5 Y1.2 Z−0.5 and back at 3000 mm/min: X and Y just beyond the 1 mm their
/// values need (the loop model's search takes its time over every second of record).
const OUT_AND_BACK: &str =
    "G21 G90 G94 G17\nG0 X0 Y0 Z0\nG1 X1.5 Y1.2 Z-0.5 F3000\nG1 X0 Y0 Z0\nM2\n";
/// How far Z is commanded to move (µm): the program's depth.
const Z_TRAVEL_UM: f64 = 500.0;

/// The record's CSV, of the nominal machine.
fn csv() -> &'static str {
    static CSV: OnceLock<String> = OnceLock::new();
    CSV.get_or_init(|| {
        let m = MachineConfig::default_preset();
        let program = program_text(OUT_AND_BACK);
        record_xyz(
            &program,
            [&m.x, &m.y, m.axis(AxisName::Z)],
            &Recording::default(),
        )
    })
}

fn record() -> MeasuredTrace {
    parse_trace(csv(), "out-and-back.csv").unwrap()
}

fn identified(template: &MachineConfig, measured: &MeasuredTrace) -> Identification {
    let settings = CompareSettings::for_machine(template);
    identify(&program_text(OUT_AND_BACK), template, measured, &settings).unwrap()
}

/// The reason given, and the machine file written read back with the template's Z.
fn assert_not_identified(id: &Identification, template: &MachineConfig, reason: &str) {
    let why = id.z_not_identified.as_deref().unwrap_or_else(|| {
        panic!(
            "Z identified: {:?}",
            id.axes.iter().map(|a| a.axis).collect::<Vec<_>>()
        )
    });
    assert!(why.contains(reason), "{why}");
    assert!(id.axes.iter().all(|a| a.axis != AxisName::Z));
    let written = id.machine_file(template, "out-and-back.nc");
    let read = MachineConfig::from_toml_str(&written, "identified.toml").unwrap();
    assert_eq!(read.z, template.z, "{written}");
}

#[test]
fn without_z_commands_z_is_not_identified() {
    // The record as a logger without Z's command column would give it.
    let lines: Vec<String> = csv()
        .lines()
        .map(|l| l.rsplit_once(',').unwrap().0.to_owned())
        .collect();
    assert_eq!(lines[0], "t,x,y,z,x_cmd,y_cmd");
    let measured = parse_trace(&lines.join("\n"), "no-z-cmd.csv").unwrap();
    let template = MachineConfig::default_preset();
    let id = identified(&template, &measured);
    assert_not_identified(&id, &template, "the record holds no Z command");
}

#[test]
fn a_template_carrying_z_leaves_z_as_it_is() {
    let mut template = MachineConfig::default_preset();
    template.z = ZAxis::Carried(PlannedAxis {
        limits: template.z.limits().clone(),
    });
    let id = identified(&template, &record());
    assert_not_identified(
        &id,
        &template,
        "the template carries Z without simulating it",
    );
}

#[test]
fn a_loop_model_is_made_for_x_and_y_only() {
    let measured = record();
    let start = loop_template(&measured);
    let settings = CompareSettings::for_machine(&start);
    let id = identify_loop(&program_text(OUT_AND_BACK), &start, &measured, &settings).unwrap();
    // The loop model starts from a table that carries Z; the reason is the loop model's,
    // not a template's to fix.
    assert!(!start.simulates_z());
    assert_not_identified(
        &id,
        &start,
        "a loop model (--template none) is made for X and Y only",
    );
}

#[test]
fn z_moving_less_than_its_values_need_is_not_identified() {
    let template = MachineConfig::default_preset();
    let id = identified(&template, &record());
    assert_not_identified(
        &id,
        &template,
        &format!(
            "Z is commanded to move {Z_TRAVEL_UM:.1} µm over the stretch compared, less than the 1 mm"
        ),
    );
}
