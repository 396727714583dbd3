//! Non-finite count and max |f| of all samples, once before the
//! reconstruction: `wgsl/mdas/stats.wgsl`.
//!
//! One invocation of `fixed_scale` then turns the maximum into the
//! reconstruction's fixed-point exponent (see [`super::reconstruct`]).
//! Doing this once here keeps barriers and atomics out of the evaluate
//! kernel. Timed as part of the `reconstruction` phase.

use super::gpu_params::{Grid, STATS_PER_INVOCATION};
use super::Kernels;
use crate::gpu::shader::Wgsl;
use crate::gpu::Gpu;
use crate::wgsl_file;

pub fn source(base: &Wgsl) -> Wgsl {
    base.clone().part(wgsl_file!("mdas/stats.wgsl"))
}

/// `stats` over the `samples` samples taken, then `fixed_scale`.
pub fn record(pass: &mut wgpu::ComputePass<'_>, k: &Kernels, gpu: &Gpu, samples: u32) {
    let grid = Grid::new(gpu, samples.div_ceil(STATS_PER_INVOCATION));
    pass.set_pipeline(&k.pipes.stats);
    pass.set_bind_group(0, &k.group0, &[]);
    pass.dispatch_workgroups(grid.x, grid.y, 1);
    pass.set_pipeline(&k.pipes.fixed_scale);
    pass.dispatch_workgroups(1, 1, 1);
}
