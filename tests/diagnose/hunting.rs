//! Holds left out of the point-by-point residual for hunting: only where the axis's loop can
//! hunt — integral action against static friction above the Coulomb level — never for the
//! ordinary settle of a loop that cannot.

use crate::common::diagnosing::recorded;
use crate::common::sample_program as program;
use contourcheck::diagnose::synth::SynthSpec;
use contourcheck::diagnose::{DiagnoseSettings, diagnose};
use contourcheck::machine::MachineConfig;

/// Seconds of X and Y left out for hunting when `machine`'s own record of `name` is
/// diagnosed against it.
fn left_out_s(machine: &MachineConfig, name: &str) -> [f64; 2] {
    let prog = program(name);
    let spec = SynthSpec {
        offset_s: 0.37,
        seed: 5,
        ..SynthSpec::default()
    };
    let measured = recorded(&prog, machine, &spec, "hold.csv");
    let settings = DiagnoseSettings::for_machine(machine);
    diagnose(&prog, machine, &measured, &settings)
        .unwrap()
        .hunting_left_out_s
}

/// The nominal machine without Coulomb friction (static friction is a multiple of it, so
/// none either): its loops are linear, and a linear loop settles into a hold along decaying
/// modes — it cannot hunt. The square holds each axis for a whole side while the other
/// moves, the pocket stops at every corner: not a second of either may be left out.
#[test]
fn a_loop_without_friction_never_has_a_hold_left_out() {
    let mut linear = MachineConfig::default_preset();
    linear.x.friction.coulomb_coefficient = 0.0;
    linear.y.friction.coulomb_coefficient = 0.0;
    for name in ["square.nc", "profile-pocket.nc"] {
        assert_eq!(left_out_s(&linear, name), [0.0, 0.0], "{name}");
    }
}

/// The nominal machine as it is: its velocity loops' integral action holds each table
/// against static friction 13 % above the Coulomb level, and at the pocket's stops the
/// integrator winds until the table breaks away, slips past and sticks again — on both
/// axes, whose holds are then left out.
#[test]
fn integral_action_against_static_friction_has_its_holds_left_out() {
    let nominal = MachineConfig::default_preset();
    let [x, y] = left_out_s(&nominal, "profile-pocket.nc");
    assert!(x > 1.0 && y > 1.0, "left out X {x} s, Y {y} s");
}
