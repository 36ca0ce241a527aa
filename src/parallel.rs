//! Where the library's parallel work runs: on a thread of rayon's pool.
//!
//! A parallel step (`par_iter` and the like) started on a thread outside
//! the pool hands its work to the pool and sleeps until the pool is done:
//! two thread switches for every step. The mesher takes thousands of
//! steps (each colour class of each smoothing pass, each batch of each
//! octree level), so its entry points first move the whole run onto a
//! pool thread ([`on_pool`]), where each step starts on the thread that
//! calls it. What that saves is measured in `docs/faithful.md` (session
//! 55).
//!
//! The entry points that do: the octree's build (every `Octree::build*`),
//! the mesher's runs ([`crate::mesher::mesh_with_cancellable`] and the
//! functions over it, [`crate::mesher::mesh_to_tolerance_cancellable`]), a
//! brick's ([`crate::mesher::brick::mesh_brick_from`]) and a tracker's
//! frame ([`crate::twin::Tracker::advance`]).
//!
//! # Limits
//!
//! The calling thread waits while the run goes on in the pool, as it
//! would for each step. A caller already on a pool thread — rayon's
//! global pool or one of its own, entered with `ThreadPool::install` —
//! runs the work where it is.
//!
//! ```
//! use isoc::parallel::on_pool;
//!
//! // From outside the pool, the work runs on a pool thread.
//! assert_eq!(rayon::current_thread_index(), None);
//! assert!(on_pool(|| rayon::current_thread_index().is_some()));
//! // Inside the pool already, it runs on the calling thread.
//! let here = rayon::scope(|_| {
//!     let me = std::thread::current().id();
//!     on_pool(|| std::thread::current().id() == me)
//! });
//! assert!(here);
//! ```

/// Runs `f` on a thread of rayon's pool: on this one if it is in a pool,
/// else on a thread of the global pool, this one waiting (see the module
/// doc). Panics in `f` reach the caller.
pub fn on_pool<R: Send>(f: impl FnOnce() -> R + Send) -> R {
    if rayon::current_thread_index().is_some() {
        f()
    } else {
        rayon::scope(|_| f())
    }
}
