//! A ripple's period where no template names one (`--template none`): looked for among the
//! leads ball screws are made with, each lead's ripple fitted on one half of the record and
//! scored on the other.
//!
//! A motor's torque ripple and a screw's eccentricity repeat once per motor turn — on a
//! direct-driven ball screw, once per lead. The leads makers offer are few, so each is
//! tried: a trial ripple of that period on the loop fitted without one (two simulations a
//! lead beside the one without a ripple, which all leads share), its sine and cosine parts
//! fitted by least squares on one half of the record and scored on the other, both ways.
//! The period taken is the one that predicts best the half it was not fitted on that gains
//! less — the largest of each lead's smaller share of the residual's energy taken off —: a
//! period only one half gains from is the noise's or the loop's own error, and a half's
//! samples never vote for the parts fitted on them. A lead whose weaker half gains less than
//! a tenth is not taken, and the report says no lead was found. The ripple of the period
//! taken is then fitted and judged as a template's would be: kept only where the held-out
//! halves predict better with it.

use rayon::prelude::*;

use super::columns::{self, Columns, Parts};
use super::{RippleVerdict, with_ripple};
use crate::identify::solve::Fit;
use crate::machine::AxisConfig;

/// The leads tried (mm): the common ball-screw leads of makers' catalogues (2 to 50 mm).
/// Shorter ripples than 2 mm pass a table's loop at its speeds far above its crossover,
/// where they leave little to fit.
const LEADS_MM: [f64; 15] = [
    2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 8.0, 10.0, 12.0, 16.0, 20.0, 25.0, 32.0, 40.0, 50.0,
];

/// What the half that gains less from a lead must gain, as a share of its residual's energy,
/// from the ripple's parts fitted on the other half, for the loop to be fitted again with
/// that lead's ripple. The ripple is kept only where it takes a twentieth off the held-out
/// RMS, nearly a tenth of the energy; a trial on top of the loop that does not take that
/// much off rarely does once the loop is fitted again with it, and the refit costs as much
/// as the fit before it.
const MIN_SHARE_GAINED: f64 = 0.1;

/// Why no lead was taken.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(in crate::identify) enum NoLead {
    /// The best lead (mm) takes this share (below [`MIN_SHARE_GAINED`]) off the half that
    /// gains less from it.
    Weak { lead_mm: f64, share: f64 },
    /// The axis travels less than two periods of the shortest lead on the samples compared.
    TooShort,
    /// No trial ripple could be simulated.
    NotSimulated,
}

/// The lead whose ripple on top of `config` (a loop fitted without one), fitted on either
/// half of the record, takes most off the other half's residual — the largest of each lead's
/// smaller share of the two ([`held_out_share`]) —, where that reaches [`MIN_SHARE_GAINED`];
/// why none is taken otherwise. Leads the axis travels less than two periods of are not
/// tried.
pub(in crate::identify) fn chosen_mm(fit: &Fit, config: &AxisConfig) -> Result<f64, NoLead> {
    let fold = fit.ctx().halves(fit.offset());
    let mask = fit.mask();
    let leads: Vec<f64> = LEADS_MM
        .into_iter()
        .filter(|&p| columns::travel_covers(fit, 2.0 * p * 1e-3).is_ok())
        .collect();
    if leads.is_empty() {
        return Err(NoLead::TooShort);
    }
    let r0 = fit
        .residual(&with_ripple(config, (0.0, 0.0)))
        .ok_or(NoLead::NotSimulated)?;
    let shares: Vec<(f64, f64)> = leads
        .par_iter()
        .filter_map(|&p| {
            let mut c = config.clone();
            c.errors.force_ripple_period_mm = p;
            let parts = Columns::force_beside(fit, &c, r0.clone()).ok()?;
            Some((p, held_out_share(&parts, mask, &fold)))
        })
        .collect();
    // The lead whose weaker direction gains most: one that only the parts fitted on one
    // half carry to the other never wins, and a near tie in one direction does not throw
    // out a lead the other direction prefers clearly.
    let best = shares.into_iter().max_by(|a, b| a.1.total_cmp(&b.1));
    match best {
        None => Err(NoLead::NotSimulated),
        Some((lead_mm, share)) if share >= MIN_SHARE_GAINED => Ok(lead_mm),
        Some((lead_mm, share)) => Err(NoLead::Weak { lead_mm, share }),
    }
}

/// The smaller of the two shares of a half's residual energy the ripple's parts fitted on
/// the other half take off (0 where a half's parts cannot be placed).
fn held_out_share(parts: &Parts, mask: &[bool], fold: &[bool]) -> f64 {
    [true, false]
        .map(|fitted_on| {
            let on = |i: usize| mask[i] && fold[i] == fitted_on;
            let other = |i: usize| mask[i] && fold[i] != fitted_on;
            parts
                .solve(&on)
                .map_or(0.0, |ab| parts.share_gained(&other, ab))
        })
        .into_iter()
        .fold(f64::INFINITY, f64::min)
}

