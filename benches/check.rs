//! `check` end to end (parse, plan, simulate X and Y, contour error, hotspots) as the command
//! line runs it, the run streamed through in chunks: a generated ten-minute program (a
//! zig-zag pocket with arcs at the row ends, as CAM emits) and an hour of squares. A second
//! group prices a simulated Z: the paper's machine with its Z simulated against the same
//! machine carrying Z, on the hour of squares (Z stands, holding its weight) and on a helix
//! (all three axes move).

use std::hint::black_box;

use contourcheck::check::{CheckSettings, check_in_chunks};
use contourcheck::gcode::{InterpretOptions, parse_program};
use contourcheck::machine::{MachineConfig, PlannedAxis, ZAxis};
use contourcheck::sim::SimError;
use criterion::{Criterion, criterion_group, criterion_main};

/// About ten minutes at F1000: 50 rows of 196 mm joined by R2 half circles.
fn ten_minute_program() -> String {
    let mut s = String::from("G21 G90 G17 G94 G64 P0.01\nG0 X0 Y0\nF1000\n");
    let (mut y, mut dir) = (0.0f64, 1.0f64);
    for _ in 0..50 {
        let x_end = if dir > 0.0 { 196.0 } else { 0.0 };
        // Each row in 1 mm steps, as a CAM system's linearised output would be.
        for i in 1..=196 {
            let x = if dir > 0.0 {
                i as f64
            } else {
                196.0 - i as f64
            };
            s.push_str(&format!("G1 X{x:.3} Y{y:.3}\n"));
        }
        let g = if dir > 0.0 { "G3" } else { "G2" };
        y += 4.0;
        s.push_str(&format!("{g} X{x_end:.3} Y{y:.3} I0 J2.\n"));
        dir = -dir;
    }
    s.push_str("M30\n");
    s
}

/// An hour at F1000: a 100 mm square traced 147 times (24.5 s each).
fn one_hour_program() -> String {
    let mut s = String::from("G21 G90 G64 P0.01\nG0 X0 Y0\nG1 X0 Y0 F1000\n");
    for _ in 0..147 {
        s.push_str("X100 Y0\nX100 Y100\nX0 Y100\nX0 Y0\n");
    }
    s.push_str("M2\n");
    s
}

fn check_bench(c: &mut Criterion) {
    let machine = MachineConfig::default_preset();
    let settings = CheckSettings::for_machine(&machine);
    let mut g = c.benchmark_group("check");
    g.sample_size(10);
    for (name, text) in [
        ("10-minute program end to end", ten_minute_program()),
        ("1-hour program end to end", one_hour_program()),
    ] {
        g.bench_function(name, |b| {
            b.iter(|| {
                let program =
                    parse_program(black_box(&text), "p.nc", &InterpretOptions::default()).unwrap();
                check_in_chunks(&program, &machine, &settings, &|_| {}, &mut |_, _| {
                    Ok::<(), SimError>(())
                })
                .unwrap()
            })
        });
    }
    g.finish();
}

/// Ten minutes at F1000 of a helix down an R50 circle, 0.5 mm a turn (32 turns of 18.8 s).
fn helix_program() -> String {
    let mut s = String::from("G21 G90 G17 G94\nG0 X50 Y0 Z0\nF1000\n");
    for turn in 1..=32 {
        s.push_str(&format!("G3 X50 Y0 Z{:.3} I-50 J0\n", -0.5 * turn as f64));
    }
    s.push_str("M2\n");
    s
}

/// The same machine with Z planned and carried rather than simulated.
fn carrying_z(machine: &MachineConfig) -> MachineConfig {
    let mut carried = machine.clone();
    carried.z = ZAxis::Carried(PlannedAxis {
        limits: machine.z.limits().clone(),
    });
    carried
}

fn z_bench(c: &mut Criterion) {
    let simulated = MachineConfig::default_preset();
    assert!(
        matches!(simulated.z, ZAxis::Simulated(_)),
        "hvmc simulates Z"
    );
    let carried = carrying_z(&simulated);
    let mut g = c.benchmark_group("check with Z");
    g.sample_size(10);
    for (program, text) in [
        ("1-hour squares", one_hour_program()),
        ("10-minute helix", helix_program()),
    ] {
        for (how, machine) in [("Z simulated", &simulated), ("Z carried", &carried)] {
            let settings = CheckSettings::for_machine(machine);
            g.bench_function(format!("{program}, {how}"), |b| {
                b.iter(|| {
                    let program =
                        parse_program(black_box(&text), "p.nc", &InterpretOptions::default())
                            .unwrap();
                    check_in_chunks(&program, machine, &settings, &|_| {}, &mut |_, _| {
                        Ok::<(), SimError>(())
                    })
                    .unwrap()
                })
            });
        }
    }
    g.finish();
}

criterion_group!(benches, check_bench, z_bench);
criterion_main!(benches);
