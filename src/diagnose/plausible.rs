//! Whether a fitted cause could exist on the machine. A fit always finds the values that
//! best bend the model towards the data; when the data hold an effect the catalogue lacks
//! (another controller, a measuring point the model does not describe), those values can
//! be ones no machine has — two kilonewtons of low-speed friction on an axis with two
//! hundred newtons of Coulomb friction, or a "resonance" at the servo loop's own
//! crossover. Such a cause is reported as fitting but implausible, never as found. Nor is
//! one whose level the record does not tell from the machine's own value.

use crate::diagnose::causes::CauseId;
use crate::machine::AxisConfig;
use crate::numeric::units::{m_from_um, per_s_from_kv_m_per_min_per_mm};
use crate::sim::AxisModel;
use crate::sim::linear::{closed_loop_modes, loop_figures, loops};

/// What a measurement shows about an axis, for judging fitted values.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Observed {
    /// Largest |commanded − measured| position over the compared samples (m).
    pub following_error_max_m: f64,
}

/// Largest Stribeck excess relative to the Coulomb force: guideway and screw friction
/// rises towards standstill by tens of percent, not by multiples.
const STRIBECK_OVER_COULOMB_MAX: f64 = 2.0;
/// Largest force ripple as a share of the drive's peak force. A servo motor's torque ripple
/// and cogging together stay within a few percent of its rated torque, and its peak torque is
/// about three times the rated one: a quarter of the peak (three quarters of the rated torque)
/// is far beyond any motor's ripple.
const RIPPLE_OVER_PEAK_MAX: f64 = 0.25;
/// Largest Coulomb coefficient of a machine-tool guideway (plain slideways reach 0.2).
const COULOMB_COEFFICIENT_MAX: f64 = 0.3;
/// Largest delay between interpolator and position loop (s): a few interpolation cycles.
const DEAD_TIME_MAX_S: f64 = 0.05;
/// Largest cyclic error of a screw or scale (m).
const CYCLIC_AMPLITUDE_MAX_M: f64 = 50e-6;
/// Largest scale or lead error (ppm): a screw's lead class, a scale's expansion.
const SCALE_ERROR_MAX_PPM: f64 = 1000.0;
/// Out-of-squareness beyond which a machine would not have left assembly (µrad): 1 mm per metre.
const SQUARENESS_MAX_URAD: f64 = 1000.0;
/// Largest bow of a guideway over its span (µm).
const STRAIGHTNESS_MAX_UM: f64 = 200.0;
/// Largest play of a carriage across its guides (µm): a worn plain slideway's clearance.
const LATERAL_PLAY_MAX_UM: f64 = 100.0;
/// Largest lost motion beyond a scale (µm): a worn holder's or head's play.
const DIRECTION_OFFSET_MAX_UM: f64 = 100.0;
/// A position gain this far from the set one is a wrong machine file, not a cause.
pub(crate) const KV_RATIO_MAX: f64 = 5.0;
/// How near (relative) a fitted resonance may lie to a loop's crossover before it is taken
/// for the loop's own overshoot rather than the structure.
const CROSSOVER_MARGIN: f64 = 0.1;
/// How near (relative) it may lie to a lightly damped closed-loop mode the model already
/// has: there it is that mode with another damping, not an extra structure.
const MODE_MARGIN: f64 = 0.025;

/// How many standard uncertainties from zero a cause's level must lie to count as found:
/// within two, the record is consistent with no such effect at all (a normal deviate falls
/// that far one time in twenty).
const DETERMINED_SIGMAS: f64 = 2.0;

