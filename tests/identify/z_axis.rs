//! `identify` on a record that measured Z, taken by the independent reference of
//! `common::reference` (its own integrator and interpolator, a vertical Z carrying its
//! weight, the commands recorded beside the positions): a helix down and back up, which
//! moves X and Y on circles and Z on two ramps with a reversal between them. The machine
//! is the nominal one but for Z's position gain, 8 % low: identify finds it on Z within
//! its uncertainty, writes it in the machine file, and leaves X and Y at their values.
//! The interpolator's limits are read from such records too: an acceleration held on every
//! axis's ramps, and a jerk held by an interpolator that limits one.

use crate::common;

use common::program_text;
use common::reference::{Recording, record, record_xyz};
use contourcheck::compare::CompareSettings;
use contourcheck::identify::{AxisIdentification, Identification, identify};
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

/// A plunge and a retract of Z alone at 1000 mm/min (3 mm), between them moves of X alone
/// and Y alone (3 mm each) at the same feed.
const PLUNGES: &str = "G21 G90 G94 G17\nG0 X0 Y0 Z0\nG1 Z-3 F1000\nG1 X3\nG1 Y3\nG1 Z0\nM2\n";

/// The same, then a fast retract of Z (25 mm, as a rapid).
const PLUNGES_AND_RAPID: &str = "G21 G90 G94 G17\nG0 X0 Y0 Z0\nG1 Z-3 F1000\nG1 X3\nG1 Y3\n\
                                 G1 Z0\nG0 Z25\nM2\n";

/// The reference's interpolator ramps every block at this (m/s²).
const RECORD_ACCEL: f64 = 0.1;

