//! Integrand evaluation of the new samples only: `wgsl/mdas/evaluate.wgsl`.
//!
//! Samples are appended, so each iteration's new samples are one index
//! range, which [`plan`] leaves in the state together with the dispatch
//! size. One invocation per sample, with no barrier or atomic around the
//! integrand. Non-finite
//! results are counted once at the end ([`super::stats`],
//! `Render::nonfinite`) and excluded by every later kernel on their bits.

use super::{plan, Kernels};
use crate::gpu::shader::Wgsl;
use crate::integrand::Integrand;
use crate::wgsl_file;

/// The kernel over an integrand's WGSL (`Integrand::wgsl`).
pub fn source(base: &Wgsl, integrand: Wgsl) -> Wgsl {
    integrand
        .include(base)
        .part(wgsl_file!("mdas/evaluate.wgsl"))
}

pub fn record(pass: &mut wgpu::ComputePass<'_>, k: &Kernels, integrand: &dyn Integrand) {
    pass.set_pipeline(&k.pipes.evaluate);
    pass.set_bind_group(0, &k.group0, &[]);
    crate::integrand::bind_integrand(pass, integrand);
    pass.dispatch_workgroups_indirect(&k.args, plan::ARGS_EVALUATE);
}
