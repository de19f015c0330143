//! The circular test's start window on command streams another interpolator made. A full
//! circle entered from rest on a trapezoidal speed along its arc is interpolated here, not
//! by our planner, and written as a control's trace writes it: sampled at 50 Hz to 10 kHz,
//! the positions rounded to encoder counts; the table follows the exact stream by the
//! independent reference of `common::reference`. The window `diagnose` leaves out at the
//! circle's start, worked out from the record's rounded commands, is held against the
//! replica's of `common::entry` on the exact commands, and the circle's G against what the
//! counts alone may spread it by.

use crate::common;

use common::entry::{
    ENTRY_RESIDUE_M, ENTRY_TIME_CONSTANTS, EntryWindow, entry_window, residue_at_m,
};
use common::program_text;
use common::reference::{Axis, Plant, s_curve_phases, through_phases};
use contourcheck::analysis::circular::CircleFigures;
use contourcheck::diagnose::causes::CauseSet;
use contourcheck::diagnose::{DiagnoseSettings, diagnose};
use contourcheck::machine::{AxisConfig, MachineConfig};
use contourcheck::trace::measured::parse_trace;
use std::f64::consts::{FRAC_1_SQRT_2, TAU};

/// A circle of the test: its radius (mm) and feed (mm/min).
#[derive(Debug, Clone, Copy)]
struct Spec {
    radius_mm: f64,
    feed_mm_per_min: f64,
    /// The path jerk the speed ramps at (m/s³), or `None` for a trapezoid.
    jerk_m_per_s3: Option<f64>,
}

impl Spec {
    fn radius_m(&self) -> f64 {
        self.radius_mm * 1e-3
    }

    fn speed_m_per_s(&self) -> f64 {
        self.feed_mm_per_min / 60e3
    }
}

/// At the machine's top feed, the lag v·τ a millimetre.
const FAST: Spec = Spec {
    radius_mm: 20.0,
    feed_mm_per_min: 1000.0,
    jerk_m_per_s3: None,
};
/// The same at the axes' jerk limit: the speed ramps for 115 ms rather than 33 ms, the
/// acceleration tapering off into the feed.
const FAST_S_CURVE: Spec = Spec {
    jerk_m_per_s3: Some(5.0),
    ..FAST
};
/// The same at a gentle jerk: the speed ramps for 0.82 s, its slowing into the circle's end
/// (6.8 mm) longer than five time constants at the feed (5 mm).
const FAST_GENTLE: Spec = Spec {
    jerk_m_per_s3: Some(0.1),
    ..FAST
};
/// At a quarter of it on a small circle: the lag a quarter of a millimetre, a count of 1 µm
/// a four times larger share of the run over a time constant.
const SLOW: Spec = Spec {
    radius_mm: 5.0,
    feed_mm_per_min: 250.0,
    jerk_m_per_s3: None,
};
/// The interpolator's path acceleration (m/s²): the axes' limit.
const ACCEL_M_PER_S2: f64 = 0.5;
/// How long the command stands before the circle and after it (s): before it, long enough
/// for the rapid's lag (6 mm at most, at 0.1 m/s) to fall below a nanometre at Kv = 1
/// m/min/mm (e^(−16.7)), so that the circle is entered from rest.
const STANDING_S: [f64; 2] = [1.0, 0.5];
/// The rapid's top speed (m/s): 6000 mm/min.
const RAPID_M_PER_S: f64 = 0.1;
/// The fine record's period (s): the run is kept at it and the records are taken from it.
const FINE_S: f64 = 1e-4;
/// The reference's integration step (s).
const STEP_S: f64 = 5e-6;

/// Distance (m), speed (m/s) and acceleration (m/s²) at `t` (s) into an S-curve from rest to
/// `v`, held for `cruise_s`, back to rest, the acceleration ramping at `jerk` to at most
/// [`ACCEL_M_PER_S2`].
fn s_curve(t: f64, v: f64, jerk: f64, cruise_s: f64) -> (f64, f64, f64) {
    through_phases(&s_curve_phases(v, ACCEL_M_PER_S2, jerk, cruise_s), t)
}

