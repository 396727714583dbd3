//! Adaptive sampling (paper §4.2): `wgsl/mdas/adapt.wgsl`, entry points
//! `count` and `apply` around [`super::scan`].
//!
//! Selection (E/E_max)^α ≥ ξ, best-candidate insertion and the object-median
//! split are documented in the WGSL file. `count` decides once per leaf and
//! parks a selected leaf's decision (split flag, winning candidate index,
//! split axis and plane) in its error word, which is recomputed after the
//! iteration anyway; `apply` regenerates only the winning candidate from
//! its index. No per-leaf scratch memory is needed, and the candidate
//! search and split test run once (halving the adaptive phase compared
//! with recomputing the decisions in `apply`).

use super::{plan, Kernels};
use crate::gpu::shader::Wgsl;
use crate::wgsl_file;

pub fn source(base: &Wgsl) -> Wgsl {
    base.clone().part(wgsl_file!("mdas/adapt.wgsl"))
}

/// `count`: every leaf's decision and the per-workgroup totals
/// (indirect, over the leaves: [`plan`]).
pub fn record_count(pass: &mut wgpu::ComputePass<'_>, k: &Kernels) {
    pass.set_bind_group(0, &k.group0, &[]);
    pass.set_pipeline(&k.pipes.count);
    pass.dispatch_workgroups_indirect(&k.args, plan::ARGS_LEAVES);
}

/// `apply`, after [`super::scan`]: places the samples and splits.
pub fn record_apply(pass: &mut wgpu::ComputePass<'_>, k: &Kernels) {
    pass.set_bind_group(0, &k.group0, &[]);
    pass.set_pipeline(&k.pipes.apply);
    pass.dispatch_workgroups_indirect(&k.args, plan::ARGS_LEAVES);
}
