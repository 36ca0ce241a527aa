//! Verification of the MC33 cell polygoniser in the spirit of Etiene et al.,
//! *Topology verification for isosurface extraction* (TVCG 2012).
//!
//! For many cells, the number of connected components and the Euler
//! characteristic of `polygonize`'s triangulation are compared with those of
//! the zero set of the trilinear interpolant computed **independently**: the
//! interpolant is sampled on a fine grid inside the cell and triangulated by
//! marching tetrahedra (Freudenthal split, no ambiguity, no table), whose
//! components and `V − E + F` are counted. Cells within a small tolerance of
//! a topological degeneracy (a face saddle or an interior critical point of
//! the interpolant with value near zero — the only events that change the
//! topology of the zero set in a cell, by stratified Morse theory) are sent
//! to a finer oracle grid, or skipped and counted when even the finest grid
//! would not resolve them. That tolerance (smallest critical value ≥
//! 2·twist/n², twist = largest bilinear/trilinear coefficient) is a
//! heuristic: an oracle error would show up as a mismatch, not hide one.
//!
//! Run: `cargo test --test mesh mc33:: -- --nocapture` (prints the statistics:
//! cells compared, refined, skipped, mismatches, topologies met, orientation).

use glam::DVec3;
use isoc::mesh::Mesh;
use isoc::mesh::topology::{analyze, triangle_components};
use isoc::polygonize::mc33::{
    self, CellMesh, EDGE_CORNERS, Vertex, polygonize, trilinear, trilinear_gradient,
};

/// Components and Euler characteristic of a zero set: what the oracle
/// computes and what the mesh's topology is compared on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Topology {
    components: usize,
    euler: i64,
}

/// Deterministic splitmix64.
struct Rng(u64);
impl Rng {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    fn f(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Uniform in [lo, hi).
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.f()
    }
}

// ---------------------------------------------------------------- oracle --

/// Trilinear coefficients: T = a + bx + cy + dz + exy + fyz + gxz + hxyz.
fn coefficients(v: &[f64; 8]) -> [f64; 8] {
    [
        v[0],
        v[1] - v[0],
        v[2] - v[0],
        v[4] - v[0],
        v[0] - v[1] - v[2] + v[3],
        v[0] - v[2] - v[4] + v[6],
        v[0] - v[1] - v[4] + v[5],
        -v[0] + v[1] + v[2] - v[3] + v[4] - v[5] - v[6] + v[7],
    ]
}

fn tl(v: &[f64; 8], x: f64, y: f64, z: f64) -> f64 {
    let [a, b, c, d, e, f, g, h] = coefficients(v);
    a + b * x + c * y + d * z + e * x * y + f * y * z + g * x * z + h * x * y * z
}

/// Smallest |value| of the interpolant at its critical points on the open
/// faces (bilinear saddles) and in the open cell (at most two points).
fn min_critical_value(v: &[f64; 8]) -> f64 {
    let mut m = f64::INFINITY;
    // Faces: fix one coordinate at 0 or 1; bilinear in the two others.
    for axis in 0..3 {
        for side in 0..2 {
            let at = |u: usize, w: usize| {
                let mut p = [0.0; 3];
                p[axis] = side as f64;
                p[(axis + 1) % 3] = u as f64;
                p[(axis + 2) % 3] = w as f64;
                tl(v, p[0], p[1], p[2])
            };
            let (v00, v10, v01, v11) = (at(0, 0), at(1, 0), at(0, 1), at(1, 1));
            let den = v00 - v10 - v01 + v11;
            if den != 0.0 {
                let (s, t) = ((v00 - v01) / den, (v00 - v10) / den);
                if (0.0..=1.0).contains(&s) && (0.0..=1.0).contains(&t) {
                    m = m.min(((v00 * v11 - v10 * v01) / den).abs());
                }
            }
        }
    }
    let [_, b, c, d, e, f, g, h] = coefficients(v);
    let mut pts: Vec<[f64; 3]> = Vec::new();
    if h != 0.0 {
        let p = (e * g / h - b) / h; // YZ
        let q = (e * f / h - c) / h; // XZ
        let r = (f * g / h - d) / h; // XY
        if p * q * r > 0.0 {
            let xx = (q * r / p).sqrt();
            for sx in [xx, -xx] {
                let (yy, zz) = (r / sx, q / sx);
                pts.push([sx - f / h, yy - g / h, zz - e / h]);
            }
        }
    } else {
        let det = 2.0 * e * f * g;
        if det != 0.0 {
            // [[0,e,g],[e,0,f],[g,f,0]] (x,y,z) = -(b,c,d)
            let (r0, r1, r2) = (-b, -c, -d);
            let x = (r0 * (0.0 - f * f) - e * (r1 * 0.0 - f * r2) + g * (r1 * f - 0.0 * r2)) / det;
            let y =
                (0.0 * (r1 * 0.0 - f * r2) - r0 * (e * 0.0 - f * g) + g * (e * r2 - r1 * g)) / det;
            let z =
                (0.0 * (0.0 * r2 - r1 * f) - e * (e * r2 - r1 * g) + r0 * (e * f - 0.0 * g)) / det;
            pts.push([x, y, z]);
        }
    }
    for p in pts {
        if p.iter().all(|c| (0.0..=1.0).contains(c)) {
            m = m.min(tl(v, p[0], p[1], p[2]).abs());
        }
    }
    m
}

