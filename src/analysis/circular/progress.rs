//! How far the command has run along a circle, sample by sample, and where a record that
//! began while the command ran round it stands on it.

use std::f64::consts::{PI, TAU};

use super::{Circle, Commanded, runs_within};

/// How far a command must have moved from where it first stood on a circle to have set off
/// along it (m): far above the rounding a standing command carries (recorded commands
/// are resampled and fitted), far below any arc worth a circular test.
const SET_OFF_M: f64 = 1e-6;

/// How far along the arc from a circle's start a record's first command on it must stand
/// for the record to have begun with the command running round it (m): a control standing
/// at the start reads within its counts of it, and a record's commands are placed on the
/// program within some 25 µm; a record that began in the last tenth of a millimetre
/// before the set-off counts its path from its first sample, as one standing. (The run-in
/// a comparison puts before a record's first command is no command on the circle:
/// [`super::CircleWindows::of`].)
const BEGUN_MID_CIRCLE_M: f64 = 1e-4;

/// How far the command has run along one circle, sample by sample. A sample counts toward
/// the circle's figures only once the command has set off on it: while the command still
/// stands at the circle's start (the control waiting for the axes to settle after the
/// approach, a record whose commands were placed on the circle as soon as they reached
/// it), the table is still arriving from the approach, and what it shows is the approach.
/// The path is counted as the arc the command's angle about the centre turns through: a
/// sum of steps between commands rounded to counts would grow with each step's zigzag (0.1 %
/// at 10 µm steps and 1 µm counts, half a millimetre over an R100 circle), and the windows
/// at the circle's end are measured back from its programmed length.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Progress {
    /// Where the command first stood on the circle (m), of the commands with numbers.
    entry_m: Option<[f64; 3]>,
    /// The command's polar angle about the centre at the last sample on the circle (rad).
    angle_rad: Option<f64>,
    /// The command's path along the circle (m): from where it set off, or, on a record
    /// begun while it ran round, from the circle's start; `None` before it set off.
    pub(super) run_m: Option<f64>,
}

impl Progress {
    /// Takes the next sample's command.
    pub(super) fn advance(&mut self, c: &Circle, command: Commanded) {
        if command.segment as usize != c.segment {
            return;
        }
        let in_plane = c.plane.coords(command.pos_m);
        if self.entry_m.is_none() && in_plane.iter().all(|v| v.is_finite()) {
            self.entry_m = Some(command.pos_m);
        }
        let Some(entry) = self.entry_m else {
            return;
        };
        let (angle_rad, _) = c.polar(in_plane);
        // A sample without a number keeps the last angle that had one.
        let last_rad = if angle_rad.is_finite() {
            self.angle_rad.replace(angle_rad)
        } else {
            self.angle_rad
        };
        self.run_m = match (self.run_m, last_rad) {
            (Some(run), Some(last_rad)) => {
                // The turn since the last sample, the short way round (its rounding's part
                // along the path cancels from step to step while the command runs on).
                let turn_rad = (angle_rad - last_rad + PI).rem_euclid(TAU) - PI;
                let along_m = c.radius_m * turn_rad.abs();
                Some(if along_m.is_finite() {
                    run + along_m
                } else {
                    run
                })
            }
            (None, None) => c.begun_at_m(angle_rad),
            _ => {
                // An axis without a number (Z where a record has none) says nothing.
                let away = (0..3)
                    .map(|i| (command.pos_m[i] - entry[i]).powi(2))
                    .filter(|d| d.is_finite())
                    .sum::<f64>()
                    .sqrt();
                (away > SET_OFF_M).then_some(away)
            }
        };
    }

    /// Whether the command has set off along circle `c` and runs between `lead_m[0]` past
    /// its start and `lead_m[1]` before its end: the loops settle into the circle after its
    /// start, and out of it as the command slows into its end (the table, lagging, follows
    /// later).
    pub(super) fn is_within(&self, c: &Circle, lead_m: [f64; 2]) -> bool {
        self.run_m.is_some_and(|run| runs_within(c, run, lead_m))
    }
}

impl Circle {
    /// The path from the circle's start to the polar angle `angle_rad` in the circle's sense
    /// (m), where a record's first command on the circle stands there, past its start by
    /// more than [`BEGUN_MID_CIRCLE_M`] each way: the record began while the command ran
    /// round it, and the path it has run counts from the circle's start, as the windows at
    /// its end are measured back from its programmed length (counted from the record's
    /// first sample, those windows fell short by all the record missed, and the table's
    /// slowing into the end counted as the circle's form). `None` at the start, where the
    /// path counts from where the command sets off. On a circle of several turns, the
    /// first pass's.
    pub(super) fn begun_at_m(&self, angle_rad: f64) -> Option<f64> {
        let sense = if self.ccw { 1.0 } else { -1.0 };
        let arc_m = self.radius_m * (sense * (angle_rad - self.start_rad)).rem_euclid(TAU);
        let turn_m = TAU * self.radius_m;
        (arc_m > BEGUN_MID_CIRCLE_M && arc_m < turn_m - BEGUN_MID_CIRCLE_M).then_some(arc_m)
    }
}
