//! A cause named on Z's own record, taken back because, with what is named on X and Y, it
//! predicts the contour in space worse than Z's nominal model does.
//!
//! The record is the independent reference's (`common::reference`): circles of 10 mm radius
//! in ZX at 1000 mm/min, with X's and Z's position gains both 8 % below the machine file's.
//! Z's own record determines its gain. X's gain is as plain in X's record, but here the
//! user asks of a cause on X or Y more evidence than any record gives (`--evidence`), so
//! nothing is named there. Each axis lags as a first-order loop of its own gain at the
//! circle's frequency ω = F/R, by atan(ω/Kv)/ω; with both gains low the record's two lags
//! are equal and its circles stay round, while Z's gain alone would give the model Z's lag
//! and X's nominal one: the ellipse of their difference Δτ, of radial amplitude R·ω·Δτ/2
//! on the diagonals. The nominal model misses only the radius both lags take (a few µm),
//! so Z's gain, right on Z, makes the contour worse by that ellipse and is taken back.

use crate::common;

use common::program_text;
use common::reference::{Recording, record_xyz};
use contourcheck::diagnose::causes::CauseId;
use contourcheck::diagnose::{DiagnoseSettings, diagnose};
use contourcheck::machine::{AxisName, MachineConfig};
use contourcheck::trace::measured::parse_trace;

/// A clockwise and a counter-clockwise circle of 10 mm radius in ZX about X0 Z0, each
/// entered and left along its tangent (Z) at X10 Z0.
const G18_CIRCLES: &str = "G21 G90 G94 G18\nG0 X10 Y0 Z-5\nG1 Z0 F1000\nG2 X10 Z0 I-10 K0\n\
     G1 Z5\nG1 Z0\nG3 X10 Z0 I-10 K0\nG1 Z-5\nM2\n";

/// X's and Z's position gains in the record, against the machine file's.
const LOW_KV: f64 = 0.92;
/// The circles' radius (m) and feed (m/s).
const RADIUS_M: f64 = 10e-3;
const FEED_M_PER_S: f64 = 1.0 / 60.0;

#[test]
fn z_s_gain_alone_predicting_the_contour_worse_is_taken_back() {
    let program = program_text(G18_CIRCLES);
    let nominal = MachineConfig::default_preset();
    let mut truth = nominal.clone();
    for a in [AxisName::X, AxisName::Z] {
        truth.axis_mut(a).position_loop.kv_m_per_min_per_mm *= LOW_KV;
    }
    let z = truth.axis(AxisName::Z);
    let csv = record_xyz(&program, [&truth.x, &truth.y, z], &Recording::default());
    let measured = parse_trace(&csv, "g18-both-slow.csv").unwrap();
    let mut settings = DiagnoseSettings::for_machine(&nominal);
    settings.evidence = 1e12;
    let d = diagnose(&program, &nominal, &measured, &settings).unwrap();
    assert!(d.causes.is_empty(), "named on X or Y: {:?}", d.causes);
    assert!(d.z.cause.is_none(), "named on Z: {:?}", d.z.cause);
    // Z's gain was found and taken back, with the contour's figures without and with it.
    let taken_back = d.z.not_named.first().unwrap_or_else(|| panic!("{:?}", d.z));
    assert_eq!(taken_back.id, CauseId::KvGain, "{taken_back:?}");
    let figures: Vec<f64> = taken_back
        .reason
        .split("in space worse (")
        .nth(1)
        .and_then(|r| r.split(" µm").next())
        .map(|r| r.split(" → ").filter_map(|v| v.parse().ok()).collect())
        .unwrap_or_default();
    assert_eq!(figures.len(), 2, "{}", taken_back.reason);
    // The ellipse Z's gain alone adds: R·ω·Δτ/2 on the diagonals, its RMS round the circle
    // that over √2; the circles are most of the record.
    let omega = FEED_M_PER_S / RADIUS_M;
    let lag_s = |kv: f64| {
        let k = kv * 1e3 / 60.0;
        (omega / k).atan() / omega
    };
    let kv = nominal.axis(AxisName::Z).position_loop.kv_m_per_min_per_mm;
    let ellipse_rms_um =
        RADIUS_M * omega * (lag_s(kv * LOW_KV) - lag_s(kv)) / 2.0 / 2f64.sqrt() * 1e6;
    let (without, with) = (figures[0], figures[1]);
    // Without it the model misses the radius both gains take, R·(s(Kv) − s(0.92 Kv)) with
    // s(k) = 1/√(1 + (ω/k)²) the share of the radius a loop keeps: on the circles only.
    let share = |kv: f64| 1.0 / (omega / (kv * 1e3 / 60.0)).hypot(1.0);
    let radius_um = RADIUS_M * (share(kv) - share(kv * LOW_KV)) * 1e6;
    assert!(
        without <= 1.2 * radius_um,
        "{without} µm, the radius {radius_um:.1} µm"
    );
    assert!(
        with - without > 0.5 * ellipse_rms_um,
        "{without} → {with} µm, the ellipse {ellipse_rms_um:.1} µm RMS"
    );
    // The machine keeps the file's Z, and the extended model's Z is the nominal one.
    assert_eq!(d.machine.z, nominal.z);
    assert_eq!(d.z.after_rms_um, d.z.before_rms_um);
}
