//! The interpolator: position, velocity and acceleration commands for each axis at every
//! interpolation cycle, taken exactly from the programmed geometry (true arcs, no chords).

use super::Plan;
use crate::machine::AxisName;
use crate::path::Geometry;
use crate::sim::AxisCommands;

/// The interpolator's output for a program: X, Y and Z commands (Z simulated where the machine
/// simulates it, else carried) on a uniform time grid t_k = k·dt, with the path segment of each sample.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Commands {
    /// Sample period (s).
    pub dt_s: f64,
    /// X commands.
    pub x: AxisCommands,
    /// Y commands.
    pub y: AxisCommands,
    /// Z commands.
    pub z: AxisCommands,
    /// Index of the path segment of each sample (into the plan's segments).
    pub segment: Vec<u32>,
}

impl Commands {
    /// One axis's commands.
    pub(crate) fn axis(&self, axis: AxisName) -> &AxisCommands {
        match axis {
            AxisName::X => &self.x,
            AxisName::Y => &self.y,
            AxisName::Z => &self.z,
        }
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.x.len()
    }

    /// The first `n` samples (all of them where there are fewer).
    pub(crate) fn first(&self, n: usize) -> Commands {
        Commands {
            dt_s: self.dt_s,
            x: self.x.first(n),
            y: self.y.first(n),
            z: self.z.first(n),
            segment: self.segment[..n.min(self.segment.len())].to_vec(),
        }
    }

    /// True when there are no samples.
    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }

    /// Time of sample k (s).
    pub(crate) fn time_s(&self, k: usize) -> f64 {
        k as f64 * self.dt_s
    }

    /// Duration covered (s).
    pub(crate) fn duration_s(&self) -> f64 {
        self.len().saturating_sub(1) as f64 * self.dt_s
    }

    /// Keeps the first `len` samples.
    pub(crate) fn truncate(&mut self, len: usize) {
        for c in [&mut self.x, &mut self.y, &mut self.z] {
            c.pos_m.truncate(len);
            c.vel_m_per_s.truncate(len);
            c.acc_m_per_s2.truncate(len);
        }
        self.segment.truncate(len);
    }

    /// Appends the samples of the commands that follow these.
    pub(crate) fn append(&mut self, next: &Commands) {
        self.x.append(&next.x);
        self.y.append(&next.y);
        self.z.append(&next.z);
        self.segment.extend_from_slice(&next.segment);
    }

    /// Appends `seconds` of standing still at the last position, so that the axes can settle
    /// after the program ends.
    pub(crate) fn hold(&mut self, seconds: f64) {
        let n = (seconds / self.dt_s).ceil() as usize;
        let (Some(&x), Some(&y), Some(&z), Some(&seg)) = (
            self.x.pos_m.last(),
            self.y.pos_m.last(),
            self.z.pos_m.last(),
            self.segment.last(),
        ) else {
            return;
        };
        for _ in 0..n {
            self.x.push(x, 0.0, 0.0);
            self.y.push(y, 0.0, 0.0);
            self.z.push(z, 0.0, 0.0);
            self.segment.push(seg);
        }
    }

    /// Room for `more` samples.
    pub(crate) fn reserve(&mut self, more: usize) {
        for c in [&mut self.x, &mut self.y, &mut self.z] {
            c.pos_m.reserve(more);
            c.vel_m_per_s.reserve(more);
            c.acc_m_per_s2.reserve(more);
        }
        self.segment.reserve(more);
    }
}

/// Peak magnitudes of one axis's commands.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct AxisPeaks {
    /// Largest |v_ref| (m/s).
    pub speed_m_per_s: f64,
    /// Largest |a_ref| (m/s²).
    pub accel_m_per_s2: f64,
    /// Largest |Δa_ref|/T between consecutive samples (m/s³).
    pub jerk_m_per_s3: f64,
    /// Where the velocity steps between two samples by more than their accelerations could
    /// take it (the ideal profile sets the feed at once): the largest such |Δv_ref|/T (m/s²),
    /// the step as sampled — its true acceleration is unbounded. `None` where v_ref follows
    /// a_ref.
    pub step_accel_m_per_s2: Option<f64>,
}

impl AxisCommands {
    /// Peak speed, acceleration and (sampled) jerk, and any velocity step.
    pub fn peaks(&self, dt_s: f64) -> AxisPeaks {
        let max_abs = |v: &[f64]| v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        let jerk = self
            .acc_m_per_s2
            .windows(2)
            .fold(0.0f64, |m, w| m.max((w[1] - w[0]).abs() / dt_s));
        // Over one cycle the velocity changes by at most the larger of the accelerations at
        // its ends times the cycle (a trapezoid's switch mid-cycle included); twice that
        // leaves room for an S-curve's peak between samples. A change beyond it is a step.
        let step = (1..self.vel_m_per_s.len())
            .filter_map(|k| {
                let dv = (self.vel_m_per_s[k] - self.vel_m_per_s[k - 1]).abs();
                let a = self.acc_m_per_s2[k]
                    .abs()
                    .max(self.acc_m_per_s2[k - 1].abs());
                (dv > 2.0 * a * dt_s + STEP_FLOOR_M_PER_S).then_some(dv / dt_s)
            })
            .reduce(f64::max);
        AxisPeaks {
            speed_m_per_s: max_abs(&self.vel_m_per_s),
            accel_m_per_s2: max_abs(&self.acc_m_per_s2),
            jerk_m_per_s3: jerk,
            step_accel_m_per_s2: step,
        }
    }
}

