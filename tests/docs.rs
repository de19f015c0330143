//! Documents generated from the code stay equal to it.

use std::collections::BTreeSet;
use std::fs;
use std::path::Path;

use contourcheck::machine::keys::reference_markdown;

/// `docs/machine-keys.md` is the key table's reference. Run with
/// `CONTOURCHECK_WRITE_DOCS=1` to write it after changing the table.
#[test]
fn the_machine_key_reference_is_the_key_table() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/machine-keys.md");
    let generated = reference_markdown();
    if std::env::var_os("CONTOURCHECK_WRITE_DOCS").is_some() {
        fs::write(&path, &generated).unwrap();
    }
    let on_disk = fs::read_to_string(&path).unwrap_or_default();
    assert!(
        on_disk == generated,
        "docs/machine-keys.md differs from the key table: run \
         `CONTOURCHECK_WRITE_DOCS=1 cargo test --release --test docs` and commit it"
    );
}

/// Every key the reference lists is one a machine file accepts: each is set in a file of
/// its own on the preset that has its section, and read back.
#[test]
fn every_listed_key_is_read_from_a_machine_file() {
    use contourcheck::machine::MachineConfig;
    use contourcheck::machine::keys::{get_on_machine, machine_paths};
    for path in machine_paths() {
        let preset = ["hvmc", "small-table"]
            .into_iter()
            .find(|p| get_on_machine(&MachineConfig::preset(p).unwrap(), &path).is_some());
        let Some(preset) = preset else { continue };
        let base = MachineConfig::preset(preset).unwrap();
        let value = get_on_machine(&base, &path).unwrap();
        let (section, leaf) = path.rsplit_once('.').unwrap();
        let text = format!("base = \"{preset}\"\n[{section}]\n{leaf} = {value:?}\n");
        let m = MachineConfig::from_toml_str(&text, "keys.toml")
            .unwrap_or_else(|e| panic!("{path}: {e}"));
        assert_eq!(get_on_machine(&m, &path), Some(value), "{path}");
    }
}

/// One row of a report's table in `docs/report-schema.md`: the full paths its field cell
/// names (object keys, arrays' `[]` left out; `.rms` after `contour_error_um.max` is
/// `contour_error_um.rms`; a last key `…` stands for every key below) and the words its
/// other cells put in backticks — the keys below those paths it names.
struct Row {
    paths: Vec<Vec<String>>,
    words: BTreeSet<String>,
}

/// One report's table in `docs/report-schema.md`.
struct Schema {
    rows: Vec<Row>,
}

/// The words within backticks of `text`, split at anything but letters, digits and `_`.
fn backticked_words(text: &str) -> impl Iterator<Item = String> + '_ {
    text.split('`')
        .skip(1)
        .step_by(2)
        .flat_map(|t| t.split(|c: char| !(c.is_ascii_alphanumeric() || c == '_')))
        .filter(|w| !w.is_empty())
        .map(str::to_string)
}

/// A field's path as keys: `hotspots[].cause.kind` → hotspots, cause, kind; one that
/// starts with `.` replaces the last key of `previous`.
fn field_path(token: &str, previous: &[String]) -> Vec<String> {
    let keys = token
        .split('.')
        .filter(|k| !k.is_empty())
        .map(|k| k.split('[').next().unwrap_or(k).to_string());
    if token.starts_with('.') {
        let stem = &previous[..previous.len().saturating_sub(1)];
        stem.iter().cloned().chain(keys).collect()
    } else {
        keys.collect()
    }
}

