//! Criterion version of the kernel comparison (same workloads as the
//! `isoc-peers` binary): `cargo bench` here, or
//! `cargo bench -- heart/point` for one group.

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use isoc_peers::*;
use std::time::Duration;

fn kernels(c: &mut Criterion) {
    for name in CORPUS {
        let case = Case::load(name).unwrap();
        let w = Workload::new(&case.surface.domain, 1 << 16, 5);
        let mut r = Runners::new(&case, &w);

        let mut g = c.benchmark_group(format!("{name}/point"));
        g.throughput(Throughput::Elements(w.n_points() as u64));
        g.bench_function(BenchmarkId::new("isoc", "point_batch"), |b| {
            b.iter(|| r.isoc_point_batch())
        });
        g.bench_function(BenchmarkId::new("fidget", "float_slice"), |b| {
            b.iter(|| r.fidget_float_slice())
        });
        g.finish();

        let mut g = c.benchmark_group(format!("{name}/interval"));
        g.throughput(Throughput::Elements(w.n_boxes() as u64));
        g.bench_function(BenchmarkId::new("isoc", "single"), |b| {
            b.iter(|| r.isoc_interval_single())
        });
        g.bench_function(BenchmarkId::new("isoc", "batch"), |b| {
            b.iter(|| r.isoc_interval_batch())
        });
        g.bench_function(BenchmarkId::new("fidget", "single"), |b| {
            b.iter(|| r.fidget_interval())
        });
        g.finish();

        let mut g = c.benchmark_group(format!("{name}/grad"));
        g.throughput(Throughput::Elements(w.n_boxes() as u64));
        g.bench_function(BenchmarkId::new("isoc", "interval_grad_batch"), |b| {
            b.iter(|| r.isoc_grad_batch())
        });
        g.bench_function(BenchmarkId::new("fidget", "grad_slice"), |b| {
            b.iter(|| r.fidget_grad_slice())
        });
        g.finish();
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .sample_size(20)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(1));
    targets = kernels
}
criterion_main!(benches);
