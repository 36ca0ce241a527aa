//! Random CSG scenes and the property checks of a mesh (issue 21, item 3).
//!
//! # The scenes
//!
//! [`Scene::random`] writes, from a seed, an `.iso` source over `[-1, 1]³`
//! in the style people build models in: sphere, box, rounded box,
//! cylinder, capsule, torus and half-space primitives, each in its own
//! frame (a random rotation from a uniform unit quaternion, and a
//! translation) bound by `let`, joined by union (`min`), intersection
//! (`max`), difference (`max(a, -b)`) and polynomial smooth blends
//! (`min(a, b) - max(k - |a - b|, 0)² / 4k` and its intersection and
//! difference forms). With [`Config::nasty`] probability a leaf of the
//! tree is one of the configurations meshers get wrong: near-tangent or
//! exactly tangent contacts, two boxes sharing a face plane, walls about
//! one level-7 cell thin (2/128), shapes cut by the domain boundary, a box
//! face lying exactly on an octree plane, features smaller than a cell.
//! With [`Config::exotic`] probability a join is a blend that uses `exp`,
//! `log`, `sqrt` or a division (exponential smooth min and max, Rvachev's
//! R-function union, a rational blend), and the whole function is now and
//! then divided by a positive polynomial. A scene is at most a few hundred
//! instructions.
//!
//! # The checks
//!
//! [`check_mesh`] applies SPEC §3 to one mesh and returns every broken
//! rule, never stopping at the first:
//!
//! - **manifold**: no edge used by three or more triangles, no boundary
//!   edge off the domain boundary, no bow-tie vertex
//!   ([`topology::analyze_in`] within the domain);
//! - **oriented**: no edge traversed twice the same way;
//! - **outward**: triangle normals along `+∇f` at the centroids, as an
//!   aggregate over the triangles whose normal is within 60° of `±∇f`
//!   ([`DECISIVE`]): over the mesh at least [`OUTWARD`] of their area, and
//!   in each component of at least [`JUDGED`] triangles at least
//!   [`FLIPPED`] of it (a flipped component
//!   fails; a sliver at a crease, a chord across a plate thinner than a
//!   cell or a blob in a thin wall does not); a mesh below the aggregate
//!   share passes if its winding number (a mesh cut by the domain closed
//!   by ∂Ω where `f < 0`) is 1 where `f < 0` and 0 where `f > 0` at points
//!   a few cells off the surface (an exact oracle of orientation, blind to
//!   thin features: [`winding_mismatches`]);
//! - **on surface**: `|f(v)| ≤ ON_SURFACE · h · |∇f(v)|` at every vertex,
//!   `h` the finest cell;
//! - **in domain**: every vertex in Ω (closed), where the surface is defined;
//! - **degenerate**: no triangle with a repeated index or zero area;
//! - **duplicated**: two vertices at the same position only where two
//!   sheets touch (their fans face opposite ways);
//! - **reference**: where the report says `guaranteed`, the components and
//!   genera equal those of an independent reference ([`reference`]:
//!   marching tetrahedra on a fine uniform grid of the point kernel).
//!
//! # Limits
//!
//! The reference resolves only what its grid resolves: when the mesh and
//! the reference disagree, a second, 1.5× finer reference decides, and if
//! the two references disagree the scene is counted as *unresolved*
//! rather than failed. "Outward" is judged at centroids, which lie off the
//! surface; "on surface" uses the point gradient, so where ∇f is not
//! defined (NaN, or 0) it falls back to a sign change of `f` within `h/64`,
//! or to the same bound with the steepest secant slope over those samples
//! (a zero the surface touches without crossing: box seed 66125).

use std::collections::HashMap;
use std::fmt::Write as _;

use glam::{DMat3, DVec3};
use isoc::mesh::{Mesh, topology};
use isoc::mesher::{self, MeshOptions, MeshReport};
use isoc::octree::{Leaf, Octree, OctreeOptions};
use isoc::{Bounds, Surface};

use super::Rng;

// ---------------------------------------------------------------- scenes

/// How [`Scene::random`] draws a scene.
#[derive(Clone, Copy, Debug)]
pub struct Config {
    /// Fewest leaves of the CSG tree.
    pub min_leaves: usize,
    /// Most leaves of the CSG tree.
    pub max_leaves: usize,
    /// Probability that a leaf is a nasty configuration rather than one
    /// primitive.
    pub nasty: f64,
    /// Probability that a join is an `exp`/`log`/`sqrt`/division blend.
    pub exotic: f64,
}

impl Default for Config {
    fn default() -> Self {
        Config {
            min_leaves: 2,
            max_leaves: 7,
            nasty: 0.35,
            exotic: 0.1,
        }
    }
}

impl Config {
    /// Every join an `exp`/`log`/division blend, fewer nasty leaves: the
    /// "real model" blends meshed at level 8.
    pub fn blends() -> Config {
        Config {
            min_leaves: 4,
            max_leaves: 7,
            nasty: 0.15,
            exotic: 1.0,
        }
    }
}

/// A random scene: its seed and `.iso` source.
#[derive(Clone, Debug)]
pub struct Scene {
    /// The seed it was drawn from.
    pub seed: u64,
    /// The `.iso` source (domain `[-1, 1]³`).
    pub source: String,
    /// The nasty configurations and exotic blends it contains, for the
    /// failure messages.
    pub features: Vec<&'static str>,
}

fn uniform(rng: &mut Rng, a: f64, b: f64) -> f64 {
    a + (b - a) * rng.unit()
}

fn below(rng: &mut Rng, n: usize) -> usize {
    (rng.next_u64() % n as u64) as usize
}

fn chance(rng: &mut Rng, p: f64) -> bool {
    rng.unit() < p
}

/// A uniform unit vector.
fn direction(rng: &mut Rng) -> DVec3 {
    loop {
        let v = DVec3::new(
            uniform(rng, -1.0, 1.0),
            uniform(rng, -1.0, 1.0),
            uniform(rng, -1.0, 1.0),
        );
        let l = v.length();
        if l > 1e-3 && l <= 1.0 {
            return v / l;
        }
    }
}

/// A uniform rotation (from a uniform unit quaternion): its rows are the
/// local axes `u v w`.
fn rotation(rng: &mut Rng) -> DMat3 {
    let q = loop {
        let q: [f64; 4] = std::array::from_fn(|_| uniform(rng, -1.0, 1.0));
        let n = q.iter().map(|c| c * c).sum::<f64>().sqrt();
        if n > 1e-3 && n <= 1.0 {
            break q.map(|c| c / n);
        }
    };
    let [w, x, y, z] = q;
    // Rows of the rotation matrix of q.
    DMat3::from_cols_array(&[
        1.0 - 2.0 * (y * y + z * z),
        2.0 * (x * y + w * z),
        2.0 * (x * z - w * y),
        2.0 * (x * y - w * z),
        1.0 - 2.0 * (x * x + z * z),
        2.0 * (y * z + w * x),
        2.0 * (x * z + w * y),
        2.0 * (y * z - w * x),
        1.0 - 2.0 * (x * x + y * y),
    ])
    .transpose()
}

/// A number as source text (6 decimals, negative ones in parentheses).
fn num(v: f64) -> String {
    let s = format!("{v:.6}");
    let s = s.trim_end_matches('0').trim_end_matches('.').to_string();
    let s = if s == "-0" || s.is_empty() {
        "0".to_string()
    } else {
        s
    };
    if s.starts_with('-') {
        format!("({s})")
    } else {
        s
    }
}

/// `e - c` as source text, `e` when `c` prints as 0.
fn minus(e: &str, c: f64) -> String {
    let n = num(c);
    if n == "0" {
        e.to_string()
    } else {
        format!("{e} - {n}")
    }
}

