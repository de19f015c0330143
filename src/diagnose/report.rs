//! The diagnosis as a report: a versioned JSON document for scripts (schema
//! `contourcheck.diagnose/1`, documented in docs/report-schema.md), a summary for the
//! terminal, and the extended machine as a machine file.

use std::fmt::Write as _;

use serde::Serialize;

use super::cause_text::{with_uncertainty, write_cause};
use super::learn::Learned;
use super::locate::{Located, Variable};
use super::repeat::Localized;
use super::ripple::Period;

use super::{
    Alternative, AxisResidual, Candidate, CircularComparison, Coverage, Diagnosis, ExtraWait,
    FittedParam, HeldOut, Place, Rejected, ResidualStats, Skipped,
};
use crate::diagnose::causes::CauseId;
use crate::machine::{AxisName, Feedback, MachineConfig};
use crate::sim::MeasuredAt;
use crate::trace::measured::MeasuredTrace;
use crate::trace::recorded::BeyondMachine;

/// Schema id of the JSON report.
pub const SCHEMA: &str = "contourcheck.diagnose/1";

/// The report.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DiagnoseReport {
    /// Schema id.
    pub schema: &'static str,
    /// The program file.
    pub program: String,
    /// The measurement.
    pub measured: MeasuredInfo,
    /// The nominal machine's name.
    pub machine: String,
    /// Measured time = program time + this (s).
    pub clock_offset_s: f64,
    /// The measurement's noise floor (standard deviation, µm).
    pub noise_floor_um: f64,
    /// With stretches aligned on their own: standstills the control held longer than planned
    /// (empty on the planned timeline).
    pub extra_waits: Vec<ExtraWait>,
    /// Causes found, strongest first; empty when none is significant.
    pub causes: Vec<CauseReport>,
    /// One sentence: what was found.
    pub verdict: String,
    /// Residual of the nominal and of the extended model, with the gains.
    pub residual: ResidualReport,
    /// Where the nominal model's residual is largest.
    pub places: Vec<Place>,
    /// Every cause tried in the first round.
    pub candidates: Vec<Candidate>,
    /// Causes not tried, and why.
    pub skipped: Vec<Skipped>,
    /// Causes that fitted with evidence but are not named, and why.
    pub rejected: Vec<Rejected>,
    /// Without recorded commands: how much later the record's second half runs than its
    /// first under one clock offset (ms); `null` with recorded commands.
    pub timing_drift_ms: Option<f64>,
    /// Where the recorded commands ask more of an axis than the machine file allows.
    pub beyond_machine: Vec<BeyondMachine>,
    /// Whether the rapids were compared too (a record with its commands that is mostly
    /// rapids).
    pub rapids_compared: bool,
    /// Per axis (X, Y), the time left out of its residual because it held still and the
    /// nominal model hunts there (s).
    pub hunting_left_out_s: [f64; 2],
    /// Circular-test figures (ISO 230-4): measured, nominal model, extended model.
    pub circular_test: CircularComparison,
    /// Where the residual left by the extended model lives, per axis where it stands out
    /// from the noise.
    pub unexplained: Vec<Located>,
    /// Position maps learned from the residual where no catalogue cause explained it (in
    /// the extended machine as `errors.position_map_mm/um`).
    pub learned: Vec<Learned>,
    /// Which stretch of the program was compared, and how the record's start was set.
    pub coverage: Coverage,
    /// Where each axis's position loop reads it (X, Y): what the explanations follow.
    pub loop_feedback: [Feedback; 2],
    /// Residuals that repeat at the same places on every pass of an axis (a tight spot, a
    /// local scale or straightness error), however small the record's RMS.
    pub localized: Vec<Localized>,
    /// Z, where the record measured it: compared with the simulated Z, its cause.
    pub z: super::z_axis::ZFindings,
}

