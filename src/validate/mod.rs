//! Side-by-side comparison with the paper (Wang et al., §4; docs/model.md §4): its measured and
//! simulated following errors (Tables 3–5), its loops' Bode figures, its critical
//! stick-slip velocity, and the parameter trends of its §3.2 — each against this model.

use rayon::prelude::*;
use serde::Serialize;

use crate::diagnose::table::{
    START_UP_STEP_S, STEADY_AFTER_S, start_up_following_error_m, steady_following_error_m,
};
use crate::machine::{AxisConfig, MachineConfig};
use crate::numeric::units::{
    m_per_s_from_mm_per_min, mm_from_m, per_s_from_kv_m_per_min_per_mm, um_from_m,
};
use crate::plan::AxisCommands;
use crate::sim::linear::{self, Loop, LoopFigures};
use crate::sim::{AxisModel, SimConfig, SimError, simulate, stickslip};

/// One of the paper's following-error tables.
#[derive(Debug, Clone, Copy)]
pub struct PaperTable {
    /// "Table 3" etc.
    pub name: &'static str,
    /// What varies.
    pub parameter: Parameter,
    /// (parameter value, measured error mm, the paper's simulated error mm).
    pub rows: &'static [(f64, f64, f64)],
}

/// The parameter a table varies (the others stay at the preset's values).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Parameter {
    /// Feed (mm/min) at Kv = 1.
    FeedMmPerMin,
    /// Kv (m/min/mm) at 500 mm/min.
    KvMPerMinPerMm,
    /// K_s (N·m·s/rad) at 500 mm/min.
    KsNmSPerRad,
}

impl Parameter {
    /// Column heading.
    pub(crate) fn heading(self) -> &'static str {
        match self {
            Parameter::FeedMmPerMin => "feed (mm/min)",
            Parameter::KvMPerMinPerMm => "Kv (m/min/mm)",
            Parameter::KsNmSPerRad => "Ks (N·m·s/rad)",
        }
    }
}

/// The paper's Tables 3, 4 and 5 (X axis, linear moves, velocity steps from rest).
pub const PAPER_TABLES: [PaperTable; 3] = [
    PaperTable {
        name: "Table 3",
        parameter: Parameter::FeedMmPerMin,
        rows: &[
            (100.0, 0.0976, 0.09993),
            (200.0, 0.1792, 0.19986),
            (300.0, 0.3015, 0.29979),
            (400.0, 0.3725, 0.39972),
            (500.0, 0.502, 0.49965),
            (600.0, 0.6011, 0.59958),
            (700.0, 0.6977, 0.69951),
            (800.0, 0.7926, 0.79944),
            (900.0, 0.9108, 0.89937),
            (1000.0, 1.0104, 0.99936),
        ],
    },
    PaperTable {
        name: "Table 4",
        parameter: Parameter::KvMPerMinPerMm,
        rows: &[
            (0.7, 0.6820, 0.6757),
            (0.8, 0.6288, 0.6107),
            (0.9, 0.5645, 0.5516),
            (1.0, 0.5020, 0.4996),
            (1.1, 0.4434, 0.4442),
            (1.2, 0.4109, 0.4210),
        ],
    },
    PaperTable {
        name: "Table 5",
        parameter: Parameter::KsNmSPerRad,
        rows: &[
            (12.0, 0.5083, 0.49965),
            (14.0, 0.5042, 0.49965),
            (16.0, 0.502, 0.49965),
            (18.0, 0.5085, 0.49965),
            (20.0, 0.5075, 0.49965),
        ],
    },
];

/// Feed of Tables 4 and 5 (mm/min).
const TABLE_FEED_MM_PER_MIN: f64 = 500.0;

/// One row of a table, with ours.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct TableRow {
    /// Parameter value.
    pub parameter: f64,
    /// The paper's measurement (mm).
    pub measured_mm: f64,
    /// The paper's simulation (mm).
    pub paper_simulated_mm: f64,
    /// This model (mm).
    pub ours_mm: f64,
    /// F/Kv (mm).
    pub f_over_kv_mm: f64,
}

/// A table with its mean absolute deviations from the measurement.
#[derive(Debug, Clone, Serialize)]
pub struct TableComparison {
    /// Table name.
    pub name: &'static str,
    /// What varies.
    pub parameter: Parameter,
    /// Rows.
    pub rows: Vec<TableRow>,
    /// Mean |ours − measured| (mm).
    pub mad_ours_mm: f64,
    /// Mean |paper's simulation − measured| (mm).
    pub mad_paper_mm: f64,
    /// Largest |ours − F/Kv| / (F/Kv).
    pub max_rel_dev_from_f_over_kv: f64,
}

