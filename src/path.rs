//! The programmed path: lines, arcs and dwells with exact geometry, in metres, each
//! carrying the source line of the block that made it.
//!
//! Arcs are general enough for what real controls interpolate: a circle in a principal plane
//! (XY, ZX or YZ: G17, G18, G19), optionally helical (the plane's normal axis linear in the
//! angle) and optionally a slight Archimedean spiral (radius linear in the angle) — the way
//! LinuxCNC interprets an I/J arc whose end radius differs from its start radius within
//! tolerance. Everything downstream evaluates the geometry by arc length `s` along the 3-D
//! path, so that the planner's speed is the true tool speed: the feed of RS274/NGC and of
//! the 840D alike, which both take F along the path of X, Y and Z together.

use serde::Serialize;

/// Whether a move is a rapid (G0) or a feed move (G1/G2/G3).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Motion {
    /// G0: at the machine's rapid rate.
    Rapid,
    /// G1/G2/G3: at the programmed feed.
    Feed,
}

/// How the move ends: stop exactly (G61) or blend into the next (G64).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Blend {
    /// G61 / G61.1: come to a stop at the end of the move.
    ExactStop,
    /// G64: keep moving through the junction, deviating from the corner by at most the
    /// tolerance (metres; `None` = the machine's default).
    Continuous {
        /// G64 P value converted to metres.
        tolerance_m: Option<f64>,
        /// G64 Q, LinuxCNC's "naive CAM" tolerance, converted to metres: short blocks whose
        /// vertices lie this close to a smooth curve are planned through as one (`None`:
        /// the P tolerance serves).
        naive_cam_m: Option<f64>,
    },
}

/// A principal plane: the working plane a block is programmed in (G17, G18, G19). An arc
/// turns in it; a line's contour error is split into the part in it and the part across it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize)]
pub enum Plane {
    /// G17: X then Y, normal Z.
    #[default]
    #[serde(rename = "XY")]
    Xy,
    /// G18: Z then X, normal Y (counter-clockwise seen from +Y).
    #[serde(rename = "ZX")]
    Zx,
    /// G19: Y then Z, normal X.
    #[serde(rename = "YZ")]
    Yz,
}

impl Plane {
    /// Indices (0 = X, 1 = Y, 2 = Z) of the plane's first axis, its second and its normal:
    /// the first turned a quarter counter-clockwise about the normal gives the second.
    pub(crate) fn axes(self) -> [usize; 3] {
        match self {
            Plane::Xy => [0, 1, 2],
            Plane::Zx => [2, 0, 1],
            Plane::Yz => [1, 2, 0],
        }
    }

    /// A point's coordinates in the plane (first, second axis).
    pub(crate) fn coords(self, p: [f64; 3]) -> [f64; 2] {
        let [a, b, _] = self.axes();
        [p[a], p[b]]
    }

    /// The plane's name as reports give it: `XY`, `ZX`, `YZ`.
    pub(crate) fn name(self) -> &'static str {
        match self {
            Plane::Xy => "XY",
            Plane::Zx => "ZX",
            Plane::Yz => "YZ",
        }
    }

    /// The G code that selects it.
    pub(crate) fn gcode(self) -> &'static str {
        match self {
            Plane::Xy => "G17",
            Plane::Zx => "G18",
            Plane::Yz => "G19",
        }
    }

    /// True for G17 (what a serialised segment leaves out).
    pub(crate) fn is_xy(&self) -> bool {
        *self == Plane::Xy
    }
}

/// A circular, helical or slightly spiral arc in its segment's plane ([`Segment::plane`]).
/// Its centre and angles are in that plane's own coordinates (first axis, second axis): for
/// G17 X and Y, for G18 Z and X, for G19 Y and Z.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Arc {
    /// Centre in the plane (m).
    pub center_m: [f64; 2],
    /// Radius at the start (m).
    pub r_start_m: f64,
    /// Radius at the end (m); differs from `r_start_m` only for a tolerated spiral.
    pub r_end_m: f64,
    /// Polar angle of the start point about the centre (rad), from the plane's first axis.
    pub theta_start_rad: f64,
    /// Signed swept angle (rad): positive counter-clockwise seen from the plane normal's +
    /// side (G3), negative clockwise (G2). Its magnitude exceeds 2π for multi-turn arcs.
    pub sweep_rad: f64,
}

