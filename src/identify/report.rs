//! An identification for people (the terminal's table), for scripts (JSON) and for the
//! control (the machine file with the values and their uncertainties in its header).

// The HTML page's note; the terminal and the file header word it in their own lines.
#[cfg(feature = "html-report")]
pub(crate) use super::held_out::in_sample_note;
use std::fmt::Write as _;

use super::knobs::{HELD_AT_START, MASS_KEY};
use crate::identify::{AxisIdentification, HeldForce, Identification, IdentifiedValue};
use crate::machine::MachineConfig;

impl Identification {
    /// The identified machine as a machine file (what `identify --out` writes), its values
    /// and their uncertainties in the header.
    pub fn machine_file(&self, template: &MachineConfig, program_file: &str) -> String {
        machine_file(self, template, program_file)
    }
}

/// Schema id of the JSON report.
pub const SCHEMA: &str = "contourcheck.identify/1";

/// The JSON report of an identification (`docs/report-schema.md`).
#[derive(Debug, Clone, serde::Serialize)]
pub struct IdentifyReport<'a> {
    /// Schema id.
    pub schema: &'static str,
    /// The program the record ran.
    pub program: &'a str,
    /// The template machine's name.
    pub template: &'a str,
    /// What was identified.
    #[serde(flatten)]
    pub identification: &'a Identification,
}

impl<'a> IdentifyReport<'a> {
    /// The report of `identification`, of a record of `program` from `template`.
    pub fn new(identification: &'a Identification, program: &'a str, template: &'a str) -> Self {
        IdentifyReport {
            schema: SCHEMA,
            program,
            template,
            identification,
        }
    }
}

/// A value for the table: fitted with its uncertainty (said so where that is not a
/// measurement), or the template's.
pub(crate) fn shown(v: &IdentifiedValue) -> String {
    if let Some(pair) = v.complex_pair {
        return format!(
            "complex pair near {} Hz, damping {:.3} ({})",
            sig(pair.natural_hz),
            pair.damping,
            status(v)
        );
    }
    if !v.fitted() {
        return format!("{} ({})", sig(v.value), status(v));
    }
    match v.measured {
        true => format!("{} ± {}", sig(v.value), sig(v.uncertainty)),
        false => format!("{} ± {} ({})", sig(v.value), sig(v.uncertainty), status(v)),
    }
}

/// How the record holds a value, in words (the report's, the HTML page's and the machine
/// file's header's): identified, a model's value (traded with another, left loose by the
/// halves, or determined but not a measurement), or the template's.
pub(crate) fn status(v: &IdentifiedValue) -> String {
    if let Some(other) = v.traded_with {
        return format!("not determined alone: traded with {other}; a model's value");
    }
    if v.loose {
        return "not determined: the record's halves leave it loose; a model's value".to_string();
    }
    match (v.determined, v.measured) {
        (true, true) => "identified".to_string(),
        (true, false) => "a model's value, not a measurement".to_string(),
        (false, _) => "not determined: the template's".to_string(),
    }
}

/// The force an axis held at rest at the record's start, in words (the terminal's and the
/// file header's).
pub(crate) fn held_line(h: &HeldForce, values: &[IdentifiedValue]) -> String {
    let what = "force held at rest at the record's start";
    if !h.told_apart_from_values {
        let traded: Vec<&str> = values
            .iter()
            .filter(|v| v.traded_with == Some(HELD_AT_START.key))
            .map(|v| v.key)
            .collect();
        let force = match h.at_level {
            true => format!("{} N, the friction's level at rest", sig(h.force_n)),
            false => format!(
                "{} ± {} N, within the friction's ±{} N at rest",
                sig(h.force_n),
                sig(h.uncertainty_n),
                sig(h.level_n)
            ),
        };
        return format!(
            "{what}: not told apart — the fit reaches the noise without it, and its values \
             fitted again beside it ({force}) move {} beyond their uncertainty by more than \
             noise alone would: those are not determined alone, their uncertainty widened to \
             the move; none kept",
            traded.join(", ")
        );
    }
    if !h.kept {
        return format!(
            "{what}: none kept — fitted with it (within the friction's ±{} N at rest), the \
             values do not predict the held-out halves better by a twentieth, or predict them \
             worse holding none (or could not be fitted again)",
            sig(h.level_n)
        );
    }
    let value = if h.at_level {
        format!(
            "{} N, the friction's level at rest (the table on the verge of breaking away; the \
             record bounds it from one side only)",
            sig(h.force_n)
        )
    } else if !h.uncertainty_n.is_finite() {
        format!(
            "{} N (not determined: the record does not see it)",
            sig(h.force_n)
        )
    } else {
        format!(
            "{} ± {} N, within the friction's ±{} N at rest{}",
            sig(h.force_n),
            sig(h.uncertainty_n),
            sig(h.level_n),
            if h.determined {
                ""
            } else {
                " (not determined alone)"
            }
        )
    };
    format!(
        "{what}: {value} — a state of the record, not of the machine: not written; fitted on top \
         of the values (after the ripple's and the bristles' figures above), which with it \
         estimated on each half scored predict the held-out halves to {} µm against {} µm \
         fitted again without it; the held-out figures above hold none, as the file does (the \
         residual above holds it)",
        sig(h.held_out_with_um),
        sig(h.held_out_refit_um)
    )
}

