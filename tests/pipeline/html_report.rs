//! The HTML reports of `check`, `diagnose` and `identify`: every figure on the page is the
//! JSON report's (read back from the page's markup), the page is self-contained and prints
//! on A4, and headless Chromium renders it — not blank, no error logged.

use crate::common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use scraper::{Html, Selector};
use serde_json::Value;

use common::cli::{read_json, run_ok, run_to_a_verdict, sample, synth_backlash_on_x};

/// The value at a dotted key with indices (`hotspots[0].error_um`).
fn lookup<'a>(json: &'a Value, key: &str) -> &'a Value {
    let mut at = json;
    for part in key.split('.') {
        let mut pieces = part.split('[');
        let name = pieces.next().unwrap();
        at = &at[name];
        for index in pieces {
            at = &at[index.trim_end_matches(']').parse::<usize>().unwrap()];
        }
    }
    at
}

/// Every figure on the page, (key, exact value, shown text), checked against the JSON
/// report: the exact value is the report's, the text is it rounded to the digits shown.
fn figures_match(page: &Html, json: &Value) -> Vec<String> {
    let selector = Selector::parse("[data-key]").unwrap();
    let mut keys = Vec::new();
    for el in page.select(&selector) {
        let key = el.value().attr("data-key").unwrap();
        let value = el.value().attr("data-value").unwrap();
        let text: String = el.text().collect();
        let expected = lookup(json, key);
        match expected {
            Value::Number(n) => {
                let exact: f64 = value.parse().unwrap_or_else(|_| panic!("{key}: {value}"));
                // serde_json's reader rounds a decimal to within an ulp of the nearest double.
                let reported = n.as_f64().unwrap();
                assert!(
                    (exact - reported).abs() <= f64::EPSILON * reported.abs(),
                    "{key}: {exact} on the page, {reported} in the report"
                );
                let shown: f64 = text
                    .trim()
                    .parse()
                    .unwrap_or_else(|_| panic!("{key}: {text}"));
                let decimals = text.trim().split('.').nth(1).map_or(0, str::len) as i32;
                assert!(
                    (shown - exact).abs() <= 0.5 * 10f64.powi(-decimals) + 1e-12,
                    "{key}: shown {text}, report {exact}"
                );
            }
            Value::String(s) => {
                assert_eq!(value, s, "{key}");
                assert_eq!(text.trim(), s, "{key}");
            }
            Value::Bool(b) => assert_eq!(value, b.to_string(), "{key}"),
            Value::Null => assert!(value.is_empty() || value == "null", "{key}: {value}"),
            other => panic!("{key}: a figure is a number, text or flag, not {other}"),
        }
        keys.push(key.to_string());
    }
    keys
}

/// Nothing on the page is fetched: no scripts, styles or images from elsewhere.
fn assert_self_contained(text: &str) {
    let page = Html::parse_document(text);
    let external = Selector::parse("script[src], link[href], img[src], iframe, object").unwrap();
    assert_eq!(
        page.select(&external).count(),
        0,
        "the page loads something"
    );
    assert!(text.contains("@page { size: A4"), "no A4 page size");
    assert_prints_compactly(text);
    for url in ["http://", "https://"] {
        let outside: Vec<&str> = text
            .match_indices(url)
            .map(|(i, _)| &text[i..(i + 40).min(text.len())])
            .filter(|u| !u.starts_with("http://www.w3.org/"))
            .collect();
        assert!(outside.is_empty(), "addresses on the page: {outside:?}");
    }
}

/// The millimetres of the first `name: …mm` declaration in `css` after `from` (the first
/// length where the declaration lists several).
fn mm_after(css: &str, from: &str, name: &str) -> f64 {
    let rest = &css[css.find(from).unwrap_or_else(|| panic!("no {from:?}"))..];
    let value = &rest[rest.find(&format!("{name}:")).unwrap() + name.len() + 1..];
    let first = value.split_whitespace().next().unwrap();
    first
        .trim_end_matches(';')
        .strip_suffix("mm")
        .unwrap_or_else(|| panic!("{name}: {first} is not in mm"))
        .parse()
        .unwrap()
}

