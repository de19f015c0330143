//! What one fit's samples have already given, by the configuration they were computed for:
//! the residual's sum of squares of a configuration, and where a search of some knobs over
//! every sample ended from a configuration. The staged start asks for both again — the
//! template's gain fitted alone is the first candidate's search and the start of the search
//! with the design's corners kept; a grid about the same point is the same grid — and a
//! simulation is a function of its configuration alone, so the figure kept is the one that
//! would be computed.

use std::collections::HashMap;
use std::sync::Mutex;

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
    searches: Mutex<HashMap<(Vec<&'static str>, Key), Ended>>,
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
        knobs: Vec<&'static str>,
        base: &AxisConfig,
        search: impl FnOnce() -> Ended,
    ) -> Ended {
        let key = (knobs, Key::of(base));
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
