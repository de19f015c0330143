//! The command-line binary run as a user runs it, and the sample programs it is given.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The binary under test.
pub fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_contourcheck"))
}

/// A program of `gcode-samples/`.
pub fn sample(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("gcode-samples")
        .join(name)
}

/// The binary run with `args` (no progress bars, as in CI), its output collected.
pub fn run(args: &[&str]) -> Output {
    bin().args(args).env("CI", "1").output().unwrap()
}

/// Output bytes as text.
pub fn text(o: &[u8]) -> String {
    String::from_utf8_lossy(o).into_owned()
}

/// The binary run with `args` as [`run`] runs it, which must succeed (what it wrote to
/// stderr is shown if it does not).
#[track_caller]
pub fn run_ok(args: &[&str]) -> Output {
    let o = run(args);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    o
}

/// The binary run with `args` as [`run`] runs it, which must end with a verdict: 0 (within
/// the tolerance) or 1 (over `--tolerance`), not an error (what it wrote to stderr is shown
/// if it does).
#[track_caller]
pub fn run_to_a_verdict(args: &[&str]) -> Output {
    let o = run(args);
    assert!(
        matches!(o.status.code(), Some(0 | 1)),
        "{args:?}: {}",
        text(&o.stderr)
    );
    o
}

/// A JSON output the binary wrote.
#[track_caller]
pub fn read_json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// A record of `program` on the preset machine with `backlash_um` µm of backlash on X,
/// written by `synth` to `record`.
#[track_caller]
pub fn synth_backlash_on_x(program: &Path, record: &Path, backlash_um: &str) {
    run_ok(&[
        "synth",
        program.to_str().unwrap(),
        "--out",
        record.to_str().unwrap(),
        "--effect",
        "backlash",
        "--axis",
        "x",
        "--values",
        backlash_um,
    ]);
}

/// A record of `program` on the machine file `machine` as a linear scale takes it beside the
/// control's commands: 10 kHz, 0.1 µm counts, 0.05 µm of noise, written by `synth` to
/// `record`.
#[track_caller]
pub fn synth_on_a_scale_with_commands(program: &str, machine: &str, record: &str) {
    run_ok(&[
        "synth",
        program,
        "--machine",
        machine,
        "--out",
        record,
        "--with-commands",
        "--rate-hz",
        "10000",
        "--quantization-um",
        "0.1",
        "--noise-um",
        "0.05",
    ]);
}