/// The primitive kinds.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Prim {
    Sphere,
    Box,
    RoundBox,
    Cylinder,
    Capsule,
    Torus,
    HalfSpace,
}

const SOLIDS: [Prim; 6] = [
    Prim::Sphere,
    Prim::Box,
    Prim::RoundBox,
    Prim::Cylinder,
    Prim::Capsule,
    Prim::Torus,
];

/// The box of half-sides `half` about the origin of the coordinates `c`:
/// `max(|c₀| − h₀, |c₁| − h₁, |c₂| − h₂)`.
fn box_sdf(c: [&str; 3], half: [f64; 3]) -> String {
    format!(
        "max(abs({}) - {}, abs({}) - {}, abs({}) - {})",
        c[0],
        num(half[0]),
        c[1],
        num(half[1]),
        c[2],
        num(half[2])
    )
}

/// A local frame: the names of its three coordinates.
#[derive(Clone)]
struct Frame([String; 3]);

impl Frame {
    /// Coordinates shifted by `o` (in the frame): `(u - o.x)` etc.
    fn shifted(&self, o: DVec3) -> [String; 3] {
        std::array::from_fn(|k| {
            let s = minus(&self.0[k], o[k]);
            if s == self.0[k] { s } else { format!("({s})") }
        })
    }
}

/// A leaf or subtree: its `let` name and a representative size and centre
/// (for placing what comes next).
#[derive(Clone)]
struct Part {
    name: String,
    centre: DVec3,
    radius: f64,
}

struct Builder {
    rng: Rng,
    cfg: Config,
    lets: Vec<String>,
    next: usize,
    features: Vec<&'static str>,
}

impl Builder {
    /// Binds `expr` to a fresh name.
    fn bind(&mut self, prefix: &str, expr: String) -> String {
        self.next += 1;
        let name = format!("{prefix}{}", self.next);
        self.lets.push(format!("let {name} = {expr};"));
        name
    }

    /// A frame at `centre` with axes the rows of `rot`.
    fn frame(&mut self, centre: DVec3, rot: DMat3) -> Frame {
        let r = rot.transpose(); // columns of r are the rows of rot
        let axes: [String; 3] = std::array::from_fn(|k| {
            let row = r.col(k);
            let terms: Vec<String> = (0..3)
                .map(|i| {
                    let v = ["x", "y", "z"][i];
                    let c = minus(v, centre[i]);
                    let c = if c == v { c } else { format!("({c})") };
                    format!("{}*{c}", num(row[i]))
                })
                .collect();
            terms.join(" + ")
        });
        self.next += 1;
        let id = self.next;
        Frame(std::array::from_fn(|k| {
            let name = format!("{}{id}", ["u", "v", "w"][k]);
            self.lets.push(format!("let {name} = {};", axes[k]));
            name
        }))
    }

    /// A random frame at `centre`: mostly rotated, now and then
    /// axis-aligned.
    fn random_frame(&mut self, centre: DVec3) -> Frame {
        let rot = if chance(&mut self.rng, 0.1) {
            DMat3::IDENTITY
        } else {
            rotation(&mut self.rng)
        };
        self.frame(centre, rot)
    }

    /// The expression of a primitive of kind `p` and size `s` in local
    /// coordinates `[u, v, w]`.
    fn shape(&mut self, p: Prim, c: &[String; 3], s: f64) -> String {
        let [u, v, w] = c;
        let rng = &mut self.rng;
        let mut ext = || s * uniform(rng, 0.5, 1.0);
        match p {
            Prim::Sphere => format!("sqrt({u}^2 + {v}^2 + {w}^2) - {}", num(s)),
            Prim::Box => {
                let (a, b, d) = (ext(), ext(), ext());
                format!(
                    "max(abs({u}) - {}, abs({v}) - {}, abs({w}) - {})",
                    num(a),
                    num(b),
                    num(d)
                )
            }
            Prim::RoundBox => {
                let (a, b, d) = (ext(), ext(), ext());
                let r = a.min(b).min(d) * uniform(&mut self.rng, 0.1, 0.5);
                let (a, b, d) = (num(a - r), num(b - r), num(d - r));
                format!(
                    "sqrt(max(abs({u}) - {a}, 0)^2 + max(abs({v}) - {b}, 0)^2 + max(abs({w}) - {d}, 0)^2) + min(max(abs({u}) - {a}, abs({v}) - {b}, abs({w}) - {d}), 0) - {}",
                    num(r)
                )
            }
            Prim::Cylinder => format!(
                "max(sqrt({u}^2 + {v}^2) - {}, abs({w}) - {})",
                num(ext()),
                num(ext())
            ),
            Prim::Capsule => format!(
                "sqrt({u}^2 + {v}^2 + max(abs({w}) - {}, 0)^2) - {}",
                num(ext()),
                num(0.6 * ext())
            ),
            Prim::Torus => {
                let big = ext();
                let small = big * uniform(&mut self.rng, 0.15, 0.5);
                format!(
                    "sqrt((sqrt({u}^2 + {v}^2) - {})^2 + {w}^2) - {}",
                    num(big),
                    num(small)
                )
            }
            Prim::HalfSpace => format!("{w} - {}", num(uniform(rng, -0.2, 0.2) * s)),
        }
    }

    /// One primitive near `near` (a random earlier part) or anywhere.
    fn primitive(&mut self, near: Option<&Part>) -> Part {
        let s = uniform(&mut self.rng, 0.08, 0.32);
        let centre = match near {
            Some(p) => {
                let d = direction(&mut self.rng);
                let reach = (p.radius + s) * uniform(&mut self.rng, 0.3, 1.1);
                (p.centre + d * reach).clamp(DVec3::splat(-0.8), DVec3::splat(0.8))
            }
            None => DVec3::new(
                uniform(&mut self.rng, -0.5, 0.5),
                uniform(&mut self.rng, -0.5, 0.5),
                uniform(&mut self.rng, -0.5, 0.5),
            ),
        };
        // Half-spaces are rare: they fill half the domain.
        let p = if chance(&mut self.rng, 0.05) {
            self.features.push("half-space");
            Prim::HalfSpace
        } else {
            SOLIDS[below(&mut self.rng, SOLIDS.len())]
        };
        self.placed("p", p, centre, s)
    }

    /// Primitive `p` of size `s` in a random frame at `centre`, bound to a
    /// `let` named with `prefix`.
    fn placed(&mut self, prefix: &str, p: Prim, centre: DVec3, s: f64) -> Part {
        let f = self.random_frame(centre);
        let e = self.shape(p, &f.0, s);
        Part {
            name: self.bind(prefix, e),
            centre,
            radius: s,
        }
    }