/// The page prints compactly: on paper no figure is split across pages, no section is
/// pushed onto a page of its own, and two figures with their captions and a heading share
/// an A4 page — a plot is 3:2, at the page's full width taller than half its height (297 mm
/// less the `@page` margins), so its print height is held below that.
fn assert_prints_compactly(text: &str) {
    let print = &text[text.find("@media print").expect("print rules")..];
    assert!(
        print.contains("break-inside: avoid") && print.contains("page-break-inside: avoid"),
        "a figure may split across pages"
    );
    assert!(!text.contains("break-before: page"), "a forced page break");
    let page_mm = 297.0 - 2.0 * mm_after(text, "@page", "margin");
    let figure_mm = mm_after(print, "figure {", "margin");
    let svg_mm = mm_after(print, "figure svg", "max-height");
    // A caption's two lines at 8.5 pt, 1 mm above; a heading's line at 11.5 pt with its
    // 4 + 1.5 mm margins and its 1 px rule (0.26 mm); lines 1.25 of their font (1 pt is
    // 25.4/72 mm).
    let line_mm = |pt: f64| 1.25 * pt * 25.4 / 72.0;
    let caption_mm = 2.0 * line_mm(8.5) + 1.0;
    let heading_mm = line_mm(11.5) + 4.0 + 1.5 + 25.4 / 96.0;
    let two = 2.0 * (svg_mm + 2.0 * figure_mm + caption_mm) + heading_mm;
    assert!(
        two <= page_mm,
        "two figures take {two} mm of a {page_mm} mm page"
    );
}

fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap()
}

#[test]
fn the_check_report_shows_the_json_figures() {
    let dir = tempfile::tempdir().unwrap();
    let (json, html) = (dir.path().join("r.json"), dir.path().join("r.html"));
    let circle = sample("circle-test.nc");
    let o = run_to_a_verdict(&[
        "check",
        circle.to_str().unwrap(),
        "--json",
        json.to_str().unwrap(),
        "--report",
        html.to_str().unwrap(),
        "--tolerance",
        "4",
    ]);
    assert_eq!(o.status.code(), Some(1), "5.07 µm exceeds 4 µm");
    let report = read_json(&json);
    // The pair of circles in XY names its plane, as each of its circles does.
    let pair = &report["circular_test"]["pairs"][0];
    assert_eq!(pair["plane"], "XY", "{pair}");
    assert_eq!(report["circular_test"]["circles"][0]["plane"], "XY");
    let text = read(&html);
    assert_self_contained(&text);
    let page = Html::parse_document(&text);
    let keys = figures_match(&page, &report);
    for key in [
        "contour_error_um.max",
        "contour_error_um.rms",
        "within_tolerance",
        "tolerance_um",
        "circular_test.circles[0].g_um",
        "circular_test.circles[0].plane",
        "circular_test.circles[1].f_min_um",
        "circular_test.pairs[0].h_um",
        "hotspots[0].error_um",
        "hotspots[0].line",
        "hotspots[0].label",
    ] {
        assert!(keys.iter().any(|k| k == key), "{key} not on the page");
    }
    let shown = keys.iter().filter(|k| k.ends_with("].rank")).count();
    let hotspots = report["hotspots"].as_array().unwrap().len();
    assert_eq!(shown, hotspots.min(20));
    let fail = Selector::parse(".verdict.fail").unwrap();
    assert_eq!(page.select(&fail).count(), 1, "the tolerance's verdict");
    // The polar plot of the pair, the toolpath, the error along the path.
    assert_eq!(text.matches("<svg").count(), 3);
    for condition in [
        "program",
        "machine",
        "programmed feed",
        "sampling",
        "date",
        "tool version",
    ] {
        assert!(
            text.contains(&format!("<th>{condition}</th>")),
            "{condition}"
        );
    }
    let words: String = page.root_element().text().collect();
    assert!(
        words.contains("F500 to F1000 mm/min (2 feeds)"),
        "the program's two feeds"
    );
    assert_renders(&html);
}

