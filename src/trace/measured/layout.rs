//! How a trace file was read: its kind, which column became what, what was skipped.

use crate::trace::format::{self, Dialect, Mapped};

/// What kind of file a trace came from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Source {
    /// A text table in this dialect.
    Text(Dialect),
    /// A MATLAB MAT-file (level 5) with this many columns among its variables.
    MatFile {
        /// Columns found (a matrix gives one per column).
        variables: usize,
    },
    /// A LinuxCNC halscope log with this many channels.
    Halscope {
        /// Channels in the log.
        channels: usize,
    },
    /// A SINUMERIK Operate trace (XML) with this many sampled signals.
    Sinumerik {
        /// Signals with samples.
        signals: usize,
    },
    /// A TwinCAT Scope export with this many channels.
    Twincat {
        /// Channels in the export.
        channels: usize,
    },
}

/// A column of the file that no signal was mapped to, shown so that the user sees everything
/// the file holds (a spindle load, a current, a second encoder) and can map it with
/// `--columns` where it is what they meant.
#[derive(Debug, Clone, PartialEq)]
pub struct UnusedColumn {
    /// The column's name as written (a header, a variable, a channel, a signal).
    pub name: String,
    /// Its lowest and highest value in the file's own units, where every sample is a
    /// number.
    pub range: Option<[f64; 2]>,
}

impl UnusedColumn {
    /// The column named `name` with the range of `values` (none where any is not finite).
    pub(crate) fn of(name: &str, values: impl IntoIterator<Item = Option<f64>>) -> Self {
        let mut range = Some([f64::INFINITY, f64::NEG_INFINITY]);
        for v in values {
            range = match (range, v) {
                (Some([lo, hi]), Some(v)) if v.is_finite() => Some([lo.min(v), hi.max(v)]),
                _ => None,
            };
        }
        let range = range.filter(|[lo, hi]| lo <= hi);
        UnusedColumn {
            name: name.to_string(),
            range,
        }
    }

    fn describe(&self) -> String {
        match self.range {
            Some([lo, hi]) => format!("{} ({} … {})", self.name, short(lo), short(hi)),
            None => format!("{} (not all numbers)", self.name),
        }
    }
}

/// A value in six significant digits, without trailing zeros.
fn short(v: f64) -> String {
    let text = format!("{v:.6e}");
    let parsed: f64 = text.parse().unwrap_or(v);
    format!("{parsed}")
}

/// How a trace file was read: its format, which column became what, and how many trailer
/// rows were skipped.
#[derive(Debug, Clone, PartialEq)]
pub struct TraceLayout {
    /// Text dialect or MAT-file.
    pub source: Source,
    /// Time, X, Y (and commands) as mapped.
    pub mapped: Vec<Mapped>,
    /// The file's other columns, in its order: read, not used.
    pub unused: Vec<UnusedColumn>,
    /// Lines after the data that were not data (skipped).
    pub trailer_rows: usize,
    /// The program origin's place in the trace's coordinates (m), subtracted from every
    /// position read (a trace in machine coordinates), when one was given.
    pub work_offset_m: Option<[f64; 2]>,
}

impl TraceLayout {
    /// Lines for the user: the dialect, then one per mapped column.
    pub fn describe(&self) -> Vec<String> {
        let first = match self.source {
            Source::Text(dialect) => format!(
                "{}-separated{}{}",
                dialect.delimiter,
                if dialect.decimal_comma {
                    ", decimal comma"
                } else {
                    ""
                },
                if self.trailer_rows > 0 {
                    format!(", {} trailer rows skipped", self.trailer_rows)
                } else {
                    String::new()
                }
            ),
            Source::MatFile { variables } => {
                format!("MATLAB MAT-file (level 5), {variables} numeric columns")
            }
            Source::Halscope { channels } => {
                format!("LinuxCNC halscope log, {channels} channels, time from its sampling period")
            }
            Source::Twincat { channels } => format!(
                "TwinCAT Scope export, {channels} channels on the clock of the most densely \
                 sampled one"
            ),
            Source::Sinumerik { signals } => format!(
                "SINUMERIK Operate trace (XML), {signals} signals on the clock of the most \
                 densely sampled one"
            ),
        };
        let mut lines = vec![first];
        lines.extend(format::describe_mapping(&self.mapped));
        if !self.unused.is_empty() {
            // Every column the file holds is shown: one line each, so that a long capture's
            // signals can be read down the page.
            lines.push(format!(
                "also in the file, not used ({}; map one with --columns):",
                self.unused.len()
            ));
            lines.extend(self.unused.iter().map(|c| format!("  {}", c.describe())));
        }
        if let Some([x, y]) = self.work_offset_m {
            lines.push(format!(
                "work offset X {:.3} mm, Y {:.3} mm subtracted from every position (machine \
                 to program coordinates)",
                x * 1e3,
                y * 1e3
            ));
        }
        lines
    }
}
