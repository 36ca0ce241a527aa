//! isoc — a compiler and robust adaptive mesher for implicit surfaces.
//!
//! The modules follow the pipeline; every arrow points down it:
//!
//! ```text
//! source ──syntax──▶ ir::Program ──▶ eval (reference interpreters)
//!                               └──▶ jit (Cranelift kernels) ──▶ surface (Surface)
//!
//! surface ──octree──▶ dual ──polygonize──▶ mesh (Mesh, topology, quality)
//!        (roots: points on f = 0)      └──▶ mesher (end to end, smoothing) ──▶ io
//! surface(t) ──twin──▶ mechanical + geometric meshes per frame
//! ```
//!
//! `geometry` (the box type), `interval` (interval arithmetic), `error`
//! (the union of every stage's error), `cancel` (stopping long work) and
//! `parallel` (the thread the stages' parallel work starts from) sit
//! beside the pipeline.
//!
//! # Use as a library
//!
//! Compile a sphere, evaluate it at a point and over a box, mesh it at
//! octree level 4 and check that the mesh is a closed genus-0 surface:
//!
//! ```
//! use isoc::{CompileOptions, Interval, MeshOptions, OctreeOptions, Surface};
//!
//! let sphere = Surface::compile(
//!     "domain [-1.5, 1.5]^3; surface x^2 + y^2 + z^2 = 1;",
//!     "sphere.iso",
//!     &CompileOptions::default(),
//! )?;
//! // The point kernel (f64): f = x² + y² + z² − 1.
//! assert_eq!(sphere.point([1.0, 0.0, 0.0, 0.0]), 0.0);
//! // An enclosure of f over a box, outward rounded: no surface in it.
//! let side = Interval { lo: 1.0, hi: 1.5 };
//! let e = sphere.interval([side, side, side, Interval::point(0.0)]);
//! assert!(e.defined && e.iv.lo > 0.0 && e.iv.lo <= 2.0);
//! // The robust mesher, at most 4 octree levels.
//! let opts = MeshOptions {
//!     octree: OctreeOptions { max_level: 4, ..OctreeOptions::default() },
//!     ..MeshOptions::default()
//! };
//! let (mesh, report) = isoc::mesher::mesh(&sphere, &opts, &|_stage| {});
//! assert!(report.topology.watertight);
//! assert_eq!(report.topology.genus, vec![Some(0)]);
//! assert_eq!(report.triangles, mesh.triangles.len());
//! // Write it (PLY, OBJ, STL, GLB or 3MF by the extension).
//! let path = std::env::temp_dir().join("isoc_doc_sphere.ply");
//! isoc::io::write_file(&mesh, &path)?;
//! # std::fs::remove_file(&path).ok();
//! # Ok::<(), isoc::Error>(())
//! ```
//!
//! The library never prints, exits or reads the environment: every failure
//! is a typed value ([`Error`], wrapping each stage's own error type). The
//! `isoc` binary (`src/main.rs`, behind the default `cli` feature) is a thin
//! layer over it; embedders can depend on isoc with
//! `default-features = false`, which leaves out clap and indicatif.

#![warn(missing_docs)]
#![deny(clippy::print_stdout, clippy::print_stderr)]

pub mod cancel;
pub mod dual;
pub mod error;
pub mod eval;
pub mod geometry;
pub mod interval;
pub mod io;
pub mod ir;
pub mod jit;
pub mod mesh;
pub mod mesher;
pub mod octree;
pub mod parallel;
pub mod polygonize;
pub mod roots;
pub mod surface;
pub mod syntax;
pub mod twin;

#[cfg(test)]
mod testing;

pub use cancel::{Cancel, Cancelled};
pub use error::Error;
pub use geometry::Bounds;
pub use interval::{DecInterval, Interval};
pub use mesh::Mesh;
pub use mesher::{MeshOptions, MeshReport};
pub use octree::OctreeOptions;
pub use surface::{CompileError, Surface};
pub use syntax::CompileOptions;
pub use twin::{FrameReport, Tracker, TwinOptions};
