//! Memory is bounded by the report, not by how long the program runs.
//!
//! This test has a binary of its own: the kernel counts in a child's peak resident memory
//! the memory of the process it was spawned from (exec records the peak of the memory it
//! replaces, and the spawn shares the parent's). Beside a hundred other tests in one
//! process, the test process's own peak, not the command's, would be measured.
#![cfg(target_os = "linux")]

use std::path::Path;
use std::process::Command;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_contourcheck"))
}

/// Runs `check` on a program and returns its output and its peak resident memory (bytes),
/// as the kernel accounts it: the command's own, or the test process's peak where that is
/// higher (small in this binary of its own: the test checks it).
// The child is reaped by wait4 below, which std does not see.
#[allow(clippy::zombie_processes)]
fn check_with_peak_memory(program: &Path, extra: &[&str]) -> (std::process::ExitStatus, u64) {
    let child = bin()
        .arg("check")
        .arg(program)
        .args(extra)
        .env("CI", "1")
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let pid = libc::pid_t::try_from(child.id()).unwrap();
    let mut status = 0;
    // SAFETY: an all-zero rusage is a valid value for wait4 to fill in.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    // SAFETY: waits for our own child, writing into the two locals.
    let waited = unsafe { libc::wait4(pid, &mut status, 0, &mut usage) };
    assert_eq!(waited, pid);
    let status = std::os::unix::process::ExitStatusExt::from_raw(status);
    // ru_maxrss is in KiB on Linux.
    (status, u64::try_from(usage.ru_maxrss).unwrap() * 1024)
}

/// The peak resident memory (bytes) of this test process's own memory, the figure a
/// spawned child's exec records (`VmHWM`; the process's `ru_maxrss` would also carry the
/// peak of whatever spawned it).
fn own_peak_memory() -> u64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap();
    let line = status.lines().find(|l| l.starts_with("VmHWM:")).unwrap();
    let kib: u64 = line.split_whitespace().nth(1).unwrap().parse().unwrap();
    kib * 1024
}

/// A 100 mm square traced over and over at F1000 (24.5 s per pass, its corners blended).
fn squares(passes: usize) -> String {
    let mut src = String::from("G21 G90 G64 P0.01\nG0 X0 Y0\nG1 X0 Y0 F1000\n");
    for _ in 0..passes {
        src += "X100 Y0\nX100 Y100\nX0 Y100\nX0 Y0\n";
    }
    src + "M2\n"
}

/// Memory is bounded by the report, not by how long the program runs: a two-hour program
/// needs no more than a quarter-hour one (held whole, the two hours took some 600 MB), and
/// its trace CSV, written as the run goes, holds every row across the pieces it was
/// simulated in.
#[test]
fn a_long_program_checks_in_the_memory_of_a_short_one() {
    let dir = tempfile::tempdir().unwrap();
    let (short, long) = (dir.path().join("short.nc"), dir.path().join("long.nc"));
    std::fs::write(&short, squares(37)).unwrap();
    std::fs::write(&long, squares(300)).unwrap();
    let trace = dir.path().join("t.csv");
    let (ok, short_bytes) = check_with_peak_memory(&short, &[]);
    assert!(ok.success());
    // The test process's own peak stays well below the commands', so what is measured is
    // theirs.
    let own_bytes = own_peak_memory();
    assert!(
        own_bytes < short_bytes / 2,
        "the test's own peak: {own_bytes} bytes"
    );
    let (ok, long_bytes) = check_with_peak_memory(
        &long,
        &["--trace", trace.to_str().unwrap(), "--trace-every", "7"],
    );
    assert!(ok.success());
    let mb = |b: u64| b as f64 / 1e6;
    assert!(
        long_bytes < short_bytes + 20_000_000 && long_bytes < 100_000_000,
        "2 h: {:.0} MB, 15 min: {:.0} MB",
        mb(long_bytes),
        mb(short_bytes)
    );
    // Every 7th sample of the 2 ms cycle, none lost or doubled at the seams.
    let mut rows = csv::Reader::from_path(&trace).unwrap();
    let times: Vec<f64> = rows
        .records()
        .map(|r| r.unwrap()[0].parse().unwrap())
        .collect();
    assert!(times.len() > 500_000, "{} rows", times.len());
    for (i, t) in times.iter().enumerate() {
        assert!((t - i as f64 * 0.014).abs() < 1e-3, "row {i}: t = {t}");
    }
}
