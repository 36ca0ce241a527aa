//! A compiled surface: its program, domain and evaluators. (in progress)

/// An axis-aligned box `[lo, hi]` in space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds {
    pub lo: [f64; 3],
    pub hi: [f64; 3],
}

/// Options of [`Surface::compile`].
#[derive(Clone, Debug, Default)]
pub struct CompileOptions {
    /// `--set NAME=VALUE` overrides of `param`s, in command-line order.
    pub params: Vec<(String, f64)>,
    /// `--domain`: replaces the file's `domain` (and makes it optional).
    pub domain: Option<Bounds>,
}

/// A compiled surface. (in progress)
pub struct Surface {}
