//! Trace files as controls and labs write them, other than text tables: MATLAB MAT-files
//! (level 5; plain variables, matrices, and the capture structures Simulink and dSPACE
//! save), LinuxCNC halscope logs, and the formats that are refused with a reason. The tests
//! write the files themselves, laid out as those tools lay them out, from a synthetic
//! record, and read them back.

use contourcheck::diagnose::synth::{SynthSpec, synthesize};
use contourcheck::machine::MachineConfig;
use contourcheck::trace::format::ColumnMap;
use contourcheck::trace::measured::{MeasuredTrace, parse_trace, read_trace_with};

/// A level-5 MAT-file holding real double matrices `(name, rows, columns, column-major
/// values)`.
fn mat_file(variables: &[(&str, usize, usize, Vec<f64>)]) -> Vec<u8> {
    let mut out = Vec::new();
    let mut text = b"MATLAB 5.0 MAT-file, written by the contourcheck tests".to_vec();
    text.resize(116, b' ');
    out.extend(text);
    out.extend([0u8; 8]); // no subsystem data
    out.extend(0x0100u16.to_le_bytes()); // version
    out.extend(*b"IM"); // little-endian
    let tag = |kind: u32, bytes: usize| {
        let mut t = kind.to_le_bytes().to_vec();
        t.extend((bytes as u32).to_le_bytes());
        t
    };
    let padded = |mut v: Vec<u8>| {
        v.resize(v.len().div_ceil(8) * 8, 0);
        v
    };
    for (name, rows, columns, values) in variables {
        assert_eq!(values.len(), rows * columns);
        let mut body = Vec::new();
        // Array flags: class double (6).
        body.extend(tag(6, 8));
        body.extend(6u32.to_le_bytes());
        body.extend(0u32.to_le_bytes());
        // Dimensions.
        body.extend(tag(5, 8));
        body.extend((*rows as i32).to_le_bytes());
        body.extend((*columns as i32).to_le_bytes());
        // Name.
        body.extend(tag(1, name.len()));
        body.extend(padded(name.as_bytes().to_vec()));
        // Real part.
        body.extend(tag(9, 8 * values.len()));
        for v in values {
            body.extend(v.to_le_bytes());
        }
        out.extend(tag(14, body.len()));
        out.extend(body);
    }
    out
}

/// The square sample program.
fn square() -> contourcheck::gcode::Program {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/gcode-samples/square.nc"
    ))
    .unwrap();
    contourcheck::gcode::parse_program(
        &text,
        "square.nc",
        &contourcheck::gcode::InterpretOptions::default(),
    )
    .unwrap()
}

/// The square on the nominal machine with its commands recorded.
fn synthetic_square() -> contourcheck::diagnose::synth::Synthetic {
    let spec = SynthSpec {
        with_commands: true,
        ..SynthSpec::default()
    };
    synthesize(&square(), &MachineConfig::default_preset(), &spec).unwrap()
}

/// A synthetic record of the square with commands, as the CSV the tool writes.
fn record() -> (String, MeasuredTrace) {
    let mut csv = Vec::new();
    synthetic_square().write_csv(&mut csv).unwrap();
    let csv = String::from_utf8(csv).unwrap();
    let trace = parse_trace(&csv, "record.csv").unwrap();
    (csv, trace)
}

/// The CSV's columns: t (s) and positions (mm).
fn columns(csv: &str) -> [Vec<f64>; 5] {
    let mut cols: [Vec<f64>; 5] = Default::default();
    for line in csv.lines().skip(1) {
        for (c, v) in cols.iter_mut().zip(line.split(',')) {
            c.push(v.parse().unwrap());
        }
    }
    cols
}

fn read(bytes: &[u8], map: Option<&str>) -> Result<MeasuredTrace, String> {
    read_named(bytes, "capture.mat", map)
}

/// `bytes` read from a file named `name`.
fn read_named(bytes: &[u8], name: &str, map: Option<&str>) -> Result<MeasuredTrace, String> {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(name);
    std::fs::write(&path, bytes).unwrap();
    let map = map.map(|m| ColumnMap::parse(m).unwrap());
    read_trace_with(&path, map.as_ref()).map_err(|e| e.to_string())
}

