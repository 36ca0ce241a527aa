//! The Cranelift kernels against independent oracles and the reference interpreters.
//!
//! One test binary for the group (each binary links the whole crate);
//! the shared helpers are in `tests/support`.

#[macro_use]
#[allow(unused_macros)]
#[path = "../support/mod.rs"]
mod support;

mod jit;
mod jit_corpus;
mod jit_vs_eval;
mod pgrad;
