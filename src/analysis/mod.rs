//! The figures of an executed run, gathered chunk by chunk as the simulation hands the run
//! on: contour error, summary figures, hotspots, circular tests, drive-limit warnings and a
//! thinned copy for plots. What is kept is bounded by the report (a few seconds of recent
//! samples, the hotspots, the circles' points, the plot's points), not by the run's duration,
//! so an eight-hour program is checked in the memory of a one-minute one.

pub mod circular;
pub mod contour;
pub mod contour3d;
pub mod hotspot;
pub mod hotspot_cause;
pub mod hotspot_merge;
#[cfg(feature = "html-report")]
pub mod polar_points;
pub mod thinning;

use serde::Serialize;

use crate::analysis::circular::{
    CirclePath, CircleSamples, CircularTest, Commanded, EntrySettling, circles,
};
use crate::analysis::contour::{ContourLocator, ContourPoint};
pub use crate::analysis::hotspot::RunPlace;
use crate::analysis::hotspot::{AxisSteady, Hotspot, HotspotConfig, HotspotFinder, RunSample};
use crate::analysis::thinning::PeakThinned;
use crate::gcode::Warning;
use crate::machine::Feedback;
use crate::machine::{AxisConfig, MachineConfig};
use crate::path::Motion;
use crate::plan::Plan;
use crate::plan::execute::RunChunk;
use crate::sim::geometry::ToolReader;
use crate::sim::linear::{equivalent_kv_per_s, settling_rate_per_s, velocity_lag_s};
use crate::sim::{AxisModel, AxisTrace, Mode};

/// Figures of a run.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Summary {
    /// Planned cycle time (s).
    pub cycle_time_s: f64,
    /// Path length, rapids included (m).
    pub path_length_m: f64,
    /// Length of the cutting moves (m).
    pub cut_length_m: f64,
    /// Largest |contour error| while cutting (m).
    pub max_contour_error_m: f64,
    /// Sample of that maximum.
    pub max_contour_sample: Option<usize>,
    /// RMS contour error while cutting (m).
    pub rms_contour_error_m: f64,
    /// Largest |following error| of X and Y while cutting (m): over the feed moves, not the
    /// dwells (the axes settling there count as positioning).
    pub max_following_error_cutting_m: [f64; 2],
    /// Z's largest |following error| while cutting and over the whole run (m), where Z is
    /// simulated.
    pub z_following_error_m: Option<[f64; 2]>,
    /// The largest parts of the contour error in the block's plane and across it (m), over
    /// the blocks measured in space (Z simulated and moving along the contour); `None` where
    /// there are none.
    pub max_components_m: Option<[f64; 2]>,
    /// Largest XY distance from the commanded point while a feed block moves Z alone or
    /// dwells (m): the axes still settling after they arrived — a positioning error at that
    /// point, not part of the contour.
    pub max_positioning_error_m: f64,
    /// Where that is: source line and time (s).
    pub max_positioning_at: Option<(u32, f64)>,
    /// Largest |following error| of X and Y over the whole run, rapids included (m).
    pub max_following_error_m: [f64; 2],
}

/// One point of the run kept for plots.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlotPoint {
    /// Actual X and Y (m).
    pub pos_m: [f64; 2],
    /// Actual Z (m): as commanded where Z is carried.
    pub z_m: f64,
    /// Path length of the contour error's foot point (m).
    pub path_s_m: f64,
    /// Contour error (m), NaN while not cutting.
    pub error_m: f64,
}

/// The mode code a carried Z reads as: stuck, never limited (it takes no part in events).
const STANDING: u8 = 2;

/// Points kept for plots (up to twice as many while a run grows): each the largest contour
/// error of its stretch of the run, so that every spike survives the thinning.
const PLOT_POINTS: usize = 20_000;

/// Everything a check reports, none of it growing with the run's duration.
#[derive(Debug, Clone)]
pub struct CheckResult {
    /// The plan, re-timed with the simulated in-position waits.
    pub plan: Plan,
    /// Hotspots, ranked.
    pub hotspots: Vec<Hotspot>,
    /// Figures.
    pub summary: Summary,
    /// Where the largest contour error occurs.
    pub max_at: Option<RunPlace>,
    /// Circular-test figures (ISO 230-4) of every full circle in the program.
    pub circular: CircularTest,
    /// The circles with figures and the actual points on them (m), thinned when long.
    pub circle_paths: Vec<CirclePath>,
    /// The run thinned for plots.
    pub plot: Vec<PlotPoint>,
    /// Samples in the run.
    pub samples: usize,
    /// Sample period (s).
    pub dt_s: f64,
}

