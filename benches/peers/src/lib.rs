//! Shared code of the isoc-vs-Fidget peer benchmark: the IR → Fidget
//! converter, the workloads (the same inputs for both libraries), one
//! runner per measured operation, and an independent mesh-topology check.
//!
//! Used by `src/main.rs` (the Markdown ratio table) and by
//! `benches/kernels.rs` (criterion).

use fidget::context::{Context, Node};
use fidget::eval::{BulkEvaluator, Function, MathFunction, Tape, TracingEvaluator};
use fidget::jit::JitFunction;
use fidget::types::{Grad, Interval as FInterval};
use fidget::var::Var as FVar;
use isoc::interval::Interval;
use isoc::ir::{BinOp, Op, Program, UnOp, Var};
use std::collections::HashMap;

/// The corpus formulas compared (relative to `benches/peers/`).
pub const CORPUS: [&str; 9] = [
    "heart",
    "torus",
    "twotorus",
    "chair_mid",
    "smile",
    "cyclide",
    "chebyshev",
    "decocube",
    "chair_off",
];

/// Fidget's own 3-D models (`../shared/models`, MPL-2.0), read through
/// isoc's `.vm` front end and converted back to a Fidget graph like the
/// corpus formulas; named by file name.
pub const MODELS: [&str; 2] = ["colonnade.vm", "tanglecube.vm"];

/// Path of a corpus file (`heart`), one of this benchmark's own surfaces
/// (`surfaces/sphere_r32.iso`) or a shared model (`colonnade.vm`), found
/// from this crate's manifest directory.
pub fn corpus_path(name: &str) -> std::path::PathBuf {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let file = format!("{name}.iso");
    if name.ends_with(".vm") {
        root.join("../../../shared/models").join(name)
    } else if root.join("surfaces").join(&file).exists() {
        // The benchmark's own surfaces (no `expect` line: not the corpus).
        root.join("surfaces").join(file)
    } else {
        root.join("../../corpus").join(file)
    }
}

// ---------------------------------------------------------------------------
// IR → Fidget
// ---------------------------------------------------------------------------

/// Builds the Fidget graph of an isoc IR program, instruction by
/// instruction (so every formula is converted the same way).
///
/// * constants become f32 (Fidget's only scalar type), using the point
///   value of isoc's constant;
/// * `t` becomes the constant `t` (the corpus surfaces do not use it);
/// * `powi(a, n)` becomes a product chain by repeated squaring
///   (`1/…` for negative `n`), `pow(a, b)` becomes `exp(b·ln a)` (isoc's
///   own definition, domain `a > 0`), `log` → `ln`, `square` → `square`;
/// * everything else maps one to one (Fidget has `atan2`, `min`, `max`).
pub fn to_fidget(prog: &Program, t: f64) -> Result<(Context, Node), String> {
    let mut ctx = Context::new();
    let mut v: Vec<Node> = Vec::with_capacity(prog.insts.len());
    let e = |_| "fidget rejected a node".to_string();
    for op in &prog.insts {
        let n = match *op {
            Op::Var(Var::X) => ctx.x(),
            Op::Var(Var::Y) => ctx.y(),
            Op::Var(Var::Z) => ctx.z(),
            Op::Var(Var::T) => ctx.constant(t as f32),
            Op::Const(c) => ctx.constant(c.value as f32),
            Op::Unary(u, a) => {
                let a = v[a.index()];
                match u {
                    UnOp::Neg => ctx.neg(a),
                    UnOp::Abs => ctx.abs(a),
                    UnOp::Sqrt => ctx.sqrt(a),
                    UnOp::Square => ctx.square(a),
                    UnOp::Exp => ctx.exp(a),
                    UnOp::Log => ctx.ln(a),
                    UnOp::Sin => ctx.sin(a),
                    UnOp::Cos => ctx.cos(a),
                    UnOp::Tan => ctx.tan(a),
                    UnOp::Asin => ctx.asin(a),
                    UnOp::Acos => ctx.acos(a),
                    UnOp::Atan => ctx.atan(a),
                    UnOp::Floor => ctx.floor(a),
                    UnOp::Ceil => ctx.ceil(a),
                    UnOp::Round => ctx.round(a),
                    UnOp::Not => ctx.not(a),
                }
                .map_err(e)?
            }
            Op::Binary(b, a, c) => {
                let (a, c) = (v[a.index()], v[c.index()]);
                match b {
                    BinOp::Add => ctx.add(a, c),
                    BinOp::Sub => ctx.sub(a, c),
                    BinOp::Mul => ctx.mul(a, c),
                    BinOp::Div => ctx.div(a, c),
                    BinOp::Min => ctx.min(a, c),
                    BinOp::Max => ctx.max(a, c),
                    BinOp::Atan2 => ctx.atan2(a, c),
                    BinOp::Pow => {
                        let l = ctx.ln(a).map_err(e)?;
                        let m = ctx.mul(c, l).map_err(e)?;
                        ctx.exp(m)
                    }
                    BinOp::Compare => ctx.compare(a, c),
                    BinOp::Mod => ctx.modulo(a, c),
                    BinOp::And => ctx.and(a, c),
                    BinOp::Or => ctx.or(a, c),
                }
                .map_err(e)?
            }
            Op::Powi(a, n) => {
                let a = v[a.index()];
                let p = powi(&mut ctx, a, n.unsigned_abs()).map_err(e)?;
                if n < 0 { ctx.recip(p).map_err(e)? } else { p }
            }
        };
        v.push(n);
    }
    Ok((ctx, v[prog.output.index()]))
}

