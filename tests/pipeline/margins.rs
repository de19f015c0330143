//! Stability margins against an axis written out by hand. A cascade on a linear motor is a
//! rigid body pushed by a current amplifier: its loops are rational functions the test
//! writes from the physics — the amplifier's lag, the PI velocity controller, the mass and
//! its viscous drag, the P position loop — and reads its own margins off, by its own root
//! finding on the open loop, and its own closed-loop eigenvalues off the characteristic
//! polynomial. Nothing here is read from the tool but the figures under test.

use std::f64::consts::TAU;

use nalgebra::{Complex, DMatrix};

use contourcheck::machine::MachineConfig;
use contourcheck::sim::AxisModel;
use contourcheck::sim::linear::{self, Loop};
use contourcheck::sim::margins::{self, LoopMargins};

/// The table: mass (kg), force constant (N/A), viscous drag (N·s/m), amplifier bandwidth
/// (Hz), velocity gain (N·s/m) and integral time (s).
const MASS: f64 = 25.0;
const KT: f64 = 60.0;
const DRAG: f64 = 200.0;
const AMP_HZ: f64 = 500.0;
const KS: f64 = 4000.0;
const TS: f64 = 0.005;

fn machine(kv_m_per_min_per_mm: f64) -> MachineConfig {
    let toml = format!(
        "base = \"small-table\"\n\
         [x.controller]\nstructure = \"cascade\"\n\
         [x.drive]\nkind = \"linear_motor\"\ntable_mass_kg = {MASS}\n\
         [x.motor]\nkt_nm_per_a = {KT}\n\
         [x.friction]\nviscous_n_s_per_m = {DRAG}\n\
         [x.amplifier]\ncurrent_bandwidth_hz = {AMP_HZ}\ni_max_a = 20.0\n\
         [x.position_loop]\nkv_m_per_min_per_mm = {kv_m_per_min_per_mm}\n\
         [x.velocity_loop]\nks_nm_s_per_rad = {KS}\nts_ms = {}\ni_max_a = 20.0\n",
        TS * 1e3
    );
    MachineConfig::from_toml_str(&toml, "m.toml").unwrap()
}

/// A polynomial in s, lowest power first.
type Poly = Vec<f64>;

fn mul(a: &[f64], b: &[f64]) -> Poly {
    let mut out = vec![0.0; a.len() + b.len() - 1];
    for (i, x) in a.iter().enumerate() {
        for (j, y) in b.iter().enumerate() {
            out[i + j] += x * y;
        }
    }
    out
}

fn add(a: &[f64], b: &[f64]) -> Poly {
    (0..a.len().max(b.len()))
        .map(|i| a.get(i).unwrap_or(&0.0) + b.get(i).unwrap_or(&0.0))
        .collect()
}

fn eval(p: &[f64], s: Complex<f64>) -> Complex<f64> {
    p.iter()
        .rev()
        .fold(Complex::new(0.0, 0.0), |acc, &c| acc * s + c)
}

/// Roots of a polynomial: the eigenvalues of its companion matrix.
fn roots(p: &[f64]) -> Vec<Complex<f64>> {
    let n = p.len() - 1;
    let lead = p[n];
    let c = DMatrix::from_fn(n, n, |i, j| {
        if i == 0 {
            -p[n - 1 - j] / lead
        } else if i == j + 1 {
            1.0
        } else {
            0.0
        }
    });
    c.complex_eigenvalues().iter().copied().collect()
}

/// The loops as numerator and denominator of their open loops: the amplifier
/// 1/(τs + 1), the PI K_s(1 + 1/(T_s s)), the mass 1/(Ms + f_v) from force to speed; the
/// position loop Kv/s around the closed velocity loop.
struct Loops {
    velocity: (Poly, Poly),
    position: (Poly, Poly),
}

fn loops(kv_per_s: f64) -> Loops {
    let tau = 1.0 / (TAU * AMP_HZ);
    let nv = vec![KS, KS * TS];
    let dv = mul(&mul(&[0.0, TS], &[1.0, tau]), &[DRAG, MASS]);
    let closed = add(&dv, &nv);
    Loops {
        position: (
            nv.iter().map(|c| c * kv_per_s).collect(),
            mul(&[0.0, 1.0], &closed),
        ),
        velocity: (nv, dv),
    }
}

