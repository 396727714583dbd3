//! The upload of `sst_perfect`'s substitute tree: the perfect tree's
//! bindings ([`crate::lights::tree::gpu`], from a CPU tree or bound as the
//! GPU build left it) and the substitute of every node (23). The radix
//! tree uploads itself ([`super::radix::RadixSubstituteTree`]).

use super::{Substitute, SubstituteTree};
use crate::gpu::Gpu;
use crate::lights::light_params::{LightParams, SamplerBuffers};
use crate::lights::tree::gpu as tree_gpu;
use anyhow::{bail, Result};

/// Uploads `t` over `params.count` lights (cones only when `cones`).
pub fn upload(
    gpu: &Gpu,
    t: &SubstituteTree,
    cones: bool,
    params: &mut LightParams,
    out: &mut SamplerBuffers,
) -> Result<()> {
    let n = params.count;
    if t.tree.light_count() != n {
        bail!(
            "substitute tree over {} lights for {n} lights",
            t.tree.light_count()
        );
    }
    tree_gpu::upload(gpu, &t.tree, cones, params, out)?;
    out.substitutes = Some(SamplerBuffers::upload(gpu, "substitutes", &t.substitutes)?);
    Ok(())
}

/// Binds the substitutes of a GPU-built tree whose nodes
/// [`tree_gpu::bind`] bound (its `params.node_count` set).
pub fn bind(
    substitutes: &wgpu::Buffer,
    params: &LightParams,
    out: &mut SamplerBuffers,
) -> Result<()> {
    if substitutes.size() < params.node_count as u64 * size_of::<Substitute>() as u64 {
        bail!(
            "GPU substitute buffer too small for {} lights",
            params.count
        );
    }
    out.substitutes = Some(substitutes.clone());
    Ok(())
}
