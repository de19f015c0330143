//! Measured data: traces from a laser, a ballbar or the CNC's own servo trace, and tables of
//! steady following errors like the paper's Tables 3–5.
//!
//! A trace is a CSV with a header: `t_s,x_mm,y_mm`, optionally `x_cmd_mm,y_cmd_mm` (the
//! commanded positions, as a servo trace records them), in any order, other columns
//! ignored. Time must increase; a gap longer than five sampling steps is an error naming the
//! row; irregular sampling is resampled to the median step.

use std::path::Path;

use crate::units::m_from_mm;

/// A measured trace on a uniform time grid, in SI units.
#[derive(Debug, Clone, PartialEq)]
pub struct MeasuredTrace {
    /// The file, for messages.
    pub file: String,
    /// Time of the first sample on the measurement's clock (s).
    pub t0_s: f64,
    /// Sampling step (s).
    pub dt_s: f64,
    /// Measured X (m).
    pub x_m: Vec<f64>,
    /// Measured Y (m).
    pub y_m: Vec<f64>,
    /// Commanded X and Y (m), when the trace has them.
    pub commands: Option<[Vec<f64>; 2]>,
    /// Whether irregular sampling was resampled.
    pub resampled: bool,
}

impl MeasuredTrace {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.x_m.len()
    }

    /// True when empty.
    pub fn is_empty(&self) -> bool {
        self.x_m.is_empty()
    }

    /// Time of sample k on the measurement's clock (s).
    pub fn time_s(&self, k: usize) -> f64 {
        self.t0_s + k as f64 * self.dt_s
    }
}

/// A problem with measured data, naming the file and, where there is one, the row.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MeasuredError {
    /// Unreadable file.
    #[error("{file}: {message}")]
    Io {
        /// File.
        file: String,
        /// OS message.
        message: String,
    },
    /// A required column is missing.
    #[error("{file}: the header has no column `{column}` (expected {expected})")]
    MissingColumn {
        /// File.
        file: String,
        /// Column.
        column: String,
        /// The columns that make a valid file.
        expected: &'static str,
    },
    /// A row is wrong.
    #[error("{file}: row {row}: {problem}")]
    Row {
        /// File.
        file: String,
        /// 1-based line number in the file.
        row: u64,
        /// What is wrong.
        problem: String,
    },
    /// Not enough data.
    #[error("{file}: {problem}")]
    Data {
        /// File.
        file: String,
        /// What is wrong.
        problem: String,
    },
}

const TRACE_COLUMNS: &str = "t_s, x_mm, y_mm and optionally x_cmd_mm, y_cmd_mm";

/// Reads a trace file.
pub fn read_trace(path: &Path) -> Result<MeasuredTrace, MeasuredError> {
    let file = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|e| MeasuredError::Io {
        file: file.clone(),
        message: e.to_string(),
    })?;
    parse_trace(&text, &file)
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

/// Parses a trace from CSV text; `file` names it in errors.
pub fn parse_trace(text: &str, file: &str) -> Result<MeasuredTrace, MeasuredError> {
    let (mut reader, headers) = csv_reader(text, file)?;
    let col = |name: &str| headers.iter().position(|h| h == name);
    let need = |name: &str| {
        col(name).ok_or_else(|| MeasuredError::MissingColumn {
            file: file.into(),
            column: name.into(),
            expected: TRACE_COLUMNS,
        })
    };
    let (ct, cx, cy) = (need("t_s")?, need("x_mm")?, need("y_mm")?);
    let cmd_cols = match (col("x_cmd_mm"), col("y_cmd_mm")) {
        (Some(a), Some(b)) => Some((a, b)),
        (None, None) => None,
        (Some(_), None) => {
            return Err(MeasuredError::MissingColumn {
                file: file.into(),
                column: "y_cmd_mm".into(),
                expected: TRACE_COLUMNS,
            });
        }
        (None, Some(_)) => {
            return Err(MeasuredError::MissingColumn {
                file: file.into(),
                column: "x_cmd_mm".into(),
                expected: TRACE_COLUMNS,
            });
        }
    };
    let mut t = Vec::new();
    let mut cols: [Vec<f64>; 4] = Default::default();
    for record in reader.records() {
        let record = record.map_err(|e| {
            let row = e.position().map_or(0, |p| p.line());
            MeasuredError::Row {
                file: file.into(),
                row,
                problem: e.to_string(),
            }
        })?;
        let row = record.position().map_or(0, |p| p.line());
        let get = |c: usize, name: &str| -> Result<f64, MeasuredError> {
            let text = record.get(c).unwrap_or("");
            match text.parse::<f64>() {
                Ok(v) if v.is_finite() => Ok(v),
                _ => Err(MeasuredError::Row {
                    file: file.into(),
                    row,
                    problem: format!("{name} '{text}' is not a finite number"),
                }),
            }
        };
        let ti = get(ct, "t_s")?;
        if let Some(&prev) = t.last().filter(|&&prev| ti <= prev) {
            return Err(MeasuredError::Row {
                file: file.into(),
                row,
                problem: format!("time {ti} s does not increase (previous row: {prev} s)"),
            });
        }
        t.push(ti);
        cols[0].push(m_from_mm(get(cx, "x_mm")?));
        cols[1].push(m_from_mm(get(cy, "y_mm")?));
        if let Some((a, b)) = cmd_cols {
            cols[2].push(m_from_mm(get(a, "x_cmd_mm")?));
            cols[3].push(m_from_mm(get(b, "y_cmd_mm")?));
        }
    }
    if t.len() < 10 {
        return Err(MeasuredError::Data {
            file: file.into(),
            problem: format!("{} rows: too few to diagnose anything", t.len()),
        });
    }
    let rows_start = 2; // the header is line 1
    let dt = median_step(&t);
    if let Some(i) = (1..t.len()).find(|&i| t[i] - t[i - 1] > 5.0 * dt) {
        return Err(MeasuredError::Row {
            file: file.into(),
            row: (rows_start + i) as u64,
            problem: format!(
                "a gap of {:.6} s before this row (the median step is {:.6} s)",
                t[i] - t[i - 1],
                dt
            ),
        });
    }
    let irregular = (1..t.len()).any(|i| ((t[i] - t[i - 1]) / dt - 1.0).abs() > 0.01);
    let [x, y, xc, yc] = if irregular {
        cols.map(|c| {
            if c.is_empty() {
                c
            } else {
                resample(&t, &c, dt)
            }
        })
    } else {
        cols
    };
    Ok(MeasuredTrace {
        file: file.into(),
        t0_s: t[0],
        dt_s: dt,
        x_m: x,
        y_m: y,
        commands: cmd_cols.map(|_| [xc, yc]),
        resampled: irregular,
    })
}

