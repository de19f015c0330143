//! `identify` end to end on a 5 s two-axis record at 10 kHz in 0.1 µm counts with its
//! commands (the sample `identify-moves.nc`): the heavy preset identified from a machine
//! with other gains, mass and friction, and the small table from one with other mechanics;
//! and the README's lead-lag table (gain, three corners, mass and friction free) on the
//! 5 s small circle.

use std::hint::black_box;

use contourcheck::compare::CompareSettings;
use contourcheck::diagnose::synth::{SynthSpec, synthesize};
use contourcheck::gcode::{InterpretOptions, Program, parse_program};
use contourcheck::identify::identify;
use contourcheck::machine::MachineConfig;
use contourcheck::trace::measured::{MeasuredTrace, parse_trace};
use criterion::{Criterion, criterion_group, criterion_main};

fn program(name: &str) -> Program {
    let path = format!("{}/gcode-samples/{name}", env!("CARGO_MANIFEST_DIR"));
    parse_program(
        &std::fs::read_to_string(path).unwrap(),
        name,
        &InterpretOptions::default(),
    )
    .unwrap()
}

fn example(name: &str) -> MachineConfig {
    let path = format!("{}/docs/examples/{name}", env!("CARGO_MANIFEST_DIR"));
    MachineConfig::load(std::path::Path::new(&path)).unwrap()
}

/// The program's record on `machine`, at 10 kHz in 0.1 µm counts with its commands.
fn record(program: &Program, machine: &MachineConfig) -> MeasuredTrace {
    let spec = SynthSpec {
        with_commands: true,
        sample_s: 1e-4,
        quantization_m: 0.1e-6,
        noise_m: 0.05e-6,
        ..SynthSpec::default()
    };
    let mut csv = Vec::new();
    synthesize(program, machine, &spec)
        .unwrap()
        .write_csv(&mut csv)
        .unwrap();
    parse_trace(std::str::from_utf8(&csv).unwrap(), "record.csv").unwrap()
}

fn identify_bench(c: &mut Criterion) {
    let moves = program("identify-moves.nc");
    let circle = program("small-circle.nc");
    let heavy = MachineConfig::default_preset();
    let mut heavy_truth = heavy.clone();
    heavy_truth.x.position_loop.kv_m_per_min_per_mm = 0.9;
    heavy_truth.x.drive.table_mass_kg = 7500.0;
    heavy_truth.y.friction.coulomb_coefficient = 0.015;
    let small = MachineConfig::from_toml_str(
        "base = \"small-table\"\n[x.controller]\naccel_feedforward = 0.0\n\
         [y.controller]\naccel_feedforward = 0.0\n",
        "small.toml",
    )
    .unwrap();
    let mut small_truth = small.clone();
    small_truth.x.drive.table_mass_kg = 45.0;
    small_truth.y.friction.viscous_n_s_per_m = 400.0;
    let mut g = c.benchmark_group("identify");
    g.sample_size(10);
    let (design, stand_in) = (
        example("lead-lag-design.toml"),
        example("lead-lag-table.toml"),
    );
    for (name, program, template, truth) in [
        ("hvmc, 5 s at 10 kHz", &moves, &heavy, &heavy_truth),
        ("small table, 5 s at 10 kHz", &moves, &small, &small_truth),
        (
            "lead-lag table, free controller, 5 s at 10 kHz",
            &circle,
            &design,
            &stand_in,
        ),
    ] {
        let measured = record(program, truth);
        let settings = CompareSettings::for_machine(template);
        g.bench_function(name, |b| {
            b.iter(|| identify(black_box(program), template, &measured, &settings).unwrap())
        });
    }
    g.finish();
}

criterion_group!(benches, identify_bench);
criterion_main!(benches);
