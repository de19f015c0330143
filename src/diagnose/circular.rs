//! The circular-test figures (ISO 230-4) of the program's full circles, measured and by both
//! models, each circle in its own plane: a circle in ZX or YZ from Z and the plane's other
//! axis, where Z is compared. A circle that gets no figures is listed with the reason.

use serde::Serialize;

use super::z_axis::ZFindings;
use super::{Context, Series};
use crate::analysis::circular::{
    CircleWindows, CircularTest, EntrySettling, MIN_SAMPLES, circles, circular_test, radial_points,
};
use crate::machine::MachineConfig;
use crate::path::Plane;

/// Circular-test figures of the same circles three ways.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct CircularComparison {
    /// From the measured path.
    pub measured: CircularTest,
    /// Predicted by the nominal model.
    pub nominal: CircularTest,
    /// Predicted by the extended model.
    pub extended: CircularTest,
    /// What each circle's figures leave out at its start and end, alike for the three
    /// paths: worked out from the program's commands.
    #[serde(skip)]
    pub windows: CircleWindows,
    /// The program's full circles the record gives no figures for, and why.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub left_out: Vec<CircleLeftOut>,
}

/// A full circle of the program without figures.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CircleLeftOut {
    /// Its source line.
    pub line: u32,
    /// Its plane.
    pub plane: Plane,
    /// Why it has no figures.
    pub reason: String,
}

impl std::fmt::Display for CircleLeftOut {
    /// "line N (ZX plane, G18): no figures: why", as the text summary and the HTML page say it.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "line {} ({} plane, {}): no figures: {}",
            self.line,
            self.plane.name(),
            self.plane.gcode(),
            self.reason
        )
    }
}

/// The figures of the measured, nominal and extended paths, on the samples the measured
/// path assigns to each circle, each from where the loops of `machine` have settled into it
/// as the program's commands tell (one window for all three paths, no noise in it); Z from
/// `z` where it was compared.
pub(crate) fn circular_comparison(
    ctx: &Context,
    machine: &MachineConfig,
    s: &Series,
    z: &ZFindings,
) -> CircularComparison {
    let circles = circles(&ctx.plan.segments);
    let (commands, run_in) = (&ctx.commands, ctx.run_in_cycles());
    let windows = CircleWindows::of(&circles, commands, run_in, EntrySettling::of(machine));
    let zs = z.series.as_ref();
    let none: &[f64] = &[];
    let command = s.commands();
    let of = |xy: &[Vec<f64>; 2], z: Option<&Vec<f64>>| {
        circular_test(
            &circles,
            &s.segment,
            [&xy[0], &xy[1], z.map_or(none, |z| z)],
            &command,
            &windows,
        )
    };
    let left_out = circles
        .iter()
        .filter_map(|c| {
            if !c.plane.is_xy() && zs.is_none() {
                let why = match &z.not_compared {
                    Some(why) => format!("Z is not compared: {why}"),
                    None => "the record has no Z".to_owned(),
                };
                return Some((c, why));
            }
            let measured = [
                &s.measured[0][..],
                &s.measured[1][..],
                zs.map_or(none, |z| &z.measured),
            ];
            let on_it = radial_points(&circles, c, &s.segment, measured, &command, &windows).len();
            (on_it < MIN_SAMPLES).then(|| {
                (
                    c,
                    format!(
                        "the stretch compared holds {on_it} samples on it, fewer than {MIN_SAMPLES}"
                    ),
                )
            })
        })
        .map(|(c, reason)| CircleLeftOut {
            line: c.line,
            plane: c.plane,
            reason,
        })
        .collect();
    CircularComparison {
        measured: of(&s.measured, zs.map(|z| &z.measured)),
        nominal: of(&s.nominal, zs.map(|z| &z.nominal)),
        extended: of(&s.extended, zs.map(|z| &z.extended)),
        windows,
        left_out,
    }
}
