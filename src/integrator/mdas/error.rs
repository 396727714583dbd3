//! Contrast error per leaf (paper eq. 4) and E_max of the initial grid:
//! `wgsl/mdas/error.wgsl`, once before the first iteration.
//!
//! Every cell is DIRTY then; E_max is a workgroup max reduction and one
//! `atomicMax` per workgroup on the bits of finite non-negative floats.
//! Later iterations sweep no leaf for their errors: the evaluate pass
//! recomputes those of the leaves an iteration changed and the count pass
//! carries the others' maximum ([`super::evaluate`]). The f̄ = 0
//! convention is in `wgsl/mdas/leaf_error.wgsl`'s header.

use super::{plan, Kernels};
use crate::gpu::shader::Wgsl;
use crate::wgsl_file;

pub fn source(base: &Wgsl) -> Wgsl {
    base.clone()
        .part(wgsl_file!("mdas/leaf_error.wgsl"))
        .part(wgsl_file!("mdas/error.wgsl"))
}

/// One invocation per leaf; the leaf count is on the GPU ([`plan`]).
pub fn record(pass: &mut wgpu::ComputePass<'_>, k: &Kernels) {
    pass.set_pipeline(&k.pipes.error);
    pass.set_bind_group(0, &k.group0, &[]);
    pass.dispatch_workgroups_indirect(&k.args, plan::ARGS_LEAVES);
}
