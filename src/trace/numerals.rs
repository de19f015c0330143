//! Numbers as trace files write them: a decimal point or a decimal comma, digits grouped in
//! threes by the other mark (`4.999,8000` in a German spreadsheet, `4,999.8000` in an
//! English one), and a logger's clock time `00:00:01.234` in the time column.
//!
//! Grouping is read only where the file itself shows which mark is the decimal one — a field
//! no grouping could have written (`0,125`, `12,5`, `999.8000`) or one with both marks — and
//! only in threes; a comma that could be either (`1,000` in a file with no other evidence)
//! is refused with the reason rather than guessed.

/// What one field says about the file's decimal mark: `Some(true)` a decimal comma,
/// `Some(false)` a decimal point, `None` nothing (an integer, or `1,000` that either mark
/// could have written). `comma_splits` where the comma separates fields (so never decimal).
pub(crate) fn mark_evidence(field: &str, comma_splits: bool) -> Option<bool> {
    if comma_splits {
        return None;
    }
    let mantissa = mantissa(field.trim().trim_matches('"'))?;
    let commas = mantissa.matches(',').count();
    let points = mantissa.matches('.').count();
    match (commas, points) {
        (0, 0) => None,
        (c, p) if c > 0 && p > 0 => Some(mantissa.rfind(',') > mantissa.rfind('.')),
        (1, 0) => (!is_grouped(mantissa, ',')).then_some(true),
        (0, 1) => (!is_grouped(mantissa, '.')).then_some(false),
        // Several of one mark: digit grouping, so the decimal mark is the other.
        (_, 0) => is_grouped(mantissa, ',').then_some(false),
        (0, _) => is_grouped(mantissa, '.').then_some(true),
        _ => None,
    }
}

/// The part of a numeric-looking field before its exponent; `None` where the field is not
/// written with digits, signs, marks and an exponent only.
fn mantissa(field: &str) -> Option<&str> {
    let numeric = !field.is_empty()
        && field.bytes().any(|b| b.is_ascii_digit())
        && field
            .bytes()
            .all(|b| b.is_ascii_digit() || b"+-.,eE".contains(&b));
    if !numeric {
        return None;
    }
    Some(field.split(['e', 'E']).next().unwrap_or(field))
}

/// Whether `text` (a sign, then digits) is an integer grouped in threes by `group`:
/// `1,000`, `-12.345.678`; a first group of one to three digits that does not start with 0.
fn is_grouped(text: &str, group: char) -> bool {
    let digits = text.trim_start_matches(['+', '-']);
    let mut parts = digits.split(group);
    let first = parts.next().unwrap_or("");
    let first_ok = (1..=3).contains(&first.len())
        && first.bytes().all(|b| b.is_ascii_digit())
        && !first.starts_with('0');
    let mut rest = 0;
    let rest_ok = parts.all(|p| {
        rest += 1;
        p.len() == 3 && p.bytes().all(|b| b.is_ascii_digit())
    });
    first_ok && rest_ok && rest > 0
}

/// A number written with digit grouping in threes by `group` and `decimal` as its decimal
/// mark (`4.999,8000`, `-1,000.5`, `1.000`), as plain digits Rust reads; `None` where it is
/// not so written.
pub(crate) fn ungrouped(field: &str, decimal: char, group: char) -> Option<String> {
    let (mantissa, exponent) = match field.find(['e', 'E']) {
        Some(i) => field.split_at(i),
        None => (field, ""),
    };
    let (integer, fraction) = match mantissa.split_once(decimal) {
        Some((i, f)) => (i, Some(f)),
        None => (mantissa, None),
    };
    if !is_grouped(integer, group)
        || fraction.is_some_and(|f| !f.bytes().all(|b| b.is_ascii_digit()))
    {
        return None;
    }
    let mut plain: String = integer.chars().filter(|c| *c != group).collect();
    if let Some(f) = fraction {
        plain.push('.');
        plain.push_str(f);
    }
    plain.push_str(exponent);
    Some(plain)
}

/// Why `field` could not be read as a number in a file with this decimal mark (`comma`) —
/// known from the file (`known`) or assumed — for the message at its row.
pub(crate) fn why_not_a_number(field: &str, comma: bool, known: bool) -> String {
    let (decimal, group) = if comma { (',', '.') } else { ('.', ',') };
    let mark = |c: bool| {
        if c {
            "a decimal comma"
        } else {
            "a decimal point"
        }
    };
    if field.contains(':') {
        return format!(
            "'{field}' is not a number: a clock time is read only in the time column, as \
             h:mm:ss or h:mm:ss.fff"
        );
    }
    if ungrouped(field, group, decimal).is_some() {
        return format!(
            "'{field}' is not a number: it reads as digits grouped by '{decimal}' with {}, \
             where the file's other numbers are written with {}",
            mark(!comma),
            mark(comma)
        );
    }
    if !known && ungrouped(field, decimal, group).is_some() {
        return format!(
            "'{field}' is not a number: '{group}' between digits could be {} or digit \
             grouping, and no number in the file tells which; write the numbers without \
             grouping",
            mark(!comma)
        );
    }
    format!("'{field}' is not a finite number")
}