fn open(l: &(Poly, Poly), f_hz: f64) -> Complex<f64> {
    let s = Complex::new(0.0, TAU * f_hz);
    eval(&l.0, s) / eval(&l.1, s)
}

/// Sign changes of `g` on a log grid from 10 mHz to 100 kHz, each refined by bisection.
fn crossings(g: impl Fn(f64) -> f64) -> Vec<f64> {
    let grid: Vec<f64> = (0..=7000)
        .map(|i| 1e-2 * 10f64.powf(i as f64 / 1000.0))
        .collect();
    let mut out = Vec::new();
    for w in grid.windows(2) {
        let (mut lo, mut hi) = (w[0], w[1]);
        if (g(lo) < 0.0) == (g(hi) < 0.0) {
            continue;
        }
        let below = g(lo) < 0.0;
        for _ in 0..80 {
            let mid = (lo * hi).sqrt();
            if (g(mid) < 0.0) == below {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        out.push(lo);
    }
    out
}

/// The margins read off an open loop written out: (crossover Hz, phase margin °, phase
/// crossover Hz, gain margin dB, closed-loop peak dB).
fn read_off(l: &(Poly, Poly)) -> (f64, f64, f64, f64, f64) {
    let gain = crossings(|f| open(l, f).norm() - 1.0);
    assert_eq!(gain.len(), 1, "one gain crossover: {gain:?}");
    let pm = 180.0 + open(l, gain[0]).arg().to_degrees();
    let phase: Vec<f64> = crossings(|f| open(l, f).im)
        .into_iter()
        .filter(|&f| open(l, f).re < 0.0)
        .collect();
    let (pc, gm) = match phase.as_slice() {
        [] => (f64::NAN, f64::INFINITY),
        [f] => (*f, -20.0 * open(l, *f).norm().log10()),
        more => panic!("one phase crossover: {more:?}"),
    };
    let peak = (0..=200_000)
        .map(|i| 1e-2 * 10f64.powf(i as f64 / 20_000.0))
        .map(|f| {
            let o = open(l, f);
            (o / (o + 1.0)).norm()
        })
        .fold(0.0, f64::max);
    (gain[0], pm, pc, gm, 20.0 * peak.log10())
}

fn of(all: &[LoopMargins], which: Loop) -> LoopMargins {
    *all.iter().find(|m| m.which == which).unwrap()
}

#[test]
fn the_margins_are_those_of_the_open_loop_written_out() {
    for kv in [3.0, 10.0] {
        let kv_per_s = kv * 1000.0 / 60.0;
        let model = AxisModel::from_config(&machine(kv).x);
        let all = margins::margins(&model);
        let written = loops(kv_per_s);
        for (which, l) in [
            (Loop::Velocity, &written.velocity),
            (Loop::Position, &written.position),
        ] {
            let (fc, pm, pc, gm, peak) = read_off(l);
            let m = of(&all, which);
            let context = format!("Kv {kv}, {which:?}: {m:?} against {fc} {pm} {pc} {gm} {peak}");
            assert!(
                (m.crossover_hz.unwrap() / fc - 1.0).abs() < 1e-6,
                "{context}"
            );
            assert!((m.phase_margin_deg - pm).abs() < 0.01, "{context}");
            assert!((m.peak_db - peak).abs() < 0.01, "{context}");
            if gm.is_finite() {
                assert!(
                    (m.phase_crossover_hz.unwrap() / pc - 1.0).abs() < 1e-6,
                    "{context}"
                );
                assert!((m.gain_margin_db - gm).abs() < 0.01, "{context}");
            } else {
                assert_eq!(m.gain_margin_db, f64::INFINITY, "{context}");
                assert_eq!(m.phase_crossover_hz, None, "{context}");
            }
        }
        // An amplifier's current is a first-order lag: L = 1/(τs), 90° at its bandwidth.
        let current = of(&all, Loop::Current);
        assert!(
            (current.crossover_hz.unwrap() / AMP_HZ - 1.0).abs() < 1e-6,
            "{current:?}"
        );
        assert!((current.phase_margin_deg - 90.0).abs() < 1e-6);
        assert_eq!(current.gain_margin_db, f64::INFINITY);
    }
    // The faster position loop has the smaller margins.
    let [slow, fast] = [3.0, 10.0].map(|kv| {
        of(
            &margins::margins(&AxisModel::from_config(&machine(kv).x)),
            Loop::Position,
        )
    });
    assert!(
        fast.phase_margin_deg < slow.phase_margin_deg - 10.0,
        "{slow:?} {fast:?}"
    );
    assert!(
        fast.gain_margin_db < slow.gain_margin_db - 5.0,
        "{slow:?} {fast:?}"
    );
}

#[test]
fn the_gain_margin_is_where_a_closed_loop_pole_reaches_the_imaginary_axis() {
    let kv = 10.0;
    let kv_per_s = kv * 1000.0 / 60.0;
    let model = AxisModel::from_config(&machine(kv).x);
    let m = margins::loop_margins(&model, Loop::Position);
    let written = loops(kv_per_s);
    // Closed loop: s(D_v + N_v) + k·Kv·N_v, the position loop's gain multiplied by k.
    let characteristic = |k: f64| {
        add(
            &written.position.1,
            &written.position.0.iter().map(|c| c * k).collect::<Vec<_>>(),
        )
    };
    // At k = 1 its roots are the tool's closed-loop eigenvalues, all of them.
    let mut ours = roots(&characteristic(1.0));
    let mut tools: Vec<Complex<f64>> = linear::closed_loop_modes(&model)
        .iter()
        .map(|p| {
            let im = (TAU * p.frequency_hz).powi(2) - p.real_per_s.powi(2);
            Complex::new(p.real_per_s, im.max(0.0).sqrt())
        })
        .collect();
    let key = |c: &Complex<f64>| (c.re, c.im.abs());
    ours.sort_by(|a, b| key(a).partial_cmp(&key(b)).unwrap());
    tools.sort_by(|a, b| key(a).partial_cmp(&key(b)).unwrap());
    assert_eq!(ours.len(), tools.len(), "{ours:?} {tools:?}");
    for (a, b) in ours.iter().zip(&tools) {
        assert!(
            (a.re - b.re).abs() < 1e-6 * a.norm() && (a.im.abs() - b.im).abs() < 1e-6 * a.norm(),
            "{ours:?} against {tools:?}"
        );
    }
    // Raised by its gain margin the loop is on the edge: a pole pair on the imaginary axis
    // at the phase crossover; a percent less is stable, a percent more is not.
    let edge = 10f64.powf(m.gain_margin_db / 20.0);
    let worst = |k: f64| {
        roots(&characteristic(k))
            .into_iter()
            .max_by(|a, b| a.re.total_cmp(&b.re))
            .unwrap()
    };
    let at_edge = worst(edge);
    assert!(
        at_edge.re.abs() < 1e-6 * at_edge.norm(),
        "{at_edge} at k {edge}"
    );
    assert!((at_edge.im.abs() / (TAU * m.phase_crossover_hz.unwrap()) - 1.0).abs() < 1e-6);
    assert!(worst(0.99 * edge).re < 0.0 && worst(1.01 * edge).re > 0.0);
    // The tool's own stability check agrees at the machine's gain so raised.
    let stable = |kv: f64| linear::check_stable(&AxisModel::from_config(&machine(kv).x)).is_ok();
    assert!(stable(0.99 * edge * kv) && !stable(1.01 * edge * kv));
}

/// On the heavy machine the position loop's margin is lost to the table ringing on its
/// screw (the 38 Hz axial mode), not to the loop's own lag: its gain margin is the distance
/// to the largest stable Kv, found by bisection on the closed-loop eigenvalues, and its
/// phase margin is nearly the 90° of an integrator.
#[test]
fn the_heavy_machines_gain_margin_is_the_distance_to_its_largest_stable_kv() {
    let base = MachineConfig::default_preset();
    let stable = |kv: f64| {
        let mut x = base.x.clone();
        x.position_loop.kv_m_per_min_per_mm = kv;
        linear::check_stable(&AxisModel::from_config(&x)).is_ok()
    };
    let (mut lo, mut hi) = (1.0, 10.0);
    for _ in 0..50 {
        let mid = 0.5 * (lo + hi);
        if stable(mid) { lo = mid } else { hi = mid }
    }
    let m = margins::loop_margins(&AxisModel::from_config(&base.x), Loop::Position);
    let by_eigenvalues = 20.0 * lo.log10();
    assert!(
        (m.gain_margin_db - by_eigenvalues).abs() < 0.01,
        "{m:?} against {by_eigenvalues}"
    );
    assert!(
        (m.phase_crossover_hz.unwrap() / 38.4 - 1.0).abs() < 0.02,
        "{m:?}"
    );
    assert!(m.phase_margin_deg > 85.0, "{m:?}");
    // Below the 6 dB engineers ask for: the preset's Kv of 1 is a setting at its limit.
    assert!(m.gain_margin_db < margins::MIN_GAIN_MARGIN_DB);
}

/// One line of `bode`'s output that starts with `prefix`.
fn line_of<'a>(out: &'a str, prefix: &str) -> &'a str {
    out.lines()
        .find(|l| l.starts_with(prefix))
        .unwrap_or_else(|| panic!("no line {prefix:?} in\n{out}"))
}

