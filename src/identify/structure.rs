//! The template's structure against a model of the loop fitted from the record alone.
//!
//! A template holds what its user knows, and what they know of a controller is often its
//! design, not what runs on the machine: a structure whose values, fitted, still leave a
//! good share of the following error on the held-out halves may be the wrong structure,
//! however well its values are fitted. Where it leaves more than [`TRIED_ABOVE_SHARE`], the
//! model of the loop `--template none` fits (the cascade's orders and the integrating
//! lead-lag on current, `super::loop_model`) is fitted on that axis too — beside the
//! template's errors (a ripple's period it names is fitted as the template's), kinematic
//! limits, lateral shift and weight, which the loop model does not replace — and written in
//! the structure's place where it predicts the held-out halves better by a twentieth. The
//! report says which was written and both figures; the loop model's values describe the
//! loop, not the machine's parts.

use serde::Serialize;

use super::{AxisIdentification, Model, identify_axis, loop_model};
use crate::compare::{CompareSettings, Comparison, Stepping, compare};
use crate::gcode::Program;
use crate::machine::{AxisConfig, AxisName, MachineConfig};
use crate::trace::measured::MeasuredTrace;

/// The share of the following error on the held-out halves above which the template's
/// structure, fitted, is compared with the loop model: the tenth the identification aims
/// at. A structure that predicts the record better than that is kept without the cost of a
/// second search.
pub(super) const TRIED_ABOVE_SHARE: f64 = 0.1;

/// How a loop model written in a structure's place introduces what it is.
const IN_PLACE: &str = "in place of the template's structure:";

/// Whether an axis's `kept` describes a loop model (without a template, or in place of the
/// template's structure) rather than what the template's values kept.
pub(crate) fn describes_a_loop(kept: &str) -> bool {
    kept.starts_with(loop_model::WITHOUT_TEMPLATE) || kept.starts_with(IN_PLACE)
}

/// What the comparison of the template's structure with the loop model found on one axis.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct StructureCompared {
    /// The template's structure, its values fitted (or the template's, where the fit was
    /// not better): the held-out residual as a share of the following error on the samples
    /// it is judged on.
    pub template_share: f64,
    /// The loop model fitted from the record alone, the same way (NaN — JSON `null` — where
    /// it could not be fitted or simulated). The figures the axis reports beside the template
    /// are, where the loop model is written, against the loop model's own start.
    pub loop_share: f64,
    /// Whether the loop model is written in the structure's place: it predicts the held-out
    /// halves better by a twentieth, and better than its own start.
    pub written: bool,
}

type Found = Option<(AxisConfig, AxisIdentification)>;

/// The axes as the template's structure fitted them (`found`, X then Y), each compared with
/// the loop model where [`tried`] asks for it, and the loop model put in its place where
/// it predicts better.
pub(super) fn compared(
    program: &Program,
    template: &MachineConfig,
    measured: &MeasuredTrace,
    settings: &CompareSettings,
    (found, noise_um): ([Found; 2], f64),
) -> [Found; 2] {
    let asks = found
        .each_ref()
        .map(|f| f.as_ref().is_some_and(|f| tried(&f.1, noise_um)));
    if !asks.contains(&true) {
        return found;
    }
    let start = start(template, measured);
    let loops: [Found; 2] = match compare(program, &start, measured, settings, Stepping::Full) {
        Ok(Comparison { ctx, offset_s, .. }) => {
            let fit = |axis: AxisName| {
                let families = loop_model::Families::besides(&template.axis(axis).controller);
                let model = Model::Loop(families);
                asks[axis.index()]
                    .then(|| identify_axis(&ctx, &start, axis, offset_s, model))
                    .flatten()
            };
            let (x, y) = rayon::join(|| fit(AxisName::X), || fit(AxisName::Y));
            [x, y]
        }
        // The loop model's start cannot follow the record: the structure stays, said so.
        Err(_) => [None, None],
    };
    let [fx, fy] = found;
    let [lx, ly] = loops;
    [(fx, lx, asks[0]), (fy, ly, asks[1])].map(|(f, l, asked)| match f {
        Some(f) if asked => Some(chosen(f, l)),
        other => other,
    })
}

/// Whether an axis's structure is compared with the loop model: fitted on enough of the
/// record, its fit's residual above the record's noise (`noise_um`) on the samples it was
/// fitted on, and predicting the held-out halves to more than [`TRIED_ABOVE_SHARE`] of the
/// following error. A structure whose fit reaches the noise is the machine's as far as the
/// record shows, whatever its halves make of a hunting axis: a loop model with more freedom
/// would only fit the hunting's phase.
fn tried(id: &AxisIdentification, noise_um: f64) -> bool {
    let share = id.judged_held_out().3;
    id.too_little.is_none()
        && !id.reached
        && !super::within_noise(id.rms_identified_um, noise_um)
        && share > TRIED_ABOVE_SHARE
}