/// A counter-clockwise full circle of `spec` about the program's start (the origin),
/// reached by a rapid and entered at its 45° point, where neither axis reverses.
fn program(spec: Spec) -> String {
    let a = spec.radius_mm * FRAC_1_SQRT_2;
    let feed = spec.feed_mm_per_min;
    format!(
        "G21 G90 G17 G94\nG0 X{a} Y{a}\nG3 X{a} Y{a} I{} J{} F{feed}\nM2\n",
        -a, -a
    )
}

/// Another interpolator's commands: the rapid to the circle's start straight on a trapezoid,
/// standing [`STANDING_S`], then the path along the arc on a trapezoid or an S-curve (from
/// rest at [`ACCEL_M_PER_S2`], or ramping to it at the jerk, to the feed, held, and down to
/// rest at the circle's end), standing after; position, speed and acceleration on each axis
/// in closed form at any time.
struct ArcStream {
    radius_m: f64,
    speed_m_per_s: f64,
    jerk_m_per_s3: Option<f64>,
    /// Time to reach the feed (s), and time at it (s).
    ramp_s: f64,
    cruise_s: f64,
    /// The rapid's length (m) and duration (s).
    rapid_m: f64,
    rapid_s: f64,
}

/// Distance (m), speed (m/s) and acceleration (m/s²) at `t` (s) into a trapezoid from rest to
/// `v`, held for `cruise_s`, back to rest, at `a`.
fn trapezoid(t: f64, v: f64, a: f64, cruise_s: f64) -> (f64, f64, f64) {
    let ramp_s = v / a;
    let stop_s = 2.0 * ramp_s + cruise_s;
    if t <= 0.0 {
        (0.0, 0.0, 0.0)
    } else if t < ramp_s {
        (0.5 * a * t * t, a * t, a)
    } else if t < ramp_s + cruise_s {
        (0.5 * v * ramp_s + v * (t - ramp_s), v, 0.0)
    } else {
        let r = (stop_s - t).max(0.0);
        let length_m = v * (ramp_s + cruise_s);
        let moving = r > 0.0;
        (
            length_m - 0.5 * a * r * r,
            a * r,
            if moving { -a } else { 0.0 },
        )
    }
}

impl ArcStream {
    fn new(spec: Spec) -> ArcStream {
        let (radius_m, speed_m_per_s) = (spec.radius_m(), spec.speed_m_per_s());
        // The time and the path to reach the feed from rest.
        let (ramp_s, ramp_m) = match spec.jerk_m_per_s3 {
            None => {
                let ramp_s = speed_m_per_s / ACCEL_M_PER_S2;
                (ramp_s, 0.5 * speed_m_per_s * ramp_s)
            }
            Some(jerk) => {
                let peak = ACCEL_M_PER_S2.min((speed_m_per_s * jerk).sqrt());
                let ramp_s = speed_m_per_s / peak + peak / jerk;
                (ramp_s, 0.5 * speed_m_per_s * ramp_s)
            }
        };
        let length_m = TAU * radius_m;
        let rapid_m = radius_m;
        // Triangular where the rapid's top speed is not reached in its half.
        let rapid_top = RAPID_M_PER_S.min((ACCEL_M_PER_S2 * rapid_m).sqrt());
        let rapid_cruise_s = (rapid_m - rapid_top * rapid_top / ACCEL_M_PER_S2) / rapid_top;
        ArcStream {
            radius_m,
            speed_m_per_s,
            jerk_m_per_s3: spec.jerk_m_per_s3,
            ramp_s,
            cruise_s: (length_m - 2.0 * ramp_m) / speed_m_per_s,
            rapid_m,
            rapid_s: 2.0 * rapid_top / ACCEL_M_PER_S2 + rapid_cruise_s,
        }
    }

    /// When the command sets off on the circle (s).
    fn circle_from_s(&self) -> f64 {
        self.rapid_s + STANDING_S[0]
    }

    /// The whole stream's duration (s).
    fn duration_s(&self) -> f64 {
        self.circle_from_s() + 2.0 * self.ramp_s + self.cruise_s + STANDING_S[1]
    }

