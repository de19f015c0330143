//! Documents generated from the code stay equal to it.

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