    /// A nasty configuration (see the module doc).
    fn nasty(&mut self, near: Option<&Part>) -> Part {
        let centre = match near {
            Some(p) => p.centre + direction(&mut self.rng) * p.radius,
            None => DVec3::new(
                uniform(&mut self.rng, -0.4, 0.4),
                uniform(&mut self.rng, -0.4, 0.4),
                uniform(&mut self.rng, -0.4, 0.4),
            ),
        }
        .clamp(DVec3::splat(-0.7), DVec3::splat(0.7));
        let gaps = [0.0, 1e-6, -1e-6, 1e-4, -1e-4, 1e-3, -1e-3, 5e-3, 0.02];
        match below(&mut self.rng, 8) {
            0 => {
                // Two spheres touching, or nearly.
                self.features.push("tangent spheres");
                let (r1, r2) = (
                    uniform(&mut self.rng, 0.08, 0.3),
                    uniform(&mut self.rng, 0.05, 0.3),
                );
                let gap = gaps[below(&mut self.rng, gaps.len())];
                let f = self.random_frame(centre);
                let a = format!(
                    "sqrt({}^2 + {}^2 + {}^2) - {}",
                    f.0[0],
                    f.0[1],
                    f.0[2],
                    num(r1)
                );
                let c = f.shifted(DVec3::new(0.0, 0.0, r1 + r2 + gap));
                let b = format!("sqrt({}^2 + {}^2 + {}^2) - {}", c[0], c[1], c[2], num(r2));
                let (a, b) = (self.bind("t", a), self.bind("t", b));
                let e = if chance(&mut self.rng, 0.5) {
                    format!("min({a}, {b})")
                } else {
                    self.features.push("tangent difference");
                    format!("max({a}, -({b}))")
                };
                Part {
                    name: self.bind("n", e),
                    centre,
                    radius: r1 + r2,
                }
            }
            1 => {
                // A sphere touching (or nearly) a box face.
                self.features.push("sphere tangent to a face");
                let (a, b, d) = (
                    uniform(&mut self.rng, 0.1, 0.3),
                    uniform(&mut self.rng, 0.1, 0.3),
                    uniform(&mut self.rng, 0.05, 0.2),
                );
                let r = uniform(&mut self.rng, 0.03, 0.2);
                let gap = gaps[below(&mut self.rng, gaps.len())];
                let f = self.random_frame(centre);
                let bx = box_sdf([&f.0[0], &f.0[1], &f.0[2]], [a, b, d]);
                let off = DVec3::new(
                    uniform(&mut self.rng, -0.5, 0.5) * a,
                    uniform(&mut self.rng, -0.5, 0.5) * b,
                    d + r + gap,
                );
                let c = f.shifted(off);
                let sp = format!("sqrt({}^2 + {}^2 + {}^2) - {}", c[0], c[1], c[2], num(r));
                let e = format!("min({}, {})", self.bind("t", bx), self.bind("t", sp));
                Part {
                    name: self.bind("n", e),
                    centre,
                    radius: a.max(b) + r,
                }
            }
            2 => {
                // Two boxes sharing a face plane, joined or cut.
                self.features.push("coincident faces");
                let dy = |rng: &mut Rng| (1 + below(rng, 6)) as f64 / 32.0;
                let (a, b, d) = (dy(&mut self.rng), dy(&mut self.rng), dy(&mut self.rng));
                let (a2, b2, d2) = (dy(&mut self.rng), dy(&mut self.rng), dy(&mut self.rng));
                let f = self.random_frame(centre);
                let b1 = box_sdf([&f.0[0], &f.0[1], &f.0[2]], [a, b, d]);
                // The second box's face u = a − 2·a2·inside lies on the
                // first's face u = a: outside it (union) or inside it
                // (a notch).
                let inside = chance(&mut self.rng, 0.5);
                let shift = if inside { a - a2 } else { a + a2 };
                let lateral = if chance(&mut self.rng, 0.5) {
                    0.0
                } else {
                    b - b2
                };
                let c = f.shifted(DVec3::new(shift, lateral, 0.0));
                let b2e = box_sdf([&c[0], &c[1], &c[2]], [a2, b2, d2]);
                let (p, q) = (self.bind("t", b1), self.bind("t", b2e));
                let e = match below(&mut self.rng, 3) {
                    0 => format!("min({p}, {q})"),
                    1 => format!("max({p}, -({q}))"),
                    _ => format!("max({p}, {q})"),
                };
                Part {
                    name: self.bind("n", e),
                    centre,
                    radius: a + 2.0 * a2,
                }
            }
            3 => {
                // A wall about one level-7 cell thick: a shell opened by
                // a plane.
                self.features.push("thin wall");
                let t = 2.0 / 128.0 * uniform(&mut self.rng, 0.4, 1.5);
                let r = uniform(&mut self.rng, 0.15, 0.35);
                let f = self.random_frame(centre);
                let [u, v, w] = &f.0;
                let outer = if chance(&mut self.rng, 0.5) {
                    format!("sqrt({u}^2 + {v}^2 + {w}^2) - {}", num(r))
                } else {
                    format!(
                        "max(abs({u}) - {}, abs({v}) - {}, abs({w}) - {})",
                        num(r),
                        num(0.8 * r),
                        num(0.6 * r)
                    )
                };
                let o = self.bind("t", outer);
                let e = format!(
                    "max({o}, -({o} + {}), {w} - {})",
                    num(t),
                    num(uniform(&mut self.rng, -0.5, 0.5) * r)
                );
                Part {
                    name: self.bind("n", e),
                    centre,
                    radius: r,
                }
            }
            4 => {
                // A shape cut by the domain boundary.
                self.features.push("cut by the domain");
                let mut c = DVec3::new(
                    uniform(&mut self.rng, -0.6, 0.6),
                    uniform(&mut self.rng, -0.6, 0.6),
                    uniform(&mut self.rng, -0.6, 0.6),
                );
                let s = uniform(&mut self.rng, 0.1, 0.35);
                for k in 0..3 {
                    if k == 0 || chance(&mut self.rng, 0.3) {
                        let side = if chance(&mut self.rng, 0.5) {
                            1.0
                        } else {
                            -1.0
                        };
                        c[k] = side * (1.0 - s * uniform(&mut self.rng, -0.3, 0.9));
                    }
                }
                let p = SOLIDS[below(&mut self.rng, SOLIDS.len())];
                self.placed("n", p, c, s)
            }
            5 => {
                // An axis-aligned box whose faces lie on octree planes
                // (f = 0 exactly at cell corners).
                self.features.push("faces on octree planes");
                let g = |rng: &mut Rng| (below(rng, 17) as f64 - 8.0) / 16.0;
                let (x0, y0, z0) = (g(&mut self.rng), g(&mut self.rng), g(&mut self.rng));
                let h = |rng: &mut Rng| (1 + below(rng, 4)) as f64 / 16.0;
                let (a, b, d) = (h(&mut self.rng), h(&mut self.rng), h(&mut self.rng));
                let e = box_sdf(
                    [&minus("x", x0), &minus("y", y0), &minus("z", z0)],
                    [a, b, d],
                );
                Part {
                    name: self.bind("n", e),
                    centre: DVec3::new(x0, y0, z0),
                    radius: a.max(b).max(d),
                }
            }
            6 => {
                // A feature smaller than a level-7 cell.
                self.features.push("tiny feature");
                let s = uniform(&mut self.rng, 0.002, 0.02);
                let p =
                    [Prim::Sphere, Prim::Torus, Prim::Box, Prim::Capsule][below(&mut self.rng, 4)];
                self.placed("n", p, centre, s)
            }
            _ => {
                // A thin slab or rod: a box one cell thick along an axis.
                self.features.push("thin plate");
                let t = 1.0 / 128.0 * uniform(&mut self.rng, 0.4, 1.5);
                let s = uniform(&mut self.rng, 0.1, 0.3);
                let f = self.random_frame(centre);
                let e = box_sdf(
                    [&f.0[0], &f.0[1], &f.0[2]],
                    [s, s * uniform(&mut self.rng, 0.3, 1.0), t],
                );
                Part {
                    name: self.bind("n", e),
                    centre,
                    radius: s,
                }
            }
        }
    }

