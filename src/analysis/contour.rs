//! Contour error (docs/model.md §3): the shortest distance from the actual tool position to the
//! programmed geometry in 3-D — the G-code's lines, true arcs and helices, not the
//! time-parametrised reference point — signed by its side in the block's plane (positive to
//! the left of the direction of travel), with its parts in the plane and across it and, on
//! arcs, the radial deviation (positive outward). `contour3d` measures one segment.
//!
//! The search is local and follows the path: for each sample only the segments within a
//! window of path length around the commanded point's place are tried, the window being
//! the distance between commanded and actual position plus a margin. The cost stays linear
//! in the length of the run, and a tool passing near an earlier part of the path is never
//! matched to it. The commanded point's place is followed from sample to sample — it enters
//! each segment at its start and moves on from where it was — because on an arc of several
//! turns (G2/G3 with P) its position alone names a point on each turn: taken for the middle
//! turn, it would put the tool still on the block before the arc out of the window, and
//! measure it against the arc's circle alone.

use super::contour3d::{Deviation, deviation};
use crate::path::{Geometry, Motion, Segment};
use crate::plan::{Commands, Plan};

/// Path length a search may look beyond the commanded–actual distance (m).
const SEARCH_MARGIN_M: f64 = 0.5e-3;

/// Contour error along a run.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ContourSeries {
    /// Signed contour error per sample (m); NaN while not cutting (rapids).
    pub error_m: Vec<f64>,
    /// Its part in the block's plane (m, signed left of travel); NaN while not cutting.
    pub in_plane_m: Vec<f64>,
    /// Its part across the block's plane (m, towards the normal's +); NaN while not cutting.
    pub across_m: Vec<f64>,
    /// Radial deviation (m, positive outward) when the nearest geometry is an arc, else NaN.
    pub radial_m: Vec<f64>,
    /// Index of the nearest segment.
    pub segment: Vec<u32>,
    /// Path length of the foot point from the program start (m).
    pub path_s_m: Vec<f64>,
    /// Whether the foot point is a segment's end, the tool beyond it: there the error's
    /// side is not defined (past a reversal it is along the path, and its sign is the
    /// noise's), only its size.
    pub at_vertex: Vec<bool>,
}

impl ContourSeries {
    /// Largest |error| and its sample, over cutting samples.
    pub fn max_abs(&self) -> Option<(usize, f64)> {
        self.error_m
            .iter()
            .enumerate()
            .filter(|(_, e)| e.is_finite())
            .map(|(k, e)| (k, e.abs()))
            .max_by(|a, b| a.1.total_cmp(&b.1))
    }

    /// Root mean square over cutting samples (m).
    pub fn rms(&self) -> f64 {
        let (sum, n) = self
            .error_m
            .iter()
            .filter(|e| e.is_finite())
            .fold((0.0, 0usize), |(s, n), e| (s + e * e, n + 1));
        if n == 0 { 0.0 } else { (sum / n as f64).sqrt() }
    }
}

/// Whether a segment is part of the cutting contour: a feed move that moves X or Y (any arc
/// does). A dwell, or a move of Z alone (a plunge), has no contour: the XY error there is a
/// positioning error, reported apart.
pub(crate) fn is_contour(seg: &Segment) -> bool {
    let moves_xy = match seg.geometry {
        Geometry::Dwell { .. } => false,
        Geometry::Arc(_) => true,
        Geometry::Line => {
            (seg.end_m[0] - seg.start_m[0]).hypot(seg.end_m[1] - seg.start_m[1]) > 1e-12
        }
    };
    seg.motion == Motion::Feed && moves_xy
}

/// One sample's contour error.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContourPoint {
    /// Signed contour error (m): the distance, signed by the in-plane side; NaN while not
    /// cutting.
    pub error_m: f64,
    /// Its part in the block's plane (m); NaN while not cutting.
    pub in_plane_m: f64,
    /// Its part across the plane (m); NaN while not cutting.
    pub across_m: f64,
    /// Radial deviation (m, outward) when the nearest geometry is an arc, else NaN.
    pub radial_m: f64,
    /// Index of the nearest segment (of the commanded one while not cutting).
    pub segment: u32,
    /// Path length of the foot point from the program start (m).
    pub path_s_m: f64,
    /// Whether the foot point is the segment's end (see [`ContourSeries::at_vertex`]).
    pub at_vertex: bool,
}