/// Scratch space of the oracle.
#[derive(Default)]
struct Scratch {
    val: Vec<f64>,
    /// Per grid edge (node * 7 + direction): (stamp, vertex id).
    slot: Vec<(u32, u32)>,
    stamp: u32,
    parent: Vec<u32>,
    planes: Vec<u8>,
}

/// Components and Euler characteristic of {T = 0} from marching tetrahedra
/// on an n³ grid of the cell (Freudenthal split of every grid cube). The
/// surface is a manifold with boundary on the cube faces, so
/// `E = (3F + B) / 2` with B the number of triangle sides on the faces.
fn oracle(v: &[f64; 8], n: usize, sc: &mut Scratch) -> Topology {
    let np = n + 1;
    let h = 1.0 / n as f64;
    let coef = coefficients(v);
    sc.val.clear();
    for k in 0..np {
        let z = k as f64 * h;
        for j in 0..np {
            let y = j as f64 * h;
            for i in 0..np {
                let x = i as f64 * h;
                let [a, b, c, d, e, f, g, hh] = coef;
                sc.val.push(
                    a + b * x + c * y + d * z + e * x * y + f * y * z + g * x * z + hh * x * y * z,
                );
            }
        }
    }
    if sc.slot.len() < np * np * np * 7 {
        sc.slot = vec![(0, 0); np * np * np * 7];
        sc.stamp = 0;
    }
    sc.stamp += 1;
    sc.parent.clear();
    sc.planes.clear();
    let stamp = sc.stamp;
    let off = [1, np, np * np];
    let perms = [
        [0, 1, 2],
        [0, 2, 1],
        [1, 0, 2],
        [1, 2, 0],
        [2, 0, 1],
        [2, 1, 0],
    ];
    let corners = [
        0,
        1,
        np,
        np + 1,
        np * np,
        np * np + 1,
        np * np + np,
        np * np + np + 1,
    ];
    let node_planes = |x: usize| -> u8 {
        let (i, j, k) = (x % np, (x / np) % np, x / (np * np));
        let mut m = 0u8;
        for (axis, c) in [i, j, k].into_iter().enumerate() {
            if c == 0 {
                m |= 1 << (2 * axis);
            }
            if c == n {
                m |= 1 << (2 * axis + 1);
            }
        }
        m
    };
    // MT vertex on the grid edge (x, y), y = x + (0/1 vector).
    let vid = |sc: &mut Scratch, x: usize, y: usize| -> u32 {
        let (lo, hi) = (x.min(y), x.max(y));
        let d = hi - lo;
        let dir = (d % np) + 2 * ((d / np) % np) + 4 * (d / (np * np)) - 1;
        let s = &mut sc.slot[lo * 7 + dir];
        if s.0 != stamp {
            let id = sc.parent.len() as u32;
            *s = (stamp, id);
            sc.parent.push(id);
            sc.planes.push(node_planes(lo) & node_planes(hi));
        }
        s.1
    };
    fn find(p: &mut [u32], mut a: u32) -> u32 {
        while p[a as usize] != a {
            p[a as usize] = p[p[a as usize] as usize];
            a = p[a as usize];
        }
        a
    }
    let mut faces = 0i64;
    let mut bsides = 0i64;
    let mut tri = |sc: &mut Scratch, t: [u32; 3]| {
        faces += 1;
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            if sc.planes[a as usize] & sc.planes[b as usize] != 0 {
                bsides += 1;
            }
            let (ra, rb) = (find(&mut sc.parent, a), find(&mut sc.parent, b));
            if ra != rb {
                sc.parent[ra as usize] = rb;
            }
        }
    };
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                let base = i + np * (j + np * k);
                let nneg = corners.iter().filter(|&&c| sc.val[base + c] < 0.0).count();
                if nneg == 0 || nneg == 8 {
                    continue;
                }
                for p in perms {
                    let t1 = base + off[p[0]];
                    let t2 = t1 + off[p[1]];
                    let tv = [base, t1, t2, t2 + off[p[2]]];
                    let mut ns = [0usize; 4];
                    let mut ps = [0usize; 4];
                    let (mut nn, mut nq) = (0, 0);
                    for x in tv {
                        if sc.val[x] < 0.0 {
                            ns[nn] = x;
                            nn += 1;
                        } else {
                            ps[nq] = x;
                            nq += 1;
                        }
                    }
                    match nn {
                        1 | 3 => {
                            let (s, o) = if nn == 1 { (ns[0], ps) } else { (ps[0], ns) };
                            let t = [vid(sc, s, o[0]), vid(sc, s, o[1]), vid(sc, s, o[2])];
                            tri(sc, t);
                        }
                        2 => {
                            let (a, b, c, d) = (ns[0], ns[1], ps[0], ps[1]);
                            let (ac, ad, bd, bc) =
                                (vid(sc, a, c), vid(sc, a, d), vid(sc, b, d), vid(sc, b, c));
                            tri(sc, [ac, ad, bd]);
                            tri(sc, [ac, bd, bc]);
                        }
                        _ => {}
                    }
                }
            }
        }
    }
    let nv = sc.parent.len();
    let components = (0..nv as u32)
        .filter(|&i| find(&mut sc.parent, i) == i)
        .count();
    let edges = (3 * faces + bsides) / 2;
    Topology {
        components,
        euler: nv as i64 - edges + faces,
    }
}

