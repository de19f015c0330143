//! The runs: check, sweep, diagnose and identify, each with the GIL released, each giving
//! the JSON report the command line writes (the Python layer reads its figures from it) and
//! what else a caller needs (the run's samples, the fitted machine file, the HTML page).

use std::sync::Arc;

use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use contourcheck::{
    CauseId, CauseSet, CheckReport, CheckRun, CheckSettings, CompareSettings, DiagnoseReport,
    DiagnoseSettings, Diagnosis, Dimension, Identification, IdentifyReport, MachineConfig,
    MeasuredAt, ProfileKind, ReportInputs,
};

use crate::errors::{Failure, detached};
use crate::inputs::{Machine, Program};
use crate::traces::Trace;

/// Planner settings as the command line's flags give them, checked alike.
fn plan_settings(
    machine: &MachineConfig,
    profile: Option<&str>,
    cycle_ms: Option<f64>,
    blend_tolerance_mm: Option<f64>,
) -> Result<CheckSettings, Failure> {
    let mut settings = CheckSettings::for_machine(machine);
    if let Some(name) = profile {
        settings.plan.profile = name.parse::<ProfileKind>().map_err(Failure::Usage)?;
    }
    if let Some(ms) = cycle_ms {
        if !(ms.is_finite() && (0.05..=100.0).contains(&ms)) {
            return Err(Failure::Usage(format!(
                "cycle_ms {ms}: must lie between 0.05 and 100"
            )));
        }
        settings.plan.cycle_s = ms * 1e-3;
    }
    if let Some(mm) = blend_tolerance_mm {
        if !(mm.is_finite() && mm > 0.0) {
            return Err(Failure::Usage(format!(
                "blend_tolerance_mm {mm}: must be positive"
            )));
        }
        settings.plan.default_blend_tolerance_m = mm * 1e-3;
    }
    Ok(settings)
}

fn json<T: serde::Serialize>(value: &T) -> String {
    serde_json::to_string(value).expect("reports serialize (non-finite numbers as null)")
}

/// A check: the report's figures and the whole run.
#[pyclass(frozen, module = "contourcheck._native")]
pub struct CheckOutcome {
    run: CheckRun,
    report: CheckReport,
    program: Arc<contourcheck::Program>,
    machine_file: Option<String>,
}

/// Checks `program` on `machine`: the JSON report's figures (`check --json`) and the run.
#[pyfunction]
#[pyo3(signature = (program, machine, profile = None, cycle_ms = None, blend_tolerance_mm = None, tolerance_um = None))]
pub fn check(
    py: Python<'_>,
    program: &Program,
    machine: &Machine,
    profile: Option<String>,
    cycle_ms: Option<f64>,
    blend_tolerance_mm: Option<f64>,
    tolerance_um: Option<f64>,
) -> PyResult<CheckOutcome> {
    let (program, config) = (program.program.clone(), machine.config.clone());
    let machine_file = machine.file.clone();
    detached(py, move || {
        if let Some(t) = tolerance_um
            && !(t.is_finite() && t > 0.0)
        {
            return Err(Failure::Usage(format!(
                "tolerance_um {t}: must be a positive number of µm"
            )));
        }
        let settings = plan_settings(&config, profile.as_deref(), cycle_ms, blend_tolerance_mm)?;
        contourcheck::check_fits(&program, &config)?;
        let run = contourcheck::check(&program, &config, &settings)?;
        let report = CheckReport::new(&run.result, &settings, &program, &config, tolerance_um);
        Ok(CheckOutcome {
            run,
            report,
            program,
            machine_file,
        })
    })
}

#[pymethods]
impl CheckOutcome {
    /// The JSON report (schema `contourcheck.check/1`).
    fn report_json(&self) -> String {
        json(&self.report)
    }