/// `identify` on `text` recorded every `sample_s` by the reference on the nominal machine,
/// from the nominal template with its interpolation cycle `cycle_ms`.
fn plunges_identified(text: &str, sample_s: f64, cycle_ms: f64) -> (MachineConfig, Identification) {
    let program = program_text(text);
    let mut template = MachineConfig::default_preset();
    template.interpolation.cycle_ms = cycle_ms;
    let rec = Recording {
        accel: RECORD_ACCEL,
        sample_s,
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
    (template, id)
}

/// What the template's planner asks of an axis moving alone to `feed` (mm/min): √(v·jerk)
/// where its jerk limit caps the acceleration before it reaches its own limit, else that.
fn jerk_capped_demand(template: &MachineConfig, axis: AxisName, feed_mm_per_min: f64) -> f64 {
    let limits = &template.axis(axis).limits;
    (feed_mm_per_min / 60e3 * limits.max_jerk_m_per_s3)
        .sqrt()
        .min(limits.max_accel_m_per_s2)
}

/// Every axis's acceleration limit read as the reference's ramp and written, its jerk (a
/// step: a trapezoidal interpolator has no jerk limit) neither read nor written. Z's
/// fastest move runs at `z_feed` (mm/min) in the template's plan; the record was sampled
/// every `sample_s`.
fn limits_read_as_the_ramp(
    template: &MachineConfig,
    id: &Identification,
    z_feed: f64,
    sample_s: f64,
) {
    let i = &id.interpolator;
    assert_eq!(i.accel_limited.len(), 3, "{i:?}");
    let written = id.machine_file(template, "plunges.nc");
    let read = MachineConfig::from_toml_str(&written, "identified.toml").unwrap();
    for (k, axis) in [AxisName::X, AxisName::Y, AxisName::Z]
        .into_iter()
        .enumerate()
    {
        // Each axis moved alone at 1000 mm/min: the template's planner asks √(v·jerk)
        // = 0.289 m/s² of it, below its 0.5 m/s² limit — the apex of a triangle in the
        // acceleration, sampled every cycle (up to jerk·cycle/2 below it) and read as the
        // record is, through a window of ±max(3 ms, 1.5 samples) (a triangle's apex
        // averaged over it: at most jerk·window lower). A rapid of Z at the template's
        // 4000 mm/min asks its limit, flat.
        let feed = if axis == AxisName::Z { z_feed } else { 1000.0 };
        let demand = jerk_capped_demand(template, axis, feed);
        let window_s = 3e-3f64.max(1.5 * sample_s);
        let sampled = template.axis(axis).limits.max_jerk_m_per_s3
            * (template.interpolation.cycle_ms * 1e-3 / 2.0 + window_s);
        let demanded = i.demanded_accel_m_per_s2[k];
        assert!(
            demanded >= demand - sampled && demanded <= 1.01 * demand,
            "{axis}: {i:?}"
        );
        assert!(
            (i.accel_m_per_s2[k] - RECORD_ACCEL).abs() < 0.01 * RECORD_ACCEL,
            "{axis}: {i:?}"
        );
        assert!(i.accel_limited[k] && !i.jerk_limited[k], "{axis}: {i:?}");
        let limits = &read.axis(axis).limits;
        assert!(
            (limits.max_accel_m_per_s2 - RECORD_ACCEL).abs() < 0.005,
            "{axis}: {limits:?}"
        );
        assert_eq!(
            limits.max_jerk_m_per_s3,
            template.axis(axis).limits.max_jerk_m_per_s3
        );
    }
}

#[test]
fn acceleration_limits_are_read_where_the_record_holds_them_below_the_demand() {
    // The reference's interpolator ramps every block at 0.1 m/s²: X, Y and Z each
    // accelerate at that, flat for 167 ms (16.7 mm/s over 0.1 m/s²), at every start and
    // stop of their own moves, where the template's planner would ask 0.289 m/s²: the
    // control's limit, 0.1, is written for each. Z's fast retract reaches 50 mm/s (√(a·d)
    // over 25 mm): over a 5 ms plateau the path speed changes by only 0.5 mm/s, 1 % of that
    // top speed, yet each axis's own ramps still show its limit.
    let (template, id) = plunges_identified(PLUNGES_AND_RAPID, 2e-3, 2.0);
    let rapid = template.axis(AxisName::Z).limits.rapid_mm_per_min;
    limits_read_as_the_ramp(&template, &id, rapid, 2e-3);
}

#[test]
fn acceleration_limits_are_read_from_a_50_hz_record_on_a_coarse_cycle() {
    // The same moves recorded at 50 Hz (a control's own trace), identified from a template
    // whose control interpolates every 10 ms: a 5 ms plateau is shorter than a cycle, yet
    // the ramps — 167 ms, eight samples each — show the limit.
    let (template, id) = plunges_identified(PLUNGES, 0.02, 10.0);
    limits_read_as_the_ramp(&template, &id, 1000.0, 0.02);
}

/// A square of 50 mm at F3000 run by the reference with a jerk-limited interpolator: each
/// side's acceleration ramps at 2 m/s³ to 0.2 m/s² and back, rest to rest — a jerk held for
/// 100 ms (0.2 / 2) four times a side — where the template's planner (5 m/s³, 0.5 m/s²)
/// asks more of both. Both limits are read and written for X and Y.
#[test]
fn a_jerk_limit_is_read_where_the_record_holds_it_below_the_demand() {
    const JERK: f64 = 2.0;
    const ACCEL: f64 = 0.2;
    let program = program_text("G21 G90 G94 G17\nG0 X0 Y0\nG1 X50 F3000\nY50\nX0\nY0\nM2\n");
    let template = MachineConfig::default_preset();
    let rec = Recording {
        accel: ACCEL,
        jerk: Some(JERK),
        ..Recording::default()
    };
    let csv = record(&program, &template.x, &template.y, &rec);
    let measured = parse_trace(&csv, "s-curves.csv").unwrap();
    let settings = CompareSettings::for_machine(&template);
    let id = identify(&program, &template, &measured, &settings).unwrap();
    let i = &id.interpolator;
    let read =
        MachineConfig::from_toml_str(&id.machine_file(&template, "square.nc"), "identified.toml")
            .unwrap();
    // The commands are written to 0.1 nm (±0.05 nm of rounding) every 1 ms; their
    // acceleration is a parabola's through ±3 ms of them (seven samples: weights
    // 2·(j² − 4)/84/dt², |·| summing to 40/84/dt²), off by at most 40/84 · 0.05 nm / (1 ms)²
    // = 2.4e-5 m/s², and the jerk, its change over at least a sample, by at most twice that
    // over 1 ms: 0.048 m/s³. The file rounds the limit up to three digits: 0.01 more.
    let read_within = 2.0 * (40.0 / 84.0) * 0.05e-9 / 1e-6 / 1e-3;
    for (k, axis) in AxisName::BOTH.into_iter().enumerate() {
        assert!(i.jerk_limited[k] && i.accel_limited[k], "{axis}: {i:?}");
        assert!(
            (i.jerk_m_per_s3[k] - JERK).abs() <= read_within,
            "{axis}: jerk read {} m/s³, the record's {JERK} (within {read_within:.3}): {i:?}",
            i.jerk_m_per_s3[k]
        );
        let written = read.axis(axis).limits.max_jerk_m_per_s3;
        assert!(
            written >= JERK - read_within && written <= JERK + read_within + 0.01,
            "{axis}: jerk written {written} m/s³, the record's {JERK}"
        );
        let accel = read.axis(axis).limits.max_accel_m_per_s2;
        assert!((accel - ACCEL).abs() < 0.005, "{axis}: {accel} m/s²");
    }
}