/// Four significant digits.
pub(crate) fn sig(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let digits = (3 - v.abs().log10().floor() as i32).clamp(0, 9) as usize;
    format!("{v:.digits$}")
}

/// The identification as the terminal shows it.
#[cfg(feature = "cli")]
pub(crate) fn summary_text(id: &Identification, template: &MachineConfig) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "identified from {} (template {}; record noise {:.3} µm)",
        id.file, template.name, id.noise_um
    );
    for line in id.coverage.describe() {
        let _ = writeln!(s, "{line}");
    }
    for a in &id.axes {
        axis_summary(&mut s, a, id.noise_um);
    }
    if let Some(line) = no_ripple_period_line(&id.axes) {
        let _ = writeln!(s, "\n{line}");
    }
    if let Some(why) = &id.z_not_identified {
        let _ = writeln!(
            s,
            "\nZ axis: not identified: {why}; the template's Z is written"
        );
    }
    let lines = interpolator_lines(&id.interpolator);
    let _ = writeln!(s, "\ninterpolator: {}", lines[0]);
    for line in &lines[1..] {
        let _ = writeln!(s, "  {line}");
    }
    s
}

/// Why an axis is compared away from its standstills, where it is: what `written` checked,
/// not a guess at the cause (a hunting hold, or a wind-up at rest the model does not carry,
/// look alike to it). A fit away from the standstills that reaches the record's noise is
/// written for that alone; one that does not, for predicting its held-out halves better
/// than the fit over every sample.
#[cfg(any(feature = "cli", feature = "html-report"))]
pub(crate) fn moving_only_note(a: &AxisIdentification) -> Option<&'static str> {
    match (a.moving_only, a.reached) {
        (false, _) => None,
        (true, true) => Some(
            "compared while moving: away from its standstills the fit reaches the record's \
             noise, over every sample it does not",
        ),
        (true, false) => Some(
            "compared while moving: the fit over every sample, standstills included, predicts \
             the held-out halves no better",
        ),
    }
}

/// One axis: its residuals, what they predict against the template and the regression, and
/// its values.
#[cfg(feature = "cli")]
fn axis_summary(s: &mut String, a: &AxisIdentification, noise_um: f64) {
    if let Some(why) = &a.too_little {
        let _ = writeln!(s, "\n{} axis: {}", a.axis, too_little_words(why));
        return;
    }
    let _ = writeln!(
        s,
        "\n{} axis: residual {:.3} → {:.3} µm RMS{} (following error {:.1} µm); held out \
         {:.3} {}",
        a.axis,
        a.rms_template_um,
        a.rms_identified_um,
        moving_only_note(a).map_or(String::new(), |note| format!(", {note}")),
        a.following_error_rms_um,
        a.held_out_template_um,
        super::held_out::identified_words(a)
    );
    if let Some(line) = while_moving_line(a) {
        let _ = writeln!(s, "  {line}");
    }
    if let Some(line) = file_line(a) {
        let _ = writeln!(s, "  {line}");
    }
    let _ = writeln!(s, "  {}", prediction(a));
    if let Some(verdict) = verdict(a, noise_um) {
        let _ = writeln!(s, "  {verdict}");
    }
    if a.values.iter().all(|v| !v.fitted()) {
        let _ = writeln!(
            s,
            "  the record determines none of {}'s values: what it compares (above) does not \
             move them beyond their uncertainty; the template's are written",
            a.axis
        );
    }
    let _ = writeln!(s, "  {:<38} {:>14}  identified", "key", "template");
    for v in &a.values {
        let _ = writeln!(
            s,
            "  {:<38} {:>14}  {} {}",
            v.key,
            sig(v.template),
            shown(v),
            v.unit
        );
    }
    if let Some(line) = gain_per_inertia_line(a) {
        let _ = writeln!(s, "  {line}");
    }
    if let Some(r) = &a.force_ripple {
        let _ = writeln!(s, "  {}", r.statement);
    }
    if let Some(p) = &a.presliding {
        let _ = writeln!(s, "  {}", p.statement);
    }
    if let Some(h) = &a.held_at_start {
        let _ = writeln!(s, "  {}", held_line(h, &a.values));
    }
    if let Some(line) = structure_line(a) {
        let _ = writeln!(s, "  {line}");
    }
    let _ = writeln!(s, "  {}", kept_line(a));
}

