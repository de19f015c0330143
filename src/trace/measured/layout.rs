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

/// How a trace file was read: its format, which column became what, and how many trailer
/// rows were skipped.
#[derive(Debug, Clone, PartialEq)]
pub struct TraceLayout {
    /// Text dialect or MAT-file.
    pub source: Source,
    /// Time, X, Y (and commands) as mapped.
    pub mapped: Vec<Mapped>,
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
