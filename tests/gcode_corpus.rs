//! A corpus of real programs written by others (with a manifest `MANIFEST.tsv` of where each
//! came from and whether LinuxCNC's interpreter accepts it), found in the folder that the
//! environment variable `CONTOURCHECK_GCODE_CORPUS` names. The files are not part of the
//! repository: without the variable each test says "skipped: corpus not present" and passes.
//! With it, every
//! XY program LinuxCNC accepts must interpret, and every program in `reject/` must be refused
//! with an error that names its line and column; and every such program must check under
//! every speed profile and at neighbouring gains.

mod common;

use std::path::{Path, PathBuf};

use contourcheck::check::{CheckSettings, check};
use contourcheck::gcode::{InterpretOptions, parse_program};
use contourcheck::machine::MachineConfig;
use contourcheck::path::{Geometry, Plane};
use contourcheck::plan::ProfileKind;
use rayon::prelude::*;

const CORPUS_VARIABLE: &str = "CONTOURCHECK_GCODE_CORPUS";

/// The corpus folder, or `None` (after saying so) when this machine has none. A folder
/// without a manifest is a broken setup, not an absent corpus: that fails.
fn corpus_dir() -> Option<PathBuf> {
    let dir = common::corpus_dir(CORPUS_VARIABLE)?;
    assert!(
        dir.join("MANIFEST.tsv").is_file(),
        "{CORPUS_VARIABLE}={} has no MANIFEST.tsv",
        dir.display()
    );
    Some(dir)
}

struct Entry {
    category: String,
    file: String,
    linuxcnc_accepts: bool,
    note: String,
}

fn manifest(dir: &Path) -> Vec<Entry> {
    let text = std::fs::read_to_string(dir.join("MANIFEST.tsv")).expect("the corpus manifest");
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split('\t').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (c_cat, c_file, c_rc) = (col("category"), col("file"), col("rs274_rc"));
    let c_note = col("note");
    lines
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let f: Vec<&str> = l.split('\t').collect();
            Entry {
                category: f[c_cat].to_string(),
                file: f[c_file].to_string(),
                linuxcnc_accepts: f[c_rc] == "0",
                note: f.get(c_note).map_or(String::new(), |n| n.to_string()),
            }
        })
        .collect()
}

fn read(dir: &Path, entry: &Entry) -> String {
    let bytes = std::fs::read(dir.join(&entry.file)).unwrap();
    String::from_utf8_lossy(&bytes).into_owned()
}

#[test]
fn every_xy_program_linuxcnc_accepts_interprets() {
    let Some(dir) = corpus_dir() else { return };
    let mut failures = Vec::new();
    let mut count = 0;
    for e in manifest(&dir)
        .iter()
        .filter(|e| e.category != "reject" && e.linuxcnc_accepts)
    {
        count += 1;
        match parse_program(&read(&dir, e), &e.file, &InterpretOptions::default()) {
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
    let Some(dir) = corpus_dir() else { return };
    let mut accepted = Vec::new();
    let (mut count, mut in_space) = (0, 0);
    for e in manifest(&dir).iter().filter(|e| e.category == "reject") {
        count += 1;
        let src = read(&dir, e);
        let parsed = parse_program(&src, &e.file, &InterpretOptions::default());
        // Refused by an XY predictor for their G18/G19 arcs alone, these are paths in space
        // now: read where nothing else keeps them out (a rotation of XY under such an arc
        // still does), with arcs outside XY among their blocks.
        if let Ok(program) = &parsed
            && e.note.trim() == "features: G18G19"
        {
            assert!(
                program
                    .segments
                    .iter()
                    .any(|s| matches!(s.geometry, Geometry::Arc(_)) && s.plane != Plane::Xy),
                "{}: no arc in ZX or YZ",
                e.file
            );
            in_space += 1;
            continue;
        }
        match parsed {
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
        in_space >= 5,
        "{in_space} programs refused for G18/G19 alone"
    );
    assert!(
        accepted.is_empty(),
        "accepted programs that must be refused: {accepted:?}"
    );
}

/// Every accepted program runs through `check` under each profile, and at Kv 0.9, 1.0 and
/// 1.1 m/min/mm (once a program stopped with chattering modes at Kv 1.0 only, a standing
/// axis breaking away at a force within rounding of static friction). A run must end with
/// both axes where the program ends, within the exact-stop window, and give finite figures.
#[test]
fn every_xy_program_linuxcnc_accepts_checks_under_every_profile_and_gain() {
    let Some(dir) = corpus_dir() else { return };
    let programs: Vec<_> = manifest(&dir)
        .into_iter()
        .filter(|e| e.category != "reject" && e.linuxcnc_accepts)
        .map(|e| {
            let p = parse_program(&read(&dir, &e), &e.file, &InterpretOptions::default())
                .unwrap_or_else(|err| panic!("{err}"));
            (e.file, p)
        })
        .collect();
    let mut cases = Vec::new();
    for (file, program) in &programs {
        for profile in [
            ProfileKind::SCurve,
            ProfileKind::Trapezoid,
            ProfileKind::Ideal,
        ] {
            cases.push((file, program, profile, 1.0));
        }
        for kv in [0.9, 1.1] {
            cases.push((file, program, ProfileKind::SCurve, kv));
        }
    }
    let failures: Vec<String> = cases
        .par_iter()
        .filter_map(|&(file, program, profile, kv)| {
            let mut machine = MachineConfig::default_preset();
            machine.x.position_loop.kv_m_per_min_per_mm = kv;
            machine.y.position_loop.kv_m_per_min_per_mm = kv;
            let mut settings = CheckSettings::for_machine(&machine);
            settings.plan.profile = profile;
            let why = match check(program, &machine, &settings) {
                Err(e) => Some(e.to_string()),
                Ok(run) => ends_where_the_program_ends(&run, &machine).err(),
            };
            why.map(|w| format!("{file} ({profile}, Kv {kv}): {w}"))
        })
        .collect();
    assert!(programs.len() >= 60);
    assert!(
        failures.is_empty(),
        "{} of {} runs failed:\n{}",
        failures.len(),
        cases.len(),
        failures.join("\n")
    );
}

fn ends_where_the_program_ends(
    run: &contourcheck::check::CheckRun,
    machine: &MachineConfig,
) -> Result<(), String> {
    let s = &run.result.summary;
    if !(s.max_contour_error_m.is_finite() && s.cycle_time_s > 0.0) {
        return Err(format!(
            "figures: contour {} m, cycle {} s",
            s.max_contour_error_m, s.cycle_time_s
        ));
    }
    let end = run.result.plan.segments.last().expect("a path").end_m;
    let window_m = machine.interpolation.in_position_window_mm * 1e-3;
    for (axis, trace, target) in [("X", &run.x, end[0]), ("Y", &run.y, end[1])] {
        let last = *trace.pos_m.last().expect("samples");
        if (last - target).abs() > window_m {
            return Err(format!(
                "{axis} ends {:.1} µm from the program's end",
                (last - target) * 1e6
            ));
        }
    }
    Ok(())
}
