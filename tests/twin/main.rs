//! Twinned meshes on moving surfaces whose truth is known.
//!
//! One test binary for the group (each binary links the whole crate);
//! the shared helpers are in `tests/support`.

#[macro_use]
#[allow(unused_macros)]
#[path = "../support/mod.rs"]
mod support;

mod twin;
