//! A record with Z, as a three-axis control's trace has it: its `z` and `z_cmd` columns are
//! read, how far Z moves over the stretch compared is reported, and the analysis of X and Y
//! is the one the same record without Z gets. On a machine that carries Z without
//! simulating it, Z is read, not compared or fitted; where Z is simulated it is compared
//! (z_records.rs beside this file), and Z that no servo could give names nothing.
//!
//! The Z the tests write is their own: a steady descent at a known rate, so the travel the
//! report must give follows from the times it compared.

use contourcheck::diagnose::synth::{SynthSpec, synthesize};
use contourcheck::diagnose::{DiagnoseSettings, Diagnosis, diagnose};
use contourcheck::gcode::{InterpretOptions, Program, parse_program};
use contourcheck::machine::{MachineConfig, PlannedAxis, ZAxis};
use contourcheck::trace::measured::{MeasuredTrace, parse_trace};
use contourcheck::{DiagnoseReport, ReportInputs, diagnose_page};

/// A square at one height, 20 mm a side at F1000: a few seconds of X and Y.
const SQUARE: &str =
    "G21 G90 G17\nG0 X0 Y0 Z1\nG1 Z0 F500\nG1 X20 F1000\nG1 Y20\nG1 X0\nG1 Y0\nM30\n";

/// Z as the test's record has it (mm) at time `t_s` on the record's clock: 3 mm above the
/// part, going down at 0.25 mm/s.
fn z_mm(t_s: f64) -> f64 {
    3.0 - 0.25 * t_s
}

fn program() -> Program {
    parse_program(SQUARE, "square.nc", &InterpretOptions::default()).unwrap()
}

/// The square on the nominal machine, recorded with its commands as CSV text.
fn record_text() -> String {
    let spec = SynthSpec {
        with_commands: true,
        offset_s: 0.2,
        ..SynthSpec::default()
    };
    let mut csv = Vec::new();
    synthesize(&program(), &MachineConfig::default_preset(), &spec)
        .unwrap()
        .write_csv(&mut csv)
        .unwrap();
    String::from_utf8(csv).unwrap()
}

/// The record with a measured and a commanded Z column added (the measured 2 µm behind).
fn with_z(text: &str) -> String {
    let mut lines = text.lines();
    let header = lines.next().unwrap();
    let mut out = format!("{header},z_mm,z_cmd_mm\n");
    for line in lines {
        let t: f64 = line.split(',').next().unwrap().parse().unwrap();
        let z = z_mm(t);
        out.push_str(&format!("{line},{:.6},{z:.6}\n", z + 0.002));
    }
    out
}

/// The preset with its Z carried: planned, not simulated.
fn carrying_z() -> MachineConfig {
    let mut m = MachineConfig::default_preset();
    m.z = ZAxis::Carried(PlannedAxis {
        limits: m.z.limits().clone(),
    });
    m
}

fn diagnosed(trace: &MeasuredTrace) -> Diagnosis {
    diagnosed_on(trace, &carrying_z())
}

fn diagnosed_on(trace: &MeasuredTrace, nominal: &MachineConfig) -> Diagnosis {
    diagnose(
        &program(),
        nominal,
        trace,
        &DiagnoseSettings::for_machine(nominal),
    )
    .unwrap()
}

