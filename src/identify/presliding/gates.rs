//! The gates a shape's fit on the whole record passes before its halves are fitted (a
//! round's two thirds): below the fit without bristles by a twentieth, Coulomb friction held
//! above its uncertainty, below the held-out share of the fit away from the standstills
//! where no shape reaches the noise, and close to the best shape's fit. Each refusal says
//! which bar no shape cleared.

use super::Shape;
use crate::identify::knobs::{COULOMB_KEY, Knob};
use crate::identify::solve::Fitted;
use crate::identify::verdict;
use crate::identify::within_noise;
use crate::numeric::units::um_from_m;

/// A shape's fit on the whole record, as the gates read it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct WholeFigures {
    /// The residual's sum of squares (m²) over the samples the fit compares …
    pub(super) cost_m2: f64,
    /// … and its RMS (µm).
    pub(super) rms_um: f64,
    /// The Coulomb force fitted and its uncertainty (N); none where it is not fitted.
    pub(super) coulomb_n: Option<(f64, f64)>,
}

impl WholeFigures {
    /// The figures of `whole` (of `knobs`) over the `samples` compared.
    pub(super) fn of(knobs: &[Knob], whole: &Fitted, samples: f64) -> WholeFigures {
        let j = knobs.iter().position(|k| k.key == COULOMB_KEY);
        WholeFigures {
            cost_m2: whole.cost,
            rms_um: um_from_m((whole.cost / samples).sqrt()),
            coulomb_n: j.map(|j| (whole.values[j], whole.sigma[j])),
        }
    }
}

/// What a shape's whole fit is measured against: the fit without bristles (sum of squares,
/// m², over the same samples), the record's noise and the axis's following error (RMS, µm).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Bars {
    pub(super) without_m2: f64,
    pub(super) noise_um: f64,
    pub(super) following_um: f64,
}

/// Why no shape goes on to the halves.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Refusal {
    /// The first-ranked shape's fit stays above the noise and does not come below this
    /// held-out share of the fit away from the standstills: that fit is written.
    FirstBelowShare(Shape, f64),
    /// (a) No shape's fit beats the fit without bristles by a twentieth.
    NoneBeatsWithout,
    /// (b) None of those holds a Coulomb force above its uncertainty.
    NoneHoldsCoulomb,
    /// (c) None reaches the noise, and none comes below this share.
    NoneBelowShare(f64),
}

impl Refusal {
    /// The reason as the axis's presliding verdict gives it.
    pub(super) fn reason(self) -> String {
        let below_share = |which: &str, share: f64| {
            format!(
                "{which} comes below {:.1} % of the following error even on the samples it \
                 was fitted to, where the fit away from the standstills predicts its held-out \
                 halves to that: it is written",
                100.0 * share
            )
        };
        match self {
            Refusal::FirstBelowShare(shape, share) => {
                let which = format!(
                    "the fit of the shape that explains the record best at the loop's values \
                     without bristles ({}; the other shapes not fitted) never",
                    shape.describe()
                );
                below_share(&which, share)
            }
            Refusal::NoneBeatsWithout => "no shape, the loop's values fitted again with it, \
                                          fits the whole record better by a twentieth"
                .to_string(),
            Refusal::NoneHoldsCoulomb => "no shape whose fit beats the fit without bristles \
                                          holds a Coulomb force above its own uncertainty, and \
                                          bristles bent by no friction carry no force"
                .to_string(),
            Refusal::NoneBelowShare(share) => below_share("no shape's fit", share),
        }
    }
}

/// The held-out share of the fit away from the standstills that the first-ranked shape's
/// fit (to `rms_um`) does not come below even on the samples it was fitted to, where that
/// keeps the others from being fitted: the fit stays above the noise, and `share` (none
/// where the fit away from the standstills is not written) is not beaten — then no shape can
/// win, and that fit is written. `share` costs that fit's halves: asked for only above the
/// noise, as in [`carried`].
pub(super) fn first_stops(
    rms_um: f64,
    bars: &Bars,
    share: &dyn Fn() -> Option<f64>,
) -> Option<f64> {
    if within_noise(rms_um, bars.noise_um) {
        return None;
    }
    share().filter(|s| rms_um >= s * bars.following_um)
}

