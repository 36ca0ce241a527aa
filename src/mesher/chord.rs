//! Chord refinement: the edges of an extracted mesh whose midpoints, or
//! whose triangles' centroids, stand too far off the surface are split,
//! the new vertex projected onto `f = 0` (faithful `--level`, SPEC §2,
//! between two octree levels).
//!
//! # Contract
//!
//! A round measures every edge's midpoint by its first-order distance
//! `|f| / ‖∇f‖` to the surface, and with [`Rules::centroids`] every
//! triangle's centroid too (at the largest turn between its corners'
//! normals over its longest edge). It splits the edges above the
//! tolerance (a [`Chord`]: its base, plus a share of the sagitta a
//! uniform mesher's chord has on the curvature `turn / length` the
//! normals at the edge's ends show), and the longest edge of each
//! triangle above it, whose
//! midpoint projects onto `f = 0` within a quarter of the edge's length,
//! onto the sheet of the edge's ends (the normal there agrees with both
//! ends' normals), and
//! re-triangulates each triangle by the number of its split edges (one:
//! two triangles; two: the corner triangle and the remaining quad by its
//! shorter diagonal; three: four triangles). An edge whose ends' normals
//! turn by more than [`SPLIT_DEG`] (and less than 120°, past which its
//! ends are more likely two sheets of a thin wall) may cut a crease off:
//! a chamfer the crease pass ([`super::crease`]) left. With `creases`, such
//! an edge is split onto the crease instead ([`onto_creases`]): from the
//! point nearest its midpoint where the ends' tangent planes meet, onto
//! `f = 0` along the ends' mean normal; where `f`'s gradients a quarter
//! of the way towards each end turn by at least 0.8 of the ends' normals'
//! turn (a kink, not a bend), onto the line where those two sides' planes
//! meet and again onto `f = 0`; the split is made when no new triangle
//! turns against its corners' normals and the fans of the four vertices
//! around it still face along their normals. A crease split that folds
//! alone may still be made with the others of its group: the crease
//! splits joined through the triangles they share, cut all at once as the
//! round cuts them (a chamfer, a triangle with a corner on one side of the
//! crease and two on the other, at both of its crossing edges: its corner
//! triangle on one side, its quad on the other), when no piece turns
//! against its old corners' normals (against their mean where they lie on
//! either side of a crease) and their fans still face along their normals
//! ([`grouped`]). The new vertex is a crease
//! vertex with one side's normal, so its edges are not split again.
//!
//! Every split vertex is shared
//! by the edge's triangles, so the mesh stays conforming: topology,
//! closedness and orientation are kept, a boundary edge stays on the
//! boundary. The decision depends on the edge and its triangles (a crease
//! split's that folds alone, on its group's triangles), the new vertex on
//! the edge alone, so the result does not depend on the order of the
//! edges. Edges with a
//! crease vertex for an end ([`super::crease`]) are left alone: between
//! two, the midpoint is off the crease; from one, a split changes the fan
//! of a crease point, whose normal is one side's and at a corner of three
//! faces lopsided already, and can turn the fan past 120° from it
//! (colonnade.vm at level 6, with the splits after smoothing). So is any
//! edge without exactly two triangles but the boundary edges, which lie in
//! a face of the domain: their midpoints move onto `f = 0` within the face
//! ([`in_faces`]). New vertices are crease vertices only when split onto
//! a crease, and are ambiguous when an end of their edge is.
//!
//! A part of a mesh (a brick of a bricked run, with its vertices'
//! [`Origins`]: [`split_edges_in`]) also splits its edges with one
//! triangle that do not lie on ∂Ω: their other triangle is in the next
//! brick, which decides the same edge the same way, and the new vertex
//! gets the same id on both sides.
//!
//! # Limits
//!
//! The measure is first order, at midpoints and centroids only. The octree's
//! chord criterion ([`crate::octree::OctreeOptions::chord`]) decides the
//! coarse sizes; this pass only corrects the last factor below a level.
//! The mesher runs it after coarsening and smoothing (`split_after_smoothing`
//! in [`super`]): its triangles get two passes that even their shapes
//! and sags out, held to the tolerance (`settle::settle`). Next to a crease
//! the faces keep the coarsened mesh's edges. A crease split needs both
//! of its edge's triangles, so on a brick's seam (one triangle in each
//! brick) an edge is not split onto a crease; and it puts one vertex on the
//! crease per edge, so a long chamfer is halved, not removed.

use glam::DVec3;
use rayon::prelude::*;
use rustc_hash::{FxHashMap as HashMap, FxHashSet as HashSet};
use smallvec::SmallVec;

use crate::cancel::{Cancel, Cancelled};
use crate::eval::Evaluator;
use crate::eval::sample::{grads_at, orient_at_kinks};
use crate::mesh::dynmesh::key;
use crate::mesh::origin::Origins;
use crate::mesh::topology::UnionFind;
use crate::mesh::{Mesh, Star};
use crate::octree::Chord;
use crate::octree::criteria::turn;
use crate::roots::{at, line_zero, project_along_batch};

use super::crease::SPLIT_DEG;

/// Rounds of splitting (each at most halves an edge).
pub const ROUNDS: usize = 3;

/// A midpoint is split only when it projects onto the surface within this
/// share of its edge's length, and the surface's normal there agrees with
/// the normals at both ends: a projection that would cross a thin wall
/// onto another sheet is refused.
const REACH: f64 = 0.25;

