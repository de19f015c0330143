//! Signals a control sampled each at its own rate (a drive's 125 µs, a position loop's
//! 2 ms, an interpolator's 4 ms), as SINUMERIK and TwinCAT traces hold them, put on one
//! clock: that of the most densely sampled signal, the others interpolated linearly between
//! their own samples — never held, which would shift a slower signal by up to its period.

/// One signal as sampled: its name and its own (time, value, line) samples.
pub struct Sampled {
    /// The column name it becomes.
    pub name: String,
    /// Its instants, increasing.
    pub t: Vec<f64>,
    /// Its values.
    pub v: Vec<f64>,
    /// The file line of each sample.
    pub line: Vec<u64>,
}

/// The signals on the clock of the most densely sampled one, within the span all cover,
/// the others interpolated linearly between their own samples; the clock becomes the first
/// column, `time_name`, its values times `to_seconds`. Each row's line is the line of the
/// clock signal's sample. `signals` must each hold a sample.
pub(crate) fn on_one_clock(
    signals: &[Sampled],
    time_name: &str,
    to_seconds: f64,
) -> (Vec<(String, Vec<f64>)>, Vec<u64>) {
    let Some(base) = signals
        .iter()
        .enumerate()
        .max_by_key(|(i, s)| (s.t.len(), std::cmp::Reverse(*i)))
        .map(|(_, s)| s)
    else {
        return (vec![(time_name.to_string(), Vec::new())], Vec::new());
    };
    if signals.iter().any(|s| s.t.is_empty()) {
        return (vec![(time_name.to_string(), Vec::new())], Vec::new());
    }
    let start = signals.iter().map(|s| s.t[0]).fold(f64::MIN, f64::max);
    let end = signals
        .iter()
        .map(|s| s.t[s.t.len() - 1])
        .fold(f64::MAX, f64::min);
    let keep: Vec<usize> = (0..base.t.len())
        .filter(|&k| base.t[k] >= start && base.t[k] <= end)
        .collect();
    let clock: Vec<f64> = keep.iter().map(|&k| base.t[k]).collect();
    let rows = keep.iter().map(|&k| base.line[k]).collect();
    let seconds = clock.iter().map(|t| t * to_seconds).collect();
    let mut columns = vec![(time_name.to_string(), seconds)];
    for s in signals {
        columns.push((s.name.clone(), interpolated(&s.t, &s.v, &clock)));
    }
    (columns, rows)
}

/// Linear interpolation of (t, v) at increasing instants inside [t₀, tₙ].
fn interpolated(t: &[f64], v: &[f64], at: &[f64]) -> Vec<f64> {
    let mut j = 0;
    at.iter()
        .map(|&x| {
            while j + 1 < t.len() && t[j + 1] <= x {
                j += 1;
            }
            if j + 1 >= t.len() || t[j] == x {
                return v[j];
            }
            let f = (x - t[j]) / (t[j + 1] - t[j]);
            v[j] + (v[j + 1] - v[j]) * f
        })
        .collect()
}
