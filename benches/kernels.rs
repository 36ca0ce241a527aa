//! JIT kernels vs the reference interpreters, per formula: point (single,
//! batch of 1024), interval (single, batch of 256), interval-gradient
//! (single, batch of 256), and compile time of all kernels.
//!
//! Run: `cargo bench --bench kernels` (filter e.g. `-- heart/`).
//! `cargo bench --bench kernels -- simd/` times the batch point kernel,
//! F64X2 (`JitOptions::simd`, the default) against the scalar loop, on
//! corpus files.
//! Set `ISOC_BENCH_NO_INTERP=1` to skip the interpreter rows.
//! `cargo bench --bench kernels -- compile_scaling/` times the front end
//! and every kernel kind `mesh` needs (compiled in parallel, as `isoc mesh`
//! does) on sums of N terms `k·u·v`, N = 100, 1,000, 10,000: the ratio of
//! the N = 10,000 and N = 1,000 times shows whether compile time is linear.

use std::hint::black_box;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use isoc::interval::Interval;
use isoc::ir::{BinOp, Builder, Const, Program, Value, Var};
use isoc::jit::{JitOptions, Kernels};

/// The formulas, built with the IR builder (same shape as the corpus).
pub fn formulas() -> Vec<(&'static str, Program)> {
    let mut v = Vec::new();
    // sphere: x² + y² + z² − 1
    {
        let mut b = Builder::new();
        let [x, y, z] = xyz(&mut b);
        let s = sum_sq(&mut b, [x, y, z]);
        let one = c(&mut b, 1.0);
        let r = b.binary(BinOp::Sub, s, one);
        v.push(("sphere", b.finish(r)));
    }
    // torus: (x² + y² + z² + R² − r²)² − 4R²(x² + y²), R = 1, r = 0.4
    {
        let mut b = Builder::new();
        let [x, y, z] = xyz(&mut b);
        let s = sum_sq(&mut b, [x, y, z]);
        let k = c(&mut b, 1.0 - 0.16);
        let a = b.binary(BinOp::Add, s, k);
        let a2 = b.powi(a, 2);
        let x2 = b.powi(x, 2);
        let y2 = b.powi(y, 2);
        let xy = b.binary(BinOp::Add, x2, y2);
        let four = c(&mut b, 4.0);
        let m = b.binary(BinOp::Mul, four, xy);
        let r = b.binary(BinOp::Sub, a2, m);
        v.push(("torus", b.finish(r)));
    }
    // heart: (2x² + y² + z² − 1)³ − (0.1x² + y²)z³
    {
        let mut b = Builder::new();
        let [x, y, z] = xyz(&mut b);
        let x2 = b.powi(x, 2);
        let y2 = b.powi(y, 2);
        let z2 = b.powi(z, 2);
        let two = c(&mut b, 2.0);
        let tx = b.binary(BinOp::Mul, two, x2);
        let s = b.binary(BinOp::Add, tx, y2);
        let s = b.binary(BinOp::Add, s, z2);
        let one = c(&mut b, 1.0);
        let a = b.binary(BinOp::Sub, s, one);
        let a3 = b.powi(a, 3);
        let tenth = b.constant(Const {
            value: 0.1,
            lo: 0.1f64.next_down(),
            hi: 0.1,
            defined: true,
        });
        let t = b.binary(BinOp::Mul, tenth, x2);
        let t = b.binary(BinOp::Add, t, y2);
        let z3 = b.powi(z, 3);
        let t = b.binary(BinOp::Mul, t, z3);
        let r = b.binary(BinOp::Sub, a3, t);
        v.push(("heart", b.finish(r)));
    }
    // csg: max(sphere, −min(|x| − 0.5, |y| − 0.5)) with a sqrt distance
    {
        let mut b = Builder::new();
        let [x, y, z] = xyz(&mut b);
        let s = sum_sq(&mut b, [x, y, z]);
        let d = b.unary(isoc::ir::UnOp::Sqrt, s);
        let one = c(&mut b, 1.0);
        let sph = b.binary(BinOp::Sub, d, one);
        let h = c(&mut b, 0.5);
        let ax = b.unary(isoc::ir::UnOp::Abs, x);
        let ay = b.unary(isoc::ir::UnOp::Abs, y);
        let bx = b.binary(BinOp::Sub, ax, h);
        let by = b.binary(BinOp::Sub, ay, h);
        let m = b.binary(BinOp::Min, bx, by);
        let nm = b.unary(isoc::ir::UnOp::Neg, m);
        let r = b.binary(BinOp::Max, sph, nm);
        v.push(("csg", b.finish(r)));
    }
    v
}

fn xyz(b: &mut Builder) -> [Value; 3] {
    [b.var(Var::X), b.var(Var::Y), b.var(Var::Z)]
}

fn c(b: &mut Builder, v: f64) -> Value {
    b.constant(Const::exact(v))
}

fn sum_sq(b: &mut Builder, vs: [Value; 3]) -> Value {
    let sq = vs.map(|v| b.powi(v, 2));
    let s = b.binary(BinOp::Add, sq[0], sq[1]);
    b.binary(BinOp::Add, s, sq[2])
}

