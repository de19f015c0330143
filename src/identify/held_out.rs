//! Whether an axis's held-out figure was measured on samples its fit did not see.
//!
//! Each half's fit starts where the fit on the whole record landed. A half whose search
//! finds no step of its own (`Fitted::own_point`) stays at values fitted to the other half
//! as well: its residual there is not held out. Above the noise, where only such halves
//! count, a round whose halves both stayed has no held-out figure at all; the figure then
//! shown is the whole fit scored on samples it was fitted to, and it is said so.

use super::AxisIdentification;
use super::verdict;
use crate::numeric::units::um_from_m;

/// The held-out figure of a fit (µm), from `own` — the RMS (m) of the halves' fits with a
/// point of its own, `Some(None)` where neither has one, `None` where only such halves were
/// not asked for (a fit at the noise) — and `all_halves`, the RMS of both halves' fits
/// whatever their points: where neither half has a point of its own, that is the whole fit's
/// in-sample figure, which the axis then marks (`held_out_in_sample`, from whether the
/// figure written is shown by such a half). None where it cannot be simulated.
pub(super) fn figure(
    own: Option<Option<f64>>,
    all_halves: impl FnOnce() -> Option<f64>,
) -> Option<f64> {
    match own {
        Some(Some(own_m)) => Some(um_from_m(own_m)),
        _ => all_halves().map(um_from_m),
    }
}

/// Whether the larger model `more` is kept over `fewer`: where both figures are of one kind
/// (held out, or both in-sample), where it predicts the held-out halves better by more than
/// a twentieth ([`verdict::predicts_better`]). A figure measured on samples the fit did not
/// see always wins over an in-sample one, whatever the two numbers: an in-sample figure is
/// lower than the same fit's held-out one would be, and the candidate it belongs to is
/// never written (`better_than_template` needs a figure shown held out), so letting it win
/// would leave the axis NOT IDENTIFIED where the other candidate was a valid model.
pub(super) fn predicts_better(more: &AxisIdentification, fewer: &AxisIdentification) -> bool {
    kept_over(
        (more.held_out_identified_um, more.held_out_in_sample),
        (fewer.held_out_identified_um, fewer.held_out_in_sample),
    )
}

/// [`predicts_better`] on the figures alone: each (µm, whether it is in-sample).
pub(super) fn kept_over(
    (more_um, more_in): (f64, bool),
    (fewer_um, fewer_in): (f64, bool),
) -> bool {
    match (more_in, fewer_in) {
        (true, false) => false,
        (false, true) => true,
        _ => verdict::predicts_better(more_um, fewer_um),
    }
}

/// The fit's held-out figure in words, after the template's: "→ 0.300 µm", or where it is
/// in-sample, that no held-out figure was measured and what the in-sample one is.
pub(crate) fn identified_words(a: &AxisIdentification) -> String {
    if a.held_out_in_sample {
        format!(
            "→ not measured (the halves' fits did not move from the whole fit's; in-sample \
             {:.3} µm)",
            a.held_out_identified_um
        )
    } else {
        format!("→ {:.3} µm", a.held_out_identified_um)
    }
}

/// Where the fit's held-out figure is in-sample, a note saying so beside a table that shows
/// it in the held-out row.
#[cfg(any(test, feature = "html-report"))]
pub(crate) fn in_sample_note(a: &AxisIdentification) -> Option<String> {
    a.held_out_in_sample.then(|| {
        format!(
            "Held out not measured: the halves' fits did not move from the whole fit's, so the \
             fit's figure in the held-out row ({:.3} µm) is in-sample.",
            a.held_out_identified_um
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_figure_of_halves_that_stayed_at_the_whole_fit_is_theirs_on_all_samples() {
        // Neither half moved: the figure of both halves, 2 µm (the whole fit's, in-sample).
        assert_eq!(figure(Some(None), || Some(2e-6)), Some(2.0));
        // A half of its own: its figure, held out.
        assert_eq!(figure(Some(Some(3e-6)), || Some(2e-6)), Some(3.0));
        // At the noise both halves count.
        assert_eq!(figure(None, || Some(5e-7)), Some(0.5));
        // Halves that cannot be simulated give no figure.
        assert_eq!(figure(Some(None), || None), None);
    }

    /// An axis fitted above the noise whose halves' fits stayed at the whole fit's values:
    /// the template predicts its halves to 0.42 µm, the fit its own samples to 0.31 µm.
    fn stayed() -> AxisIdentification {
        AxisIdentification {
            reached: false,
            held_out_in_sample: true,
            ..AxisIdentification::scored(0.42, 0.31)
        }
    }

    #[test]
    fn an_in_sample_figure_is_never_shown_as_held_out() {
        let a = stayed();
        let words = identified_words(&a);
        assert!(words.contains("not measured"), "{words}");
        assert!(words.contains("in-sample 0.310 µm"), "{words}");
        let note = in_sample_note(&a).expect("a note where the figure is in-sample");
        assert!(note.contains("(0.310 µm) is in-sample"), "{note}");
        /// The axes as the JSON report writes them.
        #[derive(serde::Serialize)]
        struct Report {
            #[serde(serialize_with = "crate::identify::result::axes_json")]
            axes: Vec<AxisIdentification>,
        }
        let json = serde_json::to_value(Report {
            axes: vec![a.clone()],
        })
        .unwrap();
        let axis = &json["axes"][0];
        assert_eq!(axis["held_out_in_sample"], true, "{json}");
        assert_eq!(axis["judged_held_out"]["in_sample"], true, "{json}");
        assert_eq!(axis["judged_held_out"]["identified_um"], 0.31, "{json}");
        // Held out, it is shown as it is, with no note.
        let measured = AxisIdentification {
            held_out_in_sample: false,
            ..a
        };
        assert_eq!(identified_words(&measured), "→ 0.310 µm");
        assert!(in_sample_note(&measured).is_none());
    }

    /// An axis above the noise whose fit predicts its halves to `identified_um` (µm),
    /// held out or in-sample, against the template's 1.0 µm.
    fn candidate(identified_um: f64, in_sample: bool) -> AxisIdentification {
        AxisIdentification {
            reached: false,
            held_out_in_sample: in_sample,
            better_than_template: !in_sample,
            ..AxisIdentification::scored(1.0, identified_um)
        }
    }

    #[test]
    fn an_in_sample_figure_never_wins_against_a_held_out_one() {
        let held_out = candidate(0.8, false);
        // In-sample at a quarter of the held-out figure: still not kept over it.
        let in_sample = candidate(0.2, true);
        assert!(!predicts_better(&in_sample, &held_out));
        // And the held-out one is kept over it though its figure is four times higher.
        assert!(predicts_better(&held_out, &in_sample));
        // Of one kind, by the twentieth: 0.75 < 0.95 × 0.8 = 0.76; 0.77 is not.
        assert!(predicts_better(&candidate(0.75, false), &held_out));
        assert!(!predicts_better(&candidate(0.77, false), &held_out));
        assert!(predicts_better(&candidate(0.15, true), &in_sample));
        assert!(!predicts_better(&candidate(0.195, true), &in_sample));
    }
}
