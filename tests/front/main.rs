//! The front end: lexing, parsing, resolution and lowering, diagnostics, the IR text form and simplification, deep inputs, and the corpus's `# expect:` lines by brute-force sampling.
//!
//! One test binary for the group (each binary links the whole crate);
//! the shared helpers are in `tests/support`.

#[macro_use]
#[allow(unused_macros)]
#[path = "../support/mod.rs"]
mod support;

mod corpus;
mod errors;
mod ir;
mod reprint;
mod roundtrip;
mod simplify;
mod stack;
mod syntax;
