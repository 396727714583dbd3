//! The GPU upload of `power`: the alias table (binding 19) and each
//! light's pmf as f32 bits (binding 18, for the pmf query). `uniform`
//! uploads nothing.

use super::alias::PowerSampler;
use crate::gpu::Gpu;
use crate::lights::light_params::{LightParams, SamplerBuffers};
use crate::lights::LightPrim;
use anyhow::Result;

/// Uploads `power`'s table over `prims` (N ≥ 1).
pub fn upload_power(
    gpu: &Gpu,
    prims: &[LightPrim],
    params: &mut LightParams,
    out: &mut SamplerBuffers,
) -> Result<()> {
    let power = PowerSampler::new(prims);
    params.alias_count = power.table.len() as u32;
    out.alias = Some(SamplerBuffers::upload(gpu, "alias", &power.table)?);
    let bits: Vec<u32> = power.pmf.iter().map(|p| p.to_bits()).collect();
    out.index = Some(SamplerBuffers::upload(gpu, "index", &bits)?);
    Ok(())
}
