//! isoc vs Fidget, side by side: prints Markdown tables of timings and
//! ratios (isoc time / Fidget time; < 1 means isoc is faster).
//!
//! ```text
//! cargo run --release                       # everything (~2–4 min)
//! cargo run --release -- --quick            # fewer repetitions
//! cargo run --release -- --levels 6 heart torus
//! cargo run --release -- --no-mesh          # kernels only
//! ```
//!
//! With `ISOC_PEERS_OBJ=DIR`, `--faithful` also writes both meshes of each
//! row to `DIR/NAME_LEVEL_isoc.obj` and `DIR/NAME_LEVEL_fidget.obj` (a
//! `/` in the name, as `csg/rs5001`'s, becomes `_`).

use isoc_peers::*;
use std::time::Instant;

/// Median wall time (seconds) of `f`, after one warm-up call: at least
/// `min_reps` runs, then more until `budget` seconds have passed (at most 200).
fn median(mut f: impl FnMut() -> f64, min_reps: usize, budget: f64) -> f64 {
    std::hint::black_box(f());
    let start = Instant::now();
    let mut t = Vec::new();
    while t.len() < min_reps || (start.elapsed().as_secs_f64() < budget && t.len() < 200) {
        let t0 = Instant::now();
        std::hint::black_box(f());
        t.push(t0.elapsed().as_secs_f64());
    }
    t.sort_by(f64::total_cmp);
    t[t.len() / 2]
}

/// The surfaces of a table (the named ones, else `default`) and the runs
/// per measurement (1 with `--quick`, else 3).
fn surfaces<'a>(a: &'a Args, default: &[&'a str]) -> (Vec<&'a str>, usize) {
    let names = if a.only.is_empty() {
        default.to_vec()
    } else {
        a.only.iter().map(String::as_str).collect()
    };
    (names, if a.quick { 1 } else { 3 })
}

/// The median wall time (seconds) of `reps` runs of `run`, after one
/// warm-up, and the last run's result.
fn timed<T>(reps: usize, mut run: impl FnMut() -> T) -> (T, f64) {
    let mut last = None;
    let t = median(
        || {
            last = Some(run());
            0.0
        },
        reps,
        0.0,
    );
    (last.expect("median runs at least once"), t)
}

/// Median of `reps` self-timed measurements.
fn median_of(mut f: impl FnMut() -> f64, reps: usize) -> f64 {
    f();
    let mut t: Vec<f64> = (0..reps).map(|_| f()).collect();
    t.sort_by(f64::total_cmp);
    t[t.len() / 2]
}

struct Args {
    quick: bool,
    mesh: bool,
    levels: Vec<u8>,
    /// isoc's smoothing passes (0: none, as Fidget; 3: isoc's default).
    smooth: usize,
    /// Only the tolerance table (isoc `--tolerance` against Fidget depth 8).
    tolerance: bool,
    /// Only the faithful-defaults table (`isoc mesh --level L` against
    /// Fidget depth L, at each of `levels`).
    faithful: bool,
    /// The chord tolerance of `--faithful` runs (default: isoc's).
    chord: Option<f64>,
    only: Vec<String>,
}

fn args() -> Args {
    let mut a = Args {
        quick: false,
        mesh: true,
        levels: vec![6, 7],
        smooth: 0,
        tolerance: false,
        faithful: false,
        chord: None,
        only: vec![],
    };
    let mut it = std::env::args().skip(1);
    while let Some(s) = it.next() {
        match s.as_str() {
            "--quick" => a.quick = true,
            "--no-mesh" => a.mesh = false,
            "--tolerance" => a.tolerance = true,
            "--faithful" => a.faithful = true,
            "--chord" => a.chord = it.next().and_then(|c| c.parse().ok()),
            "--levels" => {
                a.levels = it
                    .next()
                    .expect("--levels 6,7")
                    .split(',')
                    .map(|l| l.trim().parse().expect("a level"))
                    .collect()
            }
            "--smooth" => a.smooth = it.next().and_then(|n| n.parse().ok()).expect("--smooth 3"),
            "-h" | "--help" => {
                println!(
                    "usage: isoc-peers [--quick] [--no-mesh] [--levels 6,7] [--smooth N] [--tolerance] [--faithful [--chord C]] [formula…]"
                );
                std::process::exit(0);
            }
            _ => a.only.push(s),
        }
    }
    a
}

