//! Text tables as spreadsheets and loggers write them: digit grouping with either decimal
//! mark, a trailer after the data, clock times in the time column. Each test writes its
//! file from a small record of known numbers and reads it back; the expected values are the
//! numbers the test wrote.

use contourcheck::trace::measured::{MeasuredTrace, parse_trace};

/// Rows of the record: 2000 samples at 1 ms; time in ms, X and Y in µm, thousands and more
/// (so that both columns reach digit grouping): X = 2500 + 2000·sin(πt/1 s), Y = 1500·t/1 s.
fn record() -> Vec<[f64; 3]> {
    (0..2000)
        .map(|k| {
            let t_s = k as f64 * 1e-3;
            let x = 2500.0 + 2000.0 * (std::f64::consts::PI * t_s).sin();
            [k as f64, (x * 1e4).round() / 1e4, 1500.0 * t_s]
        })
        .collect()
}

/// `v` with four decimals, its integer digits grouped in threes by `group`, `decimal` as
/// the decimal mark: 4999.8 → `4.999,8000` (German) or `4,999.8000` (English).
fn grouped(v: f64, decimal: char, group: char) -> String {
    let text = format!("{:.4}", v.abs());
    let (int, frac) = text.split_once('.').unwrap();
    let mut out = String::new();
    for (i, c) in int.chars().enumerate() {
        if i > 0 && (int.len() - i) % 3 == 0 {
            out.push(group);
        }
        out.push(c);
    }
    format!("{}{out}{decimal}{frac}", if v < 0.0 { "-" } else { "" })
}

/// The record as a `;`-separated table with this number writing.
fn table(write: impl Fn(f64) -> String) -> String {
    let mut text = String::from("Time [ms];X [um];Y [um]\n");
    for [t, x, y] in record() {
        text.push_str(&format!("{};{};{}\n", write(t), write(x), write(y)));
    }
    text
}

/// Every sample read is the number written: time in s, positions in m.
fn assert_is_the_record(m: &MeasuredTrace) {
    let rows = record();
    assert_eq!(m.len(), rows.len());
    assert!(
        (m.t0_s - 0.0).abs() < 1e-12 && (m.dt_s - 1e-3).abs() < 1e-12,
        "{m:?}"
    );
    for (k, [_, x, y]) in rows.iter().enumerate() {
        assert!((m.x_m[k] - x * 1e-6).abs() < 1e-12, "X at row {k}");
        assert!((m.y_m[k] - y * 1e-6).abs() < 1e-12, "Y at row {k}");
    }
}

#[test]
fn digit_grouping_is_read_with_either_decimal_mark() {
    let german = table(|v| grouped(v, ',', '.'));
    assert!(
        german.contains("\n1.000,0000;"),
        "the file groups its digits"
    );
    let m = parse_trace(&german, "de.csv").unwrap();
    assert_is_the_record(&m);
    assert_eq!(m.layout.trailer_rows, 0);
    let english = table(|v| grouped(v, '.', ','));
    assert!(english.contains("\n1,000.0000;"));
    let m = parse_trace(&english, "en.csv").unwrap();
    assert_is_the_record(&m);
    assert_eq!(m.layout.trailer_rows, 0);
}

#[test]
fn grouping_the_file_cannot_tell_is_refused_at_its_row() {
    // Whole numbers only: nothing in the file says whether ',' is a decimal comma or groups
    // thousands, so the first grouped number (row 2: X 2500 µm) is refused, never read.
    let e = parse_trace(
        &table(|v| grouped(v.round(), '.', ',').replace(".0000", "")),
        "w.csv",
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("row 2") && e.contains("'2,500'"), "{e}");
    assert!(e.contains("decimal comma or digit grouping"), "{e}");
    // A German number in a file whose numbers are written with a decimal point.
    let mut text = table(|v| format!("{v:.4}"));
    text = text.replace("\n1500.0000;", "\n1.500,0000;");
    let e = parse_trace(&text, "mixed.csv").unwrap_err().to_string();
    assert!(e.contains("row 1502") && e.contains("'1.500,0000'"), "{e}");
    assert!(e.contains("decimal comma"), "{e}");
}

#[test]
fn a_trailer_is_a_few_lines_of_text_and_says_how_many() {
    let plain = table(|v| format!("{v:.4}"));
    let m = parse_trace(&format!("{plain}EOF;;\nChecksum;0x1F2E;\n;;\n"), "t.csv").unwrap();
    assert_is_the_record(&m);
    // Two lines of text; the line of separators holds nothing.
    assert_eq!(m.layout.trailer_rows, 2);
    assert!(m.layout.describe()[0].contains("2 trailer rows skipped"));
    // Hundreds of text lines at the end are not a trailer: refused at the first.
    let tail: String = (0..150).map(|_| "n/a;n/a;n/a\n").collect();
    let e = parse_trace(&format!("{plain}{tail}"), "t.csv")
        .unwrap_err()
        .to_string();
    assert!(e.contains("row 2002") && e.contains("'n/a'"), "{e}");
}

