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
//! the structure's place where it predicts the held-out halves better by a quarter. The
//! report says which was written and both figures; the loop model's values describe the
//! loop, not the machine's parts.

use serde::Serialize;

use super::solve::{Fit, masked_rms};
use super::{AxisIdentification, Model, identify_axis, loop_model, moving_samples};
use crate::compare::Context;
use crate::machine::{AxisConfig, AxisName, MachineConfig};
use crate::numeric::units::um_from_m;
use crate::trace::measured::MeasuredTrace;

/// The share of the following error on the held-out halves above which the template's
/// structure, fitted, is compared with the loop model: the tenth the identification aims
/// at. A structure that predicts the record better than that is kept without the cost of a
/// second search.
pub(super) const TRIED_ABOVE_SHARE: f64 = 0.1;
/// How much lower the loop model's held-out figure must lie than the structure's for it to
/// be written in its place: a quarter, five times the twentieth one more value must earn.
/// The two are not nested — each is fitted with its own half-dozen values — and a loop model
/// of more freedom gains on a structure that is the machine's by shaping what both lack: on
/// a record of the independent integrator whose template holds the machine's structure and
/// whose guideway has a tight spot neither models, the cascade predicted the held-out halves
/// 12 % better (70.5 % of the following error against 80.0 %).
const STRUCTURE_GAIN: f64 = 0.75;

/// How a loop model written in a structure's place introduces what it is.
const IN_PLACE: &str = "in place of the template's structure:";

/// Whether an axis's `kept` describes a loop model (without a template, or in place of the
/// template's structure) rather than what the template's values kept.
pub(crate) fn describes_a_loop(kept: &str) -> bool {
    kept.starts_with(loop_model::WITHOUT_TEMPLATE) || kept.starts_with(IN_PLACE)
}

/// What the comparison of the template's structure with the loop model found on one axis.
/// Both are scored on one footing: the same record's comparison, on the samples while the
/// axis moves (away from its standstills), where every fit has held-out figures — a fit on
/// every sample its figures while moving, a fit away from the standstills its own.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StructureCompared {
    /// What the template's structure writes — its values fitted, or the template's own where
    /// the fit was not better —: the held-out residual as a share of the following error
    /// while moving.
    pub template_share: f64,
    /// The loop model fitted from the record alone, the same way (NaN — JSON `null` — where
    /// it could not be fitted or scored).
    pub loop_share: f64,
    /// Whether the loop model is written in the structure's place: a fit (better than its
    /// own start and than the template while moving, with a point of its own on each half)
    /// predicting the held-out halves while moving better than the structure by a quarter.
    pub written: bool,
    /// Why it is written, or why not, in words.
    pub why: String,
}

type Found = Option<(AxisConfig, AxisIdentification)>;

/// The axes as the template's structure fitted them (`found`, X then Y) on the record's
/// comparison `ctx` (at `offset` s), each compared with the loop model where [`tried`] asks
/// for it — fitted on the same comparison —, and the loop model put in its place where it
/// predicts better.
pub(super) fn compared(
    (ctx, offset): (&Context, f64),
    template: &MachineConfig,
    measured: &MeasuredTrace,
    found: [Found; 2],
) -> [Found; 2] {
    let noise_um = um_from_m(ctx.noise_sigma);
    let asks = found
        .each_ref()
        .map(|f| f.as_ref().is_some_and(|f| tried(&f.1, noise_um)));
    if !asks.contains(&true) {
        return found;
    }
    let start = start(template, measured);
    let fit = |axis: AxisName| {
        let families = loop_model::Families::besides(template.axis(axis));
        asks[axis.index()]
            .then(|| identify_axis(ctx, &start, axis, offset, Model::Loop(families)))
            .flatten()
            .map(|found| against_template(found, (ctx, offset), template))
    };
    let (lx, ly) = rayon::join(|| fit(AxisName::X), || fit(AxisName::Y));
    let [fx, fy] = found;
    [(fx, lx, asks[0]), (fy, ly, asks[1])].map(|(f, l, asked)| match f {
        Some(f) if asked => Some(chosen(f, l)),
        other => other,
    })
}

