//! Measured data: traces from a laser, a ballbar or the CNC's own servo trace, and tables of
//! steady following errors like the paper's Tables 3–5.
//!
//! A trace is a table with a header: time, measured X and Y and optionally the commanded X
//! and Y (as a servo trace records them), in any order and units, other columns ignored —
//! `t_s,x_mm,y_mm,x_cmd_mm,y_cmd_mm` as `synth` writes it, or as controls and labs write
//! them (see `trace_format`). Time must increase with a plausible step; a gap longer than
//! five sampling steps is an error naming the row; irregular sampling is resampled to the
//! median step.

use std::path::Path;

use crate::trace::columns::NamedColumns;
use crate::trace::format::{self, ColumnMap, Signal};
use crate::trace::halscope;
use crate::trace::mat;
use crate::trace::sinumerik;
use crate::trace::twincat;

mod layout;
mod sampling;
mod spikes;
mod steady;
mod text;

pub use layout::{Source, TraceLayout, UnusedColumn};
pub use sampling::{HeldRows, StepStats};
use sampling::{held_rows, keep_readings, plausible_clock, resample};
pub use spikes::Spike;
pub use steady::{TableRow, parse_table, read_table};

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
    /// Measured Z (m), when the trace has it; in the trace's own coordinates.
    pub z_m: Option<Vec<f64>>,
    /// Commanded Z (m), when the trace has it; in the trace's own coordinates.
    pub z_cmd_m: Option<Vec<f64>>,
    /// Whether irregular sampling was resampled.
    pub resampled: bool,
    /// How the file was read.
    pub layout: TraceLayout,
    /// The recorded time steps before any resampling.
    pub steps: StepStats,
    /// Where the logger held each reading for several rows, the rows that carried new
    /// readings; only those were kept, and `dt_s` is their step.
    pub held: Option<HeldRows>,
}

impl MeasuredTrace {
    /// Where the recorded commands (if any) ask more of an axis than the machine file says
    /// it can give: speed, acceleration, the drive's current.
    pub(crate) fn beyond_machine(
        &self,
        machine: &crate::machine::MachineConfig,
    ) -> Vec<crate::trace::recorded::BeyondMachine> {
        self.beyond_machine_from(machine, 0.0)
    }

    /// As [`MeasuredTrace::beyond_machine`], on the commands from `from_s` after the
    /// record's first sample on (the times on the record's clock, as every time it reports): an approach before
    /// the program that the model does not follow asks nothing of it.
    pub(crate) fn beyond_machine_from(
        &self,
        machine: &crate::machine::MachineConfig,
        from_s: f64,
    ) -> Vec<crate::trace::recorded::BeyondMachine> {
        let skip = if from_s > 0.0 && self.dt_s > 0.0 {
            (from_s / self.dt_s).floor() as usize
        } else {
            0
        };
        self.commands.as_ref().map_or_else(Vec::new, |c| {
            let tail = c
                .clone()
                .map(|v| v.get(skip..).map_or_else(Vec::new, <[f64]>::to_vec));
            let mut found = crate::trace::recorded::beyond_machine(&tail, self.dt_s, machine);
            // From the tail's first sample to the record's clock.
            for b in &mut found {
                b.t_s += self.t0_s + skip as f64 * self.dt_s;
            }
            found
        })
    }

