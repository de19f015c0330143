//! Measured records from outside: every reader of trace files (delimited text, MAT-files,
//! halscope logs, SINUMERIK traces, TwinCAT Scope exports; the capture files' readers all hand
//! on [`columns::NamedColumns`]) and the layouts that tell their columns apart, what a record
//! holds before
//! anything is fitted to it, and the commands a control recorded made into the simulator's
//! input. Nothing here simulates or fits: `diagnose` and `identify` build on it.

pub mod clock;
pub mod columns;
pub mod format;
pub mod halscope;
pub mod inspect;
pub mod mat;
pub(crate) mod mat5;
pub mod measured;
pub(crate) mod numerals;
pub mod placement;
pub mod recorded;
pub mod signal;
pub mod sinumerik;
pub mod twincat;