    /// The rapid's top speed and cruise (s).
    fn rapid_profile(&self) -> (f64, f64) {
        let top = RAPID_M_PER_S.min((ACCEL_M_PER_S2 * self.rapid_m).sqrt());
        (top, self.rapid_s - 2.0 * top / ACCEL_M_PER_S2)
    }

    /// Path run along the arc (m), its speed (m/s) and tangential acceleration (m/s²) at `t_s`.
    fn along(&self, t_s: f64) -> (f64, f64, f64) {
        let t = t_s - self.circle_from_s();
        match self.jerk_m_per_s3 {
            None => trapezoid(t, self.speed_m_per_s, ACCEL_M_PER_S2, self.cruise_s),
            Some(jerk) => s_curve(t, self.speed_m_per_s, jerk, self.cruise_s),
        }
    }

    /// Axis `axis`'s position (m), speed (m/s) and acceleration (m/s²) at `t_s`.
    fn axis(&self, axis: usize, t_s: f64) -> (f64, f64, f64) {
        if t_s < self.rapid_s {
            // From the origin along the diagonal to the circle's 45° point.
            let (top, cruise_s) = self.rapid_profile();
            let (s, ds, dds) = trapezoid(t_s, top, ACCEL_M_PER_S2, cruise_s);
            return (s * FRAC_1_SQRT_2, ds * FRAC_1_SQRT_2, dds * FRAC_1_SQRT_2);
        }
        let (s, ds, dds) = self.along(t_s);
        let angle = std::f64::consts::FRAC_PI_4 + s / self.radius_m;
        let (sin, cos) = angle.sin_cos();
        let r = self.radius_m;
        // The position about the centre, the tangent and the inward normal on this axis.
        let (p, tangent, inward) = if axis == 0 {
            (r * cos, -sin, -cos)
        } else {
            (r * sin, cos, -sin)
        };
        let centripetal = ds * ds / r;
        (p, ds * tangent, dds * tangent + centripetal * inward)
    }
}

/// The run kept every [`FINE_S`]: the exact commands and the table's positions (m).
struct Run {
    command_m: Vec<[f64; 2]>,
    table_m: Vec<[f64; 2]>,
}

/// `machine`'s X and Y (the reference's axes) following `stream` from rest at its start.
fn run(stream: &ArcStream, machine: &MachineConfig) -> Run {
    let plants = [Plant::new(&machine.x), Plant::new(&machine.y)];
    let mut axes: Vec<Axis> = (0..2)
        .map(|a| Axis::at_rest(&plants[a], stream.axis(a, 0.0).0, None))
        .collect();
    let steps = (FINE_S / STEP_S).round() as usize;
    let h = FINE_S / steps as f64;
    let samples = (stream.duration_s() / FINE_S).floor() as usize;
    let mut out = Run {
        command_m: Vec::with_capacity(samples),
        table_m: Vec::with_capacity(samples),
    };
    for k in 0..samples {
        let t = k as f64 * FINE_S;
        out.command_m
            .push([stream.axis(0, t).0, stream.axis(1, t).0]);
        out.table_m.push([axes[0].table(), axes[1].table()]);
        for s in 0..steps {
            let ts = t + s as f64 * h;
            for (a, axis) in axes.iter_mut().enumerate() {
                axis.step(ts, h, &|tt| stream.axis(a, tt));
            }
        }
    }
    out
}

/// The record a control's trace would give of `run`: every `every`th fine sample, the
/// measured and commanded positions rounded to `count_m` (none where zero), in mm.
fn trace_csv(run: &Run, every: usize, count_m: f64) -> String {
    let counted = |v: f64| {
        if count_m > 0.0 {
            (v / count_m).round() * count_m
        } else {
            v
        }
    };
    let mut csv = String::from("t,x,y,x_cmd,y_cmd\n");
    for k in (0..run.command_m.len()).step_by(every) {
        let (p, c) = (run.table_m[k], run.command_m[k]);
        csv.push_str(&format!("{:.6}", k as f64 * FINE_S));
        for v in [p[0], p[1], c[0], c[1]] {
            csv.push_str(&format!(",{:.7}", counted(v) * 1e3));
        }
        csv.push('\n');
    }
    csv
}

