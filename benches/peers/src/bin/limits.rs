//! The measured limits behind two kernel ratios (one thread, medians of 21
//! runs):
//!
//! 1. **Point batch.** The heart's point formula, `(2x² + y² + z² − 1)³ −
//!    (0.1x² + y²)·z³`, hand-written with explicit vectors of each width,
//!    against isoc's JIT batch point kernel, on the same 65,536 points (ns
//!    per point). Cranelift's x86-64 backend has 128-bit vectors only, so
//!    isoc's kernel can at best match the f64×2 row; Fidget's
//!    `float_slice` is an f32×8 kernel.
//! 2. **Single-box interval calls.** What a *sound* single call costs
//!    before any arithmetic: isoc's single-box kernel of the program `x`
//!    (entry, rounding-mode probe, the two `ldmxcsr` that switch to round
//!    up and back, return), the two `ldmxcsr` alone, against the heart's
//!    single-box and batch kernels and Fidget's single-box interval
//!    evaluation (ns per box, the 32,768 cells of the level-5 grid).
//!
//! `cargo run --release --bin limits` (in `benches/peers`).

use std::arch::x86_64::*;
use std::hint::black_box;
use std::time::Instant;

const N: usize = 65_536;

fn heart(x: f64, y: f64, z: f64) -> f64 {
    let a = 2.0 * x * x + y * y + z * z - 1.0;
    a * a * a - (0.1 * x * x + y * y) * (z * z * z)
}

fn scalar(xs: &[f64], ys: &[f64], zs: &[f64], out: &mut [f64]) {
    for i in 0..xs.len() {
        out[i] = heart(xs[i], ys[i], zs[i]);
    }
}

/// f64×2 (SSE2), as Cranelift can emit.
fn sse2(xs: &[f64], ys: &[f64], zs: &[f64], out: &mut [f64]) {
    // SAFETY: SSE2 is part of x86-64; loads/stores are in bounds (i + 2 ≤ n).
    unsafe {
        let two = _mm_set1_pd(2.0);
        let one = _mm_set1_pd(1.0);
        let tenth = _mm_set1_pd(0.1);
        let mut i = 0;
        while i + 2 <= xs.len() {
            let x = _mm_loadu_pd(xs.as_ptr().add(i));
            let y = _mm_loadu_pd(ys.as_ptr().add(i));
            let z = _mm_loadu_pd(zs.as_ptr().add(i));
            let (x2, y2, z2) = (_mm_mul_pd(x, x), _mm_mul_pd(y, y), _mm_mul_pd(z, z));
            let a = _mm_sub_pd(_mm_add_pd(_mm_add_pd(_mm_mul_pd(two, x2), y2), z2), one);
            let a3 = _mm_mul_pd(_mm_mul_pd(a, a), a);
            let b = _mm_add_pd(_mm_mul_pd(tenth, x2), y2);
            let z3 = _mm_mul_pd(z2, z);
            _mm_storeu_pd(out.as_mut_ptr().add(i), _mm_sub_pd(a3, _mm_mul_pd(b, z3)));
            i += 2;
        }
    }
}

/// f64×4 (AVX), not available to Cranelift's x86-64 backend.
#[target_feature(enable = "avx")]
unsafe fn avx_f64(xs: &[f64], ys: &[f64], zs: &[f64], out: &mut [f64]) {
    // SAFETY: the caller checked AVX; loads/stores are in bounds.
    unsafe {
        let two = _mm256_set1_pd(2.0);
        let one = _mm256_set1_pd(1.0);
        let tenth = _mm256_set1_pd(0.1);
        let mut i = 0;
        while i + 4 <= xs.len() {
            let x = _mm256_loadu_pd(xs.as_ptr().add(i));
            let y = _mm256_loadu_pd(ys.as_ptr().add(i));
            let z = _mm256_loadu_pd(zs.as_ptr().add(i));
            let (x2, y2, z2) = (
                _mm256_mul_pd(x, x),
                _mm256_mul_pd(y, y),
                _mm256_mul_pd(z, z),
            );
            let a = _mm256_sub_pd(
                _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(two, x2), y2), z2),
                one,
            );
            let a3 = _mm256_mul_pd(_mm256_mul_pd(a, a), a);
            let b = _mm256_add_pd(_mm256_mul_pd(tenth, x2), y2);
            let z3 = _mm256_mul_pd(z2, z);
            _mm256_storeu_pd(
                out.as_mut_ptr().add(i),
                _mm256_sub_pd(a3, _mm256_mul_pd(b, z3)),
            );
            i += 4;
        }
    }
}