/// The shapes (by index into `wholes`) carried to the halves: those whose fit (a) beats
/// the fit without bristles by the twentieth a larger model must earn, (b) holds Coulomb
/// friction above its uncertainty, (c) where none of those reaches the noise, comes below
/// the held-out share of the fit away from the standstills (`share`, asked for only there),
/// and (d) is not beaten by another carried shape's fit by a twentieth ([`near_the_best`]).
/// Why none is, where none is.
pub(super) fn carried(
    wholes: &[WholeFigures],
    bars: &Bars,
    share: &dyn Fn() -> Option<f64>,
) -> Result<Vec<usize>, Refusal> {
    let mut kept: Vec<usize> = (0..wholes.len())
        .filter(|&i| verdict::predicts_better(wholes[i].cost_m2.sqrt(), bars.without_m2.sqrt()))
        .collect();
    if kept.is_empty() {
        return Err(Refusal::NoneBeatsWithout);
    }
    kept.retain(|&i| wholes[i].coulomb_n.is_some_and(|(f, s)| coulomb_held(f, s)));
    if kept.is_empty() {
        return Err(Refusal::NoneHoldsCoulomb);
    }
    if !kept
        .iter()
        .any(|&i| within_noise(wholes[i].rms_um, bars.noise_um))
        && let Some(share) = share()
    {
        kept.retain(|&i| wholes[i].rms_um < share * bars.following_um);
        if kept.is_empty() {
            return Err(Refusal::NoneBelowShare(share));
        }
    }
    let costs: Vec<f64> = kept.iter().map(|&i| wholes[i].cost_m2).collect();
    Ok(near_the_best(&costs).into_iter().map(|k| kept[k]).collect())
}

/// The fits (by index; sums of squares `costs_m2`) that the best of them does not beat by
/// the twentieth a model must earn: the halves choose among the shapes the whole record
/// leaves close (a round is three fits; on the real table X's 50 N/µm at Coulomb's level
/// fits to 11.2 µm where 150 N/µm fits to 10.6, and is not carried to the halves). The
/// held-out halves still judge the shapes carried.
pub(super) fn near_the_best(costs_m2: &[f64]) -> Vec<usize> {
    let best = costs_m2.iter().copied().fold(f64::INFINITY, f64::min);
    (0..costs_m2.len())
        .filter(|&i| !verdict::predicts_better(best.sqrt(), costs_m2[i].sqrt()))
        .collect()
}

