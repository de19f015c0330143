//! What one fit's samples have already given, by the configuration they were computed for:
//! the residual's sum of squares of a configuration, and where a search of some knobs over
//! every sample ended from a configuration. The staged start asks for both again — the
//! template's gain fitted alone is the first candidate's search and the start of the search
//! with the design's corners kept; a grid about the same point is the same grid — and a
//! simulation is a function of its configuration alone, so the figure kept is the one that
//! would be computed. A search's end depends on its knobs' whole definitions — their
//! bounds, whether they move by factors, their least step — not on their keys alone: two
//! knobs of one key with other bounds (the static level's floor with and without bristles)
//! are two searches. A fit's run on some of its samples is kept the same way, by its knobs,
//! its start and the samples it ran on: a loop fitted again with a lead's period and no
//! ripple yet runs every search and fit it ran without the period.
//!
//! A force ripple of no amplitude is not simulated, whatever its period and phase: a
//! configuration is kept without them where its amplitude is zero, and so is a search's or
//! a run's start where its knobs do not fit the ripple (which would give the period a
//! force to act through).

use std::collections::HashMap;
use std::sync::Mutex;

use super::Fitted;
use crate::identify::knobs::Knob;
use crate::machine::AxisConfig;

/// A configuration bit for bit: its debug form writes every number so that it reads back
/// to the same bits (the sign of a zero included).
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub(super) struct Key(String);

impl Key {
    /// A configuration as the simulation sees it: a ripple of no amplitude without its
    /// period and phase.
    pub(super) fn of(config: &AxisConfig) -> Key {
        let e = &config.errors;
        if e.force_ripple_n == 0.0
            && (e.force_ripple_period_mm != 0.0 || e.force_ripple_phase_deg != 0.0)
        {
            let mut seen = config.clone();
            seen.errors.force_ripple_n = 0.0;
            seen.errors.force_ripple_period_mm = 0.0;
            seen.errors.force_ripple_phase_deg = 0.0;
            return Key(format!("{seen:?}"));
        }
        Key(format!("{config:?}"))
    }

    /// The start of a search or run of `knobs`: as [`Key::of`] where they leave the ripple
    /// as it is, else bit for bit.
    fn of_start(knobs: &[Knob], base: &AxisConfig) -> Key {
        if knobs.iter().any(|k| k.key.starts_with(RIPPLE_KEYS)) {
            Key(format!("{base:?}"))
        } else {
            Key::of(base)
        }
    }
}

/// What the machine file's force ripple keys start with.
const RIPPLE_KEYS: &str = "errors.force_ripple";

/// The samples a run used, one bit each.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
struct Samples(Vec<u64>);

impl Samples {
    fn of(keep: &[usize]) -> Samples {
        let words = keep.last().map_or(0, |&k| k / 64 + 1);
        let mut bits = vec![0u64; words];
        for &k in keep {
            bits[k / 64] |= 1 << (k % 64);
        }
        Samples(bits)
    }
}

/// A search's end: the residual's sum of squares (m²) and the knobs' values.
pub(super) type Ended = Option<(f64, Vec<f64>)>;

/// The figures kept. Two threads that ask for the same one at once both compute it (the same
/// value); the lock is held only to look up and to keep.
#[derive(Default)]
pub(super) struct Memo {
    costs: Mutex<HashMap<Key, Option<f64>>>,
    searches: Mutex<HashMap<(Searched, Key), Ended>>,
    runs: Mutex<HashMap<(Searched, Key, Samples), Option<Fitted>>>,
}

/// The knobs of a search as defined, every field (key, bounds, step, flags) written out
/// in a form that reads back to the same bits.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
struct Searched(String);

impl Searched {
    fn of(knobs: &[Knob]) -> Searched {
        Searched(format!("{knobs:?}"))
    }
}

impl Memo {
    /// The cost of `config`, kept or computed by `compute`.
    pub(super) fn cost(
        &self,
        config: &AxisConfig,
        compute: impl FnOnce() -> Option<f64>,
    ) -> Option<f64> {
        let key = Key::of(config);
        if let Some(kept) = lock(&self.costs).get(&key) {
            return *kept;
        }
        let cost = compute();
        lock(&self.costs).insert(key, cost);
        cost
    }

    /// The end of the search of `knobs` from `base`, kept or run by `search`.
    pub(super) fn search(
        &self,
        knobs: &[Knob],
        base: &AxisConfig,
        search: impl FnOnce() -> Ended,
    ) -> Ended {
        let key = (Searched::of(knobs), Key::of_start(knobs, base));
        if let Some(kept) = lock(&self.searches).get(&key) {
            return kept.clone();
        }
        let ended = search();
        lock(&self.searches).insert(key, ended.clone());
        ended
    }

