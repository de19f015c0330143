//! Whether a setting is one to put on a machine: each loop's stability margins from the
//! linear model `bode` reads ([`crate::sim::margins`]) and the damping of the closed-loop
//! modes the loops act on, against thresholds engineers commission to. A setting short of any is flagged
//! and ranked after every healthy one, whatever its contour error: a small error bought
//! with a ringing loop is not a result.

use std::collections::HashMap;
use std::sync::Mutex;

use serde::Serialize;

use crate::machine::{AxisConfig, AxisName, MachineConfig};
use crate::sim::AxisModel;
use crate::sim::linear::{Loop, ModalFigure};
use crate::sim::margins::{
    self, LoopMargins, MIN_GAIN_MARGIN_DB, MIN_PHASE_MARGIN_DEG, least_damped_loop_mode,
    least_damped_of_the_loops_making,
};

/// Least damping ratio below which a closed-loop mode of the loops' making flags a setting
/// (the default of `sweep --min-damping`): a mode damped less rings for dozens of periods
/// after every corner. A mode of the loops' own counts, and a mode of the mechanics that the
/// loops leave with less than half the damping the mechanics alone give it; one the loops
/// leave about as damped as the mechanics make it (a screw's torsion, damped by its
/// material whatever the gains) is not the setting's doing.
pub const POOR_DAMPING: f64 = 0.05;

/// The thresholds a healthy setting meets.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Thresholds {
    /// Least phase margin of every loop (degrees).
    pub min_phase_margin_deg: f64,
    /// Least gain margin of every loop, up or down (dB).
    pub min_gain_margin_db: f64,
    /// Least damping ratio of the closed-loop modes of the loops' making.
    pub min_damping: f64,
}

impl Default for Thresholds {
    fn default() -> Self {
        Thresholds {
            min_phase_margin_deg: MIN_PHASE_MARGIN_DEG,
            min_gain_margin_db: MIN_GAIN_MARGIN_DB,
            min_damping: POOR_DAMPING,
        }
    }
}

/// One axis's loops and their margins.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AxisMargins {
    /// The axis.
    pub axis: AxisName,
    /// Its loops, inner first.
    pub loops: Vec<LoopMargins>,
}

/// What the linear model says of a setting.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Health {
    /// X's and Y's loops.
    pub margins: Vec<AxisMargins>,
    /// Least damping ratio of the closed-loop modes the loops act on, X and Y (infinite
    /// where none oscillates): the modes counted do not depend on their damping, so the
    /// figure moves continuously with the gains.
    pub loop_damping: f64,
    /// That mode's frequency (Hz) and axis.
    pub loop_damping_at: Option<(AxisName, f64)>,
    /// The least damped mode of the loops' making, X and Y — their own, or one of the
    /// mechanics they leave with less than half its own damping: (axis, Hz, damping ratio).
    pub loops_making: Option<(AxisName, f64, f64)>,
}

/// Why a setting is flagged.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Flag {
    /// A loop's phase margin is below the threshold.
    PhaseMargin {
        /// Axis.
        axis: AxisName,
        /// Loop.
        #[serde(rename = "loop")]
        which: Loop,
        /// Its phase margin (degrees).
        deg: f64,
    },
    /// A loop's gain margin is below the threshold (gain may rise that little).
    GainMargin {
        /// Axis.
        axis: AxisName,
        /// Loop.
        #[serde(rename = "loop")]
        which: Loop,
        /// Its gain margin (dB).
        db: f64,
    },
    /// A loop stable only above some gain has that little to lose.
    GainReductionMargin {
        /// Axis.
        axis: AxisName,
        /// Loop.
        #[serde(rename = "loop")]
        which: Loop,
        /// How far its gain may fall (dB).
        db: f64,
    },
    /// A loop is unstable closed on its own: its margins say how far it is from the edge,
    /// not how far it may move, and are not given as margins.
    UnstableLoop {
        /// Axis.
        axis: AxisName,
        /// Loop.
        #[serde(rename = "loop")]
        which: Loop,
    },
    /// A closed-loop mode of the loops' making is damped less than the threshold.
    PoorDamping {
        /// Axis.
        axis: AxisName,
        /// The mode's frequency (Hz).
        frequency_hz: f64,
        /// Its damping ratio.
        damping: f64,
    },
}

