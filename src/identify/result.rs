//! What an identification is: each value written (fitted, traded, loose or the template's)
//! with its uncertainty, each axis with the figures it is judged by, the whole machine, and why a
//! record cannot identify one. The search and the judging live beside it; these are what
//! the report, the JSON, the HTML page and the machine file's header read.

use serde::Serialize;

use super::baseline::Baseline;
use super::interpolator::Interpolator;
use super::verdict::{Place, WhileMoving};
use crate::compare::CompareError;
use crate::compare::start::Coverage;
use crate::machine::{AxisName, MachineConfig};

/// One identified value.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct IdentifiedValue {
    /// Key below the axis (`friction.coulomb_n`: the Coulomb force, written to the machine
    /// file as the coefficient).
    pub key: &'static str,
    /// Unit.
    pub unit: &'static str,
    /// The template's value.
    pub template: f64,
    /// The value written: fitted, or the template's where the record does not determine it.
    pub value: f64,
    /// Its standard uncertainty (NaN where the template's).
    pub uncertainty: f64,
    /// Whether the record determines it: fitted, with an uncertainty within half of it (or
    /// of its scale), on a fit whose halves predict each other. A value fitted and written
    /// though the record leaves it looser than that is not determined: it names the value
    /// it trades with (`traded_with`), or is `loose`. None of these: the template's.
    pub determined: bool,
    /// Whether it reads as the machine's own value: determined, with an uncertainty —
    /// widened to what a modelling difference of half the noise could move it by — within
    /// half of it. A determined value that is not measured is written because it predicts
    /// the record: a model's value, not a measurement.
    pub measured: bool,
    /// Where the record does not determine the value alone (its uncertainty beyond half of
    /// it) yet it is written — the fit with it predicts the held-out halves better than with
    /// the template's put back —: the value it trades with most. Only their combination is
    /// the record's; the value alone is neither determined, nor a measurement, nor certain.
    /// `held_at_start_n` where a fit at the noise, fitted again beside the force held at the
    /// record's start, moves this value beyond its uncertainty and beyond what noise alone
    /// would; the key of a value put back to the template's where, fitted again about it at
    /// the noise, this value moved so (the uncertainty then widened to the move).
    pub traded_with: Option<&'static str>,
    /// Fitted and written, but the record leaves it loose: the fit on every sample reached
    /// the record's noise, yet its halves' fits predict each other while the axis moves only
    /// to more than twice the noise (the axis judged there) — each half put the values
    /// elsewhere. Written because they predict better than the template; not determined,
    /// not a measurement.
    pub loose: bool,
    /// Where a corner the fit moved is no longer a real root — two real corners of the
    /// template's went into a complex pair —: that pair (the value is then NaN, though the
    /// coefficients written are finite).
    pub complex_pair: Option<ComplexPair>,
}

/// A complex pair of roots of a transfer function's numerator or denominator.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ComplexPair {
    /// Its natural frequency, the roots' modulus (Hz).
    pub natural_hz: f64,
    /// Its damping ratio (the real part's share of the modulus, negated).
    pub damping: f64,
}

/// A value as the JSON report writes it: its fields and whether it is [`fitted`]
/// (`IdentifiedValue::fitted`), so that readers of the report do not derive it again.
#[derive(Serialize)]
struct ValueJson<'a> {
    #[serde(flatten)]
    value: &'a IdentifiedValue,
    fitted: bool,
}

fn values_json<S: serde::Serializer>(
    values: &[IdentifiedValue],
    serializer: S,
) -> Result<S::Ok, S::Error> {
    serializer.collect_seq(values.iter().map(|value| ValueJson {
        value,
        fitted: value.fitted(),
    }))
}

/// The held-out figures an axis is judged by ([`AxisIdentification::judged_held_out`]), as
/// the JSON report writes them.
#[derive(Serialize)]
struct JudgedHeldOut {
    template_um: f64,
    identified_um: f64,
    following_error_um: f64,
    share: f64,
    /// Whether these are the figures while the axis moves.
    while_moving: bool,
    /// Whether `identified_um` is in-sample (no half's fit had a point of its own).
    in_sample: bool,
}

