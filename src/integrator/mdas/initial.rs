//! Initial sampling on the Morton grid (paper §4.1): `wgsl/mdas/initial.wgsl`.
//!
//! One invocation per cell: the Morton code is the cell (and leaf) index
//! and is decoded in the kernel, so nothing is sorted. The cell's l samples
//! are Latin-hypercube stratified inside it.

use super::{gpu_params::Grid, Kernels};
use crate::gpu::shader::Wgsl;
use crate::wgsl_file;

pub fn source(base: &Wgsl) -> Wgsl {
    base.clone().part(wgsl_file!("mdas/initial.wgsl"))
}

pub fn record(pass: &mut wgpu::ComputePass<'_>, k: &Kernels, grid: Grid) {
    pass.set_pipeline(&k.pipes.initial);
    pass.set_bind_group(0, &k.group0, &[]);
    pass.dispatch_workgroups(grid.x, grid.y, 1);
}
