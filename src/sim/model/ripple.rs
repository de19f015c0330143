//! A force that repeats with the table's position: a motor's torque ripple or cogging, a
//! ball screw's eccentricity or a preload that varies over each turn. A rigid-body model
//! of a small ball-screw table misses it most often; it acts whether the table moves or
//! stands (it moves the point where a standing table breaks away).

use crate::machine::Errors;
use crate::numeric::units::m_from_mm;

/// F(x) = A·sin(k·x + φ), pushing the table towards −.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ForceRipple {
    /// Amplitude A (N).
    pub amplitude_n: f64,
    /// Wavenumber k = 2π/period (rad/m).
    pub wavenumber_per_m: f64,
    /// Phase φ at position 0 (rad).
    pub phase_rad: f64,
}

impl ForceRipple {
    /// From the machine file's error terms; none without an amplitude (validation asks a
    /// period of every ripple).
    pub(crate) fn from_config(e: &Errors) -> Option<ForceRipple> {
        (e.force_ripple_n > 0.0 && e.force_ripple_period_mm > 0.0).then(|| ForceRipple {
            amplitude_n: e.force_ripple_n,
            wavenumber_per_m: std::f64::consts::TAU / m_from_mm(e.force_ripple_period_mm),
            phase_rad: e.force_ripple_phase_deg.to_radians(),
        })
    }

    /// The force against the table's + direction with the table at `x_m` (N).
    pub(crate) fn at(&self, x_m: f64) -> f64 {
        self.amplitude_n * (self.wavenumber_per_m * x_m + self.phase_rad).sin()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_ripple_repeats_with_its_period_and_starts_at_its_phase() {
        let errors = Errors {
            force_ripple_n: 12.0,
            force_ripple_period_mm: 10.0,
            force_ripple_phase_deg: 90.0,
            ..Errors::default()
        };
        let r = ForceRipple::from_config(&errors).unwrap();
        // sin(90°) = 1 at 0; a quarter period on, sin(180°) = 0; a period on, 1 again.
        assert!((r.at(0.0) - 12.0).abs() < 1e-12);
        assert!(r.at(2.5e-3).abs() < 1e-12);
        assert!((r.at(10e-3) - 12.0).abs() < 1e-12);
        assert_eq!(ForceRipple::from_config(&Errors::default()), None);
    }
}
