//! `contourcheck sweep`: a grid of gain (or any numeric machine) settings on one program,
//! ranked by contour error; unstable settings flagged.

use std::io::Write;
use std::path::{Path, PathBuf};

use clap::{ArgAction, ArgMatches, Args};
use serde::Serialize;

use super::Outcome;
use super::common::{
    CliError, MachineArgs, PlanningArgs, load_program, progress, stage_plots_into,
};
use crate::cli::output::{OutputBatch, outputs_apart};
use crate::machine::{AxisName, MachineConfig};
use crate::plot::Footer;
use crate::plot::sweep::{SweepHeatMap, SweepLinePlot};
use crate::sim::linear::Loop;
use crate::sim::margins::LoopMargins;
use crate::sweep::{self, Dimension, PointResult, SweepPoint, Thresholds};

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
    /// xy.drive.zeta_m=0.02,0.05 (xy: both axes, matched), z.limits.max_accel_m_per_s2=1,2 or
    /// interpolation.cycle_ms=1,2,4.
    #[arg(long = "set", action = ArgAction::Append, value_name = "AXIS.KEY=RANGE")]
    pub set: Vec<String>,
    /// Write every setting's figures as CSV.
    #[arg(long, value_name = "FILE")]
    pub csv: Option<PathBuf>,
    /// Write the sweep as JSON (schema contourcheck.sweep/2).
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
    /// Most settings a sweep runs (the product of every range's values): each simulates
    /// the whole program, so a step finer than meant is refused rather than run for hours.
    #[arg(long, default_value_t = 1000, value_name = "N")]
    pub max_settings: usize,
    /// Damping ratio below which a closed-loop mode flags a setting (ranked after every
    /// healthy one, whatever its contour error). A mode of the loops' own flags it below
    /// ZETA; a mode of the mechanics flags it only below both ZETA and half the damping the
    /// mechanics alone give it. The `loop damping` column shows the least damping of every
    /// mode the loops act on, flagged or not; that mode's axis and frequency are in the
    /// JSON (`loop_damping_at`), a flagged mode's in the row's flag.
    #[arg(long, default_value_t = crate::sweep::POOR_DAMPING, value_name = "ZETA")]
    pub min_damping: f64,
    /// Least phase margin of every loop of a healthy setting (degrees).
    #[arg(long, default_value_t = crate::sim::margins::MIN_PHASE_MARGIN_DEG, value_name = "DEG")]
    pub min_phase_margin: f64,
    /// Least gain margin of every loop of a healthy setting (dB).
    #[arg(long, default_value_t = crate::sim::margins::MIN_GAIN_MARGIN_DB, value_name = "DB")]
    pub min_gain_margin: f64,
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
            let keys: Vec<String> = prefixes.iter().map(|p| format!("{p}.{key}")).collect();
            refuse_twice(&dims, &keys, &format!("--{name} {range}"))?;
            dims.push(Dimension {
                name: format!("{axis}.{name}"),
                keys,
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
        // The interpolator's keys and Z's belong to the machine, not to an axis swept.
        let prefixes = match axis.to_ascii_lowercase().as_str() {
            "interpolation" => vec!["interpolation"],
            "z" => vec!["z"],
            _ => axis_prefixes(axis).map_err(|_| {
                usage(format!(
                    "--set {item}: a key of x., y., xy., z. or interpolation. (`{axis}` is none)"
                ))
            })?,
        };
        let keys = prefixes
            .iter()
            .map(|p| {
                sweep::resolve_key(machine, &format!("{p}.{rest}"))
                    .map_err(|e| usage(e.to_string()))
            })
            .collect::<Result<Vec<_>, _>>()?;
        refuse_twice(&dims, &keys, &format!("--set {item}"))?;
        if args.planning.cycle_ms.is_some() && keys.iter().any(|k| k == "interpolation.cycle_ms") {
            return Err(usage(format!(
                "--set {item} sweeps the cycle --cycle-ms sets: give one of them"
            )));
        }
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

/// A key swept twice would make two columns of which the first has no effect: refused,
/// naming the argument (`given`) and the dimension that already sweeps it.
fn refuse_twice(dims: &[Dimension], keys: &[String], given: &str) -> Result<(), CliError> {
    match dims
        .iter()
        .find(|d| d.keys.iter().any(|k| keys.contains(k)))
    {
        Some(twice) => Err(CliError::Usage(format!(
            "{given}: its key is already swept (as {}); give each key once",
            twice.name
        ))),
        None => Ok(()),
    }
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

/// The thresholds from the flags, each checked.
fn thresholds(args: &SweepArgs) -> Result<Thresholds, CliError> {
    if !(args.min_damping.is_finite() && (0.0..1.0).contains(&args.min_damping)) {
        return Err(CliError::Usage(format!(
            "--min-damping {}: a damping ratio from 0 up to 1",
            args.min_damping
        )));
    }
    if !(args.min_phase_margin.is_finite() && (0.0..90.0).contains(&args.min_phase_margin)) {
        return Err(CliError::Usage(format!(
            "--min-phase-margin {}: degrees from 0 up to 90",
            args.min_phase_margin
        )));
    }
    if !(args.min_gain_margin.is_finite() && (0.0..40.0).contains(&args.min_gain_margin)) {
        return Err(CliError::Usage(format!(
            "--min-gain-margin {}: dB from 0 up to 40",
            args.min_gain_margin
        )));
    }
    Ok(Thresholds {
        min_phase_margin_deg: args.min_phase_margin,
        min_gain_margin_db: args.min_gain_margin,
        min_damping: args.min_damping,
    })
}

pub(crate) fn run(args: &SweepArgs, m: &ArgMatches) -> Result<Outcome, CliError> {
    let thresholds = thresholds(args)?;
    let inputs = [
        ("the program", Some(args.program.as_path())),
        ("--machine", args.machine.machine.as_deref()),
    ];
    let outputs = [
        ("--csv", args.csv.as_deref()),
        ("--json", args.json.as_deref()),
    ];
    outputs_apart(&inputs, &outputs)?;
    let machine = args.machine.load()?;
    let plan = args.planning.config(&machine)?;
    let program = load_program(&args.program, &machine)?;
    let dims = dimensions(args, m, &machine)?;
    let total = settings_within(&dims, args.max_settings)?;
    let bar = progress(total as u64, "sweep");
    let mut points = sweep::run(&program, &machine, &plan, &dims, !args.serial, &|| {
        bar.inc(1)
    });
    bar.finish_and_clear();
    refuse_all_invalid(&points)?;
    sweep::rank(&mut points, &thresholds);
    let mut batch = OutputBatch::new();
    if let Some(path) = &args.csv {
        batch.stage(path, |w| write_csv(w, &dims, &points))?;
    }
    if let Some(path) = &args.json {
        let doc = SweepJson {
            schema: "contourcheck.sweep/2",
            program: &program.file,
            machine: &machine.name,
            thresholds: &thresholds,
            dimensions: &dims,
            points: &points,
        };
        batch.stage(path, |w| super::output::write_json(w, &doc))?;
    }
    let mut plots = Vec::new();
    if let Some(dir) = &args.plot {
        let mut footer = super::common::run_footer(
            &machine.name,
            &program.file,
            &program.segments,
            plan.cycle_s,
        );
        // A swept cycle is each setting's own: the footer names none.
        if dims
            .iter()
            .flat_map(|d| &d.keys)
            .any(|k| k == "interpolation.cycle_ms")
        {
            footer = footer.sampling("IPO cycle swept");
        }
        plots = plot(&mut batch, dir, &program.file, &dims, &points, &footer)?;
    }
    batch.commit()?;
    for path in plots {
        println!("plot: {}", path.display());
    }
    let shown = &points[..points.len().min(args.rows)];
    print_table(&program.file, &machine.name, &dims, shown, &thresholds);
    print_none_crowned(&points);
    print_margins(&dims, shown);
    if points.len() > args.rows {
        println!(
            "  … {} more (--rows, --csv, --json)",
            points.len() - args.rows
        );
    }
    Ok(Outcome::Ok)
}

/// The number of settings the ranges make, refused above `max`.
fn settings_within(dims: &[Dimension], max: usize) -> Result<usize, CliError> {
    let total = dims
        .iter()
        .map(|d| d.values.len())
        .try_fold(1usize, usize::checked_mul)
        .unwrap_or(usize::MAX);
    if total > max {
        let counts: Vec<String> = dims
            .iter()
            .map(|d| format!("{} {}", d.values.len(), d.name))
            .collect();
        return Err(CliError::Usage(format!(
            "{total} settings ({}) exceed --max-settings {max}: take a coarser step, or raise \
             --max-settings",
            counts.join(" × ")
        )));
    }
    Ok(total)
}

/// A sweep none of whose settings could be made (every value out of its key's range) is an
/// error, naming why: it has nothing to rank.
fn refuse_all_invalid(points: &[SweepPoint]) -> Result<(), CliError> {
    let mut reasons: Vec<&str> = Vec::new();
    for p in points {
        match &p.result {
            PointResult::Invalid { reason } => {
                if !reasons.contains(&reason.as_str()) {
                    reasons.push(reason);
                }
            }
            _ => return Ok(()),
        }
    }
    Err(CliError::Usage(format!(
        "every setting swept is invalid, none simulated: {}",
        reasons.join("; ")
    )))
}

/// Why no row is crowned, where none meets the thresholds: what every setting falls short
/// in alike (an axis the sweep leaves as it is), which no setting swept can mend.
fn print_none_crowned(points: &[SweepPoint]) {
    match sweep::shared_shortfall(points) {
        None => {}
        Some(shared) if shared.is_empty() => {
            println!("  no setting meets the thresholds: none is crowned");
        }
        Some(shared) => println!(
            "  no setting meets the thresholds: none is crowned; every one has {} — the swept \
             keys do not change it (--min-phase-margin, --min-gain-margin, --min-damping set \
             the rule)",
            sweep::health::describe(&shared)
        ),
    }
}

#[derive(Serialize)]
struct SweepJson<'a> {
    schema: &'static str,
    program: &'a str,
    machine: &'a str,
    thresholds: &'a Thresholds,
    dimensions: &'a [Dimension],
    points: &'a [SweepPoint],
}

/// The swept values of a row, right-aligned under their names.
fn value_cells(p: &SweepPoint) -> String {
    p.values
        .iter()
        .map(|&v| format!("{:>10}", swept_value(v)))
        .collect::<Vec<_>>()
        .join(" ")
}

/// A swept value in six significant digits at most, its trailing zeros dropped, and with
/// an exponent outside 0.001 to 10⁷: a fixed four decimals showed an inertia of 2e-5 kg·m²
/// as 0.0000 beside one of 4e-5, and a stiffness of 4e8 N/m in fourteen digits.
fn swept_value(v: f64) -> String {
    let trimmed = |s: String| {
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    };
    if v != 0.0 && !(1e-3..1e7).contains(&v.abs()) {
        let text = format!("{v:.5e}");
        let (mantissa, exponent) = text.split_once('e').unwrap_or((&text, "0"));
        return format!("{}e{exponent}", trimmed(mantissa.to_string()));
    }
    let decimals = (5 - v.abs().max(1e-3).log10().floor() as i32).clamp(0, 9) as usize;
    trimmed(format!("{v:.decimals$}"))
}

fn print_table(
    program: &str,
    machine: &str,
    dims: &[Dimension],
    points: &[SweepPoint],
    t: &Thresholds,
) {
    println!(
        "sweep of {program} on {machine}: ranked by the largest contour error; a setting with \
         a loop below {}° of phase margin or {} dB of gain margin, a closed-loop mode of the \
         loops' own damped below ζ {z}, or a mode of the mechanics damped below both ζ {z} and \
         half its damping on the mechanics alone, is flagged and ranked after every healthy one",
        t.min_phase_margin_deg,
        t.min_gain_margin_db,
        z = t.min_damping
    );
    let head: Vec<String> = dims.iter().map(|d| format!("{:>10}", d.name)).collect();
    println!(
        "  rank {}  max contour µm  RMS µm  FE X µm  FE Y µm  overshoot µm  ripple µm  \
         loop damping  dominated by",
        head.join(" ")
    );
    let mut crowned = false;
    for (i, p) in points.iter().enumerate() {
        let figures = match &p.result {
            PointResult::Ok {
                metrics: m,
                health,
                flags,
                dominant,
            } => {
                let damping = if health.loop_damping.is_finite() {
                    format!("{:>12.3}", health.loop_damping)
                } else {
                    format!("{:>12}", "—")
                };
                let verdict = if !flags.is_empty() {
                    format!("  flagged: {}", sweep::health::describe(flags))
                } else if !crowned {
                    crowned = true;
                    "  ◀ best".to_string()
                } else {
                    String::new()
                };
                format!(
                    "{:>14.2}  {:>6.2}  {:>7.1}  {:>7.1}  {:>12.2}  {:>9.3}  {damping}  {:<28}{verdict}",
                    m.max_contour_um,
                    m.rms_contour_um,
                    m.max_following_um[0],
                    m.max_following_um[1],
                    m.overshoot_um,
                    m.ripple_um,
                    dominant.label(),
                )
            }
            PointResult::Unstable { axis, frequency_hz } => {
                format!("  unstable: {axis} axis, growing mode at {frequency_hz:.1} Hz")
            }
            PointResult::Invalid { reason } => format!("  invalid: {reason}"),
        };
        println!("  {:>4} {}  {}", i + 1, value_cells(p), figures.trim_end());
    }
}

/// A margin's cell: the value, `∞` where the loop has none to lose, `—` where it lacks the loop.
fn margin_cell(v: Option<f64>, width: usize, decimals: usize, sign: bool) -> String {
    match v {
        // A loop whose gain only falls has its peak at 0 dB: no "−0.0".
        Some(v) if v.is_finite() && sign && v.abs() < 0.05 => format!("{:>width$}", "0.0"),
        Some(v) if v.is_finite() && sign => format!("{v:>+width$.decimals$}"),
        Some(v) if v.is_finite() => format!("{v:>width$.decimals$}"),
        Some(v) if v == f64::INFINITY => format!("{:>width$}", "∞"),
        _ => format!("{:>width$}", "—"),
    }
}

/// The stability margins of the rows shown, rank by rank: each loop's phase margin, gain
/// margin and closed-loop peak, the worse of X and Y.
fn print_margins(dims: &[Dimension], points: &[SweepPoint]) {
    if !points
        .iter()
        .any(|p| matches!(p.result, PointResult::Ok { .. }))
    {
        return;
    }
    println!(
        "stability margins, the worse of X and Y: phase margin (°), gain margin (dB), \
         closed-loop peak (dB)"
    );
    let head: Vec<String> = dims.iter().map(|d| format!("{:>10}", d.name)).collect();
    println!(
        "  rank {}   position  PM     GM   peak   velocity  PM     GM   peak    current  PM     GM   peak",
        head.join(" ")
    );
    for (i, p) in points.iter().enumerate() {
        let PointResult::Ok { health, .. } = &p.result else {
            continue;
        };
        let cells: Vec<String> = [Loop::Position, Loop::Velocity, Loop::Current]
            .iter()
            .map(|&l| {
                let pm = health.least(l, |m: &LoopMargins| m.phase_margin_deg);
                let gm = health.least(l, |m: &LoopMargins| m.gain_margin_db);
                let peak = health.most(l, |m: &LoopMargins| m.peak_db);
                format!(
                    "{}° {} {}",
                    margin_cell(pm, 13, 1, false),
                    margin_cell(gm, 6, 1, false),
                    margin_cell(peak, 6, 1, true)
                )
            })
            .collect();
        println!("  {:>4} {}{}", i + 1, value_cells(p), cells.join(""));
    }
}

/// The CSV columns of one axis's loop: `x_position_phase_margin_deg`, ….
const MARGIN_COLUMNS: [&str; 6] = [
    "crossover_hz",
    "phase_margin_deg",
    "gain_margin_db",
    "gain_reduction_margin_db",
    "peak_db",
    "peak_hz",
];

fn margin_values(m: Option<&LoopMargins>) -> [String; 6] {
    let v = |x: f64| {
        if x.is_finite() {
            format!("{x:.6}")
        } else if x == f64::INFINITY {
            "inf".to_string()
        } else {
            String::new()
        }
    };
    match m {
        Some(m) => [
            v(m.crossover_hz.unwrap_or(f64::NAN)),
            v(m.phase_margin_deg),
            v(m.gain_margin_db),
            v(m.gain_reduction_margin_db),
            v(m.peak_db),
            v(m.peak_hz),
        ],
        None => Default::default(),
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
            "loop_damping",
            "dominated_by",
            "flags",
        ]
        .map(String::from),
    );
    for axis in AxisName::BOTH {
        for l in Loop::ALL {
            for c in MARGIN_COLUMNS {
                header.push(format!("{}_{}_{c}", axis.as_str(), l.name()));
            }
        }
    }
    out.write_record(&header)?;
    let width = header.len();
    for p in points {
        let mut row: Vec<String> = p.values.iter().map(|v| v.to_string()).collect();
        match &p.result {
            PointResult::Ok {
                metrics: m,
                health,
                flags,
                dominant,
            } => {
                row.push(if flags.is_empty() { "ok" } else { "flagged" }.into());
                for v in [
                    m.max_contour_um,
                    m.rms_contour_um,
                    m.max_following_um[0],
                    m.max_following_um[1],
                    m.overshoot_um,
                    m.ripple_um,
                    health.loop_damping,
                ] {
                    row.push(format!("{v:.6}"));
                }
                row.push(dominant.label());
                row.push(
                    flags
                        .iter()
                        .map(|f| f.label())
                        .collect::<Vec<_>>()
                        .join("; "),
                );
                for a in &health.margins {
                    for l in Loop::ALL {
                        row.extend(margin_values(a.loops.iter().find(|m| m.which == l)));
                    }
                }
            }
            PointResult::Unstable { .. } => row.push("unstable".into()),
            PointResult::Invalid { .. } => row.push("invalid".into()),
        }
        row.resize(width, String::new());
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
    batch: &mut OutputBatch,
    dir: &Path,
    program: &str,
    dims: &[Dimension],
    points: &[SweepPoint],
    footer: &Footer,
) -> Result<Vec<PathBuf>, CliError> {
    let name = Path::new(program)
        .file_name()
        .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
    Ok(match dims {
        [d] => stage_plots_into(batch, dir, "sweep", &line_plot(&name, d, points), footer)?,
        [a, b] => stage_plots_into(
            batch,
            dir,
            "sweep",
            &heat_map(&name, [a, b], points),
            footer,
        )?,
        _ => {
            println!("(no plot for {} swept dimensions: use --csv)", dims.len());
            Vec::new()
        }
    })
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
        flagged: sorted
            .iter()
            .filter(|p| matches!(&p.result, PointResult::Ok { flags, .. } if !flags.is_empty()))
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
    let flagged = a
        .values
        .iter()
        .map(|va| {
            b.values
                .iter()
                .map(|vb| {
                    points.iter().any(|p| {
                        p.values[0] == *va
                            && p.values[1] == *vb
                            && matches!(&p.result, PointResult::Ok { flags, .. } if !flags.is_empty())
                    })
                })
                .collect()
        })
        .collect();
    SweepHeatMap {
        flagged,
        title: format!(
            "{name}: largest contour error over {} and {}",
            a.name, b.name
        ),
        labels: (labelled(a), labelled(b)),
        axes: (a.values.clone(), b.values.clone()),
        cells,
    }
}

#[cfg(test)]
mod tests {
    use super::swept_value;

    /// Values a user sweeps, each told apart and short: a stepped range's rounding gone,
    /// an inertia and a stiffness in exponent form.
    #[test]
    fn swept_values_are_shown_in_significant_digits() {
        let cases = [
            (0.7 + 0.1, "0.8"),
            (20.0, "20"),
            (1.25, "1.25"),
            (12000.0, "12000"),
            (2e-5, "2e-5"),
            (4e-5, "4e-5"),
            (4e8, "4e8"),
            (1e308, "1e308"),
            (-0.5, "-0.5"),
            (0.0, "0"),
        ];
        for (v, shown) in cases {
            assert_eq!(swept_value(v), shown, "{v}");
        }
    }
}
