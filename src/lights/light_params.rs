//! The GPU sampler interface a technique fills: `light_params`, the
//! uniform every light sampler's WGSL reads (binding 21 of `@group(1)`,
//! `wgsl/lights/bindings.wgsl`), and [`SamplerBuffers`], the bindings a
//! technique's upload provides. A technique's GPU owner (`tree/gpu.rs`,
//! `bvh/gpu.rs`, `lgh/gpu.rs`, …) fills both without importing the
//! sampler hub ([`super::gpu_sampler`]), which dispatches on the kind's
//! `Structure` and binds the rest.

use crate::gpu::buffer::STORAGE;
use crate::gpu::Gpu;
use anyhow::Result;
use bytemuck::{Pod, Zeroable};

/// The bindings a technique uploads (16 nodes, 18 index, 19 alias, 22
/// cones, 23 substitutes, 24 grid lights; `wgsl/lights/bindings.wgsl`
/// says what each holds per kind). The hub binds one zeroed element for
/// each left `None`.
#[derive(Default)]
pub struct SamplerBuffers {
    pub nodes: Option<wgpu::Buffer>,
    pub index: Option<wgpu::Buffer>,
    pub alias: Option<wgpu::Buffer>,
    pub cones: Option<wgpu::Buffer>,
    pub substitutes: Option<wgpu::Buffer>,
    pub lgh_lights: Option<wgpu::Buffer>,
}

impl SamplerBuffers {
    /// Uploads `data` as the sampler binding named `name`
    /// (`lights.sampler.<name>`).
    pub fn upload<T: Pod>(gpu: &Gpu, name: &str, data: &[T]) -> Result<wgpu::Buffer> {
        gpu.buffer_from(&format!("lights.sampler.{name}"), data, STORAGE)
    }
}

/// `light_params` (binding 21), mirrored by `LightParams` in
/// `wgsl/lights/bindings.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct LightParams {
    /// N.
    pub count: u32,
    /// [`super::registry::SamplerKind::index`].
    pub kind: u32,
    /// Perfect tree: `L + 1` levels and `P` leaves; 0 otherwise.
    pub levels: u32,
    pub leaf_count: u32,
    pub node_count: u32,
    /// Entries per block in `light_cuts` (1 for the kinds without cuts).
    pub cut_size: u32,
    pub block_size: u32,
    pub blocks_per_row: u32,
    /// Power: N, or 0 when `Σ I = 0`.
    pub alias_count: u32,
    /// Interleaved sampling (paper §3.4): sub-block side m (1 = off).
    pub interleave: u32,
    /// Frame number: rotates the sub-block assignment, p = (i + frame) mod m²,
    /// and the cut pre-pass's representative pixels.
    pub frame: u32,
    /// Frame time in scene time units (shading and shadow rays are traced
    /// at it); a uniform, so a new frame time compiles no new shader.
    pub time: f32,
    /// Square of the VPL distance clamp: a VPL's `1/d²` uses
    /// `max(d², vpl_clamp2)` (0 = no clamp).
    pub vpl_clamp2: f32,
    /// `sst`: ν_min and σ_max² of the suitability test (eq. 3).
    pub sst_nu_min: f32,
    pub sst_sigma_max2: f32,
    /// The kinds with cuts: 0 = one light per cut subtree (the paper's
    /// estimator), 1 = one pick from the cut's mixture
    /// ([`super::sampler::CutSampling`]).
    pub cut_mixture: u32,
    /// `lgh` ([`super::lgh`]): the grid's `lo`, L, h_1, 1/h_1, α, whether
    /// level 0 is used, the shadow samples S, and where the level-1 cell
    /// ranges and the sorted light ids start in `light_index` (after the
    /// vertex index of every level).
    pub lgh_lo: [f32; 3],
    pub lgh_levels: u32,
    pub lgh_h1: f32,
    pub lgh_inv_h1: f32,
    pub lgh_alpha: f32,
    pub lgh_level0: u32,
    pub lgh_shadows: u32,
    pub lgh_cells_offset: u32,
    pub lgh_sorted_offset: u32,
    /// `lgh`: the emissive triangles T (the last T sorted ids).
    pub lgh_triangles: u32,
    /// `lgh`: the grid lights' additive distance clamp (c·R)².
    pub lgh_soft2: f32,
    /// The kinds that pick one light per evaluation: picks per evaluation
    /// (`light_samples`; 0 reads as 1).
    pub light_samples: u32,
    pub _pad2: u32,
    pub _pad3: u32,
}
