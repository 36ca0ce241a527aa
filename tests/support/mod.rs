//! Shared test support: random IR programs and boxes (proptest strategies),
//! point sampling, the soundness checks, and [`backend_suite!`], the one
//! test suite every [`Evaluator`] (reference interpreters, JIT) must pass.
//!
//! Use from a test file:
//!
//! ```ignore
//! // in the test binary's main.rs: #[macro_use] mod support;
//! backend_suite!(reference, |p: &isoc::ir::Program| isoc::eval::Reference(p.clone()));
//! ```
//!
//! The checks are plain functions returning `Result<(), String>` so that the
//! suite's own tests can show they fail on broken backends.
#![allow(dead_code, clippy::needless_range_loop)]

pub mod csg;
pub mod exact;
pub mod front;
pub mod vmref;

use isoc::eval::{Evaluator, Reference, grad, point};
use isoc::interval::Interval;
use isoc::ir::{BinOp, Const, Op, Program, UnOp, Value, Var};
use proptest::prelude::*;

/// How many triangles of `m` use each edge (smaller index first): 2 for
/// an inner edge of a closed 2-manifold, 1 for a boundary edge.
pub fn edge_uses(m: &isoc::Mesh) -> std::collections::HashMap<(u32, u32), usize> {
    let mut uses = std::collections::HashMap::new();
    for t in &m.triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            *uses.entry((a.min(b), a.max(b))).or_insert(0) += 1;
        }
    }
    uses
}

/// The bits of every vertex position of `m`, in vertex order (meshes that
/// must be equal bit for bit; duplicated positions).
pub fn position_bits(m: &isoc::Mesh) -> Vec<[u64; 3]> {
    m.positions
        .iter()
        .map(|p| p.to_array().map(f64::to_bits))
        .collect()
}

// ---------------------------------------------------------------- programs

/// A constant that stands for a real number: exact floats, or a rounded
/// decimal-like value `v` with the enclosure `[v⁻, v⁺]`, or an undefined one
/// (what folding `sqrt(-1)` gives).
pub fn arb_const() -> impl Strategy<Value = Const> {
    let special = prop::sample::select(vec![
        0.0,
        -0.0,
        1.0,
        -1.0,
        2.0,
        -2.0,
        0.5,
        3.0,
        10.0,
        64.0,
        1e-300,
        -1e-300,
        1e300,
        -1e300,
        1e-10,
        1e10,
        f64::MAX,
        f64::MIN_POSITIVE,
        5e-324,
    ]);
    let rounded = prop::sample::select(vec![
        0.1,
        0.2,
        0.3,
        std::f64::consts::PI,
        std::f64::consts::FRAC_PI_2,
        -std::f64::consts::FRAC_PI_2,
        std::f64::consts::E,
        1.0 / 3.0,
    ]);
    prop_oneof![
        6 => special.prop_map(Const::exact),
        2 => (-10.0f64..10.0).prop_map(Const::exact),
        2 => rounded.prop_map(|v| Const {
            value: v,
            lo: v.next_down(),
            hi: v.next_up(),
            defined: true,
        }),
        1 => any::<f64>().prop_filter("finite", |v| v.is_finite()).prop_map(Const::exact),
        1 => Just(Const {
            value: f64::NAN,
            lo: f64::INFINITY,
            hi: f64::NEG_INFINITY,
            defined: false,
        }),
    ]
}

/// Integer exponents: small of both signs, large, and extreme.
pub fn arb_exponent() -> impl Strategy<Value = i64> {
    prop_oneof![
        8 => -4i64..=7,
        2 => 8i64..=70,
        1 => -70i64..=-8,
        1 => prop::sample::select(vec![1000, -1000, 10_000_000_000, i64::MAX, i64::MIN, i64::MIN + 1]),
    ]
}

/// How one instruction of a random program is made.
#[derive(Clone, Debug)]
enum Seed {
    Unary(UnOp, usize),
    Binary(BinOp, usize, usize),
    /// A binary op whose right operand is a fresh constant (`x - 1`, `1/x`
    /// with the constant first when `swap`).
    WithConst(BinOp, usize, Const, bool),
    Powi(usize, i64),
    Const(Const),
    /// A domain edge made likely: `log(a − 1)`, `1/a`, `sqrt(a − 1)`,
    /// `asin(a − 1)`.
    Edge(u8, usize),
}

