//! Path tracing with next-event estimation — the MDAS paper's Cornell Box
//! (6D, two indirect bounces) and Breakfast (4D, one bounce) integrand
//! (§5.5). Fixed path length, no Russian roulette, so the dimension count
//! is fixed.
//!
//! Vertex x_0 is the surface seen through the lens centre at shutter-open
//! time; vertices x_1 … x_m follow m = `max_bounces` cosine-weighted
//! bounces (Lambertian: f·cosθ/pdf = ρ, so the throughput is
//! β_k = ρ(x_0)·…·ρ(x_{k−1})). At every vertex x_0 … x_m, next-event
//! estimation adds β_k times the direct light: every point and directional
//! light with one shadow ray each (no dimensions), and — when the scene
//! has emissive triangles — one area-light sample (two dimensions; pmf
//! ∝ luminance·area, both cosines, 1/d², the area pdf). The estimate is
//!
//! L = L_e(x_0) + Σ_{k=0..m} β_k·NEE(x_k) + Σ_{k=1..m} β_k·L_bg·[bounce k escapes]
//!
//! Emission reached by a bounce ray is *not* added (the NEE at the previous
//! vertex accounts for it), so for a closed box emitting L_e everywhere
//! with albedo ρ the expected pixel value is L_e·Σ_{k=0..m+1} ρ^k
//! (tests/integrands.rs, furnace test).
//!
//! Dimensions without emissive triangles (point/directional lights only):
//!
//! | dimension         | meaning |
//! |-------------------|---------|
//! | 0, 1              | film point x, y (raster units) |
//! | 2 + 2k, 3 + 2k    | bounce direction at x_k (k = 0..m−1) |
//!
//! and with emissive triangles:
//!
//! | dimension         | meaning |
//! |-------------------|---------|
//! | 0, 1              | film point x, y (raster units) |
//! | 2 + 4k, 3 + 4k    | emitter sample at x_k (k = 0..m): `sample_emitter` u |
//! | 4 + 4k, 5 + 4k    | bounce direction at x_k (k = 0..m−1) |
//!
//! Bounce directions are cosine-weighted around the normal turned toward
//! the incoming ray (concentric disk lifted to the hemisphere);
//! `sample_emitter` is in `wgsl/shared/shading.wgsl`. So d = 2 + 2m without area lights (2 + 2m ≤ 16: m ≤ 7) and d = 4 + 4m
//! with them (m ≤ 3).
//!
//! Scene file: `[integrand] type = "path"`, `max_bounces` (integer ≥ 1,
//! default 1; at most 7, or 3 when the scene has emissive surfaces).

use super::{scene_wgsl, Integrand, MAX_DIMS};
use crate::accel::GpuScene;
use crate::film::Film;
use crate::gpu::shader::Wgsl;
use crate::wgsl_file;
use anyhow::{bail, Result};
use std::sync::Arc;

pub struct PathTracing {
    scene: Arc<GpuScene>,
    film: Film,
    max_bounces: u32,
    area_nee: bool,
}

/// Dimensions of a path with `max_bounces` bounces, with or without
/// area-light NEE (see the module docs).
pub fn path_dims(max_bounces: u32, area_lights: bool) -> u32 {
    if area_lights {
        4 + 4 * max_bounces
    } else {
        2 + 2 * max_bounces
    }
}

/// The largest `max_bounces` that fits in [`MAX_DIMS`].
pub fn max_bounces_limit(area_lights: bool) -> u32 {
    if area_lights {
        (MAX_DIMS - 4) / 4
    } else {
        (MAX_DIMS - 2) / 2
    }
}

/// The integrand's WGSL for `max_bounces` bounces, with or without
/// area-light NEE: all [`PathTracing::wgsl`] depends on, so that it can be
/// assembled (and checked, `tests/shader_interfaces.rs`) without a device.
pub fn source(max_bounces: u32, area_nee: bool) -> Wgsl {
    scene_wgsl()
        .constant("PATH_MAX_BOUNCES", max_bounces)
        .constant("PATH_AREA_NEE", area_nee as u32)
        .part(wgsl_file!("path.wgsl"))
}

impl PathTracing {
    /// The integrand over `film`; area-light NEE is on when the scene has
    /// emissive triangles. Errors if `max_bounces` is 0 or its dimension
    /// count exceeds [`MAX_DIMS`].
    pub fn new(scene: Arc<GpuScene>, film: Film, max_bounces: u32) -> Result<Self> {
        let area_nee = scene.stats.emitters > 0;
        let limit = max_bounces_limit(area_nee);
        if max_bounces == 0 || max_bounces > limit {
            bail!(
                "path: max_bounces must be in 1..={limit} ({}), got {max_bounces} ({} dimensions)",
                if area_nee {
                    "the scene has emissive surfaces: 4 + 4·max_bounces dimensions ≤ 16"
                } else {
                    "2 + 2·max_bounces dimensions ≤ 16"
                },
                path_dims(max_bounces, area_nee)
            );
        }
        Ok(PathTracing {
            scene,
            film,
            max_bounces,
            area_nee,
        })
    }

    pub fn max_bounces(&self) -> u32 {
        self.max_bounces
    }

    /// Whether each vertex samples the emissive triangles (2 dims).
    pub fn area_nee(&self) -> bool {
        self.area_nee
    }
}

impl Integrand for PathTracing {
    fn name(&self) -> &'static str {
        "path"
    }

    fn dims(&self) -> u32 {
        path_dims(self.max_bounces, self.area_nee)
    }

    fn film(&self) -> Film {
        self.film
    }

    fn wgsl(&self) -> Wgsl {
        source(self.max_bounces, self.area_nee)
    }

    fn layout(&self) -> Option<&wgpu::BindGroupLayout> {
        Some(&self.scene.layout)
    }

    fn bind_group(&self) -> Option<&wgpu::BindGroup> {
        Some(&self.scene.bind_group)
    }
}