fn assert_same(a: &MeasuredTrace, b: &MeasuredTrace) {
    assert_eq!(a.x_m.len(), b.x_m.len());
    assert!((a.dt_s - b.dt_s).abs() < 1e-12 && (a.t0_s - b.t0_s).abs() < 1e-9);
    let close = |u: &[f64], v: &[f64]| u.iter().zip(v).all(|(p, q)| (p - q).abs() < 1e-12);
    assert!(close(&a.x_m, &b.x_m) && close(&a.y_m, &b.y_m));
    let (ca, cb) = (a.commands.as_ref().unwrap(), b.commands.as_ref().unwrap());
    assert!(close(&ca[0], &cb[0]) && close(&ca[1], &cb[1]));
}

#[test]
fn vendor_named_vectors_in_milliseconds_read_like_the_csv() {
    let (csv, expected) = record();
    let [t, x, y, xc, yc] = columns(&csv);
    let n = t.len();
    let ms: Vec<f64> = t.iter().map(|v| v * 1e3).collect();
    let bytes = mat_file(&[
        ("Time", n, 1, ms),
        ("X_ActPos", n, 1, x),
        ("Y_ActPos", 1, n, y), // a row vector reads the same
        ("X_Traj", n, 1, xc),
        ("Y_Traj", n, 1, yc),
    ]);
    let trace = read(
        &bytes,
        Some("t=Time[ms],x=X_ActPos[mm],y=Y_ActPos[mm],x_cmd=X_Traj[mm],y_cmd=Y_Traj[mm]"),
    )
    .unwrap();
    assert_same(&trace, &expected);
    assert!(
        trace.layout.describe()[0].starts_with("MATLAB MAT-file (level 5), 5 numeric columns"),
        "{:?}",
        trace.layout.describe()
    );
}

#[test]
fn a_matrix_of_columns_is_read_by_index_and_recognised_names_need_no_mapping() {
    let (csv, expected) = record();
    let cols = columns(&csv);
    let n = cols[0].len();
    let matrix: Vec<f64> = cols.concat();
    let by_index = read(
        &mat_file(&[("data", n, 5, matrix)]),
        Some("t=data(1)[s],x=data(2)[mm],y=data(3)[mm],x_cmd=data(4)[mm],y_cmd=data(5)[mm]"),
    )
    .unwrap();
    assert_same(&by_index, &expected);
    let [t, x, y, xc, yc] = cols;
    let named = read(
        &mat_file(&[
            ("t_s", n, 1, t),
            ("x_mm", n, 1, x),
            ("y_mm", n, 1, y),
            ("x_cmd_mm", n, 1, xc),
            ("y_cmd_mm", n, 1, yc),
        ]),
        None,
    )
    .unwrap();
    assert_same(&named, &expected);
}

#[test]
fn bad_mat_files_are_refused_with_the_reason() {
    let (csv, _) = record();
    let [t, x, y, ..] = columns(&csv);
    let n = t.len();
    // A variable of another length names itself.
    let short = read(
        &mat_file(&[
            ("t_s", n, 1, t.clone()),
            ("x_mm", n, 1, x.clone()),
            ("y_mm", n - 3, 1, y[..n - 3].to_vec()),
        ]),
        None,
    )
    .unwrap_err();
    assert!(short.contains("variable 'y_mm' has"), "{short}");
    // A NaN names the variable and the sample.
    let mut holed = x.clone();
    holed[41] = f64::NAN;
    let nan = read(
        &mat_file(&[
            ("t_s", n, 1, t.clone()),
            ("x_mm", n, 1, holed),
            ("y_mm", n, 1, y),
        ]),
        None,
    )
    .unwrap_err();
    assert!(nan.contains("row 42") && nan.contains("'x_mm'"), "{nan}");
    // A missing signal lists what the file holds.
    let missing = read(&mat_file(&[("t_s", n, 1, t), ("x_mm", n, 1, x)]), None).unwrap_err();
    assert!(missing.contains("variables:"), "{missing}");
    // A 7.3 file (HDF5 behind the text header) says how to save it instead.
    let mut hdf5 = mat_file(&[]);
    hdf5.truncate(128);
    hdf5.extend(b"\x89HDF\r\n\x1a\n");
    hdf5.extend([0u8; 64]);
    let v73 = read(&hdf5, None).unwrap_err();
    assert!(v73.contains("7.3") && v73.contains("-v7"), "{v73}");
}