fn arb_seed() -> impl Strategy<Value = Seed> {
    let un = prop::sample::select(UnOp::ALL.to_vec());
    let bin = prop::sample::select(BinOp::ALL.to_vec());
    prop_oneof![
        4 => (un, any::<usize>()).prop_map(|(u, a)| Seed::Unary(u, a)),
        4 => (bin.clone(), any::<usize>(), any::<usize>()).prop_map(|(b, x, y)| Seed::Binary(b, x, y)),
        3 => (bin, any::<usize>(), arb_const(), any::<bool>())
            .prop_map(|(b, x, c, s)| Seed::WithConst(b, x, c, s)),
        2 => (any::<usize>(), arb_exponent()).prop_map(|(a, n)| Seed::Powi(a, n)),
        1 => arb_const().prop_map(Seed::Const),
        2 => (0u8..4, any::<usize>()).prop_map(|(k, a)| Seed::Edge(k, a)),
    ]
}

/// Picks an operand among the `n` values defined so far, mostly recent ones
/// (so programs are deep), sometimes any.
fn pick(sel: usize, n: usize) -> Value {
    let i = if sel.is_multiple_of(3) {
        (sel / 3) % n
    } else {
        n - 1 - (sel / 3) % n.min(3)
    };
    Value(i as u32)
}

fn build(seeds: Vec<Seed>, vars: usize) -> Program {
    let mut insts: Vec<Op> = Var::ALL[..vars].iter().map(|&v| Op::Var(v)).collect();
    for s in seeds {
        let n = insts.len();
        let op = match s {
            Seed::Unary(u, a) => Op::Unary(u, pick(a, n)),
            Seed::Binary(b, x, y) => Op::Binary(b, pick(x, n), pick(y, n)),
            Seed::WithConst(b, x, c, swap) => {
                insts.push(Op::Const(c));
                let (x, c) = (pick(x, n), Value(n as u32));
                if swap {
                    Op::Binary(b, c, x)
                } else {
                    Op::Binary(b, x, c)
                }
            }
            Seed::Powi(a, k) => Op::Powi(pick(a, n), k),
            Seed::Const(c) => Op::Const(c),
            Seed::Edge(k, a) => {
                let a = pick(a, n);
                insts.push(Op::Const(Const::exact(1.0)));
                let one = Value(n as u32);
                if k == 1 {
                    Op::Binary(BinOp::Div, one, a)
                } else {
                    insts.push(Op::Binary(BinOp::Sub, a, one));
                    let shifted = Value(n as u32 + 1);
                    let u = [UnOp::Log, UnOp::Log, UnOp::Sqrt, UnOp::Asin][k as usize];
                    Op::Unary(u, shifted)
                }
            }
        };
        insts.push(op);
    }
    let output = Value(insts.len() as u32 - 1);
    Program { insts, output }
}

/// Random valid SSA programs over `x y z t` using every op, with constants
/// huge/tiny/negative/zero/rounded/undefined and integer powers of every
/// size and sign. Domain edges (`sqrt(x)`, `log(x - 1)`, `1/x`) arise from
/// binary ops with constant operands and from boxes touching 0 and ±1.
pub fn arb_program() -> impl Strategy<Value = Program> {
    (prop::collection::vec(arb_seed(), 1..14), 1usize..=4).prop_map(|(s, v)| build(s, v))
}

// ---------------------------------------------------------------- boxes

fn special_points() -> Vec<f64> {
    vec![
        0.0,
        -0.0,
        1.0,
        -1.0,
        0.5,
        2.0,
        std::f64::consts::FRAC_PI_2,
        -std::f64::consts::FRAC_PI_2,
        std::f64::consts::PI,
        1e-300,
        -1e-300,
        1e-8,
        1e8,
        1e16,
        -1e16,
        1e300,
        -1e300,
        f64::MAX,
    ]
}

