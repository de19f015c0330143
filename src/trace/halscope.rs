//! LinuxCNC halscope data logs ("Save log" in halscope's menu).
//!
//! The layout is the one halscope's `write_log_file` writes (LinuxCNC,
//! `src/hal/utils/scope_files.c`): a first line `Sampling period is <N> ns`, then one line
//! per sample holding, for every channel in turn, the channel's HAL name and its value
//! (`joint.0.pos-fb +1.23400000000000 joint.0.pos-cmd +1.23500000000000 …`). There is no
//! time column; time is the sample index times the period. The writer's loop runs one
//! sample past the capture, so the last line lies outside the record and is dropped.
//!
//! Values are in the machine's own units (mm or inch, as its INI file says): state them in
//! the mapping when they are not millimetres, `x=joint.0.pos-fb[in]`.

use crate::trace::columns::NamedColumns;
use crate::trace::measured::{MeasuredError, Source};

/// The text every halscope log starts with.
const SIGNATURE: &str = "Sampling period is";

/// The name given to the time column made from the period.
pub const TIME_COLUMN: &str = "time";

/// Whether `text` is a halscope log.
pub(crate) fn is_halscope_log(text: &str) -> bool {
    text.trim_start_matches('\u{feff}')
        .trim_start()
        .starts_with(SIGNATURE)
}

/// Reads a halscope log; `file` names it in errors. Its channels as columns: `time` (s)
/// first, then one per channel named as in the file; each sample's line in the file.
pub(crate) fn halscope_columns(text: &str, file: &str) -> Result<NamedColumns, MeasuredError> {
    let row_error = |row: u64, problem: String| MeasuredError::Row {
        file: file.into(),
        row,
        problem,
    };
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| {
            (
                i as u64 + 1,
                l.trim_matches(|c: char| c.is_whitespace() || c == '\u{feff}'),
            )
        })
        .filter(|(_, l)| !l.is_empty());
    let (first_row, first) = lines.next().unwrap_or((1, ""));
    let period_s = sampling_period_s(first).ok_or_else(|| {
        row_error(
            first_row,
            format!("expected '{SIGNATURE} <N> ns' (a halscope log), found '{first}'"),
        )
    })?;
    let mut names: Vec<String> = Vec::new();
    let mut values: Vec<Vec<f64>> = Vec::new();
    let mut rows = Vec::new();
    for (row, line) in lines {
        let tokens: Vec<&str> = line.split_whitespace().collect();
        if !tokens.len().is_multiple_of(2) {
            return Err(row_error(
                row,
                "a channel name without a value (each sample is name value pairs)".into(),
            ));
        }
        if names.is_empty() {
            names = tokens.iter().step_by(2).map(|n| n.to_string()).collect();
            values = vec![Vec::new(); names.len()];
        }
        if tokens.len() != 2 * names.len() {
            return Err(row_error(
                row,
                format!(
                    "{} channels where the first sample has {}",
                    tokens.len() / 2,
                    names.len()
                ),
            ));
        }
        for (k, value) in sample_values(&tokens, &names)
            .map_err(|problem| row_error(row, problem))?
            .into_iter()
            .enumerate()
        {
            values[k].push(value);
        }
        rows.push(row);
    }
    // The writer's last sample lies one past the capture.
    if rows.len() >= 2 {
        rows.pop();
        values.iter_mut().for_each(|v| {
            v.pop();
        });
    }
    let time: Vec<f64> = (0..rows.len()).map(|k| k as f64 * period_s).collect();
    let mut columns = vec![(TIME_COLUMN.to_string(), time)];
    columns.extend(names.into_iter().zip(values));
    Ok(NamedColumns {
        source: Source::Halscope {
            channels: columns.len() - 1,
        },
        columns,
        rows,
    })
}

/// One sample's values from its `name value` pairs `tokens`, each channel in the first
/// sample's order `names`; what is wrong otherwise.
fn sample_values(tokens: &[&str], names: &[String]) -> Result<Vec<f64>, String> {
    tokens
        .chunks(2)
        .zip(names)
        .enumerate()
        .map(|(k, (pair, name))| {
            if pair[0] != name {
                return Err(format!(
                    "channel {} is '{}' where the first sample has '{name}'",
                    k + 1,
                    pair[0],
                ));
            }
            pair[1]
                .parse()
                .ok()
                .filter(|v: &f64| v.is_finite())
                .ok_or_else(|| {
                    format!(
                        "channel '{}': '{}' is not a finite number",
                        pair[0], pair[1]
                    )
                })
        })
        .collect()
}

/// The period of `Sampling period is <N> ns` (s).
fn sampling_period_s(line: &str) -> Option<f64> {
    let rest = line.strip_prefix(SIGNATURE)?.trim();
    let ns: f64 = rest.strip_suffix("ns")?.trim().parse().ok()?;
    (ns.is_finite() && ns > 0.0).then_some(ns * 1e-9)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_period_and_the_channels_are_read_and_the_extra_sample_dropped() {
        let text = "Sampling period is 1000000 ns \n\n\
            joint.0.pos-fb +1.00000000000000 joint.1.pos-fb -2.50000000000000 \n\
            joint.0.pos-fb +1.10000000000000 joint.1.pos-fb -2.40000000000000 \n\
            joint.0.pos-fb +9.00000000000000 joint.1.pos-fb +9.00000000000000 \n";
        let log = halscope_columns(text, "scope.log").unwrap();
        let names: Vec<&str> = log.columns.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(names, ["time", "joint.0.pos-fb", "joint.1.pos-fb"]);
        assert_eq!(log.columns[0].1, [0.0, 0.001]);
        assert_eq!(log.columns[2].1, [-2.5, -2.4]);
        assert_eq!(log.rows, [3, 4]);
    }

    #[test]
    fn a_damaged_line_names_its_row() {
        let text = "Sampling period is 1000000 ns\n\
            a +1.0 b +2.0\n\
            a +1.0 c +2.0\n";
        let e = halscope_columns(text, "scope.log").unwrap_err().to_string();
        assert!(e.starts_with("scope.log: row 3: channel 2 is 'c'"), "{e}");
        let e = halscope_columns("Sampling period is 1000000 ns\na +1.0 b\n", "s.log")
            .unwrap_err()
            .to_string();
        assert!(e.contains("row 2"), "{e}");
        let e = halscope_columns("Sampling period is fast\n", "s.log")
            .unwrap_err()
            .to_string();
        assert!(e.contains("row 1") && e.contains("halscope"), "{e}");
        let e = halscope_columns("Sampling period is 1000 ns\na nan\na 1\n", "s.log")
            .unwrap_err()
            .to_string();
        assert!(e.contains("row 2") && e.contains("'a'"), "{e}");
    }
}
