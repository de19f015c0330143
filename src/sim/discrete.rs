//! Exact discretisation of each mode's linear dynamics (zero-order hold on the inputs):
//! the step map [x; u] ↦ x' is the top block of exp(A·h) for the augmented matrix A.
//!
//! Mode switches are located inside a step by bisection, which needs the maps of h/2,
//! h/4, … h/2^K as well: each (mode, level) map is computed once, when first needed, and
//! shared with every other simulation whose mode has the same dynamics and step (a fit
//! simulates one axis hundreds of times, and a value such as a dead time or a friction
//! force leaves most modes' matrices as they were).

mod expm;

use std::collections::HashMap;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, OnceLock};

use nalgebra::SMatrix;

use super::model::{AugMatrix, AxisModel, Mode, N, NA};
use expm::DyadicExp;

/// Top rows of exp(A·h): x' = M·[x; u].
pub type StepMap = SMatrix<f64, N, NA>;

/// Finest subdivision used to locate events: h/2^LEVELS.
pub const LEVELS: usize = 24;

/// Lazily filled step maps (and dynamics matrices) for every mode and level.
pub struct MapCache {
    h: f64,
    dynamics: Vec<Option<Box<AugMatrix>>>,
    maps: Vec<Option<Arc<ModeMaps>>>,
}

impl MapCache {
    /// An empty cache for steps of `h` seconds.
    pub(crate) fn new(h: f64) -> Self {
        MapCache {
            h,
            dynamics: (0..Mode::COUNT).map(|_| None).collect(),
            maps: (0..Mode::COUNT).map(|_| None).collect(),
        }
    }

    /// The full step (s).
    pub(crate) fn step_s(&self) -> f64 {
        self.h
    }

    /// The augmented dynamics matrix of a mode.
    pub(crate) fn dynamics(&mut self, model: &AxisModel, mode: Mode) -> &AugMatrix {
        self.dynamics[mode.index()].get_or_insert_with(|| Box::new(model.dynamics(mode)))
    }

    /// The map of a step of h/2^level in a mode.
    pub(crate) fn map(&mut self, model: &AxisModel, mode: Mode, level: usize) -> &StepMap {
        if self.maps[mode.index()].is_none() {
            let a = *self.dynamics(model, mode);
            self.maps[mode.index()] = Some(shared_maps(&a, self.h));
        }
        self.maps[mode.index()]
            .as_ref()
            .expect("just filled")
            .at(level)
    }
}

/// The largest entry of A·h that is balanced: 19 squares of it sum to a finite number.
const BALANCED_MAX: f64 = 1e150;

/// One mode's maps at every level for one step h, computed as asked for.
struct ModeMaps {
    /// The diagonal that balanced A·h (its entries span many orders of magnitude: metres of
    /// travel, amperes, newtons through stiffnesses of 10¹⁰ N/m — unbalanced, a stiff drive's
    /// step map loses its small entries to the rounding of its large ones, a rigid table's
    /// speed drifting by 30 ppm). A·h/2^k is balanced by the same diagonal: halving every
    /// entry leaves the rows' and columns' ratios as they were, bit for bit.
    diagonal: nalgebra::SVector<f64, NA>,
    levels: [OnceLock<StepMap>; LEVELS + 1],
    /// The levels filled: at the last, the products the levels share are let go.
    filled: AtomicUsize,
    /// The exponentials of the balanced A·h at every level, sharing their powers, their
    /// order-13 approximants and squares (the levels' steps differ by powers of two).
    exps: Mutex<DyadicExp>,
}

impl ModeMaps {
    fn new(a: &AugMatrix, h: f64) -> Self {
        let mut balanced = a * h;
        // Balancing never ends where a row's or column's squared norm is infinite (an entry
        // of 10¹⁵⁴ or more: no machine's); such dynamics step to non-finite states, which the
        // simulation reports as not simulable, balanced or not.
        let diagonal = if balanced.iter().all(|v| v.abs() < BALANCED_MAX) {
            nalgebra::linalg::balancing::balance_parlett_reinsch(&mut balanced)
        } else {
            nalgebra::SVector::repeat(1.0)
        };
        ModeMaps {
            diagonal,
            levels: std::array::from_fn(|_| OnceLock::new()),
            filled: AtomicUsize::new(0),
            exps: Mutex::new(DyadicExp::new(balanced)),
        }
    }

