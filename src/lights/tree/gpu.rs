//! The upload of a perfect tree (and of the substitute tree's, which has
//! the same layout) into the samplers' bindings: nodes (16), the leaf slot
//! of each light (18), the cones of the cone kinds (22), from a CPU tree
//! or bound as the GPU build ([`super::gpu_build`]) left them.

use super::perfect::PerfectTree;
use crate::gpu::Gpu;
use crate::lights::light_params::{LightParams, SamplerBuffers};
use crate::lights::{LightCone, TreeNode};
use anyhow::{bail, Result};

/// The buffers of a perfect tree built on the GPU.
pub struct GpuTreeBuffers<'a> {
    pub nodes: &'a wgpu::Buffer,
    pub leaf_of_light: &'a wgpu::Buffer,
    pub cones: Option<&'a wgpu::Buffer>,
}

/// Sets the perfect tree's shape for `n ≥ 1` lights: `P` leaves, `L + 1`
/// levels, `2P − 1` nodes.
pub fn set_shape(params: &mut LightParams, n: u32) {
    let p = n.next_power_of_two();
    params.leaf_count = p;
    params.levels = p.trailing_zeros() + 1;
    params.node_count = 2 * p - 1;
}

/// Uploads a CPU-built tree over `params.count` lights (cones only when
/// `cones`).
pub fn upload(
    gpu: &Gpu,
    t: &PerfectTree,
    cones: bool,
    params: &mut LightParams,
    out: &mut SamplerBuffers,
) -> Result<()> {
    let n = params.count;
    if t.light_count() != n {
        bail!(
            "perfect tree over {} lights for {n} lights",
            t.light_count()
        );
    }
    set_shape(params, n);
    out.nodes = Some(SamplerBuffers::upload(gpu, "nodes", &t.nodes)?);
    out.index = Some(SamplerBuffers::upload(gpu, "index", &t.leaf_of_light)?);
    if cones {
        out.cones = Some(SamplerBuffers::upload(gpu, "cones", &t.cones)?);
    }
    Ok(())
}

/// Binds a GPU-built tree over `params.count` lights as it is, checking
/// its sizes (`cones`: the kind needs the cones).
pub fn bind(
    t: GpuTreeBuffers<'_>,
    cones: bool,
    params: &mut LightParams,
    out: &mut SamplerBuffers,
) -> Result<()> {
    let n = params.count;
    set_shape(params, n);
    let count = params.node_count as u64;
    if t.nodes.size() < count * size_of::<TreeNode>() as u64
        || t.leaf_of_light.size() < 4 * n as u64
    {
        bail!("GPU light tree buffers too small for {n} lights");
    }
    out.nodes = Some(t.nodes.clone());
    out.index = Some(t.leaf_of_light.clone());
    if cones {
        match t.cones {
            Some(c) if c.size() >= count * size_of::<LightCone>() as u64 => {
                out.cones = Some(c.clone())
            }
            _ => bail!("the sampler needs the GPU tree's cones for {n} lights"),
        }
    }
    Ok(())
}
