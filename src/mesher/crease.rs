//! Sharp creases (issue 11, item 3). Where a crease of the surface — the
//! edge or corner of a CSG `min`/`max` — crosses a dual cell, marching
//! cubes cuts it off at cell scale: the cell's vertices lie on the cell's
//! edges, on both sides of the crease, and its triangles join them by a
//! chamfer. This pass puts a vertex on the crease and re-triangulates the
//! cell's patch as a fan around it, then flips the edges between
//! neighbouring fans so that the crease becomes a polyline of mesh edges
//! (the "extended marching cubes" of Kobbelt, Botsch, Schwanecke & Seidel,
//! *Feature sensitive surface extraction from volume data*, SIGGRAPH 2001,
//! on the dual grid).
//!
//! # Contract
//!
//! Each sheet of a dual cell's patch (a component: where two sheets cross
//! or touch, as `x y = 0`'s along its axis, a cell holds one piece of
//! each, and each gets its own point on the line) is sharpened when it is
//! one disk (whose boundary vertices are cell-edge vertices; MC33's
//! interior vertices inside it go with its triangles, left unused for the
//! caller to drop: [`crate::mesh::Mesh::drop_unused`]), the surface
//! normals at its boundary vertices fall into two or three clusters more
//! than [`SPLIT_DEG`] degrees apart, the gap at least `GAP_RATIO` times
//! the largest angle inside a cluster (a crease between them) — or, at
//! the tip of a cone, turn by more than [`SPLIT_DEG`] in no such clusters
//! (a ring of normals around a singular point where the gradient
//! vanishes, as the double cone's apex; four or more clusters, as a
//! pyramid's apex) — and
//!
//! 1. the feature point — the least-squares intersection of the vertices'
//!    tangent planes (a quadratic error function solved from the vertices'
//!    mean, directions of small curvature of the error truncated, so that
//!    along a crease it stays at the mean) — lies in the cell's bounding
//!    box, after sliding along the crease (its one free direction) into
//!    the box when the mean's nearest crease point lies outside it; where
//!    the crease does not cross the box, it may lie up to `WEDGE_ROOM`
//!    sides past it when it is the tip of a wedge sharper than a right
//!    angle (the two sides' normals turn by more than 90°) and `f` keeps
//!    the patch's sign on the way there (`wedge_tip`: the dual grid's
//!    samples miss such a tip where the wedge is thinner than a cell, and
//!    the patch across it stands up to a cell short of it); on a blade
//!    (normals turning by more than 155° or so, where the error's matrix
//!    has one direction left and the solve stays at the mean, between the
//!    sides) it is where the two sides' planes meet, nearest the mean
//!    ([`sides_meet`]), up to `1.5/tan(θ/2)` sides of the box past it for
//!    an opening angle `θ` (at most 8; [`blade_room`]), with `f` keeping
//!    the patch's sign on the way there as for a wedge's tip; at a cone's
//!    tip the error's matrix keeps every direction, and the point (where
//!    the tangent planes meet) may lie as far past the box as a blade's
//!    edge of the same opening, with `f` keeping the patch's sign on the
//!    way there;
//! 2. moved onto `f = 0` ([`crate::roots::project`], to bisection
//!    precision; where the gradient line finds no zero, along the
//!    bisector of the two normals that differ most, [`line_zero`]; where
//!    neither does, as at a cone's tip where `f` keeps its sign along
//!    both, the nearest sign change towards the patch or along an axis,
//!    in the reaches of `TOUCH`), it
//!    moves less than a tenth of the box's smallest side
//!    and stays in the box (up to rounding room, `SLIDE_INSET` of the
//!    side, past the room a wedge's tip has), and it is a kink of f, not a
//!    bend: a tenth of the way from it towards the two vertices whose
//!    normals differ most, the gradients still differ by half the gap
//!    between the normals' clusters (on a smooth patch they differ by
//!    about a tenth of the normals' whole spread); where the two sides'
//!    gradients differ in length by 2× or more, also when, a quarter of
//!    the way towards one of them and a tenth towards the other, they
//!    differ by 0.8 of the gap (`STEEPER`: the steeper side's values meet
//!    the other's off the point); or, where the point stands farther off
//!    the crease than those looks reach, when along the path from one of
//!    those vertices through the point to the other the gradient jumps
//!    from one side's to the other's within 1/256 of the path (`jumps`);
//!    where the fan below folds over a boundary edge with both ends on one
//!    side of the crease, the point first slides along the crease to
//!    where none does ([`fan_slide`]), if it stays on `f = 0` and in its
//!    room there;
//! 3. the fan — one triangle `(a, b, q)` per boundary edge `a → b` of the
//!    patch, so it keeps the patch's orientation — has no degenerate
//!    triangle and each triangle faces along the surface normals at `a`
//!    and `b` (along their mean where `a–b` crosses the crease), after the
//!    flips below; a candidate that fails is dropped and the others are
//!    checked again without it.
//!
//! Where the crease leaves Ω through the sheet (one boundary edge of the
//! patch lies on a face of Ω, its ends on either side of the crease), the
//! feature point is where the crease line meets that face, moved onto
//! `f = 0` within it, if that lies in the cell's box and between the
//! edge's ends; the edge gets no fan triangle (the point splits it), so the
//! crease ends on ∂Ω instead of a chamfer across the corner there.
//!
//! A cell whose normals pass the test but whose feature point falls
//! outside its box (the crease runs just past one of its faces) is merged
//! into the fan of the neighbouring feature point that shares exactly one
//! boundary edge with it, the nearest such: one fan over both patches'
//! boundaries (the shared edge gone). If the merged fan fails step 3, the
//! neighbour keeps its own fan.
//!
//! Then every edge `a–b` shared by the fans of two different feature
//! points `q₁`, `q₂` is flipped to `q₁–q₂` when that edge does not exist
//! yet and both new triangles face along the normals at `a` and `b`; and
//! an edge `a–b` across the crease between a fan triangle `(a, b, q)` and a
//! triangle `(b, a, c)` without feature point (a crease that leaves the
//! cell next door through its side) is flipped to `q–c` when that edge is
//! new, the new triangles face the right way and the larger first-order
//! distance `|f|/‖∇f‖` at the two centroids drops.
//!
//! Hence the vertex set only grows, by feature points on the surface; a
//! patch is replaced by a disk with the same boundary (but for an edge on
//! ∂Ω split where the crease leaves Ω) and orientation, and
//! a flip re-triangulates a quadrilateral: components, Euler
//! characteristic, genus, closedness and orientation are unchanged. The
//! returned flags mark the feature points, which smoothing keeps in place
//! and whose joining edges it never flips ([`super::smooth`]).
//!
//! # Limits
//!
//! Sheets with an MC33 tunnel are left as they are, and so are creases
//! that need more than one feature point in
//! a cell (two creases through one cell, or one whose patch's two sides
//! are offset along it so far that no point on it fans both: 2 of 1,100
//! cells on a blade of 20° at depth 8), and grazed cells with no
//! neighbouring feature point to merge into (a corner whose point lies
//! outside a small cell often is one). A fan is tested against its own
//! cell's surface normals and bounding box, not against other cells'
//! triangles (no stage tests for self-intersection); a wedge's tip past
//! the box is checked only along the segment from the patch's mean, by
//! `roots::SEGMENT_SAMPLES` − 1 samples of `f`'s sign, so a sheet thinner
//! than their spacing between the patch and the tip is not seen. The
//! normals at feature points are the gradient there (one side's, where f
//! has a kink; just off the point along the patch's normals where the
//! gradient vanishes, at a singular point), as for every vertex.

use glam::{DMat3, DVec3};
use rayon::prelude::*;
use rustc_hash::{FxHashMap as HashMap, FxHashSet as HashSet};