    /// A hint where the measured positions, read as lengths, look like encoder counts: whole
    /// numbers in the unit they were read in, over a range no table travels (a thousand of
    /// that unit). The `--columns` spelling that reads them as counts, with an example
    /// resolution. `None` where the user gave the positions' unit, or they do not look so.
    pub(crate) fn counts_hint(&self) -> Option<String> {
        /// A range of whole numbers this wide is no length in the unit read.
        const COUNTS_RANGE: f64 = 1000.0;
        let column = |signal: Signal| self.layout.mapped.iter().find(|m| m.signal == signal);
        let looks_like_counts = |signal: Signal, values: &[f64], offset_m: f64| {
            let Some(m) = column(signal) else {
                return false;
            };
            if m.unit_from == "mapping" || m.unit.is_count() || values.is_empty() {
                return false;
            }
            let read: Vec<f64> = values
                .iter()
                .map(|v| (v + offset_m) / m.unit.to_si)
                .collect();
            let (lo, hi) = read
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                    (lo.min(*v), hi.max(*v))
                });
            hi.max(-lo) >= COUNTS_RANGE && read.iter().all(|v| (v - v.round()).abs() < 1e-6)
        };
        let offset = self.layout.work_offset_m.unwrap_or([0.0; 2]);
        if !looks_like_counts(Signal::X, &self.x_m, offset[0])
            || !looks_like_counts(Signal::Y, &self.y_m, offset[1])
        {
            return None;
        }
        let spelling: Vec<String> = self
            .layout
            .mapped
            .iter()
            .map(|m| {
                let unit = match m.signal {
                    Signal::Time => m.unit.label,
                    Signal::XCmd | Signal::YCmd => self.command_unit_beside_counts(m),
                    _ => "counts:0.1um",
                };
                format!("{}={}[{unit}]", m.signal.key(), m.header)
            })
            .collect();
        Some(format!(
            "the measured positions are whole numbers up to {:.0} (read as {}): they look like \
             encoder counts; give each position's resolution, e.g. --columns '{}' (0.1 µm per \
             count here: your encoder's)",
            self.x_m
                .iter()
                .chain(&self.y_m)
                .fold(0.0f64, |m, v| m.max(v.abs()))
                / column(Signal::X).map_or(1e-3, |m| m.unit.to_si),
            column(Signal::X).map_or("mm", |m| m.unit.label),
            spelling.join(",")
        ))
    }

    /// The unit a command column `m` is in where the measured positions beside it are 0.1 µm
    /// counts: the one that makes its span the measured X's (or Y's) span — a control often
    /// logs its commands in a length unit and its encoders in counts.
    fn command_unit_beside_counts(&self, m: &crate::trace::format::Mapped) -> &'static str {
        let (measured, axis) = match m.signal {
            Signal::YCmd => (&self.y_m, 1),
            _ => (&self.x_m, 0),
        };
        let span = |v: &[f64]| {
            let (lo, hi) = v
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| {
                    (lo.min(*x), hi.max(*x))
                });
            hi - lo
        };
        // Read as counts of 0.1 µm, the measured span in m; the command's as read, in its
        // column's own numbers.
        let signal = if axis == 1 { Signal::Y } else { Signal::X };
        let measured_m = span(measured) / self.unit_to_si(signal) * 1e-7;
        let command_read = self
            .commands
            .as_ref()
            .map_or(0.0, |c| span(&c[axis]) / m.unit.to_si);
        if !(measured_m > 0.0 && command_read > 0.0) {
            return "counts:0.1um";
        }
        [
            ("m", 1.0),
            ("mm", 1e-3),
            ("um", 1e-6),
            ("counts:0.1um", 1e-7),
        ]
        .into_iter()
        .min_by(|a, b| {
            let off = |scale: f64| (command_read * scale / measured_m).ln().abs();
            off(a.1).total_cmp(&off(b.1))
        })
        .map_or("counts:0.1um", |(label, _)| label)
    }

    /// The factor from the unit a measured position column was read in to metres.
    fn unit_to_si(&self, signal: Signal) -> f64 {
        let column = self.layout.mapped.iter().find(|m| m.signal == signal);
        column.map_or(1e-3, |m| m.unit.to_si)
    }

    /// The trace in the program's coordinates: `offset_m` (the program origin's place in
    /// the trace's, as a work offset G54… gives it) subtracted from every measured and
    /// commanded position.
    pub fn in_work_coordinates(mut self, offset_m: [f64; 2]) -> MeasuredTrace {
        for (values, offset) in [(&mut self.x_m, offset_m[0]), (&mut self.y_m, offset_m[1])] {
            values.iter_mut().for_each(|v| *v -= offset);
        }
        if let Some([xc, yc]) = &mut self.commands {
            xc.iter_mut().for_each(|v| *v -= offset_m[0]);
            yc.iter_mut().for_each(|v| *v -= offset_m[1]);
        }
        self.layout.work_offset_m = Some(offset_m);
        self
    }

    /// The lowest and highest Z over samples `from..=to` (m, the trace's own coordinates):
    /// its commands where recorded, else its positions; `None` where the trace has no Z.
    pub(crate) fn z_span_m(&self, from: usize, to: usize) -> Option<(f64, f64)> {
        let z = self.z_cmd_m.as_ref().or(self.z_m.as_ref())?;
        let stretch = z.get(from..=to.min(z.len().checked_sub(1)?))?;
        Some(
            stretch
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                    (lo.min(*v), hi.max(*v))
                }),
        )
        .filter(|(lo, hi)| lo <= hi)
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.x_m.len()
    }

    /// True when empty.
    pub fn is_empty(&self) -> bool {
        self.x_m.is_empty()
    }

    /// Time of sample k on the measurement's clock (s).
    pub(crate) fn time_s(&self, k: usize) -> f64 {
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

/// Reads a trace file, its columns recognised from the header.
pub fn read_trace(path: &Path) -> Result<MeasuredTrace, MeasuredError> {
    read_trace_with(path, None)
}

/// Reads a trace file with the user's column mapping (None: recognised from the header).
pub fn read_trace_with(
    path: &Path,
    map: Option<&ColumnMap>,
) -> Result<MeasuredTrace, MeasuredError> {
    let file = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|e| MeasuredError::Io {
        file: file.clone(),
        message: e.to_string(),
    })?;
    if mat::is_mat_file(&bytes) || mat::is_named_as_mat_file(path, &bytes) {
        return parse_mat_trace(&bytes, &file, map);
    }
    // Spreadsheets save "Unicode text" as UTF-16: text, though its bytes hold zeros.
    let utf16 = text::utf16_text(&bytes);
    let is_utf16 = utf16.is_some();
    let text = utf16.unwrap_or_else(|| sinumerik::decode(&bytes));
    if sinumerik::is_sinumerik_trace(&text) {
        return assemble_named(&file, sinumerik::sinumerik_columns(&text, &file)?, map);
    }
    if !is_utf16 && let Some(problem) = unreadable_kind(&bytes) {
        return Err(data_error_in(&file)(problem));
    }
    // Lab exports are not always UTF-8 (a µ in Latin-1); only numbers matter here.
    parse_trace_with(&text, &file, map)
}