fn ns(s: f64, n: usize) -> String {
    format!("{:.1}", s * 1e9 / n as f64)
}

fn topo_cell(
    components: usize,
    genus: Option<i64>,
    watertight: bool,
    expect: Option<Expect>,
) -> String {
    let g = genus.map_or("?".to_string(), |g| g.to_string());
    let ok = match expect {
        Some(e) => {
            if watertight && components == e.components && genus == Some(e.genus) {
                "✓"
            } else {
                "✗"
            }
        }
        None => "",
    };
    format!(
        "C={components} g={g} {} {ok}",
        if watertight { "closed" } else { "OPEN" }
    )
}

fn main() {
    let a = args();
    if a.tolerance {
        tolerance_table(&a);
        return;
    }
    if a.faithful {
        faithful_table(&a);
        return;
    }
    let names: Vec<&str> = CORPUS
        .iter()
        .chain(&MODELS)
        .copied()
        .filter(|n| a.only.is_empty() || a.only.iter().any(|o| o == n))
        .collect();
    let (n_points, box_level) = (1usize << 16, 5u32);
    let (reps, budget) = if a.quick { (5, 0.15) } else { (11, 0.5) };
    let started = Instant::now();

    let cases: Vec<Case> = names
        .iter()
        .map(|n| Case::load(n).unwrap_or_else(|e| panic!("{e}")))
        .collect();

    println!(
        "## Kernels (single thread; ns per evaluation, median of ≥{reps} runs; ratio = isoc / Fidget)\n"
    );
    println!(
        "Points: {n_points} random points in the domain per call. Boxes: the {} cells of the uniform \
         level-{box_level} grid over the domain.\n",
        1usize << (3 * box_level)
    );
    println!(
        "| formula | IR ops | Fidget ops | f32 agreement | point batch isoc | float_slice Fidget | **ratio** \
         | interval isoc 1-box | interval isoc batch | interval Fidget 1-box | **ratio 1-box** | **ratio batch** \
         | grad isoc (interval, batch) | grad_slice Fidget (point) | **ratio** \
         | compile isoc ms | compile Fidget ms | **ratio** |"
    );
    println!("|{}", "---|".repeat(18));
    for c in &cases {
        let w = Workload::new(&c.surface.domain, n_points, box_level);
        let mut r = Runners::new(c, &w);
        let agree = r.point_agreement();
        let np = w.n_points();
        let nb = w.n_boxes();
        let ip = median(|| r.isoc_point_batch(), reps, budget);
        let fp = median(|| r.fidget_float_slice(), reps, budget);
        let ii = median(|| r.isoc_interval_single(), reps, budget);
        let ib = median(|| r.isoc_interval_batch(), reps, budget);
        let fi = median(|| r.fidget_interval(), reps, budget);
        let ig = median(|| r.isoc_grad_batch(), reps, budget);
        let fg = median(|| r.fidget_grad_slice(), reps, budget);
        // compile: median of repeated compiles (the first one pays one-time set-up)
        let ic = median_of(|| c.time_isoc_compile(), reps);
        let fc = median_of(|| c.time_fidget_compile(), reps);
        println!(
            "| {} | {} | {} | {:.1e} | {} | {} | **{:.2}** | {} | {} | {} | **{:.2}** | **{:.2}** | {} | {} | **{:.2}** | {:.2} | {:.2} | **{:.2}** |",
            c.name,
            c.surface.program.len(),
            c.fidget_size(),
            agree,
            ns(ip, np),
            ns(fp, np),
            ip / fp,
            ns(ii, nb),
            ns(ib, nb),
            ns(fi, nb),
            ii / fi,
            ib / fi,
            ns(ig, nb),
            ns(fg, nb),
            ig / fg,
            ic * 1e3,
            fc * 1e3,
            ic / fc,
        );
    }

    if a.mesh {
        println!(
            "\n## Meshing (same box, same depth; wall time, median of {} runs, {} rayon threads; ratio = isoc / Fidget)\n",
            if a.quick { 1 } else { 3 },
            rayon_threads()
        );
        let smoothing = match a.smooth {
            0 => "no smoothing (Fidget has none)".to_string(),
            n => format!("{n} smoothing passes (`isoc mesh`'s default is 3)"),
        };
        println!(
            "isoc: paper topology test, k_max = 1, min level 3, {smoothing}. Fidget: Manifold Dual Contouring. \
             Topology computed by this benchmark from each mesh's triangles (C = components, g = total genus, \
             closed = every edge in exactly two triangles); ✓ = closed with the corpus file's expected C and g. \
             Distances: |f(p)| / ‖∇f(p)‖ in f64 at each vertex and at each triangle centroid (a first-order distance to the surface), \
             in units of the finest cell edge at that depth.\n"
        );
        println!(
            "| formula | depth | isoc ms | Fidget ms | **time ratio** | isoc tris | Fidget tris | **tris ratio** \
             | isoc topology | Fidget topology | isoc guaranteed (ambiguous cells) | Fidget non-manifold / boundary / misoriented edges \
             | isoc vertex max | isoc centroid mean / p99.9 / max | Fidget vertex max | Fidget centroid mean / p99.9 / max |"
        );
        println!("|{}", "---|".repeat(16));
        let mesh_reps = if a.quick { 1 } else { 3 };
        for c in &cases {
            for &level in &a.levels {
                let mut isoc_res = None;
                let ti = median(
                    || {
                        let (m, rep) = isoc_mesh(c, level, a.smooth);
                        let n = m.triangles.len() as f64;
                        isoc_res = Some((m, rep));
                        n
                    },
                    mesh_reps,
                    0.0,
                );
                let mut fid_res = None;
                let tf = median(
                    || {
                        let m = fidget_mesh(c, level);
                        let n = m.triangles.len() as f64;
                        fid_res = Some(m);
                        n
                    },
                    mesh_reps,
                    0.0,
                );
                let (im, rep) = isoc_res.unwrap();
                let fm = fid_res.unwrap();
                let it = topology(&isoc_triangles(&im));
                let ft = topology(&fidget_triangles(&fm));
                let tr = &rep.topology;
                let igenus: Option<i64> = tr.genus.iter().copied().sum();
                if it.components != tr.components || it.watertight != tr.watertight {
                    eprintln!(
                        "note: {} level {level}: isoc's report (C={} watertight={}) differs from this benchmark's count (C={} watertight={})",
                        c.name, tr.components, tr.watertight, it.components, it.watertight
                    );
                }
                let (ip, fp) = (isoc_points(&im), fidget_points(&fm));
                let (_, _, ivx) = vertex_distance(c, &ip, level);
                let (icm, icp, icx) =
                    vertex_distance(c, &centroids(&ip, &isoc_triangles(&im)), level);
                let (_, _, fvx) = vertex_distance(c, &fp, level);
                let (fcm, fcp, fcx) =
                    vertex_distance(c, &centroids(&fp, &fidget_triangles(&fm)), level);
                println!(
                    "| {} | {level} | {:.1} | {:.1} | **{:.2}** | {} | {} | **{:.2}** | {} | {} | {} ({}) | {} / {} / {} | {:.1e} | {:.1e} / {:.1e} / {:.1e} | {:.1e} | {:.1e} / {:.1e} / {:.1e} |",
                    c.name,
                    ti * 1e3,
                    tf * 1e3,
                    ti / tf,
                    im.triangles.len(),
                    fm.triangles.len(),
                    im.triangles.len() as f64 / fm.triangles.len().max(1) as f64,
                    topo_cell(tr.components, igenus, tr.watertight, c.expect),
                    topo_cell(ft.components, ft.genus, ft.watertight, c.expect),
                    if rep.guaranteed { "yes" } else { "no" },
                    rep.ambiguous_cells,
                    ft.nonmanifold_edges,
                    ft.boundary_edges,
                    ft.misoriented_edges,
                    ivx,
                    icm,
                    icp,
                    icx,
                    fvx,
                    fcm,
                    fcp,
                    fcx,
                );
            }
        }
    }
    eprintln!("total {:.1} s", started.elapsed().as_secs_f64());
}

