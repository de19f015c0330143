//! `identify`'s presliding (bristle) stage against a record of the independent integrator
//! of `common::reference`, which has LuGre friction of its own: the lead-lag table as it
//! ran, X's guideway with bristles whose friction near rest lies below Coulomb's, Y's
//! sticking and sliding without them; the template is the table as designed, with no
//! bristles on either axis.
//!
//! X's bristles are written, as a model's shape, and predict the record's held-out halves
//! better than the fit without them; Y's hybrid friction gets none, and says why. Where X's
//! guideway holds harder near rest one way than the other, a level each way is written
//! beside them; where it holds alike, one level stays. Without a template, the loop model
//! gets them the same way.

use crate::common;

use std::sync::OnceLock;

use common::identifying::{encoder_record, lead_lag_designed_and_run};
use common::program_text;
use contourcheck::compare::CompareSettings;
use contourcheck::gcode::Program;
use contourcheck::identify::{
    AxisIdentification, Identification, PreslidingVerdict, identify, identify_loop, loop_template,
};
use contourcheck::machine::MachineConfig;
use contourcheck::sim::MeasuredAt;

/// Out and back on each axis, slowly enough that each start and stop lingers where the
/// bristles carry the table (a few mm/s as the feed ramps), with stops between the moves.
fn program() -> Program {
    program_text("G21 G17 G90 G94\nG0 X0 Y0\nG1 X6 F600\nY4 F600\nX0 F900\nY0 F600\nM2\n")
}

/// X's guideway as the table runs: Coulomb friction of 0.3 of the table's weight (88 N on
/// 30 kg) on bristles of 50 N/µm (a presliding range of 1.2 µm at the level near rest,
/// against counts of 0.1 µm), damped at a tenth of critical on the 111 kg the drive moves
/// (30 kg, and the rotor's and screw's 2.05e-4 kg·m² through 10 mm a turn:
/// 2·√(50e6 · 111) / 10 ≈ 14,900 N·s/m), friction near rest 0.7 of Coulomb's, regained
/// over 10 mm/s (600 mm/min): one of the shapes `identify` tries, the one the real table's
/// separate model suggests.
fn truth() -> (MachineConfig, MachineConfig) {
    let (template, mut truth) = lead_lag_designed_and_run();
    let f = &mut truth.x.friction;
    f.coulomb_coefficient = 0.3;
    f.bristle_stiffness_n_per_um = 50.0;
    f.bristle_damping_n_s_per_m = 14_900.0;
    f.static_to_coulomb = 0.7;
    f.stribeck_level_n = 0.0;
    f.stribeck_velocity_mm_per_min = 600.0;
    (template, truth)
}

fn identified() -> &'static Identification {
    static ID: OnceLock<Identification> = OnceLock::new();
    ID.get_or_init(|| {
        let (template, truth) = truth();
        identified_from(&template, &truth, 41)
    })
}

/// `truth`'s record of [`program`] (noise seeded by `seed`) identified from `template`.
fn identified_from(template: &MachineConfig, truth: &MachineConfig, seed: u64) -> Identification {
    let measured = encoder_record(&program(), truth, seed);
    let mut settings = CompareSettings::for_machine(template);
    settings.measured_at = MeasuredAt::Motor;
    let id = identify(&program(), template, &measured, &settings).unwrap();
    for a in &id.axes {
        eprintln!(
            "{}: reached {}, moving only {}, held out {:.3} µm of {:.3} µm (template {:.3})",
            a.axis,
            a.reached,
            a.moving_only,
            a.held_out_identified_um,
            a.following_error_rms_um,
            a.held_out_template_um
        );
    }
    id
}

/// X's fit and what it says of presliding friction (its template names none).
fn x_presliding(id: &Identification) -> (&AxisIdentification, &PreslidingVerdict) {
    let x = &id.axes[0];
    let v = x
        .presliding
        .as_ref()
        .expect("X's template names no bristles");
    eprintln!("X: {v:?}; held out share {:.3}", x.held_out_share);
    (x, v)
}

