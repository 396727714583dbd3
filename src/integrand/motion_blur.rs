//! Motion blur — the 3D integrand of the MDAS paper's Pool scene (§5.2).
//!
//! Dimension 2 is the shutter sample t ∈ [0, 1), scene time
//! τ = shutter_open + t·(shutter_close − shutter_open). The camera ray
//! (through the lens centre) and its shadow rays are traced at τ, so every
//! mesh with `motion` keyframes is where its rigid interpolation puts it at
//! τ (unevenly spaced keyframes are honoured: the traversal finds the
//! keyframe segment containing τ). Shading as for depth of field
//! (`shade_direct` in `wgsl/shared/shading.wgsl`): emission seen directly
//! plus point and directional lights with one shadow ray each.
//!
//! | dimension | meaning |
//! |-----------|---------|
//! | 0, 1      | film point x, y (raster units) |
//! | 2         | shutter sample t (uniform over the shutter interval) |
//!
//! Scene file: `[integrand] type = "motion_blur"` (no parameters); the
//! shutter is the camera's `shutter_open`/`shutter_close`, the motion the
//! shapes' `motion` arrays.

use super::{scene_wgsl, Integrand};
use crate::accel::GpuScene;
use crate::film::Film;
use crate::gpu::shader::Wgsl;
use crate::wgsl_file;
use std::sync::Arc;

pub struct MotionBlur {
    scene: Arc<GpuScene>,
    film: Film,
}

/// The integrand's WGSL (device-free, see [`super::path::source`]).
pub fn source() -> Wgsl {
    scene_wgsl().part(wgsl_file!("motion_blur.wgsl"))
}

impl MotionBlur {
    /// The integrand over `film` (the GPU scene must be built for it).
    pub fn new(scene: Arc<GpuScene>, film: Film) -> Self {
        MotionBlur { scene, film }
    }
}

impl Integrand for MotionBlur {
    fn name(&self) -> &'static str {
        "motion_blur"
    }

    fn dims(&self) -> u32 {
        3
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