/// Splits, in up to [`ROUNDS`] rounds, the edges of `mesh` whose midpoint
/// stands farther than `tau` (at the edge's curvature: [`Chord::at`]) from
/// `f(·, t) = 0`; `feature` flags the
/// crease vertices (extended with `false` for the new ones). Returns how
/// many edges were split, or [`Cancelled`] when `cancel` was cancelled
/// before a round (the rounds done are kept). See the module doc.
pub fn split_edges<E: Evaluator + ?Sized>(
    mesh: &mut Mesh,
    feature: &mut Vec<bool>,
    f: &E,
    t: f64,
    tau: Chord,
    cancel: &Cancel,
) -> Result<usize, Cancelled> {
    split_edges_in(mesh, feature, None, f, t, tau, Rules::ALL, cancel)
}

/// [`split_edges`] on a part of a mesh whose vertices have `origins` (see
/// the module doc), kept in step; `None` is [`split_edges`]. Without
/// `creases` (`--no-creases`), no edge is split onto a crease
/// ([`onto_creases`]).
#[allow(clippy::too_many_arguments)]
pub fn split_edges_in<E: Evaluator + ?Sized>(
    mesh: &mut Mesh,
    feature: &mut Vec<bool>,
    mut origins: Option<&mut Origins>,
    f: &E,
    t: f64,
    tau: Chord,
    rules: Rules,
    cancel: &Cancel,
) -> Result<usize, Cancelled> {
    let (mut total, mut fresh) = (0, 0);
    for round in 0..ROUNDS {
        cancel.check()?;
        let part = origins.as_deref_mut().map(|o| (o, round as u32));
        let before = mesh.positions.len() as u32;
        let n = split_round_from(mesh, feature, part, f, t, (tau, rules), fresh);
        if n == 0 {
            break;
        }
        // Every edge the round made has a new vertex for an end; the
        // others, and their ends, are as the round measured them.
        fresh = before;
        total += n;
    }
    Ok(total)
}

/// One round of [`split_edges`]; returns how many edges it split.
pub fn split_round<E: Evaluator + ?Sized>(
    mesh: &mut Mesh,
    feature: &mut Vec<bool>,
    f: &E,
    t: f64,
    tau: Chord,
) -> usize {
    split_round_in(mesh, feature, None, f, t, tau, Rules::ALL)
}

/// [`split_round`] on a part of a mesh (see [`split_edges_in`]) whose
/// vertices have `origins`, as its round number `round` (the ids of the
/// new vertices depend on it: [`Origins::push_split`]), with `creases`
/// as in [`split_edges_in`].
pub fn split_round_in<E: Evaluator + ?Sized>(
    mesh: &mut Mesh,
    feature: &mut Vec<bool>,
    origins: Option<(&mut Origins, u32)>,
    f: &E,
    t: f64,
    tau: Chord,
    rules: Rules,
) -> usize {
    split_round_from(mesh, feature, origins, f, t, (tau, rules), 0)
}

/// [`split_round_in`] on the edges with an end numbered `fresh` or more
/// (the rest measured by the last round, unchanged since), with the
/// tolerance and whether edges may be split onto creases.
fn split_round_from<E: Evaluator + ?Sized>(
    mesh: &mut Mesh,
    feature: &mut Vec<bool>,
    origins: Option<(&mut Origins, u32)>,
    f: &E,
    t: f64,
    tau: (Chord, Rules),
    fresh: u32,
) -> usize {
    let part = origins.as_ref().map(|(o, _)| &**o);
    let splits = splits(mesh, feature, part, f, t, tau, fresh);
    apply(mesh, feature, &splits);
    if let Some((o, round)) = origins {
        for s in &splits {
            o.push_split(s.edge.0, s.edge.1, round);
        }
    }
    splits.len()
}

/// What a round may split besides the edges whose midpoints stand off.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Rules {
    /// An edge across a crease the crease pass left cut off is split onto
    /// it ([`onto_creases`]); `false` with `--no-creases`.
    pub creases: bool,
    /// The longest edge of a triangle whose centroid stands off is split
    /// (see `far_centroids`). Such an edge's decision reads its triangles,
    /// not the edge alone, so a run whose parts must equal the whole
    /// (`--smooth 0` bricks) leaves it off.
    pub centroids: bool,
}

impl Rules {
    /// Every rule on.
    pub const ALL: Rules = Rules {
        creases: true,
        centroids: true,
    };
}

/// Edges, each smaller index first.
type Edges = Vec<(u32, u32)>;

/// The edges marked by their triangles' centroids (smaller index first).
type Marked = HashSet<(u32, u32)>;

/// Triangles measured per task, as edges are ([`EDGES_PER_TASK`]).
const TRIANGLES_PER_TASK: usize = 4096;