fn powi(ctx: &mut Context, a: Node, n: u64) -> Result<Node, fidget::context::BadNode> {
    match n {
        0 => Ok(ctx.constant(1.0)),
        1 => Ok(a),
        2 => ctx.square(a),
        _ => {
            let h = powi(ctx, a, n / 2)?;
            let s = ctx.square(h)?;
            if n % 2 == 1 { ctx.mul(s, a) } else { Ok(s) }
        }
    }
}

// ---------------------------------------------------------------------------
// One formula, compiled by both libraries
// ---------------------------------------------------------------------------

/// The `# expect: components=C genus=G` line of a corpus file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Expect {
    pub components: usize,
    pub genus: i64,
}

pub struct Case {
    pub name: String,
    pub surface: isoc::Surface,
    pub kernels: isoc::jit::Kernels,
    pub fidget: fidget::jit::JitShape,
    pub expect: Option<Expect>,
    /// Wall time of `Kernels::compile` (all isoc kernels) in seconds.
    pub isoc_compile_s: f64,
    /// Wall time of Fidget's function + the three JIT tapes used here.
    pub fidget_compile_s: f64,
}

impl Case {
    pub fn load(name: &str) -> Result<Case, String> {
        let path = corpus_path(name);
        let src = std::fs::read_to_string(&path).map_err(|e| format!("{}: {e}", path.display()))?;
        let surface =
            isoc::Surface::compile(&src, &path.display().to_string(), &Default::default())
                .map_err(|e| format!("{name}: {e:?}"))?;
        let t0 = std::time::Instant::now();
        let kernels =
            isoc::jit::Kernels::compile(&surface.program).map_err(|e| format!("{name}: {e:?}"))?;
        let isoc_compile_s = t0.elapsed().as_secs_f64();
        let (ctx, node) = to_fidget(&surface.program, 0.0)?;
        let t0 = std::time::Instant::now();
        let f = JitFunction::new(&ctx, &[node]).map_err(|_| format!("{name}: fidget build"))?;
        let _ = f.interval_tape(Default::default());
        let _ = f.float_slice_tape(Default::default());
        let _ = f.grad_slice_tape(Default::default());
        let fidget_compile_s = t0.elapsed().as_secs_f64();
        let fidget =
            fidget::jit::JitShape::new(&ctx, node).map_err(|_| format!("{name}: fidget shape"))?;
        let expect = src.lines().find_map(parse_expect);
        Ok(Case {
            name: name.to_string(),
            surface,
            kernels,
            fidget,
            expect,
            isoc_compile_s,
            fidget_compile_s,
        })
    }

    pub fn function(&self) -> &JitFunction {
        self.fidget.inner()
    }

