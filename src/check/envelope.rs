//! Whether a program fits the machine, checked before anything is planned: it moves X or
//! Y, and its whole path — arcs included, not only their end points — stays inside each
//! axis's travel, as a control's soft limits demand. Without travel limits in the machine
//! file the bound is ±1 km: no machine tool reaches farther, and beyond it a simulation
//! resolving nanometres runs out of floating-point digits.

use crate::gcode::Program;
use crate::machine::{Limits, MachineConfig};
use crate::numeric::units::mm_from_m;

/// The bound on any coordinate when the machine file sets no travel (mm).
const FARTHEST_MM: f64 = 1e6;

/// Why a program does not fit the machine.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EnvelopeError {
    /// Nothing moves in the plane the tool checks.
    #[error("{file}: the program moves neither X nor Y — there is no contour to check")]
    NoMotion {
        /// The program.
        file: String,
    },
    /// A block leaves an axis's travel.
    #[error(
        "{file}:{line}: {axis} reaches {reach_mm:.3} mm, outside its travel {lo_mm} … {hi_mm} mm \
         ({source_of_limit})"
    )]
    OutsideTravel {
        /// The program.
        file: String,
        /// The block's line.
        line: u32,
        /// `X`, `Y` or `Z`.
        axis: char,
        /// The farthest the block goes beyond the travel (mm).
        reach_mm: f64,
        /// The travel's lower end (mm).
        lo_mm: f64,
        /// Its upper end (mm).
        hi_mm: f64,
        /// The machine key that sets it, or why there is a bound without one.
        source_of_limit: String,
    },
}

/// Checks that `program` moves in XY and stays inside `machine`'s travel.
pub fn check_fits(program: &Program, machine: &MachineConfig) -> Result<(), EnvelopeError> {
    let moves_xy = program
        .segments
        .iter()
        .any(|s| !s.is_dwell() && s.xy_length_m() > 0.0);
    if !moves_xy {
        return Err(EnvelopeError::NoMotion {
            file: program.file.clone(),
        });
    }
    let travels = [
        ('X', travel(&machine.x.limits, "x")),
        ('Y', travel(&machine.y.limits, "y")),
        ('Z', travel(machine.z.limits(), "z")),
    ];
    for seg in program.segments.iter().filter(|s| !s.is_dwell()) {
        for (extent_m, (axis, (lo_mm, hi_mm, source))) in seg.extent_m().iter().zip(&travels) {
            let [min_mm, max_mm] = extent_m.map(mm_from_m);
            // NaN never compares inside: it is refused too.
            let inside = |v: f64| v >= *lo_mm && v <= *hi_mm;
            if !(inside(min_mm) && inside(max_mm)) {
                let reach_mm = if inside(min_mm) { max_mm } else { min_mm };
                return Err(EnvelopeError::OutsideTravel {
                    file: program.file.clone(),
                    line: seg.line,
                    axis: *axis,
                    reach_mm,
                    lo_mm: *lo_mm,
                    hi_mm: *hi_mm,
                    source_of_limit: source.clone(),
                });
            }
        }
    }
    Ok(())
}

/// An axis's travel (mm) and where it comes from.
fn travel(limits: &Limits, axis: &str) -> (f64, f64, String) {
    match limits.travel_mm {
        Some([lo, hi]) => (lo, hi, format!("{axis}.limits.travel_mm")),
        None => (
            -FARTHEST_MM,
            FARTHEST_MM,
            format!("no {axis}.limits.travel_mm given; no machine tool reaches beyond ±1 km"),
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gcode::{InterpretOptions, parse_program};

    fn fits(src: &str) -> Result<(), EnvelopeError> {
        let p = parse_program(src, "t.nc", &InterpretOptions::default()).unwrap();
        check_fits(&p, &MachineConfig::default_preset())
    }

    #[test]
    fn an_arc_is_bounded_by_its_bulge_not_its_ends() {
        // A half circle of R 1400 about (0, 0) from (-1400, 0) over the top: it reaches
        // Y 1400 inside the ±1500 mm travel, but R 1600 reaches 1600 outside it.
        assert!(fits("G0 X-1400 Y0\nG2 X1400 Y0 I1400 J0 F500\n").is_ok());
        match fits("G0 X-1600 Y0\nG2 X1600 Y0 I1600 J0 F500\n") {
            Err(EnvelopeError::OutsideTravel {
                line: 2,
                axis: 'Y',
                reach_mm,
                ..
            }) => assert!((reach_mm - 1600.0).abs() < 1e-6, "{reach_mm}"),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn z_travel_and_a_program_without_xy_motion() {
        assert!(matches!(
            fits("G1 X1 F100\nG1 Z-1200\n"),
            Err(EnvelopeError::OutsideTravel {
                axis: 'Z',
                line: 2,
                ..
            })
        ));
        assert!(matches!(
            fits("G1 Z-5 F100\nG4 P1\n"),
            Err(EnvelopeError::NoMotion { .. })
        ));
    }
}
