//! What several commands share: loading the machine and the program, planning settings,
//! formatting.

use std::path::{Path, PathBuf};

use clap::Args;

use crate::cli::output::OutputError;
use crate::gcode::{GcodeErrors, InterpretOptions, Program, parse_program};
use crate::machine::{ConfigError, MachineConfig};
use crate::numeric::units::{m_from_mm, s_from_ms};
use crate::path::{Motion, Segment};
use crate::plan::{PlanConfig, ProfileKind};
use crate::plot::Footer;

/// Errors a command can end with.
#[derive(Debug, thiserror::Error)]
pub enum CliError {
    /// The program has G-code errors.
    #[error("{0}")]
    Gcode(#[from] GcodeErrors),
    /// The machine file is wrong.
    #[error("{0}")]
    Config(#[from] ConfigError),
    /// An output could not be written.
    #[error("{0}")]
    Output(#[from] OutputError),
    /// The simulation could not run (unstable gains, divergence).
    #[error("{0}")]
    Sim(#[from] crate::sim::SimError),
    /// An input file could not be read.
    #[error("{path}: {message}")]
    Read {
        /// The file.
        path: String,
        /// Why.
        message: String,
    },
    /// The program does not fit the machine (no XY motion, outside travel).
    #[error("{0}")]
    Envelope(#[from] crate::check::envelope::EnvelopeError),
    /// Measured data is unreadable or malformed.
    #[error("{0}")]
    Measured(#[from] crate::trace::measured::MeasuredError),
    /// A diagnosis could not be made.
    #[error("{0}")]
    Diagnose(#[from] crate::diagnose::DiagnoseError),
    /// A table of steady following errors does not fit the machine.
    #[error("{file}: {source}")]
    Table {
        /// The table.
        file: String,
        /// Why.
        source: crate::diagnose::table::TableError,
    },
    /// A machine could not be identified.
    #[error("{0}")]
    Identify(#[from] crate::identify::IdentifyError),
    /// An HTML report could not be made.
    #[error("{0}")]
    Report(#[from] crate::html_report::HtmlError),
    /// Arguments that make no sense together.
    #[error("{0}")]
    Usage(String),
}

/// `--machine FILE|PRESET`.
#[derive(Debug, Args)]
pub struct MachineArgs {
    /// Machine file (TOML), or an embedded preset's name (`hvmc`, `small-table`); default:
    /// the `hvmc` preset.
    #[arg(long, value_name = "FILE|PRESET")]
    pub machine: Option<PathBuf>,
}

impl MachineArgs {
    /// The machine to use: a file where one exists by that name, else a preset.
    pub(crate) fn load(&self) -> Result<MachineConfig, CliError> {
        self.load_given_as("--machine")
    }

    /// [`MachineArgs::load`] for a machine given by another `option` (`--template`), which
    /// an error names.
    pub(crate) fn load_given_as(&self, option: &str) -> Result<MachineConfig, CliError> {
        match &self.machine {
            Some(path) if !path.exists() && is_preset_name(path) => {
                Ok(MachineConfig::preset(&path.to_string_lossy())?)
            }
            Some(path) if !path.exists() => Err(CliError::Usage(no_such_machine(option, path))),
            Some(path) => {
                let (machine, warnings) = MachineConfig::load_with_warnings(path)?;
                for w in warnings {
                    eprintln!("warning: {w}");
                }
                Ok(machine)
            }
            None => Ok(MachineConfig::default_preset()),
        }
    }
}

/// A machine given by `option` that is neither a file nor a preset: the presets there are,
/// and the one meant where the name is close to one.
fn no_such_machine(option: &str, path: &std::path::Path) -> String {
    let name = path.to_string_lossy();
    let presets: Vec<&str> = crate::machine::PRESETS.iter().map(|(n, _)| *n).collect();
    let nearest = presets
        .iter()
        .map(|p| (strsim::levenshtein(&name, p), *p))
        .min_by_key(|(d, _)| *d)
        .filter(|(d, _)| *d <= 2)
        .map_or(String::new(), |(_, p)| format!("; did you mean `{p}`?"));
    format!(
        "{option} {name}: no such file, and no embedded preset of that name (presets: {}){nearest}",
        presets.join(", ")
    )
}

impl MachineArgs {
    /// What an HTML report says of the machine's source: the file given, if one was.
    pub(crate) fn report_inputs(&self) -> crate::html_report::Inputs {
        crate::html_report::Inputs {
            machine_file: self
                .machine
                .as_ref()
                .filter(|p| p.exists())
                .map(|p| p.display().to_string()),
        }
    }

    /// The machine, refused when an axis's loops are unstable, with the setting that makes
    /// them so and the range in which it is stable (for commands that simulate; `bode` and
    /// `sweep` show unstable settings instead).
    pub(crate) fn load_stable(&self) -> Result<MachineConfig, CliError> {
        let machine = self.load()?;
        let file = self
            .machine
            .as_ref()
            .map_or("the hvmc preset".to_string(), |p| p.display().to_string());
        for axis in machine.simulated_axes() {
            let config = machine.axis(axis);
            let model = crate::sim::AxisModel::from_config(config);
            if let Err(e) = crate::sim::linear::check_stable(&model) {
                return Err(CliError::Usage(unstable_advice(&file, axis, config, &e)));
            }
        }
        Ok(machine)
    }
}

/// What to change where when an axis's loops are unstable.
fn unstable_advice(
    file: &str,
    axis: crate::machine::AxisName,
    config: &crate::machine::AxisConfig,
    e: &crate::sim::SimError,
) -> String {
    let growing = match e {
        crate::sim::SimError::Unstable {
            frequency_hz,
            growth_per_s,
        } => format!("a closed-loop mode at {frequency_hz:.1} Hz grows at {growth_per_s:.3} 1/s"),
        other => other.to_string(),
    };
    let key = format!("{}.position_loop.kv_m_per_min_per_mm", axis.as_str());
    let what_to_do = match crate::sim::linear::largest_stable_kv(config) {
        Some(kv_max) => format!(
            "with its other settings held, {key} (here {}) is stable below {kv_max:.3} m/min/mm",
            config.position_loop.kv_m_per_min_per_mm
        ),
        None if config.controller.is_cascade() => format!(
            "no position gain {key} makes it stable: the velocity loop's \
             (velocity_loop.ks_nm_s_per_rad, ts_ms) or the current loop's settings are what to \
             change"
        ),
        None => format!(
            "its controller's gains in [{}.controller] are what to change",
            axis.as_str()
        ),
    };
    format!(
        "{file}: the {} axis is unstable with these settings: {growing}; {what_to_do}",
        axis.letter()
    )
}

fn is_preset_name(path: &std::path::Path) -> bool {
    let name = path.to_string_lossy();
    crate::machine::PRESETS.iter().any(|(n, _)| *n == name)
}

/// Planner flags.
#[derive(Debug, Args)]
pub struct PlanningArgs {
    /// Speed profile (`ideal`: the programmed feed from the first instant, as in the paper's
    /// experiments).
    #[arg(long, default_value = "s-curve", value_name = "KIND")]
    pub profile: ProfileKind,
    /// Interpolation cycle in ms (default: the machine's).
    #[arg(long, value_name = "MS")]
    pub cycle_ms: Option<f64>,
    /// Corner tolerance under G64 without P, in mm.
    #[arg(long, default_value_t = 0.01, value_name = "MM")]
    pub blend_tolerance_mm: f64,
}

impl PlanningArgs {
    /// Validated planner settings.
    pub(crate) fn config(&self, machine: &MachineConfig) -> Result<PlanConfig, CliError> {
        let mut c = PlanConfig::for_machine(machine);
        c.profile = self.profile;
        if let Some(ms) = self.cycle_ms {
            if !(ms.is_finite() && (0.05..=100.0).contains(&ms)) {
                return Err(CliError::Usage(format!(
                    "--cycle-ms {ms}: must lie between 0.05 and 100"
                )));
            }
            c.cycle_s = s_from_ms(ms);
        }
        let tol = self.blend_tolerance_mm;
        if !(tol.is_finite() && tol > 0.0) {
            return Err(CliError::Usage(format!(
                "--blend-tolerance-mm {tol}: must be positive"
            )));
        }
        c.default_blend_tolerance_m = m_from_mm(tol);
        Ok(c)
    }
}

/// Reads and interprets a program (bytes that are not UTF-8, in comments say, are replaced)
/// and checks that it fits the machine (it moves in XY, within travel).
pub(crate) fn load_program(path: &Path, machine: &MachineConfig) -> Result<Program, CliError> {
    let bytes = std::fs::read(path).map_err(|e| CliError::Read {
        path: path.display().to_string(),
        message: e.to_string(),
    })?;
    let text = String::from_utf8_lossy(&bytes);
    let options = InterpretOptions {
        dialect: DIALECT.get().copied(),
        subprogram_folder: path.parent().map(|p| {
            if p.as_os_str().is_empty() {
                Path::new(".")
            } else {
                p
            }
            .to_path_buf()
        }),
        ..InterpretOptions::default()
    };
    let program = parse_program(&text, &path.display().to_string(), &options)?;
    crate::check::envelope::check_fits(&program, machine)?;
    Ok(program)
}

/// "1 h 02 min 03.4 s" style durations.
pub(crate) fn format_duration(seconds: f64) -> String {
    let h = (seconds / 3600.0).floor();
    let m = ((seconds - h * 3600.0) / 60.0).floor();
    let s = seconds - h * 3600.0 - m * 60.0;
    if h > 0.0 {
        format!("{h:.0} h {m:02.0} min {s:04.1} s")
    } else if m > 0.0 {
        format!("{m:.0} min {s:04.1} s")
    } else {
        format!("{s:.2} s")
    }
}

/// A progress bar on a terminal; hidden when stderr is piped or under CI.
pub(crate) fn progress(len: u64, message: &str) -> indicatif::ProgressBar {
    use std::io::IsTerminal;
    let quiet = !std::io::stderr().is_terminal() || std::env::var_os("CI").is_some();
    if quiet {
        return indicatif::ProgressBar::hidden();
    }
    let bar = indicatif::ProgressBar::new(len);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{msg} [{bar:40}] {pos}/{len} ({eta})")
            .expect("a valid template")
            .progress_chars("=> "),
    );
    bar.set_message(message.to_string());
    bar
}

/// A spinner for work of unknown length on a terminal; hidden when piped or under CI.
pub(crate) fn spinner(message: &str) -> indicatif::ProgressBar {
    let bar = progress(0, message);
    if bar.is_hidden() {
        return bar;
    }
    let spin = indicatif::ProgressBar::new_spinner();
    spin.set_message(message.to_string());
    spin.enable_steady_tick(std::time::Duration::from_millis(120));
    spin
}

/// How to read a measured trace's columns.
#[derive(Debug, Args)]
pub struct TraceArgs {
    /// Which column is what, with units: `t=Time[ms],x=X_ActPos[mm],y=Y_ActPos[mm],
    /// x_cmd=X_Traj,y_cmd=Y_Traj` (time s|ms|us|min; lengths m|mm|um|in|counts:0.1um).
    /// Without it the usual spellings are recognised and the units read from the header.
    #[arg(long, value_name = "MAP", conflicts_with = "trace_profile")]
    pub columns: Option<String>,
    /// A TOML trace profile holding `columns = "…"`, written once per control or lab system.
    #[arg(long, value_name = "FILE")]
    pub trace_profile: Option<PathBuf>,
    /// The program origin in the trace's coordinates, `X,Y` in mm (a trace in machine
    /// coordinates of a program run under a work offset G54…): subtracted from every
    /// measured and commanded position.
    #[arg(long, value_name = "X,Y", allow_hyphen_values = true)]
    pub work_offset: Option<String>,
}

impl TraceArgs {
    /// Reads the trace at `path` as these arguments say.
    pub(crate) fn read(
        &self,
        path: &Path,
    ) -> Result<crate::trace::measured::MeasuredTrace, CliError> {
        use crate::trace::format::{ColumnMap, TraceProfile};
        let map = match (&self.columns, &self.trace_profile) {
            (Some(text), _) => Some(
                ColumnMap::parse(text).map_err(|e| CliError::Usage(format!("--columns: {e}")))?,
            ),
            (None, Some(profile)) => {
                Some(TraceProfile::load(profile).map_err(|e| CliError::Usage(e.to_string()))?)
            }
            (None, None) => None,
        };
        let trace = crate::trace::measured::read_trace_with(path, map.as_ref())?;
        let mut trace = match &self.work_offset {
            Some(text) => trace.in_work_coordinates(work_offset_m(text)?),
            None => trace,
        };
        let spikes = trace.bridge_spikes();
        for s in spikes.iter().take(SPIKES_SAID) {
            eprintln!(
                "warning: {}: measured {} at {:.6} s lies {:.1} µm off both its neighbours, \
                 beyond any axis's acceleration over one sample and back: a misread sample, \
                 bridged by their mean",
                trace.file,
                s.signal.to_uppercase(),
                s.t_s,
                s.off_m * 1e6
            );
        }
        if spikes.len() > SPIKES_SAID {
            eprintln!(
                "warning: {}: {} more misread samples bridged the same way",
                trace.file,
                spikes.len() - SPIKES_SAID
            );
        }
        Ok(trace)
    }
}

/// How many misread samples are said one by one; the rest are counted.
const SPIKES_SAID: usize = 5;

/// The largest work offset taken (mm, each axis): as far as a machine file's travel may
/// reach.
const MAX_WORK_OFFSET_MM: f64 = crate::machine::MAX_TRAVEL_MM;

/// `--work-offset X,Y` (mm) in metres.
fn work_offset_m(text: &str) -> Result<[f64; 2], CliError> {
    let values: Vec<Option<f64>> = text
        .split(',')
        .map(|v| v.trim().parse::<f64>().ok())
        .map(|v| v.filter(|v| v.abs() <= MAX_WORK_OFFSET_MM))
        .collect();
    match values.as_slice() {
        [Some(x), Some(y)] => Ok([x * 1e-3, y * 1e-3]),
        _ => Err(CliError::Usage(format!(
            "--work-offset '{text}': give X,Y in mm, each within ±{MAX_WORK_OFFSET_MM} (beyond \
             any machine's travel), e.g. --work-offset 471.103,-250"
        ))),
    }
}

/// `--axis x|y`.
#[derive(Debug, Args)]
pub struct AxisArg {
    /// Which simulated axis.
    #[arg(long, default_value = "x", value_name = "AXIS")]
    pub axis: crate::machine::AxisName,
}

/// Writes a figure into the `--plot` directory (made if missing) as `<stem>.png` and
/// `<stem>.svg`, whole or not at all, and says so on stdout — as every command's `--plot DIR`
/// does.
pub(crate) fn write_plots_into(
    dir: &Path,
    stem: &str,
    figure: &impl crate::plot::Figure,
    footer: &Footer,
) -> Result<(), CliError> {
    let mut batch = crate::cli::output::OutputBatch::new();
    let paths = stage_plots_into(&mut batch, dir, stem, figure, footer)?;
    batch.commit()?;
    for path in &paths {
        println!("plot: {}", path.display());
    }
    Ok(())
}

/// Stages a figure as `<stem>.png` and `<stem>.svg` in the `--plot` directory (made if
/// missing) into `batch`, to become visible with the command's other outputs; their paths.
pub(crate) fn stage_plots_into(
    batch: &mut crate::cli::output::OutputBatch,
    dir: &Path,
    stem: &str,
    figure: &impl crate::plot::Figure,
    footer: &Footer,
) -> Result<Vec<std::path::PathBuf>, CliError> {
    std::fs::create_dir_all(dir).map_err(|e| CliError::Read {
        path: dir.display().to_string(),
        message: e.to_string(),
    })?;
    let paths: Vec<std::path::PathBuf> = ["png", "svg"]
        .map(|ext| dir.join(format!("{stem}.{ext}")))
        .into();
    for path in &paths {
        batch.stage_with_path(path, |tmp| crate::plot::render(tmp, figure, footer))?;
    }
    Ok(paths)
}

/// Says, before any fitting, where a record's commands ask more of the machine than its file
/// allows: the fit that follows cannot make the model follow there.
pub(crate) fn warn_beyond_machine(
    measured: &crate::trace::measured::MeasuredTrace,
    machine: &crate::machine::MachineConfig,
) {
    for beyond in measured.beyond_machine(machine) {
        eprintln!("warning: {beyond}");
    }
}

/// The program a record ran, read from `path`; or, without one, the path the record's
/// commands drew (see [`crate::trace::recorded::program_from_commands`]), said on stderr.
pub(crate) fn program_or_commands_path(
    path: Option<&Path>,
    measured: &crate::trace::measured::MeasuredTrace,
    machine: &MachineConfig,
) -> Result<Program, CliError> {
    if let Some(path) = path {
        return load_program(path, machine);
    }
    let Some(commands) = &measured.commands else {
        return Err(CliError::Usage(format!(
            "{}: no program given and no commands recorded (x_cmd, y_cmd): give the program \
             the record ran, or a record with its commands",
            measured.file
        )));
    };
    let program =
        crate::trace::recorded::program_from_commands(commands, measured.dt_s, &measured.file)
            .ok_or_else(|| {
                CliError::Usage(format!(
                    "{}: no program given, and the recorded commands do not move: there is no \
                     path to compare with",
                    measured.file
                ))
            })?;
    eprintln!(
        "{}: no program given: compared with the path its commands drew, {} lines within \
         {:.1} µm of them (places are named by the record's sample where a line starts)",
        measured.file,
        program.segments.len(),
        crate::trace::recorded::COMMANDS_PATH_TOLERANCE_M * 1e6
    );
    Ok(program)
}

/// The values the command line accepts for the library's enumerations, each listed in
/// `--help` as the machine file and the reports spell it.
impl clap::ValueEnum for crate::gcode::Dialect {
    fn value_variants<'a>() -> &'a [Self] {
        &[
            crate::gcode::Dialect::Rs274,
            crate::gcode::Dialect::Sinumerik,
        ]
    }

    fn to_possible_value(&self) -> Option<clap::builder::PossibleValue> {
        Some(clap::builder::PossibleValue::new(match self {
            crate::gcode::Dialect::Rs274 => "rs274",
            crate::gcode::Dialect::Sinumerik => "sinumerik",
        }))
    }
}

/// The dialect `--dialect` names for every program read, once the arguments are parsed;
/// unset, each program's dialect is told from its file.
static DIALECT: std::sync::OnceLock<crate::gcode::Dialect> = std::sync::OnceLock::new();

/// Sets the dialect of the programs this run reads (`--dialect`).
pub(crate) fn set_dialect(dialect: crate::gcode::Dialect) {
    let _ = DIALECT.set(dialect);
}

impl clap::ValueEnum for crate::diagnose::causes::CauseId {
    fn value_variants<'a>() -> &'a [Self] {
        &crate::diagnose::causes::CauseId::ALL
    }

    fn to_possible_value(&self) -> Option<clap::builder::PossibleValue> {
        Some(clap::builder::PossibleValue::new(self.as_str()))
    }
}

impl clap::ValueEnum for crate::plan::ProfileKind {
    fn value_variants<'a>() -> &'a [Self] {
        use crate::plan::ProfileKind;
        &[
            ProfileKind::SCurve,
            ProfileKind::Trapezoid,
            ProfileKind::Ideal,
        ]
    }

    fn to_possible_value(&self) -> Option<clap::builder::PossibleValue> {
        let (name, help) = match self {
            crate::plan::ProfileKind::SCurve => ("s-curve", "jerk-limited"),
            crate::plan::ProfileKind::Trapezoid => ("trapezoid", "acceleration-limited, as BRISK"),
            crate::plan::ProfileKind::Ideal => {
                ("ideal", "the programmed feed from the first instant")
            }
        };
        Some(clap::builder::PossibleValue::new(name).help(help))
    }
}

impl clap::ValueEnum for crate::machine::AxisName {
    fn value_variants<'a>() -> &'a [Self] {
        &crate::machine::AxisName::BOTH
    }

    fn to_possible_value(&self) -> Option<clap::builder::PossibleValue> {
        Some(clap::builder::PossibleValue::new(self.as_str()))
    }
}

/// The programmed feed of the cutting moves as a footer gives it: `F 1000 mm/min`, or the
/// range `F 500–1000 mm/min`; empty for a program without feed moves.
pub(crate) fn feed_text(segments: &[Segment]) -> String {
    let feeds = segments
        .iter()
        .filter(|s| s.motion == Motion::Feed && !s.is_dwell() && s.feed_m_per_s > 0.0)
        .map(|s| crate::numeric::units::mm_per_min_from_m_per_s(s.feed_m_per_s));
    let (lo, hi) = feeds.fold((f64::INFINITY, 0.0f64), |(a, b), f| (a.min(f), b.max(f)));
    let round = |f: f64| format!("{}", (f * 10.0).round() / 10.0);
    if hi == 0.0 {
        String::new()
    } else if hi - lo < 0.05 {
        format!("F {} mm/min", round(hi))
    } else {
        format!("F {}–{} mm/min", round(lo), round(hi))
    }
}

/// A plot's footer for a run of `segments` on `machine` from `program`, sampled at the
/// interpolation cycle `cycle_s`.
pub(crate) fn run_footer(
    machine: &str,
    program: &str,
    segments: &[Segment],
    cycle_s: f64,
) -> Footer {
    Footer::new(machine)
        .program(program)
        .feed(feed_text(segments))
        .sampling(format!("IPO cycle {} ms", (cycle_s * 1e6).round() / 1e3))
}

/// What `--plot` says of each circle it draws no polar plot of: its line and why, as the
/// HTML page says it.
pub(crate) fn not_drawn_notes(circles: &[crate::figures::NotDrawn]) -> Vec<String> {
    circles
        .iter()
        .map(|c| format!("plot: circle of {c}"))
        .collect()
}