/// Why a file that is neither a MAT-file, a SINUMERIK trace nor a text table cannot be read,
/// if it is so: a binary file (TNCscope's own files, a control's binary trace) or another
/// XML. Neither has a published layout; such tools export their signals as text tables.
fn unreadable_kind(bytes: &[u8]) -> Option<String> {
    let head = &bytes[..bytes.len().min(512)];
    let text = String::from_utf8_lossy(head);
    let text = text.trim_start_matches('\u{feff}').trim_start();
    if text.starts_with("<?xml") || text.starts_with('<') {
        return Some(
            "an XML file that is not a SINUMERIK Operate trace (no traceData/dataFrame \
             element) nor a table of samples: export the signals as a text table (CSV) and \
             read that"
                .into(),
        );
    }
    let binary = head.contains(&0);
    binary.then(|| {
        "a binary file that is not a MATLAB MAT-file: binary trace formats (TNCscope's own \
         files, other controls' captures) have no published layout; export the signals as \
         a text table (CSV) or a MAT-file and read that"
            .into()
    })
}

/// A [`MeasuredError::Data`] about `file`.
fn data_error_in(file: &str) -> impl Fn(String) -> MeasuredError + '_ {
    move |problem| MeasuredError::Data {
        file: file.into(),
        problem,
    }
}

/// Parses a MAT-file trace (see [`trace_mat`]): its variables are the columns.
pub fn parse_mat_trace(
    bytes: &[u8],
    file: &str,
    map: Option<&ColumnMap>,
) -> Result<MeasuredTrace, MeasuredError> {
    assemble_named(file, mat::mat_columns(bytes, file)?, map)
}