#[test]
fn an_empty_or_headerless_mat_file_is_refused_as_a_mat_file() {
    // No bytes at all: the MAT reader's word, naming the file, not a text table's.
    let empty = read(&[], None).unwrap_err();
    assert!(
        empty.contains("capture.mat: an empty file (0 bytes)"),
        "{empty}"
    );
    assert!(!empty.contains("header line"), "{empty}");
    // A MATLAB 4 file (binary, no text header: a matrix header of five 32-bit integers).
    let v4: Vec<u8> = [0u32, 1, 1, 0, 2]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .chain(*b"x\0")
        .chain(1.5f64.to_le_bytes())
        .collect();
    let level4 = read(&v4, None).unwrap_err();
    assert!(
        level4.contains("capture.mat: not a MATLAB level-5 MAT-file: no 128-byte header"),
        "{level4}"
    );
    // A `*.mat` of text (MATLAB's `save -ascii`) is read as the table it is.
    let (csv, expected) = record();
    assert_same(&read(csv.as_bytes(), None).unwrap(), &expected);
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(300))]
    /// Any bytes behind a MAT-file's header are an error or a trace, never a panic.
    #[test]
    fn damaged_mat_files_never_panic(
        tail in proptest::collection::vec(proptest::prelude::any::<u8>(), 0..400),
        cut in 0usize..600,
    ) {
        let (csv, _) = record_small();
        let [t, x, y, ..] = columns(&csv);
        let n = t.len();
        let mut bytes = mat_file(&[("t_s", n, 1, t), ("x_mm", n, 1, x), ("y_mm", n, 1, y)]);
        bytes.truncate(128 + cut.min(bytes.len() - 128));
        bytes.extend(tail);
        let _ = read(&bytes, None);
    }
}

/// A short record (40 samples), for the property test.
fn record_small() -> (String, ()) {
    let mut csv = String::from("t_s,x_mm,y_mm\n");
    for k in 0..40 {
        csv.push_str(&format!(
            "{},{},{}\n",
            k as f64 * 0.002,
            k as f64 * 0.01,
            0.5
        ));
    }
    (csv, ())
}

/// `file` written with the MAT-file writer of the reading crate, as MATLAB's `save` would
/// (compressed: the default of `-v7`), read back as a trace.
fn saved(file: matrw::MatFile, compress: bool, map: Option<&str>) -> Result<MeasuredTrace, String> {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("capture.mat");
    matrw::save_matfile_v7(path.to_str().unwrap(), file, compress).unwrap();
    read(&std::fs::read(&path).unwrap(), map)
}

#[test]
fn a_simulink_structure_with_time_reads_by_its_signal_labels() {
    use matrw::{matfile, matvar};
    let (csv, expected) = record();
    let [t, x, y, xc, yc] = columns(&csv);
    // What a Scope block saves as "Structure with time": the time vector and a structure
    // array of signals, each with its values and label.
    let file = matfile!(
        ScopeData: matvar!({
            time: t,
            signals: matvar!([
                { values: x, label: "X_ActPos", dimensions: 1.0 },
                { values: y, label: "Y_ActPos", dimensions: 1.0 },
                { values: xc, label: "X_Traj", dimensions: 1.0 },
                { values: yc, label: "Y_Traj", dimensions: 1.0 },
            ]),
            blockName: "servo/Scope",
        })
    );
    // No mapping: `ScopeData.time` is recognised by its last part, the signals by label.
    let trace = saved(file, true, None).unwrap();
    assert_same(&trace, &expected);
}

