//! What every reader of a capture file hands on: its columns by the names the file gives
//! them (a MAT-file's variables, a halscope log's channels, a SINUMERIK trace's signals, a
//! TwinCAT export's channels), each sample's row for messages, and the kind of file. They
//! are mapped to time, X and Y as a text table's header is, in `measured`.

use crate::trace::measured::Source;

/// Named columns of samples from a capture file.
#[derive(Debug, Clone, PartialEq)]
pub struct NamedColumns {
    /// (name, values), the clock first where the file has one.
    pub columns: Vec<(String, Vec<f64>)>,
    /// Each sample's place in the file: its 1-based line in a text file, its 1-based index
    /// in a MAT-file's variable.
    pub rows: Vec<u64>,
    /// The kind of file, with how many columns it holds.
    pub source: Source,
}
