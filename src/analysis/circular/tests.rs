//! The circular-test figures of paths whose shapes are known.

use super::*;

/// The figures of a path commanded where it runs (a path without lag), each circle's first
/// sample commanded at that circle's start, where the command stands before it sets off;
/// the path's first sample is repeated before it, so that every sample of the first circle
/// counts.
fn circular_test(circles: &[Circle], segment: &[u32], pos_m: [&[f64]; 3]) -> CircularTest {
    let before = |v: &[f64]| -> Vec<f64> { v.first().into_iter().chain(v).copied().collect() };
    let segment: Vec<u32> = segment
        .first()
        .into_iter()
        .chain(segment)
        .copied()
        .collect();
    let pos_m = pos_m.map(before);
    let mut command_m = pos_m.clone();
    for k in 0..segment.len() {
        let first = k == 0 || segment[k] != segment[k - 1];
        let Some(c) = circles
            .iter()
            .find(|c| first && c.segment == segment[k] as usize)
        else {
            continue;
        };
        let [a, b, normal] = c.plane.axes();
        let (sin, cos) = c.start_rad.sin_cos();
        let start = [
            c.center_m[0] + c.radius_m * cos,
            c.center_m[1] + c.radius_m * sin,
        ];
        for (axis, v) in [(a, start[0]), (b, start[1]), (normal, c.height_m)] {
            if let Some(x) = command_m[axis].get_mut(k) {
                *x = v;
            }
        }
    }
    let command = CommandSeries {
        segment: &segment,
        pos_m: [&command_m[0], &command_m[1], &command_m[2]],
    };
    super::circular_test(
        circles,
        &segment,
        [&pos_m[0], &pos_m[1], &pos_m[2]],
        &command,
        &CircleWindows::default(),
    )
}

fn circle(ccw: bool, segment: usize) -> Circle {
    Circle {
        segment,
        line: 10 + segment as u32,
        center_m: [0.0, 0.0],
        radius_m: 0.1,
        ccw,
        feed_m_per_s: 1000.0 / 60_000.0,
        plane: Plane::Xy,
        height_m: 0.0,
        length_m: std::f64::consts::TAU * 0.1,
        start_rad: 0.0,
    }
}

/// Points of a circle of `radius` about `center`, one per degree (mid-degree, off the
/// 1° bins' edges).
fn ring(center: [f64; 2], radius: impl Fn(f64) -> f64) -> (Vec<f64>, Vec<f64>) {
    (0..360)
        .map(|d| {
            let a = (d as f64 + 0.5).to_radians();
            let r = radius(a);
            (center[0] + r * a.cos(), center[1] + r * a.sin())
        })
        .unzip()
}

#[test]
fn an_off_centre_circle_has_no_circular_deviation_but_a_radial_one() {
    // 5 µm off centre in X, 2 µm too small: G 0, F from −7 to +3 µm.
    let (x, y) = ring([5e-6, 0.0], |_| 0.1 - 2e-6);
    let t = circular_test(&[circle(true, 0)], &vec![0; 360], [&x, &y, &[]]);
    let c = t.circles[0];
    assert!(c.g_um < 1e-3, "{c:?}");
    assert!(
        (c.f_max_um - 3.0).abs() < 1e-3 && (c.f_min_um + 7.0).abs() < 1e-3,
        "{c:?}"
    );
}

#[test]
fn an_ellipse_shows_its_axes_difference_as_g_and_opposite_paths_their_hysteresis() {
    // r = R + 4 µm·cos 2θ: G = 8 µm. The clockwise path lies 3 µm further out: H = 3 µm.
    let (x1, y1) = ring([0.0, 0.0], |a| 0.1 + 4e-6 * (2.0 * a).cos());
    let (x2, y2) = ring([0.0, 0.0], |a| 0.1 + 3e-6 + 4e-6 * (2.0 * a).cos());
    let segment: Vec<u32> = [vec![0; 360], vec![1; 360]].concat();
    let t = circular_test(
        &[circle(true, 0), circle(false, 1)],
        &segment,
        [&[x1, x2].concat(), &[y1, y2].concat(), &[]],
    );
    assert!((t.circles[0].g_um - 8.0).abs() < 0.01, "{:?}", t.circles[0]);
    assert!((t.pairs[0].h_um - 3.0).abs() < 0.01, "{:?}", t.pairs[0]);
    assert!(
        (t.pairs[0].g_both_um - 11.0).abs() < 0.02,
        "{:?}",
        t.pairs[0]
    );
}

