//! Whether an axis holding still hunts: the model's trace in a hold judged against its own
//! rest, and the record's against its own arrival at the command.
//!
//! A linear loop — however many integrators, without friction — settles into a hold along
//! decaying modes: once it has come to rest it only creeps on, each stretch less than the one
//! before, and where it swings it swings less each time. A loop whose integral action holds
//! the table against static friction above the Coulomb level does not: it sticks, winds,
//! breaks away and sticks again, a limit cycle. These functions tell the two apart on one
//! hold's samples, so that a hold is left out of the point-by-point comparison only where a
//! cycle whose phase no model times is there, never for the ordinary settle.

/// How far the model must move in a stretch of [`QUIET_S`], after it has once come to rest
/// within it, to count as hunting (m): far above the simulation's rounding, far below any
/// slip of a table breaking away.
pub(super) const HUNTING_M: f64 = 0.02e-6;
/// How long the model must stand within [`HUNTING_M`] to count as at rest (s): longer than a
/// stick at a reversal of the approach lasts, far shorter than a hunting cycle (its
/// integrator winds against static friction for a good part of a second).
pub(super) const QUIET_S: f64 = 0.05;
/// How close to its command a holding axis must have come to count as arrived (m): beyond
/// the approach, which the comparison keeps, and wide enough for any hunting.
pub(super) const SETTLED_M: f64 = 2e-6;
/// A swing at least this share of the swing before it is not decaying: a lightly damped linear mode loses more than a twentieth a half cycle at a
/// damping ratio above 1.6 %, which no servo loop is designed to.
const SUSTAINED_SHARE: f64 = 0.95;
/// How many times the noise of an average over [`QUIET_S`] a record's averages must spread
/// by to count as moving: two of them differ by √2 times that noise, so a record at rest
/// passes a pair beyond it about twice in a hundred thousand.
const RECORD_NOISE_MULTIPLE: f64 = 6.0;
/// How many successive averages over [`QUIET_S`] of a record must lie within its threshold
/// for it to count as at rest (0.2 s): longer than the crest of a slow swing of its settle
/// (an overshoot creeping back over a few tenths of a second stands about 0.1 s within the
/// threshold there), shorter than the stick of a hunting cycle, whose integrator winds for a
/// good part of a second.
const RECORD_REST_MEANS: usize = 4;

/// Where in a hold the model `model` (one value per sample, `quiet` samples to [`QUIET_S`])
/// starts to hunt, or `None` where it does not: [`hunts_from`] with rest meaning a window
/// of `quiet` samples within [`HUNTING_M`].
pub(super) fn model_hunts_from(model: &[f64], quiet: usize) -> Option<usize> {
    let rule = Rule {
        rest_m: HUNTING_M,
        moves_m: HUNTING_M,
        shrink_m: 0.0,
    };
    hunts_from(model, quiet, &rule)
}

/// Where in a hold a record (`record`, from its arrival within [`SETTLED_M`] of its command,
/// `quiet` samples to [`QUIET_S`], with noise of `noise_sigma` on each sample) starts to
/// hunt, judged as its model is ([`hunts_from`]) on its averages over `quiet` samples: moving
/// where they spread by more than [`HUNTING_M`] or [`RECORD_NOISE_MULTIPLE`] times an
/// average's noise, whichever is larger, and at rest where [`RECORD_REST_MEANS`] successive
/// ones lie within half of that. A record
/// settling the rest of the way moves its averages less each time and never hunts; a table
/// sticking and slipping by less than the band does, where its model may rest. Samples from
/// the first average the record does not cover are not judged.
pub(super) fn record_hunts_from(record: &[f64], quiet: usize, noise_sigma: f64) -> Option<usize> {
    if quiet == 0 {
        return None;
    }
    let means: Vec<f64> = record
        .chunks_exact(quiet)
        .map(|c| c.iter().sum::<f64>() / quiet as f64)
        .take_while(|m| m.is_finite())
        .collect();
    let noise_of_mean = noise_sigma / (quiet as f64).sqrt();
    let moves_m = HUNTING_M.max(RECORD_NOISE_MULTIPLE * noise_of_mean);
    // At rest within half of that: the tail of a settle that passes as at rest by a hair
    // must not read as breaking away when its noise next spreads a window by another hair.
    // Two swings' sizes differ by their averages' noise alone by 2 × that noise (each is a
    // difference of two averages): only a shrink beyond three times that reads as a decay.
    let rule = Rule {
        rest_m: 0.5 * moves_m,
        moves_m,
        shrink_m: 6.0 * noise_of_mean,
    };
    hunts_from(&means, RECORD_REST_MEANS, &rule).map(|i| i * quiet)
}

