//! Exact discretisation of each mode's linear dynamics (zero-order hold on the inputs):
//! the step map [x; u] ↦ x' is the top block of exp(A·h) for the augmented matrix A.
//!
//! Mode switches are located inside a step by bisection, which needs the maps of h/2,
//! h/4, … h/2^K as well: each (mode, level) map is computed once, when first needed.

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
    maps: Vec<Option<Box<StepMap>>>,
}

impl MapCache {
    /// An empty cache for steps of `h` seconds.
    pub(crate) fn new(h: f64) -> Self {
        MapCache {
            h,
            dynamics: (0..Mode::COUNT).map(|_| None).collect(),
            maps: (0..Mode::COUNT * (LEVELS + 1)).map(|_| None).collect(),
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
        let slot = mode.index() * (LEVELS + 1) + level;
        if self.maps[slot].is_none() {
            let a = *self.dynamics(model, mode);
            let dt = self.h / (1u64 << level) as f64;
            let e = exp_balanced(a * dt);
            self.maps[slot] = Some(Box::new(e.fixed_view::<N, NA>(0, 0).into_owned()));
        }
        self.maps[slot].as_ref().expect("just filled")
    }
}

/// exp(M) through a diagonal similarity that balances M's rows and columns. The axis's
/// states span many orders of magnitude (metres of travel, amperes, newtons through
/// stiffnesses of 10¹⁰ N/m): unbalanced, a stiff drive's step map loses its small entries
/// to the rounding of its large ones (a rigid table's speed drifted by 30 ppm), balanced it
/// keeps them to the last digits.
fn exp_balanced(mut m: AugMatrix) -> AugMatrix {
    let d = nalgebra::linalg::balancing::balance_parlett_reinsch(&mut m);
    let mut e = m.exp();
    nalgebra::linalg::balancing::unbalance(&mut e, &d);
    e
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
}