/// The longest edges of the triangles (with a corner numbered `fresh` or
/// more, none a crease vertex) whose centroids stand farther than `tau`
/// at the triangle's curvature (the largest turn between its corners'
/// normals over its longest edge) off `f = 0`, where that edge has two
/// triangles. Midpoints alone miss these: an equilateral triangle's
/// centroid stands a third farther off a sphere than its edges'
/// midpoints, and smoothing makes triangles equilateral.
fn far_centroids<E: Evaluator + ?Sized>(
    mesh: &Mesh,
    star: &Star,
    feature: &[bool],
    f: &E,
    t: f64,
    (tau, fresh): (Chord, u32),
) -> Marked {
    let (p, n) = (&mesh.positions, &mesh.normals);
    let crease = |v: u32| feature.get(v as usize).copied().unwrap_or(false);
    let tris: Vec<[u32; 3]> = mesh
        .triangles
        .iter()
        .filter(|tri| tri.iter().any(|&v| v >= fresh) && !tri.iter().any(|&v| crease(v)))
        .copied()
        .collect();
    let far: Vec<(u32, u32)> = tris
        .par_chunks(TRIANGLES_PER_TASK)
        .flat_map_iter(|chunk| {
            let measured: Vec<((u32, u32), DVec3, f64)> = chunk
                .iter()
                .map(|&tri| centroid_tolerance(tau, tri, p, n))
                .collect();
            let at: Vec<DVec3> = measured.iter().map(|&(_, c, _)| c).collect();
            measured
                .into_iter()
                .zip(grads_at(f, t, &at))
                .filter(|&((_, _, tol), (v, g))| beyond(v, g, tol))
                .map(|((e, _, _), _)| e)
                .collect::<Vec<_>>()
        })
        .collect();
    far.into_iter()
        .filter(|&(a, b)| two_triangles(mesh, star, a, b))
        .collect()
}

/// A triangle's longest edge (smaller index first), its centroid and the
/// tolerance there: `tau` at the largest turn between its corners'
/// normals over that edge's length.
fn centroid_tolerance(
    tau: Chord,
    tri: [u32; 3],
    p: &[DVec3],
    n: &[DVec3],
) -> ((u32, u32), DVec3, f64) {
    let side = |k: usize| (tri[k], tri[(k + 1) % 3]);
    let length = |(a, b): (u32, u32)| p[a as usize].distance(p[b as usize]);
    let (a, b) = (0..3)
        .map(side)
        .max_by(|&x, &y| length(x).total_cmp(&length(y)))
        .expect("three sides");
    let bend = (0..3)
        .map(side)
        .map(|(x, y)| turn(n[x as usize].to_array(), n[y as usize].to_array()))
        .fold(0.0, f64::max);
    let centroid = tri.iter().map(|&v| p[v as usize]).sum::<DVec3>() / 3.0;
    let tol = tau.at(bend, length((a, b)));
    ((a.min(b), a.max(b)), centroid, tol)
}

/// Whether the edge `a–b` has exactly two triangles.
fn two_triangles(mesh: &Mesh, star: &Star, a: u32, b: u32) -> bool {
    let mut uses: SmallVec<[u32; 4]> = star
        .of(a as usize)
        .iter()
        .copied()
        .filter(|&ti| mesh.triangles[ti as usize].contains(&b))
        .collect();
    uses.dedup();
    uses.len() == 2
}

/// Edges measured per task: the midpoints and their gradients exist for
/// one task's edges at a time, not for the whole mesh.
const EDGES_PER_TASK: usize = 4096;

/// An edge (smaller index first) and a point for its new vertex.
type OnEdge = ((u32, u32), DVec3);

/// An edge to split (smaller index first), its midpoint, and how far from
/// its start a projection may go.
type Far = ((u32, u32), DVec3, f64);

/// A split: the edge (smaller index first), its new vertex's position and
/// gradient, and whether the new vertex is a crease vertex (see
/// [`across`]).
#[derive(Clone, Copy)]
struct Split {
    edge: (u32, u32),
    at: DVec3,
    grad: DVec3,
    crease: bool,
}

/// The edges to split and their new vertices.
fn splits<E: Evaluator + ?Sized>(
    mesh: &Mesh,
    feature: &[bool],
    part: Option<&Origins>,
    f: &E,
    t: f64,
    (tau, rules): (Chord, Rules),
    fresh: u32,
) -> Vec<Split> {
    let star = Star::new(mesh);
    let marked = if rules.centroids {
        far_centroids(mesh, &star, feature, f, t, (tau, fresh))
    } else {
        Marked::default()
    };
    let (edges, boundary) = inner_edges(mesh, &star, feature, part, (fresh, &marked));
    // Per chunk of edges, the far ones and their crease splits (one that
    // folds alone waits for its group: [`grouped`]).
    let measured: Vec<(Vec<Far>, Vec<Option<CreaseSplit>>)> = edges
        .par_chunks(EDGES_PER_TASK)
        .map(|chunk| {
            let far = far_edges(mesh, chunk, f, t, tau, &marked);
            let onto = if rules.creases {
                onto_creases(mesh, &star, &far, f, t)
            } else {
                vec![None; far.len()]
            };
            (far, onto)
        })
        .collect();
    let grouped = grouped(mesh, &star, &measured);
    let mut out: Vec<Split> = measured
        .into_par_iter()
        .flat_map_iter(|(far, onto)| {
            let onto: Vec<Option<Split>> = onto
                .into_iter()
                .map(|c| {
                    c.filter(|c| c.alone || grouped.contains(&c.split.edge))
                        .map(|c| c.split)
                })
                .collect();
            // The others from their midpoints, in the order of the edges.
            let rest: Vec<Far> = far
                .iter()
                .zip(&onto)
                .filter(|(_, c)| c.is_none())
                .map(|(&e, _)| e)
                .collect();
            let mut rest = from_midpoints(mesh, &rest, f, t).into_iter().peekable();
            let mut out = Vec::new();
            for (&(e, _, _), c) in far.iter().zip(onto) {
                match c {
                    Some(split) => out.push(split),
                    None => {
                        if let Some(split) = rest.next_if(|s| s.edge == e) {
                            out.push(split);
                        }
                    }
                }
            }
            out
        })
        .collect();
    let far = far_edges(mesh, &boundary, f, t, tau, &Marked::default());
    out.extend(in_faces(mesh, &far, f, t));
    out
}