/// The contour search along one plan's path, sample by sample.
#[derive(Debug, Clone)]
pub struct ContourLocator {
    /// Path length at the start of each segment, and at the end (m).
    cum_m: Vec<f64>,
    /// The segment and parameter (0–1) the commanded point was last found at.
    reference_at: Option<(usize, f64)>,
    /// Whether Z is simulated: then the error is measured in 3-D; else Z stands where it is
    /// commanded, which says nothing of the real Z, and the error is the XY projection's.
    three_d: bool,
}

impl ContourLocator {
    /// The search along `plan`'s path (its segment lengths; its timing does not matter), in
    /// the XY projection: for a machine that carries Z, or positions measured in X and Y.
    pub(crate) fn new(plan: &Plan) -> Self {
        let mut cum_m = Vec::with_capacity(plan.plans.len() + 1);
        cum_m.push(0.0);
        for p in &plan.plans {
            cum_m.push(cum_m.last().copied().unwrap_or(0.0) + p.length_m);
        }
        ContourLocator {
            cum_m,
            reference_at: None,
            three_d: false,
        }
    }

    /// The search in 3-D, for a machine that simulates Z.
    pub(crate) fn in_3d(plan: &Plan) -> Self {
        ContourLocator {
            three_d: true,
            ..Self::new(plan)
        }
    }

    /// A point's deviation from a segment, in 3-D or in the XY projection.
    fn deviation(in_space: bool, seg: &Segment, q: [f64; 3], u_hint: f64) -> Deviation {
        if in_space {
            return deviation(seg, q, u_hint);
        }
        let p = seg.project_xy([q[0], q[1]], u_hint);
        Deviation {
            distance_m: p.signed_distance_m.abs(),
            in_plane_m: p.signed_distance_m,
            across_m: 0.0,
            radial_m: p.radial_m,
            u: p.u,
        }
    }

    /// Whether the error while `seg` is commanded is measured in space: where Z is simulated
    /// and the block moves Z along the contour (a helix, a slope) or lies in ZX or YZ. A block
    /// of the XY plane at one height is measured in X and Y as on a machine that carries Z, so a 2.5-D
    /// program's figures do not change with a simulated Z; Z's own deviation there is its
    /// following error (and Z still arriving after a plunge, the plunge's).
    pub(crate) fn measures_in_space(&self, seg: &Segment) -> bool {
        self.three_d && seg.is_contour_in_space()
    }

    /// Whether a segment near the commanded one is part of the path the tool is measured
    /// against: a contour, and in 3-D also a plunge (a corner between a plunge and the cut
    /// that follows is rounded in space, and the tool still coming down is that far from
    /// the path, not as far as its height above the cut).
    fn is_nearby_path(in_space: bool, seg: &Segment) -> bool {
        is_contour(seg)
            || (in_space
                && seg.motion == Motion::Feed
                && !seg.is_dwell()
                && seg.start_m != seg.end_m)
    }

    /// Where to look for the commanded point on segment `c`: where it was on the previous
    /// sample, at the start of a segment it has just entered, and mid-segment where nothing
    /// is known (the first sample, a run taken up again further back).
    fn reference_hint(&self, c: usize) -> f64 {
        match self.reference_at {
            Some((seg, u)) if seg == c => u,
            Some((seg, _)) if seg < c => 0.0,
            _ => 0.5,
        }
    }

