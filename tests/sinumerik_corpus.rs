//! SINUMERIK programs written by others, found in the folder that the environment variable
//! `CONTOURCHECK_SINUMERIK_CORPUS` names. The files are not part of the repository; what is
//! expected of each is (`tests/data/sinumerik-corpus.tsv`: where the file came from, and
//! whether it checks, is refused at a line and column for a named feature, or stops at an
//! error the control would stop at too). Without the variable each test says "skipped:
//! corpus not present" and passes.
//!
//! A manifest's `prelude` is the control's state at program start that a file assumes
//! without setting it (the 840D's initial motion mode and feed are machine data; another
//! interpreter's tests start from a state file of their own): its lines (`\n` between them)
//! are put before the file's first, and the expected lines count from the file's own first
//! line.
//!
//! Where a file `NAME.csv` stands beside `NAME.mpf` with `X`, `Y`, `Z` columns — the block by
//! block positions another SINUMERIK interpreter wrote for it — the positions this one
//! reaches must be those, in the same order, to 1 µm.

mod common;

use std::path::Path;

use contourcheck::gcode::{GcodeErrorKind, InterpretOptions, Program, parse_program};
use contourcheck::machine::MachineConfig;
use contourcheck::path::Geometry;
use contourcheck::plan::{KinematicLimits, PlanConfig, plan};

const CORPUS_VARIABLE: &str = "CONTOURCHECK_SINUMERIK_CORPUS";
const MANIFEST: &str = include_str!("data/sinumerik-corpus.tsv");

/// What a program is expected to do.
#[derive(Debug)]
enum Expect {
    /// Read and planned.
    Checks,
    /// Refused for a feature this does not read, at `line:column`, naming `word`.
    Refused {
        line: u32,
        column: u32,
        word: String,
    },
    /// Stopped at `line:column` by an error whose message holds `says`.
    Error {
        line: u32,
        column: u32,
        says: String,
    },
}

struct Entry {
    file: String,
    prelude: String,
    expect: Expect,
}

fn manifest() -> Vec<Entry> {
    let mut lines = MANIFEST
        .lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty());
    let header: Vec<&str> = lines.next().expect("a header").split('\t').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).expect(name);
    let (c_file, c_expect, c_at, c_says) = (col("file"), col("expect"), col("at"), col("says"));
    let c_prelude = col("prelude");
    lines
        .map(|l| {
            let f: Vec<&str> = l.split('\t').collect();
            let at = || {
                let (line, column) = f[c_at].split_once(':').expect("line:column");
                (line.parse().unwrap(), column.parse().unwrap())
            };
            let says = f[c_says].to_string();
            let expect = match f[c_expect] {
                "checks" => Expect::Checks,
                "refused" => {
                    let (line, column) = at();
                    Expect::Refused {
                        line,
                        column,
                        word: says,
                    }
                }
                "error" => {
                    let (line, column) = at();
                    Expect::Error { line, column, says }
                }
                other => panic!("manifest: unknown expectation {other}"),
            };
            Entry {
                file: f[c_file].to_string(),
                prelude: f[c_prelude].to_string(),
                expect,
            }
        })
        .collect()
}

fn interpret(
    dir: &Path,
    file: &str,
    prelude: &str,
) -> Result<Program, contourcheck::gcode::GcodeErrors> {
    let bytes = std::fs::read(dir.join(file)).unwrap();
    let mut text = String::from_utf8_lossy(&bytes).into_owned();
    if !prelude.is_empty() {
        text = format!("{}\n{text}", prelude.replace("\\n", "\n"));
    }
    let opts = InterpretOptions {
        subprogram_folder: Some(dir.to_path_buf()),
        ..InterpretOptions::default()
    };
    parse_program(&text, file, &opts)
}

/// The positions the other interpreter wrote, block by block, with repeats dropped (its
/// axes unset until programmed count as the start, 0).
fn reference_positions(csv: &Path, start: [f64; 3]) -> Vec<[f64; 3]> {
    let text = std::fs::read_to_string(csv).unwrap();
    let mut rows = text.lines();
    let header: Vec<&str> = rows.next().unwrap().split(',').collect();
    let cols = ["X", "Y", "Z"].map(|a| header.iter().position(|h| *h == a));
    let mut at = start;
    let mut out = vec![at];
    for row in rows {
        let cells = split_csv(row);
        for (axis, col) in cols.iter().enumerate() {
            if let Some(v) = col.and_then(|c| cells.get(c)).and_then(|c| c.parse().ok()) {
                at[axis] = v;
            }
        }
        push_distinct(&mut out, at);
    }
    out
}

/// A CSV row's cells, quoted cells (comments with commas) kept whole.
fn split_csv(row: &str) -> Vec<String> {
    let (mut cells, mut cell, mut quoted) = (Vec::new(), String::new(), false);
    for c in row.chars() {
        match c {
            '"' => quoted = !quoted,
            ',' if !quoted => cells.push(std::mem::take(&mut cell)),
            c => cell.push(c),
        }
    }
    cells.push(cell);
    cells
}