/// The number before `unit` in `text` (the first such), in that unit; kHz read as Hz.
fn number_before(text: &str, unit: &str) -> f64 {
    let at = text
        .find(unit)
        .unwrap_or_else(|| panic!("{unit:?} in {text:?}"));
    let word = text[..at].split_whitespace().last().unwrap();
    let v: f64 = word
        .parse()
        .unwrap_or_else(|_| panic!("{word:?} in {text:?}"));
    if unit.trim_start().starts_with("kHz") {
        v * 1e3
    } else {
        v
    }
}

/// `bode`'s feedback-loop figures belong to T = L/(1 + L): with L of unit gain and phase
/// −180° + PM at the crossover, T there is 1/(2 sin(PM/2)) at −90° + PM/2 — so its −10°
/// comes before the crossover and its −3 dB after it, and its peak is at least that gain.
/// (The response from the command with feed-forward is a different one, its own figures
/// checked in `the_feed_forward_response_is_the_closed_form_one`.)
#[test]
fn bode_figures_each_belong_to_one_response() {
    let o = crate::common::cli::run_ok(&["bode", "--machine", "small-table"]);
    let out = crate::common::cli::text(&o.stdout);
    let row = line_of(&out, "position ");
    let cells: Vec<&str> = row.split_whitespace().collect();
    let crossover_hz: f64 = cells[1].parse().unwrap();
    let pm_deg: f64 = cells[3].trim_end_matches('°').parse().unwrap();
    let peak_db: f64 = cells[6].parse().unwrap();
    let (bw_3db_hz, phase_10_hz): (f64, f64) =
        (cells[11].parse().unwrap(), cells[13].parse().unwrap());
    let machine = MachineConfig::preset("small-table").unwrap();
    let model = AxisModel::from_config(&machine.x);
    let l = linear::open_loop(&model, Loop::Position, crossover_hz);
    assert!((l.norm() - 1.0).abs() < 2e-3, "{l}");
    let margin = (l.arg().to_degrees() + 180.0).rem_euclid(360.0);
    assert!((margin - pm_deg).abs() < 0.1, "{margin} against {pm_deg}");
    let t_at_fc_db = 20.0 * (1.0 / (2.0 * (pm_deg / 2.0).to_radians().sin())).log10();
    let t_phase_deg = -90.0 + pm_deg / 2.0;
    assert!(
        t_phase_deg < -10.0 && t_at_fc_db > -3.0,
        "{t_phase_deg} {t_at_fc_db}"
    );
    assert!(
        phase_10_hz < crossover_hz && bw_3db_hz > crossover_hz,
        "{row}"
    );
    assert!(peak_db >= t_at_fc_db - 0.01, "{row}: {t_at_fc_db}");
}

