//! Every corpus file compiles through the front end, and its `# expect:`
//! line (components and total genus of a closed surface) agrees with a
//! brute-force sampling of the lowered program: the solid {f < 0} is
//! voxelised on a grid, and
//!
//! - surface components = components(inside, 26-connected) plus
//!   components(outside, 6-connected) minus 1 (each closed surface
//!   separates space, and the regions form a tree);
//! - total genus = components − χ(solid), since χ(∂S) = 2χ(S).
//!
//! The surface must also stay strictly inside the domain (no inside voxel on
//! the grid's boundary layer). The grid has 64 cells per side unless the
//! expect line says `grid=N`.

use crate::support::front::eval;
use isoc::CompileOptions;
use isoc::syntax::front_end;
use std::collections::HashSet;

use crate::support::corpus;

/// The `key=value` pairs (or bare words) of the `# expect:` line.
fn expectation(src: &str) -> Vec<(String, String)> {
    let line = src
        .lines()
        .find_map(|l| l.strip_prefix("# expect:"))
        .expect("an `# expect:` line");
    line.split_whitespace()
        .map(|w| match w.split_once('=') {
            Some((k, v)) => (k.to_string(), v.to_string()),
            None => (w.to_string(), String::new()),
        })
        .collect()
}

#[test]
fn corpus_is_complete() {
    let names: Vec<String> = corpus().into_iter().map(|(n, _)| n).collect();
    for want in [
        "torus_fig1",
        "heart",
        "heart6",
        "smile",
        "twotorus",
        "cyclide",
        "chair_left",
        "chair_mid",
        "chair_right",
        "teardrop",
        "twoplanes",
        "sphere",
        "torus",
        "genus2",
        "twospheres",
        "nested",
        "pulse",
        "chebyshev",
        "decocube",
        "chair_off",
        "bretzel5",
        "bretzel2",
        "lemniscate",
        "tanglecube",
        "orthocircle",
    ] {
        assert!(
            names.iter().any(|n| n.ends_with(&format!("/{want}.iso"))),
            "missing corpus/{want}.iso"
        );
    }
}

#[test]
fn every_corpus_file_compiles() {
    for (name, src) in corpus() {
        let l = match front_end(&src, &name, &CompileOptions::default()) {
            Ok(l) => l,
            Err(e) => panic!("{}", e.render()),
        };
        l.program.validate().unwrap();
        assert!(!expectation(&src).is_empty(), "{name}");
    }
}

/// Grid topology of {f < 0} at time `t`: (components, genus, touches the
/// domain boundary).
fn topology(src: &str, t: f64, n: usize) -> (i64, i64, bool) {
    let l = front_end(src, "f", &CompileOptions::default()).unwrap();
    let (lo, hi) = (l.domain.lo, l.domain.hi);
    let idx = |i: usize, j: usize, k: usize| (i * n + j) * n + k;
    let mut inside = vec![false; n * n * n];
    let mut touches = false;
    for i in 0..n {
        for j in 0..n {
            for k in 0..n {
                let c = |a: usize, d: usize| lo[d] + (a as f64 + 0.5) / n as f64 * (hi[d] - lo[d]);
                let f = eval(&l.program, [c(i, 0), c(j, 1), c(k, 2), t]);
                let ins = f < 0.0;
                inside[idx(i, j, k)] = ins;
                if ins && [i, j, k].iter().any(|&a| a == 0 || a == n - 1) {
                    touches = true;
                }
            }
        }
    }
    let comps = |want: bool, full: bool| -> i64 {
        let mut seen = vec![false; n * n * n];
        let mut count = 0;
        for s in 0..n * n * n {
            if seen[s] || inside[s] != want {
                continue;
            }
            count += 1;
            seen[s] = true;
            let mut stack = vec![s];
            while let Some(c) = stack.pop() {
                let (i, j, k) = (c / (n * n), c / n % n, c % n);
                for di in -1i64..=1 {
                    for dj in -1i64..=1 {
                        for dk in -1i64..=1 {
                            let m = di.abs() + dj.abs() + dk.abs();
                            if m == 0 || (!full && m > 1) {
                                continue;
                            }
                            let (a, b, d) = (i as i64 + di, j as i64 + dj, k as i64 + dk);
                            if [a, b, d].iter().any(|&v| v < 0 || v >= n as i64) {
                                continue;
                            }
                            let q = idx(a as usize, b as usize, d as usize);
                            if !seen[q] && inside[q] == want {
                                seen[q] = true;
                                stack.push(q);
                            }
                        }
                    }
                }
            }
        }
        count
    };
    let ins = comps(true, true);
    let outs = comps(false, false);
    // Euler characteristic of the union of closed inside cubes: count the
    // cells of each dimension (keyed by doubled coordinates).
    let mut cells: [HashSet<(usize, usize, usize)>; 4] = Default::default();
    for (s, _) in inside.iter().enumerate().filter(|(_, ins)| **ins) {
        let (i, j, k) = (s / (n * n), s / n % n, s % n);
        for a in 0..3 {
            for b in 0..3 {
                for c in 0..3 {
                    let dim = [a, b, c].iter().filter(|&&v| v == 1).count();
                    cells[dim].insert((2 * i + a, 2 * j + b, 2 * k + c));
                }
            }
        }
    }
    let chi = cells[0].len() as i64 - cells[1].len() as i64 + cells[2].len() as i64
        - cells[3].len() as i64;
    let surfaces = ins + outs - 1;
    (surfaces, surfaces - chi, touches)
}

