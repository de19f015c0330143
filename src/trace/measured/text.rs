//! A text table's data rows: lines that hold nothing, a units row under the header, the
//! trailer after the data, the mapped columns read (numbers as the file writes them, a
//! clock time in the time column).

use super::{MeasuredError, Table, UnusedColumn, slot};
use crate::trace::format::{self, Dialect, Mapped};
use crate::trace::numerals;

/// The most lines after the data that are skipped as a trailer (`EOF;;;`, a checksum, a
/// summary block): more lines of text than this are not a trailer, and are read as data —
/// so the first is refused at its row.
const MOST_TRAILER_ROWS: usize = 100;

/// Whether a line holds something: not blank, and not separators only (`;;;;`, as a
/// spreadsheet writes an empty row), which hold nothing whatever the delimiter.
pub(super) fn holds_something(line: &str) -> bool {
    line.bytes()
        .any(|b| !b.is_ascii_whitespace() && !b",;\"".contains(&b))
}

/// The data without a units row right under the header (`s;mm;mm`, `[s],[um],…`, as data
/// acquisition software writes one): a row none of whose mapped fields is written like a
/// number and one of which is a unit of its signal. Its units become the mapped columns'
/// where the header named none; a unit the header names otherwise, or a field that is no
/// unit, is refused at the row. A mapping's unit stands (the user said so).
pub(super) fn without_units_row<'d, 'a>(
    file: &str,
    data: &'d [(u64, &'a str)],
    mapped: &mut [Mapped],
    dialect: &Dialect,
) -> Result<&'d [(u64, &'a str)], MeasuredError> {
    let Some(&(row, line)) = data.first() else {
        return Ok(data);
    };
    let fields = format::fields(line, dialect.delimiter);
    let unit_of = |m: &Mapped| unit_text(fields.get(m.index).copied().unwrap_or(""));
    let is_units_row = mapped.iter().all(|m| !looks_numeric(unit_of(m)))
        && mapped
            .iter()
            .any(|m| format::parse_unit(unit_of(m), m.signal).is_ok());
    if !is_units_row {
        return Ok(data);
    }
    let refuse = |m: &Mapped, problem: String| MeasuredError::Row {
        file: file.into(),
        row,
        problem: format!(
            "this looks like a units row: column {} '{}' ({}): {problem}",
            m.index + 1,
            m.header,
            m.signal.key()
        ),
    };
    for m in mapped.iter_mut() {
        let text = unit_of(m);
        if text.is_empty() || m.unit_from == "mapping" {
            continue;
        }
        let unit = format::parse_unit(text, m.signal).map_err(|e| refuse(m, e))?;
        if m.unit_from == "default" {
            m.unit = unit;
            m.unit_from = "units row";
        } else if (unit.to_si / m.unit.to_si - 1.0).abs() > 1e-9 {
            let problem = format!(
                "'{text}' here, {} by the header; name the unit once, or map the column \
                 with --columns",
                m.unit.label
            );
            return Err(refuse(m, problem));
        }
    }
    Ok(&data[1..])
}

/// A unit as a units row writes it, without quotes or brackets: `[mm]`, `(s)`, `"um"`.
fn unit_text(field: &str) -> &str {
    let f = field.trim().trim_matches('"').trim();
    let inner = f
        .strip_prefix('[')
        .and_then(|f| f.strip_suffix(']'))
        .or_else(|| f.strip_prefix('(').and_then(|f| f.strip_suffix(')')));
    inner.unwrap_or(f).trim()
}

/// Whether a field is written like a number or a clock time in any convention (digits with
/// signs, marks, an exponent, colons): such a field is data, never a trailer, and where it
/// cannot be read it is refused at its row.
fn looks_numeric(field: &str) -> bool {
    let f = field.trim().trim_matches('"');
    f.bytes().any(|b| b.is_ascii_digit())
        && f.bytes()
            .all(|b| b.is_ascii_digit() || b"+-.,eE: '".contains(&b))
}