#[test]
fn opposite_circles_in_planes_apart_are_no_pair() {
    // The same centre and radius in the plane's coordinates, run both ways: one pair
    // where both lie at one height in one plane; none at heights 5 mm apart, nor for a
    // ZX circle beside an XY one.
    let (x, y) = ring([0.0, 0.0], |_| 0.1);
    let segment: Vec<u32> = [vec![0; 360], vec![1; 360]].concat();
    let (xs, ys) = ([x.clone(), x].concat(), [y.clone(), y].concat());
    let pairs = |second: Circle| {
        let z = vec![0.0; 720];
        circular_test(&[circle(true, 0), second], &segment, [&xs, &ys, &z])
            .pairs
            .len()
    };
    assert_eq!(pairs(circle(false, 1)), 1);
    let lower = Circle {
        height_m: -0.005,
        ..circle(false, 1)
    };
    assert_eq!(pairs(lower), 0);
    let upright = Circle {
        plane: Plane::Zx,
        ..circle(false, 1)
    };
    assert!(!upright.is_same_circle(&circle(true, 0)));
    assert!(!lower.is_same_circle(&circle(true, 0)));
}

#[test]
fn a_spike_at_a_quadrant_point_is_measured_against_its_neighbourhood() {
    // A 6 µm outward bump within ±2° of 90°.
    let (x, y) = ring([0.0, 0.0], |a| {
        let d = (a.to_degrees() - 90.5).abs();
        0.1 + if d <= 2.0 { 6e-6 } else { 0.0 }
    });
    let t = circular_test(&[circle(true, 0)], &vec![0; 360], [&x, &y, &[]]);
    let s = t.circles[0].reversal_spikes_um;
    assert!((s[1] - 6.0).abs() < 1e-6 && s[0].abs() < 1e-6, "{s:?}");
}

#[test]
fn spikes_at_three_quadrant_points_read_as_no_ellipse() {
    // X's scale 20 ppm long — the radius R·(1 + s·cos²θ), whose 2θ term R·s/2 is read back
    // as s — with 20 µm spikes within ±2° of 90°, 180° and 270° and none at 0° (a start
    // left out there). Fitted with them, the three would add (2/360)·(−1 + 1 − 1)·5·20 µm
    // to the 2θ term: −11 ppm on R100.
    let scale = 20e-6;
    let (x, y) = ring([0.0, 0.0], |a| {
        let deg = a.to_degrees();
        let spike = [90.5, 180.5, 270.5].iter().any(|q| (deg - q).abs() <= 2.0);
        0.1 * (1.0 + scale * a.cos().powi(2)) + if spike { 20e-6 } else { 0.0 }
    });
    let t = circular_test(&[circle(true, 0)], &vec![0; 360], [&x, &y, &[]]);
    let c = &t.circles[0];
    assert!((c.scale_mismatch_ppm - 20.0).abs() < 0.2, "{c:?}");
    assert!(c.diagonal_ellipse_urad.abs() < 0.2, "{c:?}");
}

/// Both directions of the R100 circle at F1000 as axes with lags `tau_s` ([X, Y]) and
/// the X reading `alpha`·y more and (1 + `scale`)·x, from the commanded point at
/// `theta` — what a ballbar would record.
fn pair_of(tau_s: [f64; 2], alpha: f64, scale: f64) -> CircularTest {
    let omega = (1000.0 / 60_000.0) / 0.1;
    let path = |ccw: bool| -> (Vec<f64>, Vec<f64>) {
        let w = if ccw { omega } else { -omega };
        (0..720)
            .map(|k| {
                let theta = (k as f64 + 0.5).to_radians() * 0.5;
                let x = 0.1 * (theta - w * tau_s[0]).cos();
                let y = 0.1 * (theta - w * tau_s[1]).sin();
                ((1.0 + scale) * x + alpha * y, y)
            })
            .unzip()
    };
    opposite_pair(path)
}

#[test]
fn squareness_servo_and_scale_mismatch_are_told_apart_by_direction() {
    // Squareness 50 µrad: the same diagonal ellipse both ways.
    let t = pair_of([0.0, 0.0], 50e-6, 0.0);
    let p = t.pairs[0];
    assert!((p.squareness_urad - 50.0).abs() < 0.5, "{p:?}");
    assert!(
        p.servo_mismatch_ms.abs() < 0.05 && p.scale_mismatch_ppm.abs() < 0.5,
        "{p:?}"
    );
    // Y lagging X by 6.67 ms (Kv 0.9 against 1.0 m/min/mm): an ellipse that turns
    // with the direction.
    let t = pair_of([0.060, 0.060 + 0.0066667], 0.0, 0.0);
    let p = t.pairs[0];
    assert!((p.servo_mismatch_ms - 6.6667).abs() < 0.07, "{p:?}");
    assert!(p.squareness_urad.abs() < 0.5, "{p:?}");
    // Its ellipse, 111 µm across, is no lost motion, play or bow.
    for v in [
        p.backlash_x_um,
        p.backlash_y_um,
        p.lateral_play_x_um,
        p.lateral_play_y_um,
        p.straightness_x_um,
        p.straightness_y_um,
    ] {
        assert!(v.abs() < 0.3, "{p:?}");
    }
    // The X scale 30 ppm long: an ellipse along the axes.
    let t = pair_of([0.0, 0.0], 0.0, 30e-6);
    let p = t.pairs[0];
    assert!((p.scale_mismatch_ppm - 30.0).abs() < 0.3, "{p:?}");
    assert!(
        p.squareness_urad.abs() < 0.5 && p.servo_mismatch_ms.abs() < 0.05,
        "{p:?}"
    );
    assert!((t.circles[0].diagonal_ellipse_urad).abs() < 0.5);
}

