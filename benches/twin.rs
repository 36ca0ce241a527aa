//! Twinned-mesh tracking (`isoc animate`) against re-meshing every frame
//! from scratch, side by side in the same run (Bouthors & Nesme 2007 §4).
//!
//! On `corpus/ellipsoid_spin.iso` with ê = 0.07 (about 2,000 mechanical
//! triangles) and α_r = 7°, 4 passes (about 10,000 geometric triangles),
//! frames 0.01 apart in `t`:
//!
//! - `twin/frame`: one whole `Tracker::advance` (topology watch,
//!   mechanical step, remeshing, geometric rebuild);
//! - `twin/mechanical`: the same with the geometric refinement off
//!   (N_p = 0), i.e. watch + mechanical mesh;
//! - `twin/geometric`: the geometric rebuild alone, from a fixed
//!   mechanical mesh;
//! - `twin/remesh`: the robust mesher from scratch at the level whose
//!   triangle count is closest to the geometric mesh's.
//!
//! Run: `cargo bench --bench twin`. Ratios are in `docs/twin.md`.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use isoc::mesh::mesher::{self, MeshOptions, SurfaceField};
use isoc::octree::OctreeOptions;
use isoc::twin::{Tracker, TwinOptions, geometric};
use isoc::{CompileOptions, Surface};

fn surface(name: &str) -> Surface {
    let path = format!("{}/corpus/{name}.iso", env!("CARGO_MANIFEST_DIR"));
    let src = std::fs::read_to_string(&path).expect("corpus file");
    Surface::compile(&src, &path, &CompileOptions::default()).expect("compiles")
}

fn remesh_options(level: u8, t: f64) -> MeshOptions {
    MeshOptions {
        octree: OctreeOptions {
            max_level: level,
            t,
            ..OctreeOptions::default()
        },
        ..MeshOptions::default()
    }
}

fn twin(c: &mut Criterion) {
    let s = surface("ellipsoid_spin");
    let opts = TwinOptions {
        edge: Some(0.07),
        alpha_deg: 7.0,
        passes: 4,
        ..TwinOptions::default()
    };
    let mut g = c.benchmark_group("twin");
    g.sample_size(20);

    // Warm up a tracker past the initial relaxation.
    let mut tr = Tracker::new(&s, 0.0, &opts).expect("tracker");
    let mut t = 0.0;
    for _ in 0..10 {
        t += 0.01;
        tr.advance(t).expect("frame");
    }
    let rep = tr.advance(t + 0.01).expect("frame");
    t += 0.01;
    eprintln!(
        "twin: {} mechanical, {} geometric triangles at t = {t:.2}",
        rep.mechanical_triangles, rep.geometric_triangles
    );
    g.bench_function("frame/ellipsoid_spin", |b| {
        b.iter(|| {
            t += 0.01;
            black_box(tr.advance(t).expect("frame"))
        })
    });

    let mech_only = TwinOptions { passes: 0, ..opts };
    let mut tm = Tracker::new(&s, 0.0, &mech_only).expect("tracker");
    let mut tt = 0.0;
    for _ in 0..11 {
        tt += 0.01;
        tm.advance(tt).expect("frame");
    }
    g.bench_function("mechanical/ellipsoid_spin", |b| {
        b.iter(|| {
            tt += 0.01;
            black_box(tm.advance(tt).expect("frame"))
        })
    });

    let mech = tm.mechanical();
    let field = SurfaceField { surface: &s, t: tt };
    g.bench_function("geometric/ellipsoid_spin", |b| {
        b.iter(|| {
            black_box(geometric::refine(
                &mech,
                &field,
                opts.alpha_deg,
                opts.passes,
            ))
        })
    });

    // The robust mesher at the level nearest the geometric mesh's size.
    let target = rep.geometric_triangles as f64;
    let level = (5u8..=9)
        .min_by_key(|&l| {
            let (m, _) = mesher::mesh(&s, &remesh_options(l, tt), &|_| {});
            ((m.triangles.len() as f64 / target).ln().abs() * 1000.0) as u64
        })
        .unwrap_or(7);
    let (m, _) = mesher::mesh(&s, &remesh_options(level, tt), &|_| {});
    eprintln!(
        "remesh: level {level}, {} triangles (geometric mesh: {})",
        m.triangles.len(),
        rep.geometric_triangles
    );
    let mut tr2 = tt;
    g.bench_function("remesh/ellipsoid_spin", |b| {
        b.iter(|| {
            tr2 += 0.01;
            black_box(mesher::mesh(&s, &remesh_options(level, tr2), &|_| {}))
        })
    });
    g.finish();
}

criterion_group!(benches, twin);
criterion_main!(benches);
