//! The circular-test figures of circles in ZX (G18), from a record of the independent
//! reference (`common::reference`: its own integrator and interpolator, Z carrying its
//! weight, recorded commands, noise) whose Z position gain is 8 % below the machine file's.
//!
//! A circle in ZX is run by Z and X: its figures are taken in that plane, from the measured
//! Z and X, and name it. Each axis lags as a first-order loop of its own gain at the circle's
//! frequency ω, by the angle atan(ω/Kv) and to the share 1/√(1+(ω/Kv)²) of the radius; the
//! ballbar reads the difference of the two lags as its servo mismatch, the difference of
//! the two shares as its scale mismatch, and the smaller share as the radius lost. The model's
//! inner loops add lags of their own, the same in the record and in the nominal model: the
//! measured figures less the nominal model's are the position gains' alone.

use crate::common;

use std::sync::OnceLock;

use common::diagnosing::diagnose_nominal;
use common::program_text;
use common::reference::{Recording, record_xyz};
use contourcheck::analysis::circular::{CircleFigures, CircularTest, Hysteresis};
use contourcheck::diagnose::causes::CauseId;
use contourcheck::diagnose::{DiagnoseSettings, Diagnosis, diagnose};
use contourcheck::machine::{AxisName, MachineConfig, PlannedAxis, ZAxis};
use contourcheck::path::Plane;
use contourcheck::trace::measured::{MeasuredTrace, parse_trace};
use contourcheck::{DiagnoseReport, ReportInputs, diagnose_page};

/// A clockwise and a counter-clockwise circle of 10 mm radius in ZX about X0 Z0, each
/// entered and left along its tangent (Z) at X10 Z0, where Z moves fastest and X reverses.
const G18_CIRCLES: &str = "G21 G90 G94 G18\nG0 X10 Y0 Z-5\nG1 Z0 F1000\nG2 X10 Z0 I-10 K0\n\
     G1 Z5\nG1 Z0\nG3 X10 Z0 I-10 K0\nG1 Z-5\nM2\n";

/// Z's position gain in the record, against the machine file's.
const LOW_KV: f64 = 0.92;
/// The circles' radius (m) and feed (m/s).
const RADIUS_M: f64 = 10e-3;
const FEED_M_PER_S: f64 = 1.0 / 60.0;

/// The record and its diagnosis against the nominal machine (one per test binary).
fn diagnosed() -> &'static (MeasuredTrace, Diagnosis) {
    static D: OnceLock<(MeasuredTrace, Diagnosis)> = OnceLock::new();
    D.get_or_init(|| {
        let program = program_text(G18_CIRCLES);
        let mut truth = MachineConfig::default_preset();
        truth
            .axis_mut(AxisName::Z)
            .position_loop
            .kv_m_per_min_per_mm *= LOW_KV;
        let z = truth.axis(AxisName::Z);
        let csv = record_xyz(&program, [&truth.x, &truth.y, z], &Recording::default());
        let measured = parse_trace(&csv, "g18-circles.csv").unwrap();
        let d = diagnose_nominal(&program, &measured);
        (measured, d)
    })
}

fn diagnosis() -> &'static Diagnosis {
    &diagnosed().1
}

/// The position gains (1/s) of the nominal machine's Z and X.
fn nominal_gains_per_s() -> [f64; 2] {
    let m = MachineConfig::default_preset();
    [AxisName::Z, AxisName::X].map(|a| m.axis(a).position_loop.kv_m_per_min_per_mm * 1e3 / 60.0)
}

/// A first-order loop of gain `k` (1/s) at the circles' frequency: its lag (s of the
/// circle's travel, atan(ω/k)/ω) and the share of the radius it keeps.
fn lag_and_share(k: f64) -> (f64, f64) {
    let omega = FEED_M_PER_S / RADIUS_M;
    let w = omega / k;
    (w.atan() / omega, 1.0 / w.hypot(1.0))
}

fn circles_of(t: &CircularTest) -> Vec<&CircleFigures> {
    t.circles.iter().collect()
}

fn pair_of(t: &CircularTest) -> &Hysteresis {
    assert_eq!(t.pairs.len(), 1, "{t:?}");
    &t.pairs[0]
}

#[test]
fn circles_in_zx_get_their_own_figures_named_by_their_plane() {
    let d = diagnosis();
    assert!(d.z.compared, "{:?}", d.z);
    for t in [
        &d.circular.measured,
        &d.circular.nominal,
        &d.circular.extended,
    ] {
        let c = circles_of(t);
        assert_eq!(c.len(), 2, "{t:?}");
        assert_eq!([c[0].line, c[1].line], [4, 7], "{t:?}");
        assert!(c.iter().all(|c| c.plane == Plane::Zx), "{t:?}");
        assert!(c.iter().all(|c| (c.radius_mm - 10.0).abs() < 1e-9), "{t:?}");
        assert_eq!(pair_of(t).plane, Plane::Zx, "{t:?}");
    }
    let nominal = MachineConfig::default_preset();
    let said = DiagnoseReport::new(d, "g18.nc", &diagnosed().0, &nominal).to_string();
    assert!(said.contains("ZX (G18)"), "{said}");
}