/// Both directions of the R100 circle, the tool off the commanded point by
/// `off(θ, direction of X, direction of Y)` (m).
fn pair_reading(off: impl Fn(f64, f64, f64) -> [f64; 2]) -> CircularTest {
    let path = |ccw: bool| -> (Vec<f64>, Vec<f64>) {
        let turn = if ccw { 1.0 } else { -1.0 };
        (0..1440)
            .map(|k| {
                let theta = (k as f64 + 0.5).to_radians() * 0.25;
                // Counter-clockwise, X travels −sin θ and Y cos θ.
                let (dir_x, dir_y) = (-turn * theta.sin().signum(), turn * theta.cos().signum());
                let [dx, dy] = off(theta, dir_x, dir_y);
                (0.1 * theta.cos() + dx, 0.1 * theta.sin() + dy)
            })
            .unzip()
    };
    opposite_pair(path)
}

/// The figures of the R100 circle run counter-clockwise (segment 0) and clockwise
/// (segment 1) along the paths `path(ccw)` gives.
fn opposite_pair(path: impl Fn(bool) -> (Vec<f64>, Vec<f64>)) -> CircularTest {
    let ((x1, y1), (x2, y2)) = (path(true), path(false));
    let segment: Vec<u32> = [vec![0; x1.len()], vec![1; x2.len()]].concat();
    circular_test(
        &[circle(true, 0), circle(false, 1)],
        &segment,
        [&[x1, x2].concat(), &[y1, y2].concat(), &[]],
    )
}

#[test]
fn straightness_lateral_play_and_lost_motion_are_read_from_their_shapes() {
    // Y's travel bowed 5 µm over the diameter as X sees it, X shifting 4 µm across Y's
    // reversals, Y lagging 3 µm behind its direction of travel.
    let t = pair_reading(|theta, _dir_x, dir_y| {
        let bow = -5e-6 * theta.sin().powi(2);
        [bow + 2e-6 * dir_y, -1.5e-6 * dir_y]
    });
    let p = t.pairs[0];
    let near = |v: f64, want: f64| (v - want).abs() < 0.25;
    assert!(
        near(p.straightness_x_um, 5.0) && near(p.straightness_y_um, 0.0),
        "{p:?}"
    );
    assert!(
        near(p.lateral_play_x_um, 4.0) && near(p.lateral_play_y_um, 0.0),
        "{p:?}"
    );
    assert!(
        near(p.backlash_y_um, 3.0) && near(p.backlash_x_um, 0.0),
        "{p:?}"
    );
    assert!(p.squareness_urad.abs() < 1.0, "{p:?}");
    // The same on the other axes.
    let t = pair_reading(|theta, dir_x, _dir_y| {
        let bow = -5e-6 * theta.cos().powi(2);
        [-1.5e-6 * dir_x, bow + 2e-6 * dir_x]
    });
    let p = t.pairs[0];
    assert!(
        near(p.straightness_y_um, 5.0) && near(p.straightness_x_um, 0.0),
        "{p:?}"
    );
    assert!(
        near(p.lateral_play_y_um, 4.0) && near(p.lateral_play_x_um, 0.0),
        "{p:?}"
    );
    assert!(
        near(p.backlash_x_um, 3.0) && near(p.backlash_y_um, 0.0),
        "{p:?}"
    );
}