impl Schema {
    /// The table under the level-one heading that names `report`.
    fn of(doc: &str, report: &str) -> Schema {
        let mut schema = Schema { rows: Vec::new() };
        let mut inside = false;
        let mut previous: Vec<String> = Vec::new();
        for line in doc.lines() {
            if let Some(heading) = line.strip_prefix("# ") {
                inside = heading.contains(report);
                continue;
            }
            if !inside || !line.starts_with('|') {
                continue;
            }
            let (field, rest) = line[1..].split_once(" | ").unwrap_or(("", ""));
            let mut paths = Vec::new();
            for token in field.split('`').skip(1).step_by(2) {
                let path = field_path(token, &previous);
                previous.clone_from(&path);
                paths.push(path);
            }
            if paths.is_empty() {
                continue;
            }
            let words = backticked_words(rest).collect();
            schema.rows.push(Row { paths, words });
        }
        assert!(!schema.rows.is_empty(), "no table for {report}");
        schema
    }

    /// Whether `path` (object keys, arrays left out) is described by its full path: a row
    /// names it, or a key below it (it is that key's object), or a path above it whose row
    /// names each of the keys between. A row's words are taken as a set, not in their
    /// nesting (`loops[]: e`): a key filed under the wrong object of a row that names both
    /// still passes — the check finds keys the document leaves out, not misplaced ones.
    fn describes(&self, path: &[String]) -> bool {
        self.rows.iter().any(|row| {
            row.paths.iter().any(|field| {
                let (field, every_key_below) = match field.split_last() {
                    Some((last, stem)) if last == "…" => (stem, true),
                    _ => (&field[..], false),
                };
                if field.starts_with(path) {
                    return true;
                }
                path.starts_with(field)
                    && (every_key_below
                        || path[field.len()..].iter().all(|k| row.words.contains(k)))
            })
        })
    }
}

/// Every path of object keys in `value`, array elements merged.
fn key_paths(value: &serde_json::Value, at: &mut Vec<String>, out: &mut BTreeSet<Vec<String>>) {
    match value {
        serde_json::Value::Object(map) => {
            for (k, v) in map {
                at.push(k.clone());
                out.insert(at.clone());
                key_paths(v, at, out);
                at.pop();
            }
        }
        serde_json::Value::Array(items) => items.iter().for_each(|v| key_paths(v, at, out)),
        _ => {}
    }
}

/// The JSON report the binary writes with `args` and `--json`, in `dir`.
fn report(dir: &Path, name: &str, args: &[&str]) -> serde_json::Value {
    let json = dir.join(name);
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_contourcheck"))
        .args(args)
        .arg("--json")
        .arg(&json)
        .env("CI", "1")
        .output()
        .unwrap();
    assert!(
        matches!(out.status.code(), Some(0 | 1)),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_str(&fs::read_to_string(&json).unwrap()).unwrap()
}

/// Another report's schema, and the path there of a key this report's table describes as
/// that report's (`None` for a key it does not).
type Elsewhere<'a> = Option<(&'a Schema, fn(&[String]) -> Option<Vec<String>>)>;

/// The keys of `report` that `schema` does not describe, nor `elsewhere`.
fn undescribed(report: &serde_json::Value, schema: &Schema, elsewhere: Elsewhere) -> Vec<String> {
    let mut paths = BTreeSet::new();
    key_paths(report, &mut Vec::new(), &mut paths);
    paths
        .into_iter()
        .filter(|path| {
            !schema.describes(path)
                && !elsewhere
                    .is_some_and(|(other, map)| map(path).is_some_and(|p| other.describes(&p)))
        })
        .map(|path| path.join("."))
        .collect()
}

/// diagnose's circular-test figures (`circular_test.measured`, …) as check's `circular_test`.
fn as_check_circular_test(p: &[String]) -> Option<Vec<String>> {
    (p.len() > 2 && p[0] == "circular_test").then(|| [&p[..1], &p[2..]].concat())
}

/// identify's `coverage`, as diagnose's.
fn as_diagnose_coverage(p: &[String]) -> Option<Vec<String>> {
    (p[0] == "coverage").then(|| p.to_vec())
}

/// Runs the binary with `args`, which must succeed.
fn run_ok(args: &[&str]) {
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_contourcheck"))
        .args(args)
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
}

