//! How one named cause reads: its paragraph in the summary (values with their
//! uncertainties, the residual it explains, the held-out test, the causes it cannot be told
//! from), how strongly the record supports it in words, and what a user does about it. The
//! terminal summary and the HTML page say the same things in the same words.

use std::fmt::Write as _;

use super::report::CauseReport;
use super::{Alternative, HeldOutMeasure, JudgedOn};
use crate::diagnose::causes::CauseId;
use crate::machine::{AxisName, Feedback};

/// One named cause: its values, how strongly the record supports it, the residual it
/// explains, on the data it was not fitted on, what to do, and what else fits almost as well.
pub(super) fn write_cause(s: &mut String, i: usize, c: &CauseReport, feedback: Option<Feedback>) {
    let params: Vec<String> = c
        .params
        .iter()
        .map(|p| {
            format!(
                "{} = {} {}",
                p.key,
                with_uncertainty(p.value, p.uncertainty),
                p.unit
            )
            .trim_end()
            .to_string()
        })
        .collect();
    let statistical = if c.fitted_on == "points" {
        String::new()
    } else {
        format!(", fitted on the {}", c.fitted_on)
    };
    let period = c
        .period
        .describe()
        .map_or(String::new(), |p| format!(", {p}"));
    let _ = writeln!(
        s,
        "  {}. {} on {}: {}{period}{statistical}",
        i + 1,
        c.id.as_str(),
        c.axis,
        params.join(", "),
    );
    let _ = writeln!(s, "     {}", strength(c));
    let (b, a, g) = (&c.before, &c.after, &c.gain_percent);
    let _ = writeln!(
        s,
        "     {} residual: RMS {:.3} → {:.3} µm ({:+.0} %), near events {:.3} → {:.3} µm ({:+.0} %), chatter {:.3} → {:.3} µm ({:+.0} %)",
        c.axis,
        b.rms_um,
        a.rms_um,
        -g.rms,
        b.event_rms_um,
        a.event_rms_um,
        -g.event_rms,
        b.chatter_um,
        a.chatter_um,
        -g.chatter
    );
    let h = &c.held_out;
    let unseen = match h.judged_on {
        JudgedOn::OtherHalf => "fitted on half of the record, the other half's",
        JudgedOn::SecondRecord => "fitted on this record, the second record's",
    };
    let measure = h.measure.words();
    let _ = writeln!(
        s,
        "     held out: {unseen} {} {measure} {:.3} → {:.3} µm",
        c.axis, h.rms_before_um, h.rms_after_um
    );
    if h.measure == HeldOutMeasure::ChatterMismatch && a.rms_um > b.rms_um {
        let _ = writeln!(
            s,
            "     point by point the extended model chatters as the machine does, out of phase \
             (no model times the slips), so its RMS is the larger; the chatter and the \
             residual averaged over the slips are what it is judged on"
        );
    }
    let _ = writeln!(s, "     what to do: {}", next_step(c, feedback));
    write_alternatives(s, &c.alternatives);
}

/// Where a fitted gap of `gap_um` goes. On a motor encoder the control adds it at each
/// reversal; behind a linear scale the loop already holds the table where the scale reads,
/// so the same entry would move the table by the gap and make the lost motion it meant to
/// remove.
fn backlash_step(axis: AxisName, gap_um: f64, feedback: Option<Feedback>) -> String {
    match feedback {
        Some(Feedback::LinearScale) => format!(
            "enter no backlash compensation for the {axis} axis: its loop closes on a linear \
             scale beyond the {:.4} mm gap and takes it out at rest, so an entry would add that \
             much lost motion; the reversal spikes while the nut crosses the gap remain (a \
             preloaded nut or the control's reversal-spike compensation reduces them)",
            gap_um * 1e-3
        ),
        _ => format!(
            "enter {:.4} mm as the {axis} axis's backlash compensation (LinuxCNC: BACKLASH in \
             its [JOINT_n] section; SINUMERIK: MD32450 $MA_BACKLASH): its loop closes on the \
             motor, and the table trails the motor by the gap after each reversal",
            gap_um * 1e-3
        ),
    }
}

/// The causes a record cannot tell from the one named, each with its values and what
/// would separate them.
fn write_alternatives(s: &mut String, alternatives: &[Alternative]) {
    for a in alternatives {
        let values: Vec<String> = a
            .params
            .iter()
            .map(|p| {
                format!("{} = {} {}", p.key, sig(p.value), p.unit)
                    .trim_end()
                    .to_string()
            })
            .collect();
        let _ = writeln!(
            s,
            "     or {} on {} ({}): this record cannot tell them apart; {} would",
            a.id.as_str(),
            a.axis,
            values.join(", "),
            a.told_apart_by
        );
    }
}