/// The small table's X controller C(s) = (108.1 s² + 13512.5 s + 422265.6)/(s² + 1250 s) A/mm
/// with its acceleration feed-forward, on a rigid linear motor of the small table's inertia
/// as a mass at the table (110 kg; 308 N/A, its 0.49 N·m/A over the 10 mm lead's radius),
/// 200 N·s/m of drag and a 300 Hz current amplifier A(s) = ω_a/(s + ω_a). Written here from
/// that physics: the plant P = K_t·A/(M s² + c s) (m per A), the loop L = 1000·C·P (C per
/// mm), the feed-forward current M·s²·x_ref/K_t, so the command's response is
/// x/x_ref = (1000·C + M s²/K_t)·P/(1 + L) — a peak of about 1.3 dB near 49 Hz where the
/// amplifier's lag on the fed-forward current meets the loop's own rise.
const FF_MASS_KG: f64 = 110.0;
const FF_KT_N_PER_A: f64 = 308.0;
const FF_DRAG_N_S_PER_M: f64 = 200.0;
const FF_AMP_HZ: f64 = 300.0;
const FF_NUM: [f64; 3] = [108.1, 13512.5, 422265.6];
const FF_DEN: [f64; 3] = [1.0, 1250.0, 0.0];

/// |x/x_ref| (dB) of the linear motor above with feed-forward, at `f_hz`.
fn feed_forward_response_db(f_hz: f64) -> f64 {
    let s = Complex::new(0.0, TAU * f_hz);
    let poly = |c: [f64; 3]| c[0] * s * s + c[1] * s + c[2];
    let c_per_m = 1000.0 * poly(FF_NUM) / poly(FF_DEN);
    let amp = TAU * FF_AMP_HZ / (s + TAU * FF_AMP_HZ);
    let plant = FF_KT_N_PER_A * amp / (FF_MASS_KG * s * s + FF_DRAG_N_S_PER_M * s);
    let ff = FF_MASS_KG * s * s / FF_KT_N_PER_A;
    let t = (c_per_m + ff) * plant / (1.0 + c_per_m * plant);
    20.0 * t.norm().log10()
}

