//! The command line on measured records: `diagnose` and `identify` with their exit
//! statuses, outputs written whole, and warnings given once.

use crate::common;

use std::path::Path;

use common::cli::{
    read_json, run, run_ok, sample, synth_backlash_on_x, synth_on_a_scale_with_commands, text,
};

/// A control's export — milliseconds, vendor column names, semicolons with decimal commas,
/// a comment and an `EOF` trailer — is diagnosed as it is, with a column mapping, and gives
/// the diagnosis the plain file gives. `inspect` shows how it was read.
#[test]
fn a_vendor_export_is_diagnosed_without_conversion() {
    let dir = tempfile::tempdir().unwrap();
    let plain = dir.path().join("m.csv");
    // The circular test at half the radius: the same speed and reversals in half the record.
    let circle = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/circle-r50.nc");
    synth_backlash_on_x(&circle, &plain, "8");
    let mut vendor =
        String::from("// servo trace, axis positions in mm\r\nTime;X_ActPos;Y_ActPos\r\n");
    for line in std::fs::read_to_string(&plain).unwrap().lines().skip(1) {
        let f: Vec<f64> = line.split(',').map(|v| v.parse().unwrap()).collect();
        let row = format!("{:.3};{:.7};{:.7}\r\n", f[0] * 1e3, f[1], f[2]);
        vendor.push_str(&row.replace('.', ","));
    }
    vendor.push_str("EOF;;\r\n");
    let exported = dir.path().join("export.csv");
    std::fs::write(&exported, vendor).unwrap();

    let overview_dir = dir.path().join("overview");
    let overview = overview_dir.join("inspect.png");
    let o = run_ok(&[
        "inspect",
        exported.to_str().unwrap(),
        "--columns",
        "t=Time[ms],x=X_ActPos[mm],y=Y_ActPos[mm]",
        "--plot",
        overview_dir.to_str().unwrap(),
    ]);
    assert!(std::fs::read(&overview).unwrap().starts_with(b"\x89PNG"));
    let shown = text(&o.stdout);
    assert!(
        shown.contains("semicolon-separated, decimal comma, 1 trailer rows skipped"),
        "{shown}"
    );
    assert!(shown.contains("at 500.0 Hz"), "{shown}");
    // Without the mapping, the unit-less millisecond clock is read in ms — the only unit
    // giving a plausible step — and the mapping says so.
    let o = run_ok(&["inspect", exported.to_str().unwrap()]);
    let shown = text(&o.stdout);
    assert!(shown.contains("at 500.0 Hz"), "{shown}");
    assert!(
        shown.contains("in ms (unit from the sampling step"),
        "{shown}"
    );

    let found = |measured: &std::path::Path, extra: &[&str]| {
        let mut args = vec!["diagnose", circle.to_str().unwrap(), "--measured"];
        args.push(measured.to_str().unwrap());
        args.extend_from_slice(extra);
        let o = run(&args);
        assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
        text(&o.stdout)
            .lines()
            .find(|l| l.contains("drive.backlash_um ="))
            .unwrap_or_else(|| panic!("no backlash found:\n{}", text(&o.stdout)))
            .to_string()
    };
    let from_export = found(
        &exported,
        &["--columns", "t=Time[ms],x=X_ActPos[mm],y=Y_ActPos[mm]"],
    );
    assert_eq!(from_export, found(&plain, &[]));
}

/// The commands of a record `synth --with-commands` wrote at `planned`, re-timed 25 % slower
/// in another control's columns (ms, mm), written to `commands`.
fn write_slower_stream(planned: &Path, commands: &Path) {
    let mut stream = String::from("time_ms,X_Traj,Y_Traj\n");
    for line in std::fs::read_to_string(planned).unwrap().lines().skip(1) {
        let f: Vec<f64> = line.split(',').map(|v| v.parse().unwrap()).collect();
        stream.push_str(&format!("{:.3},{:.7},{:.7}\n", f[0] * 1.25e3, f[3], f[4]));
    }
    std::fs::write(commands, stream).unwrap();
}