fn boxes(n: usize) -> Vec<[Interval; 4]> {
    (0..n)
        .map(|i| {
            let f = i as f64 / n as f64;
            let lo = -1.2 + 2.0 * f;
            let iv = |o: f64| Interval {
                lo: lo + o,
                hi: lo + o + 0.05,
            };
            [iv(0.0), iv(0.13), iv(-0.07), Interval { lo: 0.0, hi: 0.0 }]
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let interp = std::env::var_os("ISOC_BENCH_NO_INTERP").is_none();
    for (name, prog) in formulas() {
        let k = Kernels::compile(&prog).expect("compile");
        let mut g = c.benchmark_group(name);

        g.bench_function("compile_all", |b| {
            b.iter(|| Kernels::compile(black_box(&prog)).expect("compile"))
        });

        let p = [0.3, -0.2, 0.5, 0.0];
        g.throughput(Throughput::Elements(1));
        g.bench_function("point/jit", |b| b.iter(|| k.point(black_box(p))));
        if interp {
            g.bench_function("point/interp", |b| {
                b.iter(|| isoc::eval::point::eval(&prog, black_box(p)))
            });
        }

        const N: usize = 1024;
        let xs: Vec<f64> = (0..N).map(|i| -1.2 + 2.4 * i as f64 / N as f64).collect();
        let ys: Vec<f64> = xs.iter().map(|x| 0.7 * x).collect();
        let zs: Vec<f64> = xs.iter().map(|x| -0.3 * x).collect();
        let mut out = vec![0.0; N];
        g.throughput(Throughput::Elements(N as u64));
        g.bench_function(BenchmarkId::new("point_batch/jit", N), |b| {
            b.iter(|| k.point_batch(&xs, &ys, &zs, 0.0, &mut out).expect("batch"))
        });

        let bx = boxes(256);
        let flat: Vec<f64> = bx
            .iter()
            .flat_map(|b| b.iter().flat_map(|iv| [iv.lo, iv.hi]))
            .collect();
        g.throughput(Throughput::Elements(1));
        g.bench_function("interval/jit", |b| b.iter(|| k.interval(black_box(bx[7]))));
        if interp {
            g.bench_function("interval/interp", |b| {
                b.iter(|| isoc::eval::interval::eval(&prog, black_box(bx[7])))
            });
        }
        let mut out2 = vec![0.0; 2 * bx.len()];
        let mut def = vec![false; bx.len()];
        g.throughput(Throughput::Elements(bx.len() as u64));
        g.bench_function(BenchmarkId::new("interval_batch/jit", bx.len()), |b| {
            b.iter(|| k.interval_batch(&flat, &mut out2, &mut def).expect("batch"))
        });

        g.throughput(Throughput::Elements(1));
        g.bench_function("grad/jit", |b| b.iter(|| k.grad(black_box(bx[7]))));
        if interp {
            g.bench_function("grad/interp", |b| {
                b.iter(|| isoc::eval::grad::eval(&prog, black_box(bx[7])))
            });
        }
        let mut out8 = vec![0.0; 8 * bx.len()];
        g.throughput(Throughput::Elements(bx.len() as u64));
        g.bench_function(BenchmarkId::new("grad_batch/jit", bx.len()), |b| {
            b.iter(|| k.grad_batch(&flat, &mut out8, &mut def).expect("batch"))
        });
        g.finish();
    }
}

/// Batch point kernel, F64X2 vs scalar loop, on corpus files (1024
/// points along a diagonal of the domain's cube `[-1.2, 1.2]^3`).
fn bench_simd(c: &mut Criterion) {
    for name in [
        "sphere",
        "heart",
        "torus_fig1",
        "twotorus",
        "chair_mid",
        "blobs_merge",
    ] {
        let path = format!("{}/corpus/{name}.iso", env!("CARGO_MANIFEST_DIR"));
        let src = std::fs::read_to_string(&path).expect("corpus file");
        let lowered = isoc::syntax::front_end(&src, &path, &isoc::CompileOptions::default())
            .expect("front end");
        let prog = lowered.program;
        let mut g = c.benchmark_group(format!("simd/{name}"));
        const N: usize = 1024;
        let xs: Vec<f64> = (0..N).map(|i| -1.2 + 2.4 * i as f64 / N as f64).collect();
        let ys: Vec<f64> = xs.iter().map(|x| 0.7 * x).collect();
        let zs: Vec<f64> = xs.iter().map(|x| -0.3 * x).collect();
        let mut out = vec![0.0; N];
        g.throughput(Throughput::Elements(N as u64));
        for (label, simd) in [("x2", true), ("scalar", false)] {
            let opts = JitOptions {
                simd,
                ..JitOptions::default()
            };
            let k = Kernels::compile_with(&prog, &opts).expect("compile");
            g.bench_function(BenchmarkId::new(format!("point_batch/{label}"), N), |b| {
                b.iter(|| {
                    k.point_batch(&xs, &ys, &zs, black_box(0.0), &mut out)
                        .expect("batch")
                })
            });
        }
        g.finish();
    }
}

/// `k0·x·y + k1·y·z + k2·x·z + …` with `n` terms and distinct
/// coefficients, as source text.
pub fn sum_source(n: usize) -> String {
    let terms: Vec<String> = (0..n)
        .map(|i| {
            let k = ((i * 7919) % 1000) as f64 / 100.0 + 0.5;
            let v = ["x*y", "y*z", "x*z"][i % 3];
            format!("{k}*{v}")
        })
        .collect();
    format!("domain [-1, 1]^3;\nsurface {} - 1;\n", terms.join(" + "))
}

fn bench_compile_scaling(c: &mut Criterion) {
    let mut g = c.benchmark_group("compile_scaling");
    g.sample_size(10);
    for n in [100, 1_000, 10_000] {
        let src = sum_source(n);
        g.bench_function(BenchmarkId::from_parameter(n), |b| {
            b.iter(|| {
                let s = isoc::Surface::compile(black_box(&src), "sum", &Default::default())
                    .expect("compile");
                s.kernels().prepare(&isoc::jit::Kind::EVERY);
                s
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench, bench_simd, bench_compile_scaling);
criterion_main!(benches);