    /// One isoc JIT compile of all kernels (seconds); for repeated timing.
    pub fn time_isoc_compile(&self) -> f64 {
        let t0 = std::time::Instant::now();
        let k = isoc::jit::Kernels::compile(&self.surface.program).unwrap();
        let s = t0.elapsed().as_secs_f64();
        drop(k);
        s
    }

    /// One Fidget build: function from the graph + interval, float-slice
    /// and grad-slice JIT tapes (seconds; graph conversion excluded).
    pub fn time_fidget_compile(&self) -> f64 {
        let (ctx, node) = to_fidget(&self.surface.program, 0.0).unwrap();
        let t0 = std::time::Instant::now();
        let f = JitFunction::new(&ctx, &[node]).unwrap();
        let a = f.interval_tape(Default::default());
        let b = f.float_slice_tape(Default::default());
        let c = f.grad_slice_tape(Default::default());
        let s = t0.elapsed().as_secs_f64();
        drop((a, b, c));
        s
    }

    /// Instructions in Fidget's compiled tape.
    pub fn fidget_size(&self) -> usize {
        self.function().size()
    }
}

fn parse_expect(line: &str) -> Option<Expect> {
    let rest = line
        .trim_start_matches('#')
        .trim()
        .strip_prefix("expect:")?;
    let mut c = None;
    let mut g = None;
    for kv in rest.split_whitespace() {
        if let Some(x) = kv.strip_prefix("components=") {
            c = x.parse().ok();
        }
        if let Some(x) = kv.strip_prefix("genus=") {
            g = x.parse().ok();
        }
    }
    Some(Expect {
        components: c?,
        genus: g?,
    })
}

// ---------------------------------------------------------------------------
// Workloads: the same inputs for both libraries
// ---------------------------------------------------------------------------

/// Deterministic xorshift, so every run uses the same points.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

pub struct Workload {
    /// Random points in the domain (f64 for isoc, the same rounded to f32
    /// for Fidget).
    pub xs: Vec<f64>,
    pub ys: Vec<f64>,
    pub zs: Vec<f64>,
    pub xf: Vec<f32>,
    pub yf: Vec<f32>,
    pub zf: Vec<f32>,
    /// The cells of the uniform level-`box_level` grid over the domain,
    /// as isoc box records (8 f64: x.lo, x.hi, y.lo, y.hi, z.lo, z.hi, t, t).
    pub boxes: Vec<f64>,
    /// The same boxes as Fidget intervals (f32, rounded outward).
    pub fboxes: Vec<[FInterval; 3]>,
    /// The same boxes as isoc intervals, for the single-box kernel.
    pub iboxes: Vec<[Interval; 4]>,
    /// Box centres seeded with unit derivatives, for Fidget's grad_slice.
    pub gx: Vec<Grad>,
    pub gy: Vec<Grad>,
    pub gz: Vec<Grad>,
}

fn down(x: f64) -> f32 {
    let f = x as f32;
    if f as f64 > x { f.next_down() } else { f }
}
fn up(x: f64) -> f32 {
    let f = x as f32;
    if (f as f64) < x { f.next_up() } else { f }
}

