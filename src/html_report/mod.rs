//! One-page HTML reports of a check, a diagnosis and an identification: a self-contained
//! file (styles inline, plots as inline SVG, nothing fetched) to hand over, printable on A4
//! from a browser.
//!
//! Each page is a `minijinja` template (`templates/`) filled with a view of the run: every
//! figure it shows carries the JSON report's key (`data-key`, e.g. `contour_error_um.max`)
//! and its exact value (`data-value`) beside the rounded text, so that a script (and the
//! tests) can read the page back and find the JSON report's figures in it.

mod check;
mod diagnose;
mod identify;

use minijinja::{Environment, Value};
use serde::Serialize;
use serde_json::Value as Json;

pub use check::check_page;
pub use diagnose::diagnose_page;
pub use identify::identify_page;

/// A report that could not be made.
#[derive(Debug, thiserror::Error)]
pub enum HtmlError {
    /// A template failed to render (a defect of the templates).
    #[error("HTML report: {0}")]
    Template(#[from] minijinja::Error),
    /// A plot could not be drawn.
    #[error("HTML report: plot: {0}")]
    Plot(String),
    /// The JSON report the page is read from could not be made.
    #[error("HTML report: {0}")]
    Json(#[from] serde_json::Error),
}

/// What a page says of its inputs beyond what the run holds.
#[derive(Debug, Clone, Default)]
pub struct Inputs {
    /// The machine file's path; `None` for an embedded preset or a machine given as text.
    pub machine_file: Option<String>,
}

impl Inputs {
    /// The machine's source in words: its file, or the preset it is.
    fn machine_source(&self, name: &str) -> String {
        match &self.machine_file {
            Some(path) => path.clone(),
            None => format!("embedded preset or given as text ({name})"),
        }
    }
}

/// A figure on a page: the JSON report's key, its exact value, the text shown.
#[derive(Debug, Clone, Serialize)]
struct Fig {
    key: String,
    value: String,
    text: String,
}

/// The figure at `key` of the JSON report (`hotspots[0].error_um`), shown with `decimals`
/// decimals; a missing or non-numeric value (a `null`) shows as "—".
fn fig(json: &Json, key: &str, decimals: usize) -> Fig {
    let value = lookup(json, key);
    let text = match value.and_then(Json::as_f64) {
        Some(v) => format!("{v:.decimals$}"),
        None => match value {
            Some(Json::Bool(b)) => b.to_string(),
            Some(Json::String(s)) => s.clone(),
            _ => "—".to_string(),
        },
    };
    Fig {
        key: key.to_string(),
        value: value.map_or_else(String::new, |v| match v {
            Json::String(s) => s.clone(),
            other => other.to_string(),
        }),
        text,
    }
}

impl Fig {
    /// A figure the report does not have (a model's path without it): no key, shown "—".
    fn missing() -> Fig {
        Fig {
            key: String::new(),
            value: String::new(),
            text: "—".to_string(),
        }
    }
}

/// Decimals that show a value to its standard uncertainty's second significant digit (4
/// where there is no uncertainty).
fn decimals_for(uncertainty: f64) -> usize {
    if uncertainty.is_finite() && uncertainty > 0.0 {
        (1 - uncertainty.log10().floor() as i32).clamp(0, 12) as usize
    } else {
        4
    }
}

/// The value at a dotted key with indices (`circular_test.circles[1].g_um`).
fn lookup<'a>(json: &'a Json, key: &str) -> Option<&'a Json> {
    let pointer: String = key
        .split('.')
        .flat_map(|part| part.split('['))
        .map(|p| format!("/{}", p.trim_end_matches(']')))
        .collect();
    json.pointer(&pointer)
}

/// A label and a value, for the test conditions.
#[derive(Debug, Clone, Serialize)]
struct Row {
    label: &'static str,
    value: String,
}

/// A drawn figure and its caption.
#[derive(Debug, Clone, Serialize)]
struct Svg {
    caption: String,
    svg: Value,
}

/// Draws a figure as inline SVG.
fn svg(caption: impl Into<String>, figure: &impl crate::plot::Figure) -> Result<Svg, HtmlError> {
    let text = crate::plot::svg_text(figure).map_err(HtmlError::Plot)?;
    Ok(Svg {
        caption: caption.into(),
        // Drawn by plotters from numbers and our own labels, which it escapes.
        svg: Value::from_safe_string(text),
    })
}

/// When the page was made (UTC, to the minute) and by which version.
#[derive(Debug, Clone, Serialize)]
struct Made {
    date: String,
    version: &'static str,
}

impl Made {
    fn now() -> Made {
        let format = time::macros::format_description!("[year]-[month]-[day] [hour]:[minute] UTC");
        Made {
            date: time::OffsetDateTime::now_utc()
                .format(&format)
                .unwrap_or_default(),
            version: env!("CARGO_PKG_VERSION"),
        }
    }
}

/// The templates, parsed once per page (a page is made once per run).
fn environment() -> Environment<'static> {
    let mut env = Environment::new();
    for (name, text) in [
        ("base.html", include_str!("templates/base.html")),
        ("check.html", include_str!("templates/check.html")),
        ("diagnose.html", include_str!("templates/diagnose.html")),
        ("identify.html", include_str!("templates/identify.html")),
    ] {
        env.add_template(name, text)
            .expect("the embedded templates parse (tested)");
    }
    env
}

/// Renders `template` with `page`.
fn render(template: &str, page: impl Serialize) -> Result<String, HtmlError> {
    let env = environment();
    Ok(env
        .get_template(template)?
        .render(Value::from(minijinja::value::Serde(page)))?)
}

/// A file's name without its folder.
fn file_name(path: &str) -> String {
    std::path::Path::new(path)
        .file_name()
        .map_or_else(|| path.to_string(), |n| n.to_string_lossy().into_owned())
}
