//! A machine no template describes (`--template none`): a model of each axis's loop from
//! command to position, identified from the record alone.
//!
//! The model is a cascade on a stiff small ball-screw drive — a proportional position loop
//! with feed-forward and a dead time around a velocity loop, with Coulomb and viscous
//! friction — whose values stand for the loop's behaviour, not for the machine's parts: a
//! table run by a PID on a current amplifier is described by the cascade that follows its
//! commands alike. It is fitted in increasing order, each order kept only where it predicts
//! the record's held-out halves better than the one below it (see [`orders`]). Beside it a
//! second family is fitted (`transfer`): an integrating lead-lag commanding current on the
//! template's screw drive or a rigid body, the structure many such tables run, written where
//! it predicts the held-out halves better than the cascade by a twentieth — the cascade
//! follows an integrating controller's commands alike but not its shape. A force ripple's period, which a template
//! would name, is looked for among the leads ball screws are made with
//! (`super::ripple::period`), for each family on its own fit.

use super::AxisIdentification;
use super::knobs::{self, Knob};
use super::solve::Fit;
use crate::machine::{
    AxisConfig, AxisName, Controller, ControllerOutput, MachineConfig, VelocityLoop,
};
use crate::trace::measured::MeasuredTrace;

mod transfer;

/// The velocity loop's bandwidth the model starts from (Hz): well above a position loop's,
/// so that the lowest order is the position loop alone.
const VELOCITY_BANDWIDTH_HZ: f64 = 50.0;
/// Kv where the record does not tell (m/min/mm): a loop whose lag reads as a higher gain
/// than [`MAX_LAG_KV`] follows by feed-forward or integral action, and starts from this with
/// full velocity feed-forward.
const DEFAULT_KV: f64 = 3.0;
const MAX_LAG_KV: f64 = 10.0;

/// The model's starting point for `measured`: the small-table preset's mechanics, with no
/// travel limits (see the body), and a cascade per axis, its Kv read from the record's steady lag (the speed over the following
/// error while moving), its velocity loop set to [`VELOCITY_BANDWIDTH_HZ`].
pub(crate) fn template(measured: &MeasuredTrace) -> MachineConfig {
    let mut m = MachineConfig::preset("small-table").expect("a built-in preset");
    m.name = "closed loop (from the record)".to_string();
    m.description = "a model of each axis's loop from command to position, identified \
                     without a template: its values describe the loop, not the machine's parts"
        .to_string();
    for axis in AxisName::BOTH {
        let kv = measured.commands.as_ref().and_then(|c| {
            let actual = if axis == AxisName::X {
                &measured.x_m
            } else {
                &measured.y_m
            };
            lag_gain_m_per_min_per_mm(&c[axis.index()], actual, measured.dt_s)
        });
        let kv_from_lag = kv.filter(|kv| *kv <= MAX_LAG_KV);
        let kv = kv_from_lag.unwrap_or(DEFAULT_KV);
        let a = m.axis_mut(axis);
        let inertia = crate::sim::model::AxisModel::from_config(a).j_tot();
        a.controller = Controller::Cascade;
        a.position_loop.kv_m_per_min_per_mm = kv;
        // A loop that follows with little lag (integral action, feed-forward) is the
        // common case on current machines; a plain P loop's lag is found from there too.
        a.position_loop.velocity_feedforward = if kv_from_lag.is_some() { 0.0 } else { 1.0 };
        a.position_loop.accel_feedforward = 0.0;
        a.position_loop.dead_time_ms = 0.0;
        a.velocity_loop = Some(VelocityLoop {
            ks_nm_s_per_rad: std::f64::consts::TAU * VELOCITY_BANDWIDTH_HZ * inertia,
            // Integral action slow enough to leave the lowest order a proportional loop.
            ts_ms: 1000.0,
            i_max_a: a
                .amplifier
                .as_ref()
                .and_then(|amp| amp.i_max_a)
                .unwrap_or(13.5),
        });
        if let Some(amp) = &mut a.amplifier {
            amp.i_max_a = None;
        }
        // The preset's travel is its own table's, not this machine's: the record shows
        // where the machine reaches, and no travel limit is set that it would disprove.
        a.limits.travel_mm = None;
    }
    m.z.limits_mut().travel_mm = None;
    m
}

/// The position-loop gain a steady lag gives: Σ v·e / Σ e² over the samples where the
/// command moves (e the following error, v the command's speed).
fn lag_gain_m_per_min_per_mm(command: &[f64], actual: &[f64], dt: f64) -> Option<f64> {
    let (mut ve, mut ee) = (0.0, 0.0);
    for k in 1..command.len().min(actual.len()) {
        let v = (command[k] - command[k - 1]) / dt;
        let e = command[k] - actual[k];
        if v.abs() > 1e-5 {
            ve += v * e;
            ee += e * e;
        }
    }
    let kv_per_s = ve / ee;
    // 1 m/min/mm is 1000/60 per second.
    let kv = kv_per_s * 60.0 / 1000.0;
    (kv.is_finite() && kv > 0.01 && kv < 100.0).then_some(kv)
}