impl Workload {
    pub fn new(domain: &isoc::Bounds, n_points: usize, box_level: u32) -> Workload {
        let (lo, hi) = (domain.lo, domain.hi);
        let mut r = Rng(0x9E37_79B9_7F4A_7C15);
        let mut coord = |k: usize| lo[k] + (hi[k] - lo[k]) * r.next();
        let mut xs = Vec::with_capacity(n_points);
        let mut ys = Vec::with_capacity(n_points);
        let mut zs = Vec::with_capacity(n_points);
        for _ in 0..n_points {
            xs.push(coord(0));
            ys.push(coord(1));
            zs.push(coord(2));
        }
        let m = 1usize << box_level;
        let mut w = Workload {
            xf: xs.iter().map(|&v| v as f32).collect(),
            yf: ys.iter().map(|&v| v as f32).collect(),
            zf: zs.iter().map(|&v| v as f32).collect(),
            xs,
            ys,
            zs,
            boxes: Vec::with_capacity(m * m * m * 8),
            fboxes: Vec::new(),
            iboxes: Vec::new(),
            gx: Vec::new(),
            gy: Vec::new(),
            gz: Vec::new(),
        };
        let at = |k: usize, i: usize| lo[k] + (hi[k] - lo[k]) * i as f64 / m as f64;
        for i in 0..m {
            for j in 0..m {
                for k in 0..m {
                    let b = [
                        (at(0, i), at(0, i + 1)),
                        (at(1, j), at(1, j + 1)),
                        (at(2, k), at(2, k + 1)),
                    ];
                    for (l, h) in b {
                        w.boxes.extend([l, h]);
                    }
                    w.boxes.extend([0.0, 0.0]);
                    w.iboxes.push([
                        Interval {
                            lo: b[0].0,
                            hi: b[0].1,
                        },
                        Interval {
                            lo: b[1].0,
                            hi: b[1].1,
                        },
                        Interval {
                            lo: b[2].0,
                            hi: b[2].1,
                        },
                        Interval { lo: 0.0, hi: 0.0 },
                    ]);
                    w.fboxes
                        .push(b.map(|(l, h)| FInterval::new(down(l), up(h))));
                    let c = b.map(|(l, h)| (0.5 * (l + h)) as f32);
                    w.gx.push(Grad::new(c[0], 1.0, 0.0, 0.0));
                    w.gy.push(Grad::new(c[1], 0.0, 1.0, 0.0));
                    w.gz.push(Grad::new(c[2], 0.0, 0.0, 1.0));
                }
            }
        }
        w
    }

    pub fn n_points(&self) -> usize {
        self.xs.len()
    }
    pub fn n_boxes(&self) -> usize {
        self.iboxes.len()
    }
}

/// Position of X, Y, Z among a Fidget tape's inputs (`None` when unused).
fn axes(vars: &fidget::var::VarMap) -> (usize, [Option<usize>; 3]) {
    let a = [FVar::X, FVar::Y, FVar::Z].map(|v| vars.get(&v));
    (vars.len(), a)
}

/// Orders per-axis inputs as a Fidget tape expects them.
fn order<T: Copy>(len: usize, a: [Option<usize>; 3], xyz: [T; 3]) -> Vec<T> {
    let mut out = vec![xyz[0]; len];
    for k in 0..3 {
        if let Some(i) = a[k] {
            out[i] = xyz[k];
        }
    }
    out
}

// ---------------------------------------------------------------------------
// Runners: one per measured operation, each returning a checksum so the
// optimiser cannot drop the work.
// ---------------------------------------------------------------------------

pub struct Runners<'a> {
    case: &'a Case,
    w: &'a Workload,
    out: Vec<f64>,
    out8: Vec<f64>,
    defined: Vec<bool>,
    f_float: <JitFunction as Function>::FloatSliceEval,
    f_float_tape: <<JitFunction as Function>::FloatSliceEval as BulkEvaluator>::Tape,
    f_grad: <JitFunction as Function>::GradSliceEval,
    f_grad_tape: <<JitFunction as Function>::GradSliceEval as BulkEvaluator>::Tape,
    f_int: <JitFunction as Function>::IntervalEval,
    f_int_tape: <<JitFunction as Function>::IntervalEval as TracingEvaluator>::Tape,
}

