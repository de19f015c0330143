//! `diagnose` on records as users bring them: placed on the program's timeline by their
//! recorded commands or by their own clock, in machine coordinates, at 50 Hz, with waits
//! longer than planned, of another program (refused with the reason), without a program,
//! and through the command line (`synth`, `diagnose`, `check` round trip; bad rows named).
//! The records are made as in `hidden_effects.rs`: a hidden effect, 0.3 µm of noise, a clock
//! offset nobody tells the diagnosis.

use crate::common;

use std::process::Command;

use common::cli::{run, run_ok};
use common::diagnosing::{recorded, sample_path};
use common::{program_text, sample_program as program};
use contourcheck::diagnose::causes::CauseId;
use contourcheck::diagnose::synth::{SynthSpec, synthesize};
use contourcheck::diagnose::{DiagnoseSettings, diagnose};
use contourcheck::machine::{AxisName, MachineConfig};
use contourcheck::trace::measured::parse_trace;

#[test]
fn recorded_commands_drive_the_simulation_and_fix_the_clock() {
    let nominal = MachineConfig::default_preset();
    let prog = program("square.nc");
    let spec = SynthSpec {
        effect: Some((CauseId::DeadTime, AxisName::Y, vec![5.0])),
        offset_s: 0.42,
        with_commands: true,
        ..SynthSpec::default()
    };
    let measured = recorded(&prog, &nominal, &spec, "trace.csv");
    assert!(measured.commands.is_some());
    let d = diagnose(
        &prog,
        &nominal,
        &measured,
        &DiagnoseSettings::for_machine(&nominal),
    )
    .unwrap();
    assert_eq!(
        d.causes.iter().map(|c| (c.id, c.axis)).collect::<Vec<_>>(),
        vec![(CauseId::DeadTime, AxisName::Y)]
    );
    assert!((d.causes[0].params[0].value - 5.0).abs() < 0.25);
    // The program starts where the recorded commands match the plan (to a command period).
    assert!((d.offset_s - 0.42).abs() < 0.003, "{}", d.offset_s);
}

#[test]
fn waits_longer_than_planned_are_measured_when_stretches_align_on_their_own() {
    // The real control checks a 3 µm in-position window where the plan assumes 10 µm: each
    // exact stop lasts ln(10/3)/Kv = 72.2 ms longer than planned.
    let nominal = MachineConfig::default_preset();
    let mut real = nominal.clone();
    real.interpolation.in_position_window_mm = 0.003;
    let prog = program("back-and-forth.nc");
    let spec = SynthSpec {
        effect: Some((CauseId::Backlash, AxisName::X, vec![10.0])),
        offset_s: 0.37,
        ..SynthSpec::default()
    };
    let measured = recorded(&prog, &real, &spec, "strokes.csv");
    // On the planned timeline the strokes drift away by 72 ms each: refused, with the way out.
    let mut settings = DiagnoseSettings::for_machine(&nominal);
    let e = diagnose(&prog, &nominal, &measured, &settings)
        .unwrap_err()
        .to_string();
    assert!(e.contains("--align-stretches"), "{e}");
    settings.compare.align_stretches = true;
    let d = diagnose(&prog, &nominal, &measured, &settings).unwrap();
    let expected_ms = (10.0f64 / 3.0).ln() / (1000.0 / 60.0) * 1e3;
    assert_eq!(d.extra_waits.len(), 3, "{:?}", d.extra_waits);
    for w in &d.extra_waits {
        assert!(
            (w.extra_ms - expected_ms).abs() < 1.0,
            "{w:?} vs {expected_ms:.1} ms"
        );
    }
    assert_eq!(
        d.causes.iter().map(|c| (c.id, c.axis)).collect::<Vec<_>>(),
        vec![(CauseId::Backlash, AxisName::X)]
    );
    assert!((d.causes[0].params[0].value - 10.0).abs() < 1.0);
    assert!(d.after.x.rms_um < 1.2 * d.noise_floor_um, "{:?}", d.after.x);
}

#[test]
fn a_measurement_of_another_program_is_rejected_with_the_reason() {
    let nominal = MachineConfig::default_preset();
    let measured = recorded(
        &program("square.nc"),
        &nominal,
        &SynthSpec::default(),
        "square-trace.csv",
    );
    let e = diagnose(
        &program("circle-test.nc"),
        &nominal,
        &measured,
        &DiagnoseSettings::for_machine(&nominal),
    )
    .unwrap_err();
    let message = e.to_string();
    assert!(
        message.starts_with("square-trace.csv: cannot align the measurement with the program"),
        "{message}"
    );
}

