//! How an axis is controlled and driven, as the machine file gives it: the controller's
//! structure (`[axis.controller]`) and, for a drive without a modelled current loop, its
//! current amplifier (`[axis.amplifier]`).
//!
//! The paper's machine is a cascade — P position, PI velocity and PI current loops — and that
//! stays the default: an axis without `[axis.controller]` is controlled by its
//! `position_loop`, `velocity_loop` and `current_loop`. A small table's control is often
//! something else: a PID or lead-lag position controller on a current amplifier (a torque-mode
//! drive), or one that commands a velocity-mode drive, or state feedback designed by pole
//! placement. Those controllers drive an amplifier given by its current bandwidth and peak
//! current; the motor's electrical data are then not needed.

use serde::{Deserialize, Serialize};

/// The axis's controller structure.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(tag = "structure", rename_all = "snake_case")]
pub enum Controller {
    /// P position loop with feed-forward, PI velocity loop, current loop: the keys in
    /// `position_loop`, `velocity_loop` and `current_loop` (or `amplifier`).
    #[default]
    Cascade,
    /// A position controller given as a transfer function from the position error to the
    /// drive's command.
    TransferFunction(TransferFunction),
    /// State feedback on the position error, its integral and the speed.
    StateFeedback(StateFeedback),
}

impl Controller {
    /// Whether this is the default cascade (which the machine file need not name).
    pub(crate) fn is_cascade(&self) -> bool {
        matches!(self, Controller::Cascade)
    }

    /// Whether the drive closes a velocity loop of its own (`velocity_loop` is used).
    pub(crate) fn uses_velocity_loop(&self) -> bool {
        match self {
            Controller::Cascade => true,
            Controller::TransferFunction(tf) => tf.output == ControllerOutput::Velocity,
            Controller::StateFeedback(_) => false,
        }
    }

    /// The structure's name as the machine file spells it.
    pub fn name(&self) -> &'static str {
        match self {
            Controller::Cascade => "cascade",
            Controller::TransferFunction(_) => "transfer_function",
            Controller::StateFeedback(_) => "state_feedback",
        }
    }
}

/// What a transfer-function controller commands.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ControllerOutput {
    /// Motor current (A), to a current amplifier (torque mode).
    Current,
    /// Table speed (m/min), to a velocity-mode drive: the axis's `velocity_loop` closes the
    /// speed loop. A constant C = Kv is the cascade's P position controller.
    Velocity,
}

/// C(s) or C(z) = N/D from the position error (mm) to the output.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TransferFunction {
    /// Numerator coefficients, highest power first.
    pub numerator: Vec<f64>,
    /// Denominator coefficients, highest power first (no higher degree than the numerator's
    /// would make the controller improper and is refused).
    pub denominator: Vec<f64>,
    /// What the controller commands.
    pub output: ControllerOutput,
    /// 0: the coefficients are in s (continuous). Above 0: they are in z for this sample
    /// period (ms), as a digital controller is written; the simulation takes the controller
    /// to continuous time by the inverse bilinear (Tustin) map, so the hold's half-period
    /// delay is not in the model (add it to `position_loop.dead_time_ms` where it matters).
    #[serde(default)]
    pub sample_ms: f64,
    /// Share of the commanded speed added to the velocity command (velocity output only).
    #[serde(default)]
    pub velocity_feedforward: f64,
    /// Share of the current that accelerates the whole drive, J_tot·a_ref/(r·i_t·K_t), added
    /// to the current command.
    #[serde(default)]
    pub accel_feedforward: f64,
}

/// Current command i = k_p·e + k_i·∫e + k_d·(k_f·v_ref − v) + k_a·(J_tot·a_ref/(r·i_t·K_t)),
/// with e the position error (mm) and v the motor's speed as table speed (mm/s).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StateFeedback {
    /// Gain on the position error (A/mm).
    pub position_gain_a_per_mm: f64,
    /// Gain on the error's integral (A/(mm·s)); 0 for none.
    #[serde(default)]
    pub integral_gain_a_per_mm_s: f64,
    /// Gain on the speed error (A per mm/s).
    pub velocity_gain_a_s_per_mm: f64,
    /// Share of the commanded speed in the speed error (1: the speed error is v_ref − v).
    #[serde(default)]
    pub velocity_feedforward: f64,
    /// Share of the accelerating current fed forward.
    #[serde(default)]
    pub accel_feedforward: f64,
}

/// A current amplifier: the motor current follows its command as a first-order lag. Given,
/// it replaces the current loop (`current_loop` and the motor's electrical data are not
/// used): the drive's own current control is taken as ideal up to its bandwidth, and the
/// supply voltage is taken to suffice.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Amplifier {
    /// −3 dB bandwidth of the current response (Hz).
    pub current_bandwidth_hz: f64,
    /// Peak current (A): the limit of the current command where no velocity loop limits it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub i_max_a: Option<f64>,
}

/// Where in a `[axis.controller]` section its error lies, and the error there: the section
/// is read whole by its `structure` tag, so the reader's own error names the section alone.
/// Read again as the structure's own keys, the error names the key (`output`,
/// `numerator[1]`, …) with what is wrong with it; `None` where the section names no
/// structure with keys of its own, or they read.
pub(crate) fn error_within(section: &toml::Table) -> Option<(String, String)> {
    fn read<T: serde::de::DeserializeOwned>(keys: toml::Table) -> Option<(String, String)> {
        let e = serde_path_to_error::deserialize::<_, T>(toml::Value::Table(keys)).err()?;
        Some((e.path().to_string(), e.inner().to_string()))
    }
    let mut keys = section.clone();
    let structure = keys.remove("structure")?;
    match structure.as_str()? {
        "transfer_function" => read::<TransferFunction>(keys),
        "state_feedback" => read::<StateFeedback>(keys),
        _ => None,
    }
}
