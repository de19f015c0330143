//! Parsing and planning a large generated program (over a million blocks), as CAM output
//! for a big part looks: short lines and arcs under G64; and the same program in the
//! SINUMERIK dialect, whose front end rewrites each line before the RS274/NGC one reads it.

use std::hint::black_box;

use contourcheck::gcode::{InterpretOptions, parse_program};
use contourcheck::machine::MachineConfig;
use contourcheck::plan::{KinematicLimits, PlanConfig, plan};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};

/// A program of `blocks` motion blocks: a zig-zag raster of short lines with an arc at
/// every row end.
fn big_program(blocks: usize) -> String {
    let mut s = String::with_capacity(blocks * 28);
    s.push_str("G21 G90 G17 G94 G64 P0.01\nF900\nG0 X0 Y0\n");
    let (mut x, mut y, mut dir) = (0.0f64, 0.0f64, 1.0f64);
    for i in 0..blocks {
        if i % 200 == 199 {
            // Row end: a half circle of R1 to the next row.
            let g = if dir > 0.0 { "G3" } else { "G2" };
            y += 2.0;
            s.push_str(&format!("{g} X{x:.3} Y{y:.3} I0 J1.\n"));
            dir = -dir;
        } else {
            x += dir * 0.5;
            let wobble = if i % 2 == 0 { 0.005 } else { -0.005 };
            s.push_str(&format!("G1 X{x:.3} Y{:.3}\n", y + wobble));
        }
    }
    s.push_str("M30\n");
    s
}

/// The RS274/NGC program `text` rewritten in the SINUMERIK dialect.
fn sinumerik_program(text: &str) -> String {
    text.replace(
        "G21 G90 G17 G94 G64 P0.01",
        "%_N_BIG_MPF\nG710 G90 G17 G94 G641 ADIS=0.01",
    )
    .replace(" I0 J1.", " CR=1")
}

fn parse_and_plan(c: &mut Criterion) {
    let blocks = 1_000_000;
    let text = big_program(blocks);
    let machine = MachineConfig::default_preset();
    let limits = KinematicLimits::of(&machine);
    let config = PlanConfig::for_machine(&machine);

    let mut g = c.benchmark_group("gcode");
    g.sample_size(10);
    g.throughput(Throughput::Bytes(text.len() as u64));
    g.bench_function("parse 1M blocks", |b| {
        b.iter(|| parse_program(black_box(&text), "big.nc", &InterpretOptions::default()).unwrap())
    });
    // The same blocks as an 840D program: `G710`, `G641 ADIS=`, arcs by `CR=`.
    let sinumerik = sinumerik_program(&text);
    g.bench_function("parse 1M blocks, SINUMERIK dialect", |b| {
        b.iter(|| {
            parse_program(
                black_box(&sinumerik),
                "big.mpf",
                &InterpretOptions::default(),
            )
            .unwrap()
        })
    });
    g.finish();

    let program = parse_program(&text, "big.nc", &InterpretOptions::default()).unwrap();
    let mut g = c.benchmark_group("planner");
    g.sample_size(10);
    g.throughput(Throughput::Elements(program.segments.len() as u64));
    g.bench_function("plan 1M blocks", |b| {
        b.iter(|| plan(black_box(&program), &limits, &config))
    });
    g.finish();
}

criterion_group!(benches, parse_and_plan);
criterion_main!(benches);