/// How a hold's trace is judged (m): at rest where a window spreads no more than `rest_m`;
/// moving again where a later one spreads more than `moves_m`, and swinging where it turns
/// back by more than that; a swing shrinks only where it is smaller than the one before by
/// more than `shrink_m` too (what the trace's noise alone makes of two swings).
struct Rule {
    rest_m: f64,
    moves_m: f64,
    shrink_m: f64,
}

/// Where a hold's trace `v` starts to hunt, at rest being a window of `quiet` values as
/// `rule` says, or `None` where it does not.
///
/// Where the trace comes to rest, it hunts if a later window moves by more than `moves_m` —
/// it broke away again — unless its swings decay ([`Swings::decay`]): an exponential settle
/// moves less in each window than in the one before, so it never breaks away, and a lightly
/// damped one that seemed to rest at a crest of its swing shrinks each swing. Where it never
/// comes to rest within the hold, it hunts if its swings are there and do not decay (from its
/// first turn on); still settling one way when the hold ends, it is a short hold, not a
/// hunting one.
fn hunts_from(v: &[f64], quiet: usize, rule: &Rule) -> Option<usize> {
    let ranges = window_ranges(v, quiet);
    let swings = Swings::of(v, rule.moves_m, rule.shrink_m);
    match ranges.iter().position(|&r| r <= rule.rest_m) {
        Some(rest) => {
            let moves_again = ranges[rest..].iter().any(|&r| r > rule.moves_m);
            (moves_again && !swings.decay()).then_some(rest)
        }
        None => swings.sustained().then(|| swings.turns[0]),
    }
}

/// A hold's swings: where a trace turns back by more than a threshold.
struct Swings {
    /// The turning points (indices).
    turns: Vec<usize>,
    /// Each complete swing, from one turning point to the next (m).
    sizes: Vec<f64>,
    /// How much smaller than the swing before one must be, beyond a twentieth, to count
    /// as shrinking (m).
    shrink_m: f64,
}

impl Swings {
    fn of(v: &[f64], h: f64, shrink_m: f64) -> Swings {
        let turns = turning_points(v, h);
        let sizes = turns
            .windows(2)
            .map(|t| (v[t[1]] - v[t[0]]).abs())
            .collect();
        Swings {
            turns,
            sizes,
            shrink_m,
        }
    }

    /// Two or more complete swings, each smaller than the one before by more than a
    /// twentieth: a decaying mode, as a linear loop's are.
    fn decay(&self) -> bool {
        let shrinks = |s: &[f64]| s[1] < SUSTAINED_SHARE * s[0] && s[0] - s[1] > self.shrink_m;
        self.sizes.len() >= 2 && self.sizes.windows(2).all(shrinks)
    }

    /// Two or more complete swings that do not decay: a cycle that keeps its size.
    fn sustained(&self) -> bool {
        self.sizes.len() >= 2 && !self.decay()
    }
}

/// Where a record of a hold first comes within [`SETTLED_M`] of its command (index), if it
/// does: its own arrival, from which its own hunting is judged.
pub(super) fn arrived_at(record: &[f64], command: &[f64]) -> Option<usize> {
    record
        .iter()
        .zip(command)
        .position(|(r, c)| (r - c).abs() < SETTLED_M)
}

/// The spread (largest minus smallest) of each run of `w` consecutive values of `v`, by the
/// run's first index; none where `v` is shorter than `w`. Sliding extremes, so that a long
/// hold finely sampled costs one pass.
fn window_ranges(v: &[f64], w: usize) -> Vec<f64> {
    use std::collections::VecDeque;
    if w == 0 || v.len() < w {
        return Vec::new();
    }
    let (mut lo, mut hi) = (VecDeque::new(), VecDeque::new());
    let mut out = Vec::with_capacity(v.len() + 1 - w);
    for i in 0..v.len() {
        while lo.back().is_some_and(|&j: &usize| v[j] >= v[i]) {
            lo.pop_back();
        }
        while hi.back().is_some_and(|&j: &usize| v[j] <= v[i]) {
            hi.pop_back();
        }
        lo.push_back(i);
        hi.push_back(i);
        if i + 1 >= w {
            let first = i + 1 - w;
            while lo.front().is_some_and(|&j| j < first) {
                lo.pop_front();
            }
            while hi.front().is_some_and(|&j| j < first) {
                hi.pop_front();
            }
            out.push(v[hi[0]] - v[lo[0]]);
        }
    }
    out
}

