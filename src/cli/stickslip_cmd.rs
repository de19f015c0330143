//! `contourcheck stickslip`: the paper's stick-slip criterion at low feeds and the critical
//! velocity.

use std::path::PathBuf;

use clap::Args;
use rayon::prelude::*;

use super::Outcome;
use super::common::{AxisArg, CliError, MachineArgs, progress, write_plots_into};
use crate::numeric::units::{m_per_s_from_mm_per_min, mm_per_min_from_m_per_s, um_from_m};
use crate::plot::stickslip::{StickSlipCurve, StickSlipPlot};
use crate::sim::{AxisModel, stickslip};

/// Arguments of `stickslip`.
#[derive(Debug, Args)]
pub struct StickSlipArgs {
    #[command(flatten)]
    pub machine: MachineArgs,
    #[command(flatten)]
    pub axis: AxisArg,
    /// Feeds to run, mm/min (the paper's Fig. 29 set by default).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "0.1,0.5,1,3,4,5",
        value_name = "MM_PER_MIN,…"
    )]
    pub feeds: Vec<f64>,
    /// Length of each run (s).
    #[arg(long, default_value_t = 30.0, value_name = "S")]
    pub duration: f64,
    /// Write time–displacement curves into this directory, as stickslip-<axis>.png and
    /// .svg.
    #[arg(long, value_name = "DIR")]
    pub plot: Option<PathBuf>,
}

/// The feeds asked for, each a positive one the axis can be commanded at (up to its rapid,
/// `rapid` mm/min), and a run's length from 1 s up to an hour.
fn checked_feeds(args: &StickSlipArgs, rapid: f64) -> Result<Vec<f64>, CliError> {
    let feeds = &args.feeds;
    if feeds.iter().any(|f| !(f.is_finite() && *f > 0.0)) {
        return Err(CliError::Usage("--feeds must all be positive".into()));
    }
    // A feed past the axis's rapid is one the interpolator never commands: the run would
    // only show the drive saturating.
    if let Some(f) = feeds.iter().find(|f| **f > rapid) {
        return Err(CliError::Usage(format!(
            "--feeds {f}: above the axis's rapid of {rapid} mm/min (stick-slip is a low-feed \
             effect; the paper's runs are below 10 mm/min)"
        )));
    }
    // A run is simulated at the loops' own time step: an hour of it is already some minutes.
    if !(args.duration.is_finite() && (1.0..=3600.0).contains(&args.duration)) {
        return Err(CliError::Usage(
            "--duration must be from 1 s up to 3600 s".into(),
        ));
    }
    Ok(feeds.clone())
}

pub(crate) fn run(args: &StickSlipArgs) -> Result<Outcome, CliError> {
    let machine = args.machine.load_stable()?;
    let model = AxisModel::from_config(machine.axis(args.axis.axis));
    let mut feeds = checked_feeds(args, machine.axis(args.axis.axis).limits.rapid_mm_per_min)?;
    feeds.sort_by(f64::total_cmp);
    let cfg = stickslip::StickSlipConfig {
        run_s: args.duration,
        ..Default::default()
    };
    let bar = progress(feeds.len() as u64, "stick-slip runs");
    let runs = feeds
        .par_iter()
        .map(|&f| {
            let r = stickslip::run(&model, m_per_s_from_mm_per_min(f), &cfg);
            bar.inc(1);
            r
        })
        .collect::<Result<Vec<_>, _>>()?;
    bar.finish_and_clear();
    println!(
        "{} axis of {}: from rest, {} s per feed; a slip ≥ 1 µm breaking away in the second half is stick-slip",
        args.axis.axis, machine.name, args.duration
    );
    println!("feed (mm/min)  slips  counted  largest counted slip  verdict");
    for r in &runs {
        println!(
            "{:>12.2} {:>6} {:>8} {:>17.3} µm  {}",
            mm_per_min_from_m_per_s(r.feed_m_per_s),
            r.slips.len(),
            r.counted_slips(),
            um_from_m(r.max_counted_slip_m),
            r.verdict()
        );
    }
    let scan: Vec<f64> = feeds.iter().map(|&f| m_per_s_from_mm_per_min(f)).collect();
    match stickslip::critical_velocity(&model, &scan, &cfg)? {
        Some(c) => println!(
            "critical stick-slip velocity: {:.2} mm/min (stick-slip at {:.2}, none at {:.2})",
            mm_per_min_from_m_per_s(c.feed_m_per_s),
            mm_per_min_from_m_per_s(c.last_sticking_m_per_s),
            mm_per_min_from_m_per_s(c.first_smooth_m_per_s)
        ),
        None if model.presliding.is_some() => {
            println!(
                "critical stick-slip velocity: {}",
                stickslip::NOT_DETERMINED
            )
        }
        None => println!("critical stick-slip velocity: not bracketed by these feeds"),
    }
    if let Some(path) = &args.plot {
        let (window_s, curves) = plot_curves(&runs, args.duration);
        let title = format!(
            "Stick-slip, {} axis of {}: displacement over {window_s} s of the run's last third",
            args.axis.axis, machine.name
        );
        let stem = format!("stickslip-{}", args.axis.axis.as_str());
        let footer = crate::plot::Footer::new(&machine.name)
            .feed(format!(
                "F {} mm/min",
                feeds
                    .iter()
                    .map(|f| f.to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            ))
            .sampling(format!("simulated at {} ms", cfg.dt_s * 1e3));
        write_plots_into(path, &stem, &StickSlipPlot { title, curves }, &footer)?;
    }
    Ok(Outcome::Ok)
}

/// A short window from each run's second half, where the criterion counts slips (over the
/// whole run µm steps would vanish in mm of travel): its length (s) and each run's table and
/// command displacement over it (µm).
fn plot_curves(runs: &[stickslip::StickSlipRun], duration_s: f64) -> (f64, Vec<StickSlipCurve>) {
    let window_s = 0.5f64.min(0.5 * duration_s);
    let curves = runs
        .iter()
        .map(|r| {
            let first = ((2.0 / 3.0 * duration_s) / r.dt_s) as usize;
            let last = (first + (window_s / r.dt_s) as usize).min(r.position_m.len() - 1);
            let origin = r.feed_m_per_s * first as f64 * r.dt_s;
            let pts = |f: &dyn Fn(usize) -> f64| -> Vec<(f64, f64)> {
                (first..=last)
                    .map(|k| (k as f64 * r.dt_s, f(k) - um_from_m(origin)))
                    .collect()
            };
            StickSlipCurve {
                label: format!(
                    "{:.2} mm/min — {} (largest slip {:.2} µm)",
                    mm_per_min_from_m_per_s(r.feed_m_per_s),
                    r.verdict(),
                    um_from_m(r.max_counted_slip_m)
                ),
                table_um: pts(&|k| um_from_m(r.position_m[k])),
                command_um: pts(&|k| um_from_m(r.feed_m_per_s * k as f64 * r.dt_s)),
            }
        })
        .collect();
    (window_s, curves)
}