/// The figures `diagnose` states of the circle in `csv` on `machine` (no cause searched:
/// the figures are the measured path's).
fn figures_of(machine: &MachineConfig, spec: Spec, csv: &str) -> CircleFigures {
    let program = program_text(&program(spec));
    let measured = parse_trace(csv, "external.csv").unwrap();
    let mut settings = DiagnoseSettings::for_machine(machine);
    settings.causes = CauseSet::NONE;
    let d = diagnose(&program, machine, &measured, &settings).unwrap();
    *d.circular
        .measured
        .circles
        .first()
        .unwrap_or_else(|| panic!("no figures: {:?}", d.circular.left_out))
}

/// The run's exact commands as the replica takes them: time (s), X and Y (m).
fn exact_rows(run: &Run) -> Vec<(f64, [f64; 2])> {
    (run.command_m.iter().enumerate())
        .map(|(k, c)| (k as f64 * FINE_S, *c))
        .collect()
}

/// The replica's start window on the run's exact commands, every fine sample.
fn replica_window(run: &Run, spec: Spec, tau_s: f64) -> EntryWindow {
    let radius_m = spec.radius_m();
    let rows = exact_rows(run);
    let on = |_: usize, c: [f64; 2]| (c[0].hypot(c[1]) - radius_m).abs() < 1e-9;
    entry_window(&rows, on, radius_m, true, [tau_s; 2]).expect("the circle runs half a turn")
}

/// The default machine without Coulomb friction: its axes alike and linear, so that on the
/// circle the table runs a circle concentric with the command's (both axes lag it by the
/// same |G(jω)|) and G is what remains of the entry and the counts' spread alone.
fn linear_machine() -> MachineConfig {
    let mut machine = MachineConfig::default_preset();
    machine.x.friction.coulomb_coefficient = 0.0;
    machine.y.friction.coulomb_coefficient = 0.0;
    machine
}

/// The decay rates of the cascade's two slowest closed-loop modes (1/s) on the rigid axis
/// `a`: a proportional position loop (Kv) around a PI speed loop (Ks, Ts) driving the axis's
/// whole mass m against its viscous friction b, whose characteristic polynomial is
/// m·Ts·s³ + (b + Ks)·Ts·s² + Ks·(1 + Ts·Kv)·s + Ks·Kv (the current loop and the springs, at
/// hundreds of Hz and more, left out); its roots by the companion matrix's eigenvalues.
fn cascade_rates_per_s(a: &AxisConfig) -> [f64; 2] {
    let (mass_kg, viscous, travel_m_per_rad) = super::circular_reference::rigid_axis(a);
    let v = a.velocity_loop.as_ref().expect("a cascade axis");
    let kv_per_s = a.position_loop.kv_m_per_min_per_mm * 1000.0 / 60.0;
    let ks = v.ks_nm_s_per_rad / travel_m_per_rad.powi(2);
    let ts_s = v.ts_ms * 1e-3;
    let poly = [
        mass_kg * ts_s,
        (viscous + ks) * ts_s,
        ks * (1.0 + ts_s * kv_per_s),
        ks * kv_per_s,
    ];
    let companion = nalgebra::Matrix3::new(
        -poly[1] / poly[0],
        -poly[2] / poly[0],
        -poly[3] / poly[0],
        1.0,
        0.0,
        0.0,
        0.0,
        1.0,
        0.0,
    );
    let mut rates: Vec<f64> = (companion.complex_eigenvalues().iter())
        .map(|r| -r.re)
        .collect();
    rates.sort_by(f64::total_cmp);
    [rates[0], rates[1]]
}