/// Another interpolator's commands drive `synth` (a record at 5 kHz in 0.1 µm motor-encoder
/// counts), and `diagnose` reads it at the motor: the hidden gain error is named, the
/// causes a motor encoder cannot see are listed as not tried, and the user steers the
/// search.
#[test]
fn a_foreign_command_stream_at_the_motor_is_diagnosed_and_the_user_steers() {
    let dir = tempfile::tempdir().unwrap();
    let program = dir.path().join("small-circle.nc");
    std::fs::write(
        &program,
        "G21 G17 G90 G94\nG0 X10 Y-5\nG1 Y0 F3000\nG3 X10 Y0 I-10 J0\nG1 Y5\nM30\n",
    )
    .unwrap();
    let program = program.to_str().unwrap();
    // Our plan's commands, re-timed 25 % slower on a 1 kHz clock: the same path at
    // another speed, as another control would run it.
    let planned = dir.path().join("planned.csv");
    run_ok(&[
        "synth",
        program,
        "--out",
        planned.to_str().unwrap(),
        "--with-commands",
        "--sample-ms",
        "1",
    ]);
    let commands = dir.path().join("commands.csv");
    write_slower_stream(&planned, &commands);
    let record = dir.path().join("record.csv");
    let mut args = vec!["synth", program, "--out", record.to_str().unwrap()];
    args.extend(["--commands", commands.to_str().unwrap()]);
    let options = "--columns t=time_ms[ms],x=X_Traj[mm],y=Y_Traj[mm] --rate-hz 5000 \
                   --quantization-um 0.1 --measured-at motor --noise-um 0.02 \
                   --effect kv_gain --axis y --values 0.9";
    args.extend(options.split_whitespace());
    run_ok(&args);

    let diagnose = |extra: &[&str]| {
        let mut args = vec!["diagnose", program, "--measured", record.to_str().unwrap()];
        args.extend_from_slice(extra);
        let o = run(&args);
        assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
        text(&o.stdout)
    };
    let at_motor = diagnose(&["--measured-at", "motor"]);
    assert!(
        at_motor.contains("1 significant cause: kv_gain on Y."),
        "{at_motor}"
    );
    assert!(at_motor.contains("held out:"), "{at_motor}");
    assert!(
        at_motor.contains("not tried: backlash on X, Y (measured at the motor"),
        "{at_motor}"
    );
    let none = diagnose(&["--measured-at", "motor", "--max-causes", "0"]);
    assert!(none.contains("No cause tried"), "{none}");
    let excluded = diagnose(&["--measured-at", "motor", "--exclude", "kv_gain,dead_time"]);
    assert!(
        !excluded.contains("significant cause: kv_gain"),
        "{excluded}"
    );
    assert!(
        excluded.contains("not tried: kv_gain on X, Y (left out"),
        "{excluded}"
    );
    // An unknown id is refused with the ids there are.
    let o = run(&[
        "diagnose",
        program,
        "--measured",
        record.to_str().unwrap(),
        "--causes",
        "lost_motion",
    ]);
    assert_eq!(o.status.code(), Some(2));
    let err = text(&o.stderr);
    assert!(
        err.contains("invalid value 'lost_motion'") && err.contains("direction_offset"),
        "{err}"
    );
}

/// `--measured` names one record to fit on and at most one to judge on.
#[test]
fn diagnose_takes_at_most_two_records() {
    let square = sample("square.nc");
    let o = run(&[
        "diagnose",
        square.to_str().unwrap(),
        "--measured",
        "a.csv",
        "--measured",
        "b.csv",
        "--measured",
        "c.csv",
    ]);
    let err = text(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("at most one to judge on"), "{err}");
}

