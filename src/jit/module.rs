//! Owning Cranelift JIT modules and compiling entry points into them.
//!
//! [`build`] makes a fresh [`JITModule`] for one kernel kind, declares the
//! helpers of [`Helper`], lowers the entry points asked for (single, batch
//! or both; [`super::entry`]), finalizes them and returns the module (in a
//! [`ModuleOwner`], which frees the code when dropped) with the function
//! pointers and their [`KernelInfo`]. One module per kind (and one more
//! for the single-box entry points, which only single calls need) lets
//! the kinds compile independently, lazily and in parallel.

use std::time::Instant;

use cranelift_codegen::ir::{AbiParam, FuncRef, InstBuilder, Signature};
use cranelift_codegen::settings::{self, Configurable};
use cranelift_frontend::{FunctionBuilder, FunctionBuilderContext};
use cranelift_jit::{JITBuilder, JITModule};
use cranelift_module::{Linkage, Module, default_libcall_names};

use super::entry::{self, entry_name, entry_sig};
use super::helpers::Helper;
use super::{Env, JitError, JitOptions, KernelInfo, Kind};
use crate::ir;

/// Owns a JIT module; only touched at construction and drop.
pub(super) struct ModuleOwner(Option<JITModule>);

// SAFETY: the module is never accessed through `&self` after construction
// (no method of `Kernels` reaches it); it is only moved and finally freed
// in `Drop`, which has exclusive access.
unsafe impl Sync for ModuleOwner {}
// SAFETY: as above; moving the module between threads is not observable
// by the kernels, which only depend on the memory it keeps mapped.
unsafe impl Send for ModuleOwner {}

impl Drop for ModuleOwner {
    fn drop(&mut self) {
        if let Some(m) = self.0.take() {
            // SAFETY: the function pointers into this memory are held only
            // by the kernels being dropped, or by nobody when a compilation
            // failed half-way; they cannot be called after.
            unsafe { m.free_memory() };
        }
    }
}

/// Whether `prog` is compiled with Cranelift's single-pass register
/// allocator (fast compilation asked for, or a long program), not the
/// backtracking one.
fn single_pass(opts: &JitOptions, prog: &ir::Program) -> bool {
    opts.fast_compile || prog.len() > opts.single_pass_above
}

/// A fresh JIT module for `opts` with the helpers registered.
fn new_module(opts: &JitOptions, single: bool) -> Result<JITModule, JitError> {
    let mut flags = settings::builder();
    let set = |f: &mut settings::Builder, k: &str, v: &str| {
        f.set(k, v).map_err(|e| JitError::Target(e.to_string()))
    };
    set(&mut flags, "opt_level", "speed")?;
    let ra = if single {
        "single_pass"
    } else {
        "backtracking"
    };
    set(&mut flags, "regalloc_algorithm", ra)?;
    set(&mut flags, "use_colocated_libcalls", "false")?;
    set(&mut flags, "is_pic", "false")?;
    set(
        &mut flags,
        "enable_verifier",
        if opts.verify { "true" } else { "false" },
    )?;
    let isa = cranelift_native::builder()
        .map_err(|e| JitError::Target(e.to_string()))?
        .finish(settings::Flags::new(flags))
        .map_err(|e| JitError::Target(e.to_string()))?;
    let mut jb = JITBuilder::with_isa(isa, default_libcall_names());
    jb.symbols(Helper::symbols());
    Ok(JITModule::new(jb))
}

/// The module, the entry points of `kind` named by `batches` (`false`
/// the single entry point, `true` the batch one; finalized code in that
/// order) and their info. The module's memory is freed if anything fails.
pub(super) fn build(
    prog: &ir::Program,
    pool_addr: i64,
    opts: &JitOptions,
    kind: Kind,
    batches: &[bool],
) -> Result<(ModuleOwner, Vec<*const u8>, Vec<KernelInfo>), JitError> {
    let mut owner = ModuleOwner(Some(new_module(opts, single_pass(opts, prog))?));
    let Some(module) = owner.0.as_mut() else {
        return Err(JitError::Target("no module".into()));
    };
    let (p, info) = define_entries(module, prog, pool_addr, opts, kind, batches)?;
    Ok((owner, p, info))
}

