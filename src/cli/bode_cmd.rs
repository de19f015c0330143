//! `contourcheck bode`: the three closed loops' frequency responses.

use std::path::PathBuf;

use clap::Args;

use super::Outcome;
use super::common::{AxisArg, CliError, MachineArgs, write_plots_into};
use crate::machine::{AxisConfig, AxisName};
use crate::plot::Footer;
use crate::plot::bode::{BodeCurve, BodeMark, BodePlot};
use crate::sim::AxisModel;
use crate::sim::linear::{self, Response, feedback_response};
use crate::sim::margins::{self, LoopMargins, MIN_GAIN_MARGIN_DB, MIN_PHASE_MARGIN_DEG};

/// Arguments of `bode`.
#[derive(Debug, Args)]
pub struct BodeArgs {
    #[command(flatten)]
    pub machine: MachineArgs,
    #[command(flatten)]
    pub axis: AxisArg,
    /// Write magnitude and phase of each loop, closed (with feed-forward too where it has
    /// one) and open, into this directory, as
    /// bode-<axis>.png and .svg.
    #[arg(long, value_name = "DIR")]
    pub plot: Option<PathBuf>,
}

pub(crate) fn run(args: &BodeArgs) -> Result<Outcome, CliError> {
    let machine = args.machine.load()?;
    let config = machine.axis(args.axis.axis);
    let model = AxisModel::from_config(config);
    println!(
        "{} axis of {} — linearised (friction as viscous only, nut in contact)",
        args.axis.axis, machine.name
    );
    let margins = margins::margins(&model);
    print_loop_table(&model, &margins);
    print_short_margins(&margins);
    print_least_damped(&model, config, args.axis.axis);
    // The figures of an unstable loop are shown, and drawn (they tell where it went wrong),
    // but the setting is an error.
    if let Some(path) = &args.plot {
        let curves = margins
            .iter()
            .flat_map(|m| loop_curves(&model, m))
            .collect();
        let title = format!(
            "Closed and open loops, {} axis of {}",
            args.axis.axis, machine.name
        );
        let stem = format!("bode-{}", args.axis.axis.as_str());
        let footer = Footer::new(&machine.name).sampling(format!(
            "{} axis, linearised: friction viscous only, nut in contact",
            args.axis.axis
        ));
        write_plots_into(path, &stem, &BodePlot { title, curves }, &footer)?;
    }
    linear::check_stable(&model).map_err(|e| e.on_axis(args.axis.axis.letter(), None))?;
    Ok(Outcome::Ok)
}

/// A loop's curves: its feedback loop closed (marked at its own peak), from the command
/// with the feed-forward where it has one (marked at that response's own peak), and its open
/// loop, where the margins are read (marked at the crossovers).
fn loop_curves(model: &AxisModel, m: &LoopMargins) -> Vec<BodeCurve> {
    let grid = margins::response_grid(model, m.which, (0.1, 10_000.0), 60);
    let curve = |label: String, response, marks| BodeCurve {
        label,
        points: linear::bode(model, m.which, &grid, response),
        marks,
    };
    let name = m.which.name();
    // An unstable closed loop has no steady response to a sine: its curve is the transfer
    // function's, which the label says.
    let closed = if m.unstable() {
        format!("{name}: feedback loop closed (unstable: no steady response)")
    } else {
        format!("{name}: feedback loop closed, peak {:+.1} dB", m.peak_db)
    };
    let peak = if m.unstable() {
        Vec::new()
    } else {
        peak_mark(m.peak_hz, m.peak_db)
    };
    let mut out = vec![curve(closed, Response::Feedback, peak)];
    if linear::has_feedforward(model, m.which) {
        let f = margins::closed_figures(model, m.which, true);
        out.push(curve(
            format!(
                "{name}: command with feed-forward, peak {:+.1} dB",
                f.peak_db
            ),
            Response::WithFeedforward,
            peak_mark(f.peak_hz, f.peak_db),
        ));
    }
    out.push(curve(
        format!("{name}: open loop, {}", margin_summary(m)),
        Response::Open,
        margin_marks(m),
    ));
    out
}

/// A loop's margins in a few words: `PM 62.7°, GM 14.2 dB`; `unstable` for a loop that is.
fn margin_summary(m: &LoopMargins) -> String {
    if m.unstable() {
        return "unstable".into();
    }
    let gm = if m.gain_margin_db.is_finite() {
        format!("{:.1} dB", m.gain_margin_db)
    } else {
        "∞".into()
    };
    let pm = if m.phase_margin_deg.is_finite() {
        format!("{:.1}°", m.phase_margin_deg)
    } else {
        "∞".into()
    };
    format!("PM {pm}, GM {gm}")
}