/// A coordinate: special values, ordinary ones, any finite float.
pub fn arb_coord() -> impl Strategy<Value = f64> {
    prop_oneof![
        3 => prop::sample::select(special_points()),
        3 => -4.0f64..4.0,
        1 => -1e6f64..1e6,
        1 => any::<f64>().prop_filter("finite", |v| v.is_finite()),
    ]
}

/// An interval: degenerate `[p, p]`, centred with a width from tiny to huge,
/// touching 0 or ±1 from either side, half-lines and the entire line.
pub fn arb_interval() -> impl Strategy<Value = Interval> {
    let width = prop::sample::select(vec![
        0.0,
        5e-324,
        1e-300,
        1e-12,
        1e-6,
        0.01,
        0.5,
        1.0,
        3.0,
        10.0,
        1e6,
        1e300,
        f64::INFINITY,
    ]);
    prop_oneof![
        2 => arb_coord().prop_map(Interval::point),
        4 => (arb_coord(), width.clone(), width.clone())
            .prop_map(|(c, a, b)| Interval::new(c - a, c + b)),
        2 => (prop::sample::select(vec![0.0, -0.0, 1.0, -1.0]), width.clone(), any::<bool>())
            .prop_map(|(e, w, below)| if below { Interval::new(e - w, e) } else { Interval::new(e, e + w) }),
        1 => (arb_coord(), any::<bool>()).prop_map(|(c, up)| if up {
            Interval::new(c, f64::INFINITY)
        } else {
            Interval::new(f64::NEG_INFINITY, c)
        }),
        1 => Just(Interval::ENTIRE),
        1 => (arb_coord(), arb_coord()).prop_map(|(a, b)| Interval::new(a.min(b), a.max(b))),
    ]
}

/// [`arb_interval`], or now and then a malformed one (a NaN bound, which
/// must read as entire and undefined).
pub fn arb_input_interval() -> impl Strategy<Value = Interval> {
    prop_oneof![
        30 => arb_interval(),
        1 => arb_coord().prop_map(|c| Interval::new(f64::NAN, c)),
        1 => arb_coord().prop_map(|c| Interval::new(c, f64::NAN)),
    ]
}

/// A box `[x, y, z, t]`.
/// Now and then a side has a NaN bound; such a box only requires that the
/// result be flagged undefined when the program reads that side.
pub fn arb_box() -> impl Strategy<Value = [Interval; 4]> {
    [
        arb_input_interval(),
        arb_input_interval(),
        arb_input_interval(),
        arb_input_interval(),
    ]
}

/// A point `[x, y, z, t]` (finite coordinates).
pub fn arb_point() -> impl Strategy<Value = [f64; 4]> {
    [arb_coord(), arb_coord(), arb_coord(), arb_coord()]
}

// ---------------------------------------------------------------- sampling

/// SplitMix64: a tiny deterministic generator for sample points.
pub struct Rng(pub u64);