/// The rate (1/s) an event's effect on the error dies away at, which sizes its hotspot
/// window: a cascade's Kv; for another controller its closed loop's bandwidth, or the
/// slowest mode its integral action leaves where that is slower (friction at a reversal
/// decays with it).
fn window_rate_per_s(model: &AxisModel) -> f64 {
    let kv = equivalent_kv_per_s(model);
    match model.control {
        crate::sim::model::ControlModel::Cascade => kv,
        _ => kv.min(settling_rate_per_s(model)),
    }
}

/// What an axis adds to a steady stretch's error: its lag per speed, and half its backlash
/// where the loop reads the motor and the table trails it by that.
fn steady_of(model: &AxisModel) -> AxisSteady {
    AxisSteady {
        lag_s: velocity_lag_s(model),
        offset_m: match model.feedback {
            Feedback::MotorEncoder => model.half_gap,
            Feedback::LinearScale => 0.0,
        },
        backlash_m: 2.0 * model.half_gap,
    }
}

/// A drive's time at its current or voltage limit.
#[derive(Debug, Clone, Copy, Default)]
struct LimitTally {
    limited: usize,
    at_current_limit: usize,
    stretches: usize,
    first: Option<(f64, u32)>,
    was_limited: bool,
}

/// Gathers a run's figures chunk by chunk.
#[derive(Debug, Clone)]
pub struct RunAnalyser {
    locator: ContourLocator,
    hotspots: HotspotFinder,
    circles: CircleSamples,
    plot: PeakThinned<PlotPoint>,
    /// X, Y and (where simulated) Z.
    limits: Vec<LimitTally>,
    i_max_a: Vec<f64>,
    /// What lies beyond the scales (squareness, straightness, maps, play), applied to the
    /// positions at the tool sample by sample.
    tool: ToolReader,
    squares_m2: f64,
    cutting_samples: usize,
    /// Largest XY positioning error while Z moves alone or the program dwells, and where.
    positioning: (f64, Option<(u32, f64)>),
    /// X, Y and (where simulated) Z.
    fe_cut_m: Vec<f64>,
    fe_all_m: Vec<f64>,
    /// The largest in-plane and across parts of the contour error, over the samples measured
    /// in space.
    components_m: Option<[f64; 2]>,
    samples: usize,
}

impl RunAnalyser {
    /// An analyser for the run of `plan` on `machine`, keeping at most `max_hotspots`.
    pub(crate) fn new(plan: &Plan, machine: &MachineConfig, max_hotspots: usize) -> Self {
        let [mx, my] = [&machine.x, &machine.y].map(AxisModel::from_config);
        let kv = window_rate_per_s(&mx).min(window_rate_per_s(&my));
        let simulated: Vec<AxisModel> = machine
            .simulated_configs()
            .into_iter()
            .map(AxisModel::from_config)
            .collect();
        let z_simulated = simulated.len() == 3;
        RunAnalyser {
            locator: if z_simulated {
                ContourLocator::in_3d(plan)
            } else {
                ContourLocator::new(plan)
            },
            hotspots: HotspotFinder::new(
                HotspotConfig {
                    with_z: z_simulated,
                    ..HotspotConfig::for_kv(kv)
                },
                [0, 1, 2].map(|a| simulated.get(a).map_or(AxisSteady::default(), steady_of)),
                plan.config.cycle_s,
                max_hotspots,
            ),
            circles: CircleSamples::new(circles(&plan.segments), EntrySettling::of(machine)),
            plot: PeakThinned::new(PLOT_POINTS, |p| {
                if p.error_m.is_finite() {
                    p.error_m.abs()
                } else {
                    -1.0
                }
            }),
            limits: vec![LimitTally::default(); simulated.len()],
            i_max_a: simulated.iter().map(|m| m.i_max).collect(),
            tool: ToolReader::new(machine),
            squares_m2: 0.0,
            cutting_samples: 0,
            positioning: (0.0, None),
            fe_cut_m: vec![0.0; simulated.len()],
            fe_all_m: vec![0.0; simulated.len()],
            components_m: None,
            samples: 0,
        }
    }

