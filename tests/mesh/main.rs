//! The mesher: MC33 cells against the trilinear interpolant, the dual grid, root finding, meshes of known topology, triangle quality, the corpus.
//!
//! One test binary for the group (each binary links the whole crate);
//! the shared helpers are in `tests/support`.

#[macro_use]
#[allow(unused_macros)]
#[path = "../support/mod.rs"]
mod support;

mod adapt;
mod bricks;
mod coarsen;
mod corpus_mesh;
mod crease;
mod csg;
mod dual;
mod faithful;
mod mc33;
mod mesh;
mod quality;
mod roots;