/// The orders tried, lowest first: the position loop (Kv, feed-forward, dead time) with
/// friction; then the velocity loop's bandwidth too (the moving mass against K_s); then its
/// integral action.
pub(crate) fn orders(axis: &AxisConfig) -> Vec<Vec<Knob>> {
    let all = knobs::for_axis(axis);
    let pick = |keys: &[&str]| -> Vec<Knob> {
        all.iter()
            .copied()
            .filter(|k| keys.contains(&k.key))
            .collect()
    };
    let first = [
        knobs::KV_KEY,
        "position_loop.velocity_feedforward",
        "position_loop.dead_time_ms",
        knobs::COULOMB_KEY,
        knobs::VISCOUS_KEY,
    ];
    let mut second = first.to_vec();
    second.push(knobs::MASS_KEY);
    let mut third = second.clone();
    third.push(knobs::INTEGRAL_TIME_KEY);
    vec![pick(&first), pick(&second), pick(&third)]
}

/// How the report introduces a loop model fitted without a template.
pub(crate) const WITHOUT_TEMPLATE: &str = "no template:";

/// What the report says the model is, at `order` (1-based).
pub(crate) fn describes(order: usize) -> String {
    format!(
        "{WITHOUT_TEMPLATE} a model of the loop from command to position, order {order} of 3 \
         (1: the position loop; 2: and its velocity loop's bandwidth; 3: and integral action), \
         chosen on the record's held-out halves — its values describe the loop, not the \
         machine's parts"
    )
}

/// The model of the family and order the held-out halves choose: the cascade's orders
/// ([`orders`]) and the integrating lead-lag on current ([`transfer`]), each with the
/// ripple its halves keep; the lead-lag is kept over the cascade only where it predicts
/// them better by more than a twentieth, and the report says which family and why.
pub(super) fn identified(
    fit: &Fit,
    template: &MachineConfig,
    moving_only: bool,
    families: Families,
) -> Option<(AxisConfig, AxisIdentification)> {
    // Side by side: where the other axis's search ends first, its core takes one family.
    let (cascade, lead_lag) = rayon::join(
        || {
            families
                .cascade
                .then(|| with_ripple(fit, template, moving_only, Family::Cascade))
                .flatten()
        },
        || {
            families
                .lead_lag
                .then(|| transfer::template(template, fit))
                .flatten()
                .and_then(|start| with_ripple(fit, &start, moving_only, Family::LeadLag))
        },
    );
    chosen_family(cascade, lead_lag)
}

/// Which of the two families are fitted.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct Families {
    /// The cascade, in its orders.
    pub cascade: bool,
    /// The integrating lead-lag on current.
    pub lead_lag: bool,
}

impl Families {
    /// Both: a machine without a template.
    pub const BOTH: Families = Families {
        cascade: true,
        lead_lag: true,
    };

    /// Those a template's axis is not already, up to the values its fit frees: a template's
    /// continuous integrator × lead-lag on current without feed-forward (two zeros, a pole
    /// and the integrator: the loop model's lead-lag), fitted on its own plant, leaves
    /// nothing the loop model's lead-lag would add but a second search's cost; nor does a
    /// cascade without acceleration feed-forward the loop model's cascade. A structure with
    /// what its fit does not free (a feed-forward, a discrete controller's fixed corners)
    /// is compared with both.
    pub fn besides(axis: &AxisConfig) -> Families {
        match &axis.controller {
            Controller::Cascade if axis.position_loop.accel_feedforward == 0.0 => Families {
                cascade: false,
                lead_lag: true,
            },
            Controller::TransferFunction(tf)
                if tf.output == ControllerOutput::Current
                    && tf.numerator.len() == 3
                    && tf.denominator.len() == 3
                    && tf.denominator.last() == Some(&0.0)
                    && tf.sample_ms == 0.0
                    && tf.accel_feedforward == 0.0 =>
            {
                Families {
                    cascade: true,
                    lead_lag: false,
                }
            }
            _ => Families::BOTH,
        }
    }
}

/// The two families a machine without a template is fitted as.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Family {
    /// The cascade of [`template`], in the orders of [`orders`].
    Cascade,
    /// An integrating lead-lag commanding current on the screw drive or a rigid body
    /// (`transfer`).
    LeadLag,
}

