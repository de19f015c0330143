//! `diagnose` end to end (alignment, noise floor, every cause fitted on the axis that
//! shows a residual, held-out check, the report's series) on synthetic records:
//!
//! - the square sample (27 s, 2 ms sampling), a resonance hidden on X;
//! - the circle test (80 s), backlash hidden on X;
//! - 3 s of a motor-encoder record at 10 kHz in 0.1 µm counts, a gain error hidden on X;
//! - a slow circle at F20 (60 s) in stick-slip, Stribeck friction hidden on X.

use std::hint::black_box;

use contourcheck::diagnose::causes::CauseId;
use contourcheck::diagnose::synth::{SynthSpec, synthesize};
use contourcheck::diagnose::{DiagnoseSettings, diagnose};
use contourcheck::gcode::{InterpretOptions, Program, parse_program};
use contourcheck::machine::{AxisName, MachineConfig};
use contourcheck::sim::MeasuredAt;
use contourcheck::trace::measured::{MeasuredTrace, parse_trace};
use criterion::{Criterion, criterion_group, criterion_main};

fn program(name: &str, text: &str) -> Program {
    parse_program(text, name, &InterpretOptions::default()).unwrap()
}

fn sample_program(name: &str) -> Program {
    let path = format!("{}/gcode-samples/{name}", env!("CARGO_MANIFEST_DIR"));
    program(name, &std::fs::read_to_string(path).unwrap())
}

/// A record of `program` with `spec`, read back as a user's file would be.
fn record(program: &Program, spec: &SynthSpec) -> MeasuredTrace {
    let mut csv = Vec::new();
    synthesize(program, &MachineConfig::default_preset(), spec)
        .unwrap()
        .write_csv(&mut csv)
        .unwrap();
    parse_trace(std::str::from_utf8(&csv).unwrap(), "record.csv").unwrap()
}

fn diagnose_bench(c: &mut Criterion) {
    let machine = MachineConfig::default_preset();
    let cases: Vec<(&str, Program, SynthSpec, MeasuredAt)> = vec![
        (
            "square, resonance hidden on X",
            sample_program("square.nc"),
            SynthSpec {
                effect: Some((CauseId::Resonance, AxisName::X, vec![40.0, 0.03])),
                offset_s: 0.4,
                ..SynthSpec::default()
            },
            MeasuredAt::Table,
        ),
        (
            "circle test 80 s, backlash hidden on X",
            sample_program("circle-test.nc"),
            SynthSpec {
                effect: Some((CauseId::Backlash, AxisName::X, vec![8.0])),
                offset_s: 0.4,
                ..SynthSpec::default()
            },
            MeasuredAt::Table,
        ),
        (
            "3 s at 10 kHz, motor encoder, gain error hidden on X",
            program(
                "r5.nc",
                "G21 G17 G90 G94\nG0 X5 Y0\nG3 X5 Y0 I-5 J0 F3000\nM30\n",
            ),
            SynthSpec {
                effect: Some((CauseId::KvGain, AxisName::X, vec![0.9])),
                sample_s: 1e-4,
                noise_m: 0.02e-6,
                quantization_m: 0.1e-6,
                measured_at: MeasuredAt::Motor,
                offset_s: 0.2,
                ..SynthSpec::default()
            },
            MeasuredAt::Motor,
        ),
        (
            "slow circle F20 60 s in stick-slip, Stribeck hidden on X",
            program(
                "f20.nc",
                "G21 G17 G90 G94\nG0 X3.2 Y0\nG3 X3.2 Y0 I-3.2 J0 F20\nM30\n",
            ),
            SynthSpec {
                effect: Some((CauseId::Stribeck, AxisName::X, vec![400.0, 20.0])),
                offset_s: 0.3,
                ..SynthSpec::default()
            },
            MeasuredAt::Table,
        ),
    ];
    let mut g = c.benchmark_group("diagnose");
    g.sample_size(10);
    for (name, program, spec, at) in &cases {
        let measured = record(program, spec);
        let mut settings = DiagnoseSettings::for_machine(&machine);
        settings.compare.measured_at = *at;
        g.bench_function(*name, |b| {
            b.iter(|| diagnose(black_box(program), &machine, &measured, &settings).unwrap())
        });
    }
    g.finish();
}

criterion_group!(benches, diagnose_bench);
criterion_main!(benches);