    /// Joins two parts by a random operation.
    fn join(&mut self, a: &Part, b: &Part) -> Part {
        let (p, q) = (&a.name, &b.name);
        let k = uniform(&mut self.rng, 0.01, 0.08);
        let c = num(1.0 / (4.0 * k));
        let kk = num(k);
        let e = if chance(&mut self.rng, self.cfg.exotic) {
            match below(&mut self.rng, 5) {
                0 => {
                    self.features.push("exp smooth union");
                    let s = num(uniform(&mut self.rng, 10.0, 40.0));
                    format!("-log(exp(-{s}*{p}) + exp(-{s}*{q}))/{s}")
                }
                1 => {
                    self.features.push("exp smooth intersection");
                    let s = num(uniform(&mut self.rng, 10.0, 40.0));
                    format!("log(exp({s}*{p}) + exp({s}*{q}))/{s}")
                }
                2 => {
                    self.features.push("R-function union");
                    format!("{p} + {q} - sqrt({p}^2 + {q}^2)")
                }
                3 => {
                    self.features.push("rational blend");
                    format!("min({p}, {q}) - {kk}^2/(4*({kk} + abs({p} - {q})))")
                }
                _ => {
                    self.features.push("exp smooth difference");
                    let s = num(uniform(&mut self.rng, 10.0, 40.0));
                    format!("log(exp({s}*{p}) + exp(-{s}*{q}))/{s}")
                }
            }
        } else {
            match below(&mut self.rng, 9) {
                0..=2 => format!("min({p}, {q})"),
                3 => format!("max({p}, {q})"),
                4 | 5 => format!("max({p}, -({q}))"),
                6 => format!("min({p}, {q}) - max({kk} - abs({p} - {q}), 0)^2 * {c}"),
                7 => format!("max({p}, {q}) + max({kk} - abs({p} - {q}), 0)^2 * {c}"),
                _ => format!("max({p}, -({q})) + max({kk} - abs({p} + {q}), 0)^2 * {c}"),
            }
        };
        Part {
            name: self.bind("j", e),
            centre: (a.centre + b.centre) * 0.5,
            radius: (a.radius + b.radius + (a.centre - b.centre).length()) * 0.5,
        }
    }
}

impl Scene {
    /// The scene with its domain `[-1, 1]³` replaced by a box drawn from
    /// its seed (deterministic): each axis a random interval inside
    /// `[-1, 1]` between a tenth and all of its length, so that boxes
    /// up to 20:1 cut the scene's shapes at random places (session 41
    /// found faults that only box domains showed).
    pub fn in_random_box(mut self) -> Scene {
        let mut rng = Rng(self.seed ^ 0xB0C5_D0A1_u64);
        let axes: Vec<String> = (0..3)
            .map(|_| {
                let side = 2.0 * uniform(&mut rng, 0.1, 1.0);
                let lo = uniform(&mut rng, -1.0, 1.0 - side);
                format!("[{lo:.4}, {:.4}]", lo + side)
            })
            .collect();
        let line = format!("domain {};", axes.join(", "));
        self.source = self.source.replacen("domain [-1, 1]^3;", &line, 1);
        self.features.push("box domain");
        self
    }

    /// The scene of `seed` under `cfg` (deterministic).
    pub fn random(seed: u64, cfg: &Config) -> Scene {
        let mut rng = Rng(seed ^ 0x05EE_DC56_u64);
        let leaves = cfg.min_leaves + below(&mut rng, cfg.max_leaves - cfg.min_leaves + 1);
        let mut b = Builder {
            rng,
            cfg: *cfg,
            lets: Vec::new(),
            next: 0,
            features: Vec::new(),
        };
        let mut parts: Vec<Part> = Vec::new();
        for _ in 0..leaves {
            let near = if parts.is_empty() || chance(&mut b.rng, 0.2) {
                None
            } else {
                Some(parts[below(&mut b.rng, parts.len())].clone())
            };
            let p = if chance(&mut b.rng, cfg.nasty) {
                b.nasty(near.as_ref())
            } else {
                b.primitive(near.as_ref())
            };
            parts.push(p);
        }
        // Join random pairs until one part is left (random tree shapes).
        while parts.len() > 1 {
            let i = below(&mut b.rng, parts.len());
            let a = parts.swap_remove(i);
            let j = below(&mut b.rng, parts.len());
            let c = parts.swap_remove(j);
            let joined = b.join(&a, &c);
            parts.push(joined);
        }
        let top = parts.pop().expect("at least one leaf").name;
        let surface = if chance(&mut b.rng, cfg.exotic * 0.5) {
            b.features.push("divided by a polynomial");
            format!("{top} / (1 + 0.5*(x^2 + y^2 + z^2))")
        } else {
            top
        };
        let mut source = format!("# random CSG scene, seed {seed}\ndomain [-1, 1]^3;\n");
        for l in &b.lets {
            source += l;
            source.push('\n');
        }
        let _ = writeln!(source, "surface {surface};");
        b.features.sort();
        b.features.dedup();
        Scene {
            seed,
            source,
            features: b.features,
        }
    }
}

// ---------------------------------------------------------------- meshing

/// A square pyramid skew to the grid, its base corners cut by Ω's faces
/// x = 1 and y = 1 (`benches/peers/surfaces/pyramid4.iso`).
pub const PYRAMID: &str = "domain [-1, 1]^3; surface max(max(max(max((0.482979992*(x-0.013) + 0.174582522*(y+0.021) + 0.858050855*(z-0.3)), (-0.533379178*(x-0.013) + 0.504222365*(y+0.021) + 0.679166003*(z-0.3))), (-0.798169519*(x-0.013) + -0.492399999*(y+0.021) + 0.347084514*(z-0.3))), (0.218189650*(x-0.013) + -0.822039842*(y+0.021) + 0.525969366*(z-0.3))), (0.245173929*(x-0.013) + 0.247218111*(y+0.021) + -0.937428904*(z-0.3) - 0.8));";

/// A rotated box: `benches/peers/surfaces/box_blob.iso` moved 27 cells of
/// level 8 along x, so that the sample of its blob there (session 51)
/// lies in a leaf against the plane x = 0, a seam at every brick level.
pub const ROTATED_BOX: &str = "domain [-1, 1]^3; surface max(max(abs((0.645414188*(x-0.1625655) + -0.744459803*(y--0.001645) + 0.170938958*(z-0.010641))) - 0.32125, abs((0.397746704*(x-0.1625655) + 0.136503231*(y--0.001645) + -0.907284094*(z-0.010641))) - 0.47288), abs((0.652102818*(x-0.1625655) + 0.653564434*(y--0.001645) + 0.384207555*(z-0.010641))) - 0.35574);";

/// The domain of every scene.
pub const DOMAIN: Bounds = Bounds {
    lo: [-1.0; 3],
    hi: [1.0; 3],
};

/// Mesher options at `level`: the defaults (smoothing and creases on), or
/// with `plain` no smoothing and no creases (the extraction alone).
pub fn options(level: u8, plain: bool) -> MeshOptions {
    let mut o = MeshOptions {
        octree: OctreeOptions {
            max_level: level,
            ..OctreeOptions::default()
        },
        ..MeshOptions::default()
    };
    if plain {
        o.smooth = 0;
        o.creases = false;
    }
    o
}

/// One broken rule of [`check_mesh`].
#[derive(Clone, Debug)]
pub struct Failure {
    /// The rule: `manifold`, `oriented`, `outward`, `on surface`,
    /// `in domain`, `degenerate`, `duplicated` or `reference`.
    pub check: &'static str,
    /// What was found, and where.
    pub detail: String,
}

/// What [`check_mesh`] found besides failures.
#[derive(Clone, Debug, Default)]
pub struct Outcome {
    /// The broken rules.
    pub failures: Vec<Failure>,
    /// The report said `guaranteed`.
    pub guaranteed: bool,
    /// Guaranteed, and the reference was compared (and agreed or was
    /// unresolved).
    pub compared: bool,
    /// Guaranteed, but the two references disagreed with each other.
    pub unresolved: bool,
    /// Pairs of vertices at the same position where two sheets touch
    /// (allowed by SPEC §3).
    pub touching_duplicates: usize,
}