/// The shape of a segment.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum Geometry {
    /// A straight move.
    Line,
    /// An arc (see [`Arc`]).
    Arc(Arc),
    /// A dwell (G4): no motion for a time.
    Dwell {
        /// Dwell time (s).
        seconds: f64,
    },
}

/// One segment of the programmed path.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Segment {
    /// Shape.
    pub geometry: Geometry,
    /// Start point in machine coordinates (m).
    pub start_m: [f64; 3],
    /// End point in machine coordinates (m).
    pub end_m: [f64; 3],
    /// Rapid or feed.
    pub motion: Motion,
    /// Programmed feed (m/s); for rapids, `f64::INFINITY` (the machine's rapid rate).
    pub feed_m_per_s: f64,
    /// How the segment ends.
    pub blend: Blend,
    /// 1-based source line of the block that made it.
    pub line: u32,
    /// The acceleration profile the program switched to for it (SINUMERIK `SOFT`: jerk
    /// limited, `BRISK`: acceleration limited); `None`: the planner's own.
    pub jerk_limited: Option<bool>,
    /// The working plane of the block (G17/G18/G19): an arc's plane; for a line, the plane
    /// its contour error is split by.
    #[serde(skip_serializing_if = "Plane::is_xy")]
    pub plane: Plane,
}

/// Position, unit tangent and curvature vector at a point of a segment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathPoint {
    /// Position (m).
    pub pos: [f64; 3],
    /// dP/ds: the unit tangent (zero for dwells).
    pub tangent: [f64; 3],
    /// d²P/ds² (1/m): the curvature vector (zero for lines).
    pub curvature: [f64; 3],
}

/// 8-point Gauss–Legendre nodes and weights on [0, 1]: exact to machine precision for the
/// smooth, nearly constant speed of a spiral arc.
const GL_NODES: [f64; 8] = [
    0.019_855_071_751_231_856,
    0.101_666_761_293_186_63,
    0.237_233_795_041_835_5,
    0.408_282_678_752_175_1,
    0.591_717_321_247_825,
    0.762_766_204_958_164_5,
    0.898_333_238_706_813_4,
    0.980_144_928_248_768_2,
];
const GL_WEIGHTS: [f64; 8] = [
    0.050_614_268_145_188_13,
    0.111_190_517_226_687_24,
    0.156_853_322_938_943_65,
    0.181_341_891_689_181,
    0.181_341_891_689_181,
    0.156_853_322_938_943_65,
    0.111_190_517_226_687_24,
    0.050_614_268_145_188_13,
];

impl Arc {
    /// Radius change over the arc (m).
    fn dr(&self) -> f64 {
        self.r_end_m - self.r_start_m
    }

    fn is_spiral(&self) -> bool {
        self.dr() != 0.0
    }

    /// |dP/du| at parameter u ∈ [0, 1], with `dz` the travel along the plane's normal.
    fn speed_du(&self, u: f64, dz: f64) -> f64 {
        let r = self.r_start_m + self.dr() * u;
        ((self.sweep_rad * r).powi(2) + self.dr().powi(2) + dz * dz).sqrt()
    }

    /// Arc length from u = 0 to `u` (m).
    fn length_to(&self, u: f64, dz: f64) -> f64 {
        if !self.is_spiral() {
            return u * self.speed_du(0.0, dz);
        }
        u * GL_NODES
            .iter()
            .zip(GL_WEIGHTS)
            .map(|(x, w)| w * self.speed_du(u * x, dz))
            .sum::<f64>()
    }

