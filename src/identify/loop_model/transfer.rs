//! The second family a machine without a template may be: a position controller that
//! commands current — an integrator cascaded with a lead-lag, as tables and drives run on
//! torque-mode amplifiers are commonly controlled — on the drive it moves, with Coulomb and
//! viscous friction. Like the cascade's, its values describe the loop, not the machine's
//! parts: the drive is the small-table preset's, either as it is (motor, coupling, screw and
//! table, the screw's and coupling's stiffness the preset's) or as one rigid mass at the
//! table (its rotating inertia taken through the screw), and the controller's gain is found
//! relative to that inertia and the motor's torque constant.
//!
//! Why both drives: the screw's stiffness is no value the record fits, but it shows in it —
//! the friction and the table's inertia strain the screw, the table lags the motor by that
//! strain and the strain flips at each reversal. On the preset's screw (100 N/µm) the table's
//! 30–60 N of friction is 0.3–0.6 µm, ten times a fine scale's noise: a table run by such a
//! controller on such a drive is not reached by the rigid mass however its controller is
//! fitted (0.6 µm left at the very values it runs, against 0.06 µm of noise). Where the
//! record shows no such strain (a stiffer screw, forces unlike the preset's), the rigid mass
//! is kept: it holds no stiffness the record did not give.
//!
//! Where it starts: the usual design of such a controller on the rigid mass — gain crossover
//! ω_c with 60° of phase margin, the integral corner at a tenth of ω_c, the lead making up the
//! phase the body and the integrator take — for each crossover of [`CROSSOVERS_HZ`] on either
//! drive, the one whose loop leaves the record's least residual, the screw drive only where
//! its best start leaves a twentieth less than the rigid mass's (RMS). The fit
//! (`super::super::identify_on`) then solves the record's equation for the controller and
//! searches its corners.

use super::super::knobs::{self, COULOMB_KEY};
use super::super::solve::Fit;
use crate::machine::{
    AxisConfig, Controller, ControllerOutput, DriveKind, MachineConfig, TransferFunction,
};
use crate::sim::AxisModel;

/// What the report says the model is, on the drive it was fitted on.
pub(super) fn describes(axis: &AxisConfig) -> String {
    let body = match axis.drive.kind {
        DriveKind::LinearMotor => "a rigid body",
        _ => "the template's screw drive (its stiffness the template's)",
    };
    format!(
        "{} a model of the loop from command to position as an integrating \
         lead-lag commanding current on {body} with Coulomb and viscous friction — its values \
         describe the loop, not the machine's parts",
        super::WITHOUT_TEMPLATE
    )
}

/// The crossovers the start is chosen among (Hz): a factor two apart, from a slow
/// positioning table's to a stiff direct drive's.
const CROSSOVERS_HZ: [f64; 5] = [5.0, 10.0, 20.0, 40.0, 80.0];
/// The design's phase margin (°) and its integral corner as a share of the crossover.
const PHASE_MARGIN_DEG: f64 = 60.0;
const INTEGRAL_SHARE: f64 = 0.1;
/// The most phase one lead stage is asked for (°): beyond it the lead's pole and zero lie
/// so far apart that the design's gain at high frequency would amplify the counts' noise.
const MAX_LEAD_DEG: f64 = 75.0;

/// How much less residual (RMS) the screw drive's best start must leave than the rigid
/// mass's to be taken: a twentieth, as the families are compared by. The rigid mass holds no
/// stiffness the record did not give; the screw's is the preset's, taken only where the
/// record shows a strain of its size.
const SCREW_SHOWN: f64 = 0.95;