/// The measurement, as read.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MeasuredInfo {
    /// File.
    pub file: String,
    /// Samples read.
    pub samples: usize,
    /// Sampling step (s).
    pub sample_step_s: f64,
    /// Whether irregular sampling was resampled.
    pub resampled: bool,
    /// Rows the logger repeated each reading for (1: every row a reading); only the rows
    /// that carried readings were used.
    pub rows_per_reading: usize,
    /// Whether the simulation ran on the commands the measurement recorded.
    pub commands_recorded: bool,
    /// Samples compared (rapids and the margins left out).
    pub samples_compared: usize,
    /// Where the positions were read: `table`, `motor` or `tool`.
    pub measured_at: MeasuredAt,
}

/// A cause as reported.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CauseReport {
    /// Id from the fixed vocabulary.
    pub id: CauseId,
    /// Axis.
    pub axis: AxisName,
    /// Fitted parameters, as machine keys below the axis, with units and standard
    /// uncertainties.
    pub params: Vec<FittedParam>,
    /// For a cause that repeats with position: its period and where that came from.
    #[serde(flatten)]
    pub period: Period,
    /// Evidence (BIC units).
    pub evidence: f64,
    /// `points` (point-by-point residual) or `statistics` (stick-slip chatter compared on
    /// its window statistics).
    pub fitted_on: &'static str,
    /// The axis's RMS residual before adding the cause (µm).
    pub rms_before_um: f64,
    /// After (µm).
    pub rms_after_um: f64,
    /// Every residual measure before.
    pub before: AxisResidual,
    /// After.
    pub after: AxisResidual,
    /// Gain in each measure (%).
    pub gain_percent: Gains,
    /// Causes that explain the data almost as well.
    pub alternatives: Vec<Alternative>,
    /// Fitted on half of the record, judged on the other half.
    pub held_out: HeldOut,
}

/// Relative fall of each residual measure (%; negative: it grew).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Gains {
    /// Whole-record RMS.
    pub rms: f64,
    /// RMS near events.
    pub event_rms: f64,
    /// Smoothed RMS.
    pub smoothed_rms: f64,
    /// Chatter amplitude mismatch.
    pub chatter: f64,
}

impl Gains {
    fn between(before: &AxisResidual, after: &AxisResidual) -> Gains {
        let gain = |b: f64, a: f64| if b > 0.0 { 100.0 * (1.0 - a / b) } else { 0.0 };
        Gains {
            rms: gain(before.rms_um, after.rms_um),
            event_rms: gain(before.event_rms_um, after.event_rms_um),
            smoothed_rms: gain(before.smoothed_rms_um, after.smoothed_rms_um),
            chatter: gain(before.chatter_um, after.chatter_um),
        }
    }
}

/// Residuals of both models.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ResidualReport {
    /// Nominal model.
    pub nominal: ResidualStats,
    /// Extended model.
    pub extended: ResidualStats,
    /// Gains per axis and for the contour (%).
    pub gain_percent: GainStats,
    /// Whether the contour error is measured in space (with Z) on the blocks that move Z
    /// along the contour or lie in ZX or YZ; else from X and Y alone.
    pub contour_in_space: bool,
}

/// Gains per axis and for the contour.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct GainStats {
    /// X.
    pub x: Gains,
    /// Y.
    pub y: Gains,
    /// Contour error.
    pub contour: Gains,
}

/// The report in words, as the command prints it: the record, the verdict, each cause
/// named or not, what the residual left shows, where the error lives.
impl std::fmt::Display for DiagnoseReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.summary_text())
    }
}

