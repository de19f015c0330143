//! What one fit's samples have already given, by the configuration they were computed for:
//! the residual's sum of squares of a configuration, and where a search of some knobs over
//! every sample ended from a configuration. The staged start asks for both again — the
//! template's gain fitted alone is the first candidate's search and the start of the search
//! with the design's corners kept; a grid about the same point is the same grid — and a
//! simulation is a function of its configuration alone, so the figure kept is the one that
//! would be computed. A search's end depends on its knobs' whole definitions — their
//! bounds, whether they move by factors, their least step — not on their keys alone: two
//! knobs of one key with other bounds (the static level's floor with and without bristles)
//! are two searches.

use std::collections::HashMap;
use std::sync::Mutex;

use crate::identify::knobs::Knob;
use crate::machine::AxisConfig;

/// A configuration bit for bit: its debug form writes every number so that it reads back
/// to the same bits (the sign of a zero included).
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub(super) struct Key(String);

impl Key {
    pub(super) fn of(config: &AxisConfig) -> Key {
        Key(format!("{config:?}"))
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
        let key = (Searched::of(knobs), Key::of(base));
        if let Some(kept) = lock(&self.searches).get(&key) {
            return kept.clone();
        }
        let ended = search();
        lock(&self.searches).insert(key, ended.clone());
        ended
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
}
