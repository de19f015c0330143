//! `identify` on a record that measured Z, taken by the independent reference of
//! `common::reference` (its own integrator and interpolator, a vertical Z carrying its
//! weight, the commands recorded beside the positions): a helix down and back up, which
//! moves X and Y on circles and Z on two ramps with a reversal between them. The machine
//! is the nominal one but for Z's position gain, 8 % low: identify finds it on Z within
//! its uncertainty, writes it in the machine file, and leaves X and Y at their values.

mod common;

use common::program_text;
use common::reference::{Recording, record_xyz};
use contourcheck::compare::CompareSettings;
use contourcheck::identify::{AxisIdentification, identify};
use contourcheck::machine::{AxisName, MachineConfig};
use contourcheck::trace::measured::parse_trace;

/// A turn of 6 mm radius about X0 Y0 down 3 mm in Z, and the same turn back up the other
/// way, at 2000 mm/min: 2.3 s of motion.
const HELIX_DOWN_AND_UP: &str = "G21 G90 G94 G17\nG0 X6 Y0 Z0\nG3 X6 Y0 Z-3 I-6 J0 F2000\n\
                                 G2 X6 Y0 Z0 I-6 J0\nM2\n";

/// Z's position gain in the record, against the nominal 1.0 m/min/mm.
const LOW_KV: f64 = 0.92;
const KV_KEY: &str = "position_loop.kv_m_per_min_per_mm";

fn value(axis: &AxisIdentification, key: &str) -> (f64, f64, bool) {
    let v = axis
        .values
        .iter()
        .find(|v| v.key == key)
        .unwrap_or_else(|| panic!("{key} not in {:?}", axis.values));
    (v.value, v.uncertainty, v.determined)
}

#[test]
fn a_low_gain_on_z_is_identified_on_z_and_x_and_y_keep_their_values() {
    let program = program_text(HELIX_DOWN_AND_UP);
    let template = MachineConfig::default_preset();
    let mut truth = template.clone();
    truth
        .axis_mut(AxisName::Z)
        .position_loop
        .kv_m_per_min_per_mm = LOW_KV;
    let csv = record_xyz(
        &program,
        [&truth.x, &truth.y, truth.axis(AxisName::Z)],
        &Recording::default(),
    );
    let measured = parse_trace(&csv, "helix.csv").unwrap();
    let settings = CompareSettings::for_machine(&template);
    let id = identify(&program, &template, &measured, &settings).unwrap();
    assert_eq!(id.z_not_identified, None);
    let axes: Vec<AxisName> = id.axes.iter().map(|a| a.axis).collect();
    assert_eq!(axes, [AxisName::X, AxisName::Y, AxisName::Z]);

    // Z's gain: its lag on the ramps, v/Kv, is 8.7 % longer than the template's — about
    // 15 µm at the ramps' 2.65 mm/s against 0.3 µm of noise.
    let z = &id.axes[2];
    let (kv, sigma, determined) = value(z, KV_KEY);
    assert!(determined, "{z:?}");
    assert!(
        (kv - LOW_KV).abs() <= 2.0 * sigma && sigma < 0.02,
        "Z: {kv} ± {sigma}"
    );
    let written = id.machine_file(&template, "helix.nc");
    let read = MachineConfig::from_toml_str(&written, "identified.toml").unwrap();
    let z_kv = read.axis(AxisName::Z).position_loop.kv_m_per_min_per_mm;
    assert!((z_kv - kv).abs() < 1e-3 * kv, "written {z_kv}, found {kv}");

    // X and Y ran the template's values: every value the record determines lies within
    // three of its uncertainties of the template's, and so does what is written.
    for a in &id.axes[..2] {
        for v in a.values.iter().filter(|v| v.determined) {
            assert!(
                (v.value - v.template).abs() <= 3.0 * v.uncertainty,
                "{}: {v:?}",
                a.axis
            );
        }
        let read_kv = read.axis(a.axis).position_loop.kv_m_per_min_per_mm;
        let (kv, sigma, _) = value(a, KV_KEY);
        assert!(
            (read_kv - 1.0).abs() <= (3.0 * sigma).max(1e-9) || read_kv == 1.0,
            "{}: written {read_kv}, found {kv} ± {sigma}",
            a.axis
        );
    }
}

/// A turn in XY at one height between plunges and retracts of Z alone at 1000 mm/min:
/// Z starts and stops eight times.
const PLUNGES: &str = "G21 G90 G94 G17\nG0 X3 Y0 Z0\nG1 Z-3 F1000\nG3 X3 Y0 I-3 J0 F2000\n\
                       G1 Z0 F1000\nG1 Z-3\nG1 Z0\nM2\n";

#[test]
fn z_s_acceleration_limit_is_read_where_the_record_holds_it_below_the_demand() {
    // The reference's interpolator ramps every block at 0.2 m/s²: a plunge of Z alone
    // accelerates Z at that, flat for 83 ms (16.7 mm/s over 0.2 m/s²), at each of its eight
    // starts and stops. The template's planner would ask more: its jerk limit (5 m/s³) lets
    // a move that reaches only v = 16.7 mm/s accelerate at √(v·jerk) = 0.289 m/s², below Z's
    // 0.5 m/s² limit. The control's limit is 0.2, written as Z's; its jerk is a step (no
    // jerk limit): not read.
    let program = program_text(PLUNGES);
    let template = MachineConfig::default_preset();
    let rec = Recording {
        accel: 0.2,
        sample_s: 2e-3,
        ..Recording::default()
    };
    let csv = record_xyz(
        &program,
        [&template.x, &template.y, template.axis(AxisName::Z)],
        &rec,
    );
    let measured = parse_trace(&csv, "plunges.csv").unwrap();
    let settings = CompareSettings::for_machine(&template);
    let id = identify(&program, &template, &measured, &settings).unwrap();
    let i = &id.interpolator;
    assert_eq!(i.accel_limited.len(), 3, "{i:?}");
    let jerk = template.axis(AxisName::Z).limits.max_jerk_m_per_s3;
    let demand = (1.0 / 60.0 * jerk).sqrt();
    assert!(
        (i.demanded_accel_m_per_s2[2] - demand).abs() < 0.01 * demand,
        "{i:?}"
    );
    assert!(
        (i.accel_m_per_s2[2] - rec.accel).abs() < 0.01 * rec.accel,
        "{i:?}"
    );
    assert!(i.accel_limited[2] && !i.jerk_limited[2], "{i:?}");
    let written = id.machine_file(&template, "plunges.nc");
    let read = MachineConfig::from_toml_str(&written, "identified.toml").unwrap();
    let z = &read.axis(AxisName::Z).limits;
    assert!((z.max_accel_m_per_s2 - rec.accel).abs() < 0.005, "{z:?}");
    assert_eq!(
        z.max_jerk_m_per_s3,
        template.axis(AxisName::Z).limits.max_jerk_m_per_s3
    );
}