// ------------------------------------------------------------- checks --

/// Structural checks; returns the number of badly oriented triangles.
fn check_structure(v: &[f64; 8], m: &CellMesh) -> usize {
    let verts = m.vertices();
    let mut used = [false; 12];
    for x in verts {
        if let Vertex::Edge { edge, t } = *x {
            let [a, b] = EDGE_CORNERS[edge as usize];
            assert!(
                (v[a as usize] < 0.0) != (v[b as usize] < 0.0),
                "edge vertex on an edge without sign change: {v:?}"
            );
            assert!((0.0..=1.0).contains(&t), "t out of range: {v:?}");
            assert!(!used[edge as usize], "two vertices on edge {edge}: {v:?}");
            used[edge as usize] = true;
        }
    }
    // Every sign-changing edge carries a vertex.
    for (e, [a, b]) in EDGE_CORNERS.iter().enumerate() {
        if (v[*a as usize] < 0.0) != (v[*b as usize] < 0.0) {
            assert!(used[e], "edge {e} with a sign change has no vertex: {v:?}");
        }
    }
    // Manifold with consistent orientation: every directed side at most
    // once; a side without its reverse is a boundary side, joining two edge
    // vertices, and every edge vertex has one boundary side in and one out.
    let mut sides = std::collections::HashSet::new();
    for t in m.triangles() {
        for k in 0..3 {
            assert!(
                sides.insert((t[k], t[(k + 1) % 3])),
                "side used twice in the same direction: {v:?}"
            );
        }
    }
    let mut deg_in = vec![0; verts.len()];
    let mut deg_out = vec![0; verts.len()];
    for &(a, b) in &sides {
        if !sides.contains(&(b, a)) {
            deg_out[a as usize] += 1;
            deg_in[b as usize] += 1;
        }
    }
    for (i, x) in verts.iter().enumerate() {
        let want = if matches!(x, Vertex::Edge { .. }) {
            1
        } else {
            0
        };
        assert!(
            deg_in[i] == want && deg_out[i] == want,
            "vertex {i} has {} boundary sides in, {} out: {v:?}",
            deg_in[i],
            deg_out[i]
        );
    }
    let mut bad = 0;
    for t in m.triangles() {
        assert!(
            t.iter().all(|&i| (i as usize) < verts.len()),
            "index out of range"
        );
        assert!(
            t[0] != t[1] && t[1] != t[2] && t[0] != t[2],
            "degenerate triangle {t:?}: {v:?}"
        );
        let p = t.map(|i| verts[i as usize].position());
        let n = (p[1] - p[0]).cross(p[2] - p[0]);
        let g = trilinear_gradient(v, (p[0] + p[1] + p[2]) / 3.0);
        if n.dot(g) <= 0.0 {
            bad += 1;
        }
    }
    bad
}

