//! The native part of the Python package `contourcheck`: programs, machines and traces as
//! Python objects, and the library's entry points run with the GIL released.
//!
//! Only the library's public interface is used — the items `contourcheck` re-exports at its
//! root, and the fields of their settings and results — so that the library's modules can
//! change without this crate noticing. The Python layer (`contourcheck/__init__.py`) turns
//! what is returned here (JSON reports, numpy arrays) into result objects.

mod errors;
mod inputs;
mod runs;
mod traces;

use pyo3::prelude::*;

/// The native module, `contourcheck._native`.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<inputs::Machine>()?;
    m.add_class::<inputs::Program>()?;
    m.add_class::<traces::Trace>()?;
    m.add_class::<runs::CheckOutcome>()?;
    m.add_class::<runs::DiagnoseOutcome>()?;
    m.add_class::<runs::IdentifyOutcome>()?;
    m.add_function(wrap_pyfunction!(inputs::presets, m)?)?;
    m.add_function(wrap_pyfunction!(traces::read_trace, m)?)?;
    m.add_function(wrap_pyfunction!(traces::trace_from_arrays, m)?)?;
    m.add_function(wrap_pyfunction!(runs::check, m)?)?;
    m.add_function(wrap_pyfunction!(runs::sweep, m)?)?;
    m.add_function(wrap_pyfunction!(runs::diagnose, m)?)?;
    m.add_function(wrap_pyfunction!(runs::identify, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
