//! The mesher: MC33 cells against the trilinear interpolant, the dual grid, root finding, meshes of known topology, triangle quality, the corpus.
//!
//! One test binary for the group (each binary links the whole crate);
//! the shared helpers are in `tests/support`.

#[macro_use]
#[allow(dead_code, unused_macros)]
#[path = "../support/mod.rs"]
mod support;

mod mesh;
mod dual;
mod mc33;
mod roots;
mod quality;
mod corpus_mesh;