#[test]
fn a_capture_struct_with_block_paths_reads_by_mapping_or_field_path() {
    use matrw::{matfile, matvar};
    let (csv, expected) = record();
    let [t, x, y, xc, yc] = columns(&csv);
    let ms: Vec<f64> = t.iter().map(|v| v * 1e3).collect();
    let um = |v: &[f64]| v.iter().map(|p| p * 1e3).collect::<Vec<f64>>();
    let (x_um, y_um) = (um(&x), um(&y));
    // A capture laid out as dSPACE tools save one: the time axis under X, the signals under
    // Y, each named by its block path.
    let capture = |with_commands: bool| {
        let mut signals = vec![
            matvar!({ Name: "Model Root/Axis X/pos_act", Data: x_um.clone() }),
            matvar!({ Name: "Model Root/Axis Y/pos_act", Data: y_um.clone() }),
        ];
        if with_commands {
            signals.push(matvar!({ Name: "Model Root/Axis X/pos_set", Data: xc.clone() }));
            signals.push(matvar!({ Name: "Model Root/Axis Y/pos_set", Data: yc.clone() }));
        }
        matfile!(capture: matvar!({
            X: matvar!({ Name: "Time", Data: ms.clone() }),
            Y: matrw::MatVariable::from(signals),
        }))
    };
    // The two axes' blocks share a name; their field paths tell them apart.
    let trace = saved(
        capture(true),
        false,
        Some(
            "t=Time[ms],x=capture.Y(1).Data[um],y=capture.Y(2).Data[um],\
             x_cmd=capture.Y(3).Data[mm],y_cmd=capture.Y(4).Data[mm]",
        ),
    )
    .unwrap();
    assert_same(&trace, &expected);
    // Unmapped, the signals are read by their block names (the shared `pos_act` told apart
    // by the block before it) and the clock in its only plausible unit; the positions'
    // unit, which nothing in the file states, is the default and is said to be.
    let said = saved(capture(false), false, None)
        .unwrap()
        .layout
        .describe()
        .join("\n");
    for expected in [
        "'Time' in ms (unit from the sampling step",
        "'Axis X/pos_act' in mm (unit from the default)",
        "'Axis Y/pos_act' in mm (unit from the default)",
    ] {
        assert!(said.contains(expected), "{expected} in:\n{said}");
    }
    // With a column missing, the error lists what the file holds, paths and names alike.
    let e = saved(
        capture(false),
        false,
        Some("t=Time[ms],x=capture.Y(1).Data[um],y=nothing"),
    )
    .unwrap_err();
    assert!(
        e.contains("capture.Y(2).Data") && e.contains("Axis Y/pos_act"),
        "{e}"
    );
}

/// The record as halscope's "Save log" writes it: the period line, then per sample each
/// channel's HAL name and value, and one sample more than the capture (see
/// `trace_halscope`). Positions in inch when `inch`.
fn halscope_log(csv: &str, inch: bool) -> String {
    let [t, x, y, xc, yc] = columns(csv);
    let period_ns = ((t[1] - t[0]) * 1e9).round();
    let scale = if inch { 1.0 / 25.4 } else { 1.0 };
    let mut log = format!("Sampling period is {period_ns} ns \n");
    let channels = [
        ("joint.0.pos-fb", &x),
        ("joint.1.pos-fb", &y),
        ("joint.0.pos-cmd", &xc),
        ("joint.1.pos-cmd", &yc),
    ];
    for k in 0..=t.len() {
        log.push('\n');
        for (name, values) in channels {
            // One past the capture: whatever the buffer held.
            let v = values.get(k).map_or(1234.5, |v| v * scale);
            log.push_str(&format!("{name} {v:+.14} "));
        }
    }
    log.push('\n');
    log
}