/// An axis as the JSON report writes it: its fields and the held-out figures it is judged
/// by (`judged_held_out`).
#[derive(Serialize)]
struct AxisJson<'a> {
    #[serde(flatten)]
    axis: &'a AxisIdentification,
    judged_held_out: JudgedHeldOut,
}

pub(super) fn axes_json<S: serde::Serializer>(
    axes: &[AxisIdentification],
    serializer: S,
) -> Result<S::Ok, S::Error> {
    serializer.collect_seq(axes.iter().map(|axis| {
        let (template_um, identified_um, following_error_um, share) = axis.judged_held_out();
        let while_moving = axis.judged_while_moving && axis.while_moving.is_some();
        AxisJson {
            axis,
            judged_held_out: JudgedHeldOut {
                template_um,
                identified_um,
                following_error_um,
                share,
                while_moving,
                in_sample: axis.held_out_in_sample && !while_moving,
            },
        }
    }))
}

impl IdentifiedValue {
    /// Whether the value written is fitted to the record (determined, traded with another,
    /// or loose), rather than the template's.
    pub fn fitted(&self) -> bool {
        self.determined || self.traded_with.is_some() || self.loose
    }
}

/// A current-commanding controller's gain over the whole drive's inertia: what a rigid
/// drive's loop depends on. The record tells the gain from the table's mass only through
/// the rotor's and screw's share of the inertia (which the template gives) and the drive's
/// compliance, and a modelling difference moves both along their ratio; the ratio itself it
/// determines.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GainPerInertia {
    /// The gain's key.
    pub gain: &'static str,
    /// The drive's inertia as a mass at the table, identified: the rotor's and screw's
    /// (the template's) with the table's (kg).
    pub inertia_kg: f64,
    /// The gain over it (the gain's unit per kg).
    pub value: f64,
    /// Its standard uncertainty, with the model's floor as every value's.
    pub uncertainty: f64,
}

