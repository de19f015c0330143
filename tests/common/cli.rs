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
