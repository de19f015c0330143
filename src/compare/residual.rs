//! Residual measures: RMS over the record, in windows around events, smoothed, in stick-
//! slip chatter amplitude, and the measurement's noise floor.

use serde::Serialize;

use crate::numeric::units::um_from_m;

/// Residual figures of one axis (µm).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct AxisResidual {
    /// RMS over the record.
    pub rms_um: f64,
    /// RMS in the windows around the axis's reversals and accelerations, where local
    /// causes (backlash, friction, a resonance) live and a whole-record RMS hides them.
    pub event_rms_um: f64,
    /// RMS of the residual averaged over ±20 ms: noise and the phase of stick-slip chatter
    /// (which no model predicts) averaged out, anything slower kept.
    pub smoothed_rms_um: f64,
    /// RMS over 0.25 s windows of the mismatch in stick-slip chatter amplitude (the
    /// spread about a ±10 ms running mean): the measure for an axis in stick-slip.
    pub chatter_um: f64,
    /// Largest |residual|.
    pub peak_um: f64,
}

/// Residual figures of a model against the measurement.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ResidualStats {
    /// X.
    pub x: AxisResidual,
    /// Y.
    pub y: AxisResidual,
    /// The contour error's residual (measured path's contour error − the model's).
    pub contour: AxisResidual,
}