/// `identify` of `program` on a record of the machine file `hidden` without its commands
/// says what the record lacks and writes nothing (files in `dir`).
fn assert_identify_refuses_a_record_without_commands(program: &str, hidden: &str, dir: &Path) {
    let path = |name: &str| dir.join(name).to_str().unwrap().to_string();
    run_ok(&[
        "synth",
        program,
        "--machine",
        hidden,
        "--out",
        &path("bare.csv"),
    ]);
    let o = run(&[
        "identify",
        program,
        "--measured",
        &path("bare.csv"),
        "--template",
        "small-table",
        "--out",
        &path("never.toml"),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        text(&o.stderr).contains("no commanded positions"),
        "{}",
        text(&o.stderr)
    );
    assert!(!dir.join("never.toml").exists());
}

/// From a record to a machine file in one command: a small table with heavier tables and
/// other friction than the preset's is recorded at 10 kHz with its commands; `identify`
/// from the `small-table` template writes a machine file that `check` takes, with the
/// values in its header. A record without commands says what it lacks.
#[test]
fn identify_writes_a_machine_file_check_takes_and_a_record_without_commands_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    // Both without acceleration feed-forward (docs/identify.md: feed-forward of a record's
    // reconstructed acceleration biases the mass).
    let no_ff =
        "[x.controller]\naccel_feedforward = 0.0\n[y.controller]\naccel_feedforward = 0.0\n";
    std::fs::write(
        path("hidden.toml"),
        format!(
            "base = \"small-table\"\n{no_ff}[x.drive]\ntable_mass_kg = 45.0\n\
             [x.friction]\ncoulomb_n = 35.0\n[y.drive]\ntable_mass_kg = 70.0\n"
        ),
    )
    .unwrap();
    std::fs::write(
        path("template.toml"),
        format!("base = \"small-table\"\n{no_ff}"),
    )
    .unwrap();
    let program = sample("identify-moves.nc");
    let program = program.to_str().unwrap();
    synth_on_a_scale_with_commands(program, &path("hidden.toml"), &path("rec.csv"));
    let o = run_ok(&[
        "identify",
        program,
        "--measured",
        &path("rec.csv"),
        "--template",
        &path("template.toml"),
        "--out",
        &path("id.toml"),
        "--json",
        &path("id.json"),
    ]);
    let out = text(&o.stdout);
    assert!(
        out.contains("drive.table_mass_kg") && out.contains("machine written to"),
        "{out}"
    );
    let id = contourcheck::machine::MachineConfig::load(Path::new(&path("id.toml"))).unwrap();
    let masses = (id.x.drive.table_mass_kg, id.y.drive.table_mass_kg);
    assert!(
        (masses.0 - 45.0).abs() < 0.5 && (masses.1 - 70.0).abs() < 0.7,
        "{masses:?}"
    );
    let json = read_json(Path::new(&path("id.json")));
    assert_eq!(json["axes"][0]["axis"], "x");
    run_ok(&["check", program, "--machine", &path("id.toml")]);
    assert_identify_refuses_a_record_without_commands(program, &path("hidden.toml"), dir.path());
}

/// docs/identify.md's example of a controller that is not its design: the documented commands,
/// on the documented files, find the stand-in's gain, corners, mass and friction, and the
/// identified machine predicts the held-out halves to the record's noise.
#[test]
fn the_readme_lead_lag_example_identifies_the_stand_in() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let example = |name: &str| {
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("docs/examples")
            .join(name)
            .to_str()
            .unwrap()
            .to_string()
    };
    let program = sample("small-circle.nc");
    let program = program.to_str().unwrap();
    synth_on_a_scale_with_commands(
        program,
        &example("lead-lag-table.toml"),
        &path("record.csv"),
    );
    run_ok(&[
        "identify",
        program,
        "--measured",
        &path("record.csv"),
        "--template",
        &example("lead-lag-design.toml"),
        "--out",
        &path("mine.toml"),
        "--json",
        &path("id.json"),
    ]);
    let json = read_json(Path::new(&path("id.json")));
    let x = &json["axes"][0];
    let value = |key: &str| {
        let v = x["values"]
            .as_array()
            .unwrap()
            .iter()
            .find(|v| v["key"] == key)
            .unwrap_or_else(|| panic!("{key}: {x}"));
        assert_eq!(v["determined"], true, "{key}: {v}");
        v["value"].as_f64().unwrap()
    };
    for (key, truth) in [
        ("controller.gain", 300.59),
        ("controller.zero_1_hz", 3.5),
        ("controller.zero_2_hz", 14.4),
        ("controller.pole_1_hz", 64.0),
        ("drive.table_mass_kg", 40.0),
        ("friction.coulomb_n", 0.15 * 40.0 * 9.81),
    ] {
        let v = value(key);
        assert!((v / truth - 1.0).abs() < 0.03, "{key}: {v} against {truth}");
    }
    let noise = json["noise_um"].as_f64().unwrap();
    for axis in json["axes"].as_array().unwrap() {
        let held_out = axis["held_out_identified_um"].as_f64().unwrap();
        assert!(held_out < 1.5 * noise, "{axis}");
        assert!(held_out < 0.15 * axis["following_error_rms_um"].as_f64().unwrap());
    }
}

/// A record whose commands run an axis faster than the machine file's rapid rate (1000
/// mm/min commanded, 600 allowed): `diagnose` warns of it once, in its report, and not again
/// on stderr.
#[test]
fn a_command_beyond_the_machine_is_warned_of_once() {
    let dir = tempfile::tempdir().unwrap();
    let program = dir.path().join("line.nc");
    std::fs::write(
        &program,
        "G21 G90 G17 G94\nG0 X0 Y0\nG1 X20 F1000\nG1 X0\nM2\n",
    )
    .unwrap();
    let record = dir.path().join("line.csv");
    run_ok(&[
        "synth",
        program.to_str().unwrap(),
        "--with-commands",
        "--out",
        record.to_str().unwrap(),
    ]);
    let slow = dir.path().join("slow.toml");
    std::fs::write(
        &slow,
        "base = \"hvmc\"\n[x.limits]\nrapid_mm_per_min = 600\nmax_feed_mm_per_min = 600\n",
    )
    .unwrap();
    let o = run_ok(&[
        "diagnose",
        program.to_str().unwrap(),
        "--measured",
        record.to_str().unwrap(),
        "--machine",
        slow.to_str().unwrap(),
    ]);
    let all = text(&o.stdout) + &text(&o.stderr);
    let warning = "beyond the rapid rate of 600 mm/min (x.limits.rapid_mm_per_min)";
    assert_eq!(all.matches(warning).count(), 1, "{all}");
}