/// A response's peak marked on its magnitude, where it rises above its low-frequency gain.
fn peak_mark(peak_hz: f64, peak_db: f64) -> Vec<BodeMark> {
    if peak_hz > 0.0 && peak_db > 0.05 {
        vec![BodeMark {
            freq_hz: peak_hz,
            on_phase: false,
            label: format!("peak {peak_db:+.1} dB at {}", hz(peak_hz)),
        }]
    } else {
        Vec::new()
    }
}

/// The margins marked on the open loop's phase: the phase margin at the gain crossover, the
/// gain margin at the phase crossover.
fn margin_marks(m: &LoopMargins) -> Vec<BodeMark> {
    let mut out = Vec::new();
    if let Some(f) = m.crossover_hz {
        out.push(BodeMark {
            freq_hz: f,
            on_phase: true,
            label: if m.unstable() {
                format!("crossover at {} (unstable)", hz(f))
            } else {
                format!("PM {:.1}° at {}", m.phase_margin_deg, hz(f))
            },
        });
    }
    if let Some(f) = m.phase_crossover_hz {
        out.push(BodeMark {
            freq_hz: f,
            on_phase: true,
            // An unstable loop's is no margin: where its phase crosses −180° is what it says.
            label: if m.unstable() {
                format!("phase −180° at {}", hz(f))
            } else {
                format!("GM {:.1} dB at {}", m.gain_margin_db, hz(f))
            },
        });
    }
    out
}

/// A frequency with three significant digits and its unit.
fn hz(f: f64) -> String {
    match f {
        f if f >= 1000.0 => format!("{:.2} kHz", f / 1000.0),
        f if f >= 100.0 => format!("{f:.0} Hz"),
        f if f >= 10.0 => format!("{f:.1} Hz"),
        f if f >= 1.0 => format!("{f:.2} Hz"),
        f => format!("{f:.3} Hz"),
    }
}

/// A table cell: the value right-aligned in `width` with its unit, or "—" where the loop
/// does not reach that point (`∞` for a margin that is not read anywhere).
fn cell(v: f64, width: usize, decimals: usize, unit: &str, missing: &mut bool) -> String {
    if v.is_finite() {
        // Slow loops (a tiny Kv) keep their significant digits.
        let slow = unit == " Hz" && v.abs() < 0.1 && v != 0.0;
        let decimals = if slow { 5 } else { decimals };
        format!("{v:>width$.decimals$}{unit}")
    } else if v == f64::INFINITY {
        format!("{:>w$}", "∞", w = width + unit.chars().count())
    } else {
        *missing = true;
        format!("{:>w$}", "—", w = width + unit.chars().count())
    }
}

/// Each loop's crossover and margins, its feedback loop's peak, bandwidths and
/// low-frequency gain; below, where the command also reaches a loop through feed-forward,
/// that response's own figures.
fn print_loop_table(model: &AxisModel, margins: &[LoopMargins]) {
    println!(
        "{:<9} {:>11} {:>13} {:>12}  {:<20} {:>13} {:>12} {:>14}",
        "loop",
        "crossover",
        "phase margin",
        "gain margin",
        "feedback loop: peak",
        "−3 dB",
        "−10°",
        "gain at fc/100"
    );
    let mut missing = false;
    for m in margins {
        let f = margins::closed_figures(model, m.which, false);
        let crossover = m.crossover_hz.unwrap_or(f64::NAN);
        let low = feedback_response(model, m.which)(crossover / 100.0);
        let gain_margin = gain_margin_cell(m, &mut missing);
        let mut c = |v, w, d, u| cell(v, w, d, u, &mut missing);
        println!(
            "{:<9} {} {} {} {} {} {} {}",
            m.which.name(),
            c(crossover, 8, 2, " Hz"),
            c(m.phase_margin_deg, 12, 1, "°"),
            gain_margin,
            peak_cell(f.peak_hz, f.peak_db),
            c(f.bandwidth_3db_hz, 10, 2, " Hz"),
            c(f.phase_10deg_hz, 9, 2, " Hz"),
            c(20.0 * low.norm().log10(), 10, 2, " dB"),
        );
    }
    if missing {
        println!("— : the loop does not reach that point between 0.1 mHz and 100 kHz");
    }
    for m in margins {
        if linear::has_feedforward(model, m.which) {
            let f = margins::closed_figures(model, m.which, true);
            let mut c = |v, w, d, u| cell(v, w, d, u, &mut missing);
            println!(
                "{} loop, command to {} with feed-forward: peak {}, −3 dB {}, −10° {}",
                m.which.name(),
                m.which.name(),
                peak_cell(f.peak_hz, f.peak_db).trim(),
                c(f.bandwidth_3db_hz, 0, 2, " Hz"),
                c(f.phase_10deg_hz, 0, 2, " Hz"),
            );
        }
    }
}

