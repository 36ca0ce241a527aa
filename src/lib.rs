//! isoc — a compiler and robust adaptive mesher for implicit surfaces.
//!
//! The modules follow the pipeline:
//!
//! ```text
//! source ──syntax──▶ AST ──syntax::lower──▶ ir::Program ──▶ eval (reference interpreters)
//!                                                       └──▶ jit (Cranelift kernels) ──▶ surface
//!
//! surface ──octree──▶ dual ──polygonize──▶ mesh (robust adaptive mesher) ──▶ io
//! surface(t) ──twin──▶ mechanical + geometric meshes per frame (`isoc animate`)
//! ```
//!
//! The library never prints and never exits: every failure is a typed value
//! ([`Error`]). The `isoc` binary ([`cli`]) is a thin layer over it.

pub mod cli;
pub mod dual;
pub mod error;
pub mod eval;
pub mod interval;
pub mod io;
pub mod ir;
pub mod jit;
pub mod mesh;
pub mod octree;
pub mod polygonize;
pub mod surface;
pub mod syntax;
pub mod twin;

pub use error::Error;
pub use interval::Interval;
pub use surface::{Bounds, CompileOptions, Surface};