/// `identify --measured-at motor` compares the model where a motor-encoder record read the
/// axes. The stock `hvmc` machine (a linear scale closes its loops) recorded at its motors
/// is its own template: read at the motors, only the record's noise is left on the held-out
/// halves. Read as the table (the default), the screw's wind-up stays: while moving, the
/// screw carries the Coulomb friction f_c = c·M_T·g and stretches by f_c / k_m, which the
/// motor's reading holds and the table's does not, with the direction's sign.
#[test]
fn identify_compares_a_motor_record_at_the_motor() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let program = sample("identify-moves.nc");
    let program = program.to_str().unwrap();
    let noise_um = 0.2;
    run_ok(&[
        "synth",
        program,
        "--out",
        &path("motor.csv"),
        "--with-commands",
        "--rate-hz",
        "1000",
        "--noise-um",
        &noise_um.to_string(),
        "--measured-at",
        "motor",
    ]);
    let held_out = |extra: &[&str], json: &str| -> Vec<f64> {
        let mut args = vec!["identify", program, "--measured"];
        let (record, out, json) = (path("motor.csv"), path("id.toml"), path(json));
        args.extend([
            record.as_str(),
            "--out",
            out.as_str(),
            "--json",
            json.as_str(),
        ]);
        args.extend_from_slice(extra);
        run_ok(&args);
        let report = read_json(Path::new(&json));
        let axes = report["axes"].as_array().unwrap();
        assert_eq!(axes.len(), 2, "{report}");
        axes.iter()
            .map(|a| a["held_out_identified_um"].as_f64().unwrap())
            .collect()
    };
    let at_motor = held_out(&["--measured-at", "motor"], "motor.json");
    let as_table = held_out(&[], "table.json");
    // hvmc.toml: c = 0.010, M_T = 6000 kg, k_m = 3.6e8 N/m on both axes: 1.6 µm of wind-up,
    // eight times the noise. A fit may pass part of it for lag (the feeds are steady), so
    // half of it is what the table's reading must keep.
    let wind_up_um = 0.010 * 6000.0 * 9.81 / 3.6e8 * 1e6;
    for (motor, table) in at_motor.iter().zip(&as_table) {
        assert!(*motor < 1.5 * noise_um, "{at_motor:?}");
        assert!(
            *table > 0.5 * wind_up_um,
            "{as_table:?} against {wind_up_um} µm"
        );
    }
}

/// `synth --commands` runs the stream without a program: given none, or one it does not
/// run, it writes the same record, whose commands are the stream's own values moved by the
/// clock offset (0.5 s: 250 samples of 2 ms). Given neither, it asks for one of them.
#[test]
fn synth_runs_a_command_stream_without_a_program() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let circle = sample("small-circle.nc");
    let circle = circle.to_str().unwrap();
    run_ok(&[
        "synth",
        circle,
        "--out",
        &path("stream.csv"),
        "--with-commands",
    ]);
    let stream = ["--commands", &path("stream.csv")];
    run_ok(&[&["synth", "--out", &path("alone.csv")][..], &stream].concat());
    let square = sample("square.nc");
    let both = [
        "synth",
        square.to_str().unwrap(),
        "--out",
        &path("both.csv"),
    ];
    let o = run_ok(&[&both[..], &stream].concat());
    assert!(
        text(&o.stderr).contains("square.nc is not run"),
        "{}",
        text(&o.stderr)
    );
    let read = |name: &str| std::fs::read_to_string(dir.path().join(name)).unwrap();
    assert_eq!(read("alone.csv"), read("both.csv"));
    let x_cmd = |name: &str| -> Vec<f64> {
        let t = read(name);
        let cell = |l: &str| l.split(',').nth(3).unwrap().parse::<f64>().unwrap();
        t.lines().skip(1).map(cell).collect()
    };
    let (given, recorded) = (x_cmd("stream.csv"), x_cmd("alone.csv"));
    assert!(given.len() > 1000 && recorded.len() >= given.len() + 250);
    for (k, (g, r)) in given.iter().zip(&recorded[250..]).enumerate() {
        assert!(
            (g - r).abs() < 1e-9,
            "sample {k}: {g} mm given, {r} mm recorded"
        );
    }
    let o = run(&["synth", "--out", &path("none.csv")]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o.stderr));
    assert!(text(&o.stderr).contains("<PROGRAM>"), "{}", text(&o.stderr));
}