/// The bound (|radial| + n·|turned|)·e⁻ⁿ falls to 0.1 µm after n time constants: for a
/// millimetre radially and nothing along the path, ln(1 mm / 0.1 µm) = ln 10⁴ = 9.2103;
/// for 1 mm along the path on a circle turning ωτ = 0.05 per time constant,
/// n·50 µm·e⁻ⁿ = 0.1 µm, i.e. n = ln(500·n) = 8.3351 (by hand, iterating n ← ln(500·n)
/// from 9). Never fewer than the floor; nothing known gives the floor; any finite
/// transient an answer that meets the bound.
#[test]
fn the_entry_time_constants_meet_the_residue_bound() {
    use super::entry::{Apart, settling_within};
    let none = Apart {
        size_m: 0.0,
        per_time_constant: 0.0,
    };
    let solve = |a: f64, b: f64, floor: f64| settling_within(a, b, none, floor);
    let residual = |a: f64, b: f64, n: f64| ((a + n * b).ln() - n - (0.1e-6f64).ln()).abs();
    let radial_only = solve(1e-3, 0.0, 5.0);
    assert!(
        (radial_only - 4.0 * std::f64::consts::LN_10).abs() < 1e-9,
        "{radial_only}"
    );
    let turned_only = solve(0.0, 0.05 * 1e-3, 5.0);
    assert!((turned_only - 8.3351).abs() < 1e-4, "{turned_only}");
    assert!(residual(0.0, 5e-5, turned_only) < 1e-9);
    // Both: more than either alone, on the bound.
    let both = solve(20e-6, 5e-5, 5.0);
    assert!(
        both > turned_only && residual(20e-6, 5e-5, both) < 1e-9,
        "{both}"
    );
    // A sign is no size: −1 mm is a millimetre.
    assert_eq!(solve(-1e-3, 0.0, 5.0), radial_only);
    // 5 µm radially falls below 0.1 µm in ln 50 = 3.9: the floor holds.
    assert_eq!(solve(5e-6, 0.0, 5.0), 5.0);
    assert!((solve(5e-6, 0.0, 0.0) - (50.0f64).ln()).abs() < 1e-9);
    for (a, b) in [(0.0, 0.0), (f64::NAN, 0.0), (0.0, f64::NAN)] {
        assert_eq!(solve(a, b, 5.0), 5.0, "{a} {b}");
    }
    for (a, b) in [(1e300, 0.0), (0.0, 1e300), (1e300, 1e300)] {
        let n = solve(a, b, 5.0);
        assert!(n.is_finite() && residual(a, b, n) < 1e-9, "{a} {b}: {n}");
    }
    let n = solve(f64::INFINITY, 0.0, 5.0);
    assert!(n.is_finite() && n >= 5.0, "{n}");
}

/// A first-order loop of time constant τ lags a command ramping at v from rest by
/// v·τ·(1 − e^(−t/τ)), whatever the sampling: X ramps under τ = 50 ms, Y stands, Z has no
/// lag (τ zero), sampled at uneven steps of 0.7 and 1.9 ms.
#[test]
fn the_loop_model_lags_a_ramp_as_the_closed_form() {
    let (v_m_per_s, tau_s) = (0.02, 0.05);
    let mut lag = super::entry::LoopLag::default();
    let mut t_s = 0.0;
    for k in 0..400 {
        lag.advance(
            [tau_s, 0.03, 0.0],
            t_s,
            [v_m_per_s * t_s, 0.1, v_m_per_s * t_s],
        );
        let want_m = v_m_per_s * tau_s * (1.0 - (-t_s / tau_s).exp());
        assert!(
            (lag.lag_m[0] - want_m).abs() < 1e-12 * v_m_per_s * tau_s,
            "{t_s}"
        );
        assert!(lag.lag_m[1] == 0.0 && lag.lag_m[2] == 0.0, "{t_s}");
        t_s += if k % 2 == 0 { 0.7e-3 } else { 1.9e-3 };
    }
    // A clock that gives no time (NaN) leaves no lag; the next ramp starts from rest.
    lag.advance([tau_s; 3], f64::NAN, [1.0; 3]);
    assert_eq!(lag.lag_m, [0.0; 3]);
}

/// On the R100 circle at F1000 (ω = 1/6 rad/s) under τ = 60 ms (ωτ = 0.01), a first-order
/// loop carries the steady lag R·jωτ/(1 + jωτ) behind the command: Rω²τ²/(1 + ω²τ²) =
/// 9.999 µm of it radial (the table inside the command) and Rωτ/(1 + ω²τ²) = 999.9 µm along
/// the path. A model carrying that lag has no transient; one at rest has all of it.
#[test]
fn the_entry_transient_is_the_lag_less_the_circles_own() {
    let entry = EntrySettling {
        time_constant_s: [0.06, 0.06, 0.0],
    };
    let wt: f64 = 0.01;
    let (radial_m, along_m) = (0.1 * wt * wt / (1.0 + wt * wt), 0.1 * wt / (1.0 + wt * wt));
    for (ccw, theta) in [(true, 0.0), (true, 1.0), (false, 2.5)] {
        let c = circle(ccw, 0);
        let (sin, cos) = f64::sin_cos(theta);
        let turn = if ccw { 1.0 } else { -1.0 };
        // Radially outward and along the direction of travel.
        let steady_m = [
            radial_m * cos - turn * along_m * sin,
            radial_m * sin + turn * along_m * cos,
            0.0,
        ];
        let command_m = [0.1 * cos, 0.1 * sin, 0.0];
        let none = entry.transient_m(&c, command_m, steady_m, c.feed_m_per_s);
        // To the rounding of a millimetre's lag (1e-19 m a digit).
        assert!(none[0].abs() < 1e-14 && none[1].abs() < 1e-14, "{none:?}");
        let all = entry.transient_m(&c, command_m, [0.0; 3], c.feed_m_per_s);
        assert!((all[0].abs() - radial_m).abs() < 1e-14, "{all:?}");
        assert!((all[1].abs() - along_m).abs() < 1e-14, "{all:?}");
    }
}

