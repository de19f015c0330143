//! The contour error of one point against one programmed segment in 3-D (docs/model.md §3):
//! the foot point on the line, arc or helix nearest the tool, the distance to it, and that
//! deviation split into its part in the block's plane (signed to the left of travel, seen
//! from the plane normal's + side) and its part across the plane.
//!
//! A segment that lies in a plane parallel to its working plane — every line and arc of an
//! XY contour — has its foot point where the tool's projection onto that plane has it, so
//! the in-plane part is the 2-D projection's, computed as it always was, and the part across
//! is the plain offset along the normal. Only a segment that climbs along the normal (a 3-D
//! line, a helix) needs the foot point searched in space.

use crate::path::{Geometry, Plane, Segment, dot3, norm3};

/// Newton steps on the foot point of a helix (each squares the error; the in-plane angle
/// starts it within a fraction of the pitch angle).
const HELIX_NEWTON_STEPS: usize = 8;

/// A point's deviation from a segment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Deviation {
    /// Distance from the point to its foot point on the segment (m).
    pub distance_m: f64,
    /// The deviation's part in the block's plane, perpendicular to the path (m): positive to
    /// the left of travel seen from the plane normal's + side.
    pub in_plane_m: f64,
    /// Its part across the plane, perpendicular to the path (m): positive towards the
    /// normal's + side (on a G17 contour, +Z: the tool above the path).
    pub across_m: f64,
    /// On arcs and helices, the radial deviation in the plane (m, positive outward).
    pub radial_m: Option<f64>,
    /// Parameter of the foot point along the segment, in [0, 1].
    pub u: f64,
}

impl Deviation {
    /// The contour error as one signed number: the distance, signed by the in-plane side.
    /// Where nothing deviates across the plane it is the in-plane part exactly.
    pub(crate) fn signed_m(&self) -> f64 {
        if self.across_m == 0.0 {
            self.in_plane_m
        } else {
            self.distance_m.copysign(self.in_plane_m)
        }
    }
}

/// The deviation of `q` (m) from `seg`; `u_hint` picks the turn of a multi-turn arc in its
/// plane (a helix's turn is the one at the point's height).
pub(crate) fn deviation(seg: &Segment, q: [f64; 3], u_hint: f64) -> Deviation {
    let plane = seg.plane();
    let [_, _, n] = plane.axes();
    let climbs = match seg.geometry {
        Geometry::Dwell { .. } => false,
        _ => seg.end_m[n] != seg.start_m[n],
    };
    if !climbs {
        return planar(seg, plane, q, u_hint);
    }
    match seg.geometry {
        Geometry::Arc(_) => helix(seg, q),
        _ => line(seg, q),
    }
}

/// A segment in a plane parallel to its working plane: the 2-D projection's foot point, and
/// the offset along the normal.
fn planar(seg: &Segment, plane: Plane, q: [f64; 3], u_hint: f64) -> Deviation {
    let [_, _, n] = plane.axes();
    let p = seg.project_in_plane(plane.coords(q), u_hint);
    let across = q[n] - seg.start_m[n];
    Deviation {
        distance_m: p.signed_distance_m.hypot(across),
        in_plane_m: p.signed_distance_m,
        across_m: across,
        radial_m: p.radial_m,
        u: p.u,
    }
}

/// A straight line climbing along the plane's normal: the foot point in closed form.
fn line(seg: &Segment, q: [f64; 3]) -> Deviation {
    let d = sub(seg.end_m, seg.start_m);
    let u = (dot3(sub(q, seg.start_m), d) / dot3(d, d)).clamp(0.0, 1.0);
    let foot = [0, 1, 2].map(|i| seg.start_m[i] + d[i] * u);
    let tangent = d.map(|v| v / norm3(d));
    split(seg.plane(), sub(q, foot), tangent, None, u)
}