/// A velocity change below this over one cycle (m/s, 0.06 mm/min) is rounding, not a step.
const STEP_FLOOR_M_PER_S: f64 = 1e-6;

/// Samples a plan at its interpolation cycle, from t = 0 to the end of the program, with
/// the plan's own waits at exact stops.
pub fn sample(plan: &Plan) -> Commands {
    let dt = plan.config.cycle_s;
    // Up to and including the first sample at or after the end, so the end point is reached.
    let n = (plan.total_time_s / dt).ceil() as usize + 1;
    let mut out = Commands {
        dt_s: dt,
        ..Default::default()
    };
    out.reserve(n);
    if plan.segments.is_empty() {
        return out;
    }
    let mut sampler = Sampler::new(plan, 0, plan.segments.len() - 1);
    for k in 0..n {
        sampler.push(k as f64 * dt, &mut out);
    }
    out
}

/// The interpolator over a run of a plan's segments: commands at increasing times, walking
/// forward from segment to segment (never past `last`, whose end it holds once reached).
pub struct Sampler<'p> {
    plan: &'p Plan,
    index: usize,
    last: usize,
    motion: super::SegmentMotion,
}

impl<'p> Sampler<'p> {
    /// A sampler over segments `first..=last` of a plan, whose start times must be set.
    pub(crate) fn new(plan: &'p Plan, first: usize, last: usize) -> Self {
        Sampler {
            plan,
            index: first,
            last,
            motion: plan.plans[first].motion(),
        }
    }

    /// Appends the commands at time `t` (s on the plan's clock; not before the last call's).
    pub(crate) fn push(&mut self, t: f64, out: &mut Commands) {
        let plan = self.plan;
        // Advance to the segment that holds t (the later one at a boundary).
        while self.index < self.last && t >= plan.plans[self.index + 1].t_start_s {
            self.index += 1;
            self.motion = plan.plans[self.index].motion_after(&self.motion);
        }
        let (seg, sp) = (&plan.segments[self.index], &plan.plans[self.index]);
        // Past the motion (an in-position wait, the program end) the profile holds its end:
        // the end point, at rest.
        let tau = (t - sp.t_start_s).clamp(0.0, sp.duration_s);
        let (s, v, a) = match seg.geometry {
            Geometry::Dwell { .. } => (0.0, 0.0, 0.0),
            _ => self.motion.eval(tau),
        };
        let p = seg.eval(s.clamp(0.0, sp.length_m), sp.length_m);
        // Axis acceleration: tangential part plus the curvature's v².
        let axis = |i: usize| {
            (
                p.pos[i],
                p.tangent[i] * v,
                p.tangent[i] * a + p.curvature[i] * v * v,
            )
        };
        let (x, y, z) = (axis(0), axis(1), axis(2));
        out.x.push(x.0, x.1, x.2);
        out.y.push(y.0, y.1, y.2);
        out.z.push(z.0, z.1, z.2);
        out.segment.push(self.index as u32);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The commands of a 2 ms cycle: standing, then `v` from one sample to the next with no
    /// acceleration (the ideal profile's start), or reached at `a` over its cycles.
    fn start(v: f64, a: Option<f64>) -> AxisCommands {
        let dt = 0.002;
        let mut c = AxisCommands::default();
        let (mut x, mut speed) = (0.0, 0.0);
        for k in 0..200 {
            let (acc, next) = match a {
                None if k >= 10 => (0.0, v),
                Some(a) if k >= 10 && speed < v => (a, (speed + a * dt).min(v)),
                _ => (0.0, speed),
            };
            c.push(x, speed, acc);
            speed = next;
            x += speed * dt;
        }
        c
    }

    #[test]
    fn a_velocity_step_is_its_change_over_one_cycle() {
        // 1000 mm/min = 1/60 m/s within 2 ms: (1/60) / 0.002 = 8.33 m/s².
        let p = start(1.0 / 60.0, None).peaks(0.002);
        assert_eq!(p.accel_m_per_s2, 0.0);
        let step = p.step_accel_m_per_s2.unwrap();
        assert!((step - 1.0 / 60.0 / 0.002).abs() < 1e-9, "{step}");
        // Reached at 0.5 m/s² the same speed has no step: its peak is the acceleration.
        let p = start(1.0 / 60.0, Some(0.5)).peaks(0.002);
        assert_eq!(p.step_accel_m_per_s2, None);
        assert_eq!(p.accel_m_per_s2, 0.5);
    }
}
