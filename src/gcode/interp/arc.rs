//! Arcs (`G2`/`G3`) in the working plane — XY (G17, centre by I/J), ZX (G18, by K/I) or YZ
//! (G19, by J/K) — or by radius (R), helical along the plane's normal and multi-turn,
//! checked against LinuxCNC's tolerances. As in RS274/NGC, G18's arcs turn from Z towards X
//! and G19's from Y towards Z: counter-clockwise (G3) seen from the normal's + side.

use super::{IResult, Interpreter, err};
use crate::gcode::error::{GcodeErrorKind, Warning};
use crate::numeric::units::{MM_PER_INCH, m_from_mm};
use crate::path::{Arc, Geometry, Motion, Plane, Segment};

/// The most turns an arc's `P` may ask for: one block of more is no part program's (a
/// helix that long is programmed in a loop), and each turn is planned and simulated.
const MAX_ARC_TURNS: f64 = 10_000.0;

/// LinuxCNC's absolute tolerance on the start/end radius difference of an I/J arc
/// (CENTER_ARC_RADIUS_TOLERANCE_MM = 2·0.01·√2 mm; the inch value, 2·0.001·√2 in, applies
/// under G20).
const ARC_RADIUS_TOL_MM: f64 = 2.0 * 0.01 * std::f64::consts::SQRT_2;
const ARC_RADIUS_TOL_INCH: f64 = 2.0 * 0.001 * std::f64::consts::SQRT_2;
/// LinuxCNC's relative tolerance on the same difference (SPIRAL_RELATIVE_TOLERANCE).
const ARC_RADIUS_REL_TOL: f64 = 0.001;
/// Slack for an R arc's radius against half its chord (RADIUS_TOLERANCE_INCH = 0.00005 in).
const R_ARC_SLACK_INCH: f64 = 0.00005;
/// R arcs within this angle of a half circle get a conditioning warning.
const R_ARC_NEAR_HALF_DEG: f64 = 5.0;
/// I/J arcs whose end lies within this distance of the start (but not on it) are warned.
const NEAR_COINCIDENT_MM: f64 = 0.001;

/// The centre-offset word of each axis: I for X, J for Y, K for Z.
const OFFSET_LETTERS: [u8; 3] = [b'I', b'J', b'K'];

impl Interpreter {
    /// G2/G3 in the working plane, by centre or R, optionally helical and multi-turn (P).
    pub(super) fn arc(&mut self, ccw: bool, end_mm: [f64; 3], offset: u32) -> IResult<()> {
        self.check_arc_plane(ccw, offset)?;
        let turns = self.arc_turns(offset)?;
        let [a0, a1, _] = self.plane.axes();
        let [l0, l1] = [a0, a1].map(|a| OFFSET_LETTERS[a]);
        let has_ij = self.block.get(l0).is_some() || self.block.get(l1).is_some();
        let words = format!("{}/{}", l0 as char, l1 as char);
        let (center, r_start, r_end) = match (self.block.get(b'R'), has_ij) {
            (Some(_), true) => {
                let off = self.block.offset_of(b'R');
                return err(
                    off,
                    GcodeErrorKind::Invalid(format!("arc with both R and {words}")),
                );
            }
            (None, false) => {
                return err(
                    offset,
                    GcodeErrorKind::Invalid(format!("arc needs {words} or R")),
                );
            }
            (Some(r), false) => self.r_arc_center(ccw, r, end_mm)?,
            (None, true) => self.ij_arc_center(end_mm)?,
        };
        let start = self.pos_mm;
        let (s, e) = (self.plane.coords(start), self.plane.coords(end_mm));
        let th0 = (s[1] - center[1]).atan2(s[0] - center[0]);
        let th1 = (e[1] - center[1]).atan2(e[0] - center[0]);
        let mut sweep = if ccw {
            let d = (th1 - th0).rem_euclid(std::f64::consts::TAU);
            if d == 0.0 { std::f64::consts::TAU } else { d }
        } else {
            let d = (th0 - th1).rem_euclid(std::f64::consts::TAU);
            -(if d == 0.0 { std::f64::consts::TAU } else { d })
        };
        sweep += sweep.signum() * std::f64::consts::TAU * (turns - 1) as f64;
        self.warn_near_coincident(s, e, sweep);
        let arc = Arc {
            center_m: [m_from_mm(center[0]), m_from_mm(center[1])],
            r_start_m: m_from_mm(r_start),
            r_end_m: m_from_mm(r_end),
            theta_start_rad: th0,
            sweep_rad: sweep,
        };
        self.segments.push(Segment {
            geometry: Geometry::Arc(arc),
            start_m: self.pos_m(),
            end_m: end_mm.map(m_from_mm),
            motion: Motion::Feed,
            feed_m_per_s: self.feed_for(Motion::Feed),
            blend: self.blend,
            line: self.line,
            jerk_limited: self.jerk_limited,
            plane: self.plane,
        });
        self.pos_mm = end_mm;
        Ok(())
    }