use crate::eval::Evaluator;
use crate::eval::sample::{grads_at, orient_at_kinks};
use crate::geometry::Bounds;
use crate::mesh::Mesh;
use crate::mesh::order::retain;
use crate::roots::{self, at, line_zero, project};

/// Normals of one cell marking a crease: they fall into two or three
/// clusters at least this many degrees apart ...
pub const SPLIT_DEG: f64 = 25.0;

/// ... and that far apart by at least this many times the largest angle
/// inside a cluster (a smooth patch, whose normals turn gradually, has no
/// such gap).
const GAP_RATIO: f64 = 3.0;

/// The kink test looks at the gradient this fraction of the way from the
/// feature point to two patch vertices ...
const NEAR: f64 = 0.1;

/// ... and, where the two sides' gradients differ in length by this
/// factor or more, once more with one of the two at [`FARTHER`] of the
/// way, the gradients then turning by [`FARTHER_SHARE`] of the gap. A
/// point projected onto one side stands a little off the crease, and
/// the sides' values meet farther along a chord the steeper the other
/// side: a point 0.006 cells off a gyroid's crease with a ball, whose
/// gradient is five times the ball's, has the gyroid's side only past 12 %
/// of the way to a vertex on it (the cell kept its chamfer: 597 such cells
/// on gyroid_ball at depth 8, `docs/faithful.md`). Where the lengths are
/// alike (exact ties of two primitives, smooth bends) the second look is
/// not taken: it would read a tight bend as a kink.
const STEEPER: f64 = 2.0;

/// See [`STEEPER`].
const FARTHER: f64 = 0.25;

/// See [`STEEPER`].
const FARTHER_SHARE: f64 = 0.8;

/// Rounding room for a feature point: one slid along its crease into its
/// cell's box stops this share of the crease's chord through the box short
/// of the face it entered by, and its projection onto `f = 0` may end this
/// share of the box's smallest side outside the box. On the face itself,
/// the projection (which moves it by rounding, a few millionths of the
/// side) left the box as often as not, and the cell lost its feature point
/// to a chamfer (66 cells, where 1,585 kept theirs, on a box and a sphere
/// in a smooth union drilled by a cylinder at level 8: `docs/faithful.md`).
const SLIDE_INSET: f64 = 0.01;

/// The reaches, in its box's smallest sides, within which a feature point
/// looks for a zero of `f` by sign changes alone, nearest first, where
/// its gradient lines find none (a cone's tip, where the gradient
/// vanishes).
const TOUCH: [f64; 4] = [1e-6, 1e-4, 1e-2, 0.1];

/// Eigenvalues of the error's matrix below this share of the largest are
/// truncated (directions along a crease, or the free directions of a flat
/// patch).
const TRUNCATE: f64 = 0.05;

/// What [`sharpen`] did.
#[derive(Clone, Debug, Default)]
pub struct Creases {
    /// Per vertex of the sharpened mesh: whether it is a feature point.
    pub feature: Vec<bool>,
    /// Cells whose patch became a fan around a feature point.
    pub cells: usize,
    /// Edges flipped: to join two feature points, and to settle fans next
    /// to cells without one.
    pub flips: usize,
}

/// A sharpening candidate: the cell's triangles, its patch boundary (the
/// cycle `a → b` in the patch's orientation), and the feature point on
/// the surface.
struct Candidate {
    /// The triangles replaced: the cell's, and those of a grazed
    /// neighbour merged into its fan.
    tris: Vec<Vec<usize>>,
    boundary: Vec<(u32, u32)>,
    point: DVec3,
    /// The cell's own boundary, when a grazed neighbour was merged in
    /// (restored if the merged fan fails its checks).
    unmerged: Option<Vec<(u32, u32)>>,
    /// The boundary edge on ∂Ω the point splits, where the crease leaves
    /// Ω ([`exit`]): it gets no fan triangle.
    exit: Option<(u32, u32)>,
    /// The point's normal where its sides' normals turn by more than
    /// [`BISECTED_DEG`]: their bisector.
    normal: Option<DVec3>,
}

impl Candidate {
    /// The boundary edges that get a fan triangle.
    fn fanned(&self) -> impl Iterator<Item = (u32, u32)> + '_ {
        self.boundary
            .iter()
            .copied()
            .filter(|&e| Some(e) != self.exit)
    }
}

/// A grazed cell: its triangles and its boundary cycle.
type Grazed = (Vec<usize>, Vec<(u32, u32)>);

/// What the test of one cell found.
enum Cell {
    /// A feature point can be placed.
    Feature(Candidate),
    /// A crease crosses the patch, but no feature point fits in the cell
    /// (it runs just outside the cell's box): the cell's triangles and
    /// boundary cycle, to be merged into a neighbour's fan.
    Grazed(Grazed),
}

/// Whether triangle `[a, b, c]` (positions `p`) is not degenerate and faces
/// along the surface normals at `a` and `b`: along each of them when they
/// lie on one side of a crease (within [`SPLIT_DEG`]), along their mean
/// when the side `a–b` crosses the crease.
fn faces(mesh: &Mesh, [a, b]: [u32; 2], p: [DVec3; 3]) -> bool {
    let (e1, e2) = (p[1] - p[0], p[2] - p[0]);
    let n = e1.cross(e2);
    let (na, nb) = (mesh.normals[a as usize], mesh.normals[b as usize]);
    let one_side = na.dot(nb) > SPLIT_DEG.to_radians().cos();
    n.length() > 1e-9 * e1.length() * e2.length()
        && if one_side {
            n.dot(na) > 0.0 && n.dot(nb) > 0.0
        } else {
            n.dot(na + nb) > 0.0
        }
}

/// Sharpens the creases of `mesh` (see the module doc), then drops MC33's
/// interior vertices of the patches that fans replaced
/// ([`Mesh::drop_unused`]). `cell_of[i]` is the dual cell of triangle `i`
/// (triangles of one cell consecutive), `bounds` a cell's bounding box (low
/// and high corners). `added(mesh, n0)` sees the sharpened mesh before the
/// drop, its feature points numbered from `n0` (a brick names them there);
/// the second result says which of that mesh's vertices remain, in order.
pub fn sharpen<E: Evaluator + ?Sized>(
    mesh: &mut Mesh,
    cell_of: &[u32],
    bounds: &(dyn Fn(u32) -> [DVec3; 2] + Sync),
    domain: &Bounds,
    f: &E,
    t: f64,
    added: impl FnOnce(&Mesh, usize),
) -> (Creases, Vec<bool>) {
    let n0 = mesh.positions.len();
    let mut creases = fan_patches(mesh, cell_of, bounds, domain, f, t);
    added(mesh, n0);
    let used = mesh.drop_unused();
    retain(&mut creases.feature, &used);
    (creases, used)
}

