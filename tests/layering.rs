//! The modules form layers along the pipeline, and every `crate::` path in the code points
//! to a lower layer: a program's path never depends on the planner, the simulator never on
//! the diagnosis. This test reads the sources and fails on any arrow that points up or
//! sideways, and on a top-level module that has not been given a layer.

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Path, PathBuf};

/// Lowest first. A module may use modules of lower layers only.
const LAYERS: &[&[&str]] = &[
    &["numeric", "plot"],
    &["path"],
    &["gcode"],
    &["machine"],
    &["sim"],
    &["plan"],
    &["analysis", "trace"],
    &["check"],
    &["compare", "sweep"],
    &["diagnose", "identify"],
    &["figures", "validate"],
    &["html_report"],
    &["cli"],
];

fn layer_of(module: &str) -> Option<usize> {
    LAYERS.iter().position(|layer| layer.contains(&module))
}

fn rust_files(dir: &Path, found: &mut Vec<PathBuf>) {
    for entry in fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            rust_files(&path, found);
        } else if path.extension().is_some_and(|e| e == "rs") {
            found.push(path);
        }
    }
}

/// The top-level module a source file belongs to (`None` for the crate root and binary).
fn top_module(src: &Path, file: &Path) -> Option<String> {
    let relative = file.strip_prefix(src).unwrap();
    let first = relative.components().next()?.as_os_str().to_str()?;
    let name = first.strip_suffix(".rs").unwrap_or(first);
    (!matches!(name, "lib" | "main")).then(|| name.to_string())
}

/// The top-level modules named by `crate::name` in the code of one file (comments left out:
/// a doc link is not a dependency).
fn used_modules(text: &str) -> BTreeSet<String> {
    let mut used = BTreeSet::new();
    for line in text.lines() {
        let code = line.split("//").next().unwrap_or("");
        let mut rest = code;
        while let Some(at) = rest.find("crate::") {
            let preceded_by_ident = rest[..at]
                .chars()
                .last()
                .is_some_and(|c| c.is_alphanumeric() || c == '_');
            rest = &rest[at + "crate::".len()..];
            if preceded_by_ident {
                continue; // `contourcheck::…` or similar, not this crate's root
            }
            let name: String = rest
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect();
            if !name.is_empty() {
                used.insert(name);
            }
        }
    }
    used
}

/// Every module → the modules it uses, over the whole `src/` tree.
fn dependencies() -> BTreeMap<String, BTreeSet<String>> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let mut deps: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for file in files {
        let Some(module) = top_module(&src, &file) else {
            continue;
        };
        let used = used_modules(&fs::read_to_string(&file).unwrap());
        let entry = deps.entry(module.clone()).or_default();
        entry.extend(used.into_iter().filter(|u| *u != module));
    }
    deps
}

#[test]
fn every_top_level_module_has_a_layer() {
    let unplaced: Vec<String> = dependencies()
        .into_keys()
        .filter(|m| layer_of(m).is_none())
        .collect();
    assert!(
        unplaced.is_empty(),
        "modules without a layer in tests/layering.rs: {unplaced:?}"
    );
}

#[test]
fn dependencies_point_down_the_layers() {
    let deps = dependencies();
    // The reader must see the arrows that are there, or the test below passes vacuously.
    assert!(deps["check"].contains("analysis"));
    assert!(deps["diagnose"].contains("trace"));
    assert!(deps["sim"].contains("machine"));

    let mut upward = Vec::new();
    for (module, used) in &deps {
        let Some(own) = layer_of(module) else {
            continue;
        };
        for target in used {
            match layer_of(target) {
                Some(theirs) if theirs < own => {}
                Some(_) => upward.push(format!("{module} → {target}")),
                None => {} // a crate-root item (e.g. a re-export), not a module
            }
        }
    }
    assert!(
        upward.is_empty(),
        "dependencies that do not point down the layers: {upward:?}"
    );
}

#[test]
fn the_reader_skips_comments_and_other_crates() {
    let text =
        "use crate::sim::AxisModel;\n// see crate::cli\nlet x = contourcheck::diagnose::run;\n";
    let used = used_modules(text);
    assert_eq!(used, BTreeSet::from(["sim".to_string()]));
}

/// The names `lib.rs` re-exports at the crate's root: its public interface.
fn root_exports() -> BTreeSet<String> {
    let lib = fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("src/lib.rs")).unwrap();
    let mut names = BTreeSet::new();
    // A `pub use` may run over several lines; join each statement up to its `;`.
    for statement in lib.split(';') {
        let Some(at) = statement.find("pub use ") else {
            continue;
        };
        let body = &statement[at + "pub use ".len()..];
        let items = match body.find('{') {
            Some(open) => body[open + 1..]
                .trim_end()
                .trim_end_matches('}')
                .to_string(),
            None => body.rsplit("::").next().unwrap_or("").to_string(),
        };
        for item in items.split(',') {
            let item = item.trim();
            let name = item.rsplit(" as ").next().unwrap_or(item).trim();
            if !name.is_empty() {
                names.insert(name.to_string());
            }
        }
    }
    names
}