/// The R100 circle at F1000 under τ = 60 ms, its command standing at the start and then
/// setting off at full feed (a step of speed) while the loop stands: the transient is the
/// whole steady lag above, 9.999 µm radial and 999.9 µm along the path, which the turning
/// circle (ωτ = 0.01) brings into the radius: (10 µm + n·10 µm)·e⁻ⁿ = 0.1 µm after
/// n = 6.638 time constants (by hand, n ← ln(100·(1 + n))), 3.803° at 0.573° each, and the
/// set-off step's 16.7 µm: 3.813° (that step's own lag moves it by under 0.01°). Entered
/// at speed along its tangent, the model already carries the steady lag along the path and
/// nothing across it: only the 10 µm radial part is a transient, ln 100 = 4.6 time
/// constants, and five are left out, 2.865°. The end keeps five.
#[test]
fn the_entry_window_is_worked_out_from_the_commands() {
    let entry = EntrySettling {
        time_constant_s: [0.06, 0.06, 0.0],
    };
    let c = circle(true, 0);
    let omega = c.feed_m_per_s / c.radius_m;
    let step_s = 1e-3;
    let turn_steps = (std::f64::consts::TAU / (omega * step_s)).round() as usize;
    let on_circle = |k: usize| {
        let a = omega * step_s * k.min(turn_steps) as f64;
        [0.1 * a.cos(), 0.1 * a.sin(), 0.0]
    };
    // Standing 1 s at the start, or running 2 s up the tangent line x = R into it.
    let from_rest: Vec<([f64; 3], u32)> = (0..1000)
        .map(|_| (on_circle(0), 0))
        .chain((1..=turn_steps).map(|k| (on_circle(k), 0)))
        .collect();
    let up_tangent: Vec<([f64; 3], u32)> = (0..2000)
        .map(|k| {
            let behind_m = c.feed_m_per_s * step_s * (2000 - k) as f64;
            ([0.1, -behind_m, 0.0], 1)
        })
        .chain((0..=turn_steps).map(|k| (on_circle(k), 0)))
        .collect();
    for (commands, want_deg) in [(from_rest, 3.813), (up_tangent, 2.865)] {
        let mut gathered = CircleSamples::new(vec![c], entry);
        for (k, &(pos_m, segment)) in commands.iter().enumerate() {
            let command = Commanded {
                segment,
                pos_m,
                t_s: k as f64 * step_s,
            };
            gathered.push(segment, pos_m, command);
        }
        let f = gathered.test().0.circles[0];
        assert!((f.start_left_out_deg - want_deg).abs() < 0.01, "{f:?}");
        assert!((f.end_left_out_deg - 2.865).abs() < 0.001, "{f:?}");
    }
}

#[test]
fn a_spike_is_cut_only_by_the_window_on_its_own_side_of_the_start() {
    // Counter-clockwise from 30°: 0° lies 30° before the start, in the end's window of 22.9°
    // (and 3° of the spike's own) — not cut; the start's 40° would have reached it.
    let ccw = Circle {
        start_rad: 30f64.to_radians(),
        ..circle(true, 0)
    };
    assert!(!cut_by_windows(&ccw, 0.0, [40.0, 22.9]));
    assert!(cut_by_windows(&ccw, 0.0, [40.0, 28.0]));
    // 90° lies 60° past the start: cut by a start window beyond 57°.
    assert!(!cut_by_windows(&ccw, 90.0, [56.0, 22.9]));
    assert!(cut_by_windows(&ccw, 90.0, [58.0, 22.9]));
    // Clockwise from 30°, 0° lies 30° past the start.
    let cw = Circle {
        start_rad: 30f64.to_radians(),
        ..circle(false, 0)
    };
    assert!(cut_by_windows(&cw, 0.0, [40.0, 5.0]));
    assert!(!cut_by_windows(&cw, 90.0, [40.0, 5.0]));
    // Nothing left out, nothing cut.
    assert!(!cut_by_windows(&cw, 0.0, [0.0, 0.0]));
}

/// Two loops at their own paces: a transient of 1 mm whose halves part by up to 0.5 mm·e⁻ⁿ
/// once they have (a tenth apart in pace: after ten time constants) — with nothing radial
/// or turned, 0.5 mm·e⁻ⁿ = 0.1 µm at n = ln 5000 = 8.517; a hundredth apart, the parting
/// 0.5 mm·0.01·n·e⁻ⁿ = 0.1 µm at n with n·e⁻ⁿ = 0.02 (5.642: n ← ln 50 + ln n from 5 gives
/// 5.521, 5.620, 5.638, 5.641, 5.642).
#[test]
fn loops_of_two_paces_part_the_transient_into_the_radius() {
    use super::entry::{Apart, settling_within};
    let apart = |k: f64| Apart {
        size_m: 0.5e-3,
        per_time_constant: k,
    };
    let far = settling_within(0.0, 0.0, apart(10.0), 5.0);
    assert!((far - 5000f64.ln()).abs() < 1e-6, "{far}");
    let near = settling_within(0.0, 0.0, apart(0.01), 0.0);
    assert!(((near * (-near).exp()) - 0.02).abs() < 1e-9, "{near}");
    assert!((near - 5.642).abs() < 0.001, "{near}");
    // Loops of one pace part nothing: the plain bound.
    assert_eq!(
        settling_within(1e-3, 0.0, apart(0.0), 5.0),
        4.0 * std::f64::consts::LN_10
    );
    // Nothing known of the parting counts as none; never below the floor.
    let nan = Apart {
        size_m: f64::NAN,
        per_time_constant: 0.5,
    };
    assert_eq!(settling_within(0.0, 0.0, nan, 5.0), 5.0);
}

