//! Programs and machine files as users bring them: a machine's own M functions in a part
//! program, machine files built on other machine files, files that name no base, and
//! misspelt presets.

use std::path::Path;

use contourcheck::gcode::{InterpretOptions, parse_program};
use contourcheck::machine::MachineConfig;

fn parse(src: &str) -> Result<contourcheck::Program, String> {
    parse_program(src, "part.nc", &InterpretOptions::default()).map_err(|e| e.to_string())
}

/// Clamps, doors and conveyors are switched by M codes of the machine builder's choosing;
/// they neither move nor hold the axes, and are accepted with one warning that lists them
/// with their lines. A code that changes the path — a subprogram call of this file — stays
/// refused at its line and column.
#[test]
fn a_machines_own_m_codes_are_listed_once_and_path_changing_ones_refused() {
    let p = parse("G21 G90\nG0 X0 Y0\nM10\nG1 X10 F500 M300\nM11\nG1 Y10\nM10\nM2\n").unwrap();
    let listed: Vec<&str> = p
        .warnings
        .iter()
        .map(|w| w.message.as_str())
        .filter(|m| m.contains("M codes"))
        .collect();
    assert_eq!(listed.len(), 1, "{:?}", p.warnings);
    assert!(
        listed[0].contains("M10 (lines 3, 7), M11 (line 5), M300 (line 4)"),
        "{}",
        listed[0]
    );
    // The path is the program's: two feed moves.
    let feeds = p.segments.iter().filter(|s| s.feed_m_per_s > 0.0).count();
    assert!(feeds >= 2, "{:?}", p.segments);
    let e = parse("G21 G90\nG0 X0 Y0\nM97 P100\nM2\n").unwrap_err();
    assert!(e.contains("part.nc:3:1") && e.contains("M97"), "{e}");
    // A G code nobody knows is still an error: G codes move.
    let e = parse("G21 G90\nG0 X0 Y0\nG555 X1\nM2\n").unwrap_err();
    assert!(e.contains("part.nc:3:1") && e.contains("G555"), "{e}");
}

fn write(dir: &Path, name: &str, text: &str) -> std::path::PathBuf {
    let path = dir.join(name);
    if let Some(parent) = path.parent() {
        std::fs::create_dir_all(parent).unwrap();
    }
    std::fs::write(&path, text).unwrap();
    path
}

/// A shop keeps one file per machine and a file per job on it: the job's `base` is the
/// machine's file, found relative to the job's, which starts from a preset in turn.
#[test]
fn a_machine_file_may_start_from_another_found_relative_to_it() {
    let dir = tempfile::tempdir().unwrap();
    write(
        dir.path(),
        "shop/mill.toml",
        "base = \"hvmc\"\nname = \"mill\"\n[x.drive]\nbacklash_um = 5.0\n",
    );
    let job = write(
        dir.path(),
        "jobs/part.toml",
        "base = \"../shop/mill.toml\"\n[y.position_loop]\nkv_m_per_min_per_mm = 0.9\n",
    );
    let m = MachineConfig::load(&job).unwrap();
    assert_eq!(m.x.drive.backlash_um, 5.0);
    assert_eq!(m.y.position_loop.kv_m_per_min_per_mm, 0.9);
    // The rest is the preset's, through the chain.
    let hvmc = MachineConfig::default_preset();
    assert_eq!(m.x.drive.table_mass_kg, hvmc.x.drive.table_mass_kg);
    assert_eq!(m.y.drive.backlash_um, hvmc.y.drive.backlash_um);
    // The job names itself: it is not the mill, nor hvmc.
    assert_eq!(m.name, "part");
    // A base file's own error is named in it, at its line.
    write(
        dir.path(),
        "shop/mill.toml",
        "base = \"hvmc\"\n[x.drive]\nbacklsh_um = 5.0\n",
    );
    let e = MachineConfig::load(&job).unwrap_err().to_string();
    assert!(
        e.contains("mill.toml:3:1") && e.contains("backlash_um"),
        "{e}"
    );
}

#[test]
fn a_chain_of_bases_that_comes_back_is_refused_with_the_chain() {
    let dir = tempfile::tempdir().unwrap();
    let a = write(dir.path(), "a.toml", "base = \"b.toml\"\n");
    write(dir.path(), "b.toml", "base = \"sub/c.toml\"\n");
    write(dir.path(), "sub/c.toml", "base = \"../a.toml\"\n");
    let e = MachineConfig::load(&a).unwrap_err().to_string();
    assert!(e.contains("key `base`") && e.contains("comes back"), "{e}");
    let chain = e.split(": ").last().unwrap();
    let names: Vec<&str> = chain
        .split(" → ")
        .map(|p| Path::new(p).file_name().unwrap().to_str().unwrap())
        .collect();
    assert_eq!(names, ["a.toml", "b.toml", "c.toml", "a.toml"], "{e}");
    // A file that is its own base, too.
    let own = write(dir.path(), "own.toml", "base = \"own.toml\"\n");
    assert!(
        MachineConfig::load(&own)
            .unwrap_err()
            .to_string()
            .contains("comes back")
    );
}

#[test]
fn a_base_that_names_nothing_says_what_was_meant() {
    let e = MachineConfig::from_toml_str("base = \"hmvc\"\n", "m.toml")
        .unwrap_err()
        .to_string();
    assert!(e.contains("m.toml:1:1") || e.contains("m.toml"), "{e}");
    assert!(
        e.contains("did you mean `hvmc`?") && e.contains("small-table"),
        "{e}"
    );
    let dir = tempfile::tempdir().unwrap();
    let m = write(dir.path(), "m.toml", "base = \"shop/mill.toml\"\n");
    let e = MachineConfig::load(&m).unwrap_err().to_string();
    assert!(e.contains("no file at") && e.contains("mill.toml"), "{e}");
}
