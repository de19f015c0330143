//! How a measured trace is laid out: which columns hold time, positions and commands, in
//! which units, and how the text is delimited — as controls and lab systems write them.
//!
//! A layout comes from a mapping the user gives (`t=Time[ms],x=X_ActPos[mm],…`, on the
//! command line or in a small TOML trace profile) or is recognised from the header's usual
//! spellings (`t_s`, `time`, `Time [ms]`; `x_mm`, `X`, `X_act`, `X_ActPos`; `x_cmd_mm`,
//! `X_ref`, `X_Traj` …). Units come from the mapping, from brackets in the header
//! (`Time [ms]`, `X (µm)`), from a suffix (`_ms`, `_um`) or from a units row under the
//! header (`s;mm;mm`, read in `measured`); counts need a stated
//! resolution (`x=X_enc[counts:0.0001mm]`). The text may be comma, semicolon, tab or
//! whitespace separated, with a decimal comma, a byte-order mark, CRLF line ends, comment
//! lines and trailer lines after the data.

use std::fmt;

use crate::trace::numerals;

/// A quantity a trace column holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Signal {
    /// Time.
    Time,
    /// Measured X.
    X,
    /// Measured Y.
    Y,
    /// Commanded X.
    XCmd,
    /// Commanded Y.
    YCmd,
    /// Measured Z (optional: read where the file has it).
    Z,
    /// Commanded Z (optional).
    ZCmd,
}

impl Signal {
    /// Every signal, time first.
    pub const ALL: [Signal; 7] = [
        Signal::Time,
        Signal::X,
        Signal::Y,
        Signal::XCmd,
        Signal::YCmd,
        Signal::Z,
        Signal::ZCmd,
    ];

    /// The key in a mapping: `t`, `x`, `y`, `x_cmd`, `y_cmd`, `z`, `z_cmd`.
    pub fn key(self) -> &'static str {
        match self {
            Signal::Time => "t",
            Signal::X => "x",
            Signal::Y => "y",
            Signal::XCmd => "x_cmd",
            Signal::YCmd => "y_cmd",
            Signal::Z => "z",
            Signal::ZCmd => "z_cmd",
        }
    }

    fn from_key(key: &str) -> Option<Signal> {
        Signal::ALL.into_iter().find(|s| s.key() == key)
    }

    /// Whether this is the time.
    pub(crate) fn is_time(self) -> bool {
        self == Signal::Time
    }

    /// Whether this is a Z signal (optional in every file).
    pub(crate) fn is_z(self) -> bool {
        matches!(self, Signal::Z | Signal::ZCmd)
    }
}

/// A column's unit: its value times `to_si` is seconds (time) or metres (positions).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Unit {
    /// Factor to SI.
    pub to_si: f64,
    /// As written, for messages.
    pub label: &'static str,
}

impl Unit {
    /// Whether a column in this unit can hold `value`: counts are whole numbers.
    pub(crate) fn takes(&self, value: f64) -> bool {
        !self.is_count() || value.fract() == 0.0
    }

    /// Whether this is a count unit (`counts:RESOLUTION`).
    pub(crate) fn is_count(&self) -> bool {
        self.label == COUNTS
    }
}

/// The label of a count unit (`counts:RESOLUTION`).
const COUNTS: &str = "counts";

/// Why `text` cannot be a count.
pub(crate) fn not_a_count(text: &str) -> String {
    format!(
        "'{text}' is not a whole number: a column read as counts (counts:RESOLUTION) holds \
         whole counts; positions in a length unit take it instead, as [mm]"
    )
}

const TIME_UNITS: [(&str, f64); 5] = [
    ("s", 1.0),
    ("ms", 1e-3),
    ("us", 1e-6),
    ("µs", 1e-6),
    ("min", 60.0),
];
/// The time units a clock may count in, one per scale (no spelling twice).
pub(crate) fn time_units() -> impl Iterator<Item = Unit> {
    TIME_UNITS
        .iter()
        .filter(|(label, _)| *label != "µs")
        .map(|&(label, to_si)| Unit { to_si, label })
}

const LENGTH_UNITS: [(&str, f64); 6] = [
    ("m", 1.0),
    ("mm", 1e-3),
    ("um", 1e-6),
    ("µm", 1e-6),
    ("in", 0.0254),
    ("inch", 0.0254),
];