/// A helix: the foot point from the in-plane angle on the turn at the point's height,
/// refined by Newton's method on (q − P(u))·P′(u) = 0.
fn helix(seg: &Segment, q: [f64; 3]) -> Deviation {
    let Geometry::Arc(arc) = seg.geometry else {
        unreachable!("called for arcs only")
    };
    let plane = seg.plane();
    let [a0, a1, n] = plane.axes();
    let lead = seg.end_m[n] - seg.start_m[n];
    let (phi, dr) = (arc.sweep_rad, arc.r_end_m - arc.r_start_m);
    // P′(u) and P″(u) in the plane's axes (first, second, normal).
    let derivatives = |u: f64| {
        let r = arc.r_start_m + dr * u;
        let (sin, cos) = (arc.theta_start_rad + phi * u).sin_cos();
        (
            [dr * cos - r * phi * sin, dr * sin + r * phi * cos, lead],
            [
                -2.0 * dr * phi * sin - r * phi * phi * cos,
                2.0 * dr * phi * cos - r * phi * phi * sin,
                0.0,
            ],
        )
    };
    let local = |p: [f64; 3]| [p[a0], p[a1], p[n]];
    let ql = local(q);
    // The turn is the one at the point's height along the normal: the in-plane angle then
    // places the foot point within it.
    let height = ((q[n] - seg.start_m[n]) / lead).clamp(0.0, 1.0);
    let mut u = seg.project_in_plane(plane.coords(q), height).u;
    for _ in 0..HELIX_NEWTON_STEPS {
        let e = sub(ql, local(seg.point_at_param(u)));
        let (d1, d2) = derivatives(u);
        let g = dot3(e, d1);
        let slope = dot3(e, d2) - dot3(d1, d1);
        if slope >= 0.0 {
            break;
        }
        let next = (u - g / slope).clamp(0.0, 1.0);
        let done = (next - u).abs() < 1e-15;
        u = next;
        if done {
            break;
        }
    }
    let foot = seg.point_at_param(u);
    let (d1, _) = derivatives(u);
    let mut tangent = [0.0; 3];
    (tangent[a0], tangent[a1], tangent[n]) = (d1[0], d1[1], d1[2]);
    let tangent = tangent.map(|v| v / norm3(d1));
    let rel = [q[a0] - arc.center_m[0], q[a1] - arc.center_m[1]];
    let radial = rel[0].hypot(rel[1]) - (arc.r_start_m + dr * u);
    split(plane, sub(q, foot), tangent, Some(radial), u)
}