/// The vertices of `mesh` outside the closed box `domain`, with their
/// indices.
pub fn outside(mesh: &Mesh, domain: &Bounds) -> Vec<(usize, DVec3)> {
    (mesh.positions.iter().enumerate())
        .filter(|(_, p)| !domain.contains(p.to_array()))
        .map(|(i, p)| (i, *p))
        .collect()
}

/// Compiles `source` (panics with the diagnostics if it does not compile).
pub fn compile(source: &str, file: &str) -> Surface {
    Surface::compile(source, file, &isoc::CompileOptions::default())
        .unwrap_or_else(|e| panic!("{}\n{source}", e.render()))
}

/// Meshes `s` at `level` ([`options`]) and checks the mesh
/// ([`check_mesh`]).
pub fn mesh_and_check(s: &Surface, level: u8, plain: bool, reference: bool) -> Outcome {
    let opts = options(level, plain);
    let (mesh, report) = mesher::mesh(s, &opts, &|_| {});
    let domain = opts.domain.unwrap_or(s.domain);
    check_mesh(s, &mesh, &report, &opts, domain, reference)
}

/// Tolerance of "on the surface", in finest cells times `|∇f|`.
pub const ON_SURFACE: f64 = 1e-6;

/// The vertices whose normal faces into the solid (`f` a step `h` along it
/// below `f` a step against it) and against their fan (the sum of their
/// triangles' area vectors), more than 120° off it: at a kink where two
/// CSG sides tie exactly at the vertex (a face two primitives share), the
/// gradient there may be the inner side's, opposite the face, and it
/// misleads every stage that reads normals. Not part of [`check_mesh`]:
/// at a sharp crease a one-sided gradient may lie more than 90° off a
/// lopsided fan (colonnade.vm at level 6: 94° and 104°), and on a ledge
/// narrower than a cell the fan does not follow the surface at all (a
/// vertex on colonnade.vm's ledge a third of a cell wide, at level 6, has
/// the ledge's outward normal 136° off its fan).
pub fn inward_normals_against_fans(s: &Surface, mesh: &Mesh, h: f64) -> Vec<usize> {
    let fan = fan_normals(mesh);
    let f = |q: DVec3| s.point([q.x, q.y, q.z, 0.0]);
    (0..mesh.positions.len())
        .filter(|&i| {
            let (p, fan) = (mesh.positions[i], fan[i].normalize_or_zero());
            mesh.normals
                .get(i)
                .is_some_and(|&n| n.dot(fan) < -0.5 && f(p + h * n) <= f(p - h * n))
        })
        .collect()
}

/// Shortest finest-cell side of `opts` over `domain`.
fn finest_cell(opts: &MeshOptions, domain: &Bounds) -> f64 {
    (0..3)
        .map(|k| (domain.hi[k] - domain.lo[k]) / f64::from(1u32 << opts.octree.max_level))
        .fold(f64::INFINITY, f64::min)
}

/// Checks one mesh of `s` made with `opts` (see the module doc); with
/// `reference`, compares a guaranteed mesh's topology with [`reference`].
pub fn check_mesh(
    s: &Surface,
    mesh: &Mesh,
    report: &MeshReport,
    opts: &MeshOptions,
    domain: Bounds,
    reference: bool,
) -> Outcome {
    let mut out = Outcome {
        guaranteed: report.guaranteed,
        ..Outcome::default()
    };
    let mut failures = Vec::new();
    let mut fail = |check: &'static str, detail: String| failures.push(Failure { check, detail });
    let h = finest_cell(opts, &domain);
    let topo = topology::analyze_in(mesh, Some(&domain));
    // The genera of equally large components come in no fixed order.
    let sorted = |t: &topology::Topology| {
        let mut t = t.clone();
        t.genus.sort();
        t
    };
    if sorted(&topo) != sorted(&report.topology) {
        fail(
            "manifold",
            format!(
                "the report's topology {:?} is not the mesh's {topo:?}",
                report.topology
            ),
        );
    }
    if !topo.manifold() {
        fail(
            "manifold",
            format!(
                "{} edge(s) used 3+ times, {} open edge(s) off ∂Ω, {} bow-tie vertex(es): {}",
                topo.nonmanifold_edges,
                topo.open_edges,
                topo.nonmanifold_vertices,
                bad_edge_sites(s, mesh, opts, &domain)
            ),
        );
    }
    if topo.misoriented_edges > 0 {
        fail(
            "oriented",
            format!(
                "{} edge(s) traversed twice the same way",
                topo.misoriented_edges
            ),
        );
    }
    // Degenerate triangles.
    let repeated = mesh
        .triangles
        .iter()
        .filter(|t| t[0] == t[1] || t[1] == t[2] || t[2] == t[0])
        .count();
    let zero = mesh
        .triangles
        .iter()
        .filter(|t| mesh.face_normal(**t).length_squared() == 0.0)
        .count();
    if repeated + zero > 0 {
        fail(
            "degenerate",
            format!("{repeated} triangle(s) with a repeated index, {zero} of zero area"),
        );
    }
    // Vertices on the surface.
    let mut off = Vec::new();
    for (i, p) in mesh.positions.iter().enumerate() {
        let (v, g) = s.point_grad([p.x, p.y, p.z, 0.0]);
        let g = DVec3::from_array(g).length();
        let ok = if g.is_finite() && g > 0.0 {
            v.abs() <= ON_SURFACE * h * g
        } else {
            zero_near(s, *p, h / 64.0, ON_SURFACE * h)
        };
        if !ok {
            off.push((i, *p, v, g));
        }
    }
    if !off.is_empty() {
        let (i, p, v, g) = off[0];
        fail(
            "on surface",
            format!(
                "{} vertex(es) off the surface, e.g. vertex {i} at {p}: f = {v:e}, |∇f| = {g:e} (h = {h:e})",
                off.len()
            ),
        );
    }
    // Vertices in Ω: the surface is only defined there.
    let outside = outside(mesh, &domain);
    if let Some((i, p)) = outside.first() {
        fail(
            "in domain",
            format!(
                "{} vertex(es) outside Ω, e.g. vertex {i} at {p}",
                outside.len()
            ),
        );
    }
    // Outward: area-weighted agreement of face normals with ∇f at the
    // centroids, per component and over the mesh.
    let comp = topology::triangle_components(mesh);
    let ncomp = comp.iter().map(|&c| c as usize + 1).max().unwrap_or(0);
    let mut agree = vec![(0.0f64, 0.0f64); ncomp];
    for (t, &c) in mesh.triangles.iter().zip(&comp) {
        let n = mesh.face_normal(*t);
        let area = n.length();
        let centroid = t.iter().map(|&i| mesh.positions[i as usize]).sum::<DVec3>() / 3.0;
        let (_, g) = s.point_grad([centroid.x, centroid.y, centroid.z, 0.0]);
        let g = DVec3::from_array(g);
        if !(g.is_finite() && area > 0.0) || g.length_squared() == 0.0 {
            continue;
        }
        // Only decisive triangles vote: one nearly along ∇f is a chord
        // across a feature thinner than a cell, not a flip.
        let cos = n.dot(g) / (area * g.length());
        if cos.abs() < DECISIVE {
            continue;
        }
        let e = &mut agree[c as usize];
        e.1 += area;
        if cos > 0.0 {
            e.0 += area;
        }
    }
    let mut size = vec![0usize; ncomp];
    for &c in &comp {
        size[c as usize] += 1;
    }
    let judged = |c: usize| size[c] >= JUDGED && agree[c].1 > 0.0;
    let flipped: Vec<usize> = (0..ncomp)
        .filter(|&c| judged(c) && agree[c].0 < FLIPPED * agree[c].1)
        .collect();
    let (good, all) = (0..ncomp)
        .filter(|&c| judged(c))
        .fold((0.0, 0.0), |(g, a), c| (g + agree[c].0, a + agree[c].1));
    // Below the aggregate share, the mesh is judged by its winding numbers
    // instead (thin features do not confuse them).
    let open = topo.boundary_edges > 0;
    let winding = (good < OUTWARD * all).then(|| winding_mismatches(s, mesh, open, &domain, h));
    let aggregate_fails = winding.is_some_and(|w| w.mismatched > 0 || w.sampled == 0);
    if !flipped.is_empty() || aggregate_fails {
        fail(
            "outward",
            format!(
                "{} of {ncomp} component(s) face −∇f by area{}; {:.4} of the decisive area faces +∇f{}",
                flipped.len(),
                flipped
                    .first()
                    .map(|&c| {
                        let tris = comp.iter().filter(|&&k| k as usize == c).count();
                        let first = comp.iter().position(|&k| k as usize == c).unwrap_or(0);
                        let at = mesh.positions[mesh.triangles[first][0] as usize];
                        format!(
                            " (e.g. component {c}: {tris} triangle(s), area {:.3e}, {:.3} of it facing +∇f, near {at:.4})",
                            agree[c].1,
                            agree[c].0 / agree[c].1
                        )
                    })
                    .unwrap_or_default(),
                if all > 0.0 { good / all } else { 1.0 },
                winding.map(|w| format!("; the winding number disagrees with the sign of f at {} of {} points far from the surface, e.g. {:.4}", w.mismatched, w.sampled, w.first)).unwrap_or_default()
            ),
        );
    }
    // Duplicated vertices: allowed only where two sheets touch, i.e. the
    // two fans face opposite ways.
    let fan = fan_normals(mesh);
    let mut by_pos: Vec<([u64; 3], usize)> = mesh
        .positions
        .iter()
        .enumerate()
        .map(|(i, p)| (p.to_array().map(|c| (c + 0.0).to_bits()), i))
        .collect();
    by_pos.sort_unstable();
    let mut same_sheet = Vec::new();
    for w in by_pos.windows(2) {
        if w[0].0 == w[1].0 {
            let (a, b) = (w[0].1, w[1].1);
            if fan[a].dot(fan[b]) < 0.0 {
                out.touching_duplicates += 1;
            } else if fan[a] != DVec3::ZERO && fan[b] != DVec3::ZERO {
                same_sheet.push((a, b));
            }
        }
    }
    if !same_sheet.is_empty() {
        let (a, b) = same_sheet[0];
        fail(
            "duplicated",
            format!(
                "{} pair(s) of vertices at one position on one sheet, e.g. {a} and {b} at {}",
                same_sheet.len(),
                mesh.positions[a]
            ),
        );
    }
    // Guaranteed topology against the reference.
    if reference && report.guaranteed {
        out.compared = true;
        let level = opts.octree.max_level;
        let got = shape_of(&topo);
        let n1 = reference_grid(level);
        let r1 = shape_of(&self::reference(s, &domain, n1));
        if r1 != got {
            let n2 = n1 * 3 / 2 + 1;
            let r2 = shape_of(&self::reference(s, &domain, n2));
            if r2 != r1 {
                out.unresolved = true;
            } else {
                fail(
                    "reference",
                    format!(
                        "guaranteed, but the mesh has (components, genera) {got:?} and the references at {n1}³ and {n2}³ cells {r1:?}"
                    ),
                );
            }
        }
    }
    out.failures = failures;
    out
}