/// [`sharpen`] before the drop: the vertices keep their indices and the
/// feature points follow them; the interior vertices of the patches
/// replaced by fans are left without triangles.
fn fan_patches<E: Evaluator + ?Sized>(
    mesh: &mut Mesh,
    cell_of: &[u32],
    bounds: &(dyn Fn(u32) -> [DVec3; 2] + Sync),
    domain: &Bounds,
    f: &E,
    t: f64,
) -> Creases {
    let n0 = mesh.positions.len();
    let mut out = Creases {
        feature: vec![false; n0],
        ..Creases::default()
    };
    if cell_of.len() != mesh.triangles.len() {
        return out;
    }
    // Runs of triangles of one cell.
    let mut runs = Vec::new();
    let mut start = 0;
    for i in 1..=cell_of.len() {
        if i == cell_of.len() || cell_of[i] != cell_of[start] {
            runs.push(start..i);
            start = i;
        }
    }
    // Each sheet of a cell's patch on its own: where sheets cross or
    // touch (`x y = 0` along its axis), each one's crease point.
    let m: &Mesh = mesh;
    let cells: Vec<Cell> = runs
        .into_par_iter()
        .flat_map_iter(|tris| {
            let cell = cell_of[tris.start];
            sheets(&m.triangles, tris)
                .into_iter()
                .filter_map(move |sheet| candidate(m, sheet, &|| bounds(cell), domain, f, t))
        })
        .collect();
    let (mut candidates, grazed): (Vec<Candidate>, Vec<Grazed>) = {
        let (mut c, mut g) = (Vec::new(), Vec::new());
        for cell in cells {
            match cell {
                Cell::Feature(x) => c.push(x),
                Cell::Grazed(x) => g.push(x),
            }
        }
        (c, g)
    };
    merge_grazed(mesh, &mut candidates, grazed);
    // Keep the candidates whose final triangles all face the right way,
    // dropping failures until none is left: a fan edge shared with a
    // neighbouring fan is flipped to join the two feature points when the
    // two new triangles face the right way, and is kept otherwise.
    let mut alive = vec![true; candidates.len()];
    let pos = |v: u32| mesh.positions[v as usize];
    let flip_ok = |a: u32, b: u32, q1: DVec3, q2: DVec3| {
        faces(mesh, [a, a], [pos(a), q2, q1]) && faces(mesh, [b, b], [pos(b), q1, q2])
    };
    let mut owner: HashMap<(u32, u32), usize> = HashMap::default();
    for (k, c) in candidates.iter().enumerate() {
        for &e in &c.boundary {
            owner.insert(e, k);
        }
    }
    loop {
        let failing: Vec<usize> = (0..candidates.len())
            .into_par_iter()
            .filter(|&k| alive[k])
            .filter(|&k| {
                let c = &candidates[k];
                !c.fanned().all(|(a, b)| {
                    let alone = faces(mesh, [a, b], [pos(a), pos(b), c.point]);
                    match owner.get(&(b, a)) {
                        Some(&d) if d != k && alive[d] => {
                            let q2 = candidates[d].point;
                            flip_ok(a, b, c.point, q2)
                                || (alone && faces(mesh, [b, a], [pos(b), pos(a), q2]))
                        }
                        _ => alone,
                    }
                })
            })
            .collect();
        if failing.is_empty() {
            break;
        }
        for k in failing {
            // A merged fan that fails falls back to the cell's own.
            match candidates[k].unmerged.take() {
                Some(own) => {
                    for e in &candidates[k].boundary {
                        owner.remove(e);
                    }
                    for &e in &own {
                        owner.insert(e, k);
                    }
                    candidates[k].boundary = own;
                    candidates[k].tris.truncate(1);
                }
                None => alive[k] = false,
            }
        }
    }
    let mut k = 0;
    candidates.retain(|_| {
        k += 1;
        alive[k - 1]
    });
    if candidates.is_empty() {
        return out;
    }

    // The new vertices and the fans in place of their patches.
    let mut replaced = vec![false; mesh.triangles.len()];
    let mut fans: Vec<[u32; 3]> = Vec::new();
    for c in &candidates {
        let q = mesh.positions.len() as u32;
        let ambiguous = c.boundary.iter().any(|&(a, _)| mesh.ambiguous[a as usize]);
        mesh.positions.push(c.point);
        mesh.ambiguous.push(ambiguous);
        mesh.normals.push(DVec3::ZERO);
        out.feature.push(true);
        for &r in c.tris.iter().flatten() {
            replaced[r] = true;
        }
        fans.extend(c.fanned().map(|(a, b)| [a, b, q]));
    }
    out.cells = candidates.len();
    let new_points: Vec<DVec3> = mesh.positions[n0..].to_vec();
    for (k, (_, g)) in grads_at(f, t, &new_points).into_iter().enumerate() {
        mesh.normals[n0 + k] = g.normalize_or_zero();
    }
    // Outward at a feature point: along its patch's vertex normals (a
    // tie of two sides there may give a gradient pointing inward).
    let outward: Vec<DVec3> = candidates
        .iter()
        .map(|c| {
            c.boundary
                .iter()
                .map(|&(a, _)| mesh.normals[a as usize])
                .sum()
        })
        .collect();
    orient_at_kinks(f, t, &new_points, &mut mesh.normals[n0..], &outward);
    for (k, c) in candidates.iter().enumerate() {
        if let Some(n) = c.normal {
            mesh.normals[n0 + k] = n;
        }
    }
    let mut tris: Vec<[u32; 3]> = mesh
        .triangles
        .iter()
        .zip(&replaced)
        .filter(|(_, r)| !**r)
        .map(|(t, _)| *t)
        .collect();
    let first_fan = tris.len();
    tris.extend(fans);
    mesh.triangles = tris;
    out.flips = join_features(mesh, first_fan);
    out.flips += settle(mesh, &out.feature, first_fan, f, t);
    out
}

/// `|f| / ‖∇f‖` (a first-order distance to the surface) at each point;
/// `+∞` where it is not a number.
fn distances<E: Evaluator + ?Sized>(f: &E, t: f64, points: &[DVec3]) -> Vec<f64> {
    grads_at(f, t, points)
        .into_iter()
        .map(|(v, g)| {
            let d = v.abs() / g.length();
            if d.is_nan() { f64::INFINITY } else { d }
        })
        .collect()
}

/// Flips of the edges `a–b` opposite a feature point `q` in a
/// triangle `(a, b, q)` whose other triangle `(b, a, c)` does not hold a
/// feature point, where `a–b` crosses the crease (the normals at `a` and
/// `b` differ by more than [`SPLIT_DEG`]; a crease leaving through a cell
/// that has no feature point): to `q–c` when that edge does not exist, both new
/// triangles face along the normals at their non-feature corners, and the
/// larger first-order distance to the surface at the two centroids drops.
/// Returns the flips made.
fn settle<E: Evaluator + ?Sized>(
    mesh: &mut Mesh,
    feature: &[bool],
    first_fan: usize,
    f: &E,
    t: f64,
) -> usize {
    let is_feature = |v: u32| feature.get(v as usize).copied().unwrap_or(false);
    let cos_split = SPLIT_DEG.to_radians().cos();
    // The fan triangles (from `first_fan` on: every triangle holding a
    // feature point) with a side across the crease, and the triangles on
    // the other side of those sides, found in one pass over the mesh.
    let key = |a: u32, b: u32| ((a as u64) << 32) | b as u64;
    // (key of `b → a`, triangle `(a, b, q)`, [a, b, q]).
    let mut wanted: Vec<(u64, usize, [u32; 3])> = Vec::new();
    for i in first_fan..mesh.triangles.len() {
        let tri = mesh.triangles[i];
        let Some(k) = (0..3).find(|&k| is_feature(tri[(k + 2) % 3])) else {
            continue;
        };
        let (a, b, q) = (tri[k], tri[(k + 1) % 3], tri[(k + 2) % 3]);
        if !(is_feature(a)
            || is_feature(b)
            || mesh.normals[a as usize].dot(mesh.normals[b as usize]) >= cos_split)
        {
            wanted.push((key(b, a), i, [a, b, q]));
        }
    }
    if wanted.is_empty() {
        return 0;
    }
    wanted.sort_unstable();
    let mut across: Vec<Option<usize>> = vec![None; wanted.len()];
    for (j, tri) in mesh.triangles.iter().enumerate() {
        for k in 0..3 {
            let e = key(tri[k], tri[(k + 1) % 3]);
            let at = wanted.partition_point(|w| w.0 < e);
            if wanted.get(at).is_some_and(|w| w.0 == e) {
                across[at] = Some(j);
            }
        }
    }
    // Edges at feature points (all in fan triangles).
    let mut at_feature: HashSet<(u32, u32)> = HashSet::default();
    for tri in &mesh.triangles[first_fan..] {
        for k in 0..3 {
            let (u, v) = (tri[k], tri[(k + 1) % 3]);
            at_feature.insert((u.min(v), u.max(v)));
        }
    }
    // Candidate flips: (t1, t2, [a, b, q, c]).
    let mut cands: Vec<(usize, usize, [u32; 4])> = Vec::new();
    for (&(_, i, [a, b, q]), &j) in wanted.iter().zip(&across) {
        let Some(j) = j else {
            continue;
        };
        let other = mesh.triangles[j];
        let Some(c) = other.iter().copied().find(|&v| v != a && v != b) else {
            continue;
        };
        if is_feature(c) || c == q || at_feature.contains(&(q.min(c), q.max(c))) {
            continue;
        }
        let pos = |v: u32| mesh.positions[v as usize];
        let ok = faces(mesh, [a, c], [pos(a), pos(c), pos(q)])
            && faces(mesh, [c, b], [pos(c), pos(b), pos(q)]);
        if ok {
            cands.push((i, j, [a, b, q, c]));
        }
    }
    if cands.is_empty() {
        return 0;
    }
    let centroid = |t: [u32; 3]| t.iter().map(|&v| mesh.positions[v as usize]).sum::<DVec3>() / 3.0;
    let points: Vec<DVec3> = cands
        .iter()
        .flat_map(|&(i, j, [a, b, q, c])| {
            [
                centroid(mesh.triangles[i]),
                centroid(mesh.triangles[j]),
                centroid([a, c, q]),
                centroid([c, b, q]),
            ]
        })
        .collect();
    let d = distances(f, t, &points);
    let mut gain: Vec<(f64, usize)> = (0..cands.len())
        .filter_map(|k| {
            let old = d[4 * k].max(d[4 * k + 1]);
            let new = d[4 * k + 2].max(d[4 * k + 3]);
            (new < old).then_some((old - new, k))
        })
        .collect();
    gain.sort_by(|x, y| y.0.total_cmp(&x.0));
    let mut touched = vec![false; mesh.triangles.len()];
    let mut made: HashSet<(u32, u32)> = HashSet::default();
    let mut flips = 0;
    for (_, k) in gain {
        let (i, j, [a, b, q, c]) = cands[k];
        if touched[i] || touched[j] || !made.insert((q.min(c), q.max(c))) {
            continue;
        }
        // Old: (a, b, q) and (b, a, c); new: (a, c, q) and (c, b, q).
        mesh.triangles[i] = [a, c, q];
        mesh.triangles[j] = [c, b, q];
        touched[i] = true;
        touched[j] = true;
        flips += 1;
    }
    flips
}