/// Whether an axis's structure is compared with the loop model: fitted on enough of the
/// record, its fit's residual above the record's noise (`noise_um`) on the samples it was
/// fitted on, and what it writes predicting the held-out halves while moving to more than
/// [`TRIED_ABOVE_SHARE`] of the following error. A structure whose fit reaches the noise is
/// the machine's as far as the record shows, whatever its halves make of a hunting axis: a
/// loop model with more freedom would only fit the hunting's phase.
fn tried(id: &AxisIdentification, noise_um: f64) -> bool {
    id.too_little.is_none()
        && !id.reached
        && !super::within_noise(id.rms_identified_um, noise_um)
        && written_share(id).is_some_and(|share| share > TRIED_ABOVE_SHARE)
}

/// Where the loop model starts: its own start for the record, each axis carrying what the
/// template says of the machine beyond its loop, which the loop model is fitted beside: its
/// errors (a cyclic error's period made explicit where the template's screw lead gave it),
/// kinematic limits, lateral shift, weight and where its loop is closed. The template's
/// motor, drive, controller and friction are what the loop model replaces.
fn start(template: &MachineConfig, measured: &MeasuredTrace) -> MachineConfig {
    let mut start = loop_model::template(measured);
    for axis in AxisName::BOTH {
        let (from, to) = (template.axis(axis), start.axis_mut(axis));
        to.errors = from.errors.clone();
        if to.errors.cyclic_amplitude_um != 0.0 && to.errors.cyclic_period_mm <= 0.0 {
            to.errors.cyclic_period_mm = from.drive.lead_mm;
        }
        to.limits = from.limits.clone();
        to.lateral_shift = from.lateral_shift.clone();
        to.gravity = from.gravity.clone();
        to.position_loop.feedback = from.position_loop.feedback;
    }
    start
}

/// The held-out figures while moving an axis is compared on, as (the template's, the
/// written values', the following error's) in µm: a fit away from the standstills its own,
/// a fit on every sample its figures while moving (none where it has none).
fn while_moving(a: &AxisIdentification) -> Option<(f64, f64, f64)> {
    if a.moving_only {
        return Some((
            a.held_out_template_um,
            a.held_out_identified_um,
            a.following_error_rms_um,
        ));
    }
    let m = a.while_moving.as_ref()?;
    Some((
        m.held_out_template_um,
        m.held_out_identified_um,
        m.following_error_rms_um,
    ))
}

/// The share of the following error while moving that what an axis writes leaves on the
/// held-out halves: its fit's, or the template's where the template's values are written
/// (the fit not better, NOT IDENTIFIED).
fn written_share(a: &AxisIdentification) -> Option<f64> {
    let (template_um, identified_um, following_um) = while_moving(a)?;
    let fit_written = a.better_than_template || a.template_holds || a.reached;
    let um = if fit_written {
        identified_um
    } else {
        template_um
    };
    Some(um / following_um)
}

/// A loop model's figures beside the template made the user's template's, not its own
/// start's: the template's residual on the same samples (the same comparison, so the
/// same masks), and whether the loop — a fit better than its own start — predicts the
/// held-out halves while moving better than it.
fn against_template(
    (config, mut id): (AxisConfig, AxisIdentification),
    (ctx, offset): (&Context, f64),
    template: &MachineConfig,
) -> (AxisConfig, AxisIdentification) {
    // A loop model no better than its own start has its start's values put back: never a
    // fit, whatever the template leaves.
    let beat_its_start = id.reached || id.better_than_template;
    id.better_than_template = false;
    let fit = Fit::new(ctx, template, id.axis, offset);
    let Some(residual) = fit.residual(template.axis(id.axis)) else {
        // The template cannot be simulated: nothing to be better than.
        return (config, id);
    };
    let moving = moving_samples(ctx, id.axis, offset);
    let all = vec![true; residual.len()];
    let whole = if id.moving_only { &moving } else { &all };
    let whole_um = um_from_m(masked_rms(&residual, whole));
    id.rms_template_um = whole_um;
    id.held_out_template_um = whole_um;
    if let Some(m) = id.while_moving.as_mut() {
        m.held_out_template_um = um_from_m(masked_rms(&residual, &moving));
    }
    id.better_than_template = better_than_template(beat_its_start, &id);
    (config, id)
}

/// Whether a loop model, with the user's template's figures beside it, is written as better
/// than the template: a fit that beat its own start (`beat_its_start`), with a point of its
/// own on each half, predicting the held-out halves while moving — where the structure is
/// judged — better than the template by a twentieth.
fn better_than_template(beat_its_start: bool, id: &AxisIdentification) -> bool {
    let better_while_moving = while_moving(id).is_some_and(|(template_um, identified_um, _)| {
        super::verdict::predicts_better(identified_um, template_um)
    });
    beat_its_start && !id.held_out_in_sample && better_while_moving
}

