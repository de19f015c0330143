//! The circular-test figures of paths whose shapes are known.

use super::*;

/// The figures of a path commanded where it runs (a path without lag), after a sample
/// whose command stands a millimetre before the first: every sample of the path counts.
fn circular_test(circles: &[Circle], segment: &[u32], pos_m: [&[f64]; 3]) -> CircularTest {
    let before = |v: &[f64], by: f64| -> Vec<f64> {
        v.first()
            .map(|&v0| v0 + by)
            .into_iter()
            .chain(v.iter().copied())
            .collect()
    };
    let segment: Vec<u32> = before(&segment.iter().map(|&s| s as f64).collect::<Vec<_>>(), 0.0)
        .into_iter()
        .map(|s| s as u32)
        .collect();
    let pos_m = pos_m.map(|v| before(v, 0.0));
    let command_m = [
        before(&pos_m[0][1..], -1e-3),
        pos_m[1].clone(),
        pos_m[2].clone(),
    ];
    let command = CommandSeries {
        segment: &segment,
        pos_m: [&command_m[0], &command_m[1], &command_m[2]],
    };
    super::circular_test(
        circles,
        &segment,
        [&pos_m[0], &pos_m[1], &pos_m[2]],
        &command,
        EntrySettling::default(),
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

/// The start's window from the deviation the table sets off with: a radial deviation r
/// decaying as r·e^(−t/τ) falls to 0.1 µm after ln(r / 0.1 µm) time constants — 9.21 for a
/// millimetre (ln 10⁴) — and never fewer than five are left out; the end keeps five.
#[test]
fn the_entry_window_grows_with_the_deviation_the_table_sets_off_with() {
    let tau_s = 0.02;
    let entry = EntrySettling {
        time_constant_s: [tau_s, tau_s, 0.0],
    };
    let c = circle(true, 0);
    let per_time_constant_m = tau_s * c.feed_m_per_s;
    // Counted from where the command set off: 0.1 mm along the circle.
    let set_off_m = 1e-4;
    let far = (entry.entry_lead_m(&c, -1e-3, set_off_m) - set_off_m) / per_time_constant_m;
    assert!((far - 4.0 * std::f64::consts::LN_10).abs() < 1e-9, "{far}");
    for near_m in [0.0, 1e-7, 5e-6, -14.8e-6] {
        let lead = entry.entry_lead_m(&c, near_m, set_off_m) / per_time_constant_m;
        assert!((lead - 5.0).abs() < 1e-9, "{near_m}: {lead}");
    }
    assert!((entry.lead_m(&c) / per_time_constant_m - 5.0).abs() < 1e-9);
}