/// How far the start window worked out from a record's commands may lie from the
/// replica's on the exact stream, in time constants at the running speed (τ = 60 ms; v·τ
/// 1 mm at F1000, 0.25 mm at F250). The speed check compares the run over the last τ with
/// the run over the τ before, to 0.1 % of v·τ; counts of q put each run's ends up to q/√2 off
/// along the path, the check's three ends up to 4·q/√2 = 2.8 µm at 1 µm counts. So it may
/// pass early, once what the ramp still lacks in the older τ, a·d²/2 for d of it there
/// (j·d³/6 on the S-curve), is under 0.1 % of v·τ and 2.8 µm: d 3.9 ms (3.5 ms at F250,
/// 17 ms on the S-curve) rather than 2 ms (1 ms, 11 ms), at most 0.1 τ early, with those few
/// micrometres of the lag still to build on a transient of about v·τ (0.004 τ and 0.012 τ as
/// its logarithm). And it may pass late, for the samples
/// the counts' sum stays above the share: that does not move the window's end, the
/// transient read later having decayed by as much as the time constants counted from there
/// shrink (the circle's turning brings at most ln(n/(n − δ)) ≈ δ/n more, ωτ = 0.05 here).
/// What moves the end: the speed the time constants are counted at, its run over τ off by up
/// to 2·q/√2 = 1.4 µm (0.14 % at F1000, 0.57 % at F250: 0.012 τ over eight, 0.04 τ over
/// seven); the loops' model following the record's samples and the cubic between them rather
/// than the exact stream (off by up to a·h²/8 = 25 µm over the ramp at 50 Hz, a few percent
/// of the lag the transient is read from: 0.03 τ as its logarithm). A tenth of a time
/// constant holds them; [`set_off_run_m`] comes on top of it.
const WINDOW_MARGIN_TIME_CONSTANTS: f64 = 0.1;

/// The path the record's commands run back and forth about the circle's start before they set
/// off on it (m), which the window counts as the circle's: resampled by cubics through the
/// samples `period_s` apart, they overshoot the rapid's stop and dip back before the circle's
/// start by up to 2/27 of the step next to the standing sample (the cubic's largest lead over
/// a standing run, at two thirds of the step) — the rapid's last step a·h²/2 and the circle's
/// first, each run there and back.
fn set_off_run_m(stream: &ArcStream, period_s: f64) -> f64 {
    let rapid_last_m = 0.5 * ACCEL_M_PER_S2 * period_s * period_s;
    let (circle_first_m, _, _) = stream.along(stream.circle_from_s() + period_s);
    2.0 * 2.0 / 27.0 * (rapid_last_m + circle_first_m)
}

/// A record taken of the run: every `every`th fine sample, positions in counts of
/// `count_m` (none where zero).
#[derive(Debug, Clone, Copy)]
struct Taken {
    every: usize,
    count_m: f64,
}

/// Every how many fine samples a record at 50 Hz, 1 kHz and 10 kHz takes one.
const AT_50_HZ: usize = 200;
const AT_1_KHZ: usize = 10;
const AT_10_KHZ: usize = 1;

/// The circle, the run on it, the loops' time constant (s) and the replica's window on the
/// run's exact commands.
struct Case {
    spec: Spec,
    stream: ArcStream,
    machine: MachineConfig,
    tau_s: f64,
    run: Run,
    replica: EntryWindow,
}

impl Case {
    fn new(spec: Spec) -> Case {
        let machine = linear_machine();
        let tau_s = 60.0 / (1000.0 * machine.x.position_loop.kv_m_per_min_per_mm);
        let stream = ArcStream::new(spec);
        let run = run(&stream, &machine);
        let replica = replica_window(&run, spec, tau_s);
        assert!(
            (replica.speed_m_per_s / spec.speed_m_per_s() - 1.0).abs() < 1e-4,
            "{replica:?}"
        );
        Case {
            spec,
            stream,
            machine,
            tau_s,
            run,
            replica,
        }
    }

    /// The figures `diagnose` states of the record `taken`.
    fn figures(&self, taken: Taken) -> CircleFigures {
        let csv = trace_csv(&self.run, taken.every, taken.count_m);
        figures_of(&self.machine, self.spec, &csv)
    }

