//! The upload of a light BVH (the unbalanced kinds, and `tree2`'s
//! two-level tree built on the CPU, which shares its layout): nodes (16),
//! each light's leaf node then each node's parent (18), the cones of the
//! cone kinds (22).

use super::LightBvh;
use crate::gpu::Gpu;
use crate::lights::light_params::{LightParams, SamplerBuffers};
use anyhow::{bail, Result};

/// Uploads `b` over `params.count` lights (cones only when `cones`).
pub fn upload(
    gpu: &Gpu,
    b: &LightBvh,
    cones: bool,
    params: &mut LightParams,
    out: &mut SamplerBuffers,
) -> Result<()> {
    let n = params.count;
    if b.leaf_of_light.len() as u32 != n {
        bail!(
            "light BVH over {} lights for {n} lights",
            b.leaf_of_light.len()
        );
    }
    params.node_count = b.nodes.len() as u32;
    out.nodes = Some(SamplerBuffers::upload(gpu, "nodes", &b.nodes)?);
    if cones {
        out.cones = Some(SamplerBuffers::upload(gpu, "cones", &b.cones)?);
    }
    let table: Vec<u32> = b.leaf_of_light.iter().chain(&b.parent).copied().collect();
    out.index = Some(SamplerBuffers::upload(gpu, "index", &table)?);
    Ok(())
}