    /// Every sample of the run: `t_s`, `line` (as the program numbers its lines),
    /// `x_cmd_mm`, `y_cmd_mm`, `x_mm`, `y_mm`, `fe_x_um`, `fe_y_um`, `contour_um` (NaN
    /// where there is no contour: rapids, moves of Z alone, dwells).
    fn samples<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let r = &self.run;
        let c = &r.commands;
        let n = c.len().min(r.x.pos_m.len()).min(r.y.pos_m.len());
        let segments = &r.result.plan.segments;
        let d = PyDict::new(py);
        let each = |f: &dyn Fn(usize) -> f64| (0..n).map(f).collect::<Vec<f64>>();
        d.set_item("t_s", PyArray1::from_vec(py, each(&|k| k as f64 * c.dt_s)))?;
        let lines: Vec<u32> = (0..n)
            .map(|k| segments.get(c.segment[k] as usize).map_or(0, |s| s.line))
            .collect();
        d.set_item("line", PyArray1::from_vec(py, lines))?;
        d.set_item(
            "x_cmd_mm",
            PyArray1::from_vec(py, each(&|k| c.x.pos_m[k] * 1e3)),
        )?;
        d.set_item(
            "y_cmd_mm",
            PyArray1::from_vec(py, each(&|k| c.y.pos_m[k] * 1e3)),
        )?;
        d.set_item(
            "x_mm",
            PyArray1::from_vec(py, each(&|k| r.x.pos_m[k] * 1e3)),
        )?;
        d.set_item(
            "y_mm",
            PyArray1::from_vec(py, each(&|k| r.y.pos_m[k] * 1e3)),
        )?;
        let fe_x = each(&|k| r.x.following_error_m(k) * 1e6);
        let fe_y = each(&|k| r.y.following_error_m(k) * 1e6);
        d.set_item("fe_x_um", PyArray1::from_vec(py, fe_x))?;
        d.set_item("fe_y_um", PyArray1::from_vec(py, fe_y))?;
        let contour = each(&|k| r.contour.error_m.get(k).map_or(f64::NAN, |e| e * 1e6));
        d.set_item("contour_um", PyArray1::from_vec(py, contour))?;
        Ok(d)
    }

    /// The one-page HTML report (`check --report`).
    fn html(&self, py: Python<'_>) -> PyResult<String> {
        let inputs = ReportInputs {
            machine_file: self.machine_file.clone(),
        };
        contourcheck::check_page(
            &self.run.result,
            &self.report,
            &self.program.sources,
            &inputs,
        )
        .map_err(|e| Failure::from(e).into_py(py))
    }
}

/// Runs every combination of `grid`'s values — (key, values) pairs, a key as `x.kv_m_per_min_per_mm`,
/// `x.drive.backlash_um` or `xy.backlash_um` (both axes alike) — and ranks them, a setting
/// short of the thresholds after every healthy one: the JSON `sweep --json` writes.
#[pyfunction]
#[pyo3(signature = (program, machine, grid, profile = None, cycle_ms = None, min_damping = 0.05, min_phase_margin = 30.0, min_gain_margin = 6.0))]
#[allow(clippy::too_many_arguments)]
pub fn sweep(
    py: Python<'_>,
    program: &Program,
    machine: &Machine,
    grid: Vec<(String, Vec<f64>)>,
    profile: Option<String>,
    cycle_ms: Option<f64>,
    min_damping: f64,
    min_phase_margin: f64,
    min_gain_margin: f64,
) -> PyResult<String> {
    let (program, config) = (program.program.clone(), machine.config.clone());
    detached(py, move || {
        if !(min_damping.is_finite() && (0.0..1.0).contains(&min_damping)) {
            return Err(Failure::Usage(format!(
                "min_damping {min_damping}: a damping ratio from 0 up to 1"
            )));
        }
        if !(min_phase_margin.is_finite() && (0.0..90.0).contains(&min_phase_margin)) {
            return Err(Failure::Usage(format!(
                "min_phase_margin {min_phase_margin}: degrees from 0 up to 90"
            )));
        }
        if !(min_gain_margin.is_finite() && (0.0..40.0).contains(&min_gain_margin)) {
            return Err(Failure::Usage(format!(
                "min_gain_margin {min_gain_margin}: dB from 0 up to 40"
            )));
        }
        let thresholds = contourcheck::SweepThresholds {
            min_phase_margin_deg: min_phase_margin,
            min_gain_margin_db: min_gain_margin,
            min_damping,
        };
        let settings = plan_settings(&config, profile.as_deref(), cycle_ms, None)?;
        contourcheck::check_fits(&program, &config)?;
        let dims = grid
            .into_iter()
            .map(|(key, values)| dimension(&config, key, values))
            .collect::<Result<Vec<_>, _>>()?;
        let mut points =
            contourcheck::run_sweep(&program, &config, &settings.plan, &dims, true, &|| {});
        contourcheck::rank_sweep(&mut points, &thresholds);
        Ok(json(&serde_json::json!({
            "schema": "contourcheck.sweep/2",
            "program": program.file,
            "machine": config.name,
            "thresholds": thresholds,
            "dimensions": dims,
            "points": points,
        })))
    })
}