    /// The parameter u at arc length `s` (Newton on the monotone length function).
    fn param_at(&self, s: f64, length: f64, dz: f64) -> f64 {
        if length <= 0.0 {
            return 0.0;
        }
        let mut u = (s / length).clamp(0.0, 1.0);
        if self.is_spiral() {
            for _ in 0..8 {
                let step = (self.length_to(u, dz) - s) / self.speed_du(u, dz);
                u = (u - step).clamp(0.0, 1.0);
                if step.abs() < 1e-15 {
                    break;
                }
            }
        }
        u
    }

    /// The point at parameter u in the plane's coordinates (for G17: X and Y).
    pub(crate) fn in_plane_at(&self, u: f64) -> [f64; 2] {
        let r = self.r_start_m + self.dr() * u;
        let th = self.theta_start_rad + self.sweep_rad * u;
        [
            self.center_m[0] + r * th.cos(),
            self.center_m[1] + r * th.sin(),
        ]
    }

    /// Radius at parameter u (m).
    pub(crate) fn radius_at(&self, u: f64) -> f64 {
        self.r_start_m + self.dr() * u
    }

    /// Smallest radius along the arc (m).
    pub(crate) fn min_radius_m(&self) -> f64 {
        self.r_start_m.min(self.r_end_m)
    }

    /// Length of the projection onto its plane (m).
    pub(crate) fn in_plane_length_m(&self) -> f64 {
        self.length_to(1.0, 0.0)
    }

    /// The lowest and highest coordinates the arc reaches along its plane's two axes (m):
    /// its ends, and each point where it passes a direction of the axes (0°, 90°, 180°,
    /// 270° about the centre).
    pub(crate) fn in_plane_extent_m(&self) -> [[f64; 2]; 2] {
        let mut ext = [[f64::INFINITY, f64::NEG_INFINITY]; 2];
        let mut include = |p: [f64; 2]| {
            for (e, v) in ext.iter_mut().zip(p) {
                e[0] = e[0].min(v);
                e[1] = e[1].max(v);
            }
        };
        include(self.in_plane_at(0.0));
        include(self.in_plane_at(1.0));
        let quarter = std::f64::consts::FRAC_PI_2;
        let (from, to) = if self.sweep_rad >= 0.0 {
            (self.theta_start_rad, self.theta_start_rad + self.sweep_rad)
        } else {
            (self.theta_start_rad + self.sweep_rad, self.theta_start_rad)
        };
        // The radius changes linearly along a spiral, so over many turns the extremes lie
        // in the first or the last turn: the quarter directions of those two suffice.
        let (first, last) = (
            (from / quarter).ceil() as i64,
            (to / quarter).floor() as i64,
        );
        let candidates = (first..=last.min(first + 4)).chain((last - 4).max(first + 5)..=last);
        for k in candidates.filter(|_| self.sweep_rad != 0.0) {
            let u = (k as f64 * quarter - self.theta_start_rad) / self.sweep_rad;
            include(self.in_plane_at(u.clamp(0.0, 1.0)));
        }
        ext
    }
}

impl Segment {
    /// The working plane of the block ([`Segment::plane`]'s value).
    pub fn plane(&self) -> Plane {
        self.plane
    }

    /// Length of the 3-D path (m); zero for dwells.
    pub fn length_m(&self) -> f64 {
        match self.geometry {
            Geometry::Line => dist3(self.start_m, self.end_m),
            Geometry::Arc(a) => a.length_to(1.0, self.normal_travel_m()),
            Geometry::Dwell { .. } => 0.0,
        }
    }

    /// Travel along the plane's normal (m): a helix's lead over the whole segment.
    pub(crate) fn normal_travel_m(&self) -> f64 {
        let n = self.plane().axes()[2];
        self.end_m[n] - self.start_m[n]
    }

    /// True for an arc that also travels along its plane's normal: a helix.
    pub(crate) fn is_helix(&self) -> bool {
        matches!(self.geometry, Geometry::Arc(_)) && self.normal_travel_m() != 0.0
    }