/// What the report says of an axis where no lead was taken, and why.
pub(in crate::identify) fn not_taken(why: NoLead) -> RippleVerdict {
    let (first, last) = (LEADS_MM[0], LEADS_MM[LEADS_MM.len() - 1]);
    let statement = match why {
        NoLead::Weak { lead_mm, share } if share > 0.0 => format!(
            "force ripple: none found (no ball-screw lead tried, {first} to {last} mm where \
             the axis travels two periods, fitted on either half of the record takes a tenth \
             off the other half's residual: the best, {lead_mm} mm, {:.0} %)",
            100.0 * share
        ),
        NoLead::Weak { .. } => format!(
            "force ripple: none found (no ball-screw lead tried, {first} to {last} mm where \
             the axis travels two periods, fitted on either half of the record takes \
             anything off the other half's residual)"
        ),
        NoLead::TooShort => format!(
            "force ripple: not looked for (the axis travels less than two periods of the \
             shortest ball-screw lead, {first} mm, on the samples compared)"
        ),
        NoLead::NotSimulated => {
            "force ripple: not looked for (the axis cannot be simulated with a trial ripple)"
                .to_string()
        }
    };
    RippleVerdict {
        written: false,
        statement,
        held_out_without_um: f64::NAN,
        held_out_force_um: f64::NAN,
        held_out_encoder_um: f64::NAN,
    }
}

/// The clause a ripple written at a lead looked for adds to its statement: the record's
/// halves run the same program, so an error of the loop model that repeats with the
/// program's positions would pass as well.
pub(in crate::identify) const LOOKED_FOR: &str = "; its period looked for among ball-screw \
    leads without a template: it may be the loop model's own error repeating with the \
    program's positions";

#[cfg(test)]
mod tests {
    use super::*;

    /// 400 samples, the first 200 one half and the rest the other; columns of a ripple 50
    /// samples long, and the residual `r0` given.
    fn ripple_parts(r0: impl Fn(usize, f64, f64) -> f64) -> (Parts, Vec<bool>) {
        let phase = |i: usize| std::f64::consts::TAU * i as f64 / 50.0;
        let (s, c): (Vec<f64>, Vec<f64>) =
            (0..400).map(|i| (phase(i).sin(), phase(i).cos())).unzip();
        let r = (0..400).map(|i| r0(i, s[i], c[i])).collect();
        let fold = (0..400).map(|i| i < 200).collect();
        (Parts::given(r, s, c), fold)
    }

    /// A lead is judged by the half that gains less from the parts fitted on the other.
    #[test]
    fn a_lead_is_judged_by_the_half_that_gains_less_from_the_others_parts() {
        let mask = vec![true; 400];
        // The residual is a ripple of parts (3, 1) all along: fitted on either half, the
        // parts are (3, 1) and take all of the other half's residual off.
        let (both, fold) = ripple_parts(|_, s, c| -(3.0 * s + c));
        let share = held_out_share(&both, &mask, &fold);
        assert!((share - 1.0).abs() < 1e-9, "{share}");
        // The second half holds half of that ripple beside a wave of another period
        // (orthogonal to the ripple's columns over its 200 samples, four of their periods).
        // Its parts, (1.5, 0.5), take three quarters off the first half; the first's, (3, 1),
        // overshoot the second's ripple by as much as they take off it: nothing gained. The
        // half that gains less decides.
        let wave = |i: usize| (std::f64::consts::TAU * i as f64 / 25.0).sin();
        let (unequal, fold) = ripple_parts(|i, s, c| {
            if i < 200 {
                -(3.0 * s + c)
            } else {
                -0.5 * (3.0 * s + c) + wave(i)
            }
        });
        let second = unequal.solve(&|i| !fold[i]).unwrap();
        let first_gains = unequal.share_gained(&|i| fold[i], second);
        assert!((first_gains - 0.75).abs() < 1e-9, "{first_gains}");
        let share = held_out_share(&unequal, &mask, &fold);
        assert!(share.abs() < 1e-9 && share < MIN_SHARE_GAINED, "{share}");
    }

    /// Why no lead was taken, said with the figures that decided it: the best lead's share
    /// in whole percent, the leads' span (2 to 50 mm) and the shortest lead where the travel
    /// is too short for any.
    #[test]
    fn no_lead_taken_says_why_with_the_figures() {
        let weak = not_taken(NoLead::Weak {
            lead_mm: 5.0,
            share: 0.064,
        });
        assert!(!weak.written);
        assert!(
            weak.statement.starts_with("force ripple: none found (")
                && weak.statement.contains("2 to 50 mm")
                && weak.statement.contains("the best, 5 mm, 6 %)"),
            "{}",
            weak.statement
        );
        let nothing = not_taken(NoLead::Weak {
            lead_mm: 5.0,
            share: 0.0,
        });
        assert!(
            nothing.statement.starts_with("force ripple: none found (")
                && !nothing.statement.contains('%'),
            "{}",
            nothing.statement
        );
        let short = not_taken(NoLead::TooShort);
        assert!(
            short
                .statement
                .starts_with("force ripple: not looked for (")
                && short.statement.contains("shortest ball-screw lead, 2 mm"),
            "{}",
            short.statement
        );
        for v in [weak, nothing, short] {
            assert!(v.held_out_force_um.is_nan() && v.held_out_without_um.is_nan());
        }
    }
}
