//! Where outputs go: `-` is the standard output (the data alone there, what is printed for
//! people on the standard error); a symbolic link is written through and stays a link; a
//! device or a FIFO is written to in place, not replaced; an output never replaces a file
//! the run reads, nor another output of the run.

use std::path::Path;
use std::process::Output;

use crate::common;

use common::cli::{read_json, run, run_ok, sample, text};

/// `check` of the square sample with `extra` arguments, run by `runner` ([`run`] or
/// [`run_ok`]).
fn check_with(extra: &[&str], runner: fn(&[&str]) -> Output) -> Output {
    let square = sample("square.nc");
    let args: Vec<&str> = ["check", square.to_str().unwrap()]
        .into_iter()
        .chain(extra.iter().copied())
        .collect();
    runner(&args)
}

/// [`check_with`] as [`run`] runs it.
fn check(extra: &[&str]) -> Output {
    check_with(extra, run)
}

/// [`check_with`] as [`run_ok`] runs it: it must succeed.
fn check_ok(extra: &[&str]) -> Output {
    check_with(extra, run_ok)
}

/// The report a plain file gets, to compare with.
fn plain_report(dir: &Path) -> serde_json::Value {
    let path = dir.join("plain.json");
    check_ok(&["--json", path.to_str().unwrap()]);
    read_json(&path)
}

#[test]
fn a_dash_writes_the_data_alone_to_standard_output() {
    let dir = tempfile::tempdir().unwrap();
    let o = check_ok(&["--json", "-"]);
    let report: serde_json::Value =
        serde_json::from_slice(&o.stdout).expect("stdout is the JSON alone");
    assert_eq!(report, plain_report(dir.path()));
    assert!(
        text(&o.stderr).contains("contour   max"),
        "the summary goes to stderr"
    );
    assert!(!Path::new("-").exists());

    let o = check_ok(&["--trace", "-", "--trace-every", "100"]);
    let mut rows = csv::Reader::from_reader(&o.stdout[..]);
    assert_eq!(rows.headers().unwrap().get(0), Some("t_s"));
    assert!(rows.records().all(|r| r.unwrap().len() == 9));

    let o = check_ok(&["--report", "-"]);
    let page = text(&o.stdout);
    assert!(page.starts_with("<!DOCTYPE html>") && page.trim_end().ends_with("</html>"));

    // Two outputs cannot share it: refused before the run.
    let o = check(&["--json", "-", "--trace", "-"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(o.stdout.is_empty());
    assert!(text(&o.stderr).contains("only one output can go to the standard output"));
}

#[test]
fn an_output_naming_an_input_or_another_output_is_refused_before_the_run() {
    let dir = tempfile::tempdir().unwrap();
    let program = dir.path().join("square.nc");
    std::fs::copy(sample("square.nc"), &program).unwrap();
    let before = std::fs::read(&program).unwrap();
    let p = program.to_str().unwrap();
    // The program itself, spelt another way (through its folder's `..`), and a link to it.
    let roundabout = dir.path().join("..").join(dir.path().file_name().unwrap());
    let roundabout = roundabout.join("square.nc");
    let link = dir.path().join("link.nc");
    std::os::unix::fs::symlink(&program, &link).unwrap();
    for out in [p, roundabout.to_str().unwrap(), link.to_str().unwrap()] {
        let o = run(&["check", p, "--json", out]);
        assert_eq!(o.status.code(), Some(2), "{out}: {}", text(&o.stderr));
        assert!(
            text(&o.stderr).contains("--json names the program, which the run reads"),
            "{}",
            text(&o.stderr)
        );
        assert_eq!(std::fs::read(&program).unwrap(), before, "{out}");
    }
    // A record `synth` made, named again as where `diagnose` writes its machine.
    let record = dir.path().join("square.csv");
    let r = record.to_str().unwrap();
    run_ok(&["synth", p, "--out", r, "--with-commands"]);
    let recorded = std::fs::read(&record).unwrap();
    let o = run(&["diagnose", p, "--measured", r, "--write-machine", r]);
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o.stderr).contains("--write-machine names --measured"));
    assert_eq!(std::fs::read(&record).unwrap(), recorded);
    // The same for a file a folder output will hold: the compensation tables' CSV.
    let tables = dir.path().join("compensation.csv");
    std::fs::copy(&record, &tables).unwrap();
    let t = tables.to_str().unwrap();
    let d = dir.path().to_str().unwrap();
    let o = run(&["diagnose", p, "--measured", t, "--write-compensation", d]);
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o.stderr).contains("--write-compensation names --measured"));
    assert_eq!(std::fs::read(&tables).unwrap(), recorded);
    // A compensation folder not there yet is made (a file's folder must be there already):
    // a record with a scale error of 50 ppm on X, which a table compensates.
    let scaled = dir.path().join("scaled.csv");
    let s = scaled.to_str().unwrap();
    let effect = [
        "--effect",
        "scale_error",
        "--values",
        "50",
        "--with-commands",
    ];
    run_ok(&[&["synth", p, "--out", s][..], &effect].concat());
    let new_folder = dir.path().join("new").join("tables");
    let n = new_folder.to_str().unwrap();
    run_ok(&["diagnose", p, "--measured", s, "--write-compensation", n]);
    assert!(new_folder.join("compensation.csv").is_file());
    // One file for two outputs, spelt two ways: refused, nothing written.
    let same = dir.path().join("same.out");
    std::fs::create_dir(dir.path().join("sub")).unwrap();
    let dotted = dir.path().join("sub").join("..").join("same.out");
    let o = check(&[
        "--json",
        same.to_str().unwrap(),
        "--report",
        dotted.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o.stderr).contains("named for both --json and --report"));
    assert!(!same.exists());
    // Streams take any number.
    check_ok(&["--json", "/dev/null", "--trace", "/dev/null"]);
}