fn push_distinct(list: &mut Vec<[f64; 3]>, p: [f64; 3]) {
    if list
        .last()
        .is_none_or(|q| (0..3).any(|i| (q[i] - p[i]).abs() > 1e-9))
    {
        list.push(p);
    }
}

/// The positions this interpreter reaches from the file's first line on: where the prelude
/// left the tool, then each move's end (mm).
fn positions(program: &Program, prelude_lines: u32) -> Vec<[f64; 3]> {
    let moves = program
        .segments
        .iter()
        .filter(|s| !matches!(s.geometry, Geometry::Dwell { .. }));
    let mm = |s: &contourcheck::path::Segment| s.end_m.map(|v| v * 1e3);
    let start = moves
        .clone()
        .rfind(|s| s.line <= prelude_lines)
        .map_or([0.0; 3], mm);
    let mut out = vec![start];
    for s in moves.filter(|s| s.line > prelude_lines) {
        push_distinct(&mut out, mm(s));
    }
    out
}

#[test]
fn sinumerik_programs_of_others_check_or_are_refused_where_expected() {
    let Some(dir) = common::corpus_dir(CORPUS_VARIABLE) else {
        return;
    };
    let machine = MachineConfig::default_preset();
    let limits = KinematicLimits::of(&machine);
    let config = PlanConfig::for_machine(&machine);
    let mut failures = Vec::new();
    let mut present = 0;
    for entry in manifest() {
        if !dir.join(&entry.file).is_file() {
            println!("{}: not in the corpus folder, skipped", entry.file);
            continue;
        }
        present += 1;
        let result = interpret(&dir, &entry.file, &entry.prelude);
        // The prelude's lines come before the file's first.
        let shift = if entry.prelude.is_empty() {
            0
        } else {
            entry.prelude.matches("\\n").count() as u32 + 1
        };
        let verdict = match (&entry.expect, &result) {
            (Expect::Checks, Ok(program)) => {
                let planned = plan(program, &limits, &config);
                let csv = dir.join(&entry.file).with_extension("csv");
                if !planned.total_time_s.is_finite() {
                    Err("the plan has no finite duration".to_string())
                } else if csv.is_file() {
                    let ours = positions(program, shift);
                    compare(&reference_positions(&csv, ours[0]), &ours)
                } else {
                    Ok(())
                }
            }
            (Expect::Refused { line, column, word }, Err(errors)) => {
                let e = &errors.0[0];
                match &e.kind {
                    GcodeErrorKind::Unsupported { word: w, .. }
                        if (e.pos.line, e.pos.column) == (*line + shift, *column)
                            && w.contains(word.as_str()) =>
                    {
                        Ok(())
                    }
                    _ => Err(format!("refused otherwise: {e}")),
                }
            }
            (Expect::Error { line, column, says }, Err(errors)) => {
                let e = &errors.0[0];
                if (e.pos.line, e.pos.column) == (*line + shift, *column)
                    && e.kind.to_string().contains(says.as_str())
                {
                    Ok(())
                } else {
                    Err(format!("stopped otherwise: {e}"))
                }
            }
            (_, Ok(_)) => Err("read without an error".to_string()),
            (_, Err(errors)) => Err(format!("not read: {}", errors.0[0])),
        };
        match verdict {
            Ok(()) => println!("{}: as expected ({:?})", entry.file, entry.expect),
            Err(why) => failures.push(format!(
                "{} (expected {:?}): {why}",
                entry.file, entry.expect
            )),
        }
    }
    println!("{present} programs of the manifest present");
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn every_sinumerik_program_in_the_folder_reads_or_stops_at_a_line() {
    let Some(dir) = common::corpus_dir(CORPUS_VARIABLE) else {
        return;
    };
    // Files the manifest does not know yet: read without a panic, and either checked or
    // stopped at a line of the file.
    for item in std::fs::read_dir(&dir).unwrap() {
        let path = item.unwrap().path();
        let is_program = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("mpf") || e.eq_ignore_ascii_case("spf"));
        if !is_program {
            continue;
        }
        let file = path.file_name().unwrap().to_string_lossy().to_string();
        if let Err(errors) = interpret(&dir, &file, "") {
            for e in &errors.0 {
                assert!(e.pos.line >= 1, "{file}: an error without its line: {e}");
            }
        }
    }
}

fn compare(reference: &[[f64; 3]], ours: &[[f64; 3]]) -> Result<(), String> {
    if reference.len() != ours.len() {
        return Err(format!(
            "{} positions here, {} in the other interpreter's record:\n here  {ours:?}\n there {reference:?}",
            ours.len(),
            reference.len()
        ));
    }
    for (k, (a, b)) in reference.iter().zip(ours).enumerate() {
        if (0..3).any(|i| (a[i] - b[i]).abs() > 1e-3) {
            return Err(format!("position {k}: {b:?} here, {a:?} there"));
        }
    }
    Ok(())
}