/// Where a mesh's winding number disagrees with the sign of `f`
/// ([`winding_mismatches`]).
#[derive(Clone, Copy, Debug)]
pub struct Winding {
    /// Points where it disagrees.
    pub mismatched: usize,
    /// Points judged.
    pub sampled: usize,
    /// The first point where it disagrees.
    pub first: DVec3,
}

/// The generalised winding number of a closed, consistently oriented mesh
/// (the sum of its triangles' signed solid angles over 4π, Van Oosterom &
/// Strackee's formula) is 1 inside the region it bounds and 0 outside when
/// its normals face out, −1 inside when they face in, whatever the shape:
/// an exact orientation oracle where the centroid vote of "outward" meets
/// features thinner than a cell. A mesh cut by the domain is closed by its
/// cap, the part of ∂Ω where `f < 0` (normals out of Ω), whose solid angle
/// is summed over a `CAP_PIXELS²` grid on each face of the domain.
///
/// Judged at points `WINDING_MARGIN` finest cells `h` off the surface on
/// either side of vertices spread over every component (at most
/// `WINDING_POINTS` in all), kept where `f` has the side's sign, the
/// first-order distance `|f| / ‖∇f‖` is still over half that (not across
/// a wall thinner than the step), and, for an open mesh, `CAP_MARGIN` of
/// the domain's side inside it (where the cap's pixels are fine enough):
/// the winding number there must be 1 where `f < 0` and 0 where `f > 0`.
/// `open`: the mesh has boundary edges (on ∂Ω).
pub fn winding_mismatches(
    s: &Surface,
    mesh: &Mesh,
    open: bool,
    domain: &Bounds,
    h: f64,
) -> Winding {
    let mut w = Winding {
        mismatched: 0,
        sampled: 0,
        first: DVec3::ZERO,
    };
    let grad = |p: DVec3| {
        let (v, g) = s.point_grad([p.x, p.y, p.z, 0.0]);
        (v, DVec3::from(g))
    };
    let cap = if open { cap(s, domain) } else { Vec::new() };
    let (lo, hi) = (DVec3::from(domain.lo), DVec3::from(domain.hi));
    let inset = CAP_MARGIN * (hi - lo).max_element();
    let inside = |p: DVec3| !open || (p.cmpge(lo + inset).all() && p.cmple(hi - inset).all());
    let step = WINDING_MARGIN * h;
    for (at, side) in winding_seeds(mesh).into_iter().flat_map(|v| {
        let (_, g) = grad(v);
        [-1.0, 1.0].map(|side| (v + side * step * g.normalize_or_zero(), side))
    }) {
        let (v, g) = grad(at);
        let g = g.length();
        if !(v.is_finite() && g.is_finite() && v * side > 0.5 * step * g && inside(at)) {
            continue;
        }
        let want = if v < 0.0 { 1.0 } else { 0.0 };
        let cap_angle: f64 = cap
            .iter()
            .map(|&(c, n)| n.dot(c - at) / (c - at).length().powi(3))
            .sum();
        let winding = winding_number(mesh, at) + cap_angle / (4.0 * std::f64::consts::PI);
        w.sampled += 1;
        if winding.round() != want {
            if w.mismatched == 0 {
                w.first = at;
            }
            w.mismatched += 1;
        }
    }
    w
}

