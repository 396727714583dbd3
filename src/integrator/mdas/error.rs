//! Contrast error per leaf (paper eq. 4) and E_max: `wgsl/mdas/error.wgsl`.
//!
//! Only leaves changed since the last pass (error word DIRTY) are
//! recomputed (§4.4); E_max is a workgroup max reduction and one
//! `atomicMax` per workgroup on the bits of finite non-negative floats.
//! The f̄ = 0 convention is in the WGSL file's header.

use super::{plan, Kernels};
use crate::gpu::shader::Wgsl;
use crate::wgsl_file;

pub fn source(base: &Wgsl) -> Wgsl {
    base.clone().part(wgsl_file!("mdas/error.wgsl"))
}

/// One invocation per leaf; the leaf count is on the GPU ([`plan`]).
pub fn record(pass: &mut wgpu::ComputePass<'_>, k: &Kernels) {
    pass.set_pipeline(&k.pipes.error);
    pass.set_bind_group(0, &k.group0, &[]);
    pass.dispatch_workgroups_indirect(&k.args, plan::ARGS_LEAVES);
}
