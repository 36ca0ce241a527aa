//! The measured limit behind the point-batch ratio: the heart's point
//! formula, `(2x² + y² + z² − 1)³ − (0.1x² + y²)·z³`, hand-written with
//! explicit vectors of each width, against isoc's JIT batch point kernel,
//! on the same 65,536 points (one thread; ns per point, median of 21 runs).
//!
//! `cargo run --release --bin limits` (in `benches/peers`).
//!
//! Cranelift's x86-64 backend has 128-bit vectors only, so isoc's kernel
//! can at best match the f64×2 row; Fidget's `float_slice` is an f32×8
//! kernel.

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
}