/// A trace from a capture file's named columns of equal length, mapped like a text header.
fn assemble_named(
    file: &str,
    named: NamedColumns,
    map: Option<&ColumnMap>,
) -> Result<MeasuredTrace, MeasuredError> {
    let NamedColumns {
        columns,
        rows,
        source,
    } = named;
    let data_error = data_error_in(file);
    let what = match source {
        Source::Halscope { .. } => "channel",
        Source::Sinumerik { .. } => "signal",
        Source::Twincat { .. } => "channel",
        _ => "variable",
    };
    let names: Vec<&str> = columns.iter().map(|(n, _)| n.as_str()).collect();
    let mapped =
        format::map_columns(&names, map).map_err(|e| data_error(format!("{what}s: {e}")))?;
    let n = columns[mapped[0].index].1.len();
    let mut table = Table::default();
    for m in &mapped {
        let (name, values) = &columns[m.index];
        if values.len() != n {
            return Err(data_error(format!(
                "{what} '{name}' has {} values, the time '{}' {n}",
                values.len(),
                mapped[0].header
            )));
        }
        if let Some(i) = values.iter().position(|v| !v.is_finite()) {
            return Err(MeasuredError::Row {
                file: file.into(),
                row: rows.get(i).copied().unwrap_or(i as u64 + 1),
                problem: format!("{what} '{name}' ({}): not a finite number", m.signal.key()),
            });
        }
        if let Some(i) = values.iter().position(|v| !m.unit.takes(*v)) {
            return Err(MeasuredError::Row {
                file: file.into(),
                row: rows.get(i).copied().unwrap_or(i as u64 + 1),
                problem: format!(
                    "{what} '{name}' ({}): {}",
                    m.signal.key(),
                    format::not_a_count(&values[i].to_string())
                ),
            });
        }
        let si: Vec<f64> = values.iter().map(|v| v * m.unit.to_si).collect();
        match slot(m.signal) {
            None => table.t = si,
            Some(k) => table.cols[k] = si,
        }
    }
    table.rows = rows;
    let unused = columns
        .iter()
        .enumerate()
        .filter(|(i, _)| !mapped.iter().any(|m| m.index == *i))
        .map(|(_, (name, values))| UnusedColumn::of(name, values.iter().map(|v| Some(*v))))
        .collect();
    let layout = TraceLayout {
        source,
        mapped,
        unused,
        trailer_rows: 0,
        work_offset_m: None,
    };
    assemble(file, table, layout)
}

/// Where a mapped signal goes: `None` for time, else its slot in [`Table::cols`].
fn slot(signal: Signal) -> Option<usize> {
    match signal {
        Signal::Time => None,
        Signal::X => Some(0),
        Signal::Y => Some(1),
        Signal::XCmd => Some(2),
        Signal::YCmd => Some(3),
        Signal::Z => Some(4),
        Signal::ZCmd => Some(5),
    }
}

/// Samples as read, in SI units, before any check: time; X, Y, commanded X, Y (empty when
/// absent); each sample's row (line in a text file, index in a MAT variable) for messages.
#[derive(Default)]
struct Table {
    t: Vec<f64>,
    cols: [Vec<f64>; 6],
    rows: Vec<u64>,
}

/// A trace from samples read: time increasing, enough rows, a plausible step, no gaps;
/// irregular sampling resampled to the median step.
fn assemble(file: &str, table: Table, layout: TraceLayout) -> Result<MeasuredTrace, MeasuredError> {
    let data_error = data_error_in(file);
    let Table { t, cols, rows } = table;
    if let Some(i) = (1..t.len()).find(|&i| t[i] <= t[i - 1]) {
        return Err(MeasuredError::Row {
            file: file.into(),
            row: rows[i],
            // In the column's own unit: which unit that is, the clock's step decides later.
            problem: format!(
                "time {} does not increase (previous row: {}; in the time column's own unit)",
                t[i],
                t[i - 1]
            ),
        });
    }
    if t.len() < 10 {
        return Err(data_error(format!(
            "{} rows: too few to diagnose anything",
            t.len()
        )));
    }
    let mut layout = layout;
    let (t, dt) = plausible_clock(t, &mut layout.mapped[0]).map_err(data_error)?;
    if let Some(i) = (1..t.len()).find(|&i| t[i] - t[i - 1] > 5.0 * dt) {
        return Err(MeasuredError::Row {
            file: file.into(),
            row: rows[i],
            problem: format!(
                "a gap of {:.6} s before this row (the median step is {:.6} s)",
                t[i] - t[i - 1],
                dt
            ),
        });
    }
    let irregular = (1..t.len()).any(|i| ((t[i] - t[i - 1]) / dt - 1.0).abs() > 0.01);
    let has_commands = !cols[2].is_empty();
    let held = if irregular { None } else { held_rows(&cols) };
    let (t, cols, dt) = match held {
        Some(h) => (
            keep_readings(&t, h),
            cols.map(|c| keep_readings(&c, h)),
            dt * h.period as f64,
        ),
        None => (t, cols, dt),
    };
    let [x, y, xc, yc, z, zc] = if irregular {
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
        commands: has_commands.then_some([xc, yc]),
        z_m: (!z.is_empty()).then_some(z),
        z_cmd_m: (!zc.is_empty()).then_some(zc),
        resampled: irregular,
        layout,
        steps: StepStats::of(&t, dt),
        held,
    })
}

