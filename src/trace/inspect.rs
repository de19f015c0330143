//! What a measured trace holds, before anything is fitted to it: sampling and its jitter,
//! duration, the stretches where the axes move, each axis's quantisation step, and — when
//! the commands were recorded — the largest following error. The first thing to look at on
//! a record from an unfamiliar machine.

use crate::numeric::units::um_from_m;
use crate::trace::format::{Mapped, Signal};
use crate::trace::measured::{MeasuredTrace, quantum};

/// An axis moves where its position changes by more than this over the window (m).
const MOVING_M: f64 = 1e-6;
/// A following error no machine tool's axis reaches (m): a servo trips on following error
/// long before its axis lags by a tenth of a metre; a figure beyond it says the columns' units
/// were read wrong.
const IMPLAUSIBLE_FOLLOWING_M: f64 = 0.1;
/// The window for deciding motion (s).
const MOVING_WINDOW_S: f64 = 0.01;

/// The figures of a trace.
#[derive(Debug, Clone, PartialEq)]
pub struct TraceSummary {
    /// Samples.
    pub samples: usize,
    /// Duration (s).
    pub duration_s: f64,
    /// Sampling rate (Hz).
    pub rate_hz: f64,
    /// Clock jitter: RMS deviation of the steps from the median, as a share of it.
    pub jitter_share: f64,
    /// Moving stretches: (start s, end s) on the trace's clock.
    pub moving: Vec<(f64, f64)>,
    /// Quantisation step of X and Y (m), where the positions sit on a grid.
    pub quantum_m: [Option<f64>; 2],
    /// The file's print precision of X and Y where their grid is that step and no coarser:
    /// the decimals printed and their unit's label.
    pub printed: [Option<(i32, &'static str)>; 2],
    /// Largest following error of X and Y (m) and when (s), with recorded commands.
    pub max_following: Option<[(f64, f64); 2]>,
}

/// Summarises a trace.
pub fn summarise(trace: &MeasuredTrace) -> TraceSummary {
    let n = trace.len();
    let max_following = trace.commands.as_ref().map(|[xc, yc]| {
        [(xc, &trace.x_m), (yc, &trace.y_m)].map(|(cmd, meas)| {
            (0..n)
                .map(|k| (cmd[k] - meas[k], trace.time_s(k)))
                .max_by(|a, b| a.0.abs().total_cmp(&b.0.abs()))
                .unwrap_or((0.0, 0.0))
        })
    });
    let column = |signal| trace.layout.mapped.iter().find(|m| m.signal == signal);
    let grids = [
        grid(&trace.x_m, column(Signal::X)),
        grid(&trace.y_m, column(Signal::Y)),
    ];
    TraceSummary {
        samples: n,
        duration_s: trace.dt_s * (n.saturating_sub(1)) as f64,
        rate_hz: 1.0 / trace.dt_s,
        jitter_share: trace.steps.jitter_rms_s / trace.steps.median_s,
        moving: moving_stretches(trace),
        quantum_m: grids.map(|g| g.0),
        printed: grids.map(|g| g.1),
        max_following,
    }
}

/// An axis's grid (m) and, where that grid is the step of the last digit the file prints,
/// its decimals and unit: the file's print precision, not a count of the measuring system
/// (whose count, if any, is no coarser). Where the file prints the positions as text, the
/// grid is the greatest common divisor of the changes counted in that last digit, whole
/// numbers (exact, where a divisor of floating-point differences drifts over thousands of
/// samples); else, or where the changes are not whole numbers of it (a resampled record),
/// as [`quantum`] finds it. A column in counts is never its print precision: its grid is
/// the count.
fn grid(x: &[f64], column: Option<&Mapped>) -> (Option<f64>, Option<(i32, &'static str)>) {
    let Some((column, step)) = column.and_then(|c| Some((c, c.print_step?))) else {
        return (quantum(x), None);
    };
    let step_m = step * column.unit.to_si;
    let digits: Option<Vec<u64>> = x
        .windows(2)
        .map(|w| (w[1] - w[0]).abs() / step_m)
        .map(|d| ((d - d.round()).abs() < 1e-3).then_some(d.round() as u64))
        .collect();
    let Some(digits) = digits else {
        return (quantum(x), None);
    };
    let gcd = |mut a: u64, mut b: u64| {
        while b > 0 {
            (a, b) = (b, a % b);
        }
        a
    };
    match digits.into_iter().fold(0, gcd) {
        0 => (None, None),
        g => {
            let printed = g == 1 && !column.unit.is_count();
            let decimals = -step.log10().round() as i32;
            (
                Some(g as f64 * step_m),
                printed.then_some((decimals, column.unit.label)),
            )
        }
    }
}

/// Stretches where either axis's mean position over 10 ms moves more than 1 µm from the
/// previous 10 ms' (means, so that measurement noise does not count as motion), merged
/// across pauses shorter than 50 ms, and at least 50 ms long.
fn moving_stretches(trace: &MeasuredTrace) -> Vec<(f64, f64)> {
    const SHORTEST_S: f64 = 0.05;
    let n = trace.len();
    let w = ((MOVING_WINDOW_S / trace.dt_s).round() as usize).max(1);
    if n < 2 * w + 1 {
        return Vec::new();
    }
    let prefix = |x: &[f64]| {
        let mut p = Vec::with_capacity(x.len() + 1);
        p.push(0.0);
        for v in x {
            p.push(p[p.len() - 1] + v);
        }
        p
    };
    let (px, py) = (prefix(&trace.x_m), prefix(&trace.y_m));
    let mean = |p: &[f64], a: usize| (p[a + w] - p[a]) / w as f64;
    let moving = |k: usize| {
        (mean(&px, k + w) - mean(&px, k)).abs() > MOVING_M
            || (mean(&py, k + w) - mean(&py, k)).abs() > MOVING_M
    };
    let mut raw: Vec<(f64, f64)> = Vec::new();
    let mut start = None;
    for k in 0..=n - 2 * w {
        match (moving(k), start) {
            (true, None) => start = Some(k + w),
            (false, Some(s)) => {
                raw.push((trace.time_s(s), trace.time_s(k + w)));
                start = None;
            }
            _ => {}
        }
    }
    if let Some(s) = start {
        raw.push((trace.time_s(s), trace.time_s(n - 1)));
    }
    let mut merged: Vec<(f64, f64)> = Vec::new();
    for (a, b) in raw {
        match merged.last_mut() {
            Some(last) if a - last.1 < SHORTEST_S => last.1 = b,
            _ => merged.push((a, b)),
        }
    }
    merged.retain(|(a, b)| b - a >= SHORTEST_S);
    merged
}

impl TraceSummary {
    /// The summary as text, one figure a line.
    pub fn text(&self) -> String {
        let mut s = format!(
            "samples   {} over {:.3} s at {:.1} Hz (clock jitter {:.2} % of the step)\n",
            self.samples,
            self.duration_s,
            self.rate_hz,
            100.0 * self.jitter_share
        );
        let moving_s: f64 = self.moving.iter().map(|(a, b)| b - a).sum();
        s.push_str(&format!(
            "moving    {} stretches, {:.3} s in all",
            self.moving.len(),
            moving_s
        ));
        if let Some((a, b)) = self.moving.first() {
            s.push_str(&format!(" (first {a:.3}–{b:.3} s)"));
        }
        s.push('\n');
        for ((axis, q), printed) in ["X", "Y"].iter().zip(self.quantum_m).zip(self.printed) {
            match (q, printed) {
                (Some(q), Some((decimals, unit))) => {
                    s.push_str(&format!(
                        "{axis} grid    positions on a {:.4} µm grid: the file's print precision \
                         ({}); no coarser count shows\n",
                        um_from_m(q),
                        print_precision(decimals, unit)
                    ));
                }
                (Some(q), None) => s.push_str(&format!(
                    "{axis} grid    positions on a {:.4} µm grid\n",
                    um_from_m(q)
                )),
                (None, _) => s.push_str(&format!("{axis} grid    no quantisation visible\n")),
            }
        }
        match &self.max_following {
            Some(f) => {
                for (axis, (e, t)) in ["X", "Y"].iter().zip(f) {
                    s.push_str(&format!(
                        "{axis} follow  largest following error {:.2} µm at {t:.3} s\n",
                        um_from_m(*e)
                    ));
                    if e.abs() > IMPLAUSIBLE_FOLLOWING_M {
                        s.push_str(&format!(
                            "          no machine's axis lags its command by {:.3} m: are \
                             the columns' units right (counts read as mm, mm as µm)? \
                             --columns sets them\n",
                            e.abs()
                        ));
                    }
                }
            }
            None => s.push_str("commands  not recorded: no following error\n"),
        }
        s
    }
}

/// A print precision in words: the decimals a file prints (`3 decimals of mm`), or, where
/// its last digit printed is a unit or above (a field written with an exponent, `15e2`, or
/// without decimals), the step of that digit (`a step of 100 mm`): a count of decimals is
/// never negative.
fn print_precision(decimals: i32, unit: &str) -> String {
    match decimals {
        1 => format!("1 decimal of {unit}"),
        d if d > 1 => format!("{d} decimals of {unit}"),
        // Up to a million the step reads as a whole number; beyond, as a power of ten.
        d if d >= -6 => format!("a step of {} {unit}", 10u64.pow(d.unsigned_abs())),
        d => format!("a step of 1e{} {unit}", d.unsigned_abs()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::trace::measured::parse_trace;

    /// 1 kHz, X moving 50 mm/min for 0.5 s on 0.1 µm counts, lagging its command by 5 µm.
    #[test]
    fn figures_of_a_quantised_record() {
        let mut text = String::from("t_s,x_um,y_mm,x_cmd_um,y_cmd_mm\n");
        for k in 0..1000 {
            let t = k as f64 * 1e-3;
            let cmd_um = if t < 0.25 {
                0.0
            } else {
                (t - 0.25).min(0.5) * 50.0 / 60.0 * 1e3
            };
            let meas_um = (((cmd_um - 5.0).max(0.0)) * 10.0).round() / 10.0;
            text.push_str(&format!("{t},{meas_um},0,{cmd_um},0\n"));
        }
        let s = summarise(&parse_trace(&text, "q.csv").unwrap());
        assert_eq!(s.samples, 1000);
        assert!((s.rate_hz - 1000.0).abs() < 1e-6);
        assert_eq!(s.moving.len(), 1);
        let (a, b) = s.moving[0];
        assert!(
            (a - 0.25).abs() < 0.02 && (b - 0.75).abs() < 0.02,
            "{a} {b}"
        );
        let q = s.quantum_m[0].unwrap();
        assert!((q - 1e-7).abs() < 1e-12, "{q}");
        assert_eq!(s.quantum_m[1], None);
        let (e, _) = s.max_following.unwrap()[0];
        assert!((e - 5e-6).abs() < 0.06e-6, "{e}");
        assert!(!s.text().contains("no machine's axis lags"));
        // The position's column read as mm where it holds µm (its command's still µm): the
        // position runs to 416.7 µm × 1000 = 0.42 m, and the lag with it, which no axis lags.
        let as_mm = text.replacen("x_um", "x_mm", 1);
        let s = summarise(&parse_trace(&as_mm, "q.csv").unwrap());
        assert!(
            s.text()
                .contains("no machine's axis lags its command by 0.4"),
            "{}",
            s.text()
        );
    }

    /// A smooth motion printed to 7 decimals of mm sits on the 0.1 nm grid of its last digit:
    /// that is the file's print precision, said so; the same motion counted in 0.1 µm and
    /// printed to 7 decimals sits on the count's grid, a thousand times the last digit's.
    #[test]
    fn a_grid_of_the_last_printed_digit_is_the_print_precision() {
        let record = |count_mm: Option<f64>| {
            let mut text = String::from("t_s,x_mm,y_mm\n");
            for k in 0..2000 {
                let t = k as f64 * 1e-3;
                let x = 10.0 * (2.0 * t).sin();
                let x = count_mm.map_or(x, |q| (x / q).round() * q);
                text.push_str(&format!("{t:.3},{x:.7},{:.7}\n", x / 3.0));
            }
            summarise(&parse_trace(&text, "p.csv").unwrap())
        };
        let printed = record(None);
        let q = printed.quantum_m[0].unwrap();
        assert!((q - 1e-10).abs() < 1e-15, "{q}");
        assert_eq!(printed.printed[0], Some((7, "mm")));
        assert!(
            printed
                .text()
                .contains("the file's print precision (7 decimals of mm)")
        );
        let counted = record(Some(1e-4));
        let q = counted.quantum_m[0].unwrap();
        assert!((q - 1e-7).abs() < 1e-12, "{q}");
        assert_eq!(counted.printed[0], None);
        assert!(
            !counted
                .text()
                .contains("X grid    positions on a 0.1000 µm grid:")
        );
    }

    /// Decimals are counted only below the unit: a last digit of 1, 100 or 10^9 mm is a step.
    #[test]
    fn a_print_precision_of_a_unit_or_above_is_a_step() {
        assert_eq!(print_precision(7, "mm"), "7 decimals of mm");
        assert_eq!(print_precision(1, "µm"), "1 decimal of µm");
        assert_eq!(print_precision(0, "mm"), "a step of 1 mm");
        assert_eq!(print_precision(-2, "mm"), "a step of 100 mm");
        assert_eq!(print_precision(-9, "m"), "a step of 1e9 m");
        assert_eq!(print_precision(i32::MIN, "m"), "a step of 1e2147483648 m");
    }

    /// Positions written with an exponent and one digit of mantissa (`3e2` mm) change in
    /// whole hundreds of mm: the grid is 100 mm = 1e8 µm, and the text says a step of 100 mm,
    /// not "-2 decimals".
    #[test]
    fn positions_printed_with_an_exponent_read_as_a_step() {
        let mut text = String::from("t_s,x_mm,y_mm\n");
        for k in 0..200 {
            let t = k as f64 * 1e-3;
            // 1e2 … 20e2 mm, each held for ten samples, Y a step behind.
            let (x, y) = (1 + k / 10, 1 + k / 12);
            text.push_str(&format!("{t:.3},{x}e2,{y}e2\n"));
        }
        let s = summarise(&parse_trace(&text, "e.csv").unwrap());
        let q = s.quantum_m[0].unwrap();
        assert!((q - 0.1).abs() < 1e-12, "{q}");
        assert_eq!(s.printed[0], Some((-2, "mm")));
        let out = s.text();
        assert!(
            out.contains("X grid    positions on a 100000.0000 µm grid: the file's print precision (a step of 100 mm)"),
            "{out}"
        );
        assert!(!out.contains("-2 decimals"), "{out}");
    }
}