/// The machine a table row runs on, and the feed (m/s).
fn table_setup(base: &AxisConfig, parameter: Parameter, value: f64) -> (AxisConfig, f64) {
    let mut axis = base.clone();
    let feed = match parameter {
        Parameter::FeedMmPerMin => value,
        Parameter::KvMPerMinPerMm => {
            axis.position_loop.kv_m_per_min_per_mm = value;
            TABLE_FEED_MM_PER_MIN
        }
        Parameter::KsNmSPerRad => {
            if let Some(v) = axis.velocity_loop.as_mut() {
                v.ks_nm_s_per_rad = value;
            }
            TABLE_FEED_MM_PER_MIN
        }
    };
    (axis, m_per_s_from_mm_per_min(feed))
}

/// Runs one of the paper's tables on the X axis of `machine`.
pub(crate) fn compare_table(
    machine: &MachineConfig,
    table: &PaperTable,
    sim: &SimConfig,
) -> Result<TableComparison, SimError> {
    let rows: Vec<TableRow> = table
        .rows
        .par_iter()
        .map(|&(value, measured_mm, paper_simulated_mm)| {
            let (axis, feed) = table_setup(&machine.x, table.parameter, value);
            let ours = steady_following_error_m(&axis, feed, sim)?;
            let kv = per_s_from_kv_m_per_min_per_mm(axis.position_loop.kv_m_per_min_per_mm);
            Ok(TableRow {
                parameter: value,
                measured_mm,
                paper_simulated_mm,
                ours_mm: mm_from_m(ours),
                f_over_kv_mm: mm_from_m(feed / kv),
            })
        })
        .collect::<Result<_, SimError>>()?;
    let n = rows.len() as f64;
    Ok(TableComparison {
        name: table.name,
        parameter: table.parameter,
        mad_ours_mm: rows
            .iter()
            .map(|r| (r.ours_mm - r.measured_mm).abs())
            .sum::<f64>()
            / n,
        mad_paper_mm: rows
            .iter()
            .map(|r| (r.paper_simulated_mm - r.measured_mm).abs())
            .sum::<f64>()
            / n,
        max_rel_dev_from_f_over_kv: rows
            .iter()
            .map(|r| (r.ours_mm - r.f_over_kv_mm).abs() / r.f_over_kv_mm)
            .fold(0.0, f64::max),
        rows,
    })
}

/// docs/model.md §2's figures for the three loops of the preset: crossover (Hz), phase margin
/// (°), closed-loop −3 dB (Hz), phase at −10° (Hz).
pub const MODEL_LOOP_FIGURES: [(Loop, f64, f64, f64, f64); 3] = [
    (Loop::Current, 593.0, 62.6, 931.0, 142.0),
    (Loop::Velocity, 127.0, 74.8, 175.0, 22.8),
    (Loop::Position, 2.68, 89.9, 2.67, 0.47),
];

/// Our loop figures beside the reference ones.
pub(crate) fn compare_bode(machine: &MachineConfig) -> Vec<(LoopFigures, (f64, f64, f64, f64))> {
    let model = AxisModel::from_config(&machine.x);
    MODEL_LOOP_FIGURES
        .iter()
        .map(|&(l, c, pm, bw, p10)| (linear::loop_figures(&model, l), (c, pm, bw, p10)))
        .collect()
}

/// The stick-slip findings on the X axis.
#[derive(Debug, Clone, Serialize)]
pub struct StickSlipSummary {
    /// Critical velocity (mm/min), if found in the scan.
    pub critical_mm_per_min: Option<f64>,
    /// Largest counted slip per feed (mm/min, µm).
    pub slips_um: Vec<(f64, f64)>,
}

/// Feeds the paper ran (Fig. 29) and a few more, for the scan (mm/min).
pub const STICK_SLIP_SCAN_MM_PER_MIN: [f64; 9] = [0.1, 0.5, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 8.0];

/// Stick-slip scan and critical velocity of the X axis.
pub(crate) fn stick_slip_summary(
    machine: &MachineConfig,
    cfg: &stickslip::StickSlipConfig,
) -> Result<StickSlipSummary, SimError> {
    let model = AxisModel::from_config(&machine.x);
    let feeds: Vec<f64> = STICK_SLIP_SCAN_MM_PER_MIN
        .iter()
        .map(|&f| m_per_s_from_mm_per_min(f))
        .collect();
    let critical = stickslip::critical_velocity(&model, &feeds, cfg)?;
    let slips_um = match &critical {
        Some(c) => c
            .scan
            .iter()
            .map(|&(f, s)| (f * 60_000.0, um_from_m(s)))
            .collect(),
        None => Vec::new(),
    };
    Ok(StickSlipSummary {
        critical_mm_per_min: critical.map(|c| c.feed_m_per_s * 60_000.0),
        slips_um,
    })
}