impl DiagnoseReport {
    /// Builds the report.
    pub fn new(
        d: &Diagnosis,
        program_file: &str,
        measured: &MeasuredTrace,
        machine: &MachineConfig,
    ) -> DiagnoseReport {
        let causes: Vec<CauseReport> = d
            .causes
            .iter()
            .map(|c| CauseReport {
                id: c.id,
                axis: c.axis,
                params: c.params.clone(),
                period: c.period.clone(),
                evidence: c.evidence,
                fitted_on: if c.statistical {
                    "statistics"
                } else {
                    "points"
                },
                rms_before_um: c.before.rms_um,
                rms_after_um: c.after.rms_um,
                before: c.before,
                after: c.after,
                gain_percent: Gains::between(&c.before, &c.after),
                alternatives: c.alternatives.clone(),
                held_out: c.held_out,
            })
            .collect();
        DiagnoseReport {
            schema: SCHEMA,
            program: program_file.to_string(),
            measured: MeasuredInfo {
                file: measured.file.clone(),
                samples: measured.len(),
                sample_step_s: measured.dt_s,
                resampled: measured.resampled,
                rows_per_reading: measured.held.map_or(1, |h| h.period),
                commands_recorded: measured.commands.is_some(),
                samples_compared: d.samples,
                measured_at: d.measured_at,
            },
            machine: machine.name.clone(),
            clock_offset_s: d.offset_s,
            noise_floor_um: d.noise_floor_um,
            extra_waits: d.extra_waits.clone(),
            verdict: verdict(d),
            causes,
            residual: ResidualReport {
                nominal: d.before,
                extended: d.after,
                gain_percent: GainStats {
                    x: Gains::between(&d.before.x, &d.after.x),
                    y: Gains::between(&d.before.y, &d.after.y),
                    contour: Gains::between(&d.before.contour, &d.after.contour),
                },
                contour_in_space: d.series.contour_in_space,
            },
            places: d.places.clone(),
            candidates: d.candidates.clone(),
            skipped: d.skipped.clone(),
            rejected: d.rejected.clone(),
            timing_drift_ms: d.timing_drift_ms,
            beyond_machine: d.beyond_machine.clone(),
            rapids_compared: d.rapids_compared,
            hunting_left_out_s: d.hunting_left_out_s,
            circular_test: d.circular.clone(),
            unexplained: d.unexplained.clone(),
            learned: d.learned.clone(),
            coverage: d.coverage,
            loop_feedback: AxisName::BOTH.map(|a| machine.axis(a).position_loop.feedback),
            localized: d.localized.clone(),
            z: d.z.clone(),
        }
    }

    /// Where `axis`'s position loop reads it; none for an axis outside the plane.
    pub(crate) fn feedback_of(&self, axis: AxisName) -> Option<Feedback> {
        self.loop_feedback.get(axis.index()).copied()
    }

    /// The summary for the terminal (the report's [`Display`](std::fmt::Display)).
    fn summary_text(&self) -> String {
        let mut s = String::new();
        self.write_record(&mut s);
        let _ = writeln!(s, "\n{}", self.verdict);
        for (i, c) in self.causes.iter().enumerate() {
            write_cause(&mut s, i, c, self.feedback_of(c.axis));
        }
        for r in &self.rejected {
            let _ = writeln!(
                s,
                "  not named: {} on {} ({})",
                r.id.as_str(),
                r.axis,
                r.reason
            );
        }
        for line in self.residual_findings() {
            let _ = writeln!(s, "  {line}");
        }
        for line in self.z.describe() {
            let _ = writeln!(s, "{line}");
        }
        for k in &self.skipped {
            let axes: Vec<String> = k.axes.iter().map(|a| a.to_string()).collect();
            let _ = writeln!(
                s,
                "  not tried: {} on {} ({})",
                k.id.as_str(),
                axes.join(", "),
                k.reason
            );
        }
        self.write_circular(&mut s);
        self.write_residuals(&mut s);
        self.write_places(&mut s);
        s
    }

    /// What the record says of the residual no named cause took, a sentence each: effects
    /// learned as tables, where the residual left lives, and residuals that repeat at the
    /// same places on every pass. The text summary and the HTML page show the same lines.
    pub(crate) fn residual_findings(&self) -> Vec<String> {
        let learned = self.learned.iter().map(learned_line);
        let unexplained = self.unexplained.iter().map(unexplained_line);
        let localized = self.localized.iter().map(localized_line);
        learned.chain(unexplained).chain(localized).collect()
    }