    /// Refuses what an arc in the working plane cannot take: the normal axis's centre word
    /// (K in G17, J in G18, I in G19), and a plane other than XY under a rotated coordinate
    /// system (the rotation turns XY about Z, which would tilt such an arc out of its plane).
    fn check_arc_plane(&self, ccw: bool, offset: u32) -> IResult<()> {
        let plane = self.plane;
        let normal = OFFSET_LETTERS[plane.axes()[2]];
        if let Some(k) = self.block.values[(normal - b'A') as usize] {
            return err(
                k.1,
                GcodeErrorKind::Invalid(format!(
                    "{} word in an arc in the {} plane ({})",
                    normal as char,
                    plane.name(),
                    plane.gcode()
                )),
            );
        }
        if plane != Plane::Xy && self.rotation_deg[self.coord_index] != 0.0 {
            let word = if ccw { "G3" } else { "G2" };
            return err(
                offset,
                GcodeErrorKind::Unsupported {
                    word: word.into(),
                    reason: "an arc outside XY (G18/G19) in a rotated coordinate system \
                             (G10 L2 R): the rotation about Z would tilt it out of its plane",
                },
            );
        }
        Ok(())
    }

    fn arc_turns(&self, offset: u32) -> IResult<u32> {
        match self.block.get(b'P') {
            None => Ok(1),
            Some(p) if p >= 1.0 && p.fract() == 0.0 && p <= MAX_ARC_TURNS => Ok(p as u32),
            Some(p) => err(
                offset,
                GcodeErrorKind::Invalid(format!(
                    "arc P{p}: turns must be a whole number from 1 to {MAX_ARC_TURNS}"
                )),
            ),
        }
    }

    /// The centre (in the plane's coordinates, mm) from the plane's two centre words, and
    /// the start and end radii.
    fn ij_arc_center(&self, end: [f64; 3]) -> IResult<([f64; 2], f64, f64)> {
        let [a0, a1, _] = self.plane.axes();
        let [l0, l1] = [a0, a1].map(|a| OFFSET_LETTERS[a]);
        let start = self.pos_mm;
        let i = self.block.get(l0).unwrap_or(0.0) * self.mm_per_unit;
        let j = self.block.get(l1).unwrap_or(0.0) * self.mm_per_unit;
        let start_prog = self.machine_to_program(start);
        let mut center_prog = [0.0; 3];
        if self.arc_absolute {
            (center_prog[a0], center_prog[a1]) = (i, j);
        } else {
            (center_prog[a0], center_prog[a1]) = (start_prog[a0] + i, start_prog[a1] + j);
        }
        let center = self.plane.coords(self.program_to_machine(center_prog));
        let (s, e) = (self.plane.coords(start), self.plane.coords(end));
        let r_start = (s[0] - center[0]).hypot(s[1] - center[1]);
        let r_end = (e[0] - center[0]).hypot(e[1] - center[1]);
        let slack = R_ARC_SLACK_INCH * MM_PER_INCH;
        if r_start < slack || r_end < slack {
            return err(
                self.block.offset_of(l0).max(self.block.offset_of(l1)),
                GcodeErrorKind::ZeroRadiusArc,
            );
        }
        // LinuxCNC's rule: an error beyond 100× the absolute tolerance, or beyond both the
        // absolute and the relative tolerance.
        let tol = if self.mm_per_unit == 1.0 {
            ARC_RADIUS_TOL_MM
        } else {
            ARC_RADIUS_TOL_INCH * MM_PER_INCH
        };
        let diff = (r_start - r_end).abs();
        let rel = diff / r_start.max(r_end);
        if diff > 100.0 * tol || (rel > ARC_RADIUS_REL_TOL && diff > tol) {
            let off = self.first_axis_offset();
            return err(
                off,
                GcodeErrorKind::ArcRadiusMismatch {
                    r_start_mm: r_start,
                    r_end_mm: r_end,
                    diff_mm: diff,
                    tolerance_mm: tol,
                },
            );
        }
        Ok((center, r_start, r_end))
    }