/// Per connected component of the cell mesh, the flux Σ n·∇T(centroid)
/// (n the area-weighted normal): positive when the component faces towards
/// increasing values.
fn component_flux(v: &[f64; 8], m: &CellMesh) -> Vec<f64> {
    let mesh = cell_mesh(m);
    let comp = triangle_components(&mesh);
    let mut flux = vec![0.0; comp.iter().map(|&c| c as usize + 1).max().unwrap_or(0)];
    for (t, &c) in mesh.triangles.iter().zip(&comp) {
        let p = t.map(|i| mesh.positions[i as usize]);
        let n = (p[1] - p[0]).cross(p[2] - p[0]);
        let g = trilinear_gradient(v, (p[0] + p[1] + p[2]) / 3.0);
        flux[c as usize] += n.dot(g);
    }
    flux
}

/// The cell's triangles as a [`Mesh`] over its own vertices.
fn cell_mesh(m: &CellMesh) -> Mesh {
    Mesh {
        positions: m.vertices().iter().map(|v| v.position()).collect(),
        triangles: m.triangles().iter().map(|t| t.map(u32::from)).collect(),
        ..Mesh::default()
    }
}

fn mesh_topology(m: &CellMesh) -> Topology {
    let t = analyze(&cell_mesh(m));
    Topology {
        components: t.components,
        euler: t.euler,
    }
}

#[derive(Default, Debug, Clone)]
struct Stats {
    cells: usize,
    compared: usize,
    skipped: usize,
    refined: usize,
    mismatches: usize,
    empty: usize,
    tris: usize,
    interior_verts: usize,
    bad_orient: usize,
    bad_orient_cells: usize,
    bad_flux: usize,
    bad_orient_tube_cells: usize,
    configs: Vec<usize>,
    by_topo: std::collections::BTreeMap<(usize, i64), usize>,
    failures: Vec<String>,
}

impl Stats {
    fn new() -> Self {
        Stats {
            configs: vec![0; 256],
            ..Default::default()
        }
    }
    fn merge(&mut self, o: Stats) {
        self.cells += o.cells;
        self.compared += o.compared;
        self.skipped += o.skipped;
        self.refined += o.refined;
        self.mismatches += o.mismatches;
        self.empty += o.empty;
        self.tris += o.tris;
        self.interior_verts += o.interior_verts;
        self.bad_orient += o.bad_orient;
        self.bad_orient_cells += o.bad_orient_cells;
        self.bad_flux += o.bad_flux;
        self.bad_orient_tube_cells += o.bad_orient_tube_cells;
        for (a, b) in self.configs.iter_mut().zip(o.configs) {
            *a += b;
        }
        for (k, c) in o.by_topo {
            *self.by_topo.entry(k).or_default() += c;
        }
        self.failures.extend(o.failures);
    }
}

/// Oracle grid resolutions, coarsest first.
const GRIDS: [usize; 4] = [12, 16, 24, 32];

fn run_cell(v: &[f64; 8], st: &mut Stats, sc: &mut Scratch) {
    st.cells += 1;
    let mut cfg = 0usize;
    for (i, x) in v.iter().enumerate() {
        if *x < 0.0 {
            cfg |= 1 << i;
        }
    }
    st.configs[cfg] += 1;
    let m = polygonize(v);
    let bad = check_structure(v, &m);
    st.tris += m.triangles().len();
    st.interior_verts += m
        .vertices()
        .iter()
        .filter(|x| matches!(x, Vertex::Interior(_)))
        .count();
    if m.is_empty() {
        st.empty += 1;
    }
    let scale = v.iter().fold(0.0f64, |a, x| a.max(x.abs()));
    let c = coefficients(v);
    let twist = c[4..].iter().fold(0.0f64, |a, x| a.max(x.abs()));
    // The oracle's grid must resolve the smallest critical value: linear
    // interpolation on a grid square of side 1/n errs by at most twist/(4n²).
    let crit = min_critical_value(v);
    let Some(&grid) = GRIDS
        .iter()
        .find(|&&n| crit >= 1e-9 * scale + 2.0 * twist / (n * n) as f64)
    else {
        st.skipped += 1;
        return;
    };
    if grid > GRIDS[0] {
        st.refined += 1;
    }
    let ours = mesh_topology(&m);
    let has_tube = ours.euler < ours.components as i64;
    if bad > 0 && has_tube {
        st.bad_orient_tube_cells += 1;
    }
    if component_flux(v, &m).iter().any(|&f| f <= 0.0) {
        st.bad_flux += 1;
        if st.failures.len() < 40 {
            st.failures.push(format!("FLUX {v:?}"));
        }
    }
    if bad > 0 {
        st.bad_orient += bad;
        st.bad_orient_cells += 1;
        if st.failures.len() < 40 {
            st.failures.push(format!("ORIENT {v:?}"));
        }
    }
    st.compared += 1;
    let truth = oracle(v, grid, sc);
    *st.by_topo
        .entry((truth.components, truth.euler))
        .or_default() += 1;
    if ours != truth {
        st.mismatches += 1;
        if st.failures.len() < 40 {
            st.failures
                .push(format!("TOPO {v:?}: ours {ours:?}, trilinear {truth:?}"));
        }
    }
}