#[test]
fn bristles_the_record_has_are_written_and_predict_its_held_out_halves_better() {
    let id = identified();
    let (x, v) = x_presliding(id);
    assert!(v.written, "{v:?}");
    // Kept only where the halves' fits with them predict the other halves better by the
    // twentieth every larger model must earn.
    assert!(v.held_out_with_um < 0.95 * v.held_out_without_um, "{v:?}");
    assert_eq!(x.held_out_identified_um, v.held_out_with_um);
    let machine_x = &id.machine.x;
    let f = &machine_x.friction;
    assert!(f.has_presliding(), "{f:?}");
    // The truth's shape is among those tried: it is the one written, its stiffness, level
    // near rest and fade speed the truth's.
    assert_eq!(f.bristle_stiffness_n_per_um, 50.0, "{f:?}");
    assert_eq!(f.static_to_coulomb, 0.7, "{f:?}");
    assert_eq!(f.stribeck_velocity_mm_per_min, 600.0, "{f:?}");
    // And the Coulomb force fitted with it is the truth's 0.3 · 30 kg · 9.81 m/s² = 88.3 N,
    // within a tenth (the template's is a third of it).
    let coulomb_n = f.coulomb_coefficient * machine_x.drive.table_mass_kg * 9.81;
    assert!((coulomb_n - 88.3).abs() < 8.8, "{coulomb_n} N");
    // With the truth's shape the fit predicts the held-out halves near the record's noise
    // — 0.05 µm, with the 0.1 µm counts' rounding (0.1/√12 = 0.029 µm): 0.058 µm — within
    // 30 % (the loop's values fitted on half the samples), where without bristles they
    // were several times above it.
    assert!(x.held_out_identified_um < 1.3 * 0.058, "{x:?}");
    assert!(v.held_out_without_um > 3.0 * 0.058, "{v:?}");
    // A shape from a grid is a model's, never a measurement.
    for key in [
        "friction.bristle_stiffness_n_per_um",
        "friction.static_to_coulomb",
    ] {
        let value = x.values.iter().find(|v| v.key == key).expect(key);
        assert!(!value.determined && !value.measured, "{value:?}");
    }
    assert!(v.statement.starts_with("presliding friction: bristles of "));
    // The truth's level near rest is one both ways: a level each way is tried, and not
    // written — it fits the whole record no better than one.
    assert!(!v.by_direction, "{v:?}");
    assert!(v.held_out_one_level_um.is_finite(), "{v:?}");
    assert!(
        v.statement
            .contains("one level near rest both ways (fitted on the whole record"),
        "{}",
        v.statement
    );
    assert_eq!(f.static_to_coulomb_negative, None, "{f:?}");
}

/// X's guideway of [`truth`], but its friction near rest differs by direction: a tenth of
/// Coulomb's towards +, 1.4 times it towards − (the lopsided guideway the real table's
/// separate model suggested on Y), each start of the program's out-and-back one way.
fn identified_by_direction() -> &'static Identification {
    static ID: OnceLock<Identification> = OnceLock::new();
    ID.get_or_init(|| {
        let (template, mut truth) = truth();
        truth.x.friction.static_to_coulomb = 0.1;
        truth.x.friction.static_to_coulomb_negative = Some(1.4);
        identified_from(&template, &truth, 43)
    })
}