    /// True for a feed move that travels in Z together with X or Y (a helix, a slope, a 3-D
    /// contour); a plunge (Z alone), a rapid or a dwell is not.
    pub(crate) fn cuts_in_space(&self) -> bool {
        if self.motion != Motion::Feed || self.is_dwell() {
            return false;
        }
        let [x, y, z] = self.extent_m();
        z[1] > z[0] && (x[1] > x[0] || y[1] > y[0])
    }

    /// True for a feed move whose contour needs Z: one that moves Z along the contour
    /// ([`Segment::cuts_in_space`]) or lies in the ZX or YZ plane (G18, G19), where Z is one
    /// of the plane's axes.
    pub(crate) fn is_contour_in_space(&self) -> bool {
        self.cuts_in_space()
            || (self.motion == Motion::Feed && !self.is_dwell() && self.plane != Plane::Xy)
    }

    /// The lowest and highest X, Y and Z the segment reaches (m), `[min, max]` per axis.
    pub(crate) fn extent_m(&self) -> [[f64; 2]; 3] {
        let span = |i: usize| {
            [
                self.start_m[i].min(self.end_m[i]),
                self.start_m[i].max(self.end_m[i]),
            ]
        };
        match self.geometry {
            Geometry::Arc(a) => {
                let [a0, a1, n] = self.plane().axes();
                let [first, second] = a.in_plane_extent_m();
                let mut extent = [[0.0; 2]; 3];
                extent[a0] = first;
                extent[a1] = second;
                extent[n] = span(n);
                extent
            }
            _ => [span(0), span(1), span(2)],
        }
    }

    /// Length of the XY projection (m). An arc in another plane projects onto a line
    /// travelled back and forth; its length is summed over fine chords.
    pub(crate) fn xy_length_m(&self) -> f64 {
        match self.geometry {
            Geometry::Line => {
                (self.end_m[0] - self.start_m[0]).hypot(self.end_m[1] - self.start_m[1])
            }
            Geometry::Arc(a) if self.plane() == Plane::Xy => a.in_plane_length_m(),
            Geometry::Arc(_) => {
                let l = self.length_m();
                let chords = 64 * (1 + (self.turns() as usize));
                let xy = |k: usize| {
                    let p = self.eval(l * k as f64 / chords as f64, l).pos;
                    [p[0], p[1]]
                };
                (1..=chords)
                    .map(|k| {
                        let (p, q) = (xy(k - 1), xy(k));
                        (q[0] - p[0]).hypot(q[1] - p[1])
                    })
                    .sum()
            }
            Geometry::Dwell { .. } => 0.0,
        }
    }

    /// The point at parameter `u` ∈ [0, 1] (the arc's angle share, linear along a line).
    pub(crate) fn point_at_param(&self, u: f64) -> [f64; 3] {
        match self.geometry {
            Geometry::Arc(a) => {
                let [a0, a1, n] = self.plane().axes();
                let q = a.in_plane_at(u);
                let mut p = [0.0; 3];
                p[a0] = q[0];
                p[a1] = q[1];
                p[n] = self.start_m[n] + self.normal_travel_m() * u;
                p
            }
            _ => [0, 1, 2].map(|i| self.start_m[i] + (self.end_m[i] - self.start_m[i]) * u),
        }
    }

    /// Whole turns an arc sweeps (0 for anything else).
    fn turns(&self) -> f64 {
        match self.geometry {
            Geometry::Arc(a) => (a.sweep_rad.abs() / std::f64::consts::TAU).floor(),
            _ => 0.0,
        }
    }

    /// True for dwells.
    pub(crate) fn is_dwell(&self) -> bool {
        matches!(self.geometry, Geometry::Dwell { .. })
    }

