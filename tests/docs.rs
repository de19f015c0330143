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

/// One report's part of `docs/report-schema.md`: its table's rows (the keys a row's field
/// names first, and every word the row puts in backticks) and the words its prose does.
struct Schema {
    rows: Vec<(BTreeSet<String>, BTreeSet<String>)>,
    prose: BTreeSet<String>,
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

impl Schema {
    /// The part of the document under the level-one heading that names `report`.
    fn of(doc: &str, report: &str) -> Schema {
        let mut schema = Schema {
            rows: Vec::new(),
            prose: BTreeSet::new(),
        };
        let mut inside = false;
        for line in doc.lines() {
            if let Some(heading) = line.strip_prefix("# ") {
                inside = heading.contains(report);
                continue;
            }
            if !inside {
                continue;
            }
            if !line.starts_with('|') {
                schema.prose.extend(backticked_words(line));
                continue;
            }
            let field = line.split(" | ").next().unwrap_or("");
            let roots = field
                .split('`')
                .skip(1)
                .step_by(2)
                .filter(|t| !t.starts_with('.'))
                .filter_map(|t| t.split(['.', '[']).next())
                .map(str::to_string)
                .collect();
            schema.rows.push((roots, backticked_words(line).collect()));
        }
        assert!(!schema.rows.is_empty(), "no table for {report}");
        schema
    }

    /// Whether `path` (object keys, arrays left out) is described: its first key starts a
    /// row, and every key below it is named by such a row or by the prose.
    fn describes(&self, path: &[String]) -> bool {
        let rows: Vec<_> = self
            .rows
            .iter()
            .filter(|(roots, _)| roots.contains(&path[0]))
            .collect();
        !rows.is_empty()
            && path[1..]
                .iter()
                .all(|k| self.prose.contains(k) || rows.iter().any(|(_, words)| words.contains(k)))
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

/// The keys of `report` that `schema` does not describe; diagnose's circular-test figures
/// (`circular_test.measured`, …) are described as check's `circular_test` is, in `check`.
fn undescribed(report: &serde_json::Value, schema: &Schema, check: &Schema) -> Vec<String> {
    let mut paths = BTreeSet::new();
    key_paths(report, &mut Vec::new(), &mut paths);
    paths
        .into_iter()
        .filter(|path| {
            let as_in_check = (path.len() > 2 && path[0] == "circular_test")
                .then(|| [&path[..1], &path[2..]].concat());
            !schema.describes(path) && !as_in_check.is_some_and(|p| check.describes(&p))
        })
        .map(|path| path.join("."))
        .collect()
}

/// `docs/report-schema.md` describes every key the reports write: check's of a program in
/// the plane and of one that moves Z along the contour, diagnose's of a record with
/// backlash on X.
#[test]
fn the_report_schema_describes_every_key_the_reports_write() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let doc = fs::read_to_string(root.join("docs/report-schema.md")).unwrap();
    let check = Schema::of(&doc, "contourcheck.check/");
    let diagnose = Schema::of(&doc, "contourcheck.diagnose/");
    let dir = std::env::temp_dir().join(format!("report-schema-{}", std::process::id()));
    fs::create_dir_all(&dir).unwrap();
    let sample = |name: &str| root.join("gcode-samples").join(name);
    let (square, helix, circle) = (
        sample("square.nc"),
        sample("helix-zx.nc"),
        sample("circle-test.nc"),
    );
    let mut missing = Vec::new();
    for program in [&square, &helix] {
        let r = report(&dir, "check.json", &["check", program.to_str().unwrap()]);
        missing.extend(undescribed(&r, &check, &check));
    }
    let record = dir.join("backlash.csv");
    let synth = [
        "synth",
        circle.to_str().unwrap(),
        "--out",
        record.to_str().unwrap(),
    ];
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_contourcheck"))
        .args(synth)
        .args(["--effect", "backlash", "--axis", "x", "--values", "8"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let measured = [
        "diagnose",
        circle.to_str().unwrap(),
        "--measured",
        record.to_str().unwrap(),
    ];
    let r = report(&dir, "diagnose.json", &measured);
    missing.extend(undescribed(&r, &diagnose, &check));
    let _ = fs::remove_dir_all(&dir);
    missing.sort();
    missing.dedup();
    assert!(
        missing.is_empty(),
        "docs/report-schema.md does not describe: {missing:?}"
    );
}