/// Reads a unit for a signal: a time or length unit, or `counts:RESOLUTION` with a length
/// unit on the resolution (`counts:0.1um`).
pub(crate) fn parse_unit(text: &str, signal: Signal) -> Result<Unit, String> {
    let t = text.trim();
    let table: &[(&'static str, f64)] = if signal.is_time() {
        &TIME_UNITS
    } else {
        &LENGTH_UNITS
    };
    if let Some((label, f)) = table.iter().find(|(l, _)| l.eq_ignore_ascii_case(t)) {
        return Ok(Unit { to_si: *f, label });
    }
    if !signal.is_time()
        && let Some(res) = t
            .strip_prefix("counts:")
            .or_else(|| t.strip_prefix("count:"))
    {
        let split = res
            .find(|c: char| c.is_alphabetic() || c == 'µ')
            .ok_or_else(|| {
                format!("counts need a resolution with a unit, as counts:0.1um (got '{t}')")
            })?;
        let (number, unit) = res.split_at(split);
        let step: f64 = number.trim().parse().map_err(|_| {
            format!("the count resolution '{res}' is not a number with a unit, as counts:0.1um")
        })?;
        let unit = parse_unit(unit, signal)?;
        if !(step.is_finite() && step > 0.0) {
            return Err(format!("the count resolution '{number}' must be positive"));
        }
        return Ok(Unit {
            to_si: step * unit.to_si,
            label: COUNTS,
        });
    }
    let known: Vec<&str> = table.iter().map(|(l, _)| *l).collect();
    Err(format!(
        "unknown {} unit '{t}' (known: {}{})",
        if signal.is_time() { "time" } else { "length" },
        known.join(", "),
        if signal.is_time() {
            ""
        } else {
            ", counts:RESOLUTION"
        }
    ))
}

/// One column as mapped: its header name and unit.
#[derive(Debug, Clone, PartialEq)]
pub struct ColumnSpec {
    /// The header as written in the file.
    pub name: String,
    /// Its unit; None: to be taken from the header, else the default (s, mm).
    pub unit: Option<Unit>,
}

/// What is wrong with a column mapping (`--columns`, a trace profile), in words that name
/// the key, the column or the file.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct MappingError(String);

/// A user's mapping of signals to columns.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ColumnMap {
    specs: Vec<(Signal, ColumnSpec)>,
}

impl ColumnMap {
    /// Parses `t=Time[ms],x=X_ActPos[mm],y=Y_ActPos,x_cmd=X_Traj,y_cmd=Y_Traj`.
    pub fn parse(text: &str) -> Result<ColumnMap, MappingError> {
        let mut map = ColumnMap::default();
        for item in split_mapping(text) {
            let (key, column) = item.split_once('=').ok_or_else(|| {
                MappingError(format!("'{item}': expected KEY=COLUMN, as t=Time[ms]"))
            })?;
            let signal = Signal::from_key(key.trim()).ok_or_else(|| {
                let keys: Vec<&str> = Signal::ALL.iter().map(|s| s.key()).collect();
                MappingError(format!("'{key}': the keys are {}", keys.join(", ")))
            })?;
            map.set(signal, column)?;
        }
        map.check_complete().map_err(MappingError)?;
        Ok(map)
    }

    /// Sets one signal from `Name[unit]` or `Name`.
    pub(crate) fn set(&mut self, signal: Signal, column: &str) -> Result<(), MappingError> {
        let (name, unit) = split_unit(column.trim());
        let unit = unit
            .map(|u| parse_unit(u, signal))
            .transpose()
            .map_err(MappingError)?;
        if name.is_empty() {
            return Err(MappingError(format!(
                "{}: the column name is empty",
                signal.key()
            )));
        }
        self.specs.retain(|(s, _)| *s != signal);
        self.specs.push((
            signal,
            ColumnSpec {
                name: name.to_string(),
                unit,
            },
        ));
        Ok(())
    }

    /// The column mapped to `signal`, if any.
    pub(crate) fn get(&self, signal: Signal) -> Option<&ColumnSpec> {
        self.specs
            .iter()
            .find(|(s, _)| *s == signal)
            .map(|(_, c)| c)
    }