    /// The record, the machine, the alignment and the warnings about the record.
    fn write_record(&self, s: &mut String) {
        let m = &self.measured;
        let _ = writeln!(
            s,
            "Diagnosis of {} against {} ({} samples every {:.3} ms{}{}{})",
            self.program,
            m.file,
            m.samples,
            m.sample_step_s * 1e3,
            if m.resampled { ", resampled" } else { "" },
            if m.rows_per_reading > 1 {
                format!(", each reading held for {} rows", m.rows_per_reading)
            } else {
                String::new()
            },
            if m.commands_recorded {
                ", simulated on its recorded commands"
            } else {
                ""
            },
        );
        let _ = writeln!(
            s,
            "machine {}; clock offset {:.4} s; noise floor {:.3} µm; {} samples compared per axis",
            self.machine, self.clock_offset_s, self.noise_floor_um, m.samples_compared
        );
        for line in self.coverage.describe() {
            let _ = writeln!(s, "{line}");
        }
        for beyond in &self.beyond_machine {
            let _ = writeln!(s, "warning: {beyond}");
        }
        if self.rapids_compared {
            let _ = writeln!(
                s,
                "rapids compared too: the record is mostly rapids, and its commands say how the \
                 control ran them"
            );
        }
        let [hx, hy] = self.hunting_left_out_s;
        if hx > 0.0 || hy > 0.0 {
            let _ = writeln!(
                s,
                "left out: X {hx:.1} s, Y {hy:.1} s where the axis holds still and the model or the machine \
                 hunts about its target (a limit cycle of static friction whose phase no model times)"
            );
        }
        if let Some(drift) = self.timing_drift_ms
            && drift.abs() >= 2.0
        {
            let _ = writeln!(
                s,
                "timing: the record's second half runs {drift:+.1} ms against its first under one \
                 clock offset — the control's timing departs from the plan; record the commanded \
                 positions (x_cmd, y_cmd) to take the timing from the machine"
            );
        }
        if !self.extra_waits.is_empty() {
            let waits: Vec<String> = self
                .extra_waits
                .iter()
                .map(|w| format!("{:+.1} ms after line {}", w.extra_ms, w.line))
                .collect();
            let _ = writeln!(s, "standstills longer than planned: {}", waits.join(", "));
        }
    }

    /// The circular-test figures measured and by both models, and where they and a named cause seem to disagree, why.
    fn write_circular(&self, s: &mut String) {
        let c = &self.circular_test;
        if !c.measured.circles.is_empty() || !c.left_out.is_empty() {
            let _ = writeln!(s, "\nCircular test (ISO 230-4 figures)");
            for (label, t) in [
                ("measured", &c.measured),
                ("nominal model", &c.nominal),
                ("extended model", &c.extended),
            ]
            .into_iter()
            .filter(|_| !c.measured.circles.is_empty())
            {
                let _ = writeln!(s, " {label}");
                s.push_str(&t.text());
            }
            for l in &c.left_out {
                let _ = writeln!(s, " {l}");
            }
            if let Some(sentence) = ballbar_and_causes(self) {
                let _ = writeln!(s, " {sentence}");
            }
        }
    }