/// How the template's structure compared with the loop model, where it was.
pub(crate) fn structure_line(a: &AxisIdentification) -> Option<String> {
    a.structure_compared.as_ref().map(super::structure::line)
}

/// What the axis kept: a loop model's family and order, or what it took from the template.
#[cfg(feature = "html-report")]
pub(crate) fn kept_line(a: &AxisIdentification) -> String {
    if super::structure::describes_a_loop(&a.kept) {
        a.kept.clone()
    } else {
        format!("kept from the template: {}", a.kept)
    }
}

/// The gain over the drive's inertia, where fitted, and how the record holds it: what the
/// record determines where the gain and the mass trade — only where it does (within half of
/// itself, on an axis none of whose values the record's halves leave loose); else a model's
/// figure, said why.
pub(crate) fn gain_per_inertia_line(a: &AxisIdentification) -> Option<String> {
    let r = a.gain_per_inertia.as_ref()?;
    // The gain and the mass trade with each other (their ratio is what the record sees);
    // traded with the force held at the start, or with a value put back to the template's,
    // the ratio is bent with them.
    let pair_traded_with = |with: &dyn Fn(&str) -> bool| {
        a.values
            .iter()
            .any(|v| (v.key == r.gain || v.key == MASS_KEY) && v.traded_with.is_some_and(with))
    };
    let how = if a.values.iter().any(|v| v.loose) {
        "not determined: the record's halves leave it loose; a model's figure"
    } else if pair_traded_with(&|w| w == HELD_AT_START.key) {
        "not determined: the record cannot tell the axis's values from a force held at its \
         start; a model's figure"
    } else if pair_traded_with(&|w| w != r.gain && w != MASS_KEY) {
        "not determined: fitted about the template's value of one the record leaves loose, \
         which moves it; a model's figure"
    } else if r.uncertainty.is_nan() || r.uncertainty > 0.5 * r.value.abs() {
        "not determined: its uncertainty exceeds half of it; a model's figure"
    } else {
        "what the record determines where the gain and the mass trade"
    };
    Some(format!(
        "{} per inertia: {} ± {} per kg, of {:.1} kg at the table (rotor, screw and table) — \
         {how}",
        r.gain,
        sig(r.value),
        sig(r.uncertainty),
        r.inertia_kg
    ))
}

/// Once for the axes whose template names no force ripple's period: no ripple is fitted
/// there, said so rather than left out.
pub(crate) fn no_ripple_period_line(axes: &[AxisIdentification]) -> Option<String> {
    let without: Vec<String> = axes
        .iter()
        .filter(|a| a.force_ripple.is_none())
        .map(|a| a.axis.to_string())
        .collect();
    (!without.is_empty()).then(|| {
        format!(
            "force ripple: not fitted on {}: the template names no period \
             (errors.force_ripple_period_mm)",
            without.join(", ")
        )
    })
}

/// Where the axis is judged by its held-out figures while moving: those, named so (the
/// whole record's stay on the axis's first line).
pub(crate) fn while_moving_line(a: &AxisIdentification) -> Option<String> {
    let m = a.while_moving.as_ref().filter(|_| a.judged_while_moving)?;
    Some(format!(
        "judged while moving (its halves' fits disagree at standstill, where it hunts): held \
         out {:.3} → {:.3} µm there (following error {:.1} µm)",
        m.held_out_template_um, m.held_out_identified_um, m.following_error_rms_um
    ))
}

