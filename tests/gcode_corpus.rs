//! The real-program corpus in `../shared/gcode-corpus/` (programs written by others, with a
//! manifest of where each came from and whether LinuxCNC's interpreter accepts it): every
//! XY program LinuxCNC accepts must interpret, and every program in `reject/` must be refused
//! with an error that names its line and column.

use std::path::{Path, PathBuf};

use contourcheck::gcode::{InterpretOptions, parse_program};

fn corpus_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/gcode-corpus")
}

struct Entry {
    category: String,
    file: String,
    linuxcnc_accepts: bool,
}

fn manifest() -> Vec<Entry> {
    let text = std::fs::read_to_string(corpus_dir().join("MANIFEST.tsv"))
        .expect("the G-code corpus manifest ../shared/gcode-corpus/MANIFEST.tsv");
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split('\t').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (c_cat, c_file, c_rc) = (col("category"), col("file"), col("rs274_rc"));
    lines
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let f: Vec<&str> = l.split('\t').collect();
            Entry {
                category: f[c_cat].to_string(),
                file: f[c_file].to_string(),
                linuxcnc_accepts: f[c_rc] == "0",
            }
        })
        .collect()
}

fn read(entry: &Entry) -> String {
    let bytes = std::fs::read(corpus_dir().join(&entry.file)).unwrap();
    String::from_utf8_lossy(&bytes).into_owned()
}

#[test]
fn every_xy_program_linuxcnc_accepts_interprets() {
    let mut failures = Vec::new();
    let mut count = 0;
    for e in manifest()
        .iter()
        .filter(|e| e.category != "reject" && e.linuxcnc_accepts)
    {
        count += 1;
        match parse_program(&read(e), &e.file, &InterpretOptions::default()) {
            Ok(p) => assert!(!p.segments.is_empty(), "{}: no path", e.file),
            Err(err) => failures.push(format!("{err}")),
        }
    }
    assert!(
        count >= 60,
        "the manifest lists {count} accepted XY programs"
    );
    assert!(
        failures.is_empty(),
        "{} failed:\n{}",
        failures.len(),
        failures.join("\n")
    );
}

#[test]
fn every_reject_program_is_refused_with_line_and_column() {
    let mut accepted = Vec::new();
    let mut count = 0;
    for e in manifest().iter().filter(|e| e.category == "reject") {
        count += 1;
        let src = read(e);
        match parse_program(&src, &e.file, &InterpretOptions::default()) {
            Ok(_) => accepted.push(e.file.clone()),
            Err(errs) => {
                let first = errs.first();
                let line_count = src.lines().count() as u32;
                assert!(
                    first.pos.line >= 1 && first.pos.line <= line_count,
                    "{first}"
                );
                assert!(first.pos.column >= 1, "{first}");
                let shown = first.to_string();
                assert!(
                    shown.starts_with(&format!("{}:{}:", e.file, first.pos.line)),
                    "{shown}"
                );
            }
        }
    }
    assert!(count >= 30, "the manifest lists {count} reject programs");
    assert!(
        accepted.is_empty(),
        "accepted programs that must be refused: {accepted:?}"
    );
}