/// A clock time `h:mm:ss` or `h:mm:ss.fff` (a decimal comma allowed) in seconds; `Ok(None)`
/// where the field has no `:`; an error naming the format where it is another clock or date.
pub(crate) fn clock_seconds(field: &str) -> Result<Option<f64>, String> {
    let field = field.trim().trim_matches('"');
    if !field.contains(':') {
        return Ok(None);
    }
    let refuse = || {
        format!(
            "'{field}' is not a clock time this reader knows: a time column holds seconds \
             (or the unit its header names) or a clock time h:mm:ss.fff; write dates and \
             other clocks as seconds"
        )
    };
    let parts: Vec<&str> = field.split(':').collect();
    let [h, m, s] = parts.as_slice() else {
        return Err(refuse());
    };
    let digits = |p: &str, most: usize| {
        (1..=most).contains(&p.len()) && p.bytes().all(|b| b.is_ascii_digit())
    };
    let seconds_written = s.bytes().next().is_some_and(|b| b.is_ascii_digit())
        && s.bytes()
            .all(|b| b.is_ascii_digit() || b == b'.' || b == b',');
    if !(digits(h, 6) && digits(m, 2) && seconds_written) {
        return Err(refuse());
    }
    let hours: f64 = h.parse().map_err(|_| refuse())?;
    let minutes: f64 = m.parse().map_err(|_| refuse())?;
    let seconds: f64 = s.replace(',', ".").parse().map_err(|_| refuse())?;
    if minutes >= 60.0 || !(0.0..60.0).contains(&seconds) {
        return Err(refuse());
    }
    Ok(Some(hours * 3600.0 + minutes * 60.0 + seconds))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_decimal_mark_is_told_only_by_a_field_grouping_could_not_have_written() {
        assert_eq!(mark_evidence("0,125", false), Some(true));
        assert_eq!(mark_evidence("12,5", false), Some(true));
        assert_eq!(mark_evidence("999.8000", false), Some(false));
        assert_eq!(mark_evidence("4.999,8000", false), Some(true));
        assert_eq!(mark_evidence("4,999.8000", false), Some(false));
        assert_eq!(mark_evidence("1.000.000", false), Some(true));
        assert_eq!(mark_evidence("1,000,000", false), Some(false));
        assert_eq!(mark_evidence("1,000", false), None);
        assert_eq!(mark_evidence("-1.5e-3", false), Some(false));
        assert_eq!(mark_evidence("12", false), None);
        assert_eq!(mark_evidence("EOF", false), None);
        assert_eq!(mark_evidence("0,125", true), None);
    }

    #[test]
    fn grouped_digits_read_as_their_value() {
        let read =
            |f: &str, d: char, g: char| ungrouped(f, d, g).map(|s| s.parse::<f64>().unwrap());
        assert_eq!(read("4.999,8000", ',', '.'), Some(4999.8));
        assert_eq!(read("4,999.8000", '.', ','), Some(4999.8));
        assert_eq!(read("-1.234.567", ',', '.'), Some(-1_234_567.0));
        assert_eq!(read("1,000.5e3", '.', ','), Some(1_000_500.0));
        // Groups of other sizes, or a first group with a leading zero, are not grouping.
        assert_eq!(read("1.00,5", ',', '.'), None);
        assert_eq!(read("0.125", ',', '.'), None);
        assert_eq!(read("1234.567,5", ',', '.'), None);
    }

    #[test]
    fn clock_times_read_as_seconds_or_are_refused_naming_the_format() {
        assert_eq!(clock_seconds("00:00:01.234"), Ok(Some(1.234)));
        assert_eq!(clock_seconds("01:02:03,5"), Ok(Some(3723.5)));
        assert_eq!(clock_seconds("0.5"), Ok(None));
        for bad in [
            "12:30",
            "00:61:00",
            "00:00:60",
            "2026-12-03 00:00:01",
            "a:b:c",
        ] {
            let e = clock_seconds(bad).unwrap_err();
            assert!(e.contains("h:mm:ss.fff"), "{bad}: {e}");
        }
    }
}
