//! A ripple's period where no template names one (`--template none`): looked for among the
//! leads ball screws are made with, each half of the record's gain counted on its own samples.
//!
//! A motor's torque ripple and a screw's eccentricity repeat once per motor turn — on a
//! direct-driven ball screw, once per lead. The leads makers offer are few, so each is
//! tried: a trial ripple of that period on the loop fitted without one, its sine and cosine
//! parts fitted by least squares (two simulations a period), on each half's samples alone.
//! The period taken is the one both halves gain from most — the largest of each lead's
//! smaller share of its residual's energy taken off —: a period only one half gains from is
//! the noise's or the loop's own error. A lead whose weaker half gains less than a tenth is
//! not taken, and the report says no lead was found. The ripple of the period taken is then
//! fitted and judged as a template's would be: kept only where the held-out halves predict
//! better with it.

use rayon::prelude::*;

use super::RippleVerdict;
use super::columns::{self, Columns};
use crate::identify::solve::Fit;
use crate::machine::AxisConfig;

/// The leads tried (mm): the common ball-screw leads of makers' catalogues (2 to 50 mm).
/// Shorter ripples than 2 mm pass a table's loop at its speeds far above its crossover,
/// where they leave little to fit.
const LEADS_MM: [f64; 15] = [
    2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 8.0, 10.0, 12.0, 16.0, 20.0, 25.0, 32.0, 40.0, 50.0,
];

/// What the half that gains less from a lead must gain, as a share of its residual's energy
/// on its own samples, for the loop to be fitted again with that lead's ripple. The ripple
/// is kept only where it takes a twentieth off the held-out RMS, nearly a tenth of the
/// energy; a trial that does not take that much off the samples it was fitted to rarely
/// does so on samples it was not, and the refit costs as much as the fit before it. On
/// records of an independent integrator without a ripple the best lead's weaker half gained
/// up to 5 %; with one (12 N every 2.5 mm) 17 % and more, and 14 % and more on Y of a real
/// table whose motor turns every 10 mm.
const MIN_SHARE_GAINED: f64 = 0.1;

/// The lead both halves of the record gain most from with a ripple on top of `config` (a
/// loop fitted without one), each half's gain a share of its own samples' residual energy
/// (the larger of the two halves' smaller shares); none where no lead takes
/// [`MIN_SHARE_GAINED`] off both halves, where the axis travels less than two of a period
/// on the samples compared, or where no trial can be simulated.
pub(in crate::identify) fn chosen_mm(fit: &Fit, config: &AxisConfig) -> Option<f64> {
    let fold = fit.ctx().halves(fit.offset());
    let mask = fit.mask();
    let reductions: Vec<(f64, [f64; 2])> = LEADS_MM
        .par_iter()
        .filter(|&&p| columns::travel_covers(fit, 2.0 * p * 1e-3).is_ok())
        .filter_map(|&p| {
            let mut c = config.clone();
            c.errors.force_ripple_period_mm = p;
            c.errors.force_ripple_n = 0.0;
            let parts = Columns::force(fit, &c).ok()?;
            let gained = [true, false].map(|side| {
                let own = |i: usize| mask[i] && fold[i] == side;
                parts
                    .solve(&own)
                    .map_or(0.0, |ab| parts.share_gained(&own, ab))
            });
            Some((p, gained))
        })
        .collect();
    // The lead the half that gains less from it gains most from: one that only one half
    // gains from never wins, and a near tie of one half's (6 and 10 mm within 4 % on one
    // half of a real table's record, 10 mm clearly on the other) does not throw it out.
    reductions
        .iter()
        .map(|(p, [a, b])| (*p, a.min(*b)))
        .filter(|(_, worse)| *worse >= MIN_SHARE_GAINED)
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(p, _)| p)
}

/// What the report says of an axis where no lead was taken ([`chosen_mm`] found none).
pub(in crate::identify) fn none_found() -> RippleVerdict {
    RippleVerdict {
        written: false,
        statement: format!(
            "force ripple: none found (no ball-screw lead from {} to {} mm takes a tenth off \
             both halves' residual)",
            LEADS_MM[0],
            LEADS_MM[LEADS_MM.len() - 1]
        ),
        held_out_without_um: f64::NAN,
        held_out_force_um: f64::NAN,
        held_out_encoder_um: f64::NAN,
    }
}
