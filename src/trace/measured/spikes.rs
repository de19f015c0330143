//! Single samples a logger got wrong: a measured position off both its neighbours by more
//! than any machine's axis could move away in one sample and come back (two such samples
//! side by side are not one misread between neighbours, and are left). One such sample of
//! 5 mm in a record of µm hid every finding of a comparison (its residual was all that
//! sample); it is bridged by its neighbours' mean and said, never left silently.

use super::MeasuredTrace;

/// An acceleration no machine tool's axis reaches (m/s²; ten times gravity): a sample that
/// leaves both its neighbours by more than this over one step and back is not the axis.
const BEYOND_ANY_AXIS_M_PER_S2: f64 = 100.0;

/// How many standard deviations of the record's own second differences, or counts of its
/// quantisation where that is more, a spike must stand out by besides: an encoder's count
/// flickering on a still axis (0, 1, 0: a second difference of two counts) is not one.
const NOISE_MARGIN: f64 = 10.0;

/// One sample bridged.
#[derive(Debug, Clone, PartialEq)]
pub struct Spike {
    /// The measured signal: `x`, `y` or `z`.
    pub signal: &'static str,
    /// Its time on the record's clock (s).
    pub t_s: f64,
    /// How far it lay off its neighbours' mean (m).
    pub off_m: f64,
}

impl MeasuredTrace {
    /// Replaces each measured sample that stands alone off both its neighbours beyond any
    /// axis's acceleration (and the record's noise) by their mean; the samples replaced.
    pub fn bridge_spikes(&mut self) -> Vec<Spike> {
        let (t0, dt) = (self.t0_s, self.dt_s);
        let mut spikes = Vec::new();
        let signals = [("x", Some(&mut self.x_m)), ("y", Some(&mut self.y_m))]
            .into_iter()
            .chain(std::iter::once(("z", self.z_m.as_mut())));
        for (signal, values) in signals {
            let Some(values) = values else { continue };
            // Each mean from the values as read (the spikes found are never side by side).
            let means: Vec<(usize, f64)> = isolated_spikes(values, dt)
                .into_iter()
                .map(|k| (k, 0.5 * (values[k - 1] + values[k + 1])))
                .collect();
            for (k, mean) in means {
                spikes.push(Spike {
                    signal,
                    t_s: t0 + k as f64 * dt,
                    off_m: values[k] - mean,
                });
                values[k] = mean;
            }
        }
        spikes
    }
}

/// The samples of `x` (sampled every `dt_s`) that leave both neighbours and come back
/// further than [`BEYOND_ANY_AXIS_M_PER_S2`] allows over a step, beyond the record's noise,
/// while the neighbours themselves lie closer together than that sample lies off them.
fn isolated_spikes(x: &[f64], dt_s: f64) -> Vec<usize> {
    if x.len() < 3 {
        return Vec::new();
    }
    let second: Vec<f64> = x.windows(3).map(|w| w[0] - 2.0 * w[1] + w[2]).collect();
    let mut magnitudes: Vec<f64> = second.iter().map(|d| d.abs()).collect();
    let mid = magnitudes.len() / 2;
    let median = *magnitudes.select_nth_unstable_by(mid, f64::total_cmp).1;
    // On a record that mostly stands still the median is 0: its count is the floor.
    let count = x
        .windows(2)
        .map(|w| (w[1] - w[0]).abs())
        .filter(|d| *d > 0.0)
        .fold(f64::INFINITY, f64::min);
    let spread = (1.4826 * median).max(if count.is_finite() { count } else { 0.0 });
    let bound = BEYOND_ANY_AXIS_M_PER_S2 * dt_s * dt_s + NOISE_MARGIN * spread;
    let stands_out = |k: usize| {
        let d2 = second[k - 1];
        d2.abs() > bound && (x[k + 1] - x[k - 1]).abs() < 0.5 * d2.abs()
    };
    // Not beside another: two samples off together are not one misread between neighbours.
    (1..x.len() - 1)
        .filter(|&k| stands_out(k))
        .filter(|&k| {
            let before = k >= 2 && stands_out(k - 1);
            let after = k + 2 < x.len() && stands_out(k + 1);
            !before && !after
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A ramp at 100 mm/s sampled at 500 Hz with 0.3 µm of jitter, then accelerating at
    /// 50 m/s² (a second difference of a·dt² = 0.2 mm, half the 100 m/s² bound): no spike;
    /// one sample 5 mm off is found, and only that one (its neighbours' second differences
    /// are as large, but they lie on the axis's path).
    #[test]
    fn a_lone_sample_off_by_millimetres_is_found_and_motion_is_not() {
        let dt = 2e-3;
        let mut x: Vec<f64> = (0..400)
            .map(|k| {
                let t = k as f64 * dt;
                let jitter = 0.3e-6 * ((k * 7919) % 13) as f64 / 13.0;
                let accel = if t > 0.5 {
                    0.5 * 50.0 * (t - 0.5).powi(2)
                } else {
                    0.0
                };
                0.1 * t + accel + jitter
            })
            .collect();
        assert!(isolated_spikes(&x, dt).is_empty());
        x[123] += 5e-3;
        assert_eq!(isolated_spikes(&x, dt), vec![123]);
        // Two side by side are left.
        x[124] -= 5e-3;
        assert!(isolated_spikes(&x, dt).is_empty());
    }

    /// A still axis at 10 kHz read in 1 µm counts, flickering by a count now and then (its
    /// second differences 2 µm, beyond the 1 µm that 100 m/s² gives over 0.1 ms): no spike.
    #[test]
    fn a_count_flickering_on_a_still_axis_is_no_spike() {
        let x: Vec<f64> = (0..20_000)
            .map(|k| if k % 97 == 0 { 1e-6 } else { 0.0 })
            .collect();
        assert!(isolated_spikes(&x, 1e-4).is_empty());
        let mut glitched = x.clone();
        glitched[5000] = 3e-3;
        assert_eq!(isolated_spikes(&glitched, 1e-4), vec![5000]);
    }

    /// Bridged by the neighbours' mean, and said with its time and size.
    #[test]
    fn a_spike_is_bridged_and_said() {
        let mut text = String::from("t_s,x_mm,y_mm\n");
        for k in 0..200 {
            let x_mm = 0.2 * k as f64 + if k == 103 { 5.0 } else { 0.0 };
            text.push_str(&format!("{},{x_mm},0\n", 0.002 * k as f64));
        }
        let mut trace = crate::trace::measured::parse_trace(&text, "t.csv").unwrap();
        let spikes = trace.bridge_spikes();
        assert_eq!(spikes.len(), 1, "{spikes:?}");
        let s = &spikes[0];
        assert_eq!(s.signal, "x");
        assert!(
            (s.t_s - 0.206).abs() < 1e-9 && (s.off_m - 5e-3).abs() < 1e-9,
            "{s:?}"
        );
        assert!((trace.x_m[103] - 20.6e-3).abs() < 1e-12);
    }
}