#[test]
fn a_halscope_log_reads_by_channel_names_in_the_machines_units() {
    let (csv, expected) = record();
    let map = "x=joint.0.pos-fb[in],y=joint.1.pos-fb[in],\
               x_cmd=joint.0.pos-cmd[in],y_cmd=joint.1.pos-cmd[in]";
    let trace = read(halscope_log(&csv, true).as_bytes(), Some(map)).unwrap();
    // Time starts at the first sample; the rest is the record, the sample past the capture
    // left out.
    assert_eq!(trace.len(), expected.len());
    assert!((trace.dt_s - expected.dt_s).abs() < 1e-12 && trace.t0_s == 0.0);
    let close = |u: &[f64], v: &[f64]| u.iter().zip(v).all(|(p, q)| (p - q).abs() < 1e-12);
    assert!(close(&trace.x_m, &expected.x_m) && close(&trace.y_m, &expected.y_m));
    let (c, e) = (trace.commands.unwrap(), expected.commands.unwrap());
    assert!(close(&c[0], &e[0]) && close(&c[1], &e[1]));
    assert!(trace.layout.describe()[0].starts_with("LinuxCNC halscope log, 4 channels"));
    // Unmapped, the error lists the channels the log holds.
    let e = read(halscope_log(&csv, false).as_bytes(), None).unwrap_err();
    assert!(
        e.contains("channels:") && e.contains("joint.1.pos-fb"),
        "{e}"
    );
}

#[test]
fn undocumented_control_formats_are_refused_with_what_to_export_instead() {
    let xml = read(
        b"<?xml version=\"1.0\"?>\n<traceData><signal name=\"X\"/></traceData>\n",
        None,
    )
    .unwrap_err();
    assert!(xml.contains("XML") && xml.contains("CSV"), "{xml}");
    let mut binary = b"DTA\x00\x01\x02".to_vec();
    binary.extend([0u8; 64]);
    let dta = read_named(&binary, "capture.dta", None).unwrap_err();
    assert!(dta.contains("binary") && dta.contains("CSV"), "{dta}");
}

#[test]
fn a_record_written_in_a_vendor_layout_reads_back_with_that_layout() {
    let (_, expected) = record();
    let layout = ColumnMap::parse(
        "t=Time[ms],x=X_ActPos[counts:0.1um],y=Y_ActPos[counts:0.1um],x_cmd=X_Traj[in],\
         y_cmd=Y_Traj[in]",
    )
    .unwrap();
    let mut csv = Vec::new();
    synthetic_square().write_csv_as(&mut csv, &layout).unwrap();
    let csv = String::from_utf8(csv).unwrap();
    assert!(
        csv.starts_with("Time,X_ActPos,Y_ActPos,X_Traj,Y_Traj\n"),
        "{}",
        &csv[..80]
    );
    // Counts are whole numbers.
    let second = csv.lines().nth(2).unwrap();
    assert!(!second.split(',').nth(1).unwrap().contains('.'), "{second}");
    let read =
        contourcheck::trace::measured::parse_trace_with(&csv, "export.csv", Some(&layout)).unwrap();
    assert_eq!(read.len(), expected.len());
    assert!((read.dt_s - expected.dt_s).abs() < 1e-12);
    // Within half a count of the record written the tool's own way.
    let within =
        |u: &[f64], v: &[f64], tol: f64| u.iter().zip(v).all(|(p, q)| (p - q).abs() <= tol);
    assert!(within(&read.x_m, &expected.x_m, 0.05e-6 + 1e-12));
    assert!(within(&read.y_m, &expected.y_m, 0.05e-6 + 1e-12));
    let (c, e) = (read.commands.unwrap(), expected.commands.unwrap());
    assert!(within(&c[0], &e[0], 1e-10) && within(&c[1], &e[1], 1e-10));
}

