//! `diagnose` on a synthetic measurement of the square sample (27 s, 2 ms sampling) with a
//! hidden resonance on X: alignment, noise floor, every cause fitted on the axis that shows
//! a residual, the report's series.

use std::hint::black_box;

use contourcheck::diagnose::causes::CauseId;
use contourcheck::diagnose::{DiagnoseSettings, diagnose};
use contourcheck::gcode::{InterpretOptions, parse_program};
use contourcheck::machine::{AxisName, MachineConfig};
use contourcheck::measured::parse_trace;
use contourcheck::synth::{SynthSpec, synthesize};
use criterion::{Criterion, criterion_group, criterion_main};

fn diagnose_bench(c: &mut Criterion) {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/gcode-samples/square.nc");
    let text = std::fs::read_to_string(path).unwrap();
    let program = parse_program(&text, "square.nc", &InterpretOptions::default()).unwrap();
    let machine = MachineConfig::default_preset();
    let spec = SynthSpec {
        effect: Some((CauseId::Resonance, AxisName::X, vec![40.0, 0.03])),
        offset_s: 0.4,
        ..SynthSpec::default()
    };
    let mut csv = Vec::new();
    synthesize(&program, &machine, &spec)
        .unwrap()
        .write_csv(&mut csv)
        .unwrap();
    let measured = parse_trace(std::str::from_utf8(&csv).unwrap(), "square.csv").unwrap();
    let settings = DiagnoseSettings::for_machine(&machine);
    let mut g = c.benchmark_group("diagnose");
    g.sample_size(10);
    g.bench_function("square, resonance hidden on X", |b| {
        b.iter(|| diagnose(black_box(&program), &machine, &measured, &settings).unwrap())
    });
    g.finish();
}

criterion_group!(benches, diagnose_bench);
criterion_main!(benches);
