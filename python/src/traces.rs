//! Measured traces: read from a file (any format the library reads) or made from arrays.

use std::fmt::Write as _;
use std::path::PathBuf;
use std::sync::Arc;

use numpy::{PyArray1, PyReadonlyArray1};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::errors::{Failure, detached};

/// A measured trace on a uniform time grid.
#[pyclass(frozen, module = "contourcheck._native")]
pub struct Trace {
    pub(crate) trace: Arc<contourcheck::MeasuredTrace>,
}

/// Reads a trace file; `columns` maps its columns (`t=Time[ms],x=X_ActPos[mm],…`; None:
/// recognised from the header); `work_offset_mm` is the program origin in its coordinates.
#[pyfunction]
#[pyo3(signature = (path, columns = None, work_offset_mm = None))]
pub fn read_trace(
    py: Python<'_>,
    path: PathBuf,
    columns: Option<String>,
    work_offset_mm: Option<(f64, f64)>,
) -> PyResult<Trace> {
    detached(py, move || {
        let map = columns
            .map(|text| {
                contourcheck::ColumnMap::parse(&text)
                    .map_err(|e| Failure::Usage(format!("columns: {e}")))
            })
            .transpose()?;
        let trace = contourcheck::read_trace_with(&path, map.as_ref())?;
        Ok(match work_offset_mm {
            Some((x, y)) => trace.in_work_coordinates([x * 1e-3, y * 1e-3]),
            None => trace,
        })
    })
    .map(|trace| Trace {
        trace: Arc::new(trace),
    })
}

/// A trace from arrays: time (s), measured X and Y (mm) and, where recorded, the commanded X
/// and Y (mm). They are read as the table they are (`t_s,x_mm,y_mm[,x_cmd_mm,y_cmd_mm]`),
/// with every check a file gets: errors name the sample.
#[pyfunction]
#[pyo3(signature = (t_s, x_mm, y_mm, x_cmd_mm = None, y_cmd_mm = None, name = "<arrays>".to_string()))]
pub fn trace_from_arrays(
    py: Python<'_>,
    t_s: PyReadonlyArray1<'_, f64>,
    x_mm: PyReadonlyArray1<'_, f64>,
    y_mm: PyReadonlyArray1<'_, f64>,
    x_cmd_mm: Option<PyReadonlyArray1<'_, f64>>,
    y_cmd_mm: Option<PyReadonlyArray1<'_, f64>>,
    name: String,
) -> PyResult<Trace> {
    let values = |a: &PyReadonlyArray1<'_, f64>| a.as_array().iter().copied().collect::<Vec<f64>>();
    let mut columns = vec![values(&t_s), values(&x_mm), values(&y_mm)];
    match (x_cmd_mm, y_cmd_mm) {
        (Some(x), Some(y)) => columns.extend([values(&x), values(&y)]),
        (None, None) => {}
        _ => {
            return Err(
                Failure::Usage("give both x_cmd_mm and y_cmd_mm, or neither".into()).into_py(py),
            );
        }
    }
    detached(py, move || {
        let n = columns[0].len();
        if columns.iter().any(|c| c.len() != n) {
            return Err(Failure::Usage(format!(
                "{name}: the arrays differ in length ({})",
                columns
                    .iter()
                    .map(|c| c.len().to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            )));
        }
        let text = table_text(&columns);
        contourcheck::parse_trace(&text, &name).map_err(|e| Failure::Trace(e, true))
    })
    .map(|trace| Trace {
        trace: Arc::new(trace),
    })
}

/// The columns as a CSV table; each number written so that it reads back exactly.
fn table_text(columns: &[Vec<f64>]) -> String {
    let header = ["t_s", "x_mm", "y_mm", "x_cmd_mm", "y_cmd_mm"];
    let mut text = header[..columns.len()].join(",");
    text.push('\n');
    for i in 0..columns[0].len() {
        for (k, c) in columns.iter().enumerate() {
            let sep = if k == 0 { "" } else { "," };
            let _ = write!(text, "{sep}{:?}", c[i]);
        }
        text.push('\n');
    }
    text
}

fn mm(values: &[f64]) -> Vec<f64> {
    values.iter().map(|v| v * 1e3).collect()
}

#[pymethods]
impl Trace {
    /// The file (or name) it was read from.
    #[getter]
    fn file(&self) -> String {
        self.trace.file.clone()
    }

    /// Sampling step (s).
    #[getter]
    fn dt_s(&self) -> f64 {
        self.trace.dt_s
    }

    /// Samples.
    fn __len__(&self) -> usize {
        self.trace.len()
    }

    /// The samples as arrays: `t_s` (on the record's clock), `x_mm`, `y_mm` and, where
    /// recorded, `x_cmd_mm`, `y_cmd_mm`.
    fn arrays<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let t = &self.trace;
        let d = PyDict::new(py);
        let times: Vec<f64> = (0..t.len()).map(|k| t.t0_s + k as f64 * t.dt_s).collect();
        d.set_item("t_s", PyArray1::from_vec(py, times))?;
        d.set_item("x_mm", PyArray1::from_vec(py, mm(&t.x_m)))?;
        d.set_item("y_mm", PyArray1::from_vec(py, mm(&t.y_m)))?;
        if let Some([x, y]) = &t.commands {
            d.set_item("x_cmd_mm", PyArray1::from_vec(py, mm(x)))?;
            d.set_item("y_cmd_mm", PyArray1::from_vec(py, mm(y)))?;
        }
        Ok(d)
    }

    /// How each signal was found: {signal: {"column": index, "header": …, "unit": …,
    /// "unit_from": …}} for `t`, `x`, `y` and, where recorded, `x_cmd`, `y_cmd`.
    fn columns<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for m in &self.trace.layout.mapped {
            let c = PyDict::new(py);
            c.set_item("column", m.index)?;
            c.set_item("header", &m.header)?;
            c.set_item("unit", m.unit.label)?;
            c.set_item("unit_from", m.unit_from)?;
            d.set_item(m.signal.key(), c)?;
        }
        Ok(d)
    }

    /// How the file was read, in the words `inspect` uses: the format, then one line per
    /// mapped column.
    fn describe(&self) -> Vec<String> {
        self.trace.layout.describe()
    }
}