/// The new vertices of `far` edges on ∂Ω: each midpoint moved onto
/// `f = 0` along the gradient there with the face's normal component
/// removed ([`line_zero`]), so the new vertex stays in the face both ends
/// lie in, with the gradient there on the ends' side. The face is the
/// coordinate both ends share at the mesh's extent (every vertex lies in
/// Ω, and the ends lie on its face); an edge with no such coordinate, or
/// two (along an edge of Ω), is left alone.
fn in_faces<E: Evaluator + ?Sized>(mesh: &Mesh, far: &[Far], f: &E, t: f64) -> Vec<Split> {
    let p = &mesh.positions;
    if far.is_empty() {
        return Vec::new();
    }
    let lo = p.iter().fold(DVec3::INFINITY, |a, &b| a.min(b));
    let hi = p.iter().fold(DVec3::NEG_INFINITY, |a, &b| a.max(b));
    let mids: Vec<DVec3> = far.iter().map(|&(_, m, _)| m).collect();
    let landed: Vec<OnEdge> = far
        .iter()
        .zip(grads_at(f, t, &mids))
        .filter_map(|(&((a, b), mid, reach), (_, g))| {
            let (pa, pb) = (p[a as usize], p[b as usize]);
            let mut shared =
                (0..3).filter(|&k| pa[k] == pb[k] && (pa[k] == lo[k] || pa[k] == hi[k]));
            let (k, None) = (shared.next()?, shared.next()) else {
                return None;
            };
            let mut dir = g;
            dir[k] = 0.0;
            line_zero(f, t, mid, dir, reach).map(|q| ((a, b), q))
        })
        .collect();
    on_ends_sheet(mesh, landed, f, t)
}

/// The edges of `chunk` whose midpoints stand farther than the tolerance
/// off `f = 0`, with their midpoints and how far a projection may go.
fn far_edges<E: Evaluator + ?Sized>(
    mesh: &Mesh,
    chunk: &[(u32, u32)],
    f: &E,
    t: f64,
    tau: Chord,
    marked: &Marked,
) -> Vec<Far> {
    let (p, n) = (&mesh.positions, &mesh.normals);
    let end = |v: u32| (p[v as usize], n[v as usize]);
    let mids: Vec<(DVec3, f64)> = chunk
        .iter()
        .map(|&(a, b)| midpoint_tolerance(tau, end(a), end(b)))
        .collect();
    let at: Vec<DVec3> = mids.iter().map(|&(m, _)| m).collect();
    chunk
        .iter()
        .zip(mids)
        .zip(grads_at(f, t, &at))
        // NaN (no gradient) is not a measurement: no split.
        .filter(|&((e, (_, tol)), (v, g))| beyond(v, g, tol) || marked.contains(e))
        .map(|((&(a, b), (mid, _)), _)| {
            ((a, b), mid, REACH * p[a as usize].distance(p[b as usize]))
        })
        .collect()
}

/// The new vertices of `far` edges split from their midpoints: projected
/// onto `f = 0`, with the gradient there on the sheet of the edge's ends
/// (not across a thin wall).
fn from_midpoints<E: Evaluator + ?Sized>(mesh: &Mesh, far: &[Far], f: &E, t: f64) -> Vec<Split> {
    let starts: Vec<(DVec3, f64)> = far.iter().map(|&(_, m, r)| (m, r)).collect();
    let projected: Vec<OnEdge> = far
        .iter()
        .zip(project_along_batch(f, t, &starts))
        .filter_map(|(&(e, _, _), r)| r.map(|(q, _)| (e, q)))
        .collect();
    on_ends_sheet(mesh, projected, f, t)
}

/// The splits at the points `landed` on `f = 0`, each for its edge, whose
/// gradient there (the new vertex's normal, [`oriented_grads`]) agrees
/// with both ends' normals: the point lies on the ends' sheet, not across
/// a thin wall.
fn on_ends_sheet<E: Evaluator + ?Sized>(
    mesh: &Mesh,
    landed: Vec<OnEdge>,
    f: &E,
    t: f64,
) -> Vec<Split> {
    let n = &mesh.normals;
    let gs = oriented_grads(f, t, &landed, n);
    landed
        .into_iter()
        .zip(gs)
        .filter(|&(((a, b), _), g)| {
            g.is_finite() && g.dot(n[a as usize]) > 0.0 && g.dot(n[b as usize]) > 0.0
        })
        .map(|((edge, at), grad)| Split {
            edge,
            at,
            grad,
            crease: false,
        })
        .collect()
}

/// The gradient at each new vertex of `projected` (its normal); where two
/// sides of a kink tie there, the side the ends' normals agree with.
fn oriented_grads<E: Evaluator + ?Sized>(
    f: &E,
    t: f64,
    projected: &[OnEdge],
    n: &[DVec3],
) -> Vec<DVec3> {
    let qs: Vec<DVec3> = projected.iter().map(|&(_, q)| q).collect();
    let mut gs: Vec<DVec3> = grads_at(f, t, &qs).into_iter().map(|(_, g)| g).collect();
    let outward: Vec<DVec3> = projected
        .iter()
        .map(|&((a, b), _)| n[a as usize] + n[b as usize])
        .collect();
    orient_at_kinks(f, t, &qs, &mut gs, &outward);
    gs
}