/// `base` with `fit`'s axis under an integrating lead-lag on current, designed at the
/// crossover of [`CROSSOVERS_HZ`] on the rigid mass whose loop follows the record best: on
/// the template's screw drive where that follows it better by [`SCREW_SHOWN`], else on the
/// rigid mass; none where no design can be simulated.
pub(super) fn template(base: &MachineConfig, fit: &Fit) -> Option<MachineConfig> {
    let rigid = rigid_body(base.axis(fit.axis()));
    let screw = on_current(base.axis(fit.axis()));
    // The same controller on either: the rigid mass is the screw drive's inertia.
    let best = |drive: &AxisConfig| {
        CROSSOVERS_HZ
            .iter()
            .filter_map(|&fc| {
                let mut a = drive.clone();
                a.controller = Controller::TransferFunction(designed(&rigid, fc));
                Some((fit.cost(&a)?, a))
            })
            .filter(|(cost, _)| cost.is_finite())
            .min_by(|a, b| a.0.total_cmp(&b.0))
    };
    let axis = match (best(&rigid), best(&screw)) {
        (Some(r), Some(s)) if s.0 < SCREW_SHOWN * SCREW_SHOWN * r.0 => s.1,
        (Some(r), _) => r.1,
        (None, s) => s?.1,
    };
    let mut m = base.clone();
    *m.axis_mut(fit.axis()) = axis;
    Some(m)
}

/// `axis`'s drive as one rigid body at the table: the whole inertia the motor moves as a
/// mass (J_tot over the travel per motor radian squared), the motor's torque constant as a
/// force constant, the Coulomb force kept; commanded as [`on_current`].
fn rigid_body(axis: &AxisConfig) -> AxisConfig {
    let model = AxisModel::from_config(axis);
    let travel_m_per_rad = model.travel_per_motor_rad();
    let coulomb_n = knobs::get(axis, COULOMB_KEY);
    let mut a = on_current(axis);
    a.drive.kind = DriveKind::LinearMotor;
    a.drive.table_mass_kg = model.j_tot() / (travel_m_per_rad * travel_m_per_rad);
    a.motor.kt_nm_per_a = axis.motor.kt_nm_per_a / travel_m_per_rad;
    knobs::set_all(&mut a, &[COULOMB_KEY], &[coulomb_n]);
    a
}

/// `axis`'s drive as it is, ready for a controller that commands current: no dead time, no
/// cascade's gains or velocity loop, the amplifier's peak current the limit.
fn on_current(axis: &AxisConfig) -> AxisConfig {
    let mut a = axis.clone();
    a.position_loop.dead_time_ms = 0.0;
    // The cascade's gains, which a transfer function does not use (nor its file write).
    a.position_loop.kv_m_per_min_per_mm = 0.0;
    a.position_loop.velocity_feedforward = 0.0;
    // No velocity loop limits the current commanded: the amplifier's peak current does (the
    // cascade's start holds it in its velocity loop).
    if let (Some(amp), Some(v)) = (&mut a.amplifier, &axis.velocity_loop) {
        amp.i_max_a = amp.i_max_a.or(Some(v.i_max_a));
    }
    a.velocity_loop = None;
    a
}

