//! The reference interpreters: the shared backend suite, interval arithmetic against exact dyadic arithmetic, forward-mode AD, per-cell pruning.
//!
//! One test binary for the group (each binary links the whole crate);
//! the shared helpers are in `tests/support`.

#[macro_use]
#[allow(unused_macros)]
#[path = "../support/mod.rs"]
mod support;

mod eval;
mod grad;
mod interval;