    /// Position, tangent and curvature at arc length `s` (m) from the segment's start.
    /// `length` must be [`Segment::length_m`] (passed in because callers cache it).
    pub fn eval(&self, s: f64, length: f64) -> PathPoint {
        match self.geometry {
            Geometry::Dwell { .. } => PathPoint {
                pos: self.start_m,
                tangent: [0.0; 3],
                curvature: [0.0; 3],
            },
            Geometry::Line => {
                if length <= 0.0 {
                    return PathPoint {
                        pos: self.start_m,
                        tangent: [0.0; 3],
                        curvature: [0.0; 3],
                    };
                }
                let u = (s / length).clamp(0.0, 1.0);
                let mut pos = [0.0; 3];
                let mut tangent = [0.0; 3];
                for i in 0..3 {
                    let d = self.end_m[i] - self.start_m[i];
                    pos[i] = self.start_m[i] + d * u;
                    tangent[i] = d / length;
                }
                // The end point is reproduced exactly, not to rounding.
                if u == 1.0 {
                    pos = self.end_m;
                }
                PathPoint {
                    pos,
                    tangent,
                    curvature: [0.0; 3],
                }
            }
            Geometry::Arc(a) => self.eval_arc(&a, s, length),
        }
    }

    fn eval_arc(&self, a: &Arc, s: f64, length: f64) -> PathPoint {
        let [a0, a1, n] = self.plane().axes();
        let dz = self.end_m[n] - self.start_m[n];
        let u = a.param_at(s, length, dz);
        let (k, phi) = (a.dr(), a.sweep_rad);
        let r = a.r_start_m + k * u;
        let th = a.theta_start_rad + phi * u;
        let (sin, cos) = th.sin_cos();
        // Each vector is built in the plane's axes (first, second, normal) and placed on X,
        // Y, Z; for G17 that is the identity.
        let place = |v: [f64; 3]| {
            let mut out = [0.0; 3];
            out[a0] = v[0];
            out[a1] = v[1];
            out[n] = v[2];
            out
        };
        let pos = if u == 1.0 {
            self.end_m
        } else {
            place([
                a.center_m[0] + r * cos,
                a.center_m[1] + r * sin,
                self.start_m[n] + dz * u,
            ])
        };
        // Derivatives with respect to u, then converted to arc length.
        let p_u = place([k * cos - r * phi * sin, k * sin + r * phi * cos, dz]);
        let p_uu = place([
            -2.0 * k * phi * sin - r * phi * phi * cos,
            2.0 * k * phi * cos - r * phi * phi * sin,
            0.0,
        ]);
        let s_u = norm3(p_u);
        if s_u == 0.0 {
            return PathPoint {
                pos,
                tangent: [0.0; 3],
                curvature: [0.0; 3],
            };
        }
        let s_uu = dot3(p_u, p_uu) / s_u;
        let mut tangent = [0.0; 3];
        let mut curvature = [0.0; 3];
        for i in 0..3 {
            tangent[i] = p_u[i] / s_u;
            curvature[i] = (p_uu[i] - p_u[i] * s_uu / s_u) / (s_u * s_u);
        }
        PathPoint {
            pos,
            tangent,
            curvature,
        }
    }

    /// Unit tangent at the start (zero for dwells and null moves).
    pub(crate) fn start_tangent(&self) -> [f64; 3] {
        self.eval(0.0, self.length_m()).tangent
    }

    /// Unit tangent at the end.
    pub(crate) fn end_tangent(&self) -> [f64; 3] {
        let l = self.length_m();
        self.eval(l, l).tangent
    }

    /// Curvature vector at the start (1/m).
    pub(crate) fn start_curvature(&self) -> [f64; 3] {
        self.eval(0.0, self.length_m()).curvature
    }

    /// Curvature vector at the end (1/m).
    pub(crate) fn end_curvature(&self) -> [f64; 3] {
        let l = self.length_m();
        self.eval(l, l).curvature
    }
}

/// Result of projecting an XY point onto a segment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Projection {
    /// Signed distance (m): positive to the left of the direction of travel.
    pub signed_distance_m: f64,
    /// Parameter of the foot point along the segment, in [0, 1].
    pub u: f64,
    /// For arcs: radial deviation |q − c| − r(u) (m), positive outward; `None` for lines.
    pub radial_m: Option<f64>,
}