/// The first 0.1 s of a record whose program starts 0.5 s in: every command is the start
/// point, nothing moved. Nothing fits a model that holds still better than any other, so the
/// diagnosis refuses the record, as its first record and as the one it judges on; the same
/// record kept on to 1.2 s (the program's approach has run 0.7 s) is diagnosed.
#[test]
fn a_record_in_which_nothing_moves_is_refused() {
    use contourcheck::compare::CompareError;
    use contourcheck::diagnose::diagnose_validated;
    let nominal = MachineConfig::default_preset();
    let prog = program("small-circle.nc");
    let spec = SynthSpec {
        offset_s: 0.5,
        with_commands: true,
        ..SynthSpec::default()
    };
    let mut csv = Vec::new();
    synthesize(&prog, &nominal, &spec)
        .unwrap()
        .write_csv(&mut csv)
        .unwrap();
    let csv = String::from_utf8(csv).unwrap();
    // The header and the samples at t < `until_s` (2 ms apart).
    let cut = |until_s: f64| -> String {
        let n = (until_s / 0.002).round() as usize;
        csv.lines().take(1 + n).map(|l| format!("{l}\n")).collect()
    };
    let still = parse_trace(&cut(0.1), "still.csv").unwrap();
    let settings = DiagnoseSettings::for_machine(&nominal);
    let e = diagnose(&prog, &nominal, &still, &settings).unwrap_err();
    assert!(
        matches!(e, CompareError::NoMotion { travel_um, .. } if travel_um == [0.0, 0.0]),
        "{e}"
    );
    assert!(e.to_string().contains("the record holds no motion"), "{e}");
    let moving = parse_trace(&cut(1.2), "moving.csv").unwrap();
    let e = diagnose_validated(&prog, &nominal, &moving, Some(&still), &settings).unwrap_err();
    assert!(matches!(e, CompareError::NoMotion { .. }), "{e}");
    let d = diagnose(&prog, &nominal, &moving, &settings).unwrap();
    assert!(d.causes.is_empty(), "a nominal record");
}

/// A CNC trace in machine coordinates of a program run under a work offset: the commands
/// run beside the program by the offset, which the refusal measures and names; given with
/// the offset, the same record is diagnosed, and nothing is named on a nominal machine.
#[test]
fn a_trace_in_machine_coordinates_names_its_work_offset_and_is_diagnosed_with_it() {
    let nominal = MachineConfig::default_preset();
    let prog = program("square.nc");
    let spec = SynthSpec {
        offset_s: 0.2,
        with_commands: true,
        ..SynthSpec::default()
    };
    let work = recorded(&prog, &nominal, &spec, "machine.csv");
    let offset_m = [0.471103, -0.25];
    let mut machine = work.clone();
    for (values, o) in [
        (&mut machine.x_m, offset_m[0]),
        (&mut machine.y_m, offset_m[1]),
    ] {
        values.iter_mut().for_each(|v| *v += o);
    }
    let [xc, yc] = machine.commands.as_mut().unwrap();
    xc.iter_mut().for_each(|v| *v += offset_m[0]);
    yc.iter_mut().for_each(|v| *v += offset_m[1]);
    let settings = DiagnoseSettings::for_machine(&nominal);
    let e = diagnose(&prog, &nominal, &machine, &settings)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("offset by X 471.103 mm, Y -250.000 mm")
            && e.contains("--work-offset 471.103,-250.000"),
        "{e}"
    );
    let shifted = machine.in_work_coordinates(offset_m);
    assert!(
        shifted
            .layout
            .describe()
            .join("\n")
            .contains("work offset X 471.103 mm")
    );
    let d = diagnose(&prog, &nominal, &shifted, &settings).unwrap();
    assert!(d.causes.is_empty(), "{:?}", d.causes);
    // A record of another program is not mistaken for a shifted one.
    let other = recorded(&program("circle-test.nc"), &nominal, &spec, "other.csv");
    let e = diagnose(&prog, &nominal, &other, &settings)
        .unwrap_err()
        .to_string();
    assert!(!e.contains("--work-offset"), "{e}");
}