#[test]
fn a_symbolic_link_is_written_through_and_stays_a_link() {
    let dir = tempfile::tempdir().unwrap();
    let target = dir.path().join("reports").join("real.json");
    std::fs::create_dir(target.parent().unwrap()).unwrap();
    std::fs::write(&target, "an older report").unwrap();
    let link = dir.path().join("link.json");
    std::os::unix::fs::symlink(&target, &link).unwrap();
    check_ok(&["--json", link.to_str().unwrap()]);
    assert!(
        std::fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink()
    );
    assert_eq!(read_json(&target), plain_report(dir.path()));
    // Staged beside the target and renamed: nothing else left in either folder.
    assert_eq!(
        std::fs::read_dir(target.parent().unwrap()).unwrap().count(),
        1
    );
    // A link to where no file is yet: the file appears there, the link stays.
    let dangling = dir.path().join("to-be.json");
    let later = target.with_file_name("later.json");
    std::os::unix::fs::symlink(&later, &dangling).unwrap();
    check_ok(&["--json", dangling.to_str().unwrap()]);
    assert!(
        std::fs::symlink_metadata(&dangling)
            .unwrap()
            .file_type()
            .is_symlink()
    );
    assert!(
        std::fs::read_to_string(&later)
            .unwrap()
            .contains("contourcheck.check/1")
    );
}

#[test]
fn a_fifo_and_dev_stdout_are_written_to_not_replaced() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("pipe");
    let c_path = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
    // SAFETY: creating a FIFO at a path of our own temporary folder.
    assert_eq!(unsafe { libc::mkfifo(c_path.as_ptr(), 0o600) }, 0);
    let reader = {
        let fifo = fifo.clone();
        std::thread::spawn(move || std::fs::read_to_string(fifo).unwrap())
    };
    check_ok(&["--json", fifo.to_str().unwrap()]);
    let read: serde_json::Value = serde_json::from_str(&reader.join().unwrap()).unwrap();
    assert_eq!(read, plain_report(dir.path()));
    use std::os::unix::fs::FileTypeExt;
    assert!(
        std::fs::symlink_metadata(&fifo)
            .unwrap()
            .file_type()
            .is_fifo()
    );

    // `/dev/stdout` (a link to the process's descriptor) is written to, before the summary.
    let o = check_ok(&["--json", "/dev/stdout"]);
    let mut stream =
        serde_json::Deserializer::from_slice(&o.stdout).into_iter::<serde_json::Value>();
    let first = stream.next().unwrap().expect("the report first on stdout");
    assert_eq!(first, plain_report(dir.path()));
    assert!(Path::new("/dev/stdout").exists());
}
