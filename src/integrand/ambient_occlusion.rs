//! Ambient occlusion — a 4D integrand with one occlusion ray per sample.
//!
//! At the surface point x seen through the lens centre at shutter-open
//! time, with n the shading normal turned toward the camera (two-sided
//! surfaces; the geometric normal unless the mesh has vertex normals), the
//! value is the cosine-weighted unoccluded fraction
//!
//! A(x) = (1/π) ∫_{H(n)} V_r(x, ω) cosθ dω ∈ [0, 1],
//!
//! where directions behind the geometric surface count as occluded.
//!
//! V_r(x, ω) = 1 when the ray from x (offset along n against
//! self-intersection) in direction ω hits nothing closer than `radius`,
//! else 0. With ω drawn from the cosine-weighted hemisphere (density
//! cosθ/π, Malley's method over the concentric disk), each sample is
//! exactly V_r ∈ {0, 1}, so an unoccluded surface gives exactly 1 in every
//! sample. Camera rays that hit nothing give the scene's `background`.
//! The result is grey (the same in R, G, B).
//!
//! | dimension | meaning |
//! |-----------|---------|
//! | 0, 1      | film point x, y (raster units) |
//! | 2, 3      | hemisphere sample u ∈ [0,1)²: disk point of the concentric map, lifted to the hemisphere around n |
//!
//! Scene file: `[integrand] type = "ambient_occlusion"`, `radius` (number
//! > 0, world units; required).

use super::{scene_wgsl, Integrand};
use crate::accel::GpuScene;
use crate::film::Film;
use crate::gpu::shader::Wgsl;
use crate::wgsl_file;
use anyhow::{bail, Result};
use std::sync::Arc;

pub struct AmbientOcclusion {
    scene: Arc<GpuScene>,
    film: Film,
    radius: f32,
}

/// The integrand's WGSL for occlusion distance `radius` (device-free, see
/// [`super::path::source`]).
pub fn source(radius: f32) -> Wgsl {
    scene_wgsl()
        .constant("AO_RADIUS_BITS", radius.to_bits())
        .part(wgsl_file!("ambient_occlusion.wgsl"))
}

impl AmbientOcclusion {
    /// The integrand over `film` with occlusion distance `radius` (> 0,
    /// finite).
    pub fn new(scene: Arc<GpuScene>, film: Film, radius: f32) -> Result<Self> {
        if !(radius.is_finite() && radius > 0.0) {
            bail!("ambient_occlusion radius must be a finite number > 0, got {radius}");
        }
        Ok(AmbientOcclusion {
            scene,
            film,
            radius,
        })
    }

    pub fn radius(&self) -> f32 {
        self.radius
    }
}

impl Integrand for AmbientOcclusion {
    fn name(&self) -> &'static str {
        "ambient_occlusion"
    }

    fn dims(&self) -> u32 {
        4
    }

    fn film(&self) -> Film {
        self.film
    }

    fn wgsl(&self) -> Wgsl {
        source(self.radius)
    }

    fn layout(&self) -> Option<&wgpu::BindGroupLayout> {
        Some(&self.scene.layout)
    }

    fn bind_group(&self) -> Option<&wgpu::BindGroup> {
        Some(&self.scene.bind_group)
    }
}
