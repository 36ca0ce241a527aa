//! The rounding-mode switches of the interval kernels: tiny assembly
//! routines (x86-64 `stmxcsr`/`ldmxcsr`) that the generated code calls.
//!
//! # Contract
//!
//! The interval and interval-gradient kernels compute every bound with the
//! hardware rounding toward +∞ (see [`super::rounding`]). The mode is a
//! per-thread register (MXCSR on x86-64), so:
//!
//! - a kernel calls [`isoc_rm_enter`] first, which saves the caller's
//!   MXCSR into a kernel stack slot and loads [`MXCSR_UP`] (round up, all
//!   exceptions masked, no flush-to-zero, no denormals-are-zero — whatever
//!   the caller had);
//! - it calls [`isoc_rm_leave`] before every return, which reloads the
//!   caller's saved MXCSR, flags included: the caller sees its own mode and
//!   its own sticky exception flags, as if the kernel had not run;
//! - **no Rust code runs in round-up mode**: every Rust helper an interval
//!   kernel calls (CORE-MATH transcendentals, division, the gradient chain
//!   rules) is reached through a trampoline ([`trampoline!`]) that loads
//!   [`MXCSR_DEFAULT`] (round to nearest), calls the helper, and loads
//!   [`MXCSR_UP`] again before returning its result (in `rax`/`xmm0`,
//!   which `ldmxcsr` does not touch).
//!
//! The routines are `#[unsafe(naked)]` functions: their whole body is the
//! assembly below, so no compiler-generated code runs between the mode
//! switch and the call. They follow the System V calling convention and
//! keep the stack 16-byte aligned for the helper.
//!
//! # Limits
//!
//! x86-64 only (the crate does not build elsewhere). A signal handler that
//! runs on the thread while a kernel is executing sees round-up mode (as it
//! would see any user-set mode); Rust's own handlers do no float work.

/// MXCSR with round to nearest, every exception masked, FTZ/DAZ off: the
/// value Rust code expects (the x86-64 System V default).
pub const MXCSR_DEFAULT: u32 = 0x1F80;
/// [`MXCSR_DEFAULT`] with rounding toward +∞ (RC = 10).
pub(crate) const MXCSR_UP: u32 = 0x5F80;

#[cfg(not(target_arch = "x86_64"))]
compile_error!(
    "isoc's interval kernels switch the x86-64 MXCSR rounding mode; only x86-64 is supported"
);

/// Saves the caller's MXCSR at `save` (4 bytes) and switches to
/// [`MXCSR_UP`].
///
/// # Safety
/// `save` is valid for a 4-byte write. Only generated kernels call this.
#[unsafe(naked)]
pub unsafe extern "C" fn isoc_rm_enter(save: *mut u32) {
    core::arch::naked_asm!(
        "stmxcsr dword ptr [rdi]",
        // The red zone below rsp is ours in a leaf routine.
        "mov dword ptr [rsp - 8], {up}",
        "ldmxcsr dword ptr [rsp - 8]",
        "ret",
        up = const MXCSR_UP,
    )
}

/// Restores the MXCSR saved by [`isoc_rm_enter`] at `save`.
///
/// # Safety
/// `save` holds a value written by [`isoc_rm_enter`].
#[unsafe(naked)]
pub unsafe extern "C" fn isoc_rm_leave(save: *const u32) {
    core::arch::naked_asm!("ldmxcsr dword ptr [rdi]", "ret")
}

/// Defines `pub unsafe extern "C" fn $name` that calls `$target` (an
/// `extern "C"` function; arguments are passed through untouched in their
/// registers) in round-to-nearest mode and returns its result in round-up
/// mode. At entry `rsp ≡ 8 (mod 16)`; the 8 bytes it reserves realign the
/// stack for the call and hold the MXCSR image `ldmxcsr` reads.
macro_rules! trampoline {
    ($(#[$m:meta])* $name:ident => $target:path) => {
        $(#[$m])*
        ///
        /// # Safety
        /// As the target's; called only by generated kernels running in
        /// round-up mode.
        #[unsafe(naked)]
        pub unsafe extern "C" fn $name() {
            core::arch::naked_asm!(
                "sub rsp, 8",
                "mov dword ptr [rsp], {nearest}",
                "ldmxcsr dword ptr [rsp]",
                "call {target}",
                "mov dword ptr [rsp], {up}",
                "ldmxcsr dword ptr [rsp]",
                "add rsp, 8",
                "ret",
                nearest = const $crate::jit::mxcsr::MXCSR_DEFAULT,
                up = const $crate::jit::mxcsr::MXCSR_UP,
                target = sym $target,
            )
        }
    };
}
pub(crate) use trampoline;

/// The current MXCSR of this thread (for tests).
pub fn current() -> u32 {
    let mut v: u32 = 0;
    // SAFETY: `stmxcsr` writes 4 bytes to a valid local.
    unsafe {
        core::arch::asm!("stmxcsr dword ptr [{p}]", p = in(reg) &mut v, options(nostack));
    }
    v
}

/// Sets this thread's MXCSR (for tests: run a kernel under a caller's
/// non-default mode and check it is given back).
///
/// # Safety
/// Rust code run afterwards computes in the mode set; the caller restores
/// [`MXCSR_DEFAULT`] before doing float work it relies on.
pub unsafe fn set(v: u32) {
    // SAFETY: `ldmxcsr` reads 4 bytes from a valid local; reserved bits are
    // the caller's responsibility (a #GP otherwise).
    unsafe {
        core::arch::asm!("ldmxcsr dword ptr [{p}]", p = in(reg) &v, options(nostack));
    }
}