/// A record with 8 µm of backlash hidden on X, diagnosed with a JSON and an HTML report.
fn diagnosed(dir: &Path) -> (Value, String) {
    let record = dir.join("m.csv");
    let circle = sample("circle-test.nc");
    synth_backlash_on_x(&circle, &record, "8");
    let (json, html) = (dir.join("d.json"), dir.join("d.html"));
    run_to_a_verdict(&[
        "diagnose",
        circle.to_str().unwrap(),
        "--measured",
        record.to_str().unwrap(),
        "--json",
        json.to_str().unwrap(),
        "--report",
        html.to_str().unwrap(),
    ]);
    (read_json(&json), read(&html))
}

#[test]
fn the_diagnose_report_ranks_the_causes_with_their_uncertainties() {
    let dir = tempfile::tempdir().unwrap();
    let (report, text) = diagnosed(dir.path());
    assert_self_contained(&text);
    let keys = figures_match(&Html::parse_document(&text), &report);
    assert_eq!(report["causes"][0]["id"], "backlash");
    for key in [
        "causes[0].id",
        "causes[0].params[0].value",
        "causes[0].params[0].uncertainty",
        "causes[0].gain_percent.rms",
        "causes[0].held_out.rms_after_um",
        "residual.nominal.x.rms_um",
        "residual.extended.contour.rms_um",
        "circular_test.measured.circles[0].g_um",
    ] {
        assert!(keys.iter().any(|k| k == key), "{key} not on the page");
    }
    assert!(text.contains("What to do:"));
    assert!(
        text.matches("<svg").count() >= 4,
        "fit, residual, two circles"
    );
    assert_renders(&dir.path().join("d.html"));
}

/// The hvmc cascade with X's position gain 1.2 m/min/mm, recorded with its commands,
/// identified from the preset.
fn identified(dir: &Path) -> (Value, String) {
    let truth = dir.join("truth.toml");
    std::fs::write(
        &truth,
        "base = \"hvmc\"\n[x.position_loop]\nkv_m_per_min_per_mm = 1.2\n",
    )
    .unwrap();
    let record = dir.join("r.csv");
    let circle = sample("small-circle.nc");
    run_ok(&[
        "synth",
        circle.to_str().unwrap(),
        "--machine",
        truth.to_str().unwrap(),
        "--with-commands",
        "--noise-um",
        "0.05",
        "--out",
        record.to_str().unwrap(),
    ]);
    let (json, html, out) = (dir.join("i.json"), dir.join("i.html"), dir.join("m.toml"));
    run_to_a_verdict(&[
        "identify",
        circle.to_str().unwrap(),
        "--measured",
        record.to_str().unwrap(),
        "--template",
        "hvmc",
        "--out",
        out.to_str().unwrap(),
        "--json",
        json.to_str().unwrap(),
        "--report",
        html.to_str().unwrap(),
    ]);
    (read_json(&json), read(&html))
}

#[test]
fn the_identify_report_sets_the_template_against_the_identified_values() {
    let dir = tempfile::tempdir().unwrap();
    let (report, text) = identified(dir.path());
    assert_self_contained(&text);
    let keys = figures_match(&Html::parse_document(&text), &report);
    let values = report["axes"][0]["values"].as_array().unwrap().len();
    for k in 0..values {
        for field in ["template", "value", "uncertainty"] {
            let key = format!("axes[0].values[{k}].{field}");
            assert!(keys.contains(&key), "{key} not on the page");
        }
    }
    for key in [
        "axes[0].held_out_template_um",
        "axes[0].held_out_identified_um",
    ] {
        assert!(keys.iter().any(|k| k == key), "{key} not on the page");
    }
    let kv = &report["axes"][0]["values"][0];
    assert_eq!(kv["key"], "position_loop.kv_m_per_min_per_mm");
    assert!(
        (kv["value"].as_f64().unwrap() - 1.2).abs() < 3.0 * kv["uncertainty"].as_f64().unwrap()
    );
    assert_renders(&dir.path().join("i.html"));
}