/// The time constants a transient of the whole steady lag takes to fall to 0.1 µm on a
/// circle of `radius_m` turning ωτ = `wt` per time constant: A = Rω²τ²/(1 + ω²τ²) radial,
/// D = Rωτ/(1 + ω²τ²) along the path, n ← ln((A + n·ωτ·D)/0.1 µm) from above.
fn whole_lag_time_constants(radius_m: f64, wt: f64) -> f64 {
    let (a_m, d_m) = (
        radius_m * wt * wt / (1.0 + wt * wt),
        radius_m * wt / (1.0 + wt * wt),
    );
    let mut n: f64 = 50.0;
    for _ in 0..200 {
        n = ((a_m + n * wt * d_m) / 0.1e-6).ln();
    }
    n
}

/// The R100 circle of F1000 run at 60 % of its feed (an override): v = 10 mm/s, ω = 0.1
/// rad/s, ωτ = 0.006 under τ = 60 ms, set off from rest at that speed. The transient is the
/// whole steady lag at that speed, Rω²τ²/(1 + ω²τ²) = 3.6 µm radial and Rωτ/(1 + ω²τ²) =
/// 600 µm along the path: n ← ln((A + n·ωτ·D)/0.1 µm) gives 5.447 time constants, and the
/// window is that many at v from the set-off, n·ωτ = 1.873°; the end's five at v, 1.719° (at
/// the feed: 2.865°). Without a clock the window is worked out at the set-off at the
/// programmed feed, no panic (its closed form below).
#[test]
fn the_window_is_counted_at_the_speed_the_command_runs() {
    let entry = EntrySettling {
        time_constant_s: [0.06, 0.06, 0.0],
    };
    let c = circle(true, 0);
    let (v, tau_s, step_s) = (0.6 * c.feed_m_per_s, 0.06, 1e-3);
    let omega = v / c.radius_m;
    let turn_steps = (std::f64::consts::TAU / (omega * step_s)).round() as usize;
    let at = |k: usize| {
        let a = omega * step_s * k.min(turn_steps) as f64;
        [0.1 * a.cos(), 0.1 * a.sin(), 0.0]
    };
    let wt = omega * tau_s;
    let n = whole_lag_time_constants(c.radius_m, wt);
    assert!((n - 5.447).abs() < 0.001, "{n}");
    for timed in [true, false] {
        let mut gathered = CircleSamples::new(vec![c], entry);
        for k in 0..1000 + turn_steps {
            let t_s = if timed { k as f64 * step_s } else { f64::NAN };
            let pos_m = at(k.saturating_sub(1000));
            gathered.push(
                0,
                pos_m,
                Commanded {
                    segment: 0,
                    pos_m,
                    t_s,
                },
            );
        }
        let f = gathered.test().0.circles[0];
        if timed {
            let want_deg = (n * wt).to_degrees();
            assert!(
                (f.start_left_out_deg - want_deg).abs() < 0.01,
                "{want_deg} {f:?}"
            );
            let end_deg = (5.0 * wt).to_degrees();
            assert!(
                (f.end_left_out_deg - end_deg).abs() < 1e-3 * end_deg,
                "{f:?}"
            );
        } else {
            // No clock: the model has no lag, read at the set-off against the circle's steady
            // lag at the programmed feed (ωτ = 0.01): A = 10.0 µm, D = 999.9 µm, and
            // n ← ln((A + n·ωτ·D)/0.1 µm) = 6.64 time constants from the set-off step
            // (0.1 rad/s for 1 ms), the end's five at the feed.
            let wt_feed = c.feed_m_per_s / c.radius_m * tau_s;
            let n = whole_lag_time_constants(c.radius_m, wt_feed);
            assert!((n - 6.64).abs() < 0.01, "{n}");
            let want_deg = (omega * step_s + n * wt_feed).to_degrees();
            assert!(
                (f.start_left_out_deg - want_deg).abs() < 0.01,
                "{want_deg} {f:?}"
            );
            let end_deg = (5.0 * wt_feed).to_degrees();
            assert!(
                (f.end_left_out_deg - end_deg).abs() < 1e-3 * end_deg,
                "{f:?}"
            );
        }
    }
}