/// Whether a Coulomb force `coulomb_n` stands above its uncertainty `sigma_n`: the
/// bristles' deflection is bounded by the friction level over their stiffness, so at no
/// Coulomb friction they carry no force — whatever such a fit gains is the other values'
/// refit, not the bristles'. (Such fits are also the costly ones: the loop's values wander
/// where nothing holds the table, its mass with them, and the bristle damping set for the
/// template's mass then asks for sub-steps of some ten microseconds where the record has
/// one per millisecond.)
pub(super) fn coulomb_held(coulomb_n: f64, sigma_n: f64) -> bool {
    coulomb_n > sigma_n
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A whole fit to `rms_um` over 1000 samples holding `coulomb` (N, ±uncertainty).
    fn whole(rms_um: f64, coulomb: Option<(f64, f64)>) -> WholeFigures {
        let rms_m = rms_um * 1e-6;
        WholeFigures {
            cost_m2: rms_m * rms_m * 1000.0,
            rms_um,
            coulomb_n: coulomb,
        }
    }

    /// The fit without bristles to `without_um` over the same 1000 samples, noise 1 µm,
    /// following error 100 µm.
    fn bars(without_um: f64) -> Bars {
        Bars {
            without_m2: whole(without_um, None).cost_m2,
            noise_um: 1.0,
            following_um: 100.0,
        }
    }

    const HELD: Option<(f64, f64)> = Some((90.0, 5.0));

    #[test]
    fn the_first_shape_stops_the_others_only_above_the_noise_and_the_moving_share() {
        let b = bars(20.0);
        // At 1.1 times the noise (1.1 µm) a fit reaches it: never stops, whatever the share.
        assert!(within_noise(1.1, 1.0) && !within_noise(1.1001, 1.0));
        let never = || -> Option<f64> { panic!("the fit reaches the noise") };
        assert_eq!(first_stops(1.1, &b, &never), None);
        // Above it, with the fit away from the standstills written at 12.5 % of the 100 µm
        // following error: a fit to 12.5 µm or more stops the others, one just below does not.
        let share = || Some(0.125);
        assert_eq!(first_stops(12.5, &b, &share), Some(0.125));
        assert_eq!(first_stops(15.0, &b, &share), Some(0.125));
        assert_eq!(first_stops(12.499, &b, &share), None);
        // No fit away from the standstills written: nothing to compare with, the others fitted.
        assert_eq!(first_stops(15.0, &b, &|| None), None);
    }

    #[test]
    fn the_share_is_asked_for_only_where_the_first_fit_stays_above_the_noise() {
        // The share costs the fit away from the standstills its halves: a first fit at the
        // 1 µm noise (1.1 times it or less) decides without it, one above asks once.
        let b = bars(20.0);
        let asked = std::cell::Cell::new(0);
        let share = || {
            asked.set(asked.get() + 1);
            Some(0.001)
        };
        for rms_um in [0.5, 1.0, 1.1] {
            assert_eq!(first_stops(rms_um, &b, &share), None);
        }
        assert_eq!(asked.get(), 0);
        assert_eq!(first_stops(1.2, &b, &share), Some(0.001));
        assert_eq!(asked.get(), 1);
    }

    #[test]
    fn a_shape_goes_on_only_where_it_beats_the_fit_without_by_a_twentieth() {
        // Without bristles 10 µm: 9.49 µm is better by more than a twentieth (9.5 is the
        // edge), 9.51 µm is not; of two, only the one that beats it goes on.
        let b = bars(10.0);
        let never = || -> Option<f64> { panic!("a shape reaches the noise or none is left") };
        let got = carried(&[whole(9.49, HELD), whole(9.51, HELD)], &b, &|| None);
        assert_eq!(got, Ok(vec![0]));
        let got = carried(&[whole(9.51, HELD), whole(10.5, HELD)], &b, &never);
        assert_eq!(got, Err(Refusal::NoneBeatsWithout));
        assert_eq!(carried(&[], &b, &never), Err(Refusal::NoneBeatsWithout));
    }

    #[test]
    fn a_shape_whose_fit_holds_no_coulomb_force_goes_no_further() {
        let b = bars(10.0);
        // 20 N known to ±51 N, and a fit that does not hold Coulomb friction at all, against
        // 90 N known to ±5 N: only the last goes on, though it fits worse.
        let wholes = [
            whole(5.0, Some((20.0, 51.0))),
            whole(6.0, None),
            whole(8.0, HELD),
        ];
        assert_eq!(carried(&wholes, &b, &|| None), Ok(vec![2]));
        // At its uncertainty exactly it is not held.
        assert!(coulomb_held(5.001, 5.0) && !coulomb_held(5.0, 5.0));
        let got = carried(&wholes[..2], &b, &|| None);
        assert_eq!(got, Err(Refusal::NoneHoldsCoulomb));
    }

    #[test]
    fn above_the_noise_a_shape_must_come_below_the_moving_share() {
        let b = bars(20.0);
        // None reaches the 1 µm noise; the fit away from the standstills predicts its
        // held-out halves to 12.5 % of the 100 µm following error: 12.49 µm goes on, 12.5 µm
        // not.
        let share = || Some(0.125);
        let wholes = [whole(12.49, HELD), whole(12.5, HELD)];
        assert_eq!(carried(&wholes, &b, &share), Ok(vec![0]));
        let got = carried(&wholes[1..], &b, &share);
        assert_eq!(got, Err(Refusal::NoneBelowShare(0.125)));
        // No fit away from the standstills written: no such bar.
        assert_eq!(carried(&wholes[1..], &b, &|| None), Ok(vec![0]));
        // One shape reaches the noise: the share is not asked for, the others are not held
        // to it (the nearest-best bar still applies: 12.5 µm is not within a twentieth of
        // 1.05 µm).
        let never = || -> Option<f64> { panic!("a shape reaches the noise") };
        let wholes = [whole(1.05, HELD), whole(12.5, HELD)];
        assert_eq!(carried(&wholes, &b, &never), Ok(vec![0]));
    }

    #[test]
    fn only_the_shapes_within_a_twentieth_of_the_best_fit_go_on() {
        // The real table's X: 150 N/µm to 10.6 µm, 50 N/µm at Coulomb's level to 11.2 µm —
        // 10.6 < 0.95 × 11.2 = 10.64, so the latter is beaten; 11.15 µm is not (10.59). A fit
        // to 10.5 µm beats 11.15 (10.59) but not 10.6 (10.07).
        let costs = |rms: &[f64]| rms.iter().map(|r| r * r * 1e3).collect::<Vec<f64>>();
        assert_eq!(near_the_best(&costs(&[11.2, 10.6])), vec![1]);
        assert_eq!(near_the_best(&costs(&[11.15, 10.6, 10.5])), vec![1, 2]);
        assert_eq!(near_the_best(&costs(&[11.15, 10.6])), vec![0, 1]);
        assert!(near_the_best(&[]).is_empty());
        // Through `carried`, the indices are those of the shapes given, the ones dropped
        // earlier skipped: the first beats nothing, the second and fourth are close.
        let b = bars(20.0);
        let wholes = [
            whole(19.5, HELD),
            whole(10.6, HELD),
            whole(10.0, None),
            whole(11.15, HELD),
        ];
        assert_eq!(carried(&wholes, &b, &|| None), Ok(vec![1, 3]));
    }

    #[test]
    fn each_refusal_names_its_bar() {
        let shape = Shape::new(150.0, 0.7);
        let first = Refusal::FirstBelowShare(shape, 0.281).reason();
        assert!(
            first.contains("150 N/µm") && first.contains("28.1 %"),
            "{first}"
        );
        assert!(first.contains("the other shapes not fitted"), "{first}");
        assert!(
            Refusal::NoneBeatsWithout
                .reason()
                .contains("by a twentieth")
        );
        assert!(Refusal::NoneHoldsCoulomb.reason().contains("Coulomb force"));
        assert!(Refusal::NoneBelowShare(0.125).reason().contains("12.5 %"));
    }
}
