//! Helpers shared by the library's unit tests (the integration tests have
//! `tests/support`, which unit tests cannot reach).

/// A small deterministic generator (a 64-bit linear congruential one,
/// Knuth's MMIX constants) of uniform numbers.
pub(crate) struct Rng(u64);

impl Rng {
    /// A generator from a seed.
    pub(crate) fn new(seed: u64) -> Rng {
        Rng(seed)
    }

    /// The next number, uniform in `[0, 1)` (the state's top 53 bits).
    pub(crate) fn unit(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// `src` compiled as an `.iso` file (a test's own text: it must compile).
pub(crate) fn surface(src: &str) -> crate::Surface {
    crate::Surface::compile(src, "test.iso", &crate::CompileOptions::default())
        .unwrap_or_else(|e| panic!("{src}: {e}"))
}