/// f32×8 (AVX), the width of Fidget's float slice.
#[target_feature(enable = "avx")]
unsafe fn avx_f32(xs: &[f32], ys: &[f32], zs: &[f32], out: &mut [f32]) {
    // SAFETY: the caller checked AVX; loads/stores are in bounds.
    unsafe {
        let two = _mm256_set1_ps(2.0);
        let one = _mm256_set1_ps(1.0);
        let tenth = _mm256_set1_ps(0.1);
        let mut i = 0;
        while i + 8 <= xs.len() {
            let x = _mm256_loadu_ps(xs.as_ptr().add(i));
            let y = _mm256_loadu_ps(ys.as_ptr().add(i));
            let z = _mm256_loadu_ps(zs.as_ptr().add(i));
            let (x2, y2, z2) = (
                _mm256_mul_ps(x, x),
                _mm256_mul_ps(y, y),
                _mm256_mul_ps(z, z),
            );
            let a = _mm256_sub_ps(
                _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(two, x2), y2), z2),
                one,
            );
            let a3 = _mm256_mul_ps(_mm256_mul_ps(a, a), a);
            let b = _mm256_add_ps(_mm256_mul_ps(tenth, x2), y2);
            let z3 = _mm256_mul_ps(z2, z);
            _mm256_storeu_ps(
                out.as_mut_ptr().add(i),
                _mm256_sub_ps(a3, _mm256_mul_ps(b, z3)),
            );
            i += 8;
        }
    }
}

fn median_ns_per_point(mut f: impl FnMut()) -> f64 {
    for _ in 0..5 {
        f();
    }
    let mut v: Vec<f64> = (0..21)
        .map(|_| {
            let t = Instant::now();
            for _ in 0..20 {
                f();
            }
            t.elapsed().as_secs_f64() * 1e9 / (20 * N) as f64
        })
        .collect();
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let mut s = 0x2545_F491_4F6C_DD1Du64;
    let mut rnd = || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f64 / (1u64 << 53) as f64 * 3.0 - 1.5
    };
    let xs: Vec<f64> = (0..N).map(|_| rnd()).collect();
    let ys: Vec<f64> = (0..N).map(|_| rnd()).collect();
    let zs: Vec<f64> = (0..N).map(|_| rnd()).collect();
    let (xf, yf, zf): (Vec<f32>, Vec<f32>, Vec<f32>) = (
        xs.iter().map(|&v| v as f32).collect(),
        ys.iter().map(|&v| v as f32).collect(),
        zs.iter().map(|&v| v as f32).collect(),
    );
    let mut out = vec![0.0; N];
    let mut outf = vec![0.0f32; N];
    let src = std::fs::read_to_string(isoc_peers::corpus_path("heart")).expect("heart.iso");
    let surface = isoc::Surface::compile(&src, "heart.iso", &Default::default()).expect("compile");
    let k = surface.kernels();

    let jit = median_ns_per_point(|| {
        k.point_batch(&xs, &ys, &zs, 0.0, &mut out).unwrap();
        black_box(&out);
    });
    let check = out.clone();
    let sc = median_ns_per_point(|| {
        scalar(&xs, &ys, &zs, &mut out);
        black_box(&out);
    });
    let v2 = median_ns_per_point(|| {
        sse2(&xs, &ys, &zs, &mut out);
        black_box(&out);
    });
    let max_err = check
        .iter()
        .zip(&out)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(
        max_err < 1e-9,
        "hand-written kernel disagrees with the JIT: {max_err}"
    );
    println!("| kernel (heart, 65,536 points, one thread) | ns / point |");
    println!("|---|---|");
    println!("| isoc JIT batch point (F64X2) | {jit:.3} |");
    println!("| hand-written scalar f64 (rustc -O) | {sc:.3} |");
    println!("| hand-written f64×2 (SSE2) | {v2:.3} |");
    if is_x86_feature_detected!("avx") {
        // SAFETY: AVX detected above.
        let v4 = median_ns_per_point(|| unsafe {
            avx_f64(&xs, &ys, &zs, &mut out);
            black_box(&out);
        });
        // SAFETY: as above.
        let v8 = median_ns_per_point(|| unsafe {
            avx_f32(&xf, &yf, &zf, &mut outf);
            black_box(&outf);
        });
        println!("| hand-written f64×4 (AVX; no Cranelift x64 equivalent) | {v4:.3} |");
        println!("| hand-written f32×8 (AVX; Fidget's width) | {v8:.3} |");
    }
    if is_x86_feature_detected!("avx512f") {
        // SAFETY: AVX-512F detected above.
        let v8 = median_ns_per_point(|| unsafe {
            avx512_f64(&xs, &ys, &zs, &mut out);
            black_box(&out);
        });
        println!("| hand-written f64×8 (AVX-512; no Cranelift x64 equivalent) | {v8:.3} |");
    }
    let fidget = {
        let case = isoc_peers::Case::load("heart").expect("heart");
        let w = isoc_peers::Workload::new(&case.surface.domain, 1 << 16, 5);
        let mut r = isoc_peers::Runners::new(&case, &w);
        median_ns_per_point(|| {
            black_box(r.fidget_float_slice());
        })
    };
    println!("| Fidget `float_slice` (f32×8, same run) | {fidget:.3} |");
    println!();
    single_box();
}