/// One axis identified.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AxisIdentification {
    /// The axis.
    pub axis: AxisName,
    /// Its values.
    #[serde(serialize_with = "values_json")]
    pub values: Vec<IdentifiedValue>,
    /// What is taken from the template as the user's setting, not fitted.
    pub kept: String,
    /// Compared only while moving (away from standstills, where the axis hunts): the
    /// residuals below are over those samples.
    pub moving_only: bool,
    /// Whether the fit reached the record's noise. Where it did not, no value reads as a
    /// measurement: the fit is written as a model's values where it predicts the held-out
    /// halves better than the template (`better_than_template`), else the template's stay.
    pub reached: bool,
    /// Whether the values written predict the record's held-out halves better than the
    /// template's (by more than a twentieth): the fit is written, reached or not.
    pub better_than_template: bool,
    /// RMS of the following error in the record (µm): the yardstick of the residuals.
    pub following_error_rms_um: f64,
    /// The held-out residual as a share of the following error on the same samples.
    pub held_out_share: f64,
    /// The plain regression of the following error on the command (the baseline a model
    /// must beat), scored on blocks it was not fitted on.
    pub baseline: Baseline,
    /// Where the residual the written values leave is largest.
    pub largest_at: Option<Place>,
    /// The residual RMS with the template, whole record (µm).
    pub rms_template_um: f64,
    /// With the identified values.
    pub rms_identified_um: f64,
    /// What the machine file written gives on this record (µm RMS): its values run on the
    /// record as `diagnose` compares a machine with it — every sample compared, the file's
    /// own hunting holds left out, no force held at the start (the file holds none) —, where
    /// that differs from `rms_identified_um` by more than a twentieth (figures while moving,
    /// a force held at the start, holds of the file's own); `None` where it does not, or the
    /// axis was not fitted.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub file_rms_um: Option<f64>,
    /// On each half of the record, the template's residual …
    pub held_out_template_um: f64,
    /// … and that of the values fitted on the other half (µm).
    pub held_out_identified_um: f64,
    /// Whether `held_out_identified_um` is in-sample, not held out: neither half's fit moved
    /// from the whole fit's values (fitted to both halves), so the figure is the whole fit's
    /// on samples it was fitted to. Such a fit has shown nothing about data it did not see.
    pub held_out_in_sample: bool,
    /// The template already explains the record to its noise and the values fitted predict
    /// its held-out halves worse: the template's values stay (none is determined).
    pub template_holds: bool,
    /// The fit on every sample reached the noise, but its halves predicted each other to
    /// it only while moving (as where an axis hunts on a limit cycle each half's fit times
    /// its own way: the halves' disagreement is what is measured, not the hunting): it is
    /// judged by its held-out figures while moving (`while_moving`), not by the whole
    /// record's above, which stay as they are.
    pub judged_while_moving: bool,
    /// For a fit on every sample: its held-out figures on the samples while the axis moves.
    pub while_moving: Option<WhileMoving>,
    /// Where the gain and the table's mass are both fitted on a controller commanding
    /// current: their ratio, which the record determines even where each alone is a
    /// model's value.
    pub gain_per_inertia: Option<GainPerInertia>,
    /// Where the template names a force ripple's period: what the record says of it,
    /// written or not determined and why. `None` where the template names no period.
    pub force_ripple: Option<super::RippleVerdict>,
    /// Where the template names no presliding bristles: whether bristles are written, or
    /// not determined and why (`None` where the template names them).
    pub presliding: Option<super::PreslidingVerdict>,
    /// Why the stretch compared holds too little of the axis to fit or judge it (too few
    /// samples, or it stands throughout), where it does: its template's values are written
    /// and its figures are ratios of nothing, not shown.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub too_little: Option<String>,
    /// Where the record starts at rest and the samples fitted hold the axis's first start:
    /// the force it held there, fitted beside its values (never written to the file).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub held_at_start: Option<HeldForce>,
    /// From a template whose structure, fitted, leaves more than a tenth of the following
    /// error on the held-out halves: how the loop model fitted from the record alone
    /// compared, and whether it is written in the structure's place.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub structure_compared: Option<super::StructureCompared>,
}

/// The force an axis held at rest at the record's start, fitted beside its values: a state
/// of the record (where its integral action stopped before the record began), not of the
/// machine — never written to the machine file; another record starts holding its own.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct HeldForce {
    /// The force (N, + pushing the table towards +); 0 where the fit holds none.
    pub force_n: f64,
    /// Its standard uncertainty (N); NaN where none is kept; infinite (JSON `null`) where it
    /// lies at the level (`at_level`), bounded from one side only, or the record does not see
    /// it.
    pub uncertainty_n: f64,
    /// The friction's level at rest the force lies within (N).
    pub level_n: f64,
    /// Whether the record determines it (its uncertainty within half of it). A force the
    /// record does not determine is held only where the fit with it predicts the held-out
    /// halves better; else none is.
    pub determined: bool,
    /// Whether it lies at the friction's level at rest: the table on the verge of breaking
    /// away, the residual unchanged by a larger force (the simulator holds no more).
    pub at_level: bool,
    /// Whether it is kept: the values fitted with it predict the held-out halves better by a
    /// twentieth than fitted again without it (both with it estimated on each half scored),
    /// and no worse as the file holds them (no force) than the values before. Where not, no
    /// force is fitted and the other fields but the level say nothing.
    pub kept: bool,
    /// Where kept: the held-out RMS (µm) of the values fitted with it, the force estimated on
    /// each half scored …
    pub held_out_with_um: f64,
    /// … and of the same values fitted again without it, scored the same way (the axis's own
    /// held-out figures hold none, as the file does).
    pub held_out_refit_um: f64,
    /// False where the record cannot tell the force from the axis's values: the fit away from
    /// the standstills reaches the record's noise without it, and fitted again beside it
    /// moves values beyond their uncertainty and beyond what noise alone would (those name the
    /// force as what they trade with: `traded_with` `held_at_start_n`). `force_n`,
    /// `uncertainty_n` and `at_level` are then the refit's; the force is not kept.
    pub told_apart_from_values: bool,
}

