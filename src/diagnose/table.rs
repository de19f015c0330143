//! Diagnosis of steady following-error tables (the paper's Tables 3–5 are one): each row
//! a feed, Kv and K_s with the measured error; the model's steady error (a velocity step from
//! rest, read after many time constants) against it.
//!
//! The noise floor is the scatter of rows the model predicts alike (same F/Kv — the paper's
//! Table 5 varies only K_s, which leaves the steady error unchanged). Of the catalogue, only
//! a gain other than the one set (a factor g on every row's Kv) changes a steady following
//! error as the control reports it: a dead time delays the set point the error is taken
//! against, friction and backlash act at reversals, measuring errors move the position and
//! its feedback together. The factor is fitted by one-dimensional minimisation through the
//! simulator and kept only with evidence above the noise, as for traces.

use rayon::prelude::*;
use serde::Serialize;

use crate::diagnose::causes::CauseId;
use crate::diagnose::plausible::KV_RATIO_MAX;
use crate::diagnose::table_verdict::{EXACT_MM, Figures, TableVerdict};
use crate::machine::{AxisConfig, AxisName, MachineConfig};
use crate::numeric::golden_section;
use crate::numeric::units::{m_per_s_from_mm_per_min, mm_from_m};
use crate::plan::AxisCommands;
use crate::sim::{AxisModel, SimConfig, SimError, simulate};
use crate::trace::measured::TableRow;

/// How long a row's run lasts before its error is read (s): many times 1/Kv.
pub(crate) const STEADY_AFTER_S: f64 = 4.0;

/// The following error (m) of an axis after a velocity step from rest to `feed`, every
/// `START_UP_STEP_S` over `STEADY_AFTER_S`.
pub(crate) fn start_up_following_error_m(
    axis: &AxisConfig,
    feed_m_per_s: f64,
    sim: &SimConfig,
) -> Result<Vec<f64>, SimError> {
    let model = AxisModel::from_config(axis);
    let n = (STEADY_AFTER_S / START_UP_STEP_S).round() as usize + 1;
    let commands = AxisCommands::ramp(0.0, feed_m_per_s, START_UP_STEP_S, n);
    let trace = simulate(&model, &commands, START_UP_STEP_S, sim)?;
    Ok((0..n).map(|k| trace.following_error_m(k)).collect())
}

/// The sample step of a start-up (s): fine against 1/Kv.
pub(crate) const START_UP_STEP_S: f64 = 0.002;

/// The steady following error (m) of an axis after a velocity step from rest to `feed`.
pub(crate) fn steady_following_error_m(
    axis: &AxisConfig,
    feed_m_per_s: f64,
    sim: &SimConfig,
) -> Result<f64, SimError> {
    let fe = start_up_following_error_m(axis, feed_m_per_s, sim)?;
    Ok(fe[fe.len() - 1])
}

/// One row with the model's predictions (mm).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RowResult {
    /// The row.
    #[serde(flatten)]
    pub row: TableRow,
    /// Nominal model.
    pub nominal_mm: f64,
    /// Extended model.
    pub extended_mm: f64,
}

/// Residual figures of one table (mm).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TableStats {
    /// Table label.
    pub table: String,
    /// Rows.
    pub rows: usize,
    /// Mean |measured − nominal|.
    pub mad_nominal_mm: f64,
    /// Mean |measured − extended|.
    pub mad_extended_mm: f64,
    /// RMS of measured − nominal.
    pub rms_nominal_mm: f64,
    /// RMS of measured − extended.
    pub rms_extended_mm: f64,
}

/// A cause fitted to a table.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TableCause {
    /// Id.
    pub id: CauseId,
    /// What the parameter is.
    pub parameter: &'static str,
    /// Fitted value.
    pub value: f64,
    /// Evidence (BIC units).
    pub evidence: f64,
    /// Whether it beats the noise floor.
    pub significant: bool,
}

/// The outcome.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TableDiagnosis {
    /// What the table lets one say.
    pub verdict: TableVerdict,
    /// The figures it is drawn from.
    #[serde(flatten)]
    pub figures: Figures,
    /// Noise floor: scatter of alike rows (mm, standard deviation).
    pub noise_floor_mm: f64,
    /// Rows the noise floor was estimated from.
    pub noise_rows: usize,
    /// Both candidates, fitted.
    pub candidates: Vec<TableCause>,
    /// The cause kept, if any.
    pub kept: Option<CauseId>,
    /// Per table.
    pub tables: Vec<TableStats>,
    /// Per row.
    pub rows: Vec<RowResult>,
}