#[test]
fn clock_times_in_the_time_column_are_seconds_and_go_on_past_midnight() {
    // The record's 2000 ms from 23:59:59.000: the clock passes midnight at row 1002.
    let mut text = String::from("Time;X [um];Y [um]\n");
    for [t_ms, x, y] in record() {
        let s = 86_399.0 + t_ms / 1000.0;
        let (h, m, sec) = (
            (s / 3600.0).floor() % 24.0,
            (s % 3600.0 / 60.0).floor(),
            s % 60.0,
        );
        text.push_str(&format!("{h:02}:{m:02}:{sec:06.3};{x:.4};{y:.4}\n"));
    }
    assert!(
        text.contains("\n00:00:00.000;"),
        "the clock passes midnight"
    );
    let m = parse_trace(&text, "hms.csv").unwrap();
    assert_eq!(m.len(), 2000);
    assert!(
        (m.t0_s - 86_399.0).abs() < 1e-9 && (m.dt_s - 1e-3).abs() < 1e-9,
        "{m:?}"
    );
    assert!((m.x_m[1500] - record()[1500][1] * 1e-6).abs() < 1e-12);
    // A clock without seconds is named, not read as no rows.
    let e = parse_trace(&text.replace("23:59:59.000", "23:59"), "hm.csv").unwrap_err();
    assert!(
        e.to_string().contains("row 2") && e.to_string().contains("h:mm:ss"),
        "{e}"
    );
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(200))]
    /// Any bytes spliced into a grouped table are read or refused, never a panic.
    #[test]
    fn damaged_text_tables_never_panic(
        at in 0usize..400,
        insert in proptest::collection::vec(proptest::prelude::any::<u8>(), 0..12),
        marks in proptest::collection::vec(proptest::sample::select(vec![",", ".", ":", ";", "e", "-", " ", "\"", "\n"]), 0..6),
    ) {
        let mut text = table(|v| grouped(v, ',', '.'))
            .lines()
            .take(30)
            .collect::<Vec<_>>()
            .join("\n");
        let at = (0..=at.min(text.len())).rev().find(|i| text.is_char_boundary(*i)).unwrap_or(0);
        let spliced = format!("{}{}", String::from_utf8_lossy(&insert), marks.concat());
        text.insert_str(at, &spliced);
        let _ = parse_trace(&text, "fuzz.csv");
    }
}

/// The record with a units row under a header that names none: time in `time_unit`, X and Y
/// and their commands (the positions, as a servo trace with no error) in `length_unit`.
fn with_units_row(units: &str, time_scale: f64, length_scale: f64) -> String {
    let mut text = format!("t,x,y,x_cmd,y_cmd\n{units}\n");
    for [t_ms, x, y] in record() {
        let (t, x, y) = (t_ms * 1e-3 * time_scale, x * length_scale, y * length_scale);
        text.push_str(&format!("{t},{x},{y},{x},{y}\n"));
    }
    text
}

#[test]
fn a_units_row_under_the_header_gives_the_columns_units() {
    // Seconds and µm as written; the same record in ms and mm: both read as the record.
    for (units, time_scale, length_scale) in [
        ("s,um,um,um,um", 1.0, 1.0),
        ("[ms],[mm],[mm],[mm],[mm]", 1e3, 1e-3),
        ("\"s\",\"µm\",\"µm\",\"µm\",\"µm\"", 1.0, 1.0),
    ] {
        let m = parse_trace(&with_units_row(units, time_scale, length_scale), "u.csv")
            .unwrap_or_else(|e| panic!("{units}: {e}"));
        assert_is_the_record(&m);
        let commands = m.commands.as_ref().unwrap();
        assert!((commands[0][700] - m.x_m[700]).abs() < 1e-15);
        assert!(m.layout.describe()[2].contains("units row"), "{units}");
    }
    // A unit that is no length, and one the header already names otherwise, are refused at
    // the row, saying it looks like a units row.
    let e = parse_trace(&with_units_row("s,mm/s,um,um,um", 1.0, 1.0), "u.csv").unwrap_err();
    assert!(
        e.to_string().contains("row 2: this looks like a units row"),
        "{e}"
    );
    assert!(e.to_string().contains("'mm/s'"), "{e}");
    let text = with_units_row("s,um,um,um,um", 1.0, 1.0).replacen("t,x,", "t,x [mm],", 1);
    let e = parse_trace(&text, "u.csv").unwrap_err().to_string();
    assert!(
        e.contains("row 2: this looks like a units row") && e.contains("mm by the header"),
        "{e}"
    );
}

#[test]
fn utf16_text_is_read_as_text() {
    // As a spreadsheet saves "Unicode text": UTF-16, tab-separated, with or without a
    // byte-order mark, either byte order.
    let text = table(|v| format!("{v:.4}")).replace(';', "\t");
    let units: Vec<u16> = text.encode_utf16().collect();
    let bytes = |bom: bool, little: bool| {
        let mut out: Vec<u8> = Vec::new();
        for u in bom
            .then_some(0xfeff)
            .into_iter()
            .chain(units.iter().copied())
        {
            out.extend(if little {
                u.to_le_bytes()
            } else {
                u.to_be_bytes()
            });
        }
        out
    };
    let dir = tempfile::tempdir().unwrap();
    for (bom, little) in [(true, true), (true, false), (false, true), (false, false)] {
        let path = dir.path().join("unicode.txt");
        std::fs::write(&path, bytes(bom, little)).unwrap();
        let m = contourcheck::trace::measured::read_trace(&path)
            .unwrap_or_else(|e| panic!("BOM {bom}, little-endian {little}: {e}"));
        assert_is_the_record(&m);
    }
    // A binary file that starts like a byte-order mark is still refused as binary.
    let path = dir.path().join("capture.bin");
    std::fs::write(&path, [0xff, 0xfe, 0, 0, 1, 0, 2, 0, 0x10, 0x27, 0, 0]).unwrap();
    let e = contourcheck::trace::measured::read_trace(&path).unwrap_err();
    assert!(e.to_string().contains("a binary file"), "{e}");
}
