//! `contourcheck plan`: what the planner makes of a program.

use std::io::Write;
use std::path::PathBuf;

use clap::Args;

use super::Outcome;
use super::common::{CliError, MachineArgs, PlanningArgs, format_duration, load_program};
use crate::cli::output::{OutputBatch, outputs_apart};
use crate::numeric::units::{mm_from_m, mm_per_min_from_m_per_s};
use crate::path::Motion;
use crate::plan::{Commands, KinematicLimits, plan, sample};

/// Arguments of `plan`.
#[derive(Debug, Args)]
pub struct PlanArgs {
    /// The part program.
    pub program: PathBuf,
    #[command(flatten)]
    pub machine: MachineArgs,
    #[command(flatten)]
    pub planning: PlanningArgs,
    /// Write the sampled axis commands to this CSV file.
    #[arg(long, value_name = "FILE")]
    pub csv: Option<PathBuf>,
}

pub(crate) fn run(args: &PlanArgs) -> Result<Outcome, CliError> {
    let inputs = [
        ("the program", Some(args.program.as_path())),
        ("--machine", args.machine.machine.as_deref()),
    ];
    outputs_apart(&inputs, &[("--csv", args.csv.as_deref())])?;
    let machine = args.machine.load_stable()?;
    let config = args.planning.config(&machine)?;
    let program = load_program(&args.program, &machine)?;
    let planned = plan(&program, &KinematicLimits::of(&machine), &config);
    let commands = sample(&planned);
    if let Some(path) = &args.csv {
        let mut batch = OutputBatch::new();
        batch.stage(path, |w| {
            write_commands_csv(w, &commands, &planned.segments, &program)
        })?;
        batch.commit()?;
    }
    let (mut feed_m, mut rapid_m) = (0.0, 0.0);
    for (seg, p) in planned.segments.iter().zip(&planned.plans) {
        match seg.motion {
            Motion::Feed => feed_m += p.length_m,
            Motion::Rapid => rapid_m += p.length_m,
        }
    }
    println!(
        "program   {} ({} lines, {} blocks, {} path segments)",
        program.file,
        program.lines,
        program.blocks,
        planned.segments.len()
    );
    println!("machine   {} — {}", machine.name, machine.description);
    println!(
        "profile   {}, interpolation cycle {} ms",
        config.profile,
        config.cycle_s * 1e3
    );
    println!(
        "path      {:.3} mm ({:.3} mm feed, {:.3} mm rapid)",
        mm_from_m(feed_m + rapid_m),
        mm_from_m(feed_m),
        mm_from_m(rapid_m)
    );
    println!("time      {}", format_duration(planned.total_time_s));
    println!("peaks     speed (mm/min)  accel (m/s²)  jerk (m/s³, sampled)");
    let mut steps = false;
    for (name, axis) in [("X", &commands.x), ("Y", &commands.y), ("Z", &commands.z)] {
        let p = axis.peaks(commands.dt_s);
        // A velocity step has no acceleration of its own: shown as sampled, and marked.
        let (accel, jerk) = match p.step_accel_m_per_s2 {
            Some(a) if a > p.accel_m_per_s2 => {
                steps = true;
                (format!("{a:.4} *"), "step *".to_string())
            }
            _ => (
                format!("{:.4}  ", p.accel_m_per_s2),
                format!("{:.3}  ", p.jerk_m_per_s3),
            ),
        };
        println!(
            "  {name}       {:>12.1}  {accel:>14}  {jerk:>14}",
            mm_per_min_from_m_per_s(p.speed_m_per_s),
        );
    }
    if steps {
        println!(
            "  * the speed steps ({} profile): the step over one {} ms cycle, as sampled; \
             its true acceleration and jerk are unbounded",
            config.profile,
            config.cycle_s * 1e3
        );
    }
    print_notes_and_warnings(&program, &planned.warnings);
    Ok(Outcome::Ok)
}

fn print_notes_and_warnings(program: &crate::gcode::Program, planner: &[crate::gcode::Warning]) {
    if !program.notes.is_empty() {
        println!("accepted without effect on the XY path:");
        for n in &program.notes {
            println!(
                "  {:<6} {:<50} {}×, first on line {}",
                n.code, n.meaning, n.count, n.first_line
            );
        }
    }
    let warnings: Vec<_> = program.warnings.iter().chain(planner).cloned().collect();
    if !warnings.is_empty() {
        println!("warnings:");
        for line in crate::check::report::group_warnings(&warnings) {
            println!("  {line}");
        }
    }
}

/// The sampled commands as CSV: time, X/Y/Z position, X/Y velocity and acceleration, and
/// the source line of the block being executed as `check --trace` gives it (`29`, or
/// `POCKET.SPF:3` in a subprogram's file).
pub(crate) fn write_commands_csv(
    w: &mut dyn Write,
    c: &Commands,
    segments: &[crate::path::Segment],
    program: &crate::gcode::Program,
) -> std::io::Result<()> {
    let mut out = csv::Writer::from_writer(w);
    out.write_record([
        "t_s",
        "x_mm",
        "y_mm",
        "z_mm",
        "vx_mm_per_min",
        "vy_mm_per_min",
        "vz_mm_per_min",
        "ax_m_per_s2",
        "ay_m_per_s2",
        "az_m_per_s2",
        "line",
    ])?;
    for k in 0..c.len() {
        out.write_record(&[
            format!("{:.4}", c.time_s(k)),
            format!("{:.6}", mm_from_m(c.x.pos_m[k])),
            format!("{:.6}", mm_from_m(c.y.pos_m[k])),
            format!("{:.6}", mm_from_m(c.z.pos_m[k])),
            format!("{:.3}", mm_per_min_from_m_per_s(c.x.vel_m_per_s[k])),
            format!("{:.3}", mm_per_min_from_m_per_s(c.y.vel_m_per_s[k])),
            format!("{:.3}", mm_per_min_from_m_per_s(c.z.vel_m_per_s[k])),
            format!("{:.6}", c.x.acc_m_per_s2[k]),
            format!("{:.6}", c.y.acc_m_per_s2[k]),
            format!("{:.6}", c.z.acc_m_per_s2[k]),
            segments
                .get(c.segment[k] as usize)
                .map_or_else(|| "0".into(), |s| program.source_line(s.line).short()),
        ])?;
    }
    out.flush()
}