    /// Where the figures of the record `taken` disagree with the replica and the closed
    /// forms; `full` the figures of the same rate at full resolution.
    fn disagreements(&self, taken: Taken, full: Option<&CircleFigures>) -> Vec<String> {
        let f = self.figures(taken);
        let (radius_m, speed_m_per_s) = (self.spec.radius_m(), self.spec.speed_m_per_s());
        let deg = |m: f64| (m / radius_m).to_degrees();
        let margin_deg = deg(WINDOW_MARGIN_TIME_CONSTANTS * self.tau_s * speed_m_per_s);
        let wiggle_deg = deg(set_off_run_m(&self.stream, taken.every as f64 * FINE_S));
        let replica_deg = deg(self.replica.start_m);
        let mut wrong = Vec::new();
        let mut check = |ok: bool, what: String| {
            if !ok {
                wrong.push(format!("{:?} {taken:?}: {what}", self.spec));
            }
        };
        let start_deg = f.start_left_out_deg;
        check(
            start_deg >= replica_deg - margin_deg
                && start_deg <= replica_deg + margin_deg + wiggle_deg,
            format!(
                "start {start_deg:.3}° against the replica's {replica_deg:.3}° \
                 (− {margin_deg:.3}°, + {:.3}°)",
                margin_deg + wiggle_deg
            ),
        );
        let residue_m = self.residue_at_m(start_deg.to_radians() * radius_m);
        check(
            residue_m <= ENTRY_RESIDUE_M,
            format!("{:.3} µm of the entry left at the start", residue_m * 1e6),
        );
        if let Some(full) = full {
            let apart_deg = start_deg - full.start_left_out_deg;
            check(
                apart_deg.abs() <= margin_deg,
                format!("start {apart_deg:+.3}° off the full resolution's"),
            );
        }
        wrong.extend(self.end_and_band(&f, taken));
        wrong
    }

    /// Where the end window and G of the figures `f` of the record `taken` disagree with
    /// the closed forms.
    fn end_and_band(&self, f: &CircleFigures, taken: Taken) -> Vec<String> {
        let (radius_m, speed_m_per_s) = (self.spec.radius_m(), self.spec.speed_m_per_s());
        let deg = |m: f64| (m / radius_m).to_degrees();
        let mut wrong = Vec::new();
        let mut check = |ok: bool, what: String| {
            if !ok {
                wrong.push(format!("{:?} {taken:?}: {what}", self.spec));
            }
        };
        // Five time constants at the running speed, read from the counted commands: the
        // speed over a time constant within 2·q/√2 of run over v·τ, and its chords between
        // the control's cycles short of the arc by (v·h/R)²/24, 10⁻⁷ at most here.
        let speed_share = 2.0 * taken.count_m * FRAC_1_SQRT_2 / (self.tau_s * speed_m_per_s) + 1e-6;
        let five_deg = deg(ENTRY_TIME_CONSTANTS * self.tau_s * speed_m_per_s) * (1.0 - speed_share);
        // At least the command's slowing into the end: the loops' lag changes from where the
        // command's speed does.
        let slowing_m = 0.5 * speed_m_per_s * self.stream.ramp_s;
        let least_deg = five_deg.max(deg(slowing_m));
        // And no more than the longer of the five (at the speed read high by as much) and
        // the path from where the command last ran steady: its slowing into the end, the
        // time constant over which a steady speed is read before it and a control's step.
        let period_s = taken.every as f64 * FINE_S;
        let most_deg = (deg(ENTRY_TIME_CONSTANTS * self.tau_s * speed_m_per_s)
            * (1.0 + speed_share))
            .max(deg(slowing_m + speed_m_per_s * (self.tau_s + period_s)));
        check(
            f.end_left_out_deg >= least_deg && f.end_left_out_deg <= most_deg,
            format!(
                "end {:.3}° outside {least_deg:.3}°..{most_deg:.3}°",
                f.end_left_out_deg
            ),
        );
        // Each measured position lies within q/√2 of its count along the radius; the circle
        // the table runs at the steady speed is the command's, scaled: the band is the entry's
        // residue and the counts' spread.
        let g_um = (self.residue_bound_m() + std::f64::consts::SQRT_2 * taken.count_m) * 1e6;
        check(
            f.g_um <= g_um,
            format!("G {:.3} µm above {g_um:.3}", f.g_um),
        );
        wrong
    }