impl Segment {
    /// Projects an XY point onto the segment's XY projection. `u_hint` picks the turn of a
    /// multi-turn arc (the foot point nearest to the hint). An arc in another plane projects
    /// onto XY as a line travelled back and forth: its foot point is searched along it.
    pub fn project_xy(&self, q: [f64; 2], u_hint: f64) -> Projection {
        match self.geometry {
            Geometry::Arc(_) if self.plane() != Plane::Xy => self.project_xy_searched(q),
            Geometry::Arc(a) => project_on_arc(&a, q, u_hint),
            Geometry::Line | Geometry::Dwell { .. } => project_on_line(
                [self.start_m[0], self.start_m[1]],
                [self.end_m[0], self.end_m[1]],
                q,
            ),
        }
    }

    /// Projects a point given in the segment's plane coordinates ([`Plane::coords`]) onto the
    /// segment's projection on that plane; the signed distance is positive to the left of
    /// travel seen from the plane normal's + side. For G17 this is [`Segment::project_xy`].
    pub(crate) fn project_in_plane(&self, q: [f64; 2], u_hint: f64) -> Projection {
        match self.geometry {
            Geometry::Arc(a) => project_on_arc(&a, q, u_hint),
            Geometry::Line | Geometry::Dwell { .. } => project_on_line(
                self.plane().coords(self.start_m),
                self.plane().coords(self.end_m),
                q,
            ),
        }
    }

    /// Projects a point in space onto the segment: the foot point of its projection onto
    /// the segment's plane (for a helix on the turn at the point's height, else on the turn
    /// nearest `u_hint`), with the offset along the plane's normal there; a line's foot
    /// point in closed form. `signed_distance_m` holds the distance in space, unsigned:
    /// exact for lines and for arcs in a plane, and for a helix exact on its path and an
    /// upper bound off it (enough to tell which block a point lies on).
    pub(crate) fn project_in_space(&self, q: [f64; 3], u_hint: f64) -> Projection {
        let Geometry::Arc(_) = self.geometry else {
            let d = [0, 1, 2].map(|i| self.end_m[i] - self.start_m[i]);
            let rel = [0, 1, 2].map(|i| q[i] - self.start_m[i]);
            let l2 = dot3(d, d);
            let u = if l2 > 0.0 {
                (dot3(rel, d) / l2).clamp(0.0, 1.0)
            } else {
                0.0
            };
            return Projection {
                signed_distance_m: dist3(q, self.point_at_param(u)),
                u,
                radial_m: None,
            };
        };
        let plane = self.plane();
        let n = plane.axes()[2];
        let lead = self.normal_travel_m();
        let hint = if lead != 0.0 {
            ((q[n] - self.start_m[n]) / lead).clamp(0.0, 1.0)
        } else {
            u_hint
        };
        let p = self.project_in_plane(plane.coords(q), hint);
        let across = q[n] - self.point_at_param(p.u)[n];
        Projection {
            signed_distance_m: p.signed_distance_m.hypot(across),
            u: p.u,
            radial_m: p.radial_m,
        }
    }

    /// The XY foot point of an arc in another plane: the nearest of fine chords' vertices,
    /// refined by golden section between its neighbours.
    fn project_xy_searched(&self, q: [f64; 2]) -> Projection {
        let l = self.length_m();
        let xy_at = |u: f64| {
            let p = self.eval(u * l, l).pos;
            [p[0], p[1]]
        };
        let d2 = |u: f64| {
            let p = xy_at(u);
            (q[0] - p[0]).powi(2) + (q[1] - p[1]).powi(2)
        };
        let steps = 64 * (1 + self.turns() as usize);
        let k = (0..=steps)
            .min_by(|&i, &j| d2(i as f64 / steps as f64).total_cmp(&d2(j as f64 / steps as f64)))
            .unwrap_or(0);
        let h = 1.0 / steps as f64;
        let (mut lo, mut hi) = ((k as f64 - 1.0) * h, (k as f64 + 1.0) * h);
        (lo, hi) = (lo.max(0.0), hi.min(1.0));
        let ratio = 0.5 * (5f64.sqrt() - 1.0);
        for _ in 0..60 {
            let (m1, m2) = (hi - ratio * (hi - lo), lo + ratio * (hi - lo));
            if d2(m1) <= d2(m2) { hi = m2 } else { lo = m1 }
        }
        let u = 0.5 * (lo + hi);
        let foot = xy_at(u);
        let ahead = xy_at((u + 1e-6).min(1.0));
        let behind = xy_at((u - 1e-6).max(0.0));
        let d = [ahead[0] - behind[0], ahead[1] - behind[1]];
        let cross = d[0] * (q[1] - foot[1]) - d[1] * (q[0] - foot[0]);
        Projection {
            signed_distance_m: (q[0] - foot[0]).hypot(q[1] - foot[1]).copysign(cross),
            u,
            radial_m: None,
        }
    }
}