/// Per `far` edge, its split onto a crease of `f` when it cuts one off
/// (a chamfer the crease pass left; the new vertex is a crease vertex):
/// from [`across`], onto `f = 0` along the ends' mean normal, then onto
/// the kink ([`on_kink`]) and again onto `f = 0` along the mean of the two
/// sides' normals, with a normal there (one side's) that faces along the
/// ends' mean. Along a mean normal, not along the gradient: at a point of
/// one face on the crease's line the gradient is the other face's, along
/// which `f` only touches 0.
fn onto_creases<E: Evaluator + ?Sized>(
    mesh: &Mesh,
    star: &Star,
    far: &[Far],
    f: &E,
    t: f64,
) -> Vec<Option<CreaseSplit>> {
    let (p, n) = (&mesh.positions, &mesh.normals);
    let onto = |((ea, eb), mid, reach): Far| {
        let (a, b) = (
            (p[ea as usize], n[ea as usize]),
            (p[eb as usize], n[eb as usize]),
        );
        let q = across(mid, a, b)?;
        let q = line_zero(f, t, q, a.1 + b.1, reach)?;
        let side = |end: DVec3| {
            let (v, g) = f.point_grad(at(q + SIDE * (end - q), t));
            (v, DVec3::from_array(g))
        };
        let sides = [side(a.0), side(b.0)];
        let c = on_kink(q, a, b, sides, reach)?;
        let q = line_zero(
            f,
            t,
            c,
            sides[0].1.normalize() + sides[1].1.normalize(),
            reach,
        )?;
        Some((q, unfolded(mesh, star, (ea, eb), q)))
    };
    // Per far edge that landed, its index, (edge, new vertex) and whether
    // it folds nothing alone.
    let mut alone = Vec::new();
    let (index, landed): (Vec<usize>, Vec<OnEdge>) = far
        .iter()
        .enumerate()
        .filter_map(|(i, &e)| {
            onto(e).map(|(q, ok)| {
                alone.push(ok);
                (i, (e.0, q))
            })
        })
        .unzip();
    let gs = oriented_grads(f, t, &landed, n);
    let mut out = vec![None; far.len()];
    for (((i, (edge, at)), grad), alone) in index.into_iter().zip(landed).zip(gs).zip(alone) {
        let (na, nb) = (n[edge.0 as usize], n[edge.1 as usize]);
        if grad.is_finite() && grad.dot(na + nb) > 0.0 {
            out[i] = Some(CreaseSplit {
                split: Split {
                    edge,
                    at,
                    grad,
                    crease: true,
                },
                alone,
            });
        }
    }
    out
}

/// A split onto a crease, and whether it folds nothing on its own
/// ([`unfolded`]).
#[derive(Clone, Copy)]
struct CreaseSplit {
    split: Split,
    alone: bool,
}

/// The edges of the crease splits that fold something alone but nothing
/// together with the crease splits of the triangles around them (see the
/// module doc): the crease splits joined through the triangles they share
/// form groups, and a group of at most [`MAX_GROUP`] splits, each with two
/// triangles, is made whole when [`together`] holds. A group is a function
/// of the mesh, so the result does not depend on the order of the edges;
/// an edge on a brick's seam (one triangle in the part) keeps its group
/// from being made.
fn grouped(
    mesh: &Mesh,
    star: &Star,
    measured: &[(Vec<Far>, Vec<Option<CreaseSplit>>)],
) -> HashSet<(u32, u32)> {
    let all: Vec<CreaseSplit> = measured
        .iter()
        .flat_map(|(_, onto)| onto.iter().flatten().copied())
        .collect();
    let mut out = HashSet::default();
    if all.iter().all(|c| c.alone) {
        return out;
    }
    let index: HashMap<(u32, u32), usize> = all
        .iter()
        .enumerate()
        .map(|(i, c)| (c.split.edge, i))
        .collect();
    let triangles = |(a, b): (u32, u32)| -> SmallVec<[u32; 2]> {
        star.of(a as usize)
            .iter()
            .copied()
            .filter(|&ti| mesh.triangles[ti as usize].contains(&b))
            .collect()
    };
    let mut sets = UnionFind((0..all.len() as u32).collect());
    for (i, c) in all.iter().enumerate() {
        for ti in triangles(c.split.edge) {
            for e in sides(mesh.triangles[ti as usize]) {
                if let Some(&j) = index.get(&e) {
                    sets.union(i as u32, j as u32);
                }
            }
        }
    }
    let mut groups: HashMap<u32, Vec<usize>> = HashMap::default();
    for i in 0..all.len() {
        groups.entry(sets.find(i as u32)).or_default().push(i);
    }
    for members in groups.values() {
        if members.iter().all(|&i| all[i].alone) || members.len() > MAX_GROUP {
            continue;
        }
        let cuts: Vec<OnEdge> = members
            .iter()
            .map(|&i| (all[i].split.edge, all[i].split.at))
            .collect();
        let around: Vec<SmallVec<[u32; 2]>> = cuts.iter().map(|&(e, _)| triangles(e)).collect();
        if around.iter().any(|t| t.len() != 2) {
            continue;
        }
        let mut tris: Vec<u32> = around.into_iter().flatten().collect();
        tris.sort_unstable();
        tris.dedup();
        if together(mesh, star, &tris, &cuts) {
            out.extend(
                members
                    .iter()
                    .filter(|&&i| !all[i].alone)
                    .map(|&i| all[i].split.edge),
            );
        }
    }
    out
}