/// The data without its trailer, and how many rows that was: the rows at the end whose time
/// field is text (`EOF`, `Summe`, empty), at most [`MOST_TRAILER_ROWS`] of them. A row whose
/// time looks like a number ends the trailer, however it is written.
pub(super) fn without_trailer<'d, 'a>(
    data: &'d [(u64, &'a str)],
    time_col: usize,
    dialect: &Dialect,
) -> (&'d [(u64, &'a str)], usize) {
    let is_text = |line: &str| {
        let f = format::fields(line, dialect.delimiter);
        !looks_numeric(f.get(time_col).copied().unwrap_or(""))
    };
    let trailer = data.iter().rev().take_while(|(_, l)| is_text(l)).count();
    if trailer > MOST_TRAILER_ROWS || trailer == data.len() {
        return (data, 0);
    }
    (&data[..data.len() - trailer], trailer)
}

/// The mapped columns of a text table's data rows, in SI units; a field that is not a number
/// is an error at its row, saying why. A time column of clock times (`00:00:01.234`) is read
/// in seconds, and its mapping says so.
pub(super) fn read_rows(
    file: &str,
    data: &[(u64, &str)],
    mapped: &mut [Mapped],
    dialect: &Dialect,
) -> Result<Table, MeasuredError> {
    let clock = clock_column(data, &mut mapped[0], dialect);
    let mut table = Table {
        rows: Vec::with_capacity(data.len()),
        ..Table::default()
    };
    let decimal = if dialect.decimal_comma { ',' } else { '.' };
    // The finest digit each column prints, by its index.
    let width = mapped.iter().map(|m| m.index + 1).max().unwrap_or(0);
    let mut steps = vec![f64::INFINITY; width];
    for &(row, line) in data {
        let f = format::fields(line, dialect.delimiter);
        for m in mapped.iter() {
            let text = f.get(m.index).map_or("", |v| v.trim_matches('"'));
            let column = || format!("column {} '{}' ({})", m.index + 1, m.header, m.signal.key());
            let at_row = |problem: String| MeasuredError::Row {
                file: file.into(),
                row,
                problem: format!("{}: {problem}", column()),
            };
            let value = if clock && m.signal.is_time() {
                numerals::clock_seconds(text)
                    .map_err(&at_row)?
                    .ok_or_else(|| {
                        at_row(format!(
                            "'{text}' is not a clock time h:mm:ss.fff like the first row's"
                        ))
                    })?
            } else {
                let v = format::number(text, dialect)
                    .ok_or_else(|| at_row(format::why_not_a_number(text, dialect)))?;
                if !m.unit.takes(v) {
                    return Err(at_row(format::not_a_count(text)));
                }
                v * m.unit.to_si
            };
            steps[m.index] = steps[m.index].min(printed_step(text, decimal));
            match slot(m.signal) {
                None => table.t.push(value),
                Some(k) => table.cols[k].push(value),
            }
        }
        table.rows.push(row);
    }
    if clock {
        past_midnight(&mut table.t);
    }
    for m in mapped.iter_mut() {
        m.print_step = Some(steps[m.index]).filter(|s| s.is_finite() && *s > 0.0);
    }
    Ok(table)
}

/// The step of the last digit `field` prints, in its own unit: `0.0004991` → 1e-7,
/// `12` → 1, `1.5e-3` → 1e-4; `decimal` is the dialect's decimal separator.
fn printed_step(field: &str, decimal: char) -> f64 {
    let (mantissa, exponent) = match field.find(['e', 'E']) {
        Some(i) => (&field[..i], field[i + 1..].parse::<i32>().unwrap_or(0)),
        None => (field, 0),
    };
    let decimals = mantissa
        .split_once(decimal)
        .map_or(0, |(_, d)| d.chars().filter(char::is_ascii_digit).count())
        as i32;
    // A field's own exponent can be any i32 ("1.5e-2147483648"): saturate rather than overflow.
    10f64.powi(exponent.saturating_sub(decimals))
}