/// The record stands still from its clock's 0 until the program starts: a start a day or
/// more later (or past any count of samples) is refused by its option, before anything is
/// simulated or written — not a file of gigabytes, an allocation that fails, or none.
#[test]
fn synth_refuses_a_program_start_no_record_waits_for() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("late.csv");
    let program = sample("line-60deg.nc");
    for offset in ["86400", "1e15", "1e300", "-1", "nan"] {
        let o = run(&[
            "synth",
            program.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            &format!("--offset-s={offset}"),
        ]);
        assert_eq!(o.status.code(), Some(2), "{offset}: {}", text(&o.stderr));
        assert!(
            text(&o.stderr).contains("--offset-s ")
                && text(&o.stderr).contains("must lie between 0 and 3600 s"),
            "{offset}: {}",
            text(&o.stderr)
        );
        assert!(!out.exists(), "{offset}");
    }
    // An hour's wait at the coarsest step is still a record.
    run_ok(&[
        "synth",
        program.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--offset-s=3600",
        "--sample-ms=100",
    ]);
    let rows = std::fs::read_to_string(&out).unwrap().lines().count();
    assert!(rows > 36_000, "{rows}");
}

/// A template that is neither a file nor a preset is named by its own option, with the
/// preset meant where the name is close to one.
#[test]
fn identify_names_a_template_that_is_nowhere_by_its_option() {
    let dir = tempfile::tempdir().unwrap();
    let record = dir.path().join("line.csv");
    let program = sample("line-60deg.nc");
    let p = program.to_str().unwrap();
    run_ok(&[
        "synth",
        p,
        "--out",
        record.to_str().unwrap(),
        "--with-commands",
    ]);
    let out = dir.path().join("id.toml");
    let o = run(&[
        "identify",
        p,
        "--measured",
        record.to_str().unwrap(),
        "--template",
        "hmvc",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o.stderr));
    let e = text(&o.stderr);
    assert!(e.contains("--template hmvc: no such file"), "{e}");
    assert!(
        e.contains("did you mean `hvmc`?") && !e.contains("--machine"),
        "{e}"
    );
    assert!(!out.exists());
}

/// A record with 8 µm of backlash on Y in which one sample of X, while X moves, was misread
/// by 5 mm: the sample is bridged and said, with its time on the record's clock, and the
/// backlash is still found (that one sample had been the whole residual: "no significant
/// cause").
#[test]
fn a_misread_sample_is_bridged_and_said_and_hides_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let (clean, glitched) = (dir.path().join("bl.csv"), dir.path().join("glitch.csv"));
    let square = sample("square.nc");
    run_ok(&[
        "synth",
        square.to_str().unwrap(),
        "--effect",
        "backlash",
        "--axis",
        "y",
        "--values",
        "8",
        "--with-commands",
        "--out",
        clean.to_str().unwrap(),
    ]);
    let text_in = std::fs::read_to_string(&clean).unwrap();
    let mut rows: Vec<Vec<String>> = text_in
        .lines()
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect();
    let x = |r: &Vec<String>| r[1].parse::<f64>().unwrap();
    // A third into the record, the first row where X moves.
    let k = (rows.len() / 3..rows.len() - 1)
        .find(|&k| (x(&rows[k + 1]) - x(&rows[k])).abs() > 1e-3)
        .unwrap();
    let at_s = rows[k][0].clone();
    rows[k][1] = format!("{:.7}", x(&rows[k]) + 5.0);
    let joined: Vec<String> = rows.iter().map(|r| r.join(",")).collect();
    std::fs::write(&glitched, joined.join("\n") + "\n").unwrap();
    let o = run_ok(&[
        "diagnose",
        square.to_str().unwrap(),
        "--measured",
        glitched.to_str().unwrap(),
    ]);
    let (out, err) = (text(&o.stdout), text(&o.stderr));
    // 5 mm off, within the record's noise and a sample's curvature of the path.
    let off_um: f64 = err
        .split(&format!("measured X at {at_s} s lies "))
        .nth(1)
        .and_then(|rest| rest.split(' ').next())
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("{err}"));
    assert!(
        (off_um - 5000.0).abs() < 3.0 && err.contains("bridged"),
        "{err}"
    );
    assert!(out.contains("backlash on Y"), "{out}");
}
