//! The footer every plot carries: what it was made of and when — the machine, the program,
//! its feed, the sampling, the date and the tool's version — so that a figure cut out of a
//! report still says what it shows.

#[cfg(feature = "cli")]
use plotters::{coord::Shift, prelude::*};

#[cfg(feature = "cli")]
use super::{FONT, err};

/// Height of the footer strip (px).
pub const FOOTER_PX: u32 = 30;

/// The conditions a plot was made under. Empty fields are left out of the text.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Footer {
    /// The machine's name (or its file).
    pub machine: String,
    /// The program's file name, where there is one.
    pub program: String,
    /// The programmed feed, e.g. `F 1000 mm/min` or `F 500–1000 mm/min`.
    pub feed: String,
    /// The sampling, e.g. `IPO cycle 2 ms` or `record at 10 kHz`.
    pub sampling: String,
    /// The date the plot was made (YYYY-MM-DD, UTC).
    pub date: String,
    /// The tool and its version.
    pub version: String,
}

#[cfg(feature = "cli")]
impl Footer {
    /// A footer for a plot of `machine`, dated today, with this tool's version.
    pub(crate) fn new(machine: &str) -> Self {
        Footer {
            machine: machine.to_string(),
            date: today(),
            version: format!("contourcheck {}", env!("CARGO_PKG_VERSION")),
            ..Footer::default()
        }
    }

    /// The same footer naming `program` (its file name only).
    pub(crate) fn program(mut self, program: &str) -> Self {
        self.program = std::path::Path::new(program)
            .file_name()
            .map_or_else(|| program.to_string(), |n| n.to_string_lossy().into_owned());
        self
    }

    /// The same footer with the feed as written.
    pub(crate) fn feed(mut self, feed: impl Into<String>) -> Self {
        self.feed = feed.into();
        self
    }

    /// The same footer with the sampling as written.
    pub(crate) fn sampling(mut self, sampling: impl Into<String>) -> Self {
        self.sampling = sampling.into();
        self
    }

    /// The footer's line: `machine hvmc · program circle-test.nc · F 1000 mm/min · IPO
    /// cycle 2 ms · 2025-01-31 · contourcheck 0.1.0`.
    pub(crate) fn text(&self) -> String {
        let named = |what: &str, v: &str| (!v.is_empty()).then(|| format!("{what} {v}"));
        [
            named("machine", &self.machine),
            named("program", &self.program),
            (!self.feed.is_empty()).then(|| self.feed.clone()),
            (!self.sampling.is_empty()).then(|| self.sampling.clone()),
            (!self.date.is_empty()).then(|| self.date.clone()),
            (!self.version.is_empty()).then(|| self.version.clone()),
        ]
        .into_iter()
        .flatten()
        .collect::<Vec<_>>()
        .join("  ·  ")
    }
}

#[cfg(feature = "cli")]
/// Today's date (UTC), or the date of `SOURCE_DATE_EPOCH` where it is set, so that a
/// build that must be reproducible can fix it.
pub(crate) fn today() -> String {
    let fixed = std::env::var("SOURCE_DATE_EPOCH")
        .ok()
        .and_then(|s| s.trim().parse::<i64>().ok())
        .and_then(|secs| time::OffsetDateTime::from_unix_timestamp(secs).ok());
    date_of(fixed.unwrap_or_else(time::OffsetDateTime::now_utc))
}

#[cfg(feature = "cli")]
/// A moment's date as YYYY-MM-DD.
fn date_of(t: time::OffsetDateTime) -> String {
    let format = time::macros::format_description!("[year]-[month]-[day]");
    t.format(&format).unwrap_or_default()
}

#[cfg(feature = "cli")]
/// Draws `footer` along the bottom of `root` — a thin rule and the line of text, left
/// aligned — and returns the area above it for the figure.
pub(crate) fn draw_footer<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    footer: &Footer,
) -> Result<DrawingArea<DB, Shift>, String> {
    let (_, h) = root.dim_in_pixel();
    let (upper, strip) = root.split_vertically(h.saturating_sub(FOOTER_PX));
    let (w, _) = strip.dim_in_pixel();
    strip
        .draw(&PathElement::new(
            vec![(8, 1), (w as i32 - 8, 1)],
            BLACK.mix(0.3),
        ))
        .map_err(err)?;
    let text = fit_to_width(&footer.text(), w.saturating_sub(20), FOOTER_FONT_PX);
    strip
        .draw(&Text::new(
            text,
            (10, 8),
            (FONT, FOOTER_FONT_PX).into_font().color(&BLACK.mix(0.7)),
        ))
        .map_err(err)?;
    Ok(upper)
}

#[cfg(feature = "cli")]
/// Font size of the footer (px).
const FOOTER_FONT_PX: u32 = 14;

#[cfg(feature = "cli")]
/// `text` cut with an ellipsis where it would run past `width_px`.
fn fit_to_width(text: &str, width_px: u32, font_px: u32) -> String {
    let fits = |t: &str| super::labels::text_width(t, font_px) <= width_px as i32;
    if fits(text) {
        return text.to_string();
    }
    let mut chars: Vec<char> = text.chars().collect();
    while !chars.is_empty() && !fits(&format!("{}…", chars.iter().collect::<String>())) {
        chars.pop();
    }
    format!("{}…", chars.iter().collect::<String>())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_footer_names_every_condition_given_and_skips_the_rest() {
        let f = Footer {
            machine: "hvmc".into(),
            program: "circle-test.nc".into(),
            feed: "F 1000 mm/min".into(),
            sampling: "IPO cycle 2 ms".into(),
            date: "2025-01-31".into(),
            version: "contourcheck 0.1.0".into(),
        };
        assert_eq!(
            f.text(),
            "machine hvmc  ·  program circle-test.nc  ·  F 1000 mm/min  ·  IPO cycle 2 ms  ·  \
             2025-01-31  ·  contourcheck 0.1.0"
        );
        let bare = Footer::new("small-table");
        assert!(bare.text().starts_with("machine small-table  ·  "));
        assert!(bare.text().ends_with(env!("CARGO_PKG_VERSION")));
        assert_eq!(Footer::new("m").program("/a/b/part.nc").program, "part.nc");
        // A long footer is cut to its strip, not drawn past it.
        let cut = fit_to_width(&"x".repeat(500), 300, 14);
        assert!(super::super::labels::text_width(&cut, 14) <= 300 && cut.ends_with('…'));
    }

    #[test]
    fn a_fixed_source_date_fixes_the_footers_date() {
        // 2021-03-04 00:00:00 UTC.
        let secs = 1_614_816_000;
        let date = date_of(time::OffsetDateTime::from_unix_timestamp(secs).unwrap());
        assert_eq!(date, "2021-03-04");
        assert_eq!(today().len(), 10);
    }
}
