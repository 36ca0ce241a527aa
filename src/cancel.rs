//! Cancelling long work: a [`Cancel`] token is shared between the caller
//! and the stages it runs. Any clone may call [`Cancel::cancel`] (another
//! thread, a signal handler's poll loop, a GUI); the stages poll
//! [`Cancel::is_cancelled`] at their checkpoints — the octree before each
//! level and each batch of cells, the mesher between its stages — and stop
//! with [`Cancelled`]. Polling is one relaxed atomic load.
//!
//! ```
//! use isoc::cancel::Cancel;
//!
//! let token = Cancel::new();
//! let other = token.clone();
//! assert!(!token.is_cancelled());
//! other.cancel();
//! assert!(token.is_cancelled());
//! ```

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

/// A shared cancellation flag (cheap to clone; clones share the flag).
#[derive(Clone, Debug, Default)]
pub struct Cancel(Arc<AtomicBool>);

impl Cancel {
    /// A token not yet cancelled.
    pub fn new() -> Cancel {
        Cancel::default()
    }

    /// Asks every holder of the token to stop.
    pub fn cancel(&self) {
        self.0.store(true, Ordering::Relaxed);
    }

    /// Whether [`Cancel::cancel`] was called on any clone.
    pub fn is_cancelled(&self) -> bool {
        self.0.load(Ordering::Relaxed)
    }

    /// `Err(Cancelled)` once cancelled: `token.check()?` at a checkpoint.
    pub fn check(&self) -> Result<(), Cancelled> {
        if self.is_cancelled() {
            Err(Cancelled)
        } else {
            Ok(())
        }
    }
}

/// Runs `work` with a token nobody else holds: it cannot be cancelled, so
/// the result is `work`'s value (the uncancellable form of a
/// `…_cancellable` function).
pub fn uncancelled<T>(work: impl FnOnce(&Cancel) -> Result<T, Cancelled>) -> T {
    match work(&Cancel::new()) {
        Ok(value) => value,
        Err(Cancelled) => unreachable!("a token nobody holds is never cancelled"),
    }
}

/// The work was cancelled through its [`Cancel`] token; nothing was
/// produced.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Cancelled;

impl std::fmt::Display for Cancelled {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("cancelled")
    }
}

impl std::error::Error for Cancelled {}
