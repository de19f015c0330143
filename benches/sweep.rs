//! A 100-point sweep (X's Kv × K_s) on the circle test, on all cores and on one, for the
//! parallel speed-up.

use contourcheck::gcode::{InterpretOptions, parse_program};
use contourcheck::machine::MachineConfig;
use contourcheck::plan::PlanConfig;
use contourcheck::sweep::{self, Dimension};
use criterion::{Criterion, criterion_group, criterion_main};

fn sweep_bench(c: &mut Criterion) {
    let src = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/gcode-samples/circle-test.nc"
    ))
    .unwrap();
    let program = parse_program(&src, "circle-test.nc", &InterpretOptions::default()).unwrap();
    let machine = MachineConfig::default_preset();
    let plan = PlanConfig::for_machine(&machine);
    let dims = [
        Dimension {
            name: "x.kv".into(),
            keys: vec!["x.position_loop.kv_m_per_min_per_mm".into()],
            values: sweep::parse_range("0.80:1.25:0.05").unwrap(),
        },
        Dimension {
            name: "x.ks".into(),
            keys: vec!["x.velocity_loop.ks_nm_s_per_rad".into()],
            values: sweep::parse_range("11:20:1").unwrap(),
        },
    ];
    assert_eq!(dims.iter().map(|d| d.values.len()).product::<usize>(), 100);
    let mut g = c.benchmark_group("sweep");
    g.sample_size(10);
    g.bench_function("100 settings, circle test, all cores", |b| {
        b.iter(|| sweep::run(&program, &machine, &plan, &dims, true, &|| {}))
    });
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    g.bench_function("100 settings, circle test, one thread", |b| {
        b.iter(|| one.install(|| sweep::run(&program, &machine, &plan, &dims, true, &|| {})))
    });
    g.finish();
}

criterion_group!(benches, sweep_bench);
criterion_main!(benches);