/// The gap between the clusters when unit normals fall into two or three
/// clusters more than [`SPLIT_DEG`] apart, that gap [`GAP_RATIO`] times
/// the largest angle inside a cluster; and the two normals farthest apart.
fn crease_gap(normals: &[DVec3]) -> Option<(f64, [usize; 2])> {
    // Compared as dot products (cosines) until the end.
    let far = farthest(normals);
    let split = SPLIT_DEG.to_radians();
    let cos_split = split.cos();
    if far.2 > cos_split {
        return None;
    }
    let mut seeds = vec![normals[far.0], normals[far.1]];
    for n in normals {
        if seeds.len() < 3 && seeds.iter().all(|s| s.dot(*n) < cos_split) {
            seeds.push(*n);
        }
    }
    let cluster: Vec<usize> = normals
        .iter()
        .map(|n| {
            (0..seeds.len())
                .max_by(|&i, &j| seeds[i].dot(*n).total_cmp(&seeds[j].dot(*n)))
                .unwrap_or(0)
        })
        .collect();
    let (mut inside, mut across) = (1.0_f64, -1.0_f64);
    for (i, a) in normals.iter().enumerate() {
        for (j, b) in normals.iter().enumerate().skip(i + 1) {
            let d = a.dot(*b);
            if cluster[i] == cluster[j] {
                inside = inside.min(d);
            } else {
                across = across.max(d);
            }
        }
    }
    let angle = |c: f64| c.clamp(-1.0, 1.0).acos();
    let (inside, across) = (angle(inside), angle(across));
    (across > split && across > GAP_RATIO * inside).then_some((across, [far.0, far.1]))
}

/// The two unit normals farthest apart: their indices and the cosine of
/// the angle between them.
fn farthest(normals: &[DVec3]) -> (usize, usize, f64) {
    let mut far = (0, 0, 2.0);
    for (i, a) in normals.iter().enumerate() {
        for (j, b) in normals.iter().enumerate().skip(i + 1) {
            let d = a.dot(*b);
            if d < far.2 {
                far = (i, j, d);
            }
        }
    }
    far
}

/// The spread of normals that fall into no two or three clusters (see
/// [`crease_gap`]) but turn by more than [`SPLIT_DEG`]: the angle between
/// the two farthest apart, and those two. Around the tip of a cone (the
/// double cone's apex, Ding-Dong's singular point, a pyramid's apex where
/// four or more planes meet) they form a ring, or more than three
/// clusters, and every tangent plane passes through the tip.
fn spread(normals: &[DVec3]) -> Option<(f64, [usize; 2])> {
    let (i, j, d) = farthest(normals);
    let angle = d.clamp(-1.0, 1.0).acos();
    (angle > SPLIT_DEG.to_radians()).then_some((angle, [i, j]))
}

/// The triangles `tris` of one cell grouped into sheets: the components of
/// the patch, joined through shared vertices (a dual cell's sheets share
/// none: each of its edges holds one vertex per sheet).
fn sheets(triangles: &[[u32; 3]], tris: std::ops::Range<usize>) -> Vec<Vec<usize>> {
    let mut sheets: Vec<(Vec<usize>, Vec<u32>)> = Vec::new();
    for i in tris {
        let t = triangles[i];
        let mut joined = (vec![i], t.to_vec());
        sheets.retain_mut(|(ts, vs)| {
            let touches = vs.iter().any(|v| t.contains(v));
            if touches {
                joined.0.append(ts);
                joined.1.append(vs);
            }
            !touches
        });
        sheets.push(joined);
    }
    sheets
        .into_iter()
        .map(|(mut ts, _)| {
            ts.sort_unstable();
            ts
        })
        .collect()
}

/// A patch's boundary: directed edges `a → b`, each one's `b` the next
/// one's `a`.
type Cycle = Vec<(u32, u32)>;

/// The boundary of `patch` (triangles over `vertices` distinct vertices)
/// when it is one disk: its boundary edges (directed, not matched by their
/// reverse) form one simple cycle, and V − E + F = 1. Returns the cycle,
/// in the patch's orientation, and its vertices, sorted. Vertices off the
/// cycle are MC33's interior vertices, which only this patch uses; a fan
/// over the cycle drops them.
fn disk(patch: &[[u32; 3]], vertices: usize) -> Option<(Cycle, Vec<u32>)> {
    let directed: Vec<(u32, u32)> = patch
        .iter()
        .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
        .collect();
    let boundary: Vec<(u32, u32)> = directed
        .iter()
        .copied()
        .filter(|&(a, b)| !directed.contains(&(b, a)))
        .collect();
    let edges = (3 * patch.len() + boundary.len()) / 2;
    if boundary.is_empty()
        || !(3 * patch.len() + boundary.len()).is_multiple_of(2)
        || vertices + patch.len() != edges + 1
    {
        return None;
    }
    let mut cycle = Vec::with_capacity(boundary.len());
    let mut at = boundary[0].0;
    for _ in 0..boundary.len() {
        let next = boundary.iter().find(|e| e.0 == at)?;
        cycle.push(*next);
        at = next.1;
    }
    let mut verts: Vec<u32> = cycle.iter().map(|e| e.0).collect();
    verts.sort_unstable();
    verts.dedup();
    (at == boundary[0].0 && verts.len() == cycle.len()).then_some((cycle, verts))
}