    /// x and y must be mapped; time may be left to recognition (a halscope log's time is
    /// made from its period).
    fn check_complete(&self) -> Result<(), String> {
        for s in [Signal::X, Signal::Y] {
            if self.get(s).is_none() {
                return Err(format!(
                    "the mapping needs {}= (x and y are required, t where the time column \
                     is not recognised)",
                    s.key()
                ));
            }
        }
        if self.get(Signal::XCmd).is_some() != self.get(Signal::YCmd).is_some() {
            return Err("x_cmd and y_cmd go together".into());
        }
        // One column read as two signals (y=x_mm beside x=x_mm) is a slip of the mapping:
        // the record would be compared with an axis it does not hold.
        for (i, (a, spec)) in self.specs.iter().enumerate() {
            if let Some((b, _)) = self.specs[i + 1..]
                .iter()
                .find(|(_, s)| s.name == spec.name)
            {
                return Err(format!(
                    "the column '{}' is mapped to both {} and {}: each needs a column of its own",
                    spec.name,
                    a.key(),
                    b.key()
                ));
            }
        }
        Ok(())
    }
}

/// Splits a mapping at commas that are not inside brackets (`counts:0,1um` stays whole).
fn split_mapping(text: &str) -> Vec<&str> {
    let mut items = Vec::new();
    let (mut depth, mut start) = (0i32, 0);
    for (i, c) in text.char_indices() {
        match c {
            '[' | '(' => depth += 1,
            ']' | ')' => depth -= 1,
            ',' if depth == 0 => {
                items.push(text[start..i].trim());
                start = i + 1;
            }
            _ => {}
        }
    }
    items.push(text[start..].trim());
    items.into_iter().filter(|s| !s.is_empty()).collect()
}

/// `Time [ms]` → ("Time", Some("ms")); `X (µm)` likewise; `Time` → ("Time", None).
fn split_unit(column: &str) -> (&str, Option<&str>) {
    for (open, close) in [('[', ']'), ('(', ')')] {
        if let (Some(a), true) = (column.rfind(open), column.ends_with(close)) {
            return (
                column[..a].trim(),
                Some(column[a + 1..column.len() - 1].trim()),
            );
        }
    }
    (column, None)
}

/// A trace profile file: a shop's mapping written once.
///
/// ```toml
/// columns = "t=Time[ms],x=X_ActPos[mm],y=Y_ActPos[mm],x_cmd=X_Traj[mm],y_cmd=Y_Traj[mm]"
/// ```
#[derive(Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TraceProfile {
    /// The mapping, as for `--columns`.
    pub columns: String,
}

impl TraceProfile {
    /// Reads a profile file into a mapping.
    #[cfg(feature = "cli")]
    pub(crate) fn load(path: &std::path::Path) -> Result<ColumnMap, MappingError> {
        let in_file = |problem: String| MappingError(format!("{}: {problem}", path.display()));
        let text = std::fs::read_to_string(path).map_err(|e| in_file(e.to_string()))?;
        let profile: TraceProfile =
            toml::from_str(&text).map_err(|e| in_file(e.message().to_string()))?;
        ColumnMap::parse(&profile.columns).map_err(|e| in_file(format!("key `columns`: {e}")))
    }
}

/// How the text is split into fields.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Delimiter {
    /// A single byte: `,`, `;` or tab.
    Byte(u8),
    /// Runs of spaces or tabs.
    Whitespace,
}

impl fmt::Display for Delimiter {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Delimiter::Byte(b',') => f.write_str("comma"),
            Delimiter::Byte(b';') => f.write_str("semicolon"),
            Delimiter::Byte(b'\t') => f.write_str("tab"),
            Delimiter::Byte(b) => write!(f, "'{}'", *b as char),
            Delimiter::Whitespace => f.write_str("whitespace"),
        }
    }
}

/// The text's dialect, as sniffed from its header and first data lines.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Dialect {
    /// Field separator.
    pub delimiter: Delimiter,
    /// Numbers written with a decimal comma (`0,125`).
    pub decimal_comma: bool,
    /// Whether a number in the file shows which mark is the decimal one (`0,125`,
    /// `999.8000`, `4.999,8000`); only then is the other mark read as digit grouping.
    pub decimal_known: bool,
}

/// Whether a line is a comment: `#`, `//`, `%` or `;` first (`;` only when it is not the
/// delimiter).
pub(crate) fn is_comment(line: &str) -> bool {
    let l = line.trim_start();
    l.starts_with('#') || l.starts_with("//") || l.starts_with('%')
}