/// The record as SINUMERIK Operate saves a trace (see `trace::sinumerik`): ISO-8859-1 XML,
/// signals listed by key with their plain names in the display setup, the actual positions
/// in every `rec` (the position controller's clock) and the setpoints in every second one
/// (the interpolator's), a no-value marker or nothing in between, and a signal the mapping
/// does not need (with a µ in its name).
fn sinumerik_trace(csv: &str) -> Vec<u8> {
    let [t, x, y, xc, yc] = columns(csv);
    let mut xml = String::from(
        "<?xml version=\"1.0\" encoding=\"ISO-8859-1\"?>\n<traceSession version=\"2\">\n\
         <traceDisplaySetup>\n<signals>\n\
         <signal key=\"k1\" name=\"/Nck/ServoData/X1/actPos\" description=\"X1 Position actual value measuring system 1\"/>\n\
         <signal key=\"k2\" name=\"/Nck/ServoData/Y1/actPos\" description=\"Y1 Position actual value measuring system 1\"/>\n\
         </signals>\n</traceDisplaySetup>\n<traceData>\n<dataFrame>\n\
         <dataSignal key=\"k1\" name=\"/Nck/ServoData/X1/actPos\"/>\n\
         <dataSignal key=\"k2\" name=\"/Nck/ServoData/Y1/actPos\"/>\n\
         <dataSignal key=\"k3\" name=\"/Nck/IpoData/X1/setPos\" description=\"X1 Position setpoint (64 bit)\"/>\n\
         <dataSignal key=\"k4\" name=\"/Nck/IpoData/Y1/setPos\" description=\"Y1 Position setpoint (64 bit)\"/>\n\
         <dataSignal key=\"k5\" name=\"/Nck/ServoData/X1/contDev\" description=\"X1 Contour deviation \u{b5}m\"/>\n",
    );
    for k in 0..t.len() {
        let mut rec = format!(
            "<rec time=\"{:.6}\" f1=\"{:.9}\" f2=\"{:.9}\"",
            t[k], x[k], y[k]
        );
        if k % 2 == 0 {
            rec.push_str(&format!(" f3=\"{:.9}\" f4=\"{:.9}\"", xc[k], yc[k]));
        } else if k % 4 == 1 {
            rec.push_str(" f3=\"9223372036854775807\" f4=\"9223372036854775807\"");
        }
        rec.push_str(&format!(" f5=\"{:.3}\"/>\n", (x[k] - xc[k]) * 1e3));
        xml.push_str(&rec);
    }
    xml.push_str("</dataFrame>\n</traceData>\n</traceSession>\n");
    // ISO-8859-1: every character here is below U+0100, one byte each.
    xml.chars()
        .map(|c| u8::try_from(u32::from(c)).unwrap())
        .collect()
}

#[test]
fn a_sinumerik_operate_trace_reads_without_a_mapping() {
    let (csv, expected) = record();
    let n = expected.len();
    // The setpoints end on an odd sample when the record's length is even: the columns
    // share the span every signal covers.
    let last_even = if n % 2 == 0 { n - 1 } else { n };
    let trace = read(&sinumerik_trace(&csv), None).unwrap();
    assert_eq!(trace.len(), last_even);
    assert!((trace.dt_s - expected.dt_s).abs() < 1e-9);
    let near = |u: &[f64], v: &[f64], tol: f64| u.iter().zip(v).all(|(p, q)| (p - q).abs() < tol);
    assert!(near(&trace.x_m, &expected.x_m, 1e-11) && near(&trace.y_m, &expected.y_m, 1e-11));
    // Setpoints interpolated midway between the interpolator's samples: exact where it
    // sampled, within a·Δt²/8 of the commands elsewhere (under 1 µm).
    let (c, e) = (trace.commands.unwrap(), expected.commands.unwrap());
    for axis in 0..2 {
        for k in 0..trace.x_m.len() {
            let tol = if k % 2 == 0 { 1e-11 } else { 1e-6 };
            assert!(
                (c[axis][k] - e[axis][k]).abs() < tol,
                "axis {axis} sample {k}: {} vs {}",
                c[axis][k],
                e[axis][k]
            );
        }
    }
    let described = trace.layout.describe();
    assert!(
        described[0].starts_with("SINUMERIK Operate trace (XML), 5 signals"),
        "{described:?}"
    );
    assert!(
        described
            .iter()
            .any(|l| l.contains("x_cmd") && l.contains("X1 Position setpoint")),
        "{described:?}"
    );
}