impl<'a> Runners<'a> {
    pub fn new(case: &'a Case, w: &'a Workload) -> Runners<'a> {
        let f = case.function();
        Runners {
            case,
            w,
            out: vec![0.0; w.n_points().max(2 * w.n_boxes())],
            out8: vec![0.0; 8 * w.n_boxes()],
            defined: vec![false; w.n_boxes()],
            f_float: JitFunction::new_float_slice_eval(),
            f_float_tape: f.float_slice_tape(Default::default()),
            f_grad: JitFunction::new_grad_slice_eval(),
            f_grad_tape: f.grad_slice_tape(Default::default()),
            f_int: JitFunction::new_interval_eval(),
            f_int_tape: f.interval_tape(Default::default()),
        }
    }

    /// isoc: one `point_batch` call over all points (f64).
    pub fn isoc_point_batch(&mut self) -> f64 {
        let n = self.w.n_points();
        let out = &mut self.out[..n];
        self.case
            .kernels
            .point_batch(&self.w.xs, &self.w.ys, &self.w.zs, 0.0, out)
            .unwrap();
        out[n / 2]
    }

    /// Fidget: one float-slice evaluation over all points (f32).
    pub fn fidget_float_slice(&mut self) -> f64 {
        let (len, a) = axes(self.f_float_tape.vars());
        let args = order(len, a, [&self.w.xf[..], &self.w.yf[..], &self.w.zf[..]]);
        let r = self.f_float.eval(&self.f_float_tape, &args).unwrap();
        r[0][self.w.n_points() / 2] as f64
    }

    /// isoc: the single-box interval kernel, once per box.
    pub fn isoc_interval_single(&mut self) -> f64 {
        let mut s = 0.0;
        for b in &self.w.iboxes {
            let r = self.case.kernels.interval(*b);
            s += r.iv.hi;
        }
        s
    }

    /// isoc: one `interval_batch` call over all boxes.
    pub fn isoc_interval_batch(&mut self) -> f64 {
        let n = self.w.n_boxes();
        self.case
            .kernels
            .interval_batch(&self.w.boxes, &mut self.out[..2 * n], &mut self.defined)
            .unwrap();
        self.out[n]
    }

    /// Fidget: the interval evaluator, once per box (it has no batch form).
    pub fn fidget_interval(&mut self) -> f64 {
        let (len, a) = axes(self.f_int_tape.vars());
        let mut s = 0.0;
        let mut args = vec![FInterval::from(0.0); len];
        for b in &self.w.fboxes {
            for k in 0..3 {
                if let Some(i) = a[k] {
                    args[i] = b[k];
                }
            }
            let (r, _) = self.f_int.eval(&self.f_int_tape, &args).unwrap();
            s += r[0].upper() as f64;
        }
        s
    }

    /// isoc: one `grad_batch` call over all boxes (interval gradient, f64).
    pub fn isoc_grad_batch(&mut self) -> f64 {
        let n = self.w.n_boxes();
        self.case
            .kernels
            .grad_batch(&self.w.boxes, &mut self.out8, &mut self.defined)
            .unwrap();
        self.out8[4 * n]
    }

    /// Fidget: one grad-slice evaluation at all box centres (point gradient, f32).
    pub fn fidget_grad_slice(&mut self) -> f64 {
        let (len, a) = axes(self.f_grad_tape.vars());
        let args = order(len, a, [&self.w.gx[..], &self.w.gy[..], &self.w.gz[..]]);
        let r = self.f_grad.eval(&self.f_grad_tape, &args).unwrap();
        r[0][self.w.n_boxes() / 2].v as f64
    }

    /// Largest |isoc − Fidget| point value over the workload, relative to
    /// the largest |f| seen: a check that the converter built the same
    /// function (differences are f32 rounding).
    pub fn point_agreement(&mut self) -> f64 {
        let n = self.w.n_points();
        self.isoc_point_batch();
        let a = self.out[..n].to_vec();
        let (len, ax) = axes(self.f_float_tape.vars());
        let args = order(len, ax, [&self.w.xf[..], &self.w.yf[..], &self.w.zf[..]]);
        let r = self.f_float.eval(&self.f_float_tape, &args).unwrap();
        let scale = a.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let mut worst = 0.0f64;
        for i in 0..n {
            worst = worst.max((a[i] - r[0][i] as f64).abs());
        }
        worst / scale
    }
}

// ---------------------------------------------------------------------------
// Meshing
// ---------------------------------------------------------------------------

/// Topology of an indexed triangle mesh, computed from its triangles only.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MeshTopology {
    pub vertices: usize,
    pub triangles: usize,
    pub components: usize,
    /// V − E + F over the vertices used by triangles.
    pub euler: i64,
    /// Sum of the genera of the closed components (`None` if any component
    /// is open or non-manifold, or has odd Euler characteristic).
    pub genus: Option<i64>,
    pub boundary_edges: usize,
    /// Edges shared by three or more triangles.
    pub nonmanifold_edges: usize,
    /// Edges whose two triangles traverse them in the same direction.
    pub misoriented_edges: usize,
    /// Every edge in exactly two triangles (and at least one triangle).
    pub watertight: bool,
    /// Triangles with two equal vertex indices.
    pub degenerate: usize,
}