    /// The residual table, nominal against extended, with its columns explained.
    fn write_residuals(&self, s: &mut String) {
        let _ = writeln!(
            s,
            "\nResidual, measured − model (µm):      nominal → extended"
        );
        let r = &self.residual;
        for (name, b, a) in [
            ("X", &r.nominal.x, &r.extended.x),
            ("Y", &r.nominal.y, &r.extended.y),
            ("contour", &r.nominal.contour, &r.extended.contour),
        ] {
            let _ = writeln!(
                s,
                "  {name:<8} RMS {:>8.3} → {:<8.3} near events {:>8.3} → {:<8.3} smoothed {:>8.3} → {:<8.3} chatter {:>7.3} → {:<7.3} peak {:>8.3} → {:.3}",
                b.rms_um,
                a.rms_um,
                b.event_rms_um,
                a.event_rms_um,
                b.smoothed_rms_um,
                a.smoothed_rms_um,
                b.chatter_um,
                a.chatter_um,
                b.peak_um,
                a.peak_um
            );
        }
        let _ = writeln!(
            s,
            "  (near events: within ±0.3 s of each axis's reversals and accelerations; smoothed: \
             averaged over ±20 ms, noise removed; chatter: the mismatch of stick-slip amplitude \
             per 0.25 s)"
        );
        if r.contour_in_space {
            let _ = writeln!(
                s,
                "  (contour: the distance to the programmed curve in space, X, Y and Z, on the \
                 blocks that move Z along the contour or lie in ZX or YZ)"
            );
        }
    }

    /// Where the nominal model's residual is largest (with Z where the contour is measured
    /// in space).
    fn write_places(&self, s: &mut String) {
        if !self.places.is_empty() {
            let with_z = self.places.iter().any(|p| p.z_mm.is_some());
            let _ = writeln!(
                s,
                "\nLargest residuals of the nominal model (t on the record's clock):"
            );
            let _ = writeln!(
                s,
                "  {:<8} {:>9} {:>10} {:>10}{} {:>6} {:>10}",
                "what",
                "t (s)",
                "X (mm)",
                "Y (mm)",
                if with_z { "     Z (mm)" } else { "" },
                "line",
                "µm"
            );
            for p in &self.places {
                let z = match p.z_mm {
                    Some(z) => format!(" {z:>10.3}"),
                    None if with_z => format!(" {:>10}", "—"),
                    None => String::new(),
                };
                let _ = writeln!(
                    s,
                    "  {:<8} {:>9.3} {:>10.3} {:>10.3}{z} {:>6} {:>+10.3}",
                    p.what, p.t_record_s, p.x_mm, p.y_mm, p.line, p.residual_um
                );
            }
        }
    }
}

/// Where the ballbar's figures and a named cause seem to disagree, the one sentence that
/// tells why: a screw's backlash behind a linear scale is taken out by the loop, so the
/// ballbar sees reversal spikes, not the step its backlash figure measures.
fn ballbar_and_causes(r: &DiagnoseReport) -> Option<String> {
    let pair = r.circular_test.measured.pairs.first()?;
    let backlash = r.causes.iter().find(|c| c.id == CauseId::Backlash)?;
    let gap = backlash.params.first()?;
    let gap_um = gap.value;
    let (step_um, spikes) = match backlash.axis {
        AxisName::X => (pair.backlash_x_um, [0usize, 2]),
        AxisName::Y => (pair.backlash_y_um, [1, 3]),
        // The ballbar's figures are the XY plane's.
        AxisName::Z => return None,
    };
    if step_um.abs() >= 0.5 * gap_um {
        return None;
    }
    let spike_um = r
        .circular_test
        .measured
        .circles
        .iter()
        .flat_map(|c| spikes.map(|i| c.reversal_spikes_um[i]))
        .filter(|v| v.is_finite())
        .fold(0.0f64, |m, v| m.max(v.abs()));
    // What the loop sees of the gap follows where it reads the axis, not where the record
    // was taken.
    let behind = match r.loop_feedback[backlash.axis.index()] {
        Feedback::LinearScale => {
            "behind the linear scale the loop takes the screw's gap out at each reversal"
        }
        Feedback::MotorEncoder => "the loop closes on the motor, beyond which the gap lies",
    };
    Some(format!(
        "The ballbar's backlash figure for {} ({step_um:+.2} µm, a step across the reversal) \
         is not the {} µm named above: {behind}, and what the circle shows of it is the \
         reversal spikes (up to {spike_um:.1} µm at {}'s reversals).",
        backlash.axis,
        with_uncertainty(gap_um, gap.uncertainty),
        backlash.axis
    ))
}

