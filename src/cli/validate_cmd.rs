//! `contourcheck validate`: every comparison with the paper in one report.

use clap::Args;
use rayon::prelude::*;

use super::Outcome;
use super::common::{CliError, MachineArgs};
use crate::machine::Feedback;
use crate::numeric::units::{m_per_s_from_mm_per_min, um_from_m};
use crate::sim::{SimConfig, stickslip};
use crate::validate::{self, PAPER_TABLES};

/// Arguments of `validate`.
#[derive(Debug, Args)]
pub struct ValidateArgs {
    #[command(flatten)]
    pub machine: MachineArgs,
}

/// The paper's tables set a cascade's position and velocity gains, and its Bode figures are
/// those of the cascade's three loops: on another controller they compare nothing.
fn refuse_without_a_cascade(machine: &crate::machine::MachineConfig) -> Result<(), CliError> {
    if machine.x.controller.is_cascade() {
        return Ok(());
    }
    Err(CliError::Usage(format!(
        "validate compares the paper's tables, which set the position and velocity gains of a \
         three-loop cascade; {}'s X axis has another controller, so there is nothing to \
         compare (run it on a cascade machine, such as hvmc)",
        machine.name
    )))
}

pub(crate) fn run(args: &ValidateArgs) -> Result<Outcome, CliError> {
    let machine = args.machine.load()?;
    refuse_without_a_cascade(&machine)?;
    let sim = SimConfig::default();
    println!(
        "Validation of the {} preset against Wang et al. (paper §4, docs/model.md §4), X axis\n",
        machine.name
    );
    let tables = PAPER_TABLES
        .par_iter()
        .map(|t| validate::compare_table(&machine, t, &sim))
        .collect::<Result<Vec<_>, _>>()?;
    for t in &tables {
        println!(
            "{} — steady following error after a velocity step from rest (mm)",
            t.name
        );
        println!(
            "  {:>14}  {:>9}  {:>11}  {:>9}  {:>9}",
            t.parameter.heading(),
            "measured",
            "paper sim.",
            "ours",
            "F/Kv"
        );
        for r in &t.rows {
            println!(
                "  {:>14.2}  {:>9.4}  {:>11.5}  {:>9.5}  {:>9.5}",
                r.parameter, r.measured_mm, r.paper_simulated_mm, r.ours_mm, r.f_over_kv_mm
            );
        }
        println!(
            "  mean |sim − measured|: paper {:.5} mm, ours {:.5} mm; ours within {:.4} % of F/Kv\n",
            t.mad_paper_mm,
            t.mad_ours_mm,
            100.0 * t.max_rel_dev_from_f_over_kv
        );
    }
    println!("Bode figures of the linearised loops (reference: docs/model.md §2)");
    println!(
        "  loop       crossover Hz (ref)   phase margin ° (ref)   −3 dB Hz (ref)    −10° Hz (ref)"
    );
    for (ours, (c, pm, bw, p10)) in validate::compare_bode(&machine) {
        println!(
            "  {:<9} {:>8.2} ({:>6.2})   {:>8.1} ({:>5.1})       {:>8.2} ({:>6.2})  {:>7.2} ({:>6.2})",
            ours.which.name(),
            ours.crossover_hz,
            c,
            ours.phase_margin_deg,
            pm,
            ours.bandwidth_3db_hz,
            bw,
            ours.phase_10deg_hz,
            p10
        );
    }
    let ss = validate::stick_slip_summary(&machine, &stickslip::StickSlipConfig::default())?;
    println!(
        "\nStick-slip (paper Figs. 29–30: critical velocity between 4 and 5 mm/min, measured and simulated)"
    );
    for (f, s) in &ss.slips_um {
        println!(
            "  {:>5.1} mm/min: largest counted slip {:.3} µm{}",
            f,
            s,
            if *s >= 1.0 { "  → stick-slip" } else { "" }
        );
    }
    match ss.critical_mm_per_min {
        Some(v) => println!("  critical stick-slip velocity: {v:.2} mm/min"),
        None if machine.x.friction.has_presliding() => println!(
            "  critical stick-slip velocity: {}",
            stickslip::NOT_DETERMINED
        ),
        None => println!("  critical stick-slip velocity: not found in the scan"),
    }
    print_trends(&machine, &sim)?;
    Ok(Outcome::Ok)
}

fn print_trends(machine: &crate::machine::MachineConfig, sim: &SimConfig) -> Result<(), CliError> {
    let feed = m_per_s_from_mm_per_min(500.0);
    println!(
        "\nStart-up at 500 mm/min from rest (paper Figs. 17–19): peak error, error at 20 ms, 1 % settling"
    );
    type Setter = fn(&mut crate::machine::AxisConfig, f64);
    let sweeps: [(&str, Vec<f64>, Setter); 3] = [
        ("fs/fc", vec![1.0, 1.1, 1.2, 1.3, 1.4], |a, v| {
            a.friction.static_to_coulomb = v
        }),
        ("c", vec![0.01, 0.02, 0.03, 0.04, 0.05], |a, v| {
            a.friction.coulomb_coefficient = v
        }),
        (
            "fv N·s/m",
            vec![1000.0, 2000.0, 3000.0, 4000.0, 5000.0],
            |a, v| a.friction.viscous_n_s_per_m = v,
        ),
    ];
    for (name, values, set) in sweeps {
        let rows = values
            .par_iter()
            .map(|&v| {
                let mut axis = machine.x.clone();
                set(&mut axis, v);
                validate::start_up(&axis, feed, sim).map(|s| (v, s))
            })
            .collect::<Result<Vec<_>, _>>()?;
        for (v, s) in rows {
            println!(
                "  {name:<9} {v:>7.2}: peak {:>9.3} µm   at 20 ms {:>8.3} µm   settles in {:.3} s",
                um_from_m(s.peak_m),
                um_from_m(s.early_m),
                s.settle_1pct_s
            );
        }
    }
    println!(
        "\nBacklash at the reversal of the paper's Fig. 20 sine (R 300 mm, 1000 mm/min), change in following error"
    );
    println!("  backlash   motor encoder: lasting step   linear scale: transient spike");
    for b in [5.0, 10.0, 20.0] {
        let semi = validate::backlash_reversal(machine, b, Feedback::MotorEncoder, sim)?;
        let full = validate::backlash_reversal(machine, b, Feedback::LinearScale, sim)?;
        println!(
            "  {b:>5.1} µm   {:>26.2} µm   {:>24.2} µm",
            um_from_m(semi.step_m),
            um_from_m(full.spike_m)
        );
    }
    println!("\nVelocity gain Ks at 500 mm/min (paper Fig. 24): steady mean and start-up ripple");
    for ks in [12.0, 14.0, 16.0, 18.0, 20.0] {
        let mut axis = machine.x.clone();
        if let Some(v) = axis.velocity_loop.as_mut() {
            v.ks_nm_s_per_rad = ks;
        }
        let (mean, ripple) = validate::mean_and_ripple_m(&axis, feed, sim)?;
        println!(
            "  Ks {ks:>4.0}: mean {:.5} mm, ripple {:.3} µm",
            mean * 1e3,
            um_from_m(ripple)
        );
    }
    Ok(())
}