/// The cap of a mesh cut by the domain: the pixels of a `CAP_PIXELS²` grid
/// on each face of the domain whose centre has `f < 0`, each as its centre
/// and its area times the face's outward unit normal.
fn cap(s: &Surface, domain: &Bounds) -> Vec<(DVec3, DVec3)> {
    let (lo, hi) = (DVec3::from(domain.lo), DVec3::from(domain.hi));
    let size = hi - lo;
    let n = CAP_PIXELS;
    let mut out = Vec::new();
    for axis in 0..3 {
        let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
        let area = size[u] * size[v] / (n * n) as f64;
        for (side, at) in [(-1.0, lo[axis]), (1.0, hi[axis])] {
            for k in 0..n * n {
                let mut c = DVec3::ZERO;
                c[axis] = at;
                c[u] = lo[u] + ((k % n) as f64 + 0.5) / n as f64 * size[u];
                c[v] = lo[v] + ((k / n) as f64 + 0.5) / n as f64 * size[v];
                if s.point([c.x, c.y, c.z, 0.0]) < 0.0 {
                    let mut normal = DVec3::ZERO;
                    normal[axis] = side * area;
                    out.push((c, normal));
                }
            }
        }
    }
    out
}

/// Pixels per side of each domain face in [`cap`].
const CAP_PIXELS: usize = 160;

/// Least distance from the domain's faces, as a share of its largest
/// side, of a point [`winding_mismatches`] judges on an open mesh.
const CAP_MARGIN: f64 = 0.03;

/// Points of the mesh (triangles' corners and centroids) spread over
/// every component of `mesh`: at most `WINDING_POINTS / 2` in all, at
/// least two a component. A component of few triangles (a plane, cut by
/// the domain into a few large ones) gives its triangles' edge midpoints
/// and three inner points as well, so that it is sampled as densely.
fn winding_seeds(mesh: &Mesh) -> Vec<DVec3> {
    let comp = topology::triangle_components(mesh);
    let ncomp = comp.iter().map(|&c| c as usize + 1).max().unwrap_or(0);
    let mut of: Vec<Vec<usize>> = vec![Vec::new(); ncomp];
    for (t, &c) in comp.iter().enumerate() {
        of[c as usize].push(t);
    }
    let per = (WINDING_POINTS / 2 / ncomp.max(1)).max(2);
    // Barycentric weights: corners and centroid first (the four a
    // triangle gives where the component has enough triangles).
    const WEIGHTS: [[f64; 3]; 10] = [
        [1.0, 0.0, 0.0],
        [1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.5, 0.5, 0.0],
        [0.0, 0.5, 0.5],
        [0.5, 0.0, 0.5],
        [4.0 / 6.0, 1.0 / 6.0, 1.0 / 6.0],
        [1.0 / 6.0, 4.0 / 6.0, 1.0 / 6.0],
        [1.0 / 6.0, 1.0 / 6.0, 4.0 / 6.0],
    ];
    let point = |t: usize, w: [f64; 3]| {
        let q = mesh.triangles[t].map(|v| mesh.positions[v as usize]);
        q[0] * w[0] + q[1] * w[1] + q[2] * w[2]
    };
    of.iter()
        .flat_map(|tris| {
            let each = if 4 * tris.len() >= per {
                4
            } else {
                WEIGHTS.len()
            };
            let n = each * tris.len();
            let stride = n.div_ceil(per).max(1);
            (0..n)
                .step_by(stride)
                .map(move |i| point(tris[i / each], WEIGHTS[i % each]))
        })
        .collect()
}

/// The generalised winding number of `mesh` at `p`.
fn winding_number(mesh: &Mesh, p: DVec3) -> f64 {
    let angle: f64 = mesh
        .triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|k| mesh.positions[k as usize] - p);
            let (la, lb, lc) = (a.length(), b.length(), c.length());
            let den = la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb;
            2.0 * a.dot(b.cross(c)).atan2(den)
        })
        .sum();
    angle / (4.0 * std::f64::consts::PI)
}

/// Most points [`winding_mismatches`] judges.
const WINDING_POINTS: usize = 256;

/// Step off the surface, in finest cells, to a point
/// [`winding_mismatches`] judges.
const WINDING_MARGIN: f64 = 3.0;

/// Share of the decisive area facing `+∇f` below which a mesh fails
/// "outward" (unless its winding numbers agree with the sign of `f`,
/// [`winding_mismatches`]).
pub const OUTWARD: f64 = 0.9;

/// Fewest triangles of a component judged "outward": a blob of a few
/// triangles around a feature smaller than a cell (a capsule 0.008 wide,
/// a pocket of a thin wall) has chords for faces, and the gradients at
/// their centroids say nothing of its orientation (seen: 8–16 triangles,
/// 0–60 % of their area facing `+∇f`). A flipped component that small
/// goes unseen.
pub const JUDGED: usize = 24;

/// A triangle votes on "outward" only when the cosine between its normal
/// and ∇f at its centroid is at least this in magnitude. Triangles of a
/// feature thinner than a cell (a plate, a lens where two shapes barely
/// overlap) cut across it, their normals nearly perpendicular to ∇f: seen
/// in 40 of 1,300 scenes at level 7, with 0.35–0.9 of the whole area
/// facing `+∇f` and no component flipped.
pub const DECISIVE: f64 = 0.5;

/// Share of a component's area facing `+∇f` below which the component is
/// flipped. Not 0.5: a blob of a few triangles in an unresolved thin wall
/// or at a crease corner has its centroids' gradients pointing every way
/// (seen: 10 triangles, 0.496 of the area facing `+∇f`); a flipped smooth
/// component has almost none.
pub const FLIPPED: f64 = 0.25;

/// Cells per axis of the first reference for a mesh at `level`.
pub fn reference_grid(level: u8) -> usize {
    // Finer than the mesh's finest cells, and not a power of two (no grid
    // plane on an octree plane).
    (2usize << level) + 1
}

/// Components and the sorted genera of a topology.
fn shape_of(t: &topology::Topology) -> (usize, Vec<Option<i64>>) {
    let mut g = t.genus.clone();
    g.sort();
    (t.components, g)
}

/// Whether `f` has a zero at `p` where its point gradient is not defined:
/// `f` changes sign (or is 0) within `r` of `p` along an axis, or `f(p)`
/// stands within `tol` of 0 measured by the steepest secant slope over
/// those samples (`|f(p)| · r / max |f(p ± r·e_k)|`): where the surface
/// touches zero without crossing it (tangent spheres), `f` keeps its sign
/// around a point of the zero set.
fn zero_near(s: &Surface, p: DVec3, r: f64, tol: f64) -> bool {
    let f = |q: DVec3| s.point([q.x, q.y, q.z, 0.0]);
    let v = f(p);
    if v == 0.0 {
        return true;
    }
    let around: Vec<f64> = (0..3)
        .flat_map(|k| {
            [-1.0, 1.0].map(|d| {
                let mut q = p;
                q[k] += d * r;
                f(q)
            })
        })
        .collect();
    let slope = around.iter().map(|w| (w - v).abs() / r).fold(0.0, f64::max);
    around.iter().any(|&w| w == 0.0 || (w < 0.0) != (v < 0.0)) || v.abs() <= tol * slope
}

/// Per vertex, the area-weighted normal of its fan (zero when unused).
fn fan_normals(mesh: &Mesh) -> Vec<DVec3> {
    let mut n = vec![DVec3::ZERO; mesh.positions.len()];
    for t in &mesh.triangles {
        let f = mesh.face_normal(*t);
        for &i in t {
            n[i as usize] += f;
        }
    }
    n
}