pub fn topology(tris: &[[usize; 3]]) -> MeshTopology {
    let nv = tris.iter().flatten().copied().max().map_or(0, |m| m + 1);
    let mut parent: Vec<usize> = (0..nv).collect();
    fn find(p: &mut [usize], mut i: usize) -> usize {
        while p[i] != i {
            p[i] = p[p[i]];
            i = p[i];
        }
        i
    }
    // edge (min, max) -> (count, signed direction sum)
    let mut edges: HashMap<(usize, usize), (u32, i32)> = HashMap::with_capacity(tris.len() * 2);
    let mut used = vec![false; nv];
    let mut degenerate = 0;
    for t in tris {
        if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
            degenerate += 1;
        }
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            used[a] = true;
            let e = edges.entry((a.min(b), a.max(b))).or_insert((0, 0));
            e.0 += 1;
            e.1 += if a < b { 1 } else { -1 };
            let (ra, rb) = (find(&mut parent, a), find(&mut parent, b));
            if ra != rb {
                parent[ra] = rb;
            }
        }
    }
    let mut boundary = 0;
    let mut nonmanifold = 0;
    let mut misoriented = 0;
    for &(c, d) in edges.values() {
        match c {
            1 => boundary += 1,
            2 if d != 0 => misoriented += 1,
            2 => {}
            _ => nonmanifold += 1,
        }
    }
    let v_used = used.iter().filter(|&&u| u).count();
    let euler = v_used as i64 - edges.len() as i64 + tris.len() as i64;
    // per-component χ
    let mut comp: HashMap<usize, (i64, i64, i64)> = HashMap::new();
    for (i, _) in used.iter().enumerate().take(nv).filter(|&(_, &u)| u) {
        let r = find(&mut parent, i);
        comp.entry(r).or_default().0 += 1;
    }
    for &(a, _) in edges.keys() {
        let r = find(&mut parent, a);
        comp.entry(r).or_default().1 += 1;
    }
    for t in tris {
        let r = find(&mut parent, t[0]);
        comp.entry(r).or_default().2 += 1;
    }
    let watertight = !tris.is_empty() && boundary == 0 && nonmanifold == 0;
    let genus = if watertight && misoriented == 0 {
        comp.values().try_fold(0i64, |g, &(v, e, f)| {
            let chi = v - e + f;
            (chi % 2 == 0).then(|| g + (2 - chi) / 2)
        })
    } else {
        None
    };
    MeshTopology {
        vertices: v_used,
        triangles: tris.len(),
        components: comp.len(),
        euler,
        genus,
        boundary_edges: boundary,
        nonmanifold_edges: nonmanifold,
        misoriented_edges: misoriented,
        watertight,
        degenerate,
    }
}

/// isoc's mesher at `level` (paper topology test, k_max = 1, min level 3,
/// `smooth` smoothing passes) on the surface's own domain.
pub fn isoc_mesh(
    case: &Case,
    level: u8,
    smooth: usize,
) -> (isoc::mesh::Mesh, isoc::mesher::MeshReport) {
    let opts = isoc::mesher::MeshOptions {
        octree: isoc::octree::OctreeOptions {
            max_level: level,
            min_level: 3.min(level),
            kmax: 1.0,
            test: isoc::octree::TopologyTest::Paper,
            t: 0.0,
            prune: true,
            // The adaptive minimum (`--coarse`): the tables below compare
            // the criteria of the paper; `faithful_table` the defaults.
            chord: None,
        },
        smooth,
        domain: None,
        creases: true,
    };
    isoc::mesher::mesh(&case.surface, &opts, &|_| {})
}