/// The deviation `e` from a foot point with unit tangent `t`, split into its in-plane and
/// across parts: n = (k × t)/|k × t| lies in the plane, left of travel; b = t × n is the
/// normal k tilted by the path's climb.
fn split(plane: Plane, e: [f64; 3], t: [f64; 3], radial_m: Option<f64>, u: f64) -> Deviation {
    let mut k = [0.0; 3];
    k[plane.axes()[2]] = 1.0;
    let side = cross(k, t);
    let size = norm3(side);
    let (in_plane_m, across_m) = if size < 1e-12 {
        // Along the normal itself the plane gives no side: all of it counts in the plane.
        (norm3(e), 0.0)
    } else {
        let n = side.map(|v| v / size);
        (dot3(e, n), dot3(e, cross(t, n)))
    };
    Deviation {
        distance_m: norm3(e),
        in_plane_m,
        across_m,
        radial_m,
        u,
    }
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::path::{Arc, Blend, Motion};
    use std::f64::consts::{FRAC_PI_2, PI, TAU};

    fn segment(geometry: Geometry, start_m: [f64; 3], end_m: [f64; 3]) -> Segment {
        Segment {
            geometry,
            start_m,
            end_m,
            motion: Motion::Feed,
            feed_m_per_s: 0.01,
            blend: Blend::ExactStop,
            line: 1,
            jerk_limited: None,
            plane: Plane::Xy,
        }
    }

    /// Two turns of a ccw helix of radius 50 mm about the Z axis, climbing 10 mm a turn.
    fn helix_segment() -> (Segment, f64) {
        let (r, lead) = (0.05, 0.01);
        let arc = Arc {
            center_m: [0.0, 0.0],
            r_start_m: r,
            r_end_m: r,
            theta_start_rad: 0.0,
            sweep_rad: 2.0 * TAU,
        };
        let seg = segment(Geometry::Arc(arc), [r, 0.0, 0.0], [r, 0.0, 2.0 * lead]);
        // The climb angle: tan α = lead per turn / circumference.
        (seg, (lead / (TAU * r)).atan())
    }

    #[test]
    fn a_helix_point_off_radially_is_off_in_the_plane_only() {
        let (seg, _) = helix_segment();
        // 1.3 turns in (the second turn), 10 µm outside the cylinder.
        let u = 1.3 / 2.0;
        let th = 2.0 * TAU * u;
        let r = 0.05 + 10e-6;
        let q = [r * th.cos(), r * th.sin(), 0.02 * u];
        let d = deviation(&seg, q, u);
        assert!((d.u - u).abs() < 1e-9, "{}", d.u);
        assert!((d.distance_m - 10e-6).abs() < 1e-12, "{}", d.distance_m);
        // Outward is to the right of ccw travel.
        assert!((d.in_plane_m + 10e-6).abs() < 1e-12, "{}", d.in_plane_m);
        assert!((d.radial_m.unwrap() - 10e-6).abs() < 1e-12);
        assert!(d.across_m.abs() < 1e-12, "{}", d.across_m);
    }

    #[test]
    fn a_helix_point_is_placed_on_the_turn_at_its_height() {
        let (seg, _) = helix_segment();
        // A fifth of the first turn in; the second turn passes 10 mm above it.
        let p = seg.point_at_param(0.1);
        let d = deviation(&seg, [p[0] + 2e-6, p[1], p[2]], 0.5);
        assert!((d.u - 0.1).abs() < 1e-4, "{}", d.u);
        assert!(d.distance_m < 3e-6, "{}", d.distance_m);
    }

    #[test]
    fn a_helix_point_above_the_path_is_off_across_by_the_climb_angle() {
        let (seg, alpha) = helix_segment();
        let u = 0.4;
        let p = seg.point_at_param(u);
        let dz = 20e-6;
        let q = [p[0], p[1], p[2] + dz];
        let d = deviation(&seg, q, u);
        // The nearest point slides along the path by dz·sin α; what remains is dz·cos α
        // across the plane (to second order in dz/R).
        let expected = dz * alpha.cos();
        assert!(
            (d.distance_m - expected).abs() < 1e-3 * expected,
            "{}",
            d.distance_m
        );
        assert!(
            (d.across_m - expected).abs() < 1e-3 * expected,
            "{}",
            d.across_m
        );
        assert!(d.in_plane_m.abs() < 1e-3 * expected, "{}", d.in_plane_m);
        assert!(d.signed_m() > 0.0);
    }

    #[test]
    fn a_climbing_line_splits_its_deviation_by_the_working_plane() {
        // From the origin to (30, 40, 50) mm: 45° climb, heading along (3, 4)/5 in XY.
        let seg = segment(Geometry::Line, [0.0; 3], [0.03, 0.04, 0.05]);
        let mid = [0.015, 0.020, 0.025];
        // 5 µm to the left in XY (perpendicular to the heading, horizontal).
        let left = [-4.0 / 5.0, 3.0 / 5.0, 0.0].map(|v| v * 5e-6);
        let q = [0, 1, 2].map(|i| mid[i] + left[i]);
        let d = deviation(&seg, q, 0.5);
        assert!((d.in_plane_m - 5e-6).abs() < 1e-15, "{}", d.in_plane_m);
        assert!(d.across_m.abs() < 1e-15);
        // 5 µm straight up: half of it along the 45° path, the rest across.
        let q = [mid[0], mid[1], mid[2] + 5e-6];
        let d = deviation(&seg, q, 0.5);
        let across = 5e-6 * (PI / 4.0).cos();
        assert!((d.across_m - across).abs() < 1e-15, "{}", d.across_m);
        assert!((d.distance_m - across).abs() < 1e-15);
        assert!(d.in_plane_m.abs() < 1e-15);
    }

    #[test]
    fn an_xy_contour_keeps_its_signed_2d_error_and_adds_z() {
        let arc = Arc {
            center_m: [0.0, 0.0],
            r_start_m: 0.1,
            r_end_m: 0.1,
            theta_start_rad: 0.0,
            sweep_rad: FRAC_PI_2,
        };
        let seg = segment(Geometry::Arc(arc), [0.1, 0.0, -0.002], [0.0, 0.1, -0.002]);
        let q2 = [0.100_003 * 0.6, 0.100_003 * 0.8];
        let flat = deviation(&seg, [q2[0], q2[1], -0.002], 0.5);
        assert_eq!(flat.signed_m(), seg.project_xy(q2, 0.5).signed_distance_m);
        assert_eq!(flat.across_m, 0.0);
        let high = deviation(&seg, [q2[0], q2[1], -0.002 + 4e-6], 0.5);
        assert!((high.across_m - 4e-6).abs() < 1e-15);
        assert!(
            (high.distance_m - 5e-6).abs() < 1e-12,
            "{}",
            high.distance_m
        );
        assert!(high.signed_m() < 0.0, "outside a ccw arc is to the right");
    }
}