/// Projects `q` onto the segment from `p0` to `p1` (2-D).
fn project_on_line(p0: [f64; 2], p1: [f64; 2], q: [f64; 2]) -> Projection {
    let d = [p1[0] - p0[0], p1[1] - p0[1]];
    let l2 = d[0] * d[0] + d[1] * d[1];
    if l2 == 0.0 {
        let dist = (q[0] - p0[0]).hypot(q[1] - p0[1]);
        return Projection {
            signed_distance_m: dist,
            u: 0.0,
            radial_m: None,
        };
    }
    let rel = [q[0] - p0[0], q[1] - p0[1]];
    let u = ((rel[0] * d[0] + rel[1] * d[1]) / l2).clamp(0.0, 1.0);
    let foot = [p0[0] + d[0] * u, p0[1] + d[1] * u];
    let dist = (q[0] - foot[0]).hypot(q[1] - foot[1]);
    // Left of travel = positive cross product of direction and offset.
    let cross = d[0] * (q[1] - foot[1]) - d[1] * (q[0] - foot[0]);
    Projection {
        signed_distance_m: dist.copysign(cross),
        u,
        radial_m: None,
    }
}

/// Projects `q` (in the arc's plane coordinates) onto the arc.
fn project_on_arc(a: &Arc, q: [f64; 2], u_hint: f64) -> Projection {
    let rel = [q[0] - a.center_m[0], q[1] - a.center_m[1]];
    let rq = rel[0].hypot(rel[1]);
    let ang = rel[1].atan2(rel[0]);
    let u = arc_param_near(a, ang, u_hint);
    let radial = rq - a.radius_at(u);
    // CCW travel has the centre on its left: outward is to the right.
    let side = if a.sweep_rad > 0.0 { -radial } else { radial };
    let signed = if u > 0.0 && u < 1.0 {
        side
    } else {
        // Beyond an end: distance to the end point, sign from the radial side.
        let e = a.in_plane_at(u);
        (q[0] - e[0]).hypot(q[1] - e[1]).copysign(side)
    };
    Projection {
        signed_distance_m: signed,
        u,
        radial_m: Some(radial),
    }
}

/// The arc parameter whose angle matches `ang` (mod 2π) and lies nearest `u_hint`, clamped
/// to the arc.
fn arc_param_near(a: &Arc, ang: f64, u_hint: f64) -> f64 {
    let tau = std::f64::consts::TAU;
    if a.sweep_rad == 0.0 {
        return 0.0;
    }
    // Angle offset from the start in the direction of travel, in [0, 2π).
    let signed = if a.sweep_rad > 0.0 {
        ang - a.theta_start_rad
    } else {
        a.theta_start_rad - ang
    };
    let base = signed.rem_euclid(tau);
    let turns = a.sweep_rad.abs();
    // Candidates base + 2πn; choose the one nearest the hint's angle.
    let hint_angle = u_hint.clamp(0.0, 1.0) * turns;
    let n = ((hint_angle - base) / tau).round();
    let mut best = base + n * tau;
    // Keep within [−π, turns + π] so that angles just outside the ends clamp to the near end.
    if best > turns + std::f64::consts::PI {
        best -= tau;
    }
    if best < -std::f64::consts::PI {
        best += tau;
    }
    (best / turns).clamp(0.0, 1.0)
}

