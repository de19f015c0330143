//! What the diagnosis and the identification share: a measured record placed on the
//! program's timeline and compared with a model driven by the same commands.
//!
//! [`compare`] builds the [`Context`] (the commands that drive the simulation — the
//! program's plan or the ones the record holds — the record's clock aligned to the
//! program's, and the samples compared), simulates the nominal machine on it, and
//! measures the record's noise floor from the residual. [`residual`] holds the figures a
//! residual is judged by.

mod align;
pub mod context;
mod held;
mod offset;
pub mod residual;
pub mod start;

use crate::check::CheckSettings;
use crate::gcode::Program;
use crate::machine::{AxisName, MachineConfig};
use crate::numeric::units::um_from_m;
use crate::sim::{MeasuredAt, SimError};
use crate::trace::measured::{MeasuredError, MeasuredTrace};

pub(crate) use align::context;
pub use context::{Context, Stepping};
pub use held::HeldAtStart;

/// How a record is placed on a program and compared with a model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CompareSettings {
    /// Planner and simulator settings.
    pub check: CheckSettings,
    /// Measure the control's waits at standstills from the measurement (each stretch between
    /// standstills matched on its own) and plan with them, for a control whose in-position
    /// waits or dwells differ from the plan's. On straight strokes between exact stops a
    /// gain error or dead time then passes in part for a longer wait; a measurement with
    /// recorded commands needs neither.
    pub align_stretches: bool,
    /// How far recorded commands may lie from the programmed geometry (m): blending at
    /// corners and chords of another interpolator stay within it.
    pub command_tolerance_m: f64,
    /// Where the measurement read the axes' positions.
    pub measured_at: MeasuredAt,
}

impl CompareSettings {
    /// Defaults for a machine.
    pub fn for_machine(machine: &MachineConfig) -> Self {
        CompareSettings {
            check: CheckSettings::for_machine(machine),
            align_stretches: false,
            command_tolerance_m: 25e-6,
            measured_at: MeasuredAt::Table,
        }
    }
}

/// Why a record cannot be compared with a program.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CompareError {
    /// The measured data is unreadable or malformed.
    #[error("{0}")]
    Measured(#[from] MeasuredError),
    /// The measurement does not line up with the program.
    #[error("{file}: cannot align the measurement with the program: {reason}")]
    CannotAlign {
        /// The measurement file.
        file: String,
        /// Why.
        reason: String,
    },
    /// The recorded commands leave the program's geometry.
    #[error(
        "{file}: the recorded commands leave the program's path by {distance_um:.1} µm at \
         t = {t_s:.4} s (line {line}); more than the {tolerance_um:.1} µm allowed \
         (--command-tolerance-um): {hint}"
    )]
    OffPath {
        /// The measurement file.
        file: String,
        /// Time on the measurement's clock (s).
        t_s: f64,
        /// Source line of the nearest block.
        line: u32,
        /// Distance from the programmed geometry (µm).
        distance_um: f64,
        /// The tolerance (µm).
        tolerance_um: f64,
        /// What the user may try: a work offset the commands show, or a question.
        hint: String,
    },
    /// The nominal model cannot be simulated.
    #[error("{0}")]
    Sim(#[from] SimError),
    /// No axis is commanded to move where the record is compared.
    #[error(
        "{file}: the record holds no motion: where it is compared, X is commanded to move \
         {:.1} µm and Y {:.1} µm — nothing to judge a model by; record the axes while the \
         program moves them",
        travel_um[0],
        travel_um[1]
    )]
    NoMotion {
        /// The measurement file.
        file: String,
        /// How far X and Y are commanded over the compared samples (µm).
        travel_um: [f64; 2],
    },
}

/// Commanded travel (m) below which a compared stretch holds no motion: a micrometre is
/// within a record's noise, and nothing a model predicts of moving axes shows there.
pub const LEAST_MOTION_M: f64 = 1e-6;

/// Refuses a comparison at the clock offset `offset_s` in which neither X nor Y, nor Z
/// where it is compared, is commanded to move [`LEAST_MOTION_M`] over the compared samples:
/// a model that holds still matches any record of still axes, which says nothing of it.
pub(crate) fn require_motion(
    ctx: &Context,
    machine: &MachineConfig,
    offset_s: f64,
) -> Result<(), CompareError> {
    let travel_m = |a| ctx.command_travel_m(a, offset_s);
    let xy = AxisName::BOTH.map(travel_m);
    let z = ctx
        .z_comparable(machine)
        .is_ok()
        .then(|| travel_m(AxisName::Z));
    // NaN compares false: a travel that cannot be measured is no motion either.
    if xy.iter().chain(z.iter()).any(|&t| t >= LEAST_MOTION_M) {
        return Ok(());
    }
    Err(CompareError::NoMotion {
        file: ctx.measured.file.clone(),
        travel_um: xy.map(um_from_m),
    })
}

/// A record placed on a program, with the nominal machine's simulation on its timeline.
#[derive(Clone)]
pub struct Comparison<'a> {
    /// The timeline, its samples and the record's noise floor.
    pub ctx: Context<'a>,
    /// The record's clock offset against the program's (s).
    pub offset_s: f64,
    /// The nominal machine's X and Y traces on the context's commands (m).
    pub nominal: [Vec<f64>; 2],
    /// Its Z trace, where Z can be compared ([`Context::z_comparable`]) and simulated (m).
    pub nominal_z: Option<Vec<f64>>,
}

/// Places `measured` on `program`, simulates `machine` on it at `stepping` and estimates the
/// record's noise floor from the residual.
pub fn compare<'a>(
    program: &Program,
    machine: &MachineConfig,
    measured: &'a MeasuredTrace,
    settings: &CompareSettings,
    stepping: Stepping,
) -> Result<Comparison<'a>, CompareError> {
    let (mut ctx, offset_s) = context(program, machine, measured, settings)?;
    ctx.stepping = stepping;
    let simulate = |a| {
        ctx.simulate_axis(machine, a)
            .ok_or_else(|| CompareError::CannotAlign {
                file: measured.file.clone(),
                reason: "the nominal machine cannot be simulated".into(),
            })
    };
    let nominal = [simulate(AxisName::X)?, simulate(AxisName::Y)?];
    // The noise from every sample, hunting holds too: it is read from the residual's
    // sample-to-sample differences, which a slow limit cycle barely moves.
    let residuals = AxisName::BOTH.map(|a| ctx.residual(a, &nominal[a.index()], offset_s));
    ctx.noise_sigma = residual::record_noise(&residuals, measured);
    for a in AxisName::BOTH {
        ctx.holding[a.index()] = ctx.hunting_holds(a, &nominal[a.index()], offset_s);
        ctx.unsettled[a.index()] = ctx.unsettled_at_start(a, offset_s);
    }
    // Z's own hunting holds where it can be compared. Its start is X's and Y's: it is
    // compared where they are.
    let nominal_z = ctx
        .z_comparable(machine)
        .ok()
        .and_then(|()| ctx.simulate_axis(machine, AxisName::Z));
    if let Some(z) = &nominal_z {
        ctx.holding[AxisName::Z.index()] = ctx.hunting_holds(AxisName::Z, z, offset_s);
    }
    Ok(Comparison {
        ctx,
        offset_s,
        nominal,
        nominal_z,
    })
}