/// Parses a trace from text, its columns recognised from the header; `file` names it in
/// errors.
pub fn parse_trace(text: &str, file: &str) -> Result<MeasuredTrace, MeasuredError> {
    parse_trace_with(text, file, None)
}

/// Parses a trace from text with the user's column mapping (None: recognised).
pub fn parse_trace_with(
    text: &str,
    file: &str,
    map: Option<&ColumnMap>,
) -> Result<MeasuredTrace, MeasuredError> {
    if halscope::is_halscope_log(text) {
        return assemble_named(file, halscope::halscope_columns(text, file)?, map);
    }
    if twincat::is_twincat_export(text) {
        return assemble_named(file, twincat::twincat_columns(text, file)?, map);
    }
    let data_error = data_error_in(file);
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    // (1-based row, line) of every line that is neither blank (or separators only, as a
    // spreadsheet writes an empty row: `;;;;`) nor a comment.
    let lines: Vec<(u64, &str)> = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i as u64 + 1, l.trim_end_matches('\r')))
        .filter(|(_, l)| text::holds_something(l) && !format::is_comment(l))
        .collect();
    let Some(((header_row, header), data)) = lines.split_first() else {
        return Err(data_error("no header line".into()));
    };
    let dialect = format::sniff(header, data.iter().map(|(_, l)| *l));
    let headers: Vec<&str> = format::fields(header, dialect.delimiter)
        .into_iter()
        .map(|h| h.trim_matches('"'))
        .collect();
    let mut mapped = format::map_columns(&headers, map)
        .map_err(|e| data_error(format!("row {header_row} (header): {e}")))?;
    let data = text::without_units_row(file, data, &mut mapped, &dialect)?;
    let (data, trailer_rows) = text::without_trailer(data, mapped[0].index, &dialect);
    let table = text::read_rows(file, data, &mut mapped, &dialect)?;
    let unused = text::unused_text_columns(&headers, &mapped, data, &dialect);
    let layout = TraceLayout {
        source: Source::Text(dialect),
        mapped,
        unused,
        trailer_rows,
        work_offset_m: None,
    };
    assemble(file, table, layout)
}