/// Sniffs the dialect from the header line and the data lines: the delimiter from the
/// header, the decimal mark from the numbers of the first twenty lines that tell it (see
/// [`numerals::mark_evidence`]), or of the first line further down that does; where none
/// does, a decimal point.
pub(crate) fn sniff<'a>(header: &str, data: impl IntoIterator<Item = &'a str>) -> Dialect {
    const SAMPLE_LINES: usize = 20;
    let count = |b: char| header.matches(b).count();
    let delimiter = if count('\t') > 0 {
        Delimiter::Byte(b'\t')
    } else if count(';') > 0 {
        Delimiter::Byte(b';')
    } else if count(',') > 0 {
        Delimiter::Byte(b',')
    } else {
        Delimiter::Whitespace
    };
    let comma_splits = delimiter == Delimiter::Byte(b',');
    let (mut comma, mut point) = (0usize, 0usize);
    for (i, line) in data.into_iter().enumerate() {
        if i >= SAMPLE_LINES && comma + point > 0 {
            break;
        }
        for field in fields(line, delimiter) {
            match numerals::mark_evidence(field, comma_splits) {
                Some(true) => comma += 1,
                Some(false) => point += 1,
                None => {}
            }
        }
    }
    // Without evidence every comma between digits could be either (`1,000`): the point is
    // taken for the decimal mark, and such a comma is refused at its row, never guessed.
    let decimal_known = comma_splits || comma + point > 0;
    let decimal_comma = comma > point;
    Dialect {
        delimiter,
        decimal_comma,
        decimal_known,
    }
}

/// Splits a line into trimmed fields.
pub(crate) fn fields(line: &str, d: Delimiter) -> Vec<&str> {
    match d {
        Delimiter::Byte(b) => line.split(b as char).map(str::trim).collect(),
        Delimiter::Whitespace => line.split_whitespace().collect(),
    }
}

/// Reads a number as written in the dialect: its decimal mark, and digit grouping by the
/// other mark where the file shows which is which.
pub(crate) fn number(field: &str, dialect: &Dialect) -> Option<f64> {
    let (decimal, group) = if dialect.decimal_comma {
        (',', '.')
    } else {
        ('.', ',')
    };
    let plain = |t: &str| t.parse::<f64>().ok().filter(|v| v.is_finite());
    if !field.contains(group) {
        return if dialect.decimal_comma {
            plain(&field.replace(',', "."))
        } else {
            plain(field)
        };
    }
    if dialect.decimal_known
        && let Some(digits) = numerals::ungrouped(field, decimal, group)
    {
        return plain(&digits);
    }
    // A point that groups nothing in a decimal-comma file: a column written with a point
    // by another tool, read as written.
    if dialect.decimal_comma && !field.contains(',') {
        return plain(field);
    }
    None
}

/// Why a field is not a number in the dialect, for the message at its row.
pub(crate) fn why_not_a_number(field: &str, dialect: &Dialect) -> String {
    numerals::why_not_a_number(field, dialect.decimal_comma, dialect.decimal_known)
}

/// A signal found in the header: its column index, header text and unit.
#[derive(Debug, Clone, PartialEq)]
pub struct Mapped {
    /// Which signal.
    pub signal: Signal,
    /// Column index (0-based).
    pub index: usize,
    /// The header as written.
    pub header: String,
    /// The unit used.
    pub unit: Unit,
    /// Where the unit came from: "mapping", "header", "default".
    pub unit_from: &'static str,
    /// The step of the finest digit a text file prints in this column, in its unit.
    pub print_step: Option<f64>,
}

/// Finds every signal's column in `headers`, from `map` when given, else by the usual
/// spellings. Errors name what is missing and list the headers found.
pub(crate) fn map_columns(
    headers: &[&str],
    map: Option<&ColumnMap>,
) -> Result<Vec<Mapped>, String> {
    let mut out = Vec::new();
    for signal in Signal::ALL {
        let found = match map {
            Some(m) => match m.get(signal) {
                Some(spec) => Some(find_named(headers, spec, signal)?),
                None if signal == Signal::Time => recognise(headers, signal)?,
                None => None,
            },
            // Z is optional: where several columns could be it, it is left to a mapping
            // rather than the whole file refused (X and Y are read either way).
            None if signal.is_z() => recognise(headers, signal).ok().flatten(),
            None => recognise(headers, signal)?,
        };
        if let Some(f) = found {
            out.push(f);
        }
    }
    let has = |s: Signal| out.iter().any(|m| m.signal == s);
    for s in [Signal::Time, Signal::X, Signal::Y] {
        if !has(s) {
            return Err(format!(
                "no column for {} among the headers {:?}; name them with --columns \
                 t=NAME[unit],x=NAME[unit],y=NAME[unit] (x_cmd, y_cmd, z, z_cmd optional)",
                describe(s),
                headers
            ));
        }
    }
    if has(Signal::XCmd) != has(Signal::YCmd) {
        return Err(format!(
            "a command column for only one axis among {headers:?}; map both x_cmd and y_cmd"
        ));
    }
    Ok(out)
}