/// Run `cells` on two threads.
fn run_all(cells: &[[f64; 8]]) -> Stats {
    let mut total = Stats::new();
    let half = cells.len().div_ceil(2);
    std::thread::scope(|s| {
        let hs: Vec<_> = cells
            .chunks(half.max(1))
            .map(|chunk| {
                s.spawn(move || {
                    let mut st = Stats::new();
                    let mut sc = Scratch::default();
                    for v in chunk {
                        run_cell(v, &mut st, &mut sc);
                    }
                    st
                })
            })
            .collect();
        for h in hs {
            total.merge(h.join().expect("worker panicked"));
        }
    });
    total
}

fn report(name: &str, st: &Stats) {
    let unseen = st.configs.iter().filter(|&&c| c == 0).count();
    eprintln!(
        "[{name}] cells {} compared {} (on a finer grid: {}) skipped {} mismatches {} empty {} tris {} interior-verts {} \
         bad-orientation triangles {} (in {} cells, {} with a tube) components with flux against the gradient {} unseen configs {} topologies (components, euler) {:?}",
        st.cells,
        st.compared,
        st.refined,
        st.skipped,
        st.mismatches,
        st.empty,
        st.tris,
        st.interior_verts,
        st.bad_orient,
        st.bad_orient_cells,
        st.bad_orient_tube_cells,
        st.bad_flux,
        unseen,
        st.by_topo,
    );
    for f in &st.failures {
        eprintln!("  {f}");
    }
}

fn random_cell(rng: &mut Rng) -> [f64; 8] {
    core::array::from_fn(|_| rng.range(-1.0, 1.0))
}

/// A cell with the sign configuration `cfg`, magnitudes in [lo, 1].
fn config_cell(rng: &mut Rng, cfg: usize, lo: f64) -> [f64; 8] {
    core::array::from_fn(|i| {
        let m = rng.range(lo, 1.0);
        if cfg >> i & 1 == 1 { -m } else { m }
    })
}

/// A cell close to a face or interior ambiguity: magnitudes clustered around
/// a common value so that saddle values are small.
fn near_ambiguous_cell(rng: &mut Rng) -> [f64; 8] {
    let cfg = (rng.next_u64() & 255) as usize;
    let spread = [0.05, 0.1, 0.2, 0.3][(rng.next_u64() % 4) as usize];
    core::array::from_fn(|i| {
        let m = 0.5 + rng.range(-spread, spread);
        if cfg >> i & 1 == 1 { -m } else { m }
    })
}

/// A degenerate dual cell (paper §4.3): corners sharing an octree leaf get
/// the same value.
fn repeated_corner_cell(rng: &mut Rng) -> [f64; 8] {
    let mut v = random_cell(rng);
    let axis = (rng.next_u64() % 3) as usize;
    let mode = rng.next_u64() % 3;
    for i in 0..8usize {
        let j = i & !(1 << axis);
        let collapse = match mode {
            0 => true,                           // a face collapsed onto its opposite
            1 => i >> ((axis + 1) % 3) & 1 == 0, // half of them
            _ => i == 1 << axis,                 // a single corner
        };
        if collapse {
            v[i] = v[j];
        }
    }
    v
}