/// Why a fitted cause is not determined, or `None` when it is: its level (the first value,
/// `values` with standard uncertainties `sigma`) lies within [`DETERMINED_SIGMAS`] of zero, or
/// has no uncertainty. A residual can fall with such a fit — the fit bends the model towards
/// whatever the residual holds — but the record does not tell the effect from none.
pub(crate) fn undetermined(cause: CauseId, values: &[f64], sigma: &[f64]) -> Option<String> {
    let param = cause.params().first()?;
    let (value, s) = (*values.first()?, *sigma.first()?);
    let sig = super::cause_text::with_uncertainty;
    if !(s.is_finite() && s > 0.0) {
        return Some(format!(
            "fits, but not determined: {} = {} {} has no uncertainty the record fixes",
            param.key,
            sig(value, s),
            param.unit
        ));
    }
    (value.abs() < DETERMINED_SIGMAS * s).then(|| {
        format!(
            "fits, but not determined: {} = {} {} lies within {DETERMINED_SIGMAS} standard \
             uncertainties of zero",
            param.key,
            sig(value, s),
            param.unit
        )
    })
}

/// Why fitted `values` of `cause` are implausible on `axis` (its nominal settings), or
/// `None` when they are not.
pub(crate) fn implausible(
    cause: CauseId,
    values: &[f64],
    axis: &AxisConfig,
    observed: &Observed,
) -> Option<String> {
    implausible_mechanics(cause, values, axis, observed)
        .or_else(|| implausible_control(cause, values, axis))
        .or_else(|| implausible_geometry(cause, values, axis))
}

/// Friction and lost motion beyond the machine and the record.
fn implausible_mechanics(
    cause: CauseId,
    values: &[f64],
    axis: &AxisConfig,
    observed: &Observed,
) -> Option<String> {
    let model = AxisModel::from_config(axis);
    match cause {
        CauseId::Stribeck => {
            let level = values[0];
            (level > STRIBECK_OVER_COULOMB_MAX * model.f_c).then(|| {
                format!(
                    "a low-speed friction excess of {level:.0} N is more than {STRIBECK_OVER_COULOMB_MAX} × \
                     the axis's Coulomb friction ({:.0} N)",
                    model.f_c
                )
            })
        }
        // A ripple is a small share of what the drive can push.
        CauseId::ForceRipple => {
            let peak_n = super::ripple::peak_force_n(axis)?;
            (values[0] > RIPPLE_OVER_PEAK_MAX * peak_n).then(|| {
                format!(
                    "a force ripple of {:.0} N exceeds {RIPPLE_OVER_PEAK_MAX} × the most the \
                     axis's drive can push ({peak_n:.0} N: its current limit through the motor's \
                     torque constant); a motor's ripple is a few percent of its rated force",
                    values[0]
                )
            })
        }
        CauseId::CoulombFriction => (values[0] > COULOMB_COEFFICIENT_MAX).then(|| {
            format!(
                "a friction coefficient of {:.3} exceeds any guideway's ({COULOMB_COEFFICIENT_MAX})",
                values[0]
            )
        }),
        CauseId::Backlash => {
            let gap = m_from_um(values[0]);
            (gap > observed.following_error_max_m).then(|| {
                format!(
                    "{:.1} µm of lost motion exceed the largest following error measured ({:.1} µm)",
                    values[0],
                    observed.following_error_max_m * 1e6
                )
            })
        }
        _ => None,
    }
}

/// Delays, gains and resonances no control or structure has.
fn implausible_control(cause: CauseId, values: &[f64], axis: &AxisConfig) -> Option<String> {
    let model = AxisModel::from_config(axis);
    match cause {
        CauseId::DeadTime => (values[0] * 1e-3 > DEAD_TIME_MAX_S).then(|| {
            format!(
                "a delay of {:.1} ms is longer than any control's ({:.0} ms)",
                values[0],
                DEAD_TIME_MAX_S * 1e3
            )
        }),
        CauseId::KvGain => {
            let set = per_s_from_kv_m_per_min_per_mm(axis.position_loop.kv_m_per_min_per_mm);
            let ratio = per_s_from_kv_m_per_min_per_mm(values[0]) / set;
            (!(1.0 / KV_RATIO_MAX..=KV_RATIO_MAX).contains(&ratio)).then(|| {
                format!(
                    "a position gain {ratio:.2} × the set one is a different machine file, not a \
                     mismatch"
                )
            })
        }
        CauseId::Resonance => loop_frequency_near(&model, values[0]).map(|(what, f)| {
            format!(
                "{:.1} Hz lies at the model's own {what} ({f:.1} Hz): the loop, not the structure",
                values[0]
            )
        }),
        _ => None,
    }
}