    fn at(&self, level: usize) -> &StepMap {
        self.levels[level].get_or_init(|| {
            // A panic elsewhere while the lock was held leaves whole matrices only. The lock
            // is let go before the unbalancing: only the shared products need it.
            let mut exps = self.exps.lock().unwrap_or_else(|e| e.into_inner());
            let full = exps.at(level);
            // Each level is filled once: after the last, no level asks for the products.
            if self.filled.fetch_add(1, Ordering::Relaxed) == LEVELS {
                exps.release();
            }
            drop(exps);
            let mut top = full.fixed_view::<N, NA>(0, 0).into_owned();
            // D·E·D⁻¹, as nalgebra's `unbalance` does it, on the rows kept.
            for (j, mut col) in top.column_iter_mut().enumerate() {
                let denom = 1.0 / self.diagonal[j];
                for (i, v) in col.iter_mut().enumerate() {
                    *v *= self.diagonal[i] * denom;
                }
            }
            top
        })
    }
}

/// The maps of every level of one mode, computed afresh (not shared with the simulations):
/// the sum of their entries, for the benches.
pub(crate) fn all_levels(a: &AugMatrix, h: f64) -> f64 {
    let maps = ModeMaps::new(a, h);
    (0..=LEVELS).map(|level| maps.at(level).sum()).sum()
}

/// A dynamics matrix and a step, bit for bit: the same key gives the same maps.
type MapKey = (Vec<u64>, u64);

/// The shared maps in two generations: a map is found in either, and one found in the older
/// is moved to the newer. When the newer is full it becomes the older and the older is
/// dropped, so the maps in use (found since the last turn) survive it, and a fit that walks
/// through many values never holds more than two generations.
struct Generations<V> {
    newer: HashMap<MapKey, Arc<V>>,
    older: HashMap<MapKey, Arc<V>>,
    /// The older generations a turn let go, to be dropped by whoever holds the lock once it
    /// has let go of it: freeing up to [`GENERATION_MAX`] modes' maps holds up no other
    /// simulation.
    retired: Vec<HashMap<MapKey, Arc<V>>>,
}

type Shared = Generations<ModeMaps>;

/// Modes' maps in one generation: an entry is about 70 to 120 kB at the presets' steps (its
/// key, room for every level and the products its levels share, which are let go once every
/// level is filled; up to ~160 kB for a mode needing 16 or more squarings), so at most some
/// 60 MB for the two generations at the presets' steps.
const GENERATION_MAX: usize = 256;

impl<V> Generations<V> {
    fn new() -> Self {
        Generations {
            newer: HashMap::new(),
            older: HashMap::new(),
            retired: Vec::new(),
        }
    }

    fn find(&mut self, key: &MapKey) -> Option<Arc<V>> {
        if let Some(m) = self.newer.get(key) {
            return Some(Arc::clone(m));
        }
        let (key, m) = self.older.remove_entry(key)?;
        Some(self.keep(key, m))
    }

    /// Keeps `maps` in the newer generation (or the ones kept first, where another
    /// simulation built them at the same time).
    fn insert(&mut self, key: MapKey, maps: Arc<V>) -> Arc<V> {
        match self.find(&key) {
            Some(kept) => kept,
            None => self.keep(key, maps),
        }
    }

    fn keep(&mut self, key: MapKey, maps: Arc<V>) -> Arc<V> {
        if self.newer.len() >= GENERATION_MAX {
            let newer = std::mem::take(&mut self.newer);
            self.retired.push(std::mem::replace(&mut self.older, newer));
        }
        Arc::clone(self.newer.entry(key).or_insert(maps))
    }

    /// The generations let go since last asked, for the caller to drop outside the lock.
    fn take_retired(&mut self) -> Vec<HashMap<MapKey, Arc<V>>> {
        std::mem::take(&mut self.retired)
    }
}

static SHARED: OnceLock<Mutex<Shared>> = OnceLock::new();

/// The maps of a mode with dynamics `a` and step `h`: the ones shared where another
/// simulation has them.
fn shared_maps(a: &AugMatrix, h: f64) -> Arc<ModeMaps> {
    let key: MapKey = (a.iter().map(|v| v.to_bits()).collect(), h.to_bits());
    let shared = SHARED.get_or_init(|| Mutex::new(Shared::new()));
    shared_in(shared, key, || ModeMaps::new(a, h))
}