    /// Takes the next chunk of the run; returns its samples' contour errors.
    pub(crate) fn take(&mut self, chunk: &RunChunk) -> Vec<ContourPoint> {
        let (plan, c) = (chunk.plan, chunk.commands);
        let traces: Vec<&AxisTrace> = [&chunk.x, &chunk.y]
            .into_iter()
            .chain(chunk.z.as_ref())
            .collect();
        let n = traces.iter().fold(c.len(), |n, t| n.min(t.len()));
        let mut points = Vec::with_capacity(n);
        for i in 0..n {
            let k = chunk.first + i;
            let seg = c.segment[i] as usize;
            let t_s = c.time_s(k);
            // At the tool: the axes' geometry lies beyond the scales the loops close on.
            let pos_m = self.tool.read([chunk.x.pos_m[i], chunk.y.pos_m[i]]);
            let reference = [c.x.pos_m[i], c.y.pos_m[i]];
            let z_m = chunk.z.as_ref().map_or(c.z.pos_m[i], |z| z.pos_m[i]);
            let point = self.locator.locate(
                plan,
                seg,
                [reference[0], reference[1], c.z.pos_m[i]],
                [pos_m[0], pos_m[1], z_m],
            );
            let block = &plan.segments[seg];
            let feed_block = block.motion == Motion::Feed;
            let line = block.line;
            // A dwell cuts nothing: the axes settling there are positioning, counted below.
            self.tally_errors(&traces, i, feed_block && !block.is_dwell());
            if feed_block && !contour::is_contour(block) {
                let off = (pos_m[0] - reference[0]).hypot(pos_m[1] - reference[1]);
                if off > self.positioning.0 {
                    self.positioning = (off, Some((line, t_s)));
                }
            }
            self.tally_limits(&traces, i, t_s, line);
            if point.error_m.is_finite() {
                self.squares_m2 += point.error_m * point.error_m;
                self.cutting_samples += 1;
                if self.locator.measures_in_space(&plan.segments[seg]) {
                    let parts = [point.in_plane_m.abs(), point.across_m.abs()];
                    let largest = self.components_m.unwrap_or_default();
                    self.components_m = Some([0, 1].map(|j| largest[j].max(parts[j])));
                }
            }
            self.hotspots.push(
                plan,
                &RunSample {
                    t_s,
                    pos_m,
                    z_m,
                    error_m: point.error_m,
                    path_s_m: point.path_s_m,
                    segment: c.segment[i],
                    cmd_vel_m_per_s: [c.x.vel_m_per_s[i], c.y.vel_m_per_s[i], c.z.vel_m_per_s[i]],
                    cmd_acc_m_per_s2: [
                        c.x.acc_m_per_s2[i],
                        c.y.acc_m_per_s2[i],
                        c.z.acc_m_per_s2[i],
                    ],
                    mode: [
                        chunk.x.mode[i],
                        chunk.y.mode[i],
                        chunk.z.as_ref().map_or(STANDING, |z| z.mode[i]),
                    ],
                },
            );
            let command = Commanded::of(c, i, t_s);
            self.circles
                .push(point.segment, [pos_m[0], pos_m[1], z_m], command);
            self.plot.push(PlotPoint {
                pos_m,
                z_m,
                path_s_m: point.path_s_m,
                error_m: point.error_m,
            });
            points.push(point);
        }
        self.samples += n;
        points
    }

    fn tally_errors(&mut self, traces: &[&AxisTrace], i: usize, cutting: bool) {
        for (a, t) in traces.iter().enumerate() {
            let e = t.following_error_m(i).abs();
            self.fe_all_m[a] = self.fe_all_m[a].max(e);
            if cutting {
                self.fe_cut_m[a] = self.fe_cut_m[a].max(e);
            }
        }
    }

    fn tally_limits(&mut self, traces: &[&AxisTrace], i: usize, t_s: f64, line: u32) {
        for (a, t) in traces.iter().enumerate() {
            let tally = &mut self.limits[a];
            let limited = Mode::code_is_limited(t.mode[i]);
            if limited {
                tally.limited += 1;
                if !tally.was_limited {
                    tally.stretches += 1;
                }
                if t.current_a[i].abs() >= 0.95 * self.i_max_a[a] {
                    tally.at_current_limit += 1;
                }
                tally.first.get_or_insert((t_s, line));
            }
            tally.was_limited = limited;
        }
    }