/// The integrating lead-lag K·(αT·s + 1)(s + ω_i)/((T·s + 1)·s) from the error (mm) to the
/// current (A) that crosses over at `crossover_hz` with [`PHASE_MARGIN_DEG`] on `axis`'s
/// rigid body M·s² + b·s behind a force constant k (N/A).
pub(super) fn designed(axis: &AxisConfig, crossover_hz: f64) -> TransferFunction {
    let (m, b) = (axis.drive.table_mass_kg, axis.friction.viscous_n_s_per_m);
    let force_per_a = axis.motor.kt_nm_per_a;
    let wc = std::f64::consts::TAU * crossover_hz;
    let wi = INTEGRAL_SHARE * wc;
    // The body's phase at ω_c, and the integrator's.
    let body_deg = -90.0 - (wc * m).atan2(b).to_degrees();
    let integrator_deg = -(wi / wc).atan().to_degrees();
    let lead_deg =
        (PHASE_MARGIN_DEG - (180.0 + body_deg + integrator_deg)).clamp(0.0, MAX_LEAD_DEG);
    let s = lead_deg.to_radians().sin();
    let alpha = (1.0 + s) / (1.0 - s);
    let t = 1.0 / (wc * alpha.sqrt());
    // |P(jω_c)| in mm/A: 1000·k/(ω_c·|jω_c·M + b|).
    let body_mm_per_a = 1000.0 * force_per_a / (wc * (wc * m).hypot(b));
    let k = 1.0 / (alpha.sqrt() * (1.0 + (wi / wc).powi(2)).sqrt() * body_mm_per_a);
    TransferFunction {
        numerator: vec![k * alpha, k * (alpha * t * wi + 1.0) / t, k * wi / t],
        denominator: vec![1.0, 1.0 / t, 0.0],
        output: ControllerOutput::Current,
        sample_ms: 0.0,
        velocity_feedforward: 0.0,
        accel_feedforward: 0.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Complex;

    /// A polynomial (highest power first) at `s`.
    fn at(coefficients: &[f64], s: Complex<f64>) -> Complex<f64> {
        coefficients
            .iter()
            .fold(Complex::new(0.0, 0.0), |acc, &c| acc * s + c)
    }

    #[test]
    fn the_design_crosses_over_where_asked_with_its_phase_margin() {
        // A 40 kg body with 300 N·s/m behind 80 N/A, and a frictionless one (the body's own
        // phase then -180°): the open loop C(jω_c)·1000·k/(jω_c·(jω_c·M + b)) is 1 in
        // magnitude at ω_c and 60° above -180°.
        for b in [300.0, 0.0] {
            let mut axis = MachineConfig::preset("small-table").unwrap().x;
            axis.drive.table_mass_kg = 40.0;
            axis.friction.viscous_n_s_per_m = b;
            axis.motor.kt_nm_per_a = 80.0;
            let c = designed(&axis, 20.0);
            let s = Complex::new(0.0, std::f64::consts::TAU * 20.0);
            let body = 1000.0 * 80.0 / (s * (s * 40.0 + b));
            let open = at(&c.numerator, s) / at(&c.denominator, s) * body;
            assert!((open.norm() - 1.0).abs() < 1e-9, "{b}: {}", open.norm());
            let margin_deg = 180.0 + open.arg().to_degrees();
            assert!((margin_deg - 60.0).abs() < 1e-6, "{b}: {margin_deg}");
            // An integrator (a zero constant term in the denominator) with its corner at a
            // tenth of the crossover: the numerator's roots hold 2π·2 Hz.
            assert_eq!(c.denominator[2], 0.0);
            let wi = std::f64::consts::TAU * 2.0;
            assert!(at(&c.numerator, Complex::new(-wi, 0.0)).norm() < 1e-6 * c.numerator[2]);
        }
    }

    #[test]
    fn the_rigid_body_moves_as_the_drive_did() {
        // The preset's drive as one mass: its inertia at the motor over the travel per
        // radian squared, J_m + J_s + M·r² (i_t 1) over r², and the force constant K_t/r.
        let axis = MachineConfig::preset("small-table").unwrap().x;
        let r = axis.drive.lead_mm * 1e-3 / std::f64::consts::TAU;
        let j = axis.motor.jm_kg_m2
            + axis.drive.gear_ratio.powi(2) * axis.drive.js_kg_m2
            + (r * axis.drive.gear_ratio).powi(2) * axis.drive.table_mass_kg;
        let body = rigid_body(&axis);
        let expected_kg = j / (r * axis.drive.gear_ratio).powi(2);
        assert!((body.drive.table_mass_kg / expected_kg - 1.0).abs() < 1e-12);
        let expected_n_per_a = axis.motor.kt_nm_per_a / (r * axis.drive.gear_ratio);
        assert!((body.motor.kt_nm_per_a / expected_n_per_a - 1.0).abs() < 1e-12);
        let coulomb = |a: &AxisConfig| knobs::get(a, COULOMB_KEY);
        assert!((coulomb(&body) / coulomb(&axis) - 1.0).abs() < 1e-12);
        assert_eq!(body.drive.kind, DriveKind::LinearMotor);
    }
}
