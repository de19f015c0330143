//! `diagnose --table` where the table cannot judge the model: one row per feed (no scatter
//! to weigh a cause against), rows copied rather than measured again, a table in the wrong
//! units, a machine without the gains the table sets. Every table is built from the steady
//! following error of a position loop, F/Kv (F in m/min, Kv in m/min/mm, the error in mm):
//! a table at `factor` × F/Kv is the table of a machine whose real gain is Kv / `factor`.

use crate::common;

use std::path::Path;

use common::cli::{run, run_ok, text};
use contourcheck::diagnose::causes::CauseId;
use contourcheck::diagnose::table::{TableDiagnosis, TableError, diagnose_table};
use contourcheck::diagnose::table_verdict::TableVerdict;
use contourcheck::machine::{AxisName, MachineConfig};
use contourcheck::sim::SimConfig;
use contourcheck::trace::measured::parse_table;

const HEADER: &str =
    "table,axis,feed_mm_per_min,kv_m_per_min_per_mm,ks_nm_s_per_rad,following_error_mm\n";

/// A table of X at Kv 1 m/min/mm and K_s 16, one row per feed of 100..1000 mm/min and
/// `repeats` rows each, each at `factor` × F/Kv plus the row's entry of `scatter_mm`.
fn table(factor: f64, repeats: usize, scatter_mm: &[f64]) -> String {
    let mut text = String::from(HEADER);
    for (i, feed) in (1..=10).map(|k| 100.0 * k as f64).enumerate() {
        for j in 0..repeats {
            let f_over_kv_mm = feed / 1000.0 / 1.0;
            let e = scatter_mm[(i + j) % scatter_mm.len()];
            text.push_str(&format!(
                "T,X,{feed},1.0,16,{}\n",
                factor * f_over_kv_mm + e
            ));
        }
    }
    text
}

fn diagnosed(text: &str) -> TableDiagnosis {
    let rows = parse_table(text, "t.csv").unwrap();
    diagnose_table(
        &MachineConfig::default_preset(),
        &rows,
        &SimConfig::default(),
        10.0,
    )
    .unwrap()
}

/// The residual's share of the measured errors.
fn share(d: &TableDiagnosis) -> f64 {
    d.figures.residual_rms_nominal_mm / d.figures.measured_rms_mm
}

#[test]
fn one_row_per_feed_is_not_determined_and_still_shows_the_factor() {
    // Every row 1.3 × F/Kv: the residual is 0.3/1.3 of every row, so of their RMS too.
    let d = diagnosed(&table(1.3, 1, &[0.0]));
    assert_eq!(d.verdict, TableVerdict::NoRepeatedRows);
    assert_eq!(d.kept, None);
    assert_eq!(d.noise_rows, 0);
    assert!((share(&d) - 0.3 / 1.3).abs() < 1e-3, "{}", share(&d));
    let factor = d.candidates[0].value;
    assert!((factor - 1.0 / 1.3).abs() < 1e-3, "{factor}");
    assert!(d.figures.residual_rms_fitted_mm < 1e-3 * d.figures.measured_rms_mm);
    // Measured three times with 2 µm of scatter, the same table names the gain error.
    let d = diagnosed(&table(
        1.3,
        3,
        &[0.002, -0.001, -0.0015, 0.0005, 0.001, -0.002],
    ));
    assert_eq!(d.verdict, TableVerdict::Found);
    assert_eq!(d.kept, Some(CauseId::KvGain));
    assert!((d.candidates[0].value - 1.0 / 1.3).abs() < 0.005);
}

#[test]
fn a_table_a_thousand_times_the_model_is_implausible_even_with_repeats() {
    // µm written in the mm column of a machine 10 % slower than set: the repeats' scatter
    // would make any gain factor "significant".
    let d = diagnosed(&table(1000.0 * 1.1, 3, &[2.0, -1.0, -1.5, 0.5, 1.0, -2.0]));
    assert_eq!(d.verdict, TableVerdict::Implausible);
    assert_eq!(d.kept, None);
    assert!(!d.candidates[0].significant);
    assert!(
        (d.figures.ratio / 1100.0 - 1.0).abs() < 0.01,
        "{}",
        d.figures.ratio
    );
    // Three times the model is a gain a third of the set one: still a machine's.
    let d = diagnosed(&table(
        3.0,
        3,
        &[0.002, -0.001, -0.0015, 0.0005, 0.001, -0.002],
    ));
    assert_eq!(d.verdict, TableVerdict::Found);
    assert!((d.candidates[0].value - 1.0 / 3.0).abs() < 0.005);
}

#[test]
fn within_the_scatter_only_where_the_scatter_is_fine_against_the_values() {
    // At F/Kv with 1 µm of scatter on errors of 0.1–1 mm: the model holds.
    let d = diagnosed(&table(1.0, 2, &[0.001, -0.001]));
    assert_eq!(d.verdict, TableVerdict::WithinScatter);
    // With ±0.08 mm on the same rows (their scatter 0.08·√2 = 0.113 mm, a sixth of their
    // RMS) the model is within the scatter too, but so would be a model 10 % off.
    let d = diagnosed(&table(1.0, 2, &[0.08, -0.08]));
    assert_eq!(d.verdict, TableVerdict::CoarseScatter);
}

#[test]
fn rows_that_agree_exactly_are_no_scatter_and_no_residual_exceeds_it() {
    let text = format!("{HEADER}T,X,500,1,16,0.5\nT,Z,500,1,16,0.5\nT,X,1000,1,16,1.0\n");
    let d = diagnosed(&text);
    assert_eq!(d.noise_rows, 2);
    assert_eq!(d.verdict, TableVerdict::ExactRepeats);
    assert!(d.figures.residual_rms_nominal_mm < 1e-6);
}

#[test]
fn a_machine_without_the_cascade_refuses_a_table_of_its_gains() {
    let paper = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("data/paper-tables.csv"),
    )
    .unwrap();
    let rows = parse_table(&paper, "paper-tables.csv").unwrap();
    let small = MachineConfig::preset("small-table").unwrap();
    let err = diagnose_table(&small, &rows, &SimConfig::default(), 10.0).unwrap_err();
    // Four comment lines and the header before the first row.
    assert!(
        matches!(
            err,
            TableError::NoCascade {
                line: 6,
                axis: AxisName::X,
                ..
            }
        ),
        "{err}"
    );
}

#[test]
fn the_command_line_says_not_determined_for_one_row_per_feed() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("k13.csv");
    std::fs::write(&path, table(1.3, 1, &[0.0])).unwrap();
    let out = text(&run_ok(&["diagnose", "--table", path.to_str().unwrap()]).stdout);
    let second = out.lines().nth(1).unwrap();
    assert!(
        second.starts_with("not determined: no repeated rows to judge the scatter"),
        "{out}"
    );
    assert!(!out.contains("within its scatter"), "{out}");
    assert!(out.contains("23.1 % of the measured errors"), "{out}");
    let thousand = dir.path().join("um.csv");
    std::fs::write(&thousand, table(1000.0, 1, &[0.0])).unwrap();
    let out = text(&run_ok(&["diagnose", "--table", thousand.to_str().unwrap()]).stdout);
    assert!(out.contains("Implausible table"), "{out}");
    assert!(out.contains("µm written in the mm column"), "{out}");
    let o = run(&[
        "diagnose",
        "--table",
        path.to_str().unwrap(),
        "--machine",
        "small-table",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        text(&o.stderr).contains("not the cascade"),
        "{}",
        text(&o.stderr)
    );
}
