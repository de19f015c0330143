//! Where a cause's fit starts: first guesses of its parameters read off the residual
//! (regressions where the cause is linear in them, the residual's strongest frequency for a
//! resonance, typical values elsewhere) and, for causes the fit cannot reach from any one
//! start, a small grid of others. The fit descends from each and keeps the best, so the
//! grids only need to land within its reach of the answer.

use crate::diagnose::causes::{CauseId, Kinematics};
use crate::machine::AxisConfig;
use crate::numeric::units::{
    kv_m_per_min_per_mm_from_per_s, per_s_from_kv_m_per_min_per_mm, um_from_m,
};

/// First guesses of a cause's parameters from the residual (regressions where the cause
/// is linear in its parameters, typical values elsewhere).
pub(super) fn initial_guess(
    cause: CauseId,
    axis: &AxisConfig,
    r: &[f64],
    k: &Kinematics,
) -> Vec<f64> {
    let (pos, vel) = (k.pos_m, k.vel_m_per_s);
    let slope = |f: &dyn Fn(usize) -> f64| line_slope(r, f);
    match cause {
        // r = −s·x in full closed loop (the table stops short): ppm = −slope.
        CauseId::ScaleError => vec![-slope(&|i| pos[i]) * 1e6],
        CauseId::CyclicError => {
            let w = std::f64::consts::TAU / k.cyclic_period_m;
            let (a, b) = (
                slope(&|i| (w * pos[i]).sin()),
                slope(&|i| (w * pos[i]).cos()),
            );
            // r = −A sin(wx + φ) = −A cos φ sin wx − A sin φ cos wx.
            vec![um_from_m(a.hypot(b)), (-b).atan2(-a).to_degrees()]
        }
        CauseId::DeadTime => vec![(-slope(&|i| vel[i]) * 1e3).clamp(0.0, 200.0)],
        CauseId::KvGain => {
            let kv = per_s_from_kv_m_per_min_per_mm(axis.position_loop.kv_m_per_min_per_mm);
            let c = slope(&|i| vel[i]);
            let kv_new = 1.0 / (1.0 / kv - c);
            vec![kv_m_per_min_per_mm_from_per_s(if kv_new > 0.0 {
                kv_new
            } else {
                kv
            })]
        }
        CauseId::Backlash => {
            let peak = r
                .iter()
                .zip(k.near_reversal)
                .filter(|(_, n)| **n)
                .fold(0.0f64, |m, (v, _)| m.max(v.abs()));
            vec![um_from_m(peak * 1.4).max(1.0)]
        }
        CauseId::CoulombFriction => vec![axis.friction.coulomb_coefficient * 3.0],
        CauseId::Stribeck => vec![300.0, 20.0],
        CauseId::Resonance => vec![dominant_frequency(r, k.dt_s), 0.05],
        // r = α·y: µrad = slope.
        CauseId::Squareness => vec![slope(&|i| k.other_pos_m[i]) * 1e6],
        // r = −b·(2q/L)²: b = −slope on (2q/L)².
        CauseId::Straightness => {
            let half_span_m = 0.5e-3 * axis.errors.straightness_span_mm;
            vec![-slope(&|i| (k.other_pos_m[i] / half_span_m).powi(2)) * 1e6]
        }
        // r = ±p/2 with the other axis's direction (or its own): p = 2·slope.
        CauseId::LateralPlay => {
            let dir = k.other_direction();
            vec![2.0 * slope(&|i| dir[i]) * 1e6]
        }
        CauseId::DirectionOffset => {
            let dir = k.own_direction();
            vec![2.0 * slope(&|i| dir[i]) * 1e6]
        }
        // Found from two simulations instead (`ripple::linear_start`): the machine's.
        CauseId::ForceRipple => vec![
            axis.errors.force_ripple_n,
            axis.errors.force_ripple_phase_deg,
        ],
    }
}

/// The slope of the straight line through (f(i), r[i]) by least squares, an intercept
/// beside it; 0 where f does not vary.
fn line_slope(r: &[f64], f: &dyn Fn(usize) -> f64) -> f64 {
    let n = r.len();
    let (mut sxy, mut sxx, mut sx, mut sy) = (0.0, 0.0, 0.0, 0.0);
    for (i, &y) in r.iter().enumerate() {
        let x = f(i);
        sxy += x * y;
        sxx += x * x;
        sx += x;
        sy += y;
    }
    let d = sxx - sx * sx / n as f64;
    if d.abs() > 0.0 {
        (sxy - sx * sy / n as f64) / d
    } else {
        0.0
    }
}

/// Where a fit may start: the data's first guess and, for causes that are not linear in
/// their parameters, a small grid around typical values (the fit refines the best).
pub(super) fn starts(cause: CauseId, guess: Vec<f64>, current: &[f64]) -> Vec<Vec<f64>> {
    let mut s = vec![guess.clone()];
    match cause {
        // Log-spaced grids: 0.5–50 µm; 0.25–8 × the nominal coefficient; levels and
        // velocities over two decades; 5–200 Hz.
        CauseId::Backlash => s.extend((0..=16).map(|i| vec![0.5 * 10f64.powf(i as f64 / 8.0)])),
        CauseId::CoulombFriction => {
            s.extend((0..=10).map(|i| vec![guess[0] / 3.0 * 0.25 * 2f64.powf(i as f64 / 2.0)]))
        }
        // Levels 30–770 N, velocities 3–50 mm/min: 35 starts (each a simulation of the
        // whole record), about 1.7× and 2× apart, which the descent's ±20–50 % spans.
        CauseId::Stribeck => {
            for i in 0..7 {
                for j in 0..5 {
                    s.push(vec![
                        30.0 * 1.5f64.powf(i as f64 * 8.0 / 6.0),
                        3.0 * 1.6f64.powf(j as f64 * 6.0 / 4.0),
                    ]);
                }
            }
        }
        // Gains 0.6–1.5 × the guess, dead times 0–20 ms: a lag also moves the program's
        // waits, which can throw the regression's guess far off.
        CauseId::KvGain => s.extend((0..=12).map(|i| vec![current[0] * 0.6 * 1.08f64.powi(i)])),
        CauseId::DeadTime => s.extend((0..=10).map(|i| vec![2.0 * i as f64])),
        CauseId::Resonance => {
            for i in 0..12 {
                for zeta in [0.02, 0.1] {
                    s.push(vec![5.0 * 40f64.powf(i as f64 / 11.0), zeta]);
                }
            }
        }
        _ => {}
    }
    s
}

/// The frequency (5–200 Hz) where the residual's periodogram peaks.
fn dominant_frequency(r: &[f64], dt: f64) -> f64 {
    let mut best = (20.0, 0.0);
    let mut f = 5.0;
    while f < 200.0f64.min(0.45 / dt) {
        let w = std::f64::consts::TAU * f * dt;
        let (mut c, mut s) = (0.0, 0.0);
        for (i, v) in r.iter().enumerate() {
            let (sn, cs) = (w * i as f64).sin_cos();
            c += v * cs;
            s += v * sn;
        }
        let p = c * c + s * s;
        if p > best.1 {
            best = (f, p);
        }
        f *= 1.01;
    }
    best.0
}