fn describe(s: Signal) -> &'static str {
    match s {
        Signal::Time => "time",
        Signal::X => "the measured X",
        Signal::Y => "the measured Y",
        Signal::XCmd => "the commanded X",
        Signal::YCmd => "the commanded Y",
        Signal::Z => "the measured Z",
        Signal::ZCmd => "the commanded Z",
    }
}

fn find_named(headers: &[&str], spec: &ColumnSpec, signal: Signal) -> Result<Mapped, String> {
    let index = headers
        .iter()
        .position(|h| *h == spec.name || split_unit(h).0 == spec.name)
        .ok_or_else(|| {
            format!(
                "{}={}: no such column among the headers {headers:?}",
                signal.key(),
                spec.name
            )
        })?;
    mapped(headers[index], index, signal, spec.unit)
}

/// The column's mapping with its unit: the one given, else the header's, else the default.
fn mapped(
    header: &str,
    index: usize,
    signal: Signal,
    given: Option<Unit>,
) -> Result<Mapped, String> {
    let (unit, unit_from) = match given {
        Some(u) => (u, "mapping"),
        None => match header_unit(header, signal)? {
            Some(u) => (u, "header"),
            None => (
                parse_unit(if signal.is_time() { "s" } else { "mm" }, signal)?,
                "default",
            ),
        },
    };
    Ok(Mapped {
        signal,
        index,
        header: header.to_string(),
        unit,
        unit_from,
        print_step: None,
    })
}

/// A unit written into a header: `Time [ms]`, `X (µm)`, `t_ms`, `x_um`.
fn header_unit(header: &str, signal: Signal) -> Result<Option<Unit>, String> {
    if let (_, Some(u)) = split_unit(header) {
        return parse_unit(u, signal)
            .map(Some)
            .map_err(|e| format!("column '{header}': {e}"));
    }
    let lower = header.to_lowercase();
    let table: &[(&'static str, f64)] = if signal.is_time() {
        &TIME_UNITS
    } else {
        &LENGTH_UNITS
    };
    Ok(table
        .iter()
        .find(|(l, _)| lower.ends_with(&format!("_{l}")))
        .map(|(label, f)| Unit { to_si: *f, label }))
}

/// The usual spellings of each signal, compared without case, spaces, `_`, `-` or units.
fn spellings(signal: Signal) -> &'static [&'static str] {
    match signal {
        Signal::Time => &TIME_SPELLINGS,
        Signal::X => &X_SPELLINGS,
        Signal::Y => &Y_SPELLINGS,
        Signal::XCmd => &X_CMD_SPELLINGS,
        Signal::YCmd => &Y_CMD_SPELLINGS,
        Signal::Z => &Z_SPELLINGS,
        Signal::ZCmd => &Z_CMD_SPELLINGS,
    }
}

const TIME_SPELLINGS: [&str; 8] = [
    "t",
    "ts",
    "tms",
    "time",
    "times",
    "timems",
    "zeit",
    "timestamp",
];
const X_SPELLINGS: [&str; 13] = [
    "x",
    "xmm",
    "xum",
    "xact",
    "xactpos",
    "xpos",
    "posx",
    "actposx",
    "xactual",
    "xmeas",
    "xmeasured",
    "xis",
    "xist",
];
const Y_SPELLINGS: [&str; 13] = [
    "y",
    "ymm",
    "yum",
    "yact",
    "yactpos",
    "ypos",
    "posy",
    "actposy",
    "yactual",
    "ymeas",
    "ymeasured",
    "yis",
    "yist",
];
const X_CMD_SPELLINGS: [&str; 12] = [
    "xcmd",
    "xcmdmm",
    "xref",
    "xtraj",
    "xset",
    "xsetpos",
    "xcmdpos",
    "cmdposx",
    "xsoll",
    "xcommand",
    "xcommanded",
    "setposx",
];
const Y_CMD_SPELLINGS: [&str; 12] = [
    "ycmd",
    "ycmdmm",
    "yref",
    "ytraj",
    "yset",
    "ysetpos",
    "ycmdpos",
    "cmdposy",
    "ysoll",
    "ycommand",
    "ycommanded",
    "setposy",
];
const Z_SPELLINGS: [&str; 13] = [
    "z",
    "zmm",
    "zum",
    "zact",
    "zactpos",
    "zpos",
    "posz",
    "actposz",
    "zactual",
    "zmeas",
    "zmeasured",
    "zis",
    "zist",
];
const Z_CMD_SPELLINGS: [&str; 12] = [
    "zcmd",
    "zcmdmm",
    "zref",
    "ztraj",
    "zset",
    "zsetpos",
    "zcmdpos",
    "cmdposz",
    "zsoll",
    "zcommand",
    "zcommanded",
    "setposz",
];