impl Flag {
    /// A few words for tables, the axis last: `position PM 6.3° (X)`.
    #[cfg(feature = "cli")]
    pub(crate) fn label(&self) -> String {
        format!("{} ({})", self.what(), self.axis())
    }

    #[cfg(feature = "cli")]
    fn axis(&self) -> AxisName {
        match *self {
            Flag::PhaseMargin { axis, .. }
            | Flag::GainMargin { axis, .. }
            | Flag::GainReductionMargin { axis, .. }
            | Flag::UnstableLoop { axis, .. }
            | Flag::PoorDamping { axis, .. } => axis,
        }
    }

    /// The flag without its axis.
    #[cfg(feature = "cli")]
    fn what(&self) -> String {
        match self {
            Flag::PhaseMargin { which, deg, .. } => format!("{} PM {deg:.1}°", which.name()),
            Flag::GainMargin { which, db, .. } => format!("{} GM {db:.1} dB", which.name()),
            Flag::GainReductionMargin { which, db, .. } => {
                format!("{} GM −{db:.1} dB", which.name())
            }
            Flag::UnstableLoop { which, .. } => format!("{} unstable", which.name()),
            Flag::PoorDamping {
                frequency_hz,
                damping,
                ..
            } => format!("ζ {damping:.3} at {frequency_hz:.0} Hz"),
        }
    }
}

