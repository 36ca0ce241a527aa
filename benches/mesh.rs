//! The mesher per stage on corpus surfaces at levels 6–8: octree
//! construction (interval-gradient kernels in batches), dual grid (with the
//! leaf-centre values), polygonisation (MC33 + bisection), smoothing (two
//! passes), and the whole pipeline.
//!
//! Run: `cargo bench --bench mesh` (filter e.g. `-- heart/7`). The side by
//! side comparison with Fidget's mesher is in `benches/peers/`.

use std::hint::black_box;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use isoc::mesher::smooth;
use isoc::mesher::{self, MeshOptions};
use isoc::octree::{Octree, OctreeOptions};
use isoc::polygonize::extract::{self, CornerValues};
use isoc::{CompileOptions, Surface};

fn surface(name: &str) -> Surface {
    let path = format!("{}/corpus/{name}.iso", env!("CARGO_MANIFEST_DIR"));
    let src = std::fs::read_to_string(&path).expect("corpus file");
    Surface::compile(&src, &path, &CompileOptions::default()).expect("compiles")
}

fn stages(c: &mut Criterion) {
    let mut g = c.benchmark_group("mesh");
    g.sample_size(10);
    for (name, levels) in [
        ("heart", &[6u8, 7, 8][..]),
        ("torus_fig1", &[6, 7, 8]),
        ("chair_mid", &[6, 7]),
        ("twotorus", &[6, 7]),
    ] {
        let s = surface(name);
        for &level in levels {
            let opts = OctreeOptions {
                max_level: level,
                ..OctreeOptions::default()
            };
            let id = |stage: &str| BenchmarkId::new(stage, format!("{name}/{level}"));
            g.bench_function(id("octree"), |b| {
                b.iter(|| black_box(Octree::build(&s, s.domain, &opts, &|_, _| {})))
            });
            let tree = Octree::build(&s, s.domain, &opts, &|_, _| {});
            g.bench_function(id("dual"), |b| {
                b.iter(|| {
                    let mut values = CornerValues::at_leaves(&tree, &s, 0.0);
                    black_box(extract::active_cells(&tree, &s, 0.0, &mut values))
                })
            });
            let mut values = CornerValues::at_leaves(&tree, &s, 0.0);
            let (active, _) = extract::active_cells(&tree, &s, 0.0, &mut values);
            let never = isoc::Cancel::new();
            let extract = || extract::extract(&tree, &s, 0.0, &values, &active, &never);
            g.bench_function(id("polygonize"), |b| b.iter(|| black_box(extract())));
            let (mesh, _, _) = extract().expect("never cancelled");
            g.bench_function(id("smooth"), |b| {
                b.iter(|| {
                    let mut m = mesh.clone();
                    black_box(smooth::smooth(&mut m, &s, 0.0, 2))
                })
            });
            let all = MeshOptions {
                octree: opts,
                ..MeshOptions::default()
            };
            g.bench_function(id("total"), |b| {
                b.iter(|| black_box(mesher::mesh(&s, &all, &|_| {})))
            });
        }
    }
    g.finish();
}

criterion_group!(benches, stages);
criterion_main!(benches);