#[test]
fn topology_matches_trilinear_interpolant() {
    let t0 = std::time::Instant::now();
    let mut rng = Rng(0x1234_5678);
    let mut total = Stats::new();
    let sets: [(&str, Vec<[f64; 8]>); 4] = [
        (
            "uniform",
            (0..100_000).map(|_| random_cell(&mut rng)).collect(),
        ),
        (
            "configs",
            (0..256 * 20)
                .map(|i| config_cell(&mut rng, i % 256, 0.05))
                .collect(),
        ),
        (
            "near-ambiguous",
            (0..10_000).map(|_| near_ambiguous_cell(&mut rng)).collect(),
        ),
        (
            "repeated-corners",
            (0..5_000).map(|_| repeated_corner_cell(&mut rng)).collect(),
        ),
    ];
    for (name, cells) in sets {
        let st = run_all(&cells);
        report(name, &st);
        total.merge(st);
    }
    report("total", &total);
    eprintln!("time {:?}", t0.elapsed());
    let unseen = total.configs.iter().filter(|&&c| c == 0).count();
    assert_eq!(unseen, 0, "sign configurations not exercised");
    assert_eq!(total.mismatches, 0, "topology mismatches");
    // Orientation: every triangle of a cell without a tunnel faces along the
    // gradient at its centroid; a tube's long triangles may not (reported
    // above; most tubes need a rung inside a low face, which only the waist
    // ring avoids: see mc33's "Chords"), but every component faces along
    // the gradient on the whole.
    assert_eq!(
        total.bad_orient_cells, total.bad_orient_tube_cells,
        "badly oriented triangles in a cell without a tube"
    );
    assert!(
        total.bad_orient_tube_cells * 3
            < 2 * total
                .by_topo
                .iter()
                .filter(|((c, e), _)| (*e as usize) < *c)
                .map(|(_, n)| n)
                .sum::<usize>()
    );
    assert_eq!(total.bad_flux, 0, "a component faces against the gradient");
    assert!(total.compared >= 100_000);
    assert!(total.skipped * 20 < total.cells, "too many skipped cells");
}

/// Directed boundary sides of `m` lying on face (`axis`, `side`), as
/// ((edge, t), (edge, t)) pairs.
fn face_sides(m: &CellMesh, axis: usize, side: u8) -> Vec<((u8, u64), (u8, u64))> {
    let on_face = |e: u8| {
        EDGE_CORNERS[e as usize]
            .iter()
            .all(|&c| (c >> axis) & 1 == side)
    };
    let ev = |i: u8| match m.vertices()[i as usize] {
        Vertex::Edge { edge, t } => Some((edge, t.to_bits())),
        Vertex::Interior(_) => None,
    };
    let mut sides = std::collections::HashSet::new();
    for t in m.triangles() {
        for k in 0..3 {
            sides.insert((t[k], t[(k + 1) % 3]));
        }
    }
    let mut out: Vec<_> = sides
        .iter()
        .filter(|(a, b)| !sides.contains(&(*b, *a)))
        .filter_map(|&(a, b)| Some((ev(a)?, ev(b)?)))
        .filter(|((ea, _), (eb, _))| on_face(*ea) && on_face(*eb))
        .collect();
    out.sort_unstable();
    out
}

/// The edge of the neighbouring cell across the face normal to `axis` that
/// is edge `e` of a face on either side (its corners' `axis` bits flip).
fn across(e: u8, axis: usize) -> u8 {
    let [a, b] = EDGE_CORNERS[e as usize];
    mc33::edge_between(a ^ (1 << axis), b ^ (1 << axis)).expect("edge")
}

