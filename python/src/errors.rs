//! The library's errors as the package's Python exceptions (`contourcheck.errors`), each
//! carrying where the problem is: file, line and column (G-code, machine files), key
//! (machine files), row (traces).

use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use contourcheck::{
    CompareError, ConfigError, EnvelopeError, GcodeErrors, HtmlError, IdentifyError, MeasuredError,
    SimError, SweepInputError,
};

/// Why a call failed, before it is raised in Python (made without the GIL).
#[derive(Debug)]
pub enum Failure {
    /// The program has G-code errors.
    Program(GcodeErrors),
    /// The program does not fit the machine.
    Envelope(EnvelopeError),
    /// The machine file is wrong; `text_given`: the places are in a text made from a dict,
    /// not in a file the user has.
    Machine(ConfigError, bool),
    /// The trace is unreadable or malformed; `from_arrays`: its rows are samples of arrays.
    Trace(MeasuredError, bool),
    /// The simulation could not run.
    Simulation(SimError),
    /// A record could not be compared, diagnosed or identified.
    Analysis(String),
    /// A sweep's key or values.
    Sweep(SweepInputError),
    /// A file could not be read.
    Io { file: String, message: String },
    /// Arguments that make no sense.
    Usage(String),
    /// The HTML report could not be made.
    Report(HtmlError),
}

/// Converts the library's errors.
macro_rules! failure_from {
    ($($error:ty => $variant:expr),* $(,)?) => {
        $(impl From<$error> for Failure {
            fn from(e: $error) -> Failure {
                $variant(e)
            }
        })*
    };
}

failure_from! {
    GcodeErrors => Failure::Program,
    EnvelopeError => Failure::Envelope,
    SimError => Failure::Simulation,
    SweepInputError => Failure::Sweep,
    HtmlError => Failure::Report,
}

impl From<ConfigError> for Failure {
    fn from(e: ConfigError) -> Failure {
        Failure::Machine(e, false)
    }
}

impl From<MeasuredError> for Failure {
    fn from(e: MeasuredError) -> Failure {
        Failure::Trace(e, false)
    }
}

impl From<CompareError> for Failure {
    fn from(e: CompareError) -> Failure {
        match e {
            CompareError::Measured(m) => Failure::Trace(m, false),
            other => Failure::Analysis(other.to_string()),
        }
    }
}

impl From<IdentifyError> for Failure {
    fn from(e: IdentifyError) -> Failure {
        match e {
            IdentifyError::Compare(c) => c.into(),
            other => Failure::Analysis(other.to_string()),
        }
    }
}

/// What an exception carries beside its message.
#[derive(Default)]
struct Place {
    file: Option<String>,
    line: Option<usize>,
    column: Option<usize>,
    key: Option<String>,
    row: Option<u64>,
    sample: Option<u64>,
}

impl Failure {
    /// The Python exception: its class in `contourcheck.errors`, message and place.
    pub fn into_py(self, py: Python<'_>) -> PyErr {
        match self.raise(py) {
            Ok(err) | Err(err) => err,
        }
    }

    fn raise(self, py: Python<'_>) -> PyResult<PyErr> {
        let message = self.message();
        let (class, place, problems) = self.classify(py)?;
        let errors = py.import("contourcheck.errors")?;
        let kwargs = PyDict::new(py);
        kwargs.set_item("file", place.file)?;
        kwargs.set_item("line", place.line)?;
        kwargs.set_item("column", place.column)?;
        kwargs.set_item("key", place.key)?;
        kwargs.set_item("row", place.row)?;
        kwargs.set_item("sample", place.sample)?;
        if let Some(problems) = problems {
            kwargs.set_item("problems", problems)?;
        }
        let value = errors.getattr(class)?.call((message,), Some(&kwargs))?;
        Ok(PyErr::from_value(value))
    }