/// A 50 Hz servo trace in machine coordinates of a program that is mostly rapids (two
/// rapids of 200 mm around a 20 mm cut): with the work offset, it is diagnosed rapids and
/// all — left out, they would leave too little of the record — and on the nominal machine
/// nothing is named.
#[test]
fn a_mostly_rapid_50_hz_trace_in_machine_coordinates_is_diagnosed() {
    let nominal = MachineConfig::default_preset();
    let text = "G21 G90 G17 G94\nG0 X0 Y0\nG0 X200 Y100\nG1 X220 F1000\nG0 X0 Y0\nM2\n";
    let prog = program_text(text);
    let spec = SynthSpec {
        offset_s: 0.2,
        sample_s: 0.02,
        with_commands: true,
        ..SynthSpec::default()
    };
    let offset_m = [0.471103, -0.25];
    let mut machine = recorded(&prog, &nominal, &spec, "machine.csv");
    for (values, o) in [
        (&mut machine.x_m, offset_m[0]),
        (&mut machine.y_m, offset_m[1]),
    ] {
        values.iter_mut().for_each(|v| *v += o);
    }
    for (values, o) in machine.commands.as_mut().unwrap().iter_mut().zip(offset_m) {
        values.iter_mut().for_each(|v| *v += o);
    }
    let settings = DiagnoseSettings::for_machine(&nominal);
    let shifted = machine.in_work_coordinates(offset_m);
    let d = diagnose(&prog, &nominal, &shifted, &settings).unwrap();
    assert!(d.rapids_compared);
    assert!(d.causes.is_empty(), "{:?}", d.causes);
    // Most of the record is compared: its rapids are.
    assert!(
        d.samples as f64 > 0.8 * shifted.len() as f64,
        "{} of {}",
        d.samples,
        shifted.len()
    );
    // The machine's own plan stays within its file's limits: nothing is beyond it.
    assert!(d.beyond_machine.is_empty(), "{:?}", d.beyond_machine);
}

/// A control that interpolates 0.2 % slower than the plan, recorded without its commands:
/// one clock offset cannot fit both ends, and the refusal measures how far the timing
/// departs — the halves' centres lie 40 s apart, so 80 ms.
#[test]
fn a_record_whose_timing_departs_from_the_plan_is_refused_with_the_drift() {
    let nominal = MachineConfig::default_preset();
    let spec = SynthSpec {
        offset_s: 0.4,
        ..SynthSpec::default()
    };
    let mut csv = Vec::new();
    let mut truth = synthesize(&program("circle-test.nc"), &nominal, &spec).unwrap();
    for row in &mut truth.rows {
        row[0] *= 1.002;
    }
    truth.write_csv(&mut csv).unwrap();
    let measured = parse_trace(std::str::from_utf8(&csv).unwrap(), "slow.csv").unwrap();
    let message = diagnose(
        &program("circle-test.nc"),
        &nominal,
        &measured,
        &DiagnoseSettings::for_machine(&nominal),
    )
    .unwrap_err()
    .to_string();
    let drift: f64 = message
        .split("second half runs ")
        .nth(1)
        .and_then(|rest| rest.split(" ms").next())
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("{message}"));
    assert!((drift - 80.0).abs() < 5.0, "{message}");
}

/// A record of another program, without its commands: the refusal says the path is not this
/// program's, and does not send the user to align waits that cannot mend it.
#[test]
fn a_record_of_another_program_is_not_sent_to_align_its_waits() {
    let nominal = MachineConfig::default_preset();
    let other = recorded(
        &program("square.nc"),
        &nominal,
        &SynthSpec::default(),
        "square.csv",
    );
    let e = diagnose(
        &program("circle-test.nc"),
        &nominal,
        &other,
        &DiagnoseSettings::for_machine(&nominal),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("no timing can mend that"), "{e}");
    assert!(
        !e.contains("--align-stretches") && !e.contains("timing departs"),
        "{e}"
    );
}

