//! Exact discretisation of each mode's linear dynamics (zero-order hold on the inputs):
//! the step map [x; u] ↦ x' is the top block of exp(A·h) for the augmented matrix A.
//!
//! Mode switches are located inside a step by bisection, which needs the maps of h/2,
//! h/4, … h/2^K as well: each (mode, level) map is computed once, when first needed, and
//! shared with every other simulation whose mode has the same dynamics and step (a fit
//! simulates one axis hundreds of times, and a value such as a dead time or a friction
//! force leaves most modes' matrices as they were).

use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock};

use nalgebra::SMatrix;

use super::model::{AugMatrix, AxisModel, Mode, N, NA};

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

/// One mode's maps at every level for one step h, computed as asked for.
struct ModeMaps {
    /// A·h balanced (its entries span many orders of magnitude: metres of travel, amperes,
    /// newtons through stiffnesses of 10¹⁰ N/m — unbalanced, a stiff drive's step map loses its
    /// small entries to the rounding of its large ones, a rigid table's speed drifting by 30
    /// ppm), and the diagonal that balanced it. A·h/2^k is
    /// balanced by the same diagonal: halving every entry leaves the rows' and columns'
    /// ratios as they were, bit for bit.
    balanced: AugMatrix,
    diagonal: nalgebra::SVector<f64, NA>,
    levels: [OnceLock<StepMap>; LEVELS + 1],
}

impl ModeMaps {
    fn new(a: &AugMatrix, h: f64) -> Self {
        let mut balanced = a * h;
        // Balancing never ends on an infinite entry; such dynamics step to non-finite states,
        // which the simulation reports as not simulable, balanced or not.
        let diagonal = if balanced.iter().all(|v| v.is_finite()) {
            nalgebra::linalg::balancing::balance_parlett_reinsch(&mut balanced)
        } else {
            nalgebra::SVector::repeat(1.0)
        };
        ModeMaps {
            balanced,
            diagonal,
            levels: std::array::from_fn(|_| OnceLock::new()),
        }
    }

    fn at(&self, level: usize) -> &StepMap {
        self.levels[level].get_or_init(|| {
            let m = self.balanced * (1.0 / (1u64 << level) as f64);
            let mut top = m.exp().fixed_view::<N, NA>(0, 0).into_owned();
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

/// A dynamics matrix and a step, bit for bit: the same key gives the same maps.
type MapKey = (Vec<u64>, u64);

type Shared = HashMap<MapKey, Arc<ModeMaps>>;

/// Modes' maps kept before the shared ones are cleared: about 55 kB an entry (its key and
/// room for every level), so under 30 MB for the process.
const SHARED_MAX: usize = 512;

static SHARED: OnceLock<Mutex<Shared>> = OnceLock::new();

/// The maps of a mode with dynamics `a` and step `h`: the ones shared where another
/// simulation has them.
fn shared_maps(a: &AugMatrix, h: f64) -> Arc<ModeMaps> {
    let key: MapKey = (a.iter().map(|v| v.to_bits()).collect(), h.to_bits());
    let shared = SHARED.get_or_init(|| Mutex::new(Shared::default()));
    // A panic elsewhere while the lock was held leaves whole entries only.
    let lock = || shared.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(m) = lock().get(&key) {
        return Arc::clone(m);
    }
    // Balanced outside the lock, so one slow mode holds up no other simulation; two threads
    // that build the same maps at once build equal ones, and the first kept is used.
    let built = Arc::new(ModeMaps::new(a, h));
    let mut maps = lock();
    if maps.len() >= SHARED_MAX {
        maps.clear();
    }
    Arc::clone(maps.entry(key).or_insert(built))
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

    /// Each level's map is the one balancing that level's matrix on its own gives, bit for
    /// bit: halving a matrix leaves its balancing as it was.
    #[test]
    fn maps_balanced_once_are_those_balanced_at_each_level() {
        let mode = Mode {
            friction: FrictionMode::SlipPos,
            contact: ContactMode::Pos,
            current: ClampMode::Linear,
            voltage: ClampMode::Linear,
        };
        for preset in ["hvmc", "small-table"] {
            let machine = MachineConfig::preset(preset).unwrap();
            let model = AxisModel::from_config(&machine.x);
            let (a, h) = (model.dynamics(mode), 1e-4);
            let maps = ModeMaps::new(&a, h);
            for level in 0..=LEVELS {
                let mut m = a * (h / (1u64 << level) as f64);
                let d = nalgebra::linalg::balancing::balance_parlett_reinsch(&mut m);
                let mut e = m.exp();
                nalgebra::linalg::balancing::unbalance(&mut e, &d);
                let want = e.fixed_view::<N, NA>(0, 0).into_owned();
                assert_eq!(maps.at(level), &want, "{preset} level {level}");
            }
        }
    }
}