    /// The centre (in the plane's coordinates, mm) of an R-form arc, and its radius twice.
    fn r_arc_center(&mut self, ccw: bool, r: f64, end: [f64; 3]) -> IResult<([f64; 2], f64, f64)> {
        let (start, end) = (self.plane.coords(self.pos_mm), self.plane.coords(end));
        let r_mm = r * self.mm_per_unit;
        let (dx, dy) = (end[0] - start[0], end[1] - start[1]);
        let chord = dx.hypot(dy);
        let off = self.block.offset_of(b'R');
        if chord == 0.0 {
            return err(off, GcodeErrorKind::RArcFullCircle);
        }
        let abs_r = r_mm.abs();
        let half = chord / 2.0;
        if abs_r < half - R_ARC_SLACK_INCH * MM_PER_INCH {
            return err(
                off,
                GcodeErrorKind::ArcRadiusTooSmall {
                    r_mm: abs_r,
                    chord_mm: chord,
                },
            );
        }
        let abs_r = abs_r.max(half);
        let h = (abs_r * abs_r - half * half).max(0.0).sqrt();
        // Centre on the left of the chord for a CCW minor arc (or a CW major arc).
        let left = ccw == (r_mm > 0.0);
        let (nx, ny) = if left {
            (-dy / chord, dx / chord)
        } else {
            (dy / chord, -dx / chord)
        };
        let center = [start[0] + dx / 2.0 + nx * h, start[1] + dy / 2.0 + ny * h];
        self.warn_badly_conditioned_r(abs_r, half, h);
        Ok((center, abs_r, abs_r))
    }

    fn warn_badly_conditioned_r(&mut self, r: f64, half: f64, h: f64) {
        let sweep_deg = 2.0 * (half / r).min(1.0).asin().to_degrees();
        if (180.0 - sweep_deg).abs() < R_ARC_NEAR_HALF_DEG {
            // How far 1 µm of rounding that shortens the half chord moves the centre off the
            // chord: h grows to √(h² + 2·half·δ) — half/h µm per µm where h is large, and
            // √(2·half·δ) at an exact half circle (h = 0), where the slope is infinite.
            let delta_mm = 1e-3;
            let moved_um = 1e3 * ((h * h + 2.0 * half * delta_mm).sqrt() - h);
            self.warnings.push(Warning {
                line: self.line,
                message: format!(
                    "R-format arc spans {:.2}° (near a half circle): its centre is badly \
                     conditioned, 1 µm of end-point rounding moves it by {:.0} µm; prefer I/J",
                    sweep_deg, moved_um
                ),
            });
        }
    }

    fn warn_near_coincident(&mut self, start: [f64; 2], end: [f64; 2], sweep: f64) {
        let d = (end[0] - start[0]).hypot(end[1] - start[1]);
        if d > 0.0 && d < NEAR_COINCIDENT_MM {
            self.warnings.push(Warning {
                line: self.line,
                message: format!(
                    "arc start and end nearly coincide ({:.3} µm apart): read as a {:.1}° arc",
                    d * 1000.0,
                    sweep.abs().to_degrees()
                ),
            });
        }
    }
}
