//! TwinCAT Scope exports: the text file TwinCAT 3's Scope View writes from a recording
//! ("Export" to CSV), read as named columns on one clock.
//!
//! The layout is the one the public `pytcs` reader (CagtayFabry/pytcs on GitHub) reads and
//! its test files show: a few lines about the scope (`Name`, `File`, `Starttime of export`
//! …), then a block of channel properties, one per line, each line a key and its values
//! (`Name`, `SymbolComment`, `Data-Type`, `SampleTime[ms]`, … `Unit`, `Unit ScaleFactor`,
//! `Unit Offset`), an empty line, and the samples. The `Name` line says which column is
//! which: a cell `Name` starts a time column (in ms), and the channel names that follow it
//! share that time column — one per channel by default, one per sampling period with
//! "exclude double timestamps". Values are exported already scaled; a channel's unit comes
//! from its `Unit` cell (`mm (Millimeter)`), `(None)` meaning none. The delimiter is the
//! one after `SampleTime[ms]` (tab by default; `;`, `,` or space as chosen), the decimal
//! mark a point or a comma. Channels at different periods end at different rows; each is
//! read on its own instants and all are put on the clock of the most densely sampled one.

use crate::trace::clock::{Sampled, on_one_clock};
use crate::trace::columns::NamedColumns;
use crate::trace::measured::{MeasuredError, Source};

/// The name given to the shared clock.
pub const TIME_COLUMN: &str = "time [s]";

/// The key of the line every export holds, whose following character is the delimiter.
const SAMPLE_TIME_KEY: &str = "SampleTime[ms]";

/// Whether `text` is a TwinCAT Scope export: it starts with `Name` and holds the channels'
/// `SampleTime[ms]` among its first lines.
pub(crate) fn is_twincat_export(text: &str) -> bool {
    let head = text.trim_start_matches('\u{feff}').trim_start();
    head.starts_with("Name")
        && head
            .lines()
            .take(60)
            .any(|l| l.trim_start().starts_with(SAMPLE_TIME_KEY))
}

/// Where a channel's samples are: its time column and its value column.
struct Channel {
    name: String,
    time_col: usize,
    value_col: usize,
}

/// Reads a TwinCAT Scope export; `file` names it in errors. Its channels as columns of
/// equal length: the clock (s) first, then one per channel named `name [unit]` where the
/// export gives a unit; each row's 1-based line.
pub(crate) fn twincat_columns(text: &str, file: &str) -> Result<NamedColumns, MeasuredError> {
    let data_error = |problem: String| MeasuredError::Data {
        file: file.into(),
        problem,
    };
    let lines: Vec<&str> = text.lines().collect();
    let layout = layout_of(&lines).map_err(data_error)?;
    let sampled = read_samples(&lines, &layout, file)?;
    if let Some(empty) = sampled.iter().find(|s| s.t.is_empty()) {
        return Err(data_error(format!(
            "channel '{}' holds no samples",
            empty.name
        )));
    }
    let (columns, rows) = on_one_clock(&sampled, TIME_COLUMN, 1e-3);
    if rows.len() < 2 {
        return Err(data_error(
            "the channels' samples do not overlap in time: no instant has them all".into(),
        ));
    }
    Ok(NamedColumns {
        source: Source::Twincat {
            channels: columns.len() - 1,
        },
        columns,
        rows,
    })
}

/// How an export is laid out: its delimiter, its channels, and where its samples start.
struct Layout {
    delimiter: char,
    channels: Vec<Channel>,
    first_data: usize,
}

/// The layout from the property block; why not, where it is not one.
fn layout_of(lines: &[&str]) -> Result<Layout, String> {
    let sample_time_line = lines
        .iter()
        .position(|l| l.trim_start().starts_with(SAMPLE_TIME_KEY))
        .ok_or_else(|| format!("no {SAMPLE_TIME_KEY} line: not a TwinCAT Scope export"))?;
    // Only the sampling period line is sure to hold a delimiter right after its key.
    let delimiter = lines[sample_time_line]
        .trim_start()
        .chars()
        .nth(SAMPLE_TIME_KEY.chars().count())
        .ok_or_else(|| format!("{SAMPLE_TIME_KEY} holds no value"))?;
    let name_line = (0..sample_time_line)
        .rev()
        .find(|&i| {
            cells(lines[i], delimiter)
                .first()
                .is_some_and(|c| c == "Name")
        })
        .ok_or("no Name line above the channels' properties")?;
    let names = cells(lines[name_line], delimiter);
    let units = (name_line..lines.len())
        .take_while(|&i| !lines[i].trim().is_empty())
        .map(|i| cells(lines[i], delimiter))
        .find(|c| c.first().is_some_and(|k| k == "Unit"));
    let channels = channels_of(&names, units.as_deref());
    if channels.is_empty() {
        return Err("the Name line names no channel".into());
    }
    let first_data = (name_line..lines.len())
        .find(|&i| lines[i].trim().is_empty())
        .map(|i| i + 1)
        .ok_or("no samples after the channels' properties")?;
    Ok(Layout {
        delimiter,
        channels,
        first_data,
    })
}

/// A line's cells, trimmed.
fn cells(line: &str, delimiter: char) -> Vec<String> {
    line.split(delimiter)
        .map(|c| c.trim().to_string())
        .collect()
}

