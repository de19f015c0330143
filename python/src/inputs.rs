//! What a run starts from: a machine (preset, TOML text, file, or a table as a dict) and a
//! program (text or file).

use std::path::{Path, PathBuf};
use std::sync::Arc;

use pyo3::prelude::*;

use crate::errors::Failure;

/// The embedded presets' names.
#[pyfunction]
pub fn presets() -> Vec<&'static str> {
    contourcheck::PRESETS
        .iter()
        .map(|(name, _)| *name)
        .collect()
}

/// A machine: the servo loops, drives, mechanics and friction of both axes.
#[pyclass(frozen, module = "contourcheck._native")]
pub struct Machine {
    pub(crate) config: Arc<contourcheck::MachineConfig>,
    /// The file it was read from, if it was.
    pub(crate) file: Option<String>,
}

impl Machine {
    fn of(
        py: Python<'_>,
        result: Result<contourcheck::MachineConfig, Failure>,
        file: Option<String>,
    ) -> PyResult<Self> {
        result
            .map(|config| Machine {
                config: Arc::new(config),
                file,
            })
            .map_err(|f| f.into_py(py))
    }
}

#[pymethods]
impl Machine {
    /// An embedded preset by name (`hvmc`, `small-table`).
    #[staticmethod]
    fn preset(py: Python<'_>, name: &str) -> PyResult<Self> {
        Machine::of(
            py,
            contourcheck::MachineConfig::preset(name).map_err(Failure::from),
            None,
        )
    }

    /// A machine file's text; `name` names it in errors.
    #[staticmethod]
    #[pyo3(signature = (text, name = "<text>"))]
    fn from_toml(py: Python<'_>, text: &str, name: &str) -> PyResult<Self> {
        Machine::of(
            py,
            contourcheck::MachineConfig::from_toml_str(text, name).map_err(Failure::from),
            None,
        )
    }

    /// A machine file.
    #[staticmethod]
    fn from_file(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        let file = path.display().to_string();
        Machine::of(
            py,
            contourcheck::MachineConfig::load(&path).map_err(Failure::from),
            Some(file),
        )
    }

    /// A machine file's table given as JSON text (the Python layer's `dict`); errors name
    /// the key (their lines and columns would be those of a text the user never saw).
    #[staticmethod]
    #[pyo3(signature = (json, name = "<dict>"))]
    fn from_json(py: Python<'_>, json: &str, name: &str) -> PyResult<Self> {
        let text = toml_of_json(json);
        let config = text.and_then(|text| {
            contourcheck::MachineConfig::from_toml_str(&text, name)
                .map_err(|e| Failure::Machine(e, true))
        });
        Machine::of(py, config, None)
    }

    /// Its name.
    #[getter]
    fn name(&self) -> String {
        self.config.name.clone()
    }

    /// Its description.
    #[getter]
    fn description(&self) -> String {
        self.config.description.clone()
    }

    /// The file it was read from, or None.
    #[getter]
    fn file(&self) -> Option<String> {
        self.file.clone()
    }

    /// The whole machine as a machine file's text (every key, `base = "none"` implied).
    fn to_toml(&self) -> String {
        self.config.to_toml()
    }
}

/// A JSON object as TOML text.
fn toml_of_json(json: &str) -> Result<String, Failure> {
    let value: serde_json::Value =
        serde_json::from_str(json).map_err(|e| Failure::Usage(format!("machine table: {e}")))?;
    let table = toml::Value::try_from(value)
        .map_err(|e| Failure::Usage(format!("machine table: {e} (no None values in a machine)")))?;
    toml::to_string(&table).map_err(|e| Failure::Usage(format!("machine table: {e}")))
}

/// A part program, parsed and interpreted into its path.
#[pyclass(frozen, module = "contourcheck._native")]
pub struct Program {
    pub(crate) program: Arc<contourcheck::Program>,
}

/// The dialect named, or None to tell it from the file.
fn dialect(name: Option<&str>) -> Result<Option<contourcheck::Dialect>, Failure> {
    match name {
        None => Ok(None),
        Some("rs274") => Ok(Some(contourcheck::Dialect::Rs274)),
        Some("sinumerik") => Ok(Some(contourcheck::Dialect::Sinumerik)),
        Some(other) => Err(Failure::Usage(format!(
            "dialect '{other}': rs274 or sinumerik"
        ))),
    }
}

fn parse(
    text: &str,
    name: &str,
    folder: Option<PathBuf>,
    dialect_name: Option<&str>,
) -> Result<contourcheck::Program, Failure> {
    let options = contourcheck::InterpretOptions {
        dialect: dialect(dialect_name)?,
        subprogram_folder: folder,
        ..contourcheck::InterpretOptions::default()
    };
    Ok(contourcheck::parse_program(text, name, &options)?)
}

#[pymethods]
impl Program {
    /// A program's text; `name` names it in errors; subprograms are looked for in `folder`.
    #[staticmethod]
    #[pyo3(signature = (text, name = "<text>".to_string(), dialect = None, folder = None))]
    fn from_text(
        py: Python<'_>,
        text: String,
        name: String,
        dialect: Option<String>,
        folder: Option<PathBuf>,
    ) -> PyResult<Self> {
        crate::errors::detached(py, move || parse(&text, &name, folder, dialect.as_deref())).map(
            |p| Program {
                program: Arc::new(p),
            },
        )
    }

    /// A program file (bytes that are not UTF-8 are replaced); its subprograms are looked
    /// for beside it.
    #[staticmethod]
    #[pyo3(signature = (path, dialect = None))]
    fn from_file(py: Python<'_>, path: PathBuf, dialect: Option<String>) -> PyResult<Self> {
        crate::errors::detached(py, move || {
            let bytes = std::fs::read(&path).map_err(|e| Failure::Io {
                file: path.display().to_string(),
                message: e.to_string(),
            })?;
            let folder = path.parent().map(|p| {
                if p.as_os_str().is_empty() {
                    Path::new(".").to_path_buf()
                } else {
                    p.to_path_buf()
                }
            });
            parse(
                &String::from_utf8_lossy(&bytes),
                &path.display().to_string(),
                folder,
                dialect.as_deref(),
            )
        })
        .map(|p| Program {
            program: Arc::new(p),
        })
    }

    /// The file name as given.
    #[getter]
    fn file(&self) -> String {
        self.program.file.clone()
    }

    /// Source lines.
    #[getter]
    fn lines(&self) -> usize {
        self.program.lines
    }

    /// Blocks with words.
    #[getter]
    fn blocks(&self) -> usize {
        self.program.blocks
    }

    /// Path segments.
    #[getter]
    fn segments(&self) -> usize {
        self.program.segments.len()
    }

    /// The interpreter's warnings: (line, message).
    #[getter]
    fn warnings(&self) -> Vec<(u32, String)> {
        self.program
            .warnings
            .iter()
            .map(|w| (w.line, w.message.clone()))
            .collect()
    }

    /// A line as the program numbers it, named by its file: (file or None for the
    /// program's own, line in that file).
    fn source_line(&self, line: u32) -> (Option<String>, u32) {
        let at = self.program.source_line(line);
        (at.file.map(str::to_string), at.line)
    }
}