/// Measuring and geometric errors beyond any machine's.
fn implausible_geometry(cause: CauseId, values: &[f64], axis: &AxisConfig) -> Option<String> {
    match cause {
        CauseId::CyclicError => (m_from_um(values[0].abs()) > CYCLIC_AMPLITUDE_MAX_M).then(|| {
            format!(
                "a cyclic error of {:.1} µm exceeds any screw's or scale's ({:.0} µm)",
                values[0],
                CYCLIC_AMPLITUDE_MAX_M * 1e6
            )
        }),
        CauseId::ScaleError => (values[0].abs() > SCALE_ERROR_MAX_PPM).then(|| {
            format!(
                "a scale error of {:.0} ppm exceeds any screw's or scale's ({SCALE_ERROR_MAX_PPM:.0} ppm)",
                values[0]
            )
        }),
        CauseId::Squareness => (values[0].abs() > SQUARENESS_MAX_URAD).then(|| {
            format!(
                "axes {:.0} µrad out of square ({:.2} mm per metre) would have been seen at \
                 assembly",
                values[0],
                values[0] * 1e-3
            )
        }),
        CauseId::Straightness => (values[0].abs() > STRAIGHTNESS_MAX_UM).then(|| {
            format!(
                "a guideway bowed {:.0} µm over {:.0} mm is beyond any machine's ({STRAIGHTNESS_MAX_UM:.0} µm)",
                values[0], axis.errors.straightness_span_mm
            )
        }),
        CauseId::LateralPlay => (values[0].abs() > LATERAL_PLAY_MAX_UM).then(|| {
            format!(
                "{:.0} µm of play across the guides is beyond any guideway's ({LATERAL_PLAY_MAX_UM:.0} µm)",
                values[0]
            )
        }),
        CauseId::DirectionOffset => (values[0].abs() > DIRECTION_OFFSET_MAX_UM).then(|| {
            format!(
                "{:.0} µm of lost motion beyond the scale is beyond any machine's ({DIRECTION_OFFSET_MAX_UM:.0} µm)",
                values[0]
            )
        }),
        _ => None,
    }
}

