//! `contourcheck sweep`: a grid of gain (or any numeric machine) settings on one program,
//! ranked by contour error; unstable settings flagged.

use std::io::Write;
use std::path::{Path, PathBuf};

use clap::{ArgAction, ArgMatches, Args};
use serde::Serialize;

use super::Outcome;
use super::common::{
    CliError, MachineArgs, PlanningArgs, load_program, progress, write_plots_into,
};
use crate::cli::output::OutputBatch;
use crate::machine::MachineConfig;
use crate::plot::sweep::{SweepHeatMap, SweepLinePlot};
use crate::sweep::{self, Dimension, PointResult, SweepPoint};

/// Arguments of `sweep`.
#[derive(Debug, Args)]
pub struct SweepArgs {
    /// The part program.
    pub program: PathBuf,
    #[command(flatten)]
    pub machine: MachineArgs,
    #[command(flatten)]
    pub planning: PlanningArgs,
    /// Axis the --kv/--ks/--ff after it apply to: x, y, or xy (both, matched). Give --axis
    /// again to sweep another axis independently.
    #[arg(long, action = ArgAction::Append, value_name = "x|y|xy")]
    pub axis: Vec<String>,
    /// Position gain values, m/min/mm: from:to:step or a,b,c.
    #[arg(long, action = ArgAction::Append, value_name = "RANGE", allow_hyphen_values = true)]
    pub kv: Vec<String>,
    /// Velocity gain values, N·m·s/rad.
    #[arg(long, action = ArgAction::Append, value_name = "RANGE")]
    pub ks: Vec<String>,
    /// Velocity feed-forward: on, off or both (on,off).
    #[arg(long, action = ArgAction::Append, value_name = "on,off")]
    pub ff: Vec<String>,
    /// Any numeric machine key: AXIS.KEY=RANGE, e.g. x.backlash_um=0:20:5 or
    /// xy.drive.zeta_m=0.02,0.05 (xy: both axes, matched).
    #[arg(long = "set", action = ArgAction::Append, value_name = "AXIS.KEY=RANGE")]
    pub set: Vec<String>,
    /// Write every setting's figures as CSV.
    #[arg(long, value_name = "FILE")]
    pub csv: Option<PathBuf>,
    /// Write the sweep as JSON (schema contourcheck.sweep/1).
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
    /// Write the plot (PNG and SVG) into this directory: error against the parameter for one
    /// swept dimension, a heat map for two.
    #[arg(long, value_name = "DIR")]
    pub plot: Option<PathBuf>,
    /// Run the settings one after another instead of in parallel.
    #[arg(long)]
    pub serial: bool,
    /// Settings listed on the terminal.
    #[arg(long, default_value_t = 20, value_name = "N")]
    pub rows: usize,
    /// Least closed-loop damping ratio of a healthy setting: below it a setting is flagged
    /// "poorly damped" and ranked after every healthy one, whatever its contour error.
    #[arg(long, default_value_t = crate::sweep::POOR_DAMPING, value_name = "ZETA")]
    pub min_damping: f64,
}

/// The axis an occurrence of `arg` belongs to: the last --axis given before it.
fn axes_of(m: &ArgMatches, arg: &str) -> Vec<String> {
    let axes: Vec<(usize, String)> = match (m.indices_of("axis"), m.get_many::<String>("axis")) {
        (Some(i), Some(v)) => i.zip(v.cloned()).collect(),
        _ => Vec::new(),
    };
    m.indices_of(arg)
        .map(|idx| {
            idx.map(|i| {
                axes.iter()
                    .rev()
                    .find(|(j, _)| *j < i)
                    .map_or_else(|| "x".to_string(), |(_, a)| a.clone())
            })
            .collect()
        })
        .unwrap_or_default()
}

fn axis_prefixes(spec: &str) -> Result<Vec<&'static str>, CliError> {
    match spec.to_ascii_lowercase().as_str() {
        "x" => Ok(vec!["x"]),
        "y" => Ok(vec!["y"]),
        "xy" | "yx" | "both" => Ok(vec!["x", "y"]),
        other => Err(CliError::Usage(format!("--axis {other}: x, y or xy"))),
    }
}