/// Where the loop model starts: its own start for the record, each axis carrying the
/// template's errors, kinematic limits, lateral shift and weight — what the template says
/// of the machine beyond its loop, which the loop model is fitted beside.
fn start(template: &MachineConfig, measured: &MeasuredTrace) -> MachineConfig {
    let mut start = loop_model::template(measured);
    for axis in AxisName::BOTH {
        let (from, to) = (template.axis(axis), start.axis_mut(axis));
        to.errors = from.errors.clone();
        to.limits = from.limits.clone();
        to.lateral_shift = from.lateral_shift.clone();
        to.gravity = from.gravity.clone();
    }
    start
}

/// Of the structure's fit and the loop model's, the one written: the loop model where it is
/// a fit (better than its own start, not in-sample) predicting the held-out halves better by
/// a twentieth than what the structure would write; both figures said.
fn chosen(
    (config, mut structure): (AxisConfig, AxisIdentification),
    loop_fit: Found,
) -> (AxisConfig, AxisIdentification) {
    let template_share = structure.judged_held_out().3;
    let Some((loop_config, mut loop_id)) = loop_fit else {
        structure.structure_compared = Some(StructureCompared {
            template_share,
            loop_share: f64::NAN,
            written: false,
        });
        return (config, structure);
    };
    let loop_share = loop_id.judged_held_out().3;
    let is_fit = (loop_id.reached || loop_id.better_than_template) && !loop_id.held_out_in_sample;
    let written = is_fit && super::verdict::predicts_better(loop_share, template_share);
    let compared = Some(StructureCompared {
        template_share,
        loop_share,
        written,
    });
    if written {
        // Its values describe the loop, not the machine's parts: none reads as a measurement.
        for v in &mut loop_id.values {
            v.measured = false;
        }
        loop_id.structure_compared = compared;
        loop_id.kept = loop_id
            .kept
            .replacen(loop_model::WITHOUT_TEMPLATE, IN_PLACE, 1);
        (loop_config, loop_id)
    } else {
        structure.structure_compared = compared;
        (config, structure)
    }
}

/// The report's line for an axis whose structure was compared with the loop model.
pub(crate) fn line(c: &StructureCompared) -> String {
    let pct = |share: f64| format!("{:.1} %", 100.0 * share);
    if c.loop_share.is_nan() {
        return format!(
            "the template's structure predicts the held-out halves to {} of the following \
             error; a model of the loop from the record alone could not be fitted: the \
             structure is written",
            pct(c.template_share)
        );
    }
    if c.written {
        format!(
            "the template's structure, fitted, predicts the held-out halves to {} of the \
             following error; a model of the loop fitted from the record alone predicts them \
             to {}: written in its place (its values describe the loop, not the machine's \
             parts; the template's errors, limits, lateral shift and weight stay; the figures \
             beside the template above are the loop model's start's)",
            pct(c.template_share),
            pct(c.loop_share)
        )
    } else {
        format!(
            "the template's structure predicts the held-out halves to {} of the following \
             error; a model of the loop fitted from the record alone, to {}: not better by a \
             twentieth, the structure is written",
            pct(c.template_share),
            pct(c.loop_share)
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fitted(share: f64) -> (AxisConfig, AxisIdentification) {
        let mut id = AxisIdentification::scored(1.0, 3.0 * share);
        id.reached = false;
        id.better_than_template = true;
        let config = MachineConfig::preset("small-table").expect("a built-in preset");
        (config.axis(AxisName::Y).clone(), id)
    }

    #[test]
    fn the_loop_model_is_written_only_where_it_predicts_better_by_a_twentieth() {
        // 0.25 against 0.30: better by a sixth, written; 0.29 against 0.30: by a thirtieth.
        let (_, id) = chosen(fitted(0.30), Some(fitted(0.25)));
        let c = id.structure_compared.expect("compared");
        assert!(c.written);
        assert!((id.held_out_share - 0.25).abs() < 1e-12);
        let (_, id) = chosen(fitted(0.30), Some(fitted(0.29)));
        let c = id.structure_compared.expect("compared");
        assert!(!c.written);
        assert!((id.held_out_share - 0.30).abs() < 1e-12);
        assert!((c.loop_share - 0.29).abs() < 1e-12);
    }

    #[test]
    fn a_loop_model_no_better_than_its_start_is_never_written() {
        let mut start_only = fitted(0.05);
        start_only.1.better_than_template = false;
        let (_, id) = chosen(fitted(0.30), Some(start_only));
        assert!(!id.structure_compared.expect("compared").written);
        let (_, id) = chosen(fitted(0.30), None);
        assert!(id.structure_compared.expect("compared").loop_share.is_nan());
    }

    #[test]
    fn a_structure_within_a_tenth_or_at_the_noise_is_not_compared() {
        // `scored` leaves 3 µm on every sample (its template's 1 µm): noise 0.1 µm.
        assert!(tried(&fitted(0.30).1, 0.1));
        assert!(!tried(&fitted(0.08).1, 0.1));
        let mut reached = fitted(0.30).1;
        reached.reached = true;
        assert!(!tried(&reached, 0.1));
        // A fit within the noise on its samples, though its halves miss each other.
        assert!(!tried(&fitted(0.30).1, 3.0 * 0.30 / 1.05));
    }
}