/// A row's steady error (mm) on `machine` with a factor on the row's Kv.
fn predict(
    machine: &MachineConfig,
    row: &TableRow,
    gain: f64,
    sim: &SimConfig,
) -> Result<f64, SimError> {
    let mut axis = machine.axis(row.axis).clone();
    axis.position_loop.kv_m_per_min_per_mm = row.kv_m_per_min_per_mm * gain;
    if let Some(v) = axis.velocity_loop.as_mut() {
        v.ks_nm_s_per_rad = row.ks_nm_s_per_rad;
    }
    Ok(mm_from_m(steady_following_error_m(
        &axis,
        m_per_s_from_mm_per_min(row.feed_mm_per_min),
        sim,
    )?))
}

fn predict_all(
    machine: &MachineConfig,
    rows: &[TableRow],
    gain: f64,
    sim: &SimConfig,
) -> Result<Vec<f64>, SimError> {
    rows.par_iter()
        .map(|r| predict(machine, r, gain, sim))
        .collect()
}

fn rss(rows: &[TableRow], predicted: &[f64]) -> f64 {
    rows.iter()
        .zip(predicted)
        .map(|(r, p)| (r.measured_mm - p).powi(2))
        .sum()
}

/// Pooled standard deviation of rows with the same predicted error (mm) and how many rows
/// that used.
fn noise_floor(rows: &[TableRow], predicted: &[f64]) -> (f64, usize) {
    let mut groups: Vec<(f64, Vec<f64>)> = Vec::new();
    for (r, &p) in rows.iter().zip(predicted) {
        match groups.iter_mut().find(|g| (g.0 - p).abs() < 1e-7) {
            Some(g) => g.1.push(r.measured_mm),
            None => groups.push((p, vec![r.measured_mm])),
        }
    }
    let (mut ss, mut dof, mut used) = (0.0, 0usize, 0usize);
    for (_, v) in groups.iter().filter(|g| g.1.len() > 1) {
        let mean = v.iter().sum::<f64>() / v.len() as f64;
        ss += v.iter().map(|x| (x - mean).powi(2)).sum::<f64>();
        dof += v.len() - 1;
        used += v.len();
    }
    if dof == 0 {
        (f64::NAN, 0)
    } else {
        ((ss / dof as f64).sqrt(), used)
    }
}

/// Why a table cannot be diagnosed on a machine.
#[derive(Debug, thiserror::Error)]
pub enum TableError {
    /// The model cannot be simulated with a row's settings.
    #[error("{0}")]
    Sim(#[from] SimError),
    /// A row's axis has no cascade: the row's Kv and K_s have nothing to set.
    #[error(
        "line {line}: axis {axis}: {why} — the row's kv_m_per_min_per_mm and ks_nm_s_per_rad \
         have nothing to set on this machine; a table of steady errors by Kv and K_s needs a \
         machine whose {axis} axis is the cascade (e.g. --machine hvmc)"
    )]
    NoCascade {
        /// 1-based line of the first such row.
        line: u64,
        /// Its axis.
        axis: AxisName,
        /// Why the axis has no Kv.
        why: &'static str,
    },
}

/// Refuses rows whose axis has no Kv and K_s to set them in.
fn cascade_rows(machine: &MachineConfig, rows: &[TableRow]) -> Result<(), TableError> {
    for r in rows {
        if let Some(why) = CauseId::KvGain.inapplicable_to(machine.axis(r.axis)) {
            return Err(TableError::NoCascade {
                line: r.line,
                axis: r.axis,
                why,
            });
        }
    }
    Ok(())
}

/// RMS (mm) of measured − `predicted` over the rows `idx`.
fn rms_of(rows: &[TableRow], predicted: &[f64], idx: &[usize]) -> f64 {
    let ss: f64 = idx
        .iter()
        .map(|&i| (rows[i].measured_mm - predicted[i]).powi(2))
        .sum();
    (ss / idx.len().max(1) as f64).sqrt()
}