#[test]
fn a_records_z_is_read_its_travel_reported_and_x_and_y_analysed_as_without_it() {
    let plain = record_text();
    let xy = parse_trace(&plain, "xy.csv").unwrap();
    let xyz = parse_trace(&with_z(&plain), "xyz.csv").unwrap();
    assert!(xy.z_m.is_none() && xy.z_cmd_m.is_none());
    // The columns read as written, in metres, sample by sample.
    let (z, z_cmd) = (xyz.z_m.as_ref().unwrap(), xyz.z_cmd_m.as_ref().unwrap());
    assert_eq!(z.len(), xyz.len());
    for k in [0, xyz.len() / 2, xyz.len() - 1] {
        let t = xyz.t0_s + k as f64 * xyz.dt_s;
        assert!((z_cmd[k] - z_mm(t) * 1e-3).abs() < 1e-9, "{k}");
        assert!((z[k] - (z_mm(t) + 0.002) * 1e-3).abs() < 1e-9, "{k}");
    }
    let (a, b) = (diagnosed(&xy), diagnosed(&xyz));
    // Z changes nothing of X and Y's analysis.
    assert_eq!(a.before, b.before);
    assert_eq!(a.causes.len(), b.causes.len());
    assert_eq!(a.coverage.z_span_mm, None);
    // The travel over the stretch compared, from the commanded Z the test wrote there.
    let c = b.coverage;
    let [lo, hi] = c.z_span_mm.unwrap();
    let (first, last) = (z_mm(c.compared_from_s), z_mm(c.compared_to_s));
    assert!(
        (hi - first).abs() < 1e-6 && (lo - last).abs() < 1e-6,
        "{c:?}"
    );
    assert!(hi - lo > 0.5, "{c:?}");
    let said = c.to_string();
    assert!(
        said.contains(&format!("Z: moves {:.3} mm", hi - lo)),
        "{said}"
    );
    assert!(said.contains("not compared, diagnosed or fitted"), "{said}");
    assert!(!a.coverage.to_string().contains("Z:"));
    let z = b.z.describe().join("\n");
    assert!(
        z.contains("Z: not compared: the machine file carries Z"),
        "{z}"
    );
    assert!(a.z.describe().is_empty());
    // Where Z is not compared (a record without it, or Z carried) the figures have no Z panel.
    for (d, trace) in [(&a, &xy), (&b, &xyz)] {
        assert!(d.z.series.is_none());
        let report = DiagnoseReport::new(d, "square.nc", trace, &carrying_z());
        let page = diagnose_page(d, &report, &ReportInputs::default()).unwrap();
        assert!(page.contains("X axis: position − command"));
        assert!(!page.contains("Z axis:"));
    }
}

#[test]
fn where_z_is_simulated_the_records_z_is_compared_with_it() {
    // The test's Z descends at 0.25 mm/s and reads 2 µm above its command: a lag of 2 µm,
    // where the preset's Kv (1 m/min/mm, 16.7 /s) lags v / Kv = 15 µm. The comparison shows
    // the difference, 13 µm; a gain on Z can only explain it by being higher than set.
    let preset = MachineConfig::default_preset();
    let xyz = parse_trace(&with_z(&record_text()), "xyz.csv").unwrap();
    let d = diagnosed_on(&xyz, &preset);
    assert!(d.z.compared, "{:?}", d.z);
    let lag_um = 0.25e-3 / (1000.0 / 60.0) * 1e6;
    assert!(
        (d.z.before_peak_um - (lag_um - 2.0)).abs() < 0.5,
        "{:?}, lag {lag_um}",
        d.z
    );
    // A pure gain error would lag v / Kv: 2 µm at 0.25 mm/s is Kv = 125 /s (7.5 m/min/mm,
    // 7.5 times the set one), which the gain's fit does not reach: it stops near 2.8
    // m/min/mm, far from the set one, leaving a quarter of Z's residual (RMS) on a record
    // without noise — a value bent to what the gain cannot explain: not named, and said why.
    assert!(d.z.cause.is_none(), "{:?}", d.z);
    let kv =
        d.z.not_named
            .iter()
            .find(|n| n.id == contourcheck::diagnose::causes::CauseId::KvGain)
            .unwrap_or_else(|| panic!("{:?}", d.z));
    assert!(
        kv.reason.starts_with("not determined") && kv.reason.contains("of Z's residual"),
        "{}",
        kv.reason
    );
    assert!(!d.z.describe().join("\n").contains("found on Z"));
    assert!(d.causes.is_empty(), "{:?}", d.causes);
}

#[test]
fn a_standing_z_in_a_record_is_not_worth_a_word() {
    let plain = record_text();
    let mut lines = plain.lines();
    let mut text = format!("{},Z_ActPos\n", lines.next().unwrap());
    for line in lines {
        text.push_str(&format!("{line},-12.5\n"));
    }
    let trace = parse_trace(&text, "standing.csv").unwrap();
    assert!(trace.z_cmd_m.is_none());
    assert!(trace.z_m.as_ref().unwrap().iter().all(|&z| z == -12.5e-3));
    let c = diagnosed(&trace).coverage;
    assert_eq!(c.z_span_mm, Some([-12.5, -12.5]));
    assert!(!c.to_string().contains("Z:"));
}