fn dimensions(
    args: &SweepArgs,
    m: &ArgMatches,
    machine: &MachineConfig,
) -> Result<Vec<Dimension>, CliError> {
    let usage = CliError::Usage;
    let mut dims = Vec::new();
    let shortcuts: [(&str, &Vec<String>, &str); 3] = [
        ("kv", &args.kv, "position_loop.kv_m_per_min_per_mm"),
        ("ks", &args.ks, "velocity_loop.ks_nm_s_per_rad"),
        ("ff", &args.ff, "position_loop.velocity_feedforward"),
    ];
    for (name, ranges, key) in shortcuts {
        for (range, axis) in ranges.iter().zip(axes_of(m, name)) {
            let values = if name == "ff" {
                on_off(range)?
            } else {
                sweep::parse_range(range).map_err(|e| usage(e.to_string()))?
            };
            let prefixes = axis_prefixes(&axis)?;
            dims.push(Dimension {
                name: format!("{axis}.{name}"),
                keys: prefixes.iter().map(|p| format!("{p}.{key}")).collect(),
                values,
            });
        }
    }
    for item in &args.set {
        let (key, range) = item
            .split_once('=')
            .ok_or_else(|| usage(format!("--set {item}: AXIS.KEY=RANGE")))?;
        let (axis, rest) = key
            .split_once('.')
            .ok_or_else(|| usage(format!("--set {item}: name the axis, e.g. x.{key}")))?;
        let keys = axis_prefixes(axis)?
            .iter()
            .map(|p| {
                sweep::resolve_key(machine, &format!("{p}.{rest}"))
                    .map_err(|e| usage(e.to_string()))
            })
            .collect::<Result<Vec<_>, _>>()?;
        dims.push(Dimension {
            name: key.to_string(),
            keys,
            values: sweep::parse_range(range).map_err(|e| usage(e.to_string()))?,
        });
    }
    if dims.is_empty() {
        return Err(usage(
            "nothing to sweep: give --kv, --ks, --ff or --set".into(),
        ));
    }
    let points: usize = dims.iter().map(|d| d.values.len()).product();
    if points > 100_000 {
        return Err(usage(format!("{points} settings: more than 100000")));
    }
    Ok(dims)
}

fn on_off(text: &str) -> Result<Vec<f64>, CliError> {
    text.split(',')
        .map(|v| match v.trim() {
            "on" | "1" => Ok(1.0),
            "off" | "0" => Ok(0.0),
            other => Err(CliError::Usage(format!("--ff {other}: on or off"))),
        })
        .collect()
}

pub fn run(args: &SweepArgs, m: &ArgMatches) -> Result<Outcome, CliError> {
    let machine = args.machine.load()?;
    let plan = args.planning.config(&machine)?;
    let program = load_program(&args.program, &machine)?;
    let dims = dimensions(args, m, &machine)?;
    let total: usize = dims.iter().map(|d| d.values.len()).product();
    let bar = progress(total as u64, "sweep");
    let mut points = sweep::run(&program, &machine, &plan, &dims, !args.serial, &|| {
        bar.inc(1)
    });
    bar.finish_and_clear();
    if !(args.min_damping.is_finite() && (0.0..1.0).contains(&args.min_damping)) {
        return Err(CliError::Usage(format!(
            "--min-damping {}: a damping ratio from 0 up to 1",
            args.min_damping
        )));
    }
    crate::sweep::rank(&mut points, args.min_damping);
    let mut batch = OutputBatch::new();
    if let Some(path) = &args.csv {
        batch.stage(path, |w| write_csv(w, &dims, &points))?;
    }
    if let Some(path) = &args.json {
        let doc = SweepJson {
            schema: "contourcheck.sweep/1",
            program: &program.file,
            machine: &machine.name,
            dimensions: &dims,
            points: &points,
        };
        batch.stage(path, |w| {
            serde_json::to_writer_pretty(&mut *w, &doc).map_err(std::io::Error::other)?;
            writeln!(w)
        })?;
    }
    batch.commit()?;
    if let Some(dir) = &args.plot {
        plot(dir, &program.file, &dims, &points)?;
    }
    print_table(
        &program.file,
        &machine.name,
        &dims,
        &points,
        args.rows,
        args.min_damping,
    );
    Ok(Outcome::Ok)
}