/// The most crease splits [`grouped`] decides together.
const MAX_GROUP: usize = 64;

/// The sides of triangle `t`, each smaller index first.
fn sides(t: [u32; 3]) -> [(u32, u32); 3] {
    [0, 1, 2].map(|k| key(t[k], t[(k + 1) % 3]))
}

/// Whether splitting the edges of `cuts` at their points, all at once,
/// folds nothing in the triangles `tris` around them, re-cut as the round
/// cuts them ([`pieces`]): each piece is not degenerate and faces along
/// the normals at its old corners (along their mean where they lie on
/// either side of a crease, past [`SPLIT_DEG`]; along the old triangle's
/// corners' where it has none), and the fans of those corners still face
/// along their normals (as [`unfolded`] asks of one split).
fn together(mesh: &Mesh, star: &Star, tris: &[u32], cuts: &[OnEdge]) -> bool {
    let (p, n) = (&mesh.positions, &mesh.normals);
    let fresh = p.len() as u32;
    let at = |v: u32| match v.checked_sub(fresh) {
        Some(i) => cuts[i as usize].1,
        None => p[v as usize],
    };
    let d2 = |a: u32, b: u32| at(a).distance_squared(at(b));
    let area = |t: [u32; 3]| (at(t[1]) - at(t[0])).cross(at(t[2]) - at(t[0]));
    let cos_split = SPLIT_DEG.to_radians().cos();
    let mut fans = Fans::new(mesh, star);
    for &ti in tris {
        let t = mesh.triangles[ti as usize];
        let m = sides(t).map(|e| {
            cuts.iter()
                .position(|&(c, _)| c == e)
                .map(|i| fresh + i as u32)
        });
        let (pieces, count) = pieces(t, m, d2);
        let old = area(t);
        let scale = old.length();
        for &v in &t {
            fans.change(v, -old);
        }
        for &piece in &pieces[..count] {
            let nt = area(piece);
            let mut corners: SmallVec<[u32; 3]> =
                piece.iter().copied().filter(|&v| v < fresh).collect();
            if corners.is_empty() {
                corners.extend(t);
            }
            let normals = corners.iter().map(|&v| n[v as usize]);
            let one_side = normals
                .clone()
                .all(|a| normals.clone().all(|b| a.dot(b) > cos_split));
            let faces = if one_side {
                normals.clone().all(|c| nt.dot(c) > 0.0)
            } else {
                nt.dot(normals.clone().sum::<DVec3>()) > 0.0
            };
            if !faces || nt.length() <= 1e-9 * scale {
                return false;
            }
            for &v in piece.iter().filter(|&&v| v < fresh) {
                fans.change(v, nt);
            }
        }
    }
    fans.face_along_normals()
}

/// The midpoint of the edge `a–b`, given its ends' positions and unit
/// normals, and the tolerance for it: `tau` at the normals' turn over the
/// edge's length.
pub(crate) fn midpoint_tolerance(
    tau: Chord,
    (pa, na): (DVec3, DVec3),
    (pb, nb): (DVec3, DVec3),
) -> (DVec3, f64) {
    let bend = turn(na.to_array(), nb.to_array());
    ((pa + pb) * 0.5, tau.at(bend, pa.distance(pb)))
}

/// Whether a point where `f` is `v` and ∇f is `g` stands farther than
/// `tol` off `f = 0`, to first order (`|f| / ‖∇f‖`); false where there is
/// no gradient (NaN is not a measurement).
pub(crate) fn beyond(v: f64, g: DVec3, tol: f64) -> bool {
    v.abs() / g.length() > tol
}

/// Where to start the projection of the midpoint `mid` of an edge whose
/// ends' normals turn by more than [`SPLIT_DEG`]: the point nearest `mid`
/// on the line where the ends' tangent planes meet ([`meet`]), when it
/// lies between the ends (along the edge) and within half the edge's
/// length of `mid`. Across a crease that the crease pass left cut off (a
/// chamfer), the projection then lands near the crease rather than on one
/// face, where the new vertex's normal would face away from the other end.
fn across(mid: DVec3, (pa, na): (DVec3, DVec3), (pb, nb): (DVec3, DVec3)) -> Option<DVec3> {
    // Past 120° the ends are more likely two sheets of a thin wall than
    // two faces of a crease.
    let cos = na.dot(nb);
    if cos.is_nan() || cos >= SPLIT_DEG.to_radians().cos() || cos <= -0.5 {
        return None;
    }
    let q = meet(mid, (pa, na), (pb, nb))?;
    let (ab, len2) = (pb - pa, pa.distance_squared(pb));
    let along = (q - pa).dot(ab);
    ((0.0..=len2).contains(&along) && q.distance_squared(mid) <= 0.25 * len2).then_some(q)
}