/// A header reduced for comparison: no unit (bracketed or as a `_unit` suffix), no case, no
/// separators.
fn normalised(header: &str) -> String {
    let mut name = split_unit(header).0.to_lowercase();
    if let Some((stem, suffix)) = name.rsplit_once('_')
        && TIME_UNITS
            .iter()
            .chain(&LENGTH_UNITS)
            .any(|(label, _)| *label == suffix)
    {
        name = stem.to_string();
    }
    name.chars().filter(|c| c.is_alphanumeric()).collect()
}

/// The columns whose name is a spelling of `signal`; where none is, those whose last part
/// after a `.` is (a MAT-file's field path, `ScopeData.time`).
fn recognise(headers: &[&str], signal: Signal) -> Result<Option<Mapped>, String> {
    let names = spellings(signal);
    let matching = |name: &dyn Fn(&str) -> Option<String>| -> Vec<usize> {
        (0..headers.len())
            .filter(|&i| name(headers[i]).is_some_and(|n| names.contains(&n.as_str())))
            .collect()
    };
    let mut hits = matching(&|h| Some(normalised(h)));
    if hits.is_empty() {
        hits = matching(&|h| h.rsplit_once('.').map(|(_, leaf)| normalised(leaf)));
    }
    if hits.is_empty() {
        // Descriptive names, as capture tools give signals ("Encoder Feedback X", "Feed
        // Reference DataX/RefCommand"): taken only where exactly one column reads so.
        let described: Vec<usize> = (0..headers.len())
            .filter(|&i| described_signal(headers[i]) == Some(signal))
            .collect();
        if let [one] = described.as_slice() {
            hits = vec![*one];
        }
    }
    match hits.as_slice() {
        [] => Ok(None),
        [i] => mapped(headers[*i], *i, signal, None).map(Some),
        many => Err(format!(
            "several columns could be {}: {:?}; choose with --columns",
            describe(signal),
            many.iter().map(|&i| headers[i]).collect::<Vec<_>>()
        )),
    }
}

/// Words that make a name a commanded position, a measured one, or something else.
const COMMAND_WORDS: [&str; 12] = [
    "ref",
    "reference",
    "cmd",
    "command",
    "commanded",
    "set",
    "setpoint",
    "soll",
    "demand",
    "target",
    "desired",
    "traj",
];
const MEASURED_WORDS: [&str; 9] = [
    "encoder", "feedback", "fb", "act", "actual", "measured", "meas", "ist", "scale",
];
/// Words naming the quantity, not where it came from: a position is measured unless a
/// command word says it is the setpoint ("Position setpoint").
const POSITION_WORDS: [&str; 2] = ["pos", "position"];
/// How an axis is named among a name's words: its letter, or SINUMERIK's machine-axis name.
const X_WORDS: [&str; 2] = ["x", "x1"];
const Y_WORDS: [&str; 2] = ["y", "y1"];
const Z_WORDS: [&str; 2] = ["z", "z1"];
const OTHER_QUANTITY_WORDS: [&str; 20] = [
    "vel",
    "velocity",
    "speed",
    "rate",
    "acc",
    "accel",
    "acceleration",
    "jerk",
    "current",
    "torque",
    "force",
    "voltage",
    "error",
    "err",
    "deviation",
    "following",
    "lag",
    "diff",
    "temperature",
    "temp",
];

