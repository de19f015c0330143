//! SINUMERIK Operate trace files: the XML that Operate saves from its trace (Diagnostics ›
//! Trace, and the servo trace of Commissioning), read as named columns on one clock.
//!
//! The layout is the one public readers of these files rely on (the Trace-Tools reader for
//! SINUMERIK Operate, eliasrhoden/Trace-Tools on GitHub): a `traceData` element holds a
//! `dataFrame`; the frame lists its signals as `dataSignal` elements (`name`, the control's
//! path of the variable; `description`, its plain name; `key`), then one `rec` element per
//! sampling instant, `time` in seconds and one attribute `f1`, `f2` … per signal, numbered in
//! the order the signals are listed. Newer versions keep the plain names in
//! `traceDisplaySetup/signals` under the same keys.
//!
//! The control samples its signals at their own rates (the drive's 125 µs, the position
//! controller's 2 ms, the interpolator's 4 ms …), so a `rec` holds only the signals sampled
//! at its instant, and a value of 2⁶³ or more marks one that has no value there. Each signal
//! is read on its own instants; the columns share the clock of the most densely sampled
//! signal, the others interpolated linearly onto it (never held: holding a 4 ms command at a
//! 2 ms clock would shift it by up to a cycle), over the span every signal covers.
//!
//! Positions are in the control's unit system, mm on a metric machine; the files carry no
//! unit, so state it in the mapping on an inch machine (`x=…[in]`).

use std::collections::HashMap;

use crate::trace::clock::{Sampled, on_one_clock};
use crate::trace::columns::NamedColumns;
use crate::trace::measured::{MeasuredError, Source};

/// The name given to the shared clock.
pub const TIME_COLUMN: &str = "time [s]";

/// A value this large marks a signal without a sample at that instant (the control writes
/// its 64-bit "no value").
const NO_VALUE: f64 = 9.2e18;

/// Whether `text` is a SINUMERIK Operate trace (XML holding a `traceData` frame).
pub(crate) fn is_sinumerik_trace(text: &str) -> bool {
    let head = text.trim_start_matches('\u{feff}').trim_start();
    head.starts_with('<') && text.contains("<traceData") && text.contains("<dataFrame")
}

/// The file's text: Operate declares ISO-8859-1 (a µ in a description is one byte), which
/// is read as such; anything else as UTF-8.
pub(crate) fn decode(bytes: &[u8]) -> String {
    let head = String::from_utf8_lossy(&bytes[..bytes.len().min(200)]).to_ascii_lowercase();
    if head.contains("iso-8859-1") || head.contains("latin1") || head.contains("latin-1") {
        bytes.iter().map(|&b| char::from(b)).collect()
    } else {
        String::from_utf8_lossy(bytes).into_owned()
    }
}

/// Reads a SINUMERIK Operate trace; `file` names it in errors. Its signals as columns of
/// equal length: the clock first, then one per signal that has samples; each row's line in
/// the file (of the `rec` it was taken at).
pub(crate) fn sinumerik_columns(text: &str, file: &str) -> Result<NamedColumns, MeasuredError> {
    let data_error = |problem: String| MeasuredError::Data {
        file: file.into(),
        problem,
    };
    let doc = roxmltree::Document::parse(text).map_err(|e| {
        let at = e.pos();
        data_error(format!(
            "not well-formed XML at line {}, column {}: {e}",
            at.row, at.col
        ))
    })?;
    let frame = doc
        .descendants()
        .find(|n| n.has_tag_name("traceData"))
        .and_then(|d| d.children().find(|n| n.has_tag_name("dataFrame")))
        .ok_or_else(|| {
            data_error("an XML file without a trace's traceData/dataFrame element".into())
        })?;
    let mut signals = signals_of(&doc, frame);
    if signals.is_empty() {
        return Err(data_error(
            "the trace's dataFrame lists no dataSignal: nothing was recorded".into(),
        ));
    }
    read_records(&doc, frame, &mut signals, file)?;
    let sampled: Vec<Sampled> = signals.into_iter().filter(|s| !s.t.is_empty()).collect();
    if sampled.is_empty() {
        return Err(data_error(
            "the trace holds no samples (no rec with a value)".into(),
        ));
    }
    let (columns, rows) = on_one_clock(&sampled, TIME_COLUMN, 1.0);
    if rows.len() < 2 {
        return Err(data_error(
            "the signals' samples do not overlap in time: no instant has them all".into(),
        ));
    }
    Ok(NamedColumns {
        source: Source::Sinumerik {
            signals: columns.len() - 1,
        },
        columns,
        rows,
    })
}

/// The frame's signals in their listed order, each named by its plain description (from
/// the signal or the display setup, its "(64 bit)" note dropped) and its path where that
/// adds something.
fn signals_of(doc: &roxmltree::Document, frame: roxmltree::Node) -> Vec<Sampled> {
    let display: HashMap<&str, &str> = doc
        .descendants()
        .filter(|n| n.has_tag_name("traceDisplaySetup"))
        .flat_map(|d| d.descendants())
        .filter_map(|n| Some((n.attribute("key")?, n.attribute("description")?)))
        .collect();
    let mut used_names: HashMap<String, usize> = HashMap::new();
    frame
        .children()
        .filter(|n| n.has_tag_name("dataSignal"))
        .enumerate()
        .map(|(i, n)| {
            let path = n.attribute("name").unwrap_or("").trim();
            let described = n
                .attribute("description")
                .or_else(|| n.attribute("key").and_then(|k| display.get(k).copied()))
                .unwrap_or("")
                .replace("(64 bit)", "");
            let described = described.trim();
            let mut name = match (described.is_empty(), path.is_empty()) {
                (true, true) => format!("f{}", i + 1),
                (true, false) => path.to_string(),
                (false, true) => described.to_string(),
                (false, false) if described.contains(path) => described.to_string(),
                (false, false) => format!("{described} · {path}"),
            };
            let seen = used_names.entry(name.clone()).or_insert(0);
            *seen += 1;
            if *seen > 1 {
                name = format!("{name} #{seen}");
            }
            Sampled {
                name,
                t: Vec::new(),
                v: Vec::new(),
                line: Vec::new(),
            }
        })
        .collect()
}