/// The point nearest `x` on the line where the plane through `pa` normal
/// to the unit `na` meets the one through `pb` normal to `nb` (`None` for
/// parallel planes).
fn meet(x: DVec3, (pa, na): (DVec3, DVec3), (pb, nb): (DVec3, DVec3)) -> Option<DVec3> {
    let cos = na.dot(nb);
    let d = na.cross(nb);
    let det = d.length_squared();
    if det.is_nan() || det <= 1e-12 {
        return None;
    }
    // The point of both planes in the span of the normals.
    let (ha, hb) = (na.dot(pa), nb.dot(pb));
    let x0 = ((ha - hb * cos) * na + (hb - ha * cos) * nb) / det;
    let q = x0 + d * ((x - x0).dot(d) / det);
    q.is_finite().then_some(q)
}

/// How far from a point projected from [`across`] towards each end of its
/// edge [`on_kink`] reads the two sides of `f`.
const SIDE: f64 = 0.25;

/// The crease point near `q`, a point projected from [`across`] for the
/// edge with ends `(pa, na)`, `(pb, nb)`, from `f`'s value and gradient
/// `sa`, `sb` at [`SIDE`] of the way towards each end: `None` unless the
/// unit gradients there turn by at least 0.8 of the ends' normals' turn
/// (a kink of `f` between them: on a smooth bend they turn by about half
/// of it, the middle half of the arc), else the point nearest `q` where
/// the two sides' first-order planes meet, if within `reach` of `q`.
fn on_kink(
    q: DVec3,
    (pa, na): (DVec3, DVec3),
    (pb, nb): (DVec3, DVec3),
    [sa, sb]: [(f64, DVec3); 2],
    reach: f64,
) -> Option<DVec3> {
    let plane = |p: DVec3, (v, g): (f64, DVec3)| {
        let at = q + SIDE * (p - q);
        let u = g.normalize();
        // The side's plane: through the first-order foot of its sample.
        (u.is_finite() && v.is_finite()).then(|| (at - (v / g.length()) * u, u))
    };
    let (a, b) = (plane(pa, sa)?, plane(pb, sb)?);
    let ends = turn(na.to_array(), nb.to_array());
    if turn(a.1.to_array(), b.1.to_array()) < 0.8 * ends {
        return None;
    }
    meet(q, a, b).filter(|c| c.distance(q) <= reach)
}

/// Whether splitting the edge `a–b` at `q` folds nothing: the edge has
/// two triangles (on a brick's seam, one: such an edge is not split onto
/// a crease, as the next brick cannot see the other), each of the four
/// new ones faces along the normals at its two corners other than `q`
/// (whose normal is one side's), and the fans of `a`, `b` and the two
/// opposite corners still face along their normals (the sum of their
/// triangles' area normals: a split next to a crumpled patch of a thin
/// wall could turn one over).
fn unfolded(mesh: &Mesh, star: &Star, (a, b): (u32, u32), q: DVec3) -> bool {
    let (p, n) = (&mesh.positions, &mesh.normals);
    let area = |t: [DVec3; 3]| (t[1] - t[0]).cross(t[2] - t[0]);
    let mut fans = Fans::new(mesh, star);
    let mut sides = 0;
    for &ti in star.of(a as usize) {
        let t = mesh.triangles[ti as usize];
        let Some(k) =
            (0..3).find(|&k| (t[k], t[(k + 1) % 3]) == (a, b) || (t[k], t[(k + 1) % 3]) == (b, a))
        else {
            continue;
        };
        sides += 1;
        let (x, y, c) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
        let [px, py, pc] = [x, y, c].map(|v| p[v as usize]);
        let (old, first, second) = (area([px, py, pc]), area([px, q, pc]), area([q, py, pc]));
        let faces = |u: u32, nt: DVec3| nt.dot(n[u as usize]) > 0.0 && nt.dot(n[c as usize]) > 0.0;
        if !faces(x, first) || !faces(y, second) {
            return false;
        }
        fans.change(x, first - old);
        fans.change(y, second - old);
        fans.change(c, first + second - old);
    }
    sides == 2 && fans.face_along_normals()
}

/// The area normals of the fans of the vertices whose triangles some
/// splits re-cut (the sum of their triangles' right-hand normals), each
/// from its fan in the mesh plus what [`Fans::change`] adds: what
/// [`unfolded`] and [`together`] ask to keep facing along the vertices'
/// normals.
struct Fans<'a> {
    mesh: &'a Mesh,
    star: &'a Star,
    sums: SmallVec<[(u32, DVec3); 8]>,
}

impl<'a> Fans<'a> {
    fn new(mesh: &'a Mesh, star: &'a Star) -> Fans<'a> {
        Fans {
            mesh,
            star,
            sums: SmallVec::new(),
        }
    }

    /// Adds `by` to the fan of vertex `u`.
    fn change(&mut self, u: u32, by: DVec3) {
        match self.sums.iter_mut().find(|(v, _)| *v == u) {
            Some((_, s)) => *s += by,
            None => {
                let fan: DVec3 = self
                    .star
                    .of(u as usize)
                    .iter()
                    .map(|&ti| self.mesh.face_normal(self.mesh.triangles[ti as usize]))
                    .sum();
                self.sums.push((u, fan + by));
            }
        }
    }

    /// Whether every changed fan faces along its vertex's normal.
    fn face_along_normals(&self) -> bool {
        let n = &self.mesh.normals;
        self.sums.iter().all(|&(u, s)| s.dot(n[u as usize]) > 0.0)
    }
}

