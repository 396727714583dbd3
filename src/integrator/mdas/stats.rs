//! Non-finite count and max |f| of all samples, once before the
//! reconstruction: `wgsl/mdas/stats.wgsl`.
//!
//! The reconstruction's fixed-point scale comes from the maximum
//! ([`super::reconstruct::fixed_exponent`]); doing this once here keeps
//! barriers and atomics out of the evaluate kernel. Timed as part of the
//! `reconstruction` phase.

use super::gpu_params::{Grid, STATS_PER_INVOCATION};
use super::Kernels;
use crate::gpu::shader::Wgsl;
use crate::gpu::Gpu;
use crate::wgsl_file;

pub fn source(base: &Wgsl) -> Wgsl {
    base.clone().part(wgsl_file!("mdas/stats.wgsl"))
}

/// Over the `samples` samples taken.
pub fn record(pass: &mut wgpu::ComputePass<'_>, k: &Kernels, gpu: &Gpu, samples: u32) {
    let grid = Grid::new(gpu, samples.div_ceil(STATS_PER_INVOCATION));
    pass.set_pipeline(&k.pipes.stats);
    pass.set_bind_group(0, &k.group0, &[]);
    pass.dispatch_workgroups(grid.x, grid.y, 1);
}
