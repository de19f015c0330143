//! What a table of steady following errors lets one say about the model. A cause is named
//! only against the scatter of rows measured alike; where the table has no such rows, or
//! they agree to the last digit, the scatter is unknown and the verdict is "not determined" —
//! with the fitted factor and what it leaves, as a share of the measured errors, so that the
//! user still sees how far the model is off. A table further from the model than any gain
//! error of a machine takes it is a slip in the units or columns, not a measurement to fit.

use serde::Serialize;

use crate::diagnose::plausible::KV_RATIO_MAX;

/// Below this (mm, one nanometre) a scatter or a residual is zero: no table of following
/// errors resolves it. Repeated rows that agree this closely were copied, not measured.
pub(crate) const EXACT_MM: f64 = 1e-6;

/// A residual within the scatter is still no match when the scatter itself is more than
/// this share of the measured errors: the table is then too coarse to judge the model by.
const COARSE_SHARE: f64 = 0.1;

/// The verdict on a table.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum TableVerdict {
    /// A cause explains more than the scatter of alike rows (`kept`).
    Found,
    /// The measured errors lie further from the model than any gain error of a machine
    /// takes them (beyond ×5 either way): a slip in the table's units or columns.
    Implausible,
    /// Not determined: no two rows are predicted alike, so the scatter is unknown.
    NoRepeatedRows,
    /// Not determined: the rows predicted alike agree exactly, which is no estimate of the
    /// scatter.
    ExactRepeats,
    /// Not determined: the residual is within the scatter, but the scatter or the residual
    /// is more than a tenth of the measured errors.
    CoarseScatter,
    /// The nominal model predicts the table to within its scatter.
    WithinScatter,
    /// The residual exceeds the scatter and a gain error does not explain it.
    Unexplained,
}

/// The table's figures the verdict is drawn from (mm).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Figures {
    /// Median of measured ÷ nominal over the rows: how far off the table is, as a factor.
    pub ratio: f64,
    /// RMS of the measured errors themselves: what residuals are shares of.
    pub measured_rms_mm: f64,
    /// RMS of measured − nominal over every row.
    pub residual_rms_nominal_mm: f64,
    /// RMS of measured − the model with the fitted gain factor, kept or not.
    pub residual_rms_fitted_mm: f64,
    /// Pooled scatter of alike rows (NaN where there are none).
    #[serde(skip)]
    pub noise_floor_mm: f64,
}

impl Figures {
    /// The verdict, given whether a cause beat the scatter and how many rows gave it.
    pub(crate) fn verdict(&self, kept: bool, noise_rows: usize) -> TableVerdict {
        let sigma = self.noise_floor_mm;
        if !(1.0 / KV_RATIO_MAX..=KV_RATIO_MAX).contains(&self.ratio) {
            TableVerdict::Implausible
        } else if kept {
            TableVerdict::Found
        } else if noise_rows == 0 || !sigma.is_finite() {
            TableVerdict::NoRepeatedRows
        } else if sigma <= EXACT_MM {
            TableVerdict::ExactRepeats
        } else if self.residual_rms_nominal_mm > 2.0 * sigma {
            TableVerdict::Unexplained
        } else if sigma.max(self.residual_rms_nominal_mm) > COARSE_SHARE * self.measured_rms_mm {
            TableVerdict::CoarseScatter
        } else {
            TableVerdict::WithinScatter
        }
    }
}

/// The verdict in words: what the command line prints.
#[cfg(feature = "cli")]
impl Figures {
    /// `rms` as a share of the measured errors (%).
    fn percent(&self, rms: f64) -> f64 {
        100.0 * rms / self.measured_rms_mm
    }

    /// What the nominal model leaves, as mm and share.
    fn nominal_left(&self) -> String {
        format!(
            "{:.4} mm RMS, {:.1} % of the measured errors",
            self.residual_rms_nominal_mm,
            self.percent(self.residual_rms_nominal_mm)
        )
    }

    /// The fitted factor and what it leaves.
    fn fitted_left(&self, factor: f64) -> String {
        format!(
            "a gain factor {factor:.4} on the set Kv leaves {:.4} mm RMS ({:.1} %)",
            self.residual_rms_fitted_mm,
            self.percent(self.residual_rms_fitted_mm)
        )
    }

    /// A likely slip behind a ratio no machine gives.
    fn slip(&self) -> &'static str {
        let near = |f: f64| (self.ratio / f - 1.0).abs() < 0.1;
        if near(1000.0) {
            "µm written in the mm column?"
        } else if near(1e-3) {
            "m written in the mm column?"
        } else if near(60.0) {
            "the feed in mm/s rather than mm/min?"
        } else if near(1000.0 / 60.0) {
            "Kv in 1/s rather than m/min/mm?"
        } else {
            "check the units of each column"
        }
    }

    /// The verdict as a sentence: the cause found, or why none is, with the residual as a
    /// share of the measured errors.
    pub(crate) fn sentence(&self, verdict: TableVerdict, cause: &str, factor: f64) -> String {
        let sigma = self.noise_floor_mm;
        match verdict {
            TableVerdict::Found => format!(
                "Significant cause: {cause} — {}; the nominal model leaves {}.",
                self.fitted_left(factor),
                self.nominal_left()
            ),
            TableVerdict::Implausible => format!(
                "Implausible table: the measured errors are {} × the model's steady errors \
                 (F/Kv at the rows' settings); no machine with these gains lags so (a gain \
                 beyond ×{KV_RATIO_MAX} of the set one is another machine file) — a unit slip: {} \
                 Nothing is fitted.",
                if self.ratio >= 10.0 {
                    format!("{:.0}", self.ratio)
                } else {
                    format!("{:.3}", self.ratio)
                },
                self.slip()
            ),
            TableVerdict::NoRepeatedRows | TableVerdict::ExactRepeats => format!(
                "Not determined: {}. The nominal model leaves {}; {}. Measure some rows again \
                 (the same axis, feed and gains) to judge the fit against the scatter.",
                if verdict == TableVerdict::NoRepeatedRows {
                    "no repeated rows to judge the scatter"
                } else {
                    "the repeated rows agree exactly, which is no estimate of the scatter"
                },
                self.nominal_left(),
                self.fitted_left(factor)
            ),
            TableVerdict::CoarseScatter => format!(
                "Not determined: the nominal model leaves {}, within the scatter of alike rows \
                 ({sigma:.4} mm), but that scatter is itself {:.1} % of the measured errors: too \
                 coarse to judge the model by; {}.",
                self.nominal_left(),
                self.percent(sigma),
                self.fitted_left(factor)
            ),
            TableVerdict::WithinScatter => format!(
                "No significant cause: the nominal model predicts the table to within its \
                 scatter ({}; scatter of alike rows {sigma:.4} mm).",
                self.nominal_left()
            ),
            TableVerdict::Unexplained => format!(
                "No significant cause: the residual ({}) exceeds the scatter of alike rows \
                 ({sigma:.4} mm), but a gain error does not explain it ({}) — the rows scatter \
                 about the model without a trend.",
                self.nominal_left(),
                self.fitted_left(factor)
            ),
        }
    }
}