    /// [`Case::disagreements`] of records at `every`, at full resolution and in each of
    /// `counts_m`.
    fn at_rate(&self, every: usize, counts_m: &[f64]) -> Vec<String> {
        let full = Taken {
            every,
            count_m: 0.0,
        };
        let f = self.figures(full);
        let mut wrong = self.disagreements(full, None);
        for &count_m in counts_m {
            wrong.extend(self.disagreements(Taken { every, count_m }, Some(&f)));
        }
        wrong
    }

    /// What may remain of the entry in the table's radius where the window starts (m): the
    /// replica's [`ENTRY_RESIDUE_M`] of a first-order loop at Kv, the cascade's slowest mode
    /// decaying at p₁ a little slower (n of the window's time constants leave e^(n·(Kv/p₁ − 1))
    /// more), and its share of the transient other than a first-order loop's by about p₁/p₂,
    /// p₂ its next mode's rate; the faster modes are gone (e^(−n·p₂/Kv)).
    fn residue_bound_m(&self) -> f64 {
        let [p1, p2] = cascade_rates_per_s(&self.machine.x);
        let kv_per_s = 1.0 / self.tau_s;
        let n = self.replica.time_constants;
        ENTRY_RESIDUE_M * (n * (kv_per_s / p1 - 1.0)).exp() * (1.0 + p1 / p2)
    }

    /// What remains of the entry transient in the radius in the replica's model on the exact
    /// commands (m) where the command has run `at_m` along the circle.
    fn residue_at_m(&self, at_m: f64) -> f64 {
        let radius_m = self.spec.radius_m();
        let rows = exact_rows(&self.run);
        let on = |_: usize, c: [f64; 2]| (c[0].hypot(c[1]) - radius_m).abs() < 1e-9;
        let circle = (radius_m, true, self.replica.speed_m_per_s);
        residue_at_m(&rows, on, circle, [self.tau_s; 2], at_m)
    }
}

/// Records at 50 Hz, exact and (at F1000) in counts of 0.1 µm, and at 1 kHz or 10 kHz,
/// exact and in counts of 1 µm, of circles entered on a trapezoid and (at F1000) on an
/// S-curve: the start window `diagnose` works out from each record's commands is the
/// replica's on the exact stream to a tenth of a time constant (and the commands' set-off
/// wiggle), and leaves at most 0.1 µm of the entry; the end is five time constants at the
/// running speed (the commands' slowing into the end is shorter); G no wider than the
/// entry's residue and the counts' spread. The 50 Hz records in counts of the others are
/// below.
#[test]
fn the_start_window_on_another_interpolators_commands() {
    let fast = Case::new(FAST);
    let slow = Case::new(SLOW);
    let mut wrong = fast.at_rate(AT_50_HZ, &[0.1e-6]);
    wrong.extend(fast.at_rate(AT_1_KHZ, &[1e-6]));
    wrong.extend(slow.at_rate(AT_50_HZ, &[]));
    let s_curve = Case::new(FAST_S_CURVE);
    wrong.extend(s_curve.at_rate(AT_50_HZ, &[0.1e-6]));
    wrong.extend(s_curve.at_rate(AT_1_KHZ, &[1e-6]));
    wrong.extend(slow.at_rate(AT_10_KHZ, &[1e-6]));
    assert!(
        wrong.is_empty(),
        "{:?}\n{:?}\n{wrong:#?}",
        fast.replica,
        slow.replica
    );
}