fn median_step(t: &[f64]) -> f64 {
    let mut d: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
    let mid = d.len() / 2;
    *d.select_nth_unstable_by(mid, f64::total_cmp).1
}

/// Linear interpolation of (t, v) onto t0 + k·dt up to the last time.
fn resample(t: &[f64], v: &[f64], dt: f64) -> Vec<f64> {
    let n = ((t[t.len() - 1] - t[0]) / dt).floor() as usize + 1;
    let mut out = Vec::with_capacity(n);
    let mut j = 0;
    for k in 0..n {
        let tk = t[0] + k as f64 * dt;
        while j + 2 < t.len() && t[j + 1] < tk {
            j += 1;
        }
        let f = ((tk - t[j]) / (t[j + 1] - t[j])).clamp(0.0, 1.0);
        out.push(v[j] + (v[j + 1] - v[j]) * f);
    }
    out
}

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

#[cfg(test)]
mod tests {
    use super::*;

    fn csv_of(rows: &[(f64, f64, f64)]) -> String {
        let mut s = String::from("t_s,x_mm,y_mm\n");
        for (t, x, y) in rows {
            s.push_str(&format!("{t},{x},{y}\n"));
        }
        s
    }

    #[test]
    fn errors_name_the_row() {
        let mut rows: Vec<(f64, f64, f64)> =
            (0..20).map(|i| (i as f64 * 0.002, i as f64, 0.0)).collect();
        rows[7].0 = rows[6].0;
        let e = parse_trace(&csv_of(&rows), "m.csv").unwrap_err();
        assert!(e.to_string().starts_with("m.csv: row 9: time"), "{e}");
        let mut rows: Vec<(f64, f64, f64)> =
            (0..20).map(|i| (i as f64 * 0.002, i as f64, 0.0)).collect();
        for r in rows.iter_mut().skip(12) {
            r.0 += 0.5;
        }
        let e = parse_trace(&csv_of(&rows), "m.csv").unwrap_err();
        assert!(e.to_string().starts_with("m.csv: row 14: a gap"), "{e}");
        let e = parse_trace("t_s,x_mm,y_mm\n0,1,nan\n", "m.csv").unwrap_err();
        assert!(e.to_string().contains("row 2"), "{e}");
        let e = parse_trace("time,x_mm,y_mm\n0,1,2\n", "m.csv").unwrap_err();
        assert!(e.to_string().contains("`t_s`"), "{e}");
    }

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

    #[test]
    fn irregular_sampling_is_resampled() {
        let rows: Vec<(f64, f64, f64)> = (0..100)
            .map(|i| {
                let t = i as f64 * 0.002 + if i % 2 == 1 { 0.0003 } else { 0.0 };
                (t, 1000.0 * t, 0.0)
            })
            .collect();
        let m = parse_trace(&csv_of(&rows), "m.csv").unwrap();
        assert!(m.resampled);
        assert!((m.dt_s - 0.002).abs() < 0.0004);
        // x = 1 m/s·t: linear, so the resampled values lie on it exactly.
        for k in 0..m.len() {
            assert!((m.x_m[k] - m.time_s(k)).abs() < 1e-12, "{k}");
        }
    }
}
