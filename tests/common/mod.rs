//! What several test files share: the sample programs, and a foreign interpolator that
//! commands them as another control would.

#![allow(dead_code)]

use std::path::Path;

use contourcheck::diagnose::Diagnosis;
use contourcheck::diagnose::learn::Term;
use contourcheck::gcode::{InterpretOptions, Program, parse_program};
use contourcheck::machine::AxisName;
use contourcheck::path::{Geometry, Motion};
use contourcheck::synth::CommandStream;

pub fn sample_program(name: &str) -> Program {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("gcode-samples")
        .join(name);
    parse_program(
        &std::fs::read_to_string(&path).unwrap(),
        name,
        &InterpretOptions::default(),
    )
    .unwrap()
}

pub fn program_text(text: &str) -> Program {
    parse_program(text, "test.nc", &InterpretOptions::default()).unwrap()
}

/// A block of the foreign interpolator: XY position at a time into it.
type Block = Box<dyn Fn(f64) -> [f64; 2]>;

/// The foreign interpolator: each block on its own trapezoidal profile (accelerate at
/// `accel`, cruise at the programmed feed, stop at the block's end), rapids at 10 m/min,
/// dwells standing; `pre_s` of standstill before and 0.5 s after; positions every `dt_s`.
pub fn foreign_commands(program: &Program, accel: f64, dt_s: f64, pre_s: f64) -> CommandStream {
    const RAPID_M_PER_S: f64 = 10.0 / 60.0;
    // Per block: its duration and a way to evaluate its position at a time into it.
    let mut blocks: Vec<(f64, Block)> = Vec::new();
    let start = program.segments[0].start_m;
    blocks.push((pre_s, Box::new(move |_| [start[0], start[1]])));
    for seg in program.segments.iter().copied() {
        if let Geometry::Dwell { seconds } = seg.geometry {
            let p = seg.start_m;
            blocks.push((seconds, Box::new(move |_| [p[0], p[1]])));
            continue;
        }
        let length = seg.length_m();
        if length <= 0.0 {
            continue;
        }
        let v = if seg.motion == Motion::Rapid {
            RAPID_M_PER_S
        } else {
            seg.feed_m_per_s.min(RAPID_M_PER_S)
        };
        // Triangular when the block is too short to reach the feed.
        let v = v.min((accel * length).sqrt());
        let t_acc = v / accel;
        let t_cruise = (length - v * t_acc) / v;
        let total = 2.0 * t_acc + t_cruise;
        let distance = move |t: f64| {
            if t < t_acc {
                0.5 * accel * t * t
            } else if t < t_acc + t_cruise {
                0.5 * v * t_acc + v * (t - t_acc)
            } else {
                let r = (total - t).max(0.0);
                length - 0.5 * accel * r * r
            }
        };
        blocks.push((
            total,
            Box::new(move |t| {
                let p = seg.eval(distance(t).clamp(0.0, length), length).pos;
                [p[0], p[1]]
            }),
        ));
    }
    let end = program.segments.last().unwrap().end_m;
    blocks.push((0.5, Box::new(move |_| [end[0], end[1]])));
    let total: f64 = blocks.iter().map(|b| b.0).sum();
    let n = (total / dt_s).floor() as usize;
    let (mut x, mut y) = (Vec::with_capacity(n), Vec::with_capacity(n));
    let (mut block, mut block_start) = (0, 0.0);
    for k in 0..n {
        let t = k as f64 * dt_s;
        while block + 1 < blocks.len() && t >= block_start + blocks[block].0 {
            block_start += blocks[block].0;
            block += 1;
        }
        let p = (blocks[block].1)(t - block_start);
        x.push(p[0]);
        y.push(p[1]);
    }
    CommandStream {
        dt_s,
        x_m: x,
        y_m: y,
    }
}

/// That `d` names no catalogue cause and learns the tight spot hidden on X — friction
/// 589 N higher between 60 and 80 mm — where it is, at about its size, and so that the
/// half of the record it was not fitted on loses more than half of its residual.
pub fn assert_tight_spot_learned(d: &Diagnosis) {
    assert!(d.causes.is_empty(), "{:?}", d.causes);
    assert_eq!(d.learned.len(), 1, "{:?}", d.learned);
    let l = &d.learned[0];
    assert_eq!((l.axis, l.term), (AxisName::X, Term::FrictionMap), "{l:?}");
    let (lo, hi) = l.interval.unwrap();
    assert!(
        (55.0..=63.0).contains(&lo) && (77.0..=85.0).contains(&hi),
        "{l:?}"
    );
    assert!((l.peak - 589.0).abs() < 0.25 * 589.0, "{l:?}");
    assert!(l.held_out_after_um <= 0.5 * l.held_out_before_um, "{l:?}");
}