/// Headless Chromium, as this machine runs it: where it is not installed the test says so.
fn chromium() -> Option<PathBuf> {
    let path = std::env::var_os("CONTOURCHECK_CHROMIUM")
        .map_or_else(|| PathBuf::from("/usr/bin/chromium"), PathBuf::from);
    path.exists().then_some(path)
}

/// Seconds one rendering may take: a page renders in a few; headless Chromium now and then
/// stalls on its screenshot with nothing to do (seen on a page it rendered in seconds on
/// other runs), and a stalled browser must fail or retry, never hold the suite.
const RENDER_LIMIT_S: u32 = 60;

/// Headless Chromium's screenshot of `page` into `shot`, under `timeout` (which stops the
/// browser's whole process group): a stalled run is tried again, up to three times, each in a
/// fresh profile.
fn screenshot(chromium: &Path, page: &Path, profile: &Path, shot: &Path) -> Output {
    for attempt in 1..=3 {
        let user_data = profile.join(format!("profile-{attempt}"));
        let o = Command::new("timeout")
            .args(["-k", "5", &RENDER_LIMIT_S.to_string()])
            .arg(chromium)
            .args([
                "--headless",
                "--no-sandbox",
                "--disable-gpu",
                "--disable-quic",
                "--no-first-run",
                "--disable-background-networking",
                "--disable-component-update",
                "--disable-sync",
                "--hide-scrollbars",
                "--enable-logging=stderr",
                "--v=0",
                "--window-size=900,1800",
            ])
            .arg(format!("--user-data-dir={}", user_data.display()))
            .arg(format!("--screenshot={}", shot.display()))
            .arg(format!("file://{}", page.display()))
            .output()
            .unwrap();
        // `timeout` exits 124 when it stopped the browser, 137 when it had to kill it.
        if !matches!(o.status.code(), Some(124 | 137)) {
            return o;
        }
        eprintln!(
            "chromium stalled on {} (attempt {attempt}); again",
            page.display()
        );
    }
    panic!(
        "headless chromium did not render {} within {RENDER_LIMIT_S} s, three times",
        page.display()
    );
}

/// Renders `page` in headless Chromium: the screenshot is not blank and the page logged no
/// error (no console message, no resource that failed to load).
fn assert_renders(page: &Path) {
    let Some(chromium) = chromium() else {
        eprintln!("skipped: chromium not present");
        return;
    };
    let profile = tempfile::tempdir().unwrap();
    let shot = profile.path().join("shot.png");
    let o = screenshot(&chromium, page, profile.path(), &shot);
    let log = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "chromium failed: {log}");
    let page_errors: Vec<&str> = log
        .lines()
        .filter(|l| l.contains("CONSOLE") || l.contains("Failed to load") || l.contains("Uncaught"))
        .collect();
    assert!(page_errors.is_empty(), "the page logged: {page_errors:?}");
    let decoder = png::Decoder::new(std::fs::File::open(&shot).unwrap());
    let mut reader = decoder.read_info().unwrap();
    let mut pixels = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut pixels).unwrap();
    let channels = info.color_type.samples();
    let inked = pixels[..info.buffer_size()]
        .chunks(channels)
        .filter(|p| p.iter().take(3).any(|&c| c < 200))
        .count();
    let share = inked as f64 / (info.width * info.height) as f64;
    assert!(
        share > 0.01,
        "the page is blank ({:.4} of the pixels inked)",
        share
    );
}
