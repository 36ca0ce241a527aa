//! Twinned-mesh tracking (`isoc animate`) against meshing every frame
//! from scratch, side by side in the same run (Bouthors & Nesme 2007 §4),
//! at about 10k, 50k and 200k geometric triangles on three animations:
//!
//! - `merge`: `corpus/blobs_merge.iso` over t ∈ [0, 0.5] (the blobs merge
//!   at t ≈ 0.223);
//! - `split`: the same played backwards (they split);
//! - `spin`: `corpus/ellipsoid_spin.iso` over t ∈ [0, 0.5] (turning and
//!   stretching, no topology change).
//!
//! 26 frames each (Δt = 0.02), N_p = 4; per animation and size, ê is
//! chosen for a mechanical mesh of about an eighth of the target and α_r
//! for a geometric mesh of about the target, at the first frame. For each case the bench
//! first tracks the whole animation once and prints (stderr) a line of
//! `docs/twin.md`'s table: triangles, the median frame and its stages
//! (`FrameReport::ms`), the slowest frame over the median (the topology
//! change), frames per second, and the robust mesher from scratch on the
//! middle frame — the octree level and `k_max` whose triangle count is
//! nearest the geometric mesh's, 2 smoothing passes, kernels compiled —
//! with the ratio tracked ÷ from scratch. Then criterion measures:
//!
//! - `twin/<anim>/<size>/frame`: `Tracker::advance` over the animation's
//!   frames in turn (a new tracker, untimed, when it ends), so the mean
//!   includes the topology-change frame;
//! - `twin/<anim>/<size>/scratch`: the robust mesher on the middle frame.
//!
//! Run: `RAYON_NUM_THREADS=1 cargo bench --bench twin` (and with 2);
//! `ISOC_TWIN_ONLY=50k` (or `merge`, `spin/10k`, …) runs only the cases
//! whose id contains it.
//! Figures are in `docs/twin.md`.

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::{Criterion, criterion_group, criterion_main};
use isoc::mesher::{self, MeshOptions};
use isoc::octree::OctreeOptions;
use isoc::twin::{FrameReport, Tracker, TwinOptions, geometric};
use isoc::{CompileOptions, Surface};

/// An animation: corpus file, first and last time.
struct Animation {
    name: &'static str,
    file: &'static str,
    t0: f64,
    t1: f64,
}

const ANIMATIONS: [Animation; 3] = [
    Animation {
        name: "merge",
        file: "blobs_merge",
        t0: 0.0,
        t1: 0.5,
    },
    Animation {
        name: "split",
        file: "blobs_merge",
        t0: 0.5,
        t1: 0.0,
    },
    Animation {
        name: "spin",
        file: "ellipsoid_spin",
        t0: 0.0,
        t1: 0.5,
    },
];

const FRAMES: usize = 26;
const SIZES: [usize; 3] = [10_000, 50_000, 200_000];

impl Animation {
    fn time(&self, k: usize) -> f64 {
        self.t0 + (self.t1 - self.t0) * k as f64 / (FRAMES - 1) as f64
    }
}

fn surface(name: &str) -> Surface {
    let path = format!("{}/corpus/{name}.iso", env!("CARGO_MANIFEST_DIR"));
    let src = std::fs::read_to_string(&path).expect("corpus file");
    Surface::compile(&src, &path, &CompileOptions::default()).expect("compiles")
}

fn options(edge: f64, alpha_deg: f64) -> TwinOptions {
    TwinOptions {
        edge: Some(edge),
        alpha_deg,
        passes: 4,
        ..TwinOptions::default()
    }
}

