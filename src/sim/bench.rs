//! The simulator's innermost pieces, for the benches in `benches/` to time on their own: the
//! step maps of every level of an axis's modes (shared work against each level computed
//! alone) and the hybrid step (compiled for AVX or portable). Not an interface.

use super::AxisModel;
use super::discrete::LEVELS;
use super::hybrid::AxisSim;
use super::model::{AR, ContactMode, FrictionMode, Mode, VR, XR};
use super::simulate::rest_state;

/// Every friction and contact mode with the limits off.
fn modes() -> impl Iterator<Item = Mode> {
    use super::model::ClampMode::Linear;
    [
        FrictionMode::SlipPos,
        FrictionMode::SlipNeg,
        FrictionMode::Stick,
    ]
    .into_iter()
    .flat_map(|friction| {
        [ContactMode::Pos, ContactMode::Free, ContactMode::Neg]
            .into_iter()
            .map(move |contact| Mode {
                friction,
                contact,
                current: Linear,
                voltage: Linear,
            })
    })
}

/// The maps of steps h/2⁰ … h/2²⁴ in each of the axis's nine modes, the levels sharing
/// their work as the simulator computes them. Returns their entries' sum.
pub fn step_maps_shared(model: &AxisModel, h: f64) -> f64 {
    modes()
        .map(|mode| super::discrete::all_levels(&model.dynamics(mode), h))
        .sum()
}

/// The same maps with each level's exponential computed on its own (nalgebra's `exp` of
/// the balanced matrix halved level by level: balanced once, as the simulator once did).
pub fn step_maps_each_level(model: &AxisModel, h: f64) -> f64 {
    use nalgebra::linalg::balancing::{balance_parlett_reinsch, unbalance};
    let mut sum = 0.0;
    for mode in modes() {
        let mut balanced = model.dynamics(mode) * h;
        let d = balance_parlett_reinsch(&mut balanced);
        for level in 0..=LEVELS {
            let mut e = (balanced * (1.0 / (1u64 << level) as f64)).exp();
            unbalance(&mut e, &d);
            sum += e
                .fixed_view::<{ super::model::N }, { super::model::NA }>(0, 0)
                .sum();
        }
    }
    sum
}

/// `steps` hybrid steps of h from rest following a 5 mm, 5 Hz sine (reversals every 0.1 s:
/// sticking, breakaway, bisections), in the copy compiled for AVX or the portable one.
/// Returns the table's final position (m).
pub fn hybrid_steps(model: &AxisModel, h: f64, steps: usize, avx: bool) -> f64 {
    let mut sim = AxisSim::new(model, h);
    sim.use_avx(avx);
    let (mut x, mut mode) = rest_state(model, 0.0);
    let w = std::f64::consts::TAU * 5.0;
    for k in 0..steps {
        let t = k as f64 * h;
        x[XR] = 5e-3 * (w * t).sin();
        x[VR] = 5e-3 * w * (w * t).cos();
        x[AR] = -5e-3 * w * w * (w * t).sin();
        if sim.step(&mut x, &mut mode, t, None).is_err() {
            return f64::NAN;
        }
    }
    x[super::model::X2]
}
