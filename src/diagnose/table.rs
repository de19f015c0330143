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
use crate::machine::{AxisConfig, MachineConfig};
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

/// Diagnoses a table on a machine.
pub fn diagnose_table(
    machine: &MachineConfig,
    rows: &[TableRow],
    sim: &SimConfig,
    evidence: f64,
) -> Result<TableDiagnosis, SimError> {
    let nominal = predict_all(machine, rows, 1.0, sim)?;
    let (sigma, noise_rows) = noise_floor(rows, &nominal);
    let rss0 = rss(rows, &nominal);
    let n = rows.len() as f64;
    let cost =
        |gain: f64| predict_all(machine, rows, gain, sim).map_or(f64::INFINITY, |p| rss(rows, &p));
    let gain = golden_section(0.5, 2.0, 1e-6, &cost);
    let evidence_of = |r: f64| {
        if sigma.is_finite() && sigma > 0.0 {
            (rss0 - r) / (sigma * sigma) - n.ln()
        } else {
            f64::NEG_INFINITY
        }
    };
    let kv = evidence_of(cost(gain));
    let candidates = vec![TableCause {
        id: CauseId::KvGain,
        parameter: "gain factor on the set Kv",
        value: gain,
        evidence: kv,
        significant: kv >= evidence,
    }];
    let best = candidates.iter().find(|c| c.significant).map(|c| c.id);
    let extended = if best.is_some() {
        predict_all(machine, rows, gain, sim)?
    } else {
        nominal.clone()
    };
    let mut labels: Vec<String> = rows.iter().map(|r| r.table.clone()).collect();
    labels.dedup();
    let tables = labels
        .into_iter()
        .map(|label| {
            let idx: Vec<usize> = (0..rows.len())
                .filter(|&i| rows[i].table == label)
                .collect();
            let stat = |p: &[f64], abs: bool| {
                let v: Vec<f64> = idx.iter().map(|&i| rows[i].measured_mm - p[i]).collect();
                if abs {
                    v.iter().map(|x| x.abs()).sum::<f64>() / v.len() as f64
                } else {
                    (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt()
                }
            };
            TableStats {
                rows: idx.len(),
                mad_nominal_mm: stat(&nominal, true),
                mad_extended_mm: stat(&extended, true),
                rms_nominal_mm: stat(&nominal, false),
                rms_extended_mm: stat(&extended, false),
                table: label,
            }
        })
        .collect();
    Ok(TableDiagnosis {
        noise_floor_mm: sigma,
        noise_rows,
        candidates,
        kept: best,
        tables,
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
        if self.noise_rows > 0 {
            let _ = writeln!(
                s,
                "noise floor {:.4} mm (scatter of {} rows the model predicts alike)",
                self.noise_floor_mm, self.noise_rows
            );
        } else {
            let _ = writeln!(
                s,
                "no rows the model predicts alike: the noise floor cannot be estimated, no cause can be named"
            );
        }
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

    /// The verdict: the cause kept, or why none is.
    #[cfg(feature = "cli")]
    fn verdict(&self) -> String {
        if let Some(id) = self.kept {
            return format!("Significant cause: {}.", id.as_str());
        }
        let rms = (self
            .rows
            .iter()
            .map(|r| (r.row.measured_mm - r.nominal_mm).powi(2))
            .sum::<f64>()
            / self.rows.len().max(1) as f64)
            .sqrt();
        if self.noise_floor_mm.is_finite() && rms > 2.0 * self.noise_floor_mm {
            format!(
                "No significant cause: the residual ({rms:.4} mm RMS) exceeds the scatter of alike rows \
                 ({:.4} mm), but a gain error does not explain it — the rows scatter about the model without a trend.",
                self.noise_floor_mm
            )
        } else {
            "No significant cause: the nominal model predicts the table to within its scatter."
                .into()
        }
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