    fn message(&self) -> String {
        match self {
            Failure::Program(e) => e.to_string(),
            Failure::Envelope(e) => e.to_string(),
            // A dict's places are in a text made from it: left out of the message too.
            Failure::Machine(e, true) => match e.place() {
                (file, Some((line, column))) => {
                    e.to_string()
                        .replacen(&format!("{file}:{line}:{column}"), file, 1)
                }
                _ => e.to_string(),
            },
            Failure::Machine(e, false) => e.to_string(),
            Failure::Trace(MeasuredError::Row { row, problem, .. }, true) => {
                format!("sample {}: {problem}", row.saturating_sub(2))
            }
            Failure::Trace(e, _) => e.to_string(),
            Failure::Simulation(e) => e.to_string(),
            Failure::Analysis(m) | Failure::Usage(m) => m.clone(),
            Failure::Sweep(e) => e.to_string(),
            Failure::Io { file, message } => format!("{file}: {message}"),
            Failure::Report(e) => e.to_string(),
        }
    }

    /// The exception's class name, its place and (G-code) every problem found.
    fn classify<'py>(
        self,
        py: Python<'py>,
    ) -> PyResult<(&'static str, Place, Option<Bound<'py, PyList>>)> {
        Ok(match self {
            Failure::Program(e) => {
                let problems = PyList::empty(py);
                for g in &e.0 {
                    let d = PyDict::new(py);
                    d.set_item("file", &g.file)?;
                    d.set_item("line", g.pos.line)?;
                    d.set_item("column", g.pos.column)?;
                    d.set_item("message", g.kind.to_string())?;
                    problems.append(d)?;
                }
                let first = e.first();
                let place = Place {
                    file: Some(first.file.clone()),
                    line: Some(first.pos.line as usize),
                    column: Some(first.pos.column as usize),
                    ..Place::default()
                };
                ("ProgramError", place, Some(problems))
            }
            Failure::Envelope(e) => {
                let place = match &e {
                    EnvelopeError::NoMotion { file } => Place {
                        file: Some(file.clone()),
                        ..Place::default()
                    },
                    EnvelopeError::OutsideTravel { file, line, .. } => Place {
                        file: Some(file.clone()),
                        line: Some(*line as usize),
                        ..Place::default()
                    },
                };
                ("ProgramError", place, None)
            }
            Failure::Machine(e, text_given) => {
                let (file, at) = e.place();
                let at = if text_given { None } else { at };
                let place = Place {
                    file: Some(file.to_string()),
                    line: at.map(|a| a.0),
                    column: at.map(|a| a.1),
                    key: e.key().map(str::to_string),
                    ..Place::default()
                };
                ("MachineError", place, None)
            }
            Failure::Trace(e, from_arrays) => ("TraceError", trace_place(&e, from_arrays), None),
            Failure::Simulation(_) => ("SimulationError", Place::default(), None),
            Failure::Analysis(_) => ("AnalysisError", Place::default(), None),
            Failure::Sweep(_) | Failure::Usage(_) => ("UsageError", Place::default(), None),
            Failure::Io { file, .. } => (
                "InputError",
                Place {
                    file: Some(file),
                    ..Place::default()
                },
                None,
            ),
            Failure::Report(_) => ("ReportError", Place::default(), None),
        })
    }
}

/// A trace error's file and row; for arrays, the sample's index instead of the row of the
/// table they were read as (its header is row 1).
fn trace_place(e: &MeasuredError, from_arrays: bool) -> Place {
    let file = match e {
        MeasuredError::Io { file, .. }
        | MeasuredError::MissingColumn { file, .. }
        | MeasuredError::Row { file, .. }
        | MeasuredError::Data { file, .. } => file.clone(),
    };
    let row = match e {
        MeasuredError::Row { row, .. } => Some(*row),
        _ => None,
    };
    Place {
        file: Some(file),
        row: row.filter(|_| !from_arrays),
        sample: row.filter(|_| from_arrays).map(|r| r.saturating_sub(2)),
        ..Place::default()
    }
}

/// Runs `work` with the GIL released (the simulation runs on Rust threads), then raises its
/// failure as the package's exception.
pub fn detached<T: Send>(
    py: Python<'_>,
    work: impl FnOnce() -> Result<T, Failure> + Send,
) -> PyResult<T> {
    py.detach(work).map_err(|f| f.into_py(py))
}
