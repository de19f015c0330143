//! Reading a large measured trace as a control exports it: 2 million rows at 10 kHz,
//! semicolon-separated with decimal commas, time in ms, vendor column names.

use std::hint::black_box;

use contourcheck::trace::format::ColumnMap;
use contourcheck::trace::measured::parse_trace_with;
use criterion::{Criterion, Throughput, criterion_group, criterion_main};

fn export(rows: usize) -> String {
    let mut s = String::from("Time [ms];X_ActPos;Y_ActPos;X_Traj;Y_Traj\n");
    for k in 0..rows {
        let a = k as f64 * 1e-5;
        let (x, y) = (50.0 * a.sin(), 50.0 * a.cos());
        let row = format!(
            "{:.1};{x:.4};{y:.4};{:.4};{y:.4}\n",
            k as f64 * 0.1,
            x + 0.001
        );
        s.push_str(&row.replace('.', ","));
    }
    s
}

fn trace_read(c: &mut Criterion) {
    let text = export(2_000_000);
    let map =
        ColumnMap::parse("t=Time[ms],x=X_ActPos[mm],y=Y_ActPos[mm],x_cmd=X_Traj,y_cmd=Y_Traj")
            .unwrap();
    let mut g = c.benchmark_group("trace");
    g.sample_size(10);
    g.throughput(Throughput::Bytes(text.len() as u64));
    g.bench_function("read 2M-row vendor export", |b| {
        b.iter(|| parse_trace_with(black_box(&text), "export.csv", Some(&map)).unwrap())
    });
    g.finish();
}

criterion_group!(benches, trace_read);
criterion_main!(benches);