/// Every name the Python bindings take from the library: `contourcheck::name` and the
/// members of `contourcheck::{…}`.
fn python_imports() -> BTreeSet<String> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("python/src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let mut names = BTreeSet::new();
    for file in files {
        let text: String = fs::read_to_string(&file)
            .unwrap()
            .lines()
            .map(|line| line.split("//").next().unwrap_or(""))
            .collect::<Vec<_>>()
            .join("\n");
        let mut rest = text.as_str();
        while let Some(at) = rest.find("contourcheck::") {
            rest = &rest[at + "contourcheck::".len()..];
            if let Some(group) = rest.strip_prefix('{') {
                let close = group.find('}').unwrap_or(group.len());
                names.extend(group[..close].split(',').map(|n| n.trim().to_string()));
            } else {
                // `contourcheck::MachineConfig::load` takes `MachineConfig`; `contourcheck::
                // sim::AxisModel` takes the module `sim`, which the root does not re-export.
                let name: String = rest
                    .chars()
                    .take_while(|c| c.is_alphanumeric() || *c == '_')
                    .collect();
                names.insert(name);
            }
        }
    }
    names.retain(|n| !n.is_empty());
    names
}

/// The Python package stands on the library's root interface alone: a module path or a name
/// `lib.rs` does not re-export would tie it to internals that change with the code.
#[test]
fn the_python_package_uses_only_the_root_interface() {
    let exports = root_exports();
    // The reader must see what is there, or the check below passes vacuously.
    assert!(
        exports.contains("check") && exports.contains("ReportInputs"),
        "{exports:?}"
    );
    let imports = python_imports();
    assert!(imports.contains("check_fits"), "{imports:?}");
    let outside: Vec<&String> = imports.iter().filter(|n| !exports.contains(*n)).collect();
    assert!(
        outside.is_empty(),
        "python/src takes names lib.rs does not re-export: {outside:?}"
    );
}

/// The top-level modules of this crate that `text` (another crate's code, a test's) names as
/// `contourcheck::name`, grouped imports (`contourcheck::{a::X, b}`) included; comments left
/// out.
fn library_modules_named(text: &str) -> BTreeSet<String> {
    let code: String = text
        .lines()
        .map(|line| line.split("//").next().unwrap_or(""))
        .collect::<Vec<_>>()
        .join("\n");
    let ident = |s: &str| -> String {
        s.trim_start()
            .chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_')
            .collect()
    };
    let mut named = BTreeSet::new();
    let mut rest = code.as_str();
    while let Some(at) = rest.find("contourcheck::") {
        rest = &rest[at + "contourcheck::".len()..];
        let Some(group) = rest.strip_prefix('{') else {
            named.insert(ident(rest));
            continue;
        };
        // Each path at the group's own depth starts after its `{` or a comma.
        let mut depth = 1;
        named.insert(ident(group));
        for (i, c) in group.char_indices() {
            match c {
                '{' => depth += 1,
                '}' if depth == 1 => break,
                '}' => depth -= 1,
                ',' if depth == 1 => {
                    named.insert(ident(&group[i + 1..]));
                }
                _ => {}
            }
        }
    }
    named.retain(|n| !n.is_empty());
    named
}

#[test]
fn the_library_reader_sees_grouped_imports_and_skips_comments() {
    let text = "use contourcheck::{sim::{AxisModel, X}, gcode,\n  machine::Y};\n\
                // contourcheck::plan\nlet p = contourcheck::path::Geometry::Line;\n";
    let named = library_modules_named(text);
    let expected = ["gcode", "machine", "path", "sim"].map(String::from);
    assert_eq!(named, BTreeSet::from(expected));
}

/// The tests' reference (`tests/common/reference/`) integrates the model's equations apart
/// from the tool, so that its records check the simulator rather than repeat it: it takes
/// from the library only what a user gives the tool — the program and the machine file —
/// never the simulator, the planner or anything built on them.
#[test]
fn the_tests_reference_takes_only_the_program_and_the_machine_file() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/common/reference");
    let mut files = Vec::new();
    rust_files(&dir, &mut files);
    let mut named = BTreeSet::new();
    for file in &files {
        named.extend(library_modules_named(&fs::read_to_string(file).unwrap()));
    }
    // The reader must see what is there, or the check below passes vacuously.
    assert!(named.contains("machine"), "{named:?}");
    let allowed = ["gcode", "machine", "path"];
    let other: Vec<&String> = named
        .iter()
        .filter(|n| !allowed.contains(&n.as_str()))
        .collect();
    assert!(
        other.is_empty(),
        "the reference names the library's {other:?}: it must stay independent of it"
    );
}
