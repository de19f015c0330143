//! Compensation tables a control can load: the static errors of a machine's axes — its
//! measuring-system errors (scale, cyclic, a learned position map), its backlash and lost
//! motion beyond its scale — as offsets of the actual position from the commanded one, per
//! direction of travel.
//!
//! The offset at a position is found from the model rather than by reasoning about signs:
//! the axis is put at rest where its feedback reads the position (as the control holds it),
//! and the table's place there, less the position, is the error (a linear scale reading too
//! long leaves the table short; a lead error on a motor encoder moves it along). Backlash
//! follows where the loop closes: on a motor encoder the table trails the screw by half the
//! gap, against the direction of travel; on a linear scale the loop reads the table beyond
//! the gap and holds it where the scale says, so at rest the gap leaves no offset and the
//! table carries none (an offset there would move the table by it and create the lost
//! motion it meant to remove).
//!
//! Two layouts are written:
//! - a control-neutral CSV, `axis,position_mm,forward_um,reverse_um` (documented in
//!   docs/report-schema.md);
//! - LinuxCNC's joint compensation file, `COMP_FILE_TYPE = 1`: one line per point, the
//!   nominal position, the offset travelling in the positive and in the negative direction,
//!   in machine units (mm here), ascending, at most 256 lines — as LinuxCNC's INI
//!   documentation (`[JOINT_n] COMP_FILE`) describes it. A joint with a compensation file
//!   ignores its `BACKLASH`, so the backlash is in the file.

#[cfg(feature = "cli")]
use std::fmt::Write as _;

use crate::machine::{AxisConfig, AxisName, Feedback, MachineConfig};
use crate::numeric::units::{m_from_mm, um_from_m};
use crate::sim::AxisModel;
use crate::sim::geometry::CrossTerms;
use crate::sim::model::X2;
use crate::sim::simulate::rest_state;

/// Points of a table over the travel at least (a scale error is a straight line).
const GRID_POINTS: usize = 101;
/// Points a period of a cyclic error gets: a control interpolating linearly between them
/// misses its sine by at most A·(π/16)²/2, 2 % of its amplitude.
const POINTS_PER_PERIOD: f64 = 16.0;
/// Most points of a table: a millimetre's cyclic error over six metres of travel.
const MOST_POINTS: usize = 100_000;
/// Most lines LinuxCNC keeps per joint.
pub const LINUXCNC_MOST_POINTS: usize = 256;

/// One axis's table.
#[derive(Debug, Clone, PartialEq)]
pub struct AxisCompensation {
    /// The axis.
    pub axis: AxisName,
    /// (position mm, offset travelling forward µm, offset travelling in reverse µm),
    /// ascending.
    pub points: Vec<(f64, f64, f64)>,
}

/// The tables of the axes that have anything to compensate; none when nothing has.
pub fn compensation(machine: &MachineConfig) -> Vec<AxisCompensation> {
    AxisName::BOTH
        .into_iter()
        .filter_map(|axis| axis_compensation(machine, axis))
        .collect()
}

fn axis_compensation(machine: &MachineConfig, axis: AxisName) -> Option<AxisCompensation> {
    let config = machine.axis(axis);
    let mut model = AxisModel::from_config(config);
    if cyclic_too_fine(config, &model).is_some() {
        // Drawn at points its period apart, it would come out as another, slower curve.
        model.measuring.amplitude_m = 0.0;
    }
    let map = CrossTerms::of(machine, axis);
    // Only a loop closed before the gap leaves the table off by half of it at rest.
    let half_gap_um = match config.position_loop.feedback {
        Feedback::MotorEncoder => 0.5 * config.drive.backlash_um,
        Feedback::LinearScale => 0.0,
    };
    // Beyond the scale the axis reads half the offset more travelling forward.
    let half_offset_um = 0.5 * config.errors.direction_offset_um;
    if !model.measuring.is_active()
        && map.map.is_empty()
        && half_gap_um == 0.0
        && half_offset_um == 0.0
    {
        return None;
    }
    let positions = positions_mm(config, &model);
    let points = positions
        .into_iter()
        .map(|p| {
            let (state, _) = rest_state(&model, m_from_mm(p));
            // Where the table stands, and the position map beyond the scale.
            let offset_um = um_from_m(state[X2] - m_from_mm(p) + map.map_at(state[X2]));
            let forward = half_offset_um - half_gap_um;
            (p, offset_um + forward, offset_um - forward)
        })
        .collect();
    Some(AxisCompensation { axis, points })
}

/// The axes whose backlash (µm) the tables leave out because their loops read the table
/// beyond the gap.
pub fn gaps_behind_a_scale(machine: &MachineConfig) -> Vec<(AxisName, f64)> {
    AxisName::BOTH
        .into_iter()
        .map(|axis| (axis, machine.axis(axis)))
        .filter(|(_, c)| {
            c.position_loop.feedback == Feedback::LinearScale && c.drive.backlash_um > 0.0
        })
        .map(|(axis, c)| (axis, c.drive.backlash_um))
        .collect()
}