    /// The figures of the whole run, `plan` as the execution re-timed it.
    pub(crate) fn finish(self, mut plan: Plan, machine: &MachineConfig) -> CheckResult {
        let dt_s = plan.config.cycle_s;
        let z_simulated = self.fe_all_m.len() == 3;
        for ((axis, config), tally) in ['X', 'Y', 'Z']
            .into_iter()
            .zip(machine.simulated_configs())
            .zip(self.limits)
        {
            if let Some(w) = limit_warning(axis, &tally, config, dt_s) {
                plan.warnings.push(w);
            }
        }
        if !z_simulated {
            plan.warnings.extend(carried_z_warnings(&plan));
        }
        let (circular, circle_paths) = self.circles.test();
        let largest = self.hotspots.largest();
        let summary = Summary {
            cycle_time_s: plan.total_time_s,
            path_length_m: plan.path_length_m(),
            cut_length_m: cut_length_m(&plan),
            max_contour_error_m: largest.map_or(0.0, |m| m.0),
            max_contour_sample: largest.map(|m| m.1.sample),
            rms_contour_error_m: if self.cutting_samples == 0 {
                0.0
            } else {
                (self.squares_m2 / self.cutting_samples as f64).sqrt()
            },
            max_following_error_cutting_m: [self.fe_cut_m[0], self.fe_cut_m[1]],
            z_following_error_m: z_simulated.then(|| [self.fe_cut_m[2], self.fe_all_m[2]]),
            max_components_m: self.components_m,
            max_positioning_error_m: self.positioning.0,
            max_positioning_at: self.positioning.1,
            max_following_error_m: [self.fe_all_m[0], self.fe_all_m[1]],
        };
        CheckResult {
            hotspots: self.hotspots.finish(),
            summary,
            max_at: largest.map(|m| m.1),
            circular,
            circle_paths,
            plot: self.plot.into_points(),
            samples: self.samples,
            dt_s,
            plan,
        }
    }
}

/// On a machine that carries Z, one warning per feed block that moves Z together with X or
/// Y (a helix, a slope, a 3-D contour): Z arrives with its command there, so the contour
/// error is X's and Y's alone. A plunge (Z alone) is no contour and is not warned.
fn carried_z_warnings(plan: &Plan) -> Vec<Warning> {
    plan.segments
        .iter()
        .filter(|s| s.cuts_in_space())
        .map(|s| Warning {
            line: s.line,
            message: "Z moves along the contour, but this machine carries Z (its file gives \
                      Z only limits): the contour error here is X's and Y's alone"
                .into(),
        })
        .collect()
}

fn cut_length_m(plan: &Plan) -> f64 {
    plan.segments
        .iter()
        .zip(&plan.plans)
        .filter(|(s, _)| s.motion == Motion::Feed)
        // Folded from +0: an empty float sum is −0, which prints as "-0.0 mm cutting".
        .fold(0.0, |total, (_, p)| total + p.length_m)
}

/// A drive that spends time at its current or voltage limit cannot follow its command
/// there: the prediction includes it, but a wrong limit in the machine file (a 3 A current
/// limit on a 60 A drive) would show as a large error at every reversal with no other hint.
/// Says where (the first stretch's line), how long in all and which limit.
fn limit_warning(
    axis: char,
    tally: &LimitTally,
    config: &AxisConfig,
    dt_s: f64,
) -> Option<Warning> {
    let (first_t_s, line) = tally.first?;
    let which = match (
        &config.velocity_loop,
        &config.current_loop,
        &config.amplifier,
    ) {
        (_, Some(i), _) if 2 * tally.at_current_limit < tally.limited => {
            format!("voltage limit (current_loop.u_max_v = {} V)", i.u_max_v)
        }
        (Some(v), ..) if config.controller.uses_velocity_loop() => {
            format!("current limit (velocity_loop.i_max_a = {} A)", v.i_max_a)
        }
        (.., Some(amp)) => format!(
            "current limit (amplifier.i_max_a = {} A)",
            amp.i_max_a.unwrap_or(f64::INFINITY)
        ),
        _ => "current limit".to_string(),
    };
    Some(Warning {
        line,
        message: format!(
            "the {axis} drive is at its {which} for {:.1} ms in {} stretch{}, the \
             first at t = {first_t_s:.3} s: it cannot follow the command there (included in \
             the prediction; check the limit if this is unexpected)",
            tally.limited as f64 * dt_s * 1e3,
            tally.stretches,
            if tally.stretches == 1 { "" } else { "es" },
        ),
    })
}