/// The most inward radial deviation F: each axis keeps its share of the radius, late by its
/// lag, so the path is an ellipse along the diagonals whose inward extreme is the radius lost
/// at 45° between the axes — tens of µm more with Z's gain 8 % low than with both at the
/// set gain (the nominal model).
#[test]
fn the_most_inward_deviation_is_the_two_lags_ellipse() {
    let d = diagnosis();
    let [kz, kx] = nominal_gains_per_s();
    let inward_um = |[k_first, k_second]: [f64; 2]| {
        let omega = FEED_M_PER_S / RADIUS_M;
        let ((l1, a1), (l2, a2)) = (lag_and_share(k_first), lag_and_share(k_second));
        (0..3600)
            .map(|i| {
                let psi = (i as f64 / 10.0).to_radians();
                let r = (a1 * (psi - omega * l1).cos()).hypot(a2 * (psi - omega * l2).sin());
                (1.0 - r) * RADIUS_M * 1e6
            })
            .fold(0.0f64, f64::max)
    };
    let (measured, nominal) = (inward_um([LOW_KV * kz, kx]), inward_um([kz, kx]));
    // ≈ 97 and 50 µm.
    assert!(measured - nominal > 40.0, "{measured} {nominal}");
    for (t, expected) in [
        (&d.circular.measured, measured),
        (&d.circular.nominal, nominal),
    ] {
        for c in circles_of(t) {
            // The inner loops' lag adds a little; the noise and the spikes at the reversals
            // a micrometre at most.
            assert!(
                (-c.f_min_um - expected).abs() < 0.02 * expected + 1.0,
                "F min {} µm, {expected:.2} µm expected: {c:?}",
                c.f_min_um
            );
        }
    }
}

/// The pair's servo mismatch and scale mismatch, measured less nominal: the lag and the
/// share Z's low gain adds, with the plane's first axis Z and its second X.
#[test]
fn the_pairs_mismatches_are_z_gain_against_x() {
    let d = diagnosis();
    let [kz, _] = nominal_gains_per_s();
    let ((lag_low, share_low), (lag_set, share_set)) =
        (lag_and_share(LOW_KV * kz), lag_and_share(kz));
    // The second axis (X) lagging the first (Z) is positive: Z lags more, by ≈ 5.2 ms.
    let servo_ms = -(lag_low - lag_set) * 1e3;
    // The first axis (Z) reading longer is positive: Z keeps less of the radius, ≈ −890 ppm.
    let scale_ppm = (share_low / share_set - 1.0) * 1e6;
    let (m, n) = (pair_of(&d.circular.measured), pair_of(&d.circular.nominal));
    let servo = m.servo_mismatch_ms - n.servo_mismatch_ms;
    assert!(
        (servo - servo_ms).abs() < 0.05 * servo_ms.abs(),
        "{servo} ms, {servo_ms:.3} expected: {m:?} {n:?}"
    );
    let scale = m.scale_mismatch_ppm - n.scale_mismatch_ppm;
    assert!(
        (scale - scale_ppm).abs() < 0.05 * scale_ppm.abs(),
        "{scale} ppm, {scale_ppm:.1} expected: {m:?} {n:?}"
    );
}

/// On a machine file that carries Z without simulating it, Z is not compared: the circles in
/// ZX get no figures (X alone is no circular test), and the report says why for each.
#[test]
fn circles_in_zx_without_z_compared_are_left_out_with_the_reason() {
    let (measured, _) = diagnosed();
    let mut carrying = MachineConfig::default_preset();
    carrying.z = ZAxis::Carried(PlannedAxis {
        limits: carrying.z.limits().clone(),
    });
    let program = program_text(G18_CIRCLES);
    let d = diagnose(
        &program,
        &carrying,
        measured,
        &DiagnoseSettings::for_machine(&carrying),
    )
    .unwrap();
    assert!(!d.z.compared, "{:?}", d.z);
    let c = &d.circular;
    assert!(
        c.measured.circles.is_empty() && c.measured.pairs.is_empty(),
        "{c:?}"
    );
    let left: Vec<(u32, Plane)> = c.left_out.iter().map(|l| (l.line, l.plane)).collect();
    assert_eq!(left, [(4, Plane::Zx), (7, Plane::Zx)], "{c:?}");
    let report = DiagnoseReport::new(&d, "g18.nc", measured, &carrying);
    let said = report.to_string();
    let why = "(ZX plane, G18): no figures: Z is not compared: the machine file carries Z";
    assert!(said.contains(&format!("line 4 {why}")), "{said}");
    // The HTML page lists them too, each with its reason.
    let page = diagnose_page(&d, &report, &ReportInputs::default()).unwrap();
    for line in [4, 7] {
        assert!(
            page.contains(&format!("Circle of line {line} {why}")),
            "line {line} not listed on the page"
        );
    }
}

