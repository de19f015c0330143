//! Z identified from a record that measured it, where the template simulates Z and the
//! record's Z commands move it far enough: the same values as X's and Y's (the controller's
//! gains, the moving mass, Coulomb and viscous friction, a dead time; static friction and
//! play on top where those leave the record above its noise), fitted by re-simulating Z on
//! its own commands, on the samples Z is compared at (where X and Y are, away from Z's own
//! hunting holds). The weight Z carries is the template's: its `[z.gravity]` (vertical, the
//! counterbalance) is taken as set, the load then following the moving mass fitted.
//!
//! Where Z cannot be identified the template's Z stays in the machine written, and the
//! reason is said: the record has no Z or no Z command, the template carries Z without
//! simulating it, Z stands or barely moves, or the template's Z cannot follow the record.

use super::{AxisIdentification, LEAST_TRAVEL_M, Model, identify_axis};
use crate::compare::Context;
use crate::compare::context::ZUncomparable;
use crate::machine::{AxisConfig, AxisName, MachineConfig};
use crate::numeric::units::um_from_m;

/// What the record gives of Z: its values identified, or why not (`None` for a record
/// without Z, where there is nothing to say).
pub(super) type ZOutcome = Result<(AxisConfig, AxisIdentification), Option<String>>;

/// Z identified from the record placed in `ctx`, from `template`'s Z.
pub(super) fn identify(
    ctx: &Context,
    template: &MachineConfig,
    offset_s: f64,
    model: Model,
) -> ZOutcome {
    let not = |why: String| Err(Some(why));
    let comparable = ctx.z_comparable(template);
    if comparable == Err(ZUncomparable::NotRecorded) {
        return Err(None);
    }
    // A loop model starts from a table that carries Z: what to say is that the loop model
    // leaves Z out, not that a template should simulate it.
    if matches!(model, Model::Loop(_)) {
        return not("a loop model (--template none) is made for X and Y only".into());
    }
    match comparable {
        Err(ZUncomparable::Carried) => {
            return not(
                "the template carries Z without simulating it: give it [z.*] sections to have \
                 Z identified"
                    .into(),
            );
        }
        // A record identify takes holds X's and Y's commands.
        Err(ZUncomparable::NoCommand) => {
            return not("the record holds no Z command (z_cmd): Z's lag cannot be measured".into());
        }
        _ => {}
    }
    let travel_m = ctx.command_travel_m(AxisName::Z, offset_s);
    if travel_m < LEAST_TRAVEL_M {
        return not(format!(
            "Z is commanded to move {:.1} µm over the stretch compared, less than the {:.0} mm \
             its values need",
            um_from_m(travel_m),
            LEAST_TRAVEL_M * 1e3
        ));
    }
    identify_axis(ctx, template, AxisName::Z, offset_s, model).ok_or_else(|| {
        Some("the template's Z cannot follow the record's Z commands (its loop diverges)".into())
    })
}

/// Writes Z's outcome: its values into `machine` and its identification after X's and Y's
/// where identified; else why not.
pub(super) fn write(
    outcome: ZOutcome,
    machine: &mut MachineConfig,
    axes: &mut Vec<AxisIdentification>,
) -> Option<String> {
    match outcome {
        Ok((config, identified)) => {
            *machine.axis_mut(AxisName::Z) = config;
            axes.push(identified);
            None
        }
        Err(why) => why,
    }
}
