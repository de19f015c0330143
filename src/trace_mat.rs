//! Traces in MATLAB's MAT-file format, level 5 (what `save` writes by default up to
//! `-v7`), read with the `matfile` crate — pure Rust and maintained, the one crate that
//! reads MAT files without a C library; the bindings to libmatio would need it (and HDF5
//! for `-v7.3`) installed on every machine.
//!
//! `matfile` reads numeric arrays; structures, cells and `-v7.3` (HDF5) files it does not,
//! and they are refused with what to do instead. Every numeric vector becomes a column
//! named after its variable (`t`, `X_act` …); a matrix of several columns gives one column
//! each, named `name(1)`, `name(2)` … as MATLAB indexes them. Columns are then mapped
//! exactly as a text trace's headers are: recognised spellings or `--columns`.

use crate::measured::MeasuredError;

/// The signature every level-5 MAT file starts with.
const LEVEL5_SIGNATURE: &[u8] = b"MATLAB 5.0 MAT-file";

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
    let mat = matfile::MatFile::parse(bytes)
        .map_err(|e| error(format!("not a readable MAT-file (level 5): {e:?}")))?;
    let mut out = Vec::new();
    for array in mat.arrays() {
        let size = array.size();
        if size.len() != 2 {
            continue;
        }
        let Some(values) = real_values(array.data()) else {
            continue;
        };
        let (rows, columns) = (size[0], size[1]);
        if rows == 1 || columns == 1 {
            out.push((array.name().to_string(), values));
        } else {
            // Column-major: column j holds values[j·rows .. (j+1)·rows].
            for j in 0..columns {
                out.push((
                    format!("{}({})", array.name(), j + 1),
                    values[j * rows..(j + 1) * rows].to_vec(),
                ));
            }
        }
    }
    if out.is_empty() {
        return Err(error(
            "no numeric vectors or matrices in the MAT-file (structures and cells are not \
             read: save the signals as plain variables, e.g. `t = capture.X.Data`)"
                .into(),
        ));
    }
    Ok(out)
}

/// The real part of a numeric array as f64.
fn real_values(data: &matfile::NumericData) -> Option<Vec<f64>> {
    use matfile::NumericData as D;
    Some(match data {
        D::Double { real, .. } => real.clone(),
        D::Single { real, .. } => real.iter().map(|&v| f64::from(v)).collect(),
        D::Int8 { real, .. } => real.iter().map(|&v| f64::from(v)).collect(),
        D::UInt8 { real, .. } => real.iter().map(|&v| f64::from(v)).collect(),
        D::Int16 { real, .. } => real.iter().map(|&v| f64::from(v)).collect(),
        D::UInt16 { real, .. } => real.iter().map(|&v| f64::from(v)).collect(),
        D::Int32 { real, .. } => real.iter().map(|&v| f64::from(v)).collect(),
        D::UInt32 { real, .. } => real.iter().map(|&v| f64::from(v)).collect(),
        D::Int64 { real, .. } => real.iter().map(|&v| v as f64).collect(),
        D::UInt64 { real, .. } => real.iter().map(|&v| v as f64).collect(),
    })
}
