//! A record of a program run by the reference: its axes stepped in lockstep, read with
//! noise and counts at a sampling period, written as a control's trace.

use contourcheck::gcode::Program;
use contourcheck::machine::AxisConfig;
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};

use super::axis::Axis;
use super::interpolator::Trapezoids;
use super::plant::{Cycle, Plant, Timed};

/// How a reference record is taken.
#[derive(Clone, Copy, Debug)]
pub struct Recording {
    /// Sampling period (s).
    pub sample_s: f64,
    /// Measurement noise, standard deviation (m).
    pub noise_m: f64,
    /// Encoder count (m), 0 for none.
    pub count_m: f64,
    /// Integration step (s).
    pub step_s: f64,
    /// Seed of the noise.
    pub seed: u64,
    /// The interpolator's path acceleration (m/s²).
    pub accel: f64,
    /// The interpolator's path jerk (m/s³), where it limits one: each block's acceleration
    /// then ramps at it (an S-curve); `None` steps it (a trapezoid).
    pub jerk: Option<f64>,
    /// A tight spot on X: (from m, to m, factor on Coulomb friction).
    pub tight_spot_x: Option<(f64, f64, f64)>,
    /// A cyclic error of X's encoder (amplitude in m), which the control reads too.
    pub encoder_error_x: Cycle,
    /// A force on X's table that repeats with time, not with its position.
    pub timed_force_x: Timed,
    /// The position is read where the control reads it (the motor's encoder on a
    /// semi-closed loop), else at the table.
    pub at_feedback: bool,
    /// Where the machine stands before the program (m): the run starts there and its first
    /// move comes from there ([`Trapezoids::from_home`]); `None` for the program's start.
    pub home_m: Option<[f64; 2]>,
    /// The stretch of the run the record keeps (s from the run's start, from and to): a
    /// logger started late or stopped early, its clock starting at zero where it starts.
    /// `None` keeps the whole run.
    pub keep_s: Option<(f64, f64)>,
    /// The force X's loops push with at the start, friction holding it (N, towards +).
    pub held_x_n: f64,
}

impl Default for Recording {
    fn default() -> Self {
        Recording {
            sample_s: 1e-3,
            noise_m: 0.3e-6,
            count_m: 0.0,
            step_s: 5e-6,
            seed: 1,
            accel: 0.5,
            jerk: None,
            tight_spot_x: None,
            encoder_error_x: Cycle::default(),
            timed_force_x: Timed::default(),
            at_feedback: false,
            home_m: None,
            keep_s: None,
            held_x_n: 0.0,
        }
    }
}

/// A record of `program` run by the reference on axes `x` and `y`: a CSV with the time (s),
/// the measured positions (at the table, or where the control reads them) and the
/// commanded positions (mm), as a control's trace would give them.
pub fn record(program: &Program, x: &AxisConfig, y: &AxisConfig, rec: &Recording) -> String {
    record_axes(program, &[x, y], rec)
}

/// [`record`] with Z run too, on `z`: its measured and commanded columns after X's and Y's.
pub fn record_xyz(program: &Program, [x, y, z]: [&AxisConfig; 3], rec: &Recording) -> String {
    record_axes(program, &[x, y, z], rec)
}

/// A record of the first `configs.len()` axes (X, Y and perhaps Z).
fn record_axes(program: &Program, configs: &[&AxisConfig], rec: &Recording) -> String {
    let interpolator = match rec.jerk {
        Some(jerk) => Trapezoids::s_curves(program, rec.accel, jerk, 0.3, 0.5),
        None => Trapezoids::from_home(program, rec.accel, 0.3, 0.5, rec.home_m),
    };
    let mut plants: Vec<Plant> = configs.iter().map(|c| Plant::new(c)).collect();
    plants[0].encoder_error = rec.encoder_error_x;
    plants[0].timed_force = rec.timed_force_x;
    plants[0] = plants[0].holding(rec.held_x_n);
    let start = interpolator.position(0.0);
    let mut axes: Vec<Axis> = plants
        .iter()
        .enumerate()
        .map(|(a, p)| Axis::at_rest(p, start[a], rec.tight_spot_x.filter(|_| a == 0)))
        .collect();
    let mut rng = rand::rngs::StdRng::seed_from_u64(rec.seed);
    let noise = Normal::new(0.0, rec.noise_m.max(1e-15)).unwrap();
    let steps_per_sample = (rec.sample_s / rec.step_s).round() as usize;
    let h = rec.sample_s / steps_per_sample as f64;
    let samples = (interpolator.duration_s / rec.sample_s).floor() as usize;
    let mut csv = String::from(if axes.len() == 3 {
        "t,x,y,z,x_cmd,y_cmd,z_cmd\n"
    } else {
        "t,x,y,x_cmd,y_cmd\n"
    });
    let read = |v: f64, rng: &mut rand::rngs::StdRng| {
        let m = v + noise.sample(rng);
        if rec.count_m > 0.0 {
            (m / rec.count_m).round() * rec.count_m
        } else {
            m
        }
    };
    let (keep_from, keep_to) = rec.keep_s.unwrap_or((0.0, f64::INFINITY));
    for k in 0..samples {
        let t = k as f64 * rec.sample_s;
        let cmd = interpolator.position(t);
        let kept = t >= keep_from - 1e-9 && t < keep_to - 1e-9;
        let at = |axis: &Axis| {
            if rec.at_feedback {
                axis.feedback()
            } else {
                axis.table()
            }
        };
        let measured: Vec<f64> = axes.iter().map(|a| read(at(a), &mut rng)).collect();
        if kept {
            let mut row = format!("{:.6}", t - keep_from);
            for v in measured.iter().chain(&cmd[..axes.len()]) {
                row.push_str(&format!(",{:.7}", v * 1e3));
            }
            csv.push_str(&row);
            csv.push('\n');
        } else if t >= keep_to {
            break;
        }
        for s in 0..steps_per_sample {
            let ts = t + s as f64 * h;
            for (a, axis) in axes.iter_mut().enumerate() {
                if axis.feeds_forward() {
                    axis.step(ts, h, &|tt| interpolator.axis(a, tt));
                } else {
                    axis.step(ts, h, &|tt| (interpolator.position(tt)[a], 0.0, 0.0));
                }
            }
        }
    }
    csv
}