/// The grid positions sit on, if they do (an encoder's count, a display's last digit): the
/// greatest common divisor of the changes between samples, by Euclid's algorithm with a
/// tolerance far below any real count. Positions off any grid drive it to nothing.
pub(crate) fn quantum(x: &[f64]) -> Option<f64> {
    const TOLERANCE_M: f64 = 1e-13;
    const FINEST_M: f64 = 1e-11;
    let gcd = |mut a: f64, mut b: f64| {
        while b > TOLERANCE_M {
            (a, b) = (b, a % b);
        }
        a
    };
    let mut steps = x
        .windows(2)
        .map(|w| (w[1] - w[0]).abs())
        .filter(|d| *d > TOLERANCE_M);
    let first = steps.next()?;
    let q = steps.fold(first, gcd);
    (q > FINEST_M).then_some(q)
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
        let e = parse_trace("when,x_mm,y_mm\n0,1,2\n", "m.csv").unwrap_err();
        assert!(e.to_string().contains("no column for time"), "{e}");
    }

    /// Encoders logged in 0.1 µm counts and commands in µm with decimals (a lab's export, no
    /// units in the header): the hint reads the positions as counts and the commands as µm,
    /// whose span (4.9 mm) matches the counts' (49,000 × 0.1 µm).
    #[test]
    fn the_counts_hint_reads_commands_in_the_unit_their_span_gives() {
        let mut text = String::from("Time [ms];X_ActPos;Y_ActPos;X_Traj;Y_Traj\n");
        for k in 0..50 {
            let counts = (k * 1000) as f64;
            let um = counts / 10.0 + 0.25;
            text.push_str(&format!(
                "{};{counts};{};{um};{}\n",
                k as f64 * 0.5,
                -counts,
                -um
            ));
        }
        let hint = parse_trace(&text, "lab.csv")
            .unwrap()
            .counts_hint()
            .unwrap();
        for spelled in [
            "x=X_ActPos[counts:0.1um]",
            "y=Y_ActPos[counts:0.1um]",
            "x_cmd=X_Traj[um]",
            "y_cmd=Y_Traj[um]",
        ] {
            assert!(hint.contains(spelled), "{spelled}: {hint}");
        }
    }

    /// A vendor export: BOM, CRLF, semicolons and decimal commas, time in ms, vendor
    /// names, positions in µm counts of 0.1 µm, a comment, and an `EOF` trailer.
    #[test]
    fn a_vendor_export_reads_without_conversion() {
        let mut text = String::from("\u{feff}// exported by the control\r\n");
        text.push_str("Time [ms];X_ActPos;Y_ActPos;X_Traj;Y_Traj;Spindle\r\n");
        for k in 0..50 {
            let t_ms = k as f64 * 0.5; // 2 kHz
            let x_counts = (k * 1000) as f64; // 100 µm per sample in 0.1 µm counts
            text.push_str(&format!(
                "{};{};{};{};{};0\r\n",
                format!("{t_ms:.1}").replace('.', ","),
                x_counts,
                -x_counts,
                x_counts + 5.0,
                -x_counts - 5.0
            ));
        }
        text.push_str("EOF;;;;;\r\n");
        let map = ColumnMap::parse(
            "t=Time[ms],x=X_ActPos[counts:0.1um],y=Y_ActPos[counts:0.1um],\
             x_cmd=X_Traj[counts:0.1um],y_cmd=Y_Traj[counts:0.1um]",
        )
        .unwrap();
        let m = parse_trace_with(&text, "v.csv", Some(&map)).unwrap();
        assert_eq!(m.len(), 50);
        assert!((m.dt_s - 5e-4).abs() < 1e-12, "{}", m.dt_s);
        assert!((m.x_m[10] - 1e-3).abs() < 1e-15, "{}", m.x_m[10]);
        assert!((m.y_m[10] + 1e-3).abs() < 1e-15);
        let [xc, _] = m.commands.as_ref().unwrap();
        assert!((xc[10] - m.x_m[10] - 5e-7).abs() < 1e-15);
        assert_eq!(m.layout.trailer_rows, 1);
        assert!(matches!(m.layout.source, Source::Text(d) if d.decimal_comma));
        // Without the mapping the names are recognised, but counts read as mm are not
        // guessed: the time unit comes from the header, the positions default to mm.
        let m = parse_trace(&text, "v.csv").unwrap();
        assert!((m.dt_s - 5e-4).abs() < 1e-12);
        assert!((m.x_m[10] - 10.0).abs() < 1e-9);
        // A column of millimetres mapped as counts is refused at its first fraction, not
        // read as positions on a grid of nothing.
        let mm = text.replacen("\r\n0,5;1000;", "\r\n0,5;1000,5;", 1);
        assert_ne!(mm, text);
        let e = parse_trace_with(&mm, "v.csv", Some(&map))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("row 4") && e.contains("'1000,5' is not a whole number"),
            "{e}"
        );
        assert!(e.contains("column 2 'X_ActPos'"), "{e}");
    }

    #[test]
    fn a_clock_without_unit_is_read_in_the_only_plausible_unit() {
        let clock = |step: f64| -> String {
            std::iter::once("Time,x,y\n".to_string())
                .chain((0..100).map(|k| format!("{},{},0\n", step * k as f64, k)))
                .collect()
        };
        // A lab's 10 kHz record in ms: 0.1 s steps are implausible, 0.1 µs too; only ms fits.
        for (step, dt_s) in [(0.1, 1e-4), (2.0, 2e-3)] {
            let m = parse_trace(&clock(step), "lab.csv").unwrap();
            assert!((m.dt_s - dt_s).abs() < 1e-15 * dt_s.max(1.0), "{}", m.dt_s);
            let said = m.layout.describe().join("\n");
            assert!(
                said.contains("in ms (unit from the sampling step"),
                "{said}"
            );
        }
        // Steps of 20 are 20 ms (50 Hz) or 20 µs (50 kHz): the user must say which.
        let e = parse_trace(&clock(20.0), "ms.csv").unwrap_err().to_string();
        assert!(e.contains("implausible") && e.contains("t=Time[ms]"), "{e}");
        let m = parse_trace_with(
            &clock(20.0),
            "ms.csv",
            Some(&ColumnMap::parse("t=Time[ms],x=x,y=y").unwrap()),
        )
        .unwrap();
        assert!((m.dt_s - 20e-3).abs() < 1e-15);
        // A unit the header states is never second-guessed.
        let stated = clock(2.0).replacen("Time", "Time [s]", 1);
        assert!(parse_trace(&stated, "s.csv").is_err());
    }

    #[test]
    fn a_bad_field_inside_the_data_names_row_and_column() {
        let mut text = String::from("t_s,x_mm,y_mm\n");
        for k in 0..20 {
            text.push_str(&format!("{},{},0\n", k as f64 * 0.001, k));
        }
        text = text.replace("\n0.005,5,0\n", "\n0.005,5.5.5,0\n");
        let e = parse_trace(&text, "b.csv").unwrap_err().to_string();
        assert!(
            e.starts_with("b.csv: row 7: column 2 'x_mm' (x): '5.5.5'"),
            "{e}"
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

    /// Rows of 1 ms of two axes moving at their own speeds, each value read at row
    /// `phase + k·period` and repeated until the next reading.
    fn held_csv(rows: usize, period: usize, phase: usize) -> String {
        let reading = |i: usize| {
            if i < phase {
                0
            } else {
                phase + (i - phase) / period * period
            }
        };
        let mut s = String::from("t_s,x_mm,y_mm\n");
        for i in 0..rows {
            let r = reading(i) as f64;
            s.push_str(&format!(
                "{},{},{}\n",
                i as f64 * 1e-3,
                0.013 * r,
                2.0 - 0.0071 * r
            ));
        }
        s
    }

    /// Commands whose X speed peaks at 2 m/s (120,000 mm/min, beyond any rapid rate) 0.25 s
    /// after the record's first sample, on a clock that starts at 1 s: the peak is said at
    /// 1.25 s, the time every other line of a report gives for it.
    #[test]
    fn commands_beyond_the_machine_are_timed_on_the_records_clock() {
        let (dt, peak_row, half_width) = (1e-3, 250.0, 50.0);
        let speed = |i: f64| 2.0 * (1.0 - (i - peak_row).abs() / half_width).max(0.0);
        let mut text = String::from("t_s,x_mm,y_mm,x_cmd_mm,y_cmd_mm\n");
        let mut x_mm = 0.0;
        for i in 0..500 {
            let t = 1.0 + i as f64 * dt;
            text.push_str(&format!("{t},{x_mm},0,{x_mm},0\n"));
            x_mm += speed(i as f64) * dt * 1e3;
        }
        let m = parse_trace(&text, "late.csv").unwrap();
        let machine = crate::machine::MachineConfig::preset("hvmc").unwrap();
        let rapid = m
            .beyond_machine(&machine)
            .into_iter()
            .find(|b| b.key == "limits.rapid_mm_per_min")
            .expect("beyond the rapid rate");
        assert!((rapid.t_s - 1.25).abs() < 2.0 * dt, "{rapid:?}");
        let from = m.beyond_machine_from(&machine, 0.1);
        assert!(
            from.iter().any(|b| (b.t_s - 1.25).abs() < 2.0 * dt),
            "{from:?}"
        );
    }

    #[test]
    fn a_logger_that_holds_its_readings_is_read_at_its_own_rate() {
        let m = parse_trace(&held_csv(2000, 15, 7), "held.csv").unwrap();
        assert_eq!(
            m.held,
            Some(HeldRows {
                period: 15,
                phase: 7
            })
        );
        assert!((m.dt_s - 0.015).abs() < 1e-15 && (m.t0_s - 0.007).abs() < 1e-15);
        assert_eq!(m.len(), (2000usize - 7).div_ceil(15));
        // Each kept row is a new reading.
        assert!(m.x_m.windows(2).all(|w| w[1] > w[0]));
        // A reading once taken a row late leaves the grid as it was.
        let text = held_csv(2000, 15, 7);
        let mut lines: Vec<String> = text.lines().map(String::from).collect();
        let grid_row = 1 + 7 + 15 * 33;
        let (_, old) = lines[grid_row - 1].split_once(',').unwrap();
        let (time, _) = lines[grid_row].split_once(',').unwrap();
        lines[grid_row] = format!("{time},{old}");
        let late = parse_trace(&(lines.join("\n") + "\n"), "late.csv").unwrap();
        assert_eq!(
            late.held,
            Some(HeldRows {
                period: 15,
                phase: 7
            })
        );
        // Every row a reading, or too few readings to tell: read as written.
        let every_row = parse_trace(&held_csv(2000, 1, 0), "rows.csv").unwrap();
        assert_eq!((every_row.held, every_row.len()), (None, 2000));
        let few = parse_trace(&held_csv(600, 15, 7), "few.csv").unwrap();
        assert_eq!((few.held, few.len()), (None, 600));
    }
}
