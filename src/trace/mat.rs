//! Traces in MATLAB's MAT-file format, level 5 (what `save` writes by default up to
//! `-v7`, compressed or not, and what capture tools write), decoded by [`crate::trace::mat5`].
//!
//! Every numeric vector becomes a column named by where it sits: a variable `t`, a
//! structure field `ScopeData.time`, an element of a structure array
//! `ScopeData.signals(2).values`, a cell `log{3}`. A matrix of several columns gives one
//! column each, `data(1)`, `data(2)` … as MATLAB indexes them. A structure that describes
//! one signal — a name (`label`, `Name`, `name`, `title`) beside one numeric vector
//! (`values`, `Data`, `data`) — also gives that vector under its own name: the last part of
//! its block path (`"Model Root"/"Encoder Feedback X"/"x [mm]"` gives `x [mm]`), or as many
//! parts as it takes to tell it from the other signals (two signals ending in `RefCommand`
//! become `Feed Reference DataX/RefCommand` and `…DataY/RefCommand`); a unit the structure
//! gives separately (`Unit`) is added in brackets. Simulink's structure-with-time and dSPACE
//! ControlDesk captures name their signals so; a ControlDesk capture's time axis (the
//! structure `X` beside the signal array `Y`) becomes the column `time`. Columns are then
//! mapped exactly as a text trace's headers are: recognised spellings, the last part of a
//! field path, or `--columns`.
//!
//! `-v7.3` (HDF5) files are refused with what to do instead.

use crate::trace::columns::NamedColumns;
use crate::trace::mat5::{self, Value};
use crate::trace::measured::{MeasuredError, Source};

/// How deep structures may nest before the rest is ignored (a capture is two or three
/// levels; a file deeper than this is not a trace).
const DEEPEST: usize = 8;

/// Whether `bytes` are a MAT file (level 5, or the HDF5-based 7.3, which carries the same
/// text header).
pub(crate) fn is_mat_file(bytes: &[u8]) -> bool {
    bytes.starts_with(mat5::SIGNATURE)
}

/// Whether a file that does not start as a MAT-file is still one to the user: named
/// `*.mat` and empty or binary (a NUL among its first bytes). Its reader's refusal then says
/// what is wrong with it as a MAT-file, where a text table's reader would speak of headers.
/// (A `*.mat` of text, as MATLAB's `save -ascii` writes, is read as the text table it is.)
pub(crate) fn is_named_as_mat_file(path: &std::path::Path, bytes: &[u8]) -> bool {
    let named = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("mat"));
    named && (bytes.is_empty() || bytes[..bytes.len().min(512)].contains(&0))
}

/// The columns of a MAT file: (name, values), in the file's order; a sample's row is its
/// index in the variable.
pub(crate) fn mat_columns(bytes: &[u8], file: &str) -> Result<NamedColumns, MeasuredError> {
    let error = |problem: String| MeasuredError::Data {
        file: file.into(),
        problem,
    };
    // A 7.3 file is an HDF5 container behind the same 128-byte text header.
    if bytes.len() > 136 && &bytes[128..136] == b"\x89HDF\r\n\x1a\n" {
        return Err(error(
            "a MATLAB 7.3 (HDF5) MAT-file: save it with `save(file, '-v7')` or export the \
             signals as CSV"
                .into(),
        ));
    }
    let variables = mat5::read(bytes).map_err(|e| match e {
        mat5::Mat5Error::NotLevel5(_) => error(format!(
            "{e}: save it with `save(file, '-v7')` or export the signals as a text table (CSV)"
        )),
        e => error(e.to_string()),
    })?;
    let mut found = Found::default();
    for variable in &variables {
        collect(&variable.name, &variable.value, 0, &mut found);
    }
    let mut out = found.columns;
    out.extend(distinct_names(found.named));
    if out.is_empty() {
        return Err(error(
            "no numeric vectors or matrices in the MAT-file, in its variables or in the \
             fields of its structures and cells"
                .into(),
        ));
    }
    let n = out.iter().map(|(_, v)| v.len()).max().unwrap_or(0);
    Ok(NamedColumns {
        source: Source::MatFile {
            variables: out.len(),
        },
        rows: (1..=n as u64).collect(),
        columns: out,
    })
}

/// What a file holds: columns named by their place, and signals named by their own label
/// (its block path's parts), to be told apart once all are known.
#[derive(Default)]
struct Found {
    columns: Vec<(String, Vec<f64>)>,
    named: Vec<(Vec<String>, Vec<f64>)>,
}

/// The columns held in `value` at `path`.
fn collect(path: &str, value: &Value, depth: usize, found: &mut Found) {
    if depth > DEEPEST {
        return;
    }
    match value {
        Value::Numeric {
            dims,
            real,
            complex: false,
        } if dims.len() == 2 => push_matrix(path, dims[0], dims[1], real, &mut found.columns),
        Value::Struct {
            fields, elements, ..
        } => {
            for (k, element) in elements.iter().enumerate() {
                let at = if elements.len() == 1 {
                    path.to_string()
                } else {
                    format!("{path}({})", k + 1)
                };
                for (field, value) in fields.iter().zip(element) {
                    collect(&format!("{at}.{field}"), value, depth + 1, found);
                }
                if let Some(named) = named_signal(fields, element) {
                    found.named.push(named);
                }
            }
            if let Some(time) = capture_time(value) {
                found.columns.push(time);
            }
        }
        Value::Cell(cells) => {
            for (k, element) in cells.iter().enumerate() {
                collect(&format!("{path}{{{}}}", k + 1), element, depth + 1, found);
            }
        }
        // Complex values, text, empty values, sparse matrices and objects hold no signals.
        _ => {}
    }
}

