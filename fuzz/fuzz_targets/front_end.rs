//! Fuzzes the whole front end: arbitrary bytes → diagnostics or a surface,
//! then all three reference evaluators on a few points and boxes, checking
//! the enclosure property on the way (a panic or a broken enclosure is a
//! crash). The same bytes go to both front ends: as `fuzz.iso` and as a
//! Fidget model `fuzz.vm`.
#![no_main]

use isoc::interval::Interval;
use isoc::{CompileOptions, Surface};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    for file in ["fuzz.iso", "fuzz.vm"] {
        check(data, file);
    }
});

fn check(data: &[u8], file: &str) {
    let opts = CompileOptions::default();
    let Ok(surface) = Surface::compile_bytes(data, file, &opts) else {
        return;
    };
    let d = surface.domain;
    let boxes = [
        [d.lo, d.hi],
        [d.lo, [0.5 * (d.lo[0] + d.hi[0]), 0.5 * (d.lo[1] + d.hi[1]), 0.5 * (d.lo[2] + d.hi[2])]],
        [[0.1, -0.2, 0.3], [0.1, -0.2, 0.3]],
    ];
    for [lo, hi] in boxes {
        let b = [
            Interval { lo: lo[0], hi: hi[0] },
            Interval { lo: lo[1], hi: hi[1] },
            Interval { lo: lo[2], hi: hi[2] },
            Interval { lo: 0.0, hi: 0.0 },
        ];
        let iv = surface.interval(b);
        let g = surface.grad(b);
        for p in [lo, hi, [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]), 0.5 * (lo[2] + hi[2])]] {
            let v = surface.point([p[0], p[1], p[2], 0.0]);
            let (v2, _) = surface.point_grad([p[0], p[1], p[2], 0.0]);
            if !v.is_nan() {
                assert!(iv.iv.lo <= v && v <= iv.iv.hi, "{v} not in {:?}", iv.iv);
                assert!(g.value.lo <= v && v <= g.value.hi, "{v} not in {:?}", g.value);
                assert!(v == v2 || (v.is_nan() && v2.is_nan()));
            }
        }
    }
}