/// Reads every `rec` into its signals' samples; a value that is not a number is an error
/// naming the line, a no-value marker is no sample.
fn read_records(
    doc: &roxmltree::Document,
    frame: roxmltree::Node,
    signals: &mut [Sampled],
    file: &str,
) -> Result<(), MeasuredError> {
    let row_error = |row: u64, problem: String| MeasuredError::Row {
        file: file.into(),
        row,
        problem,
    };
    let listed = signals.len();
    let mut last_t = f64::NEG_INFINITY;
    for rec in frame.children().filter(|n| n.has_tag_name("rec")) {
        let line = u64::from(doc.text_pos_at(rec.range().start).row);
        let time = rec
            .attribute("time")
            .ok_or_else(|| row_error(line, "a rec without its time".into()))?;
        let t: f64 = time
            .trim()
            .parse()
            .ok()
            .filter(|t: &f64| t.is_finite())
            .ok_or_else(|| row_error(line, format!("time '{time}' is not a number")))?;
        if t <= last_t {
            return Err(row_error(
                line,
                format!("time {t} s does not follow the previous record's {last_t} s"),
            ));
        }
        last_t = t;
        for attr in rec.attributes() {
            let Some(index) = signal_index(attr.name()) else {
                continue;
            };
            let signal = signals.get_mut(index).ok_or_else(|| {
                row_error(
                    line,
                    format!(
                        "value {} for a signal the frame does not list (it lists {})",
                        attr.name(),
                        listed
                    ),
                )
            })?;
            let v: f64 = attr.value().trim().parse().map_err(|_| {
                row_error(
                    line,
                    format!("{} = '{}' is not a number", attr.name(), attr.value()),
                )
            })?;
            if !v.is_finite() || v.abs() >= NO_VALUE {
                continue;
            }
            signal.t.push(t);
            signal.v.push(v);
            signal.line.push(line);
        }
    }
    Ok(())
}

/// `f3` → 2: the 0-based signal an attribute holds a value of.
fn signal_index(attribute: &str) -> Option<usize> {
    let n: usize = attribute.strip_prefix('f')?.parse().ok()?;
    n.checked_sub(1)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn trace(recs: &str) -> String {
        format!(
            "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<traceSession>\n<traceData>\n<dataFrame>\n\
             <dataSignal key=\"a\" name=\"/Nck/Servo/X1/pos\" description=\"X1 Position actual value (64 bit)\"/>\n\
             <dataSignal key=\"b\" name=\"/Nck/Ipo/X1/set\" description=\"X1 Position setpoint\"/>\n\
             {recs}</dataFrame>\n</traceData>\n</traceSession>\n"
        )
    }

    #[test]
    fn signals_at_two_rates_share_the_denser_clock() {
        let recs = "<rec time=\"0.000\" f1=\"1.0\" f2=\"10.0\"/>\n\
                    <rec time=\"0.002\" f1=\"2.0\"/>\n\
                    <rec time=\"0.004\" f1=\"3.0\" f2=\"14.0\"/>\n\
                    <rec time=\"0.006\" f1=\"4.0\"/>\n";
        let c = sinumerik_columns(&trace(recs), "t.xml").unwrap();
        assert_eq!(c.columns[0].1, vec![0.0, 0.002, 0.004]);
        assert_eq!(
            c.columns[1].0,
            "X1 Position actual value · /Nck/Servo/X1/pos"
        );
        assert_eq!(c.columns[1].1, vec![1.0, 2.0, 3.0]);
        assert_eq!(c.columns[2].1, vec![10.0, 12.0, 14.0]);
        assert_eq!(c.rows, vec![7, 8, 9]);
    }

    #[test]
    fn a_no_value_marker_is_no_sample() {
        let recs = "<rec time=\"0\" f1=\"1\" f2=\"9223372036854775807\"/>\n\
                    <rec time=\"1\" f1=\"2\" f2=\"5\"/>\n\
                    <rec time=\"2\" f1=\"3\" f2=\"7\"/>\n";
        let c = sinumerik_columns(&trace(recs), "t.xml").unwrap();
        assert_eq!(c.columns[0].1, vec![1.0, 2.0]);
        assert_eq!(c.columns[2].1, vec![5.0, 7.0]);
    }

    #[test]
    fn bad_values_name_their_line() {
        let recs = "<rec time=\"0\" f1=\"1\" f2=\"2\"/>\n<rec time=\"1\" f1=\"x\" f2=\"2\"/>\n";
        let e = sinumerik_columns(&trace(recs), "t.xml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("row 8") || e.contains("line 8"), "{e}");
        let recs = "<rec time=\"0\" f1=\"1\" f3=\"2\"/>\n";
        let e = sinumerik_columns(&trace(recs), "t.xml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("f3"), "{e}");
        let e = sinumerik_columns("<a><traceData><dataFrame>", "t.xml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("not well-formed XML at line 1"), "{e}");
    }

    #[test]
    fn latin1_is_read_as_declared() {
        let bytes = b"<?xml version=\"1.0\" encoding=\"ISO-8859-1\"?><a d=\"\xb5m\"/>";
        assert!(decode(bytes).contains("\u{b5}m"));
    }
}
