//! Compile-time and code-size smoke test: every `corpus/*.iso` goes through
//! the front end and the JIT; the kernels agree with the reference
//! evaluators at the domain's centre and on the whole domain. No time limit
//! is asserted.

use isoc::CompileOptions;
use isoc::eval::{Evaluator, Reference};
use isoc::interval::Interval;
use isoc::jit::{JitOptions, Kernels, Kind};

#[test]
fn every_corpus_file_compiles() {
    let mut files: Vec<_> = std::fs::read_dir(concat!(env!("CARGO_MANIFEST_DIR"), "/corpus"))
        .expect("corpus/")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "iso"))
        .collect();
    files.sort();
    assert!(!files.is_empty());
    for path in files {
        let name = path.display().to_string();
        let src = std::fs::read_to_string(&path).expect("read");
        let lowered = isoc::syntax::front_end(&src, &name, &CompileOptions::default())
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        let prog = &lowered.program;
        let opts = JitOptions {
            keep_text: true,
            verify: true,
            ..JitOptions::default()
        };
        let k = Kernels::compile_with(prog, &opts).unwrap_or_else(|e| panic!("{name}: {e}"));
        for kind in Kind::ALL {
            assert!(k.code_bytes(kind) > 0, "{name}: {kind:?}");
            assert!(k.compile_time(kind).as_nanos() > 0, "{name}: {kind:?}");
        }
        for info in k.info() {
            assert!(info.clif.as_deref().is_some_and(|s| s.contains("function")));
            assert!(info.asm.as_deref().is_some_and(|s| !s.is_empty()));
        }
        let d = lowered.domain;
        let b = [0, 1, 2].map(|i| Interval {
            lo: d.lo[i],
            hi: d.hi[i],
        });
        let b = [b[0], b[1], b[2], Interval { lo: 0.0, hi: 0.0 }];
        let c = [0, 1, 2].map(|i| 0.5 * (d.lo[i] + d.hi[i]) + 0.0123 * (i as f64 + 1.0));
        let p = [c[0], c[1], c[2], 0.0];
        let r = Reference(prog.clone());
        let (jv, rv) = (k.point(p), r.point(p));
        assert!(
            jv == rv || (jv.is_nan() && rv.is_nan()),
            "{name}: {jv} vs {rv}"
        );
        let (ji, ri) = (k.interval(b), r.interval(b));
        assert!(ji.iv.lo <= rv && rv <= ji.iv.hi || rv.is_nan(), "{name}");
        assert_eq!(ji.defined, ri.defined, "{name}");
        let (jg, rg) = (k.grad(b), r.grad(b));
        assert_eq!(jg.defined, rg.defined, "{name}");
        let (_, dv) = isoc::eval::grad::eval_point(prog, p);
        for (i, (d, g)) in dv.iter().zip(jg.grad).enumerate() {
            assert!(d.is_nan() || (g.lo <= *d && *d <= g.hi), "{name}: d{i}");
        }
        // The point-gradient kernel (verified, with text) is bit for bit
        // the reference.
        let (pv, pd) = k.point_grad(p);
        let same = |a: f64, b: f64| a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan());
        let (ev, _) = isoc::eval::grad::eval_point(prog, p);
        assert!(same(pv, ev), "{name}: {pv} vs {ev}");
        for i in 0..3 {
            assert!(same(pd[i], dv[i]), "{name}: d{i} {} vs {}", pd[i], dv[i]);
        }
        for info in k.point_grad_info().unwrap() {
            assert!(info.code_bytes > 0, "{name}: {}", info.name);
            assert!(info.clif.as_deref().is_some_and(|s| s.contains("function")));
        }
    }
}