    /// The fit of `knobs` from `base` on the samples `keep` (indices, ascending), kept or
    /// run by `run`.
    pub(super) fn run(
        &self,
        knobs: &[Knob],
        base: &AxisConfig,
        keep: &[usize],
        run: impl FnOnce() -> Option<Fitted>,
    ) -> Option<Fitted> {
        let key = (
            Searched::of(knobs),
            Key::of_start(knobs, base),
            Samples::of(keep),
        );
        if let Some(kept) = lock(&self.runs).get(&key) {
            return kept.clone();
        }
        let fitted = run();
        lock(&self.runs).insert(key, fitted.clone());
        fitted
    }
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::machine::MachineConfig;

    /// A static level's knob with its floor at `min`.
    fn static_level(min: f64) -> Knob {
        Knob {
            key: "friction.static_to_coulomb",
            unit: "",
            logarithmic: true,
            least_scale: 0.0,
            undetermined_beyond: 0.5,
            input_floor: 0.02,
            min,
            max: 3.0,
        }
    }

    #[test]
    fn knobs_of_one_key_and_other_bounds_are_searched_apart() {
        let memo = Memo::default();
        let base = MachineConfig::default_preset().x;
        let (floored, bristled) = (static_level(1.0), static_level(0.1));
        let ended = |cost: f64, level: f64| Some((cost, vec![level]));
        assert_eq!(
            memo.search(&[floored], &base, || ended(4.0, 1.0)),
            ended(4.0, 1.0)
        );
        // The same knob from the same base is the search kept: it is not run again.
        let again = memo.search(&[floored], &base, || panic!("searched twice"));
        assert_eq!(again, ended(4.0, 1.0));
        // The key alone would hand back the search bounded at 1.0; its own bounds run it.
        let mut ran = false;
        let lower = memo.search(&[bristled], &base, || {
            ran = true;
            ended(2.5, 0.4)
        });
        assert!(ran);
        assert_eq!(lower, ended(2.5, 0.4));
        // A step of another size, or a factor in place of an increment, is another search.
        for other in [
            Knob {
                least_scale: 0.05,
                ..floored
            },
            Knob {
                logarithmic: false,
                ..floored
            },
        ] {
            assert_eq!(
                memo.search(&[other], &base, || ended(9.0, 2.0)),
                ended(9.0, 2.0)
            );
        }
    }

    #[test]
    fn a_ripple_of_no_amplitude_is_kept_as_the_configuration_without_it() {
        let memo = Memo::default();
        let base = MachineConfig::default_preset().x;
        let mut with_period = base.clone();
        with_period.errors.force_ripple_period_mm = 2.5;
        with_period.errors.force_ripple_phase_deg = 40.0;
        assert_eq!(memo.cost(&base, || Some(3.0)), Some(3.0));
        // No force acts: the figure kept is the configuration's without the period.
        assert_eq!(
            memo.cost(&with_period, || panic!("simulated again")),
            Some(3.0)
        );
        // A force of 1 N acts through the period: another configuration.
        let mut pushed = with_period.clone();
        pushed.errors.force_ripple_n = 1.0;
        assert_eq!(memo.cost(&pushed, || Some(5.0)), Some(5.0));
        // A run of the loop's values from either start on the same samples is one run; on
        // other samples, another.
        let gain = Knob {
            key: "position_loop.kv_m_per_min_per_mm",
            ..static_level(0.1)
        };
        let fitted = |cost: f64| Fitted {
            values: vec![cost],
            sigma: vec![0.1],
            model_sigma: vec![0.1],
            cost,
            own_point: true,
            spread: None,
        };
        let ran = |m: &Memo, c: &AxisConfig, keep: &[usize], f: Fitted| {
            m.run(&[gain], c, keep, || Some(f)).map(|f| f.cost)
        };
        assert_eq!(ran(&memo, &base, &[0, 2, 70], fitted(1.0)), Some(1.0));
        assert_eq!(
            ran(&memo, &with_period, &[0, 2, 70], fitted(9.0)),
            Some(1.0)
        );
        assert_eq!(ran(&memo, &with_period, &[0, 2], fitted(2.0)), Some(2.0));
        assert_eq!(
            ran(&memo, &with_period, &[0, 2, 71], fitted(4.0)),
            Some(4.0)
        );
        // A search of the ripple's own amplitude starts from the period it is given.
        let amplitude = Knob {
            key: "errors.force_ripple_n",
            ..static_level(0.0)
        };
        let ended = |cost: f64| Some((cost, vec![cost]));
        assert_eq!(memo.search(&[amplitude], &base, || ended(6.0)), ended(6.0));
        assert_eq!(
            memo.search(&[amplitude], &with_period, || ended(7.0)),
            ended(7.0)
        );
    }
}
