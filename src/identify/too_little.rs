//! An axis of which the stretch compared holds too little to fit or to judge: a record of a
//! program's start that ends a moment into its first cut, an axis that stands while the
//! others move. Its template's values are written, and the report says why in place of
//! figures that would be ratios of nothing (a residual of no samples reads as a perfect fit).

use super::{AxisIdentification, LEAST_TRAVEL_M, following_error_rms, knobs, unfitted};
use crate::compare::Context;
use crate::identify::solve::Fit;
use crate::machine::{AxisConfig, AxisName, MachineConfig};
use crate::numeric::units::um_from_m;

/// Samples per value fitted that the stretch compared must hold at least: each of the two
/// halves a fit is judged on then holds twice as many samples as the values it fits.
const SAMPLES_PER_VALUE: usize = 4;

/// Why the stretch compared holds too little of `axis` to fit it, or `None` where it holds
/// enough: too few samples after the run-in, an axis commanded to stand (less than
/// [`LEAST_TRAVEL_M`] of travel), or one whose following error stays within the record's
/// noise.
pub(super) fn why(
    ctx: &Context,
    template: &AxisConfig,
    axis: AxisName,
    offset_s: f64,
) -> Option<String> {
    let compared = (0..ctx.samples.len())
        .filter(|&k| ctx.compared(axis, k))
        .count();
    let values = knobs::for_axis(template).len();
    if compared < SAMPLES_PER_VALUE * values {
        return Some(format!(
            "the stretch compared holds {compared} of its samples, fewer than the {} that \
             fitting its {values} values on two halves asks",
            SAMPLES_PER_VALUE * values
        ));
    }
    let mask: Vec<bool> = (0..ctx.samples.len())
        .map(|k| ctx.compared(axis, k))
        .collect();
    let travel_um = um_from_m(commanded_travel_m(ctx, axis, offset_s, &mask));
    if travel_um.is_nan() || travel_um < um_from_m(LEAST_TRAVEL_M) {
        return Some(format!(
            "it is commanded to move {travel_um:.1} µm in the stretch compared: nothing to \
             identify it from"
        ));
    }
    let following_um = um_from_m(following_error_rms(ctx, axis, offset_s, &mask));
    let noise_um = um_from_m(ctx.noise_sigma);
    (following_um.is_nan() || following_um <= noise_um).then(|| {
        format!(
            "its following error in the stretch compared ({following_um:.3} µm) stays within the \
             record's noise ({noise_um:.3} µm): its loop's response is not seen"
        )
    })
}

/// How far the axis's commands range over the samples `mask` allows (m).
fn commanded_travel_m(ctx: &Context, axis: AxisName, offset_s: f64, mask: &[bool]) -> f64 {
    let (lo, hi) = ctx
        .samples
        .iter()
        .zip(mask)
        .filter(|(_, m)| **m)
        .map(|(&i, _)| ctx.command_at(axis, ctx.prog_time(i, offset_s)).0)
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| {
            (l.min(v), h.max(v))
        });
    if hi >= lo { hi - lo } else { 0.0 }
}

/// The axis not identified, because `why`: the template's values, said so.
pub(super) fn not_identified(
    ctx: &Context,
    template: &MachineConfig,
    axis: AxisName,
    offset_s: f64,
    why: String,
) -> Option<(AxisConfig, AxisIdentification)> {
    let (config, mut id) = unfitted(Fit::new(ctx, template, axis, offset_s), template.axis(axis))?;
    id.too_little = Some(why);
    id.presliding = None;
    Some((config, id))
}