/// A response's peak: its gain and where, or that it only falls.
fn peak_cell(peak_hz: f64, peak_db: f64) -> String {
    if peak_hz > 0.0 {
        format!("{peak_db:>+6.2} dB at {:>8}", hz(peak_hz))
    } else {
        format!("{peak_db:>+6.2} dB {:>11}", "(none)")
    }
}

/// The gain margin's cell: none for a loop that is unstable already, which no rise of its
/// gain makes so (its edge is given below the table).
fn gain_margin_cell(m: &LoopMargins, missing: &mut bool) -> String {
    if m.unstable() {
        format!("{:>12}", "unstable")
    } else {
        cell(m.gain_margin_db, 9, 1, " dB", missing)
    }
}

/// What an unstable loop's margins say: how far past the edge it is, and where the gain
/// crosses −180° above 0 dB, how far the gain must fall at least to reach the edge.
fn unstable_words(m: &LoopMargins) -> String {
    let past = if m.phase_margin_deg.is_finite() {
        format!("unstable (phase margin {:.1}°)", m.phase_margin_deg)
    } else {
        "unstable (its gain never crosses 0 dB)".to_string()
    };
    match m.gain_reduction_hz {
        Some(at) if m.gain_reduction_margin_db.is_finite() => format!(
            "{past}: its gain must fall by at least {:.1} dB to reach the edge (at {})",
            m.gain_reduction_margin_db,
            hz(at)
        ),
        _ => past,
    }
}

/// The loops short of the usual margins, each with what it lacks; an unstable one, how far
/// past the edge it is.
fn print_short_margins(margins: &[LoopMargins]) {
    for m in margins {
        if m.unstable() {
            println!("{} loop: {}", m.which.name(), unstable_words(m));
            continue;
        }
        let mut short = Vec::new();
        if m.phase_margin_deg < MIN_PHASE_MARGIN_DEG {
            short.push(format!(
                "phase margin {:.1}° (below {MIN_PHASE_MARGIN_DEG}°)",
                m.phase_margin_deg
            ));
        }
        if m.gain_margin_db < MIN_GAIN_MARGIN_DB {
            short.push(format!(
                "gain margin {:.1} dB (below {MIN_GAIN_MARGIN_DB} dB)",
                m.gain_margin_db
            ));
        }
        if m.gain_reduction_margin_db < MIN_GAIN_MARGIN_DB {
            short.push(format!(
                "unstable if its gain falls by {:.1} dB (at {}; below {MIN_GAIN_MARGIN_DB} dB)",
                m.gain_reduction_margin_db,
                m.gain_reduction_hz.map_or_else(|| "—".into(), hz)
            ));
        }
        if !short.is_empty() {
            println!("{} loop: {}", m.which.name(), short.join(", "));
        }
    }
}

/// The least damped closed-loop mode and, where it grows, why the margins miss it and the
/// gain that would be stable.
fn print_least_damped(model: &AxisModel, config: &AxisConfig, axis: AxisName) {
    if let Some(m) = linear::least_damped(model) {
        println!(
            "least damped closed-loop mode: {:.1} Hz, damping ratio {:.3}",
            m.frequency_hz, m.damping
        );
        print_least_damped_loop_mode(model, &m);
        if m.damping < 0.0 {
            // The margins are read where each loop's gain first crosses 0 dB; a mode far
            // above that crossing grows unseen by them — say so beside them.
            println!(
                "  UNSTABLE: this mode grows. The phase margins above are read at each loop's \
                 crossover; a mode at {:.1} Hz lies beyond them (the closed loops' magnitude peaks \
                 there).",
                m.frequency_hz
            );
            if let Some(kv_max) = linear::largest_stable_kv(config) {
                println!(
                    "  With the other settings held, {}.position_loop.kv_m_per_min_per_mm (here \
                     {}) is stable below {kv_max:.3} m/min/mm.",
                    axis.as_str(),
                    config.position_loop.kv_m_per_min_per_mm
                );
            }
        }
    }
}

/// Where the least damped closed-loop mode `overall` is one of the mechanics' that the loops
/// leave where the mechanics put it (a screw's kilohertz torsion), the least damped of the
/// modes the loops act on too: the figure a gain setting is judged by (`sweep`'s `loop
/// damping`).
fn print_least_damped_loop_mode(model: &AxisModel, overall: &linear::ModalFigure) {
    match margins::least_damped_loop_mode(model) {
        Some(own) if own != *overall => println!(
            "least damped of the modes the loops act on: {:.1} Hz, damping ratio {:.3} (the \
             {:.1} Hz mode is the mechanics', left where they put it)",
            own.frequency_hz, own.damping, overall.frequency_hz
        ),
        _ => {}
    }
}