/// Of the structure's fit and the loop model's, the one written: the loop model where it is
/// a fit (better than the template, with a point of its own on each half) predicting the
/// held-out halves while moving better by a quarter ([`STRUCTURE_GAIN`]) than what the
/// structure writes; both figures said.
fn chosen(
    (config, mut structure): (AxisConfig, AxisIdentification),
    loop_fit: Found,
) -> (AxisConfig, AxisIdentification) {
    let template_share = written_share(&structure).unwrap_or(f64::NAN);
    let loop_share = loop_fit
        .as_ref()
        .and_then(|l| written_share(&l.1))
        .unwrap_or(f64::NAN);
    let is_fit = loop_fit
        .as_ref()
        .is_some_and(|l| (l.1.reached || l.1.better_than_template) && !l.1.held_out_in_sample);
    let better = loop_share < STRUCTURE_GAIN * template_share;
    let why = match (loop_fit.is_some(), is_fit, better) {
        (false, _, _) => "a model of the loop could not be fitted on this record",
        _ if template_share.is_nan() || loop_share.is_nan() => {
            "no held-out figure while moving to compare them by"
        }
        (_, false, _) => {
            "the loop model is not a fit that predicts the held-out halves better than the \
             template (or a half's fit had no point of its own)"
        }
        (_, true, false) => "not better by a quarter",
        (_, true, true) => "better by more than a quarter",
    };
    let compared = StructureCompared {
        template_share,
        loop_share,
        written: is_fit && better,
        why: why.to_string(),
    };
    match loop_fit {
        Some((loop_config, mut loop_id)) if compared.written => {
            // Its values describe the loop, not the machine's parts: none reads as a
            // measurement.
            for v in &mut loop_id.values {
                v.measured = false;
            }
            loop_id.structure_compared = Some(compared);
            loop_id.kept = loop_id
                .kept
                .replacen(loop_model::WITHOUT_TEMPLATE, IN_PLACE, 1);
            (loop_config, loop_id)
        }
        _ => {
            structure.structure_compared = Some(compared);
            (config, structure)
        }
    }
}

