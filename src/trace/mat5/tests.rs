//! MAT-files as real capture software writes them, built byte by byte from the level-5
//! format in this file (not by the reader's code, nor by a reader crate's own writer): the
//! layout dSPACE ControlDesk saves — a structure with the time in `X` and a 1×n structure
//! array of signals in `Y`, named by block paths such as
//! `"Model Root"/"Encoder Feedback X"/"x [mm]"` — with that writer's habits: text as
//! `miUINT16`, empty text as zero-length data, integer classes for flags, a double scalar
//! stored as `miUINT8`, four-byte data in small elements; in either byte order, and
//! compressed. And no damaged file makes the decoder panic.

use crate::trace::mat5::{self, Value};
use crate::trace::measured::parse_mat_trace;
use proptest::prelude::*;

const MI_INT8: u32 = 1;
const MI_UINT8: u32 = 2;
const MI_UINT16: u32 = 4;
const MI_INT32: u32 = 5;
const MI_UINT32: u32 = 6;
const MI_DOUBLE: u32 = 9;
const MI_MATRIX: u32 = 14;
const MI_COMPRESSED: u32 = 15;
const MX_STRUCT: u32 = 2;
const MX_CHAR: u32 = 4;
const MX_DOUBLE: u32 = 6;
const MX_INT32: u32 = 12;

/// A writer of level-5 elements in one byte order.
#[derive(Clone, Copy)]
struct Writer {
    big_endian: bool,
}

impl Writer {
    fn u32(self, v: u32) -> [u8; 4] {
        self.ordered(v.to_le_bytes(), v.to_be_bytes())
    }

    /// A data element: a small one (type and size in one word, data in the next) where the
    /// data fit in four bytes and `small` allows, else a full tag and data padded to 8.
    fn element(self, kind: u32, data: &[u8], small: bool) -> Vec<u8> {
        let mut out = Vec::new();
        if small && data.len() <= 4 && !data.is_empty() {
            out.extend(self.u32(((data.len() as u32) << 16) | kind));
            let mut four = data.to_vec();
            four.resize(4, 0);
            out.extend(four);
            return out;
        }
        out.extend(self.u32(kind));
        out.extend(self.u32(data.len() as u32));
        out.extend(data);
        out.resize(out.len().next_multiple_of(8), 0);
        out
    }

    /// A number's bytes in this writer's order.
    fn ordered<const N: usize>(self, little: [u8; N], big: [u8; N]) -> [u8; N] {
        if self.big_endian { big } else { little }
    }

    fn doubles(self, v: &[f64]) -> Vec<u8> {
        v.iter()
            .flat_map(|x| self.ordered(x.to_le_bytes(), x.to_be_bytes()))
            .collect()
    }

    fn int32s(self, v: &[i32]) -> Vec<u8> {
        v.iter()
            .flat_map(|x| self.ordered(x.to_le_bytes(), x.to_be_bytes()))
            .collect()
    }

    /// An array: flags, dimensions, name, then `parts` (already elements).
    fn array(self, class: u32, dims: &[i32], name: &str, parts: &[Vec<u8>]) -> Vec<u8> {
        let mut body = self.element(MI_UINT32, &[self.u32(class), [0; 4]].concat(), false);
        body.extend(self.element(MI_INT32, &self.int32s(dims), false));
        body.extend(self.element(MI_INT8, name.as_bytes(), true));
        for p in parts {
            body.extend(p);
        }
        self.element(MI_MATRIX, &body, false)
    }

    fn vector(self, values: &[f64]) -> Vec<u8> {
        let data = self.element(MI_DOUBLE, &self.doubles(values), false);
        self.array(MX_DOUBLE, &[1, values.len() as i32], "", &[data])
    }

    /// A double scalar stored as one unsigned byte, as ControlDesk saves small counts.
    fn byte_double(self, v: u8) -> Vec<u8> {
        self.array(
            MX_DOUBLE,
            &[1, 1],
            "",
            &[self.element(MI_UINT8, &[v], true)],
        )
    }

    fn int32(self, v: i32) -> Vec<u8> {
        let data = self.element(MI_INT32, &self.int32s(&[v]), true);
        self.array(MX_INT32, &[1, 1], "", &[data])
    }

    /// Text as UTF-16 code units in `miUINT16`; empty text as a 0×0 array with no data.
    fn text(self, s: &str) -> Vec<u8> {
        let units: Vec<u8> = s
            .encode_utf16()
            .flat_map(|u| self.ordered(u.to_le_bytes(), u.to_be_bytes()))
            .collect();
        let dims = if s.is_empty() {
            [0, 0]
        } else {
            [1, s.encode_utf16().count() as i32]
        };
        self.array(
            MX_CHAR,
            &dims,
            "",
            &[self.element(MI_UINT16, &units, false)],
        )
    }