/// Options whose meshes at the animation's start have about `target`
/// geometric triangles: ê for a mechanical mesh of about target / 8
/// (three secant steps from triangles ∝ ê⁻²), then α_r by bisection on
/// its logarithm.
fn options_for(s: &Surface, a: &Animation, target: usize) -> TwinOptions {
    let mech_target = target as f64 / GEOMETRIC_PER_MECHANICAL;
    let mut edge = 0.1;
    let mut tr = Tracker::new(s, a.t0, &options(edge, 20.0)).expect("tracker");
    for _ in 0..3 {
        let ratio = tr.mechanical().triangles.len() as f64 / mech_target;
        if ratio.ln().abs() < 0.1 {
            break;
        }
        edge *= ratio.sqrt();
        tr = Tracker::new(s, a.t0, &options(edge, 20.0)).expect("tracker");
    }
    let (mut lo, mut hi) = (0.2f64, 40.0f64);
    for _ in 0..8 {
        let mid = (lo * hi).sqrt();
        let (geo, _) = geometric::refine(tr.mechanical(), s, a.t0, mid, 4);
        if geo.triangles.len() > target {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    options(edge, (lo * hi).sqrt())
}

/// How many geometric triangles per mechanical one the bench asks for.
const GEOMETRIC_PER_MECHANICAL: f64 = 8.0;

fn scratch_options(level: u8, kmax: f64, t: f64) -> MeshOptions {
    MeshOptions {
        octree: OctreeOptions {
            max_level: level,
            kmax,
            t,
            ..OctreeOptions::default()
        },
        ..MeshOptions::default()
    }
}

/// The robust mesher's options at `t` whose triangle count is nearest
/// `target`, with that count.
fn scratch_for(s: &Surface, t: f64, target: usize) -> (MeshOptions, usize) {
    let mut best = (scratch_options(8, 0.3, t), usize::MAX, f64::INFINITY);
    for level in 7u8..=10 {
        let mut most = 0;
        for kmax in [1.0, 0.5, 0.3, 0.2, 0.15, 0.1, 0.05] {
            let opts = scratch_options(level, kmax, t);
            let n = mesher::mesh(s, &opts, &|_| {}).0.triangles.len();
            most = most.max(n);
            let miss = (n as f64 / target as f64).ln().abs();
            if miss < best.2 {
                best = (opts, n, miss);
            }
        }
        // Finer levels only give more triangles.
        if most >= target {
            break;
        }
    }
    (best.0, best.1)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Tracks the whole animation once; its frame reports.
fn track(s: &Surface, a: &Animation, opts: &TwinOptions) -> Vec<FrameReport> {
    let mut tr = Tracker::new(s, a.t0, opts).expect("tracker");
    (0..FRAMES)
        .map(|k| tr.advance(a.time(k)).expect("frame"))
        .collect()
}

fn twin(c: &mut Criterion) {
    let threads = rayon::current_num_threads();
    eprintln!(
        "| animation | target | ê, α_r | mechanical / geometric triangles | median frame ms (watch / mechanical / geometric) | slowest frame ÷ median | fps | from scratch ms (triangles) | tracked ÷ from scratch | ({threads} thread(s)) |"
    );
    let mut g = c.benchmark_group("twin");
    g.sample_size(10);
    g.warm_up_time(Duration::from_millis(500));
    g.measurement_time(Duration::from_secs(3));
    for a in &ANIMATIONS {
        let s = surface(a.file);
        for target in SIZES {
            let id = format!("{}/{}k", a.name, target / 1000);
            if std::env::var("ISOC_TWIN_ONLY").is_ok_and(|only| !id.contains(&only)) {
                continue;
            }
            let opts = options_for(&s, a, target);
            // Skip frame 0 (the tracker's construction relaxes there).
            let reps = &track(&s, a, &opts)[1..];
            let med = |f: fn(&FrameReport) -> f64| median(reps.iter().map(f).collect());
            let frame = med(|r| r.ms.total);
            let slowest = reps.iter().map(|r| r.ms.total).fold(0.0, f64::max);
            let mid = FRAMES / 2;
            let geo = reps[mid - 1].geometric_triangles;
            let (scratch, n) = scratch_for(&s, a.time(mid), geo);
            let scratch_ms = median(
                (0..3)
                    .map(|_| {
                        let t0 = Instant::now();
                        black_box(mesher::mesh(&s, &scratch, &|_| {}));
                        t0.elapsed().as_secs_f64() * 1e3
                    })
                    .collect(),
            );
            eprintln!(
                "| {} | {}k | {:.3}, {:.1}° | {} / {} | {frame:.1} ({:.1} / {:.1} / {:.1}) | {:.1} | {:.1} | {scratch_ms:.0} ({n}, level {}, k_max {}) | {:.3} |",
                a.name,
                target / 1000,
                opts.edge.unwrap_or(0.0),
                opts.alpha_deg,
                med(|r| r.mechanical_triangles as f64),
                med(|r| r.geometric_triangles as f64),
                med(|r| r.ms.watch),
                med(|r| r.ms.mechanical),
                med(|r| r.ms.geometric),
                slowest / frame,
                1e3 / frame,
                scratch.octree.max_level,
                scratch.octree.kmax,
                frame / scratch_ms,
            );

            g.bench_function(format!("{id}/frame"), |b| {
                let mut tr = Tracker::new(&s, a.t0, &opts).expect("tracker");
                let mut k = 1;
                b.iter_custom(|iters| {
                    let mut spent = Duration::ZERO;
                    for _ in 0..iters {
                        if k == FRAMES {
                            tr = Tracker::new(&s, a.t0, &opts).expect("tracker");
                            k = 1;
                        }
                        let t0 = Instant::now();
                        black_box(tr.advance(a.time(k)).expect("frame"));
                        spent += t0.elapsed();
                        k += 1;
                    }
                    spent
                })
            });
            g.bench_function(format!("{id}/scratch"), |b| {
                b.iter(|| black_box(mesher::mesh(&s, &scratch, &|_| {})))
            });
        }
    }
    g.finish();
}

criterion_group!(benches, twin);
criterion_main!(benches);