/// The report's line for an axis whose structure was compared with the loop model.
pub(crate) fn line(c: &StructureCompared) -> String {
    let pct = |share: f64| {
        if share.is_nan() {
            "—".to_string()
        } else {
            format!("{:.1} %", 100.0 * share)
        }
    };
    let outcome = if c.written {
        "the loop model is written in the structure's place: its values describe the loop, \
         not the machine's parts (the template's errors, limits, lateral shift, weight and \
         feedback stay; its motor, drive, friction and current limits are the loop model's, \
         the values' template figures its start's)"
    } else {
        "the structure is written"
    };
    format!(
        "the template's structure predicts the held-out halves while moving to {} of the \
         following error, a model of the loop fitted from the record alone to {} ({}): {}",
        pct(c.template_share),
        pct(c.loop_share),
        c.why,
        outcome
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fit away from the standstills leaving `share` of a 3 µm following error on its
    /// held-out halves, where its template leaves 1 µm (a third).
    fn fitted(share: f64) -> (AxisConfig, AxisIdentification) {
        let mut id = AxisIdentification::scored(1.0, 3.0 * share);
        id.reached = false;
        id.moving_only = true;
        id.better_than_template = true;
        let config = MachineConfig::preset("small-table").expect("a built-in preset");
        (config.axis(AxisName::Y).clone(), id)
    }

    #[test]
    fn the_loop_model_is_written_only_where_it_predicts_better_by_a_quarter() {
        // 0.20 against 0.30: better by a third, written; 0.25 against 0.30: by a sixth only.
        let (_, id) = chosen(fitted(0.30), Some(fitted(0.20)));
        let c = id.structure_compared.expect("compared");
        assert!(c.written, "{c:?}");
        assert!((id.held_out_share - 0.20).abs() < 1e-12);
        let (_, id) = chosen(fitted(0.30), Some(fitted(0.25)));
        let c = id.structure_compared.expect("compared");
        assert!(!c.written && c.why.contains("quarter"), "{c:?}");
        assert!((id.held_out_share - 0.30).abs() < 1e-12);
        assert!((c.loop_share - 0.25).abs() < 1e-12);
    }

    #[test]
    fn a_structure_not_identified_is_judged_by_the_template_it_writes() {
        // The structure's fit leaves 0.30 but is not better than its template, which is
        // written and leaves 0.20 (0.6 µm of 3): a loop model at 0.18 predicts better than
        // the fit by far but not than what the structure writes by a quarter.
        let mut not_identified = fitted(0.30);
        not_identified.1.better_than_template = false;
        not_identified.1.held_out_template_um = 0.6;
        let (_, id) = chosen(not_identified.clone(), Some(fitted(0.18)));
        let c = id.structure_compared.expect("compared");
        assert!(
            !c.written && (c.template_share - 0.2).abs() < 1e-12,
            "{c:?}"
        );
        let (_, id) = chosen(not_identified, Some(fitted(0.10)));
        assert!(id.structure_compared.expect("compared").written);
    }

    #[test]
    fn the_figures_compared_are_those_while_moving() {
        // A structure fitted on every sample: 0.40 there, 0.30 while moving (0.9 of 3 µm).
        let mut everywhere = fitted(0.40);
        everywhere.1.moving_only = false;
        everywhere.1.while_moving = Some(super::super::WhileMoving {
            held_out_template_um: 1.0,
            held_out_identified_um: 0.9,
            following_error_rms_um: 3.0,
            held_out_share: 0.3,
        });
        // A loop model at 0.28 while moving is not a quarter better than 0.30, though it is
        // than the 0.40 on every sample.
        let (_, id) = chosen(everywhere.clone(), Some(fitted(0.28)));
        let c = id.structure_compared.expect("compared");
        assert!(
            !c.written && (c.template_share - 0.3).abs() < 1e-12,
            "{c:?}"
        );
        // With no figure while moving, nothing is compared and the structure stays.
        everywhere.1.while_moving = None;
        let (_, id) = chosen(everywhere, Some(fitted(0.10)));
        assert!(!id.structure_compared.expect("compared").written);
    }

    #[test]
    fn a_loop_model_no_better_than_the_template_is_never_written() {
        let mut no_better = fitted(0.05);
        no_better.1.better_than_template = false;
        let (_, id) = chosen(fitted(0.30), Some(no_better));
        assert!(!id.structure_compared.expect("compared").written);
        let mut in_sample = fitted(0.05);
        in_sample.1.held_out_in_sample = true;
        let (_, id) = chosen(fitted(0.30), Some(in_sample));
        assert!(!id.structure_compared.expect("compared").written);
        let (_, id) = chosen(fitted(0.30), None);
        assert!(id.structure_compared.expect("compared").loop_share.is_nan());
    }

    #[test]
    fn a_loop_model_is_better_than_the_template_only_as_a_fit_and_while_moving() {
        // 0.25 of 3 µm held out where the template leaves 1 µm (a third): better.
        let (_, loop_id) = fitted(0.25);
        assert!(better_than_template(true, &loop_id));
        // Its own start put back (no fit beat it): never, whatever the template leaves.
        assert!(!better_than_template(false, &loop_id));
        // A half's fit without a point of its own: never.
        let mut in_sample = loop_id.clone();
        in_sample.held_out_in_sample = true;
        assert!(!better_than_template(true, &in_sample));
        // On every sample better, while moving not: judged while moving.
        let mut everywhere = loop_id;
        everywhere.moving_only = false;
        everywhere.while_moving = Some(super::super::WhileMoving {
            held_out_template_um: 1.0,
            held_out_identified_um: 0.99,
            following_error_rms_um: 3.0,
            held_out_share: 0.33,
        });
        assert!(!better_than_template(true, &everywhere));
    }

    #[test]
    fn a_structure_within_a_tenth_or_at_the_noise_is_not_compared() {
        // `fitted` leaves 0.9 µm where its template leaves 1 µm: noise 0.1 µm.
        assert!(tried(&fitted(0.30).1, 0.1));
        assert!(!tried(&fitted(0.08).1, 0.1));
        let mut reached = fitted(0.30).1;
        reached.reached = true;
        assert!(!tried(&reached, 0.1));
        // A fit within the noise on its samples, though its halves miss each other.
        assert!(!tried(&fitted(0.30).1, 3.0 * 0.30 / 1.05));
    }
}