/// The surfaces of the tolerance table (issue 11's targets): high-genus
/// algebraic surfaces and simpler ones from the corpus.
pub const TOLERANCE_SET: [&str; 11] = [
    "tanglecube",
    "orthocircle",
    "decocube",
    "chebyshev",
    "bretzel2",
    "bretzel5",
    "genus2",
    "twotorus",
    "nested",
    "blobs_merge",
    "torus",
];

/// isoc's mesher to a tolerance `tol` (`isoc mesh --tolerance`: the
/// defaults otherwise, level cap 10) on the surface's own domain.
pub fn isoc_mesh_tolerance(
    case: &Case,
    tol: f64,
) -> (
    isoc::mesh::Mesh,
    isoc::mesher::MeshReport,
    isoc::mesher::ToleranceReport,
) {
    let mut opts = isoc::mesher::MeshOptions::default();
    opts.octree.max_level = 10;
    isoc::mesher::mesh_to_tolerance(&case.surface, case.surface.domain, &opts, tol, &|_| {})
}

/// The length of the domain's diagonal.
pub fn diagonal(case: &Case) -> f64 {
    let d = case.surface.domain;
    (0..3)
        .map(|k| (d.hi[k] - d.lo[k]).powi(2))
        .sum::<f64>()
        .sqrt()
}

/// The share of triangles whose aspect ratio `4√3·area / Σ edge²` exceeds
/// 0.8 (SPEC's `aspect_good`), computed here for both meshers alike.
pub fn aspect_share(pts: &[[f64; 3]], tris: &[[usize; 3]]) -> f64 {
    if tris.is_empty() {
        return 0.0;
    }
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let good = tris
        .iter()
        .filter(|t| {
            let [a, b, c] = t.map(|i| pts[i]);
            let (u, v, w) = (sub(b, a), sub(c, a), sub(c, b));
            let n = [
                u[1] * v[2] - u[2] * v[1],
                u[2] * v[0] - u[0] * v[2],
                u[0] * v[1] - u[1] * v[0],
            ];
            let s = dot(u, u) + dot(v, v) + dot(w, w);
            s > 0.0 && 2.0 * 3f64.sqrt() * dot(n, n).sqrt() / s > 0.8
        })
        .count();
    good as f64 / tris.len() as f64
}

/// Fidget's Manifold Dual Contouring at `depth` on the same box: its octree
/// lives on [-1, 1]³ and `world_to_model` maps that cube onto the domain
/// (per-axis scale + translation, so non-cubic domains match exactly).
pub fn fidget_mesh(case: &Case, depth: u8) -> fidget::mesh::Mesh {
    let d = case.surface.domain;
    let c: [f32; 3] = std::array::from_fn(|k| (0.5 * (d.lo[k] + d.hi[k])) as f32);
    let h: [f32; 3] = std::array::from_fn(|k| (0.5 * (d.hi[k] - d.lo[k])) as f32);
    let m = nalgebra::Matrix4::new(
        h[0], 0.0, 0.0, c[0], //
        0.0, h[1], 0.0, c[1], //
        0.0, 0.0, h[2], c[2], //
        0.0, 0.0, 0.0, 1.0,
    );
    let settings = fidget::mesh::Settings {
        depth,
        world_to_model: m,
        ..Default::default()
    };
    let bound = case.fidget.clone().try_into().expect("no extra vars");
    let o = fidget::mesh::Octree::build(&bound, &settings).expect("not cancelled");
    o.walk_dual()
}

pub fn fidget_triangles(m: &fidget::mesh::Mesh) -> Vec<[usize; 3]> {
    m.triangles.iter().map(|t| [t[0], t[1], t[2]]).collect()
}

pub fn isoc_triangles(m: &isoc::mesh::Mesh) -> Vec<[usize; 3]> {
    m.triangles.iter().map(|t| t.map(|i| i as usize)).collect()
}