/// Per table label: its rows' spread about both models.
fn table_stats(rows: &[TableRow], nominal: &[f64], extended: &[f64]) -> Vec<TableStats> {
    let mut labels: Vec<String> = rows.iter().map(|r| r.table.clone()).collect();
    labels.dedup();
    labels
        .into_iter()
        .map(|label| {
            let idx: Vec<usize> = (0..rows.len())
                .filter(|&i| rows[i].table == label)
                .collect();
            let mad = |p: &[f64]| {
                idx.iter()
                    .map(|&i| (rows[i].measured_mm - p[i]).abs())
                    .sum::<f64>()
                    / idx.len() as f64
            };
            TableStats {
                rows: idx.len(),
                mad_nominal_mm: mad(nominal),
                mad_extended_mm: mad(extended),
                rms_nominal_mm: rms_of(rows, nominal, &idx),
                rms_extended_mm: rms_of(rows, extended, &idx),
                table: label,
            }
        })
        .collect()
}

/// The factor on every row's Kv that fits the table best, searched on a logarithmic scale
/// over the gains a machine of this file could have.
fn fitted_gain(machine: &MachineConfig, rows: &[TableRow], sim: &SimConfig) -> f64 {
    let cost = |ln_gain: f64| {
        predict_all(machine, rows, ln_gain.exp(), sim).map_or(f64::INFINITY, |p| rss(rows, &p))
    };
    let bound = KV_RATIO_MAX.ln();
    golden_section(-bound, bound, 1e-7, &cost).exp()
}

/// Diagnoses a table on a machine.
pub fn diagnose_table(
    machine: &MachineConfig,
    rows: &[TableRow],
    sim: &SimConfig,
    evidence: f64,
) -> Result<TableDiagnosis, TableError> {
    cascade_rows(machine, rows)?;
    let nominal = predict_all(machine, rows, 1.0, sim)?;
    let (sigma, noise_rows) = noise_floor(rows, &nominal);
    let gain = fitted_gain(machine, rows, sim);
    let fitted = predict_all(machine, rows, gain, sim)?;
    let all: Vec<usize> = (0..rows.len()).collect();
    let figures = Figures {
        ratio: median_ratio(rows, &nominal),
        measured_rms_mm: (rows.iter().map(|r| r.measured_mm.powi(2)).sum::<f64>()
            / rows.len().max(1) as f64)
            .sqrt(),
        residual_rms_nominal_mm: rms_of(rows, &nominal, &all),
        residual_rms_fitted_mm: rms_of(rows, &fitted, &all),
        noise_floor_mm: sigma,
    };
    let plausible = (1.0 / KV_RATIO_MAX..=KV_RATIO_MAX).contains(&figures.ratio);
    let n = rows.len() as f64;
    let kv = if sigma.is_finite() && sigma > EXACT_MM {
        (rss(rows, &nominal) - rss(rows, &fitted)) / (sigma * sigma) - n.ln()
    } else {
        f64::NEG_INFINITY
    };
    let candidates = vec![TableCause {
        id: CauseId::KvGain,
        parameter: "gain factor on the set Kv",
        value: gain,
        evidence: kv,
        significant: plausible && kv >= evidence,
    }];
    let kept = candidates.iter().find(|c| c.significant).map(|c| c.id);
    let verdict = figures.verdict(kept.is_some(), noise_rows);
    let extended = if kept.is_some() {
        fitted
    } else {
        nominal.clone()
    };
    Ok(TableDiagnosis {
        verdict,
        figures,
        noise_floor_mm: sigma,
        noise_rows,
        candidates,
        kept,
        tables: table_stats(rows, &nominal, &extended),
        rows: rows
            .iter()
            .zip(nominal.iter().zip(&extended))
            .map(|(r, (a, b))| RowResult {
                row: r.clone(),
                nominal_mm: *a,
                extended_mm: *b,
            })
            .collect(),
    })
}

/// The median of measured ÷ nominal over the rows: how far the table lies from the model
/// as a factor, unmoved by a few odd rows.
fn median_ratio(rows: &[TableRow], nominal: &[f64]) -> f64 {
    let mut r: Vec<f64> = rows
        .iter()
        .zip(nominal)
        .filter(|(_, p)| **p > 0.0)
        .map(|(row, p)| row.measured_mm / p)
        .collect();
    if r.is_empty() {
        return f64::NAN;
    }
    r.sort_by(f64::total_cmp);
    let m = r.len() / 2;
    if r.len() % 2 == 1 {
        r[m]
    } else {
        0.5 * (r[m - 1] + r[m])
    }
}

/// Schema id of the table diagnosis as JSON.
pub const TABLE_SCHEMA: &str = "contourcheck.diagnose-table/1";

