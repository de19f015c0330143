//! The page of an identification: the record and the template, per axis the residual and
//! the held-out figure, the template's values against the identified ones with their
//! uncertainties, and the interpolator's limits.

use serde::Serialize;
use serde_json::Value as Json;

use super::{Fig, HtmlError, Inputs, Made, Row, decimals_for, fig, file_name, render};
use crate::identify::report::IdentifyReport;

/// The page's view of an identification.
#[derive(Serialize)]
struct IdentifyPage {
    title: String,
    made: Made,
    conditions: Vec<Row>,
    axes: Vec<AxisView>,
    interpolator: Vec<String>,
}

/// One axis: its residuals and its values.
#[derive(Serialize)]
struct AxisView {
    axis: String,
    /// Template → identified on the whole record, and on the held-out halves.
    residual: [Fig; 2],
    held_out: [Fig; 2],
    /// The held-out halves while moving, where the axis is judged on them.
    held_out_while_moving: Option<[Fig; 2]>,
    following_error: Fig,
    notes: Vec<String>,
    values: Vec<ValueView>,
    gain_per_inertia: Option<String>,
}

/// A template's value against the identified one.
#[derive(Serialize)]
struct ValueView {
    key: String,
    unit: String,
    template: Fig,
    value: Fig,
    uncertainty: Fig,
    status: String,
}

/// The HTML report of an identification, from its JSON `report`.
pub fn identify_page(report: &IdentifyReport, inputs: &Inputs) -> Result<String, HtmlError> {
    let json = serde_json::to_value(report)?;
    let id = report.identification;
    let page = IdentifyPage {
        title: format!(
            "Machine identified from {} ({})",
            file_name(&id.file),
            file_name(report.program)
        ),
        made: Made::now(),
        conditions: vec![
            Row {
                label: "program",
                value: report.program.to_string(),
            },
            Row {
                label: "record",
                value: id.file.clone(),
            },
            Row {
                label: "template",
                value: report.template.to_string(),
            },
            Row {
                label: "template file",
                value: inputs.machine_source(report.template),
            },
            Row {
                label: "record noise",
                value: format!("{:.3} µm", id.noise_um),
            },
        ],
        axes: (0..id.axes.len())
            .map(|a| axis_view(report, &json, a))
            .collect(),
        interpolator: crate::identify::report::interpolator_lines(&id.interpolator),
    };
    render("identify.html", page)
}

fn axis_view(report: &IdentifyReport, json: &Json, a: usize) -> AxisView {
    let axis = &report.identification.axes[a];
    // An axis the record holds too little of has figures of nothing: shown "—".
    let f = |field: &str, d| match &axis.too_little {
        Some(_) if !field.starts_with("values[") => super::Fig::missing(),
        _ => fig(json, &format!("axes[{a}].{field}"), d),
    };
    let mut notes = vec![crate::identify::report::prediction(axis)];
    notes.extend(crate::identify::report::verdict(
        axis,
        report.identification.noise_um,
    ));
    if let Some(note) = crate::identify::report::moving_only_note(axis) {
        // A sentence of its own: capitalised, closed.
        let mut chars = note.chars();
        let first = chars
            .next()
            .map(|c| c.to_uppercase().to_string())
            .unwrap_or_default();
        notes.push(format!("{first}{}.", chars.as_str()));
    }
    notes.extend(crate::identify::report::while_moving_line(axis));
    notes.extend(crate::identify::report::file_line(axis));
    notes.extend(crate::identify::report::in_sample_note(axis));
    notes.extend(crate::identify::report::structure_line(axis));
    let kept = crate::identify::report::kept_line(axis);
    let mut first = kept.chars();
    notes.push(first.next().map_or(String::new(), |c| {
        c.to_uppercase().chain(first).collect::<String>()
    }));
    let values = axis
        .values
        .iter()
        .enumerate()
        .map(|(k, v)| {
            let decimals = decimals_for(v.uncertainty);
            ValueView {
                key: v.key.to_string(),
                unit: v.unit.to_string(),
                template: f(&format!("values[{k}].template"), 4),
                value: f(&format!("values[{k}].value"), decimals),
                uncertainty: f(&format!("values[{k}].uncertainty"), decimals),
                // A corner gone complex has no value to show: its pair, in words.
                status: match v.complex_pair {
                    Some(_) => crate::identify::report::shown(v),
                    None => crate::identify::report::status(v),
                },
            }
        })
        .collect();
    AxisView {
        axis: axis.axis.to_string(),
        residual: [f("rms_template_um", 3), f("rms_identified_um", 3)],
        held_out: [f("held_out_template_um", 3), f("held_out_identified_um", 3)],
        held_out_while_moving: axis.judged_while_moving.then(|| {
            [
                f("while_moving.held_out_template_um", 3),
                f("while_moving.held_out_identified_um", 3),
            ]
        }),
        following_error: f("following_error_rms_um", 1),
        notes,
        values,
        gain_per_inertia: crate::identify::report::gain_per_inertia_line(axis),
    }
}
