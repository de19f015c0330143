//! The command line: exit statuses, outputs written whole, errors that name the place —
//! `check` and the commands on a machine and a program (`plan`, `bode`, `stickslip`,
//! `validate`, `sweep`). The commands on measured records are in `cli_records.rs`.

use crate::common;

use std::path::Path;

use common::cli::{bin, read_json, run, run_ok, sample, text};

#[test]
fn check_writes_a_report_a_trace_and_plots_that_parse_back() {
    let dir = tempfile::tempdir().unwrap();
    let (json, csv_path, plots) = (
        dir.path().join("r.json"),
        dir.path().join("t.csv"),
        dir.path().join("plots"),
    );
    let o = run_ok(&[
        "check",
        sample("circle-test.nc").to_str().unwrap(),
        "--json",
        json.to_str().unwrap(),
        "--trace",
        csv_path.to_str().unwrap(),
        "--trace-every",
        "10",
        "--plot",
        plots.to_str().unwrap(),
    ]);
    assert!(text(&o.stdout).contains("hotspots"));
    let report = read_json(&json);
    assert_eq!(report["schema"], "contourcheck.check/1");
    let max = report["contour_error_um"]["max"].as_f64().unwrap();
    assert!(max > 0.0 && max < 1000.0);
    // The radius loss all round each circle: one row per circle, with the stretch it covers.
    let hotspots = report["hotspots"].as_array().unwrap();
    assert_eq!(hotspots.len(), 2, "{hotspots:#?}");
    assert_eq!(report["hotspots"][0]["rank"], 1);
    for h in hotspots {
        assert_eq!(h["cause"]["kind"], "steady_lag");
        assert!(h["extent"]["places"].as_u64().unwrap() >= 3, "{h}");
    }
    let mut reader = csv::Reader::from_path(&csv_path).unwrap();
    assert_eq!(reader.headers().unwrap().get(8), Some("contour_um"));
    let rows = reader.records().count();
    let cycle = report["cycle_time_s"].as_f64().unwrap();
    // Every 10th sample of a 2 ms grid over the cycle plus the settling tail.
    assert!(
        (rows as f64 - (cycle + 0.3) / 0.02).abs() < 3.0,
        "{rows} rows for {cycle} s"
    );
    // Every plot says what it was made of: machine, program, feed, sampling, date, tool.
    for name in ["toolpath.svg", "contour-along-path.svg", "circle-1.svg"] {
        let svg = std::fs::read_to_string(plots.join(name)).unwrap();
        for part in [
            "machine hvmc",
            "program circle-test.nc",
            "F 500–1000 mm/min",
            "IPO cycle 2 ms",
            concat!("contourcheck ", env!("CARGO_PKG_VERSION")),
        ] {
            assert!(svg.contains(part), "{name} lacks {part}");
        }
    }
    for name in [
        "toolpath.png",
        "toolpath.svg",
        "contour-along-path.png",
        "circle-1.png",
        "circle-1.svg",
    ] {
        let len = std::fs::metadata(plots.join(name))
            .map(|m| m.len())
            .unwrap_or(0);
        assert!(len > 10_000, "{name}: {len} bytes");
    }
    // Nothing but the outputs: no temporary files left behind.
    assert_eq!(std::fs::read_dir(&plots).unwrap().count(), 6);
}

#[test]
fn tolerance_gates_with_exit_status_one() {
    let circle = sample("circle-test.nc");
    let over = run(&["check", circle.to_str().unwrap(), "--tolerance", "1"]);
    assert_eq!(over.status.code(), Some(1), "{}", text(&over.stderr));
    assert!(text(&over.stdout).contains("EXCEEDS"));
    let within = run(&["check", circle.to_str().unwrap(), "--tolerance", "500"]);
    assert_eq!(within.status.code(), Some(0));
}