/// The sharpening candidate of one sheet of a cell's triangles, or `None` (steps 1
/// and 2 of the module doc).
fn candidate<E: Evaluator + ?Sized>(
    mesh: &Mesh,
    tris: Vec<usize>,
    bounds: &dyn Fn() -> [DVec3; 2],
    domain: &Bounds,
    f: &E,
    t: f64,
) -> Option<Cell> {
    let patch: Vec<[u32; 3]> = tris.iter().map(|&i| mesh.triangles[i]).collect();
    // Most cells are smooth: their normals all lie within half the split
    // angle of the first one (so within the split angle of each other).
    let n0 = mesh.normals[patch[0][0] as usize];
    let cos_half = (0.5 * SPLIT_DEG).to_radians().cos();
    if patch
        .iter()
        .flatten()
        .all(|&v| mesh.normals[v as usize].dot(n0) >= cos_half)
    {
        return None;
    }
    // Normals that turn by no more than the split angle hold neither a
    // crease nor a cone's tip (a cheap test before the disk's).
    let mut all: Vec<u32> = patch.iter().flatten().copied().collect();
    all.sort_unstable();
    all.dedup();
    let turn: Vec<DVec3> = all.iter().map(|&v| mesh.normals[v as usize]).collect();
    spread(&turn)?;
    let (cycle, verts) = disk(&patch, all.len())?;
    // A crease: the cell-edge vertices' normals fall into clusters.
    let normals: Vec<DVec3> = verts.iter().map(|&v| mesh.normals[v as usize]).collect();
    if normals
        .iter()
        .any(|n| !n.is_finite() || (n.length_squared() - 1.0).abs() > 1e-6)
    {
        return None;
    }
    let clusters = crease_gap(&normals);
    // No clusters: perhaps the tip of a cone (an apex).
    let apex = clusters.is_none();
    let (gap, far) = clusters.or_else(|| spread(&normals))?;
    // The feature point: the tangent planes' least-squares intersection.
    let [lo, hi] = bounds();
    let grazed = || Some(Cell::Grazed((tris.clone(), cycle.clone())));
    let pos: Vec<DVec3> = verts.iter().map(|&v| mesh.positions[v as usize]).collect();
    let mean = pos.iter().copied().sum::<DVec3>() / pos.len() as f64;
    let mut a = DMat3::ZERO;
    let mut r = DVec3::ZERO;
    for (n, p) in normals.iter().zip(&pos) {
        a += DMat3::from_cols(*n * n.x, *n * n.y, *n * n.z);
        r += *n * n.dot(*p - mean);
    }
    let (x, free) = truncated_solve(a, r);
    let mut p = mean + x;
    let side = (hi - lo).min_element();
    let feature = |q: DVec3, exit: Option<(u32, u32)>| {
        kinks(f, t, q, [pos[far[0]], pos[far[1]]], gap).then_some(Cell::Feature(Candidate {
            tris: vec![tris.clone()],
            boundary: cycle.clone(),
            point: q,
            unmerged: None,
            exit,
            normal: bisected([normals[far[0]], normals[far[1]]]),
        }))
    };
    if let ([dir], true) = (free.as_slice(), p.is_finite())
        && let Some((edge, q)) = exit(mesh, &cycle, (p, *dir), ([lo, hi], domain), f, t)
    {
        return feature(q, Some(edge));
    }
    // In the box grown by `room` on every side.
    let within = |x: DVec3, room: f64| {
        x.cmpge(lo - DVec3::splat(room)).all() && x.cmple(hi + DVec3::splat(room)).all()
    };
    let sides = [normals[far[0]], normals[far[1]]];
    // The crease's direction: the error's free one, or a blade's edge.
    let mut along = (free.len() == 1).then(|| free[0]);
    // Along a crease (one free direction) the point may slide along it
    // into the box; the tip of a wedge may lie past it.
    let mut room = 0.0;
    if apex {
        // The tangent planes meet at one point, the tip, which the dual
        // grid's samples miss by up to where the cone is as thick as
        // their spacing, as along a blade's edge.
        room = blade_room(gap) * side;
        let tip = [pos[far[0]], pos[far[1]]];
        if !free.is_empty()
            || !p.is_finite()
            || !within(p, room)
            || !kinks(f, t, p, tip, gap)
            || !keeps_sign(f, t, mean, p)
        {
            return None;
        }
    }
    if free.len() == 2 && p.is_finite() && sides[0].dot(sides[1]) < 0.0 {
        // A blade: its sides' planes are too near parallel for the error's
        // matrix, which keeps the point at the mean, between them.
        let tip = sides_meet(&pos, &normals, far, mean)?;
        room = blade_room(gap) * side;
        if !within(tip, room) || !wedge_tip(f, t, mean, tip, sides) {
            return None;
        }
        p = tip;
        along = Some(sides[0].cross(sides[1]).normalize_or_zero());
    }
    if free.len() == 1 && p.is_finite() && !within(p, 0.0) {
        match slide_into(p, free[0], lo, hi) {
            Some(x) => p = x,
            None if wedge_tip(f, t, mean, p, sides) => {
                room = WEDGE_ROOM * side;
            }
            None => return grazed(),
        }
    }
    if !p.is_finite() || !within(p, room) {
        return grazed();
    }
    // Along the gradient line of one side of a crease, the other side's
    // value changes at the cosine of the angle between their normals:
    // hardly at all near a right angle, the wrong way past it. From a
    // point off both sides (a lens's rim: 87°), the bisector of the
    // normals reaches the surface where that line does not.
    let bisector = (sides[0] + sides[1]).normalize_or_zero();
    // Near a cone's tip the gradient vanishes and `f` keeps its sign along
    // both lines; the nearest zero found towards the patch or along an
    // axis, in reaches growing by [`TOUCH`] up to a tenth of the side, is
    // on the cone within that reach of the tip.
    let touching = |x: DVec3| {
        TOUCH.iter().find_map(|reach| {
            [mean - x, DVec3::X, DVec3::Y, DVec3::Z]
                .into_iter()
                .find_map(|d| line_zero(f, t, x, d, reach * side))
        })
    };
    let onto = |x: DVec3| {
        project(f, t, x, 0.1 * side)
            .or_else(|| line_zero(f, t, x, bisector, 0.1 * side))
            .or_else(|| touching(x))
    };
    let q = onto(p)?;
    // In the box and its room, and in Ω, where `f` is the surface's.
    let fits = |q: &DVec3| within(*q, room + SLIDE_INSET * side) && domain.contains(q.to_array());
    if !fits(&q) || q.distance(p) > 0.1 * side {
        return None;
    }
    // Slid along its crease to where its fan faces the right way, if it
    // does not there (and the slid point, back on `f = 0`, still fits).
    let slid = along
        .and_then(|d| {
            fan_slide(mesh, &cycle, q, d)
                .filter(|&s| s != 0.0)
                .map(|s| q + d * s)
        })
        .and_then(onto)
        .filter(fits);
    feature(slid.unwrap_or(q), None)
}

/// Past this turn between a crease's two sides, its feature point's
/// normal is their bisector ([`bisected`]).
const BISECTED_DEG: f64 = 120.0;

/// The bisector of a crease's sides' normals `sides` where they turn by
/// more than [`BISECTED_DEG`]. The gradient at the point is one side's,
/// and there more than 120° off the other side's triangles of its fan: on
/// colonnade.vm (sides 162° apart, about x = 0.78) at level 6, 11 feature points'
/// normals faced against their fans' (area-weighted) normals.
fn bisected(sides: [DVec3; 2]) -> Option<DVec3> {
    let turn = sides[0].dot(sides[1]).clamp(-1.0, 1.0).acos();
    let n = (sides[0] + sides[1]).normalize_or_zero();
    (turn > BISECTED_DEG.to_radians() && n != DVec3::ZERO).then_some(n)
}