/// A record with its commands and no program (a lab's own trajectory): compared with the
/// path its commands drew, the hidden backlash is found as with the program; without
/// commands there is no path, and the refusal says what to give.
#[test]
fn a_record_with_its_commands_is_diagnosed_without_its_program() {
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let circle = sample_path("circle-test.nc");
    let run = |args: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_contourcheck"))
            .args(args)
            .env("CI", "1")
            .output()
            .unwrap()
    };
    let synth = |out: &str, commands: bool| {
        let mut args = vec![
            "synth",
            circle.to_str().unwrap(),
            "--out",
            out,
            "--effect",
            "backlash",
            "--axis",
            "y",
            "--values",
            "12",
        ];
        if commands {
            args.push("--with-commands");
        }
        let o = run(&args);
        assert_eq!(
            o.status.code(),
            Some(0),
            "{}",
            String::from_utf8_lossy(&o.stderr)
        );
    };
    synth(&p("with.csv"), true);
    let o = run(&[
        "diagnose",
        "--measured",
        &p("with.csv"),
        "--json",
        &p("d.json"),
    ]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{stderr}");
    assert!(stderr.contains("no program given: compared with the path its commands drew"));
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(p("d.json")).unwrap()).unwrap();
    assert_eq!(report["causes"][0]["id"], "backlash", "{report}");
    assert_eq!(report["causes"][0]["axis"], "y");
    let backlash = report["causes"][0]["params"][0]["value"].as_f64().unwrap();
    assert!((backlash - 12.0).abs() < 1.0, "{backlash}");
    synth(&p("without.csv"), false);
    let o = run(&["diagnose", "--measured", &p("without.csv")]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("no program given and no commands recorded")
    );
}

/// The diagnosis's JSON at `path` names backlash on Y in µm, which lowers the residual, and
/// carries the ballbar figures measured and by the extended model.
fn assert_backlash_on_y_in_the_json(path: &str) {
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    assert_eq!(report["schema"], "contourcheck.diagnose/1");
    assert_eq!(report["causes"][0]["id"], "backlash");
    assert_eq!(report["causes"][0]["axis"], "y");
    assert_eq!(report["causes"][0]["params"][0]["unit"], "µm");
    assert!(
        report["causes"][0]["rms_after_um"].as_f64().unwrap()
            < report["causes"][0]["rms_before_um"].as_f64().unwrap()
    );
    // The ballbar figures, measured and by both models, in the JSON; a polar plot a circle.
    let measured_circles = report["circular_test"]["measured"]["circles"]
        .as_array()
        .unwrap();
    assert_eq!(measured_circles.len(), 2);
    assert!(
        report["circular_test"]["extended"]["pairs"][0]["h_um"]
            .as_f64()
            .unwrap()
            > 0.0
    );
}

/// Each of `names` in `folder` is a plot written whole (over 1 kB).
fn assert_plots_written(folder: &std::path::Path, names: &[&str]) {
    for plot in names {
        assert!(folder.join(plot).metadata().unwrap().len() > 1000, "{plot}");
    }
}

#[test]
fn the_command_line_round_trip_synth_diagnose_check() {
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let circle = sample_path("circle-test.nc");
    let circle = circle.to_str().unwrap();
    run_ok(&[
        "synth",
        circle,
        "--out",
        &p("m.csv"),
        "--effect",
        "backlash",
        "--axis",
        "y",
        "--values",
        "12",
    ]);
    let o = run_ok(&[
        "diagnose",
        circle,
        "--measured",
        &p("m.csv"),
        "--json",
        &p("d.json"),
        "--write-machine",
        &p("fitted.toml"),
        "--plot",
        &p("plots"),
    ]);
    let shown = String::from_utf8_lossy(&o.stdout);
    assert!(shown.contains("backlash on Y"));
    // One story: the ballbar's small backlash step beside the 12 µm named is explained.
    assert!(
        shown.contains("The ballbar's backlash figure for Y") && shown.contains("reversal spikes"),
        "{shown}"
    );
    // Every file written is said.
    assert!(
        shown.contains(&format!("wrote {}", p("fitted.toml"))),
        "{shown}"
    );
    assert_backlash_on_y_in_the_json(&p("d.json"));
    assert_plots_written(
        &dir.path().join("plots"),
        &[
            "diagnose-fit.png",
            "diagnose-residual-time.svg",
            "diagnose-residual-path.png",
            "diagnose-polar-line13.png",
            "diagnose-polar-line16.svg",
        ],
    );
    // The fitted machine loads and predicts with the backlash.
    let fitted = MachineConfig::load(&dir.path().join("fitted.toml")).unwrap();
    assert!(
        (fitted.y.drive.backlash_um - 12.0).abs() < 1.0,
        "{}",
        fitted.y.drive.backlash_um
    );
    run_ok(&["check", circle, "--machine", &p("fitted.toml")]);
    // A control names nothing and says so; the JSON has an empty list.
    let o = run(&["synth", circle, "--out", &p("n.csv"), "--seed", "3"]);
    assert_eq!(o.status.code(), Some(0));
    let o = run(&[
        "diagnose",
        circle,
        "--measured",
        &p("n.csv"),
        "--json",
        &p("n.json"),
    ]);
    assert!(String::from_utf8_lossy(&o.stdout).contains("No significant cause"));
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(p("n.json")).unwrap()).unwrap();
    assert_eq!(report["causes"].as_array().unwrap().len(), 0);
}

