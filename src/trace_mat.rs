//! Traces in MATLAB's MAT-file format, level 5 (what `save` writes by default up to
//! `-v7`, compressed or not), read with the `matrw` crate: pure Rust, so no C library
//! (libmatio, and HDF5 for `-v7.3`) has to be installed on every machine, and — unlike the
//! older `matfile` crate — it reads structures and cells, the form capture tools save in.
//!
//! Every numeric vector becomes a column named by where it sits: a variable `t`, a
//! structure field `ScopeData.time`, an element of a structure array
//! `ScopeData.signals(2).values`, a cell `log{3}`. A matrix of several columns gives one
//! column each, `data(1)`, `data(2)` … as MATLAB indexes them. A structure that describes
//! one signal — a name (`label`, `Name`, `name`, `title`) beside one numeric vector
//! (`values`, `Data`, `data`) — also gives that vector under its own name, the last part of
//! a block path: Simulink's structure-with-time and dSPACE captures name their signals so.
//! Columns are then mapped exactly as a text trace's headers are: recognised spellings, the
//! last part of a field path, or `--columns`.
//!
//! `-v7.3` (HDF5) files are refused with what to do instead.

use matrw::{MatVariable, MatlabType};

use crate::measured::MeasuredError;

/// The signature every level-5 MAT file starts with.
const LEVEL5_SIGNATURE: &[u8] = b"MATLAB 5.0 MAT-file";

/// How deep structures may nest before the rest is ignored (a capture is two or three
/// levels; a file deeper than this is not a trace).
const DEEPEST: usize = 8;

/// Whether `bytes` are a MAT file (level 5, or the HDF5-based 7.3, which carries the same
/// text header).
pub fn is_mat_file(bytes: &[u8]) -> bool {
    bytes.starts_with(LEVEL5_SIGNATURE)
}

/// The columns of a MAT file: (name, values), in the file's order.
pub fn mat_columns(bytes: &[u8], file: &str) -> Result<Vec<(String, Vec<f64>)>, MeasuredError> {
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
    // The reader is young and asserts on some malformed input; a damaged file must be an
    // error like any other, not the end of the program.
    let parsed = std::panic::catch_unwind(|| matrw::load_matfile_from_u8(bytes))
        .map_err(|_| error("not a readable MAT-file (level 5): its contents are damaged".into()))?
        .map_err(|e| error(format!("not a readable MAT-file (level 5): {e}")))?;
    let mut out = Vec::new();
    for (name, variable) in parsed.iter() {
        collect(name, variable, 0, &mut out);
    }
    if out.is_empty() {
        return Err(error(
            "no numeric vectors or matrices in the MAT-file, in its variables or in the \
             fields of its structures and cells"
                .into(),
        ));
    }
    Ok(out)
}

/// The columns held in `variable` at `path`, appended to `out`.
fn collect(path: &str, variable: &MatVariable, depth: usize, out: &mut Vec<(String, Vec<f64>)>) {
    if depth > DEEPEST {
        return;
    }
    match variable {
        MatVariable::NumericArray(array) => {
            if array.dim.len() == 2
                && let Some(values) = real_values(&array.value)
            {
                push_matrix(path, array.dim[0], array.dim[1], values, out);
            }
        }
        MatVariable::Structure(s) => {
            for (field, value) in &s.value {
                collect(&format!("{path}.{field}"), value, depth + 1, out);
            }
            if let Some(named) = named_signal(variable) {
                out.push(named);
            }
        }
        MatVariable::StructureArray(array) => {
            for (k, element) in array.value.iter().enumerate() {
                collect(&format!("{path}({})", k + 1), element, depth + 1, out);
            }
        }
        MatVariable::CellArray(cells) => {
            for (k, element) in cells.value.iter().enumerate() {
                collect(&format!("{path}{{{}}}", k + 1), element, depth + 1, out);
            }
        }
        MatVariable::Compressed(c) => collect(path, &c.value, depth, out),
        // Sparse matrices, empty values and objects hold no signals.
        MatVariable::SparseArray(_) | MatVariable::Null | MatVariable::Unsupported => {}
    }
}

/// A vector as one column, a matrix as one column per column (stored column-major).
fn push_matrix(
    name: &str,
    rows: usize,
    columns: usize,
    values: Vec<f64>,
    out: &mut Vec<(String, Vec<f64>)>,
) {
    if values.len() != rows * columns || values.is_empty() {
        return;
    }
    if rows == 1 || columns == 1 {
        out.push((name.to_string(), values));
    } else {
        for j in 0..columns {
            out.push((
                format!("{name}({})", j + 1),
                values[j * rows..(j + 1) * rows].to_vec(),
            ));
        }
    }
}

/// A structure describing one signal — a text name and one numeric vector — as the column
/// (name, values), the name being the last part of a block path.
fn named_signal(variable: &MatVariable) -> Option<(String, Vec<f64>)> {
    const NAMES: [&str; 5] = ["label", "Name", "name", "title", "signalName"];
    const DATA: [&str; 4] = ["values", "Data", "data", "Values"];
    let MatVariable::Structure(s) = variable else {
        return None;
    };
    let label = NAMES.iter().find_map(|f| match uncompressed(s.get(f)?) {
        MatVariable::NumericArray(a) => text(&a.value),
        _ => None,
    })?;
    let label = label.rsplit(['/', '\\']).next()?.trim().trim_matches('"');
    let mut data = DATA.iter().filter_map(|f| match uncompressed(s.get(f)?) {
        MatVariable::NumericArray(a) if a.dim.len() == 2 && a.dim.contains(&1) => {
            real_values(&a.value)
        }
        _ => None,
    });
    let values = data.next().filter(|v| !v.is_empty())?;
    (!label.is_empty() && data.next().is_none()).then(|| (label.to_string(), values))
}

fn uncompressed(variable: &MatVariable) -> &MatVariable {
    match variable {
        MatVariable::Compressed(c) => uncompressed(&c.value),
        other => other,
    }
}

/// A character array as text.
fn text(value: &MatlabType) -> Option<String> {
    match value {
        MatlabType::UTF8(chars) | MatlabType::UTF16(chars) => Some(chars.iter().collect()),
        _ => None,
    }
}

/// The real values of a numeric array as f64; `None` for text and logicals.
fn real_values(value: &MatlabType) -> Option<Vec<f64>> {
    use MatlabType as T;
    Some(match value {
        T::F64(v) => v.clone(),
        T::F32(v) => v.iter().map(|&x| f64::from(x)).collect(),
        T::I8(v) => v.iter().map(|&x| f64::from(x)).collect(),
        T::U8(v) => v.iter().map(|&x| f64::from(x)).collect(),
        T::I16(v) => v.iter().map(|&x| f64::from(x)).collect(),
        T::U16(v) => v.iter().map(|&x| f64::from(x)).collect(),
        T::I32(v) => v.iter().map(|&x| f64::from(x)).collect(),
        T::U32(v) => v.iter().map(|&x| f64::from(x)).collect(),
        T::I64(v) => v.iter().map(|&x| x as f64).collect(),
        T::U64(v) => v.iter().map(|&x| x as f64).collect(),
        T::UTF8(_) | T::UTF16(_) | T::BOOL(_) => return None,
    })
}