pub(crate) fn rms(v: &[f64]) -> f64 {
    if v.is_empty() {
        0.0
    } else {
        (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt()
    }
}

/// The noise floor of a record (m): from its residuals against the nominal model, and never
/// below the rounding of its own counts — a record of an encoder's 0.1 µm steps is not known
/// better than 0.029 µm, however still its residual stands.
pub(crate) fn record_noise(
    residuals: &[Vec<f64>],
    measured: &crate::trace::measured::MeasuredTrace,
) -> f64 {
    let rounding = [&measured.x_m, &measured.y_m]
        .map(|v| crate::trace::measured::quantum(v).unwrap_or(0.0) / 12f64.sqrt())
        .into_iter()
        .fold(0.0, f64::max);
    noise_floor(residuals).max(rounding).max(1e-12)
}

/// The noise floor: the robust spread of the residual's sample-to-sample differences over
/// both axes, divided by √2 (model errors barely change between samples; noise does).
pub(crate) fn noise_floor(residuals: &[Vec<f64>]) -> f64 {
    let mut d: Vec<f64> = residuals
        .iter()
        .flat_map(|r| r.windows(2).map(|w| (w[1] - w[0]).abs()))
        .collect();
    if d.is_empty() {
        return 0.0;
    }
    let mid = d.len() / 2;
    let median = *d.select_nth_unstable_by(mid, f64::total_cmp).1;
    1.4826 * median / std::f64::consts::SQRT_2
}

/// Residual figures of a model's trace against the measured one (at the residual samples).
pub(crate) fn axis_residual(
    meas: &[f64],
    model: &[f64],
    event: &[bool],
    dt_s: f64,
    sigma: f64,
) -> AxisResidual {
    let r: Vec<f64> = meas.iter().zip(model).map(|(a, b)| a - b).collect();
    let ev: Vec<f64> = r
        .iter()
        .zip(event)
        .filter(|(_, e)| **e)
        .map(|(v, _)| *v)
        .collect();
    AxisResidual {
        rms_um: um_from_m(rms(&r)),
        event_rms_um: um_from_m(rms(&ev)),
        smoothed_rms_um: um_from_m(rms(&moving_average(
            &r,
            ((0.02 / dt_s).round() as usize).max(1),
        ))),
        chatter_um: um_from_m(chatter_mismatch(meas, model, dt_s, sigma)),
        peak_um: um_from_m(r.iter().fold(0.0f64, |m, v| m.max(v.abs()))),
    }
}

/// Centred moving average over ±`h` samples (fewer at the ends).
pub(crate) fn moving_average(v: &[f64], h: usize) -> Vec<f64> {
    let mut prefix = vec![0.0; v.len() + 1];
    for (i, x) in v.iter().enumerate() {
        prefix[i + 1] = prefix[i] + x;
    }
    (0..v.len())
        .map(|i| {
            let (lo, hi) = (i.saturating_sub(h), (i + h + 1).min(v.len()));
            (prefix[hi] - prefix[lo]) / (hi - lo) as f64
        })
        .collect()
}

/// One 0.25 s window of a measured and a modelled trace.
pub(crate) struct ChatterWindow {
    /// Samples.
    pub n: f64,
    /// Mean measured − mean modelled (m).
    pub mean_mismatch: f64,
    /// Measured chatter power, its noise share removed (m²).
    pub measured_power: f64,
    /// Modelled chatter power (m²).
    pub model_power: f64,
}

/// Half-width of the running mean chatter is taken about (s): half a slip cycle.
const CHATTER_HALF_S: f64 = 0.01;

/// Samples per half-width of the chatter's running mean.
pub(crate) fn chatter_half(dt_s: f64) -> usize {
    ((CHATTER_HALF_S / dt_s).round() as usize).max(1)
}

/// The share of white noise of deviation σ left about the running mean.
pub(crate) fn chatter_noise_power(sigma: f64, dt_s: f64) -> f64 {
    sigma * sigma * (1.0 - 1.0 / (2 * chatter_half(dt_s) + 1) as f64)
}

/// Per 0.25 s window: the mean mismatch and the chatter power (variance about a ±10 ms
/// running mean) of each trace.
pub(crate) fn chatter_windows(
    meas: &[f64],
    model: &[f64],
    dt_s: f64,
    sigma: f64,
) -> Vec<ChatterWindow> {
    let h = chatter_half(dt_s);
    let (sm, ss) = (moving_average(meas, h), moving_average(model, h));
    let noise_power = chatter_noise_power(sigma, dt_s);
    let window = ((0.25 / dt_s).round() as usize).max(2 * h + 1);
    (0..meas.len())
        .step_by(window)
        .map(|start| {
            let end = (start + window).min(meas.len());
            let n = (end - start) as f64;
            let mean = |v: &[f64]| v[start..end].iter().sum::<f64>() / n;
            let power = |raw: &[f64], smooth: &[f64]| {
                (start..end)
                    .map(|j| (raw[j] - smooth[j]).powi(2))
                    .sum::<f64>()
                    / n
            };
            ChatterWindow {
                n,
                mean_mismatch: mean(meas) - mean(model),
                measured_power: (power(meas, &sm) - noise_power).max(0.0),
                model_power: power(model, &ss),
            }
        })
        .collect()
}

/// RMS over 0.25 s windows of the difference between the measured and the modelled
/// chatter amplitude (m): how far a model is from the stick-slip it should reproduce.
pub(crate) fn chatter_mismatch(meas: &[f64], model: &[f64], dt_s: f64, sigma: f64) -> f64 {
    let d: Vec<f64> = chatter_windows(meas, model, dt_s, sigma)
        .iter()
        .map(|w| w.measured_power.sqrt() - w.model_power.sqrt())
        .collect();
    rms(&d)
}

/// The share of a residual's samples that count as independent: (1 − ρ)/(1 + ρ) for its
/// lag-one autocorrelation ρ > 0 (the variance inflation of a first-order autoregression),
/// 1 for a white residual. A fit that leaves a smooth residual has explained noise-sized
/// wiggles of a larger model error, and its sum-of-squares gain proves that much less.
pub(crate) fn independent_share(r: &[f64]) -> f64 {
    let power: f64 = r.iter().map(|v| v * v).sum();
    if power <= 0.0 {
        return 1.0;
    }
    let lag: f64 = r.windows(2).map(|w| w[0] * w[1]).sum();
    let rho = (lag / power).clamp(0.0, 1.0);
    (1.0 - rho) / (1.0 + rho)
}

/// Half-width of the average a stick-slip axis's residual is judged on (s): a window of the
/// statistical fit, long enough to hold a dozen slips whose timing no model predicts.
pub(crate) const CHATTER_AVERAGE_HALF_S: f64 = 0.125;

/// RMS of a residual (samples `dt_s` apart) averaged over ±`half_s` (m); plain RMS for 0.
pub(crate) fn averaged_rms(r: &[f64], dt_s: f64, half_s: f64) -> f64 {
    rms(&moving_average(r, (half_s / dt_s).round() as usize))
}