/// Where the bad edges are (up to four): the edge's midpoint, its uses,
/// whether its ends lie in ambiguous regions, the octree leaves around it
/// (their levels and kinds: a level transition shows as two levels), and
/// its distance to ∂Ω in finest cells.
pub fn bad_edge_sites(s: &Surface, mesh: &Mesh, opts: &MeshOptions, domain: &Bounds) -> String {
    let uses = super::edge_uses(mesh);
    let h = finest_cell(opts, domain);
    let on_face = |p: DVec3| {
        (0..3).any(|k| {
            (p[k] - domain.lo[k]).abs() <= 1e-6 * h || (p[k] - domain.hi[k]).abs() <= 1e-6 * h
        })
    };
    let mut bad: Vec<((u32, u32), usize)> = uses
        .into_iter()
        .filter(|&((a, b), n)| {
            n > 2
                || (n == 1
                    && !(on_face(mesh.positions[a as usize])
                        && on_face(mesh.positions[b as usize])))
        })
        .collect();
    bad.sort();
    let tree = Octree::build(s, *domain, &opts.octree, &|_, _| {});
    let mut text = String::new();
    for &((a, b), n) in bad.iter().take(4) {
        let (pa, pb) = (mesh.positions[a as usize], mesh.positions[b as usize]);
        let m = (pa + pb) * 0.5;
        let mut leaves: Vec<(u8, &'static str)> = Vec::new();
        for d in [
            DVec3::ZERO,
            DVec3::X,
            -DVec3::X,
            DVec3::Y,
            -DVec3::Y,
            DVec3::Z,
            -DVec3::Z,
        ] {
            if let Some(l) = tree.leaf_containing(m + d * (0.5 * h)) {
                let node = &tree.nodes[l];
                let kind = match node.leaf() {
                    Some(Leaf::Empty) => "empty",
                    Some(Leaf::Surface) => "surface",
                    Some(Leaf::Ambiguous) => "ambiguous",
                    Some(Leaf::Outside) => "outside",
                    None => "inner",
                };
                leaves.push((node.level, kind));
            }
        }
        leaves.sort();
        leaves.dedup();
        let to_boundary = (0..3)
            .map(|k| (m[k] - domain.lo[k]).min(domain.hi[k] - m[k]))
            .fold(f64::INFINITY, f64::min)
            / h;
        let _ = write!(
            text,
            "\n    edge {a}-{b} used {n}× at {m:.5}, ends ambiguous {}/{}, leaves around {leaves:?}, {to_boundary:.1} cells from ∂Ω",
            mesh.ambiguous[a as usize], mesh.ambiguous[b as usize]
        );
    }
    if bad.len() > 4 {
        let _ = write!(text, "\n    … {} more", bad.len() - 4);
    }
    text
}

// ---------------------------------------------------------------- reference

/// The Kuhn (Freudenthal) tetrahedra of the unit cube, as corner indices
/// (bit 0 = x, bit 1 = y, bit 2 = z): the paths 0 → 7 along the axes.
const KUHN: [[usize; 4]; 6] = [
    [0, 1, 3, 7],
    [0, 1, 5, 7],
    [0, 2, 3, 7],
    [0, 2, 6, 7],
    [0, 4, 5, 7],
    [0, 4, 6, 7],
];

/// An independent reference surface: marching tetrahedra (Kuhn
/// subdivision, consistent across cells, so a closed 2-manifold for the
/// sign pattern) over `n³` uniform cells of `domain`, on the point kernel's
/// signs (`f < 0` inside, NaN outside). Vertices are the midpoints of the
/// tetrahedra's edges: only the topology matters. Returns its
/// [`topology::analyze_in`] within the domain.
pub fn reference(s: &Surface, domain: &Bounds, n: usize) -> topology::Topology {
    let lo = DVec3::from_array(domain.lo);
    let step = (DVec3::from_array(domain.hi) - lo) / n as f64;
    let m = n + 1;
    let at = |i: usize, j: usize, k: usize| lo + step * DVec3::new(i as f64, j as f64, k as f64);
    // Inside flags of one z-slice of lattice points.
    let slice = |k: usize| -> Vec<bool> {
        let (mut xs, mut ys) = (Vec::with_capacity(m * m), Vec::with_capacity(m * m));
        for j in 0..m {
            for i in 0..m {
                let p = at(i, j, k);
                xs.push(p.x);
                ys.push(p.y);
            }
        }
        let zs = vec![at(0, 0, k).z; m * m];
        let mut out = vec![0.0; m * m];
        s.point_batch(&xs, &ys, &zs, 0.0, &mut out)
            .expect("batch lengths agree");
        out.iter().map(|&v| v < 0.0).collect()
    };
    let mut mesh = Mesh::default();
    let mut ids: HashMap<(u64, u64), u32> = HashMap::new();
    let key = |i: usize, j: usize, k: usize| (i + m * (j + m * k)) as u64;
    let mut below = slice(0);
    for k in 0..n {
        let above = slice(k + 1);
        for j in 0..n {
            for i in 0..n {
                let inside: [bool; 8] = std::array::from_fn(|c| {
                    let (di, dj, dk) = (c & 1, (c >> 1) & 1, (c >> 2) & 1);
                    let layer = if dk == 0 { &below } else { &above };
                    layer[(i + di) + m * (j + dj)]
                });
                if inside.iter().all(|&b| b) || inside.iter().all(|&b| !b) {
                    continue;
                }
                let corner = |c: usize| (i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1));
                for tet in KUHN {
                    let ins: Vec<usize> = tet.iter().copied().filter(|&c| inside[c]).collect();
                    let outs: Vec<usize> = tet.iter().copied().filter(|&c| !inside[c]).collect();
                    if ins.is_empty() || outs.is_empty() {
                        continue;
                    }
                    let mut vertex = |a: usize, b: usize, mesh: &mut Mesh| {
                        let (ca, cb) = (corner(a), corner(b));
                        let (ka, kb) = (key(ca.0, ca.1, ca.2), key(cb.0, cb.1, cb.2));
                        let kk = (ka.min(kb), ka.max(kb));
                        *ids.entry(kk).or_insert_with(|| {
                            let p = (at(ca.0, ca.1, ca.2) + at(cb.0, cb.1, cb.2)) * 0.5;
                            mesh.positions.push(p);
                            mesh.normals.push(DVec3::ZERO);
                            mesh.ambiguous.push(false);
                            (mesh.positions.len() - 1) as u32
                        })
                    };
                    let polygon: Vec<u32> = match (ins.len(), outs.len()) {
                        (1, 3) => outs.iter().map(|&o| vertex(ins[0], o, &mut mesh)).collect(),
                        (3, 1) => ins.iter().map(|&i| vertex(i, outs[0], &mut mesh)).collect(),
                        _ => vec![
                            vertex(ins[0], outs[0], &mut mesh),
                            vertex(ins[0], outs[1], &mut mesh),
                            vertex(ins[1], outs[1], &mut mesh),
                            vertex(ins[1], outs[0], &mut mesh),
                        ],
                    };
                    // Orient each triangle away from an inside corner.
                    let c_in = {
                        let c = corner(ins[0]);
                        at(c.0, c.1, c.2)
                    };
                    for w in 1..polygon.len() - 1 {
                        let mut t = [polygon[0], polygon[w], polygon[w + 1]];
                        let n = mesh.face_normal(t);
                        if n.dot(mesh.positions[t[0] as usize] - c_in) < 0.0 {
                            t.swap(1, 2);
                        }
                        mesh.triangles.push(t);
                    }
                }
            }
        }
        below = above;
    }
    topology::analyze_in(&mesh, Some(domain))
}

/// One scene's result line for failure messages: seed, level, variant,
/// the broken rules and the source.
pub fn describe(scene: &Scene, level: u8, plain: bool, failures: &[Failure]) -> String {
    let mut s = format!(
        "seed {} level {level} {}: features {:?}\n",
        scene.seed,
        if plain {
            "smooth 0, no creases"
        } else {
            "defaults"
        },
        scene.features
    );
    for f in failures {
        let _ = writeln!(s, "  [{}] {}", f.check, f.detail);
    }
    s + &scene.source
}