/// The signal a descriptive name stands for: one axis letter among its words (`DataX` and
/// `posX` split at the case change; `X1` as SINUMERIK names machine axes), a word of command
/// or of measurement (not both; "position" alone counts as measured), and no word of another
/// quantity (speed, current, error …).
fn described_signal(header: &str) -> Option<Signal> {
    let words = words(split_unit(header).0);
    let has = |list: &[&str]| words.iter().any(|w| list.contains(&w.as_str()));
    if has(&OTHER_QUANTITY_WORDS) {
        return None;
    }
    let axis = match (has(&X_WORDS), has(&Y_WORDS), has(&Z_WORDS)) {
        (true, false, false) => 0,
        (false, true, false) => 1,
        (false, false, true) => 2,
        _ => return None,
    };
    let command = has(&COMMAND_WORDS);
    let measured = has(&MEASURED_WORDS) || (has(&POSITION_WORDS) && !command);
    match (command, measured) {
        (true, false) => Some([Signal::XCmd, Signal::YCmd, Signal::ZCmd][axis]),
        (false, true) => Some([Signal::X, Signal::Y, Signal::Z][axis]),
        _ => None,
    }
}

/// A name's words, lower-cased: split at anything not a letter or digit, where a lower-case
/// letter meets a capital (`DataX`, `posX`), and where capitals meet a word (`XIndex`).
fn words(name: &str) -> Vec<String> {
    let chars: Vec<char> = name.chars().collect();
    let mut out = Vec::new();
    let mut word = String::new();
    for (i, &c) in chars.iter().enumerate() {
        if !c.is_alphanumeric() {
            if !word.is_empty() {
                out.push(std::mem::take(&mut word).to_lowercase());
            }
            continue;
        }
        let previous = i.checked_sub(1).map(|p| chars[p]);
        let next = chars.get(i + 1);
        let boundary = c.is_uppercase()
            && previous.is_some_and(|p| {
                p.is_lowercase() || (p.is_uppercase() && next.is_some_and(|n| n.is_lowercase()))
            });
        if boundary && !word.is_empty() {
            out.push(std::mem::take(&mut word).to_lowercase());
        }
        word.push(c);
    }
    if !word.is_empty() {
        out.push(word.to_lowercase());
    }
    out
}

