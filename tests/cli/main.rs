//! The `isoc` binary (SPEC §2) and the mesh writers (SPEC §3).
//!
//! One test binary for the group (each binary links the whole crate);
//! the shared helpers are in `tests/support`.

#[macro_use]
#[allow(unused_macros)]
#[path = "../support/mod.rs"]
mod support;

mod bricks;
mod cli;
mod io;
mod layout;
mod threemf;