#[derive(Serialize)]
struct SweepJson<'a> {
    schema: &'static str,
    program: &'a str,
    machine: &'a str,
    dimensions: &'a [Dimension],
    points: &'a [SweepPoint],
}

fn print_table(
    program: &str,
    machine: &str,
    dims: &[Dimension],
    points: &[SweepPoint],
    rows: usize,
    min_damping: f64,
) {
    println!(
        "sweep of {program} on {machine}: {} settings, ranked by the largest contour error; \
         settings whose loops leave a mode damped below ζ {min_damping} and below the \
         mechanics' own ranked after the healthy ones",
        points.len()
    );
    let head: Vec<String> = dims.iter().map(|d| format!("{:>10}", d.name)).collect();
    println!(
        "  rank {}  max contour µm  RMS µm  FE X µm  FE Y µm  overshoot µm  ripple µm  damping",
        head.join(" ")
    );
    for (i, p) in points.iter().enumerate().take(rows) {
        let values: Vec<String> = p.values.iter().map(|v| format!("{v:>10.4}")).collect();
        let figures = match &p.result {
            PointResult::Ok {
                metrics: m,
                least_damping,
                poorly_damped,
                ..
            } => format!(
                "{:>14.2}  {:>6.2}  {:>7.1}  {:>7.1}  {:>12.2}  {:>9.3}  {:>7.4}{}",
                m.max_contour_um,
                m.rms_contour_um,
                m.max_following_um[0],
                m.max_following_um[1],
                m.overshoot_um,
                m.ripple_um,
                least_damping,
                if *poorly_damped {
                    "  poorly damped: ranked after the healthy settings"
                } else {
                    ""
                }
            ),
            PointResult::Unstable { axis, frequency_hz } => {
                format!("  unstable: {axis} axis, growing mode at {frequency_hz:.1} Hz")
            }
            PointResult::Invalid { reason } => format!("  invalid: {reason}"),
        };
        let best = if i == 0
            && matches!(
                p.result,
                PointResult::Ok {
                    poorly_damped: false,
                    ..
                }
            ) {
            "  ◀ best"
        } else {
            ""
        };
        println!("  {:>4} {}  {figures}{best}", i + 1, values.join(" "));
    }
    if points.len() > rows {
        println!("  … {} more (--rows, --csv, --json)", points.len() - rows);
    }
}

fn write_csv(w: &mut dyn Write, dims: &[Dimension], points: &[SweepPoint]) -> std::io::Result<()> {
    let mut out = csv::Writer::from_writer(w);
    let mut header: Vec<String> = dims.iter().map(|d| d.name.clone()).collect();
    header.extend(
        [
            "status",
            "max_contour_um",
            "rms_contour_um",
            "max_fe_x_um",
            "max_fe_y_um",
            "overshoot_um",
            "ripple_um",
            "least_damping",
        ]
        .map(String::from),
    );
    out.write_record(&header)?;
    for p in points {
        let mut row: Vec<String> = p.values.iter().map(|v| v.to_string()).collect();
        match &p.result {
            PointResult::Ok {
                metrics: m,
                least_damping,
                poorly_damped,
                ..
            } => {
                row.push(
                    if *poorly_damped {
                        "poorly_damped"
                    } else {
                        "ok"
                    }
                    .into(),
                );
                for v in [
                    m.max_contour_um,
                    m.rms_contour_um,
                    m.max_following_um[0],
                    m.max_following_um[1],
                    m.overshoot_um,
                    m.ripple_um,
                    *least_damping,
                ] {
                    row.push(format!("{v:.6}"));
                }
            }
            PointResult::Unstable { .. } => row.extend(
                std::iter::once("unstable".to_string())
                    .chain(std::iter::repeat_n(String::new(), 7)),
            ),
            PointResult::Invalid { .. } => row.extend(
                std::iter::once("invalid".to_string()).chain(std::iter::repeat_n(String::new(), 7)),
            ),
        }
        out.write_record(&row)?;
    }
    out.flush()
}

