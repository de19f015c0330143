//! Commands a control recorded (a servo trace's commanded positions, or any other
//! interpolator's output) made into the simulator's input, and placed on the program.
//!
//! Another control interpolates on its own clock, with its own feed profile, look-ahead
//! and blending, so its command stream cannot be expected to follow our plan in time; it
//! must only follow the program's geometry. Two steps:
//!
//! 1. [`commands_from_record`]: positions resampled to the simulation's step; velocity and
//!    acceleration (the feed-forward inputs) from a local quadratic least-squares fit over
//!    a few milliseconds of the raw samples — differences of neighbouring samples would
//!    amplify the encoder's quantisation (0.1 µm at 0.1 ms is 1 mm/s of noise).
//! 2. [`super::placement`]: each command sample located on the program's segments, from
//!    where the stream joins the program's path.

use crate::gcode::Program;
use crate::machine::{AxisConfig, AxisName, MachineConfig};
use crate::numeric::units::{m_per_s_from_mm_per_min, mm_per_min_from_m_per_s};
use crate::path::{Blend, Geometry, Motion, Plane, Segment};
use crate::plan::{AxisCommands, Commands};
use crate::sim::AxisModel;
use crate::trace::signal::sample;

/// Half-width of the derivative fit (s): wide enough to average a 10 kHz record's
/// quantisation, short against any feed change a servo follows.
pub(crate) const DERIVATIVE_HALF_WIDTH_S: f64 = 3e-3;

/// What recorded commands ask of an axis beyond what the machine file says it can do.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct BeyondMachine {
    /// The axis.
    pub axis: AxisName,
    /// What is exceeded, in words.
    pub what: &'static str,
    /// The machine-file key that holds the limit, below the axis (`limits.rapid_mm_per_min`).
    pub key: &'static str,
    /// The commands' peak, in the key's unit.
    pub recorded: f64,
    /// The limit, in the key's unit.
    pub limit: f64,
    /// The unit of both.
    pub unit: &'static str,
    /// Time of the peak on the record's clock (s).
    pub t_s: f64,
}

impl std::fmt::Display for BeyondMachine {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        // Speeds to the mm/min, accelerations to the cm/s².
        let digits = if self.unit == "mm/min" { 0 } else { 2 };
        write!(
            f,
            "{} axis: the recorded commands reach {:.digits$} {} at t = {:.3} s, beyond the {} \
             of {:.digits$} {} ({}.{}); the model cannot follow them there",
            self.axis.letter(),
            self.recorded,
            self.unit,
            self.t_s,
            self.what,
            self.limit,
            self.unit,
            self.axis.as_str(),
            self.key
        )
    }
}

/// How far the path drawn from a record's commands may lie from them (m): far below what a
/// servo's contour error is, far above a 0.1 µm count.
pub const COMMANDS_PATH_TOLERANCE_M: f64 = 0.2e-6;

/// The path a record's commands drew, as a program of straight lines (a polygon within
/// [`COMMANDS_PATH_TOLERANCE_M`] of every command sample), for a record whose program is not
/// at hand — a lab's own trajectory, a capture of an unknown part. The commands still drive
/// the simulation; this only gives the contour error a path to be measured from. Each
/// line's "source line" is the record's sample (1-based) where it starts. `None` without
/// commands or without motion.
pub fn program_from_commands(commands_m: &[Vec<f64>; 2], dt_s: f64, file: &str) -> Option<Program> {
    let [xs, ys] = commands_m;
    let n = xs.len().min(ys.len());
    // Standing samples add nothing to a path: keep the first of each run.
    let moving: Vec<usize> = (0..n)
        .filter(|&i| i == 0 || xs[i] != xs[i - 1] || ys[i] != ys[i - 1])
        .collect();
    if moving.len() < 2 {
        return None;
    }
    let point = |i: usize| [xs[i], ys[i]];
    let vertices = simplified(&moving, &point, COMMANDS_PATH_TOLERANCE_M);
    let speed_between = |a: usize, b: usize| {
        let length = distance(point(a), point(b));
        (length / ((b - a).max(1) as f64 * dt_s)).max(1e-6)
    };
    let segments: Vec<Segment> = vertices
        .windows(2)
        .map(|w| Segment {
            geometry: Geometry::Line,
            start_m: [xs[w[0]], ys[w[0]], 0.0],
            end_m: [xs[w[1]], ys[w[1]], 0.0],
            motion: Motion::Feed,
            feed_m_per_s: speed_between(w[0], w[1]),
            blend: Blend::Continuous {
                tolerance_m: Some(COMMANDS_PATH_TOLERANCE_M),
                naive_cam_m: None,
            },
            line: u32::try_from(w[0] + 1).unwrap_or(u32::MAX),
            jerk_limited: None,
            plane: Plane::Xy,
        })
        .collect();
    Some(Program {
        file: format!("{file} (the path of its recorded commands)"),
        blocks: segments.len(),
        block_numbers: Vec::new(),
        segments,
        events: Vec::new(),
        notes: Vec::new(),
        warnings: Vec::new(),
        lines: n,
        sources: Vec::new(),
    })
}