impl TableDiagnosis {
    /// The diagnosis as its JSON document: the schema, the table file and the machine, then
    /// the diagnosis itself.
    #[cfg(feature = "cli")]
    pub(crate) fn json_document<'a>(
        &'a self,
        file: &'a str,
        machine: &'a str,
    ) -> impl Serialize + 'a {
        #[derive(Serialize)]
        struct Doc<'a> {
            schema: &'static str,
            table_file: &'a str,
            machine: &'a str,
            #[serde(flatten)]
            diagnosis: &'a TableDiagnosis,
        }
        Doc {
            schema: TABLE_SCHEMA,
            table_file: file,
            machine,
            diagnosis: self,
        }
    }

    /// The summary for the terminal.
    #[cfg(feature = "cli")]
    pub(crate) fn summary_text(&self, file: &str, machine: &str) -> String {
        use std::fmt::Write as _;
        let mut s = String::new();
        let _ = writeln!(
            s,
            "Diagnosis of the steady following errors in {file} ({} rows) on {machine}",
            self.rows.len()
        );
        let _ = writeln!(s, "{}", self.scatter_line());
        let _ = writeln!(s, "\nCandidates:");
        for c in &self.candidates {
            let _ = writeln!(
                s,
                "  {:<10} {} = {:.4}  evidence {:.1}{}",
                c.id.as_str(),
                c.parameter,
                c.value,
                c.evidence,
                if Some(c.id) == self.kept {
                    "  ← kept"
                } else if c.significant {
                    "  (significant)"
                } else {
                    ""
                }
            );
        }
        let _ = writeln!(s, "\n{}", self.verdict());
        s.push_str(&self.tables_text());
        s.push_str(&self.rows_text());
        s
    }

    /// What the scatter of alike rows is, or why the table has none.
    #[cfg(feature = "cli")]
    fn scatter_line(&self) -> String {
        if self.noise_rows == 0 {
            "not determined: no repeated rows to judge the scatter (no two rows the model \
             predicts alike), so no cause can be named"
                .into()
        } else if self.noise_floor_mm <= EXACT_MM {
            format!(
                "not determined: the {} rows the model predicts alike agree exactly, which is no \
                 estimate of the scatter, so no cause can be named",
                self.noise_rows
            )
        } else {
            format!(
                "noise floor {:.4} mm (scatter of {} rows the model predicts alike)",
                self.noise_floor_mm, self.noise_rows
            )
        }
    }

    /// The verdict: the cause kept, or why none is.
    #[cfg(feature = "cli")]
    fn verdict(&self) -> String {
        let c = &self.candidates[0];
        self.figures
            .sentence(self.verdict, self.kept.unwrap_or(c.id).as_str(), c.value)
    }

    /// Each table's spread about both models.
    #[cfg(feature = "cli")]
    fn tables_text(&self) -> String {
        use std::fmt::Write as _;
        let mut s = String::new();
        let _ = writeln!(
            s,
            "\n  {:<8} {:>5} {:>16} {:>16} {:>14} {:>14}",
            "table", "rows", "MAD nominal mm", "MAD extended mm", "RMS nominal", "RMS extended"
        );
        for t in &self.tables {
            let _ = writeln!(
                s,
                "  {:<8} {:>5} {:>16.5} {:>16.5} {:>14.5} {:>14.5}",
                t.table,
                t.rows,
                t.mad_nominal_mm,
                t.mad_extended_mm,
                t.rms_nominal_mm,
                t.rms_extended_mm
            );
        }
        s
    }

    /// Every row: its settings, the measured error and both models'.
    #[cfg(feature = "cli")]
    fn rows_text(&self) -> String {
        use std::fmt::Write as _;
        let mut s = String::new();
        let _ = writeln!(
            s,
            "\n  {:<8} {:>5} {:>9} {:>7} {:>6} {:>12} {:>12} {:>12}",
            "table", "axis", "feed", "Kv", "Ks", "measured mm", "nominal mm", "extended mm"
        );
        for r in &self.rows {
            let _ = writeln!(
                s,
                "  {:<8} {:>5} {:>9.0} {:>7.2} {:>6.1} {:>12.4} {:>12.4} {:>12.4}",
                r.row.table,
                r.row.axis,
                r.row.feed_mm_per_min,
                r.row.kv_m_per_min_per_mm,
                r.row.ks_nm_s_per_rad,
                r.row.measured_mm,
                r.nominal_mm,
                r.extended_mm
            );
        }
        s
    }
}