/// A vector as one column, a matrix as one column per column (stored column-major).
fn push_matrix(
    name: &str,
    rows: usize,
    columns: usize,
    values: &[f64],
    out: &mut Vec<(String, Vec<f64>)>,
) {
    if values.len() != rows * columns || values.is_empty() {
        return;
    }
    if rows == 1 || columns == 1 {
        out.push((name.to_string(), values.to_vec()));
    } else {
        for j in 0..columns {
            out.push((
                format!("{name}({})", j + 1),
                values[j * rows..(j + 1) * rows].to_vec(),
            ));
        }
    }
}

const LABEL_FIELDS: [&str; 5] = ["label", "Name", "name", "title", "signalName"];
const DATA_FIELDS: [&str; 4] = ["values", "Data", "data", "Values"];

/// A structure describing one signal — a text name and one numeric vector — as its label's
/// parts (the block path, quotes removed; a separate unit added in brackets) and values.
fn named_signal(fields: &[String], element: &[Value]) -> Option<(Vec<String>, Vec<f64>)> {
    let field = |name: &str| element.get(fields.iter().position(|f| f == name)?);
    let label = LABEL_FIELDS.iter().find_map(|f| field(f)?.text())?;
    let mut parts = label_parts(label);
    let mut data = DATA_FIELDS.iter().filter_map(|f| vector(field(f)?));
    let values = data.next().filter(|v| !v.is_empty())?;
    if parts.is_empty() || data.next().is_some() {
        return None;
    }
    if let Some(unit) = field("Unit").and_then(Value::text)
        && !unit.trim().is_empty()
        && let Some(last) = parts.last_mut()
        && !last.contains('[')
    {
        *last = format!("{last} [{}]", unit.trim());
    }
    Some((parts, values))
}

/// A label's block-path parts: `"Model Root"/"Encoder Feedback X"/"x [mm]"` (quoted parts,
/// which may hold a `/` of their own, as in a unit `[m/s]`) or `Model/Scope/x`.
fn label_parts(label: &str) -> Vec<String> {
    let label = label.trim();
    let parts: Vec<&str> = if label.starts_with('"') && label.contains("\"/\"") {
        label.split("\"/\"").collect()
    } else {
        label.split(['/', '\\']).collect()
    };
    parts
        .into_iter()
        .map(|p| p.trim().trim_matches('"').trim().to_string())
        .filter(|p| !p.is_empty())
        .collect()
}

/// Each named signal under the shortest tail of its block path that no other signal ends
/// with (the whole path where even that is shared).
fn distinct_names(named: Vec<(Vec<String>, Vec<f64>)>) -> Vec<(String, Vec<f64>)> {
    let tail = |parts: &[String], n: usize| parts[parts.len().saturating_sub(n)..].join("/");
    let names: Vec<String> = named
        .iter()
        .map(|(parts, _)| {
            (1..=parts.len())
                .map(|n| tail(parts, n))
                .find(|name| {
                    named
                        .iter()
                        .filter(|(other, _)| (1..=other.len()).any(|m| tail(other, m) == *name))
                        .count()
                        == 1
                })
                .unwrap_or_else(|| parts.join("/"))
        })
        .collect();
    names
        .into_iter()
        .zip(named)
        .map(|(name, (_, values))| (name, values))
        .collect()
}

/// A ControlDesk capture's unnamed time axis: a structure whose field `X` holds the time
/// (`Data`, with an optional `Unit`, seconds by default) beside the signal array `Y`, as the column
/// `time [unit]`. Of several time axes (signals captured at several rates) the first is
/// taken; signals on another axis then differ from it in length, which the trace reader
/// reports.
fn capture_time(capture: &Value) -> Option<(String, Vec<f64>)> {
    let x = capture.field("X")?;
    let signals = capture.field("Y")?;
    let Value::Struct { fields, .. } = signals else {
        return None;
    };
    if !fields.iter().any(|f| f == "Name") || !fields.iter().any(|f| f == "Data") {
        return None;
    }
    // A time axis with a name of its own is a named signal like the others.
    if x.field("Name")
        .and_then(Value::text)
        .is_some_and(|n| !n.trim().is_empty())
    {
        return None;
    }
    let data = vector(x.field("Data")?)?;
    let unit = x
        .field("Unit")
        .and_then(Value::text)
        .map(str::trim)
        .filter(|u| !u.is_empty())
        .unwrap_or("s");
    Some((format!("time [{unit}]"), data))
}

/// A real numeric vector's values.
fn vector(value: &Value) -> Option<Vec<f64>> {
    match value {
        Value::Numeric {
            dims,
            real,
            complex: false,
        } if dims.len() == 2 && dims.contains(&1) => Some(real.clone()),
        _ => None,
    }
}