    /// A structure array of `elements`, each a value per field.
    fn structure(self, name: &str, fields: &[&str], elements: &[Vec<Vec<u8>>]) -> Vec<u8> {
        const NAME_LENGTH: usize = 32;
        let mut names = Vec::new();
        for f in fields {
            let mut n = f.as_bytes().to_vec();
            n.resize(NAME_LENGTH, 0);
            names.extend(n);
        }
        let mut parts = vec![
            self.element(MI_INT32, &self.int32s(&[NAME_LENGTH as i32]), true),
            self.element(MI_INT8, &names, false),
        ];
        for e in elements {
            parts.extend(e.iter().cloned());
        }
        self.array(MX_STRUCT, &[1, elements.len() as i32], name, &parts)
    }

    fn header(self) -> Vec<u8> {
        let mut h =
            b"MATLAB 5.0 MAT-file, Platform: PCWIN, Created on: Wed Dec 01 14:01:48 2021".to_vec();
        h.resize(116, b' ');
        h.extend([0u8; 8]);
        if self.big_endian {
            h.extend([0x01, 0x00]);
            h.extend(b"MI");
        } else {
            h.extend([0x00, 0x01]);
            h.extend(b"IM");
        }
        h
    }
}

/// A ControlDesk-style capture of `n` samples at 10 kHz: X and Y encoder feedback in mm and
/// the two feed references (no unit), as the lab's capture holds them.
fn capture(w: Writer, n: usize, compressed: bool) -> (Vec<u8>, [Vec<f64>; 5]) {
    // The capture's clock, as ControlDesk writes it: single-precision steps of 0.1 ms.
    let t: Vec<f64> = (0..n).map(|k| f64::from(k as f32 * 1e-4_f32)).collect();
    let xr: Vec<f64> = (0..n).map(|k| 0.01 * k as f64).collect();
    let yr: Vec<f64> = (0..n).map(|k| 5.0 - 0.004 * k as f64).collect();
    let quantised = |v: &[f64], lag: f64| -> Vec<f64> {
        v.iter().map(|p| ((p - lag) * 1e4).round() / 1e4).collect()
    };
    let (x, y) = (quantised(&xr, 0.05), quantised(&yr, -0.02));
    let signal = |path: &str, data: &[f64]| {
        vec![
            w.text(path),
            w.int32(5),
            w.vector(data),
            w.text(""),
            w.int32(1),
        ]
    };
    let top = w.structure(
        "lab3",
        &["X", "Y", "Description", "RTProgram", "Capture"],
        &[vec![
            w.structure(
                "",
                &["Name", "Type", "Data", "Unit"],
                &[vec![w.text(""), w.int32(4), w.vector(&t), w.text("")]],
            ),
            w.structure(
                "",
                &["Name", "Type", "Data", "Unit", "XIndex"],
                &[
                    signal(r#""Model Root"/"Encoder Feedback X"/"x [mm]""#, &x),
                    signal(r#""Model Root"/"Encoder Feedback Y"/"y [mm]""#, &y),
                    signal(r#""Model Root"/"Feed Reference DataX"/"RefCommand""#, &xr),
                    signal(r#""Model Root"/"Feed Reference DataY"/"RefCommand""#, &yr),
                ],
            ),
            w.structure(
                "",
                &["Description", "Author", "GeneratorVersion"],
                &[vec![
                    w.text(""),
                    w.text(""),
                    w.text("ControlDesk MATLAB File Format Revision 2.0"),
                ]],
            ),
            w.structure(
                "",
                &["BoardName", "DateTime", "ObjectFile"],
                &[vec![
                    w.text("ds1103"),
                    w.text("12/01/2021 13:57:39"),
                    w.text(r"C:\Users\lab\lab3.ppc"),
                ]],
            ),
            w.structure(
                "",
                &[
                    "Length",
                    "Downsampling",
                    "SamplingPeriod",
                    "TriggerState",
                    "TriggerSignal",
                ],
                &[vec![
                    w.byte_double(40),
                    w.int32(1),
                    w.vector(&[1e-4]),
                    w.text("off"),
                    w.text(""),
                ]],
            ),
        ]],
    );
    let mut file = w.header();
    if compressed {
        use std::io::Write;
        let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
        z.write_all(&top).unwrap();
        let packed = z.finish().unwrap();
        file.extend(w.u32(MI_COMPRESSED));
        file.extend(w.u32(packed.len() as u32));
        file.extend(packed);
    } else {
        file.extend(top);
    }
    (file, [t, x, y, xr, yr])
}

#[test]
fn a_controldesk_capture_is_read_as_it_is_in_either_byte_order_and_compressed() {
    for (big_endian, compressed) in [(false, false), (true, false), (false, true)] {
        let (bytes, [t, x, y, xr, yr]) = capture(Writer { big_endian }, 400, compressed);
        let trace = parse_mat_trace(&bytes, "lab3.mat", None)
            .unwrap_or_else(|e| panic!("big-endian {big_endian}, compressed {compressed}: {e}"));
        let said = trace.layout.describe().join("\n");
        for expected in [
            "t     ← column",
            "'time [s]' in s",
            "'x [mm]' in mm",
            "'y [mm]' in mm",
            "'Feed Reference DataX/RefCommand' in mm",
            "'Feed Reference DataY/RefCommand' in mm",
        ] {
            assert!(said.contains(expected), "{expected} in:\n{said}");
        }
        assert_eq!(trace.len(), t.len());
        assert!((trace.dt_s - 1e-4).abs() < 1e-9, "{}", trace.dt_s);
        let commands = trace.commands.as_ref().expect("the feed references");
        for k in [0, 17, 399] {
            assert!((trace.x_m[k] - x[k] * 1e-3).abs() < 1e-15);
            assert!((trace.y_m[k] - y[k] * 1e-3).abs() < 1e-15);
            assert!((commands[0][k] - xr[k] * 1e-3).abs() < 1e-15);
            assert!((commands[1][k] - yr[k] * 1e-3).abs() < 1e-15);
        }
    }
}

#[test]
fn the_writers_habits_decode_to_their_values() {
    let w = Writer { big_endian: false };
    let (bytes, _) = capture(w, 20, false);
    let vars = mat5::read(&bytes).unwrap();
    assert_eq!(vars.len(), 1);
    assert_eq!(vars[0].name, "lab3");
    let top = &vars[0].value;
    let capture = top.field("Capture").unwrap();
    // A double stored as a byte, an int32 scalar in a small element, empty text.
    assert!(
        matches!(capture.field("Length"), Some(Value::Numeric { real, .. }) if real == &[40.0])
    );
    assert!(
        matches!(capture.field("Downsampling"), Some(Value::Numeric { real, .. }) if real == &[1.0])
    );
    assert_eq!(
        capture.field("TriggerSignal").and_then(Value::text),
        Some("")
    );
    assert_eq!(
        top.field("Description")
            .and_then(|d| d.field("GeneratorVersion"))
            .and_then(Value::text),
        Some("ControlDesk MATLAB File Format Revision 2.0")
    );
    let Some(Value::Struct { dims, elements, .. }) = top.field("Y") else {
        panic!("Y is the signal array")
    };
    assert_eq!((dims.as_slice(), elements.len()), ([1, 4].as_slice(), 4));
}

#[test]
fn damage_is_named_with_its_byte_offset() {
    let (bytes, _) = capture(Writer { big_endian: false }, 20, false);
    let cut = &bytes[..bytes.len() - 100];
    let e = mat5::read(cut).unwrap_err().to_string();
    assert!(e.starts_with("damaged at byte 128"), "{e}");
    assert!(e.contains("only"), "{e}");
    let e = parse_mat_trace(cut, "cut.mat", None)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("cut.mat") && e.contains("damaged at byte"),
        "{e}"
    );
    let mut wrong_order = bytes.clone();
    wrong_order[126..128].copy_from_slice(b"XX");
    assert!(
        mat5::read(&wrong_order)
            .unwrap_err()
            .to_string()
            .contains("byte-order")
    );
}

/// Dimensions a file claims but does not pay for in bytes cost it nothing: a structure of
/// 2³¹×2³¹ elements without fields, a cell of as many cells.
#[test]
fn claimed_dimensions_cost_only_the_bytes_there() {
    let w = Writer { big_endian: false };
    let huge = [i32::MAX, i32::MAX];
    let no_fields = {
        let parts = vec![
            w.element(MI_INT32, &w.int32s(&[32]), true),
            w.element(MI_INT8, &[], false),
        ];
        w.array(MX_STRUCT, &huge, "s", &parts)
    };
    let mut file = w.header();
    file.extend(no_fields);
    let vars = mat5::read(&file).unwrap();
    assert!(matches!(&vars[0].value, Value::Struct { elements, .. } if elements.is_empty()));
    let mut file = w.header();
    file.extend(w.array(1, &huge, "c", &[]));
    assert!(
        mat5::read(&file)
            .unwrap_err()
            .to_string()
            .contains("damaged")
    );
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 400, ..ProptestConfig::default() })]

    /// Bytes overwritten, or the file cut anywhere: an error or a value, never a panic.
    #[test]
    fn no_damaged_file_makes_the_decoder_panic(
        edits in proptest::collection::vec((128usize..3000, any::<u8>()), 0..6),
        cut in 128usize..3200,
        compressed in any::<bool>(),
    ) {
        let (mut bytes, _) = capture(Writer { big_endian: false }, 20, compressed);
        for (at, b) in edits {
            if at < bytes.len() {
                bytes[at] = b;
            }
        }
        bytes.truncate(cut.max(128));
        let _ = mat5::read(&bytes);
        let _ = parse_mat_trace(&bytes, "fuzz.mat", None);
    }
}