/// The indices at which `v` turns back by more than `h` from its furthest value in the
/// direction it moved: the extremes of its swings, small wiggles below `h` ignored.
fn turning_points(v: &[f64], h: f64) -> Vec<usize> {
    let mut turns = Vec::new();
    let (mut direction, mut extreme) = (0.0, 0);
    for i in 1..v.len() {
        let d = v[i] - v[extreme];
        if direction == 0.0 {
            if d.abs() > h {
                direction = d.signum();
                extreme = i;
            }
        } else if d * direction > 0.0 {
            extreme = i;
        } else if -d * direction > h {
            turns.push(extreme);
            direction = -direction;
            extreme = i;
        }
    }
    turns
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    /// 1 ms samples: 50 to a quiet window.
    const QUIET: usize = 50;

    /// A first-order settle into a hold: 2 µm from the command at its start, closing with
    /// the time constant of a position loop of Kv = 1 m/min/mm (60 ms), for `hold_s`.
    fn exponential(hold_s: f64, tau_s: f64) -> Vec<f64> {
        (0..(hold_s * 1e3) as usize)
            .map(|i| 2e-6 * (-(i as f64) * 1e-3 / tau_s).exp())
            .collect()
    }

    #[test]
    fn an_exponential_settle_does_not_hunt_however_long_the_hold() {
        // 2 µm falls below 0.02 µm a window after ln(100)·τ: the settle from the 2 µm band
        // moves far more than HUNTING_M, and is no hunting.
        for hold_s in [0.05, 0.12, 0.3, 1.0, 6.0] {
            for tau_s in [0.01, 0.06, 0.3] {
                let m = exponential(hold_s, tau_s);
                assert_eq!(model_hunts_from(&m, QUIET), None, "{hold_s} s, τ {tau_s} s");
            }
        }
    }

    #[test]
    fn a_decaying_oscillation_does_not_hunt() {
        // An underdamped loop: 8 Hz, damping ratio 0.2 (a third lost each half cycle).
        let (f, zeta) = (8.0, 0.2);
        let w = 2.0 * PI * f;
        for hold_s in [0.2, 0.5, 3.0] {
            let m: Vec<f64> = (0..(hold_s * 1e3) as usize)
                .map(|i| {
                    let t = i as f64 * 1e-3;
                    2e-6 * (-zeta * w * t).exp() * (w * t).cos()
                })
                .collect();
            assert_eq!(model_hunts_from(&m, QUIET), None, "{hold_s} s");
        }
    }

    #[test]
    fn a_stick_then_a_slip_hunts_from_the_stick() {
        // Settles in 0.1 s onto 0.3 µm short of the command, stuck for 0.4 s while the
        // integrator winds, then slips 0.5 µm past in 10 ms, and sticks again.
        let m: Vec<f64> = (0..1000)
            .map(|i| match i {
                0..100 => 2e-6 - 1.7e-6 * i as f64 / 100.0,
                100..500 => 0.3e-6,
                500..510 => 0.3e-6 - 0.5e-6 * (i - 500) as f64 / 10.0,
                _ => -0.2e-6,
            })
            .collect();
        // The window from 1 ms before the stick moves 17 nm, within HUNTING_M: at rest.
        assert_eq!(model_hunts_from(&m, QUIET), Some(99));
    }

    #[test]
    fn a_limit_cycle_of_sticks_and_slips_hunts() {
        // Comes to rest 0.3 µm short, then every 0.3 s slips 0.5 µm the other way.
        let m: Vec<f64> = (0..2000)
            .map(|i| match i {
                0..100 => 2e-6 - 1.7e-6 * i as f64 / 100.0,
                _ if (i - 100) / 300 % 2 == 0 => 0.3e-6,
                _ => -0.2e-6,
            })
            .collect();
        assert_eq!(model_hunts_from(&m, QUIET), Some(99));
    }

    #[test]
    fn a_cycle_that_never_rests_hunts_one_that_settles_one_way_does_not() {
        // A 30 Hz cycle of 0.2 µm never stands 50 ms; its swings keep their size.
        let m: Vec<f64> = (0..600)
            .map(|i| 0.1e-6 * (2.0 * PI * 30.0 * i as f64 * 1e-3).sin())
            .collect();
        // The first turn is at the first crest, a quarter period (8.3 ms) in.
        assert_eq!(model_hunts_from(&m, QUIET), Some(8));
        // A slow settle (τ = 1 s) still far from rest when a 0.3 s hold ends.
        assert_eq!(model_hunts_from(&exponential(0.3, 1.0), QUIET), None);
    }

    /// Gaussian noise of `sigma` on each of `n` samples, from a fixed seed (xorshift and
    /// Box–Muller): the same every run.
    fn noise(n: usize, sigma: f64, mut seed: u64) -> Vec<f64> {
        let mut uniform = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            ((seed >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        };
        (0..n)
            .map(|_| sigma * (-2.0 * uniform().ln()).sqrt() * (2.0 * PI * uniform()).cos())
            .collect()
    }

    #[test]
    fn a_noisy_record_that_settles_does_not_hunt_one_that_sticks_and_slips_does() {
        // 0.3 µm of noise on each 1 ms sample: a 50 ms average carries 0.3/√50 = 0.042 µm,
        // so the record is at rest where its averages stay within 6 × 0.042 = 0.25 µm.
        let sigma = 0.3e-6;
        for (seed, tau_s) in [(3, 0.02), (7, 0.06), (11, 0.15)] {
            // From the band's edge, 2 µm, closing with τ and standing for 2 s.
            let settle: Vec<f64> = exponential(2.0, tau_s)
                .iter()
                .zip(noise(2000, sigma, seed))
                .map(|(x, e)| x + e)
                .collect();
            assert_eq!(
                record_hunts_from(&settle, QUIET, sigma),
                None,
                "τ {tau_s} s"
            );
        }
        // Noise alone about a table that stands.
        assert_eq!(
            record_hunts_from(&noise(2000, sigma, 5), QUIET, sigma),
            None
        );
        // Stuck 0.4 s at 0.4 µm past the target, slipping to 0.4 µm short in 10 ms, stuck
        // 0.4 s, slipping back: a cycle of 0.8 µm, inside the 2 µm band, that keeps its size.
        let cycle: Vec<f64> = (0..2000)
            .map(|i| match i % 820 {
                0..400 => 0.4e-6,
                j @ 400..410 => 0.4e-6 - 0.8e-6 * (j - 400) as f64 / 10.0,
                410..810 => -0.4e-6,
                j => -0.4e-6 + 0.8e-6 * (j - 810) as f64 / 10.0,
            })
            .zip(noise(2000, sigma, 13))
            .map(|(x, e)| x + e)
            .collect();
        // At rest within the first stick (its four averages inside the first 0.4 s), broken
        // away after.
        let from = record_hunts_from(&cycle, QUIET, sigma);
        assert!(from.is_some_and(|i| i + 4 * QUIET <= 400), "{from:?}");
        // Twice the size with twice the noise, it is the same cycle.
        let big: Vec<f64> = cycle.iter().map(|x| 2.0 * x).collect();
        assert!(record_hunts_from(&big, QUIET, 2.0 * sigma).is_some());
    }

    #[test]
    fn window_ranges_are_each_windows_spread() {
        let v = [0.0, 3.0, 1.0, -2.0, 5.0, 4.0];
        assert_eq!(window_ranges(&v, 3), vec![3.0, 5.0, 7.0, 7.0]);
        assert!(window_ranges(&v, 7).is_empty());
    }

    #[test]
    fn a_record_arrives_where_it_first_comes_within_the_band() {
        let command = [0.0; 5];
        let record = [5e-6, 2.5e-6, 1.5e-6, 3e-6, 0.0];
        assert_eq!(arrived_at(&record, &command), Some(2));
        assert_eq!(arrived_at(&[3e-6; 5], &command), None);
    }
}
