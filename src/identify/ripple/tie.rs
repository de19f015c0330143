//! The force ripple against a cyclic error in the positions recorded of the same period: which of the two the
//! held-out halves keep, and whether the record tells them apart.

use super::{IdentifiedValue, RippleVerdict};
use crate::identify::verdict::predicts_better;
use crate::numeric::units::{mm_from_m, um_from_m};

/// What the held-out halves say of a ripple of the template's period.
#[derive(Clone, PartialEq, Debug)]
enum Outcome {
    /// Not fitted.
    None,
    /// Neither the force nor the encoder's error predicts the halves better by a twentieth.
    NeitherHelps,
    /// The force does, and predicts each half better than the encoder's error by a
    /// twentieth.
    Force,
    /// The force does, and neither it nor the encoder's error predicts each half better than
    /// the other by a twentieth: the record cannot tell them apart (the force is written as
    /// the model's value only, whichever held-out figure is the lower).
    CannotTell,
    /// The encoder's error does and predicts each half better than the force by a twentieth.
    Encoder,
    /// The encoder's error does, the force does not, and the halves do not tell them apart.
    EncoderOnly,
    /// The halves kept the force, but the record says it is not a force of the position,
    /// for the reason given.
    Refused(String),
}

/// The held-out figures of a ripple on the halves counted, and what they say.
pub(super) struct Tie {
    /// Held-out RMS (m) over the halves counted: without a ripple, with the force, with the
    /// encoder's error.
    without_m: f64,
    pub(super) force_m: f64,
    encoder_m: f64,
    outcome: Outcome,
}

impl Tie {
    /// No ripple fitted.
    pub(super) fn none() -> Tie {
        Tie {
            without_m: f64::NAN,
            force_m: f64::NAN,
            encoder_m: f64::NAN,
            outcome: Outcome::None,
        }
    }

    /// The halves' figures (each half's held-out sums of squares without a ripple, with the
    /// force, with the positions' cyclic error, and how many samples they are over), of the
    /// halves `counted` allows.
    pub(super) fn of(halves: &[([f64; 3], usize); 2], counted: [bool; 2]) -> Tie {
        let counted: Vec<&([f64; 3], usize)> = halves
            .iter()
            .zip(counted)
            .filter(|(_, c)| *c)
            .map(|(h, _)| h)
            .collect();
        let n = counted.iter().map(|h| h.1).sum::<usize>();
        if n == 0 {
            return Tie::none();
        }
        let rms = |k: usize| (counted.iter().map(|h| h.0[k]).sum::<f64>() / n as f64).sqrt();
        let [without_m, force_m, encoder_m] = [0, 1, 2].map(rms);
        // Each half on its own samples: one alternative wins only where it predicts every
        // half better than the other by the twentieth a larger model must earn.
        let on_each = |k: usize, other: usize| {
            counted.iter().all(|h| {
                let per = |j: usize| (h.0[j] / h.1.max(1) as f64).sqrt();
                predicts_better(per(k), per(other))
            })
        };
        let force_helps = predicts_better(force_m, without_m);
        let encoder_helps = predicts_better(encoder_m, without_m);
        let outcome = if force_helps && on_each(1, 2) {
            Outcome::Force
        } else if encoder_helps && on_each(2, 1) {
            Outcome::Encoder
        } else if force_helps {
            Outcome::CannotTell
        } else if encoder_helps {
            Outcome::EncoderOnly
        } else {
            Outcome::NeitherHelps
        };
        Tie {
            without_m,
            force_m,
            encoder_m,
            outcome,
        }
    }

    /// The same figures with the force not written, for `why`.
    pub(super) fn refused(&self, why: String) -> Tie {
        Tie {
            outcome: Outcome::Refused(why),
            ..*self
        }
    }

    /// Whether the force ripple is written.
    pub(super) fn force_written(&self) -> bool {
        matches!(self.outcome, Outcome::Force | Outcome::CannotTell)
    }

    /// What the written amplitude and phase trade with: the amplitude with the fitted mass
    /// (the record fixes a force only per unit of the inertia it moves, which trades with
    /// the gain), both with a cyclic error in the positions recorded of the same period.
    /// Even where the force predicts the halves clearly better than that error, one the
    /// loop reads as well is not excluded: below the crossover the loop follows it, and it
    /// moves the table as a force of the same period would.
    pub(super) fn trades(&self) -> (&'static str, &'static str) {
        (
            "drive.table_mass_kg (the record fixes the force per mass) and with a cyclic error \
             in the positions recorded of the same period, read by the loop",
            "a cyclic error in the positions recorded of the same period, read by the loop \
             (the record does not tell a force from it)",
        )
    }

    /// The statement of the outcome: `values` the force's amplitude and phase as written,
    /// `encoder` the encoder's error fitted on the whole record instead (m; none where it
    /// could not be).
    pub(super) fn verdict(
        &self,
        values: &[IdentifiedValue; 2],
        encoder: Option<(f64, f64)>,
        period_m: f64,
    ) -> RippleVerdict {
        let [w, f, e] = [self.without_m, self.force_m, self.encoder_m].map(um_from_m);
        let figures = format!(
            "held out {f:.3} µm with it, {e:.3} µm as a cyclic error in the positions \
             recorded, {w:.3} µm without"
        );
        let encoder = encoder.map_or("not fitted".to_string(), |(a, b)| {
            format!(
                "{:.3} µm at {:.1}° as the record shows it: below the loop's crossover the \
                 loop follows an error it reads, and the encoder's own is larger",
                um_from_m(a.hypot(b)),
                b.atan2(a).to_degrees()
            )
        });
        let [amplitude, phase] = values;
        let force = format!(
            "{:.4} ± {:.2} N at {:.1} ± {:.1}° every {:.3} mm",
            amplitude.value,
            amplitude.uncertainty,
            phase.value,
            phase.uncertainty,
            mm_from_m(period_m)
        );
        let statement = match &self.outcome {
            Outcome::None => {
                "force ripple: not determined (no half's fit holds a held-out figure)".to_string()
            }
            Outcome::Force => format!(
                "force ripple: {force}, a model's value: as a force it predicts each held-out \
                 half better by a twentieth than a cyclic error in the positions recorded of \
                 the same period ({figures}); one the loop reads as well is not excluded \
                 (below the crossover it acts as a force would)"
            ),
            Outcome::CannotTell => format!(
                "force ripple: the record cannot tell a force from a cyclic error in the \
                 positions recorded of the same period ({encoder}): neither predicts each \
                 held-out half better than the other by a twentieth ({figures}); written as \
                 a force, {force}, the model's value only"
            ),
            Outcome::Encoder => format!(
                "force ripple: not determined (a cyclic error in the positions recorded of the \
                 same period, {encoder}, predicts each held-out half better than a force by a \
                 twentieth; {figures})"
            ),
            Outcome::EncoderOnly => format!(
                "force ripple: not determined (as a force it predicts the held-out halves no \
                 better by a twentieth; as a cyclic error in the positions recorded of the \
                 same period, {encoder}, it does, but not each half clearly better than the \
                 force; {figures})"
            ),
            Outcome::Refused(why) => {
                format!("force ripple: not determined ({why}; {figures})")
            }
            Outcome::NeitherHelps => format!(
                "force ripple: not determined (the held-out halves predict no better with it \
                 by a twentieth, as a force or as a cyclic error in the positions recorded: \
                 {figures})"
            ),
        };
        RippleVerdict {
            written: self.force_written(),
            statement,
            held_out_without_um: w,
            held_out_force_um: f,
            held_out_encoder_um: e,
        }
    }
}