/// How far past its cell's box a blade's tip may lie, in sides of the
/// box's smallest side, where its sides' normals turn by `gap`: the patch
/// across a blade of opening angle `θ = π − gap` stands where the blade is
/// as thick as the dual grid's spacing (up to two cells), `1/tan(θ/2)`
/// such spacings from the tip; [`BLADE_REACH`] of that, at most
/// [`BLADE_FAR`].
fn blade_room(gap: f64) -> f64 {
    let half = 0.5 * (std::f64::consts::PI - gap);
    (BLADE_REACH / half.tan()).min(BLADE_FAR)
}

/// See [`blade_room`]. On a blade of 20° whose edge is skew to the grid
/// (`benches/peers/surfaces/blade20.iso`, depth 7), 1, 1.5 and 2 gave the
/// same mesh, with no blade point out of reach; a flat room of one side
/// (the wedge's, [`WEDGE_ROOM`]) left 48 cells' points out of it.
const BLADE_REACH: f64 = 1.5;

/// See [`blade_room`].
const BLADE_FAR: f64 = 8.0;

/// Where the planes of a patch's two sides meet, nearest `mean`: each
/// side's plane through the mean position of its vertices (those whose
/// normals lie nearer `normals[far[k]]` than the other), along their mean
/// normal. On a blade sharper than about 25° the error's matrix has one
/// eigenvalue above [`TRUNCATE`] of the largest, so [`truncated_solve`]
/// leaves the point at the mean; two planes still meet where the blade's
/// edge is (exactly, on a flat-sided blade). `None` where the planes are
/// parallel.
fn sides_meet(pos: &[DVec3], normals: &[DVec3], far: [usize; 2], mean: DVec3) -> Option<DVec3> {
    let mut planes = [(DVec3::ZERO, DVec3::ZERO, 0.0); 2];
    for (p, n) in pos.iter().zip(normals) {
        let k = usize::from(n.dot(normals[far[1]]) > n.dot(normals[far[0]]));
        planes[k].0 += *p;
        planes[k].1 += *n;
        planes[k].2 += 1.0;
    }
    let [(c1, n1, k1), (c2, n2, k2)] = planes;
    let (n1, n2) = (n1.normalize_or_zero(), n2.normalize_or_zero());
    let (r1, r2) = (n1.dot(c1 / k1 - mean), n2.dot(c2 / k2 - mean));
    // mean + a n1 + b n2 on both planes: a + d b = r1, d a + b = r2.
    let d = n1.dot(n2);
    let det = 1.0 - d * d;
    if det.is_nan() || det <= 1e-6 {
        return None;
    }
    let x = mean + n1 * ((r1 - d * r2) / det) + n2 * ((r2 - d * r1) / det);
    x.is_finite().then_some(x)
}

/// The shift `s` along the unit crease direction `d` after which every
/// fan triangle `(a, b, q + s d)` over a boundary edge `a → b` of `cycle`
/// whose ends lie on one side of the crease (within [`SPLIT_DEG`]) faces
/// along both ends' normals (each such condition is linear in `s`): 0
/// where `q` passes already, else the end of the feasible interval nearest
/// 0, moved a tenth of the interval into it (one hundredth of the longest
/// edge where the interval is unbounded); `None` where no shift passes.
/// On a crease that crosses the cell's patch askew, the point nearest the
/// patch's mean can lie past a radial boundary edge, and its fan fold over
/// it (a fan that fails [`faces`], and the cell keeps its chamfer).
fn fan_slide(mesh: &Mesh, cycle: &[(u32, u32)], q: DVec3, d: DVec3) -> Option<f64> {
    let cos_split = SPLIT_DEG.to_radians().cos();
    let (mut lo, mut hi) = (f64::NEG_INFINITY, f64::INFINITY);
    let mut longest = 0.0_f64;
    for &(a, b) in cycle {
        let (na, nb) = (mesh.normals[a as usize], mesh.normals[b as usize]);
        let (pa, pb) = (mesh.positions[a as usize], mesh.positions[b as usize]);
        let e = pb - pa;
        longest = longest.max(e.length());
        if na.dot(nb) <= cos_split {
            continue;
        }
        for n in [na, nb] {
            // (e × (q + s d − a))·n = c + g s > 0.
            let (c, g) = (e.cross(q - pa).dot(n), e.cross(d).dot(n));
            if g > 0.0 {
                lo = lo.max(-c / g);
            } else if g < 0.0 {
                hi = hi.min(-c / g);
            } else if c <= 0.0 {
                return None;
            }
        }
    }
    if lo.is_nan() || hi.is_nan() || lo >= hi {
        return None;
    }
    if lo < 0.0 && 0.0 < hi {
        return Some(0.0);
    }
    let margin = if hi - lo < f64::INFINITY {
        0.1 * (hi - lo)
    } else {
        0.01 * longest
    };
    let s = if lo >= 0.0 { lo + margin } else { hi - margin };
    s.is_finite().then_some(s)
}

/// How far past its cell's box the tip of a wedge may lie, in sides of the
/// box's smallest side (see [`wedge_tip`]).
const WEDGE_ROOM: f64 = 1.0;

/// Whether the crease point `p`, off its cell's box, is the tip of a wedge
/// that the patch cuts off: the normals `far` on its two sides turn by
/// more than a right angle (a wedge sharper than one, whose tip the dual
/// grid's samples miss: the patch across it lies up to a cell short of
/// the crease), and `f` keeps the sign it has at the patch's `mean` on the
/// way from there to `p` (no other sheet lies between the patch and the
/// tip).
fn wedge_tip<E: Evaluator + ?Sized>(f: &E, t: f64, mean: DVec3, p: DVec3, far: [DVec3; 2]) -> bool {
    far[0].dot(far[1]) < 0.0 && keeps_sign(f, t, mean, p)
}

/// Whether `f` keeps, on the way from a patch's `mean` to a point `p`
/// past it (a wedge's or a cone's tip), the non-zero sign it has at the
/// mean ([`roots::keeps_sign`]): no other sheet lies between them.
fn keeps_sign<E: Evaluator + ?Sized>(f: &E, t: f64, mean: DVec3, p: DVec3) -> bool {
    let inside = f.point(at(mean, t));
    inside != 0.0 && !inside.is_nan() && roots::keeps_sign(f, t, [mean, p], inside < 0.0)
}

/// A kink, not a bend, at the feature point `q`: near it, towards the two
/// patch vertices `towards` whose normals differ most, the gradient still
/// turns by at least half the normals' `gap` ([`NEAR`]; on a smooth surface
/// it turns by about that fraction of the patch's whole turn), or, where
/// the two sides' gradients differ in length, by most of it a little
/// farther towards one of them ([`STEEPER`]); or where the gradient jumps
/// between the sides along the path through `q` ([`jumps`]).
fn kinks<E: Evaluator + ?Sized>(f: &E, t: f64, q: DVec3, towards: [DVec3; 2], gap: f64) -> bool {
    let grad = |x: DVec3| DVec3::from_array(f.point_grad(at(x, t)).1);
    let unit_grad = |v: DVec3, near: f64| grad(q + (v - q) * near).normalize_or_zero();
    let turns = |[ni, nj]: [f64; 2], share: f64| {
        let (gi, gj) = (unit_grad(towards[0], ni), unit_grad(towards[1], nj));
        gi.length_squared() >= 0.5
            && gj.length_squared() >= 0.5
            && gi.dot(gj).clamp(-1.0, 1.0).acos() >= share * gap
    };
    if turns([NEAR, NEAR], 0.5) {
        return true;
    }
    // Sides whose gradients differ in length meet off the point.
    let ends = towards.map(grad);
    let [li, lj] = ends.map(DVec3::length);
    let steeper = li.max(lj) / li.min(lj);
    (steeper >= STEEPER
        && (turns([FARTHER, NEAR], FARTHER_SHARE) || turns([NEAR, FARTHER], FARTHER_SHARE)))
        || jumps(f, t, [towards[0], q, towards[1]], ends, gap)
}

/// Halvings of [`jumps`]' search: from a path about a cell long, the last
/// piece is about 1/256 of a cell.
const JUMP_HALVINGS: usize = 8;