/// The edges (smaller index first, sorted) with no end on a crease,
/// among those with an end numbered `fresh` or more or `marked`: those
/// with exactly two triangles (in a `part` of a mesh, also those with one
/// triangle off ∂Ω, a seam: see the module doc), and apart the boundary
/// edges (one triangle, on ∂Ω), whose midpoints move within their face
/// ([`in_faces`]).
fn inner_edges(
    mesh: &Mesh,
    star: &Star,
    feature: &[bool],
    part: Option<&Origins>,
    (fresh, marked): (u32, &Marked),
) -> (Edges, Edges) {
    let crease = |v: u32| feature.get(v as usize).copied().unwrap_or(false);
    let tris = &mesh.triangles;
    (0..mesh.positions.len() as u32)
        .into_par_iter()
        .flat_map_iter(|a| {
            // The uses of the edges whose smaller end is `a` (a triangle's
            // sides, as many times as it has them: once per triangle but
            // for one with a repeated corner), sorted.
            let mut uses: SmallVec<[u32; 16]> = SmallVec::new();
            let mut last = None;
            for &ti in star.of(a as usize) {
                if last.replace(ti) == Some(ti) {
                    // The star lists a triangle once per corner it is.
                    continue;
                }
                let t = tris[ti as usize];
                for k in 0..3 {
                    let (x, y) = (t[k], t[(k + 1) % 3]);
                    let (lo, hi) = (x.min(y), x.max(y));
                    let measured = hi >= fresh || marked.contains(&(lo, hi));
                    if lo == a && measured && !(crease(lo) || crease(hi)) {
                        uses.push(hi);
                    }
                }
            }
            uses.sort_unstable();
            // The edges used exactly twice (once, on a part's seam), and
            // apart those used once on ∂Ω.
            let mut kept: SmallVec<[((u32, u32), bool); 8]> = SmallVec::new();
            for run in uses.chunk_by(|x, y| x == y) {
                let b = run[0];
                let on_face = part.is_none_or(|o| o.on_boundary(a, b));
                match run.len() {
                    2 => kept.push(((a, b), false)),
                    1 => kept.push(((a, b), on_face)),
                    _ => {}
                }
            }
            kept
        })
        .partition_map(|(e, on_face)| {
            if on_face {
                rayon::iter::Either::Right(e)
            } else {
                rayon::iter::Either::Left(e)
            }
        })
}

/// Splits `mesh`'s edges at the given vertices (see the module doc).
fn apply(mesh: &mut Mesh, feature: &mut Vec<bool>, splits: &[Split]) {
    feature.resize(mesh.positions.len(), false);
    if splits.is_empty() {
        return;
    }
    let mut at: HashMap<(u32, u32), u32> = HashMap::default();
    at.reserve(splits.len());
    for s in splits {
        let (a, b) = s.edge;
        at.insert((a, b), mesh.positions.len() as u32);
        let ambiguous = mesh.ambiguous[a as usize] || mesh.ambiguous[b as usize];
        mesh.positions.push(s.at);
        mesh.normals.push(s.grad.normalize());
        mesh.ambiguous.push(ambiguous);
        feature.push(s.crease);
    }
    let mid = |a: u32, b: u32| at.get(&(a.min(b), a.max(b))).copied();
    // Each triangle is replaced by its first piece in place; the others
    // are appended (no second copy of the triangle list).
    let p = &mesh.positions;
    let d2 = |a: u32, b: u32| p[a as usize].distance_squared(p[b as usize]);
    let mut extra = Vec::with_capacity(3 * splits.len());
    for t in mesh.triangles.iter_mut() {
        let m = [0, 1, 2].map(|k| mid(t[k], t[(k + 1) % 3]));
        let (pieces, count) = pieces(*t, m, d2);
        *t = pieces[0];
        extra.extend_from_slice(&pieces[1..count]);
    }
    mesh.triangles.append(&mut extra);
}

/// The triangles that replace `t = [a, b, c]` given the split vertices
/// `m[k]` of its edges `t[k]→t[k+1]` (see the module doc); `d2` measures
/// a squared length, to cut a quad by its shorter diagonal. Returns the
/// pieces (the first `count` of the array).
fn pieces(
    t: [u32; 3],
    m: [Option<u32>; 3],
    d2: impl Fn(u32, u32) -> f64,
) -> ([[u32; 3]; 4], usize) {
    let pad = |p: &[[u32; 3]]| {
        let mut out = [t; 4];
        out[..p.len()].copy_from_slice(p);
        (out, p.len())
    };
    match m.iter().filter(|x| x.is_some()).count() {
        0 => pad(&[t]),
        3 => {
            let [ab, bc, ca] = m.map(|x| x.expect("three splits"));
            let [a, b, c] = t;
            pad(&[[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]])
        }
        n => {
            // Rotate so that edge 0 (a→b) is split and, with two splits,
            // edge 1 (b→c) too.
            let r = (0..3)
                .find(|&r| m[r].is_some() && (n == 1 || m[(r + 1) % 3].is_some()))
                .expect("a split edge");
            let [a, b, c] = [t[r], t[(r + 1) % 3], t[(r + 2) % 3]];
            let ab = m[r].expect("split");
            if n == 1 {
                return pad(&[[a, ab, c], [ab, b, c]]);
            }
            let bc = m[(r + 1) % 3].expect("split");
            // The quad a, ab, bc, c by its shorter diagonal.
            if d2(a, bc) <= d2(ab, c) {
                pad(&[[ab, b, bc], [a, ab, bc], [a, bc, c]])
            } else {
                pad(&[[ab, b, bc], [a, ab, c], [ab, bc, c]])
            }
        }
    }
}