/// `bode`'s line for the response with feed-forward gives that response's own peak and
/// −3 dB, as the closed form above has them on a grid of 4000 points a decade.
#[test]
fn the_feed_forward_response_is_the_closed_form_one() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("linear.toml");
    let num = FF_NUM.map(|c| format!("{c:?}")).join(", ");
    let den = FF_DEN.map(|c| format!("{c:?}")).join(", ");
    std::fs::write(
        &file,
        format!(
            "base = \"small-table\"\n\
             [x.controller]\nstructure = \"transfer_function\"\nnumerator = [{num}]\n\
             denominator = [{den}]\noutput = \"current\"\nsample_ms = 0.0\n\
             accel_feedforward = 1.0\n\
             [x.drive]\nkind = \"linear_motor\"\ntable_mass_kg = {FF_MASS_KG:?}\n\
             [x.motor]\nkt_nm_per_a = {FF_KT_N_PER_A:?}\n\
             [x.friction]\nviscous_n_s_per_m = {FF_DRAG_N_S_PER_M:?}\n\
             [x.amplifier]\ncurrent_bandwidth_hz = {FF_AMP_HZ:?}\ni_max_a = 20.0\n"
        ),
    )
    .unwrap();
    let o = crate::common::cli::run_ok(&["bode", "--machine", file.to_str().unwrap()]);
    let out = crate::common::cli::text(&o.stdout);
    let ff = line_of(
        &out,
        "position loop, command to position with feed-forward:",
    );
    let ff_db = number_before(ff, " dB at");
    let at = &ff[ff.find(" dB at ").unwrap() + 7..];
    let ff_hz = number_before(at, " Hz");
    let bw_hz = number_before(&ff[ff.find("−3 dB").unwrap()..], " Hz");
    let (mut best_db, mut best_hz, mut below_3db_hz) = (f64::MIN, 0.0, None);
    for i in 0..=20_000 {
        let f = 10f64.powf(-1.0 + 5.0 * f64::from(i) / 20_000.0);
        let db = feed_forward_response_db(f);
        if db > best_db {
            (best_db, best_hz) = (db, f);
        }
        if db < -3.0 && below_3db_hz.is_none() {
            below_3db_hz = Some(f);
        }
    }
    assert!(best_db > 1.0 && best_hz > 30.0, "{best_db} at {best_hz}");
    assert!(
        (ff_db - best_db).abs() < 0.01,
        "{ff}: {best_db:.3} dB at {best_hz:.1} Hz"
    );
    assert!(
        (ff_hz / best_hz - 1.0).abs() < 0.01,
        "{ff}: {best_hz:.1} Hz"
    );
    let below_3db_hz = below_3db_hz.unwrap();
    assert!(
        (bw_hz / below_3db_hz - 1.0).abs() < 0.01,
        "{ff}: −3 dB at {below_3db_hz:.1} Hz"
    );
}