/// Whether the gradient jumps between a crease's two sides along the path
/// `a → q → b` from one to the other of the two patch vertices whose
/// normals differ most, through the feature point `q`. The half of the
/// path, then of each piece, over which the unit gradient turns the more
/// is kept: a kink keeps its whole jump in the piece, a bend of radius `ρ`
/// turns by `ℓ/ρ` over a piece of length `ℓ`. It jumps where the last
/// piece still turns by half the normals' `gap`, and each of its ends by
/// at most a quarter of it from the path's end on its side (not a jump to
/// a side's reverse, as across the middle of a thin wall). `ends` are the
/// gradients at `a` and `b`, which [`kinks`] has read already.
///
/// [`kinks`]' looks a fixed share of the way towards `a` and `b` miss a
/// kink that `q` stands off by more than that share: the least-squares
/// point of a curved side's tangent planes, projected onto `f = 0`, stood
/// a tenth of a cell off a cylinder's rim (0.08–0.13 cells at depth 8),
/// and the cell kept its chamfer (`docs/faithful.md`, session 56).
fn jumps<E: Evaluator + ?Sized>(
    f: &E,
    t: f64,
    [a, q, b]: [DVec3; 3],
    ends: [DVec3; 2],
    gap: f64,
) -> bool {
    let unit = |x: DVec3| {
        let g = DVec3::from_array(f.point_grad(at(x, t)).1);
        (x, g.normalize_or_zero())
    };
    // The turn between two unit gradients; −1 where either is missing.
    let turn = |g: DVec3, h: DVec3| {
        if g == DVec3::ZERO || h == DVec3::ZERO {
            -1.0
        } else {
            g.dot(h).clamp(-1.0, 1.0).acos()
        }
    };
    let (ea, eq, eb) = (
        (a, ends[0].normalize_or_zero()),
        unit(q),
        (b, ends[1].normalize_or_zero()),
    );
    let (mut lo, mut hi) = if turn(ea.1, eq.1) >= turn(eq.1, eb.1) {
        (ea, eq)
    } else {
        (eq, eb)
    };
    for _ in 0..JUMP_HALVINGS {
        let m = unit(lo.0.midpoint(hi.0));
        if turn(lo.1, m.1) >= turn(m.1, hi.1) {
            hi = m;
        } else {
            lo = m;
        }
    }
    let side = |g: DVec3, end: DVec3| (0.0..=0.25 * gap).contains(&turn(g, end));
    side(lo.1, ea.1) && side(hi.1, eb.1) && turn(lo.1, hi.1) >= 0.5 * gap
}

/// Where the crease line `(p, dir)` (a point and its direction) leaves Ω
/// through the patch `cycle`: the one cycle edge `a → b` on a face of Ω
/// (`(cell, domain)`: the cell's box and Ω) whose ends' normals lie on
/// either side of the crease, and the point where the line meets that
/// face, moved onto `f = 0` within the face, if it lies in the cell's box
/// and between `a` and `b`. The crease then ends on ∂Ω (without it, the
/// fan would end a cell short of it, and a chamfer would join `a` and
/// `b`); `None` where no edge, or more than one, is such an edge, or the
/// crease runs along the face.
fn exit<E: Evaluator + ?Sized>(
    mesh: &Mesh,
    cycle: &[(u32, u32)],
    (p, dir): (DVec3, DVec3),
    ([lo, hi], domain): ([DVec3; 2], &Bounds),
    f: &E,
    t: f64,
) -> Option<((u32, u32), DVec3)> {
    let pos = |v: u32| mesh.positions[v as usize];
    let cos_split = SPLIT_DEG.to_radians().cos();
    // The first face of Ω both ends lie on: its axis and coordinate.
    let face = |a: DVec3, b: DVec3| {
        let shared = domain.faces(a.to_array()) & domain.faces(b.to_array());
        let bit = shared.trailing_zeros() as usize;
        let k = bit / 2;
        (shared != 0).then(|| (k, [domain.lo, domain.hi][bit % 2][k]))
    };
    let mut across = cycle.iter().filter_map(|&(a, b)| {
        let split = mesh.normals[a as usize].dot(mesh.normals[b as usize]) < cos_split;
        face(pos(a), pos(b))
            .filter(|_| split)
            .map(|kw| ((a, b), kw))
    });
    let (((a, b), (k, w)), None) = (across.next()?, across.next()) else {
        return None;
    };
    if dir[k].abs() < 0.1 {
        return None;
    }
    let mut e = p + dir * ((w - p[k]) / dir[k]);
    e[k] = w;
    let side = (hi - lo).min_element();
    let (v, g) = f.point_grad([e.x, e.y, e.z, t]);
    let q = if v == 0.0 {
        e
    } else {
        let mut along = DVec3::from_array(g);
        along[k] = 0.0;
        line_zero(f, t, e, along, 0.1 * side)?
    };
    // Between the edge's ends: within the slab the edge spans, and no
    // farther off the edge than its length (the chamfer it is).
    let (pa, pb) = (pos(a), pos(b));
    let s = (q - pa).dot(pb - pa) / pa.distance_squared(pb);
    let between = s > 0.0 && s < 1.0 && (pa + (pb - pa) * s).distance(q) <= pa.distance(pb);
    (q.cmpge(lo).all() && q.cmple(hi).all() && between).then_some(((a, b), q))
}

/// Merges each grazed cell into the fan of a neighbouring candidate that
/// shares exactly one boundary edge with it (the crease runs through the
/// neighbour, just past the shared face; of several such neighbours, the
/// one whose feature point is nearest the grazed patch): the neighbour's
/// cycle with that edge `b → a` replaced by the grazed cell's path from
/// `b` around to `a`. Edges the grazed cell shares with other candidates
/// stay, and are joined like any two fans'. A candidate takes at most one
/// grazed cell.
fn merge_grazed(mesh: &Mesh, candidates: &mut [Candidate], grazed: Vec<Grazed>) {
    let mut owner: HashMap<(u32, u32), usize> = HashMap::default();
    for (k, c) in candidates.iter().enumerate() {
        for &e in &c.boundary {
            owner.insert(e, k);
        }
    }
    let mut taken = vec![false; candidates.len()];
    for (tris, cycle) in grazed {
        let shared: Vec<(usize, usize)> = cycle
            .iter()
            .enumerate()
            .filter_map(|(i, &(a, b))| owner.get(&(b, a)).map(|&d| (i, d)))
            .collect();
        let centre = cycle
            .iter()
            .map(|e| mesh.positions[e.0 as usize])
            .sum::<DVec3>()
            / cycle.len() as f64;
        let once = |d: usize| shared.iter().filter(|s| s.1 == d).count() == 1;
        let Some(&(i, d)) = shared
            .iter()
            .filter(|&&(_, d)| !taken[d] && once(d))
            .min_by(|x, y| {
                let dist = |k: usize| candidates[k].point.distance(centre);
                dist(x.1).total_cmp(&dist(y.1))
            })
        else {
            continue;
        };
        let (a, b) = cycle[i];
        let cand = &mut candidates[d];
        let Some(at) = cand.boundary.iter().position(|&e| e == (b, a)) else {
            continue;
        };
        // The grazed cell's path b → … → a, then the rest of the cycle.
        let path: Vec<(u32, u32)> = (1..cycle.len())
            .map(|k| cycle[(i + k) % cycle.len()])
            .collect();
        // Its vertices must be new to the candidate's cycle (one disk).
        let inner: HashSet<u32> = path.iter().map(|e| e.1).filter(|&v| v != a).collect();
        if cand.boundary.iter().any(|e| inner.contains(&e.0)) {
            continue;
        }
        cand.unmerged = Some(cand.boundary.clone());
        cand.boundary.splice(at..=at, path);
        cand.tris.push(tris);
        taken[d] = true;
    }
}