/// The one-sentence outcome, and the causes the record shows but the model cannot
/// determine.
fn verdict(d: &Diagnosis) -> String {
    let seen: Vec<String> = d
        .rejected
        .iter()
        .filter(|r| r.seen)
        .map(|r| format!("{} on {}", r.id.as_str(), r.axis))
        .collect();
    let outcome = found_sentence(d);
    if seen.is_empty() {
        outcome
    } else {
        format!(
            "{outcome} Seen, not determined: {} (the record shows it, but the model extended \
             by it predicts the record worse point by point; below).",
            seen.join(", ")
        )
    }
}

/// What was found, in a sentence.
fn found_sentence(d: &Diagnosis) -> String {
    if !d.searched {
        return "No cause tried (none allowed by --max-causes, --causes, --exclude or the \
                measuring point); the residuals below are the nominal model's."
            .into();
    }
    if !d.causes.is_empty() {
        // A cause the record cannot tell from others is named with them.
        let names: Vec<String> = d
            .causes
            .iter()
            .map(|c| {
                let one = |id: CauseId, axis: AxisName| format!("{} on {axis}", id.as_str());
                let mut all = vec![one(c.id, c.axis)];
                all.extend(c.alternatives.iter().map(|a| one(a.id, a.axis)));
                if all.len() > 1 {
                    format!("{} (this record cannot tell them apart)", all.join(" or "))
                } else {
                    all.remove(0)
                }
            })
            .collect();
        return format!(
            "{} significant cause{}: {}.",
            d.causes.len(),
            if d.causes.len() == 1 { "" } else { "s" },
            names.join(", ")
        );
    }
    if !d.learned.is_empty() {
        let terms: Vec<String> = d
            .learned
            .iter()
            .map(|l| format!("{} on {}", l.term.describe(), l.axis))
            .collect();
        return format!(
            "No catalogue cause; unlisted effect learned: {}.",
            terms.join(", ")
        );
    }
    let worst = d.before.x.rms_um.max(d.before.y.rms_um);
    if !d.localized.is_empty() {
        let axes: Vec<String> = d.localized.iter().map(|l| l.axis.to_string()).collect();
        format!(
            "No significant cause; a residual repeats at the same places on every pass of {} \
             (a local effect, below), though the whole record's residual is {worst:.3} µm RMS \
             against a noise of {:.3} µm.",
            axes.join(" and "),
            d.noise_floor_um
        )
    } else if worst <= 1.2 * d.noise_floor_um {
        format!(
            "No significant cause: the nominal model predicts the measurement to its noise ({:.3} µm).",
            d.noise_floor_um
        )
    } else {
        format!(
            "No significant cause: the residual ({worst:.3} µm RMS) exceeds the noise ({:.3} µm), but no cause of the \
             catalogue explains enough of it.",
            d.noise_floor_um
        )
    }
}

/// A learned term, in a line.
fn learned_line(l: &Learned) -> String {
    let unit = l.term.variable_unit();
    let decimals = if unit == "mm" { 1 } else { 0 };
    let place = match (l.interval, l.period_mm) {
        (_, Some(p)) => format!(" with a period of {p:.2} mm"),
        (Some((lo, hi)), None) => format!(" between {lo:.decimals$} and {hi:.decimals$} {unit}"),
        (None, None) => String::new(),
    };
    format!(
        "unlisted effect learned: {} on {}{place}, peak {:+.2} {}, as a {}-point table ({}): {} RMS \
         {:.3} → {:.3} µm; held out {:.3} → {:.3} µm",
        l.term.describe(),
        l.axis,
        l.peak,
        l.term.value_unit(),
        l.points,
        l.term.keys(),
        l.axis,
        l.rms_before_um,
        l.rms_after_um,
        l.held_out_before_um,
        l.held_out_after_um
    )
}

