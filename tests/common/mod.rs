//! What several test files share: the sample programs, and a foreign interpolator that
//! commands them as another control would.

#![allow(dead_code)]

#[allow(dead_code)]
pub mod cli;
#[allow(dead_code)]
pub mod diagnosing;
#[allow(dead_code)]
pub mod entry;
#[allow(dead_code)]
pub mod identifying;
#[allow(dead_code)]
pub mod reference;

use std::path::Path;

use contourcheck::diagnose::Diagnosis;
use contourcheck::diagnose::learn::Term;
use contourcheck::diagnose::synth::CommandStream;
use contourcheck::gcode::{InterpretOptions, Program, parse_program};
use contourcheck::machine::AxisName;

pub fn sample_program(name: &str) -> Program {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let sample = root.join("gcode-samples").join(name);
    // Programs only the tests use live in the tests' own data.
    let path = if sample.exists() {
        sample
    } else {
        root.join("tests").join("data").join(name)
    };
    parse_program(
        &std::fs::read_to_string(&path).unwrap(),
        name,
        &InterpretOptions::default(),
    )
    .unwrap()
}

/// The folder of programs written by others that the environment variable `variable`
/// names, or `None` (after saying "skipped: corpus not present") when this machine has
/// none. A variable that names no folder is a broken setup, not an absent corpus: that
/// fails.
pub fn corpus_dir(variable: &str) -> Option<std::path::PathBuf> {
    use std::io::Write;
    let Some(dir) = std::env::var_os(variable) else {
        // Straight to the stream: the test harness captures `eprintln!`, and the skip must
        // be seen.
        let _ = writeln!(
            std::io::stderr(),
            "skipped: corpus not present ({variable} is not set)"
        );
        return None;
    };
    let dir = std::path::PathBuf::from(dir);
    assert!(dir.is_dir(), "{variable}={} is not a folder", dir.display());
    Some(dir)
}

pub fn program_text(text: &str) -> Program {
    parse_program(text, "test.nc", &InterpretOptions::default()).unwrap()
}

/// The points per turn a "no polar plot" reason states ("…, N per turn, fewer than …"), as
/// the terminal and the HTML page word it.
pub fn stated_points_per_turn(reason: &str) -> f64 {
    reason
        .split(" per turn")
        .next()
        .and_then(|s| s.rsplit(", ").next())
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| panic!("no points per turn in: {reason}"))
}

/// The foreign interpolator ([`reference::Trapezoids`]: each block on its own trapezoidal
/// profile at `accel`, stopping at its end) with `pre_s` of standstill before and 0.5 s after,
/// sampled every `dt_s`.
pub fn foreign_commands(program: &Program, accel: f64, dt_s: f64, pre_s: f64) -> CommandStream {
    let interpolator = reference::Trapezoids::new(program, accel, pre_s, 0.5);
    let n = (interpolator.duration_s / dt_s).floor() as usize;
    let (x, y) = (0..n)
        .map(|k| {
            let p = interpolator.position(k as f64 * dt_s);
            (p[0], p[1])
        })
        .unzip();
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

/// That `d` names nothing and reports `cause` on `axis` as seen, not determined: the record
/// shows it, but the model extended by it predicts the axis worse point by point — its
/// reason gives that RMS before and after, and after is the larger — so the model stays the
/// nominal one.
pub fn assert_seen_not_named(d: &Diagnosis, cause: contourcheck::CauseId, axis: AxisName) {
    assert!(d.causes.is_empty(), "{:?}", d.causes);
    let seen: Vec<_> = d.rejected.iter().filter(|r| r.seen).collect();
    assert_eq!(seen.len(), 1, "{:?}", d.rejected);
    assert_eq!((seen[0].id, seen[0].axis), (cause, axis));
    let figures: Vec<f64> = seen[0]
        .reason
        .split("residual RMS ")
        .nth(1)
        .and_then(|r| r.split(" µm").next())
        .map(|r| r.split(" → ").map(|v| v.parse().unwrap()).collect())
        .unwrap_or_default();
    assert!(
        figures.len() == 2 && figures[1] > figures[0],
        "{}",
        seen[0].reason
    );
    assert_eq!(d.after.x.rms_um, d.before.x.rms_um);
    assert_eq!(d.after.y.rms_um, d.before.y.rms_um);
}

/// That an estimate stated as `estimate ± sigma` (a standard uncertainty) lies within `k` of
/// its σ of `truth`, the value the hidden machine has. The message names the value, the
/// truth, the estimate, σ, k and how many σ apart they landed. A σ that is not a number fails.
pub fn assert_within_k_sigma(what: &str, truth: f64, estimate: f64, sigma: f64, k: f64) {
    let off = (estimate - truth).abs();
    assert!(
        off <= k * sigma,
        "{what}: the estimate {estimate} ± {sigma} (σ) lies {:.2}σ from the truth {truth}, \
         more than k = {k}",
        off / sigma
    );
}

/// As [`assert_within_k_sigma`], and also within `share` of the truth's size: a value found
/// to a tight σ that misses by more than a user could use (a σ the fit understates) fails too.
pub fn assert_within_k_sigma_and_share(
    what: &str,
    truth: f64,
    estimate: f64,
    sigma: f64,
    k: f64,
    share: f64,
) {
    assert_within_k_sigma(what, truth, estimate, sigma, k);
    let off = (estimate - truth).abs();
    assert!(
        off <= share * truth.abs(),
        "{what}: the estimate {estimate} misses the truth {truth} by {:.2} % of it, more than \
         {:.2} %",
        100.0 * off / truth.abs(),
        100.0 * share
    );
}