fn distance(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

/// Distance of `p` from the segment a–b.
fn distance_to_segment(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let len2 = dx * dx + dy * dy;
    if len2 == 0.0 {
        return distance(p, a);
    }
    let f = (((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / len2).clamp(0.0, 1.0);
    distance(p, [a[0] + f * dx, a[1] + f * dy])
}

/// The indices (among `kept`) of a polygon through the first and last points that stays
/// within `tolerance` of every point (Douglas–Peucker, on an explicit stack).
fn simplified(kept: &[usize], point: &dyn Fn(usize) -> [f64; 2], tolerance: f64) -> Vec<usize> {
    let mut keep = vec![false; kept.len()];
    keep[0] = true;
    keep[kept.len() - 1] = true;
    let mut stack = vec![(0usize, kept.len() - 1)];
    while let Some((first, last)) = stack.pop() {
        let (a, b) = (point(kept[first]), point(kept[last]));
        let farthest = (first + 1..last)
            .map(|k| (k, distance_to_segment(point(kept[k]), a, b)))
            .fold(
                (first, 0.0f64),
                |best, c| if c.1 > best.1 { c } else { best },
            );
        if farthest.1 > tolerance {
            keep[farthest.0] = true;
            stack.push((first, farthest.0));
            stack.push((farthest.0, last));
        }
    }
    kept.iter()
        .zip(keep)
        .filter_map(|(&i, k)| k.then_some(i))
        .collect()
}

/// Share by which a peak may exceed a limit before it is reported: the derivative fit and a
/// control's own rounding of its limits stay within it.
const BEYOND_MARGIN: f64 = 1.05;

/// The recorded commands' peak speed and acceleration on each axis against the machine
/// file's rapid rate, acceleration limit and the acceleration its drive's current limit can
/// give (friction left aside, so this errs towards silence). Positions in m every `dt_s`.
pub(crate) fn beyond_machine(
    commands_m: &[Vec<f64>; 2],
    dt_s: f64,
    machine: &MachineConfig,
) -> Vec<BeyondMachine> {
    if commands_m[0].len() < 3 || dt_s.is_nan() || dt_s <= 0.0 {
        return Vec::new();
    }
    let c = commands_from_record(&commands_m[0], &commands_m[1], dt_s, dt_s);
    let mut found = Vec::new();
    for (axis, commands) in [(AxisName::X, &c.x), (AxisName::Y, &c.y)] {
        found.extend(axis_beyond(axis, machine.axis(axis), commands, dt_s));
    }
    found
}

/// One axis's peaks against its limits.
pub(crate) fn axis_beyond(
    axis: AxisName,
    config: &AxisConfig,
    c: &AxisCommands,
    dt_s: f64,
) -> Vec<BeyondMachine> {
    let peak = |v: &[f64]| {
        v.iter()
            .enumerate()
            .fold((0.0f64, 0usize), |(m, at), (k, x)| {
                if x.abs() > m { (x.abs(), k) } else { (m, at) }
            })
    };
    let (v_peak, v_at) = peak(&c.vel_m_per_s);
    let (a_peak, a_at) = peak(&c.acc_m_per_s2);
    let model = AxisModel::from_config(config);
    let drive_accel = model.kt * model.i_max * model.travel_per_motor_rad() / model.j_tot();
    let current_key = if config.velocity_loop.is_some() && config.controller.uses_velocity_loop() {
        "velocity_loop.i_max_a"
    } else {
        "amplifier.i_max_a"
    };
    let checks = [
        (
            "rapid rate",
            "limits.rapid_mm_per_min",
            mm_per_min_from_m_per_s(v_peak),
            config.limits.rapid_mm_per_min,
            "mm/min",
            v_at,
            v_peak > BEYOND_MARGIN * m_per_s_from_mm_per_min(config.limits.rapid_mm_per_min),
        ),
        (
            "acceleration limit",
            "limits.max_accel_m_per_s2",
            a_peak,
            config.limits.max_accel_m_per_s2,
            "m/s²",
            a_at,
            a_peak > BEYOND_MARGIN * config.limits.max_accel_m_per_s2,
        ),
        (
            "acceleration its drive's current limit gives",
            current_key,
            a_peak,
            drive_accel,
            "m/s²",
            a_at,
            drive_accel.is_finite() && a_peak > BEYOND_MARGIN * drive_accel,
        ),
    ];
    checks
        .into_iter()
        .filter(|c| c.6)
        .map(|(what, key, recorded, limit, unit, at, _)| BeyondMachine {
            axis,
            what,
            key,
            recorded,
            limit,
            unit,
            t_s: at as f64 * dt_s,
        })
        .collect()
}

/// Commands on a uniform step `dt_out_s` from positions recorded every `dt_in_s` (the first
/// sample at t = 0).
pub(crate) fn commands_from_record(
    x_m: &[f64],
    y_m: &[f64],
    dt_in_s: f64,
    dt_out_s: f64,
) -> Commands {
    let len = x_m.len().min(y_m.len());
    let n = if len == 0 {
        0
    } else {
        ((len - 1) as f64 * dt_in_s / dt_out_s).floor() as usize + 1
    };
    let half = DERIVATIVE_HALF_WIDTH_S
        .max(1.5 * dt_out_s)
        .max(1.5 * dt_in_s);
    let axis = |v: &[f64]| {
        let v = &v[..len];
        let mut out = AxisCommands {
            pos_m: Vec::with_capacity(n),
            vel_m_per_s: Vec::with_capacity(n),
            acc_m_per_s2: Vec::with_capacity(n),
        };
        for k in 0..n {
            let t = k as f64 * dt_out_s;
            let (vel, acc) = local_derivatives(v, dt_in_s, t, half);
            out.pos_m.push(sample(v, dt_in_s, t));
            out.vel_m_per_s.push(vel);
            out.acc_m_per_s2.push(acc);
        }
        out
    };
    Commands {
        dt_s: dt_out_s,
        x: axis(x_m),
        y: axis(y_m),
        z: AxisCommands {
            pos_m: vec![0.0; n],
            vel_m_per_s: vec![0.0; n],
            acc_m_per_s2: vec![0.0; n],
        },
        segment: vec![0; n],
    }
}

/// Slope and curvature at `t` of the least-squares parabola through the samples of `v`
/// (step `dt`) within ±`half` of `t`; zero where fewer than three samples lie there.
pub(crate) fn local_derivatives(v: &[f64], dt: f64, t: f64, half: f64) -> (f64, f64) {
    let lo = ((t - half) / dt).ceil().max(0.0) as usize;
    let hi = (((t + half) / dt).floor() as usize).min(v.len().saturating_sub(1));
    if hi < lo + 2 {
        return (0.0, 0.0);
    }
    // τ in units of `half` keeps the normal equations well conditioned.
    let mut s = [0.0f64; 5];
    let mut m = [0.0f64; 3];
    let y0 = v[lo];
    for (j, &vj) in v.iter().enumerate().take(hi + 1).skip(lo) {
        let tau = (j as f64 * dt - t) / half;
        let y = vj - y0;
        let mut p = 1.0;
        for (k, sk) in s.iter_mut().enumerate() {
            *sk += p;
            if k < 3 {
                m[k] += p * y;
            }
            p *= tau;
        }
    }
    // Normal equations of y ≈ a + b τ + c τ².
    let normal = nalgebra::Matrix3::new(s[0], s[1], s[2], s[1], s[2], s[3], s[2], s[3], s[4]);
    match normal.lu().solve(&nalgebra::Vector3::new(m[0], m[1], m[2])) {
        Some(c) => (c[1] / half, 2.0 * c[2] / (half * half)),
        None => (0.0, 0.0),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// X accelerates at `accel` to `speed` (m/s) and cruises, Y stands; sampled at 50 Hz for
    /// 1.5 s, as a control's 50 Hz trace of a rapid.
    fn rapid_at_50_hz(accel: f64, speed: f64) -> [Vec<f64>; 2] {
        let dt = 0.02;
        let t_ramp = speed / accel;
        let x = (0..75)
            .map(|k| {
                let t = k as f64 * dt;
                if t < t_ramp {
                    0.5 * accel * t * t
                } else {
                    0.5 * accel * t_ramp * t_ramp + speed * (t - t_ramp)
                }
            })
            .collect();
        [x, vec![0.1; 75]]
    }

    #[test]
    fn the_path_of_recorded_commands_stays_within_its_tolerance_with_few_lines() {
        // A 10 kHz record of a 20 mm line, a stop, and a quarter circle of radius 10 mm,
        // in 0.1 µm counts.
        let count = |v: f64| (v / 1e-7).round() * 1e-7;
        let (mut x, mut y) = (Vec::new(), Vec::new());
        for k in 0..=2000 {
            x.push(count(k as f64 * 1e-5));
            y.push(0.0);
        }
        for _ in 0..500 {
            x.push(0.02);
            y.push(0.0);
        }
        for k in 0..=3000 {
            let a = std::f64::consts::FRAC_PI_2 * k as f64 / 3000.0;
            x.push(count(0.01 + 0.01 * a.cos()));
            y.push(count(0.01 * a.sin()));
        }
        let program = program_from_commands(&[x.clone(), y.clone()], 1e-4, "r.csv").unwrap();
        let segs = &program.segments;
        // The line is one line; the arc needs chords of about √(8·R·tol) = 0.13 mm.
        assert_eq!(segs[0].end_m[..2], [0.02, 0.0]);
        assert!(segs.len() > 50 && segs.len() < 400, "{}", segs.len());
        assert_eq!(
            segs[1].line, 2001,
            "the arc starts where the line ended (sample 2001)"
        );
        for (px, py) in x.iter().zip(&y) {
            let nearest = segs
                .iter()
                .map(|s| {
                    let (a, b) = ([s.start_m[0], s.start_m[1]], [s.end_m[0], s.end_m[1]]);
                    distance_to_segment([*px, *py], a, b)
                })
                .fold(f64::INFINITY, f64::min);
            assert!(nearest <= COMMANDS_PATH_TOLERANCE_M + 1e-12, "{nearest}");
        }
        assert!(program_from_commands(&[vec![0.1; 10], vec![0.2; 10]], 1e-3, "still").is_none());
    }

    #[test]
    fn commands_beyond_the_machine_file_are_named_with_their_numbers() {
        let hvmc = MachineConfig::default_preset();
        // 36 m/min at 3 m/s²: beyond the preset's 6 m/min rapid and 0.5 m/s², within the
        // ≈5 m/s² its 60 A and 2.34 N·m/A give the 6 t table.
        let found = beyond_machine(&rapid_at_50_hz(3.0, 0.6), 0.02, &hvmc);
        let keys: Vec<(AxisName, &str)> = found.iter().map(|b| (b.axis, b.key)).collect();
        assert_eq!(
            keys,
            [
                (AxisName::X, "limits.rapid_mm_per_min"),
                (AxisName::X, "limits.max_accel_m_per_s2")
            ]
        );
        assert!((found[0].recorded - 36000.0).abs() < 50.0, "{}", found[0]);
        assert!((found[1].recorded - 3.0).abs() < 0.3, "{}", found[1]);
        let said = found[0].to_string();
        assert!(
            said.contains("X axis") && said.contains("36000") && said.contains("x.limits.rapid"),
            "{said}"
        );
        // 10 m/s² needs more current than the drive has.
        let found = beyond_machine(&rapid_at_50_hz(10.0, 1.0), 0.02, &hvmc);
        assert!(
            found.iter().any(|b| b.key == "velocity_loop.i_max_a"),
            "{found:?}"
        );
        // Within every limit: nothing.
        assert!(beyond_machine(&rapid_at_50_hz(0.2, 0.015), 0.02, &hvmc).is_empty());
    }

    #[test]
    fn derivatives_of_a_quantised_parabola_are_close_to_the_truth() {
        // x = 0.5·a·t² at 10 kHz with 0.1 µm counts; a = 2 m/s².
        let dt = 1e-4;
        let q = 1e-7;
        let x: Vec<f64> = (0..20_000)
            .map(|i| {
                let t = i as f64 * dt;
                (t * t / q).round() * q
            })
            .collect();
        let c = commands_from_record(&x, &x, dt, 2e-3);
        for k in 10..c.len() - 10 {
            let t = k as f64 * 2e-3;
            assert!((c.x.vel_m_per_s[k] - 2.0 * t).abs() < 2e-5, "{k}");
            assert!((c.x.acc_m_per_s2[k] - 2.0).abs() < 0.02, "{k}");
        }
    }

    #[test]
    fn three_samples_give_central_differences() {
        let x = [0.0, 1.0, 4.0];
        let (v, a) = local_derivatives(&x, 1.0, 1.0, 1.5);
        assert!((v - 2.0).abs() < 1e-12 && (a - 2.0).abs() < 1e-12);
    }
}
