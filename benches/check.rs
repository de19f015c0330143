//! `check` end to end (parse, plan, simulate X and Y, contour error, hotspots) on a
//! generated ten-minute program: a zig-zag pocket with arcs at the row ends, as CAM emits.

use std::hint::black_box;

use contourcheck::check::{CheckSettings, check};
use contourcheck::gcode::{InterpretOptions, parse_program};
use contourcheck::machine::MachineConfig;
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

fn check_bench(c: &mut Criterion) {
    let text = ten_minute_program();
    let machine = MachineConfig::default_preset();
    let settings = CheckSettings::for_machine(&machine);
    let mut g = c.benchmark_group("check");
    g.sample_size(10);
    g.bench_function("10-minute program end to end", |b| {
        b.iter(|| {
            let program =
                parse_program(black_box(&text), "pocket.nc", &InterpretOptions::default()).unwrap();
            check(&program, &machine, &settings).unwrap()
        })
    });
    g.finish();
}

criterion_group!(benches, check_bench);
criterion_main!(benches);