/// A frequency of the model's own loops within the margin of `freq_hz`: the crossovers of
/// the loops the axis has (a position controller on a current amplifier has no velocity
/// loop) and the lightly damped closed-loop modes.
fn loop_frequency_near(model: &AxisModel, freq_hz: f64) -> Option<(String, f64)> {
    let near = |f: f64, margin: f64| f.is_finite() && (freq_hz / f - 1.0).abs() <= margin;
    for which in loops(model).into_iter().rev() {
        let f = loop_figures(model, which).crossover_hz;
        if near(f, CROSSOVER_MARGIN) {
            return Some((format!("{} loop's crossover", which.name()), f));
        }
    }
    closed_loop_modes(model)
        .into_iter()
        .find(|m| m.damping < 0.3 && near(m.frequency_hz, MODE_MARGIN))
        .map(|m| ("closed-loop mode".to_string(), m.frequency_hz))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::machine::MachineConfig;

    #[test]
    fn a_level_within_two_uncertainties_of_zero_is_not_determined() {
        let said = |cause, values: &[f64], sigma: &[f64]| undetermined(cause, values, sigma);
        // 126 ± 175 N of Stribeck excess on an axis with none: zero lies 0.7 σ away.
        let why = said(CauseId::Stribeck, &[126.0, 100.0], &[175.0, 50.0]).unwrap();
        assert!(
            why.contains("stribeck_level_n") && why.contains("126 ± 175"),
            "{why}"
        );
        // 126 ± 40 N: 3.2 σ from zero, determined.
        assert_eq!(
            said(CauseId::Stribeck, &[126.0, 100.0], &[40.0, 50.0]),
            None
        );
        // A Coulomb coefficient of 0.03 ± 0.02: 1.5 σ from none.
        assert!(said(CauseId::CoulombFriction, &[0.03], &[0.02]).is_some());
        // 0.0149 ± 0.0040: 3.7 σ from none, determined.
        assert_eq!(said(CauseId::CoulombFriction, &[0.0149], &[0.0040]), None);
        // A dead time of 0.000 ± 0.017 ms where the machine has none.
        assert!(said(CauseId::DeadTime, &[0.0], &[0.017]).is_some());
        // No uncertainty: nothing the record fixes.
        assert!(said(CauseId::DeadTime, &[0.5], &[f64::NAN]).is_some());
    }

    fn ripple_verdict(amplitude_n: f64) -> Option<String> {
        let machine = MachineConfig::default_preset();
        let observed = Observed {
            following_error_max_m: 1e-3,
        };
        implausible(
            CauseId::ForceRipple,
            &[amplitude_n, 0.0],
            &machine.x,
            &observed,
        )
    }

    /// Where |L(jω)| = 1 (Hz) for the small-table X axis taken as a rigid body: its
    /// controller K (s + 62.5)² / (s (s + 1250)) in A per mm of error, the motor's torque
    /// through the 10 mm lead onto the inertia of rotor, screw and 30 kg table.
    fn small_table_rigid_crossover_hz() -> f64 {
        let (k_a_per_mm, kt, lead_m) = (108.1, 0.49, 0.010);
        let r = lead_m / std::f64::consts::TAU;
        let inertia = 1.8e-4 + 2.5e-5 + 30.0 * r * r;
        let gain = |w: f64| {
            let controller =
                k_a_per_mm * (w * w + 62.5 * 62.5) / (w * (w * w + 1250.0f64.powi(2)).sqrt());
            // Current (A) to position (mm): kt r / (J ω²), in mm.
            controller * kt * r * 1e3 / (inertia * w * w)
        };
        let (mut lo, mut hi): (f64, f64) = (10.0, 10_000.0);
        for _ in 0..100 {
            let mid = (lo * hi).sqrt();
            if gain(mid) > 1.0 { lo = mid } else { hi = mid }
        }
        lo / std::f64::consts::TAU
    }

    #[test]
    fn a_resonance_at_the_crossover_of_a_controller_on_a_current_amplifier_is_the_loops() {
        // small-table's controller drives a current amplifier: the axis has a current and a
        // position loop and no velocity loop to ask about.
        let axis = MachineConfig::preset("small-table").unwrap().x;
        let observed = Observed {
            following_error_max_m: 1e-3,
        };
        let crossover_hz = small_table_rigid_crossover_hz();
        // Designed for 40 Hz; the rigid body's figure, not the model's, is what is asked.
        assert!((35.0..45.0).contains(&crossover_hz), "{crossover_hz}");
        let at = implausible(CauseId::Resonance, &[crossover_hz, 0.05], &axis, &observed);
        assert!(
            at.as_deref()
                .is_some_and(|w| w.contains("position loop's crossover")),
            "{at:?}"
        );
        // Three times higher lies on no loop of the axis: a structure may ring there.
        let above = implausible(
            CauseId::Resonance,
            &[3.0 * crossover_hz, 0.05],
            &axis,
            &observed,
        );
        assert_eq!(above, None);
    }

    #[test]
    fn a_ripple_of_a_third_of_the_peak_force_is_no_motors_but_one_of_a_tenth_may_be() {
        // The nominal machine's X: 60 A × 2.34 N·m/A over 16 mm × 0.25 / 2π of travel per
        // motor radian = 220.5 kN of peak force.
        let peak_n = 60.0 * 2.34 / (16e-3 * 0.25 / std::f64::consts::TAU);
        assert!(ripple_verdict(peak_n / 3.0).is_some());
        assert!(ripple_verdict(peak_n / 10.0).is_none());
    }
}