/// 50 Hz records in counts (1 µm at F1000 on a trapezoid and on an S-curve, 0.1 µm and 1 µm
/// at F250): the command standing before the circle, resampled between its samples, moves by
/// the floating point's last bits alike over two time constants, and a speed check that took
/// any speed above zero for the circle's decided the window there, a second before the
/// command set off on the circle (0.03° left out at F1000, G 25.9 µm of entry transient). A
/// standing command has no steady speed: the windows as on the other records.
#[test]
fn the_start_window_on_50_hz_commands_in_counts() {
    let mut wrong = Case::new(FAST).at_rate(AT_50_HZ, &[1e-6]);
    wrong.extend(Case::new(SLOW).at_rate(AT_50_HZ, &[0.1e-6, 1e-6]));
    wrong.extend(Case::new(FAST_S_CURVE).at_rate(AT_50_HZ, &[1e-6]));
    assert!(wrong.is_empty(), "{wrong:#?}");
}

/// `csv` from the first row at or after `from_s` (s) on: a record begun later.
fn cut_csv(csv: &str, from_s: f64) -> String {
    let mut lines = csv.lines();
    let mut cut: String = lines.next().map(|h| format!("{h}\n")).unwrap_or_default();
    for line in lines {
        let t_s: f64 = line.split(',').next().and_then(|t| t.parse().ok()).unwrap();
        if t_s >= from_s {
            cut.push_str(line);
            cut.push('\n');
        }
    }
    cut
}

/// Records begun while the command ran round the circle at its feed, a tenth, four tenths
/// and seven tenths of the way round (at 50 Hz in counts of 0.1 µm, at 1 kHz in counts of
/// 1 µm; the comparison runs the model in before each one's first command), and the whole
/// records beside them: the end is left out as on a whole record — at least five time
/// constants at the running speed, at least the command's slowing into the end where that
/// is longer (6.8 mm at a jerk of 0.1 m/s³) — where the path counted from the record's
/// first sample left out the arc the record missed less, and the table's slowing into the
/// end counted as the circle's form (its radial lag v²/(2·Kv²·R): 25 µm at F1000 on R20,
/// 6.25 µm at F250 on R5); G no wider than the entry's residue and the counts' spread; the
/// start at least five time constants past where the record began, at most a quarter turn.
#[test]
fn a_record_begun_mid_circle_leaves_the_same_end_out() {
    let mut wrong = Vec::new();
    for spec in [FAST, FAST_GENTLE, SLOW] {
        let case = Case::new(spec);
        for (every, count_m) in [(AT_50_HZ, 0.1e-6), (AT_1_KHZ, 1e-6)] {
            wrong.extend(case.begun_later(Taken { every, count_m }));
        }
    }
    assert!(wrong.is_empty(), "{wrong:#?}");
}

impl Case {
    /// Where the figures of the record `taken`, whole and begun a tenth, four tenths and
    /// seven tenths of the way round at the feed, disagree with the closed forms.
    fn begun_later(&self, taken: Taken) -> Vec<String> {
        let csv = trace_csv(&self.run, taken.every, taken.count_m);
        let whole = figures_of(&self.machine, self.spec, &csv);
        let mut wrong = self.end_and_band(&whole, taken);
        let deg = |m: f64| (m / self.spec.radius_m()).to_degrees();
        let speed_m_per_s = self.spec.speed_m_per_s();
        let five_deg = deg(ENTRY_TIME_CONSTANTS * self.tau_s * speed_m_per_s);
        let cruise_from_s = self.stream.circle_from_s() + self.stream.ramp_s;
        for share in [0.1, 0.4, 0.7] {
            let from_s = cruise_from_s + share * self.stream.cruise_s;
            let f = figures_of(&self.machine, self.spec, &cut_csv(&csv, from_s));
            let begun = format!("begun {share} of the way round");
            let mut found = self.end_and_band(&f, taken);
            // The first row at or after `from_s`: where the record's commands begin.
            let first_s =
                (from_s / (taken.every as f64 * FINE_S)).ceil() * taken.every as f64 * FINE_S;
            let begun_deg = deg(self.stream.along(first_s).0);
            let start_deg = f.start_left_out_deg;
            if !(start_deg >= begun_deg + 0.99 * five_deg && start_deg <= begun_deg + 90.0) {
                found.push(format!("start {start_deg:.3}° begun at {begun_deg:.3}°"));
            }
            wrong.extend(found.into_iter().map(|w| format!("{begun}: {w}")));
        }
        wrong
    }
}
