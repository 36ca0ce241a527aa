//! Reference evaluators: simple, obviously correct interpreters over the IR
//! (`point`, `interval`, `grad`), the oracles that the JIT and the mesher are
//! tested against.

pub mod grad;
pub mod interval;
pub mod point;
