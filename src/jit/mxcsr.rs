//! The rounding-mode switches of the interval kernels: tiny assembly
//! routines (x86-64 `stmxcsr`/`ldmxcsr`) that the generated code calls.
//!
//! # Contract
//!
//! The interval and interval-gradient kernels compute every bound with the
//! hardware rounding toward +∞ (see [`super::rounding`]). The mode is a
//! per-thread register (MXCSR on x86-64), so:
//!
//! - a batch kernel calls [`isoc_rm_enter`] first, which saves the
//!   caller's MXCSR into a kernel stack slot and loads [`MXCSR_UP`] (round
//!   up, all exceptions masked, no flush-to-zero, no denormals-are-zero —
//!   whatever the caller had);
//! - it calls [`isoc_rm_leave`] before it returns, which reloads the
//!   saved MXCSR, flags included: the caller sees its own mode and its own
//!   sticky exception flags, as if the kernel had not run. Every result is
//!   stored in the loop, before that call: Cranelift places a pure
//!   instruction at its first use, and a call orders memory, so no
//!   arithmetic of the body can be scheduled after the restore;
//! - a single-box kernel switches nothing: the safe single calls bracket
//!   it with inline assembly ([`call_interval_up`], [`call_grad_up`]) that
//!   probes the caller's rounding direction, saves the MXCSR only if it is
//!   not round to nearest (reading the register stalls behind the previous
//!   call's restore), loads [`MXCSR_UP`], calls, and restores — the caller
//!   in round to nearest gets [`MXCSR_DEFAULT`] back, any other caller its
//!   own MXCSR; the results come back in registers, after the kernel's
//!   `ret`, so nothing of the body runs after the restore;
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

/// [`MXCSR_UP`] in memory, for `ldmxcsr`.
static UP: u32 = MXCSR_UP;

/// Whether this processor runs the single-box bracket ([`call_up`]): its
/// probe is SSE4.1's `roundpd`.
pub(crate) fn single_box_bracket_runs() -> bool {
    std::arch::is_x86_feature_detected!("sse4.1")
}

/// Calls the single-box kernel at `f` with `args` in `rdi`, `rsi`, `rdx`,
/// in round-up mode; returns what it leaves in `xmm0`, `xmm1` and `rax`.
///
/// The single-box kernels do not switch the mode themselves: this inline
/// assembly does it around the call, so that nothing but the kernel runs
/// in round-up mode, the results come back in registers (Cranelift cannot
/// schedule the body after a `ret`), and a single call costs two
/// `ldmxcsr` and no helper calls.
///
/// `stmxcsr` waits for every `ldmxcsr` still in flight, so in a loop of
/// single calls each save would stall behind the previous call's restore
/// (figures in `docs/jit.md`). So the caller's rounding direction is first
/// *probed*: `roundpd` with the "use MXCSR.RC" and "suppress inexact"
/// immediate rounds `(0.5, 1.5)` to integers, which gives `(+0, 2)`
/// exactly when the caller rounds to nearest (`(1, 2)` rounding up, `(0,
/// 1)` down or toward zero) and raises no exception flag. Rounding to
/// nearest, [`MXCSR_DEFAULT`] — the state Rust code runs in — is what
/// gets restored, without reading the register; otherwise the MXCSR is
/// saved and restored whole.
///
/// # Limits
/// A caller that rounds to nearest gets [`MXCSR_DEFAULT`] back:
/// flush-to-zero and denormals-are-zero off, sticky exception flags clear
/// (probing those would take subnormal arithmetic, which costs a
/// microcode assist of ~100 cycles). A caller in another rounding
/// direction gets its whole MXCSR back, bit for bit. `roundpd` is SSE4.1,
/// which `Kernels` checks before it uses the single-box kernels.
///
/// # Safety
/// `f` is the address of a finalized single-box kernel whose arguments
/// `args` are valid (`entry_sig(kind, false)`), the processor has SSE4.1.
#[inline]
unsafe fn call_up(f: *const u8, args: [usize; 3]) -> (f64, f64, u64) {
    let mut save: u32 = 0;
    let (x0, x1, r): (f64, f64, u64);
    // SAFETY: the caller's promises; the asm saves and restores the mode
    // around the call and declares every register the C ABI lets `f`
    // clobber; the probe writes only `rax rcx r8 xmm0 xmm1`, none of them
    // an input. The block is not `nomem`: memory `f` writes is seen after.
    unsafe {
        core::arch::asm!(
            // xmm0 = (0.5, 1.5), built in registers.
            "mov rax, 0x3FE0000000000000",
            "movq xmm0, rax",
            "mov rax, 0x3FF8000000000000",
            "movq xmm1, rax",
            "unpcklpd xmm0, xmm1",
            // Round to integers in the caller's direction (imm bit 2), no
            // inexact exception (bit 3): (+0, 2) iff rounding to nearest.
            "roundpd xmm0, xmm0, 12",
            "movq rax, xmm0",
            "pextrq rcx, xmm0, 1",
            "mov r8, 0x4000000000000000",
            "xor rcx, r8",
            "or rax, rcx",
            "jnz 2f",
            "mov dword ptr [r12], 0x1F80",
            "jmp 3f",
            "2:",
            "stmxcsr dword ptr [r12]",
            "3:",
            "ldmxcsr dword ptr [rip + {up}]",
            "call r11",
            "ldmxcsr dword ptr [r12]",
            // `f` in a register the probe leaves alone, `save` in one the
            // call preserves.
            in("r11") f,
            in("r12") &mut save,
            up = sym UP,
            in("rdi") args[0],
            in("rsi") args[1],
            in("rdx") args[2],
            out("xmm0") x0,
            out("xmm1") x1,
            out("rax") r,
            clobber_abi("C"),
        );
    }
    (x0, x1, r)
}

/// Calls the single-box interval kernel at `f` on the record at `input`
/// with its constant pool `pool`, in round-up mode ([`call_up`]); returns
/// `(lo, hi, defined)`.
///
/// # Safety
/// `f` is the address of a finalized single-box interval kernel
/// (`entry_sig(Interval, false)`), `input` points to one record of 8 f64,
/// `pool` is the constant pool `f` was compiled for, the processor has
/// SSE4.1.
#[inline]
pub(crate) unsafe fn call_interval_up(
    f: *const u8,
    input: *const f64,
    pool: *const f64,
) -> (f64, f64, u8) {
    // SAFETY: the caller's promises; the kernel returns `lo` in xmm0, `hi`
    // in xmm1 and the flag in `al` (Cranelift's System V multi-value
    // return).
    let (lo, hi, d) = unsafe { call_up(f, [input as usize, pool as usize, 0]) };
    (lo, hi, d as u8)
}

/// [`call_interval_up`] for the single-box gradient kernel at `f`, which
/// writes its 8 f64 at `out` and returns the flag.
///
/// # Safety
/// As [`call_interval_up`], with `f` a single-box gradient kernel and
/// `out` valid for 8 f64.
#[inline]
pub(crate) unsafe fn call_grad_up(
    f: *const u8,
    input: *const f64,
    out: *mut f64,
    pool: *const f64,
) -> u8 {
    // SAFETY: the caller's promises; the flag comes back in `al`.
    let (_, _, d) = unsafe { call_up(f, [input as usize, out as usize, pool as usize]) };
    d as u8
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
