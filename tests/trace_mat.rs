//! Traces in MATLAB MAT-files (level 5): the tests write the files themselves, as MATLAB's
//! `save` lays them out, from a synthetic record, and read them back.

use contourcheck::machine::MachineConfig;
use contourcheck::measured::{MeasuredTrace, parse_trace, read_trace_with};
use contourcheck::synth::{SynthSpec, synthesize};
use contourcheck::trace_format::ColumnMap;

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

/// A synthetic record of the square with commands, as the CSV the tool writes.
fn record() -> (String, MeasuredTrace) {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/gcode-samples/square.nc"
    ))
    .unwrap();
    let program = contourcheck::gcode::parse_program(
        &text,
        "square.nc",
        &contourcheck::gcode::InterpretOptions::default(),
    )
    .unwrap();
    let spec = SynthSpec {
        with_commands: true,
        ..SynthSpec::default()
    };
    let mut csv = Vec::new();
    synthesize(&program, &MachineConfig::default_preset(), &spec)
        .unwrap()
        .write_csv(&mut csv)
        .unwrap();
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
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("capture.mat");
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