/// The record's two starts, one each way, cannot be explained by one level near rest: a
/// level each way is written beside the bristles, and predicts the held-out halves better
/// than one level by the twentieth a larger model must earn. The truth's friction near rest
/// is 0.1 × 88.3 = 8.8 N towards + and 1.4 × 88.3 = 123.6 N towards −: the levels come
/// back on the truth's sides of Coulomb friction (the record fixes which way the guideway
/// holds harder), apart by the truth's 114.8 N within a quarter — the gain, the lead's
/// corners and the mass stay the template's where the out-and-back leaves them loose, and
/// the fit takes up what they miss.
#[test]
fn friction_near_rest_that_differs_by_direction_is_written_each_way() {
    let id = identified_by_direction();
    let (x, v) = x_presliding(id);
    assert!(v.written && v.by_direction, "{v:?}");
    // The rule they are written by.
    assert!(v.held_out_with_um < 0.95 * v.held_out_one_level_um, "{v:?}");
    assert_eq!(x.held_out_identified_um, v.held_out_with_um);
    let machine_x = &id.machine.x;
    let f = &machine_x.friction;
    let coulomb_n = f.coulomb_coefficient * machine_x.drive.table_mass_kg * 9.81;
    let plus_n = f.static_to_coulomb * coulomb_n;
    let minus_n = f.static_to_coulomb_negative.expect("a level towards −") * coulomb_n;
    eprintln!("{coulomb_n:.1} N, near rest {plus_n:.1} N towards +, {minus_n:.1} N towards −");
    assert!(plus_n < coulomb_n && coulomb_n < minus_n, "{f:?}");
    assert!((minus_n - plus_n - 114.8).abs() < 0.25 * 114.8, "{f:?}");
    // Towards + the guideway holds a tenth of Coulomb's: well below the one level of the
    // shapes tried (0.7 and 1.0), and below a quarter of Coulomb's as found.
    assert!(plus_n < 0.25 * coulomb_n, "{f:?}");
    // Fitted values with their uncertainty, not a grid's: towards − the record determines it.
    let negative = (x.values.iter())
        .find(|v| v.key == "friction.static_to_coulomb_negative")
        .expect("reported");
    assert!(negative.determined && !negative.measured, "{negative:?}");
    assert!(
        v.statement.contains("friction near rest each way"),
        "{}",
        v.statement
    );
    // The machine file written carries it, and reads back to the same friction.
    let text = id.machine.to_toml();
    assert!(text.contains("static_to_coulomb_negative"), "{text}");
    let back = contourcheck::machine::MachineConfig::from_toml_str(&text, "written.toml").unwrap();
    assert_eq!(back.x.friction, *f);
}

#[test]
fn hybrid_friction_gets_no_bristles_and_says_why() {
    let id = identified();
    let y = &id.axes[1];
    let v = y
        .presliding
        .as_ref()
        .expect("Y's template names no bristles");
    eprintln!("Y: {v:?}");
    assert!(!v.written, "{v:?}");
    assert!(
        v.statement
            .starts_with("presliding friction: not determined ("),
        "{}",
        v.statement
    );
    assert!(!id.machine.y.friction.has_presliding());
}

/// Without a template the loop model fitted from the record alone holds Coulomb friction
/// too, and the bristles are tried on it the same way. The small table (its own cascade, not
/// the lead-lag above) on X's guideway of [`truth`] holding a tenth of Coulomb's near rest
/// towards + and 1.4 times it towards −: they are written with a level each way — whether
/// one level's fit on the whole record goes on to its halves or not —, the levels on the
/// truth's sides of Coulomb's force (in the loop model's own units: its Coulomb force, like
/// its mass, describes the loop), and the held-out halves predicted better than the loop
/// model without them by the twentieth a larger model must earn.
#[test]
fn the_loop_model_gets_bristles_with_a_level_each_way_too() {
    let mut truth = MachineConfig::preset("small-table").unwrap();
    let f = &mut truth.x.friction;
    f.coulomb_coefficient = 0.3;
    f.bristle_stiffness_n_per_um = 50.0;
    f.bristle_damping_n_s_per_m = 14_900.0;
    f.static_to_coulomb = 0.1;
    f.static_to_coulomb_negative = Some(1.4);
    f.stribeck_level_n = 0.0;
    f.stribeck_velocity_mm_per_min = 600.0;
    let measured = encoder_record(&program(), &truth, 43);
    let start = loop_template(&measured);
    let mut settings = CompareSettings::for_machine(&start);
    settings.measured_at = MeasuredAt::Motor;
    let id = identify_loop(&program(), &start, &measured, &settings).unwrap();
    let (x, v) = x_presliding(&id);
    assert!(v.written && v.by_direction, "{v:?}");
    assert!(v.held_out_with_um < 0.95 * v.held_out_without_um, "{v:?}");
    assert_eq!(x.held_out_identified_um, v.held_out_with_um);
    let f = &id.machine.x.friction;
    let minus = f.static_to_coulomb_negative.expect("a level towards −");
    assert!(f.static_to_coulomb < 0.25 && 1.0 < minus, "{f:?}");
    assert!(
        v.statement.contains("friction near rest each way"),
        "{}",
        v.statement
    );
}