/// The start-up of a velocity step from rest: what §3.2's friction figures show.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct StartUp {
    /// Largest following error (m).
    pub peak_m: f64,
    /// Following error 20 ms after the start, where friction's effect shows (m).
    pub early_m: f64,
    /// Time after which the error stays within 1 % of its final value (s).
    pub settle_1pct_s: f64,
    /// Final error (m).
    pub final_m: f64,
}

/// Start-up of an axis at `feed` (m/s) from rest.
pub(crate) fn start_up(
    axis: &AxisConfig,
    feed_m_per_s: f64,
    sim: &SimConfig,
) -> Result<StartUp, SimError> {
    let fe = start_up_following_error_m(axis, feed_m_per_s, sim)?;
    let dt = START_UP_STEP_S;
    let final_m = fe[fe.len() - 1];
    let outside = fe
        .iter()
        .rposition(|e| (e - final_m).abs() > 0.01 * final_m.abs());
    Ok(StartUp {
        peak_m: fe.iter().copied().fold(f64::MIN, f64::max),
        early_m: fe[(0.02 / dt).round() as usize],
        settle_1pct_s: outside.map_or(0.0, |k| (k + 1) as f64 * dt),
        final_m,
    })
}

/// The paper's Fig. 20 input: x = R·sin(t/18 s) with R = 300 mm (a circle's axis at
/// 1000 mm/min), reversing at t = 9π ≈ 28.3 s.
pub(crate) fn fig20_commands(dt_s: f64, duration_s: f64) -> AxisCommands {
    let (r, w) = (0.3, 1.0 / 18.0);
    let n = (duration_s / dt_s).round() as usize + 1;
    let mut c = AxisCommands::default();
    for k in 0..n {
        let t = k as f64 * dt_s;
        c.pos_m.push(r * (w * t).sin());
        c.vel_m_per_s.push(r * w * (w * t).cos());
        c.acc_m_per_s2.push(-r * w * w * (w * t).sin());
    }
    c
}

/// What a backlash does to the following error at the Fig. 20 reversal, as the difference
/// between runs with and without it.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct BacklashReversal {
    /// Lasting step: mean difference after the reversal minus before (m). With the motor
    /// encoder as feedback this is −b: the table trails by the whole gap the other way.
    pub step_m: f64,
    /// Largest |difference| after the reversal (m): with a linear scale the loop sees the
    /// stuck table and recovers it, so the backlash shows as a transient spike instead.
    pub spike_m: f64,
}

/// Backlash `b_um` on the X axis at the Fig. 20 reversal, with the given feedback.
pub(crate) fn backlash_reversal(
    machine: &MachineConfig,
    b_um: f64,
    feedback: crate::machine::Feedback,
    sim: &SimConfig,
) -> Result<BacklashReversal, SimError> {
    let dt = 0.002;
    let commands = fig20_commands(dt, 34.0);
    let run = |b: f64| -> Result<Vec<f64>, SimError> {
        let mut axis = machine.x.clone();
        axis.drive.backlash_um = b;
        axis.position_loop.feedback = feedback;
        let t = simulate(&AxisModel::from_config(&axis), &commands, dt, sim)?;
        Ok((0..t.len()).map(|k| t.following_error_m(k)).collect())
    };
    let (with, without) = (run(b_um)?, run(0.0)?);
    let diff: Vec<f64> = with.iter().zip(&without).map(|(a, b)| a - b).collect();
    let reversal = (9.0 * std::f64::consts::PI / dt) as usize;
    let mean = |s: &[f64]| s.iter().sum::<f64>() / s.len() as f64;
    // Before: the 4 s leading up to the reversal; after: the last second of the run.
    let before = mean(&diff[reversal - 2000..reversal - 50]);
    let after = mean(&diff[diff.len() - 500..]);
    Ok(BacklashReversal {
        step_m: after - before,
        spike_m: diff[reversal..].iter().map(|d| d.abs()).fold(0.0, f64::max),
    })
}

/// Following error's mean at steady state and its ripple during the start-up: the largest
/// departure from the ideal first-order lag F/Kv·(1 − e^{−Kv t}) (both m).
pub(crate) fn mean_and_ripple_m(
    axis: &AxisConfig,
    feed_m_per_s: f64,
    sim: &SimConfig,
) -> Result<(f64, f64), SimError> {
    let model = AxisModel::from_config(axis);
    let dt = 0.002;
    let n = (STEADY_AFTER_S / dt).round() as usize + 1;
    let trace = simulate(
        &model,
        &AxisCommands::ramp(0.0, feed_m_per_s, dt, n),
        dt,
        sim,
    )?;
    let kv = model.kv_per_s();
    let ripple = (0..n)
        .map(|k| {
            let ideal = feed_m_per_s / kv * (1.0 - (-kv * k as f64 * dt).exp());
            (trace.following_error_m(k) - ideal).abs()
        })
        .fold(0.0, f64::max);
    Ok((trace.following_error_m(n - 1), ripple))
}

#[cfg(test)]
mod tests;