/// Where the table has points: those of a learned position map (within LinuxCNC's limit),
/// else an even grid over the axis's travel, or ±500 mm without one: 101 points, or
/// [`POINTS_PER_PERIOD`] a period of a cyclic error where that is more.
fn positions_mm(config: &AxisConfig, model: &AxisModel) -> Vec<f64> {
    let map = &config.errors.position_map_mm;
    if !map.is_empty() {
        let every = map.len().div_ceil(LINUXCNC_MOST_POINTS);
        let mut kept: Vec<f64> = map.iter().step_by(every).copied().collect();
        if kept.last() != map.last() {
            kept.push(map[map.len() - 1]);
        }
        kept.truncate(LINUXCNC_MOST_POINTS);
        return kept;
    }
    let [lo, hi] = travel_mm(config);
    // A cyclic error needs its points a fraction of its period apart, or the table a
    // control interpolates between them draws another curve ([`cyclic_too_fine`] leaves one
    // out that would need more than the most points).
    let n = cyclic_points(config, model)
        .filter(|n| *n <= MOST_POINTS as f64)
        .map_or(GRID_POINTS, |n| (n as usize).max(GRID_POINTS));
    (0..n)
        .map(|k| lo + (hi - lo) * k as f64 / (n - 1) as f64)
        .collect()
}

/// The travel a table spans (mm): the machine file's, or ±500 mm without one.
fn travel_mm(config: &AxisConfig) -> [f64; 2] {
    config.limits.travel_mm.unwrap_or([-500.0, 500.0])
}

/// The points [`POINTS_PER_PERIOD`] a period of the axis's cyclic error need over its
/// travel, where it has one (unbounded for a period of nothing).
fn cyclic_points(config: &AxisConfig, model: &AxisModel) -> Option<f64> {
    let m = &model.measuring;
    (m.amplitude_m != 0.0 && m.wavenumber_per_m > 0.0).then(|| {
        let [lo, hi] = travel_mm(config);
        let period_mm = 1e3 * std::f64::consts::TAU / m.wavenumber_per_m;
        ((hi - lo) / period_mm * POINTS_PER_PERIOD).ceil() + 1.0
    })
}

/// Why the axis's cyclic error is left out of its table, where its period is too short to
/// draw over the travel within the most points.
fn cyclic_too_fine(config: &AxisConfig, model: &AxisModel) -> Option<String> {
    let n = cyclic_points(config, model)?;
    let [lo, hi] = travel_mm(config);
    // A period of nothing needs infinitely many (or NaN of them): too many as well.
    let drawable = n.is_finite() && n <= MOST_POINTS as f64;
    (!drawable).then(|| {
        format!(
            "its cyclic error is left out: {POINTS_PER_PERIOD} points a period over {lo}..{hi} \
             mm would be {n:.0}, more than the {MOST_POINTS} a table holds"
        )
    })
}

/// The axes whose cyclic error the tables leave out, and why (its period too short to draw
/// over the travel).
pub fn cyclic_errors_left_out(machine: &MachineConfig) -> Vec<(AxisName, String)> {
    AxisName::BOTH
        .into_iter()
        .filter_map(|axis| {
            let config = machine.axis(axis);
            let why = cyclic_too_fine(config, &AxisModel::from_config(config))?;
            Some((axis, why))
        })
        .collect()
}

/// The tables as the control-neutral CSV.
#[cfg(feature = "cli")]
pub(crate) fn neutral_csv(tables: &[AxisCompensation]) -> String {
    let mut s = String::from("axis,position_mm,forward_um,reverse_um\n");
    for t in tables {
        for (p, f, r) in &t.points {
            let _ = writeln!(s, "{},{p:.4},{f:.3},{r:.3}", t.axis);
        }
    }
    s
}