#[test]
fn bad_measured_data_names_the_row_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.csv");
    let mut text = String::from("t_s,x_mm,y_mm\n");
    for k in 0..50 {
        let t = if k == 30 { 0.05 } else { k as f64 * 0.002 };
        text.push_str(&format!("{t},{},0\n", k as f64 * 0.01));
    }
    std::fs::write(&bad, text).unwrap();
    let json = dir.path().join("d.json");
    let o = Command::new(env!("CARGO_BIN_EXE_contourcheck"))
        .args([
            "diagnose",
            sample_path("square.nc").to_str().unwrap(),
            "--measured",
            bad.to_str().unwrap(),
            "--json",
            json.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("bad.csv: row 32"), "{err}");
    assert!(!json.exists());
}

/// The small circle recorded with its commands on the nominal machine: the commands reach
/// the circle's start while the table still settles from the approach rapid (the control
/// waits there for the in-position check). The circle's figures come from the samples
/// whose command runs along the circle: the radial deviation is the position loop's steady
/// lag on a circle, v²/(2·R·Kv²) inward (a first-order loop lags v/Kv in time; on radius R
/// that chord falls short of the circle by R(1 − cos(v/(R·Kv)))), and G cannot exceed it
/// by more than the friction spikes and the noise, nor does a square machine show an ellipse
/// along the diagonals.
#[test]
fn a_circle_recorded_with_its_commands_is_measured_from_where_its_commands_set_off() {
    let nominal = MachineConfig::default_preset();
    assert_eq!(nominal.x.position_loop.velocity_feedforward, 0.0);
    let prog = program("small-circle.nc");
    let spec = SynthSpec {
        offset_s: 0.5,
        with_commands: true,
        ..SynthSpec::default()
    };
    let measured = recorded(&prog, &nominal, &spec, "nom.csv");
    let d = diagnose(
        &prog,
        &nominal,
        &measured,
        &DiagnoseSettings::for_machine(&nominal),
    )
    .unwrap();
    // R10 at F800; Kv in 1/s from m/min/mm.
    let (v, r) = (0.8 / 60.0, 0.010);
    let kv = nominal.x.position_loop.kv_m_per_min_per_mm * 1000.0 / 60.0;
    let lag_um = v * v / (2.0 * r * kv * kv) * 1e6;
    assert!((lag_um - 32.0).abs() < 0.1, "{lag_um}");
    let test = &d.circular.measured;
    assert_eq!(test.circles.len(), 2, "{test:?}");
    for c in &test.circles {
        // The steady lag, within the 0.3 µm noise and the friction's few µm at reversals.
        assert!(
            (c.f_min_um + lag_um).abs() < 0.1 * lag_um,
            "{c:?} against {lag_um}"
        );
        assert!(c.g_um < 1.1 * lag_um, "{c:?} against {lag_um}");
    }
    // 20 µrad on R10 is an ellipse of ±0.1 µm, a third of the record's noise.
    let pair = test.pairs[0];
    assert!(pair.squareness_urad.abs() < 20.0, "{pair:?}");
    // A lag the same at every angle is no ellipse along the axes either: well under 1 % of
    // lag/R (3200 ppm), which the entry transient, left in, would reach a quarter of.
    let lag_over_radius_ppm = lag_um / (r * 1e6) * 1e6;
    assert!(
        pair.scale_mismatch_ppm.abs() < 0.01 * lag_over_radius_ppm,
        "{pair:?}"
    );
}
