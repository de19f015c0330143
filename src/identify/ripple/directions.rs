//! Whether a ripple fitted acts at the same phase of position whichever way the axis moves.
//!
//! A force that repeats with the table's position, F = A·sin(2π·x/p + φ), pushes at the same
//! phase of x moving + or −: its sine and cosine parts fitted on the samples of each
//! direction apart agree. An error that repeats with time or with the program — a
//! disturbance of a steady frequency, the loop model's own error at the program's feeds —
//! can look like a ripple of one period in each direction, but its phase against the
//! position is set by when each pass starts, and need not agree. Where the record passes a
//! period of travel each way, the two phases are compared; where they differ beyond their
//! uncertainty, the ripple is not a force of the position.

use super::columns::Parts;
use crate::identify::Sliding;
use crate::identify::solve::Fit;

/// How many of their combined uncertainties the two directions' phases may differ by for
/// the ripple to be taken as one force of the position.
const K_SIGMA: f64 = 3.0;

/// The phases of the ripple fitted on each direction's samples apart.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum Directions {
    /// Both fitted: moving + and moving −, each (phase °, its uncertainty °).
    Compared { plus: (f64, f64), minus: (f64, f64) },
    /// Not compared, and why.
    NotCompared(String),
}

impl Directions {
    /// The ripple's parts fitted on `parts`'s columns over the samples the fit compares
    /// where the axis slides each way, each direction's uncertainty the spread of its fits
    /// on the record's two halves (`fold`), not below its least-squares floor.
    pub(super) fn of(fit: &Fit, parts: &Parts, fold: &[bool], period_m: f64) -> Directions {
        let ctx = fit.ctx();
        let sliding = Sliding::of(ctx, fit.axis());
        let direction: Vec<f64> = ctx
            .samples
            .iter()
            .map(|&i| {
                let t = ctx.prog_time(i, fit.offset());
                if sliding.settled_at(ctx, t) {
                    sliding.direction_at(ctx, t)
                } else {
                    0.0
                }
            })
            .collect();
        let mask = fit.mask();
        let x = ctx.measured_axis(fit.axis());
        let one_way = |sign: f64| -> Result<(f64, f64), String> {
            let on = |i: usize| mask[i] && direction[i] == sign;
            let travel = travel_m(&ctx.samples, x, &on);
            if travel < period_m {
                return Err(format!(
                    "moving {} the axis travels {:.3} mm on the samples compared, less than \
                     a period",
                    if sign > 0.0 { "+" } else { "−" },
                    travel * 1e3
                ));
            }
            let ab = parts.solve(&on)?;
            let floor = parts.least_squares_sigma(&on, ab);
            let halves = [true, false].map(|side| parts.solve(&|i| on(i) && fold[i] == side));
            let spread = match halves {
                [Ok((a0, b0)), Ok((a1, b1))] => 0.5 * (a0 - a1).hypot(b0 - b1),
                _ => f64::INFINITY,
            };
            Ok(phase_of(ab, spread.max(floor)))
        };
        match (one_way(1.0), one_way(-1.0)) {
            (Ok(plus), Ok(minus)) => Directions::Compared { plus, minus },
            (Err(why), _) | (_, Err(why)) => Directions::NotCompared(why),
        }
    }

    /// The two phases' difference (°, within ±180) and its uncertainty (°), where compared.
    fn difference(&self) -> Option<(f64, f64)> {
        let Directions::Compared { plus, minus } = self else {
            return None;
        };
        let d = (plus.0 - minus.0 + 540.0).rem_euclid(360.0) - 180.0;
        Some((d, plus.1.hypot(minus.1)))
    }

    /// Why the ripple is not a force of the position: the phases differ by more than
    /// [`K_SIGMA`] of their uncertainty. None where they agree or were not compared.
    pub(super) fn differ(&self) -> Option<String> {
        let (d, sigma) = self.difference()?;
        let Directions::Compared { plus, minus } = self else {
            return None;
        };
        (d.abs() > K_SIGMA * sigma).then(|| {
            format!(
                "the phase differs between directions: {:.1} ± {:.1}° moving +, {:.1} ± \
                 {:.1}° moving −, {d:.1}° apart where a force that repeats with the \
                 position acts at the same phase either way (the model's own lag at the \
                 ripple's frequency shifts the two apart as well): not shown to be a force of \
                 the position",
                plus.0, plus.1, minus.0, minus.1
            )
        })
    }