/// First-order distance of mesh vertices to the surface, |f(v)| / ‖∇f(v)‖,
/// with f and ∇f evaluated in f64 by isoc's point-gradient kernel (forward
/// AD: where the branches of a `min` or `max` tie, one branch's gradient,
/// as the mesher's own measure reads it; the midpoint of the interval
/// gradient there would average the branches' gradients, and on two
/// spheres kissing at a tie plane read 0.5 cells as 4). Returns (mean,
/// 99.9th percentile, max) divided by the finest cell edge of the depth
/// (largest domain edge / 2^depth). Vertices where ∇f vanishes are
/// skipped.
pub fn vertex_distance(case: &Case, pts: &[[f64; 3]], depth: u8) -> (f64, f64, f64) {
    let d = case.surface.domain;
    let edge = (0..3).map(|k| d.hi[k] - d.lo[k]).fold(0.0, f64::max);
    distance_in(case, pts, edge / (1u64 << depth) as f64)
}

/// [`vertex_distance`] in units of `unit`.
pub fn distance_in(case: &Case, pts: &[[f64; 3]], unit: f64) -> (f64, f64, f64) {
    let n = pts.len();
    if n == 0 {
        return (f64::NAN, f64::NAN, f64::NAN);
    }
    let col = |k: usize| pts.iter().map(|p| p[k]).collect::<Vec<f64>>();
    let mut out = vec![0.0; 4 * n];
    case.kernels
        .point_grad_batch(&col(0), &col(1), &col(2), 0.0, &mut out)
        .unwrap();
    let h = unit;
    let mut dists = Vec::with_capacity(n);
    for v in out.chunks_exact(4) {
        let g = (v[1].powi(2) + v[2].powi(2) + v[3].powi(2)).sqrt();
        if g > 0.0 && g.is_finite() && v[0].is_finite() {
            dists.push(v[0].abs() / g / h);
        }
    }
    if dists.is_empty() {
        return (f64::NAN, f64::NAN, f64::NAN);
    }
    dists.sort_by(f64::total_cmp);
    let mean = dists.iter().sum::<f64>() / dists.len() as f64;
    let p999 = dists[((dists.len() - 1) as f64 * 0.999) as usize];
    (mean, p999, dists[dists.len() - 1])
}

pub fn fidget_points(m: &fidget::mesh::Mesh) -> Vec<[f64; 3]> {
    m.vertices
        .iter()
        .map(|v| [v.x as f64, v.y as f64, v.z as f64])
        .collect()
}

pub fn isoc_points(m: &isoc::mesh::Mesh) -> Vec<[f64; 3]> {
    m.positions.iter().map(|v| [v.x, v.y, v.z]).collect()
}

/// isoc's mesher at `level` with `isoc mesh`'s defaults (faithful
/// `--level`: the chord criterion, smoothing, creases) on the surface's own
/// domain; `chord` replaces the default chord tolerance (calibration).
pub fn isoc_mesh_default(
    case: &Case,
    level: u8,
    chord: Option<f64>,
) -> (isoc::mesh::Mesh, isoc::mesher::MeshReport) {
    let mut opts = isoc::mesher::MeshOptions::default();
    opts.octree.max_level = level;
    if let Some(c) = chord {
        opts.octree.chord = Some(c);
    }
    isoc::mesher::mesh(&case.surface, &opts, &|_| {})
}

/// Triangle centroids and edge midpoints: where the chord error of a mesh
/// shows (issue 21's chord measure).
pub fn chord_points(pts: &[[f64; 3]], tris: &[[usize; 3]]) -> Vec<[f64; 3]> {
    let mid =
        |a: usize, b: usize| -> [f64; 3] { std::array::from_fn(|k| 0.5 * (pts[a][k] + pts[b][k])) };
    let mut edges: Vec<(usize, usize)> = tris
        .iter()
        .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
        .map(|(a, b)| (a.min(b), a.max(b)))
        .collect();
    edges.sort_unstable();
    edges.dedup();
    let mut out = centroids(pts, tris);
    out.extend(edges.into_iter().map(|(a, b)| mid(a, b)));
    out
}

/// Triangle centroids: where the chord error of a coarse mesh shows.
pub fn centroids(pts: &[[f64; 3]], tris: &[[usize; 3]]) -> Vec<[f64; 3]> {
    tris.iter()
        .map(|t| std::array::from_fn(|k| (pts[t[0]][k] + pts[t[1]][k] + pts[t[2]][k]) / 3.0))
        .collect()
}
