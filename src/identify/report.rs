//! An identification for people (the terminal's table), for scripts (JSON) and for the
//! control (the machine file with the values and their uncertainties in its header).

use std::fmt::Write as _;

use crate::identify::{AxisIdentification, Identification, IdentifiedValue, Interpolator};
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

    /// Writes the report as pretty JSON.
    pub fn write_json(&self, w: &mut dyn std::io::Write) -> std::io::Result<()> {
        serde_json::to_writer_pretty(&mut *w, self).map_err(std::io::Error::other)?;
        w.write_all(b"\n")
    }
}

/// A value for the table: fitted with its uncertainty (said so where that is not a
/// measurement), or the template's.
pub fn shown(v: &IdentifiedValue) -> String {
    match (v.determined, v.measured) {
        (true, true) => format!("{} ± {}", sig(v.value), sig(v.uncertainty)),
        (true, false) => format!(
            "{} ± {} (a model's value, not a measurement)",
            sig(v.value),
            sig(v.uncertainty)
        ),
        (false, _) => format!("{} (not determined: the template's)", sig(v.value)),
    }
}

/// Four significant digits.
pub fn sig(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let digits = (3 - v.abs().log10().floor() as i32).clamp(0, 9) as usize;
    format!("{v:.digits$}")
}

/// The identification as the terminal shows it.
pub fn summary_text(id: &Identification, template: &MachineConfig) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "identified from {} (template {}; record noise {:.3} µm)",
        id.file, template.name, id.noise_um
    );
    for a in &id.axes {
        write_axis(&mut s, a, id.noise_um);
    }
    let lines = interpolator_lines(&id.interpolator);
    let _ = writeln!(s, "\ninterpolator: {}", lines[0]);
    for line in &lines[1..] {
        let _ = writeln!(s, "  {line}");
    }
    s
}

/// One axis: its residuals, whether it was identified, its values against the template's.
fn write_axis(s: &mut String, a: &AxisIdentification, noise_um: f64) {
    let _ = writeln!(
        s,
        "\n{} axis: residual {:.3} → {:.3} µm RMS{} (following error {:.1} µm); held out \
         {:.3} → {:.3} µm",
        a.axis,
        a.rms_template_um,
        a.rms_identified_um,
        if a.moving_only {
            ", compared while moving: the axis hunts at standstill"
        } else {
            ""
        },
        a.following_error_rms_um,
        a.held_out_template_um,
        a.held_out_identified_um
    );
    if !a.reached {
        let _ = writeln!(
            s,
            "  NOT IDENTIFIED: the best fit stays at {:.3} µm against the record's noise of \
             {:.3} µm — the template's controller or settings are not this machine's (or it \
             has effects `diagnose` looks for); the template's values are kept",
            a.rms_identified_um, noise_um
        );
    }
    if a.template_holds {
        let _ = writeln!(
            s,
            "  the template explains the record to its noise, and values fitted to it \
             predict its held-out halves worse than the template does: the template's \
             values stay"
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
    if let Some(r) = &a.gain_per_inertia {
        let _ = writeln!(
            s,
            "  {} per inertia: {} ± {} per kg, of {:.1} kg at the table (rotor, screw and \
             table) — what the record determines where the gain and the mass trade",
            r.gain,
            sig(r.value),
            sig(r.uncertainty),
            r.inertia_kg
        );
    }
    if a.kept.starts_with("no template") {
        let _ = writeln!(s, "  {}", a.kept);
    } else {
        let _ = writeln!(s, "  kept from the template: {}", a.kept);
    }
}

/// The record's interpolator in words: the path speed, then per axis its speed and its
/// acceleration and jerk, each said to be held (written as the limit) or not.
pub fn interpolator_lines(i: &Interpolator) -> Vec<String> {
    let limit = |value: f64, unit: &str, held: bool| {
        if held {
            format!("{value:.3} {unit} (held: written as the limit)")
        } else {
            format!("{value:.3} {unit} (not held: the template's limit stays)")
        }
    };
    let mut lines = vec![format!(
        "path speed up to {:.0} mm/min",
        i.path_speed_mm_per_min
    )];
    for (k, axis) in ["X", "Y"].iter().enumerate() {
        lines.push(format!(
            "{axis}: up to {:.0} mm/min, acceleration {}, jerk {}",
            i.velocity_mm_per_min[k],
            limit(i.accel_m_per_s2[k], "m/s²", i.accel_limited[k]),
            limit(i.jerk_m_per_s3[k], "m/s³", i.jerk_limited[k]),
        ));
    }
    lines
}

/// The identified machine as a machine file, its values and their uncertainties in the
/// header.
pub fn machine_file(id: &Identification, template: &MachineConfig, program_file: &str) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# {} identified from {program_file} against {}.",
        template.name, id.file
    );
    for a in &id.axes {
        for v in &a.values {
            let _ = writeln!(s, "#   {}.{} = {} {}", a.axis, v.key, shown(v), v.unit);
        }
        if let Some(r) = &a.gain_per_inertia {
            let _ = writeln!(
                s,
                "#   {}.{} per inertia = {} ± {} per kg (of {:.1} kg)",
                a.axis,
                r.gain,
                sig(r.value),
                sig(r.uncertainty),
                r.inertia_kg
            );
        }
    }
    let _ = writeln!(s, "base = \"none\"\n");
    s.push_str(&id.machine.to_toml());
    s
}