/// The identification of a machine from a record.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Identification {
    /// The record's file.
    pub file: String,
    /// The identified machine (the template with the values and the interpolator's limits
    /// written).
    #[serde(skip)]
    pub machine: MachineConfig,
    /// Per axis.
    #[serde(serialize_with = "axes_json")]
    pub axes: Vec<AxisIdentification>,
    /// The interpolator's peaks in the record.
    pub interpolator: Interpolator,
    /// The record's noise floor (µm).
    pub noise_um: f64,
    /// Which stretch of the program the record was compared on, and how its start was set
    /// (a trace that begins at the machine's home is compared from where its commands join
    /// the program).
    pub coverage: Coverage,
    /// Why Z was not identified, where the record measured Z (its template's values stay);
    /// `None` where it was, or where the record has no Z.
    pub z_not_identified: Option<String>,
}

/// Why a record cannot identify a machine.
#[derive(Debug, thiserror::Error)]
pub enum IdentifyError {
    /// The record has no commanded positions.
    #[error(
        "{file}: the record holds no commanded positions (x_cmd, y_cmd columns): identification \
         compares what the axes did with what they were told — record the control's setpoints \
         too, or map them with --columns"
    )]
    NoCommands {
        /// The record.
        file: String,
    },
    /// Neither X nor Y moves in the record's commands.
    #[error(
        "{file}: X is commanded to move {:.1} µm in the record and Y {:.1} µm: there is \
         nothing to identify them from — record a program that moves an axis",
        travel_um[0],
        travel_um[1]
    )]
    StillAxes {
        /// The record.
        file: String,
        /// How far X and Y were commanded (µm).
        travel_um: [f64; 2],
    },
    /// The record could not be placed on the program.
    #[error(transparent)]
    Compare(#[from] CompareError),
    /// The template cannot be simulated on the record's commands.
    #[error(
        "{file}: the template machine cannot follow the record's commands on {axis} (its loop is \
         unstable or diverges): start from a template closer to the machine"
    )]
    CannotSimulate {
        /// The record.
        file: String,
        /// The axis.
        axis: AxisName,
    },
}

#[cfg(test)]
impl AxisIdentification {
    /// A Y axis at the noise on every sample, no values, whose template and fit predict the
    /// held-out halves to `template_um` and `identified_um`, against a following error of
    /// 3 µm.
    pub(super) fn scored(template_um: f64, identified_um: f64) -> AxisIdentification {
        AxisIdentification {
            axis: AxisName::Y,
            values: Vec::new(),
            kept: String::new(),
            moving_only: false,
            reached: true,
            better_than_template: false,
            following_error_rms_um: 3.0,
            held_out_share: identified_um / 3.0,
            baseline: super::Baseline {
                held_out_um: 1.0,
                share: 0.3,
            },
            largest_at: None,
            rms_template_um: template_um,
            rms_identified_um: identified_um,
            file_rms_um: None,
            held_out_template_um: template_um,
            held_out_identified_um: identified_um,
            held_out_in_sample: false,
            gain_per_inertia: None,
            template_holds: false,
            judged_while_moving: false,
            while_moving: None,
            force_ripple: None,
            presliding: None,
            too_little: None,
            held_at_start: None,
            structure_compared: None,
        }
    }
}

#[cfg(test)]
impl IdentifiedValue {
    /// A gain fitted at 440.5 ± 21.6 from a template's 337.8: determined, or loose.
    pub(super) fn fitted_gain(loose: bool) -> IdentifiedValue {
        IdentifiedValue {
            key: "controller.gain",
            unit: "",
            template: 337.8,
            value: 440.5,
            uncertainty: 21.6,
            determined: !loose,
            measured: !loose,
            traded_with: None,
            loose,
            complex_pair: None,
        }
    }
}