/// One axis's table as a LinuxCNC compensation file (type 1, mm); why not where it has
/// more points than LinuxCNC keeps (a cyclic error's over a long travel).
#[cfg(feature = "cli")]
pub(crate) fn linuxcnc_file(table: &AxisCompensation) -> Result<String, String> {
    let n = table.points.len();
    if n > LINUXCNC_MOST_POINTS {
        return Err(format!(
            "its table needs {n} points ({POINTS_PER_PERIOD} a period of its cyclic error over \
             the travel) and LinuxCNC keeps {LINUXCNC_MOST_POINTS} per joint: load \
             compensation.csv into a control that takes them"
        ));
    }
    let mut s = String::new();
    for (p, f, r) in &table.points {
        let _ = writeln!(s, "{p:.4} {:.6} {:.6}", f * 1e-3, r * 1e-3);
    }
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_scale_error_is_an_offset_and_a_gap_behind_the_scale_is_none() {
        let mut m = MachineConfig::default_preset();
        assert_eq!(m.x.position_loop.feedback, Feedback::LinearScale);
        // The X scale reads 100 ppm long: the control holds the table 100 ppm short.
        m.x.errors.scale_error_ppm = 100.0;
        m.x.drive.backlash_um = 8.0;
        let tables = compensation(&m);
        assert_eq!(tables.len(), 1);
        let x = &tables[0];
        assert_eq!(x.axis, AxisName::X);
        let at = |p: f64| *x.points.iter().find(|q| (q.0 - p).abs() < 1e-9).unwrap();
        let (_, forward, reverse) = at(1000.0);
        // Held where the scale reads 1000 mm, the table stands at 1000/(1 + 10⁻⁴) mm:
        // 99.990 µm short whichever way it came, the gap lying before the scale.
        let short_um = -1e6 * 1e-4 / (1.0 + 1e-4);
        assert!((forward - short_um).abs() < 1e-6, "{forward}");
        assert!((reverse - short_um).abs() < 1e-6, "{reverse}");
        let text = linuxcnc_file(x).unwrap();
        assert_eq!(text.lines().count(), x.points.len());
        assert!(text.contains("\n1000.0000 -0.099990 -0.099990\n"), "{text}");
        assert_eq!(gaps_behind_a_scale(&m), vec![(AxisName::X, 8.0)]);
        // Nothing to compensate on the nominal machine, nor for a gap behind the scale.
        assert!(compensation(&MachineConfig::default_preset()).is_empty());
        m.x.errors.scale_error_ppm = 0.0;
        assert!(compensation(&m).is_empty());
    }

    #[test]
    fn a_cyclic_error_gets_points_close_enough_to_draw_it_and_no_linuxcnc_file_past_its_limit() {
        // X's scale reads 3 µm · sin(2π·x/16 mm + 30°) too long over a travel of 1000 mm:
        // held where the scale reads p, the table stands 3 µm · sin(2π·p/16 + 30°) short
        // (to within A·k = 1.2·10⁻³ of it).
        let mut m = MachineConfig::default_preset();
        m.x.limits.travel_mm = Some([0.0, 1000.0]);
        m.x.errors.cyclic_amplitude_um = 3.0;
        m.x.errors.cyclic_period_mm = 16.0;
        m.x.errors.cyclic_phase_deg = 30.0;
        let x = &compensation(&m)[0];
        let short_um =
            |p: f64| -3.0 * (std::f64::consts::TAU * p / 16.0 + 30f64.to_radians()).sin();
        // Between every two points, as a control interpolates them: within 2.5 % of the
        // amplitude (a grid of 101 points, 10 mm apart, would miss it by more than itself).
        for w in x.points.windows(2) {
            let ((p0, f0, _), (p1, f1, _)) = (w[0], w[1]);
            let mid = 0.5 * (p0 + p1);
            let drawn = 0.5 * (f0 + f1);
            assert!(
                (drawn - short_um(mid)).abs() <= 0.025 * 3.0 + 0.01,
                "{mid} mm: {drawn}"
            );
        }
        // 1001 points: more than LinuxCNC keeps, so no file for it, and why.
        assert!(x.points.len() > LINUXCNC_MOST_POINTS);
        let why = linuxcnc_file(x).unwrap_err();
        assert!(why.contains("256 per joint"), "{why}");
        assert!(cyclic_errors_left_out(&m).is_empty());
        // A scale's 20 µm pitch (or a period of nothing) over the metre would need 800,000
        // points or more: left out of the table, and said, not drawn as an alias of itself.
        for period_mm in [0.02, 1e-300] {
            m.x.errors.cyclic_period_mm = period_mm;
            assert!(compensation(&m).is_empty(), "{period_mm}");
            let left = cyclic_errors_left_out(&m);
            assert_eq!(left.len(), 1, "{period_mm}");
            assert!(left[0].1.contains("left out"), "{left:?}");
        }
    }

    #[test]
    fn a_gap_before_a_motor_encoder_is_half_of_it_against_the_travel() {
        let mut m = MachineConfig::default_preset();
        m.x.position_loop.feedback = Feedback::MotorEncoder;
        m.x.drive.backlash_um = 8.0;
        // The loop holds the motor; travelling + the nut pushes the table from behind,
        // 4 µm short of the motor's place, travelling − 4 µm beyond it.
        let tables = compensation(&m);
        assert_eq!(tables.len(), 1);
        for &(_, forward, reverse) in &tables[0].points {
            assert!((forward + 4.0).abs() < 1e-6, "{forward}");
            assert!((reverse - 4.0).abs() < 1e-6, "{reverse}");
        }
        assert!(gaps_behind_a_scale(&m).is_empty());
    }

    #[test]
    fn lost_motion_beyond_the_scale_is_an_offset_by_direction() {
        // Y reads 6 µm more travelling + than travelling −: +3 µm forward, −3 µm back.
        let mut m = MachineConfig::default_preset();
        m.y.errors.direction_offset_um = 6.0;
        let tables = compensation(&m);
        assert_eq!(tables.len(), 1);
        assert_eq!(tables[0].axis, AxisName::Y);
        for &(_, forward, reverse) in &tables[0].points {
            assert!((forward - 3.0).abs() < 1e-6 && (reverse + 3.0).abs() < 1e-6);
        }
    }
}