#[test]
fn a_bad_program_names_file_line_and_column_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.nc");
    std::fs::write(&bad, "G21 G90 F500\nG1 X10\nG41 D1 G1 Y10\nG1 X#3\n").unwrap();
    let json = dir.path().join("r.json");
    let plots = dir.path().join("plots");
    let o = run(&[
        "check",
        bad.to_str().unwrap(),
        "--json",
        json.to_str().unwrap(),
        "--plot",
        plots.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    let err = text(&o.stderr);
    assert!(err.contains("bad.nc:3:1: G41"), "{err}");
    assert!(err.contains("bad.nc:4:5:"), "{err}");
    assert!(!json.exists() && !plots.exists(), "no partial outputs");
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
}

/// `check` of the square on a machine file `name` holding `toml`.
fn check_square_on_machine(name: &str, toml: &str) -> std::process::Output {
    let dir = tempfile::tempdir().unwrap();
    let m = dir.path().join(name);
    std::fs::write(&m, toml).unwrap();
    run(&[
        "check",
        sample("square.nc").to_str().unwrap(),
        "--machine",
        m.to_str().unwrap(),
    ])
}

#[test]
fn a_bad_machine_file_names_the_key() {
    let o = check_square_on_machine("m.toml", "[y.friction]\nstatic_to_coulomb = 0.8\n");
    assert_eq!(o.status.code(), Some(2));
    let err = text(&o.stderr);
    assert!(
        err.contains("m.toml") && err.contains("y.friction.static_to_coulomb"),
        "{err}"
    );
}

#[test]
fn a_value_no_machine_has_is_refused_by_key() {
    for (section, key, value) in [
        ("x.drive", "table_mass_kg", "1e300"),
        ("y.drive", "backlash_um", "1e12"),
        ("interpolation", "arc_normal_share", "1.5"),
    ] {
        let o = check_square_on_machine("m.toml", &format!("[{section}]\n{key} = {value}\n"));
        assert_eq!(o.status.code(), Some(2));
        let err = text(&o.stderr);
        assert!(
            err.contains(&format!("{section}.{key}"))
                && (err.contains("at most") || err.contains("between")),
            "{err}"
        );
    }
}

#[test]
fn programs_that_do_not_fit_the_machine_are_refused_with_line_and_axis() {
    let dir = tempfile::tempdir().unwrap();
    let cases = [
        // Beyond the preset's X travel (±2500 mm) by a slip of the exponent.
        (
            "far.nc",
            "G1 X10 F500\nG1 X100000000000000000\n",
            "far.nc:2: X reaches",
        ),
        // An arc whose ends are inside the Y travel (±1500 mm) but whose bulge is not.
        (
            "bulge.nc",
            "G0 X-1000 Y1000\nG2 X1000 Y1000 I1000 J0 F500\n",
            "bulge.nc:2: Y reaches",
        ),
        (
            "empty.nc",
            "(only a comment)\nM30\n",
            "moves neither X nor Y",
        ),
        // Fine geometry, but days of motion: refused before any memory is taken.
        ("slow.nc", "G1 X10 F0.0001\n", "runs 1666.7 h"),
    ];
    for (name, program, expected) in cases {
        let path = dir.path().join(name);
        std::fs::write(&path, program).unwrap();
        let o = run(&["check", path.to_str().unwrap()]);
        assert_eq!(o.status.code(), Some(2), "{name}: {}", text(&o.stdout));
        assert!(
            text(&o.stderr).contains(expected),
            "{name}: {}",
            text(&o.stderr)
        );
    }
}

#[test]
fn bode_shows_no_nan_and_refuses_an_unstable_setting() {
    let dir = tempfile::tempdir().unwrap();
    let bode_at_kv = |name: &str, kv: f64| {
        let m = dir.path().join(name);
        let toml = format!("base = \"hvmc\"\n[x.position_loop]\nkv_m_per_min_per_mm = {kv}\n");
        std::fs::write(&m, toml).unwrap();
        run(&["bode", "--machine", m.to_str().unwrap()])
    };
    // A crawling position loop (crossover 2.65 mHz) is still measured.
    let o = bode_at_kv("slow.toml", 0.001);
    assert_eq!(o.status.code(), Some(0));
    let out = text(&o.stdout);
    assert!(!out.to_lowercase().contains("nan"), "{out}");
    assert!(out.contains("0.00265 Hz"), "{out}");
    let o = bode_at_kv("hot.toml", 60.0);
    assert_eq!(o.status.code(), Some(2));
    assert!(!text(&o.stdout).to_lowercase().contains("nan"));
    // The growing mode is named beside the margins, with the gain that would be stable.
    let shown = text(&o.stdout);
    assert!(shown.contains("UNSTABLE: this mode grows"), "{shown}");
    assert_is_the_stability_edge(&shown, contourcheck::machine::AxisName::X);
    let err = text(&o.stderr);
    assert!(err.contains("X axis: unstable"), "{err}");
    // Just past the edge, the position loop's margins say how far its gain is beyond it —
    // the gain that must fall, by what separates it from the stable Kv stated — not how far
    // it may move.
    let kv = 2.0;
    let o = bode_at_kv("edge.toml", kv);
    assert_eq!(o.status.code(), Some(2));
    let shown = text(&o.stdout);
    assert_is_the_stability_edge(&shown, contourcheck::machine::AxisName::X);
    let position = shown.lines().find(|l| l.starts_with("position ")).unwrap();
    assert!(position.contains("unstable"), "{shown}");
    assert!(!shown.contains("unstable if its gain falls"), "{shown}");
    let must_fall_db: f64 = (shown.split("must fall by at least ").nth(1))
        .and_then(|rest| rest.split_whitespace().next())
        .and_then(|db| db.parse().ok())
        .unwrap_or_else(|| panic!("no fall stated: {shown}"));
    let edge: f64 = (shown.split("is stable below ").nth(1))
        .and_then(|rest| rest.split_whitespace().next())
        .and_then(|k| k.parse().ok())
        .unwrap();
    let apart_db = 20.0 * (kv / edge).log10();
    assert!(
        (must_fall_db - apart_db).abs() <= 0.1,
        "{must_fall_db} dB against {apart_db}"
    );
    // Its plot is drawn all the same (it shows where the loop went wrong), its position
    // loop's curves labelled unstable and not by margins or a peak it does not have; the
    // status stays 2.
    let plots = dir.path().join("plots");
    let m = dir.path().join("edge.toml");
    let o = run(&[
        "bode",
        "--machine",
        m.to_str().unwrap(),
        "--plot",
        plots.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    let svg = std::fs::read_to_string(plots.join("bode-x.svg")).unwrap();
    assert!(
        svg.contains("position: open loop, unstable")
            && svg.contains("position: feedback loop closed (unstable"),
        "labels"
    );
    std::fs::remove_dir_all(&plots).unwrap();
    // A plot directory that cannot be made says why as any other file would.
    let blocked = dir.path().join("hot.toml").join("plots");
    let o = run(&["bode", "--plot", blocked.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o.stderr).contains("hot.toml"), "{}", text(&o.stderr));
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        3,
        "only the three machines"
    );
}

/// The Kv a message states as the edge of stability ("is stable below K m/min/mm") is the
/// edge of the preset's axis by the closed-loop eigenvalues: stable 1 % below, unstable 1 %
/// above.
fn assert_is_the_stability_edge(text: &str, axis: contourcheck::machine::AxisName) {
    use contourcheck::sim::{AxisModel, linear::check_stable};
    let stated: f64 = text
        .split("is stable below ")
        .nth(1)
        .and_then(|rest| rest.split_whitespace().next())
        .and_then(|k| k.parse().ok())
        .unwrap_or_else(|| panic!("no stable Kv stated: {text}"));
    let stable_at = |kv: f64| {
        let mut config = contourcheck::MachineConfig::default_preset()
            .axis(axis)
            .clone();
        config.position_loop.kv_m_per_min_per_mm = kv;
        check_stable(&AxisModel::from_config(&config)).is_ok()
    };
    assert!(
        stable_at(0.99 * stated) && !stable_at(1.01 * stated),
        "{stated}"
    );
}

#[test]
fn missing_files_and_unstable_gains_are_errors_not_panics() {
    let o = run(&["check", "/nonexistent/part.nc"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o.stderr).contains("/nonexistent/part.nc"));
    let o = check_square_on_machine(
        "hot.toml",
        "[y.position_loop]\nkv_m_per_min_per_mm = 40.0\n",
    );
    assert_eq!(o.status.code(), Some(2));
    let err = text(&o.stderr);
    // Which file and axis, the key that makes it so and where it is stable; and the likely
    // unit mix-up (1/s for m/min/mm) said first.
    assert!(
        err.contains("hot.toml: the Y axis is unstable")
            && err.contains("y.position_loop.kv_m_per_min_per_mm (here 40) is stable below"),
        "{err}"
    );
    assert_is_the_stability_edge(&err, contourcheck::machine::AxisName::Y);
    assert!(
        err.contains("if 1/s were meant, write kv_m_per_min_per_mm = 2.400"),
        "{err}"
    );
    // Z, which the preset simulates, the same (it was let through to the run, whose error
    // named no file and no gain).
    let o = check_square_on_machine(
        "hot-z.toml",
        "[z.position_loop]\nkv_m_per_min_per_mm = 3.0\n",
    );
    assert_eq!(o.status.code(), Some(2));
    let err = text(&o.stderr);
    assert!(
        err.contains("hot-z.toml: the Z axis is unstable")
            && err.contains("z.position_loop.kv_m_per_min_per_mm (here 3) is stable below"),
        "{err}"
    );
    assert_is_the_stability_edge(&err, contourcheck::machine::AxisName::Z);
}

#[test]
fn plan_bode_stickslip_and_validate_run() {
    let dir = tempfile::tempdir().unwrap();
    let csv_path = dir.path().join("c.csv");
    run_ok(&[
        "plan",
        sample("profile-pocket.nc").to_str().unwrap(),
        "--csv",
        csv_path.to_str().unwrap(),
    ]);
    assert!(csv::Reader::from_path(&csv_path).unwrap().records().count() > 1000);
    let plots = dir.path().join("plots");
    let o = run(&["bode", "--axis", "y", "--plot", plots.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0));
    assert!(text(&o.stdout).contains("velocity"));
    // Every plot written is said, as on every command with --plot DIR.
    let bode = plots.join("bode-y.svg");
    assert!(text(&o.stdout).contains(&format!("plot: {}", bode.display())));
    assert!(std::fs::read_to_string(&bode).unwrap().contains("<svg"));
    assert!(plots.join("bode-y.png").exists());
    let ss = plots.clone();
    let o = run_ok(&[
        "stickslip",
        "--feeds",
        "3,6",
        "--duration",
        "4",
        "--plot",
        ss.to_str().unwrap(),
    ]);
    assert!(text(&o.stdout).contains("stick-slip"));
    assert!(ss.join("stickslip-x.png").exists() && ss.join("stickslip-x.svg").exists());
    // hvmc's X rapids at 6000 mm/min: a feed past it is refused, not run into saturation.
    let o = run(&["stickslip", "--feeds", "50000"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        text(&o.stderr).contains("above the axis's rapid of 6000"),
        "{o:?}"
    );
    let o = run(&["validate"]);
    assert_eq!(o.status.code(), Some(0));
    assert!(text(&o.stdout).contains("Table 4"));
    // small-table's lead-lag on current has no Kv or Ks for the tables to set.
    let o = run(&["validate", "--machine", "small-table"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o.stderr).contains("three-loop cascade"), "{o:?}");
    assert!(!text(&o.stdout).contains("NaN") && !text(&o.stdout).contains("inf"));
}

/// Interrupted while writing its outputs, a run removes what it had staged and reports
/// status 130; leftovers of a run killed outright are removed by the next run writing to the
/// same place, and those of a live run are left alone.
#[cfg(unix)]
#[test]
fn interrupted_and_killed_runs_leave_nothing_behind() {
    let dir = tempfile::tempdir().unwrap();
    let program = dir.path().join("long.nc");
    // 2 m at F200: a 600 s run whose 20 MB trace takes a while to write.
    std::fs::write(&program, "G1 X2000 F200\n").unwrap();
    let out = dir.path().join("out");
    std::fs::create_dir(&out).unwrap();
    let trace = out.join("t.csv");
    let left = || -> Vec<_> { std::fs::read_dir(&out).unwrap().flatten().collect() };
    // A run that finished before the poll saw its trace staged (a loaded machine can leave
    // the poll unscheduled for the whole write), or that the signal reached after the
    // rename (status 0, or 130 from the handler with nothing staged left to remove), wrote
    // its trace whole; another run is started, until one is interrupted while staging. Any
    // other outcome fails.
    let mut interrupted = false;
    for _ in 0..5 {
        let status = signalled_once_staged(&program, &trace);
        let code = status.map_or(Some(0), |s| s.code());
        let left = left();
        if code == Some(130) && left.is_empty() {
            interrupted = true;
            break;
        }
        assert!(
            matches!(code, Some(0 | 130)) && left.len() == 1 && left[0].path() == trace,
            "a run ended with {status:?} and left {left:?}"
        );
        std::fs::remove_file(&trace).unwrap();
    }
    assert!(
        interrupted,
        "no run of five was interrupted while staging its trace"
    );

    // A dead run's leftover goes, a live one's stays.
    let dead = out.join(".t.csv.tmp4194399.csv");
    let live = out.join(format!(".t.csv.tmp{}.csv", std::process::id()));
    std::fs::write(&dead, "half a trace").unwrap();
    std::fs::write(&live, "being written").unwrap();
    run_ok(&[
        "check",
        sample("square.nc").to_str().unwrap(),
        "--trace",
        trace.to_str().unwrap(),
    ]);
    assert!(!dead.exists(), "a dead run's temporary file stayed");
    assert!(live.exists(), "a live run's temporary file was removed");
    assert!(trace.exists());
}

/// `check` of `program` writing its trace to `trace`, sent SIGINT as soon as the trace is
/// seen staged beside it: how the run ended, or none where it ended before the trace was
/// seen staged. It is waited on rather than timed (a loaded machine only makes it slower),
/// up to a deadline far beyond any run's, so that a run that hangs fails the test.
#[cfg(unix)]
fn signalled_once_staged(program: &Path, trace: &Path) -> Option<std::process::ExitStatus> {
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(300);
    let mut child = bin()
        .args(["check", program.to_str().unwrap(), "--trace"])
        .arg(trace)
        .env("CI", "1")
        .stdout(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let out = trace.parent().unwrap();
    let prefix = format!(".{}.tmp", trace.file_name().unwrap().to_string_lossy());
    let staged = || {
        std::fs::read_dir(out)
            .unwrap()
            .flatten()
            .any(|e| e.file_name().to_string_lossy().starts_with(&prefix))
    };
    let mut signalled = false;
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            if !signalled {
                assert_eq!(status.code(), Some(0), "a run not signalled failed");
            }
            return signalled.then_some(status);
        }
        if std::time::Instant::now() > deadline {
            child.kill().unwrap();
            panic!("the run did not end within 300 s");
        }
        if !signalled && staged() {
            // SAFETY: signalling our own child process.
            unsafe { libc::kill(child.id() as libc::pid_t, libc::SIGINT) };
            signalled = true;
        }
        std::thread::sleep(std::time::Duration::from_millis(1));
    }
}

/// A current limit set far too low (1.5 A on a drive the preset gives 60 A; the square's
/// 0.5 m/s² on 6 t take about 2 A) costs the prediction its shape: the run says so, with the
/// axis, the key and where.
#[test]
fn time_at_a_drive_limit_is_reported() {
    let o = check_square_on_machine("weak.toml", "[x.velocity_loop]\ni_max_a = 1.5\n");
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    let out = text(&o.stdout);
    assert!(
        out.contains("line 8: the X drive is at its current limit (velocity_loop.i_max_a = 1.5 A)"),
        "{out}"
    );
    let o = run(&["check", sample("square.nc").to_str().unwrap()]);
    assert!(!text(&o.stdout).contains("drive is at"));
}

/// The second preset by name, and its amplifier's current limit named in the warning when a
/// file sets it too low (0.05 A on an axis whose friction alone takes 0.12 A at F1000).
#[test]
fn the_small_table_preset_runs_by_name_and_its_amplifier_limit_is_reported() {
    let o = run_ok(&[
        "check",
        sample("square.nc").to_str().unwrap(),
        "--machine",
        "small-table",
    ]);
    let out = text(&o.stdout);
    assert!(out.contains("machine   small-table"), "{out}");
    assert!(!out.contains("drive is at"), "{out}");
    let o = check_square_on_machine(
        "weak.toml",
        "base = \"small-table\"\n[x.amplifier]\ncurrent_bandwidth_hz = 1000.0\ni_max_a = 0.05\n",
    );
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    let out = text(&o.stdout);
    assert!(
        out.contains("the X drive is at its current limit (amplifier.i_max_a = 0.05 A)"),
        "{out}"
    );
    let o = run(&["bode", "--machine", "small-table"]);
    let out = text(&o.stdout);
    assert!(
        out.contains("current ") && out.contains("position ") && !out.contains("velocity "),
        "{out}"
    );
}

/// A program longer than is simulated is refused before it starts, naming its longest block.
#[test]
fn a_program_of_days_is_refused_before_it_runs() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("slow.nc");
    // 100 mm at 0.03 mm/min: 55.6 h.
    std::fs::write(&p, "G21 G90\nG1 X100 F0.03\nM2\n").unwrap();
    let o = run(&["check", p.to_str().unwrap()]);
    let err = text(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("runs 55.6 h") && err.contains("line 2"),
        "{err}"
    );
}

#[test]
fn a_subprogram_files_lines_are_named_by_file_in_the_report_and_the_trace() {
    let dir = tempfile::tempdir().unwrap();
    let main = dir.path().join("main.mpf");
    std::fs::write(
        &main,
        "N10 G710 G17 G90 G94 G64\nN20 G0 X0 Y0 Z5\nN30 G1 Z0 F300\nSQUARE\nN50 M30\n",
    )
    .unwrap();
    std::fs::write(
        dir.path().join("SQUARE.SPF"),
        "PROC SQUARE\nN10 G1 X20 F1000\nN20 Y20\nN30 X0\nN40 Y0\nM17\n",
    )
    .unwrap();
    let trace = dir.path().join("t.csv");
    let o = run(&[
        "check",
        main.to_str().unwrap(),
        "--trace",
        trace.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(
        text(&o.stdout).contains("SQUARE.SPF line"),
        "{}",
        text(&o.stdout)
    );
    let csv = std::fs::read_to_string(&trace).unwrap();
    let lines: std::collections::BTreeSet<&str> = csv
        .lines()
        .skip(1)
        .filter_map(|row| row.split(',').nth(1))
        .collect();
    // The main file's own lines by number, the subprogram's by file and line.
    for want in ["2", "3", "SQUARE.SPF:2", "SQUARE.SPF:5"] {
        assert!(lines.contains(want), "{want} not among {lines:?}");
    }
    // The plan's commands name them the same way (their line is the last column).
    let commands = dir.path().join("c.csv");
    run_ok(&[
        "plan",
        main.to_str().unwrap(),
        "--csv",
        commands.to_str().unwrap(),
    ]);
    let csv = std::fs::read_to_string(&commands).unwrap();
    let planned: std::collections::BTreeSet<&str> = csv
        .lines()
        .skip(1)
        .filter_map(|row| row.rsplit(',').next())
        .collect();
    assert_eq!(planned, lines, "the plan's lines against the trace's");
}

/// A sweep's CSV has a column for its conditions, flags and each loop's margins per axis;
/// its JSON the thresholds, and the first (crowned) setting healthy with its margins.
fn assert_sweep_files_carry_the_margins(csv_path: &Path, json: &Path) {
    let mut reader = csv::Reader::from_path(csv_path).unwrap();
    let headers = reader.headers().unwrap().clone();
    for column in [
        "loop_damping",
        "dominated_by",
        "flags",
        "x_position_phase_margin_deg",
        "y_velocity_gain_margin_db",
        "x_current_peak_db",
    ] {
        assert!(
            headers.iter().any(|h| h == column),
            "{column} in {headers:?}"
        );
    }
    let doc = read_json(json);
    assert_eq!(doc["schema"], "contourcheck.sweep/2");
    assert_eq!(doc["thresholds"]["min_phase_margin_deg"], 30.0);
    let first = &doc["points"][0]["result"];
    assert_eq!(first["status"], "ok");
    assert!(
        first["health"]["margins"][0]["loops"][2]["phase_margin_deg"]
            .as_f64()
            .unwrap()
            >= 30.0
    );
}

/// The sweep a user compares gains with, the README's, on its small mill: each row says what dominates its error and whether
/// it is flagged; the margins of every row follow, by rank; the CSV and JSON carry each
/// loop's margins per axis, and the plot its conditions.
#[test]
fn a_sweep_shows_each_settings_margins_and_flags_the_ringing_one() {
    let dir = tempfile::tempdir().unwrap();
    let m = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/examples/small-mill.toml");
    let (csv_path, json, plots) = (
        dir.path().join("s.csv"),
        dir.path().join("s.json"),
        dir.path().join("plots"),
    );
    let o = run_ok(&[
        "sweep",
        sample("square.nc").to_str().unwrap(),
        "--machine",
        m.to_str().unwrap(),
        "--axis",
        "xy",
        "--kv",
        "6,10,20,40",
        "--ks",
        "4,16",
        "--csv",
        csv_path.to_str().unwrap(),
        "--json",
        json.to_str().unwrap(),
        "--plot",
        plots.to_str().unwrap(),
    ]);
    let out = text(&o.stdout);
    assert!(
        out.contains("loop damping  dominated by") && out.contains("stability margins"),
        "{out}"
    );
    // The ranking comes first, the margins' table after it.
    let stiff = out
        .lines()
        .find(|l| l.contains("  40          4 "))
        .unwrap_or_else(|| panic!("no row in {out}"));
    assert!(
        stiff.contains("ringing") && stiff.contains("flagged: position PM"),
        "{stiff}"
    );
    let best = out.lines().find(|l| l.contains("◀ best")).unwrap();
    assert!(
        !best.contains("  40          4 ") && !best.contains("flagged"),
        "{best}"
    );
    assert_sweep_files_carry_the_margins(&csv_path, &json);
    let svg = std::fs::read_to_string(plots.join("sweep.svg")).unwrap();
    assert!(svg.contains("machine small") && svg.contains("program square.nc"));
    // Stricter thresholds are the user's: at 60° the crowned setting is flagged too.
    let o = run(&[
        "sweep",
        sample("square.nc").to_str().unwrap(),
        "--machine",
        m.to_str().unwrap(),
        "--axis",
        "xy",
        "--kv",
        "20",
        "--ks",
        "4",
        "--min-phase-margin",
        "60",
    ]);
    let out = text(&o.stdout);
    assert!(
        out.contains("flagged: position PM") && !out.contains("◀ best"),
        "{out}"
    );
}

/// A file that names no base runs on the default preset's keys: it says so, and is named
/// after itself in the output, not after the preset.
#[test]
fn a_machine_file_without_a_base_is_warned_about_and_named_after_itself() {
    let dir = tempfile::tempdir().unwrap();
    let m = dir.path().join("my-table.toml");
    std::fs::write(&m, "[x.drive]\nbacklash_um = 3.0\n").unwrap();
    let plots = dir.path().join("plots");
    let o = run_ok(&[
        "bode",
        "--machine",
        m.to_str().unwrap(),
        "--plot",
        plots.to_str().unwrap(),
    ]);
    let err = text(&o.stderr);
    assert!(
        err.contains("my-table.toml gives no `base`") && err.contains("`hvmc`"),
        "{err}"
    );
    let out = text(&o.stdout);
    assert!(out.starts_with("X axis of my-table "), "{out}");
    // The least damped closed-loop mode is the screw's torsion, damped by its material
    // whatever the gains: the least damped mode the loops act on is named beside it.
    let figures = |prefix: &str| -> (String, f64) {
        let line = out
            .lines()
            .find(|l| l.starts_with(prefix))
            .unwrap_or_else(|| panic!("{out}"));
        let rest = &line[prefix.len()..];
        let (hz, rest) = rest.split_once(" Hz, damping ratio ").unwrap();
        let zeta = rest.split_whitespace().next().unwrap().parse().unwrap();
        (hz.trim().to_string(), zeta)
    };
    let (overall_hz, overall_zeta) = figures("least damped closed-loop mode:");
    let (_, own_zeta) = figures("least damped of the modes the loops act on:");
    assert!(own_zeta > overall_zeta, "{out}");
    assert!(
        out.contains(&format!("(the {overall_hz} Hz mode is the mechanics'")),
        "{out}"
    );
    // The Bode plot marks each loop's margins and carries the machine's name.
    let svg = std::fs::read_to_string(plots.join("bode-x.svg")).unwrap();
    for part in ["PM 89.9°", "GM 5.0 dB", "peak +2.2 dB", "machine my-table"] {
        assert!(svg.contains(part), "bode-x.svg lacks {part}");
    }
    // And a preset misspelt as a base meets the one meant.
    std::fs::write(&m, "base = \"hmvc\"\n").unwrap();
    let o = run(&["bode", "--machine", m.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        text(&o.stderr).contains("did you mean `hvmc`?"),
        "{}",
        text(&o.stderr)
    );
}

/// `--set` sweeps the machine's own keys too — the interpolator's and Z's — each written as
/// the file writes it; a key given twice, or a section no machine has, is refused by name.
#[test]
fn a_sweep_sets_the_interpolators_and_zs_keys_and_each_key_once() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("s.json");
    let square = sample("square.nc");
    run_ok(&[
        "sweep",
        square.to_str().unwrap(),
        "--set",
        "interpolation.cycle_ms=2,4",
        "--set",
        "z.limits.max_accel_m_per_s2=1,2",
        "--json",
        json.to_str().unwrap(),
    ]);
    let doc = read_json(&json);
    let dims = doc["dimensions"].as_array().unwrap();
    assert_eq!(dims[0]["keys"][0], "interpolation.cycle_ms");
    assert_eq!(dims[1]["keys"][0], "z.limits.max_accel_m_per_s2");
    assert_eq!(doc["points"].as_array().unwrap().len(), 4);
    let twice = run(&[
        "sweep",
        square.to_str().unwrap(),
        "--set",
        "x.drive.backlash_um=0,10",
        "--set",
        "x.drive.backlash_um=0,20",
    ]);
    assert_eq!(twice.status.code(), Some(2));
    assert!(text(&twice.stderr).contains("already swept"), "{twice:?}");
    // The same through a shortcut and through --set.
    let twice = run(&[
        "sweep",
        square.to_str().unwrap(),
        "--kv",
        "0.8,1",
        "--set",
        "x.position_loop.kv_m_per_min_per_mm=0.9",
    ]);
    assert!(
        text(&twice.stderr).contains("already swept (as x.kv)"),
        "{twice:?}"
    );
    let nowhere = run(&[
        "sweep",
        square.to_str().unwrap(),
        "--set",
        "w.drive.backlash_um=1",
    ]);
    let err = text(&nowhere.stderr);
    assert!(err.contains("x., y., xy., z. or interpolation."), "{err}");
}

/// A sweep writes its outputs together or none: an output whose folder is not there is
/// refused before the run, and a plot folder that cannot be made leaves the CSV unwritten
/// (both were left beside the error before); the cycle swept beside `--cycle-ms` is refused.
#[test]
fn a_sweep_writes_its_outputs_together_or_none() {
    let dir = tempfile::tempdir().unwrap();
    let square = sample("square.nc");
    let (json, csv) = (dir.path().join("s.json"), dir.path().join("s.csv"));
    let nowhere = dir.path().join("not-here").join("s.csv");
    let o = run(&[
        "sweep",
        square.to_str().unwrap(),
        "--kv",
        "1",
        "--json",
        json.to_str().unwrap(),
        "--csv",
        nowhere.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o.stderr).contains("there is no folder"), "{o:?}");
    assert!(!json.exists());
    // A regular file where the plots' folder should be.
    let taken = dir.path().join("plots");
    std::fs::write(&taken, "a file").unwrap();
    let o = run(&[
        "sweep",
        square.to_str().unwrap(),
        "--kv",
        "1",
        "--csv",
        csv.to_str().unwrap(),
        "--plot",
        taken.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2), "{o:?}");
    assert!(!csv.exists());
    let both = run(&[
        "sweep",
        square.to_str().unwrap(),
        "--set",
        "interpolation.cycle_ms=1,2",
        "--cycle-ms",
        "4",
    ]);
    assert!(text(&both.stderr).contains("--cycle-ms sets"), "{both:?}");
}

/// A sweep none of whose settings can be made fails with why; one whose ranges make more
/// settings than `--max-settings` (1000 unless raised) is refused before it runs, naming
/// how many: 0.5 to 1 by 0.0001 is (1 − 0.5)/0.0001 + 1 = 5001 values, and 0.5 to 1.5 by
/// 0.01 beside 10 to 20 by 1 is 101 × 11 = 1111.
#[test]
fn a_sweep_with_nothing_to_run_or_too_much_is_refused() {
    let square = sample("square.nc");
    let sweep = |args: &[&str]| run(&[&["sweep", square.to_str().unwrap()][..], args].concat());
    let invalid = sweep(&["--ks", "1e9"]);
    assert_eq!(invalid.status.code(), Some(2), "{invalid:?}");
    let err = text(&invalid.stderr);
    assert!(err.contains("every setting swept is invalid"), "{err}");
    assert!(err.contains("x.velocity_loop.ks_nm_s_per_rad"), "{err}");
    let fine = sweep(&["--kv", "0.5:1:0.0001"]);
    assert_eq!(fine.status.code(), Some(2), "{fine:?}");
    assert!(text(&fine.stderr).contains("5001 settings"), "{fine:?}");
    let grid = sweep(&["--kv", "0.5:1.5:0.01", "--ks", "10:20:1"]);
    assert!(
        text(&grid.stderr).contains("1111 settings (101 x.kv × 11 x.ks)"),
        "{grid:?}"
    );
    let few = sweep(&["--kv", "0.9,1,1.1", "--max-settings", "2"]);
    assert!(text(&few.stderr).contains("3 settings"), "{few:?}");
    run_ok(&[
        "sweep",
        square.to_str().unwrap(),
        "--kv",
        "0.9,1,1.1",
        "--max-settings",
        "3",
    ]);
}

/// `sweep --help` says what `--min-damping` flags as the health rule does it — a mode of the
/// mechanics only below both the threshold and half its damping on the mechanics alone —
/// and promises the mode's frequency only where it is written (the JSON and the flag), not
/// in the `loop damping` column, which holds the damping alone.
#[test]
fn sweep_help_says_which_modes_min_damping_flags() {
    let o = run_ok(&["sweep", "--help"]);
    let help = text(&o.stdout)
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ");
    assert!(
        help.contains(
            "a mode of the mechanics flags it only below both ZETA and half the damping the \
             mechanics alone give it"
        ) && help.contains("(`loop_damping_at`)"),
        "{help}"
    );
    assert!(!help.contains("with its frequency"), "{help}");
}

/// Numbers no run can use are refused by their option before anything is written: a trace
/// that keeps every 0th sample, a work offset beyond any machine's travel (or not a number).
#[test]
fn numbers_no_run_can_use_are_refused_by_their_option() {
    let dir = tempfile::tempdir().unwrap();
    let trace = dir.path().join("t.csv");
    let square = sample("square.nc");
    let o = run(&[
        "check",
        square.to_str().unwrap(),
        "--trace",
        trace.to_str().unwrap(),
        "--trace-every",
        "0",
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o.stderr));
    assert!(
        text(&o.stderr).contains("--trace-every 0"),
        "{}",
        text(&o.stderr)
    );
    assert!(!trace.exists());
    let record = dir.path().join("m.csv");
    run_ok(&[
        "synth",
        square.to_str().unwrap(),
        "--out",
        record.to_str().unwrap(),
    ]);
    for offset in ["1e308,0", "0,-2e6", "nan,0", "inf,1"] {
        let o = run(&["inspect", record.to_str().unwrap(), "--work-offset", offset]);
        assert_eq!(o.status.code(), Some(2), "{offset}: {}", text(&o.stderr));
        assert!(
            text(&o.stderr).contains(&format!("--work-offset '{offset}'")),
            "{}",
            text(&o.stderr)
        );
    }
    run_ok(&[
        "inspect",
        record.to_str().unwrap(),
        "--work-offset",
        "-471.1,250",
    ]);
}

/// `--trace-every` without `--trace` has nothing to thin: refused, naming `--trace`, rather
/// than ignored.
#[test]
fn trace_every_without_a_trace_is_refused() {
    let o = run(&[
        "check",
        sample("circle-test.nc").to_str().unwrap(),
        "--trace-every",
        "10",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o.stderr).contains("--trace <FILE>"), "{o:?}");
}