fn define_entries(
    module: &mut JITModule,
    prog: &ir::Program,
    pool_addr: i64,
    opts: &JitOptions,
    kind: Kind,
    batches: &[bool],
) -> Result<(Vec<*const u8>, Vec<KernelInfo>), JitError> {
    let ptr = module.target_config().pointer_type();
    let cc = module.isa().default_call_conv();
    let mut helper_ids = Vec::with_capacity(Helper::ALL.len());
    for h in Helper::ALL {
        let (params, ret) = h.types(ptr);
        let mut sig = Signature::new(cc);
        sig.params.extend(params.into_iter().map(AbiParam::new));
        sig.returns.extend(ret.map(AbiParam::new));
        let id = module
            .declare_function(h.symbol(), Linkage::Import, &sig)
            .map_err(|e| JitError::Codegen(e.to_string()))?;
        helper_ids.push(id);
    }

    let mut ctx = module.make_context();
    let mut fctx = FunctionBuilderContext::new();
    let mut ids = Vec::new();
    let mut info = Vec::new();
    for &batch in batches {
        let t0 = Instant::now();
        let name = entry_name(kind, batch);
        let sig = entry_sig(kind, batch, cc, ptr);
        let id = module
            .declare_function(name, Linkage::Local, &sig)
            .map_err(|e| JitError::Codegen(e.to_string()))?;
        ctx.func.signature = sig;
        {
            let mut b = FunctionBuilder::new(&mut ctx.func, &mut fctx);
            let refs: Vec<FuncRef> = helper_ids
                .iter()
                .map(|&h| module.declare_func_in_func(h, b.func))
                .collect();
            let entry = b.create_block();
            b.append_block_params_for_function_params(entry);
            b.switch_to_block(entry);
            // The single-box entry points get the pool's address as their
            // last argument (in a register, so that pool loads address it
            // directly); the others build it from a constant.
            let pool_v = if !batch && matches!(kind, Kind::Interval | Kind::Grad) {
                *b.block_params(entry).last().expect("pool argument")
            } else {
                b.ins().iconst(ptr, pool_addr)
            };
            let mut env = Env {
                b,
                pool: pool_v,
                helpers: refs,
                ptr,
                iv_slot: None,
                gd_slots: None,
                pg_slot: None,
                cheap_joins: !single_pass(opts, prog),
            };
            entry::emit_entry(&mut env, prog, kind, batch, entry, opts);
            env.b.seal_all_blocks();
            env.b.finalize(module.target_config());
        }
        super::sign_mask::share(&mut ctx.func, ptr);
        ctx.set_disasm(opts.keep_text);
        module
            .define_function(id, &mut ctx)
            .map_err(|e| JitError::Codegen(format!("{e:?}")))?;
        let code = ctx.compiled_code();
        let code_bytes = code.map_or(0, |c| c.code_buffer().len());
        let asm = if opts.keep_text {
            code.and_then(|c| c.vcode.clone())
        } else {
            None
        };
        let clif = opts.keep_text.then(|| ctx.func.display().to_string());
        module.clear_context(&mut ctx);
        ids.push(id);
        info.push(KernelInfo {
            kind,
            batch,
            name,
            code_bytes,
            compile_time: t0.elapsed(),
            clif,
            asm,
        });
    }
    let t0 = Instant::now();
    module
        .finalize_definitions()
        .map_err(|e| JitError::Codegen(e.to_string()))?;
    // Attribute finalisation (relocation, mprotect) evenly.
    let share = t0.elapsed() / info.len() as u32;
    for i in &mut info {
        i.compile_time += share;
    }
    let p = ids
        .iter()
        .map(|&id| module.get_finalized_function(id))
        .collect();
    Ok((p, info))
}