/// A swept key: `axis.key` or `xy.key` (the same key on both axes).
fn dimension(machine: &MachineConfig, key: String, values: Vec<f64>) -> Result<Dimension, Failure> {
    let (axis, rest) = key
        .split_once('.')
        .ok_or_else(|| Failure::Usage(format!("{key}: name the axis, e.g. x.{key}")))?;
    let axes: &[&str] = match axis {
        "x" => &["x"],
        "y" => &["y"],
        "xy" => &["x", "y"],
        other => {
            return Err(Failure::Usage(format!(
                "{key}: axis '{other}' is x, y or xy"
            )));
        }
    };
    let keys = axes
        .iter()
        .map(|a| contourcheck::resolve_key(machine, &format!("{a}.{rest}")))
        .collect::<Result<Vec<_>, _>>()?;
    if values.is_empty() || values.iter().any(|v| !v.is_finite()) {
        return Err(Failure::Usage(format!("{key}: give finite values")));
    }
    Ok(Dimension {
        name: key,
        keys,
        values,
    })
}

/// The program a record ran, or the path its commands drew.
fn program_or_commands(
    program: Option<Arc<contourcheck::Program>>,
    trace: &contourcheck::MeasuredTrace,
) -> Result<Arc<contourcheck::Program>, Failure> {
    if let Some(p) = program {
        return Ok(p);
    }
    let commands = trace.commands.as_ref().ok_or_else(|| {
        Failure::Usage(format!(
            "{}: no program given and no commands recorded: give the program the record ran",
            trace.file
        ))
    })?;
    contourcheck::program_from_commands(commands, trace.dt_s, &trace.file)
        .map(Arc::new)
        .ok_or_else(|| {
            Failure::Usage(format!(
                "{}: no program given, and the recorded commands do not move",
                trace.file
            ))
        })
}

/// A diagnosis: its report, the extended machine and the page.
#[pyclass(frozen, module = "contourcheck._native")]
pub struct DiagnoseOutcome {
    diagnosis: Diagnosis,
    report: DiagnoseReport,
    machine_file: Option<String>,
}

/// The cause ids named, each checked.
fn cause_ids(names: &[String]) -> Result<Vec<CauseId>, Failure> {
    names
        .iter()
        .map(|n| {
            CauseId::ALL
                .into_iter()
                .find(|c| c.as_str() == n)
                .ok_or_else(|| {
                    let all: Vec<&str> = CauseId::ALL.iter().map(|c| c.as_str()).collect();
                    Failure::Usage(format!("cause '{n}': one of {}", all.join(", ")))
                })
        })
        .collect()
}

/// What the record measured: `table`, `motor` or `tool`.
fn measured_at(name: &str) -> Result<MeasuredAt, Failure> {
    [MeasuredAt::Table, MeasuredAt::Motor, MeasuredAt::Tool]
        .into_iter()
        .find(|m| m.as_str() == name)
        .ok_or_else(|| Failure::Usage(format!("measured_at '{name}': table, motor or tool")))
}

/// What the model gets wrong against a record, the cause and the fitted extension
/// (`diagnose`); `second`: another record of the program to judge the causes on.
#[pyfunction]
#[pyo3(signature = (program, machine, trace, second = None, causes = None, exclude = None,
    max_causes = 3, evidence = 10.0, measured_at = "table".to_string(), align_stretches = false,
    command_tolerance_um = 25.0, profile = None, cycle_ms = None))]
#[allow(clippy::too_many_arguments)]
pub fn diagnose(
    py: Python<'_>,
    program: Option<&Program>,
    machine: &Machine,
    trace: &Trace,
    second: Option<&Trace>,
    causes: Option<Vec<String>>,
    exclude: Option<Vec<String>>,
    max_causes: usize,
    evidence: f64,
    measured_at: String,
    align_stretches: bool,
    command_tolerance_um: f64,
    profile: Option<String>,
    cycle_ms: Option<f64>,
) -> PyResult<DiagnoseOutcome> {
    let program = program.map(|p| p.program.clone());
    let config = machine.config.clone();
    let machine_file = machine.file.clone();
    let (record, second) = (trace.trace.clone(), second.map(|t| t.trace.clone()));
    let at = measured_at;
    detached(py, move || {
        if !(evidence.is_finite() && evidence >= 0.0) {
            return Err(Failure::Usage(format!("evidence {evidence}: a number ≥ 0")));
        }
        if !(command_tolerance_um.is_finite() && command_tolerance_um > 0.0) {
            return Err(Failure::Usage(format!(
                "command_tolerance_um {command_tolerance_um}: a number > 0"
            )));
        }
        let program = program_or_commands(program, &record)?;
        let mut settings = DiagnoseSettings::for_machine(&config);
        settings.compare.check = plan_settings(&config, profile.as_deref(), cycle_ms, None)?;
        settings.max_causes = max_causes;
        settings.evidence = evidence;
        settings.compare.align_stretches = align_stretches;
        settings.compare.measured_at = self::measured_at(&at)?;
        settings.compare.command_tolerance_m = command_tolerance_um * 1e-6;
        settings.causes = match &causes {
            Some(names) => CauseSet::of(&cause_ids(names)?),
            None => CauseSet::ALL,
        }
        .without(&cause_ids(&exclude.unwrap_or_default())?);
        let diagnosis = contourcheck::diagnose_validated(
            &program,
            &config,
            &record,
            second.as_deref(),
            &settings,
        )?;
        let report = DiagnoseReport::new(&diagnosis, &program.file, &record, &config);
        Ok(DiagnoseOutcome {
            diagnosis,
            report,
            machine_file,
        })
    })
}