/// What the machine written predicts of the record's held-out halves — while moving, said
/// so, where the axis is judged there —, against the template and the plain regression on
/// the command (whole record).
pub(crate) fn prediction(a: &AxisIdentification) -> String {
    if let Some(why) = &a.too_little {
        return too_little_words(why);
    }
    let (template_um, fitted_um, following_um, _) = a.judged_held_out();
    let written = if a.better_than_template || a.template_holds {
        fitted_um
    } else {
        template_um
    };
    let (on, regression_on) = if a.judged_while_moving {
        (" while moving", " (whole record)")
    } else {
        ("", "")
    };
    let share = |um: f64| 100.0 * um / following_um;
    let place = a
        .largest_at
        .map_or(String::new(), |p| format!(", largest {}", p.describe()));
    let b = &a.baseline;
    let against = if written < b.held_out_um {
        format!("{:.1}× better", b.held_out_um / written)
    } else {
        format!("the model is {:.1}× WORSE than it", written / b.held_out_um)
    };
    format!(
        "predicts held-out data{on} to {:.1} % of the following error ({:.3} µm RMS \
         left{place}); the template {:.0} %; a regression on the command's velocity, \
         acceleration, jerk and direction{regression_on} {:.0} % ({against})",
        share(written),
        written,
        share(template_um),
        100.0 * b.share,
    )
}

/// An axis the record holds too little of: why, and what is written.
fn too_little_words(why: &str) -> String {
    format!("not identified: {why}; the template's values are written")
}

/// What the fit is, where it is not simply identified to the record's noise.
#[cfg(feature = "html-report")]
pub(crate) fn verdict(a: &AxisIdentification, noise_um: f64) -> Option<String> {
    // Too little compared to judge: `prediction` says why, and nothing is claimed.
    if a.too_little.is_some() {
        return None;
    }
    if a.template_holds {
        return Some(
            "the template explains the record to its noise, and values fitted to it predict \
             its held-out halves worse than the template does: the template's values stay"
                .to_string(),
        );
    }
    if a.reached {
        return None;
    }
    let on = if a.judged_while_moving {
        " while moving"
    } else {
        ""
    };
    // At the noise on the samples it was fitted to, a fit whose halves disagree was left
    // loose by the record; above it, the model lacks something, loose values or not.
    let at_noise = a.judged_while_moving || super::within_noise(a.rms_identified_um, noise_um);
    let loose = a.values.iter().any(|v| v.loose);
    Some(if a.better_than_template && at_noise {
        format!(
            "written as a model: it follows the record to its noise ({:.3} µm against {:.3} \
             µm), but its halves predict each other{on} only to {:.3} µm, more than twice \
             the noise — the record leaves its values loose: they predict better than the \
             template's, none is a measurement",
            a.rms_identified_um,
            noise_um,
            a.judged_held_out().1
        )
    } else if a.better_than_template {
        let left = if loose {
            ", and the record leaves some of its values loose (marked)"
        } else {
            ""
        };
        format!(
            "written as a model: it stays at {:.3} µm against the record's noise of {:.3} µm \
             (the model lacks something of this machine: `diagnose` looks for effects beyond \
             it){left}, and predicts the held-out halves better than the template — its \
             values predict, none is a measurement",
            a.rms_identified_um, noise_um
        )
    } else {
        format!(
            "NOT IDENTIFIED: the best fit ({:.3} µm) predicts the held-out halves no better \
             than the template — the template's controller or settings are not this \
             machine's (or it has effects `diagnose` looks for); the template's values are \
             kept",
            a.rms_identified_um
        )
    })
}

/// The record's interpolator in words: the path speed, then per axis its speeds and its
/// acceleration and jerk, each said to be held (written as the limit), beyond the
/// template's limit (its peak written), or only a peak.
#[cfg(feature = "html-report")]
pub(crate) fn interpolator_lines(i: &crate::identify::Interpolator) -> Vec<String> {
    use super::interpolator::beyond;
    let limit = |value: f64, demanded: f64, unit: &str, held: bool, template: Option<f64>| {
        if held {
            format!(
                "{value:.3} {unit} (held where the template's planner asked {demanded:.3}: \
                 written as the limit)"
            )
        } else if let Some(t) = template.filter(|t| beyond(value, *t)) {
            format!(
                "peak {value:.3} {unit} (beyond the template's limit of {t:.3}: the peak is \
                 written as the limit)"
            )
        } else {
            format!("peak {value:.3} {unit} (not shown to be a limit: the template's stays)")
        }
    };
    let speed = |what: &str, value: f64, template: f64| {
        if beyond(value, template) {
            format!(
                "{what} up to {value:.0} mm/min (beyond the template's {template:.0}: \
                 written as the limit)"
            )
        } else {
            format!("{what} up to {value:.0} mm/min")
        }
    };
    let mut lines = vec![format!(
        "path speed up to {:.0} mm/min",
        i.path_speed_mm_per_min
    )];
    for (k, axis) in i.axes.iter().enumerate() {
        lines.push(format!(
            "{axis}: {}, {}, acceleration {}, jerk {}",
            speed(
                "at feed",
                i.feed_mm_per_min[k],
                i.template_feed_mm_per_min[k]
            ),
            speed(
                "in rapids",
                i.rapid_mm_per_min[k],
                i.template_rapid_mm_per_min[k]
            ),
            limit(
                i.accel_m_per_s2[k],
                i.demanded_accel_m_per_s2[k],
                "m/s²",
                i.accel_limited[k],
                Some(i.template_accel_m_per_s2[k])
            ),
            limit(
                i.jerk_m_per_s3[k],
                i.demanded_jerk_m_per_s3[k],
                "m/s³",
                i.jerk_limited[k],
                None
            ),
        ));
    }
    lines
}