/// The places of the largest contour residuals give Z, and lie on the circle in ZX where
/// its two lags differ most: near the diagonals between Z and X (45° off each axis), where
/// the ellipse of Z's lag less the model's stands out. From X alone the places would sit on
/// the line the circle runs along seen from above.
#[test]
fn the_largest_contour_residuals_are_placed_in_space_on_the_diagonals() {
    let (measured, d) = diagnosed();
    let contour: Vec<_> = d.places.iter().filter(|p| p.what == "contour").collect();
    assert!(!contour.is_empty(), "{:?}", d.places);
    for p in &contour {
        let z_mm = p.z_mm.unwrap_or_else(|| panic!("no Z: {p:?}"));
        assert!(p.line == 4 || p.line == 7, "{p:?}");
        assert!(p.y_mm.abs() < 0.01, "{p:?}");
        assert!((p.x_mm.hypot(z_mm) - 10.0).abs() < 0.2, "{p:?}");
        let off_axes_deg = z_mm.atan2(p.x_mm).to_degrees().rem_euclid(90.0);
        assert!((off_axes_deg - 45.0).abs() < 15.0, "{off_axes_deg}° {p:?}");
    }
    let nominal = MachineConfig::default_preset();
    let report = DiagnoseReport::new(d, "g18.nc", measured, &nominal);
    assert!(report.to_string().contains("Z (mm)"));
    let page = diagnose_page(d, &report, &ReportInputs::default()).unwrap();
    assert!(
        page.contains("data-key=\"places[0].z_mm\""),
        "no Z on the page"
    );
    // The circles' table names their plane.
    let plane = "data-key=\"circular_test.measured.circles[0].plane\" data-value=\"ZX\">ZX<";
    assert!(page.contains(plane), "no plane on the page");
}

/// With X's and Z's position gains both 8 % low, both axes lag alike and the circle in ZX
/// keeps its shape: the measured contour shows no diagonal ellipse. Each gain on its own
/// would give the model one (43 µm, the two lags' difference) that the record does not
/// have, so judged one axis at a time against the nominal model neither would be named.
/// Each axis's record against its own commands determines its gain, and together the two
/// predict the contour no worse: both are named, each at its value. With Z's gain alone low
/// (the record above) its gain takes the ellipse away and is named.
#[test]
fn gains_low_on_both_axes_of_a_zx_circle_are_both_named_at_their_values() {
    let program = program_text(G18_CIRCLES);
    let mut truth = MachineConfig::default_preset();
    for a in [AxisName::X, AxisName::Z] {
        truth.axis_mut(a).position_loop.kv_m_per_min_per_mm *= LOW_KV;
    }
    let z = truth.axis(AxisName::Z);
    let csv = record_xyz(&program, [&truth.x, &truth.y, z], &Recording::default());
    let measured = parse_trace(&csv, "g18-both-slow.csv").unwrap();
    let d = diagnose_nominal(&program, &measured);
    let nominal = MachineConfig::default_preset();
    let z_cause = d.z.cause.as_ref().unwrap_or_else(|| panic!("{:?}", d.z));
    assert_eq!(z_cause.id, CauseId::KvGain, "{:?}", d.z);
    let x_cause = d
        .causes
        .iter()
        .find(|c| c.axis == AxisName::X && c.id == CauseId::KvGain)
        .unwrap_or_else(|| panic!("X's gain not named: {:?} {:?}", d.causes, d.rejected));
    for (axis, kv) in [
        (AxisName::X, &x_cause.params[0]),
        (AxisName::Z, &z_cause.params[0]),
    ] {
        let truth_kv = nominal.axis(axis).position_loop.kv_m_per_min_per_mm * LOW_KV;
        assert_eq!(kv.key, "position_loop.kv_m_per_min_per_mm");
        assert!(
            (kv.value - truth_kv).abs() <= 0.01 * truth_kv,
            "{axis:?}: {kv:?} against {truth_kv}"
        );
    }
    assert!(
        d.after.contour.rms_um <= d.before.contour.rms_um * 1.005,
        "{:?}",
        d.after
    );
    // The gain on Z alone low is named, and the contour in space falls with it.
    let alone = diagnosis();
    assert_eq!(
        alone.z.cause.as_ref().map(|c| c.id),
        Some(CauseId::KvGain),
        "{:?}",
        alone.z
    );
    assert!(alone.after.contour.rms_um < 0.5 * alone.before.contour.rms_um);
}