#[test]
fn corpus_topology_matches_expectations() {
    let mut failures = Vec::new();
    for (name, src) in corpus() {
        let e = expectation(&src);
        let get = |k: &str| {
            e.iter()
                .find(|(a, _)| a == k)
                .map(|(_, v)| v.parse::<i64>().unwrap())
        };
        let (Some(comp), Some(genus)) = (get("components"), get("genus")) else {
            assert!(
                e.iter().any(|(k, _)| k == "singular"),
                "{name}: no topology"
            );
            continue;
        };
        let (c, g, touches) = topology(&src, 0.0, get("grid").unwrap_or(64) as usize);
        if (c, g, touches) != (comp, genus, false) {
            failures.push(format!(
                "{name}: expected components={comp} genus={genus}, sampled {c} and {g}{}",
                if touches {
                    " (touches the domain boundary)"
                } else {
                    ""
                }
            ));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Resolution study for one file (`CORPUS_FILE=… cargo test -- --ignored`).
#[test]
#[ignore]
fn topology_at_several_resolutions() {
    let file = std::env::var("CORPUS_FILE").unwrap_or("corpus/chair_mid.iso".into());
    let src = std::fs::read_to_string(&file).unwrap();
    for n in [60, 100, 140] {
        println!("{file} n={n}: {:?}", topology(&src, 0.0, n));
    }
}

/// The corpus formulas written by hand in Rust, compared with the lowered
/// programs (run by the reference point evaluator) at scattered points.
#[test]
fn corpus_values_match_hand_written_formulas() {
    type F = fn(f64, f64, f64, f64) -> f64;
    fn g(x: f64, y: f64, z: f64, c: f64) -> f64 {
        (x * x + y * y + z * z + c).powi(2) - 64.0 * (x * x + y * y)
    }
    fn chair(x: f64, y: f64, z: f64, _: f64) -> f64 {
        let (a, b, k) = (0.95, 0.8, 5.0);
        (x * x + y * y + z * z - a * k * k).powi(2)
            - b * ((z - k).powi(2) - 2.0 * x * x) * ((z + k).powi(2) - 2.0 * y * y)
    }
    let cases: [(&str, F); 29] = [
        ("torus_fig1", |x, y, z, _| {
            (1.5 - (x * x + y * y).sqrt()).powi(2) + z * z - 1.35f64.powi(2)
        }),
        ("heart", |x, y, z, _| {
            (2.0 * x * x + y * y + z * z - 1.0).powi(3) - (0.1 * x * x + y * y) * z.powi(3)
        }),
        ("heart6", |x, y, z, _| {
            (2.0 * x * x + y * y + z * z - 1.0).powi(6) - (0.1 * x * x + y * y) * z.powi(3)
        }),
        ("smile", |x, y, z, _| {
            (y - x * x - y * y + 1.0).powi(4) + (x * x + y * y + z * z).powi(4) - 1.0
        }),
        ("twotorus", |x, y, z, _| {
            g(10.0 * x, 8.0 * y - 2.0, 10.0 * z, 13.0) * g(10.0 * z, 10.0 * y + 2.0, 10.0 * x, 12.0)
                + 1000.0
        }),
        ("cyclide", |x, y, z, _| {
            let (a, b, r): (f64, f64, f64) = (10.0, 2.0, 2.0);
            (x * x + y * y + z * z).powi(2)
                - 2.0 * (x * x + r * r) * (a * a + b * b)
                - 2.0 * (y * y - z * z) * (a * a - b * b)
                + (a * a - b * b).powi(2)
                + 8.0 * a * b * r * x
        }),
        ("chair_left", chair),
        ("chair_mid", chair),
        ("chair_right", chair),
        ("teardrop", |x, y, z, _| {
            0.5 * x.powi(5) + 0.5 * x.powi(4) - y * y - z * z
        }),
        ("twoplanes", |x, y, _, _| x * y),
        ("sphere", |x, y, z, _| x * x + y * y + z * z - 1.0),
        ("torus", |x, y, z, _| {
            ((x * x + y * y).sqrt() - 1.0).powi(2) + z * z - 0.16
        }),
        ("genus2", |x, y, z, _| {
            (x * (x - 1.0).powi(2) * (x - 2.0) + y * y).powi(2) + z * z - 0.01
        }),
        ("twospheres", |x, y, z, _| {
            ((x + 1.5).powi(2) + y * y + z * z - 1.0).min((x - 1.5).powi(2) + y * y + z * z - 1.0)
        }),
        ("nested", |x, y, z, _| {
            let rr = x * x + y * y + z * z;
            (rr - 1.0) * (rr - 4.0)
        }),
        ("pulse", |x, y, z, t| {
            x * x + y * y + z * z - (1.0 + 0.5 * (2.0 * std::f64::consts::PI * t).sin()).powi(2)
        }),
        ("ellipsoid_spin", |x, y, z, t| {
            let th = std::f64::consts::PI * t / 2.0;
            let u = x * th.cos() + y * th.sin();
            let v = -x * th.sin() + y * th.cos();
            let a = 1.2 + 0.4 * (2.0 * std::f64::consts::PI * t).sin();
            (u / a).powi(2) + (v / 0.6).powi(2) + (z / 0.5).powi(2) - 1.0
        }),
        ("blobs_pass", |x, y, z, t| {
            let s = 0.8 * (2.0 * std::f64::consts::PI * t).sin();
            let blob = |cx: f64, cy: f64| (-((x - cx).powi(2) + (y - cy).powi(2) + z * z)).exp();
            0.3 - blob(-1.6, s) - blob(1.6, -s)
        }),
        ("blobs_merge", |x, y, z, t| {
            let d = 1.6 - t;
            let blob = |cx: f64| (-((x - cx).powi(2) + y * y + z * z)).exp();
            0.3 - blob(-d) - blob(d)
        }),
        ("chebyshev", |x, y, z, _| {
            let t6 = |u: f64| 32.0 * u.powi(6) - 48.0 * u.powi(4) + 18.0 * u * u - 1.0;
            t6(x) + t6(y) + t6(z)
        }),
        ("decocube", |x, y, z, _| {
            let ring =
                |u: f64, v: f64, w: f64| (u * u + v * v - 0.64).powi(2) + (w * w - 1.0).powi(2);
            ring(x, y, z) * ring(y, z, x) * ring(z, x, y) - 0.01
        }),
        ("chair_off", |x, y, z, _| {
            let (x, y, z) = (x - 0.37, y + 0.61, z - 0.23);
            let k: f64 = 5.0;
            (x * x + y * y + z * z - 0.95 * k * k).powi(2)
                - 0.8 * ((z - k).powi(2) - 2.0 * x * x) * ((z + k).powi(2) - 2.0 * y * y)
        }),
        ("torus_twist", |x, y, z, t| {
            let phi = t * x;
            let v = y * phi.cos() + z * phi.sin();
            let w = -y * phi.sin() + z * phi.cos();
            ((x * x + v * v).sqrt() - 1.0).powi(2) + w * w - 0.35f64.powi(2)
        }),
        ("bretzel5", |x, y, z, _| {
            ((x * x + y * y / 4.0 - 1.0) * (x * x / 4.0 + y * y - 1.0)).powi(2) + z * z - 0.1
        }),
        ("bretzel2", |x, y, z, _| {
            (x * x * (1.0 - x * x) - y * y).powi(2) + 0.5 * z * z - 0.01
        }),
        ("lemniscate", |x, y, z, _| {
            (x * x + y * y).powi(2) - (x * x - y * y) + z * z - 0.01
        }),
        ("tanglecube", |x, y, z, _| {
            let q = |u: f64| u.powi(4) - 5.0 * u * u;
            q(x) + q(y) + q(z) + 11.8
        }),
        ("orthocircle", |x, y, z, _| {
            let ring = |u: f64, v: f64, w: f64| (u * u + v * v - 1.0).powi(2) + w * w;
            ring(x, y, z) * ring(y, z, x) * ring(z, x, y)
                - 0.075f64.powi(2) * (1.0 + 3.0 * (x * x + y * y + z * z))
        }),
    ];
    let files = corpus();
    assert_eq!(
        files.len(),
        cases.len(),
        "a corpus file has no hand formula"
    );
    let mut s: u64 = 0x9e37_79b9_7f4a_7c15;
    let mut rnd = move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f64 / (1u64 << 53) as f64
    };
    for (name, f) in cases {
        let (path, src) = files
            .iter()
            .find(|(p, _)| p.ends_with(&format!("/{name}.iso")))
            .unwrap();
        let l = front_end(src, path, &CompileOptions::default()).unwrap();
        for _ in 0..200 {
            let p: [f64; 4] = std::array::from_fn(|d| {
                if d == 3 {
                    rnd()
                } else {
                    l.domain.lo[d] + rnd() * (l.domain.hi[d] - l.domain.lo[d])
                }
            });
            let want = f(p[0], p[1], p[2], p[3]);
            let got = isoc::eval::point::eval(&l.program, p);
            let tol = 1e-9 * (1.0 + want.abs());
            assert!(
                (got - want).abs() <= tol,
                "{name} at {p:?}: lowered {got}, by hand {want}"
            );
        }
    }
}