#[pymethods]
impl DiagnoseOutcome {
    /// The JSON report (schema `contourcheck.diagnose/1`).
    fn report_json(&self) -> String {
        json(&self.report)
    }

    /// The extended machine as a machine file (`diagnose --write-machine`).
    fn machine_toml(&self) -> String {
        self.diagnosis
            .machine_file(&self.report.program, &self.report.measured.file)
    }

    /// The one-page HTML report (`diagnose --report`).
    fn html(&self, py: Python<'_>) -> PyResult<String> {
        let inputs = ReportInputs {
            machine_file: self.machine_file.clone(),
        };
        contourcheck::diagnose_page(&self.diagnosis, &self.report, &inputs)
            .map_err(|e| Failure::from(e).into_py(py))
    }
}

/// An identification: its values, the identified machine and the page.
#[pyclass(frozen, module = "contourcheck._native")]
pub struct IdentifyOutcome {
    identification: Identification,
    template: MachineConfig,
    template_file: Option<String>,
    program_file: String,
}

/// A machine fitted to a record with its commands (`identify`), from `template`, or with
/// None a model of each loop from command to position.
#[pyfunction]
#[pyo3(signature = (
    program, template, trace, command_tolerance_um = 25.0, profile = None, cycle_ms = None,
    measured_at = "table".to_string()
))]
#[allow(clippy::too_many_arguments)] // one per keyword of the Python function
pub fn identify(
    py: Python<'_>,
    program: Option<&Program>,
    template: Option<&Machine>,
    trace: &Trace,
    command_tolerance_um: f64,
    profile: Option<String>,
    cycle_ms: Option<f64>,
    measured_at: String,
) -> PyResult<IdentifyOutcome> {
    let program = program.map(|p| p.program.clone());
    let given = template.map(|m| (m.config.clone(), m.file.clone()));
    let without_template = given.is_none();
    let record = trace.trace.clone();
    detached(py, move || {
        if !(command_tolerance_um.is_finite() && command_tolerance_um > 0.0) {
            return Err(Failure::Usage(format!(
                "command_tolerance_um {command_tolerance_um}: a number > 0"
            )));
        }
        let (template, template_file) = match given {
            Some((config, file)) => ((*config).clone(), file),
            None => (contourcheck::loop_template(&record), None),
        };
        let program = program_or_commands(program, &record)?;
        let mut settings = CompareSettings::for_machine(&template);
        settings.check = plan_settings(&template, profile.as_deref(), cycle_ms, None)?;
        settings.command_tolerance_m = command_tolerance_um * 1e-6;
        settings.measured_at = self::measured_at(&measured_at)?;
        let identification = if without_template {
            contourcheck::identify_loop(&program, &template, &record, &settings)?
        } else {
            contourcheck::identify(&program, &template, &record, &settings)?
        };
        Ok(IdentifyOutcome {
            identification,
            template,
            template_file,
            program_file: program.file.clone(),
        })
    })
}

#[pymethods]
impl IdentifyOutcome {
    /// The JSON report (schema `contourcheck.identify/1`).
    fn report_json(&self) -> String {
        json(&self.report())
    }

    /// The identified machine as a machine file (`identify --out`).
    fn machine_toml(&self) -> String {
        self.identification
            .machine_file(&self.template, &self.program_file)
    }

    /// The one-page HTML report (`identify --report`).
    fn html(&self, py: Python<'_>) -> PyResult<String> {
        let inputs = ReportInputs {
            machine_file: self.template_file.clone(),
        };
        contourcheck::identify_page(&self.report(), &inputs)
            .map_err(|e| Failure::from(e).into_py(py))
    }
}

impl IdentifyOutcome {
    fn report(&self) -> IdentifyReport<'_> {
        IdentifyReport::new(
            &self.identification,
            &self.program_file,
            &self.template.name,
        )
    }
}
