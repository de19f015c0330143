//! Presliding friction (the LuGre model, docs/model.md §1.9): the guideway's contacts as
//! bristles of mean deflection z that bend elastically before the table slides,
//!
//! ```text
//!   dz/dt = v − σ0·|v|·z / g(v),   F = σ0·z + σ1·dz/dt + f_v·v,
//!   g(v)  = f_c + (f_rest − f_c)·exp(−(v/v_s)²)  (+ what the friction maps add),
//! ```
//!
//! so that a table at rest yields by about g/σ0 before it slides, and a small motion back
//! and forth traces a hysteresis loop instead of a stick/slip switch. The friction is one
//! smooth force in every state: the axis runs in a sliding mode without a Coulomb term, and
//! the bristles' force is held over each simulation sub-step as the table's external force.
//!
//! Why the sub-step update is stable: the bristle equation is stiff while sliding (z settles
//! within a displacement of g/σ0, a few µm, in microseconds), so explicit Euler would blow up
//! at any useful step. Written per unit of travel, dz/dx = 1 − σ0·sgn(v)·z/g is linear in z,
//! and its exact solution over a displacement Δx of one sign,
//! z₁ = z∞ + (z₀ − z∞)·exp(−σ0·|Δx|/g) with z∞ = sgn(Δx)·g/σ0, cannot overshoot whatever
//! the step. What remains explicit is the bristles' push on the table, held over the
//! sub-step: that is the explicit step of a spring σ0 and a damper σ1 on the table's mass,
//! stable and accurate while the step is short against √(m/σ0) and m/σ1 — the run divides
//! its cycle finely enough ([`Presliding::substeps`]).

use crate::machine::{AxisConfig, bristle_steps_s};
use crate::numeric::units::m_per_s_from_mm_per_min;

/// The presliding parameters of one axis, in SI.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Presliding {
    /// Bristle stiffness σ0 (N/m).
    pub sigma0_n_per_m: f64,
    /// Bristle damping σ1 (N·s/m).
    pub sigma1_n_s_per_m: f64,
    /// Coulomb friction f_c (N).
    pub coulomb_n: f64,
    /// Friction level at rest f_rest (N) towards + and towards −: static friction, or below
    /// Coulomb's where the machine file says so; the same both ways unless it gives a level
    /// towards − of its own (a guideway whose lubrication or preload differs by direction).
    pub rest_n: [f64; 2],
    /// Speed over which the level at rest passes into Coulomb's (m/s); 0 when they are equal.
    pub fade_m_per_s: f64,
}

impl Presliding {
    /// The axis's presliding friction, if its machine file gives bristles: Coulomb friction
    /// `f_c` and the level at rest `f_rest` (N) each way as the model derives them.
    pub(crate) fn from_config(c: &AxisConfig, f_c: f64, f_rest: [f64; 2]) -> Option<Presliding> {
        let f = &c.friction;
        f.has_presliding().then(|| Presliding {
            sigma0_n_per_m: f.bristle_stiffness_n_per_um * 1e6,
            sigma1_n_s_per_m: f.bristle_damping_n_s_per_m,
            coulomb_n: f_c,
            rest_n: f_rest,
            fade_m_per_s: m_per_s_from_mm_per_min(f.stribeck_velocity_mm_per_min),
        })
    }

    /// The steady sliding friction g(v) (N) at speed `v_m_per_s`, with `added_n` from the
    /// friction maps; never negative. The level near rest is that of the direction moved
    /// (at a standstill the bristles do not bend, whichever is taken).
    pub(crate) fn level_n(&self, v_m_per_s: f64, added_n: f64) -> f64 {
        let rest_n = self.rest_n[usize::from(v_m_per_s < 0.0)];
        let fade = if self.fade_m_per_s > 0.0 {
            (-(v_m_per_s / self.fade_m_per_s).powi(2)).exp()
        } else {
            0.0
        };
        (self.coulomb_n + (rest_n - self.coulomb_n) * fade + added_n).max(0.0)
    }

    /// Sub-steps a cycle of `dt_s` needs for the bristles on a table of `mass_kg`.
    pub(crate) fn substeps(&self, dt_s: f64, mass_kg: f64) -> usize {
        let [spring_s, damper_s] =
            bristle_steps_s(mass_kg, self.sigma0_n_per_m, self.sigma1_n_s_per_m);
        // Validation keeps the step at a microsecond or longer; the cap guards the count.
        (dt_s / spring_s.min(damper_s)).ceil().clamp(1.0, 1e6) as usize
    }

