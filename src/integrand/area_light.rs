//! Area-light direct lighting — the 4D integrand of the MDAS paper's
//! area-light scenes (§5.4).
//!
//! Dimensions: 0–1 film point (raster units); 2 selects an emissive
//! triangle with probability ∝ luminance(L_e)·area and, remapped within the
//! selected CDF interval, is the first coordinate of a uniform point on it;
//! 3 is the second coordinate. The estimator is
//! L_e(x) + ρ(x)/π · L_e(y) · cosθ_x · cosθ_y / |x − y|² · V(x, y) / p(y)
//! with p(y) = pmf(triangle)/area(triangle): one shadow ray, both cosines,
//! the inverse squared distance and the area pdf (docs/conventions.md
//! "Lights").
//! Emission is one-sided (the side the geometric normal faces); reflection
//! is two-sided, with cosθ_x from the shading normal (vertex normals, if
//! the mesh has them) and 0 for light behind the geometric surface.
//! Camera rays use the lens centre and shutter-open time.
//!
//! The estimator lives in `wgsl/shared/shading.wgsl` (`direct_area_light`),
//! shared with the path tracer's NEE.
//!
//! Scene file: `[integrand] type = "area_light"` (no parameters).

use super::{scene_wgsl, Integrand};
use crate::accel::GpuScene;
use crate::film::Film;
use crate::gpu::shader::Wgsl;
use crate::wgsl_file;
use std::sync::Arc;

pub struct AreaLight {
    scene: Arc<GpuScene>,
    film: Film,
}

/// The integrand's WGSL (device-free, see [`super::path::source`]).
pub fn source() -> Wgsl {
    scene_wgsl().part(wgsl_file!("area_light.wgsl"))
}

impl AreaLight {
    /// The integrand over `film` (the scene's film or a scaled one; the
    /// GPU scene must have been built for the same film).
    pub fn new(scene: Arc<GpuScene>, film: Film) -> Self {
        AreaLight { scene, film }
    }
}

impl Integrand for AreaLight {
    fn name(&self) -> &'static str {
        "area_light"
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