/// A value with its standard uncertainty in two significant digits, the value to the same
/// decimal place: `7.989 ± 0.019`.
pub(crate) fn with_uncertainty(value: f64, uncertainty: f64) -> String {
    if !(uncertainty.is_finite() && uncertainty > 0.0) {
        return format!("{} (uncertainty not determined)", sig(value));
    }
    let decimals = (1 - uncertainty.log10().floor() as i32).clamp(0, 12) as usize;
    format!("{value:.decimals$} ± {uncertainty:.decimals$}")
}

/// How strongly the record supports a cause, in words a user can weigh: by how much the
/// residual falls on data the fit did not see, against what chance would give.
pub(crate) fn strength(c: &CauseReport) -> String {
    let h = &c.held_out;
    let fall = if h.rms_before_um > 0.0 {
        100.0 * (1.0 - h.rms_after_um / h.rms_before_um)
    } else {
        0.0
    };
    let word = match h.evidence {
        e if e >= 100.0 => "strong",
        e if e >= 20.0 => "clear",
        _ => "moderate",
    };
    let near = c.gain_percent.event_rms;
    let where_ = if near > 1.5 * c.gain_percent.rms && near > 0.0 {
        format!(
            " (on the whole record, near the reversals and accelerations where it acts: by \
             {near:.0} %)"
        )
    } else {
        String::new()
    };
    let unseen = match h.judged_on {
        JudgedOn::OtherHalf => "the half of the record it was not fitted on",
        JudgedOn::SecondRecord => "the second record, which it was not fitted on",
    };
    let what = match h.measure {
        HeldOutMeasure::Rms => "residual",
        HeldOutMeasure::ChatterMismatch => "chatter amplitude mismatch",
    };
    format!(
        "{word}: on {unseen}, {}'s {what} falls by {fall:.0} % — beyond what the noise alone \
         would give{where_}",
        c.axis
    )
}

/// What a user does about a cause once it is named: where the value goes, or what to check.
/// `feedback` is where the axis's loop reads it (none for an axis not simulated in the
/// plane): a backlash compensation belongs only to a loop closed before the gap.
pub(crate) fn next_step(c: &CauseReport, feedback: Option<Feedback>) -> String {
    let axis = c.axis;
    let value = c.params.first().map_or(f64::NAN, |p| p.value);
    match c.id {
        CauseId::Backlash => backlash_step(axis, value, feedback),
        CauseId::KvGain => format!(
            "the {axis} axis's position gain is not the machine file's: check it on the control \
             (SINUMERIK MD32200 $MA_POS_CTRLGAIN; LinuxCNC: the position PID's P gain) and keep \
             the fitted Kv in the machine file for predictions"
        ),
        CauseId::DeadTime => format!(
            "the {axis} loop reacts {value:.2} ms late: check the measuring system's and the \
             drive's delays and filters; keep the fitted dead time for predictions"
        ),
        CauseId::CoulombFriction | CauseId::Stribeck => format!(
            "the {axis} axis's friction differs from the model: check lubrication and the gibs \
             or preload; the fitted machine file (--write-machine) predicts with it"
        ),
        CauseId::ScaleError | CauseId::CyclicError | CauseId::DirectionOffset => format!(
            "a static error of the {axis} axis's measurement: --write-compensation DIR writes the \
             table a control loads (LinuxCNC comp file; SINUMERIK leadscrew error compensation)"
        ),
        CauseId::Squareness | CauseId::Straightness | CauseId::LateralPlay => format!(
            "a geometric error between the axes, seen on {axis}: compensate it \
             (--write-compensation DIR) or realign the axes"
        ),
        CauseId::ForceRipple => format!(
            "a force on the {axis} table repeats with its position every {} mm: check the \
             motor's torque ripple and cogging, the screw's run-out and the drive's ripple \
             compensation; the fitted machine file predicts with it",
            c.period.period_mm.map_or_else(|| "?".into(), sig)
        ),
        CauseId::Resonance => format!(
            "a structural mode at {value:.1} Hz shows on {axis}: check the velocity loop's filters \
             and the machine's mounting; the fitted machine file predicts with it"
        ),
    }
}

/// A value with about four significant digits.
pub(super) fn sig(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let digits = (3 - v.abs().log10().floor() as i32).clamp(0, 9) as usize;
    format!("{v:.digits$}")
}
