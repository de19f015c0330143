//! An independent reference for the diagnosis: the servo-feed axis of `docs/model.md` §1
//! integrated here, apart from `contourcheck::sim` — the paper's cascade, or a transfer
//! function or state feedback commanding a current amplifier (a first-order lag) with the
//! position read at the motor's encoder where the machine file says so (the motor's own
//! angle, where the tool reads the screw's) — classical fourth-order Runge–Kutta at a
//! fixed step of a few microseconds, friction switched by a sticking test at each step rather
//! than by the simulator's exact switching instants — and driven by a continuous trapezoidal
//! interpolator that stops at every block end, evaluated at every step rather than once per
//! interpolation cycle. Records made here share with the tool only the machine file's numbers
//! and the model's equations; what the tool's own planner, command reconstruction and
//! integrator do differently shows up as residual.
//!
//! One file a concept: the axis's constants read from the machine file (`plant`), the laws its
//! current is commanded by (`controllers`), its state integrated step by step (`axis`), the
//! continuous interpolator that drives it (`interpolator`), and a record taken of a program
//! run on it (`recording`).

mod axis;
mod controllers;
mod interpolator;
mod plant;
mod recording;

// Each test binary uses some of these: the rest would be unused imports in it.
#[allow(unused_imports)]
pub use axis::{Axis, Reference};
#[allow(unused_imports)]
pub use interpolator::{Trapezoids, s_curve_phases, through_phases};
#[allow(unused_imports)]
pub use plant::{Cycle, Plant, Timed};
#[allow(unused_imports)]
pub use recording::{Recording, record, record_xyz};