/// Each channel's samples on its own instants; a cell that is not a number, or a time that
/// does not increase, is an error naming the row.
fn read_samples(
    lines: &[&str],
    layout: &Layout,
    file: &str,
) -> Result<Vec<Sampled>, MeasuredError> {
    let decimal_comma = layout.delimiter != ',';
    let row_error = |row: u64, problem: String| MeasuredError::Row {
        file: file.into(),
        row,
        problem,
    };
    let mut sampled: Vec<Sampled> = layout
        .channels
        .iter()
        .map(|c| Sampled {
            name: c.name.clone(),
            t: Vec::new(),
            v: Vec::new(),
            line: Vec::new(),
        })
        .collect();
    let end = data_end(lines, layout.first_data, layout.delimiter);
    for (i, line) in lines.iter().enumerate().take(end).skip(layout.first_data) {
        let row = i as u64 + 1;
        let row_cells = cells(line, layout.delimiter);
        for (channel, series) in layout.channels.iter().zip(sampled.iter_mut()) {
            let cell = |col: usize| row_cells.get(col).map_or("", String::as_str);
            let (t, v) = (cell(channel.time_col), cell(channel.value_col));
            if t.is_empty() && v.is_empty() {
                continue; // this channel's samples have ended
            }
            let number = |text: &str, what: &str| {
                parse_number(text, decimal_comma).ok_or_else(|| {
                    row_error(
                        row,
                        format!(
                            "{what} of channel '{}': '{text}' is not a number",
                            channel.name
                        ),
                    )
                })
            };
            let (t, v) = (number(t, "time")?, number(v, "value")?);
            if series.t.last().is_some_and(|&last| t <= last) {
                return Err(row_error(
                    row,
                    format!(
                        "time {t} ms of channel '{}' does not follow the previous row's",
                        channel.name
                    ),
                ));
            }
            series.t.push(t);
            series.v.push(v);
            series.line.push(row);
        }
    }
    Ok(sampled)
}

/// The channels the `Name` line lists, each with the time column of the `Name` cell it
/// follows, named with the unit of the `Unit` line where there is one.
fn channels_of(names: &[String], units: Option<&[String]>) -> Vec<Channel> {
    let mut channels = Vec::new();
    // Every `Name` cell (the line's key included) stands over a time column.
    let mut time_col = 0;
    for (col, name) in names.iter().enumerate() {
        if name == "Name" {
            time_col = col;
            continue;
        }
        let time = time_col;
        let unit = units
            .and_then(|u| u.get(col))
            .map(|u| u.split(" (").next().unwrap_or("").trim())
            .filter(|u| !u.is_empty() && !u.starts_with('('));
        channels.push(Channel {
            name: match unit {
                Some(unit) => format!("{name} [{unit}]"),
                None => name.clone(),
            },
            time_col: time,
            value_col: col,
        });
    }
    channels
}

/// The line after the last line of samples: trailing lines with no number (an `EOF`
/// marker, a note) are not samples.
fn data_end(lines: &[&str], first: usize, delimiter: char) -> usize {
    let mut end = lines.len();
    while end > first {
        let line = lines[end - 1];
        let any_number = line
            .split(delimiter)
            .any(|c| parse_number(c.trim(), delimiter != ',').is_some());
        if any_number {
            break;
        }
        end -= 1;
    }
    end
}

/// A number with a point, or a comma where the delimiter is not one.
fn parse_number(text: &str, decimal_comma: bool) -> Option<f64> {
    let parsed = if decimal_comma && text.contains(',') {
        text.replace(',', ".").parse::<f64>().ok()
    } else {
        text.parse::<f64>().ok()
    };
    parsed.filter(|v| v.is_finite())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An export in the default layout (a time column per channel), decimal comma, a slower
    /// channel that ends early, and an `EOF` trailer.
    const EXPORT: &str = "Name\tscope\nFile\tC:\\x.csv\nStarttime of export\t1\tMontag\t15:56\n\n\n\
        Name\tX_Act\tName\tX_Set\n\
        SymbolComment\t\tSymbolComment\t\n\
        SampleTime[ms]\t1\tSampleTime[ms]\t2\n\
        Unit\tmm (Millimeter)\tUnit\t(None)\n\
        \n\
        0\t1,5\t0\t10\n\
        1\t2,5\t2\t12\n\
        2\t3,5\t4\t14\n\
        3\t4,5\t\t\n\
        4\t5,5\t\t\n\
        EOF\n";

    #[test]
    fn channels_at_two_periods_share_the_denser_clock_in_seconds() {
        assert!(is_twincat_export(EXPORT));
        let c = twincat_columns(EXPORT, "x.csv").unwrap();
        let names: Vec<&str> = c.columns.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(names, ["time [s]", "X_Act [mm]", "X_Set"]);
        assert_eq!(c.columns[0].1, vec![0.0, 0.001, 0.002, 0.003, 0.004]);
        assert_eq!(c.columns[1].1, vec![1.5, 2.5, 3.5, 4.5, 5.5]);
        assert_eq!(c.columns[2].1, vec![10.0, 11.0, 12.0, 13.0, 14.0]);
        assert_eq!(c.rows, vec![11, 12, 13, 14, 15]);
    }

    #[test]
    fn shared_time_columns_and_bad_cells() {
        let shared = "Name\ts\n\nName;A;B\nSampleTime[ms];1;1\n\n0;1;2\n1;3;4\n";
        let c = twincat_columns(shared, "s.csv").unwrap();
        assert_eq!(c.columns[1].1, vec![1.0, 3.0]);
        assert_eq!(c.columns[2].1, vec![2.0, 4.0]);
        let bad = shared.replace("1;3;4", "1;x;4");
        let e = twincat_columns(&bad, "s.csv").unwrap_err().to_string();
        assert!(e.contains("row 7") && e.contains("'x'"), "{e}");
    }
}