#[test]
fn damaged_sinumerik_traces_are_refused_with_the_line() {
    let (csv, _) = record();
    let good = String::from_utf8_lossy(&sinumerik_trace(&csv)).into_owned();
    let cut = &good[..good.len() / 2];
    let e = read(cut.as_bytes(), None).unwrap_err();
    assert!(e.contains("not well-formed XML at line"), "{e}");
    let bad = good.replacen("f1=\"", "f1=\"x", 3);
    let e = read(bad.as_bytes(), None).unwrap_err();
    assert!(e.contains("f1 = 'x") && e.contains("row 1"), "{e}");
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(300))]
    /// A SINUMERIK trace cut anywhere, with any text spliced in, is an error or a trace,
    /// never a panic.
    #[test]
    fn damaged_sinumerik_traces_never_panic(
        splice in "[<>=\"/a-z0-9. f]{0,40}",
        at in 0usize..4000,
        cut in 0usize..4000,
    ) {
        static XML: std::sync::OnceLock<String> = std::sync::OnceLock::new();
        let whole = XML.get_or_init(|| {
            let (csv, _) = record();
            let short: String = csv.lines().take(60).flat_map(|l| [l, "\n"]).collect();
            String::from_utf8_lossy(&sinumerik_trace(&short)).into_owned()
        });
        let mut xml = whole.clone();
        let at = xml.floor_char_boundary(at.min(xml.len()));
        xml.insert_str(at, &splice);
        let cut = xml.floor_char_boundary(cut.min(xml.len()));
        let _ = read(&xml.as_bytes()[..xml.len() - cut], None);
    }
}

/// The record as TwinCAT 3's Scope View exports it (see `trace::twincat`): the scope's
/// lines, the channels' properties (NC axis variables, units "mm (Millimeter)"), a time
/// column per channel in ms with a decimal comma, the set positions at half the actual
/// positions' rate (so their columns end early), and the `EOF` line the export can append.
fn twincat_export(csv: &str) -> String {
    let [t, x, y, xc, yc] = columns(csv);
    let ms = |v: f64| format!("{:.6}", v * 1e3).replace('.', ",");
    let mm = |v: f64| format!("{v:.9}").replace('.', ",");
    let channels = [
        ("MAIN.Axis_X.NcToPlc.ActPos", &x, 1),
        ("MAIN.Axis_Y.NcToPlc.ActPos", &y, 1),
        ("MAIN.Axis_X.NcToPlc.SetPos", &xc, 2),
        ("MAIN.Axis_Y.NcToPlc.SetPos", &yc, 2),
    ];
    let row = |key: &str, cell: &dyn Fn(usize) -> String| {
        let cells: Vec<String> = (0..channels.len())
            .map(|c| format!("{key}\t{}", cell(c)))
            .collect();
        cells.join("\t") + "\n"
    };
    let period_ms = (t[1] - t[0]) * 1e3;
    let mut out = String::from(
        "Name\trecord\nFile\tC:\\TwinCAT\\record.csv\nStarttime of export\t133000000000000000\t\
         Montag, 2. Mai 2022\t15:56:24.376\nEndtime of export\t133000000010000000\t\
         Montag, 2. Mai 2022\t15:56:25.375\n\n\n",
    );
    out += &row("Name", &|c| channels[c].0.to_string());
    out += &row("SymbolComment", &|_| String::new());
    out += &row("Data-Type", &|_| "REAL64".into());
    out += &row("SampleTime[ms]", &|c| {
        ms(period_ms * channels[c].2 as f64 * 1e-3)
    });
    out += &row("Unit", &|_| "mm (Millimeter)".into());
    out += &row("Unit ScaleFactor", &|_| "1".into());
    out += "\n";
    for k in 0..t.len() {
        let cells: Vec<String> = channels
            .iter()
            .map(|(_, values, every)| {
                let j = k * every;
                if j < t.len() {
                    format!("{}\t{}", ms(t[j] - t[0]), mm(values[j]))
                } else {
                    "\t".into()
                }
            })
            .collect();
        out += &(cells.join("\t") + "\n");
    }
    out + "EOF\n"
}