/// The value under `key` in `shared`, built where it has none. Neither the building nor the
/// dropping of a generation let go is done with the lock held.
fn shared_in<V>(shared: &Mutex<Generations<V>>, key: MapKey, build: impl FnOnce() -> V) -> Arc<V> {
    // A panic elsewhere while the lock was held leaves whole entries only.
    let lock = || shared.lock().unwrap_or_else(|e| e.into_inner());
    let (found, retired) = {
        let mut g = lock();
        (g.find(&key), g.take_retired())
    };
    drop(retired);
    if let Some(m) = found {
        return m;
    }
    // Built outside the lock, so one slow mode holds up no other simulation; two threads
    // that build the same maps at once build equal ones, and the first kept is used.
    let built = Arc::new(build());
    let (kept, retired) = {
        let mut g = lock();
        (g.insert(key, built), g.take_retired())
    };
    drop(retired);
    kept
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::machine::MachineConfig;
    use crate::sim::model::{AR, Aug, ClampMode, ContactMode, FrictionMode, ONE, VR, XR};

    #[test]
    fn two_half_steps_equal_one_step() {
        let model = AxisModel::from_config(&MachineConfig::default_preset().x);
        let mode = Mode {
            friction: FrictionMode::SlipPos,
            contact: ContactMode::Pos,
            current: ClampMode::Linear,
            voltage: ClampMode::Linear,
        };
        let mut cache = MapCache::new(5e-4);
        let mut x = Aug::zeros();
        x[VR] = 0.01;
        x[AR] = 0.2;
        x[ONE] = 1.0;
        x[XR] = 0.1;
        let full = cache.map(&model, mode, 0) * x;
        let half = *cache.map(&model, mode, 1);
        let mut y = x;
        let first = half * y;
        y.fixed_rows_mut::<N>(0).copy_from(&first);
        let second = half * y;
        for i in 0..N {
            let scale = full[i].abs().max(1e-6);
            assert!(
                (full[i] - second[i]).abs() <= 1e-9 * scale,
                "state {i}: {} vs {}",
                full[i],
                second[i]
            );
        }
        // The reference is integrated exactly: x_r + v_r h + a_r h²/2.
        let h = 5e-4;
        assert!((full[XR] - (0.1 + 0.01 * h + 0.1 * h * h)).abs() < 1e-16);
    }

    /// A map asked for again within a generation's worth of others is never dropped; one not
    /// asked for over two generations is; the two hold no more than their sizes.
    #[test]
    fn maps_in_use_survive_a_turn_of_generations() {
        let mut shared = Generations::new();
        let key = |i: usize| -> MapKey { (vec![i as u64], 0) };
        let in_use = shared.insert(key(0), Arc::new(0));
        for i in 1..4 * GENERATION_MAX {
            shared.insert(key(i), Arc::new(i));
            if i % (GENERATION_MAX / 2) == 0 {
                let found = shared.find(&key(0)).expect("in use");
                assert!(Arc::ptr_eq(&found, &in_use), "after {i} others");
            }
            assert!(shared.newer.len() + shared.older.len() <= 2 * GENERATION_MAX);
        }
        assert!(shared.find(&key(1)).is_none());
        let last = 4 * GENERATION_MAX - 1;
        assert_eq!(shared.find(&key(last)).as_deref(), Some(&last));
    }

    /// A value that counts whether it was dropped with [`PROBED`]'s lock held.
    struct Probe;

    static PROBED: OnceLock<Mutex<Generations<Probe>>> = OnceLock::new();
    static DROPS: [std::sync::atomic::AtomicUsize; 2] = [AtomicUsize::new(0), AtomicUsize::new(0)];

    impl Drop for Probe {
        fn drop(&mut self) {
            let locked = matches!(
                PROBED.get().map(Mutex::try_lock),
                Some(Err(std::sync::TryLockError::WouldBlock))
            );
            DROPS[usize::from(locked)].fetch_add(1, Ordering::Relaxed);
        }
    }

    /// The maps a turn of generations lets go are dropped once the lock is let go: none
    /// with it held, and every one of the older generation's (on one thread, the lock is
    /// held only by it).
    #[test]
    fn a_generation_let_go_is_dropped_outside_the_lock() {
        let shared = PROBED.get_or_init(|| Mutex::new(Generations::new()));
        let key = |i: usize| -> MapKey { (vec![i as u64], 1) };
        // Three generations' worth: the second turn lets go of the first generation.
        for i in 0..3 * GENERATION_MAX {
            shared_in(shared, key(i), || Probe);
        }
        assert_eq!(
            DROPS[1].load(Ordering::Relaxed),
            0,
            "dropped with the lock held"
        );
        assert!(DROPS[0].load(Ordering::Relaxed) >= GENERATION_MAX);
        assert!(shared.lock().unwrap().retired.is_empty());
    }

    /// Each level's map is the one nalgebra's exponential of that level's balanced matrix
    /// gives, bit for bit: halving a matrix leaves its balancing as it was, and the shared
    /// powers, approximants and squares are exactly what each level would have formed (only
    /// subnormal entries could round otherwise; these dynamics have none). Every friction and
    /// contact mode, current and voltage limits off, held and sliding, both presets' axes and
    /// one with presliding bristles, steps needing from no squaring to a dozen. Each level
    /// takes the Padé order the paper's bounds give for its matrix, and every order is taken.
    #[test]
    fn maps_at_every_level_are_each_levels_own_exponential() {
        use crate::sim::model::ClampMode::*;
        use crate::sim::model::ContactMode::*;
        use crate::sim::model::FrictionMode::*;
        let mut axes = Vec::new();
        for preset in ["hvmc", "small-table"] {
            let machine = MachineConfig::preset(preset).unwrap();
            axes.extend([machine.x, machine.y]);
        }
        axes.push(bristled());
        let limits = [
            (Linear, Linear),
            (HeldHi, Linear),
            (SlideLo, Linear),
            (Linear, HeldHi),
            (Linear, SlideLo),
            (HeldLo, SlideHi),
        ];
        let (mut checked, mut squarings) = (0, 0);
        let mut orders = [[0usize; 5]; LEVELS + 1];
        for axis in &axes {
            let model = AxisModel::from_config(axis);
            for friction in [SlipPos, SlipNeg, Stick] {
                for contact in [Pos, Free, Neg] {
                    for (current, voltage) in limits {
                        let mode = Mode {
                            friction,
                            contact,
                            current,
                            voltage,
                        };
                        for h in [1e-4, 1e-3] {
                            let (levels, squared) = check_levels(&model, mode, h, &mut orders);
                            checked += levels;
                            squarings += squared;
                        }
                    }
                }
            }
        }
        assert_eq!(checked, 5 * 3 * 3 * 6 * 2 * (LEVELS + 1));
        // The coarse levels of the stiff drives came from shared squares.
        assert!(squarings > 100, "{squarings} squarings");
        for (i, order) in PADE_ORDERS.iter().enumerate() {
            assert!(orders.iter().any(|o| o[i] > 0), "order {order}: {orders:?}");
        }
    }

    /// The Padé orders, and the bounds on the norms of a matrix's powers below which orders
    /// 3, 5, 7 and 9 reach unit roundoff (Al-Mohy and Higham 2009, table 3.1); order 13 above.
    const PADE_ORDERS: [usize; 5] = [3, 5, 7, 9, 13];
    const PADE_BOUNDS: [f64; 4] = [
        1.495_585_217_958_292e-2,
        2.539_398_330_063_23e-1,
        9.504_178_996_162_932e-1,
        2.097_847_961_257_068e0,
    ];

    /// The order the bounds give for `m`: 3 or 5 where max(‖M⁴‖^¼, ‖M⁶‖^⅙) is below theirs, 7
    /// or 9 where max(‖M⁶‖^⅙, ‖M⁸‖^⅛) is (1-norms), else 13 (the paper's algorithm 5.1, its
    /// extra squarings for rounding aside).
    fn pade_order(m: &AugMatrix) -> usize {
        let norm = |p: &AugMatrix| {
            p.column_iter()
                .map(|c| c.iter().map(|v| v.abs()).sum::<f64>())
                .fold(0.0, f64::max)
        };
        let m2 = m * m;
        let m4 = m2 * m2;
        let m6 = m4 * m2;
        let m8 = m6 * m2;
        let (d4, d6, d8) = (
            norm(&m4).powf(0.25),
            norm(&m6).powf(1.0 / 6.0),
            norm(&m8).powf(0.125),
        );
        let eta = [d4.max(d6), d4.max(d6), d6.max(d8), d6.max(d8)];
        (0..4)
            .find(|&i| eta[i] < PADE_BOUNDS[i])
            .map_or(13, |i| PADE_ORDERS[i])
    }

    /// hvmc's X (a modelled current loop, so its voltage limit acts) with presliding
    /// bristles of 50 N/µm: its friction is the bristles', not a Coulomb term in the maps.
    fn bristled() -> crate::machine::AxisConfig {
        let mut x = MachineConfig::preset("hvmc").unwrap().x;
        let f = &mut x.friction;
        f.bristle_stiffness_n_per_um = 50.0;
        f.bristle_damping_n_s_per_m = 2e4;
        f.static_to_coulomb = 0.7;
        f.stribeck_velocity_mm_per_min = 600.0;
        x
    }

    /// The bristled axis's and the voltage-limited modes' maps are of other dynamics than
    /// those of the same modes without: the test above covers them.
    #[test]
    fn bristles_and_a_voltage_limit_change_the_dynamics() {
        use crate::sim::model::ClampMode::*;
        let plain = AxisModel::from_config(&MachineConfig::preset("hvmc").unwrap().x);
        let bristles = AxisModel::from_config(&bristled());
        assert!(bristles.presliding.is_some());
        let mode = |voltage| Mode {
            friction: FrictionMode::SlipPos,
            contact: ContactMode::Pos,
            current: Linear,
            voltage,
        };
        assert_ne!(
            plain.dynamics(mode(Linear)),
            bristles.dynamics(mode(Linear))
        );
        assert_ne!(plain.dynamics(mode(Linear)), plain.dynamics(mode(HeldHi)));
        assert_ne!(plain.dynamics(mode(HeldHi)), plain.dynamics(mode(SlideLo)));
    }

    /// Dynamics with an infinite entry, or finite ones whose powers overflow, give maps that
    /// are not finite (which the simulation reports) at once: no squaring is attempted.
    #[test]
    fn dynamics_beyond_any_machine_give_maps_that_are_not_finite() {
        for v in [f64::INFINITY, 1e200] {
            let mut a = AugMatrix::zeros();
            a[(0, 1)] = 1.0;
            a[(1, 0)] = -v;
            let maps = ModeMaps::new(&a, 1e-4);
            for level in [0, LEVELS / 2, LEVELS] {
                assert!(
                    maps.at(level).iter().any(|x| !x.is_finite()),
                    "{v} level {level}"
                );
            }
            let exps = maps.exps.lock().unwrap();
            assert_eq!(exps.squarings(), 0, "{v}");
        }
    }

    /// The levels checked and the squarings they shared; the orders the levels took counted
    /// into `orders` (by level, as [`PADE_ORDERS`]), each the one [`pade_order`] gives.
    fn check_levels(
        model: &AxisModel,
        mode: Mode,
        h: f64,
        orders: &mut [[usize; 5]; LEVELS + 1],
    ) -> (usize, usize) {
        let a = model.dynamics(mode);
        let maps = ModeMaps::new(&a, h);
        // Asked for out of order, as a bisection after a first full step does.
        let order = std::iter::once(LEVELS / 2).chain(0..=LEVELS);
        let mut filled = std::collections::BTreeSet::new();
        for level in order {
            let mut m = a * (h / (1u64 << level) as f64);
            let d = nalgebra::linalg::balancing::balance_parlett_reinsch(&mut m);
            let mut e = m.exp();
            nalgebra::linalg::balancing::unbalance(&mut e, &d);
            let want = e.fixed_view::<N, NA>(0, 0).into_owned();
            assert_eq!(maps.at(level), &want, "{mode} h {h} level {level}");
            // The shared products are held until the last level is filled, not after.
            filled.insert(level);
            let held = maps.exps.lock().unwrap().holds_products();
            assert_eq!(held, filled.len() <= LEVELS, "{mode} h {h} level {level}");
        }
        let exps = maps.exps.lock().unwrap();
        for &(level, order) in &exps.orders {
            let mut m = a * (h / (1u64 << level) as f64);
            nalgebra::linalg::balancing::balance_parlett_reinsch(&mut m);
            assert_eq!(order, pade_order(&m), "{mode} h {h} level {level}");
            let i = PADE_ORDERS
                .iter()
                .position(|&o| o == order)
                .expect("a Padé order");
            orders[level][i] += 1;
        }
        assert_eq!(exps.orders.len(), LEVELS + 1, "each level once");
        (LEVELS + 1, exps.squarings())
    }
}