/// `docs/report-schema.md` describes every key the reports write, each by its full path:
/// check's of a program in the plane and of one that moves Z along the contour, diagnose's
/// and identify's of a record with backlash on X, sweep's of two gains.
#[test]
fn the_report_schema_describes_every_key_the_reports_write() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let doc = fs::read_to_string(root.join("docs/report-schema.md")).unwrap();
    let [check, diagnose, identify, sweep] = [
        "contourcheck.check/",
        "contourcheck.diagnose/",
        "contourcheck.identify/",
        "contourcheck.sweep/",
    ]
    .map(|r| Schema::of(&doc, r));
    let dir = std::env::temp_dir().join(format!("report-schema-{}", std::process::id()));
    fs::create_dir_all(&dir).unwrap();
    let sample = |name: &str| root.join("gcode-samples").join(name);
    let path = |p: &Path| p.to_str().unwrap().to_string();
    let programs = ["square.nc", "helix-zx.nc", "circle-test.nc"].map(|p| path(&sample(p)));
    let [square, helix, circle] = programs.each_ref().map(String::as_str);
    let mut missing = Vec::new();
    for program in [square, helix] {
        let r = report(&dir, "check.json", &["check", program]);
        missing.extend(undescribed(&r, &check, None));
    }
    let record = path(&dir.join("backlash.csv"));
    let record = record.as_str();
    run_ok(&[
        "synth", circle, "--out", record, "--effect", "backlash", "--axis", "x", "--values", "8",
    ]);
    let r = report(
        &dir,
        "diagnose.json",
        &["diagnose", circle, "--measured", record],
    );
    missing.extend(undescribed(
        &r,
        &diagnose,
        Some((&check, as_check_circular_test)),
    ));
    // identify reads the commands from the record.
    let recorded = path(&dir.join("backlash-with-commands.csv"));
    let recorded = recorded.as_str();
    run_ok(&[
        "synth",
        circle,
        "--out",
        recorded,
        "--effect",
        "backlash",
        "--axis",
        "x",
        "--values",
        "8",
        "--with-commands",
    ]);
    let machine = path(&dir.join("identified.toml"));
    let identified = [
        "identify",
        circle,
        "--measured",
        recorded,
        "--template",
        "hvmc",
        "--out",
        &machine,
    ];
    let r = report(&dir, "identify.json", &identified);
    missing.extend(undescribed(
        &r,
        &identify,
        Some((&diagnose, as_diagnose_coverage)),
    ));
    let swept = ["sweep", square, "--axis", "xy", "--kv", "0.8,1.2"];
    let r = report(&dir, "sweep.json", &swept);
    missing.extend(undescribed(&r, &sweep, None));
    let _ = fs::remove_dir_all(&dir);
    missing.sort();
    missing.dedup();
    assert!(
        missing.is_empty(),
        "docs/report-schema.md does not describe: {missing:?}"
    );
}

/// A key is described by its full path only: below a row's field, by a word of that row;
/// not by a word of the prose, nor by a row under another field that happens to name it.
#[test]
fn a_schema_describes_a_key_by_its_full_path() {
    let doc = "# `r --json`, schema `r/1`\n\nProse naming `c` and `d`.\n\n\
               | field | type | meaning |\n|---|---|---|\n\
               | `a[].b` | object | `c`, `loops[]`: `e` |\n\
               | `a[].f`, `.g` | number | `d` |\n\
               | `h.…` | number | anything below |\n";
    let schema = Schema::of(doc, "r/");
    let keys = |p: &str| p.split('.').map(str::to_string).collect::<Vec<_>>();
    for described in [
        "a",
        "a.b",
        "a.b.c",
        "a.b.loops.e",
        "a.f",
        "a.g",
        "a.g.d",
        "h.x.y",
    ] {
        assert!(schema.describes(&keys(described)), "{described}");
    }
    for not in ["b", "a.c", "a.b.d", "a.f.c", "c", "a.i"] {
        assert!(!schema.describes(&keys(not)), "{not}");
    }
}