/// `x` minimising `|a x − r|` in the eigenvector basis of the symmetric
/// `a`, with the components along eigenvalues below [`TRUNCATE`] × the
/// largest set to 0 (the smallest such `x`), and the truncated directions.
fn truncated_solve(a: DMat3, r: DVec3) -> (DVec3, Vec<DVec3>) {
    let (values, vectors) = symmetric_eigen(a);
    let top = values.iter().copied().fold(0.0, f64::max);
    if top.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return (DVec3::ZERO, vectors.to_vec());
    }
    let kept = |k: &usize| values[*k] > TRUNCATE * top;
    let x = (0..3)
        .filter(kept)
        .map(|k| vectors[k] * (vectors[k].dot(r) / values[k]))
        .sum();
    (x, (0..3).filter(|k| !kept(k)).map(|k| vectors[k]).collect())
}

/// `p + s d` for the `s` nearest 0 that puts it in the box `[lo, hi]`,
/// [`SLIDE_INSET`] of the line's chord through the box inside it where it
/// has to slide, or `None` when the line misses the box.
fn slide_into(p: DVec3, d: DVec3, lo: DVec3, hi: DVec3) -> Option<DVec3> {
    let (mut s0, mut s1) = (f64::NEG_INFINITY, f64::INFINITY);
    for k in 0..3 {
        if d[k].abs() < 1e-12 {
            if p[k] < lo[k] || p[k] > hi[k] {
                return None;
            }
            continue;
        }
        let (a, b) = ((lo[k] - p[k]) / d[k], (hi[k] - p[k]) / d[k]);
        s0 = s0.max(a.min(b));
        s1 = s1.min(a.max(b));
    }
    let inset = SLIDE_INSET * (s1 - s0);
    (s0 <= s1).then(|| p + d * 0.0_f64.clamp(s0 + inset, s1 - inset))
}

/// Eigenvalues and unit eigenvectors of a symmetric 3 × 3 matrix (cyclic
/// Jacobi rotations).
fn symmetric_eigen(a: DMat3) -> ([f64; 3], [DVec3; 3]) {
    let mut m = [
        [a.x_axis.x, a.y_axis.x, a.z_axis.x],
        [a.x_axis.y, a.y_axis.y, a.z_axis.y],
        [a.x_axis.z, a.y_axis.z, a.z_axis.z],
    ];
    let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for _ in 0..32 {
        let off = m[0][1].abs() + m[0][2].abs() + m[1][2].abs();
        let diag = m[0][0].abs() + m[1][1].abs() + m[2][2].abs();
        if off <= 1e-15 * diag || off == 0.0 {
            break;
        }
        for (p, q) in [(0, 1), (0, 2), (1, 2)] {
            if m[p][q] == 0.0 {
                continue;
            }
            let theta = (m[q][q] - m[p][p]) / (2.0 * m[p][q]);
            let tan = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
            let c = 1.0 / (tan * tan + 1.0).sqrt();
            let s = tan * c;
            for row in &mut m {
                let (mkp, mkq) = (row[p], row[q]);
                row[p] = c * mkp - s * mkq;
                row[q] = s * mkp + c * mkq;
            }
            let (rp, rq) = (m[p], m[q]);
            m[p] = std::array::from_fn(|k| c * rp[k] - s * rq[k]);
            m[q] = std::array::from_fn(|k| s * rp[k] + c * rq[k]);
            for row in &mut v {
                let (vp, vq) = (row[p], row[q]);
                row[p] = c * vp - s * vq;
                row[q] = s * vp + c * vq;
            }
        }
    }
    let col = |k: usize| DVec3::new(v[0][k], v[1][k], v[2][k]);
    ([m[0][0], m[1][1], m[2][2]], [col(0), col(1), col(2)])
}

/// Flips the edges between fans of two different feature points (the
/// triangles from `first_fan` on, each `[a, b, q]` with `a → b` on its
/// cell's boundary) to join the feature points; returns the flips made.
fn join_features(mesh: &mut Mesh, first_fan: usize) -> usize {
    let by_edge: HashMap<(u32, u32), usize> = (first_fan..mesh.triangles.len())
        .map(|i| {
            let [a, b, _] = mesh.triangles[i];
            ((a, b), i)
        })
        .collect();
    let mut joined: HashSet<(u32, u32)> = HashSet::default();
    let mut flipped = vec![false; mesh.triangles.len()];
    let mut flips = 0;
    for i in first_fan..mesh.triangles.len() {
        if flipped[i] {
            continue;
        }
        let [a, b, q1] = mesh.triangles[i];
        let Some(&j) = by_edge.get(&(b, a)) else {
            continue;
        };
        if j < i || flipped[j] {
            continue;
        }
        let [b2, a2, q2] = mesh.triangles[j];
        if (b2, a2) != (b, a) || q1 == q2 || !joined.insert((q1.min(q2), q1.max(q2))) {
            continue;
        }
        let new = [[a, q2, q1], [b, q1, q2]];
        let at = |t: [u32; 3]| t.map(|v| mesh.positions[v as usize]);
        if faces(mesh, [a, a], at(new[0])) && faces(mesh, [b, b], at(new[1])) {
            mesh.triangles[i] = new[0];
            mesh.triangles[j] = new[1];
            flipped[i] = true;
            flipped[j] = true;
            flips += 1;
        } else {
            joined.remove(&(q1.min(q2), q1.max(q2)));
        }
    }
    flips
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eigen_decomposition_reconstructs_symmetric_matrices() {
        let mut rng = crate::testing::Rng::new(0x9e37_79b9_7f4a_7c15);
        let mut next = || rng.unit() * 2.0 - 1.0;
        for _ in 0..200 {
            let (a, b, c, d, e, f) = (next(), next(), next(), next(), next(), next());
            let m = DMat3::from_cols(
                DVec3::new(a, b, c),
                DVec3::new(b, d, e),
                DVec3::new(c, e, f),
            );
            let (values, vectors) = symmetric_eigen(m);
            for k in 0..3 {
                let (lambda, v) = (values[k], vectors[k]);
                assert!((v.length() - 1.0).abs() < 1e-12);
                assert!((m * v - v * lambda).length() < 1e-10, "{m:?}");
                for w in &vectors[..k] {
                    assert!(v.dot(*w).abs() < 1e-10);
                }
            }
        }
    }

    #[test]
    fn the_truncated_solve_meets_two_planes_on_their_line() {
        // Planes x = 1 and y = 2 (normals X and Y): the crease is the line
        // (1, 2, z); from the origin the solve stays at z = 0.
        let (n1, n2) = (DVec3::X, DVec3::Y);
        let (p1, p2) = (DVec3::new(1.0, 0.0, 5.0), DVec3::new(0.0, 2.0, -5.0));
        let mut a = DMat3::ZERO;
        let mut r = DVec3::ZERO;
        for (n, p) in [(n1, p1), (n2, p2)] {
            a += DMat3::from_cols(n * n.x, n * n.y, n * n.z);
            r += n * n.dot(p);
        }
        let (x, free) = truncated_solve(a, r);
        assert!((x - DVec3::new(1.0, 2.0, 0.0)).length() < 1e-12, "{x}");
        assert_eq!(free.len(), 1);
        assert!(free[0].cross(DVec3::Z).length() < 1e-12);
        // Slid along the crease into a box above it, past the face it
        // enters by SLIDE_INSET of its chord through the box (z from 3 to
        // 4), so that rounding keeps it inside.
        let lo = DVec3::new(0.0, 0.0, 3.0);
        let hi = DVec3::new(2.0, 3.0, 4.0);
        let p = slide_into(x, free[0], lo, hi).unwrap();
        let entered = DVec3::new(1.0, 2.0, 3.0 + SLIDE_INSET);
        assert!((p - entered).length() < 1e-12, "{p}");
        assert!(slide_into(x, free[0], lo + DVec3::X * 1.5, hi).is_none());
    }
}