/// Section 2 of the module doc.
fn single_box() {
    let case = isoc_peers::Case::load("heart").expect("heart");
    let w = isoc_peers::Workload::new(&case.surface.domain, 1024, 5);
    let n = w.n_boxes();
    let bare = isoc::Surface::compile(
        "domain [-1.5, 1.5]^3;\nsurface x = 0;\n",
        "x.iso",
        &Default::default(),
    )
    .expect("x");
    let kx = isoc::jit::Kernels::compile(&bare.program).expect("x kernels");
    let per_box = |f: &mut dyn FnMut() -> f64| {
        for _ in 0..3 {
            black_box(f());
        }
        let mut v: Vec<f64> = (0..21)
            .map(|_| {
                let t = Instant::now();
                black_box(f());
                t.elapsed().as_secs_f64() * 1e9 / n as f64
            })
            .collect();
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let floor = per_box(&mut || w.iboxes.iter().map(|b| kx.interval(*b).iv.hi).sum());
    let switch = per_box(&mut || {
        let (up, nearest) = (0x5F80u32, isoc::jit::mxcsr::MXCSR_DEFAULT);
        for _ in 0..n {
            // SAFETY: round up is set and the default restored at once; no
            // float work runs in between.
            unsafe {
                std::arch::asm!("ldmxcsr [{p}]", p = in(reg) &up, options(nostack));
                std::arch::asm!("ldmxcsr [{p}]", p = in(reg) &nearest, options(nostack));
            }
        }
        0.0
    });
    let mut r = isoc_peers::Runners::new(&case, &w);
    let single = per_box(&mut || r.isoc_interval_single());
    let batch = per_box(&mut || r.isoc_interval_batch());
    let fidget = per_box(&mut || r.fidget_interval());
    println!("| single-box interval call ({n} boxes, one thread) | ns / box |");
    println!("|---|---|");
    println!("| isoc single-box kernel of `x` (no arithmetic) | {floor:.1} |");
    println!("| two `ldmxcsr` (round up, back to nearest) alone | {switch:.1} |");
    println!("| isoc single-box kernel of the heart | {single:.1} |");
    println!("| isoc batch kernel of the heart, per box | {batch:.1} |");
    println!("| Fidget single-box interval evaluation of the heart | {fidget:.1} |");
}

/// f64×8 (AVX-512F).
#[target_feature(enable = "avx512f")]
unsafe fn avx512_f64(xs: &[f64], ys: &[f64], zs: &[f64], out: &mut [f64]) {
    // SAFETY: the caller checked AVX-512F; loads/stores are in bounds.
    unsafe {
        let two = _mm512_set1_pd(2.0);
        let one = _mm512_set1_pd(1.0);
        let tenth = _mm512_set1_pd(0.1);
        let mut i = 0;
        while i + 8 <= xs.len() {
            let x = _mm512_loadu_pd(xs.as_ptr().add(i));
            let y = _mm512_loadu_pd(ys.as_ptr().add(i));
            let z = _mm512_loadu_pd(zs.as_ptr().add(i));
            let (x2, y2, z2) = (
                _mm512_mul_pd(x, x),
                _mm512_mul_pd(y, y),
                _mm512_mul_pd(z, z),
            );
            let a = _mm512_sub_pd(
                _mm512_add_pd(_mm512_add_pd(_mm512_mul_pd(two, x2), y2), z2),
                one,
            );
            let a3 = _mm512_mul_pd(_mm512_mul_pd(a, a), a);
            let b = _mm512_add_pd(_mm512_mul_pd(tenth, x2), y2);
            let z3 = _mm512_mul_pd(z2, z);
            _mm512_storeu_pd(
                out.as_mut_ptr().add(i),
                _mm512_sub_pd(a3, _mm512_mul_pd(b, z3)),
            );
            i += 8;
        }
    }
}
