//! Depth of field — the 4D integrand of the MDAS paper's Chess and Bistro
//! scenes (§5.3).
//!
//! A thin-lens camera (docs/conventions.md "Primary ray"): the ray through
//! film point (x, y) leaves the lens point
//! position + aperture_radius·disk(u)·(r, u)
//! and passes through the point that the pinhole ray meets on the plane of
//! focus. The ray is traced at shutter-open time and shaded by
//! `shade_direct` (`wgsl/shared/shading.wgsl`): the emission it sees plus,
//! for each point and directional light that faces the surface, ρ/π·E·cosθ
//! with one shadow ray; the background where it hits nothing. Area lights
//! are seen (their emission) but not sampled: this integrand has no light
//! dimensions.
//!
//! | dimension | meaning |
//! |-----------|---------|
//! | 0, 1      | film point x, y (raster units) |
//! | 2, 3      | lens sample u ∈ [0,1)², mapped by the Shirley–Chiu concentric disk map |
//!
//! Scene file: `[integrand] type = "depth_of_field"` (no parameters); the
//! lens is the camera's `aperture_radius` and `focus_distance`.

use super::{scene_wgsl, Integrand};
use crate::accel::GpuScene;
use crate::film::Film;
use crate::gpu::shader::Wgsl;
use crate::wgsl_file;
use std::sync::Arc;

pub struct DepthOfField {
    scene: Arc<GpuScene>,
    film: Film,
}

/// The integrand's WGSL (device-free, see [`super::path::source`]).
pub fn source() -> Wgsl {
    scene_wgsl().part(wgsl_file!("depth_of_field.wgsl"))
}

impl DepthOfField {
    /// The integrand over `film` (the GPU scene must be built for it).
    pub fn new(scene: Arc<GpuScene>, film: Film) -> Self {
        DepthOfField { scene, film }
    }
}

impl Integrand for DepthOfField {
    fn name(&self) -> &'static str {
        "depth_of_field"
    }

    fn dims(&self) -> u32 {
        4
    }

    fn film(&self) -> Film {
        self.film
    }

    fn wgsl(&self) -> Wgsl {
        source()
    }

    fn layout(&self) -> Option<&wgpu::BindGroupLayout> {
        Some(&self.scene.layout)
    }

    fn bind_group(&self) -> Option<&wgpu::BindGroup> {
        Some(&self.scene.bind_group)
    }
}