    /// The contour error of the actual position `q` (m) while segment `c` is commanded at
    /// `reference` (m), the samples taken in order.
    pub(crate) fn locate(
        &mut self,
        plan: &Plan,
        c: usize,
        reference: [f64; 3],
        q: [f64; 3],
    ) -> ContourPoint {
        let segs = &plan.segments;
        let in_space = self.measures_in_space(&segs[c]);
        let ref_u = Self::deviation(in_space, &segs[c], reference, self.reference_hint(c)).u;
        self.reference_at = Some((c, ref_u));
        let cum = &self.cum_m;
        let s_ref = cum[c] + ref_u * plan.plans[c].length_m;
        let none = ContourPoint {
            error_m: f64::NAN,
            in_plane_m: f64::NAN,
            across_m: f64::NAN,
            radial_m: f64::NAN,
            segment: c as u32,
            path_s_m: s_ref,
            at_vertex: false,
        };
        if !is_contour(&segs[c]) {
            return none;
        }
        let apart = (q[0] - reference[0])
            .hypot(q[1] - reference[1])
            .hypot(if in_space { q[2] - reference[2] } else { 0.0 });
        let window = apart * 2.0 + SEARCH_MARGIN_M;
        let mut best: Option<(f64, ContourPoint)> = None;
        let mut consider = |j: usize, hint: f64| {
            if !Self::is_nearby_path(in_space, &segs[j]) {
                return;
            }
            let p = Self::deviation(in_space, &segs[j], q, hint);
            let d = p.distance_m;
            if best.is_none_or(|b| d < b.0) {
                let point = ContourPoint {
                    error_m: p.signed_m(),
                    in_plane_m: p.in_plane_m,
                    across_m: p.across_m,
                    radial_m: p.radial_m.unwrap_or(f64::NAN),
                    segment: j as u32,
                    path_s_m: cum[j] + p.u * plan.plans[j].length_m,
                    at_vertex: p.u <= 0.0 || p.u >= 1.0,
                };
                best = Some((d, point));
            }
        };
        consider(c, ref_u);
        let mut j = c;
        while j > 0 && s_ref - cum[j] <= window {
            j -= 1;
            consider(j, 1.0);
        }
        let mut j = c + 1;
        while j < segs.len() && cum[j] - s_ref <= window {
            consider(j, 0.0);
            j += 1;
        }
        best.map_or(none, |b| b.1)
    }
}

/// Contour errors of the actual positions (`x_m`, `y_m`, one per command sample; Z where
/// it is commanded).
pub fn contour_errors(plan: &Plan, commands: &Commands, x_m: &[f64], y_m: &[f64]) -> ContourSeries {
    let z_m = &commands.z.pos_m;
    locate_all(ContourLocator::new(plan), plan, commands, [x_m, y_m, z_m])
}

/// Contour errors of actual positions in X, Y and Z (one per command sample): in space on
/// the blocks that move Z along the contour or lie in ZX or YZ, in X and Y on the rest
/// ([`ContourLocator::measures_in_space`]), as `check` measures a machine that simulates Z.
pub fn contour_errors_in_space(
    plan: &Plan,
    commands: &Commands,
    xyz_m: [&[f64]; 3],
) -> ContourSeries {
    locate_all(ContourLocator::in_3d(plan), plan, commands, xyz_m)
}

/// Each sample's contour error by `locator`.
fn locate_all(
    mut locator: ContourLocator,
    plan: &Plan,
    commands: &Commands,
    [x_m, y_m, z_m]: [&[f64]; 3],
) -> ContourSeries {
    let n = x_m.len().min(y_m.len()).min(z_m.len()).min(commands.len());
    let mut out = ContourSeries {
        error_m: Vec::with_capacity(n),
        in_plane_m: Vec::with_capacity(n),
        across_m: Vec::with_capacity(n),
        radial_m: Vec::with_capacity(n),
        segment: Vec::with_capacity(n),
        path_s_m: Vec::with_capacity(n),
        at_vertex: Vec::with_capacity(n),
    };
    for k in 0..n {
        let reference = [
            commands.x.pos_m[k],
            commands.y.pos_m[k],
            commands.z.pos_m[k],
        ];
        let c = commands.segment[k] as usize;
        out.push(locator.locate(plan, c, reference, [x_m[k], y_m[k], z_m[k]]));
    }
    out
}

impl ContourSeries {
    /// Appends one sample's contour error.
    pub(crate) fn push(&mut self, p: ContourPoint) {
        self.error_m.push(p.error_m);
        self.in_plane_m.push(p.in_plane_m);
        self.across_m.push(p.across_m);
        self.radial_m.push(p.radial_m);
        self.segment.push(p.segment);
        self.path_s_m.push(p.path_s_m);
        self.at_vertex.push(p.at_vertex);
    }
}