fn check_shared_face(rng: &mut Rng, pick: &mut dyn FnMut(&mut Rng) -> f64) -> usize {
    let axis = (rng.next_u64() % 3) as usize;
    let a: [f64; 8] = core::array::from_fn(|_| pick(rng));
    let mut b: [f64; 8] = core::array::from_fn(|_| pick(rng));
    for c in 0..8u8 {
        if (c >> axis) & 1 == 1 {
            b[(c ^ (1 << axis)) as usize] = a[c as usize];
        }
    }
    let (ma, mb) = (polygonize(&a), polygonize(&b));
    check_structure(&a, &ma);
    check_structure(&b, &mb);
    let sa = face_sides(&ma, axis, 1);
    let mut sa_in_b: Vec<_> = sa
        .iter()
        .map(|&((ea, ta), (eb, tb))| ((across(eb, axis), tb), (across(ea, axis), ta)))
        .collect();
    sa_in_b.sort_unstable();
    let sb = face_sides(&mb, axis, 0);
    assert_eq!(
        sa_in_b, sb,
        "crack between cells {a:?} and {b:?} (axis {axis})"
    );
    // No edge of the pair has more than two triangles: an inner edge drawn
    // inside the shared face by one cell is never drawn by the other.
    let on_face = |e: u8, side: u8| {
        EDGE_CORNERS[e as usize]
            .iter()
            .all(|&c| (c >> axis) & 1 == side)
    };
    // Vertices on the shared face keyed by b's edge id, the others apart.
    let key = |m: &CellMesh, i: u8, from_a: bool| match m.vertices()[i as usize] {
        Vertex::Edge { edge, .. } if from_a && on_face(edge, 1) => across(edge, axis) as u32,
        Vertex::Edge { edge, .. } if !from_a && on_face(edge, 0) => edge as u32,
        _ => 100 * (1 + from_a as u32) + i as u32,
    };
    let mut uses = std::collections::HashMap::new();
    for (m, from_a) in [(&ma, true), (&mb, false)] {
        for t in m.triangles() {
            for k in 0..3 {
                let (p, q) = (key(m, t[k], from_a), key(m, t[(k + 1) % 3], from_a));
                *uses.entry((p.min(q), p.max(q))).or_insert(0) += 1;
            }
        }
    }
    let over = uses.iter().find(|(_, n)| **n > 2);
    assert!(
        over.is_none(),
        "edge {over:?} drawn by both cells {a:?} and {b:?} (axis {axis})"
    );
    sa.len()
}

#[test]
fn face_adjacent_cells_agree() {
    let mut rng = Rng(42);
    let mut segments = 0;
    for _ in 0..20_000 {
        segments += check_shared_face(&mut rng, &mut |r| r.range(-1.0, 1.0));
    }
    // Exact ties of the asymptotic decider (a·c = b·d), zeros, repeated values.
    let vals = [-1.0, -0.5, -0.25, 0.0, 0.25, 0.5, 1.0, 2.0];
    for _ in 0..20_000 {
        segments += check_shared_face(&mut rng, &mut |r| vals[(r.next_u64() % 8) as usize]);
    }
    // Neighbours of very different magnitudes (the face decision must not
    // depend on the rest of the cell).
    for _ in 0..10_000 {
        segments += check_shared_face(&mut rng, &mut |r| {
            r.range(-1.0, 1.0) * 10f64.powi((r.next_u64() % 600) as i32 - 300)
        });
    }
    eprintln!("shared-face segments compared: {segments}");
    assert!(segments > 20_000);
}

#[test]
fn degenerate_values_do_not_break_the_contract() {
    let vals = [
        -1.0,
        1.0,
        0.0,
        -0.0,
        f64::NAN,
        f64::INFINITY,
        f64::NEG_INFINITY,
        1e-300,
        -1e-300,
        1e300,
        -1e300,
        f64::MIN_POSITIVE,
        -5e-324,
    ];
    let mut rng = Rng(7);
    for _ in 0..50_000 {
        let v: [f64; 8] =
            core::array::from_fn(|_| vals[(rng.next_u64() % vals.len() as u64) as usize]);
        let m = polygonize(&v);
        let clean = v.map(|x| if x.is_nan() { 0.0 } else { x });
        check_structure(&clean, &m);
    }
    assert!(polygonize(&[0.0; 8]).is_empty());
    assert!(polygonize(&[f64::NAN; 8]).is_empty());
    assert!(polygonize(&[-1.0; 8]).is_empty());
    // A single zero corner among negatives: it counts as positive.
    let mut v = [-1.0; 8];
    v[5] = 0.0;
    let m = polygonize(&v);
    assert_eq!(m.triangles().len(), 1);
    assert_eq!(
        mesh_topology(&m),
        Topology {
            components: 1,
            euler: 1
        }
    );
}

#[test]
fn trilinear_helpers_agree() {
    let v = [-1.0, 0.5, 0.3, 0.2, 0.7, 0.1, 0.4, 0.9];
    let p = DVec3::new(0.3, 0.6, 0.2);
    assert!((trilinear(&v, p) - tl(&v, p.x, p.y, p.z)).abs() < 1e-12);
    let _ = mc33::MAX_TRIS;
}

