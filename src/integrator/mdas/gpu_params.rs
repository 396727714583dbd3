//! The uniform block every MDAS kernel reads (`Params` in
//! `wgsl/mdas/common.wgsl`) and the dispatch arithmetic they share.

use crate::gpu::Gpu;

/// Invocations per workgroup of every MDAS kernel.
pub const WG: u32 = 256;

/// Mirror of `Params` in `wgsl/mdas/common.wgsl` (16 scalars, 64 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuParams {
    pub seed: u32,
    pub iteration: u32,
    pub leaf_count: u32,
    pub sample_count: u32,
    pub budget: u32,
    /// Invocations per row of the 2D dispatch grid.
    pub row_threads: u32,
    /// Workgroups of the leaf dispatch (entries of `partials`).
    pub partial_count: u32,
    pub pass_offset: u32,
    pub width: u32,
    pub height: u32,
    /// Colour terms are scaled by 2^fixed_exp before the fixed-point sum.
    pub fixed_exp: i32,
    /// α = 0: every leaf is selected.
    pub select_all: u32,
    pub scale_factor: f32,
    pub inv_alpha: f32,
    pub epsilon: f32,
    pub eval_count: u32,
}

/// A 2D grid of workgroups covering `threads` invocations.
#[derive(Clone, Copy, Debug)]
pub struct Grid {
    pub x: u32,
    pub y: u32,
    /// Workgroups in the grid's first row times [`WG`].
    pub row_threads: u32,
    /// Workgroups needed (≤ x·y).
    pub groups: u32,
}

impl Grid {
    pub fn new(gpu: &Gpu, threads: u32) -> Grid {
        let groups = threads.div_ceil(WG).max(1);
        let (x, y) = gpu.dispatch_dims(groups);
        Grid {
            x,
            y,
            row_threads: x * WG,
            groups,
        }
    }
}