/// Euclidean distance between two points.
pub(crate) fn dist3(a: [f64; 3], b: [f64; 3]) -> f64 {
    norm3([b[0] - a[0], b[1] - a[1], b[2] - a[2]])
}

/// Euclidean norm.
pub(crate) fn norm3(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

/// Dot product.
pub(crate) fn dot3(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::{FRAC_PI_2, PI};

    fn arc_segment(arc: Arc, z0: f64, z1: f64) -> Segment {
        let s = arc.in_plane_at(0.0);
        let e = arc.in_plane_at(1.0);
        Segment {
            geometry: Geometry::Arc(arc),
            start_m: [s[0], s[1], z0],
            end_m: [e[0], e[1], z1],
            motion: Motion::Feed,
            feed_m_per_s: 0.01,
            blend: Blend::ExactStop,
            line: 1,
            jerk_limited: None,
            plane: Plane::Xy,
        }
    }

    #[test]
    fn circle_length_curvature_and_projection() {
        let arc = Arc {
            center_m: [0.0, 0.0],
            r_start_m: 0.1,
            r_end_m: 0.1,
            theta_start_rad: 0.0,
            sweep_rad: FRAC_PI_2,
        };
        let seg = arc_segment(arc, 0.0, 0.0);
        let l = seg.length_m();
        assert!((l - 0.1 * FRAC_PI_2).abs() < 1e-15);
        let mid = seg.eval(l / 2.0, l);
        let k = norm3(mid.curvature);
        assert!((k - 10.0).abs() < 1e-12, "curvature 1/R");
        // A point 1 µm outside the arc, CCW travel: right of travel, radial positive.
        let p = seg.project_xy(
            [0.100001 * (PI / 4.0).cos(), 0.100001 * (PI / 4.0).sin()],
            0.5,
        );
        assert!((p.radial_m.unwrap() - 1e-6).abs() < 1e-15);
        assert!((p.signed_distance_m + 1e-6).abs() < 1e-15);
        assert!((p.u - 0.5).abs() < 1e-12);
    }

    #[test]
    fn helix_length_is_the_hypotenuse() {
        let arc = Arc {
            center_m: [0.0, 0.0],
            r_start_m: 0.05,
            r_end_m: 0.05,
            theta_start_rad: 0.0,
            sweep_rad: -2.0 * PI,
        };
        let seg = arc_segment(arc, 0.0, -0.01);
        let expected = (2.0 * PI * 0.05f64).hypot(0.01);
        assert!((seg.length_m() - expected).abs() < 1e-15);
        let end = seg.eval(seg.length_m(), seg.length_m());
        assert_eq!(end.pos, seg.end_m);
    }

    #[test]
    fn spiral_length_matches_fine_quadrature() {
        let arc = Arc {
            center_m: [0.01, -0.02],
            r_start_m: 0.02,
            r_end_m: 0.02002,
            theta_start_rad: 0.3,
            sweep_rad: 3.0,
        };
        let seg = arc_segment(arc, 0.0, 0.0);
        // Polyline with a million chords.
        let n = 1_000_000;
        let mut l = 0.0;
        let mut prev = arc.in_plane_at(0.0);
        for i in 1..=n {
            let p = arc.in_plane_at(i as f64 / n as f64);
            l += (p[0] - prev[0]).hypot(p[1] - prev[1]);
            prev = p;
        }
        assert!(
            (seg.length_m() - l).abs() < 1e-12,
            "{} vs {}",
            seg.length_m(),
            l
        );
        // Evaluating at half the length lands where the length to it is half.
        let half = seg.eval(l / 2.0, seg.length_m());
        let u = arc.param_at(l / 2.0, seg.length_m(), 0.0);
        assert!((arc.length_to(u, 0.0) - l / 2.0).abs() < 1e-14);
        assert!((norm3(half.tangent) - 1.0).abs() < 1e-12);
    }
}