/// Whether the time column holds clock times (its first row's time has a `:`); if so its
/// unit becomes seconds, from the clock.
fn clock_column(data: &[(u64, &str)], time: &mut Mapped, dialect: &Dialect) -> bool {
    let first = data.first().map_or("", |(_, line)| {
        format::fields(line, dialect.delimiter)
            .get(time.index)
            .copied()
            .unwrap_or("")
    });
    let clock = first.contains(':');
    if clock {
        time.unit = format::time_units()
            .find(|u| u.label == "s")
            .unwrap_or(time.unit);
        time.unit_from = "clock times h:mm:ss";
    }
    clock
}

/// Clock times that pass midnight go on counting: a time half a day or more before the one
/// above is on the next day.
fn past_midnight(t: &mut [f64]) {
    const DAY_S: f64 = 86_400.0;
    let mut days = 0.0;
    for i in 1..t.len() {
        let before = t[i - 1];
        t[i] += days;
        if t[i] < before - DAY_S / 2.0 {
            days += DAY_S;
            t[i] += DAY_S;
        }
    }
}

/// The text of a file written in UTF-16 (a spreadsheet's "Unicode text"): with a byte-order
/// mark, or without one where the first bytes are plain text with a zero byte beside every
/// character (`T\0i\0m\0e\0`), and whose first characters are text. `None` for any other
/// file.
pub(super) fn utf16_text(bytes: &[u8]) -> Option<String> {
    let head = &bytes[..bytes.len().min(512) & !1];
    let plain_beside_zeros = |zero: usize| {
        head.len() >= 8
            && head.chunks(2).all(|pair| {
                pair[zero] == 0
                    && (pair[1 - zero].is_ascii_graphic() || pair[1 - zero].is_ascii_whitespace())
            })
    };
    let little = match bytes {
        [0xff, 0xfe, ..] => true,
        [0xfe, 0xff, ..] => false,
        _ if plain_beside_zeros(1) => true,
        _ if plain_beside_zeros(0) => false,
        _ => return None,
    };
    let units = bytes.chunks_exact(2).map(|pair| {
        if little {
            u16::from_le_bytes([pair[0], pair[1]])
        } else {
            u16::from_be_bytes([pair[0], pair[1]])
        }
    });
    let text: String = char::decode_utf16(units)
        .map(|c| c.unwrap_or(char::REPLACEMENT_CHARACTER))
        .collect();
    // A binary file that happens to start with a byte-order mark decodes to control codes.
    let text = text.trim_start_matches('\u{feff}');
    let readable = text
        .chars()
        .take(256)
        .all(|c| !c.is_control() || matches!(c, '\t' | '\r' | '\n'));
    readable.then(|| text.to_string())
}

/// A text table's columns that no signal was mapped to, each with its range.
pub(super) fn unused_text_columns(
    headers: &[&str],
    mapped: &[Mapped],
    data: &[(u64, &str)],
    dialect: &Dialect,
) -> Vec<UnusedColumn> {
    let rows: Vec<Vec<&str>> = data
        .iter()
        .map(|(_, line)| format::fields(line, dialect.delimiter))
        .collect();
    (0..headers.len())
        .filter(|i| !mapped.iter().any(|m| m.index == *i))
        .map(|i| {
            let values = rows.iter().map(|f| {
                f.get(i)
                    .and_then(|v| format::number(v.trim_matches('"'), dialect))
            });
            UnusedColumn::of(headers[i], values)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::printed_step;

    #[test]
    fn the_last_printed_digit_is_read_with_its_exponent_and_decimal_sign() {
        for (field, decimal, step) in [
            ("0.0004991", '.', 1e-7),
            ("12", '.', 1.0),
            ("1.5e-3", '.', 1e-4),
            ("-3,25", ',', 1e-2),
            ("2.50E2", '.', 1.0),
        ] {
            let got = printed_step(field, decimal);
            assert!((got / step - 1.0).abs() < 1e-12, "{field}: {got}");
        }
    }

    #[test]
    fn an_exponent_at_the_end_of_its_range_neither_overflows_nor_claims_a_step() {
        // i32::MIN minus one decimal would overflow; the step is then below any f64 (0).
        assert_eq!(printed_step("1.5e-2147483648", '.'), 0.0);
        assert!(printed_step("1.5e2147483647", '.').is_infinite());
    }
}
