//! Twinned-mesh tracking (`isoc animate`) against re-meshing every frame
//! from scratch, side by side in the same run (Bouthors & Nesme 2007 §4).
//!
//! On `corpus/ellipsoid_spin.iso` (ê = 0.07, α_r = 7°) and
//! `corpus/blobs_pass.iso` (ê = 0.14, α_r = 6°), 4 passes — about 2,000
//! mechanical and 10,000 geometric triangles — frames 0.01 apart in `t`:
//!
//! - `twin/frame`: one whole `Tracker::advance` (topology watch,
//!   mechanical step, remeshing, geometric rebuild);
//! - `twin/mechanical`: the same with the geometric refinement off
//!   (N_p = 0), i.e. watch + mechanical mesh;
//! - `twin/geometric`: the geometric rebuild alone, from a fixed
//!   mechanical mesh;
//! - `twin/remesh`: the robust mesher from scratch (level 8, the k_max
//!   whose triangle count is closest to the geometric mesh's, 2 smoothing
//!   passes), the kernels already compiled.
//!
//! Run: `cargo bench --bench twin`. Ratios are in `docs/twin.md`.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use isoc::mesher::{self, MeshOptions};
use isoc::octree::OctreeOptions;
use isoc::twin::{Tracker, TwinOptions, geometric};
use isoc::{CompileOptions, Surface};

fn surface(name: &str) -> Surface {
    let path = format!("{}/corpus/{name}.iso", env!("CARGO_MANIFEST_DIR"));
    let src = std::fs::read_to_string(&path).expect("corpus file");
    Surface::compile(&src, &path, &CompileOptions::default()).expect("compiles")
}

fn remesh_options(kmax: f64, t: f64) -> MeshOptions {
    MeshOptions {
        octree: OctreeOptions {
            max_level: 8,
            kmax,
            t,
            ..OctreeOptions::default()
        },
        ..MeshOptions::default()
    }
}

fn twin(c: &mut Criterion) {
    let mut g = c.benchmark_group("twin");
    g.sample_size(20);
    for (name, edge, alpha_deg) in [("ellipsoid_spin", 0.07, 7.0), ("blobs_pass", 0.14, 6.0)] {
        let s = surface(name);
        let opts = TwinOptions {
            edge: Some(edge),
            alpha_deg,
            passes: 4,
            ..TwinOptions::default()
        };

        // Warm up a tracker past the initial relaxation.
        let mut tr = Tracker::new(&s, 0.0, &opts).expect("tracker");
        let mut t = 0.0;
        for _ in 0..10 {
            t += 0.01;
            tr.advance(t).expect("frame");
        }
        t += 0.01;
        let rep = tr.advance(t).expect("frame");
        eprintln!(
            "{name}: {} mechanical, {} geometric triangles at t = {t:.2}",
            rep.mechanical_triangles, rep.geometric_triangles
        );
        g.bench_function(format!("frame/{name}"), |b| {
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
        g.bench_function(format!("mechanical/{name}"), |b| {
            b.iter(|| {
                tt += 0.01;
                black_box(tm.advance(tt).expect("frame"))
            })
        });

        let mech = tm.mechanical().clone();
        g.bench_function(format!("geometric/{name}"), |b| {
            b.iter(|| {
                black_box(geometric::refine(
                    &mech,
                    &s,
                    tt,
                    opts.alpha_deg,
                    opts.passes,
                ))
            })
        });

        // The robust mesher (level 8) at the k_max whose triangle count is
        // nearest the geometric mesh's.
        let target = rep.geometric_triangles as f64;
        let count = |k: f64| {
            let (m, _) = mesher::mesh(&s, &remesh_options(k, tt), &|_| {});
            m.triangles.len()
        };
        let kmax = [1.0, 0.5, 0.4, 0.3, 0.25, 0.2, 0.15]
            .into_iter()
            .min_by_key(|&k| ((count(k) as f64 / target).ln().abs() * 1e6) as u64)
            .unwrap_or(0.3);
        eprintln!(
            "{name} remesh: level 8, k_max {kmax}: {} triangles (geometric mesh: {})",
            count(kmax),
            rep.geometric_triangles
        );
        let mut tr2 = tt;
        g.bench_function(format!("remesh/{name}"), |b| {
            b.iter(|| {
                tr2 += 0.01;
                black_box(mesher::mesh(&s, &remesh_options(kmax, tr2), &|_| {}))
            })
        });
    }
    g.finish();
}

criterion_group!(benches, twin);
criterion_main!(benches);
