//! The simulator's two innermost costs on their own, each against the way it was done before:
//! - the step maps of all 25 levels of the paper's X axis's nine friction × contact modes at
//!   the 10 kHz step, the levels sharing their powers, approximant and squares (`shared`)
//!   against each level's exponential computed alone (`each_level`) — the same bits;
//! - 20,000 hybrid steps of 0.1 ms of that axis (10 µm backlash) following a 5 Hz sine, in the
//!   copy compiled for AVX (`avx`, where the processor has it) and the portable one.
//!
//! Run one case briefly: `cargo bench --bench kernels -- --quick step_maps`.

use std::hint::black_box;

use contourcheck::machine::MachineConfig;
use contourcheck::sim::AxisModel;
use contourcheck::sim::bench::{hybrid_steps, step_maps_each_level, step_maps_shared};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};

fn x_axis() -> AxisModel {
    let mut machine = MachineConfig::default_preset();
    machine.x.drive.backlash_um = 10.0;
    AxisModel::from_config(&machine.x)
}

fn step_maps(c: &mut Criterion) {
    let model = x_axis();
    let mut g = c.benchmark_group("step_maps");
    g.sample_size(10);
    g.bench_function("shared", |b| {
        b.iter(|| step_maps_shared(black_box(&model), 1e-4))
    });
    g.bench_function("each_level", |b| {
        b.iter(|| step_maps_each_level(black_box(&model), 1e-4))
    });
    g.finish();
}

fn hybrid(c: &mut Criterion) {
    let model = x_axis();
    let steps = 20_000;
    // The first steps build the maps the rest reuse: warm the shared ones up.
    black_box(hybrid_steps(&model, 1e-4, steps, false));
    let mut g = c.benchmark_group("hybrid_step");
    g.throughput(Throughput::Elements(steps as u64));
    for (name, avx) in [("avx", true), ("portable", false)] {
        g.bench_function(name, |b| {
            b.iter(|| hybrid_steps(black_box(&model), 1e-4, steps, avx))
        });
    }
    g.finish();
}

criterion_group!(benches, step_maps, hybrid);
criterion_main!(benches);