/// One line per mapped signal, for the user: `t ← Time [ms] (unit from the header)`.
pub(crate) fn describe_mapping(mapped: &[Mapped]) -> Vec<String> {
    mapped
        .iter()
        .map(|m| {
            format!(
                "{:<5} ← column {} '{}' in {} (unit from the {})",
                m.signal.key(),
                m.index + 1,
                m.header,
                m.unit.label,
                m.unit_from
            )
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_mapping_reads_names_units_and_counts() {
        let m = ColumnMap::parse("t=Time[ms],x=X_enc[counts:0.1um],y=Y_ActPos[in]").unwrap();
        let headers = ["Time", "X_enc", "Y_ActPos"];
        let mapped = map_columns(&headers, Some(&m)).unwrap();
        assert_eq!(mapped[0].unit.to_si, 1e-3);
        assert!((mapped[1].unit.to_si - 1e-7).abs() < 1e-22);
        assert_eq!(mapped[2].unit.to_si, 0.0254);
        assert!(ColumnMap::parse("t=Time[hours],x=a,y=b").is_err());
        assert!(
            ColumnMap::parse("t=Time,x=a")
                .unwrap_err()
                .to_string()
                .contains("y=")
        );
        assert!(ColumnMap::parse("t=T,x=a,y=b,x_cmd=c").is_err());
    }

    #[test]
    fn a_column_mapped_twice_or_a_count_without_number_is_refused_by_name() {
        let e = ColumnMap::parse("t=t_s,x=x_mm,y=x_mm")
            .unwrap_err()
            .to_string();
        assert!(e.contains("'x_mm' is mapped to both x and y"), "{e}");
        let e = ColumnMap::parse("t=t_s,x=x_mm,y=y_mm,x_cmd=x_mm,y_cmd=y_c")
            .unwrap_err()
            .to_string();
        assert!(e.contains("'x_mm' is mapped to both x and x_cmd"), "{e}");
        let e = ColumnMap::parse("t=t_s,x=x_mm[counts:abc],y=y_mm")
            .unwrap_err()
            .to_string();
        assert!(e.contains("'abc'"), "{e}");
        // A key that is none lists every key there is, Z's among them.
        let e = ColumnMap::parse("t=t_s,x=x_mm,y=y_mm,w=w_mm")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("'w': the keys are t, x, y, x_cmd, y_cmd, z, z_cmd"),
            "{e}"
        );
    }

    #[test]
    fn vendor_spellings_are_recognised_with_their_units() {
        let headers = ["Time [ms]", "X_Traj", "Y_Traj", "X_ActPos", "Y_ActPos"];
        let m = map_columns(&headers, None).unwrap();
        let by = |s: Signal| m.iter().find(|x| x.signal == s).unwrap();
        assert_eq!(by(Signal::Time).index, 0);
        assert_eq!(by(Signal::Time).unit.to_si, 1e-3);
        assert_eq!(by(Signal::X).index, 3);
        assert_eq!(by(Signal::XCmd).index, 1);
        assert_eq!(by(Signal::YCmd).unit_from, "default");
        // Ours as ever.
        let m = map_columns(&["t_s", "x_mm", "y_mm"], None).unwrap();
        assert_eq!(m.len(), 3);
        let e = map_columns(&["a", "b"], None).unwrap_err();
        assert!(e.contains("no column for time"), "{e}");
    }

    #[test]
    fn descriptive_capture_names_are_recognised() {
        let headers = [
            "time [s]",
            "Encoder Feedback X/x [mm]",
            "Encoder Feedback Y/y [mm]",
            "Feed Reference DataX/RefCommand",
            "Feed Reference DataY/RefCommand",
            "Velocity Reference X",
        ];
        let mapped = map_columns(&headers, None).unwrap();
        let index_of = |s: Signal| mapped.iter().find(|m| m.signal == s).map(|m| m.index);
        assert_eq!(index_of(Signal::X), Some(1));
        assert_eq!(index_of(Signal::Y), Some(2));
        assert_eq!(index_of(Signal::XCmd), Some(3));
        assert_eq!(index_of(Signal::YCmd), Some(4));
        assert_eq!(
            words("XIndex posX DataY"),
            ["x", "index", "pos", "x", "data", "y"]
        );
        // A speed, a following error or a name with both axes is never a position.
        for other in [
            "X set velocity",
            "Following error X",
            "XY reference",
            "Current X",
        ] {
            assert_eq!(described_signal(other), None, "{other}");
        }
        // Two columns that read alike are left to the user, never picked between.
        let twice = [
            "t",
            "x",
            "y",
            "X reference A",
            "X reference B",
            "Y reference",
        ];
        let mapped = map_columns(&twice, None);
        assert!(mapped.is_err() || mapped.unwrap().iter().all(|m| m.signal != Signal::XCmd));
    }

    #[test]
    fn dialects_are_sniffed() {
        let d = sniff("Zeit;X;Y", ["0,001;1,5;2"]);
        assert_eq!(d.delimiter, Delimiter::Byte(b';'));
        assert!(d.decimal_comma);
        assert_eq!(number("1,5", &d), Some(1.5));
        let d = sniff("t x y", ["0.1 1 2"]);
        assert_eq!(d.delimiter, Delimiter::Whitespace);
        assert_eq!(fields("  0.1   1\t2 ", d.delimiter), vec!["0.1", "1", "2"]);
        let d = sniff("t,x,y", ["0.1,1,2"]);
        assert!(!d.decimal_comma);
    }

    #[test]
    fn z_columns_are_read_where_a_file_has_them_and_never_refuse_it() {
        let index_of = |headers: &[&str], signal: Signal| {
            map_columns(headers, None)
                .unwrap()
                .iter()
                .find(|m| m.signal == signal)
                .map(|m| m.index)
        };
        // A SINUMERIK-style export with all three axes.
        let h = [
            "time",
            "pos_x",
            "pos_y",
            "pos_z",
            "cmd_pos_x",
            "cmd_pos_y",
            "cmd_pos_z",
        ];
        assert_eq!(index_of(&h, Signal::Z), Some(3));
        assert_eq!(index_of(&h, Signal::ZCmd), Some(6));
        // Descriptive names, one axis letter each.
        let h = ["t", "x", "y", "Encoder Feedback Z", "Z Reference"];
        assert_eq!(index_of(&h, Signal::Z), Some(3));
        assert_eq!(index_of(&h, Signal::ZCmd), Some(4));
        // Two columns that could each be Z: Z is left to a mapping, X and Y still read.
        let h = ["t", "x", "y", "z", "Z_pos"];
        assert_eq!(index_of(&h, Signal::Z), None);
        assert_eq!(index_of(&h, Signal::X), Some(1));
        // A file without Z reads as before.
        assert_eq!(index_of(&["t", "x", "y"], Signal::Z), None);
        // And a mapping may name it.
        let m = ColumnMap::parse("t=t,x=x,y=y,z=Z_pos[um]").unwrap();
        let mapped = map_columns(&h, Some(&m)).unwrap();
        let z = mapped.iter().find(|m| m.signal == Signal::Z).unwrap();
        assert_eq!((z.index, z.unit.to_si), (4, 1e-6));
    }
}