/// Of the two families' fits, the one written: the lead-lag where it predicts the held-out
/// halves better than the cascade by more than a twentieth (or the cascade has none), with
/// both figures said.
fn chosen_family(
    cascade: Option<(AxisConfig, AxisIdentification)>,
    lead_lag: Option<(AxisConfig, AxisIdentification)>,
) -> Option<(AxisConfig, AxisIdentification)> {
    let (Some(c), Some(l)) = (&cascade, &lead_lag) else {
        return cascade.or(lead_lag);
    };
    let figures = format!(
        "held out {:.3} µm as the cascade, {:.3} µm as the lead-lag on current",
        c.1.held_out_identified_um, l.1.held_out_identified_um
    );
    let lead_lag_kept = super::predicts_better(&l.1, &c.1);
    let (config, mut id, start) = if lead_lag_kept {
        let (config, mut id) = lead_lag.expect("matched above");
        // Judged against the start every family's figures are compared with: the cascade's.
        id.rms_template_um = c.1.rms_template_um;
        id.held_out_template_um = c.1.held_out_template_um;
        id.better_than_template = !id.held_out_in_sample
            && super::verdict::predicts_better(id.held_out_identified_um, id.held_out_template_um);
        (config, id, "kept: better by more than a twentieth")
    } else {
        let (config, id) = cascade.expect("matched above");
        (config, id, "the lead-lag not better by a twentieth")
    };
    id.kept = format!("{}; families compared: {figures} ({start})", id.kept);
    Some((config, id))
}

/// One family's fit at `template`, with a ripple at the lead its halves take where the
/// template names no period.
fn with_ripple(
    fit: &Fit,
    template: &MachineConfig,
    moving_only: bool,
    family: Family,
) -> Option<(AxisConfig, AxisIdentification)> {
    let chosen = fitted(fit, template, moving_only, family);
    if template.axis(fit.axis()).errors.force_ripple_period_mm > 0.0 {
        return chosen;
    }
    let (config, mut id) = chosen?;
    match super::ripple::period::chosen_mm(fit, &config) {
        Ok(period_mm) => {
            let mut with_period = template.clone();
            let axis = with_period.axis_mut(fit.axis());
            axis.errors.force_ripple_period_mm = period_mm;
            // The refit runs the stages that just succeeded on the same template but for
            // the period of a ripple of zero amplitude, which the simulation does not see;
            // the ripple's own failures are said "not determined" by it, never failing the
            // fit. So it succeeds as the fit without the period did.
            fitted(fit, &with_period, moving_only, family).map(as_looked_for)
        }
        Err(why) => {
            id.force_ripple = Some(super::ripple::period::not_taken(why));
            Some((config, id))
        }
    }
}

/// One family's fit at `template` (a ripple's period in it fitted as a template's): the
/// cascade in the order the held-out halves choose, each order kept over the one below only
/// where it predicts them better by more than a twentieth; the lead-lag with its gain,
/// corners, dead time, mass and friction free.
fn fitted(
    fit: &Fit,
    template: &MachineConfig,
    moving_only: bool,
    family: Family,
) -> Option<(AxisConfig, AxisIdentification)> {
    if family == Family::LeadLag {
        // The corners free: a design's corners, which the template path also tries, are
        // here only a start's (and trying them too would double the family's time).
        let knobs = super::knobs::for_axis(template.axis(fit.axis()));
        let (config, mut id) = super::identify_on(fit, template, moving_only, &knobs)?;
        id.kept = transfer::describes(&config);
        return Some((config, id));
    }
    let mut chosen: Option<(usize, (AxisConfig, AxisIdentification))> = None;
    for (i, knobs) in orders(template.axis(fit.axis())).iter().enumerate() {
        let Some(found) = super::identify_on(fit, template, moving_only, knobs) else {
            continue;
        };
        let better = chosen
            .as_ref()
            .is_none_or(|(_, c)| super::predicts_better(&found.1, &c.1));
        if better {
            chosen = Some((i + 1, found));
        }
    }
    chosen.map(|(order, (config, mut id))| {
        id.kept = describes(order);
        (config, id)
    })
}

/// A loop fitted again with a lead's ripple: where the held-out halves kept it, its
/// statement says the period was looked for; where they did not, the file names no period
/// (a period named there would read as a template's when the file is used as one).
fn as_looked_for(
    (mut config, mut id): (AxisConfig, AxisIdentification),
) -> (AxisConfig, AxisIdentification) {
    match id.force_ripple.as_mut() {
        Some(r) if r.written => r.statement.push_str(super::ripple::period::LOOKED_FOR),
        _ => {
            config.errors.force_ripple_period_mm = 0.0;
            config.errors.force_ripple_n = 0.0;
        }
    }
    (config, id)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_lag_gives_the_gain() {
        // A ramp followed at a lag of v/Kv with Kv 2 m/min/mm = 33.3 /s.
        let dt = 1e-3;
        let kv_per_s = 2.0 * 1000.0 / 60.0;
        let v = 0.01;
        let command: Vec<f64> = (0..1000).map(|k| v * k as f64 * dt).collect();
        let actual: Vec<f64> = command.iter().map(|c| c - v / kv_per_s).collect();
        let kv = lag_gain_m_per_min_per_mm(&command, &actual, dt).unwrap();
        assert!((kv - 2.0).abs() < 1e-9, "{kv}");
        assert_eq!(lag_gain_m_per_min_per_mm(&command, &command, dt), None);
    }
}