    /// The bristles' deflection after the table travels `dx_m` from deflection `z_m`, with
    /// the sliding level `level_n` held: the exact solution of dz/dx (module comment).
    pub(crate) fn bent(&self, z_m: f64, dx_m: f64, level_n: f64) -> f64 {
        if dx_m == 0.0 {
            return z_m;
        }
        let z_end = dx_m.signum() * level_n / self.sigma0_n_per_m;
        let decay = if level_n > 0.0 {
            (-self.sigma0_n_per_m * dx_m.abs() / level_n).exp()
        } else {
            0.0
        };
        z_end + (z_m - z_end) * decay
    }

    /// The bristles' force on the table held over a sub-step of `h_s` that starts at
    /// deflection `z_m` and speed `v_m_per_s` (N, against positive travel): σ0 times the
    /// deflection midway plus σ1 times its mean rate, as the speed at the start predicts them.
    /// The viscous term f_v·v is the mode's own (exact) damping.
    pub(crate) fn held_force_n(&self, z_m: f64, v_m_per_s: f64, h_s: f64, level_n: f64) -> f64 {
        let dx = v_m_per_s * h_s;
        let z_mid = self.bent(z_m, 0.5 * dx, level_n);
        let z_end = self.bent(z_m, dx, level_n);
        self.sigma0_n_per_m * z_mid + self.sigma1_n_s_per_m * (z_end - z_m) / h_s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bristles() -> Presliding {
        Presliding {
            sigma0_n_per_m: 50e6,
            sigma1_n_s_per_m: 2e4,
            coulomb_n: 100.0,
            rest_n: [80.0, 80.0],
            fade_m_per_s: 0.001,
        }
    }

    /// The exact update agrees with a fine explicit integration of dz/dx = 1 − σ0·z/g, and
    /// one step of any length gives what many short ones give (it composes).
    #[test]
    fn the_deflection_follows_its_equation_at_any_step() {
        let p = bristles();
        let g = 100.0;
        let mut z = -1.0e-6;
        let n = 200_000;
        let dx = 10e-6 / n as f64;
        for _ in 0..n {
            z += dx * (1.0 - p.sigma0_n_per_m * z / g);
        }
        let exact = p.bent(-1.0e-6, 10e-6, g);
        assert!(
            (exact - z).abs() < 1e-4 * g / p.sigma0_n_per_m,
            "{exact} {z}"
        );
        let halves = p.bent(p.bent(-1.0e-6, 5e-6, g), 5e-6, g);
        assert!((halves - exact).abs() < 1e-15);
        // A step a thousand times the presliding range lands on the steady deflection.
        assert!((p.bent(0.0, 2e-3, g) - g / p.sigma0_n_per_m).abs() < 1e-18);
    }

    /// The level is f_rest at rest, Coulomb's far above the fade speed, and below Coulomb's
    /// near rest where f_rest is.
    #[test]
    fn the_level_passes_from_rest_to_coulomb() {
        let p = bristles();
        assert!((p.level_n(0.0, 0.0) - 80.0).abs() < 1e-12);
        assert!((p.level_n(0.01, 0.0) - 100.0).abs() < 1e-9);
        let at_fade = 100.0 - 20.0 * (-1.0f64).exp();
        assert!((p.level_n(-0.001, 0.0) - at_fade).abs() < 1e-12);
    }

    /// A level near rest towards − of its own acts only while the table moves towards −;
    /// far above the fade speed both directions slide at Coulomb's level.
    #[test]
    fn the_level_near_rest_is_that_of_the_direction_moved() {
        let p = Presliding {
            rest_n: [20.0, 140.0],
            ..bristles()
        };
        // At a thousandth of the fade speed the fade is exp(−1e−6): the level near rest.
        assert!((p.level_n(1e-6, 0.0) - 20.0).abs() < 1e-3);
        assert!((p.level_n(-1e-6, 0.0) - 140.0).abs() < 1e-3);
        assert!((p.level_n(0.01, 0.0) - 100.0).abs() < 1e-9);
        assert!((p.level_n(-0.01, 0.0) - 100.0).abs() < 1e-9);
    }

    /// A cycle is cut so that each sub-step is a tenth of the bristles' time scale.
    #[test]
    fn sub_steps_resolve_the_bristles() {
        let p = bristles();
        // √(50 kg / 5e7 N/m) = 1 ms, 50/2e4 = 2.5 ms: 0.1 ms steps, 10 per 0.95 ms cycle.
        assert_eq!(p.substeps(0.95e-3, 50.0), 10);
        assert_eq!(p.substeps(1e-5, 50.0), 1);
    }
}