#[test]
fn a_twincat_scope_export_reads_without_a_mapping() {
    let (csv, expected) = record();
    let trace = read(twincat_export(&csv).as_bytes(), None).unwrap();
    // The set positions end at the last even sample: the columns share their span.
    let n = expected.len();
    assert_eq!(trace.len(), if n % 2 == 0 { n - 1 } else { n });
    assert!((trace.dt_s - expected.dt_s).abs() < 1e-9);
    let near = |u: &[f64], v: &[f64], tol: f64| u.iter().zip(v).all(|(p, q)| (p - q).abs() < tol);
    assert!(near(&trace.x_m, &expected.x_m, 1e-11) && near(&trace.y_m, &expected.y_m, 1e-11));
    let (c, e) = (trace.commands.unwrap(), expected.commands.unwrap());
    for axis in 0..2 {
        assert!(near(&c[axis], &e[axis], 1e-6), "axis {axis}");
    }
    let described = trace.layout.describe().join("\n");
    assert!(
        described.starts_with("TwinCAT Scope export, 4 channels")
            && described.contains("x_cmd ← column 4 'MAIN.Axis_X.NcToPlc.SetPos [mm]'"),
        "{described}"
    );
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(300))]
    /// A TwinCAT export cut anywhere, with any cells spliced in, is an error or a trace,
    /// never a panic.
    #[test]
    fn damaged_twincat_exports_never_panic(
        splice in "[\t\n;,0-9a-zA-Z.()\\[\\] -]{0,40}",
        at in 0usize..6000,
        cut in 0usize..6000,
    ) {
        static EXPORT: std::sync::OnceLock<String> = std::sync::OnceLock::new();
        let whole = EXPORT.get_or_init(|| {
            let (csv, _) = record();
            let short: String = csv.lines().take(60).flat_map(|l| [l, "\n"]).collect();
            twincat_export(&short)
        });
        let mut text = whole.clone();
        let at = text.floor_char_boundary(at.min(text.len()));
        text.insert_str(at, &splice);
        let cut = text.floor_char_boundary(cut.min(text.len()));
        let _ = read(&text.as_bytes()[..text.len() - cut], None);
    }
}

/// Every column a file holds is shown, the ones no signal was mapped to with their ranges as
/// the file gives them, in a text table and in a capture file alike.
#[test]
fn columns_no_signal_was_mapped_to_are_listed_with_their_ranges() {
    let n = 400;
    let load: Vec<f64> = (0..n).map(|i| 10.0 + (i % 9) as f64 * 0.5).collect();
    let mut csv = String::from("time_s,x_mm,y_mm,spindle_load_pct,mode\n");
    for (i, l) in load.iter().enumerate() {
        let t = i as f64 * 1e-3;
        csv += &format!("{t},{},{},{l},m{}\n", t * 10.0, t * 5.0, i % 3);
    }
    let trace = parse_trace(&csv, "extra.csv").unwrap();
    let unused = &trace.layout.unused;
    assert_eq!(unused.len(), 2, "{unused:?}");
    assert_eq!(unused[0].name, "spindle_load_pct");
    // 10 + 8·0.5: the largest load written.
    assert_eq!(unused[0].range, Some([10.0, 14.0]));
    assert_eq!(unused[1].name, "mode");
    assert_eq!(unused[1].range, None, "text is not a range");
    let shown = trace.layout.describe().join("\n");
    assert!(shown.contains("not used (2"), "{shown}");
    assert!(shown.contains("spindle_load_pct (10 … 14)"), "{shown}");

    let t: Vec<f64> = (0..n).map(|i| i as f64 * 1e-3).collect();
    let current: Vec<f64> = (0..n).map(|i| -2.0 + i as f64 * 0.01).collect();
    let bytes = mat_file(&[
        ("t", n, 1, t.clone()),
        ("x", n, 1, t.iter().map(|v| v * 10.0).collect()),
        ("y", n, 1, t.iter().map(|v| v * 5.0).collect()),
        ("motor_current_A", n, 1, current),
    ]);
    let trace = read(&bytes, None).unwrap();
    let unused = &trace.layout.unused;
    assert_eq!(unused.len(), 1, "{unused:?}");
    assert_eq!(unused[0].name, "motor_current_A");
    // −2 + 399·0.01 = 1.99.
    let [lo, hi] = unused[0].range.unwrap();
    assert!(
        (lo + 2.0).abs() < 1e-12 && (hi - 1.99).abs() < 1e-12,
        "{lo} {hi}"
    );
}