/// A dual cell across a pyramid's 130° edge (`benches/peers/surfaces/pyramid4.iso`
/// at level 8), whose corner of value 0.019 is the centre of a leaf four
/// times as large: the interpolant joins that corner to the opposite
/// positive one through the cell, and MC33 draws a tube where the solid is
/// convex. Refused, the tunnel closes into two discs. Over random cells,
/// refusing every tunnel leaves only discs and the same segments on every
/// face (so the neighbours still agree), and accepting every one is
/// [`polygonize`].
#[test]
fn a_refused_tunnel_closes_into_discs() {
    let v = [
        -0.000995, 0.000546, 0.000562, 0.019233, 0.001717, -0.004519, -0.002130, -0.004847,
    ];
    let tube = mesh_topology(&polygonize(&v));
    assert_eq!(
        tube,
        Topology {
            components: 1,
            euler: 0
        }
    );
    let discs = mesh_topology(&mc33::polygonize_checked(&v, &|_, _| false));
    assert_eq!(
        discs,
        Topology {
            components: 2,
            euler: 2
        }
    );
    let mut rng = Rng(0x7ab_0001);
    let (mut tubes, mut closed) = (0, 0);
    for _ in 0..50_000 {
        let v = near_ambiguous_cell(&mut rng);
        let (all, none) = (polygonize(&v), mc33::polygonize_checked(&v, &|_, _| false));
        let same = mc33::polygonize_checked(&v, &|_, _| true);
        assert_eq!(same.triangles(), all.triangles());
        let (ta, tn) = (mesh_topology(&all), mesh_topology(&none));
        assert_eq!(tn.euler, tn.components as i64, "{v:?}: {tn:?}");
        for axis in 0..3 {
            for side in 0..2 {
                assert_eq!(
                    face_sides(&none, axis, side),
                    face_sides(&all, axis, side),
                    "{v:?}"
                );
            }
        }
        if ta != tn {
            tubes += 1;
            closed += usize::from(tn.components > ta.components);
        }
    }
    assert!(
        tubes > 100 && closed == tubes,
        "{tubes} tunnels, {closed} closed"
    );
}

/// Corners joined by the caller ([`mc33::polygonize_joined`]) share a
/// region whatever the interpolant says. Opposite corners of a cell (case
/// 4 without a tunnel) become a tube; opposite corners of a face that the
/// asymptotic decider separates become one disc, with that face's
/// segments flipped the same way in the cell across it, so the two still
/// agree. Pairs that are not opposite, or not of one sign, change nothing;
/// a cell without surface is one region.
#[test]
fn joined_corners_share_a_region() {
    assert_eq!(polygonize(&[1.0; 8]).regions(), [0; 8]);
    let mut body = [1.0; 8];
    (body[0], body[7]) = (-1.0, -1.0);
    let apart = polygonize(&body);
    let regions = apart.regions();
    assert_ne!(regions[0], regions[7]);
    assert_eq!(
        mesh_topology(&apart),
        Topology {
            components: 2,
            euler: 2
        }
    );
    let tube = mc33::polygonize_joined(&body, &|_, _| true, &[[0, 7]]);
    assert_eq!(tube.regions()[0], tube.regions()[7]);
    assert_eq!(
        mesh_topology(&tube),
        Topology {
            components: 1,
            euler: 0
        }
    );
    // Corners 0 and 3 are opposite on the face z = 0; the cell below has
    // that face on its top, where they are corners 4 and 7.
    let mut low = [1.0; 8];
    (low[0], low[3]) = (-0.5, -0.5);
    let mut below = [0.8, 0.9, 1.1, 0.7, 1.0, 1.0, 1.0, 1.0];
    (below[4], below[7]) = (-0.5, -0.5);
    assert_eq!(mesh_topology(&polygonize(&low)).components, 2);
    let (a, b) = (
        mc33::polygonize_joined(&low, &|_, _| true, &[[3, 0]]),
        mc33::polygonize_joined(&below, &|_, _| true, &[[4, 7]]),
    );
    assert_eq!(
        mesh_topology(&a),
        Topology {
            components: 1,
            euler: 1
        }
    );
    let mut a_in_b: Vec<_> = face_sides(&a, 2, 0)
        .iter()
        .map(|&((ea, ta), (eb, tb))| ((across(eb, 2), tb), (across(ea, 2), ta)))
        .collect();
    a_in_b.sort_unstable();
    assert_eq!(a_in_b, face_sides(&b, 2, 1));
    assert_ne!(face_sides(&a, 2, 0), face_sides(&polygonize(&low), 2, 0));
    for ignored in [[0, 1], [0, 5], [0, 9]] {
        let m = mc33::polygonize_joined(&body, &|_, _| true, &[ignored]);
        assert_eq!(m.triangles(), apart.triangles(), "{ignored:?}");
    }
}