/// Flags as a table gives them: each figure once, with the axes that share it —
/// `position PM 11.9° (X, Y), ζ 0.041 at 183 Hz (X)`.
#[cfg(feature = "cli")]
pub(crate) fn describe(flags: &[Flag]) -> String {
    let mut seen: Vec<(String, Vec<AxisName>)> = Vec::new();
    for f in flags {
        let what = f.what();
        match seen.iter_mut().find(|(w, _)| *w == what) {
            Some((_, axes)) => axes.push(f.axis()),
            None => seen.push((what, vec![f.axis()])),
        }
    }
    seen.iter()
        .map(|(what, axes)| {
            let axes: Vec<String> = axes.iter().map(|a| a.to_string()).collect();
            format!("{what} ({})", axes.join(", "))
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// One axis's margins and least damped own mode, by its settings: a sweep of one axis's
/// gains reads the other axis once.
#[derive(Debug, Default)]
pub struct AxisCache {
    read: Mutex<HashMap<String, AxisReading>>,
}

/// An axis's loops' margins, its least damped mode the loops act on, and its least damped
/// mode of the loops' making.
type AxisReading = (Vec<LoopMargins>, Option<ModalFigure>, Option<ModalFigure>);

impl AxisCache {
    fn reading(&self, config: &AxisConfig) -> AxisReading {
        let key = serde_json::to_string(config).expect("an axis always serialises");
        if let Some(r) = self.read.lock().expect("no reader panics").get(&key) {
            return r.clone();
        }
        let model = AxisModel::from_config(config);
        let r = (
            margins::margins(&model),
            least_damped_loop_mode(&model),
            least_damped_of_the_loops_making(&model),
        );
        self.read
            .lock()
            .expect("no reader panics")
            .insert(key, r.clone());
        r
    }
}

/// The margins of both axes' loops and the least damping of the modes they act on.
pub fn health(machine: &MachineConfig) -> Health {
    health_with(machine, &AxisCache::default())
}

/// [`health`], each axis read once per setting of it into `cache`.
pub(crate) fn health_with(machine: &MachineConfig, cache: &AxisCache) -> Health {
    let mut loop_damping = f64::INFINITY;
    let mut loop_damping_at = None;
    let mut loops_making: Option<(AxisName, f64, f64)> = None;
    let margins = AxisName::BOTH
        .iter()
        .map(|&axis| {
            let (loops, least, making) = cache.reading(machine.axis(axis));
            if let Some(m) = least
                && m.damping < loop_damping
            {
                loop_damping = m.damping;
                loop_damping_at = Some((axis, m.frequency_hz));
            }
            if let Some(m) = making
                && loops_making.is_none_or(|(_, _, z)| m.damping < z)
            {
                loops_making = Some((axis, m.frequency_hz, m.damping));
            }
            AxisMargins { axis, loops }
        })
        .collect();
    Health {
        margins,
        loop_damping,
        loop_damping_at,
        loops_making,
    }
}

impl Health {
    /// What falls short of `t`: each loop's margins, then the damping.
    pub(crate) fn flags(&self, t: &Thresholds) -> Vec<Flag> {
        let mut flags = Vec::new();
        for a in &self.margins {
            for m in &a.loops {
                let (axis, which) = (a.axis, m.which);
                if m.unstable() {
                    flags.push(Flag::UnstableLoop { axis, which });
                    continue;
                }
                if m.phase_margin_deg < t.min_phase_margin_deg {
                    flags.push(Flag::PhaseMargin {
                        axis,
                        which,
                        deg: m.phase_margin_deg,
                    });
                }
                if m.gain_margin_db < t.min_gain_margin_db {
                    flags.push(Flag::GainMargin {
                        axis,
                        which,
                        db: m.gain_margin_db,
                    });
                }
                if m.gain_reduction_margin_db < t.min_gain_margin_db {
                    flags.push(Flag::GainReductionMargin {
                        axis,
                        which,
                        db: m.gain_reduction_margin_db,
                    });
                }
            }
        }
        if let Some((axis, frequency_hz, damping)) = self.loops_making
            && damping < t.min_damping
        {
            flags.push(Flag::PoorDamping {
                axis,
                frequency_hz,
                damping,
            });
        }
        flags
    }

    /// The least of a figure over both axes for one loop (`None` where neither axis has it).
    pub fn least(&self, which: Loop, figure: impl Fn(&LoopMargins) -> f64) -> Option<f64> {
        self.margins
            .iter()
            .flat_map(|a| a.loops.iter().filter(|m| m.which == which))
            .map(figure)
            .reduce(f64::min)
    }

    /// The largest of a figure over both axes for one loop.
    #[cfg(feature = "cli")]
    pub(crate) fn most(&self, which: Loop, figure: impl Fn(&LoopMargins) -> f64) -> Option<f64> {
        self.margins
            .iter()
            .flat_map(|a| a.loops.iter().filter(|m| m.which == which))
            .map(figure)
            .reduce(f64::max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn velocity_loop(stable: bool) -> LoopMargins {
        // An unstable loop's figures: negative phase margin, a gain "margin" that is the
        // distance to the edge from the wrong side.
        LoopMargins {
            which: Loop::Velocity,
            crossover_hz: Some(120.0),
            phase_margin_deg: if stable { 45.0 } else { -12.0 },
            phase_crossover_hz: Some(300.0),
            gain_margin_db: if stable { 12.0 } else { 2.5 },
            gain_reduction_margin_db: f64::INFINITY,
            gain_reduction_hz: None,
            peak_db: 3.0,
            peak_hz: 110.0,
            stable,
        }
    }

    fn health_of(loops: Vec<LoopMargins>) -> Health {
        Health {
            margins: vec![AxisMargins {
                axis: AxisName::Y,
                loops,
            }],
            loop_damping: f64::INFINITY,
            loop_damping_at: None,
            loops_making: None,
        }
    }

    /// An unstable loop is flagged as unstable, never by a margin it does not have; a stable
    /// loop with the same crossover is not flagged at all.
    #[test]
    fn an_unstable_loop_is_flagged_as_unstable_not_by_its_margins() {
        let t = Thresholds::default();
        let flags = health_of(vec![velocity_loop(false)]).flags(&t);
        assert_eq!(
            flags,
            vec![Flag::UnstableLoop {
                axis: AxisName::Y,
                which: Loop::Velocity
            }]
        );
        assert!(health_of(vec![velocity_loop(true)]).flags(&t).is_empty());
    }
}
