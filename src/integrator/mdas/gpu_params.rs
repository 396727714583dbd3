//! The uniform block every MDAS kernel reads (`Params` in
//! `wgsl/mdas/common.wgsl`), the bind-group layouts they share and the
//! dispatch arithmetic.

use crate::gpu::shader::{storage_entry, uniform_entry};
use crate::gpu::Gpu;

/// Invocations per workgroup of every MDAS kernel.
pub const WG: u32 = 256;

/// Samples one invocation of the statistics kernel reads.
pub const STATS_PER_INVOCATION: u32 = 16;

/// Mirror of `Params` in `wgsl/mdas/common.wgsl` (16 scalars, 64 bytes).
/// Only what is fixed for a render (and the reconstruction's pass offset):
/// the iteration state lives in the counters buffer on the GPU.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuParams {
    pub seed: u32,
    pub budget: u32,
    pub max_iterations: u32,
    /// Largest workgroup count per dispatch dimension.
    pub max_groups: u32,
    pub pass_offset: u32,
    pub width: u32,
    pub height: u32,
    /// α = 0: every leaf is selected.
    pub select_all: u32,
    pub scale_factor: f32,
    pub inv_alpha: f32,
    pub epsilon: f32,
    /// κ of the per-pixel reconstruction (`pixel_prior`).
    pub pixel_prior: f32,
    /// The paced selection's share of the samples left per iteration
    /// (`pace`; 0: the paper's rule, plan.wgsl).
    pub pace: f32,
    /// The fewest samples a paced iteration aims to place.
    pub pace_floor: u32,
    /// The fewest workgroups an evaluate dispatch aims for: an invocation
    /// takes fewer than `EVAL_PER_INVOCATION` samples where that would
    /// leave fewer (plan.wgsl `evaluate_groups`; [`eval_min_groups`]).
    pub eval_min_groups: u32,
    pub _pad: u32,
}

/// The fewest workgroups an evaluate dispatch aims for on `gpu`: four per
/// hardware thread on a CPU adapter (lavapipe runs a workgroup on one
/// thread, so an adaptive iteration's few thousand samples in one
/// workgroup of 8-sample invocations left the other threads idle and cost
/// twice an initial sample, BENCHMARKS.md), 1 on a GPU, whose invocations
/// take one sample each anyway. `Mdas::with_eval_min_groups` overrides it.
pub fn eval_min_groups(gpu: &Gpu) -> u32 {
    if gpu.info.device_type == wgpu::DeviceType::Cpu {
        let threads = std::env::var("LP_NUM_THREADS")
            .ok()
            .and_then(|v| v.parse::<u32>().ok())
            .filter(|&n| n > 0)
            .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get() as u32));
        4 * threads
    } else {
        1
    }
}

/// Group 0 of every MDAS kernel (`wgsl/mdas/common.wgsl`): `params` at 0,
/// eight read-write storage buffers at 1–8, and `extra_pages` more from 9
/// on for the paged arrays' further pages ([`super::pages::Pages`]).
/// Device-free, so that `tests/shader_interfaces.rs` checks the same
/// entries the runtime uses.
pub fn layout_entries(extra_pages: u32) -> Vec<wgpu::BindGroupLayoutEntry> {
    let mut entries = vec![uniform_entry(0)];
    entries.extend((1..=8 + extra_pages).map(|b| storage_entry(b, false)));
    entries
}

/// Group 1 of `prime` and `plan` (`wgsl/mdas/plan.wgsl`): the indirect
/// arguments they write.
pub fn args_layout_entries() -> Vec<wgpu::BindGroupLayoutEntry> {
    vec![storage_entry(0, false)]
}

/// A 2D grid of workgroups covering some invocations.
#[derive(Clone, Copy, Debug)]
pub struct Grid {
    pub x: u32,
    pub y: u32,
}

impl Grid {
    /// Workgroups of [`WG`] invocations covering `threads` (the kernels
    /// read the row width from the num_workgroups built-in).
    pub fn new(gpu: &Gpu, threads: u32) -> Grid {
        let (x, y) = gpu.dispatch_dims(threads.div_ceil(WG).max(1));
        Grid { x, y }
    }
}