/// The R100 circle run at v = 10 mm/s from its set-off and slowed into its end at a steady
/// v/T_d over T_d = 30τ (τ = 60 ms): the slowing takes v·T_d/2 = 9 mm of path (5.16°), longer
/// than the five time constants at v (3 mm, 1.72°) the end leaves out at least. Commands as a
/// control records them: at 50 Hz and 1 kHz, rounded to 1 µm and 0.1 µm counts. The end's
/// window reaches back to where the command last ran at v: the slowing's path, and no more
/// than one time constant and a sample's step beyond it (where the newer of the last two
/// spans found steady began). The start's, set off at v from rest, is the whole lag's 5.447
/// time constants at v (as above), however the commands were recorded.
#[test]
fn the_end_window_reaches_back_to_where_the_command_slows() {
    let tau_s = 0.06;
    let c = circle(true, 0);
    let v = 0.01;
    let t_d = 30.0 * tau_s;
    let slowing_m = 0.5 * v * t_d;
    let start_time_constants = whole_lag_time_constants(c.radius_m, v / c.radius_m * tau_s);
    // Path run at time t: at v until the slowing, then v·s − v·s²/(2·T_d) for s into it.
    let steady_s = (c.length_m - slowing_m) / v;
    let run_at = |t: f64| {
        let s = (t - steady_s).clamp(0.0, t_d);
        v * t.min(steady_s) + v * s - v * s * s / (2.0 * t_d)
    };
    for (rate_hz, count_m) in [
        (50.0, 1e-6),
        (50.0, 0.1e-6),
        (1000.0, 1e-6),
        (1000.0, 0.1e-6),
    ] {
        let step_s = 1.0 / rate_hz;
        let rounded = |x: f64| (x / count_m).round() * count_m;
        let end_k = ((steady_s + t_d) / step_s).ceil() as usize;
        let commands = (0..=end_k + 10).map(|k| {
            let a = run_at(k as f64 * step_s) / c.radius_m;
            [rounded(0.1 * a.cos()), rounded(0.1 * a.sin()), 0.0]
        });
        let f = figures_of_commands(c, tau_s, step_s, commands);
        let end_m = f.end_left_out_deg.to_radians() * c.radius_m;

        assert!(
            end_m >= slowing_m,
            "{rate_hz} Hz, {count_m} m: {end_m} {f:?}"
        );
        let most_m = slowing_m + tau_s * v + step_s * v;
        assert!(end_m < most_m, "{rate_hz} Hz, {count_m} m: {end_m} {f:?}");
        let start_deg = (start_time_constants * v / c.radius_m * tau_s).to_degrees();
        assert!(
            (f.start_left_out_deg - start_deg).abs() < 0.01,
            "{rate_hz} Hz, {count_m} m: {start_deg} {f:?}"
        );
    }
}

/// A record's commands as a resampled rapid leaves them: the command overshoots onto the
/// circle by 2 µm along its tangent and comes back (which sets it off: more than 1 µm), then
/// stands for a second reading a picometre apart from sample to sample along the path (a
/// fitted resampling's noise; 1.7e-8 m/s over every span alike), then runs round at v =
/// 10 mm/s. The standing reads no steady speed: the start is worked out where the command
/// runs, n = 5.447 time constants of the whole lag at v (as above), to 0.005° (9 µm of path;
/// the overshoot's is a few µm).
#[test]
fn a_standing_command_has_no_steady_speed() {
    let tau_s = 0.06;
    let c = circle(true, 0);
    let (v, step_s) = (0.01, 1e-3);
    let omega = v / c.radius_m;
    let turn_steps = (std::f64::consts::TAU / (omega * step_s)).round() as usize;
    let overshoot = [0.0, 1e-6, 2e-6, 1e-6, 0.0].map(|y| [0.1, y, 0.0]);
    let standing = (0..1000).map(|k| [0.1, if k % 2 == 0 { 0.0 } else { 1e-12 }, 0.0]);
    let running = (1..=turn_steps).map(|k| {
        let a = omega * step_s * k as f64;
        [0.1 * a.cos(), 0.1 * a.sin(), 0.0]
    });
    let commands = overshoot.into_iter().chain(standing).chain(running);
    let f = figures_of_commands(c, tau_s, step_s, commands);
    let n = whole_lag_time_constants(c.radius_m, omega * tau_s);
    let want_deg = (n * omega * tau_s).to_degrees();
    assert!(
        (f.start_left_out_deg - want_deg).abs() < 0.005,
        "{want_deg} {f:?}"
    );
}