/// isoc `--tolerance D` (D = 10⁻⁴ of the domain's diagonal) against Fidget
/// at depth 8 (issue 11's targets), on [`TOLERANCE_SET`] or the named
/// surfaces.
fn tolerance_table(a: &Args) {
    let (names, reps) = surfaces(a, &TOLERANCE_SET);
    println!(
        "## Meshing to a tolerance (wall time, median of {reps} runs, {} rayon threads; ratio = isoc / Fidget)\n",
        rayon_threads()
    );
    println!(
        "isoc: `mesh --tolerance D` with D = 10⁻⁴ of the domain's diagonal (level cap 10, all defaults). \
         Fidget: Manifold Dual Contouring at depth 8. Chord error: |f| / ‖∇f‖ at every triangle centroid, \
         in units of D (target: 99.9th percentile ≤ 1, max ≤ 3). Aspect: share of triangles with \
         aspect ratio > 0.8. Topology from each mesh's triangles.\n"
    );
    println!(
        "| surface | D | isoc tris | Fidget tris | **tris ratio** | isoc ms | Fidget ms | **time ratio** \
         | isoc chord p99.9 / max | Fidget chord p99.9 / max | isoc aspect | Fidget aspect \
         | isoc topology | Fidget topology | isoc met |"
    );
    println!("|{}", "---|".repeat(15));
    for name in names {
        let c = Case::load(name).unwrap_or_else(|e| panic!("{e}"));
        let d = 1e-4 * diagonal(&c);
        let ((im, rep, tol), ti) = timed(reps, || isoc_mesh_tolerance(&c, d));
        let (fm, tf) = timed(reps, || fidget_mesh(&c, 8));
        let (ip, fp) = (isoc_points(&im), fidget_points(&fm));
        let (it, ft) = (isoc_triangles(&im), fidget_triangles(&fm));
        let (_, icp, icx) = distance_in(&c, &centroids(&ip, &it), d);
        let (_, fcp, fcx) = distance_in(&c, &centroids(&fp, &ft), d);
        let (itop, ftop) = (topology(&it), topology(&ft));
        let tr = &rep.topology;
        let igenus: Option<i64> = tr.genus.iter().copied().sum();
        if itop.components != tr.components || itop.watertight != tr.watertight {
            eprintln!(
                "note: {name}: isoc's report (C={} watertight={}) differs from this benchmark's count (C={} watertight={})",
                tr.components, tr.watertight, itop.components, itop.watertight
            );
        }
        println!(
            "| {name} | {d:.2e} | {} | {icp:.2} / {icx:.2} | {fcp:.2} / {fcx:.2} | {:.3} | {:.3} | {} | {} | {} |",
            sizes_and_times((it.len(), ft.len()), (ti, tf)),
            aspect_share(&ip, &it),
            aspect_share(&fp, &ft),
            topo_cell(tr.components, igenus, tr.watertight, c.expect),
            topo_cell(ftop.components, ftop.genus, ftop.watertight, c.expect),
            if tol.met { "yes" } else { "no" },
        );
    }
}