fn figure(p: &SweepPoint, pick: impl Fn(&crate::sweep::Metrics) -> f64) -> f64 {
    match &p.result {
        PointResult::Ok { metrics, .. } => pick(metrics),
        _ => f64::NAN,
    }
}

/// A swept dimension's name with the unit its machine key carries (the key table's), for a
/// plot's axis: `x.kv (m/min/mm)`; a ratio's name alone.
fn labelled(d: &Dimension) -> String {
    let key = d.keys.first().map_or("", String::as_str);
    match crate::machine::keys::unit_on_machine(key) {
        Some(unit) if !unit.is_empty() => format!("{} ({unit})", d.name),
        _ => d.name.clone(),
    }
}

fn plot(
    dir: &Path,
    program: &str,
    dims: &[Dimension],
    points: &[SweepPoint],
) -> Result<(), CliError> {
    let name = Path::new(program)
        .file_name()
        .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
    match dims {
        [d] => write_plots_into(dir, "sweep", &line_plot(&name, d, points))?,
        [a, b] => write_plots_into(dir, "sweep", &heat_map(&name, [a, b], points))?,
        _ => println!("(no plot for {} swept dimensions: use --csv)", dims.len()),
    }
    Ok(())
}

/// One swept dimension: the contour and following errors against it, unstable settings
/// marked.
fn line_plot(name: &str, d: &Dimension, points: &[SweepPoint]) -> SweepLinePlot {
    let mut sorted: Vec<&SweepPoint> = points.iter().collect();
    sorted.sort_by(|a, b| a.values[0].total_cmp(&b.values[0]));
    let series = |f: &dyn Fn(&crate::sweep::Metrics) -> f64| {
        sorted
            .iter()
            .map(|p| (p.values[0], figure(p, f)))
            .collect::<Vec<_>>()
    };
    SweepLinePlot {
        title: format!("{name}: error against {}", d.name),
        x_label: labelled(d),
        panels: vec![
            (
                "contour error (µm)".into(),
                vec![
                    ("max contour error".into(), series(&|m| m.max_contour_um)),
                    ("RMS contour error".into(), series(&|m| m.rms_contour_um)),
                ],
            ),
            (
                "following error (µm)".into(),
                vec![
                    (
                        "max following error X".into(),
                        series(&|m| m.max_following_um[0]),
                    ),
                    (
                        "max following error Y".into(),
                        series(&|m| m.max_following_um[1]),
                    ),
                ],
            ),
        ],
        unstable: sorted
            .iter()
            .filter(|p| matches!(p.result, PointResult::Unstable { .. }))
            .map(|p| p.values[0])
            .collect(),
    }
}

/// Two swept dimensions: the largest contour error over both.
fn heat_map(name: &str, [a, b]: [&Dimension; 2], points: &[SweepPoint]) -> SweepHeatMap {
    let cells = a
        .values
        .iter()
        .map(|va| {
            b.values
                .iter()
                .map(|vb| {
                    points
                        .iter()
                        .find(|p| p.values[0] == *va && p.values[1] == *vb)
                        .map_or(f64::NAN, |p| figure(p, |m| m.max_contour_um))
                })
                .collect()
        })
        .collect();
    SweepHeatMap {
        title: format!(
            "{name}: largest contour error over {} and {}",
            a.name, b.name
        ),
        labels: (labelled(a), labelled(b)),
        axes: (a.values.clone(), b.values.clone()),
        cells,
    }
}