/// A record that stops three quarters of the way round a clockwise R100 circle run at v =
/// 10 mm/s: the command never slowed, so the end leaves out its five time constants at v
/// (3 mm, 1.719°), not the path from where the record stopped to the circle's end.
#[test]
fn a_record_that_stops_on_the_circle_has_not_seen_it_slow() {
    let tau_s = 0.06;
    let c = circle(false, 0);
    let (v, step_s) = (0.01, 1e-3);
    let omega = v / c.radius_m;
    let steps = (0.75 * std::f64::consts::TAU / (omega * step_s)) as usize;
    let commands = (0..=steps).map(|k| {
        let a = -omega * step_s * k as f64;
        [0.1 * a.cos(), 0.1 * a.sin(), 0.0]
    });
    let f = figures_of_commands(c, tau_s, step_s, commands);
    let end_deg = (5.0 * tau_s * omega).to_degrees();
    assert!((end_deg - 1.719).abs() < 0.001, "{end_deg}");
    assert!(
        (f.end_left_out_deg - end_deg).abs() < 1e-3 * end_deg,
        "{f:?}"
    );
}

/// The figures of circle `c` (plan segment 0) from a path run where it is commanded (no
/// lag), its commands `commands` one every `step_s` from time zero, both loops of time
/// constant `tau_s`.
fn figures_of_commands(
    c: Circle,
    tau_s: f64,
    step_s: f64,
    commands: impl IntoIterator<Item = [f64; 3]>,
) -> CircleFigures {
    let entry = EntrySettling {
        time_constant_s: [tau_s, tau_s, 0.0],
    };
    let mut gathered = CircleSamples::new(vec![c], entry);
    for (k, pos_m) in commands.into_iter().enumerate() {
        let t_s = k as f64 * step_s;
        gathered.push(
            0,
            pos_m,
            Commanded {
                segment: 0,
                pos_m,
                t_s,
            },
        );
    }
    gathered.test().0.circles[0]
}

/// A record begun while the command ran round a circle counts the command's path from the
/// circle's start: at every point the path places a given length along full circles in
/// each plane and sense (the path's own parametrisation, not the polar angle), that length;
/// none within a tenth of a millimetre of the start either way, where the command may stand.
#[test]
fn a_record_begun_mid_circle_counts_from_the_circles_start() {
    let text = "G21 G90 G17 G94\nG0 X10 Y0 Z0\nG3 X10 Y0 I-10 J0 F1000\nG2 X10 Y0 I-10 J0\n\
                G18 G2 X10 Z0 I-10 K0\nG3 X10 Z0 I-10 K0\nG19 G3 Y0 Z0 J-5 K0\n\
                G2 Y0 Z0 J-5 K0\nM2\n";
    let program =
        crate::gcode::parse_program(text, "t.nc", &crate::gcode::InterpretOptions::default())
            .unwrap();
    let found = circles(&program.segments);
    assert_eq!(found.len(), 6, "{found:?}");
    for c in &found {
        let seg = program.segments[c.segment];
        let at = |along_m: f64| {
            let p = seg.eval(along_m, c.length_m).pos;
            c.begun_at_m(c.polar(c.plane.coords(p)).0)
        };
        for share in [0.01, 0.25, 0.5, 0.75, 0.99] {
            let along_m = share * c.length_m;
            let got = at(along_m).unwrap_or(f64::NAN);
            assert!((got - along_m).abs() < 1e-9, "{c:?} at {along_m}: {got}");
        }
        for near_m in [0.0, 5e-5, c.length_m - 5e-5] {
            assert_eq!(at(near_m), None, "{c:?} at {near_m}");
        }
    }
}

/// A circle too sparsely sampled for its loops' settling: under loops of τ = 2 s the R100
/// circle at F1000 (16.7 mm/s) needs five time constants, 167 mm, at its end and more from
/// rest at its start, so each window takes its most, a quarter turn, and half the turn is
/// left. Sampled 80 times a turn, that half holds 39 points — figures enough (36), the
/// quarter turns left out; sampled 60 times, 29: every point counts, nothing is said to be
/// left out, and the figures and their line say they hold the settling.
#[test]
fn a_circle_too_sparse_for_its_windows_says_its_figures_hold_the_settling() {
    let c = circle(true, 0);
    let turn_s = c.length_m / c.feed_m_per_s;
    for (per_turn, included) in [(80usize, false), (60, true)] {
        let step_s = turn_s / per_turn as f64;
        let commands = (0..=per_turn).map(|k| {
            let a = std::f64::consts::TAU * k as f64 / per_turn as f64;
            [0.1 * a.cos(), 0.1 * a.sin(), 0.0]
        });
        let f = figures_of_commands(c, 2.0, step_s, commands);
        assert_eq!(f.settling_included, included, "{per_turn}: {f:?}");
        let left_out_deg = if included { 0.0 } else { 90.0 };
        assert!((f.start_left_out_deg - left_out_deg).abs() < 1e-9, "{f:?}");
        assert!((f.end_left_out_deg - left_out_deg).abs() < 1e-9, "{f:?}");
        let text = CircularTest {
            circles: vec![f],
            pairs: Vec::new(),
        }
        .text();
        assert_eq!(text.contains("too few samples between"), included, "{text}");
        assert_eq!(text.contains("left out"), !included, "{text}");
    }
}