/// The table cells "isoc tris | Fidget tris | **ratio** | isoc ms |
/// Fidget ms | **ratio**" of a side-by-side run (times in seconds).
fn sizes_and_times((it, ft): (usize, usize), (ti, tf): (f64, f64)) -> String {
    format!(
        "{it} | {ft} | **{:.2}** | {:.1} | {:.1} | **{:.2}**",
        it as f64 / ft.max(1) as f64,
        ti * 1e3,
        tf * 1e3,
        ti / tf
    )
}

/// `isoc mesh FILE --level L` with every default (issue 21's faithful
/// `--level`) against Fidget at depth L, on the corpus formulas and models
/// or the named surfaces, at each of `--levels`.
fn faithful_table(a: &Args) {
    let all: Vec<&str> = CORPUS.iter().chain(&MODELS).copied().collect();
    let (names, reps) = surfaces(a, &all);
    println!(
        "## Faithful `--level` (wall time, median of {reps} runs, {} rayon threads; ratio = isoc / Fidget)\n",
        rayon_threads()
    );
    println!(
        "isoc: `mesh --level L`, every default. Fidget: Manifold Dual Contouring at depth L. Chord error: \
         |f| / ‖∇f‖ at every triangle centroid and edge midpoint, 99.9th percentile, in cells of depth L \
         (largest domain side / 2^L). Targets: chord ratio ≤ 1, triangles ≤ 0.6, time ≤ 1.\n"
    );
    println!(
        "| surface | L | isoc tris | Fidget tris | **tris ratio** | isoc ms | Fidget ms | **time ratio** \
         | isoc chord p99.9 | Fidget chord p99.9 | **chord ratio** | isoc topology | Fidget topology |"
    );
    println!("|{}", "---|".repeat(13));
    for name in names {
        let c = Case::load(name).unwrap_or_else(|e| panic!("{e}"));
        for &level in &a.levels {
            let ((im, rep), ti) = timed(reps, || isoc_mesh_default(&c, level, a.chord));
            let (fm, tf) = timed(reps, || fidget_mesh(&c, level));
            let (ip, fp) = (isoc_points(&im), fidget_points(&fm));
            let (it, ft) = (isoc_triangles(&im), fidget_triangles(&fm));
            if let Ok(dir) = std::env::var("ISOC_PEERS_OBJ") {
                let fidget = isoc::Mesh {
                    positions: fp.iter().map(|&p| p.into()).collect(),
                    triangles: ft.iter().map(|t| t.map(|i| i as u32)).collect(),
                    ..Default::default()
                };
                for (who, m) in [("isoc", &im), ("fidget", &fidget)] {
                    let file = name.replace('/', "_");
                    let path = format!("{dir}/{file}_{level}_{who}.obj");
                    isoc::io::write_file(m, std::path::Path::new(&path))
                        .unwrap_or_else(|e| panic!("{e}"));
                }
            }
            let (_, icp, _) = vertex_distance(&c, &chord_points(&ip, &it), level);
            let (_, fcp, _) = vertex_distance(&c, &chord_points(&fp, &ft), level);
            let ftop = topology(&ft);
            let tr = &rep.topology;
            let igenus: Option<i64> = tr.genus.iter().copied().sum();
            println!(
                "| {name} | {level} | {} | {icp:.3} | {fcp:.3} | **{:.2}** | {} | {} |",
                sizes_and_times((it.len(), ft.len()), (ti, tf)),
                icp / fcp,
                topo_cell(tr.components, igenus, tr.watertight, c.expect),
                topo_cell(ftop.components, ftop.genus, ftop.watertight, c.expect),
            );
        }
    }
}

/// The size of rayon's global pool (which both meshers use): the
/// `RAYON_NUM_THREADS` rayon honours, else the machine's parallelism.
fn rayon_threads() -> usize {
    std::env::var("RAYON_NUM_THREADS")
        .ok()
        .and_then(|v| v.parse::<usize>().ok())
        .filter(|&n| n > 0)
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
}