    /// The clause a ripple written adds to its statement: that its phases show no difference,
    /// or that they were not compared where [`K_SIGMA`] of their uncertainty spans a quarter
    /// turn (no difference that matters could have shown).
    pub(super) fn clause(&self) -> String {
        match (self, self.difference()) {
            (Directions::Compared { .. }, Some((d, sigma))) if K_SIGMA * sigma >= 90.0 => {
                format!(
                    "; its phase moving + and moving − not compared: each direction alone fixes \
                     it too loosely ({d:.1} ± {sigma:.1}° apart)"
                )
            }
            (Directions::Compared { .. }, Some((d, sigma))) => {
                format!(
                    "; its phase moving + and moving − shows no difference ({d:.1} ± {sigma:.1}° \
                     apart)"
                )
            }
            (Directions::NotCompared(why), _) => {
                format!("; its phase not compared between directions ({why})")
            }
            _ => String::new(),
        }
    }
}

/// The phase (°) of the parts `(a, b)` = A·(cos φ, sin φ), and its uncertainty (°) where the
/// parts are known to `sigma` (N): the largest turn a vector of that length moves them by,
/// all of 180° where it is as long as they are.
fn phase_of((a, b): (f64, f64), sigma: f64) -> (f64, f64) {
    let amplitude = a.hypot(b);
    let uncertainty = if sigma < amplitude {
        (sigma / amplitude).asin().to_degrees()
    } else {
        180.0
    };
    (b.atan2(a).to_degrees(), uncertainty)
}

/// The span of positions `x` (m) at the samples `on` allows.
fn travel_m(samples: &[usize], x: &[f64], on: &dyn Fn(usize) -> bool) -> f64 {
    let (lo, hi) = samples
        .iter()
        .enumerate()
        .filter(|(k, _)| on(*k))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), (_, &i)| {
            (lo.min(x[i]), hi.max(x[i]))
        });
    (hi - lo).max(0.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn phases_that_differ_beyond_three_of_their_uncertainties_differ() {
        // 10° and 50°, each known to 5°: 40° apart against 7.07°, beyond three.
        let d = Directions::Compared {
            plus: (10.0, 5.0),
            minus: (50.0, 5.0),
        };
        let why = d.differ().expect("40° apart");
        assert!(why.contains("-40.0° apart"), "{why}");
        // Across ±180°: 175° and −175° are 10° apart, within three of 7.07°.
        let d = Directions::Compared {
            plus: (175.0, 5.0),
            minus: (-175.0, 5.0),
        };
        assert_eq!(d.differ(), None);
        assert!(
            d.clause().contains("shows no difference (-10.0 ±"),
            "{}",
            d.clause()
        );
        // Each known to 25°: three of their 35.4° span more than a quarter turn, and nothing
        // is said of a difference; at 20° (three of 28.3° = 85°) no difference is shown.
        let loose = |sigma: f64| Directions::Compared {
            plus: (10.0, sigma),
            minus: (50.0, sigma),
        };
        assert_eq!(loose(25.0).differ(), None);
        let clause = loose(25.0).clause();
        assert!(clause.contains("too loosely (-40.0 ±"), "{clause}");
        let clause = loose(20.0).clause();
        assert!(clause.contains("shows no difference (-40.0 ±"), "{clause}");
    }

    #[test]
    fn a_phase_as_uncertain_as_its_amplitude_is_all_of_half_a_turn() {
        // sin 30° = 1/2: a sigma half the amplitude turns the phase by up to 30°.
        let (phase, sigma) = phase_of((0.0, 2.0), 1.0);
        assert!((phase - 90.0).abs() < 1e-12 && (sigma - 30.0).abs() < 1e-9);
        assert_eq!(phase_of((1.0, 0.0), 1.5).1, 180.0);
    }
}