impl Rng {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in `[0, 1)`.
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// A representative inside point of an interval (finite when possible).
pub fn centre(iv: Interval) -> f64 {
    match (iv.lo.is_finite(), iv.hi.is_finite()) {
        (true, true) => (iv.lo / 2.0 + iv.hi / 2.0).clamp(iv.lo, iv.hi),
        (false, true) => iv.hi.min(0.0) - 1.0,
        (true, false) => iv.lo.max(0.0) + 1.0,
        (false, false) => 0.0,
    }
}

/// A random point of an interval: uniform, near an end, or (for unbounded
/// sides) at a random magnitude.
pub fn sample(iv: Interval, rng: &mut Rng) -> f64 {
    if iv.is_empty() || iv.lo.is_nan() || iv.hi.is_nan() {
        return f64::NAN;
    }
    let u = rng.unit();
    let x = match rng.next_u64() % 8 {
        0 => iv.lo.next_up(),
        1 => iv.hi.next_down(),
        // Domain edges and critical points, when inside.
        2 => [0.0, 1.0, -1.0, std::f64::consts::FRAC_PI_2][(rng.next_u64() % 4) as usize],
        _ if iv.lo.is_finite() && iv.hi.is_finite() => iv.lo * (1.0 - u) + iv.hi * u,
        _ => {
            let m = 10f64.powf(u * 600.0 - 300.0);
            let s = if rng.next_u64().is_multiple_of(2) {
                m
            } else {
                -m
            };
            let c = centre(iv);
            c + s
        }
    };
    if x.is_nan() {
        centre(iv)
    } else {
        x.clamp(iv.lo, iv.hi)
    }
}

/// Sample points of a box: every corner (infinite ones included), the
/// centre, and `n` random points.
pub fn sample_points(b: &[Interval; 4], seed: u64, n: usize) -> Vec<[f64; 4]> {
    let mut out = Vec::with_capacity(17 + n);
    for mask in 0..16u32 {
        out.push(std::array::from_fn(|i| {
            if mask >> i & 1 == 0 { b[i].lo } else { b[i].hi }
        }));
    }
    out.push(b.map(centre));
    let mut rng = Rng(seed);
    for _ in 0..n {
        out.push(std::array::from_fn(|i| sample(b[i], &mut rng)));
    }
    out
}

// ---------------------------------------------------------------- checks

/// "The interval contains the point value", robustly: a NaN point value
/// (outside the domain, or `∞ − ∞`) is not checked; a finite one must lie
/// in `[lo, hi]` (so an empty interval fails); `±∞` needs the matching
/// unbounded side.
pub fn encloses(iv: Interval, v: f64) -> bool {
    // A NaN bound is the entire line (`Interval::normalize`, the library's
    // convention; SPEC §2 prints it as null with `defined: false`).
    v.is_nan() || iv.normalize().0.contains(v)
}

/// A NaN bound anywhere in an interval-gradient result.
fn has_nan_bound(g: &isoc::eval::grad::GradEval) -> bool {
    std::iter::once(g.value)
        .chain(g.grad)
        .any(|iv| iv.lo.is_nan() || iv.hi.is_nan())
}

/// Same point value (both NaN, or equal; `-0 == 0`).
pub fn same(a: f64, b: f64) -> bool {
    a == b || (a.is_nan() && b.is_nan())
}

fn show(program: &Program, b: &[Interval; 4]) -> String {
    let mut s = String::new();
    for (i, op) in program.insts.iter().enumerate() {
        s += &format!("  v{i} = {op:?}\n");
    }
    s += &format!("  output {:?}\n  box {:?}", program.output, b);
    s
}

/// True when the output depends on the variable `v`.
fn reads(program: &Program, v: Var) -> bool {
    let mut live = vec![false; program.insts.len()];
    if let Some(l) = live.get_mut(program.output.index()) {
        *l = true;
    }
    let mut found = false;
    for i in (0..program.insts.len()).rev() {
        if !live[i] {
            continue;
        }
        let op = &program.insts[i];
        if *op == Op::Var(v) {
            found = true;
        }
        for a in op.args() {
            if let Some(l) = live.get_mut(a.index()) {
                *l = true;
            }
        }
    }
    found
}

/// True when the point value at `p` is NaN because an op left its domain
/// (finite inputs and no infinite intermediate value, so it is not an
/// `∞ − ∞` or `0·∞` artefact of overflow).
fn undefined_at(program: &Program, p: [f64; 4]) -> bool {
    if !p.iter().all(|c| c.is_finite()) {
        return false;
    }
    let vals = point::eval_all(program, p);
    vals[program.output.index()].is_nan() && vals.iter().all(|v| !v.is_infinite())
}

/// Interval soundness on one program and box: at every sample point, the
/// backend's and the reference's point values lie in the backend's
/// interval; the backend's point value equals the reference's; where the
/// value is undefined the interval says so.
pub fn check_interval<B: Evaluator>(
    backend: &B,
    program: &Program,
    b: &[Interval; 4],
    seed: u64,
) -> Result<(), String> {
    let r = backend.interval(*b);
    let oracle = Reference(program.clone());
    let nan_side = |v: Var| b[v.index()].lo.is_nan() || b[v.index()].hi.is_nan();
    if Var::ALL.iter().any(|&v| nan_side(v) && reads(program, v)) && r.defined {
        return Err(format!(
            "a NaN box side gave a defined result {r:?}\n{}",
            show(program, b)
        ));
    }
    for p in sample_points(b, seed, 24) {
        let want = oracle.point(p);
        let got = backend.point(p);
        if !same(want, got) {
            return Err(format!(
                "point value {got:e} != reference {want:e} at {p:?}\n{}",
                show(program, b)
            ));
        }
        if !encloses(r.iv, want) {
            return Err(format!(
                "interval {:?} misses point value {want:e} at {p:?}\n{}",
                r,
                show(program, b)
            ));
        }
        if r.defined && undefined_at(program, p) {
            return Err(format!(
                "interval {:?} claims defined but f is undefined at {p:?}\n{}",
                r,
                show(program, b)
            ));
        }
    }
    Ok(())
}

/// Gradient soundness on one program and box: the value interval of the
/// gradient kernel contains the point values, and the gradient intervals
/// contain the point gradients (forward-mode AD in f64) at sample points.
pub fn check_grad<B: Evaluator>(
    backend: &B,
    program: &Program,
    b: &[Interval; 4],
    seed: u64,
) -> Result<(), String> {
    let g = backend.grad(*b);
    for p in sample_points(b, seed, 24) {
        let (v, dv) = grad::eval_point(program, p);
        let pv = point::eval(program, p);
        if !same(v, pv) {
            return Err(format!(
                "eval_point value {v:e} != point value {pv:e} at {p:?}\n{}",
                show(program, b)
            ));
        }
        if !encloses(g.value, v) {
            return Err(format!(
                "grad value {:?} misses {v:e} at {p:?}\n{}",
                g.value,
                show(program, b)
            ));
        }
        for k in 0..3 {
            if !encloses(g.grad[k], dv[k]) {
                return Err(format!(
                    "partial {k} {:?} misses {:e} at {p:?} (gradient {dv:?})\n{}",
                    g.grad[k],
                    dv[k],
                    show(program, b)
                ));
            }
        }
        if g.defined && undefined_at(program, p) {
            return Err(format!(
                "grad claims defined but f is undefined at {p:?}\n{}",
                show(program, b)
            ));
        }
    }
    if g.defined && has_nan_bound(&g) {
        return Err(format!(
            "grad claims defined with a NaN bound: {g:?}\n{}",
            show(program, b)
        ));
    }
    Ok(())
}

/// The degenerate box `[p, p]`: interval and gradient kernels contain the
/// point value and gradient at `p`.
pub fn check_degenerate<B: Evaluator>(
    backend: &B,
    program: &Program,
    p: [f64; 4],
) -> Result<(), String> {
    let b = p.map(Interval::point);
    let v = point::eval(program, p);
    let r = backend.interval(b);
    if !encloses(r.iv, v) || !encloses(r.iv, backend.point(p)) {
        return Err(format!(
            "interval {:?} misses point value {v:e}\n{}",
            r,
            show(program, &b)
        ));
    }
    let (gv, dv) = grad::eval_point(program, p);
    let g = backend.grad(b);
    if !encloses(g.value, gv) {
        return Err(format!(
            "grad value {:?} misses {gv:e}\n{}",
            g.value,
            show(program, &b)
        ));
    }
    for k in 0..3 {
        if !encloses(g.grad[k], dv[k]) {
            return Err(format!(
                "partial {k} {:?} misses {:e}\n{}",
                g.grad[k],
                dv[k],
                show(program, &b)
            ));
        }
    }
    Ok(())
}

/// Bit-for-bit equality of two floats, every NaN equal to every NaN.
pub fn bits_eq(a: f64, b: f64) -> bool {
    a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
}

fn iv_bits_eq(a: Interval, b: Interval) -> bool {
    bits_eq(a.lo, b.lo) && bits_eq(a.hi, b.hi)
}

/// Every batch method equals its single method element by element, bit for
/// bit (`pts` at time `t` for the point forms, `boxes` for the box forms).
pub fn check_batches<E: Evaluator>(
    e: &E,
    pts: &[[f64; 3]],
    t: f64,
    boxes: &[[Interval; 4]],
) -> Result<(), String> {
    let n = pts.len();
    let col = |k: usize| pts.iter().map(|p| p[k]).collect::<Vec<f64>>();
    let mut out = vec![1.5; n];
    e.point_batch(&col(0), &col(1), &col(2), t, &mut out);
    let mut pg = vec![(1.5, [1.5; 3]); n];
    e.point_grad_batch(pts, t, &mut pg);
    for (i, q) in pts.iter().enumerate() {
        let at = [q[0], q[1], q[2], t];
        let single = e.point(at);
        if !bits_eq(out[i], single) {
            return Err(format!(
                "point_batch[{i}] of {n} {:e} != point {single:e} at {at:?}",
                out[i]
            ));
        }
        let (v, g) = e.point_grad(at);
        let (bv, bg) = pg[i];
        if !bits_eq(v, bv) || (0..3).any(|k| !bits_eq(g[k], bg[k])) {
            return Err(format!(
                "point_grad_batch[{i}] of {n} {:?} != point_grad {:?} at {at:?}",
                pg[i],
                (v, g)
            ));
        }
    }
    let m = boxes.len();
    let mut iv = vec![isoc::eval::WHOLE; m];
    e.interval_batch(boxes, &mut iv);
    let mut gr = vec![isoc::eval::WHOLE_GRAD; m];
    e.grad_batch(boxes, &mut gr);
    for (i, b) in boxes.iter().enumerate() {
        let single = e.interval(*b);
        if !iv_bits_eq(iv[i].iv, single.iv) || iv[i].defined != single.defined {
            return Err(format!(
                "interval_batch[{i}] of {m} {:?} != interval {single:?} on {b:?}",
                iv[i]
            ));
        }
        let single = e.grad(*b);
        let same_grad = (0..3).all(|k| iv_bits_eq(gr[i].grad[k], single.grad[k]));
        if !iv_bits_eq(gr[i].value, single.value) || !same_grad || gr[i].defined != single.defined {
            return Err(format!(
                "grad_batch[{i}] of {m} {:?} != grad {single:?} on {b:?}",
                gr[i]
            ));
        }
    }
    Ok(())
}

/// The point gradient at `p`: its value is the point value, and value and
/// gradient lie in the interval-gradient enclosure over a small box around
/// `p` (and over the degenerate box `[p, p]`).
pub fn check_point_grad<E: Evaluator>(e: &E, program: &Program, p: [f64; 4]) -> Result<(), String> {
    let (v, d) = e.point_grad(p);
    let pv = e.point(p);
    if !same(v, pv) {
        return Err(format!(
            "point_grad value {v:e} != point {pv:e} at {p:?}\n{}",
            show(program, &p.map(Interval::point))
        ));
    }
    let h = |c: f64| (c.abs() * 1e-6).max(1e-9);
    let small: [Interval; 4] = std::array::from_fn(|k| {
        if k < 3 {
            Interval::new(p[k] - h(p[k]), p[k] + h(p[k]))
        } else {
            Interval::point(p[k])
        }
    });
    for b in [small, p.map(Interval::point)] {
        let g = e.grad(b);
        if !encloses(g.value, v) {
            return Err(format!(
                "grad value {:?} misses point_grad value {v:e}\n{}",
                g.value,
                show(program, &b)
            ));
        }
        for k in 0..3 {
            if !encloses(g.grad[k], d[k]) {
                return Err(format!(
                    "partial {k} {:?} misses point_grad {:e} at {p:?}\n{}",
                    g.grad[k],
                    d[k],
                    show(program, &b)
                ));
            }
        }
    }
    Ok(())
}

/// A coordinate for the batch checks: [`arb_coord`], or now and then NaN,
/// ±∞, ±0 or a subnormal.
pub fn arb_batch_coord() -> impl Strategy<Value = f64> {
    prop_oneof![
        6 => arb_coord(),
        1 => prop::sample::select(vec![
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            -0.0,
            0.0,
            -f64::MIN_POSITIVE,
            5e-324,
        ]),
    ]
}

/// A batch length: 0, 1, 2, 3, 17 or anything below 40.
pub fn arb_batch_len() -> impl Strategy<Value = usize> {
    prop_oneof![prop::sample::select(vec![0usize, 1, 2, 3, 17]), 0usize..40]
}

/// Cases per property (at least 10,000; `PROPTEST_CASES` overrides).
pub fn cases() -> u32 {
    std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(10_000)
}

/// The shared soundness suite, instantiated once per backend:
/// `backend_suite!(name, |program: &Program| make_backend(program));`.
/// The test binary must declare `#[macro_use] mod support;` at its root.
#[macro_export]
macro_rules! backend_suite {
    ($name:ident, $make:expr) => {
        mod $name {
            #[allow(unused_imports)]
            use super::*;
            use $crate::support::{
                arb_batch_coord, arb_batch_len, arb_box, arb_point, arb_program, cases,
                check_batches, check_degenerate, check_grad, check_interval, check_point_grad,
            };
            use proptest::prelude::*;

            proptest! {
                #![proptest_config(ProptestConfig::with_cases(cases()))]

                #[test]
                fn interval_soundness(program in arb_program(), b in arb_box(), seed in any::<u64>()) {
                    let backend = ($make)(&program);
                    if let Err(e) = check_interval(&backend, &program, &b, seed) {
                        prop_assert!(false, "{}", e);
                    }
                }

                #[test]
                fn gradient_soundness(program in arb_program(), b in arb_box(), seed in any::<u64>()) {
                    let backend = ($make)(&program);
                    if let Err(e) = check_grad(&backend, &program, &b, seed) {
                        prop_assert!(false, "{}", e);
                    }
                }

                #[test]
                fn degenerate_box_contains_point(program in arb_program(), p in arb_point()) {
                    let backend = ($make)(&program);
                    if let Err(e) = check_degenerate(&backend, &program, p) {
                        prop_assert!(false, "{}", e);
                    }
                }

                #[test]
                fn point_grad_is_point_and_inside_interval_grad(program in arb_program(), p in arb_point()) {
                    let backend = ($make)(&program);
                    if let Err(e) = check_point_grad(&backend, &program, p) {
                        prop_assert!(false, "{}", e);
                    }
                }
            }

            proptest! {
                // Each case checks up to 40 points and 40 boxes.
                #![proptest_config(ProptestConfig::with_cases((cases() / 10).max(1)))]

                #[test]
                fn batch_equals_single(
                    program in arb_program(),
                    pts in arb_batch_len().prop_flat_map(|n| prop::collection::vec([arb_batch_coord(), arb_batch_coord(), arb_batch_coord()], n)),
                    t in arb_batch_coord(),
                    boxes in arb_batch_len().prop_flat_map(|n| prop::collection::vec(arb_box(), n)),
                ) {
                    let backend = ($make)(&program);
                    if let Err(e) = check_batches(&backend, &pts, t, &boxes) {
                        prop_assert!(false, "{}\n{}", e, program);
                    }
                }
            }
        }
    };
}

/// A surface compiled from `.iso` source (named `test.iso`); panics with the
/// rendered diagnostics when it does not compile.
pub fn surface(src: &str) -> isoc::Surface {
    isoc::Surface::compile(src, "test.iso", &isoc::CompileOptions::default())
        .unwrap_or_else(|e| panic!("{}", e.render()))
}

/// The first-order distance `|f| / ‖∇f‖` from `p` to `s = 0` at time `t`
/// (the mesher's own measure of a point's distance to the surface).
pub fn first_order(s: &isoc::Surface, p: glam::DVec3, t: f64) -> f64 {
    let (v, g) = s.point_grad([p.x, p.y, p.z, t]);
    v.abs() / glam::DVec3::from_array(g).length()
}

/// Every `corpus/*.iso` file as (path, source), sorted by path.
pub fn corpus() -> Vec<(String, String)> {
    let mut files: Vec<(String, String)> = std::fs::read_dir("corpus")
        .expect("corpus/ exists")
        .filter_map(|e| e.ok())
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|x| x == "iso"))
        .map(|p| {
            let src = std::fs::read_to_string(&p).expect("a readable corpus file");
            (p.display().to_string(), src)
        })
        .collect();
    files.sort();
    files
}
