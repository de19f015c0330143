//! Scratch: writes independent records to /tmp/dr (not part of the repository).
mod common;
use common::program_text;
use common::reference::{Recording, record};
use contourcheck::machine::MachineConfig;

fn write(name: &str, text: &str, truth: &MachineConfig, rec: &Recording) {
    let program = program_text(text);
    std::fs::write(format!("/tmp/dr/{name}.nc"), text).unwrap();
    let csv = record(&program, &truth.x, &truth.y, rec);
    std::fs::write(format!("/tmp/dr/{name}.csv"), &csv).unwrap();
    // Without commands.
    let no_cmd: String = csv
        .lines()
        .map(|l| l.split(',').take(3).collect::<Vec<_>>().join(",") + "\n")
        .collect();
    std::fs::write(format!("/tmp/dr/{name}-nocmd.csv"), no_cmd).unwrap();
}

const CIRCLE: &str = "G21 G90 G17 G94\nG0 X30 Y0\nG3 X30 Y0 I-30 J0 F1000\nG3 X30 Y0 I-30 J0\nM2\n";
const SQUARE: &str = "G21 G90 G17 G94\nG0 X0 Y0\nG1 X60 F1000\nY60\nX0\nY0\nM2\n";

#[test]
fn scratch() {
    let which = std::env::var("DR").unwrap_or_default();
    let nominal = MachineConfig::default_preset();
    let mut kv = nominal.clone();
    kv.y.position_loop.kv_m_per_min_per_mm = 0.92;
    let rec = Recording::default();
    if which.contains("cut") {
        write(
            "circle-kv-cut",
            CIRCLE,
            &kv,
            &Recording {
                keep_s: Some((8.0, 100.0)),
                ..rec
            },
        );
        write("circle-kv", CIRCLE, &kv, &rec);
    }
    if which.contains("square") {
        write(
            "square-mid",
            SQUARE,
            &nominal,
            &Recording {
                keep_s: Some((5.0, 100.0)),
                ..rec
            },
        );
        write(
            "square-first4",
            SQUARE,
            &nominal,
            &Recording {
                keep_s: Some((0.0, 4.0)),
                ..rec
            },
        );
    }
    if which.contains("home") {
        write(
            "square-home",
            SQUARE,
            &nominal,
            &Recording {
                home_m: Some([0.2, -0.05]),
                ..rec
            },
        );
    }
    if which.contains("bl8") {
        let mut m = nominal.clone();
        m.x.drive.backlash_um = 8.0;
        write("circle-bl8", CIRCLE, &m, &rec);
        write(
            "circle-bl8-home",
            CIRCLE,
            &m,
            &Recording {
                home_m: Some([0.2, -0.05]),
                ..rec
            },
        );
    }
    if which.contains("three") {
        let mut m = nominal.clone();
        m.x.drive.backlash_um = 10.0;
        m.y.position_loop.kv_m_per_min_per_mm = 0.95;
        m.y.friction.coulomb_coefficient *= 1.5;
        write("circle-three", CIRCLE, &m, &rec);
    }
    if which.contains("lag") {
        let mut m = nominal.clone();
        m.x.position_loop.dead_time_ms = 4.0;
        let line = "G21 G90 G17 G94\nG0 X0 Y0\nG1 X30 Y52 F500\nM2\n";
        write("line-dt4", line, &m, &rec);
        write(
            "line-dt4-mid",
            line,
            &m,
            &Recording {
                keep_s: Some((2.0, 6.0)),
                ..rec
            },
        );
    }
}