/// What the file written gives on the record, where that is not the fit's figure: why
/// they differ, so that a user who runs the file knows which figure to expect.
pub(crate) fn file_line(a: &AxisIdentification) -> Option<String> {
    let file_um = a.file_rms_um?;
    let held = a.held_at_start.is_some_and(|h| h.kept);
    let why = if a.moving_only && held {
        "the fit's figures are while moving and hold a force at the record's start; the file \
         runs the record's starts and stops too, holding none"
    } else if a.moving_only {
        "the fit's figures are while moving; the file runs the record's starts and stops too"
    } else if held {
        "the fit held a force at the record's start; the file holds none"
    } else {
        "the file's model holds still differently, so other samples are left out"
    };
    Some(format!(
        "the machine file written leaves {file_um:.3} µm RMS on this record, every sample \
         compared as `diagnose` compares it ({why})"
    ))
}

/// The identified machine as a machine file, its values and their uncertainties in the
/// header.
pub(crate) fn machine_file(
    id: &Identification,
    template: &MachineConfig,
    program_file: &str,
) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# {} identified from {program_file} against {}.",
        template.name, id.file
    );
    for a in &id.axes {
        let _ = writeln!(s, "#   {}: {}", a.axis, prediction(a));
        if let Some(line) = file_line(a) {
            let _ = writeln!(s, "#   {}: {line}", a.axis);
        }
        if a.held_out_in_sample {
            let _ = writeln!(
                s,
                "#   {}: held out {:.3} (template) {}",
                a.axis,
                a.held_out_template_um,
                super::held_out::identified_words(a)
            );
        }
        if let Some(line) = while_moving_line(a) {
            let _ = writeln!(
                s,
                "#   {}: {line}; on the whole record held out {:.3} → {:.3} µm",
                a.axis, a.held_out_template_um, a.held_out_identified_um
            );
        }
        for v in &a.values {
            let _ = writeln!(s, "#   {}.{} = {} {}", a.axis, v.key, shown(v), v.unit);
        }
        if let Some(line) = gain_per_inertia_line(a) {
            let _ = writeln!(s, "#   {}.{line}", a.axis);
        }
        if let Some(r) = &a.force_ripple {
            let _ = writeln!(s, "#   {}: {}", a.axis, r.statement);
        }
        if let Some(p) = &a.presliding {
            let _ = writeln!(s, "#   {}: {}", a.axis, p.statement);
        }
        if let Some(h) = &a.held_at_start {
            let _ = writeln!(s, "#   {}: {}", a.axis, held_line(h, &a.values));
        }
        if let Some(line) = structure_line(a) {
            let _ = writeln!(s, "#   {}: {line}", a.axis);
        }
        // A loop model: the family and order the held-out halves chose, and why.
        if super::structure::describes_a_loop(&a.kept) {
            let _ = writeln!(s, "#   {}: {}", a.axis, a.kept);
        }
    }
    if let Some(line) = no_ripple_period_line(&id.axes) {
        let _ = writeln!(s, "#   {line}");
    }
    if let Some(why) = &id.z_not_identified {
        let _ = writeln!(s, "#   Z: not identified ({why}): the template's");
    }
    let _ = writeln!(s, "base = \"none\"\n");
    s.push_str(&id.machine.to_toml());
    s
}

#[cfg(all(test, any(feature = "cli", feature = "html-report")))]
mod tests {
    use super::*;

    #[test]
    fn a_fit_while_moving_says_which_check_wrote_it() {
        let mut a = AxisIdentification::scored(1.0, 0.5);
        a.moving_only = false;
        assert_eq!(moving_only_note(&a), None);
        // Written for reaching the noise away from the standstills ...
        a.moving_only = true;
        a.reached = true;
        assert!(moving_only_note(&a).is_some_and(|n| n.contains("reaches the record's noise")));
        // ... or, above it, for predicting the held-out halves better.
        a.reached = false;
        assert!(moving_only_note(&a).is_some_and(|n| n.contains("held-out halves no better")));
    }
}