/// A residual that repeats at the same places, in a line: where, how large, how sure.
fn localized_line(l: &Localized) -> String {
    let spots: Vec<String> = l
        .spots
        .iter()
        .map(|p| {
            let way = if p.follows_direction {
                " (against the motion: as on passes towards +)"
            } else {
                ""
            };
            format!(
                "{} {:.1} mm ({:.1}–{:.1}) {:+.2} µm{way}, every pass ≥ {:.1} σ, together {:.1} σ",
                l.axis,
                p.centre_mm,
                p.from_mm,
                p.to_mm,
                p.residual_um,
                p.weakest_pass_sigma,
                p.combined_sigma
            )
        })
        .collect();
    let stretch = l.stretch_mm.map_or(String::new(), |(a, b)| {
        format!(
            "; of opposite sign at both ends of {} {a:.1}–{b:.1} mm, as where a stretch differs \
             (friction, scale)",
            l.axis
        )
    });
    format!(
        "localized on {}: the residual repeats at the same places on all {} passes over them \
         (of {} steady passes; windows of {:.1} mm, σ the spread of a window's mean): {}{stretch}. \
         Not a cause of the catalogue, and not machine-wide: a tight spot, or a local scale or \
         straightness error",
        l.axis,
        l.passes_over_spots,
        l.passes,
        l.window_mm,
        spots.join("; ")
    )
}

/// Where an axis's unexplained residual lives, in a line.
fn unexplained_line(u: &Located) -> String {
    let Some(variable) = u.variable else {
        return format!(
            "unexplained on {}: {:.3} µm RMS left, following none of position, velocity, \
             acceleration, direction, time or a period in position",
            u.axis, u.residual_rms_um
        );
    };
    let unit = variable.unit();
    let place = match (variable, u.interval) {
        (Variable::Period, Some((p, _))) => format!(" of {p:.2} mm, amplitude {:.2} µm", u.peak_um),
        (Variable::Direction, _) => format!(", {:+.2} µm one way", u.peak_um),
        (_, Some((lo, hi))) => {
            let d = variable.decimals();
            format!(
                ", largest between {lo:.d$} and {hi:.d$} {unit}: {:+.2} µm",
                u.peak_um
            )
        }
        (_, None) => String::new(),
    };
    format!(
        "unexplained on {}: {:.0} % of the {:.3} µm RMS left follows {}{place} (share predicted \
         on the half of the record not fitted)",
        u.axis,
        100.0 * u.share,
        u.residual_rms_um,
        variable.describe()
    )
}

impl Diagnosis {
    /// The extended machine as a complete machine file (`base = "none"`), the fitted values
    /// and their uncertainties as comments: what `diagnose --write-machine` writes, for a
    /// record `record_file` of `program_file`.
    pub fn machine_file(&self, program_file: &str, record_file: &str) -> String {
        machine_file(&self.machine, self, program_file, record_file)
    }
}

/// The extended machine as a machine file that `check`, `sweep` and `diagnose` load.
pub(crate) fn machine_file(
    machine: &MachineConfig,
    d: &Diagnosis,
    program_file: &str,
    measured_file: &str,
) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# {} extended by diagnosis of {program_file} against {measured_file}.",
        machine.name
    );
    if d.causes.is_empty() {
        let _ = writeln!(
            s,
            "# No significant cause was found: this is the nominal machine."
        );
    }
    for c in &d.causes {
        for p in &c.params {
            let _ = writeln!(
                s,
                "#   {}.{} = {} {}  ({})",
                c.axis,
                p.key,
                with_uncertainty(p.value, p.uncertainty),
                p.unit,
                c.id.as_str()
            );
        }
    }
    let _ = writeln!(s, "base = \"none\"\n");
    // The written machine is not the preset any more: it says so in its name.
    let mut fitted = machine.clone();
    if !d.causes.is_empty() || !d.learned.is_empty() {
        fitted.name = format!("{}-fitted", machine.name);
        fitted.description = format!(
            "{}, extended by diagnosis against {measured_file}",
            machine.description
        );
    }
    s.push_str(&fitted.to_toml());
    s
}
