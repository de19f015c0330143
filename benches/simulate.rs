//! One axis following 60 s of the circle test's command stream with the full nonlinear
//! model (friction, backlash, limits, lateral shift), on the paper's machine and on the
//! small table (a PID position controller on a current amplifier, 1 ms cycle). Throughput is in simulation steps, so
//! criterion reports steps per second; simulated seconds per second follow by dividing by
//! the steps per simulated second (`substeps` / interpolation cycle).

use std::hint::black_box;

use contourcheck::gcode::{InterpretOptions, parse_program};
use contourcheck::machine::MachineConfig;
use contourcheck::plan::{KinematicLimits, PlanConfig, plan, sample};
use contourcheck::sim::{AxisModel, SimConfig, simulate};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};

fn circle_commands(machine: &MachineConfig, seconds: f64) -> contourcheck::plan::Commands {
    let src = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/gcode-samples/circle-test.nc"
    ))
    .unwrap();
    let program = parse_program(&src, "circle-test.nc", &InterpretOptions::default()).unwrap();
    let p = plan(
        &program,
        &KinematicLimits::of(machine),
        &PlanConfig::for_machine(machine),
    );
    let mut c = sample(&p);
    let n = (seconds / c.dt_s) as usize + 1;
    c.x.pos_m.truncate(n);
    c.x.vel_m_per_s.truncate(n);
    c.x.acc_m_per_s2.truncate(n);
    c
}

fn bench_axis(c: &mut Criterion, name: &str, mut machine: MachineConfig) {
    let commands = circle_commands(&machine, 60.0);
    machine.x.drive.backlash_um = 10.0; // the full nonlinear model: every mode in play
    let model = AxisModel::from_config(&machine.x);
    let config = SimConfig::default();
    let steps = (commands.x.len() - 1) as u64 * config.substeps as u64;
    let mut g = c.benchmark_group("simulator");
    g.sample_size(20);
    g.throughput(Throughput::Elements(steps));
    g.bench_function(name, |b| {
        b.iter(|| simulate(black_box(&model), &commands.x, commands.dt_s, &config).unwrap())
    });
    g.finish();
}

fn simulate_axis(c: &mut Criterion) {
    bench_axis(
        c,
        "one axis, 60 s circle test",
        MachineConfig::default_preset(),
    );
    bench_axis(
        c,
        "small table, one axis, 60 s circle test",
        MachineConfig::preset("small-table").unwrap(),
    );
}

criterion_group!(benches, simulate_axis);
criterion_main!(benches);
