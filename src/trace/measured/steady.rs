//! Tables of steady following errors, like the paper's Tables 3–5: one row per axis, feed
//! and gains, each value within what a machine can have.

use std::path::Path;

use super::MeasuredError;

/// One row of a steady following-error table.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct TableRow {
    /// Label of the table it came from (e.g. "Table 3").
    pub table: String,
    /// Axis.
    pub axis: crate::machine::AxisName,
    /// Feed (mm/min).
    pub feed_mm_per_min: f64,
    /// Position gain (m/min/mm).
    pub kv_m_per_min_per_mm: f64,
    /// Velocity gain (N·m·s/rad).
    pub ks_nm_s_per_rad: f64,
    /// Measured steady following error (mm).
    pub measured_mm: f64,
    /// 1-based line in the file.
    pub line: u64,
}

const TABLE_COLUMNS: &str =
    "table, axis, feed_mm_per_min, kv_m_per_min_per_mm, ks_nm_s_per_rad, following_error_mm";

/// Reads a table of steady following errors.
pub fn read_table(path: &Path) -> Result<Vec<TableRow>, MeasuredError> {
    let file = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|e| MeasuredError::Io {
        file: file.clone(),
        message: e.to_string(),
    })?;
    parse_table(&text, &file)
}

/// Parses a table from CSV text (lines starting with `#` are comments).
pub fn parse_table(text: &str, file: &str) -> Result<Vec<TableRow>, MeasuredError> {
    let (mut reader, headers) = csv_reader(text, file)?;
    let col = |name: &str| {
        headers
            .iter()
            .position(|h| h == name)
            .ok_or_else(|| MeasuredError::MissingColumn {
                file: file.into(),
                column: name.into(),
                expected: TABLE_COLUMNS,
            })
    };
    let c = [
        col("table")?,
        col("axis")?,
        col("feed_mm_per_min")?,
        col("kv_m_per_min_per_mm")?,
        col("ks_nm_s_per_rad")?,
        col("following_error_mm")?,
    ];
    let mut rows = Vec::new();
    for record in reader.records() {
        let record = record.map_err(|e| MeasuredError::Row {
            file: file.into(),
            row: e.position().map_or(0, |p| p.line()),
            problem: e.to_string(),
        })?;
        let line = record.position().map_or(0, |p| p.line());
        let bad = |problem: String| MeasuredError::Row {
            file: file.into(),
            row: line,
            problem,
        };
        // Bounds as for a machine file: beyond them a value is a typing slip, not a setting.
        let num = |i: usize, name: &str, at_most: f64| -> Result<f64, MeasuredError> {
            let text = record.get(c[i]).unwrap_or("");
            match text.parse::<f64>() {
                Ok(v) if v.is_finite() && v > 0.0 && v <= at_most => Ok(v),
                Ok(v) if v.is_finite() && v > at_most => Err(bad(format!(
                    "{name} '{text}' is more than {at_most:e}: no machine has that"
                ))),
                _ => Err(bad(format!("{name} '{text}' is not a positive number"))),
            }
        };
        let axis = record.get(c[1]).unwrap_or("").parse().map_err(bad)?;
        rows.push(TableRow {
            table: record.get(c[0]).unwrap_or("").to_string(),
            axis,
            feed_mm_per_min: num(2, "feed_mm_per_min", 1e6)?,
            kv_m_per_min_per_mm: num(3, "kv_m_per_min_per_mm", 100.0)?,
            ks_nm_s_per_rad: num(4, "ks_nm_s_per_rad", 1e5)?,
            measured_mm: num(5, "following_error_mm", 1e4)?,
            line,
        });
    }
    if rows.is_empty() {
        return Err(MeasuredError::Data {
            file: file.into(),
            problem: "no rows".into(),
        });
    }
    Ok(rows)
}

/// A CSV reader over `text` (fields trimmed, lines starting with `#` comments) and its
/// header.
fn csv_reader<'t>(
    text: &'t str,
    file: &str,
) -> Result<(csv::Reader<&'t [u8]>, csv::StringRecord), MeasuredError> {
    let mut reader = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .comment(Some(b'#'))
        .from_reader(text.as_bytes());
    let headers = reader
        .headers()
        .map_err(|e| MeasuredError::Data {
            file: file.into(),
            problem: e.to_string(),
        })?
        .clone();
    Ok((reader, headers))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_table_value_no_machine_has_is_refused_at_its_row() {
        let head = "table,axis,feed_mm_per_min,kv_m_per_min_per_mm,ks_nm_s_per_rad,\
                    following_error_mm\n3,x,500,1,16,0.5\n";
        assert_eq!(parse_table(head, "t.csv").unwrap().len(), 1);
        let e = parse_table(&format!("{head}3,x,1e300,1,16,0.5\n"), "t.csv").unwrap_err();
        let shown = e.to_string();
        assert!(
            shown.starts_with("t.csv: row 3:") && shown.contains("feed_mm_per_min '1e300'"),
            "{shown}"
        );
    }
}
